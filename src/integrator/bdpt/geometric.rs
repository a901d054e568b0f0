//! The wavelength-free random walk of the BDPT sub-paths, shared by `bdpt-forward`/
//! `bdpt-backward` (which layer per-vertex wavelengths on top, `subpath.rs`) and `bdpt-allbins`
//! (which layers a scalar throughput on top and keeps its bin spectra in parallel buffers,
//! `allbins/`). Vertices, their pdfs, scattering lobes, light sampling and visibility come from
//! the transport layer (`crate::transport`).

use crate::geometry::Ray;
use crate::geometry::ray::spawn_ray;
use crate::integrator::Sampler;
use crate::scene::{NONE, Scene};
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

/// Extend a sub-path `verts` (holding at least its first vertex) along `ray`, leaving the last
/// vertex with solid-angle pdf `pdf_dir`, until it holds `max_vertices` vertices, the ray escapes,
/// a vertex does not scatter (`material == NONE`: emitter or black surface) or `on_vertex` says
/// otherwise. Each new vertex gets its `pdf_fwd` and a default payload, then
/// `on_vertex(verts, sampler)` fills the payload; it is also called for non-scattering vertices.
/// A scattering vertex then samples its lobe (sampler: two values), which sets its
/// predecessor's `pdf_rev` (unless that is the pinhole), as pbrt-v4 does; both lobes are sampled
/// exactly, so the directional throughput f·|cos|/pdf of every bounce is 1. Rays cast are
/// added to `rays`.
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
        let mut v = Vertex::surface(&it, 0.0);
        v.pdf_fwd = Vertex::<P>::area_pdf(pdf_dir, ray.d, d2, &v);
        verts.push(v);
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
        let cur = verts.len() - 1;
        let lobe = verts[cur].scattering();
        let wo = -ray.d;
        let s = lobe.sample(wo, sampler.next2());
        let prev = &verts[cur - 1];
        if prev.kind != VertexKind::Camera {
            // The pdf of sampling `prev` from this vertex, leaving towards `s.wi`.
            let pdf_rev = Vertex::<P>::area_pdf(lobe.pdf(s.wi, wo), ray.d, d2, prev);
            verts[cur - 1].pdf_rev = pdf_rev;
        }
        ray = spawn_ray(it.p, it.n, s.wi);
        pdf_dir = s.pdf;
    }
}
