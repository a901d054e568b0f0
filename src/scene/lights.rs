//! Diffuse area lights and light sampling behind one interface, [`LightSet`], with pbrt-v4's
//! four operations: sample and pdf of incident light at a point (`sample_li`, `pdf_li`: next-event
//! estimation and its MIS), and sample and pdf of emission for light paths (`sample_le_*`,
//! `pdf_le_*`). Emission is sampled in two steps, origin then direction, so that a light sub-path
//! can draw its first wavelength in between (Jung Alg. 3). Lights are chosen ∝ power.

use crate::geometry::frame::{sample_cosine_hemisphere, spherical_direction};
use crate::geometry::{Frame, Sphere, Triangle};
use crate::spectrum::{Distribution1D, Domain, Spectrum};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_1_PI, PI};

/// The emitting shape of a light (its own copy of the geometry, so sampling needs no scene).
#[derive(Clone, Debug)]
pub enum LightShape {
    /// Triangles with an area CDF and their unit normals (made once, not per sample).
    Triangles {
        tris: Vec<Triangle>,
        cdf: Vec<f32>,
        normals: Vec<Vec3>,
    },
    Sphere {
        sphere: Sphere,
        flip: bool,
    },
}

impl LightShape {
    /// Triangles `tris` with the area CDF `cdf`.
    pub fn triangles(tris: Vec<Triangle>, cdf: Vec<f32>) -> LightShape {
        let normals = tris.iter().map(|t| t.normal_raw().normalize()).collect();
        LightShape::Triangles { tris, cdf, normals }
    }
}

#[derive(Clone, Debug)]
pub struct AreaLight {
    pub name: String,
    pub shape: LightShape,
    /// Emitted spectral radiance, scale included.
    pub spectrum: Spectrum,
    pub two_sided: bool,
    pub area: f32,
    /// 1 / `area` (the area pdf of a uniform point), divided once here, not per sample.
    inv_area: f32,
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
            inv_area: 1.0 / area,
            power,
            wavelengths,
        }
    }

    /// Emitted radiance at λ leaving a point with oriented normal `n` in direction `w`.
    #[inline]
    pub fn le(&self, l: f32, n: Vec3, w: Vec3) -> f32 {
        if self.emits_towards(n, w) {
            self.spectrum.eval(l)
        } else {
            0.0
        }
    }

    /// Whether light leaves the surface with normal `n` in direction `w` (spectrum aside): the
    /// directional profile of a diffuse emitter is 1 on its emitting sides.
    #[inline]
    pub fn emits_towards(&self, n: Vec3, w: Vec3) -> bool {
        self.two_sided || n.dot(w) > 0.0
    }

    /// Uniform point by area (`u` picks the triangle, `v` the point).
    #[inline(always)]
    pub fn sample_point(&self, u: f32, v: [f32; 2]) -> LightPoint {
        match &self.shape {
            LightShape::Triangles { tris, cdf, normals } => {
                let k = first_above(cdf, u).min(tris.len() - 1);
                LightPoint {
                    p: tris[k].sample_uniform(v[0], v[1]),
                    n: normals[k],
                    pdf_area: self.inv_area,
                }
            }
            LightShape::Sphere { sphere, flip } => {
                let d = spherical_direction(1.0 - 2.0 * v[0], 2.0 * PI * v[1]);
                LightPoint {
                    p: sphere.center + d * sphere.radius,
                    n: if *flip { -d } else { d },
                    pdf_area: self.inv_area,
                }
            }
        }
    }

    /// Solid-angle pdf of emitting direction `w` from the point with normal `n` (cosine lobe on
    /// each emitting side, either side with ½ if two-sided).
    #[inline]
    pub fn pdf_direction(&self, n: Vec3, w: Vec3) -> f32 {
        let c = n.dot(w);
        if self.two_sided {
            c.abs() * 0.5 * FRAC_1_PI
        } else if c > 0.0 {
            c * FRAC_1_PI
        } else {
            0.0
        }
    }
}

/// The number of entries `c <= u` at the start of the non-decreasing `cdf`:
/// `cdf.partition_point(|&c| c <= u)`, by a branch-free count for the short tables of most lights
/// (a quad's two triangles, a scene's few lights), where it is the same index.
#[inline(always)]
fn first_above(cdf: &[f32], u: f32) -> usize {
    if cdf.len() <= 4 {
        cdf.iter().map(|&c| (c <= u) as usize).sum()
    } else {
        cdf.partition_point(|&c| c <= u)
    }
}

named_enum! {
    /// How light sub-paths choose their first wavelength (Jung 6.2.1).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub enum LightWavelengths {
        /// Option 4: ∝ the chosen light's emission spectrum.
        #[default]
        Emission = "emission",
        /// Option 1: uniform over the domain.
        Uniform = "uniform",
    }
}

/// Incident light sampled at a point (next-event estimation).
#[derive(Clone, Copy, Debug)]
pub struct LiSample {
    pub light: usize,
    /// The point on the light and its oriented normal.
    pub p: Vec3,
    pub n: Vec3,
    /// Unit direction from the receiving point towards the light.
    pub wi: Vec3,
    /// Solid-angle pdf at the receiving point (light choice included).
    pub pdf: f32,
}

