//! The two node layouts of the BVH8 and their visits: [`Node8`], the CWBVH node decoded to full
//! precision (Embree's `AABBNode8` layout, 256 bytes), and the compressed CWBVH node itself
//! (`obvhs`' `CwBvhNode`, 80 bytes, child boxes quantised to 8 bits). A visit tests the ray
//! against the 8 child boxes and returns the hit internal slots and the lanes of the hit leaf
//! children, without a branch per child where AVX2 is used.
//!
//! The full layout needs no decoding (about half the instructions of a visit); the compressed
//! one touches a third of the memory, which wins once the nodes no longer fit in the caches
//! ([`FULL_NODES_MAX`]).

use glam::Vec3A;
use obvhs::cwbvh::node::CwBvhNode;
use std::mem::MaybeUninit;

use crate::geometry::Ray;

/// Largest BVH (in nodes) traced with [`Node8`]: 8 MiB of full nodes. Larger ones keep the
/// compressed nodes (measured: soup100k, 11 k nodes, 9 % faster with full nodes; the 1M-triangle
/// sets, 110–140 k nodes, 10–15 % slower).
pub(super) const FULL_NODES_MAX: usize = (8 << 20) / std::mem::size_of::<Node8>();

/// Traversal ray: origin, direction, clamped reciprocal direction.
#[derive(Clone, Copy)]
pub(super) struct TRay {
    pub o: Vec3A,
    pub d: Vec3A,
    pub inv_d: Vec3A,
    /// Plane numbers (0 min x, 1 max x, 2 min y, … 5 max z) of the near and far child planes
    /// per axis: the max plane is the near one where the direction is negative. Chosen once per
    /// ray, so a visit does not branch on the direction.
    planes: [usize; 6],
}

impl TRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> TRay {
        let d = Vec3A::from(ray.d);
        // Avoid infinities (0 * inf = NaN in the slab test): clamp tiny components.
        let safe = |x: f32| {
            if x.abs() < 1e-20 {
                1.0 / 1e-20f32.copysign(x)
            } else {
                1.0 / x
            }
        };
        let axis = |neg: bool, k: usize| {
            if neg {
                [2 * k + 1, 2 * k]
            } else {
                [2 * k, 2 * k + 1]
            }
        };
        let [nx, fx] = axis(d.x < 0.0, 0);
        let [ny, fy] = axis(d.y < 0.0, 1);
        let [nz, fz] = axis(d.z < 0.0, 2);
        TRay {
            o: Vec3A::from(ray.o),
            d,
            inv_d: Vec3A::new(safe(d.x), safe(d.y), safe(d.z)),
            planes: [nx, fx, ny, fy, nz, fz],
        }
    }
}

/// What a node visit found: the hit internal slots and the lanes of the hit leaf children
/// (relative to the node's first packet, bits 0..24).
pub(super) struct Visit {
    pub inner: u32,
    pub leaves: u32,
}

/// Traversal stack entry: node index and the ray's entry distance into its box.
#[derive(Clone, Copy, Default)]
#[repr(C)]
pub(super) struct Entry {
    pub node: u32,
    pub t: f32,
}

/// A node layout the traversal can visit.
pub(super) trait WideNode {
    /// Cache lines to prefetch for a node.
    const LINES: usize;
    /// The node's first packet of leaf lanes.
    fn packet_base(&self) -> usize;
    /// Whether any slot is a leaf.
    fn has_leaves(&self) -> bool;
    /// Node index of the internal child in `slot`.
    fn inner_child(&self, slot: usize) -> u32;
    /// Test `r` against the child boxes with t in [0, t_max]; entry distances to `tmin_out`.
    fn visit<const AVX: bool>(&self, r: &TRay, t_max: f32, tmin_out: &mut [f32; 8]) -> Visit;
    /// Write the entries of the internal children in `inner` to `out` (8 entries, all written).
    fn write_inner<const AVX: bool>(
        &self,
        inner: u32,
        tmins: &[f32; 8],
        out: &mut [MaybeUninit<Entry>],
    );
}

