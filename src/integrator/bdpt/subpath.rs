//! Camera and light sub-paths of `bdpt-forward`/`bdpt-backward` (Jung Alg. 1 and Alg. 3): the
//! shared geometric walk of `geometric.rs` with per-vertex wavelengths layered on top. Every
//! vertex stores the wavelength on its light side (`lambda_in`) and on its camera side
//! (`lambda_out`); whether the vertex shifted the wavelength is the core vertex's `shift`.

use super::cache::SpectralCache;
use super::geometric::{self, SegmentLog, Step, Walker};
use crate::geometry::Ray;
use crate::geometry::ray::spawn_ray;
use crate::integrator::{Sampler, Stats};
use crate::material::{Bbrrdf, PathSide, ShiftSampling};
use crate::medium::{Medium, Tracking};
use crate::scene::{LightWavelengths, Scene};
use crate::transport::segment::towards;
use crate::transport::spectral::with_spectrum;
use crate::transport::{self, Segment, Travel, travel};

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

/// Sample the wavelength on the far side of a scattering vertex `v` with spectral part `m`
/// (a material, or a medium per unit density) whose near side carries `l` (eq. 6.6 on camera
/// paths, 6.7 on light paths); returns the weight f/p.
#[inline]
fn scatter(
    v: &mut Vertex,
    m: &impl Bbrrdf,
    l: f32,
    (side, shift): (PathSide, ShiftSampling),
    sampler: &mut Sampler,
    spectral: &mut SpectralCache,
) -> f32 {
    v.data = Lambdas {
        lambda_in: l,
        lambda_out: l,
    };
    if !m.is_fluorescent() {
        return spectral.diagonal(v, m, l);
    }
    v.fluorescent = true;
    // decide with P, then sample the absorption (camera) or emission (light) side
    let s = m.sample(l, sampler.next2(), side, shift);
    match side {
        PathSide::Camera => v.data.lambda_in = s.lambda,
        PathSide::Light => v.data.lambda_out = s.lambda,
    }
    v.shift = s.fluorescent;
    s.weight()
}

/// The sub-path side of the walk: wavelengths at vertices, free flights at the segment's
/// wavelength with the side's collision coefficients, and the zero-throughput stop.
struct SpectralWalker<'a, const LIGHT: bool> {
    scene: &'a Scene,
    shift: ShiftSampling,
    tracking: Tracking,
    stop_on_zero: bool,
    beta: f32,
    /// Free-flight weight of the segment being traced.
    w: f32,
    /// The diagonals of the materials at the wavelengths last seen (`super::cache`).
    spectral: &'a mut SpectralCache,
}

impl<const LIGHT: bool> SpectralWalker<'_, LIGHT> {
    const SIDE: PathSide = if LIGHT {
        PathSide::Light
    } else {
        PathSide::Camera
    };

    /// The wavelength on the segment leaving the last vertex.
    #[inline]
    fn segment_lambda(&self, v: &Vertex) -> f32 {
        if LIGHT {
            v.data.lambda_out
        } else {
            v.data.lambda_in
        }
    }
}

impl<const LIGHT: bool> Walker<Lambdas> for SpectralWalker<'_, LIGHT> {
    #[inline]
    fn travel(
        &mut self,
        _: u32,
        medium: &Medium,
        ray: &Ray,
        t_max: f32,
        verts: &[Vertex],
        sampler: &mut Sampler,
    ) -> Option<f32> {
        let l = self.segment_lambda(&verts[verts.len() - 1]);
        let mut u = || sampler.next();
        match travel::<f32>(medium, ray, t_max, l, 1, self.tracking, LIGHT, &mut u) {
            Travel::Collision { t, factor, .. } => {
                self.w *= factor;
                Some(t)
            }
            Travel::Pass { factor, .. } => {
                self.w *= factor;
                None
            }
        }
    }

    #[inline]
    fn on_vertex(
        &mut self,
        verts: &mut [Vertex],
        seg: Option<&mut Segment>,
        sampler: &mut Sampler,
    ) -> Step {
        let [.., prev, v] = verts else { unreachable!() };
        let l = self.segment_lambda(prev);
        if let Some(seg) = seg {
            seg.w = self.w;
            seg.lambda = l;
            self.beta *= self.w;
            self.w = 1.0;
        }
        if !v.scatters() {
            v.data = Lambdas {
                lambda_in: l,
                lambda_out: l,
            };
            // Camera paths keep an emitter they hit (t = 0); light paths cannot use it.
            return if LIGHT { Step::Discard } else { Step::Stop };
        }
        let (how, spectral) = ((Self::SIDE, self.shift), &mut *self.spectral);
        let w = with_spectrum!(self.scene, v, m => scatter(v, m, l, how, sampler, spectral),
            else return Step::Discard);
        self.beta *= w;
        if self.stop_on_zero && !(self.beta > 0.0) {
            Step::Stop
        } else {
            Step::Continue
        }
    }

    #[inline]
    fn needs_far(&self) -> bool {
        self.tracking == Tracking::Aware
    }
}

