//! The 1-D normal distribution: density, CDF, upper tail, quantile (Wichura's AS 241), the mass of
//! an interval and inverse-CDF sampling of a truncated normal (`truncated.rs`), all accurate far
//! out in the tails.
//! Gaussian-mixture materials use these to sample their truncated conditional Gaussians.
//!
//! The CDF comes from [`erfc`] (Numerical Recipes' Chebyshev fit, fractional error < 1.2e-7,
//! no cancellation in the tails). Masses are always formed as differences of the *smaller* tail
//! probability, so an interval far in one tail keeps a small relative error; it only underflows
//! to 0 beyond about 37.5 standard deviations, where [`sample_truncated`] switches to the
//! asymptotic exponential tail.

use super::erfc;
use std::f64::consts::FRAC_1_SQRT_2;

mod truncated;
pub use truncated::sample_truncated;

/// 1/√(2π).
const INV_SQRT_2PI: f64 = 0.398_942_280_401_432_7;

/// Standard normal density φ(z).
pub fn std_pdf(z: f64) -> f64 {
    // φ(z) = exp(−z²/2) / √(2π)
    INV_SQRT_2PI * (-0.5 * z * z).exp()
}

/// Standard normal CDF Φ(z) = P(Z ≤ z); accurate (relative) in the lower tail.
pub fn std_cdf(z: f64) -> f64 {
    // Φ(z) = erfc(−z/√2) / 2
    0.5 * erfc(-z * FRAC_1_SQRT_2)
}

/// Standard normal upper tail 1 − Φ(z) = P(Z > z); accurate (relative) for large z.
pub fn std_sf(z: f64) -> f64 {
    // 1 − Φ(z) = erfc(z/√2) / 2
    0.5 * erfc(z * FRAC_1_SQRT_2)
}

// AS 241 coefficients, ascending powers, exactly as published (more digits than f64 holds).
#[allow(clippy::excessive_precision)]
const AS241_A: [f64; 8] = [
    3.3871328727963666080e0,
    1.3314166789178437745e2,
    1.9715909503065514427e3,
    1.3731693765509461125e4,
    4.5921953931549871457e4,
    6.7265770927008700853e4,
    3.3430575583588128105e4,
    2.5090809287301226727e3,
];
#[allow(clippy::excessive_precision)]
const AS241_B: [f64; 8] = [
    1.0,
    4.2313330701600911252e1,
    6.8718700749205790830e2,
    5.3941960214247511077e3,
    2.1213794301586595867e4,
    3.9307895800092710610e4,
    2.8729085735721942674e4,
    5.2264952788528545610e3,
];
#[allow(clippy::excessive_precision)]
const AS241_C: [f64; 8] = [
    1.42343711074968357734e0,
    4.63033784615654529590e0,
    5.76949722146069140550e0,
    3.64784832476320460504e0,
    1.27045825245236838258e0,
    2.41780725177450611770e-1,
    2.27238449892691845833e-2,
    7.74545014278341407640e-4,
];
#[allow(clippy::excessive_precision)]
const AS241_D: [f64; 8] = [
    1.0,
    2.05319162663775882187e0,
    1.67638483018380384940e0,
    6.89767334985100004550e-1,
    1.48103976427480074590e-1,
    1.51986665636164571966e-2,
    5.47593808499534494600e-4,
    1.05075007164441684324e-9,
];
#[allow(clippy::excessive_precision)]
const AS241_E: [f64; 8] = [
    6.65790464350110377720e0,
    5.46378491116411436990e0,
    1.78482653991729133580e0,
    2.96560571828504891230e-1,
    2.65321895265761230930e-2,
    1.24266094738807843860e-3,
    2.71155556874348757815e-5,
    2.01033439929228813265e-7,
];
#[allow(clippy::excessive_precision)]
const AS241_F: [f64; 8] = [
    1.0,
    5.99832206555887937690e-1,
    1.36929880922735805310e-1,
    1.48753612908506148525e-2,
    7.86869131145613259100e-4,
    1.84631831751005468180e-5,
    1.42151175831644588870e-7,
    2.04426310338993978564e-15,
];

