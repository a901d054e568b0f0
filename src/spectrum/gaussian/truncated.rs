//! Inverse-CDF sampling of a truncated normal distribution, accurate far out in the tails.

use super::{std_pdf, std_quantile, std_sf, upper_mass};

/// Largest f64 below 1.
const ONE_BELOW_ONE: f64 = 1.0 - f64::EPSILON / 2.0;

/// Beyond this many standard deviations the tail mass is about to underflow (sf(37) ≈ 5.7e-300)
/// and sampling uses the exponential tail approximation.
const FAR_TAIL: f64 = 37.0;

/// Intervals at most this many standard deviations wide are sampled with the density linearised
/// in the exponent (relative density error ≤ width²/2 ≤ 5e-13), which keeps working when the
/// tail probabilities at the two ends are too close to subtract.
const NARROW: f64 = 1e-6;

/// Offset t ∈ [0, w] from the start of an interval of width w (w may be +∞) where the standard
/// normal density, linearised in the exponent at the start z₀, is ∝ exp(−rate·t), rate = z₀.
/// `u` is the probability measured from the start, `v = 1 − u` (passed separately so that both
/// ends keep full resolution). Exact up to the dropped factor exp(−t²/2): relative error ≤ w²/2
/// for narrow intervals, and asymptotically exact (error ~ 1/rate²) in the far tail.
fn exp_offset(rate: f64, w: f64, u: f64, v: f64) -> f64 {
    // k = rate·w, the drop of the log-density across the interval.
    let k = rate * w;
    if k.abs() < 1e-12 {
        // Density flat to 1e-12: uniform, t = u·w.
        return u * w;
    }
    if u <= 0.5 {
        // Inverse CDF of the exponential truncated at w: t = −ln(1 + u·(e^(−k) − 1)) / rate.
        -(u * (-k).exp_m1()).ln_1p() / rate
    } else {
        // Same from the far end, t = −ln(v + u·e^(−k)) / rate, summed in logs because e^(−k)
        // may underflow; v = 0 is the far end itself, the smallest normal f64 if that is at ∞.
        let ln_v = if v > 0.0 {
            v.ln()
        } else if w.is_finite() {
            f64::NEG_INFINITY
        } else {
            f64::MIN_POSITIVE.ln()
        };
        let ln_u = u.ln() - k;
        let (big, small) = if ln_v >= ln_u {
            (ln_v, ln_u)
        } else {
            (ln_u, ln_v)
        };
        // ln(e^big + e^small) = big + ln(1 + e^(small − big)).
        -(big + (small - big).exp().ln_1p()) / rate
    }
}

/// Offset t ∈ [0, hi − lo] of a sample of the standard normal truncated to [lo, hi], 0 ≤ lo < hi
/// (hi may be +∞), by inverting the upper tail: the near end `lo` is at u = 0, `v = 1 − u`.
fn upper_offset(lo: f64, hi: f64, u: f64, v: f64) -> f64 {
    if lo > FAR_TAIL {
        return exp_offset(lo, hi - lo, u, v);
    }
    let s_lo = std_sf(lo);
    let s_hi = std_sf(hi);
    // Mass of the interval as a difference of upper tails.
    let d = s_lo - s_hi;
    if !(d > 0.0) {
        return exp_offset(lo, hi - lo, u, v);
    }
    // Upper-tail probability of the sample, q = sf(lo) − u·(sf(lo) − sf(hi)), formed from the
    // nearer end in u so that neither end loses resolution.
    let q = if u <= 0.5 { s_lo - u * d } else { s_hi + v * d };
    // z with 1 − Φ(z) = q, i.e. z = −Φ⁻¹(q); q = 0 only for v = 0 with hi = ∞.
    let mut z = (-std_quantile(q.max(f64::MIN_POSITIVE))).max(lo).min(hi);
    let density = std_pdf(z);
    // Skipped only beyond ~37.5 sd, where the density and tail are subnormal and imprecise.
    if density >= f64::MIN_POSITIVE {
        // One Newton step on std_sf(z) = q: the quantile inverts the exact Φ, this makes the
        // sample invert the erfc fit that `interval_mass` uses, so the ends map exactly onto lo
        // and hi and narrow intervals are not distorted by the fit's 1e-7 error.
        z = (z + (std_sf(z) - q) / density).max(lo).min(hi);
    }
    z - lo
}

