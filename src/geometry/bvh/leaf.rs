//! Primitive records, 8-lane leaf packets and their intersection kernels; brute-force reference.

use glam::Vec3A;

use super::Accel;
use super::isa::ISA_AVX2;
use super::nodes::{self, TRay};
use crate::geometry::{Hit, Ray, Sphere, Triangle};

/// `a x b` with each component's difference fused, `a.y b.z - (a.z b.y)` for x: one rounding
/// fewer than `Vec3A::cross`, and one instruction fewer in the packet test
/// ([`Accel::block_lanes`] does the same operations, so its results are the same to the bit).
#[inline(always)]
fn cross(a: Vec3A, b: Vec3A) -> Vec3A {
    Vec3A::new(
        a.y.mul_add(b.z, -(a.z * b.y)),
        a.z.mul_add(b.x, -(a.x * b.z)),
        a.x.mul_add(b.y, -(a.y * b.x)),
    )
}

/// `a . b` as `(a.x b.x + a.y b.y) + a.z b.z` with both additions fused, as
/// [`Accel::block_lanes`] computes it.
#[inline(always)]
fn dot(a: Vec3A, b: Vec3A) -> f32 {
    a.z.mul_add(b.z, a.y.mul_add(b.y, a.x * b.x))
}

/// Precomputed primitive record (one per BVH primitive slot).
///
/// Triangle: `a = v0`, `b = v0 - v1`, `c = v2 - v0`, `d = b x c` ([`cross`], fused; layout of
/// madmann91's `bvh` / `obvhs::rt_triangle::RtTriangle`). Sphere: `a = center`, `b = (r, r^2, 0)`.
/// Aligned to a cache line (one line per record).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(super) struct Prim {
    a: Vec3A,
    b: Vec3A,
    c: Vec3A,
    pub(super) d: Vec3A,
}

impl Prim {
    pub(super) fn triangle(t: &Triangle) -> Prim {
        let v0 = Vec3A::from(t.v[0]);
        let e1 = v0 - Vec3A::from(t.v[1]);
        let e2 = Vec3A::from(t.v[2]) - v0;
        Prim {
            a: v0,
            b: e1,
            c: e2,
            d: cross(e1, e2),
        }
    }

    pub(super) fn sphere(s: &Sphere) -> Prim {
        Prim {
            a: Vec3A::from(s.center),
            b: Vec3A::new(s.radius, s.radius * s.radius, 0.0),
            c: Vec3A::ZERO,
            d: Vec3A::ZERO,
        }
    }

    /// Möller–Trumbore (no culling), its cross and dot products fused ([`cross`], [`dot`]).
    /// Returns `t` (or a value failing `0 < t < t_max`, possibly NaN) and the barycentrics of v1
    /// and v2.
    #[inline(always)]
    fn intersect_triangle(&self, r: &TRay) -> (f32, f32, f32) {
        let c = self.a - r.o;
        let rr = cross(r.d, c);
        let inv_det = 1.0 / dot(r.d, self.d);
        let u = dot(rr, self.c) * inv_det;
        let v = dot(rr, self.b) * inv_det;
        let w = 1.0 - u - v;
        // Sign bits: rejects negative values and -0; NaN (degenerate / parallel) gives NaN t below.
        if (u.to_bits() | v.to_bits() | w.to_bits()) & 0x8000_0000 != 0 {
            return (f32::NAN, 0.0, 0.0);
        }
        (dot(c, self.d) * inv_det, u, v)
    }

