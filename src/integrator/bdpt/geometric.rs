//! The wavelength-free core of the BDPT sub-paths, shared by `bdpt-forward`/`bdpt-backward`
//! (which layer per-vertex wavelengths on top, `subpath.rs`) and `bdpt-allbins` (which layers a
//! scalar throughput on top and keeps its bin spectra in parallel buffers, `allbins/`).
//!
//! A [`Vertex`] holds the geometry (position, normal, material, emitter) and the area-measure pdfs
//! of being generated in both directions (pbrt-v4 `pdfFwd` / `pdfRev`), plus a payload `P` that
//! the integrator owns. All materials are two-sided diffuse and all emitters diffuse area lights,
//! so a pdf depends only on the vertices involved: [`Vertex::pdf`] evaluates any of them.

use crate::geometry::frame::sample_cosine_hemisphere;
use crate::geometry::ray::{offset_origin, spawn_ray, spawn_ray_to};
use crate::geometry::{Frame, Ray};
use crate::integrator::Sampler;
use crate::integrator::pt::sample_diffuse;
use crate::scene::{NONE, Scene};
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// What generated a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VertexKind {
    /// The pinhole x0; `n` is the viewing direction.
    Camera,
    /// A point sampled on an emitter (first light sub-path vertex or NEE sample).
    Light,
    /// A surface hit (it may also be an emitter: `light != NONE`).
    #[default]
    Surface,
}

/// A geometric path vertex with the integrator's payload `data`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Vertex<P> {
    pub p: Vec3,
    /// Geometric normal (camera: forward axis; light: oriented emitting normal).
    pub n: Vec3,
    pub kind: VertexKind,
    /// bdpt-forward/backward: the vertex changed the wavelength (λ_in ≠ λ_out sampled, a
    /// fluorescent interaction); false in bdpt-allbins. Wavelength bookkeeping, but kept here
    /// rather than in the payload because it fits in the padding after `kind`: as a payload
    /// field it grows the bdpt vertex from 52 to 56 bytes, which cost 3.5 % more instructions
    /// per bdpt-forward sample (the connections copy vertices into `FullPath`).
    pub shift: bool,
    pub material: u32,
    pub light: u32,
    /// Area pdf of this vertex given its predecessor on its own sub-path.
    pub pdf_fwd: f32,
    /// Area pdf of this vertex sampled from its successor on its own sub-path (the reverse
    /// direction); set when the successor is generated.
    pub pdf_rev: f32,
    /// Integrator-specific payload (wavelengths, scalar throughput).
    pub data: P,
}

/// Reverse area pdf at `prev` when sampled from the diffuse vertex at `at` (cosine lobe), for a
/// segment of direction `dir` and squared length `dist2`.
#[inline]
pub fn diffuse_area_pdf(at_n: Vec3, prev_n: Vec3, dir: Vec3, dist2: f32) -> f32 {
    at_n.dot(dir).abs() * FRAC_1_PI * prev_n.dot(dir).abs() / dist2
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

impl<P: Copy + Default> Vertex<P> {
    /// The pinhole x0 and the primary ray through film position (x, y) with its solid-angle pdf.
    #[inline]
    pub fn camera(scene: &Scene, x: f32, y: f32) -> (Self, Ray, f32) {
        let cam = &scene.camera;
        let ray = cam.generate_ray(x, y);
        let v = Vertex {
            p: cam.origin,
            n: cam.forward,
            kind: VertexKind::Camera,
            material: NONE,
            light: NONE,
            pdf_fwd: 1.0,
            ..Default::default()
        };
        (v, ray, cam.pdf_dir(ray.d.dot(cam.forward)))
    }
}

impl<P> Vertex<P> {
    #[inline]
    pub fn on_surface(&self) -> bool {
        self.kind != VertexKind::Camera
    }
    #[inline]
    pub fn is_emitter(&self) -> bool {
        self.light != NONE
    }

    /// Unit direction to `next` and the squared distance.
    #[inline]
    fn towards<Q>(&self, next: &Vertex<Q>) -> (Vec3, f32) {
        let d = next.p - self.p;
        let d2 = d.length_squared();
        (d / d2.sqrt(), d2)
    }

    /// Solid-angle → area conversion (pbrt `ConvertDensity`): p_A = p_ω · |cos θ_next| / d² for the unit direction `w` to `next` at squared distance
    /// `d2` (no cosine at the pinhole).
    #[inline]
    fn area_of<Q>(pdf_dir: f32, w: Vec3, d2: f32, next: &Vertex<Q>) -> f32 {
        let cos = if next.on_surface() {
            next.n.dot(w).abs()
        } else {
            1.0
        };
        pdf_dir * cos / d2
    }

    /// Area pdf that a scattering vertex, reached from `prev`, samples `next` (two-sided
    /// reflective diffuse lobe: cosine-weighted on the side of `prev`).
    #[inline]
    pub fn pdf_scatter<Q, R>(&self, prev: &Vertex<Q>, next: &Vertex<R>) -> f32 {
        let (w, d2) = self.towards(next);
        let (cn, cp) = (self.n.dot(w), self.n.dot(prev.p - self.p));
        if cn * cp <= 0.0 {
            return 0.0;
        }
        Self::area_of(cn.abs() * FRAC_1_PI, w, d2, next)
    }

    /// Area pdf that the light sub-path's emission sampling leaves this emitter point towards
    /// `next` (pbrt `PdfLight`).
    #[inline]
    pub fn pdf_emit<Q>(&self, scene: &Scene, next: &Vertex<Q>) -> f32 {
        let light = &scene.lights[self.light as usize];
        let (w, d2) = self.towards(next);
        Self::area_of(emission_pdf_dir(light.two_sided, self.n, w), w, d2, next)
    }

    /// Area pdf of choosing this emitter point as a light origin (pbrt `PdfLightOrigin`).
    #[inline]
    pub fn pdf_light_origin(&self, scene: &Scene) -> f32 {
        let l = self.light as usize;
        scene.light_pmf(l) / scene.lights[l].area
    }

    /// Area pdf of `next` given this vertex (pbrt `Vertex::Pdf`), for any vertex kind; a surface
    /// vertex needs its other neighbour `prev`.
    #[inline]
    pub fn pdf<Q, R>(&self, scene: &Scene, prev: Option<&Vertex<Q>>, next: &Vertex<R>) -> f32 {
        match self.kind {
            VertexKind::Camera => {
                let (w, d2) = self.towards(next);
                let cos = w.dot(self.n);
                if cos <= 0.0 || scene.camera.project(w).is_none() {
                    return 0.0;
                }
                Self::area_of(scene.camera.pdf_dir(cos), w, d2, next)
            }
            VertexKind::Light => self.pdf_emit(scene, next),
            VertexKind::Surface => match prev {
                Some(prev) => self.pdf_scatter(prev, next),
                None => 0.0,
            },
        }
    }
}

/// A light vertex: a light chosen by power and a point by area, with `pdf_fwd` their product
/// (sampler: one value for the light, three for the point).
#[inline]
pub fn sample_light_vertex<P: Default>(scene: &Scene, sampler: &mut Sampler) -> Vertex<P> {
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
        pdf_rev: 0.0,
        shift: false,
        data: P::default(),
    }
}

