//! Weighted variational Bayesian inference of a 2-D Gaussian mixture (Hua §5.2), following
//! Bishop, PRML §10.2, with every sufficient statistic weighted by the point weights.
//!
//! - Weights: the point weights are rescaled to sum to the number of points with positive weight
//!   (the effective sample size N), so that a matrix of N cells weighs like N observations
//!   whatever its units. This sets how strongly the prior acts: it counts as about one
//!   observation per component against N. Points of zero weight are ignored.
//! - Priors (scikit-learn's defaults for `BayesianGaussianMixture` with
//!   `weight_concentration_prior_type = "dirichlet_distribution"`): a symmetric Dirichlet on the
//!   weights with concentration α0 = 1/k; a Gaussian–Wishart on each component with mean prior
//!   m0 = the weighted data mean, β0 = 1, ν0 = 2 (the dimension) and W0⁻¹ = the weighted data
//!   covariance plus the cell's Δ²/12·I.
//! - Cells: as in the EM ([`super::em`]), a point stands for a uniform square of side Δ. The
//!   model is fitted to the points smeared over their cells, each point's log-likelihood taken
//!   as E_u[ln N(x + u | μ, Λ⁻¹)] = ln N(x | μ, Λ⁻¹) − ½ Δ²/12 Tr Λ. The smear adds Δ²/12·I to
//!   every scatter S_k (so no covariance collapses) and −½ Δ²/12 E[Tr Λ_k] to every
//!   responsibility's exponent. Both updates then maximise one and the same lower bound, which
//!   therefore never decreases.
//! - Start: the hard assignment of every point to the nearest mean of the weighted
//!   k-means++ + Lloyd start of the EM ([`super::em::initial_components`]).
//! - Deletions: plain coordinate ascent empties a redundant component only slowly: two copies
//!   of one Gaussian explain the data as well as one, and only the prior's O(1) terms, against
//!   thousands of effective points, push one out. On the two-Gaussian test grid (30 000 points,
//!   k = 8) most seeds still carried a split-off copy of 5–17 % weight after 5000 updates, the
//!   bound gaining as little as 1e-8 per unit weight per update. Every [`DELETION_EVERY`]
//!   updates, and before stopping, the fit therefore tries to empty one component, the lightest
//!   first (its points shared out by an E-step without it, then an M-step), and keeps the first
//!   trial that raises the bound; the emptied component keeps zero responsibilities from then on. K and the priors are unchanged, so this is still ascent on
//!   the same bound and ends at one of its local maxima, only much sooner.
//! - Stop: when an update changes the lower bound per unit weight by less than the tolerance and
//!   no deletion raises it; at least one update is always made. The reported `iterations` counts
//!   the kept updates (VB updates and deletions) and `log_likelihood` is the final bound per
//!   unit weight.
//! - Output: weight E[π_k] = α_k / Σ_j α_j, mean m_k and covariance the posterior mean
//!   E[Σ_k] = W_k⁻¹/(ν_k − 3) (the mean of the inverse Wishart; it exists for ν_k > 3), else
//!   W_k⁻¹/ν_k = E[Λ_k]⁻¹. The expected covariance is the Bayes estimate of the covariance, where
//!   scikit-learn reports E[Λ_k]⁻¹ (the precision the responsibilities use); the two differ by
//!   a factor 1 + 3/(ν_k − 3), i.e. by about 3 / (effective points of the component).
//!   Deleted components and those whose weight falls below 1e-3 are dropped and the rest
//!   renormalised: this is how the fit uses fewer Gaussians than the k allowed.

use super::{Component, FitReport, WeightedPoints};
use std::f64::consts::{LN_2, PI};

/// A symmetric 2×2 matrix.
type Mat = [[f64; 2]; 2];

/// The dimension D.
const D: f64 = 2.0;

/// Components with a smaller expected weight are dropped from the output.
const MIN_WEIGHT: f64 = 1e-3;

/// Component deletions are tried every this many updates, and at convergence.
const DELETION_EVERY: usize = 10;

