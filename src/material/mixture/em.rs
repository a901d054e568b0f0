//! Weighted expectation–maximisation with k-means++ initialisation (Hua §5.2).
//!
//! Each matrix cell is an observation at its centre, weighted by its value. A cell stands for a
//! uniform square of side Δ, whose own covariance Δ²/12·I is added in every M-step: that is the
//! EM of binned data with the responsibilities taken at the cell centres, and it floors every
//! covariance, so no component can collapse onto one cell.

use super::{Component, FitReport, WeightedPoints};
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

/// Lloyd iterations after the k-means++ seeding.
const LLOYD_ITERATIONS: usize = 20;

/// A component's share of the total weight below which it is dropped as empty.
const EMPTY_SHARE: f64 = 1e-9;

/// k-means++ seeding (each next centre drawn with probability ∝ w·d²), weighted Lloyd
/// iterations, then one component per non-empty cluster from its weighted moments.
pub fn initial_components(data: &WeightedPoints, k: usize, seed: u64) -> Vec<Component> {
    let n = data.x.len();
    let k = k.min(data.w.iter().filter(|&&w| w > 0.0).count());
    if k == 0 {
        return vec![];
    }
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let d2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let mut centres = vec![data.x[draw(&data.w, rng.random())]];
    let mut nearest: Vec<f64> = data.x.iter().map(|&x| d2(x, centres[0])).collect();
    while centres.len() < k {
        let p: Vec<f64> = (0..n).map(|j| data.w[j] * nearest[j]).collect();
        if p.iter().sum::<f64>() <= 0.0 {
            break; // every weighted point already is a centre
        }
        let c = data.x[draw(&p, rng.random())];
        for (m, &x) in nearest.iter_mut().zip(&data.x) {
            *m = m.min(d2(x, c));
        }
        centres.push(c);
    }
    let mut label = vec![0usize; n];
    for _ in 0..LLOYD_ITERATIONS {
        for (l, &x) in label.iter_mut().zip(&data.x) {
            *l = (0..centres.len())
                .min_by(|&a, &b| d2(x, centres[a]).total_cmp(&d2(x, centres[b])))
                .unwrap();
        }
        let moved = centres.clone();
        for (c, centre) in centres.iter_mut().enumerate() {
            let (mut s, mut m) = (0.0, [0.0; 2]);
            for j in (0..n).filter(|&j| label[j] == c) {
                s += data.w[j];
                m[0] += data.w[j] * data.x[j][0];
                m[1] += data.w[j] * data.x[j][1];
            }
            if s > 0.0 {
                *centre = [m[0] / s, m[1] / s];
            }
        }
        if moved == centres {
            break;
        }
    }
    let resp: Vec<Vec<f64>> = (0..centres.len())
        .map(|c| label.iter().map(|&l| (l == c) as u8 as f64).collect())
        .collect();
    maximise(data, &resp)
}

/// Index drawn with probability ∝ `p` from a uniform number.
fn draw(p: &[f64], u: f64) -> usize {
    let total: f64 = p.iter().sum();
    let mut acc = 0.0;
    for (j, &x) in p.iter().enumerate() {
        acc += x;
        if acc > u * total && x > 0.0 {
            return j;
        }
    }
    p.iter().rposition(|&x| x > 0.0).unwrap_or(0)
}

/// M-step: weights, means and covariances (plus the cell's own Δ²/12) from responsibilities
/// `resp[k][j]`; components with no weight are dropped.
fn maximise(data: &WeightedPoints, resp: &[Vec<f64>]) -> Vec<Component> {
    let total: f64 = data.w.iter().sum();
    let floor = data.cell * data.cell / 12.0;
    let mut out = Vec::with_capacity(resp.len());
    for r in resp {
        let nk: f64 = r.iter().zip(&data.w).map(|(r, w)| r * w).sum();
        if nk <= EMPTY_SHARE * total {
            continue;
        }
        let mut mean = [0.0; 2];
        for ((r, w), x) in r.iter().zip(&data.w).zip(&data.x) {
            mean[0] += r * w * x[0];
            mean[1] += r * w * x[1];
        }
        mean = [mean[0] / nk, mean[1] / nk];
        let mut cov = [[0.0; 2]; 2];
        for ((r, w), x) in r.iter().zip(&data.w).zip(&data.x) {
            let (dx, dy) = (x[0] - mean[0], x[1] - mean[1]);
            cov[0][0] += r * w * dx * dx;
            cov[0][1] += r * w * dx * dy;
            cov[1][1] += r * w * dy * dy;
        }
        let c01 = cov[0][1] / nk;
        out.push(Component {
            weight: nk / total,
            mean,
            cov: [[cov[0][0] / nk + floor, c01], [c01, cov[1][1] / nk + floor]],
        });
    }
    out
}

