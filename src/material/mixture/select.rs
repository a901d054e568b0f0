//! Choosing the number of Gaussians by the Bayesian information criterion (Hua §5.2).
//!
//! BIC = p ln n − 2 ln L̂, the smallest wins. A matrix is weighted cells, not samples, so n and
//! L̂ need a convention. Here each positive cell is one observation, and the cells share the
//! data's log-likelihood in proportion to their weights: n is the number of positive cells and
//! ln L̂ = n · ℓ̄, with ℓ̄ = Σ w ln p / Σ w the weighted mean log-likelihood that EM maximises
//! (its `log_likelihood`). So ln L̂ does not depend on the matrix's overall brightness, and a
//! fit that is ℓ̄ better gains n·ℓ̄ against ln n per parameter. A mixture of K 2-D Gaussians has
//! p = 6K − 1 free parameters (K − 1 weights, 2K mean coordinates, 3K covariance entries);
//! K is the number of components the fit kept (EM drops empty ones). On a tie the smaller K
//! wins.

use super::{FitReport, WeightedPoints};

/// Free parameters of a mixture of `k` 2-D Gaussians: 6k − 1.
pub fn parameters(k: usize) -> usize {
    (6 * k).saturating_sub(1)
}

/// BIC = p ln n − 2 n ℓ̄ of a fit with `k` components and weighted mean log-likelihood
/// `mean_log_likelihood` on `n` positive cells.
pub fn bic(mean_log_likelihood: f64, n: usize, k: usize) -> f64 {
    let n = n as f64;
    parameters(k) as f64 * n.ln() - 2.0 * n * mean_log_likelihood
}

/// The BIC of a fit of `data`.
pub fn bic_of(report: &FitReport, data: &WeightedPoints) -> f64 {
    let n = data.w.iter().filter(|&&w| w > 0.0).count();
    bic(report.log_likelihood, n, report.components.len())
}

/// Fit `data` with 1..=`max` components (`fit(k)`, whose [`FitReport`] `report` gives) and keep
/// the fit of smallest BIC; also returns every K's BIC, K = 1 first.
pub fn by_bic<T>(
    data: &WeightedPoints,
    max: usize,
    fit: impl Fn(usize) -> Result<T, String>,
    report: impl Fn(&T) -> &FitReport,
) -> Result<(T, Vec<f64>), String> {
    let mut best: Option<(T, f64)> = None;
    let mut all = Vec::with_capacity(max);
    for k in 1..=max.max(1) {
        let f = fit(k)?;
        let b = bic_of(report(&f), data);
        all.push(b);
        if best.as_ref().is_none_or(|(_, x)| b < *x) {
            best = Some((f, b));
        }
    }
    let (f, _) = best.expect("at least one number of components is fitted");
    Ok((f, all))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::mixture::fit::{FitMethod, FitOptions, best_start};
    use crate::material::mixture::{Component, mixture_density};
    use rand::{Rng, SeedableRng};

    fn three() -> [Component; 3] {
        [
            Component {
                weight: 0.3,
                mean: [350.0, 440.0],
                cov: [[250.0, 80.0], [80.0, 300.0]],
            },
            Component {
                weight: 0.45,
                mean: [420.0, 560.0],
                cov: [[400.0, -120.0], [-120.0, 250.0]],
            },
            Component {
                weight: 0.25,
                mean: [480.0, 650.0],
                cov: [[200.0, 50.0], [50.0, 350.0]],
            },
        ]
    }

    /// The cells of side `cell` nm covering [280, 580] × [380, 780] nm with a positive weight `w(x)`
    /// at their centres.
    fn grid(cell: f64, w: impl Fn([f64; 2]) -> f64) -> WeightedPoints {
        let mut data = WeightedPoints {
            cell,
            ..Default::default()
        };
        let (ni, no) = ((300.0 / cell) as usize, (400.0 / cell) as usize);
        for i in 0..ni {
            for o in 0..no {
                let x = [
                    280.0 + cell * (i as f64 + 0.5),
                    380.0 + cell * (o as f64 + 0.5),
                ];
                let v = w(x);
                if v > 0.0 {
                    data.x.push(x);
                    data.w.push(v);
                }
            }
        }
        data
    }

    fn chosen(data: &WeightedPoints, max: usize) -> (usize, Vec<f64>) {
        let mut opt = FitOptions::new(max, FitMethod::Em, 0);
        opt.tolerance = 1e-9;
        let (f, all) = by_bic(data, max, |k| best_start(data, k, &opt), |b| &b.report).unwrap();
        (f.report.components.len(), all)
    }

    #[test]
    fn parameters_of_a_mixture() {
        assert_eq!(parameters(1), 5);
        assert_eq!(parameters(8), 47);
        // The penalty grows with K and n; a better fit lowers BIC by 2n per nat.
        assert!(bic(-10.0, 1000, 3) > bic(-10.0, 1000, 2));
        assert!((bic(-10.0, 1000, 2) - bic(-10.001, 1000, 2) + 2.0).abs() < 1e-9);
    }

    /// Cells holding the exact density of a known 3-component mixture, and cells counting
    /// 200 000 draws from it: BIC picks 3 of 1..=6 both times, each K being fitted from
    /// several starts.
    #[test]
    fn bic_picks_the_number_of_components_of_the_data() {
        let truth = three();
        let exact = grid(4.0, |x| mixture_density(&truth, x));
        let (k, all) = chosen(&exact, 6);
        assert_eq!(k, 3, "BIC {all:?}");

        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let cell = 4.0;
        let (ni, no) = (75, 100);
        let mut counts = vec![0.0; ni * no];
        for _ in 0..200_000 {
            let u: f64 = rng.random();
            let mut acc = 0.0;
            let c = truth
                .iter()
                .find(|c| {
                    acc += c.weight;
                    u < acc
                })
                .unwrap_or(&truth[2]);
            // A correlated normal draw through the Cholesky factor of the covariance.
            let (z0, z1) = (normal(&mut rng), normal(&mut rng));
            let l00 = c.cov[0][0].sqrt();
            let l10 = c.cov[0][1] / l00;
            let l11 = (c.cov[1][1] - l10 * l10).sqrt();
            let x = [c.mean[0] + l00 * z0, c.mean[1] + l10 * z0 + l11 * z1];
            let (i, o) = ((x[0] - 280.0) / cell, (x[1] - 380.0) / cell);
            if (0.0..ni as f64).contains(&i) && (0.0..no as f64).contains(&o) {
                counts[i as usize * no + o as usize] += 1.0;
            }
        }
        let drawn = grid(cell, |x| {
            let (i, o) = ((x[0] - 280.0) / cell, (x[1] - 380.0) / cell);
            counts[i as usize * no + o as usize]
        });
        let (k, all) = chosen(&drawn, 6);
        assert_eq!(k, 3, "BIC {all:?}");
        // One Gaussian is clearly worse than the truth.
        assert!(all[0] > all[2], "{all:?}");
    }

    fn normal(rng: &mut impl Rng) -> f64 {
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        (-2.0 * (1.0 - u).ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}
