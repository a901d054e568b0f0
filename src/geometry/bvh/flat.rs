//! The flat 8-wide loops that trace tiny triangle-only scenes without a traversal (AVX2, and the
//! same compiled for AVX-512).

use super::leaf::{Prim, TriBlock};
use super::{Accel, Isa};
use crate::geometry::{Hit, Sphere, Triangle};

/// Largest triangle-only scene traced with the flat loop instead of the BVH.
const FLAT_MAX: usize = 64;

/// A packet of the flat loop of tiny scenes, with its normals stored: there the data stay in
/// the L1 cache and the arithmetic decides.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
pub(super) struct FlatBlock {
    tri: TriBlock,
    n: [[f32; 8]; 3],
}

impl Accel {
    pub(super) fn flat_blocks(triangles: &[Triangle], spheres: &[Sphere]) -> Vec<FlatBlock> {
        if !spheres.is_empty() || triangles.len() > FLAT_MAX || !Isa::Avx2.supported() {
            return Vec::new();
        }
        triangles
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
            .collect()
    }

    /// Closest hit over the flat blocks (a scene of at most `FLAT_MAX` triangles). The ray
    /// comes in registers, not behind a reference: loaded whole from a ray its caller has just
    /// stored piece by piece, it would wait for the stores to complete (a failed store-to-load
    /// forward; pt-hero on cornell-box ran 4–6 % slower that way).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi1")]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn intersect_flat(
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
        for (k, blk) in self.flat.iter().enumerate() {
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
        best
    }

    /// Any hit over the flat blocks, the ray in registers as for [`Self::intersect_flat`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi1")]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn occluded_flat(
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
            .iter()
            .any(|blk| Self::flat_block(&blk.tri, Some(&blk.n), o, d, t_max, None) != 0)
    }

    ray_entry!(
        /// [`Self::intersect_flat`] on the AVX-512 path, 8 lanes (testing two packets at once in
        /// 16 lanes traced the Cornell box's rays 1.25× as fast alone, but made pt-hero 0.89× as
        /// fast, the 512-bit instructions slowing the shading code around them;
        /// docs/performance.md §1). The compiler does not inline the AVX2 loop here (this entry
        /// is a jump to it, `nm -S`), so the closest hit of tiny scenes runs the AVX2 code on
        /// this path too; the any-hit loop below is inlined and compiled for AVX-512.
        intersect_flat_avx512,
        "avx512f,avx512vl,avx512dq,avx2,popcnt,bmi1",
        Option<Hit>,
        |a, ray, t_max| {
            let (o, d) = (ray.o, ray.d);
            a.intersect_flat(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
        }
    );

    ray_entry!(
        /// [`Self::occluded_flat`] compiled for AVX-512, as [`Self::intersect_flat_avx512`].
        occluded_flat_avx512,
        "avx512f,avx512vl,avx512dq,avx2,popcnt,bmi1",
        bool,
        |a, ray, t_max| {
            let (o, d) = (ray.o, ray.d);
            a.occluded_flat(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
        }
    );
}
