//! Lambertian reflector: a reflectance spectrum, no wavelength shifting.

use super::{Bbrrdf, BinOperator, PathSide, ShiftDraw};
use crate::spectrum::{BinGrid, Spectrum};

#[derive(Clone, Debug)]
pub struct Lambert {
    pub reflectance: Spectrum,
}

impl Bbrrdf for Lambert {
    #[inline]
    fn diagonal(&self, l: f32) -> f32 {
        self.reflectance.eval(l)
    }
    fn kernel(&self, _: f32, _: f32) -> f32 {
        0.0
    }
    fn is_fluorescent(&self) -> bool {
        false
    }
    fn fluorescence_probability_light(&self, _: f32) -> f32 {
        0.0
    }
    fn fluorescence_probability_camera(&self, _: f32) -> f32 {
        0.0
    }
    fn sample_shift(&self, l: f32, _: [f32; 2], _: PathSide) -> ShiftDraw {
        ShiftDraw {
            lambda: l,
            density: 0.0,
            kernel: 0.0,
        }
    }
    fn shift_density(&self, _: f32, _: f32, _: PathSide) -> f32 {
        0.0
    }
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator {
        BinOperator::Diagonal {
            diag: self.reflectance.to_bins(grid),
        }
    }
}