    /// Nearest root in `(0, t_max)` of a ray/sphere intersection, using the numerically robust
    /// form of Ray Tracing Gems, ch. 7 (discriminant from the closest-approach vector and the
    /// `q = b + sign(b) sqrt(...)` root pair). Returns NaN/inf/<=0 on miss.
    /// The ray is its origin `o` and direction `d`.
    #[inline(always)]
    pub(super) fn intersect_sphere(&self, o: Vec3A, d: Vec3A, t_max: f32) -> f32 {
        let r2 = self.b.y;
        let f = o - self.a;
        let a = d.length_squared();
        let b = -f.dot(d); // b' (half of -b in the textbook form)
        let c = f.length_squared() - r2;
        let l = f + (b / a) * d;
        let disc = r2 - l.length_squared();
        if disc < 0.0 {
            return f32::NAN;
        }
        let q = b + (a * disc).sqrt().copysign(b);
        let t0 = c / q;
        let t1 = q / a;
        let (t_near, t_far) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        if t_near > 0.0 && t_near < t_max {
            t_near
        } else {
            t_far
        }
    }
}

/// 8 triangles in SoA form (same quantities as [`Prim::triangle`]). A sphere lane holds its
/// centre in `a` and (r, r²) in `b.x`, `b.y` ([`Prim::sphere`]); unused lanes are all zero, which
/// no ray hits (t = 0 · ∞ = NaN).
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
pub(super) struct TriBlock {
    /// v0, v0 - v1, v2 - v0; per axis, per lane. The normal (v0 - v1) x (v2 - v0) is computed
    /// in the test, with the operations of [`cross`], so it is the same to the bit.
    a: [[f32; 8]; 3],
    b: [[f32; 8]; 3],
    c: [[f32; 8]; 3],
    /// Original primitive id per lane (`u32::MAX` if unused); in the packet's last cache line,
    /// which the test has loaded.
    pub(super) ids: [u32; 8],
}

impl std::hash::Hash for TriBlock {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        for v in [&self.a, &self.b, &self.c] {
            v.map(|row| row.map(f32::to_bits)).hash(h);
        }
        self.ids.hash(h);
    }
}

// the packet size the node layouts prefetch by
const _: () = assert!(std::mem::size_of::<TriBlock>() == nodes::PACKET_BYTES);

impl TriBlock {
    /// No primitive in any lane (all zero, which no ray hits; ids `u32::MAX`).
    pub(super) const UNUSED: TriBlock = TriBlock {
        a: [[0.0; 8]; 3],
        b: [[0.0; 8]; 3],
        c: [[0.0; 8]; 3],
        ids: [u32::MAX; 8],
    };

    pub(super) fn set(&mut self, l: usize, p: &Prim) {
        for k in 0..3 {
            self.a[k][l] = p.a[k];
            self.b[k][l] = p.b[k];
            self.c[k][l] = p.c[k];
        }
    }

    /// The sphere in lane `l`.
    #[inline(always)]
    fn sphere(&self, l: usize) -> Prim {
        Prim {
            a: Vec3A::new(self.a[0][l], self.a[1][l], self.a[2][l]),
            b: Vec3A::new(self.b[0][l], self.b[1][l], 0.0),
            c: Vec3A::ZERO,
            d: Vec3A::ZERO,
        }
    }
}

