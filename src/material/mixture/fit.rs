//! From a cleaned BFC matrix to a fitted, scaled model (Hua §5).

use super::conditional::MAX_COMPONENTS;
use super::file::{FORMAT, FitInfo, Grid, Source};
use super::{ConditionalMixture, GmmFile, WeightedPoints, bayes, em};
use crate::material::reradiation::BfcMatrix;

named_enum! {
    /// The fitting algorithm.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
    pub enum FitMethod {
        /// Weighted expectation–maximisation.
        #[default]
        Em = "em",
        /// Weighted variational Bayesian inference (may use fewer components than asked).
        Bayes = "bayes",
    }
}

/// Settings of one fit.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitOptions {
    pub components: usize,
    pub method: FitMethod,
    pub seed: u64,
    pub max_iterations: usize,
    /// Convergence: stop when the mean log-likelihood changes by less than this.
    pub tolerance: f64,
}

impl FitOptions {
    pub fn new(components: usize, method: FitMethod, seed: u64) -> Self {
        FitOptions {
            components,
            method,
            seed,
            max_iterations: 1000,
            tolerance: 1e-7,
        }
    }
}

/// The off-diagonal cells with a positive value as weighted observations at their centres.
pub fn points(m: &BfcMatrix) -> WeightedPoints {
    let mut data = WeightedPoints {
        cell: m.step as f64,
        ..Default::default()
    };
    for o in 0..m.n_em {
        for i in 0..m.n_ex {
            let v = m.off(o, i);
            if v > 0.0 {
                data.x.push([m.ex(i) as f64, m.em(o) as f64]);
                data.w.push(v as f64);
            }
        }
    }
    data
}

