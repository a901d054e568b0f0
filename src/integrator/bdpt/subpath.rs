//! Camera and light sub-paths of `bdpt-forward`/`bdpt-backward` (Jung Alg. 1 and Alg. 3): the
//! shared geometric walk of `geometric.rs` with per-vertex wavelengths layered on top. Every
//! vertex stores the wavelength on its light side (`lambda_in`) and on its camera side
//! (`lambda_out`); whether the vertex shifted the wavelength is the core vertex's `shift`.

use super::geometric::{self, Step};
use crate::geometry::ray::spawn_ray;
use crate::integrator::{Sampler, Stats};
use crate::material::{Bbrrdf, Material, PathSide, ShiftSampling};
use crate::scene::{LightWavelengths, NONE, Scene};
use crate::transport;

/// The wavelength payload of a bdpt-forward/backward vertex.
#[derive(Clone, Copy, Debug, Default)]
pub struct Lambdas {
    /// Wavelength arriving from the light side (λ_i at x_i).
    pub lambda_in: f32,
    /// Wavelength leaving toward the camera side (λ_{i-1} at x_i).
    pub lambda_out: f32,
}

/// A sub-path vertex: geometry and area pdfs (transport layer) plus wavelengths.
pub type Vertex = transport::Vertex<Lambdas>;

/// Sample the wavelength on the far side of a scattering vertex `v` of material `m` whose near
/// side carries `l` (eq. 6.6 on camera paths, 6.7 on light paths); returns the weight f/p.
#[inline]
fn scatter(
    v: &mut Vertex,
    m: &Material,
    l: f32,
    side: PathSide,
    shift: ShiftSampling,
    sampler: &mut Sampler,
) -> f32 {
    v.data = Lambdas {
        lambda_in: l,
        lambda_out: l,
    };
    if !m.is_fluorescent() {
        return m.diagonal(l);
    }
    // decide with P, then sample the absorption (camera) or emission (light) side
    let s = m.sample(l, sampler.next2(), side, shift);
    match side {
        PathSide::Camera => v.data.lambda_in = s.lambda,
        PathSide::Light => v.data.lambda_out = s.lambda,
    }
    v.shift = s.fluorescent;
    s.weight()
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
    shift: ShiftSampling,
    stop_on_zero: bool,
    sampler: &mut Sampler,
    stats: &mut Stats,
    out: &mut Vec<Vertex>,
) {
    out.clear();
    let (mut x0, ray, pdf_dir) = Vertex::camera(scene, x, y);
    x0.data.lambda_in = lambda0;
    x0.data.lambda_out = lambda0;
    out.push(x0);
    let mut beta = 1.0f32;
    let mut rays = 0u64;
    geometric::random_walk(
        scene,
        ray,
        pdf_dir,
        out,
        max_vertices,
        sampler,
        &mut rays,
        |verts, sampler| {
            let [.., prev, v] = verts else { unreachable!() };
            let lambda_out = prev.data.lambda_in;
            if v.material == NONE {
                v.data = Lambdas {
                    lambda_in: lambda_out,
                    lambda_out,
                };
                return Step::Stop;
            }
            let m: &Material = &scene.materials[v.material as usize];
            beta *= scatter(v, m, lambda_out, PathSide::Camera, shift, sampler);
            if stop_on_zero && beta <= 0.0 {
                Step::Stop
            } else {
                Step::Continue
            }
        },
    );
    stats.rays += rays;
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
    shift: ShiftSampling,
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
    let li = v0.light as usize;
    let (l, _) = scene
        .lights
        .sample_wavelength(li, sampler.next(), light_mode);
    v0.data.lambda_in = l;
    v0.data.lambda_out = l;
    let mut beta = scene.lights[li].spectrum.eval(l);
    out.push(v0);
    if max_vertices == 1 || (stop_on_zero && beta <= 0.0) {
        return;
    }
    let e = scene.lights.sample_le_direction(li, v0.n, sampler.next2());
    let ray = spawn_ray(v0.p, v0.n, e.w);
    let mut rays = 0u64;
    geometric::random_walk(
        scene,
        ray,
        e.pdf_dir,
        out,
        max_vertices,
        sampler,
        &mut rays,
        |verts, sampler| {
            let [.., prev, v] = verts else { unreachable!() };
            if v.material == NONE {
                // Black: cannot scatter or connect.
                return Step::Discard;
            }
            let m: &Material = &scene.materials[v.material as usize];
            beta *= scatter(v, m, prev.data.lambda_out, PathSide::Light, shift, sampler);
            if stop_on_zero && beta <= 0.0 {
                Step::Stop
            } else {
                Step::Continue
            }
        },
    );
    stats.rays += rays;
}

/// A light vertex: a light chosen by power and a point by area, with `pdf_fwd` their product
/// (sampler: one value for the light, three for the point). No wavelength yet.
#[inline]
pub fn sample_light_vertex(scene: &Scene, sampler: &mut Sampler) -> Vertex {
    let (ul, up, u2) = (sampler.next(), sampler.next(), sampler.next2());
    Vertex::light(&scene.lights.sample_le_origin(ul, up, u2))
}
