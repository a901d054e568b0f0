//! The two node layouts of the BVH8 and their visits: [`Node8`], full-precision child boxes
//! (Embree's `AABBNode8` layout, 256 bytes) in the tree of [`super::collapse`] with leaves of up
//! to 8 primitives, one packet each; and the compressed CWBVH node of `obvhs` (`CwBvhNode`, 80
//! bytes, child boxes quantised to 8 bits, leaves of up to 3 primitives sharing the node's
//! packets). A visit tests the ray against the 8 child boxes and returns the hit internal slots
//! and the hit leaves, without a branch per child where AVX2 is used.
//!
//! The full layout needs no decoding and its tree is shallower; the compressed one touches less
//! memory, which pays once the nodes no longer fit in the caches ([`FULL_NODES_MAX`]).

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::node::CwBvhNode;
use std::mem::MaybeUninit;

use super::prefetch;
use crate::geometry::Ray;

/// Bytes of one leaf packet (`TriBlock`).
pub(super) const PACKET_BYTES: usize = 320;

/// Largest BVH (in nodes) traced with [`Node8`]: 8 MiB of full nodes. Larger ones keep the
/// compressed nodes. Measured: soup100k (4 800 full nodes) 1.3× faster with full nodes; the
/// 1M-triangle sets (49 000–70 000 full nodes) within the noise of either, soup1m 7 % slower.
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

/// What a node visit found: the hit internal slots and the hit leaves (their meaning is the
/// layout's: see [`WideNode::leaf_packets`]).
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
    /// Ask for the node's leaf packets (`blocks`: the first packet) while the boxes are tested.
    fn prefetch_leaves(&self, blocks: *const u8);
    /// Call `f(packet, lanes)` for each packet of the hit leaves `leaves` of a [`Visit`], until
    /// it returns true (then true).
    fn leaf_packets(&self, leaves: u32, f: impl FnMut(usize, u32) -> bool) -> bool;
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

/// A BVH8 node with its children's boxes in full precision, plane by plane (Embree's
/// `AABBNode8` layout): a visit needs no decoding. Built by [`super::collapse`]; each leaf child
/// is one packet of its own.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Node8 {
    /// Child box planes: min x, max x, min y, max y, min z, max z, each per slot. Empty slots
    /// are inverted (+∞ … −∞) and never hit.
    planes: [[f32; 8]; 6],
    /// Per slot: an internal child's node index; a leaf child's packet with [`LEAF`] set; 0 for
    /// an empty slot.
    child: [u32; 8],
}

impl Node8 {
    /// A node without children.
    pub fn empty() -> Node8 {
        Node8 {
            planes: EMPTY_PLANES,
            child: [0; 8],
        }
    }

    /// Slot `slot` holds `aabb`, rounded outwards by one ulp (the boxes of split triangle
    /// pieces are clipped in floating point).
    fn set_box(&mut self, slot: usize, aabb: &Aabb) {
        for k in 0..3 {
            self.planes[2 * k][slot] = aabb.min[k].next_down();
            self.planes[2 * k + 1][slot] = aabb.max[k].next_up();
        }
    }

    /// Slot `slot` is the leaf `packet` with box `aabb`.
    pub fn set_leaf(&mut self, slot: usize, aabb: &Aabb, packet: u32) {
        assert!(packet < LEAF, "too many leaves");
        self.set_box(slot, aabb);
        self.child[slot] = LEAF | packet;
    }

    /// Slot `slot` is the internal node `node` with box `aabb`.
    pub fn set_inner(&mut self, slot: usize, aabb: &Aabb, node: u32) {
        self.set_box(slot, aabb);
        self.child[slot] = node;
    }
}

impl WideNode for Node8 {
    const LINES: usize = 4;

    /// The first packet is not known without a look at the slots; these BVHs are small.
    #[inline(always)]
    fn prefetch_leaves(&self, _blocks: *const u8) {}

    /// `leaves` are the hit leaf slots; each is one packet, all of whose lanes are tested
    /// (unused lanes never hit).
    #[inline(always)]
    fn leaf_packets(&self, mut leaves: u32, mut f: impl FnMut(usize, u32) -> bool) -> bool {
        while leaves != 0 {
            let i = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            if f((self.child[i] & !LEAF) as usize, 0xff) {
                return true;
            }
        }
        false
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
            if tmin <= tmax && self.child[i] != 0 {
                if self.child[i] & LEAF != 0 {
                    leaves |= 1 << i;
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
        let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32;
        // the sign bits of `child` are the leaf slots
        let leaf = _mm256_movemask_ps(_mm256_loadu_ps(node.child.as_ptr() as *const f32)) as u32;
        Visit {
            inner: hit & !leaf,
            leaves: hit & leaf,
        }
    }
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

    /// The node's first packet (5 cache lines); nodes without leaves prefetch packet 0, without
    /// a branch.
    #[inline(always)]
    fn prefetch_leaves(&self, blocks: *const u8) {
        let has_leaves = (self.imask != 0xff) as usize;
        let first = has_leaves * (self.primitive_base_idx as usize / 8);
        prefetch(blocks.wrapping_add(first * PACKET_BYTES), 5);
    }

    /// `leaves` are lanes from the node's first packet (bits 0..24): each packet with a lane.
    #[inline(always)]
    fn leaf_packets(&self, mut leaves: u32, mut f: impl FnMut(usize, u32) -> bool) -> bool {
        let base = self.primitive_base_idx as usize / 8;
        while leaves != 0 {
            let k = leaves.trailing_zeros() as usize / 8;
            let lanes = (leaves >> (8 * k)) & 0xff;
            leaves &= !(0xff << (8 * k));
            if f(base + k, lanes) {
                return true;
            }
        }
        false
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
