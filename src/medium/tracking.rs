//! Free-flight distance sampling in a homogeneous stretch of medium (Mojzík §5.2–5.3): the
//! three tracking schemes written as one density,
//!
//! p(t) = a·e^(−b·t) / n for a collision at t < d,   P(pass) = e^(−b·d) / n,
//! n = e^(−b·d) + a·d·φ(b·d),   φ(x) = −expm1(−x)/x,
//!
//! with (a, b) = (σ̂t, σ̂t) for exponential tracking, (m, m) with m = max(σ̂t, σ̂s) for the
//! max hot-fix, and (σ̂s, σ̂t) for fluorescence-aware tracking (eq. 5 and Appendix A). With a = b
//! the normaliser is 1 and this is classic exponential tracking; with a ≠ b it is eq. 6 in the
//! stable form of docs/design.md §5, which holds as b → 0 (uniform sampling of [0, d]), a → 0
//! (always pass), b·d → ∞ (exponential) and d → 0. It is computed in f32 (1 − e^(−x) by its
//! series for small x), in f64 only where a·d would overflow.

use serde::{Deserialize, Serialize};

named_enum! {
    /// The distance-tracking scheme (`--tracking`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub enum Tracking {
        /// Classic sampling by σ̂t of the current wavelength: misses collisions where σ̂t < σ̂s
        /// (Mojzík Fig. 10a).
        Exponential = "exponential",
        /// Exponential sampling by max(σ̂t, σ̂s), the hot-fix of Mojzík §5.2.
        Max = "max",
        /// Fluorescence-aware tracking (Mojzík eq. 6); in grid media the max hot-fix majorant (§7.5).
        #[default]
        Aware = "aware",
    }
}

/// The outcome of a free flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// A collision at distance `t` with density `pdf` (per unit length).
    Collision { t: f32, pdf: f32 },
    /// No collision before `d`, with probability `prob`.
    Pass { prob: f32 },
}

/// The free-flight density of one wavelength in a homogeneous stretch (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeFlight {
    /// The collision coefficient the density is proportional to.
    pub a: f32,
    /// The exponential rate.
    pub b: f32,
}

/// Below this optical depth b·d the density is uniform over the stretch to f32 precision
/// (φ(x) = 1 − x/2 + …).
const TINY: f32 = 1e-7;

/// 1 − e^(−x) for x ≥ 0, accurate as x → 0, given e^(−x).
#[inline(always)]
fn one_minus_exp(x: f32, e: f32) -> f32 {
    if x < 0.03 {
        // Taylor series: the subtraction would cancel (error below 1e-9 relative here).
        x * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0))))
    } else {
        1.0 - e
    }
}

impl FreeFlight {
    /// The density of `mode` for the fluorescence-aware extinction `hat_t` (σ̂t) and collision
    /// coefficient `hat_s` (σ̂s) of Mojzík Table 1.
    #[inline]
    pub fn new(mode: Tracking, hat_t: f32, hat_s: f32) -> Self {
        match mode {
            Tracking::Exponential => FreeFlight { a: hat_t, b: hat_t },
            Tracking::Max => {
                let m = hat_t.max(hat_s);
                FreeFlight { a: m, b: m }
            }
            Tracking::Aware => FreeFlight { a: hat_s, b: hat_t },
        }
    }

    /// The (a, b) actually used over a stretch of length `d`: with d = ∞ and b = 0 the aware
    /// density cannot be normalised, and it falls back to the max hot-fix (docs/design.md §5).
    #[inline(always)]
    fn effective(&self, d: f32) -> (f32, f32) {
        if d.is_infinite() && self.b <= 0.0 {
            let m = self.a.max(self.b);
            (m, m)
        } else {
            (self.a, self.b)
        }
    }