/// The positive-weight points, weights rescaled to sum to their number.
struct Points {
    x: Vec<[f64; 2]>,
    w: Vec<f64>,
    /// Σ w = N, the effective sample size.
    total: f64,
    /// The cell's own variance Δ²/12.
    cell_var: f64,
}

/// The hyperparameters of the priors.
struct Prior {
    alpha0: f64,
    beta0: f64,
    nu0: f64,
    m0: [f64; 2],
    w0inv: Mat,
    /// ln B(W0, ν0).
    ln_b0: f64,
}

/// The variational posterior of one component, with its weighted statistics.
struct Factor {
    /// N_k, x̄_k and S_k (the latter with the cell's Δ²/12·I).
    n: f64,
    xbar: [f64; 2],
    s: Mat,
    alpha: f64,
    beta: f64,
    m: [f64; 2],
    winv: Mat,
    w: Mat,
    nu: f64,
    /// E[ln |Λ_k|] and E[ln π_k].
    ln_lambda: f64,
    ln_pi: f64,
}

/// Fit at most `k` components by weighted variational inference.
pub fn fit_bayes(
    data: &WeightedPoints,
    k: usize,
    seed: u64,
    max_iterations: usize,
    tolerance: f64,
) -> Result<FitReport, String> {
    fit_traced(data, k, seed, max_iterations, tolerance).map(|(report, _)| report)
}

/// [`fit_bayes`], also returning the lower bound per unit weight after every update.
fn fit_traced(
    data: &WeightedPoints,
    k: usize,
    seed: u64,
    max_iterations: usize,
    tolerance: f64,
) -> Result<(FitReport, Vec<f64>), String> {
    let p = points(data)?;
    let init = super::em::initial_components(data, k, seed);
    if init.is_empty() || p.x.is_empty() {
        let report = FitReport {
            components: vec![],
            iterations: 0,
            log_likelihood: f64::NEG_INFINITY,
            converged: true,
        };
        return Ok((report, vec![]));
    }
    let prior = prior(&p, k);
    let d2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let mut resp = vec![vec![0.0; p.x.len()]; init.len()];
    for (j, &x) in p.x.iter().enumerate() {
        let c = (0..init.len())
            .min_by(|&a, &b| d2(x, init[a].mean).total_cmp(&d2(x, init[b].mean)))
            .unwrap_or(0);
        resp[c][j] = 1.0;
    }
    let mut active = vec![true; init.len()];
    // Σ_n w_n Σ_k r_nk ln r_nk is zero for a hard assignment.
    let mut state = State::new(&p, &prior, resp, 0.0);
    let mut history: Vec<f64> = Vec::new();
    let converged = loop {
        if !state.bound.is_finite() {
            return Err(format!(
                "singular fit: the lower bound became {} at iteration {}",
                state.bound,
                history.len() + 1
            ));
        }
        let converged = history
            .last()
            .is_some_and(|&last| (state.bound - last).abs() < tolerance);
        history.push(state.bound);
        let budget = history.len() < max_iterations;
        if budget
            && (converged || history.len().is_multiple_of(DELETION_EVERY))
            && let Some(better) = delete_one(&p, &prior, &state, &mut active)
        {
            state = better;
            continue;
        }
        if converged || !budget {
            break converged;
        }
        let mut resp = state.resp;
        let r_ln_r = expect(&p, &state.factors, &active, &mut resp);
        state = State::new(&p, &prior, resp, r_ln_r);
    };
    let report = FitReport {
        components: components(&state.factors, &active),
        iterations: history.len(),
        log_likelihood: *history.last().unwrap_or(&f64::NEG_INFINITY),
        converged,
    };
    Ok((report, history))
}

/// Responsibilities, the factors they give and their lower bound per unit weight.
struct State {
    resp: Vec<Vec<f64>>,
    factors: Vec<Factor>,
    bound: f64,
}

