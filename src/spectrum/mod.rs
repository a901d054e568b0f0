//! Spectral core: the wavelength domain, analytic and tabulated spectra, bins, 1-D sampling
//! tables, the CIE observer and hero wavelength sets.

pub mod bins;
pub mod cie;
pub mod colorimetry;
pub mod gaussian;
pub mod hero;
pub mod illuminants;
pub mod lanes;
pub mod sampling;

pub use bins::BinGrid;
pub use cie::{Observer, xyz_to_linear_srgb};
pub use hero::SampledWavelengths;
pub use lanes::{LaneArr, Lanes, MAX_LANES};
pub use sampling::Distribution1D;

/// Default wavelength domain Λ = [280, 780] nm (Jung 4.1), so that UV light can drive fluorescence.
pub const DEFAULT_DOMAIN: Domain = Domain {
    min: 280.0,
    max: 780.0,
};

/// A closed wavelength interval in nm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain {
    pub min: f32,
    pub max: f32,
}

impl Domain {
    pub fn width(&self) -> f32 {
        self.max - self.min
    }
    pub fn contains(&self, l: f32) -> bool {
        l >= self.min && l <= self.max
    }
    /// Density of the uniform distribution over the domain at `l` (zero outside).
    #[inline]
    pub fn uniform_pdf(&self, l: f32) -> f32 {
        if self.contains(l) {
            1.0 / self.width()
        } else {
            0.0
        }
    }
    /// A uniform wavelength from `u` in [0, 1).
    #[inline]
    pub fn sample_uniform(&self, u: f32) -> f32 {
        self.min + u * self.width()
    }
    pub fn intersect(&self, o: &Domain) -> Domain {
        Domain {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }
}

/// A spectrum as a function of wavelength (nm).
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    Constant(f32),
    /// `value` on [lo, hi], zero elsewhere.
    Box {
        lo: f32,
        hi: f32,
        value: f32,
    },
    /// A Gaussian with centre, standard deviation and peak value.
    Gaussian {
        center: f32,
        sigma: f32,
        peak: f32,
    },
    /// Piecewise-linear through (xs, ys), zero outside [xs[0], xs[n-1]]. xs strictly increasing.
    Tabulated {
        xs: Vec<f32>,
        ys: Vec<f32>,
    },
    /// Piecewise-constant: `values[i]` on [lo + i·width, lo + (i+1)·width).
    Binned {
        lo: f32,
        width: f32,
        values: Vec<f32>,
    },
}

impl Spectrum {
    /// A Gaussian given by its full width at half maximum.
    pub fn gaussian_fwhm(center: f32, fwhm: f32, peak: f32) -> Spectrum {
        Spectrum::Gaussian {
            center,
            sigma: fwhm / (2.0 * (2.0f32 * 2f32.ln()).sqrt()),
            peak,
        }
    }

    /// Value at wavelength `l`. Constants and boxes, the cheap and common cases, are
    /// evaluated inline; the others by [`Self::eval_shaped`].
    #[inline]
    pub fn eval(&self, l: f32) -> f32 {
        match self {
            Spectrum::Constant(v) => *v,
            Spectrum::Box { lo, hi, value } => {
                if l >= *lo && l <= *hi {
                    *value
                } else {
                    0.0
                }
            }
            _ => self.eval_shaped(l),
        }
    }

    /// [`Self::eval`] of a Gaussian, tabulated or binned spectrum.
    #[inline(never)]
    fn eval_shaped(&self, l: f32) -> f32 {
        match self {
            Spectrum::Constant(_) | Spectrum::Box { .. } => self.eval(l),
            Spectrum::Gaussian {
                center,
                sigma,
                peak,
            } => {
                let x = (l - center) / sigma;
                peak * (-0.5 * x * x).exp()
            }
            Spectrum::Tabulated { xs, ys } => tabulated(xs, ys, l, knot_above),
            Spectrum::Binned { lo, width, values } => {
                let f = (l - lo) / width;
                if f < 0.0 {
                    return 0.0;
                }
                let i = f as usize;
                if i < values.len() {
                    values[i]
                } else if i == values.len() && f == i as f32 {
                    values[i - 1]
                } else {
                    0.0
                }
            }
        }
    }

