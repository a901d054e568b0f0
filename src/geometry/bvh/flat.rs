//! The flat loops that trace tiny scenes without a traversal: the triangles 8 at a time (AVX2,
//! and the same compiled for AVX-512, whose closest hit keeps each lane's nearest hit in
//! registers), then the few spheres one by one, in the order and with the tests of a linear scan.

use glam::Vec3A;

use super::leaf::{Prim, TriBlock};
use super::{Accel, Isa};
use crate::geometry::{Hit, Sphere, Triangle};

/// Largest number of triangles of a scene traced with the flat loop instead of the BVH.
const FLAT_MAX: usize = 64;

/// Largest number of spheres of a scene traced with the flat loop, and of triangles beside them:
/// a sphere is one scalar test a ray, and the tree of a scene with spheres skips most of the
/// primitives a flat loop tests (counted in docs/performance.md §1, "Tiny scenes with spheres").
const FLAT_SPHERES_MAX: usize = 4;
/// Largest number of triangles beside spheres traced with the flat loop (see above).
const FLAT_MAX_WITH_SPHERES: usize = 32;

/// A packet of the flat loop of tiny scenes, with its normals stored: there the data stay in
/// the L1 cache and the arithmetic decides.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
pub(super) struct FlatBlock {
    tri: TriBlock,
    n: [[f32; 8]; 3],
}

/// The primitives of a scene small enough for the flat loops (at most [`FLAT_MAX`] triangles,
/// or [`FLAT_MAX_WITH_SPHERES`] and at most [`FLAT_SPHERES_MAX`] spheres; AVX2 or AVX-512
/// only): the triangles in their original order, 8 a packet, then the spheres, whose ids follow
/// the triangles'.
#[derive(Default)]
pub(super) struct Flat {
    /// Whether the scene is traced this way.
    pub(super) on: bool,
    blocks: Vec<FlatBlock>,
    spheres: Vec<Prim>,
    /// The first sphere's primitive id (the number of triangles).
    sphere_base: u32,
}

impl Flat {
    pub(super) fn new(triangles: &[Triangle], spheres: &[Sphere]) -> Flat {
        let max = if spheres.is_empty() {
            FLAT_MAX
        } else {
            FLAT_MAX_WITH_SPHERES
        };
        if triangles.len() > max
            || spheres.len() > FLAT_SPHERES_MAX
            || triangles.len() + spheres.len() == 0
            || !Isa::Avx2.supported()
        {
            return Flat::default();
        }
        let blocks = triangles
            .chunks(8)
            .map(|chunk| {
                let mut blk = FlatBlock::default();
                for (l, t) in chunk.iter().enumerate() {
                    let p = Prim::triangle(t);
                    blk.tri.set(l, &p);
                    for k in 0..3 {
                        blk.n[k][l] = p.d[k];
                    }
                }
                blk
            })
            .collect();
        Flat {
            on: true,
            blocks,
            spheres: spheres.iter().map(Prim::sphere).collect(),
            sphere_base: triangles.len() as u32,
        }
    }

    /// The nearest sphere hit in (0, `t_best`), if any, else `best`: the spheres in order, each
    /// taking the hit only if strictly nearer, as `brute_force_intersect` does.
    #[inline(always)]
    fn nearest_sphere(
        &self,
        o: Vec3A,
        d: Vec3A,
        mut best: Option<Hit>,
        mut t_best: f32,
    ) -> Option<Hit> {
        for (i, s) in self.spheres.iter().enumerate() {
            let t = s.intersect_sphere(o, d, t_best);
            if t > 0.0 && t < t_best {
                t_best = t;
                best = Some(Hit {
                    t,
                    prim: self.sphere_base + i as u32,
                    u: 0.0,
                    v: 0.0,
                });
            }
        }
        best
    }

    /// Whether a sphere is hit in (0, `t_max`).
    #[inline(always)]
    fn any_sphere(&self, o: Vec3A, d: Vec3A, t_max: f32) -> bool {
        self.spheres.iter().any(|s| {
            let t = s.intersect_sphere(o, d, t_max);
            t > 0.0 && t < t_max
        })
    }
}