/// The origin of a light path: a light and a point on it.
#[derive(Clone, Copy, Debug)]
pub struct LightOrigin {
    pub light: usize,
    pub p: Vec3,
    pub n: Vec3,
    /// Area pdf of the point, light choice included.
    pub pdf_pos: f32,
}

/// An emitted direction.
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    pub w: Vec3,
    /// Solid-angle pdf of `w`.
    pub pdf_dir: f32,
    /// Directional profile · |cos θ| / pdf_dir (π, or 2π for a two-sided light).
    pub weight: f32,
}

/// The lights of a scene with power-proportional selection. Derefs to the lights.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    lights: Vec<AreaLight>,
    cdf: Vec<f32>,
    pmf: Vec<f32>,
}

impl std::ops::Deref for LightSet {
    type Target = [AreaLight];
    fn deref(&self) -> &[AreaLight] {
        &self.lights
    }
}

impl<'a> IntoIterator for &'a LightSet {
    type Item = &'a AreaLight;
    type IntoIter = std::slice::Iter<'a, AreaLight>;
    fn into_iter(self) -> Self::IntoIter {
        self.lights.iter()
    }
}

impl LightSet {
    /// Selection ∝ power; the caller makes sure the total power is positive.
    pub fn new(lights: Vec<AreaLight>) -> Self {
        let total: f64 = lights.iter().map(|l| l.power).sum();
        let pmf = lights.iter().map(|l| (l.power / total) as f32).collect();
        let mut acc = 0.0;
        let cdf = lights
            .iter()
            .map(|l| {
                acc += l.power / total;
                acc as f32
            })
            .collect();
        LightSet { lights, cdf, pmf }
    }

    /// Pick a light ∝ power: (index, probability).
    #[inline]
    pub fn choose(&self, u: f32) -> (usize, f32) {
        let i = first_above(&self.cdf, u).min(self.lights.len() - 1);
        (i, self.pmf[i])
    }

    /// Sample light arriving at point `p`: a light ∝ power (`u_light`) and a point on it by area
    /// (`u_point`, `u2`). `None` when the point cannot send light to `p` (back of a one-sided
    /// light, grazing, coincident). Visibility is the caller's.
    #[inline(always)]
    pub fn sample_li(&self, p: Vec3, u_light: f32, u_point: f32, u2: [f32; 2]) -> Option<LiSample> {
        let (li, pmf) = self.choose(u_light);
        let light = &self.lights[li];
        let lp = light.sample_point(u_point, u2);
        let d = lp.p - p;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let wi = d / dist2.sqrt();
        let cos_l = lp.n.dot(-wi);
        if !light.emits_towards(lp.n, -wi) || cos_l == 0.0 {
            return None;
        }
        Some(LiSample {
            light: li,
            p: lp.p,
            n: lp.n,
            wi,
            pdf: pmf * lp.pdf_area * dist2 / cos_l.abs(),
        })
    }

    /// Solid-angle pdf with which [`LightSet::sample_li`] at `from` chooses the point `p` (normal
    /// `n`) of light `light` (for MIS when a scattered ray hits an emitter).
    #[inline]
    pub fn pdf_li(&self, from: Vec3, light: usize, p: Vec3, n: Vec3) -> f32 {
        let d = p - from;
        let dist2 = d.length_squared();
        let cos_l = n.dot(d / dist2.sqrt()).abs();
        if cos_l == 0.0 {
            return f32::INFINITY;
        }
        self.pmf[light] / self.lights[light].area * dist2 / cos_l
    }

    /// The origin of a light path: a light ∝ power and a point by area.
    #[inline]
    pub fn sample_le_origin(&self, u_light: f32, u_point: f32, u2: [f32; 2]) -> LightOrigin {
        let (li, pmf) = self.choose(u_light);
        let lp = self.lights[li].sample_point(u_point, u2);
        LightOrigin {
            light: li,
            p: lp.p,
            n: lp.n,
            pdf_pos: pmf * lp.pdf_area,
        }
    }

    /// Area pdf of [`LightSet::sample_le_origin`] choosing a point of light `light`.
    #[inline]
    pub fn pdf_le_origin(&self, light: usize) -> f32 {
        self.pmf[light] / self.lights[light].area
    }

    /// Cosine emission from a point with normal `n` of light `light` on its emitting side (either
    /// side, chosen with ½, if the light is two-sided).
    #[inline]
    pub fn sample_le_direction(&self, light: usize, n: Vec3, u: [f32; 2]) -> Emission {
        let light = &self.lights[light];
        let mut u = u;
        let mut side_n = n;
        let mut side = 1.0;
        if light.two_sided {
            side = 0.5;
            if u[0] < 0.5 {
                u[0] *= 2.0;
            } else {
                u[0] = (u[0] - 0.5) * 2.0;
                side_n = -n;
            }
            u[0] = u[0].min(1.0 - f32::EPSILON);
        }
        let local = sample_cosine_hemisphere(u[0], u[1]);
        let w = Frame::from_normal(side_n).to_world(local);
        Emission {
            w,
            pdf_dir: light.pdf_direction(n, w),
            weight: PI / side,
        }
    }