impl State {
    /// The M-step from `resp` (with Σ_n w_n Σ_k r_nk ln r_nk = `r_ln_r`) and its bound.
    fn new(p: &Points, prior: &Prior, resp: Vec<Vec<f64>>, r_ln_r: f64) -> Self {
        let factors = maximise(p, &resp, prior);
        let bound = lower_bound(&factors, prior, r_ln_r) / p.total;
        State {
            resp,
            factors,
            bound,
        }
    }
}

/// Try to empty one active component, the lightest first: its points go to the others by an
/// E-step without it, then an M-step. The first trial that raises the bound is kept and the
/// component retired for good (its responsibilities stay zero).
fn delete_one(p: &Points, prior: &Prior, state: &State, active: &mut [bool]) -> Option<State> {
    let mut order: Vec<usize> = (0..active.len()).filter(|&c| active[c]).collect();
    if order.len() < 2 {
        return None;
    }
    order.sort_by(|&a, &b| state.factors[a].n.total_cmp(&state.factors[b].n));
    for c in order {
        let mut trial = active.to_vec();
        trial[c] = false;
        let mut resp = vec![vec![0.0; p.x.len()]; active.len()];
        let r_ln_r = expect(p, &state.factors, &trial, &mut resp);
        let next = State::new(p, prior, resp, r_ln_r);
        if next.bound > state.bound {
            active[c] = false;
            return Some(next);
        }
    }
    None
}

/// Check the data and keep the positive-weight points, weights rescaled to sum to their number.
fn points(data: &WeightedPoints) -> Result<Points, String> {
    if data.x.len() != data.w.len() {
        return Err(format!(
            "{} points but {} weights: one weight per point is needed",
            data.x.len(),
            data.w.len()
        ));
    }
    if data.w.iter().any(|w| !w.is_finite() || *w < 0.0) {
        return Err("the weights must be finite and non-negative".into());
    }
    if !data.cell.is_finite() || data.cell < 0.0 {
        return Err(format!(
            "the cell size {} is not a non-negative number",
            data.cell
        ));
    }
    let (mut x, mut w) = (Vec::new(), Vec::new());
    for (&xj, &wj) in data.x.iter().zip(&data.w).filter(|(_, w)| **w > 0.0) {
        if !xj.iter().all(|v| v.is_finite()) {
            return Err(format!("the point {xj:?} has a weight but is not finite"));
        }
        x.push(xj);
        w.push(wj);
    }
    let sum: f64 = w.iter().sum();
    if !sum.is_finite() {
        return Err("the sum of the weights overflows".into());
    }
    let total = w.len() as f64;
    for wj in &mut w {
        *wj *= total / sum;
    }
    Ok(Points {
        x,
        w,
        total,
        cell_var: data.cell * data.cell / 12.0,
    })
}

/// The priors: scikit-learn's defaults, from the weighted data mean and covariance.
fn prior(p: &Points, k: usize) -> Prior {
    let (m0, mut w0inv) = moments(p, |_| 1.0, p.total);
    w0inv[0][0] += p.cell_var;
    w0inv[1][1] += p.cell_var;
    let nu0 = D;
    Prior {
        alpha0: 1.0 / k as f64,
        beta0: 1.0,
        nu0,
        m0,
        w0inv,
        ln_b0: ln_wishart_b(&w0inv, nu0),
    }
}

/// Weighted mean and covariance (without the cell) of the points with extra factors `r(j)`
/// summing, with the weights, to `n` > 0.
fn moments(p: &Points, r: impl Fn(usize) -> f64, n: f64) -> ([f64; 2], Mat) {
    let mut mean = [0.0; 2];
    for (j, (x, w)) in p.x.iter().zip(&p.w).enumerate() {
        let rw = r(j) * w;
        mean[0] += rw * x[0];
        mean[1] += rw * x[1];
    }
    mean = [mean[0] / n, mean[1] / n];
    let mut cov = [[0.0; 2]; 2];
    for (j, (x, w)) in p.x.iter().zip(&p.w).enumerate() {
        let rw = r(j) * w;
        let (dx, dy) = (x[0] - mean[0], x[1] - mean[1]);
        cov[0][0] += rw * dx * dx;
        cov[0][1] += rw * dx * dy;
        cov[1][1] += rw * dy * dy;
    }
    let c01 = cov[0][1] / n;
    (mean, [[cov[0][0] / n, c01], [c01, cov[1][1] / n]])
}

