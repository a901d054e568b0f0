//! Directional scattering at a path vertex behind one small interface: a surface's diffuse lobe
//! today, a medium's Henyey–Greenstein phase function next. The directional part never depends on
//! wavelength, so a path's geometry is independent of its wavelengths (docs/design.md §3.1).
//!
//! Convention (pbrt-v4): `wo` and `wi` are unit vectors pointing away from the vertex, `wo`
//! towards where the path came from and `wi` towards where it goes. `pdf(wo, wi)` is the
//! solid-angle density of sampling `wi` given `wo`; the reverse direction is `pdf(wi, wo)`.

use crate::geometry::Frame;
use crate::geometry::frame::{sample_cosine_hemisphere, spherical_direction};
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// The directional part of scattering at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scattering {
    /// Two-sided Lambertian reflection about the geometric normal `n` (every material of
    /// stokes): f = 1/π when both directions lie on the same side, 0 otherwise.
    Diffuse { n: Vec3 },
    /// Henyey–Greenstein phase function with mean cosine `g` in (−1, 1) (medium vertices).
    HenyeyGreenstein { g: f32 },
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionSample {
    pub wi: Vec3,
    /// f(wo, wi), without the cosine.
    pub f: f32,
    /// Solid-angle pdf of `wi`.
    pub pdf: f32,
    /// f · |cos θi| / pdf: exactly 1 for both lobes, which are sampled in proportion to it.
    pub weight: f32,
}

/// The Henyey–Greenstein phase function (Henyey & Greenstein 1941) of μ = wo·wi (both pointing away from the vertex):
/// p = (1 − g²) / (4π (1 + g² + 2gμ)^{3/2}); forward scattering is μ = −1.
#[inline]
pub fn henyey_greenstein(mu: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g + 2.0 * g * mu;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(0.0).sqrt())
}

/// f of the diffuse lobe (without the cosine) where it joins its two directions.
pub const DIFFUSE_F: f32 = FRAC_1_PI;

/// Whether the diffuse lobe joins two directions whose cosines to the normal are `cos_o` and
/// `cos_i`: both on one side of the surface.
#[inline(always)]
pub fn diffuse_joins(cos_o: f32, cos_i: f32) -> bool {
    cos_o * cos_i > 0.0
}

/// f of the diffuse lobe without the cosine, from the cosines n·wo and n·wi of its two
/// directions: [`DIFFUSE_F`] where it joins them, else 0.
#[inline(always)]
pub fn diffuse_f(cos_o: f32, cos_i: f32) -> f32 {
    if diffuse_joins(cos_o, cos_i) {
        DIFFUSE_F
    } else {
        0.0
    }
}

/// Solid-angle pdf of the diffuse lobe's cosine-weighted sampling of wi given wo, from the
/// cosines n·wo and n·wi: [`diffuse_pdf_joined`] where it joins them, else 0.
#[inline(always)]
pub fn diffuse_pdf(cos_o: f32, cos_i: f32) -> f32 {
    if diffuse_joins(cos_o, cos_i) {
        diffuse_pdf_joined(cos_i)
    } else {
        0.0
    }
}

/// [`diffuse_pdf`] of directions the lobe is known to join: |cos θi| / π.
#[inline(always)]
pub fn diffuse_pdf_joined(cos_i: f32) -> f32 {
    cos_i.abs() * FRAC_1_PI
}