impl FitOptions {
    fn check(&self) -> Result<(), String> {
        if self.components == 0 || self.components > MAX_COMPONENTS {
            return Err(format!(
                "components: {} is not in 1..={MAX_COMPONENTS}",
                self.components
            ));
        }
        if self.max_iterations == 0 || self.max_iterations > 1_000_000 {
            return Err(format!(
                "max_iterations: {} is not in 1..=1000000",
                self.max_iterations
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(format!(
                "tolerance: {} is not a positive number",
                self.tolerance
            ));
        }
        Ok(())
    }
}

/// Fit a cleaned matrix (its off-diagonal part, Hua §5.2) and scale the mixture by the integral
/// ratio (eq. 5) so that the model keeps the matrix's energy. The result's `source` is left
/// empty for the caller to fill.
pub fn fit_matrix(m: &BfcMatrix, opt: &FitOptions) -> Result<GmmFile, String> {
    opt.check()?;
    let data = points(m);
    let report = match opt.method {
        FitMethod::Em => em::fit_em(
            &data,
            opt.components,
            opt.seed,
            opt.max_iterations,
            opt.tolerance,
        ),
        FitMethod::Bayes => bayes::fit_bayes(
            &data,
            opt.components,
            opt.seed,
            opt.max_iterations,
            opt.tolerance,
        ),
    }?;
    if let Some(k) = report.components.iter().position(|c| !c.is_valid()) {
        return Err(format!(
            "singular fit: component {k} came out as {:?}",
            report.components[k]
        ));
    }
    let grid = Grid::of(m);
    // ∬ρ = Σ D/Δλ · Δλ · Δλ over the off-diagonal cells, nm.
    let energy: f64 = data.w.iter().sum::<f64>() * m.step as f64;
    let mass = ConditionalMixture::new(
        &report.components,
        1.0,
        grid.ex_support(),
        grid.em_support(),
    )
    .mass();
    let scale = if report.components.is_empty() {
        0.0
    } else if mass > 0.0 && (energy / mass).is_finite() {
        energy / mass // Hua eq. 5
    } else {
        return Err(format!(
            "singular fit: the mixture has mass {mass} above the diagonal of the measured support"
        ));
    };
    Ok(GmmFile {
        format: FORMAT.to_string(),
        source: Source::default(),
        fit: FitInfo {
            options: *opt,
            iterations: report.iterations,
            log_likelihood: report.log_likelihood,
            converged: report.converged,
        },
        grid,
        reflectance: (0..m.n_em).map(|o| m.reflectance(o)).collect(),
        scale,
        components: report.components,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::mixture::{Component, mixture_density};

    /// A 10 nm matrix whose cells hold Δλ·S·p of a known mixture, with p a density per nm²:
    /// the kernel per nm is D/Δλ = S·p (docs/design.md §2).
    fn synthetic(truth: &[Component], s: f64) -> BfcMatrix {
        let (n_em, n_ex) = (41, 49);
        let mut m = BfcMatrix {
            em_lo: 380.0,
            ex_lo: 300.0,
            step: 10.0,
            n_em,
            n_ex,
            d: vec![0.0; n_em * n_ex],
        };
        for o in 0..n_em {
            for i in 0..n_ex {
                let (lo, li) = (m.em(o) as f64, m.ex(i) as f64);
                m.d[o * n_ex + i] = if m.is_diagonal(o, i) {
                    0.2
                } else if lo > li {
                    (10.0 * s * mixture_density(truth, [li, lo])) as f32
                } else {
                    0.0
                };
            }
        }
        m
    }

    /// The fit of a matrix drawn from a known two-component mixture recovers its weights,
    /// means, covariances and scale S, so the kernel comes out per nm: a per-bin reading
    /// would be ten times too large, a missing Δλ ten times too small.
    #[test]
    fn recovers_a_known_mixture_and_its_scale_per_nm() {
        let truth = [
            Component {
                weight: 0.4,
                mean: [360.0, 460.0],
                cov: [[500.0, 150.0], [150.0, 700.0]],
            },
            Component {
                weight: 0.6,
                mean: [470.0, 580.0],
                cov: [[800.0, -200.0], [-200.0, 600.0]],
            },
        ];
        let s0 = 55.0;
        let m = synthetic(&truth, s0);
        let f = fit_matrix(&m, &FitOptions::new(2, FitMethod::Em, 1)).unwrap();
        assert!(f.fit.converged);
        let mut c = f.components.clone();
        c.sort_by(|a, b| a.mean[0].total_cmp(&b.mean[0]));
        for (c, t) in c.iter().zip(&truth) {
            assert!((c.weight - t.weight).abs() < 0.01, "{c:?} vs {t:?}");
            for a in 0..2 {
                assert!((c.mean[a] - t.mean[a]).abs() < 1.0, "{c:?} vs {t:?}");
                for b in 0..2 {
                    let want = t.cov[a][b] + if a == b { 100.0 / 12.0 } else { 0.0 };
                    assert!((c.cov[a][b] - want).abs() < 0.05 * t.cov[a][a], "{c:?}");
                }
            }
        }
        assert!((f.scale / s0 - 1.0).abs() < 0.01, "S = {} vs {s0}", f.scale);
        // The kernel per nm at the first component's mean, and the matrix it evaluates to.
        let cond = f.conditional(crate::spectrum::DEFAULT_DOMAIN);
        let want = s0 * mixture_density(&truth, [360.0, 460.0]);
        let got = cond.kernel(360.0, 460.0);
        assert!((got / want - 1.0).abs() < 0.02, "ρ = {got} vs {want}");
        let back = f.to_matrix();
        let (o, i) = (8, 6); // λo = 460, λi = 360
        assert!((back.d[o * 49 + i] / m.d[o * 49 + i] - 1.0).abs() < 0.02);
        assert_eq!(back.reflectance(20), 0.2);
    }

    /// The integral ratio keeps the measured energy: Σ over columns of ∫ρ dλo times the column
    /// width equals Σ D·Δλ; and each column's ∫ρ dλo is close to the measured column sum Σ_o D.
    #[test]
    fn integral_ratio_keeps_the_energy_of_a_measured_matrix() {
        let m = BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap();
        let f = fit_matrix(&m, &FitOptions::new(8, FitMethod::Em, 0)).unwrap();
        let g = f.grid;
        let cond = ConditionalMixture::new(&f.components, f.scale, g.ex_support(), g.em_support());
        let energy: f64 = points(&m).w.iter().sum::<f64>() * 10.0;
        let (a, b) = g.ex_support();
        let n = 4900;
        let h = (b - a) / n as f64;
        let total: f64 = (0..n)
            .map(|j| cond.total(a + (j as f64 + 0.5) * h, 0) * h)
            .sum();
        assert!((total / energy - 1.0).abs() < 1e-4, "{total} vs {energy}");
        // Per column (the bright ones), the fit's ∫ρ dλo against the measured Σ_o D[o][i]: the
        // fit error scatters them by about ±10 %, but their median is 1 (a unit slip would put
        // it at 10 or 0.1).
        let col = |i: usize| (0..m.n_em).map(|o| m.off(o, i) as f64).sum::<f64>();
        let mut r: Vec<f64> = (0..m.n_ex)
            .filter(|&i| col(i) > 0.05)
            .map(|i| cond.total(m.ex(i) as f64, 0) / col(i))
            .collect();
        r.sort_by(f64::total_cmp);
        let median = r[r.len() / 2];
        assert!((median - 1.0).abs() < 0.05, "{r:?}");
    }

    #[test]
    fn bad_options_and_empty_matrices() {
        let mut m = BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap();
        for k in [0, 33] {
            let e = fit_matrix(&m, &FitOptions::new(k, FitMethod::Em, 0)).unwrap_err();
            assert!(e.contains("components"), "{e}");
        }
        let mut o = FitOptions::new(2, FitMethod::Em, 0);
        o.tolerance = f64::NAN;
        assert!(fit_matrix(&m, &o).unwrap_err().contains("tolerance"));
        // No fluorescence: an empty mixture, not an error.
        for o in 0..m.n_em {
            for i in 0..m.n_ex {
                if !m.is_diagonal(o, i) {
                    m.d[o * m.n_ex + i] = 0.0;
                }
            }
        }
        let f = fit_matrix(&m, &FitOptions::new(4, FitMethod::Em, 0)).unwrap();
        assert!(f.components.is_empty());
        assert_eq!(f.scale, 0.0);
        assert!(f.conditional(crate::spectrum::DEFAULT_DOMAIN).is_empty());
    }
}