    /// Exact integral over [a, b] (Gaussian through erf).
    pub fn integral(&self, a: f32, b: f32) -> f64 {
        if b <= a {
            return 0.0;
        }
        let (a64, b64) = (a as f64, b as f64);
        match self {
            Spectrum::Constant(v) => *v as f64 * (b64 - a64),
            Spectrum::Box { lo, hi, value } => {
                let l = a64.max(*lo as f64);
                let h = b64.min(*hi as f64);
                if h > l { *value as f64 * (h - l) } else { 0.0 }
            }
            Spectrum::Gaussian {
                center,
                sigma,
                peak,
            } => {
                let s = *sigma as f64;
                let c = *center as f64;
                let k = std::f64::consts::SQRT_2 * s;
                *peak as f64
                    * s
                    * (std::f64::consts::PI / 2.0).sqrt()
                    * (erf((b64 - c) / k) - erf((a64 - c) / k))
            }
            Spectrum::Tabulated { xs, ys } => {
                let mut sum = 0.0;
                for i in 1..xs.len() {
                    let (x0, x1) = (xs[i - 1] as f64, xs[i] as f64);
                    let l = a64.max(x0);
                    let h = b64.min(x1);
                    if h <= l {
                        continue;
                    }
                    let y = |x: f64| {
                        let t = (x - x0) / (x1 - x0);
                        ys[i - 1] as f64 * (1.0 - t) + ys[i] as f64 * t
                    };
                    sum += 0.5 * (y(l) + y(h)) * (h - l);
                }
                sum
            }
            Spectrum::Binned { lo, width, values } => {
                let mut sum = 0.0;
                for (i, v) in values.iter().enumerate() {
                    let x0 = *lo as f64 + i as f64 * *width as f64;
                    let x1 = x0 + *width as f64;
                    let l = a64.max(x0);
                    let h = b64.min(x1);
                    if h > l {
                        sum += *v as f64 * (h - l);
                    }
                }
                sum
            }
        }
    }

    /// Average over [a, b] (the value of a bin), not a point sample.
    pub fn bin_average(&self, a: f32, b: f32) -> f32 {
        (self.integral(a, b) / (b as f64 - a as f64)) as f32
    }

    /// Bin averages on a grid.
    pub fn to_bins(&self, grid: &BinGrid) -> Vec<f32> {
        (0..grid.len())
            .map(|i| self.bin_average(grid.edge(i), grid.edge(i + 1)))
            .collect()
    }

    /// Largest value on the domain (dense scan for smooth kinds).
    pub fn max_value(&self, d: Domain) -> f32 {
        match self {
            Spectrum::Constant(v) => *v,
            Spectrum::Box { lo, hi, value } => {
                if *hi >= d.min && *lo <= d.max {
                    *value
                } else {
                    0.0
                }
            }
            Spectrum::Tabulated { xs, ys } => xs
                .iter()
                .zip(ys)
                .filter(|(x, _)| d.contains(**x))
                .map(|(_, y)| *y)
                .fold(self.eval(d.min).max(self.eval(d.max)), f32::max),
            Spectrum::Binned { .. } | Spectrum::Gaussian { .. } => {
                let n = ((d.width() * 4.0) as usize).max(1);
                (0..=n)
                    .map(|i| self.eval(d.min + d.width() * i as f32 / n as f32))
                    .fold(0.0, f32::max)
            }
        }
    }

    /// Smallest value on the domain (used for validation).
    pub fn min_value(&self, d: Domain) -> f32 {
        match self {
            Spectrum::Constant(v) => *v,
            Spectrum::Box { value, .. } => value.min(0.0),
            Spectrum::Gaussian { peak, .. } => peak.min(0.0),
            Spectrum::Tabulated { ys, .. } => ys.iter().copied().fold(0.0, f32::min),
            Spectrum::Binned { values, .. } => values.iter().copied().fold(0.0, f32::min),
        }
        .min(self.eval(d.min).min(self.eval(d.max)))
    }

    /// The same spectrum divided by `by` (its peak or area, to make that 1), each value
    /// divided in f64: the f32 reciprocal of a `by` near the ends of the f32 range would lose
    /// precision or overflow. Check `by` with [`normalisable`] first.
    pub fn divided(&self, by: f64) -> Spectrum {
        self.map_values(|v| (v as f64 / by) as f32)
    }

    /// The same spectrum multiplied by `k`.
    pub fn scaled(&self, k: f32) -> Spectrum {
        self.map_values(|v| v * k)
    }

    /// The same spectrum with every value (not the wavelengths) mapped by `f`.
    fn map_values(&self, f: impl Fn(f32) -> f32) -> Spectrum {
        match self {
            Spectrum::Constant(v) => Spectrum::Constant(f(*v)),
            Spectrum::Box { lo, hi, value } => Spectrum::Box {
                lo: *lo,
                hi: *hi,
                value: f(*value),
            },
            Spectrum::Gaussian {
                center,
                sigma,
                peak,
            } => Spectrum::Gaussian {
                center: *center,
                sigma: *sigma,
                peak: f(*peak),
            },
            Spectrum::Tabulated { xs, ys } => Spectrum::Tabulated {
                xs: xs.clone(),
                ys: ys.iter().map(|&y| f(y)).collect(),
            },
            Spectrum::Binned { lo, width, values } => Spectrum::Binned {
                lo: *lo,
                width: *width,
                values: values.iter().map(|&y| f(y)).collect(),
            },
        }
    }