impl Accel {
    /// 8-wide Möller–Trumbore over one block: hit lane mask (0 < t < t_max) and t, u, v per lane.
    /// Same operations in the same order as [`Prim::intersect_triangle`], so results are
    /// bit-identical to it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) fn flat_block(
        blk: &TriBlock,
        normal: Option<&[[f32; 8]; 3]>,
        o: [f32; 3],
        d: [f32; 3],
        t_max: f32,
        out: Option<&mut [[f32; 8]; 3]>,
    ) -> u32 {
        use std::arch::x86_64::*;
        let (ok, neg, t, u, v) = Self::block_lanes(blk, normal, o, d, _mm256_set1_ps(t_max));
        let hits = _mm256_movemask_ps(ok) as u32 & !(_mm256_movemask_ps(neg) as u32);
        if hits != 0
            && let Some(out) = out
        {
            // SAFETY: each store writes one whole `[f32; 8]`.
            unsafe {
                _mm256_storeu_ps(out[0].as_mut_ptr(), t);
                _mm256_storeu_ps(out[1].as_mut_ptr(), u);
                _mm256_storeu_ps(out[2].as_mut_ptr(), v);
            }
        }
        hits
    }

    /// The lanes of [`Self::flat_block`] in registers: `ok` is set in the lanes with t in
    /// (0, t_max) (t_max per lane), the sign bit of `neg` in those with a negative u, v or w,
    /// which miss; then t, u, v.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) fn block_lanes(
        blk: &TriBlock,
        normal: Option<&[[f32; 8]; 3]>,
        o: [f32; 3],
        d: [f32; 3],
        t_max: std::arch::x86_64::__m256,
    ) -> (
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
    ) {
        use std::arch::x86_64::*;
        // SAFETY: AVX2 is enabled for this function; all loads read whole `[f32; 8]` fields.
        unsafe {
            let ld = |a: &[f32; 8]| _mm256_loadu_ps(a.as_ptr());
            let (mul, sub) = (_mm256_mul_ps, _mm256_sub_ps);
            let (fma, fms) = (_mm256_fmadd_ps, _mm256_fmsub_ps);
            let (dx, dy, dz) = (
                _mm256_set1_ps(d[0]),
                _mm256_set1_ps(d[1]),
                _mm256_set1_ps(d[2]),
            );
            let cx = sub(ld(&blk.a[0]), _mm256_set1_ps(o[0]));
            let cy = sub(ld(&blk.a[1]), _mm256_set1_ps(o[1]));
            let cz = sub(ld(&blk.a[2]), _mm256_set1_ps(o[2]));
            // one component of a x b, a1 b2 - (a2 b1) fused, as `cross` computes it
            let cross1 = |a1, b2, a2, b1| fms(a1, b2, mul(a2, b1));
            let rx = cross1(dy, cz, cy, dz);
            let ry = cross1(dz, cx, cz, dx);
            let rz = cross1(dx, cy, cx, dy);
            // a . b, (ax bx + ay by) + az bz with both additions fused, as `dot` computes it
            let dotv = |ax, ay, az, bx, by, bz| fma(az, bz, fma(ay, by, mul(ax, bx)));
            let dot = |ax, ay, az, bx: &[f32; 8], by: &[f32; 8], bz: &[f32; 8]| {
                dotv(ax, ay, az, ld(bx), ld(by), ld(bz))
            };
            // n = b x c, stored ([`Prim::triangle`]'s) or computed the same way.
            let (nx, ny, nz) = match normal {
                Some(n) => (ld(&n[0]), ld(&n[1]), ld(&n[2])),
                None => {
                    let (bx, by, bz) = (ld(&blk.b[0]), ld(&blk.b[1]), ld(&blk.b[2]));
                    let (ex, ey, ez) = (ld(&blk.c[0]), ld(&blk.c[1]), ld(&blk.c[2]));
                    (
                        cross1(by, ez, ey, bz),
                        cross1(bz, ex, ez, bx),
                        cross1(bx, ey, ex, by),
                    )
                }
            };
            let det = dotv(dx, dy, dz, nx, ny, nz);
            let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
            let u = mul(dot(rx, ry, rz, &blk.c[0], &blk.c[1], &blk.c[2]), inv_det);
            let v = mul(dot(rx, ry, rz, &blk.b[0], &blk.b[1], &blk.b[2]), inv_det);
            let w = sub(sub(_mm256_set1_ps(1.0), u), v);
            let t = mul(dotv(cx, cy, cz, nx, ny, nz), inv_det);
            let ok = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(t, _mm256_setzero_ps()),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max),
            );
            (ok, _mm256_or_ps(_mm256_or_ps(u, v), w), t, u, v)
        }
    }

    /// Test the lanes `lanes` (bits 0..8) of packet `b` against `r`: the mask of lanes hit in
    /// (0, t_max), their t, u, v in `tuv`. Spheres (in mixed scenes) are tested one by one.
    #[inline(always)]
    pub(super) fn test_block<const MIXED: bool, const ISA: u8>(
        &self,
        b: usize,
        lanes: u32,
        r: &TRay,
        t_max: f32,
        tuv: &mut [[f32; 8]; 3],
    ) -> u32 {
        // SAFETY: node lane bases and leaf offsets address packets the build wrote.
        let blk = unsafe { self.blocks.get_unchecked(b) };
        // (the heap-stack traversal of a deep tree takes this path in scenes without spheres
        // too, whose table is empty)
        let spheres = if MIXED {
            self.sphere_lanes.get(b).map_or(0, |&m| m as u32)
        } else {
            0
        };
        let mut hits = 0;
        if lanes & !spheres != 0 {
            #[cfg(target_arch = "x86_64")]
            if ISA >= ISA_AVX2 {
                // SAFETY: `ISA` is only AVX2 or above on CPUs with AVX2 (`Isa::supported`).
                hits = unsafe {
                    Self::flat_block(blk, None, r.o.to_array(), r.d.to_array(), t_max, Some(tuv))
                };
            } else {
                hits = block_portable(blk, r, t_max, tuv);
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                hits = block_portable(blk, r, t_max, tuv);
            }
            hits &= lanes & !spheres;
        }
        let mut s = lanes & spheres;
        while s != 0 {
            let l = s.trailing_zeros() as usize;
            s &= s - 1;
            let t = blk.sphere(l).intersect_sphere(r.o, r.d, t_max);
            if t > 0.0 && t < t_max {
                hits |= 1 << l;
                tuv[0][l] = t;
                tuv[1][l] = 0.0;
                tuv[2][l] = 0.0;
            }
        }
        hits
    }
}

