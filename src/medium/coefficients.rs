//! The spectral coefficients of a medium (Mojzík §5.1, eq. 3–4 and Table 1), per unit density.
//!
//! A medium has an absorption σa(λ), a scattering σs(λ) and optionally a fluorophore with
//! absorption spectrum a(λ) (max 1) at concentration c (an extinction per scene unit), emission
//! spectrum e(λ) (unit area) and quantum yield Φ. The fluorophore removes c·a(λ) from a beam;
//! the fraction Φ is re-emitted with spectrum e, so the bispectral collision coefficient is
//!
//!   σsΦ(λi → λo) = c·a(λi)·Φ·e(λo),
//!
//! and the rest, (1 − Φ)·c·a(λ), is absorption. Mojzík Table 1 then gives
//!
//! - σ̂t(λ) = σa + σs + c·a(λ): extinction including the out-shift ∫σsΦ(λ, λo) dλo (the row
//!   sum, what light at λ loses; eq. 3);
//! - σ̂s(λ) = σs + c·Φ·e(λ)·∫a: collision coefficient including the in-shift ∫σsΦ(λi, λ) dλi
//!   (the column sum, what a camera path at λ can gather);
//! - σ̂s,light(λ) = σs + c·Φ·a(λ): the row sum, what a light path at λ scatters into any
//!   wavelength.

use crate::spectrum::{Distribution1D, Domain, Lanes, Spectrum};

/// A fluorophore dissolved in a medium.
#[derive(Clone, Debug)]
pub struct Fluorophore {
    /// Absorption spectrum, max 1 on the domain.
    pub a: Spectrum,
    /// Concentration: the extinction per scene unit at the peak of `a`.
    pub c: f32,
    /// Emission spectrum, unit area on the domain.
    pub e: Spectrum,
    /// Quantum yield.
    pub phi: f32,
    /// ∫ a dλ over the domain.
    pub a_integral: f32,
    /// λ ∝ a (camera side: the incident wavelength of an in-shift).
    pub a_dist: Distribution1D,
    /// λ ∝ e (light side: the emitted wavelength of an out-shift).
    pub e_dist: Distribution1D,
}

impl Fluorophore {
    /// Build from spectra already normalised (a to max 1, e to unit area) by the scene loader.
    pub fn new(a: Spectrum, c: f32, e: Spectrum, phi: f32, domain: Domain) -> Self {
        let a_integral = a.integral(domain.min, domain.max) as f32;
        Fluorophore {
            a_dist: Distribution1D::from_spectrum(&a, domain, 1.0),
            e_dist: Distribution1D::from_spectrum(&e, domain, 1.0),
            a,
            c,
            e,
            phi,
            a_integral,
        }
    }

    /// σsΦ(λi → λo) = c·a(λi)·Φ·e(λo).
    #[inline]
    pub fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        self.c * self.a.eval(l_in) * self.phi * self.e.eval(l_out)
    }
}

/// The coefficients of a medium per unit density.
#[derive(Clone, Debug)]
pub struct Coefficients {
    pub sigma_a: Spectrum,
    pub sigma_s: Spectrum,
    pub fluorophore: Option<Fluorophore>,
    /// (σ̂t, σ̂s = σs) when they do not depend on wavelength (constant spectra, no fluorophore):
    /// every lane then tracks alike and the tracers skip the per-lane work.
    pub grey: Option<(f32, f32)>,
}

/// The coefficients of Mojzík Table 1 at the first `n` lanes of a wavelength vector.
#[derive(Clone, Copy, Debug)]
pub struct CollisionCoefficients<L> {
    /// σs: elastic scattering.
    pub sigma_s: L,
    /// σ̂t: fluorescence-aware extinction (eq. 3).
    pub hat_t: L,
    /// σ̂s: fluorescence-aware collision coefficient: the column sum on the camera side, the
    /// row sum on the light side (see [`Coefficients::at_side`]).
    pub hat_s: L,
}

