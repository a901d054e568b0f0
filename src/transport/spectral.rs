//! The spectral part of scattering at a path vertex, surface or medium, behind the one BBRRDF
//! interface of `crate::material` (wavelength sampling, pdfs and P_c/P_l of Jung 5.3 and the
//! all-bins operator).
//!
//! A medium collision is a BBRRDF per unit density whose diagonal is σs(λ) and whose kernel is
//! the fluorophore's σsΦ(λi → λo) = c·a(λi)·Φ·e(λo) (Mojzík eq. 4). Generalising Jung eqs. 5.10
//! and 5.12 to it, the probability that a collision is fluorescent is
//!
//! - P_l(λi) = c·Φ·a(λi) / (σs(λi) + c·Φ·a(λi)) given the wavelength on the light side (the row
//!   sum's fluorescent share), and
//! - P_c(λo) = c·Φ·∫a·e(λo) / (σs(λo) + c·Φ·∫a·e(λo)) given the camera side (the column sum's).
//!
//! The new wavelength is drawn from e on light paths and from a on camera paths, so the spectral
//! weight of a collision is σ̂s of the path's side (Table 1), as in the uni-directional walk.

use crate::material::{Bbrrdf, BinOperator, PathSide, ShiftDraw, average_fn};
use crate::medium::Coefficients;
use crate::spectrum::BinGrid;

/// Evaluate `$body` with `$m` bound to the spectral part of the scattering vertex `$v`: its
/// material (`&Material`) on a surface, its medium's coefficients (`&Coefficients`, per unit
/// density) in a medium; `$none` for a vertex that does not scatter. Each arm is compiled for
/// its own type, so a surface calls its material with no extra dispatch.
macro_rules! with_spectrum {
    ($scene:expr, $v:expr, $m:ident => $body:expr, else $none:expr) => {{
        let (kind, id) = ($v.kind, $v.material);
        match kind {
            $crate::transport::VertexKind::Surface if id != $crate::scene::NONE => {
                let $m = &$scene.materials[id as usize];
                $body
            }
            $crate::transport::VertexKind::Medium => {
                let $m = &$scene.media[id as usize].coefficients;
                $body
            }
            _ => $none,
        }
    }};
}
pub(crate) use with_spectrum;

impl Bbrrdf for Coefficients {
    #[inline]
    fn diagonal(&self, l: f32) -> f32 {
        self.sigma_s.eval(l)
    }
    #[inline]
    fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        match &self.fluorophore {
            Some(f) => f.kernel(l_in, l_out),
            None => 0.0,
        }
    }
    #[inline]
    fn is_fluorescent(&self) -> bool {
        Coefficients::is_fluorescent(self)
    }
    /// P_l: the fluorescent share of the row sum σ̂s,light(λi).
    #[inline]
    fn fluorescence_probability_light(&self, l_in: f32) -> f32 {
        let Some(f) = self.fluorophore.as_ref().filter(|_| self.is_fluorescent()) else {
            return 0.0;
        };
        let fl = f.c * f.phi * f.a.eval(l_in);
        if fl <= 0.0 {
            return 0.0;
        }
        fl / (fl + self.sigma_s.eval(l_in))
    }
    /// P_c: the fluorescent share of the column sum σ̂s(λo).
    #[inline]
    fn fluorescence_probability_camera(&self, l_out: f32) -> f32 {
        let Some(f) = self.fluorophore.as_ref().filter(|_| self.is_fluorescent()) else {
            return 0.0;
        };
        let fl = f.c * f.phi * f.a_integral * f.e.eval(l_out);
        if fl <= 0.0 {
            return 0.0;
        }
        fl / (fl + self.sigma_s.eval(l_out))
    }
    /// Emission-spectrum sampling on light paths, absorption-spectrum sampling on camera paths.
    #[inline]
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        let Some(f) = &self.fluorophore else {
            return ShiftDraw {
                lambda: l,
                density: 0.0,
                kernel: 0.0,
            };
        };
        ShiftDraw::rank_one(
            &f.a_dist,
            &f.e_dist,
            |li, lo| f.kernel(li, lo),
            l,
            u[1],
            side,
        )
    }
    #[inline]
    fn shift_density(&self, _l: f32, l_new: f32, side: PathSide) -> f32 {
        match (&self.fluorophore, side) {
            (Some(f), PathSide::Light) => f.e_dist.pdf(l_new),
            (Some(f), PathSide::Camera) => f.a_dist.pdf(l_new),
            (None, _) => 0.0,
        }
    }
    /// Diagonal σs plus rank one: t ← σs·t + Φ·e·∫ c·a·t dλ' per unit density.
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator {
        let n = grid.len();
        let mut diag = Vec::with_capacity(n);
        let (mut absorb, mut emit) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let (lo, hi) = (grid.edge(i), grid.edge(i + 1));
            diag.push(average_fn(|l| self.sigma_s.eval(l), lo, hi));
            if let Some(f) = self.fluorophore.as_ref().filter(|_| self.is_fluorescent()) {
                absorb[i] = f.c * f.a.integral(lo, hi) as f32;
                emit[i] = f.phi * f.e.bin_average(lo, hi);
            }
        }
        if self.is_fluorescent() {
            BinOperator::RankOne { diag, absorb, emit }
        } else {
            BinOperator::Diagonal { diag }
        }
    }
}