/// Inverse-CDF sample of X ~ N(mean, sd²) truncated to [a, b] from u ∈ [0, 1); sd > 0, a ≤ b,
/// either end may be infinite (both infinite is plain normal sampling). Non-decreasing in u,
/// u = 0 maps to a, u → 1 to b.
///
/// Accurate in the tails: an interval right of the mean inverts upper-tail probabilities
/// (q = sf(α) − u·(sf(α) − sf(β)), x = mean − sd·Φ⁻¹(q)), one left of it is mirrored, and one
/// straddling the mean is split there. Beyond 37 sd, where the mass is about to underflow, the asymptotically
/// exact exponential tail (rate α/sd from the near end, truncated at the far end) is used, and
/// intervals narrower than 1e-6 sd use the density linearised in the exponent. The result is
/// clamped into [a, b], and is never NaN or infinite unless a and b are (a degenerate or empty
/// interval, b ≤ a, returns a).
pub fn sample_truncated(mean: f64, sd: f64, a: f64, b: f64, u: f64) -> f64 {
    debug_assert!(sd > 0.0, "sample_truncated: sd = {sd}");
    debug_assert!(a <= b, "sample_truncated: empty interval [{a}, {b}]");
    if !(a < b) {
        return a;
    }
    let u = u.clamp(0.0, ONE_BELOW_ONE);
    // Exact for u ≥ 0.5 (Sterbenz), and ≥ 2⁻⁵³ since u < 1.
    let v = 1.0 - u;
    // Standardised ends α = (a − mean)/sd, β = (b − mean)/sd.
    let alpha = (a - mean) / sd;
    let beta = (b - mean) / sd;
    let x = if beta - alpha <= NARROW {
        // Narrow interval: density ∝ exp(−α·t) on [0, β − α], x = a + sd·t.
        a + sd * exp_offset(alpha, beta - alpha, u, v)
    } else if alpha >= 0.0 {
        // Right of the mean: x = a + sd·t with t from upper-tail probabilities.
        a + sd * upper_offset(alpha, beta, u, v)
    } else if beta <= 0.0 {
        // Left of the mean: mirror onto [−β, −α], whose near end −β corresponds to u = 1.
        b - sd * upper_offset(-beta, -alpha, v, u)
    } else if alpha == f64::NEG_INFINITY && beta == f64::INFINITY {
        // Untruncated: x = mean + sd·Φ⁻¹(u) (u = 0 gives about −37.5 sd, not −∞).
        mean + sd * std_quantile(u.max(f64::MIN_POSITIVE))
    } else {
        // Straddles the mean: pick a side in proportion to its mass, then sample that side
        // from the mean outwards, rescaling u (the left side runs from α at u = 0 to the mean).
        let ml = upper_mass(0.0, -alpha);
        let mr = upper_mass(0.0, beta);
        let m = ml + mr;
        // Target mass measured from a, and (accurately) from b.
        let t = u * m;
        let t_from_b = v * m;
        if t < ml {
            // Left side: fraction from the mean (ml − t)/ml, from a t/ml.
            mean - sd * upper_offset(0.0, -alpha, (ml - t) / ml, t / ml)
        } else {
            // Right side: fraction from the mean (t − ml)/mr, from b (m − t)/mr.
            let ur = ((t - ml) / mr).min(1.0);
            let vr = (t_from_b / mr).min(1.0);
            mean + sd * upper_offset(0.0, beta, ur, vr)
        }
    };
    // Clamp into [a, b] (max/min rather than clamp: never panics, maps NaN to a).
    x.max(a).min(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::gaussian::interval_mass;
    use crate::spectrum::gaussian::tests::simpson;
    use rand::{Rng, SeedableRng};

    /// Edges of 20 equal-width cells over [a, b]; an infinite end is replaced by a window of
    /// `span` sd from the finite end, and the outermost cell extended to infinity.
    fn cell_edges(mean: f64, sd: f64, a: f64, b: f64, span: f64) -> Vec<f64> {
        let (lo, hi) = match (a.is_finite(), b.is_finite()) {
            (true, true) => (a, b),
            (true, false) => (a, a + span * sd),
            (false, true) => (b - span * sd, b),
            (false, false) => (mean - span * sd, mean + span * sd),
        };
        let mut edges: Vec<f64> = (0..=20).map(|i| lo + (hi - lo) * i as f64 / 20.0).collect();
        edges[0] = a;
        edges[20] = b;
        edges
    }

    /// Draws `n` samples on [a, b], checks each is finite and inside, and returns the χ²
    /// statistic of the 20-cell histogram against the cell probabilities `probs`.
    fn chi2(mean: f64, sd: f64, a: f64, b: f64, edges: &[f64], probs: &[f64], seed: u64) -> f64 {
        let n = 200_000;
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let mut counts = vec![0u64; probs.len()];
        for _ in 0..n {
            let u: f64 = rng.random();
            let x = sample_truncated(mean, sd, a, b, u);
            assert!(x.is_finite() && a <= x && x <= b, "x = {x} for u = {u}");
            // Cell: the last edge below x (the first cell also takes x == a).
            let cell = edges[1..edges.len() - 1].partition_point(|&e| e < x);
            counts[cell] += 1;
        }
        let total: f64 = probs.iter().sum();
        counts
            .iter()
            .zip(probs)
            .map(|(&c, &p)| {
                let expected = n as f64 * p / total;
                assert!(expected >= 5.0, "test design: expected count {expected}");
                (c as f64 - expected).powi(2) / expected
            })
            .sum()
    }

    /// 99.9 % quantile of χ² with 19 degrees of freedom.
    const CHI2_19_999: f64 = 43.82;

    #[test]
    fn truncated_samples_follow_the_truncated_density() {
        let (mean, sd) = (550.0, 20.0);
        let inf = f64::INFINITY;
        // (a, b) in sd from the mean, window span for infinite ends.
        let cases = [
            (-1.5, 2.0, 0.0),
            (3.0, 5.0, 0.0),
            (12.0, inf, 0.5),
            (-inf, -9.0, 0.5),
            (0.7, 0.7001, 0.0),
            (-3e-7, 5e-7, 0.0),
            (-0.2, 4.0, 0.0),
            (-inf, inf, 3.0),
        ];
        for (seed, (lo, hi, span)) in cases.into_iter().enumerate() {
            let (a, b) = (mean + sd * lo, mean + sd * hi);
            let edges = cell_edges(mean, sd, a, b, span);
            let probs: Vec<f64> = edges
                .windows(2)
                .map(|w| interval_mass(mean, sd, w[0], w[1]))
                .collect();
            let c = chi2(mean, sd, a, b, &edges, &probs, seed as u64);
            assert!(c < CHI2_19_999, "[{lo}, {hi}] sd: χ² = {c}");
        }
    }

    /// Beyond ~37.5 sd the masses underflow: the expected cell probabilities come from integrating
    /// the exact density rescaled by exp(α²/2), exp(−(z − α)(z + α)/2), and the samples come from
    /// the exponential-tail fallback.
    #[test]
    fn far_tail_fallback_follows_the_truncated_density() {
        let (mean, sd) = (550.0, 20.0);
        let inf = f64::INFINITY;
        for (seed, (lo, hi, span)) in [(40.0, 40.1, 0.0), (-inf, -40.0, 0.1), (45.0, inf, 0.1)]
            .into_iter()
            .enumerate()
        {
            let (a, b) = (mean + sd * lo, mean + sd * hi);
            assert_eq!(interval_mass(mean, sd, a, b), 0.0, "not underflowing");
            let edges = cell_edges(mean, sd, a, b, span);
            let near = if lo.is_finite() { lo } else { hi };
            let scaled = |z: f64| (-(z - near) * (z + near) / 2.0).exp();
            let probs: Vec<f64> = edges
                .windows(2)
                .map(|w| {
                    let (zl, zh) = ((w[0] - mean) / sd, (w[1] - mean) / sd);
                    // Cut infinite ends where the rescaled density is below e^(−100).
                    let (zl, zh) = (zl.max(near - 3.0), zh.min(near + 3.0));
                    simpson(scaled, zl, zh, 20_000)
                })
                .collect();
            let c = chi2(mean, sd, a, b, &edges, &probs, 100 + seed as u64);
            assert!(c < CHI2_19_999, "[{lo}, {hi}] sd: χ² = {c}");
        }
    }

    #[test]
    fn extreme_u_stays_finite_inside_and_monotone() {
        let (mean, sd) = (550.0, 20.0);
        let inf = f64::INFINITY;
        let cases = [
            (-1.5, 2.0),
            (3.0, 5.0),
            (12.0, inf),
            (-inf, -9.0),
            (40.0, 40.1),
            (-inf, -40.0),
            (40.0, inf),
            (-40.5, -40.0),
            (0.7, 0.7001),
            (-3e-7, 5e-7),
            (0.0, inf),
            (-inf, 0.0),
            (-inf, 2.0),
            (-2.0, inf),
            (-inf, inf),
            (36.9, 37.2),
            (-1000.0, -999.0),
        ];
        for (lo, hi) in cases {
            let (a, b) = (mean + sd * lo, mean + sd * hi);
            let mut prev = f64::NEG_INFINITY;
            for u in [
                0.0,
                1e-300,
                1e-16,
                1e-3,
                0.25,
                0.5,
                0.75,
                1.0 - 1e-9,
                1.0 - 1e-16,
            ] {
                let x = sample_truncated(mean, sd, a, b, u);
                assert!(
                    x.is_finite() && a <= x && x <= b,
                    "[{lo}, {hi}] sd, u = {u}: x = {x}"
                );
                assert!(x >= prev, "[{lo}, {hi}] sd: not monotone at u = {u}");
                prev = x;
            }
            // u = 0 starts at a finite a, u → 1 ends near a finite b (within 1e-9 sd).
            if a.is_finite() {
                let x0 = sample_truncated(mean, sd, a, b, 0.0);
                assert!(
                    (x0 - a).abs() <= 1e-9 * sd,
                    "[{lo}, {hi}]: u = 0 gives {x0}"
                );
            }
            let mut prev = f64::NEG_INFINITY;
            for i in 0..1000 {
                let x = sample_truncated(mean, sd, a, b, i as f64 / 1000.0);
                assert!(
                    x >= prev,
                    "[{lo}, {hi}] sd: not monotone at u = {}",
                    i as f64 / 1000.0
                );
                prev = x;
            }
        }
        // Degenerate interval.
        assert_eq!(sample_truncated(mean, sd, 600.0, 600.0, 0.3), 600.0);
    }
}