/// `_mm_max_ps(a, b)` lane by lane: `b` unless `a > b` (so `b` where either is NaN).
#[inline(always)]
fn max_ps(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `_mm_min_ps(a, b)` lane by lane: `b` unless `a < b`.
#[inline(always)]
fn min_ps(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Planes of a node with 8 empty slots (inverted boxes).
const EMPTY_PLANES: [[f32; 8]; 6] = {
    let (lo, hi) = ([f32::INFINITY; 8], [f32::NEG_INFINITY; 8]);
    [lo, hi, lo, hi, lo, hi]
};

/// Top bit of [`Node8::child`]: the slot is a leaf.
const LEAF: u32 = 1 << 31;

/// A BVH8 node: a CWBVH node with its children's boxes decoded once at build time (rounded
/// outwards, so they contain the quantised boxes) and kept in full precision, plane by plane.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Node8 {
    /// Child box planes: min x, max x, min y, max y, min z, max z, each per slot. Empty slots
    /// are inverted (+∞ … −∞) and never hit.
    planes: [[f32; 8]; 6],
    /// Per slot: an internal child's node index; a leaf child's lanes (relative to
    /// `packet_base`) with [`LEAF`] set; 0 for an empty slot.
    child: [u32; 8],
    packet_base: u32,
    /// Internal slots.
    imask: u8,
}

impl Node8 {
    /// Decode CWBVH node `n` (leaves packed: `primitive_base_idx` is a packet's first lane).
    pub fn from_cwbvh(n: &CwBvhNode) -> Node8 {
        let ext = n.compute_extent();
        let p = Vec3A::from(n.p);
        let mut node = Node8 {
            planes: EMPTY_PLANES,
            child: [0; 8],
            packet_base: n.primitive_base_idx / 8,
            imask: n.imask,
        };
        let q = [
            (&n.child_min_x, &n.child_max_x),
            (&n.child_min_y, &n.child_max_y),
            (&n.child_min_z, &n.child_max_z),
        ];
        for i in 0..8 {
            let meta = n.child_meta[i];
            if meta == 0 {
                continue;
            }
            for (k, (lo, hi)) in q.iter().enumerate() {
                // p + q·2^e, rounded outwards: the decoded box contains the quantised one
                node.planes[2 * k][i] = (p[k] + lo[i] as f32 * ext[k]).next_down();
                node.planes[2 * k + 1][i] = (p[k] + hi[i] as f32 * ext[k]).next_up();
            }
            node.child[i] = if is_inner(meta) {
                n.inner_child(i)
            } else {
                LEAF | leaf_lanes(meta)
            };
        }
        node
    }
}

impl WideNode for Node8 {
    const LINES: usize = 4;

    #[inline(always)]
    fn packet_base(&self) -> usize {
        self.packet_base as usize
    }

    #[inline(always)]
    fn has_leaves(&self) -> bool {
        self.imask != 0xff
    }

    #[inline(always)]
    fn inner_child(&self, slot: usize) -> u32 {
        self.child[slot]
    }

    /// The slab test per plane as (p − o) / d, the near planes' maximum against the far
    /// planes' minimum.
    #[inline(always)]
    fn visit<const AVX: bool>(&self, r: &TRay, t_max: f32, tmin_out: &mut [f32; 8]) -> Visit {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            // SAFETY: `AVX` is only true in code reached after checking for AVX2 support.
            return unsafe { visit_full_avx2(self, r, t_max, tmin_out) };
        }
        let (o, inv) = (r.o.to_array(), r.inv_d.to_array());
        let [nx, fx, ny, fy, nz, fz] = r.planes.map(|k| &self.planes[k]);
        let (mut inner, mut leaves) = (0, 0);
        for i in 0..8 {
            let t = |p: &[f32; 8], k: usize| (p[i] - o[k]) * inv[k];
            let tmin = max_ps(max_ps(t(nx, 0), t(ny, 1)), max_ps(t(nz, 2), 0.0));
            let tmax = min_ps(min_ps(t(fx, 0), t(fy, 1)), min_ps(t(fz, 2), t_max));
            tmin_out[i] = tmin;
            if tmin <= tmax {
                if self.child[i] & LEAF != 0 {
                    leaves |= self.child[i] & !LEAF;
                } else {
                    inner |= 1 << i;
                }
            }
        }
        Visit { inner, leaves }
    }

    #[inline(always)]
    fn write_inner<const AVX: bool>(
        &self,
        inner: u32,
        tmins: &[f32; 8],
        out: &mut [MaybeUninit<Entry>],
    ) {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            // SAFETY: `AVX` is only true on the AVX2 path.
            unsafe {
                let child = std::arch::x86_64::_mm256_loadu_si256(self.child.as_ptr().cast());
                write_packed_avx2(child, inner, tmins, out)
            };
            return;
        }
        let pack = &PACK[inner as usize & 0xff];
        for (o, &i) in out[..8].iter_mut().zip(pack) {
            let i = i as usize;
            *o = MaybeUninit::new(Entry {
                node: self.child[i],
                t: tmins[i],
            });
        }
    }
}