    /// The two terms of the normaliser for a stretch of length `d`: e^(−b·d) and a·d·φ(b·d)
    /// = (a/b)·(1 − e^(−b·d)). In f32, falling back to f64 where a·d overflows.
    #[inline(always)]
    fn terms(a: f32, b: f32, d: f32) -> (f32, f32) {
        if d.is_infinite() {
            // e^(−∞) = 0; a·d·φ(b·d) → a/b.
            return (0.0, if a > 0.0 { a / b } else { 0.0 });
        }
        let x = b * d;
        let pass = (-x).exp();
        if !(a > 0.0) {
            return (pass, 0.0);
        }
        let coll = if x < TINY {
            // φ(x) = 1 to f32 precision; below f32::MIN_POSITIVE x is subnormal and a ratio
            // of subnormals would lose every digit (Gaussian tails of σ̂t reach 1e-44).
            a * d
        } else if x < 0.03 {
            a * d * (one_minus_exp(x, pass) / x).min(1.0)
        } else {
            a / b * (1.0 - pass)
        };
        if coll.is_finite() {
            (pass, coll)
        } else {
            let (a, b, d) = (a as f64, b as f64, d as f64);
            let x = b * d;
            let phi = if x > 0.0 { -(-x).exp_m1() / x } else { 1.0 };
            (pass, (a * d * phi).min(f32::MAX as f64) as f32)
        }
    }

    /// Sample a flight over a stretch of length `d` (may be ∞) from `u` in [0, 1).
    #[inline]
    pub fn sample(&self, d: f32, u: f32) -> Flight {
        let (a, b) = self.effective(d);
        let (pass, coll) = Self::terms(a, b, d);
        let n = pass + coll;
        if !(coll > 0.0) || !(n > 0.0) {
            return Flight::Pass { prob: 1.0 };
        }
        let p_coll = coll / n;
        if u >= p_coll {
            return Flight::Pass { prob: pass / n };
        }
        let zeta = (u / p_coll).min(1.0 - f32::EPSILON);
        // Inverse of the conditional CDF (1 − e^(−b·t)) / (1 − e^(−b·d)) (Appendix A, eq. 6).
        let t = if d.is_infinite() {
            -(-zeta).ln_1p() / b
        } else {
            let x = b * d;
            // Below TINY the conditional density is uniform to f32 precision (and the formula
            // would quantise t in subnormal arithmetic).
            let s = if x >= TINY {
                -(-zeta * one_minus_exp(x, pass)).ln_1p() / x
            } else {
                zeta
            };
            d * s.clamp(0.0, 1.0)
        };
        let pdf = a * (-b * t).exp() / n;
        Flight::Collision { t, pdf }
    }

    /// The density of a collision at `t` over a stretch of length `d`.
    #[inline]
    pub fn pdf_collision(&self, t: f32, d: f32) -> f32 {
        let (a, b) = self.effective(d);
        let (pass, coll) = Self::terms(a, b, d);
        let n = pass + coll;
        if !(coll > 0.0) || !(n > 0.0) || t > d {
            return 0.0;
        }
        a * (-b * t).exp() / n
    }

    /// The probability of passing a stretch of length `d` without a collision.
    #[inline]
    pub fn pdf_pass(&self, d: f32) -> f32 {
        let (a, b) = self.effective(d);
        let (pass, coll) = Self::terms(a, b, d);
        let n = pass + coll;
        if !(coll > 0.0) || !(n > 0.0) {
            return 1.0;
        }
        pass / n
    }
}

/// A wavelength-independent free-flight density for tracers that carry every wavelength bin at
/// once: the even mixture of exponentials at rates `lo` and `hi`,
///
/// p(t) = ½·(lo·e^(−lo·t) + hi·e^(−hi·t)),   P(pass d) = ½·(e^(−lo·d) + e^(−hi·d)).
///
/// With `lo` ≤ every bin's σ̂t and `hi` ≥ every bin's σ̂t and σ̂s, each bin's weight T/p is at
/// most 2 when passing and 2/lo at a collision, and no bin's collisions go unsampled; a single
/// rate would weigh a clear bin by e^((hi − σ̂t)·d) when passing (docs/design.md §3.5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixtureFlight {
    pub lo: f32,
    pub hi: f32,
}

