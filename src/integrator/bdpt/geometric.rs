//! The wavelength-free random walk of the BDPT sub-paths, shared by `bdpt-forward`/
//! `bdpt-backward` (which layer per-vertex wavelengths on top, `subpath.rs`) and `bdpt-allbins`
//! (which layers a scalar throughput on top and keeps its bin spectra in parallel buffers,
//! `allbins/`). Vertices, their pdfs, scattering lobes, light sampling and visibility come from
//! the transport layer (`crate::transport`).
//!
//! In media the walk samples free flights through the integrator's [`Walker::travel`] (which
//! keeps the spectral free-flight weight), makes medium vertices at collisions, crosses
//! index-matched boundaries without a vertex, and logs every segment's stretches of medium
//! ([`SegmentLog`]) so that the integrator can evaluate distance pdfs in both directions later.

use crate::geometry::Ray;
use crate::geometry::ray::{cross_boundary_ray, spawn_ray};
use crate::integrator::Sampler;
use crate::medium::Medium;
use crate::scene::lights::Emission;
use crate::scene::{NONE, Scene};
use crate::transport::media::MAX_CROSSINGS;
use crate::transport::segment::{Segment, Stretch, distance_to_surface, surface_media, towards};
use crate::transport::{Vertex, VertexKind};

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

/// The segments of a sub-path in a media scene: `segs[i]` is the segment arriving at vertex i
/// (`segs[0]` is unused) and `stretches` holds their stretches of medium.
#[derive(Clone, Debug, Default)]
pub struct SegmentLog {
    pub segs: Vec<Segment>,
    pub stretches: Vec<Stretch>,
    /// The first stretch of the segment being traced.
    open: u32,
    /// Per segment, its free-flight pdfs in full-path order (forward, reverse) at the
    /// wavelength whose bits are given, once a connection has computed them: every later
    /// connection through the segment at that wavelength reuses them (`media::distance_pdfs`).
    pub pdfs: std::cell::RefCell<Vec<Option<(u32, f64, f64)>>>,
}

impl SegmentLog {
    pub fn clear(&mut self) {
        self.segs.clear();
        self.segs.push(Segment::default());
        self.stretches.clear();
        self.open = 0;
        self.pdfs.get_mut().clear();
    }

    /// Add a stretch of `len` along `ray` in `medium` to the segment being traced.
    #[inline]
    fn stretch(&mut self, medium: u32, ray: &Ray, len: f32) {
        if len.is_finite() {
            self.stretches.push(Stretch {
                medium,
                o: ray.o,
                d: ray.d,
                len,
            });
        }
    }

    /// End the segment being traced at a vertex.
    #[inline]
    fn close(&mut self, far_end: f32, far_start: f32, end_media: [u32; 2]) {
        let last = self.stretches.len() as u32;
        self.segs.push(Segment {
            first: self.open,
            last,
            far_end,
            far_start,
            end_media,
            ..Segment::default()
        });
        self.open = last;
    }
}

/// The integrator's part of a sub-path.
pub trait Walker<P> {
    /// Sample a free flight in `medium` (id `id`) along `ray` up to the surface at `t_max` (∞: none) for
    /// the sub-path `verts` so far: `Some(t)` for a collision. The walker keeps the free-flight
    /// weight itself and hands it to the next vertex's segment.
    fn travel(
        &mut self,
        id: u32,
        medium: &Medium,
        ray: &Ray,
        t_max: f32,
        verts: &[Vertex<P>],
        sampler: &mut Sampler,
    ) -> Option<f32>;

    /// Fill the payload of the new last vertex of `verts` (and, in media scenes, the weight
    /// fields of the segment that reached it); called for non-scattering vertices too.
    fn on_vertex(
        &mut self,
        verts: &mut [Vertex<P>],
        seg: Option<&mut Segment>,
        sampler: &mut Sampler,
    ) -> Step;

    /// Whether segment pdfs need the distance past a medium vertex to the next surface in the
    /// reverse direction (fluorescence-aware tracking).
    fn needs_far(&self) -> bool;
}

/// Where a sub-path's walk starts: the ray leaving its first vertex, the solid-angle pdf of that
/// direction and the medium the ray starts in.
#[derive(Clone, Copy, Debug)]
pub struct Start {
    pub ray: Ray,
    pub pdf_dir: f32,
    pub medium: u32,
}

impl Start {
    /// A light sub-path's start: the emission direction sampled at the light origin `y0`
    /// (sampler: two values), and the emission sample (its weight L_e·cos / pdf_dir).
    #[inline]
    pub fn emission<P>(scene: &Scene, y0: &Vertex<P>, sampler: &mut Sampler) -> (Start, Emission) {
        let light = y0.light as usize;
        let e = scene
            .lights
            .sample_le_direction(light, y0.n, sampler.next2());
        let start = Start {
            ray: spawn_ray(y0.p, y0.n, e.w),
            pdf_dir: e.pdf_dir,
            medium: towards(scene.light_media(light), y0.n, e.w),
        };
        (start, e)
    }
}

/// What a walk fills: the sub-path's vertices (holding at least its first) up to
/// `max_vertices`, and in media scenes the log of its segments.
pub struct Trace<'a, P> {
    pub verts: &'a mut Vec<Vertex<P>>,
    pub max_vertices: usize,
    pub log: Option<&'a mut SegmentLog>,
}