/// AVX2 [`Node8::visit`]: the same operations, all 8 slots at once, no branches.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn visit_full_avx2(node: &Node8, r: &TRay, t_max: f32, tmin_out: &mut [f32; 8]) -> Visit {
    use std::arch::x86_64::*;
    let [nx, fx, ny, fy, nz, fz] = r.planes.map(|k| node.planes[k].as_ptr());
    let (o, inv) = (r.o, r.inv_d);
    // SAFETY: AVX2 is enabled for this function; every load reads one `[f32; 8]` or `[u32; 8]`
    // field of the node.
    unsafe {
        let t = |p: *const f32, o: f32, inv: f32| {
            _mm256_mul_ps(
                _mm256_sub_ps(_mm256_loadu_ps(p), _mm256_set1_ps(o)),
                _mm256_set1_ps(inv),
            )
        };
        let tmin = _mm256_max_ps(
            _mm256_max_ps(t(nx, o.x, inv.x), t(ny, o.y, inv.y)),
            _mm256_max_ps(t(nz, o.z, inv.z), _mm256_setzero_ps()),
        );
        let tmax = _mm256_min_ps(
            _mm256_min_ps(t(fx, o.x, inv.x), t(fy, o.y, inv.y)),
            _mm256_min_ps(t(fz, o.z, inv.z), _mm256_set1_ps(t_max)),
        );
        _mm256_storeu_ps(tmin_out.as_mut_ptr(), tmin);
        let hit = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax));
        let child = _mm256_loadu_si256(node.child.as_ptr() as *const __m256i);
        let leaf = _mm256_srai_epi32::<31>(child);
        let inner = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_andnot_si256(leaf, hit))) as u32;
        let lanes = _mm256_and_si256(child, _mm256_and_si256(leaf, hit));
        Visit {
            inner,
            leaves: or_lanes(lanes) & !LEAF,
        }
    }
}

/// The OR of 8 u32 lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn or_lanes(x: std::arch::x86_64::__m256i) -> u32 {
    use std::arch::x86_64::*;
    let x = _mm_or_si128(_mm256_castsi256_si128(x), _mm256_extracti128_si256::<1>(x));
    let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b01_00_11_10>(x));
    let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b10_11_00_01>(x));
    _mm_cvtsi128_si32(x) as u32
}

/// Is child slot `meta` an internal node? (Internal slots store `24 + slot` in the low 5 bits with
/// the high bits `001`; leaf slots store a primitive offset < 24.)
#[inline(always)]
pub(super) fn is_inner(meta: u8) -> bool {
    meta & 0b1_1000 == 0b1_1000
}

/// Lanes (node-relative, bits 0..24) of the leaf child with metadata `meta`.
#[inline(always)]
pub(super) fn leaf_lanes(meta: u8) -> u32 {
    ((1u32 << (meta >> 5).count_ones()) - 1) << (meta & 0b1_1111)
}

impl WideNode for CwBvhNode {
    const LINES: usize = 2;

    #[inline(always)]
    fn packet_base(&self) -> usize {
        self.primitive_base_idx as usize / 8
    }

    #[inline(always)]
    fn has_leaves(&self) -> bool {
        self.imask != 0xff
    }

    #[inline(always)]
    fn inner_child(&self, slot: usize) -> u32 {
        self.child_base_idx + (self.imask as u32 & ((1u32 << slot) - 1)).count_ones()
    }