impl Accel {
    /// Closest hit over the flat blocks, then, if `SPHERES`, the spheres ([`Flat`]; a scene
    /// without them does not pay for their loop, 5 % of cornell-box's instructions). The ray
    /// comes in registers, not behind a reference: loaded whole from a ray its caller has just
    /// stored piece by piece, it would wait for the stores to complete (a failed store-to-load
    /// forward; pt-hero on cornell-box ran 4–6 % slower that way).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1")]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn intersect_flat<const SPHERES: bool>(
        &self,
        ox: f32,
        oy: f32,
        oz: f32,
        dx: f32,
        dy: f32,
        dz: f32,
        t_max: f32,
    ) -> Option<Hit> {
        let (o, d) = ([ox, oy, oz], [dx, dy, dz]);
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        let mut tuv = [[0.0f32; 8]; 3];
        for (k, blk) in self.flat.blocks.iter().enumerate() {
            // Unused lanes are zero and never hit.
            let mut hits = Self::flat_block(&blk.tri, Some(&blk.n), o, d, t_best, Some(&mut tuv));
            while hits != 0 {
                let l = hits.trailing_zeros() as usize;
                hits &= hits - 1;
                // Lowest index wins ties, as in a linear scan.
                if tuv[0][l] < t_best {
                    t_best = tuv[0][l];
                    best = Some(Hit {
                        t: t_best,
                        prim: (k * 8 + l) as u32,
                        u: tuv[1][l],
                        v: tuv[2][l],
                    });
                }
            }
        }
        if !SPHERES {
            return best;
        }
        let (o, d) = (Vec3A::from_array(o), Vec3A::from_array(d));
        self.flat.nearest_sphere(o, d, best, t_best)
    }

    /// Closest hit over the flat blocks on the AVX-512 path: each lane keeps its nearest hit
    /// across the blocks in registers (t, u, v and the block), and one reduction at the end
    /// picks the nearest of the eight, the lowest index on a tie, as a linear scan would. It
    /// needs AVX-512's thirty-two registers: with AVX2's sixteen the loop spills, and pt-hero
    /// on cornell-box ran 0.97× as fast (docs/performance.md §1), so AVX2 keeps
    /// [`Self::intersect_flat`]. Inlined into its entry point, so the ray stays in registers
    /// whatever the signature.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma,popcnt,bmi1")]
    fn intersect_flat_lanes<const SPHERES: bool>(
        &self,
        o: [f32; 3],
        d: [f32; 3],
        t_max: f32,
    ) -> Option<Hit> {
        use std::arch::x86_64::*;
        let mut bt = _mm256_set1_ps(t_max);
        let (mut bu, mut bv) = (_mm256_setzero_ps(), _mm256_setzero_ps());
        let mut bk = _mm256_setzero_ps();
        for (k, blk) in self.flat.blocks.iter().enumerate() {
            // Unused lanes are zero and never hit; a lane takes a hit only if strictly nearer,
            // so the earlier block keeps a tie.
            let (ok, neg, t, u, v) = Self::block_lanes(&blk.tri, Some(&blk.n), o, d, bt);
            // blendv reads the sign bit only: set where t is in range and u, v, w are not negative.
            let hit = _mm256_andnot_ps(neg, ok);
            bt = _mm256_blendv_ps(bt, t, hit);
            bu = _mm256_blendv_ps(bu, u, hit);
            bv = _mm256_blendv_ps(bv, v, hit);
            bk = _mm256_blendv_ps(bk, _mm256_castsi256_ps(_mm256_set1_epi32(k as i32)), hit);
        }
        // The nearest t of the eight lanes in every lane.
        let m = _mm256_min_ps(bt, _mm256_permute2f128_ps::<1>(bt, bt));
        let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
        let m = _mm256_min_ps(m, _mm256_permute_ps::<0b10_11_00_01>(m));
        let t_best = _mm256_cvtss_f32(m);
        let (ov, dv) = (Vec3A::from_array(o), Vec3A::from_array(d));
        if !(t_best < t_max) {
            return if SPHERES {
                self.flat.nearest_sphere(ov, dv, None, t_max)
            } else {
                None
            };
        }
        let mut near = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(bt, m)) as u32;
        let (mut uv, mut ks) = ([[0.0f32; 8]; 2], [0u32; 8]);
        // SAFETY: each store writes one whole `[f32; 8]` or `[u32; 8]`.
        unsafe {
            _mm256_storeu_ps(uv[0].as_mut_ptr(), bu);
            _mm256_storeu_ps(uv[1].as_mut_ptr(), bv);
            _mm256_storeu_ps(ks.as_mut_ptr().cast(), bk);
        }
        let (mut best, mut lane) = (u32::MAX, 0);
        while near != 0 {
            let l = near.trailing_zeros() as usize;
            near &= near - 1;
            let prim = ks[l] * 8 + l as u32;
            if prim < best {
                (best, lane) = (prim, l);
            }
        }
        let hit = Hit {
            t: t_best,
            prim: best,
            u: uv[0][lane],
            v: uv[1][lane],
        };
        if SPHERES {
            self.flat.nearest_sphere(ov, dv, Some(hit), t_best)
        } else {
            Some(hit)
        }
    }

    /// Any hit over the flat blocks and the spheres, the ray in registers as for
    /// [`Self::intersect_flat`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1")]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn occluded_flat<const SPHERES: bool>(
        &self,
        ox: f32,
        oy: f32,
        oz: f32,
        dx: f32,
        dy: f32,
        dz: f32,
        t_max: f32,
    ) -> bool {
        let (o, d) = ([ox, oy, oz], [dx, dy, dz]);
        self.flat
            .blocks
            .iter()
            .any(|blk| Self::flat_block(&blk.tri, Some(&blk.n), o, d, t_max, None) != 0)
            || (SPHERES
                && self
                    .flat
                    .any_sphere(Vec3A::from_array(o), Vec3A::from_array(d), t_max))
    }

    ray_entry!(
        /// [`Self::intersect_flat_lanes`]: the AVX-512 path, 8 lanes (testing two packets at once
        /// in 16 lanes traced the Cornell box's rays 1.25× as fast alone, but made pt-hero 0.89×
        /// as fast, the 512-bit instructions slowing the shading code around them;
        /// docs/performance.md §1).
        intersect_flat_avx512,
        "avx512f,avx512vl,avx512dq,avx2,fma,popcnt,bmi1",
        Option<Hit>,
        |a, ray, t_max| {
            a.intersect_flat_lanes::<false>(ray.o.to_array(), ray.d.to_array(), t_max)
        }
    );

    ray_entry!(
        /// [`Self::intersect_flat_avx512`] for a scene with spheres.
        intersect_flat_spheres_avx512,
        "avx512f,avx512vl,avx512dq,avx2,fma,popcnt,bmi1",
        Option<Hit>,
        |a, ray, t_max| {
            a.intersect_flat_lanes::<true>(ray.o.to_array(), ray.d.to_array(), t_max)
        }
    );

    ray_entry!(
        /// [`Self::occluded_flat`] compiled for AVX-512, as [`Self::intersect_flat_avx512`].
        occluded_flat_avx512,
        "avx512f,avx512vl,avx512dq,avx2,fma,popcnt,bmi1",
        bool,
        |a, ray, t_max| {
            let (o, d) = (ray.o, ray.d);
            a.occluded_flat::<false>(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
        }
    );

    ray_entry!(
        /// [`Self::occluded_flat_avx512`] for a scene with spheres.
        occluded_flat_spheres_avx512,
        "avx512f,avx512vl,avx512dq,avx2,fma,popcnt,bmi1",
        bool,
        |a, ray, t_max| {
            let (o, d) = (ray.o, ray.d);
            a.occluded_flat::<true>(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
        }
    );
}
