//! Camera and light sub-paths of `bdpt-forward`/`bdpt-backward` (Jung Alg. 1 and Alg. 3): the
//! shared geometric walk of `geometric.rs` with per-vertex wavelengths layered on top. Every
//! vertex stores the wavelength on its light side (`lambda_in`) and on its camera side
//! (`lambda_out`); whether the vertex shifted the wavelength is the core vertex's `shift`.

use super::cache::SpectralCache;
use super::geometric::{self, SegmentLog, Start, Step, Trace, Walker};
use super::wavelength::light_wavelength;
use crate::geometry::Ray;
use crate::integrator::{Sampler, Stats};
use crate::material::{Bbrrdf, PathSide, ShiftSampling};
use crate::medium::{Medium, Tracking};
use crate::scene::{LightWavelengths, Scene};
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

impl Lambdas {
    /// The same wavelength on both sides (a vertex that does not shift, or an end).
    #[inline(always)]
    pub fn both(lambda: f32) -> Self {
        Lambdas {
            lambda_in: lambda,
            lambda_out: lambda,
        }
    }
}

/// A sub-path vertex: geometry and area pdfs (transport layer) plus wavelengths.
pub type Vertex = transport::Vertex<Lambdas>;

/// Sample the wavelength on the far side of a scattering vertex `v` with spectral part `m`
/// (a material, or a medium per unit density) whose near side carries `lambda` (eq. 6.6 on camera
/// paths, 6.7 on light paths); returns the weight f/p.
#[inline]
fn scatter(
    v: &mut Vertex,
    m: &impl Bbrrdf,
    lambda: f32,
    (side, shift): (PathSide, ShiftSampling),
    sampler: &mut Sampler,
    spectral: &mut SpectralCache,
) -> f32 {
    v.data = Lambdas::both(lambda);
    if !m.is_fluorescent() {
        return spectral.diagonal(v, m, lambda);
    }
    v.fluorescent = true;
    // decide with P, then sample the absorption (camera) or emission (light) side
    let s = m.sample(lambda, sampler.next2(), side, shift);
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
    /// The first vertex after which the throughput is zero (`usize::MAX`: none).
    zero_at: usize,
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
        let lambda = self.segment_lambda(&verts[verts.len() - 1]);
        let mut u = || sampler.next();
        match travel::<f32>(medium, ray, t_max, lambda, 1, self.tracking, LIGHT, &mut u) {
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
        let lambda = self.segment_lambda(prev);
        if let Some(seg) = seg {
            seg.w = self.w;
            seg.lambda = lambda;
            self.beta *= self.w;
            self.w = 1.0;
        }
        if !v.scatters() {
            v.data = Lambdas::both(lambda);
            // Camera paths keep an emitter they hit (t = 0); light paths cannot use it.
            return if LIGHT { Step::Discard } else { Step::Stop };
        }
        let (how, spectral) = ((Self::SIDE, self.shift), &mut *self.spectral);
        let w = with_spectrum!(self.scene, v, m => scatter(v, m, lambda, how, sampler, spectral),
            else return Step::Discard);
        self.beta *= w;
        if !(self.beta > 0.0) {
            self.zero_at = self.zero_at.min(verts.len() - 1);
            if self.stop_on_zero {
                return Step::Stop;
            }
        }
        Step::Continue
    }

    #[inline]
    fn needs_far(&self) -> bool {
        self.tracking == Tracking::Aware
    }
}

/// How a bdpt-forward/backward sub-path samples: new wavelengths at fluorescent vertices, free
/// flights, and whether it ends at zero spectral throughput (its wavelengths are final).
#[derive(Clone, Copy, Debug)]
pub struct Sampling {
    pub shift: ShiftSampling,
    pub tracking: Tracking,
    pub stop_on_zero: bool,
}

/// The buffers one sub-path fills: its vertices, its segments (media scenes) and the spectral
/// cache of the sample.
pub struct Buffers<'a> {
    pub out: &'a mut Vec<Vertex>,
    pub log: Option<&'a mut SegmentLog>,
    pub spectral: &'a mut SpectralCache,
}

impl<'a> Buffers<'a> {
    /// Empty the vertices and the segment log.
    fn clear(&mut self) {
        self.out.clear();
        if let Some(log) = self.log.as_deref_mut() {
            log.clear();
        }
    }

