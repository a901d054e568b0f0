//! Connections of the all-bins BDPT: the directional factors (f_dir = 1/π, G, W_e) are scalars
//! and the spectral factor is an inner product of an importance row with a light spectrum, so a
//! connection costs O(bins) whatever the path length.

use super::subpath::{Vertex, VertexKind};
use crate::geometry::Ray;
use crate::geometry::ray::spawn_ray_to;
use crate::material::Material;
use crate::scene::Scene;
use glam::Vec3;

/// Σ a[i]·b[i], with eight independent partial sums so the loop vectorises.
#[inline]
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    acc.iter().sum::<f32>() + s
}

/// XYZ = (w_X·t, w_Y·t, w_Z·t) for importance rows stored as [X | Y | Z], each `t.len()` long.
#[inline]
pub fn dot3(rows: &[f32], t: &[f32]) -> Vec3 {
    let n = t.len();
    Vec3::new(
        dot(&rows[..n], t),
        dot(&rows[n..2 * n], t),
        dot(&rows[2 * n..3 * n], t),
    )
}

/// Whether any entry is non-zero (a sub-path whose payload vanished can stop).
#[inline]
pub fn any_nonzero(v: &[f32]) -> bool {
    v.iter().any(|&x| x != 0.0)
}

/// Directional factor of vertex `v` for light leaving (or importance arriving) towards `to`,
/// given the other neighbour `prev` on its own sub-path: the diffuse 1/π when both directions lie
/// on the same side (two-sided reflective lobe), the emitter's directional profile (1 on an
/// emitting side) for a light origin.
#[inline]
pub fn f_dir(scene: &Scene, v: &Vertex, prev: Option<&Vertex>, to: Vec3) -> f32 {
    match v.kind {
        VertexKind::Light => {
            let l = &scene.lights[v.light as usize];
            if l.emits_towards(v.n, to - v.p) {
                1.0
            } else {
                0.0
            }
        }
        VertexKind::Surface => {
            let Some(prev) = prev else { return 0.0 };
            if v.n.dot(to - v.p) * v.n.dot(prev.p - v.p) > 0.0 {
                Material::DIFFUSE
            } else {
                0.0
            }
        }
        VertexKind::Camera => 0.0,
    }
}

/// Geometry term G = |cos_a|·|cos_b| / d² between two surface vertices (Veach eq. 8.3).
#[inline]
pub fn geometry(a: &Vertex, b: &Vertex) -> f32 {
    let d = b.p - a.p;
    let d2 = d.length_squared();
    let w = d / d2.sqrt();
    a.n.dot(w).abs() * b.n.dot(w).abs() / d2
}

/// Shadow ray between two surface points.
#[inline]
pub fn visible(scene: &Scene, a: &Vertex, b: &Vertex, rays: &mut u64) -> bool {
    *rays += 1;
    let (ray, tmax) = spawn_ray_to(a.p, a.n, b.p, b.n);
    !scene.occluded(&ray, tmax)
}

/// Shadow ray from a surface point to the pinhole.
#[inline]
pub fn visible_to_camera(scene: &Scene, a: &Vertex, cam: Vec3, rays: &mut u64) -> bool {
    *rays += 1;
    let o = crate::geometry::ray::offset_origin(a.p, a.n, cam - a.p);
    let d = cam - o;
    let len = d.length();
    !scene.occluded(&Ray::new(o, d / len), len * (1.0 - 1e-4))
}

/// Pinhole importance for a light-tracing splat: the pixel's W_e = N_pixels / (A_film · cos⁴θ)
/// (pbrt-v3 `PerspectiveCamera::We` with a box pixel filter), divided by the N_pixels light
/// sub-paths traced per pass, since film = (Σ samples + Σ splats) / spp: 1 / (A_film · cos⁴θ).
#[inline]
pub fn pinhole_we(scene: &Scene, cos: f32) -> f32 {
    let c2 = cos * cos;
    1.0 / (scene.camera.film_area() * c2 * c2)
}
