//! Uni-directional path tracers (Mojzík §6) and the pieces they share: next-event estimation
//! geometry and the BSDF/light MIS.

pub mod hero;
pub mod mono;

pub use hero::PtHero;
pub use mono::PtMono;

use crate::geometry::ray::spawn_ray_to;
use crate::geometry::{Frame, frame::sample_cosine_hemisphere, ray::spawn_ray};
use crate::integrator::{Sampler, Stats};
use crate::scene::{Interaction, Scene};
use glam::Vec3;

/// A sampled connection from a surface point to a point on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightConnection {
    pub light: usize,
    /// Unit direction from the surface towards the light.
    pub wi: Vec3,
    /// |cos| at the receiving surface.
    pub cos_surface: f32,
    /// Solid-angle pdf of this direction under light sampling (selection · area → solid angle).
    pub pdf_solid: f32,
    /// Geometry of the light point, for evaluating Le at any wavelength.
    pub light_n: Vec3,
}

/// Sample a light ∝ power and a point on it as seen from `it`; returns `None` when the point
/// cannot contribute (back side of a one-sided light, below the surface, occluded).
#[inline]
pub fn sample_light_connection(
    scene: &Scene,
    it: &Interaction,
    wo: Vec3,
    sampler: &mut Sampler,
    stats: &mut Stats,
) -> Option<LightConnection> {
    let (li, pmf) = scene.sample_light(sampler.next());
    let light = &scene.lights[li];
    let lp = light.sample_point(&scene.triangles, sampler.next(), sampler.next2());
    let d = lp.p - it.p;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 {
        return None;
    }
    let dist = dist2.sqrt();
    let wi = d / dist;
    // Two-sided diffuse: light must arrive on the side the path leaves from.
    let cos_s = it.n.dot(wi);
    if cos_s * it.n.dot(wo) <= 0.0 {
        return None;
    }
    let cos_l = lp.n.dot(-wi);
    if !light.emits_towards(lp.n, -wi) || cos_l == 0.0 {
        return None;
    }
    let pdf_solid = pmf * lp.pdf_area * dist2 / cos_l.abs();
    stats.rays += 1;
    let (ray, tmax) = spawn_ray_to(it.p, it.n, lp.p, lp.n);
    if scene.occluded(&ray, tmax) {
        return None;
    }
    Some(LightConnection {
        light: li,
        wi,
        cos_surface: cos_s.abs(),
        pdf_solid,
        light_n: lp.n,
    })
}

/// Solid-angle pdf with which light sampling would have chosen the emitter point `hit` seen from
/// `from` (for MIS when a BSDF-sampled ray hits an emitter).
#[inline]
pub fn light_pdf_solid(scene: &Scene, from: Vec3, hit: &Interaction) -> f32 {
    let light = &scene.lights[hit.light as usize];
    let d = hit.p - from;
    let dist2 = d.length_squared();
    let cos_l = hit.n.dot(d / dist2.sqrt()).abs();
    if cos_l == 0.0 {
        return f32::INFINITY;
    }
    scene.light_pmf(hit.light as usize) / light.area * dist2 / cos_l
}

/// Sample the next direction of a diffuse lobe on the side of `wo`: (ray, direction, pdf).
#[inline]
pub fn sample_diffuse(
    it: &Interaction,
    wo: Vec3,
    u: [f32; 2],
) -> (crate::geometry::Ray, Vec3, f32) {
    let n = if it.n.dot(wo) < 0.0 { -it.n } else { it.n };
    let local = sample_cosine_hemisphere(u[0], u[1]);
    let wi = Frame::from_normal(n).to_world(local);
    let pdf = local.z * std::f32::consts::FRAC_1_PI;
    (spawn_ray(it.p, it.n, wi), wi, pdf)
}