/// Variational M-step: q(π) and q(μ_k, Λ_k) from the responsibilities `resp[k][j]`.
fn maximise(p: &Points, resp: &[Vec<f64>], prior: &Prior) -> Vec<Factor> {
    let mut factors: Vec<Factor> = resp
        .iter()
        .map(|r| {
            // PRML eq. 10.51
            let n: f64 = r.iter().zip(&p.w).map(|(r, w)| r * w).sum();
            // PRML eq. 10.52 and 10.53 (unused if N_k = 0: they only appear times N_k)
            let (xbar, mut s) = if n > 0.0 {
                moments(p, |j| r[j], n)
            } else {
                (prior.m0, [[0.0; 2]; 2])
            };
            s[0][0] += p.cell_var;
            s[1][1] += p.cell_var;
            let (b0, m0) = (prior.beta0, prior.m0);
            // PRML eq. 10.60
            let beta = b0 + n;
            // PRML eq. 10.61
            let m = [
                (b0 * m0[0] + n * xbar[0]) / beta,
                (b0 * m0[1] + n * xbar[1]) / beta,
            ];
            let (dx, dy) = (xbar[0] - m0[0], xbar[1] - m0[1]);
            let shrink = b0 * n / (b0 + n);
            // PRML eq. 10.62
            let c01 = prior.w0inv[0][1] + n * s[0][1] + shrink * dx * dy;
            let winv = [
                [prior.w0inv[0][0] + n * s[0][0] + shrink * dx * dx, c01],
                [c01, prior.w0inv[1][1] + n * s[1][1] + shrink * dy * dy],
            ];
            // PRML eq. 10.63
            let nu = prior.nu0 + n;
            // PRML eq. 10.65
            let ln_lambda =
                digamma(nu / 2.0) + digamma((nu - 1.0) / 2.0) + D * LN_2 - det(&winv).ln();
            Factor {
                n,
                xbar,
                s,
                // PRML eq. 10.58
                alpha: prior.alpha0 + n,
                beta,
                m,
                winv,
                w: inverse(&winv),
                nu,
                ln_lambda,
                ln_pi: 0.0,
            }
        })
        .collect();
    let alpha_hat: f64 = factors.iter().map(|f| f.alpha).sum();
    for f in &mut factors {
        // PRML eq. 10.66
        f.ln_pi = digamma(f.alpha) - digamma(alpha_hat);
    }
    factors
}

/// Variational E-step: the responsibilities `resp[k][j]` from the factors, zero for the
/// inactive components; returns Σ_n w_n Σ_k r_nk ln r_nk.
fn expect(p: &Points, factors: &[Factor], active: &[bool], resp: &mut [Vec<f64>]) -> f64 {
    // PRML eq. 10.46 with 10.64–10.66, and the cell's −½ Δ²/12 E[Tr Λ_k] (E[Λ_k] = ν_k W_k)
    let offsets: Vec<f64> = factors
        .iter()
        .map(|f| {
            f.ln_pi + 0.5 * f.ln_lambda
                - 0.5 * D * (2.0 * PI).ln()
                - 0.5 * D / f.beta
                - 0.5 * f.nu * p.cell_var * (f.w[0][0] + f.w[1][1])
        })
        .collect();
    let mut logs = vec![0.0; factors.len()];
    let mut r_ln_r = 0.0;
    for (j, &x) in p.x.iter().enumerate() {
        for (((l, f), o), &on) in logs.iter_mut().zip(factors).zip(&offsets).zip(active) {
            // PRML eq. 10.64
            *l = if on {
                o - 0.5 * f.nu * quad(&f.w, [x[0] - f.m[0], x[1] - f.m[1]])
            } else {
                f64::NEG_INFINITY
            };
        }
        let top = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lse = top + logs.iter().map(|l| (l - top).exp()).sum::<f64>().ln();
        let mut h = 0.0;
        for (r, l) in resp.iter_mut().zip(&logs) {
            // PRML eq. 10.49
            let ln_r = l - lse;
            r[j] = ln_r.exp();
            if r[j] > 0.0 {
                h += r[j] * ln_r;
            }
        }
        r_ln_r += p.w[j] * h;
    }
    r_ln_r
}

