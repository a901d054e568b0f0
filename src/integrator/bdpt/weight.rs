//! The one multiple-importance weight of every BDPT: the ratio walk of Veach eq. 10.9 as pbrt-v4
//! writes it (`MISWeight`), generalised to Jung's full pdfs p_A · p_Λ (eqs. 6.14, 6.15).
//!
//! A path x0 … x(k−1) made by strategy s (s camera vertices) could have been made by any ŝ =
//! 1 … k. Its area pdf (eq. 6.3) is p_A(ŝ) = ∏_{m<ŝ} pa_fwd[m] · ∏_{m≥ŝ} pa_rev[m], so
//! p_A(ŝ)/p_A(ŝ+1) = pa_rev[ŝ]/pa_fwd[ŝ]: one ratio per vertex, walked outwards from the
//! connection. What differs between the integrators enters through the arguments:
//!
//! - the (pa_fwd, pa_rev) each vertex reports, with the pdfs the connection changed already put
//!   in (pbrt's `ScopedAssignment`s), and free-flight pdfs folded in where there are media;
//! - the wavelength pdf ratio p_Λ(ŝ)/p_Λ(s) of each strategy: 1 for `bdpt-allbins`, which
//!   samples no wavelength (Jung 6.4.2); two values for a path that cannot shift; a table
//!   built by the reset for a fluorescent path (`FullPath::wavelength_pdfs`).
//!
//! Every pdf the walk divides by is a factor of the strategy's own pdf, which the caller has
//! checked to be positive, so a strategy that cannot make the path (a zero pdf) gets ratio 0.
//! The running ratios are kept below f64::MAX, so that a zero after an overflow still ends a
//! sum (a test per vertex would cost more).

use crate::integrator::MisHeuristic;

/// The strategy's own area pdf p_A(s) (eq. 6.3) and its MIS weight among ŝ = 1 … k (eq. 6.15
/// generalised to the power heuristic), in one pass over x1 … x(k−1).
///
/// - `lower`: (pa_fwd, pa_rev) of x1 … x(s−1), in path order;
/// - `upper`: (pa_fwd, pa_rev) of x_s … x(k−1), in path order;
/// - `lambda(ŝ)`: p_Λ(ŝ) / p_Λ(s).
///
/// Below s the sum Σ_{ŝ<s} p(ŝ)/p(s) is taken by Horner's rule walking up from x1; above s the
/// ratio runs up from x_s.
#[inline(always)]
pub fn mis_walk(
    lower: impl Iterator<Item = (f64, f64)>,
    upper: impl Iterator<Item = (f64, f64)>,
    s: usize,
    lambda: impl Fn(usize) -> f64,
    h: MisHeuristic,
) -> (f64, f64) {
    // one copy of the loops per heuristic, without its test inside them
    match h {
        MisHeuristic::Power => walk::<true>(lower, upper, s, |m| square(lambda(m)), 1.0),
        MisHeuristic::Balance => walk::<false>(lower, upper, s, lambda, 1.0),
    }
}

/// [`mis_walk`] where several techniques share each strategy ŝ (`bdpt-combined`: one per
/// reset), so that the own strategy's term is not 1: `lambda_pow(ŝ)` is Σ_r p_Λ,r(ŝ)^β over the
/// techniques of ŝ, and `own` the same sum at ŝ = s, both divided by the sampling technique's
/// p_Λ(s)^β. Returns p_A(s) and p(s)^β / Σ_{ŝ,r} p_r(ŝ)^β, the weight of the sampling technique.
#[inline(always)]
pub fn mis_walk_shared(
    lower: impl Iterator<Item = (f64, f64)>,
    upper: impl Iterator<Item = (f64, f64)>,
    (s, own): (usize, f64),
    lambda_pow: impl Fn(usize) -> f64,
    h: MisHeuristic,
) -> (f64, f64) {
    match h {
        MisHeuristic::Power => walk::<true>(lower, upper, s, lambda_pow, own),
        MisHeuristic::Balance => walk::<false>(lower, upper, s, lambda_pow, own),
    }
}

#[inline(always)]
fn square(x: f64) -> f64 {
    x * x
}