impl Scattering {
    /// f(wo, wi) without the cosine.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            Scattering::Diffuse { n } => diffuse_f(n.dot(wo), n.dot(wi)),
            Scattering::HenyeyGreenstein { g } => henyey_greenstein(wo.dot(wi), g),
        }
    }

    /// Solid-angle pdf of [`Scattering::sample`] choosing `wi` given `wo`.
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            Scattering::Diffuse { n } => diffuse_pdf(n.dot(wo), n.dot(wi)),
            Scattering::HenyeyGreenstein { g } => henyey_greenstein(wo.dot(wi), g),
        }
    }

    /// [`Scattering::eval`] and [`Scattering::pdf`] at once, given also the cosines n·wo and
    /// n·wi of the two directions, which a lobe that depends on nothing else (the diffuse lobe)
    /// uses instead of the directions: connections that have the cosines at hand save the dot
    /// products.
    #[inline(always)]
    pub fn eval_pdf_with_cosines(
        &self,
        (wo, cos_o): (Vec3, f32),
        (wi, cos_i): (Vec3, f32),
    ) -> (f32, f32) {
        match *self {
            Scattering::Diffuse { .. } => {
                if diffuse_joins(cos_o, cos_i) {
                    (DIFFUSE_F, diffuse_pdf_joined(cos_i))
                } else {
                    (0.0, 0.0)
                }
            }
            Scattering::HenyeyGreenstein { g } => {
                let p = henyey_greenstein(wo.dot(wi), g);
                (p, p)
            }
        }
    }

    /// The projected-solid-angle factor |cos θ| of direction `w` at the vertex: the normal's
    /// cosine on a surface, 1 in a medium.
    #[inline(always)]
    pub fn abs_cos(&self, w: Vec3) -> f32 {
        match *self {
            Scattering::Diffuse { n } => n.dot(w).abs(),
            Scattering::HenyeyGreenstein { .. } => 1.0,
        }
    }

    /// Sample `wi` given `wo` from two uniform numbers: cosine-weighted on the side of `wo`
    /// (diffuse), or by inverting the Henyey–Greenstein CDF in μ.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, u: [f32; 2]) -> DirectionSample {
        match *self {
            Scattering::Diffuse { n } => {
                let n = if n.dot(wo) < 0.0 { -n } else { n };
                let local = sample_cosine_hemisphere(u[0], u[1]);
                DirectionSample {
                    wi: Frame::from_normal(n).to_world(local),
                    f: FRAC_1_PI,
                    pdf: local.z * FRAC_1_PI,
                    weight: 1.0,
                }
            }
            Scattering::HenyeyGreenstein { g } => sample_henyey_greenstein(wo, g, u),
        }
    }
}