/// The evidence lower bound (PRML eq. 10.70) for the factors and the responsibilities that
/// made them, given Σ_n w_n Σ_k r_nk ln r_nk.
fn lower_bound(factors: &[Factor], prior: &Prior, r_ln_r: f64) -> f64 {
    let kk = factors.len() as f64;
    let (a0, b0, nu0) = (prior.alpha0, prior.beta0, prior.nu0);
    let ln_2pi = (2.0 * PI).ln();
    let alpha_hat: f64 = factors.iter().map(|f| f.alpha).sum();
    // PRML eq. 10.73 (ln C(α0), eq. B.23) and 10.76 (−ln C(α))
    let mut l = ln_gamma(kk * a0) - kk * ln_gamma(a0) - ln_gamma(alpha_hat);
    // PRML eq. 10.75
    l -= r_ln_r;
    for f in factors {
        let dx = [f.xbar[0] - f.m[0], f.xbar[1] - f.m[1]];
        let dm = [f.m[0] - prior.m0[0], f.m[1] - prior.m0[1]];
        // PRML eq. 10.71
        l += 0.5
            * f.n
            * (f.ln_lambda
                - D / f.beta
                - f.nu * trace_product(&f.s, &f.w)
                - f.nu * quad(&f.w, dx)
                - D * ln_2pi);
        // PRML eq. 10.72 and 10.73
        l += (f.n + a0 - 1.0) * f.ln_pi;
        // PRML eq. 10.74
        l += 0.5 * (D * (b0 / (2.0 * PI)).ln() + f.ln_lambda - D * b0 / f.beta)
            - 0.5 * b0 * f.nu * quad(&f.w, dm)
            + prior.ln_b0
            + 0.5 * (nu0 - D - 1.0) * f.ln_lambda
            - 0.5 * f.nu * trace_product(&prior.w0inv, &f.w);
        // PRML eq. 10.76
        l -= (f.alpha - 1.0) * f.ln_pi - ln_gamma(f.alpha);
        // PRML eq. B.82: H[q(Λ_k)]
        let entropy =
            -ln_wishart_b(&f.winv, f.nu) - 0.5 * (f.nu - D - 1.0) * f.ln_lambda + 0.5 * f.nu * D;
        // PRML eq. 10.77
        l -= 0.5 * f.ln_lambda + 0.5 * D * (f.beta / (2.0 * PI)).ln() - 0.5 * D - entropy;
    }
    l
}

/// The fitted components: expected weights, posterior means and expected covariances; the
/// retired components and those below [`MIN_WEIGHT`] dropped and the rest renormalised.
fn components(factors: &[Factor], active: &[bool]) -> Vec<Component> {
    let alpha_hat: f64 = factors.iter().map(|f| f.alpha).sum();
    // PRML eq. B.17: E[π_k]
    let weights: Vec<f64> = factors.iter().map(|f| f.alpha / alpha_hat).collect();
    let heaviest = weights.iter().zip(active).filter(|(_, on)| **on);
    let floor = MIN_WEIGHT.min(heaviest.map(|(w, _)| *w).fold(0.0, f64::max));
    let mut out: Vec<Component> = factors
        .iter()
        .zip(&weights)
        .zip(active)
        .filter(|&((_, &w), &on)| on && w >= floor)
        .map(|(fw, _)| fw)
        .map(|(f, &weight)| {
            // Mean of the inverse Wishart, W⁻¹/(ν − D − 1), where it exists; else E[Λ]⁻¹ (B.80).
            let scale = if f.nu > D + 1.0 { f.nu - D - 1.0 } else { f.nu };
            let c01 = 0.5 * (f.winv[0][1] + f.winv[1][0]) / scale;
            Component {
                weight,
                mean: f.m,
                cov: [[f.winv[0][0] / scale, c01], [c01, f.winv[1][1] / scale]],
            }
        })
        .collect();
    let sum: f64 = out.iter().map(|c| c.weight).sum();
    for c in &mut out {
        c.weight /= sum;
    }
    out
}