/// Trace a camera sub-path with at most `max_vertices` vertices (x0 included), Jung Alg. 1.
/// At each scattering vertex (surface or medium) the incident wavelength is sampled as a camera
/// path does (eq. 6.6), the last vertex included. With `stop_on_zero` (forward reset: camera
/// wavelengths are final) the path ends when its spectral throughput is zero; otherwise only by
/// depth or escape. `log` (media scenes) receives the segments.
#[allow(clippy::too_many_arguments)]
pub fn camera_subpath(
    scene: &Scene,
    x: f32,
    y: f32,
    lambda0: f32,
    max_vertices: usize,
    shift: ShiftSampling,
    tracking: Tracking,
    stop_on_zero: bool,
    sampler: &mut Sampler,
    stats: &mut Stats,
    out: &mut Vec<Vertex>,
    log: Option<&mut SegmentLog>,
    spectral: &mut SpectralCache,
) {
    out.clear();
    let (mut x0, ray, pdf_dir) = Vertex::camera(scene, x, y);
    x0.data.lambda_in = lambda0;
    x0.data.lambda_out = lambda0;
    out.push(x0);
    let mut walker = SpectralWalker::<false> {
        scene,
        shift,
        tracking,
        stop_on_zero,
        beta: 1.0,
        w: 1.0,
        spectral,
    };
    let mut rays = 0u64;
    let mut log = log;
    if let Some(l) = log.as_deref_mut() {
        l.clear();
    }
    geometric::random_walk(
        scene,
        ray,
        pdf_dir,
        scene.camera_medium,
        out,
        max_vertices,
        sampler,
        &mut rays,
        log,
        &mut walker,
    );
    stats.rays += rays;
}

/// Trace a light sub-path with at most `max_vertices` vertices, Jung Alg. 3: light ∝ power,
/// λ from its emission spectrum (or uniform), cosine emission, and at each scattering vertex the
/// exitant wavelength sampled as a light path does (eq. 6.7). With `stop_on_zero` (backward
/// reset: light wavelengths are final) it ends at zero spectral throughput.
#[allow(clippy::too_many_arguments)]
pub fn light_subpath(
    scene: &Scene,
    max_vertices: usize,
    light_mode: LightWavelengths,
    shift: ShiftSampling,
    tracking: Tracking,
    stop_on_zero: bool,
    sampler: &mut Sampler,
    stats: &mut Stats,
    out: &mut Vec<Vertex>,
    log: Option<&mut SegmentLog>,
    spectral: &mut SpectralCache,
) {
    out.clear();
    let mut log = log;
    if let Some(l) = log.as_deref_mut() {
        l.clear();
    }
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
    let beta = scene.lights[li].spectrum.eval(l);
    out.push(v0);
    if max_vertices == 1 || (stop_on_zero && beta <= 0.0) {
        return;
    }
    let e = scene.lights.sample_le_direction(li, v0.n, sampler.next2());
    let ray = spawn_ray(v0.p, v0.n, e.w);
    let medium = towards(scene.light_media(li), v0.n, e.w);
    let mut walker = SpectralWalker::<true> {
        scene,
        shift,
        tracking,
        stop_on_zero,
        beta,
        w: 1.0,
        spectral,
    };
    let mut rays = 0u64;
    geometric::random_walk(
        scene,
        ray,
        e.pdf_dir,
        medium,
        out,
        max_vertices,
        sampler,
        &mut rays,
        log,
        &mut walker,
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
