//! Visibility and transmittance between two path vertices: the one function that next-event
//! estimation, BDPT connections and all-bins connections call. Without participating media a
//! segment is either blocked (transmittance 0) or clear (1); media will attenuate it per
//! wavelength here, and every caller already multiplies by the result.

use crate::geometry::ray::spawn_ray_to;
use crate::scene::Scene;
use crate::spectrum::Lanes;
use glam::Vec3;

/// An end of a segment: a point and the geometric normal its ray is offset along (zero where
/// there is no surface, as at the pinhole).
#[derive(Clone, Copy, Debug)]
pub struct Endpoint {
    pub p: Vec3,
    pub n: Vec3,
}

/// The transmittance of a segment, evaluated at any wavelength.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transmittance {
    blocked: bool,
}

impl Transmittance {
    /// True when no light passes at any wavelength.
    #[inline]
    pub fn is_zero(&self) -> bool {
        self.blocked
    }

    /// T(λ).
    #[inline]
    pub fn at(&self, _l: f32) -> f32 {
        if self.blocked { 0.0 } else { 1.0 }
    }

    /// T at every lane of `lambda` (the first `n`).
    #[inline]
    pub fn at_lanes<L: Lanes>(&self, n: usize, _lambda: L) -> L {
        L::splat_n(n, if self.blocked { 0.0 } else { 1.0 })
    }
}

/// Transmittance from `a` to `b`; the shadow ray starts at `a` and is counted in `rays`.
///
/// Always inlined: called, its two endpoints went through memory and were loaded back in wider
/// pieces than they were stored, which stalls (pt-hero on cornell-box 1.09× faster inlined).
#[inline(always)]
pub fn transmittance(scene: &Scene, a: Endpoint, b: Endpoint, rays: &mut u64) -> Transmittance {
    *rays += 1;
    let (ray, tmax) = spawn_ray_to(a.p, a.n, b.p, b.n);
    Transmittance {
        blocked: scene.occluded(&ray, tmax),
    }
}
