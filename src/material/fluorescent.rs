//! The diffuse, partly fluorescent BBRRDF of Jung ch. 5: reflectance r, absorption a, emission e,
//! quantum yield Φ and concentration c.

use super::{Bbrrdf, BinOperator, PathSide, ShiftDraw, average_fn};
use crate::spectrum::{BinGrid, Distribution1D, Domain, Spectrum, normalisable};

#[derive(Clone, Debug)]
pub struct FluorescentDiffuse {
    pub r: Spectrum,
    /// Absorption, scaled so max a = 1 on the domain (Jung eq. 5.1).
    pub a: Spectrum,
    /// Emission, scaled to unit area on the domain (Jung eq. 5.2).
    pub e: Spectrum,
    pub phi: f32,
    pub c: f32,
    pub domain: Domain,
    /// ∫ a dλ over the domain (precomputed for eq. 5.12).
    a_integral: f32,
    a_dist: Distribution1D,
    e_dist: Distribution1D,
}

impl FluorescentDiffuse {
    /// Build the model; returns the warnings produced by normalising a and e, or the field
    /// (`absorption`, `emission`) and a message when a or e is zero on the whole domain or its
    /// peak or area is too small to normalise (it is divided by in f64).
    pub fn new(
        r: Spectrum,
        a: Spectrum,
        e: Spectrum,
        phi: f32,
        c: f32,
        domain: Domain,
    ) -> Result<(Self, Vec<String>), (&'static str, String)> {
        let mut warnings = Vec::new();
        let a_max = a.max_value(domain);
        if a_max <= 0.0 {
            return Err((
                "absorption",
                "is zero on the whole wavelength domain".into(),
            ));
        }
        normalisable("its peak", a_max as f64).map_err(|m| ("absorption", m))?;
        let a = if (a_max - 1.0).abs() > 1e-3 {
            warnings.push(format!(
                "max of the absorption spectrum is {a_max}, not 1: normalised (Jung eq. 5.1)"
            ));
            a.divided(a_max as f64)
        } else {
            a
        };
        // In f64: the area of finite f32 values may overflow f32, or be subnormal.
        let e_area = e.integral(domain.min, domain.max);
        if !(e_area > 0.0) {
            return Err(("emission", "is zero on the whole wavelength domain".into()));
        }
        normalisable("its area (nm)", e_area).map_err(|m| ("emission", m))?;
        let e = if (e_area - 1.0).abs() > 1e-3 {
            warnings.push(format!(
                "the emission spectrum has area {e_area} nm on the domain, not 1: normalised (Jung eq. 5.2)"
            ));
            e.divided(e_area)
        } else {
            e
        };
        let a_integral = a.integral(domain.min, domain.max) as f32;
        let a_dist = Distribution1D::from_spectrum(&a, domain, 1.0);
        let e_dist = Distribution1D::from_spectrum(&e, domain, 1.0);
        Ok((
            FluorescentDiffuse {
                r,
                a,
                e,
                phi,
                c,
                domain,
                a_integral,
                a_dist,
                e_dist,
            },
            warnings,
        ))
    }
}