/// [`mis_walk`] for the balance (`POWER` false) or the power heuristic (β = 2), with the
/// wavelength pdf ratios already raised to β (`lambda_pow`) and the own strategy's term `own`.
#[inline(always)]
fn walk<const POWER: bool>(
    lower: impl Iterator<Item = (f64, f64)>,
    upper: impl Iterator<Item = (f64, f64)>,
    s: usize,
    lambda_pow: impl Fn(usize) -> f64,
    own: f64,
) -> (f64, f64) {
    let power = |r: f64| if POWER { r * r } else { r };
    let (mut area, mut down) = (1.0, 0.0);
    for (m, (fwd, rev)) in (1..).zip(lower) {
        // p(ŝ)/p(s) for ŝ = 1 … m: each gains the factor pa_rev/pa_fwd of x_m, and ŝ = m joins
        area *= fwd;
        // kept finite, so that a zero ratio ends the sum below even where it overflowed (∞ · 0
        // would be NaN); a NaN ratio (a degenerate pdf) counts as overwhelming: weight 0
        down = (power(rev / fwd) * (down + lambda_pow(m))).min(f64::MAX);
    }
    let (mut up, mut run) = (0.0, 1.0);
    for (m, (fwd, rev)) in (s..).zip(upper) {
        // p(m + 1)/p(s) = p(m)/p(s) · pa_fwd[m] / pa_rev[m]
        area *= rev;
        run = (run * power(fwd / rev)).min(f64::MAX);
        up += run * lambda_pow(m + 1);
    }
    (area, 1.0 / (own + down + up))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walk against the definition: p(ŝ) = ∏_{m<ŝ} fwd · ∏_{m≥ŝ} rev · Λ(ŝ), w = p(s)^β /
    /// Σ p(ŝ)^β, for every s of a path of five vertices and both heuristics.
    #[test]
    fn walk_matches_the_definition() {
        let fwd = [0.0, 2.0, 0.5, 3.0, 0.8];
        let rev = [0.7, 1.5, 4.0, 0.25, 1.1];
        let lam = [0.3, 1.7, 0.9, 2.2, 0.6]; // Λ(ŝ) at ŝ − 1
        let k = 5;
        let p = |sh: usize| {
            let a: f64 =
                (1..sh).map(|m| fwd[m]).product::<f64>() * (sh..k).map(|m| rev[m]).product::<f64>();
            a * lam[sh - 1]
        };
        for h in [MisHeuristic::Balance, MisHeuristic::Power] {
            let e = if h == MisHeuristic::Power { 2 } else { 1 };
            for s in 1..=k {
                let lower = (1..s).map(|m| (fwd[m], rev[m]));
                let upper = (s..k).map(|m| (fwd[m], rev[m]));
                let (area, w) = mis_walk(lower, upper, s, |sh| lam[sh - 1] / lam[s - 1], h);
                let sum: f64 = (1..=k).map(|sh| p(sh).powi(e)).sum();
                let want = p(s).powi(e) / sum;
                assert!((w - want).abs() < 1e-14, "{h:?} s = {s}: {w} vs {want}");
                assert!((area * lam[s - 1] - p(s)).abs() < 1e-14 * p(s));
            }
        }
    }

    /// A strategy that cannot make the path (a zero pdf on its side) gets no share.
    #[test]
    fn impossible_strategies_weigh_nothing() {
        // x2 cannot be reached from the light side: ŝ ≤ 2 are impossible for s = 3.
        let fwd = [0.0, 1.0, 2.0, 1.0];
        let rev = [0.0, 1.0, 0.0, 1.0];
        let lower = (1..3).map(|m| (fwd[m], rev[m]));
        let upper = (3..4).map(|m| (fwd[m], rev[m]));
        let (_, w) = mis_walk(lower, upper, 3, |_| 1.0, MisHeuristic::Balance);
        // only ŝ = 3 and ŝ = 4 (ratio fwd[3]/rev[3] = 1) remain
        assert!((w - 0.5).abs() < 1e-15, "{w}");
        // The same where the ratios before the zero overflow: ŝ ≤ 3 are impossible for s = 4,
        // and ŝ = 5 has ratio 1.
        let lower = [(1e-200, 1e200), (1e-200, 1e200), (1.0, 0.0)].into_iter();
        let upper = [(1.0, 1.0)].into_iter();
        let (_, w) = mis_walk(lower, upper, 4, |_| 1.0, MisHeuristic::Power);
        assert_eq!(w, 0.5);
        let lower = [(1.0, 1.0)].into_iter();
        let upper = [(1e200, 1e-200), (1e200, 1e-200), (0.0, 1.0)].into_iter();
        // ŝ = 3, 4 are infinitely more likely than s = 2: its weight is 0, not NaN
        let (_, w) = mis_walk(lower, upper, 2, |_| 1.0, MisHeuristic::Balance);
        assert_eq!(w, 0.0);
    }
}
