//! Camera and light sub-paths (Jung Alg. 1 and Alg. 3). Every vertex stores the wavelength on
//! its light side (`lambda_in`) and on its camera side (`lambda_out`), whether the vertex shifted
//! the wavelength, and the area-measure pdfs of being generated in both directions (as pbrt-v4).

use crate::geometry::Frame;
use crate::geometry::frame::sample_cosine_hemisphere;
use crate::geometry::ray::spawn_ray;
use crate::integrator::pt::sample_diffuse;
use crate::integrator::{LightWavelengths, Sampler, Stats};
use crate::material::{Bbrrdf, Material, WavelengthSampling};
use crate::scene::{NONE, Scene};
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VertexKind {
    /// The pinhole x0.
    Camera,
    /// The first vertex of a light sub-path (or a fresh NEE vertex), on an emitter.
    Light,
    /// A surface hit.
    #[default]
    Surface,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct Vertex {
    pub p: Vec3,
    /// Geometric normal (camera: forward axis; light: oriented emitting normal).
    pub n: Vec3,
    pub kind: VertexKind,
    pub material: u32,
    pub light: u32,
    /// Wavelength arriving from the light side (λ_i at x_i).
    pub lambda_in: f32,
    /// Wavelength leaving toward the camera side (λ_{i-1} at x_i).
    pub lambda_out: f32,
    /// Whether `lambda_in != lambda_out` was sampled (a fluorescent interaction).
    pub shift: bool,
    /// Area pdf of this vertex given its predecessor on its own sub-path.
    pub pdf_fwd: f32,
    /// Area pdf of this vertex sampled from its successor on its own sub-path (the reverse
    /// direction); set when the successor is generated.
    pub pdf_rev: f32,
}

/// Reverse area pdf at `prev` when sampled from the diffuse vertex at `at` (cosine lobe).
#[inline]
fn diffuse_area_pdf(at_n: Vec3, prev_n: Vec3, dir: Vec3, dist2: f32) -> f32 {
    at_n.dot(dir).abs() * FRAC_1_PI * prev_n.dot(dir).abs() / dist2
}

/// Trace a camera sub-path with at most `max_vertices` vertices (x0 included), Jung Alg. 1.
/// At each surface the incident wavelength is sampled as a camera path does (eq. 6.6), the last
/// vertex included. With `stop_on_zero` (forward reset: camera wavelengths are final) the path
/// ends when its spectral throughput is zero; otherwise only by depth or escape.
#[allow(clippy::too_many_arguments)]
pub fn camera_subpath(
    scene: &Scene,
    x: f32,
    y: f32,
    lambda0: f32,
    max_vertices: usize,
    mode: WavelengthSampling,
    stop_on_zero: bool,
    sampler: &mut Sampler,
    stats: &mut Stats,
    out: &mut Vec<Vertex>,
) {
    out.clear();
    let cam = &scene.camera;
    let mut ray = cam.generate_ray(x, y);
    out.push(Vertex {
        p: cam.origin,
        n: cam.forward,
        kind: VertexKind::Camera,
        material: NONE,
        light: NONE,
        lambda_in: lambda0,
        lambda_out: lambda0,
        pdf_fwd: 1.0,
        ..Default::default()
    });
    let mut pdf_dir = cam.pdf_dir(ray.d.dot(cam.forward));
    let mut beta = 1.0f32;
    while out.len() < max_vertices {
        stats.rays += 1;
        let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
            break;
        };
        let d2 = it.t * it.t;
        let lambda_out = out.last().unwrap().lambda_in;
        let mut v = Vertex {
            p: it.p,
            n: it.n,
            kind: VertexKind::Surface,
            material: it.material,
            light: it.light,
            lambda_in: lambda_out,
            lambda_out,
            shift: false,
            pdf_fwd: pdf_dir * it.n.dot(ray.d).abs() / d2,
            pdf_rev: 0.0,
        };
        let prev = out.len() - 1;
        if out[prev].kind == VertexKind::Surface {
            out[prev].pdf_rev = diffuse_area_pdf(it.n, out[prev].n, ray.d, d2);
        }
        if it.material == NONE {
            out.push(v);
            break;
        }
        let m: &Material = &scene.materials[it.material as usize];
        if m.is_fluorescent() {
            // eq. 6.6: decide with P_c, then sample the absorption side
            let s = m.sample_wavelength_camera(lambda_out, sampler.next2(), mode);
            v.lambda_in = s.lambda;
            v.shift = s.shifted;
            beta *= s.weight;
        } else {
            beta *= m.diagonal(lambda_out);
        }
        out.push(v);
        if stop_on_zero && beta <= 0.0 {
            break;
        }
        let wo = -ray.d;
        let (next, _wi, pdf) = sample_diffuse(&it, wo, sampler.next2());
        ray = next;
        pdf_dir = pdf;
    }
}

/// Light wavelength pdf of a light sub-path's first wavelength (eq. 6.5 / option 1).
#[inline]
pub fn light_lambda_pdf(scene: &Scene, light: usize, l: f32, mode: LightWavelengths) -> f32 {
    match mode {
        LightWavelengths::Emission => scene.lights[light].pdf_wavelength(l),
        LightWavelengths::Uniform => {
            if scene.domain.contains(l) {
                1.0 / scene.domain.width()
            } else {
                0.0
            }
        }
    }
}