/// A wavelength drawn at a camera-side collision.
#[derive(Clone, Copy, Debug)]
pub struct InShift {
    /// The incident wavelength (equal to the outgoing one for an elastic collision).
    pub lambda: f32,
    /// The probability density of the draw (the choice times the wavelength density); 0 means
    /// the draw failed.
    pub pdf: f32,
    /// (σs·δ + σsΦ(λi → λo)) / pdf: the collision coefficient over the draw's probability
    /// (σ̂s when the draw follows the coefficients exactly).
    pub weight: f32,
    pub fluorescent: bool,
}

impl Coefficients {
    pub fn new(sigma_a: Spectrum, sigma_s: Spectrum, fluorophore: Option<Fluorophore>) -> Self {
        let grey = match (&sigma_a, &sigma_s, &fluorophore) {
            (Spectrum::Constant(a), Spectrum::Constant(s), None) => Some((a + s, *s)),
            _ => None,
        };
        Coefficients {
            sigma_a,
            sigma_s,
            fluorophore,
            grey,
        }
    }

    /// True when the medium shifts wavelengths.
    pub fn is_fluorescent(&self) -> bool {
        cfg!(feature = "fluorescence")
            && self
                .fluorophore
                .as_ref()
                .is_some_and(|f| f.c > 0.0 && f.phi > 0.0)
    }

    /// σ̂t, σ̂s (camera side) and σs at every lane (Mojzík Table 1).
    #[inline]
    pub fn at<L: Lanes>(&self, n: usize, lambda: L) -> CollisionCoefficients<L> {
        let sigma_s = self.sigma_s.eval_lanes(n, lambda);
        let mut hat_t = self.sigma_a.eval_lanes(n, lambda) + sigma_s;
        let mut hat_s = sigma_s;
        if let Some(f) = &self.fluorophore {
            hat_t += f.a.eval_lanes(n, lambda) * f.c;
            hat_s += f.e.eval_lanes(n, lambda) * (f.c * f.phi * f.a_integral);
        }
        CollisionCoefficients {
            sigma_s,
            hat_t,
            hat_s,
        }
    }

    /// The coefficients seen by a path of the given side: camera paths gather what scatters
    /// *into* λ (σ̂s is the column sum, [`Coefficients::at`]); light paths carry what scatters
    /// *out of* λ into any wavelength (σ̂s is the row sum σs + c·Φ·a(λ)). σ̂t is the same for both:
    /// it is the extinction of light at λ and drives the transmittance (Mojzík eq. 3).
    #[inline]
    pub fn at_side<L: Lanes>(&self, n: usize, lambda: L, light: bool) -> CollisionCoefficients<L> {
        let mut c = self.at(n, lambda);
        if light {
            c.hat_s = c.sigma_s;
            if let Some(f) = &self.fluorophore {
                c.hat_s += f.a.eval_lanes(n, lambda) * (f.c * f.phi);
            }
        }
        c
    }

    /// The largest σ̂t, camera-side σ̂s and light-side σ̂s over `domain` (sampled every 1 nm and
    /// at the ends, with 1 % headroom): the wavelength-independent tracking coefficient of the
    /// all-bins evaluator.
    pub fn majorant_over(&self, domain: Domain) -> f32 {
        let steps = (domain.width().ceil() as usize).max(1);
        let mut m = 0.0f32;
        for i in 0..=steps {
            let l = (domain.min + i as f32).min(domain.max);
            let c = self.at(1, l);
            m = m.max(c.hat_t).max(c.hat_s).max(self.hat_s_light(l));
        }
        m * 1.01
    }

    /// σ̂s on the light side (row sum): σs + c·Φ·a(λ).
    #[inline]
    pub fn hat_s_light(&self, l: f32) -> f32 {
        let mut s = self.sigma_s.eval(l);
        if let Some(f) = &self.fluorophore {
            s += f.c * f.phi * f.a.eval(l);
        }
        s
    }