    /// True if the spectrum is zero everywhere on the domain.
    pub fn is_zero_on(&self, d: Domain) -> bool {
        self.integral(d.min, d.max).abs() == 0.0 && self.max_value(d) == 0.0
    }
}

/// Whether a spectrum whose peak or area (`what`) is `v` can be normalised to 1 with
/// [`Spectrum::divided`]: `v` must be finite and at least [`f32::MIN_POSITIVE`] (about 1.2e-38,
/// the smallest normal f32). Below it, a peak is subnormal and keeps only a few significant bits
/// of the spectrum's shape (and its f32 reciprocal overflows). An area above `f32::MAX` is fine:
/// the division is in f64.
pub fn normalisable(what: &str, v: f64) -> Result<(), String> {
    // As the f32 it was read as, when it is one (1e-45, not 1.401298464324817e-45).
    let shown = match v as f32 {
        f if f != 0.0 && f.is_finite() => format!("{f:e}"),
        _ => format!("{v:e}"),
    };
    if v >= f32::MIN_POSITIVE as f64 && v.is_finite() {
        Ok(())
    } else if v > 0.0 && v < f32::MIN_POSITIVE as f64 {
        Err(format!(
            "{what} {shown} is too small to normalise (below {:e}, the smallest normal f32)",
            f32::MIN_POSITIVE
        ))
    } else {
        Err(format!("{what} {shown} cannot be normalised to 1"))
    }
}

/// Error function, from [`erfc`] (|error| < 1.2e-7).
pub fn erf(x: f64) -> f64 {
    let ans = erfc_abs(x.abs());
    if x >= 0.0 { 1.0 - ans } else { ans - 1.0 }
}

/// Complementary error function 1 − erf(x), accurate in the tails too (fractional error
/// < 1.2e-7 everywhere, no cancellation for large x): the mass of a Gaussian beyond a point,
/// as truncated Gaussians need.
pub fn erfc(x: f64) -> f64 {
    let ans = erfc_abs(x.abs());
    if x >= 0.0 { ans } else { 2.0 - ans }
}

/// erfc(z) for z ≥ 0: Numerical Recipes' `erfcc` Chebyshev fit (fractional error < 1.2e-7).
fn erfc_abs(z: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * z);
    t * (-z * z - 1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398
                                + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
        .exp()
}

/// The piecewise-linear table (`xs`, `ys`) at `l`, 0 outside it; `knot` finds the first knot
/// above `l` (clamped to 1..n−1), so that every way of finding it gives the same value.
#[inline(always)]
pub(crate) fn tabulated(
    xs: &[f32],
    ys: &[f32],
    l: f32,
    knot: impl FnOnce(&[f32], f32) -> usize,
) -> f32 {
    let n = xs.len();
    if n == 0 || l < xs[0] || l > xs[n - 1] {
        return 0.0;
    }
    if n == 1 {
        return ys[0];
    }
    let i = knot(xs, l);
    let (x0, x1) = (xs[i - 1], xs[i]);
    let t = (l - x0) / (x1 - x0);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}