/// Sample a light sub-path's first wavelength: (λ, pdf).
#[inline]
pub fn sample_light_lambda(
    scene: &Scene,
    light: usize,
    u: f32,
    mode: LightWavelengths,
) -> (f32, f32) {
    match mode {
        LightWavelengths::Emission => scene.lights[light].sample_wavelength(u),
        LightWavelengths::Uniform => (
            scene.domain.min + u * scene.domain.width(),
            1.0 / scene.domain.width(),
        ),
    }
}

/// A light vertex chosen by power and a point by area (no wavelength yet).
#[inline]
pub fn sample_light_vertex(scene: &Scene, sampler: &mut Sampler) -> Vertex {
    let (li, pmf) = scene.sample_light(sampler.next());
    let light = &scene.lights[li];
    let lp = light.sample_point(&scene.triangles, sampler.next(), sampler.next2());
    Vertex {
        p: lp.p,
        n: lp.n,
        kind: VertexKind::Light,
        material: NONE,
        light: li as u32,
        pdf_fwd: pmf * lp.pdf_area,
        ..Default::default()
    }
}

/// Solid-angle pdf of emitting direction `w` from a diffuse area light with normal `n`.
#[inline]
pub fn emission_pdf_dir(two_sided: bool, n: Vec3, w: Vec3) -> f32 {
    let c = n.dot(w);
    if two_sided {
        c.abs() * 0.5 * FRAC_1_PI
    } else if c > 0.0 {
        c * FRAC_1_PI
    } else {
        0.0
    }
}

/// Trace a light sub-path with at most `max_vertices` vertices, Jung Alg. 3: light ∝ power,
/// λ from its emission spectrum (or uniform), cosine emission, and at each surface the exitant
/// wavelength sampled as a light path does (eq. 6.7). With `stop_on_zero` (backward reset: light
/// wavelengths are final) it ends at zero spectral throughput.
#[allow(clippy::too_many_arguments)]
pub fn light_subpath(
    scene: &Scene,
    max_vertices: usize,
    light_mode: LightWavelengths,
    mode: WavelengthSampling,
    stop_on_zero: bool,
    sampler: &mut Sampler,
    stats: &mut Stats,
    out: &mut Vec<Vertex>,
) {
    out.clear();
    if max_vertices == 0 || scene.lights.is_empty() {
        return;
    }
    let mut v0 = sample_light_vertex(scene, sampler);
    let light = &scene.lights[v0.light as usize];
    let (l, _) = sample_light_lambda(scene, v0.light as usize, sampler.next(), light_mode);
    v0.lambda_in = l;
    v0.lambda_out = l;
    let mut beta = light.spectrum.eval(l);
    out.push(v0);
    if max_vertices == 1 || (stop_on_zero && beta <= 0.0) {
        return;
    }
    // Cosine emission on the emitting side (either side, chosen with ½, if two-sided).
    let mut u = sampler.next2();
    let mut n = v0.n;
    if light.two_sided {
        if u[0] < 0.5 {
            u[0] *= 2.0;
        } else {
            u[0] = (u[0] - 0.5) * 2.0;
            n = -n;
        }
        u[0] = u[0].min(1.0 - f32::EPSILON);
    }
    let local = sample_cosine_hemisphere(u[0], u[1]);
    let d = Frame::from_normal(n).to_world(local);
    let mut pdf_dir = emission_pdf_dir(light.two_sided, v0.n, d);
    let mut ray = spawn_ray(v0.p, v0.n, d);
    while out.len() < max_vertices {
        stats.rays += 1;
        let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
            break;
        };
        let d2 = it.t * it.t;
        let lambda_in = out.last().unwrap().lambda_out;
        let mut v = Vertex {
            p: it.p,
            n: it.n,
            kind: VertexKind::Surface,
            material: it.material,
            light: it.light,
            lambda_in,
            lambda_out: lambda_in,
            shift: false,
            pdf_fwd: pdf_dir * it.n.dot(ray.d).abs() / d2,
            pdf_rev: 0.0,
        };
        let prev = out.len() - 1;
        out[prev].pdf_rev = diffuse_area_pdf(it.n, out[prev].n, ray.d, d2);
        if it.material == NONE {
            // Black: cannot scatter or connect.
            break;
        }
        let m: &Material = &scene.materials[it.material as usize];
        if m.is_fluorescent() {
            // eq. 6.7: decide with P_l, then sample the emission side
            let s = m.sample_wavelength_light(lambda_in, sampler.next2(), mode);
            v.lambda_out = s.lambda;
            v.shift = s.shifted;
            beta *= s.weight;
        } else {
            beta *= m.diagonal(lambda_in);
        }
        out.push(v);
        if stop_on_zero && beta <= 0.0 {
            break;
        }
        let (next, _wi, pdf) = sample_diffuse(&it, -ray.d, sampler.next2());
        ray = next;
        pdf_dir = pdf;
    }
}
