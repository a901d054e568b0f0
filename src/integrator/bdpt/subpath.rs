//! Camera and light sub-paths of `bdpt-forward`/`bdpt-backward` (Jung Alg. 1 and Alg. 3): the
//! shared geometric walk of `geometric.rs` with per-vertex wavelengths layered on top. Every
//! vertex stores the wavelength on its light side (`lambda_in`) and on its camera side
//! (`lambda_out`); whether the vertex shifted the wavelength is the core vertex's `shift`.

use super::geometric::{self, Step};
use crate::integrator::{LightWavelengths, Sampler, Stats};
use crate::material::{Bbrrdf, Material, WavelengthSampling};
use crate::scene::{NONE, Scene};

pub use super::geometric::{VertexKind, emission_pdf_dir};

/// The wavelength payload of a bdpt-forward/backward vertex.
#[derive(Clone, Copy, Debug, Default)]
pub struct Lambdas {
    /// Wavelength arriving from the light side (λ_i at x_i).
    pub lambda_in: f32,
    /// Wavelength leaving toward the camera side (λ_{i-1} at x_i).
    pub lambda_out: f32,
}

/// A sub-path vertex: geometry and area pdfs (shared core) plus wavelengths.
pub type Vertex = geometric::Vertex<Lambdas>;

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
            v.data = Lambdas {
                lambda_in: lambda_out,
                lambda_out,
            };
            if v.material == NONE {
                return Step::Stop;
            }
            let m: &Material = &scene.materials[v.material as usize];
            if m.is_fluorescent() {
                // eq. 6.6: decide with P_c, then sample the absorption side
                let s = m.sample_wavelength_camera(lambda_out, sampler.next2(), mode);
                v.data.lambda_in = s.lambda;
                v.shift = s.shifted;
                beta *= s.weight;
            } else {
                beta *= m.diagonal(lambda_out);
            }
            if stop_on_zero && beta <= 0.0 {
                Step::Stop
            } else {
                Step::Continue
            }
        },
    );
    stats.rays += rays;
}
/// Light wavelength pdf of a light sub-path's first wavelength (eq. 6.5 / option 1).
#[inline]
pub fn light_lambda_pdf(scene: &Scene, light: usize, l: f32, mode: LightWavelengths) -> f32 {
    match mode {
        LightWavelengths::Emission => scene.lights[light].pdf_wavelength(l),
        LightWavelengths::Uniform => scene.domain.uniform_pdf(l),
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
        LightWavelengths::Uniform => {
            let l = scene.domain.sample_uniform(u);
            (l, scene.domain.uniform_pdf(l))
        }
    }
}

/// A light vertex chosen by power and a point by area (no wavelength yet).
#[inline]
pub fn sample_light_vertex(scene: &Scene, sampler: &mut Sampler) -> Vertex {
    geometric::sample_light_vertex(scene, sampler)
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
    v0.data.lambda_in = l;
    v0.data.lambda_out = l;
    let mut beta = light.spectrum.eval(l);
    out.push(v0);
    if max_vertices == 1 || (stop_on_zero && beta <= 0.0) {
        return;
    }
    let (ray, pdf_dir) = geometric::sample_emission(scene, &v0, sampler);
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
            if v.material == NONE {
                // Black: cannot scatter or connect.
                return Step::Discard;
            }
            let lambda_in = prev.data.lambda_out;
            v.data = Lambdas {
                lambda_in,
                lambda_out: lambda_in,
            };
            let m: &Material = &scene.materials[v.material as usize];
            if m.is_fluorescent() {
                // eq. 6.7: decide with P_l, then sample the emission side
                let s = m.sample_wavelength_light(lambda_in, sampler.next2(), mode);
                v.data.lambda_out = s.lambda;
                v.shift = s.shifted;
                beta *= s.weight;
            } else {
                beta *= m.diagonal(lambda_in);
            }
            if stop_on_zero && beta <= 0.0 {
                Step::Stop
            } else {
                Step::Continue
            }
        },
    );
    stats.rays += rays;
}