impl Bbrrdf for FluorescentDiffuse {
    /// r(λ)·(1 − c·a(λ)) (Jung eq. 5.5, δ part).
    #[inline]
    fn diagonal(&self, l: f32) -> f32 {
        self.r.eval(l) * (1.0 - self.c * self.a.eval(l))
    }
    /// c·a(λin)·Φ·e(λout) (Jung eq. 5.3).
    #[inline]
    fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        self.c * self.a.eval(l_in) * self.phi * self.e.eval(l_out)
    }
    fn is_fluorescent(&self) -> bool {
        self.c > 0.0 && self.phi > 0.0
    }
    /// Jung eq. 5.10.
    #[inline]
    fn fluorescence_probability_light(&self, l_in: f32) -> f32 {
        let ca = self.c * self.a.eval(l_in);
        let fl = ca * self.phi;
        if fl <= 0.0 {
            return 0.0;
        }
        fl / (fl + self.r.eval(l_in) * (1.0 - ca))
    }
    /// Jung eq. 5.12.
    #[inline]
    fn fluorescence_probability_camera(&self, l_out: f32) -> f32 {
        let fl = self.c * self.a_integral * self.phi * self.e.eval(l_out);
        if fl <= 0.0 {
            return 0.0;
        }
        fl / (fl + self.r.eval(l_out) * (1.0 - self.c * self.a.eval(l_out)))
    }
    /// Emission-spectrum sampling on light paths, absorption-spectrum sampling on camera paths
    /// (Jung 5.3.2).
    #[inline]
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        let k = |li, lo| self.kernel(li, lo);
        ShiftDraw::rank_one(&self.a_dist, &self.e_dist, k, l, u[1], side)
    }
    #[inline]
    fn shift_density(&self, _l: f32, l_new: f32, side: PathSide) -> f32 {
        match side {
            PathSide::Light => self.e_dist.pdf(l_new),
            PathSide::Camera => self.a_dist.pdf(l_new),
        }
    }
    /// Diagonal plus rank one: t ← (1 − c·a)·r·t + Φ·e·∫ c·a·t dλ' (Jung Alg. 6 line 4, as
    /// corrected in docs/design.md §4).
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator {
        let n = grid.len();
        let mut diag = Vec::with_capacity(n);
        let mut absorb = Vec::with_capacity(n);
        let mut emit = Vec::with_capacity(n);
        for i in 0..n {
            let (lo, hi) = (grid.edge(i), grid.edge(i + 1));
            diag.push(average_fn(|l| self.diagonal(l), lo, hi));
            absorb.push(self.c * self.a.integral(lo, hi) as f32);
            emit.push(self.phi * self.e.bin_average(lo, hi));
        }
        BinOperator::RankOne { diag, absorb, emit }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::DEFAULT_DOMAIN;

    fn model(r: f32, c: f32, phi: f32) -> FluorescentDiffuse {
        FluorescentDiffuse::new(
            Spectrum::Constant(r),
            Spectrum::Box {
                lo: 300.0,
                hi: 400.0,
                value: 1.0,
            },
            Spectrum::Box {
                lo: 500.0,
                hi: 550.0,
                value: 1.0 / 50.0,
            },
            phi,
            c,
            DEFAULT_DOMAIN,
        )
        .unwrap()
        .0
    }

    #[test]
    fn energy_conservation_eq_5_8() {
        // ∫ f dλout ≤ 1 for every λin, with equality for r = Φ = 1.
        for &(r, c, phi) in &[
            (1.0, 1.0, 1.0),
            (0.8, 0.5, 0.9),
            (0.0, 1.0, 1.0),
            (1.0, 0.3, 1.0),
        ] {
            let m = model(r, c, phi);
            for li in (280..780).step_by(7) {
                let li = li as f32 + 0.5;
                let total = m.diagonal(li)
                    + (m.e.integral(280.0, 780.0) as f32) * m.kernel(li, 525.0) / m.e.eval(525.0);
                assert!(total <= 1.0 + 1e-5, "λin {li}: {total}");
                if r == 1.0 && phi == 1.0 {
                    assert!((total - 1.0).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn probabilities_match_hand_computed_cases() {
        // r = 0.5, c = 0.5, Φ = 0.8. Light path at 350 nm: a = 1:
        // P_l = 0.5·1·0.8 / (0.4 + 0.5·(1 − 0.5)) = 0.4 / 0.65.
        let m = model(0.5, 0.5, 0.8);
        assert!((m.fluorescence_probability_light(350.0) - 0.4 / 0.65).abs() < 1e-6);
        assert_eq!(m.fluorescence_probability_light(450.0), 0.0);
        // Camera path at 520 nm: ∫a = 100, e = 0.02, a(520) = 0:
        // P_c = 0.5·100·0.8·0.02 / (0.8 + 0.5·1) = 0.8 / 1.3.
        assert!((m.fluorescence_probability_camera(520.0) - 0.8 / 1.3).abs() < 1e-6);
        assert_eq!(m.fluorescence_probability_camera(450.0), 0.0);
        // Purely fluorescent: P = 1.
        let p = model(0.0, 1.0, 1.0);
        assert_eq!(p.fluorescence_probability_light(350.0), 1.0);
        assert_eq!(p.fluorescence_probability_camera(520.0), 1.0);
    }

    #[test]
    fn normalisation_warns() {
        let (m, w) = FluorescentDiffuse::new(
            Spectrum::Constant(0.5),
            Spectrum::Box {
                lo: 300.0,
                hi: 400.0,
                value: 2.0,
            },
            Spectrum::Box {
                lo: 500.0,
                hi: 550.0,
                value: 1.0,
            },
            1.0,
            1.0,
            DEFAULT_DOMAIN,
        )
        .unwrap();
        assert_eq!(w.len(), 2);
        assert!((m.a.max_value(DEFAULT_DOMAIN) - 1.0).abs() < 1e-6);
        assert!((m.e.integral(280.0, 780.0) - 1.0).abs() < 1e-6);
    }
}