/// Horner evaluation of c[0] + c[1]·x + … + c[7]·x⁷.
fn poly7(c: &[f64; 8], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// Inverse of [`std_cdf`]: the z with Φ(z) = p, by Wichura's algorithm AS 241 (PPND16, relative
/// accuracy about 1e-16). p ≤ 0 gives −∞, p ≥ 1 gives +∞, NaN gives NaN. For an upper-tail
/// probability q use `-std_quantile(q)`, which keeps full relative accuracy for tiny q.
///
/// M. J. Wichura, "Algorithm AS 241: The Percentage Points of the Normal Distribution",
/// Applied Statistics 37(3), 477–484, 1988.
pub fn std_quantile(p: f64) -> f64 {
    if p.is_nan() {
        return f64::NAN;
    }
    if p <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if p >= 1.0 {
        return f64::INFINITY;
    }
    let q = p - 0.5;
    if q.abs() <= 0.425 {
        // Central region: z = q·A(r)/B(r) with r = 0.425² − q².
        let r = 0.180625 - q * q;
        return q * poly7(&AS241_A, r) / poly7(&AS241_B, r);
    }
    // Tails: r = √(−ln t) of the smaller tail probability t (1 − p is exact for p > 0.5).
    let tail = if q < 0.0 { p } else { 1.0 - p };
    let r = (-tail.ln()).sqrt();
    let z = if r <= 5.0 {
        // Intermediate tail (t down to ~1.4e-11): z = C(r − 1.6)/D(r − 1.6).
        poly7(&AS241_C, r - 1.6) / poly7(&AS241_D, r - 1.6)
    } else {
        // Far tail: z = E(r − 5)/F(r − 5).
        poly7(&AS241_E, r - 5.0) / poly7(&AS241_F, r - 5.0)
    };
    if q < 0.0 { -z } else { z }
}

/// P(lo < Z < hi) for a standard normal Z and 0 ≤ lo ≤ hi: a difference of upper tails, so it
/// keeps its relative accuracy however far right the interval lies.
fn upper_mass(lo: f64, hi: f64) -> f64 {
    // P(lo < Z < hi) = (1 − Φ(lo)) − (1 − Φ(hi))
    std_sf(lo) - std_sf(hi)
}

/// std_sf(0) as the erfc fit gives it (within 3e-8 of 1/2), computed once.
#[inline]
fn sf_at_zero() -> f64 {
    static SF0: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *SF0.get_or_init(|| std_sf(0.0))
}

/// P(a < X < b) for X ~ N(mean, sd²), sd > 0; a and b may be infinite; 0 when b ≤ a.
///
/// Small relative error (about 1e-7, up to ~6.5e-6 for very narrow intervals, from the slope of
/// the erfc fit's error) wherever the interval lies: an interval right of the mean is a difference
/// of upper tails, one left of it a difference of lower tails, and one straddling the mean is
/// 1 − (1 − Φ(β)) − Φ(α) with the 1 written as 2·(1 − Φ(0)) evaluated by the same erfc fit, so that
/// the fit's error at 0 cancels and tiny intervals around the mean stay accurate too. Underflows
/// to 0 when the whole interval lies beyond about 37.5 sd.
pub fn interval_mass(mean: f64, sd: f64, a: f64, b: f64) -> f64 {
    debug_assert!(sd > 0.0, "interval_mass: sd = {sd}");
    if b <= a {
        return 0.0;
    }
    // Standardised ends α = (a − mean)/sd, β = (b − mean)/sd.
    let alpha = (a - mean) / sd;
    let beta = (b - mean) / sd;
    if alpha >= 0.0 {
        upper_mass(alpha, beta)
    } else if beta <= 0.0 {
        // Mirror: P(α < Z < β) = P(−β < Z < −α), i.e. Φ(β) − Φ(α) as a lower-tail difference.
        upper_mass(-beta, -alpha)
    } else {
        // Straddles the mean: [(1 − Φ(0)) − Φ(α)] + [(1 − Φ(0)) − (1 − Φ(β))], at most 1.
        // A tail beyond 8.3 sd (< 5e-17) cannot change a sum near 1 in f64: skip its erfc.
        let tail = |z: f64| if z > 8.3 { 0.0 } else { std_sf(z) };
        let sf0 = sf_at_zero();
        ((sf0 - tail(-alpha)) + (sf0 - tail(beta))).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f over [lo, hi] by composite Simpson with `n` (even) panels.
    pub(super) fn simpson(f: impl Fn(f64) -> f64, lo: f64, hi: f64, n: usize) -> f64 {
        assert_eq!(n % 2, 0);
        let h = (hi - lo) / n as f64;
        let inner: f64 = (1..n)
            .map(|i| f(lo + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (f(lo) + inner + f(hi)) * h / 3.0
    }

    /// P(a < X < b) for X ~ N(mean, sd²) by numerical integration of `std_pdf`; infinite ends are
    /// cut at 40 sd, beyond which the mass (< 1e-349) is below f64's range anyway.
    fn integrated_mass(mean: f64, sd: f64, a: f64, b: f64) -> f64 {
        let lo = ((a - mean) / sd).max(-40.0);
        let hi = ((b - mean) / sd).min(40.0);
        simpson(std_pdf, lo, hi, 200_000)
    }

    #[test]
    fn quantile_known_values() {
        // References from mpmath at 60 digits (root of Φ(z) = p).
        for (p, want, rel) in [
            (0.975, 1.959963984540054, 1e-9),
            (1e-10, -6.361340902404056, 1e-9),
            (0.3, -0.5244005127080408, 1e-14),
            (0.02, -2.053748910631823, 1e-14),
            (1e-50, -14.933337534788489, 1e-14),
            (1e-300, -37.0470962993612, 1e-14),
            (f64::EPSILON / 2.0, -8.209536151601387, 1e-14),
        ] {
            let got = std_quantile(p);
            assert!(
                (got - want).abs() <= rel * want.abs(),
                "std_quantile({p}) = {got}, want {want}"
            );
            // Symmetry: Φ⁻¹(1 − p) = −Φ⁻¹(p) (1 − p rounds by at most 1.1e-16, moving z < 1e-15).
            if p >= 0.25 {
                let mirrored = std_quantile(1.0 - p);
                assert!((mirrored + want).abs() <= rel * want.abs(), "1 − {p}");
            }
        }
        assert_eq!(std_quantile(0.5), 0.0);
        assert_eq!(std_quantile(0.0), f64::NEG_INFINITY);
        assert_eq!(std_quantile(-0.1), f64::NEG_INFINITY);
        assert_eq!(std_quantile(1.0), f64::INFINITY);
        assert_eq!(std_quantile(1.5), f64::INFINITY);
        assert!(std_quantile(f64::NAN).is_nan());
        assert!(std_quantile(f64::MIN_POSITIVE).is_finite());
        assert!(std_quantile(5e-324).is_finite());
    }

    /// Φ⁻¹(Φ(z)) = z and −Φ⁻¹(1 − Φ(z)) = z, to the accuracy the erfc fit allows: a relative error
    /// of 1.2e-7 in the smaller tail probability p (plus rounding of Φ near 1, one ulp of 1)
    /// moves z by (1.2e-7·p + ε)/φ(z); twice that is allowed.
    #[test]
    fn quantile_inverts_cdf_and_sf() {
        for i in -160..=160 {
            let z = i as f64 * 0.05;
            let p = std_cdf(z);
            let tail = p.min(1.0 - p);
            let tol = 2.0 * (1.2e-7 * tail + f64::EPSILON) / std_pdf(z) + 1e-14;
            let back = std_quantile(p);
            assert!((back - z).abs() <= tol, "Φ⁻¹(Φ({z})) = {back}, tol {tol}");
        }
        for i in 0..=300 {
            let z = i as f64 * 0.1;
            let q = std_sf(z);
            let tol = 2.0 * 1.2e-7 * q / std_pdf(z) + 1e-14 * z.max(1.0);
            let back = -std_quantile(q);
            assert!((back - z).abs() <= tol, "−Φ⁻¹(sf({z})) = {back}, tol {tol}");
            // And the lower tail the same way, Φ⁻¹(Φ(−z)) = −z.
            let back = std_quantile(std_cdf(-z));
            assert!((back + z).abs() <= tol, "Φ⁻¹(Φ(−{z})) = {back}, tol {tol}");
        }
    }

    #[test]
    fn pdf_cdf_sf_basics() {
        assert!((std_pdf(0.0) - 0.3989422804014327).abs() < 1e-16);
        assert!((std_pdf(1.5) / 0.12951759566589174 - 1.0).abs() < 1e-15);
        assert!((std_cdf(0.0) - 0.5).abs() < 1e-7);
        // mpmath: 1 − Φ(30) = 4.9067139271481871e-198.
        assert!((std_sf(30.0) / 4.906713927148187e-198 - 1.0).abs() < 1.2e-7);
        assert!((std_cdf(-30.0) / 4.906713927148187e-198 - 1.0).abs() < 1.2e-7);
        for i in -100..=100 {
            let z = i as f64 * 0.1;
            assert_eq!(std_cdf(z), std_sf(-z));
            assert!((std_cdf(z) + std_sf(z) - 1.0).abs() < 1e-7, "z = {z}");
        }
        assert_eq!(std_sf(f64::INFINITY), 0.0);
        assert_eq!(std_cdf(f64::INFINITY), 1.0);
        assert_eq!(std_cdf(f64::NEG_INFINITY), 0.0);
    }

    #[test]
    fn interval_mass_matches_numerical_integral() {
        let (mean, sd) = (550.0, 20.0);
        let inf = f64::INFINITY;
        // Intervals in sd from the mean.
        let cases = [
            (-1.0, 2.0),
            (0.5, 0.6),
            (-0.001, 0.001),
            (-2e-6, 3e-6),
            (0.0, 1e-4),
            (3.0, 5.0),
            (10.0, 12.0),
            (30.0, 31.0),
            (-12.0, -10.0),
            (-31.0, -30.0),
            (-5.0, -3.0),
            (-inf, 1.0),
            (-inf, -20.0),
            (2.0, inf),
            (25.0, inf),
            (-inf, inf),
            (-9.0, 8.0),
        ];
        for (lo, hi) in cases {
            let (a, b) = (mean + sd * lo, mean + sd * hi);
            let got = interval_mass(mean, sd, a, b);
            let want = integrated_mass(mean, sd, a, b);
            assert!(want > 0.0);
            let rel = (got / want - 1.0).abs();
            assert!(
                rel < 1e-5,
                "[{lo}, {hi}] sd: mass {got:e}, integral {want:e}, rel {rel:e}"
            );
            // The mirror image has exactly the same mass (standardised, so the ends are exact).
            let m = interval_mass(0.0, 1.0, lo, hi);
            assert_eq!(
                interval_mass(0.0, 1.0, -hi, -lo),
                m,
                "mirror of [{lo}, {hi}]"
            );
            assert!(
                (m / got - 1.0).abs() < 1e-9,
                "[{lo}, {hi}] standardised: {m:e}"
            );
        }
        assert_eq!(interval_mass(mean, sd, 600.0, 600.0), 0.0);
        assert_eq!(interval_mass(mean, sd, 600.0, 500.0), 0.0);
        assert_eq!(interval_mass(mean, sd, -inf, inf), 1.0);
        assert!(interval_mass(mean, sd, mean - 10.0 * sd, mean + 10.0 * sd) <= 1.0);
    }
}
