//! The wavelengths of the bidirectional tracers in one place: how a sub-path's first
//! wavelength is drawn (Jung eqs. 6.4, 6.5), and the key under which the caches of a sample
//! remember values computed at one wavelength.
//!
//! A vertex carries the wavelength on each of its sides (`subpath::Lambdas`: `lambda_in` from
//! the light side, `lambda_out` towards the camera), and a connected path one per segment
//! (`FullPath::lambda`). The pdfs the MIS weights need are those of the wavelengths after the
//! reset, not of the ones drawn, so they are evaluated at the path's final wavelengths
//! (`FullPath::wavelength_pdfs`) rather than carried with the draw.

use crate::integrator::{LightWavelengths, Sampler};
use crate::scene::Scene;
use crate::spectrum::cie::CameraWavelengths;

/// A drawn wavelength and the pdf it was drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathWavelength {
    pub lambda: f32,
    pub pdf: f32,
}

/// λ0 of a camera sub-path, from the observer's sampling `mode` (eq. 6.4; sampler: one value).
#[inline]
pub fn camera_wavelength(
    scene: &Scene,
    mode: CameraWavelengths,
    sampler: &mut Sampler,
) -> PathWavelength {
    let (lambda, pdf) = scene.observer.sample_wavelength(mode, sampler.next());
    PathWavelength { lambda, pdf }
}

/// The wavelength light `light` emits a light sub-path, a fresh next-event light point or the
/// backward reset's emitter with, from its emission spectrum or uniformly (`mode`, eq. 6.5;
/// sampler: one value). The one place a light wavelength is drawn.
#[inline]
pub fn light_wavelength(
    scene: &Scene,
    light: u32,
    mode: LightWavelengths,
    sampler: &mut Sampler,
) -> PathWavelength {
    let u = sampler.next();
    let (lambda, pdf) = scene.lights.sample_wavelength(light as usize, u, mode);
    PathWavelength { lambda, pdf }
}

/// A wavelength as a cache key: its bits, so that a cached value is reused only at exactly the
/// wavelength it was computed at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct LambdaKey(u32);

impl LambdaKey {
    #[inline(always)]
    pub fn of(lambda: f32) -> Self {
        LambdaKey(lambda.to_bits())
    }

    /// The key of a pair of wavelengths (λ_in, λ_out).
    #[inline(always)]
    pub fn pair(lambda_in: f32, lambda_out: f32) -> u64 {
        ((lambda_in.to_bits() as u64) << 32) | lambda_out.to_bits() as u64
    }
}
