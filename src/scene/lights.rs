//! Diffuse area lights on any shape: choose by power, sample a point by area, sample λ from the
//! emission spectrum.

use crate::geometry::{Sphere, Triangle};
use crate::spectrum::{Distribution1D, Domain, Spectrum};
use glam::Vec3;

/// Which primitives carry a light.
#[derive(Clone, Debug)]
pub enum LightShape {
    /// Triangles (indices into the scene's triangle list) with an area CDF.
    Triangles { prims: Vec<u32>, cdf: Vec<f32> },
    Sphere {
        prim: u32,
        sphere: Sphere,
        flip: bool,
    },
}

#[derive(Clone, Debug)]
pub struct AreaLight {
    pub name: String,
    pub shape: LightShape,
    /// Emitted spectral radiance, scale included.
    pub spectrum: Spectrum,
    pub two_sided: bool,
    pub area: f32,
    /// Φ = π · A · ∫ Le dλ (· 2 if two-sided).
    pub power: f64,
    /// λ ∝ Le over the domain.
    pub wavelengths: Distribution1D,
}

/// A sampled point on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    /// Oriented normal (the emitting side for one-sided lights).
    pub n: Vec3,
    pub prim: u32,
    /// Area-measure pdf of the point given this light.
    pub pdf_area: f32,
}

impl AreaLight {
    pub fn new(
        name: String,
        shape: LightShape,
        spectrum: Spectrum,
        two_sided: bool,
        area: f32,
        domain: Domain,
    ) -> Self {
        let integral = spectrum.integral(domain.min, domain.max);
        let power =
            std::f64::consts::PI * area as f64 * integral * if two_sided { 2.0 } else { 1.0 };
        let wavelengths = Distribution1D::from_spectrum(&spectrum, domain, 1.0);
        AreaLight {
            name,
            shape,
            spectrum,
            two_sided,
            area,
            power,
            wavelengths,
        }
    }

    /// Emitted radiance at λ leaving a point with oriented normal `n` in direction `w`.
    #[inline]
    pub fn le(&self, l: f32, n: Vec3, w: Vec3) -> f32 {
        if self.two_sided || n.dot(w) > 0.0 {
            self.spectrum.eval(l)
        } else {
            0.0
        }
    }

    /// Whether light leaves the surface with normal `n` in direction `w` (spectrum aside).
    #[inline]
    pub fn emits_towards(&self, n: Vec3, w: Vec3) -> bool {
        self.two_sided || n.dot(w) > 0.0
    }

    /// Uniform point by area.
    pub fn sample_point(&self, tris: &[Triangle], u: f32, v: [f32; 2]) -> LightPoint {
        match &self.shape {
            LightShape::Triangles { prims, cdf } => {
                let k = cdf.partition_point(|&c| c <= u).min(prims.len() - 1);
                let tri = &tris[prims[k] as usize];
                let p = tri.sample_uniform(v[0], v[1]);
                LightPoint {
                    p,
                    n: tri.normal_raw().normalize(),
                    prim: prims[k],
                    pdf_area: 1.0 / self.area,
                }
            }
            LightShape::Sphere { prim, sphere, flip } => {
                let z = 1.0 - 2.0 * v[0];
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * std::f32::consts::PI * v[1];
                let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                let n = if *flip { -d } else { d };
                LightPoint {
                    p: sphere.center + d * sphere.radius,
                    n,
                    prim: *prim,
                    pdf_area: 1.0 / self.area,
                }
            }
        }
    }

    /// Sample λ from the emission spectrum: (λ, pdf).
    #[inline]
    pub fn sample_wavelength(&self, u: f32) -> (f32, f32) {
        self.wavelengths.sample(u)
    }
    #[inline]
    pub fn pdf_wavelength(&self, l: f32) -> f32 {
        self.wavelengths.pdf(l)
    }
}