    /// The quantised boxes relative to the node: t = q · (2^e / d) + (p − o) / d per plane
    /// (`CwBvhNode::intersect_ray_simd`'s arithmetic, with t_min = 0 instead of its 1e-4).
    #[inline(always)]
    fn visit<const AVX: bool>(&self, r: &TRay, t_max: f32, tmin_out: &mut [f32; 8]) -> Visit {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            // SAFETY: `AVX` is only true in code reached after checking for AVX2 support.
            return unsafe { visit_compressed_avx2(self, r, t_max, tmin_out) };
        }
        let adj_dir_inv = (self.compute_extent() * r.inv_d).to_array();
        let adj_orig = ((Vec3A::from(self.p) - r.o) * r.inv_d).to_array();
        let [nx, fx, ny, fy, nz, fz] = r.planes.map(|k| quantised_plane(self, k));
        let (mut inner, mut leaves) = (0, 0);
        for i in 0..8 {
            let t = |q: &[u8; 8], k: usize| q[i] as f32 * adj_dir_inv[k] + adj_orig[k];
            let tmin = max_ps(max_ps(t(nx, 0), t(ny, 1)), max_ps(t(nz, 2), 0.0));
            let tmax = min_ps(min_ps(t(fx, 0), t(fy, 1)), min_ps(t(fz, 2), t_max));
            tmin_out[i] = tmin;
            let meta = self.child_meta[i];
            if tmin <= tmax && meta != 0 {
                if is_inner(meta) {
                    inner |= 1 << i;
                } else {
                    leaves |= leaf_lanes(meta);
                }
            }
        }
        Visit { inner, leaves }
    }

    #[inline(always)]
    fn write_inner<const AVX: bool>(
        &self,
        inner: u32,
        tmins: &[f32; 8],
        out: &mut [MaybeUninit<Entry>],
    ) {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            // SAFETY: `AVX` is only true on the AVX2 path; the load reads one `[u8; 8]` row.
            unsafe {
                use std::arch::x86_64::*;
                let rank = INNER_RANK[self.imask as usize].as_ptr() as *const __m128i;
                let child = _mm256_add_epi32(
                    _mm256_cvtepu8_epi32(_mm_loadl_epi64(rank)),
                    _mm256_set1_epi32(self.child_base_idx as i32),
                );
                write_packed_avx2(child, inner, tmins, out)
            };
            return;
        }
        let pack = &PACK[inner as usize & 0xff];
        for (o, &i) in out[..8].iter_mut().zip(pack) {
            let i = i as usize;
            *o = MaybeUninit::new(Entry {
                node: self.inner_child(i),
                t: tmins[i],
            });
        }
    }
}