    /// At a camera-side collision with outgoing wavelength `l_out`, choose elastic scattering
    /// with probability σs/σ̂s or a fluorescent one otherwise (the medium's P_c, cf. Jung eq.
    /// 5.12), and draw the incident wavelength from a(λ) (absorption-spectrum sampling).
    #[inline]
    pub fn sample_in_shift(&self, l_out: f32, u: [f32; 2]) -> InShift {
        let sigma_s = self.sigma_s.eval(l_out);
        let elastic = InShift {
            lambda: l_out,
            pdf: 1.0,
            weight: sigma_s,
            fluorescent: false,
        };
        let Some(f) = self.fluorophore.as_ref().filter(|_| self.is_fluorescent()) else {
            return elastic;
        };
        let in_shift = f.c * f.phi * f.a_integral * f.e.eval(l_out);
        let hat_s = sigma_s + in_shift;
        if !(in_shift > 0.0) {
            return elastic;
        }
        let p_fl = in_shift / hat_s;
        if u[0] >= p_fl {
            return InShift {
                pdf: 1.0 - p_fl,
                weight: hat_s,
                ..elastic
            };
        }
        let (l_in, density) = f.a_dist.sample(u[1]);
        let pdf = p_fl * density;
        let k = f.kernel(l_in, l_out);
        InShift {
            lambda: l_in,
            pdf,
            weight: if pdf > 0.0 { k / pdf } else { 0.0 },
            fluorescent: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn medium() -> Coefficients {
        let d = crate::spectrum::DEFAULT_DOMAIN;
        let a = Spectrum::gaussian_fwhm(450.0, 40.0, 1.0);
        let e = Spectrum::gaussian_fwhm(550.0, 40.0, 1.0);
        let area = e.integral(d.min, d.max) as f32;
        Coefficients::new(
            Spectrum::Constant(0.1),
            Spectrum::Constant(0.3),
            Some(Fluorophore::new(a, 2.0, e.scaled(1.0 / area), 0.8, d)),
        )
    }

    #[test]
    fn table_one_row_and_column_sums() {
        let m = medium();
        let d = crate::spectrum::DEFAULT_DOMAIN;
        let f = m.fluorophore.as_ref().unwrap();
        for l in [420.0f32, 450.0, 550.0, 600.0] {
            let c = m.at(1, l);
            // Row sum ∫ σsΦ(λ, λo) dλo and column sum ∫ σsΦ(λi, λ) dλi by quadrature.
            let h = 0.5;
            let steps = (d.width() / h) as usize;
            let (mut row, mut col) = (0.0f64, 0.0f64);
            for i in 0..steps {
                let x = d.min + (i as f32 + 0.5) * h;
                row += f.kernel(l, x) as f64 * h as f64;
                col += f.kernel(x, l) as f64 * h as f64;
            }
            let fl_abs = f.c * f.a.eval(l);
            let expect_t = 0.1 + 0.3 + fl_abs;
            assert!((c.hat_t - expect_t).abs() < 1e-5);
            // σ̂t = σt + row sum, where σt holds the lossy part (1 − Φ)·c·a.
            let sigma_t = 0.1 + 0.3 + (1.0 - f.phi) * fl_abs;
            assert!((c.hat_t as f64 - (sigma_t as f64 + row)).abs() < 2e-3 * c.hat_t as f64);
            assert!((c.hat_s as f64 - (0.3 + col)).abs() < 2e-3 * c.hat_s as f64);
            assert!((m.hat_s_light(l) as f64 - (0.3 + row)).abs() < 2e-3);
        }
    }

    #[test]
    fn in_shift_draw_is_unbiased() {
        // E[weight · g(λi)] = σs·g(λo) + ∫ σsΦ(λi, λo)·g(λi) dλi for a test function g.
        let m = medium();
        let f = m.fluorophore.as_ref().unwrap();
        let g = |l: f32| 1.0 + (l - 400.0) / 100.0;
        let l_out = 550.0;
        let n = 400_000;
        let mut sum = 0.0f64;
        let mut sq = 0.0f64;
        let mut state = 0x1234_5678u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        for _ in 0..n {
            let s = m.sample_in_shift(l_out, [next(), next()]);
            let v = (s.weight * g(s.lambda)) as f64;
            sum += v;
            sq += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
        let d = crate::spectrum::DEFAULT_DOMAIN;
        let mut expect = 0.3 * g(l_out) as f64;
        let h = 0.25;
        for i in 0..(d.width() / h) as usize {
            let x = d.min + (i as f32 + 0.5) * h;
            expect += (f.kernel(x, l_out) * g(x)) as f64 * h as f64;
        }
        assert!(
            (mean - expect).abs() < 4.0 * se + 1e-3 * expect,
            "{mean} vs {expect} ± {se}"
        );
    }
}