/// The first knot above `l` (clamped to 1..n−1) of a table with n ≥ 2 knots and
/// `xs[0] ≤ l ≤ xs[n−1]`: on an evenly spaced long table (measured data mostly is) the index
/// computed from `l` is checked and taken, O(1); else a binary search (short tables: always).
/// Either way the same index.
#[inline]
fn knot_above(xs: &[f32], l: f32) -> usize {
    let n = xs.len();
    if n > 16 {
        let g = ((l - xs[0]) / (xs[n - 1] - xs[0]) * (n - 1) as f32) as usize + 1;
        let g = g.clamp(1, n - 1);
        if xs[g - 1] <= l && (g == n - 1 || l < xs[g]) {
            return g;
        }
    }
    xs.partition_point(|&x| x <= l).clamp(1, n - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The guessed knot is the binary search's, on even and uneven tables, at and between knots.
    #[test]
    fn knot_above_is_the_binary_search() {
        let even: Vec<f32> = (0..95).map(|i| 360.0 + 5.0 * i as f32).collect();
        let uneven = vec![360.0, 361.0, 400.0, 400.5, 555.0, 556.0, 700.0, 830.0];
        let third: Vec<f32> = (0..31).map(|i| 380.0 + i as f32 / 3.0 * 10.0).collect();
        for xs in [even, uneven, third, vec![400.0, 700.0]] {
            let (lo, hi) = (xs[0], xs[xs.len() - 1]);
            let mut ls: Vec<f32> = (0..=20_000)
                .map(|k| lo + (hi - lo) * k as f32 / 20_000.0)
                .collect();
            ls.extend(&xs);
            ls.extend(xs.iter().map(|x| x.next_up().min(hi)));
            ls.extend(xs.iter().map(|x| x.next_down().max(lo)));
            for l in ls {
                let want = xs.partition_point(|&x| x <= l).clamp(1, xs.len() - 1);
                assert_eq!(knot_above(&xs, l), want, "{l} in {xs:?}");
            }
        }
    }

    #[test]
    fn erfc_matches_reference_values_in_the_tails() {
        // Reference values from the series / continued fraction, 16 digits.
        for (x, want) in [
            (0.0, 1.0),
            (0.5, 0.4795001221869535),
            (1.0, 0.1572992070502851),
            (3.0, 2.209049699858544e-5),
            (5.0, 1.537459794428035e-12),
            (10.0, 2.088487583762545e-45),
            (-1.0, 1.842700792949715),
            (-4.0, 1.999999984582742),
        ] {
            let got = erfc(x);
            assert!(
                (got - want).abs() <= 2e-7 * want,
                "erfc({x}) = {got}, want {want}"
            );
            assert!((erf(x) - (1.0 - want)).abs() < 2e-7, "erf({x})");
        }
    }

    #[test]
    fn box_integrates_exactly() {
        let s = Spectrum::Box {
            lo: 400.0,
            hi: 450.0,
            value: 2.0,
        };
        assert_eq!(s.integral(280.0, 780.0), 100.0);
        assert_eq!(s.integral(420.0, 430.0), 20.0);
        assert_eq!(s.bin_average(445.0, 455.0), 1.0);
        assert_eq!(s.bin_average(400.0, 405.0), 2.0);
    }

    #[test]
    fn bin_average_is_average_not_point_sample() {
        // A ramp 0..1 over [400, 500]: the bin [400, 450] averages 0.25; its centre is also 0.25,
        // but the bin [490, 510] straddles the end: average (0.9+1)/2·0.5 = 0.475, centre = 1.
        let s = Spectrum::Tabulated {
            xs: vec![400.0, 500.0],
            ys: vec![0.0, 1.0],
        };
        assert!((s.bin_average(400.0, 450.0) - 0.25).abs() < 1e-6);
        assert!((s.bin_average(490.0, 510.0) - 0.475).abs() < 1e-6);
        assert_eq!(s.eval(500.0), 1.0);
        assert_eq!(s.eval(500.1), 0.0);
        let g = BinGrid::new(DEFAULT_DOMAIN, 50.0);
        let bins = s.to_bins(&g);
        assert_eq!(bins.len(), 10);
        assert!(
            (bins[2] - 0.09).abs() < 1e-6
                && (bins[3] - 0.55).abs() < 1e-6
                && (bins[4] - 0.36).abs() < 1e-6
        );
        assert_eq!(bins[0], 0.0);
    }

    #[test]
    fn gaussian_integral_matches_closed_form() {
        let g = Spectrum::gaussian_fwhm(500.0, 30.0, 1.0);
        let Spectrum::Gaussian { sigma, .. } = g else {
            unreachable!()
        };
        let exact = sigma as f64 * (2.0 * std::f64::consts::PI).sqrt();
        assert!((g.integral(0.0, 1000.0) - exact).abs() < 1e-5 * exact);
        assert!((g.eval(515.0) - 0.5).abs() < 1e-5);
        // Numerical integration agrees on a sub-interval.
        let n = 10000;
        let num: f64 = (0..n)
            .map(|i| g.eval(480.0 + 40.0 * (i as f32 + 0.5) / n as f32) as f64)
            .sum::<f64>()
            * 40.0
            / n as f64;
        assert!((g.integral(480.0, 520.0) - num).abs() < 1e-4);
    }

    #[test]
    fn binned_and_tabulated_integrals() {
        let b = Spectrum::Binned {
            lo: 400.0,
            width: 10.0,
            values: vec![1.0, 2.0, 3.0],
        };
        assert_eq!(b.integral(0.0, 1000.0), 60.0);
        assert_eq!(b.eval(415.0), 2.0);
        assert_eq!(b.eval(430.0), 3.0);
        assert_eq!(b.eval(431.0), 0.0);
        let t = Spectrum::Tabulated {
            xs: vec![400.0, 410.0, 430.0],
            ys: vec![0.0, 1.0, 1.0],
        };
        assert!((t.integral(0.0, 1000.0) - 25.0).abs() < 1e-9);
    }
}