/// Per `imask`: for each slot, the number of internal slots below it (an internal child's
/// offset from `child_base_idx`).
const INNER_RANK: [[u8; 8]; 256] = {
    let mut t = [[0u8; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let mut i = 0;
        while i < 8 {
            t[m][i] = (m & ((1 << i) - 1)).count_ones() as u8;
            i += 1;
        }
        m += 1;
    }
    t
};

/// Plane `k` (0 min x, 1 max x, …, 5 max z) of a CWBVH node's quantised child boxes: the six
/// `[u8; 8]` fields follow one another in that order (`CwBvhNode` is `repr(C)`).
#[inline(always)]
fn quantised_plane(n: &CwBvhNode, k: usize) -> &[u8; 8] {
    const FIRST: usize = std::mem::offset_of!(CwBvhNode, child_min_x);
    const _: () = assert!(std::mem::offset_of!(CwBvhNode, child_max_z) == FIRST + 40);
    debug_assert!(k < 6);
    let base = (n as *const CwBvhNode as *const u8).wrapping_add(FIRST + 8 * k);
    // SAFETY: k < 6 (`TRay::planes` holds plane numbers), and bytes FIRST + 8k .. FIRST + 8k + 8
    // of the node are the field of plane k
    unsafe { &*(base as *const [u8; 8]) }
}

/// AVX2 [`CwBvhNode`] visit: the same operations, all 8 slots at once, no branches.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn visit_compressed_avx2(node: &CwBvhNode, r: &TRay, t_max: f32, tmin_out: &mut [f32; 8]) -> Visit {
    use std::arch::x86_64::*;
    let adj_dir_inv = node.compute_extent() * r.inv_d;
    let adj_orig = (Vec3A::from(node.p) - r.o) * r.inv_d;
    let [nx, fx, ny, fy, nz, fz] = r.planes.map(|k| quantised_plane(node, k).as_ptr());
    // SAFETY: AVX2 is enabled for this function; the 8-byte loads read one `[u8; 8]` field each.
    unsafe {
        let q = |p: *const u8| {
            _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(p as *const __m128i)))
        };
        let t = |p: *const u8, d: f32, o: f32| {
            _mm256_add_ps(_mm256_mul_ps(q(p), _mm256_set1_ps(d)), _mm256_set1_ps(o))
        };
        let tmin = _mm256_max_ps(
            _mm256_max_ps(
                t(nx, adj_dir_inv.x, adj_orig.x),
                t(ny, adj_dir_inv.y, adj_orig.y),
            ),
            _mm256_max_ps(t(nz, adj_dir_inv.z, adj_orig.z), _mm256_setzero_ps()),
        );
        let tmax = _mm256_min_ps(
            _mm256_min_ps(
                t(fx, adj_dir_inv.x, adj_orig.x),
                t(fy, adj_dir_inv.y, adj_orig.y),
            ),
            _mm256_min_ps(t(fz, adj_dir_inv.z, adj_orig.z), _mm256_set1_ps(t_max)),
        );
        _mm256_storeu_ps(tmin_out.as_mut_ptr(), tmin);
        let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32;
        let empty = _mm_movemask_epi8(_mm_cmpeq_epi8(
            _mm_loadl_epi64(node.child_meta.as_ptr() as *const __m128i),
            _mm_setzero_si128(),
        )) as u32;
        let hit = hit & !empty & 0xff;
        // the leaves' lanes one hit leaf at a time: fewer instructions than all 8 slots at
        // once for these nodes, whose visits wait on memory more than on arithmetic
        let mut leaf_hits = hit & !(node.imask as u32);
        let mut leaves = 0;
        while leaf_hits != 0 {
            let i = leaf_hits.trailing_zeros() as usize;
            leaf_hits &= leaf_hits - 1;
            leaves |= leaf_lanes(node.child_meta[i]);
        }
        Visit {
            inner: hit & node.imask as u32,
            leaves,
        }
    }
}

/// Per 8-bit mask: its set bits in increasing order, then zeros (the left-packing permutation).
const PACK: [[u8; 8]; 256] = {
    let mut t = [[0u8; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let (mut i, mut k) = (0, 0);
        while i < 8 {
            if m & (1 << i) != 0 {
                t[m][k] = i as u8;
                k += 1;
            }
            i += 1;
        }
        m += 1;
    }
    t
};

/// Write the entries (child node from `child`, t) of the slots in `inner` to `out`, in slot order and without
/// gaps, with one left-pack; all 8 entries are written (the rest repeat slot 0's and are not
/// used).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn write_packed_avx2(
    child: std::arch::x86_64::__m256i,
    inner: u32,
    tmins: &[f32; 8],
    out: &mut [MaybeUninit<Entry>],
) {
    use std::arch::x86_64::*;
    let out = &mut out[..8];
    let pack = &PACK[inner as usize & 0xff];
    // SAFETY: AVX2 is enabled for this function; the loads read one `[u8; 8]` table row and
    // `tmins`; the two stores write the 8 entries of `out` (64 bytes, `Entry` is repr(C)).
    unsafe {
        let idx = _mm256_cvtepu8_epi32(_mm_loadl_epi64(pack.as_ptr() as *const __m128i));
        let child = _mm256_permutevar8x32_epi32(child, idx);
        let t = _mm256_castps_si256(_mm256_permutevar8x32_ps(
            _mm256_loadu_ps(tmins.as_ptr()),
            idx,
        ));
        // (node, t) pairs: unpack within 128-bit halves, then put the halves in order
        let lo = _mm256_unpacklo_epi32(child, t);
        let hi = _mm256_unpackhi_epi32(child, t);
        let dst = out.as_mut_ptr() as *mut __m256i;
        _mm256_storeu_si256(dst, _mm256_permute2x128_si256::<0x20>(lo, hi));
        _mm256_storeu_si256(dst.add(1), _mm256_permute2x128_si256::<0x31>(lo, hi));
    }
}