/// ln B(W, ν) of the Wishart normaliser (PRML eq. B.79), from W⁻¹, for D = 2.
fn ln_wishart_b(winv: &Mat, nu: f64) -> f64 {
    0.5 * nu * det(winv).ln()
        - 0.5 * nu * D * LN_2
        - 0.25 * D * (D - 1.0) * PI.ln()
        - ln_gamma(0.5 * nu)
        - ln_gamma(0.5 * (nu - 1.0))
}

#[inline]
fn det(a: &Mat) -> f64 {
    a[0][0] * a[1][1] - a[0][1] * a[1][0]
}

/// The inverse of a symmetric 2×2 matrix.
#[inline]
fn inverse(a: &Mat) -> Mat {
    let d = det(a);
    let c01 = -0.5 * (a[0][1] + a[1][0]) / d;
    [[a[1][1] / d, c01], [c01, a[0][0] / d]]
}

/// dᵀ A d for a symmetric A.
#[inline]
fn quad(a: &Mat, d: [f64; 2]) -> f64 {
    a[0][0] * d[0] * d[0] + 2.0 * a[0][1] * d[0] * d[1] + a[1][1] * d[1] * d[1]
}

/// Tr(A B) for symmetric A and B.
#[inline]
fn trace_product(a: &Mat, b: &Mat) -> f64 {
    a[0][0] * b[0][0] + 2.0 * a[0][1] * b[0][1] + a[1][1] * b[1][1]
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine terms; about 1e-15 relative).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Γ(x) = Γ(x + 1) / x
        return ln_gamma(x + 1.0) - x.ln();
    }
    let x = x - 1.0;
    let t = x + G + 0.5;
    let a = C[0]
        + C[1..]
            .iter()
            .enumerate()
            .map(|(i, c)| c / (x + i as f64 + 1.0))
            .sum::<f64>();
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The digamma function ψ(x) for x > 0 (recurrence up to x ≥ 10, then the asymptotic series
/// to x⁻¹²).
fn digamma(x: f64) -> f64 {
    let (mut x, mut acc) = (x, 0.0);
    while x < 10.0 {
        // ψ(x) = ψ(x + 1) − 1/x
        acc -= 1.0 / x;
        x += 1.0;
    }
    // ψ(x) ~ ln x − 1/(2x) − Σ_n B_2n / (2n x^2n)
    const B: [f64; 6] = [
        1.0 / 12.0,
        -1.0 / 120.0,
        1.0 / 252.0,
        -1.0 / 240.0,
        1.0 / 132.0,
        -691.0 / 32760.0,
    ];
    let f = 1.0 / (x * x);
    let series = f * B.iter().rev().fold(0.0, |acc, b| b + f * acc);
    acc + x.ln() - 0.5 / x - series
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::bfc::BfcMatrix;

    use super::super::tests::known_mixture;

    /// `fit` (sorted by λi) matches `want` within ±0.01 in weight, ±0.5 nm in mean and ±3 % in
    /// every covariance entry, once the cell's Δ²/12 is taken off both.
    fn assert_matches(fit: &[Component], want: &[Component], cell: f64) {
        assert_eq!(fit.len(), want.len(), "{fit:?}");
        let mut fit = fit.to_vec();
        fit.sort_by(|a, b| a.mean[0].total_cmp(&b.mean[0]));
        let mut want = want.to_vec();
        want.sort_by(|a, b| a.mean[0].total_cmp(&b.mean[0]));
        let off = |c: &Component, a: usize, b: usize| {
            c.cov[a][b] - if a == b { cell * cell / 12.0 } else { 0.0 }
        };
        for (c, t) in fit.iter().zip(&want) {
            assert!((c.weight - t.weight).abs() <= 0.01, "{c:?} vs {t:?}");
            for a in 0..2 {
                assert!((c.mean[a] - t.mean[a]).abs() <= 0.5, "{c:?} vs {t:?}");
                for b in 0..2 {
                    let (got, exp) = (c.cov[a][b], off(t, a, b));
                    assert!(
                        (off(c, a, b) - exp).abs() <= 0.03 * exp.abs(),
                        "{got} {c:?} vs {t:?}"
                    );
                }
            }
        }
    }

    /// The reference points are the truth itself: its covariances carry no cell term.
    fn with_cell(truth: &[Component], cell: f64) -> Vec<Component> {
        truth
            .iter()
            .map(|t| {
                let mut t = *t;
                t.cov[0][0] += cell * cell / 12.0;
                t.cov[1][1] += cell * cell / 12.0;
                t
            })
            .collect()
    }

    #[test]
    fn prunes_extra_components_of_a_known_mixture() {
        let (truth, data) = known_mixture();
        let fit = fit_bayes(&data, 8, 7, 1000, 1e-10).unwrap();
        assert!(fit.converged, "{} iterations", fit.iterations);
        let heavy: Vec<Component> = fit
            .components
            .iter()
            .copied()
            .filter(|c| c.weight > 0.01)
            .collect();
        assert_eq!(heavy.len(), 2, "{:?}", fit.components);
        assert_matches(&heavy, &with_cell(&truth, data.cell), data.cell);
        assert!(fit.components.iter().all(|c| c.is_valid()));
    }

    #[test]
    fn agrees_with_em_for_two_components() {
        let (truth, data) = known_mixture();
        let bayes = fit_bayes(&data, 2, 7, 1000, 1e-10).unwrap();
        let em = super::super::em::fit_em(&data, 2, 7, 2000, 1e-10).unwrap();
        assert!(bayes.converged && em.converged);
        assert_matches(&bayes.components, &em.components, data.cell);
        assert_matches(&bayes.components, &with_cell(&truth, data.cell), data.cell);
        // A lower bound on the evidence, itself below the best likelihood; not far below it
        // with 30 000 effective points.
        assert!(bayes.log_likelihood < em.log_likelihood, "{bayes:?} {em:?}");
        assert!(
            bayes.log_likelihood > em.log_likelihood - 0.01,
            "{bayes:?} {em:?}"
        );
    }

    /// With one component q(μ, Λ) is the exact posterior and the bound is the exact evidence
    /// (Murphy 2007, eq. 266), the cells' Δ²/12 included in the scatter.
    #[test]
    fn one_component_bound_is_the_evidence() {
        let data = WeightedPoints {
            x: vec![
                [400.0, 500.0],
                [420.0, 505.0],
                [410.0, 530.0],
                [395.0, 515.0],
                [1e3, 0.0],
            ],
            w: vec![0.5, 2.0, 1.0, 0.25, 0.0],
            cell: 5.0,
        };
        let fit = fit_bayes(&data, 1, 0, 100, 1e-12).unwrap();
        assert!(fit.converged && fit.iterations == 2, "{fit:?}");
        let p = points(&data).unwrap();
        let n = p.total;
        let (xbar, s) = moments(&p, |_| 1.0, n);
        let c = p.cell_var;
        let (m0, w0inv) = (xbar, [[s[0][0] + c, s[0][1]], [s[1][0], s[1][1] + c]]);
        // The prior mean is the data mean: no shrinkage term.
        let wn = [
            [w0inv[0][0] + n * (s[0][0] + c), w0inv[0][1] + n * s[0][1]],
            [w0inv[1][0] + n * s[1][0], w0inv[1][1] + n * (s[1][1] + c)],
        ];
        let (nu0, nun, b0, bn) = (2.0, 2.0 + n, 1.0, 1.0 + n);
        let ln_gamma2 = |a: f64| 0.5 * PI.ln() + ln_gamma(a) + ln_gamma(a - 0.5);
        let evidence = -n * PI.ln() + ln_gamma2(nun / 2.0) - ln_gamma2(nu0 / 2.0)
            + 0.5 * nu0 * det(&w0inv).ln()
            - 0.5 * nun * det(&wn).ln()
            + (b0 / bn).ln();
        assert!(
            (fit.log_likelihood - evidence / n).abs() < 1e-12,
            "{fit:?} vs {}",
            evidence / n
        );
        for (got, want) in fit.components[0].mean.iter().zip(m0) {
            assert!((got - want).abs() < 1e-9, "{fit:?}");
        }
    }

    #[test]
    fn fits_are_deterministic_and_survive_degenerate_data() {
        let (_, data) = known_mixture();
        let a = fit_bayes(&data, 8, 11, 300, 1e-9).unwrap();
        let b = fit_bayes(&data, 8, 11, 300, 1e-9).unwrap();
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        super::super::tests::check_degenerate_data(fit_bayes);
    }

    #[test]
    fn the_lower_bound_never_decreases() {
        let (_, data) = known_mixture();
        for (k, seed) in [(8, 7), (3, 1), (2, 5)] {
            let (fit, history) = fit_traced(&data, k, seed, 150, 0.0).unwrap();
            assert_eq!(history.len(), fit.iterations);
            for w in history.windows(2) {
                assert!(
                    w[1] >= w[0] - 1e-9 * w[0].abs(),
                    "k = {k}: {} then {}",
                    w[0],
                    w[1]
                );
            }
        }
        let data = golfye();
        let (_, history) = fit_traced(&data, 8, 1, 1000, 0.0).unwrap();
        for w in history.windows(2) {
            assert!(
                w[1] >= w[0] - 1e-9 * w[0].abs(),
                "GOLFYE: {} then {}",
                w[0],
                w[1]
            );
        }
    }

    /// The off-diagonal cells of GOLFYE with a positive value.
    fn golfye() -> WeightedPoints {
        let m = BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap();
        let mut data = WeightedPoints {
            cell: m.step as f64,
            ..Default::default()
        };
        for o in 0..m.n_em {
            for i in 0..m.n_ex {
                if m.off(o, i) > 0.0 {
                    data.x.push([m.ex(i) as f64, m.em(o) as f64]);
                    data.w.push(m.off(o, i) as f64);
                }
            }
        }
        data
    }

    #[test]
    fn fits_a_measured_matrix() {
        let data = golfye();
        let fit = fit_bayes(&data, 8, 1, 1000, 1e-7).unwrap();
        assert!(fit.converged, "{} iterations", fit.iterations);
        assert!(fit.iterations <= 1000);
        assert!(!fit.components.is_empty() && fit.components.len() <= 8);
        assert!(
            fit.components.iter().all(|c| c.is_valid()),
            "{:?}",
            fit.components
        );
        let sum: f64 = fit.components.iter().map(|c| c.weight).sum();
        assert!((sum - 1.0).abs() < 1e-12, "{sum}");
    }

    #[test]
    fn special_functions() {
        let gamma = 0.577_215_664_901_532_9;
        assert!((ln_gamma(0.5) - 0.5 * PI.ln()).abs() < 1e-14);
        assert!(ln_gamma(1.0).abs() < 1e-14 && ln_gamma(2.0).abs() < 1e-14);
        assert!((ln_gamma(0.125) - 2.019_418_357_553_796_3).abs() < 1e-13);
        assert!((ln_gamma(101.0) - 363.739_375_555_563_5).abs() < 1e-10);
        assert!((digamma(1.0) + gamma).abs() < 1e-14);
        assert!((digamma(0.5) + gamma + 2.0 * LN_2).abs() < 1e-14);
        assert!((digamma(0.125) - -8.388_492_663_295_854).abs() < 1e-12);
        assert!((digamma(1e4) - (1e4f64.ln() - 0.5e-4 - 1.0 / 12e8)).abs() < 1e-15);
    }
}
