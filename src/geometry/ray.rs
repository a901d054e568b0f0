//! Rays, hits and the self-intersection offset.

use glam::Vec3;

/// A ray with origin `o` and (unit) direction `d`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray { o, d }
    }
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// A closest hit: distance along the ray, primitive id and surface parameters.
/// Primitive ids `0..n_triangles` are triangles, `n_triangles..` spheres.
/// For triangles `(u, v)` are barycentrics of `v1` and `v2`.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// Offset a point along the geometric normal, on the side of `dir`, so that a ray spawned there
/// does not hit the surface it leaves (the error bound scales with the point's magnitude).
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, dir: Vec3) -> Vec3 {
    let eps = 1e-4 * (1.0 + p.abs().max_element());
    let n = if n.dot(dir) < 0.0 { -n } else { n };
    p + n * eps
}

/// Spawn a ray leaving surface point `p` (geometric normal `n`) in direction `d`.
#[inline]
pub fn spawn_ray(p: Vec3, n: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_origin(p, n, d), d)
}

/// A shadow ray from `p` (normal `np`) towards `q` (normal `nq`): returns the ray and the
/// maximum distance to test, both ends offset.
#[inline]
pub fn spawn_ray_to(p: Vec3, np: Vec3, q: Vec3, nq: Vec3) -> (Ray, f32) {
    let d0 = q - p;
    let o = offset_origin(p, np, d0);
    let target = offset_origin(q, nq, -d0);
    let d = target - o;
    let len = d.length();
    (Ray::new(o, d / len), len * (1.0 - 1e-4))
}