/// Extend a sub-path (`trace.verts`, holding at least its first vertex) from `start` until it
/// holds `max_vertices` vertices, the ray escapes, a vertex does not scatter (`material ==
/// NONE`: emitter or black surface) or the walker says otherwise; returns the rays cast. Each
/// new vertex gets its `pdf_fwd` (directional only: solid angle to area, no free-flight pdf) and
/// a default payload, then the walker fills the payload. A scattering vertex then samples its
/// lobe (sampler: two values), which sets its predecessor's `pdf_rev` (unless that is the
/// pinhole), as pbrt-v4 does; both lobes are sampled exactly, so the directional throughput
/// f·|cos|/pdf of every bounce is 1. `trace.log` (media scenes only) receives the segments.
#[inline]
pub fn random_walk<P: Copy + Default>(
    scene: &Scene,
    start: Start,
    trace: Trace<P>,
    sampler: &mut Sampler,
    walker: &mut impl Walker<P>,
) -> u64 {
    let Start {
        mut ray,
        mut pdf_dir,
        mut medium,
    } = start;
    let Trace {
        verts,
        max_vertices,
        mut log,
    } = trace;
    let mut rays = 0u64;
    let mut crossings = 0usize;
    let mut far_start = f32::INFINITY;
    while verts.len() < max_vertices {
        rays += 1;
        let hit = scene.intersect(&ray, f32::INFINITY);
        let mut collision = None;
        // Squared distance from the last vertex to the new one.
        let mut d2 = 0.0f32;
        if let Some(log) = log.as_deref_mut()
            && let Some(m) = scene.medium(medium)
        {
            let t_max = hit.map_or(f32::INFINITY, |h| h.t);
            collision = walker.travel(medium, m, &ray, t_max, verts, sampler);
            log.stretch(medium, &ray, collision.unwrap_or(t_max));
            if let Some(t) = collision {
                let p = ray.at(t);
                d2 = (p - verts[verts.len() - 1].p).length_squared();
                verts.push(Vertex::medium(p, medium, pdf_dir / d2));
                log.close(t_max - t, far_start, [medium, medium]);
            }
        }
        let (cur_p, cur_n) = if collision.is_some() {
            let v = verts[verts.len() - 1];
            (v.p, v.n)
        } else {
            let Some(it) = hit else {
                return rays;
            };
            if log.is_some() && it.material == NONE && it.light == NONE {
                // An index-matched boundary: not a vertex of the path.
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    return rays;
                }
                medium = scene.medium_after(&it, ray.d, medium);
                ray = cross_boundary_ray(it.p, it.n, ray.d);
                continue;
            }
            let prev = verts[verts.len() - 1];
            d2 = if log.is_some() {
                (it.p - prev.p).length_squared()
            } else {
                it.t * it.t
            };
            let mut v = Vertex::surface(&it, 0.0);
            v.pdf_fwd = Vertex::<P>::area_pdf(pdf_dir, ray.d, d2, &v);
            verts.push(v);
            if let Some(log) = log.as_deref_mut() {
                let media = surface_media(scene.interface(&it), medium);
                log.close(f32::INFINITY, far_start, media);
            }
            (it.p, it.n)
        };
        let seg = log.as_deref_mut().and_then(|log| log.segs.last_mut());
        match walker.on_vertex(verts, seg, sampler) {
            Step::Continue => {}
            Step::Stop => return rays,
            Step::Discard => {
                verts.pop();
                if let Some(log) = log.as_deref_mut() {
                    log.segs.pop();
                }
                return rays;
            }
        }
        let cur = verts.len() - 1;
        if !verts[cur].scatters() {
            return rays;
        }
        let lobe = verts[cur].scattering(scene);
        let wo = -ray.d;
        let s = lobe.sample(wo, sampler.next2());
        let prev = &verts[cur - 1];
        if prev.kind != VertexKind::Camera {
            // The pdf of sampling `prev` from this vertex, leaving towards `s.wi`.
            let pdf_rev = Vertex::<P>::area_pdf(lobe.pdf(s.wi, wo), ray.d, d2, prev);
            verts[cur - 1].pdf_rev = pdf_rev;
        }
        let medium_vertex = verts[cur].kind == VertexKind::Medium;
        far_start = if medium_vertex && walker.needs_far() {
            distance_to_surface(scene, cur_p, -s.wi, &mut rays)
        } else {
            f32::INFINITY
        };
        if medium_vertex {
            ray = Ray::new(cur_p, s.wi);
        } else {
            ray = spawn_ray(cur_p, cur_n, s.wi);
        }
        pdf_dir = s.pdf;
        if let Some(log) = log.as_deref()
            && !medium_vertex
        {
            medium = towards(log.segs[cur].end_media, cur_n, s.wi);
        }
        crossings = 0;
    }
    rays
}

/// A walker for scenes without media: only the vertex callback.
pub struct SurfaceWalker<F>(pub F);

impl<P, F: FnMut(&mut [Vertex<P>], &mut Sampler) -> Step> Walker<P> for SurfaceWalker<F> {
    #[inline]
    fn travel(
        &mut self,
        _: u32,
        _: &Medium,
        _: &Ray,
        _: f32,
        _: &[Vertex<P>],
        _: &mut Sampler,
    ) -> Option<f32> {
        None
    }
    #[inline]
    fn on_vertex(
        &mut self,
        verts: &mut [Vertex<P>],
        _: Option<&mut Segment>,
        s: &mut Sampler,
    ) -> Step {
        (self.0)(verts, s)
    }
    #[inline]
    fn needs_far(&self) -> bool {
        false
    }
}