/// ln N(x | μ, Σ).
#[inline]
fn log_density(c: &Component, x: [f64; 2]) -> f64 {
    let det = c.det();
    let (dx, dy) = (x[0] - c.mean[0], x[1] - c.mean[1]);
    let q = (c.cov[1][1] * dx * dx - 2.0 * c.cov[0][1] * dx * dy + c.cov[0][0] * dy * dy) / det;
    -0.5 * q - (2.0 * PI * det.sqrt()).ln()
}

/// E-step: responsibilities `resp[k][j]` and the mean log-likelihood per unit weight.
fn expect(data: &WeightedPoints, comps: &[Component], resp: &mut [Vec<f64>]) -> f64 {
    let total: f64 = data.w.iter().sum();
    let mut ll = 0.0;
    let mut logs = vec![0.0; comps.len()];
    for (j, &x) in data.x.iter().enumerate() {
        for (l, c) in logs.iter_mut().zip(comps) {
            *l = c.weight.ln() + log_density(c, x);
        }
        let top = logs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let s: f64 = logs.iter().map(|l| (l - top).exp()).sum();
        let lse = top + s.ln();
        for (r, l) in resp.iter_mut().zip(&logs) {
            r[j] = (l - lse).exp();
        }
        ll += data.w[j] * lse;
    }
    ll / total
}

/// Weighted EM from the k-means++ start until the mean log-likelihood changes by less than
/// `tolerance` or `max_iterations` pass.
pub fn fit_em(
    data: &WeightedPoints,
    k: usize,
    seed: u64,
    max_iterations: usize,
    tolerance: f64,
) -> Result<FitReport, String> {
    if data.x.len() != data.w.len() || data.w.iter().any(|w| !w.is_finite() || *w < 0.0) {
        return Err("the weights must be finite and non-negative, one per point".into());
    }
    let mut comps = initial_components(data, k, seed);
    let mut ll = f64::NEG_INFINITY;
    let mut iterations = 0;
    let mut converged = comps.is_empty();
    while !converged && iterations < max_iterations {
        let mut resp = vec![vec![0.0; data.x.len()]; comps.len()];
        let next = expect(data, &comps, &mut resp);
        if !next.is_finite() {
            return Err(format!(
                "singular fit: the log-likelihood became {next} at iteration {iterations}"
            ));
        }
        converged = (next - ll).abs() < tolerance;
        ll = next;
        comps = maximise(data, &resp);
        iterations += 1;
    }
    Ok(FitReport {
        components: comps,
        iterations,
        log_likelihood: ll,
        converged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A weighted grid of cells drawn from a known two-component mixture: EM recovers its
    /// weights, means and covariances (the cell's Δ²/12 is part of the fitted covariance).
    #[test]
    fn recovers_a_known_mixture() {
        let (truth, data) = super::super::tests::known_mixture();
        let cell = data.cell;
        let fit = fit_em(&data, 2, 7, 2000, 1e-10).unwrap();
        assert!(fit.converged);
        let mut c = fit.components.clone();
        c.sort_by(|a, b| a.mean[0].total_cmp(&b.mean[0]));
        for (c, t) in c.iter().zip(&truth) {
            assert!((c.weight - t.weight).abs() < 2e-3, "{c:?} vs {t:?}");
            for a in 0..2 {
                assert!((c.mean[a] - t.mean[a]).abs() < 0.1, "{c:?} vs {t:?}");
                for b in 0..2 {
                    let want = t.cov[a][b] + if a == b { cell * cell / 12.0 } else { 0.0 };
                    assert!((c.cov[a][b] - want).abs() < 2.0, "{c:?} vs {t:?}");
                }
            }
        }
    }

    #[test]
    fn fits_are_deterministic_and_survive_degenerate_data() {
        super::super::tests::check_degenerate_data(fit_em);
    }
}
