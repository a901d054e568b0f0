//! Two-dimensional Gaussian mixtures over (λi, λo): Hua 2022's compact reradiation model.
//!
//! A mixture p(λi, λo) = Σ π_k N((λi, λo) | μ_k, Σ_k) (Hua eq. 1–2) is a density per nm². The
//! fluorescent kernel it stands for is ρ(λi → λo) = S · p(λi, λo) per nm (eq. 3), restricted to
//! the physical side of the diagonal (λo > λi) and to the measured support. Axis 0 ("a") is
//! always λi and axis 1 ("b") is λo.
//!
//! - [`em`]: weighted EM with k-means++ initialisation (Hua §5.2);
//! - [`bayes`]: weighted variational Bayesian inference (Hua §5.2);
//! - [`fit`]: from a cleaned BFC matrix to a fitted, scaled model, the best of several seeded
//!   starts (§5.1, §5.3);
//! - [`select`]: the number of components by BIC (§5.2);
//! - [`file`]: the JSON file format of a fitted model;
//! - [`conditional`]: the truncated conditional mixtures λo | λi and λi | λo (§6).

pub mod bayes;
pub mod conditional;
pub mod em;
pub mod file;
pub mod fit;
pub mod select;

pub use conditional::ConditionalMixture;
pub use file::GmmFile;
pub use fit::{FitMethod, FitOptions, ScaleMethod, fit_matrix};

use serde::{Deserialize, Serialize};

/// One weighted 2-D Gaussian of a mixture.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Component {
    /// Mixing coefficient π_k.
    pub weight: f64,
    /// Mean (λi, λo), nm.
    pub mean: [f64; 2],
    /// Covariance [[σaa, σab], [σba, σbb]], nm².
    pub cov: [[f64; 2]; 2],
}

impl Component {
    /// Determinant of the covariance.
    #[inline]
    pub fn det(&self) -> f64 {
        self.cov[0][0] * self.cov[1][1] - self.cov[0][1] * self.cov[1][0]
    }

    /// Whether the covariance is symmetric positive definite and every number finite.
    pub fn is_valid(&self) -> bool {
        let c = &self.cov;
        self.weight.is_finite()
            && self.weight >= 0.0
            && self.mean.iter().all(|m| m.is_finite())
            && c.iter().flatten().all(|x| x.is_finite())
            && c[0][0] > 0.0
            && c[1][1] > 0.0
            && (c[0][1] - c[1][0]).abs() <= 1e-9 * (c[0][0] * c[1][1]).sqrt()
            && self.det() > 0.0
    }

    /// N(x | μ, Σ) (Hua eq. 2), without the weight.
    #[inline]
    pub fn density(&self, x: [f64; 2]) -> f64 {
        let det = self.det();
        let (dx, dy) = (x[0] - self.mean[0], x[1] - self.mean[1]);
        // (x − μ)ᵀ Σ⁻¹ (x − μ) with the closed-form 2×2 inverse.
        let q = (self.cov[1][1] * dx * dx - 2.0 * self.cov[0][1] * dx * dy
            + self.cov[0][0] * dy * dy)
            / det;
        (-0.5 * q).exp() / (2.0 * std::f64::consts::PI * det.sqrt())
    }
}

/// p(x) = Σ π_k N(x | μ_k, Σ_k) (Hua eq. 1).
pub fn mixture_density(components: &[Component], x: [f64; 2]) -> f64 {
    components.iter().map(|c| c.weight * c.density(x)).sum()
}

/// Weighted observations: the matrix cells (λi, λo) with their values as weights (Hua §5.2).
#[derive(Clone, Debug, Default)]
pub struct WeightedPoints {
    pub x: Vec<[f64; 2]>,
    pub w: Vec<f64>,
    /// Side of the square cell each point stands for, nm (its uniform spread adds Δ²/12 to
    /// every covariance, which is also the covariance floor).
    pub cell: f64,
}

/// The outcome of one fit, before scaling.
#[derive(Clone, Debug)]
pub struct FitReport {
    pub components: Vec<Component>,
    pub iterations: usize,
    /// Weighted mean log-likelihood per unit weight at the end (EM), or the lower bound (Bayes).
    pub log_likelihood: f64,
    pub converged: bool,
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A known two-component mixture and its weighted grid of 2 nm cells (150 × 200 cells from
    /// (280, 380) nm): the data of the fit-recovery tests.
    pub(crate) fn known_mixture() -> ([Component; 2], WeightedPoints) {
        let truth = [
            Component {
                weight: 0.35,
                mean: [360.0, 450.0],
                cov: [[300.0, 120.0], [120.0, 400.0]],
            },
            Component {
                weight: 0.65,
                mean: [430.0, 560.0],
                cov: [[500.0, -150.0], [-150.0, 250.0]],
            },
        ];
        let cell = 2.0;
        let mut data = WeightedPoints {
            cell,
            ..Default::default()
        };
        for i in 0..150 {
            for o in 0..200 {
                let x = [280.0 + cell * i as f64, 380.0 + cell * o as f64];
                data.x.push(x);
                data.w.push(mixture_density(&truth, x));
            }
        }
        (truth, data)
    }

    /// A weighted fit: data, components, seed, iterations, tolerance.
    pub(crate) type Fitter =
        fn(&WeightedPoints, usize, u64, usize, f64) -> Result<FitReport, String>;

    /// What any fit must survive: more components than weighted points (at most one per point,
    /// valid, deterministic, weights summing to 1), no weight at all (no components), bad
    /// weights (an error), coincident points without a cell (a "singular fit" error).
    pub(crate) fn check_degenerate_data(fit: Fitter) {
        let data = WeightedPoints {
            x: vec![[400.0, 500.0], [400.0, 510.0], [410.0, 520.0]],
            w: vec![1.0, 2.0, 0.0],
            cell: 10.0,
        };
        let a = fit(&data, 8, 3, 500, 1e-9).unwrap();
        let b = fit(&data, 8, 3, 500, 1e-9).unwrap();
        assert_eq!(format!("{:?}", a.components), format!("{:?}", b.components));
        assert!(!a.components.is_empty() && a.components.len() <= 2, "{a:?}");
        assert!(a.components.iter().all(|c| c.is_valid()), "{a:?}");
        let sum: f64 = a.components.iter().map(|c| c.weight).sum();
        assert!((sum - 1.0).abs() < 1e-12);
        let empty = WeightedPoints {
            w: vec![0.0; 3],
            ..data.clone()
        };
        assert!(fit(&empty, 4, 0, 10, 1e-9).unwrap().components.is_empty());
        for w in [
            vec![1.0, f64::NAN, 0.0],
            vec![1.0, -1.0, 0.0],
            vec![1.0, 1.0],
        ] {
            let bad = WeightedPoints { w, ..data.clone() };
            assert!(fit(&bad, 2, 0, 10, 1e-9).is_err());
        }
        let singular = WeightedPoints {
            x: vec![[400.0, 500.0]; 3],
            w: vec![1.0; 3],
            cell: 0.0,
        };
        let e = fit(&singular, 2, 0, 10, 1e-9).unwrap_err();
        assert!(e.starts_with("singular fit: "), "{e}");
    }
}