impl MixtureFlight {
    /// The flight between the smallest σ̂t and the largest of σ̂t and σ̂s of a medium (`lo` at
    /// least 1/1000 of `hi`, so that a clear band still collides now and then).
    pub fn new(min_hat_t: f32, max_rate: f32) -> Self {
        let hi = max_rate.max(0.0);
        MixtureFlight {
            lo: min_hat_t.clamp(1e-3 * hi, hi),
            hi,
        }
    }

    /// A collision distance from two uniform numbers (the rate by `u[0]`).
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> f32 {
        let c = if u[0] < 0.5 { self.lo } else { self.hi };
        -(1.0 - u[1]).ln() / c
    }

    #[inline]
    pub fn pdf_collision(&self, t: f32) -> f32 {
        0.5 * (self.lo * (-self.lo * t).exp() + self.hi * (-self.hi * t).exp())
    }

    #[inline]
    pub fn pdf_pass(&self, d: f32) -> f32 {
        if d.is_infinite() {
            return 0.0;
        }
        0.5 * ((-self.lo * d).exp() + (-self.hi * d).exp())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;

    const MODES: [Tracking; 3] = [Tracking::Exponential, Tracking::Max, Tracking::Aware];

    /// ∫0^d p(t) dt by the midpoint rule with `k` cells, plus P(pass).
    fn total_mass(f: FreeFlight, d: f32, k: usize) -> f64 {
        let h = d as f64 / k as f64;
        let mut s = 0.0;
        for i in 0..k {
            s += f.pdf_collision(((i as f64 + 0.5) * h) as f32, d) as f64 * h;
        }
        s + f.pdf_pass(d) as f64
    }

    #[test]
    fn the_density_integrates_to_one() {
        for (t, s) in [
            (1.0, 1.0),
            (0.2, 3.0),
            (3.0, 0.2),
            (0.0, 2.0),
            (2.0, 0.0),
            (1e-30, 5.0),
            (1e-40, 5.0),
            (4.6e-44, 2.0),
        ] {
            for mode in MODES {
                for d in [0.01, 1.0, 4.0] {
                    let m = total_mass(FreeFlight::new(mode, t, s), d, 20000);
                    assert!((m - 1.0).abs() < 1e-3, "{mode:?} σ̂t {t} σ̂s {s} d {d}: {m}");
                }
            }
        }
    }

    #[test]
    fn stable_in_the_limits() {
        // σ̂t → 0: uniform over [0, d]; collision probability a·d / (1 + a·d).
        // Subnormal σ̂t (4.6e-44: a Gaussian absorption 240 nm from its peak) included.
        for b in [0.0f32, 1e-30, 1e-12, 1e-40, 4.6e-44] {
            let f = FreeFlight { a: 2.0, b };
            assert!((f.pdf_pass(3.0) - 1.0 / 7.0).abs() < 1e-6, "b {b}");
            assert!((f.pdf_collision(0.1, 3.0) - 2.0 / 7.0).abs() < 1e-6);
            assert!((f.pdf_collision(2.9, 3.0) - 2.0 / 7.0).abs() < 1e-6);
            match f.sample(3.0, 0.5) {
                Flight::Collision { t, pdf } => {
                    // ζ = 0.5 / (6/7) → t = ζ·d.
                    assert!((t - 0.5 * 7.0 / 6.0 * 3.0).abs() < 1e-5, "{t}");
                    assert!((pdf - 2.0 / 7.0).abs() < 1e-6);
                }
                f => panic!("{f:?}"),
            }
        }
        // σ̂s → 0: always pass, with probability 1.
        for a in [0.0f32, 1e-30] {
            let f = FreeFlight { a, b: 5.0 };
            assert!(matches!(f.sample(2.0, 0.0), Flight::Pass { .. }) || a > 0.0);
            assert!((f.pdf_pass(2.0) - 1.0).abs() < 1e-6);
        }
        // d·σ̂t → ∞: exponential tracking; a collision is certain.
        for d in [1e6f32, 1e30, f32::INFINITY] {
            let f = FreeFlight { a: 0.5, b: 2.0 };
            assert_eq!(f.pdf_pass(d), 0.0);
            assert!((f.pdf_collision(1.0, d) - 2.0 * (-2.0f32).exp()).abs() < 1e-6);
            match f.sample(d, 0.3) {
                Flight::Collision { t, pdf } => {
                    let t_exp = -(0.7f32).ln() / 2.0;
                    assert!((t - t_exp).abs() < 1e-5, "d {d}: {t}");
                    assert!(pdf.is_finite() && pdf > 0.0);
                }
                f => panic!("{f:?}"),
            }
        }
        // d → 0: the stretch is passed.
        for d in [0.0f32, 1e-30, 1e-20] {
            let f = FreeFlight { a: 3.0, b: 1.0 };
            assert!((f.pdf_pass(d) - 1.0).abs() < 1e-6);
            assert!(matches!(f.sample(d, 0.5), Flight::Pass { .. }));
        }
        // σ̂t = σ̂s = 0 with d = ∞: nothing to collide with.
        let f = FreeFlight::new(Tracking::Aware, 0.0, 0.0);
        assert_eq!(f.sample(f32::INFINITY, 0.2), Flight::Pass { prob: 1.0 });
        // σ̂t = 0, d = ∞: the max hot-fix, exponential with σ̂s.
        let f = FreeFlight::new(Tracking::Aware, 0.0, 0.5);
        assert!((f.pdf_collision(1.0, f32::INFINITY) - 0.5 * (-0.5f32).exp()).abs() < 1e-6);
        // Every output finite for extreme inputs.
        for (a, b) in [(1e30, 1e30), (1e-30, 1e30), (1e30, 1e-30), (0.0, 0.0)] {
            for d in [0.0, 1e-30, 1.0, 1e30, f32::INFINITY] {
                let f = FreeFlight { a, b };
                for u in [0.0, 0.5, 0.99999994] {
                    match f.sample(d, u) {
                        Flight::Collision { t, pdf } => {
                            assert!(t.is_finite() && t >= 0.0 && t <= d && pdf.is_finite())
                        }
                        Flight::Pass { prob } => assert!(prob.is_finite() && prob >= 0.0),
                    }
                }
            }
        }
    }

    #[test]
    fn exponential_has_unit_normaliser() {
        let f = FreeFlight::new(Tracking::Exponential, 0.7, 5.0);
        assert!((f.pdf_pass(2.0) - (-1.4f32).exp()).abs() < 1e-6);
        assert!((f.pdf_collision(1.0, 2.0) - 0.7 * (-0.7f32).exp()).abs() < 1e-6);
        let f = FreeFlight::new(Tracking::Max, 0.7, 5.0);
        assert_eq!((f.a, f.b), (5.0, 5.0));
    }

    /// χ² test of sampled flights against the density: 20 cells over [0, d) plus the pass event.
    fn chi_square(f: FreeFlight, d: f32, seed: u64) -> (f64, usize) {
        const CELLS: usize = 20;
        const N: usize = 200_000;
        let mut rng = Pcg32::seed_from_u64(seed);
        let mut hist = [0usize; CELLS + 1];
        for _ in 0..N {
            match f.sample(d, rng.random::<f32>()) {
                Flight::Collision { t, pdf } => {
                    assert!((pdf - f.pdf_collision(t, d)).abs() <= 1e-4 * pdf.max(1e-3));
                    hist[((t / d * CELLS as f32) as usize).min(CELLS - 1)] += 1;
                }
                Flight::Pass { prob } => {
                    assert!((prob - f.pdf_pass(d)).abs() < 1e-6);
                    hist[CELLS] += 1;
                }
            }
        }
        let h = d as f64 / CELLS as f64;
        let mut chi2 = 0.0;
        let mut dof = 0;
        for (i, &count) in hist.iter().enumerate() {
            let p = if i < CELLS {
                (0..100)
                    .map(|k| {
                        let t = (i as f64 + (k as f64 + 0.5) / 100.0) * h;
                        f.pdf_collision(t as f32, d) as f64 * h / 100.0
                    })
                    .sum::<f64>()
            } else {
                f.pdf_pass(d) as f64
            };
            let expected = p * N as f64;
            if expected > 5.0 {
                chi2 += (count as f64 - expected).powi(2) / expected;
                dof += 1;
            } else {
                assert!(
                    count as f64 <= 5.0 + 10.0 * expected.sqrt() + 10.0,
                    "cell {i}"
                );
            }
        }
        (chi2, dof - 1)
    }

    #[test]
    fn samples_follow_the_density_chi_square() {
        let cases = [
            (1.0, 1.0, 2.0),
            (0.3, 2.0, 3.0),     // fluorescent: σ̂s > σ̂t
            (2.0, 0.2, 1.5),     // absorbing: mostly passes
            (0.0, 1.0, 2.0),     // clear: uniform collisions
            (1e-30, 0.5, 4.0),   // almost clear
            (4.6e-44, 0.5, 2.0), // subnormal σ̂t
            (4.0, 4.0, 50.0),    // truncated far away: almost pure exponential
        ];
        for (k, (t, s, d)) in cases.into_iter().enumerate() {
            for mode in MODES {
                let f = FreeFlight::new(mode, t, s);
                let (chi2, dof) = chi_square(f, d, 7 + k as u64);
                // 99.9 % quantile of χ² with ≤ 20 degrees of freedom is below 45.4.
                assert!(
                    chi2 < 45.4,
                    "{mode:?} {t} {s} {d}: χ² {chi2} with {dof} dof"
                );
            }
        }
    }

    /// The two-rate mixture: its density integrates to one with its pass probability, and its
    /// samples follow it (χ² on 40 cells of the truncated range, the rest lumped).
    #[test]
    fn mixture_flight_is_a_density_and_is_sampled_by_it() {
        let f = MixtureFlight::new(0.05, 3.0);
        let d = 2.0f32;
        let k = 20000;
        let h = d as f64 / k as f64;
        let mass: f64 = (0..k)
            .map(|i| f.pdf_collision(((i as f64 + 0.5) * h) as f32) as f64 * h)
            .sum::<f64>()
            + f.pdf_pass(d) as f64;
        assert!((mass - 1.0).abs() < 1e-4, "{mass}");
        let mut rng = Pcg32::seed_from_u64(9);
        let n = 200_000;
        let cells = 40;
        let mut hist = vec![0u32; cells + 1];
        for _ in 0..n {
            let t = f.sample([rng.random(), rng.random()]);
            let c = if t < d {
                (t / d * cells as f32) as usize
            } else {
                cells
            };
            hist[c.min(cells)] += 1;
        }
        let mut chi2 = 0.0;
        for (c, &count) in hist.iter().enumerate() {
            let p = if c == cells {
                f.pdf_pass(d) as f64
            } else {
                let (a, b) = (
                    c as f64 * d as f64 / cells as f64,
                    (c + 1) as f64 * d as f64 / cells as f64,
                );
                let m = 64;
                (0..m)
                    .map(|j| {
                        f.pdf_collision((a + (j as f64 + 0.5) * (b - a) / m as f64) as f32) as f64
                    })
                    .sum::<f64>()
                    * (b - a)
                    / m as f64
            };
            let e = p * n as f64;
            chi2 += (count as f64 - e).powi(2) / e;
        }
        // 40 degrees of freedom: mean 40, sd 9; allow 5 sd.
        assert!(chi2 < 40.0 + 5.0 * 80f64.sqrt(), "χ² = {chi2}");
        assert_eq!(f.pdf_pass(f32::INFINITY), 0.0);
        assert_eq!(MixtureFlight::new(0.0, 2.0).lo, 2e-3);
    }
}