/// [`Accel::flat_block`] without AVX2: [`Prim::intersect_triangle`] lane by lane, which performs
/// the same operations in the same order, so the results are bit-identical.
#[inline(always)]
fn block_portable(blk: &TriBlock, r: &TRay, t_max: f32, out: &mut [[f32; 8]; 3]) -> u32 {
    let mut hits = 0;
    for l in 0..8 {
        let row = |v: &[[f32; 8]; 3]| Vec3A::new(v[0][l], v[1][l], v[2][l]);
        let (b, c) = (row(&blk.b), row(&blk.c));
        // the lane's record as `Prim::triangle` makes it (the normal computed, as in the test)
        let p = Prim {
            a: row(&blk.a),
            b,
            c,
            d: cross(b, c),
        };
        let (t, u, v) = p.intersect_triangle(r);
        if t > 0.0 && t < t_max {
            hits |= 1 << l;
            out[0][l] = t;
            out[1][l] = u;
            out[2][l] = v;
        }
    }
    hits
}

/// Brute-force reference intersection (same primitive intersectors, no BVH); for tests.
#[doc(hidden)]
pub fn brute_force_intersect(
    triangles: &[Triangle],
    spheres: &[Sphere],
    ray: &Ray,
    t_max: f32,
) -> Option<Hit> {
    let r = TRay::new(ray);
    let mut best: Option<Hit> = None;
    let mut t_best = t_max;
    for (i, tri) in triangles.iter().enumerate() {
        let (t, u, v) = Prim::triangle(tri).intersect_triangle(&r);
        if t > 0.0 && t < t_best {
            t_best = t;
            best = Some(Hit {
                t,
                prim: i as u32,
                u,
                v,
            });
        }
    }
    for (i, s) in spheres.iter().enumerate() {
        let t = Prim::sphere(s).intersect_sphere(r.o, r.d, t_best);
        if t > 0.0 && t < t_best {
            t_best = t;
            best = Some(Hit {
                t,
                prim: (triangles.len() + i) as u32,
                u: 0.0,
                v: 0.0,
            });
        }
    }
    best
}
