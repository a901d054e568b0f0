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
///
/// The origin moves along `d` itself, so the ray is the line through `p`: it hits what a ray
/// from `p` hits, and the pdfs an integrator computes at `p` (the direction's cosine, a light's
/// solid-angle pdf from `p`) belong to the ray traced. Moving the origin by ε along the normal
/// instead, as [`offset_origin`] does, shifts the whole ray off `p`: on a concave surface
/// near-grazing rays then land about √(2ε) from `p` instead of at the true chord, and the MIS
/// weights of emitter hits, computed at `p`, no longer complement those of next-event
/// estimation (a relative bias of about −ε/2 per bounce: −0.95·10⁻⁴ of Y for ε = 2·10⁻⁴ in the
/// closed unit-sphere furnace, tests/furnace_grey_precision.rs).
///
/// The step along `d` is just long enough for the origin to clear the surface by
/// [`SPAWN_CLEARANCE`] of `1 + max |p_i|` (far above the rounding error of hit points), and no
/// longer: every surface farther from `p` than the step is skipped, so a longer step (10⁻⁴ of
/// the scale at least, as it once was) lets rays that leave a point near a concave edge pass
/// the adjacent wall (−3.8·10⁻⁵ of Y in the closed cube furnace). Below a cosine of
/// [`SPAWN_MIN_COS`] the step would exceed 10⁻³ of the scale and leave a concave surface
/// altogether (a unit sphere's chord is shorter than it below that cosine), so such grazing rays
/// leave along the normal as in [`cross_boundary_ray`], off the line through `p` by only
/// [`SPAWN_CLEARANCE`].
#[inline]
pub fn spawn_ray(p: Vec3, n: Vec3, d: Vec3) -> Ray {
    let cos = n.dot(d).abs();
    if cos < SPAWN_MIN_COS {
        return cross_boundary_ray(p, n, d);
    }
    let scale = 1.0 + p.abs().max_element();
    Ray::new(p + d * (SPAWN_CLEARANCE * scale / cos), d)
}

/// The distance of a spawned ray's origin from the surface it leaves, relative to
/// `1 + max |p_i|`.
pub const SPAWN_CLEARANCE: f32 = 1e-6;
/// The least `|cos|` of a direction that [`spawn_ray`] steps along (a step of at most 10⁻³ of
/// the scale); grazing directions leave along the normal instead.
pub const SPAWN_MIN_COS: f32 = 1e-3;

/// The ray that goes on along `d` after crossing an index-matched boundary at `p` (geometric
/// normal `n`): its origin leaves the surface along the normal, on the side of `d`, by
/// [`SPAWN_CLEARANCE`] of `1 + max |p_i|`, and does not move along `d`.
///
/// A step along `d` skips every surface closer than the step: when [`spawn_ray`] stepped at
/// least 10⁻⁴ of the scale, a ray that entered a box of medium within about 10⁻⁴ of an edge
/// missed the face it leaves by, and the walk carried the medium out of the box (into the room,
/// where the next surface has no interface to correct it, and on to free flights of length
/// 1/σ, 10¹⁷ at σ = 10⁻¹⁷, off the open side of the scene). The normal offset keeps every
/// surface ahead of `p` ahead of the origin at any angle, and moves the line off `p` by only
/// 10⁻⁶ of the scale (the line through `p` matters at scattering vertices, where pdfs are
/// computed, which a crossing is not).
#[inline]
pub fn cross_boundary_ray(p: Vec3, n: Vec3, d: Vec3) -> Ray {
    let eps = SPAWN_CLEARANCE * (1.0 + p.abs().max_element());
    let side = if n.dot(d) < 0.0 { -n } else { n };
    Ray::new(p + side * eps, d)
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