    /// Walk on from `start` (`geometric::random_walk`) with `walker`, counting the rays.
    #[inline]
    fn walk<const LIGHT: bool>(
        self,
        scene: &Scene,
        start: Start,
        max_vertices: usize,
        (sampler, stats): (&mut Sampler, &mut Stats),
        how: Sampling,
        beta: f32,
    ) -> usize {
        let mut walker = SpectralWalker::<LIGHT> {
            scene,
            shift: how.shift,
            tracking: how.tracking,
            stop_on_zero: how.stop_on_zero,
            beta,
            zero_at: usize::MAX,
            w: 1.0,
            spectral: self.spectral,
        };
        let trace = Trace {
            verts: self.out,
            max_vertices,
            log: self.log,
        };
        stats.rays += geometric::random_walk(scene, start, trace, sampler, &mut walker);
        walker.zero_at
    }
}

/// Trace a camera sub-path through film position `(x, y)` with at most `max_vertices` vertices
/// (x0 included), Jung Alg. 1. At each scattering vertex (surface or medium) the incident
/// wavelength is sampled as a camera path does (eq. 6.6), the last vertex included. With
/// `stop_on_zero` (forward reset: camera wavelengths are final) the path ends when its spectral
/// throughput is zero; otherwise only by depth or escape. Returns the first vertex after which
/// the throughput is zero (`usize::MAX`: none): the forward reset's connections through it are 0.
pub fn camera_subpath(
    scene: &Scene,
    (x, y): (f32, f32),
    lambda0: f32,
    max_vertices: usize,
    how: Sampling,
    (sampler, stats): (&mut Sampler, &mut Stats),
    mut bufs: Buffers,
) -> usize {
    bufs.clear();
    let (mut x0, ray, pdf_dir) = Vertex::camera(scene, x, y);
    x0.data = Lambdas::both(lambda0);
    bufs.out.push(x0);
    let medium = scene.camera_medium;
    let start = Start {
        ray,
        pdf_dir,
        medium,
    };
    bufs.walk::<false>(scene, start, max_vertices, (sampler, stats), how, 1.0)
}

/// Trace a light sub-path with at most `max_vertices` vertices, Jung Alg. 3: light ∝ power,
/// λ from its emission spectrum (or uniform), cosine emission, and at each scattering vertex the
/// exitant wavelength sampled as a light path does (eq. 6.7). With `stop_on_zero` (backward
/// reset: light wavelengths are final) it ends at zero spectral throughput. Returns the first
/// vertex after which the throughput is zero (`usize::MAX`: none): the backward reset's
/// connections through it are 0.
pub fn light_subpath(
    scene: &Scene,
    max_vertices: usize,
    light_mode: LightWavelengths,
    how: Sampling,
    (sampler, stats): (&mut Sampler, &mut Stats),
    mut bufs: Buffers,
) -> usize {
    bufs.clear();
    if max_vertices == 0 || scene.lights.is_empty() {
        return usize::MAX;
    }
    let mut v0 = sample_light_vertex(scene, sampler);
    let light = v0.light as usize;
    let lambda = light_wavelength(scene, v0.light, light_mode, sampler).lambda;
    v0.data = Lambdas::both(lambda);
    let beta = scene.lights[light].spectrum.eval(lambda);
    bufs.out.push(v0);
    let zero_at = if beta > 0.0 { usize::MAX } else { 0 };
    if max_vertices == 1 || (how.stop_on_zero && zero_at == 0) {
        return zero_at;
    }
    let (start, _) = Start::emission(scene, &v0, sampler);
    let walked = bufs.walk::<true>(scene, start, max_vertices, (sampler, stats), how, beta);
    zero_at.min(walked)
}

/// A light vertex: a light chosen by power and a point by area, with `pdf_fwd` their product
/// (sampler: one value for the light, three for the point). No wavelength yet.
#[inline]
pub fn sample_light_vertex(scene: &Scene, sampler: &mut Sampler) -> Vertex {
    let (ul, up, u2) = (sampler.next(), sampler.next(), sampler.next2());
    Vertex::light(&scene.lights.sample_le_origin(ul, up, u2))
}