    /// Solid-angle pdf of [`LightSet::sample_le_direction`] emitting `w`.
    #[inline]
    pub fn pdf_le_direction(&self, light: usize, n: Vec3, w: Vec3) -> f32 {
        self.lights[light].pdf_direction(n, w)
    }

    /// The first wavelength of a light path from light `light`: (λ, pdf).
    #[inline]
    pub fn sample_wavelength(&self, light: usize, u: f32, mode: LightWavelengths) -> (f32, f32) {
        let l = &self.lights[light];
        match mode {
            LightWavelengths::Emission => l.wavelengths.sample(u),
            LightWavelengths::Uniform => {
                let d = l.wavelengths.domain();
                let x = d.sample_uniform(u);
                (x, d.uniform_pdf(x))
            }
        }
    }

    /// Density of [`LightSet::sample_wavelength`] (eq. 6.5 / option 1).
    #[inline]
    pub fn pdf_wavelength(&self, light: usize, l: f32, mode: LightWavelengths) -> f32 {
        let light = &self.lights[light];
        match mode {
            LightWavelengths::Emission => light.wavelengths.pdf(l),
            LightWavelengths::Uniform => light.wavelengths.domain().uniform_pdf(l),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::frame::integrate_over_sphere;
    use crate::spectrum::DEFAULT_DOMAIN;
    use rand::{Rng, SeedableRng};

    #[test]
    fn first_above_is_the_partition_point_of_a_cdf() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
        for len in 1..=8 {
            for _ in 0..2000 {
                let mut acc = 0.0f32;
                let mut cdf: Vec<f32> = (0..len)
                    .map(|_| {
                        // Some cells of zero mass: repeated values.
                        if rng.random::<f32>() < 0.7 {
                            acc += rng.random::<f32>();
                        }
                        acc
                    })
                    .collect();
                if acc > 0.0 {
                    cdf.iter_mut().for_each(|c| *c /= acc);
                }
                for u in [rng.random::<f32>(), 0.0, 1.0, cdf[0], cdf[len - 1]] {
                    assert_eq!(
                        first_above(&cdf, u),
                        cdf.partition_point(|&c| c <= u),
                        "{cdf:?} {u}"
                    );
                }
            }
        }
    }

    fn quad_light(two_sided: bool) -> AreaLight {
        let (a, b, c, d) = (
            Vec3::new(-1.0, 2.0, -1.0),
            Vec3::new(1.0, 2.0, -1.0),
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(-1.0, 2.0, 1.0),
        );
        let tris = vec![Triangle::new(a, b, c), Triangle::new(a, c, d)];
        let area = 4.0;
        let shape = LightShape::triangles(tris, vec![0.5, 1.0]);
        AreaLight::new(
            "q".into(),
            shape,
            Spectrum::Constant(1.0),
            two_sided,
            area,
            DEFAULT_DOMAIN,
        )
    }

    /// `sample_li` and `pdf_li` agree, and the estimator ∫ Le cos/(pdf) of the irradiance from a
    /// uniform square light converges to the same value as a uniform-area estimate.
    #[test]
    fn sample_li_agrees_with_pdf_li_and_emission_pdfs_integrate_to_one() {
        let set = LightSet::new(vec![quad_light(false), quad_light(true)]);
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let p = Vec3::new(0.3, 0.0, -0.2);
        let mut hits = 0;
        for _ in 0..10_000 {
            let u = (rng.random(), rng.random(), [rng.random(), rng.random()]);
            if let Some(s) = set.sample_li(p, u.0, u.1, u.2) {
                hits += 1;
                let q = set.pdf_li(p, s.light, s.p, s.n);
                assert!((q - s.pdf).abs() <= 1e-4 * s.pdf, "{q} vs {}", s.pdf);
            }
        }
        // The one-sided light faces away from p (normal from its winding): only the two-sided one
        // can be seen.
        assert!(hits > 0);
        for li in 0..2 {
            // ∫ pdf_dir dω = 1 over the sphere.
            let n = Vec3::new(0.0, -1.0, 0.0);
            let integral = integrate_over_sphere(400, |w| set.pdf_le_direction(li, n, w) as f64);
            assert!((integral - 1.0).abs() < 1e-3, "light {li}: {integral}");
            // Sampled directions carry their pdf and the cosine weight.
            for _ in 0..1000 {
                let e = set.sample_le_direction(li, n, [rng.random(), rng.random()]);
                assert!((e.pdf_dir - set.pdf_le_direction(li, n, e.w)).abs() < 1e-5);
                let cos = n.dot(e.w).abs();
                if e.pdf_dir > 1e-3 {
                    assert!((cos / e.pdf_dir - e.weight).abs() < 1e-3 * e.weight);
                }
            }
        }
    }
}