/// Cosine emission from a light vertex on its emitting side (either side, chosen with ½, if the
/// light is two-sided): the ray and its solid-angle pdf (sampler: two values).
#[inline]
pub fn sample_emission<P>(scene: &Scene, v0: &Vertex<P>, sampler: &mut Sampler) -> (Ray, f32) {
    let light = &scene.lights[v0.light as usize];
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
    let pdf_dir = emission_pdf_dir(light.two_sided, v0.n, d);
    (spawn_ray(v0.p, v0.n, d), pdf_dir)
}

/// Shadow ray between two surface vertices `a` (camera side) and `b`; counted in `rays`.
#[inline]
pub fn visible<P, Q>(scene: &Scene, a: &Vertex<P>, b: &Vertex<Q>, rays: &mut u64) -> bool {
    *rays += 1;
    let (ray, tmax) = spawn_ray_to(a.p, a.n, b.p, b.n);
    !scene.occluded(&ray, tmax)
}

/// Shadow ray from surface vertex `a` to the pinhole at `cam`; counted in `rays`.
#[inline]
pub fn visible_to_camera<P>(scene: &Scene, a: &Vertex<P>, cam: Vec3, rays: &mut u64) -> bool {
    *rays += 1;
    let o = offset_origin(a.p, a.n, cam - a.p);
    let d = cam - o;
    let len = d.length();
    !scene.occluded(&Ray::new(o, d / len), len * (1.0 - 1e-4))
}

/// What [`random_walk`] does after the integrator has seen a new vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Keep the vertex and scatter on (unless it does not scatter or the path is full).
    Continue,
    /// Keep the vertex and end the sub-path.
    Stop,
    /// Drop the vertex and end the sub-path.
    Discard,
}

/// Extend a sub-path `verts` (holding at least its first vertex) along `ray`, leaving the last
/// vertex with solid-angle pdf `pdf_dir`, until it holds `max_vertices` vertices, the ray escapes,
/// a vertex does not scatter (`material == NONE`: emitter or black surface) or `on_vertex` says
/// otherwise. Each new vertex gets its `pdf_fwd`, its predecessor's `pdf_rev` (unless that is the
/// pinhole) and a default payload, then `on_vertex(verts, sampler)` fills the payload; it is also
/// called for non-scattering vertices. Directions are cosine-sampled on the incoming side
/// (sampler: two values per scattering vertex kept), so the directional throughput
/// f_dir·cos/pdf of every bounce is 1. Rays cast are added to `rays`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn random_walk<P: Copy + Default>(
    scene: &Scene,
    mut ray: Ray,
    mut pdf_dir: f32,
    verts: &mut Vec<Vertex<P>>,
    max_vertices: usize,
    sampler: &mut Sampler,
    rays: &mut u64,
    mut on_vertex: impl FnMut(&mut [Vertex<P>], &mut Sampler) -> Step,
) {
    while verts.len() < max_vertices {
        *rays += 1;
        let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
            return;
        };
        let d2 = it.t * it.t;
        let prev = verts.len() - 1;
        if verts[prev].kind != VertexKind::Camera {
            verts[prev].pdf_rev = diffuse_area_pdf(it.n, verts[prev].n, ray.d, d2);
        }
        verts.push(Vertex {
            p: it.p,
            n: it.n,
            kind: VertexKind::Surface,
            material: it.material,
            light: it.light,
            pdf_fwd: pdf_dir * it.n.dot(ray.d).abs() / d2,
            pdf_rev: 0.0,
            shift: false,
            data: P::default(),
        });
        match on_vertex(verts, sampler) {
            Step::Continue => {}
            Step::Stop => return,
            Step::Discard => {
                verts.pop();
                return;
            }
        }
        if it.material == NONE {
            return;
        }
        let (next, _wi, pdf) = sample_diffuse(&it, -ray.d, sampler.next2());
        ray = next;
        pdf_dir = pdf;
    }
}