/// Sample the Henyey–Greenstein phase function about `wo` by inverting its CDF in μ:
/// F(μ) = (1 − g²)/(2g) · (1/(1 − g) − (1 + g² + 2gμ)^{−1/2}) = u, uniform μ when g ≈ 0.
fn sample_henyey_greenstein(wo: Vec3, g: f32, u: [f32; 2]) -> DirectionSample {
    let mu = if g.abs() < 1e-3 {
        1.0 - 2.0 * u[0]
    } else {
        let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u[0]);
        (-(1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let local = spherical_direction(mu, 2.0 * PI * u[1]);
    let p = henyey_greenstein(mu, g);
    DirectionSample {
        wi: Frame::from_normal(wo).to_world(local),
        f: p,
        pdf: p,
        weight: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::frame::integrate_over_sphere;
    use rand::{Rng, SeedableRng};

    fn lobes() -> Vec<Scattering> {
        vec![
            Scattering::Diffuse {
                n: Vec3::new(0.3, 0.9, -0.1).normalize(),
            },
            Scattering::HenyeyGreenstein { g: 0.0 },
            Scattering::HenyeyGreenstein { g: 0.7 },
            Scattering::HenyeyGreenstein { g: -0.4 },
            Scattering::HenyeyGreenstein { g: 0.95 },
        ]
    }

    #[test]
    fn pdf_integrates_to_one() {
        let wo = Vec3::new(0.2, 0.5, 0.8).normalize();
        for lobe in lobes() {
            for wo in [wo, -wo] {
                let integral = integrate_over_sphere(600, |wi| lobe.pdf(wo, wi) as f64);
                assert!((integral - 1.0).abs() < 2e-3, "{lobe:?}: ∫pdf = {integral}");
            }
        }
    }

    /// Samples fall into 16 × 16 (cos θ, φ) cells about the lobe's own axis as the pdf says
    /// (χ² test with the cells' expected counts from the pdf), and each sample reports the pdf,
    /// value and weight that `pdf` and `eval` give.
    #[test]
    fn samples_follow_the_pdf() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let wo = Vec3::new(-0.4, 0.1, 0.9).normalize();
        for lobe in lobes() {
            // Cells are measured in a frame around the normal (diffuse) or wo (phase).
            let axis = match lobe {
                Scattering::Diffuse { n } => n,
                Scattering::HenyeyGreenstein { .. } => wo,
            };
            let frame = Frame::from_normal(axis);
            let to_local = |w: Vec3| Vec3::new(w.dot(frame.s), w.dot(frame.t), w.dot(frame.n));
            let (nz, np) = (16usize, 16usize);
            let n = 400_000;
            let mut hist = vec![0u32; nz * np];
            for _ in 0..n {
                let s = lobe.sample(wo, [rng.random(), rng.random()]);
                assert!((s.wi.length() - 1.0).abs() < 1e-4);
                let p = lobe.pdf(wo, s.wi);
                assert!((p - s.pdf).abs() <= 2e-3 * p, "{lobe:?}: {p} vs {}", s.pdf);
                assert!((lobe.eval(wo, s.wi) - s.f).abs() <= 2e-3 * s.f);
                let w = s.f * lobe.abs_cos(s.wi) / s.pdf;
                assert!((w - s.weight).abs() < 2e-3, "{lobe:?}: weight {w}");
                let l = to_local(s.wi);
                let iz = (((l.z + 1.0) * 0.5 * nz as f32) as usize).min(nz - 1);
                let phi = l.y.atan2(l.x).rem_euclid(2.0 * PI);
                let ip = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
                hist[iz * np + ip] += 1;
            }
            let mut chi2 = 0.0f64;
            let mut dof = 0;
            for iz in 0..nz {
                for ip in 0..np {
                    // Expected mass of the cell by a midpoint rule, fine in cos θ (both lobes are
                    // symmetric about the axis, but the phase function peaks sharply in cos θ).
                    let (kz, kp) = (256, 2);
                    let mut mass = 0.0f64;
                    for a in 0..kz {
                        let z = -1.0 + (iz as f32 + (a as f32 + 0.5) / kz as f32) * 2.0 / nz as f32;
                        for b in 0..kp {
                            let phi =
                                (ip as f32 + (b as f32 + 0.5) / kp as f32) * 2.0 * PI / np as f32;
                            mass +=
                                lobe.pdf(wo, frame.to_world(spherical_direction(z, phi))) as f64;
                        }
                    }
                    let k2 = (kz * kp) as f64;
                    let cell = (2.0 / nz as f64) * (2.0 * std::f64::consts::PI / np as f64);
                    let e = mass / k2 * cell * n as f64;
                    let h = hist[iz * np + ip] as f64;
                    if e >= 5.0 {
                        chi2 += (h - e) * (h - e) / e;
                        dof += 1;
                    } else {
                        assert!(
                            h <= e + 5.0 * e.max(1.0).sqrt() + 5.0,
                            "{lobe:?} cell {iz},{ip}: {h} vs {e}"
                        );
                    }
                }
            }
            // χ² with `dof` degrees of freedom: mean dof, sd √(2 dof); allow 5 sd.
            let bound = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
            assert!(
                chi2 < bound,
                "{lobe:?}: χ² = {chi2:.1} over {dof} cells (bound {bound:.1})"
            );
        }
    }

    #[test]
    fn diffuse_is_two_sided_and_reciprocal() {
        let lobe = Scattering::Diffuse { n: Vec3::Z };
        let (a, b) = (Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, -0.6, 0.8));
        assert_eq!(lobe.eval(a, b), FRAC_1_PI);
        assert_eq!(lobe.eval(-a, -b), FRAC_1_PI);
        assert_eq!(lobe.eval(a, -b), 0.0);
        assert_eq!(lobe.pdf(a, b), lobe.pdf(-a, -b));
        assert!((lobe.pdf(a, b) - 0.8 * FRAC_1_PI).abs() < 1e-7);
        let hg = Scattering::HenyeyGreenstein { g: 0.5 };
        assert_eq!(hg.eval(a, b), hg.eval(b, a));
        // Forward scattering (wi = −wo) dominates for g > 0.
        assert!(hg.pdf(a, -a) > hg.pdf(a, a));
    }
}
