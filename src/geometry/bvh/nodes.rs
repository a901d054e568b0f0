//! The two node layouts of the BVH8 that [`super::collapse`] writes, and their visits:
//! [`Node8`], full-precision child boxes (Embree's `AABBNode8` layout, 256 bytes), and
//! [`QNode8`], child boxes quantised to 8 bits per plane (the CWBVH encoding, 80 bytes). A
//! visit tests the ray against the 8 child boxes and returns the hit internal slots and the hit
//! leaves (one packet each), without a branch per child where AVX2 is used.
//!
//! The full layout needs no decoding; the quantised one touches a third of the memory, which
//! pays once the nodes no longer fit in the caches ([`FULL_NODES_MAX`]). Larger trees take both
//! (`Nodes::Tiered`): full nodes for their top levels, which every ray visits and which stay
//! cached, quantised ones below.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use std::mem::MaybeUninit;

use super::isa::{ISA_AVX2, ISA_AVX512};
use super::prefetch;
use crate::geometry::Ray;

/// Bytes of one leaf packet (`TriBlock`).
pub(super) const PACKET_BYTES: usize = 320;

/// Largest BVH (in nodes) traced with [`Node8`] alone: 2 MiB of full nodes. Measured (medians
/// of paired rounds, the quantised layout's speed over the full one's; docs/performance.md,
/// section 1): soup100k (3 463 nodes) 0.92×, the 300k-triangle sets (10 300–11 000 nodes)
/// 1.01–1.03×, the 600k sets (20 400–20 500) 1.10–1.11×, the 1M sets (34 000–44 000)
/// 1.14–1.21×. Larger trees keep as many of their top levels in full nodes as fit in the same
/// 2 MiB, the rest quantised: the 1M sets 1.03–1.10× as fast as all quantised (section 1,
/// "Tiered nodes").
pub(super) const FULL_NODES_MAX: usize = (2 << 20) / std::mem::size_of::<Node8>();

/// Traversal ray: origin, direction, clamped reciprocal direction.
#[derive(Clone, Copy)]
pub(super) struct TRay {
    pub o: Vec3A,
    pub d: Vec3A,
    pub inv_d: Vec3A,
    /// o · inv_d, for the full nodes' fused slab test (p · inv_d − o · inv_d).
    pub o_inv: Vec3A,
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
        let inv_d = Vec3A::new(safe(d.x), safe(d.y), safe(d.z));
        TRay {
            o: Vec3A::from(ray.o),
            d,
            inv_d,
            o_inv: Vec3A::from(ray.o) * inv_d,
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
    /// Cache lines to prefetch for a child of a node of this layout (from the child's first).
    const LINES: usize;
    /// Whether the traversals test this layout's hit leaves one step late, after the next
    /// node's visit, so that their packets' misses overlap it: the quantised nodes' (the large
    /// trees', whose packets come from memory; soup1m 1.12×, grid1m 1.04×), not the full
    /// nodes' (a tree that fits the caches gained nothing; docs/performance.md §1).
    const LEAVES_LATE: bool;
    /// Ask for the node's leaf packets (`blocks`: the first packet) while the boxes are tested.
    fn prefetch_leaves(&self, blocks: *const u8);
    /// Ask for the packets of the hit leaf slots `leaves` of a [`Visit`].
    #[inline(always)]
    fn prefetch_hit_leaves(&self, leaves: u32, blocks: *const u8) {
        self.leaf_packets(leaves, |packet, _| {
            prefetch(blocks.wrapping_add(packet * PACKET_BYTES), 5);
            false
        });
    }
    /// The packets of the hit leaf slots `leaves` of a [`Visit`] into `out`, in slot order;
    /// how many.
    #[inline(always)]
    fn hit_packets(&self, leaves: u32, out: &mut [u32; 8]) -> usize {
        let mut n = 0;
        self.leaf_packets(leaves, |packet, _| {
            out[n] = packet as u32;
            n += 1;
            false
        });
        n
    }
    /// Call `f(packet, lanes)` for each packet of the hit leaves `leaves` of a [`Visit`], until
    /// it returns true (then true).
    fn leaf_packets(&self, leaves: u32, f: impl FnMut(usize, u32) -> bool) -> bool;
    /// Node index of the internal child in `slot`.
    fn inner_child(&self, slot: usize) -> u32;
    /// Test `r` against the child boxes with t in [0, t_max]; entry distances to `tmin_out`.
    ///
    /// `SITE` numbers the traversal loop that calls it (one per loop, see `Accel::intersect_stack`
    /// and `Accel::occluded_stack`), so that each AVX2 visit below is its own copy with a single
    /// caller. The compiler then inlines it into its loop. With one copy shared by all six loops it
    /// was called out of line, and soup100k took 2 072 instructions a ray instead of 1 644
    /// (docs/performance.md §1, "The node visits inlined again"). `#[inline(always)]` cannot be
    /// combined with `#[target_feature]` in stable Rust.
    fn visit<const ISA: u8, const SITE: u8>(
        &self,
        r: &TRay,
        t_max: f32,
        tmin_out: &mut [f32; 8],
    ) -> Visit;
    /// Each slot's internal child index as an AVX2 vector (any value for the other slots).
    ///
    /// # Safety
    /// Only on CPUs with AVX2, inlined into AVX2 code.
    #[cfg(target_arch = "x86_64")]
    unsafe fn children_avx2(&self) -> std::arch::x86_64::__m256i;

    /// Write the entries of the internal children in `inner` to `out`, in slot order and
    /// without gaps; all 8 entries are written (the rest repeat slot 0's and are not used).
    /// Without branches on the mask where AVX2 or AVX-512 is used.
    #[inline(always)]
    fn write_inner<const ISA: u8>(
        &self,
        inner: u32,
        tmins: &[f32; 8],
        out: &mut [MaybeUninit<Entry>],
    ) {
        #[cfg(target_arch = "x86_64")]
        if ISA >= ISA_AVX2 {
            // SAFETY: `ISA` is only AVX2 or above on CPUs with AVX2. (AVX-512 packs with the
            // same table: a `vpcompressq` over the 8 entries in one 512-bit register measured
            // 0.94–0.99× on an AVX-512 Xeon, where any 512-bit instruction slows the 256-bit
            // ones around it.)
            unsafe { write_packed_avx2(self.children_avx2(), inner, tmins, out) };
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

/// A node layout [`super::collapse`] can write.
pub(super) trait Encode {
    /// A node without children, whose children all lie in `aabb`.
    fn new(aabb: &Aabb) -> Self
    where
        Self: Sized;
    /// The node's first internal child and first leaf packet (children and packets are
    /// consecutive, in slot order), before its slots are set.
    fn bases(&mut self, child: u32, packet: u32);
    /// Slot `slot` is the leaf `packet` with box `aabb`.
    fn set_leaf(&mut self, slot: usize, aabb: &Aabb, packet: u32);
    /// Slot `slot` is the internal node `node` with box `aabb`.
    fn set_inner(&mut self, slot: usize, aabb: &Aabb, node: u32);
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

impl std::hash::Hash for Node8 {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.planes.map(|row| row.map(f32::to_bits)).hash(h);
        self.child.hash(h);
    }
}

impl Node8 {
    /// Slot `slot` holds `aabb`, rounded outwards by one ulp (the boxes of split triangle
    /// pieces are clipped in floating point).
    fn set_box(&mut self, slot: usize, aabb: &Aabb) {
        for k in 0..3 {
            self.planes[2 * k][slot] = aabb.min[k].next_down();
            self.planes[2 * k + 1][slot] = aabb.max[k].next_up();
        }
    }
}

impl Encode for Node8 {
    fn new(_aabb: &Aabb) -> Node8 {
        Node8 {
            planes: EMPTY_PLANES,
            child: [0; 8],
        }
    }

    fn bases(&mut self, _child: u32, _packet: u32) {}

    fn set_leaf(&mut self, slot: usize, aabb: &Aabb, packet: u32) {
        assert!(packet < LEAF, "too many leaves");
        self.set_box(slot, aabb);
        self.child[slot] = LEAF | packet;
    }

    fn set_inner(&mut self, slot: usize, aabb: &Aabb, node: u32) {
        self.set_box(slot, aabb);
        self.child[slot] = node;
    }
}

impl WideNode for Node8 {
    const LINES: usize = 4;
    const LEAVES_LATE: bool = false;

    /// The first packet is not known without a look at the slots. (Keeping it in the node's
    /// padding and fetching it here did not pay: soup100k 0.98× on an AVX-512 Xeon; the
    /// largest leaf's packet, on an AMD EPYC, added nothing to `prefetch_hit_leaves`.)
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

    /// The slab test per plane as p · (1/d) − o · (1/d) (one fused multiply-add), the near
    /// planes' maximum against the far planes' minimum.
    #[inline(always)]
    fn visit<const ISA: u8, const SITE: u8>(
        &self,
        r: &TRay,
        t_max: f32,
        tmin_out: &mut [f32; 8],
    ) -> Visit {
        #[cfg(target_arch = "x86_64")]
        if ISA == ISA_AVX512 {
            // SAFETY: `ISA` is only AVX-512 in code reached after checking for its support.
            return unsafe { visit_full_avx512::<SITE>(self, r, t_max, tmin_out) };
        } else if ISA >= ISA_AVX2 {
            // SAFETY: `ISA` is only AVX2 in code reached after checking for AVX2 support.
            return unsafe { visit_full_avx2::<SITE>(self, r, t_max, tmin_out) };
        }
        let (o_inv, inv) = (r.o_inv.to_array(), r.inv_d.to_array());
        let [nx, fx, ny, fy, nz, fz] = r.planes.map(|k| &self.planes[k]);
        let (mut inner, mut leaves) = (0, 0);
        for i in 0..8 {
            // p · (1/d) − o · (1/d), fused, as the AVX2 visit does (a library call without FMA)
            let t = |p: &[f32; 8], k: usize| p[i].mul_add(inv[k], -o_inv[k]);
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

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn children_avx2(&self) -> std::arch::x86_64::__m256i {
        // SAFETY: reads the node's `[u32; 8]` of children (AVX2: the caller's promise).
        unsafe { std::arch::x86_64::_mm256_loadu_si256(self.child.as_ptr().cast()) }
    }
}

/// The entry and exit distances of `$r` into the 8 child boxes of the full node `$node` (AVX2
/// intrinsics; the AVX2 and AVX-512 visits share them, so the two compute the same bits). Each
/// plane's distance is one fused multiply-subtract, p · (1/d) − o · (1/d): 2 % fewer
/// instructions a ray on soup100k than (p − o) · (1/d), and 1.02–1.03× the speed
/// (docs/performance.md §1).
#[cfg(target_arch = "x86_64")]
macro_rules! full_slabs {
    ($node:expr, $r:expr, $t_max:expr) => {{
        use std::arch::x86_64::*;
        let [nx, fx, ny, fy, nz, fz] = $r.planes.map(|k| $node.planes[k].as_ptr());
        let (oi, inv) = ($r.o_inv, $r.inv_d);
        let t = |p: *const f32, oi: f32, inv: f32| {
            _mm256_fmsub_ps(_mm256_loadu_ps(p), _mm256_set1_ps(inv), _mm256_set1_ps(oi))
        };
        let tmin = _mm256_max_ps(
            _mm256_max_ps(t(nx, oi.x, inv.x), t(ny, oi.y, inv.y)),
            _mm256_max_ps(t(nz, oi.z, inv.z), _mm256_setzero_ps()),
        );
        let tmax = _mm256_min_ps(
            _mm256_min_ps(t(fx, oi.x, inv.x), t(fy, oi.y, inv.y)),
            _mm256_min_ps(t(fz, oi.z, inv.z), _mm256_set1_ps($t_max)),
        );
        (tmin, tmax)
    }};
}

/// AVX2 [`Node8::visit`]: the same operations, all 8 slots at once, no branches. One copy per
/// `SITE` (`WideNode::visit`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
fn visit_full_avx2<const SITE: u8>(
    node: &Node8,
    r: &TRay,
    t_max: f32,
    tmin_out: &mut [f32; 8],
) -> Visit {
    use std::arch::x86_64::*;
    // SAFETY: AVX2 and FMA are enabled for this function; every load reads one `[f32; 8]` or
    // `[u32; 8]` field of the node.
    unsafe {
        let (tmin, tmax) = full_slabs!(node, r, t_max);
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

/// AVX-512 [`Node8::visit`]: the AVX2 visit's arithmetic, compared into mask registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
#[inline]
fn visit_full_avx512<const SITE: u8>(
    node: &Node8,
    r: &TRay,
    t_max: f32,
    tmin_out: &mut [f32; 8],
) -> Visit {
    use std::arch::x86_64::*;
    // SAFETY: AVX-512 (F, VL, DQ), AVX2 and FMA are enabled for this function; every load
    // reads one `[f32; 8]` or `[u32; 8]` field of the node.
    unsafe {
        let (tmin, tmax) = full_slabs!(node, r, t_max);
        _mm256_storeu_ps(tmin_out.as_mut_ptr(), tmin);
        let hit = _mm256_cmp_ps_mask::<_CMP_LE_OQ>(tmin, tmax) as u32;
        let leaf = _mm256_movepi32_mask(_mm256_loadu_si256(node.child.as_ptr().cast())) as u32;
        Visit {
            inner: hit & !leaf,
            leaves: hit & leaf,
        }
    }
}

/// [`QNode8::meta`] of a leaf slot (with the leaf's packet offset in the low bits).
const QLEAF: u8 = 0x80;
/// [`QNode8::meta`] of an internal slot.
const QINNER: u8 = 0x40;

/// A BVH8 node with its children's boxes quantised to 8 bits per plane relative to the node's
/// box (the CWBVH encoding of Ylitie et al. 2017, as in `obvhs`' `CwBvhNode`): 80 bytes. The
/// internal children are consecutive nodes from `child_base`, the leaves consecutive packets
/// from `packet_base`, both in slot order.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(super) struct QNode8 {
    /// The node box's min corner.
    p: [f32; 3],
    /// Per axis: the exponent bits of the quantisation step 2^(e − 127).
    e: [u8; 3],
    /// Internal slots.
    imask: u8,
    child_base: u32,
    packet_base: u32,
    /// Per slot: 0 empty, [`QINNER`], or [`QLEAF`] | the leaf's packet offset.
    meta: [u8; 8],
    /// Child box planes: min x, max x, min y, max y, min z, max z, in steps from `p`.
    planes: [[u8; 8]; 6],
}

impl std::hash::Hash for QNode8 {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.p.map(f32::to_bits).hash(h);
        (self.e, self.imask, self.child_base, self.packet_base).hash(h);
        (self.meta, self.planes).hash(h);
    }
}

impl QNode8 {
    /// The quantisation step per axis.
    #[inline(always)]
    fn step(&self) -> Vec3A {
        let s = |e: u8| f32::from_bits((e as u32) << 23);
        Vec3A::new(s(self.e[0]), s(self.e[1]), s(self.e[2]))
    }

    /// Slot `slot` holds `aabb`: its planes rounded outwards to whole steps.
    fn set_box(&mut self, slot: usize, aabb: &Aabb) {
        let step = self.step();
        for k in 0..3 {
            let q = |x: f32| (x as f64 - self.p[k] as f64) / step[k] as f64;
            self.planes[2 * k][slot] = q(aabb.min[k]).floor().clamp(0.0, 255.0) as u8;
            self.planes[2 * k + 1][slot] = q(aabb.max[k]).ceil().clamp(0.0, 255.0) as u8;
        }
    }
}

impl Encode for QNode8 {
    fn new(aabb: &Aabb) -> QNode8 {
        // the smallest power of two with 255 steps covering the box
        let e = |k: usize| {
            let extent = (aabb.max[k] - aabb.min[k]).max(1e-20);
            ((extent / 255.0).log2().ceil().exp2().to_bits() >> 23) as u8
        };
        QNode8 {
            p: aabb.min.to_array(),
            e: [e(0), e(1), e(2)],
            imask: 0,
            child_base: 0,
            packet_base: 0,
            meta: [0; 8],
            planes: [[0; 8]; 6],
        }
    }

    fn bases(&mut self, child: u32, packet: u32) {
        (self.child_base, self.packet_base) = (child, packet);
    }

    fn set_leaf(&mut self, slot: usize, aabb: &Aabb, packet: u32) {
        let offset = packet - self.packet_base;
        assert!(offset < 8);
        self.set_box(slot, aabb);
        self.meta[slot] = QLEAF | offset as u8;
    }

    fn set_inner(&mut self, slot: usize, aabb: &Aabb, node: u32) {
        self.set_box(slot, aabb);
        self.meta[slot] = QINNER;
        self.imask |= 1 << slot;
        debug_assert_eq!(node, self.inner_child(slot));
    }
}

impl WideNode for QNode8 {
    /// The node spans two lines (80 bytes); the third holds most of the next sibling, often
    /// visited too (children are consecutive). Paired on the 1M-triangle sets, 3 against 2:
    /// grid1m 1.04× and 1.02×, soup1m 1.03× and 1.05×, sphere1m 1.00× and 1.02× (12 and 20
    /// rounds); 4 lines 1.03×, 0.98×, 0.98× (docs/performance.md §1, "Tiered nodes").
    const LINES: usize = 3;
    const LEAVES_LATE: bool = true;

    /// The node's first leaf packet (packet 0 for a node without leaves, without a branch).
    #[inline(always)]
    fn prefetch_leaves(&self, blocks: *const u8) {
        let has_leaves = (self.imask != 0xff) as usize;
        let first = has_leaves * self.packet_base as usize;
        prefetch(blocks.wrapping_add(first * PACKET_BYTES), 5);
    }

    /// `leaves` are the hit leaf slots; each is one packet, all of whose lanes are tested.
    #[inline(always)]
    fn leaf_packets(&self, mut leaves: u32, mut f: impl FnMut(usize, u32) -> bool) -> bool {
        while leaves != 0 {
            let i = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            let packet = self.packet_base as usize + (self.meta[i] & !QLEAF) as usize;
            if f(packet, 0xff) {
                return true;
            }
        }
        false
    }

    #[inline(always)]
    fn inner_child(&self, slot: usize) -> u32 {
        self.child_base + (self.imask as u32 & ((1u32 << slot) - 1)).count_ones()
    }

    /// t = q · (step / d) + (p − o) / d per plane (the CWBVH slab test), one fused multiply-add.
    #[inline(always)]
    fn visit<const ISA: u8, const SITE: u8>(
        &self,
        r: &TRay,
        t_max: f32,
        tmin_out: &mut [f32; 8],
    ) -> Visit {
        #[cfg(target_arch = "x86_64")]
        if ISA == ISA_AVX512 {
            // SAFETY: `ISA` is only AVX-512 in code reached after checking for its support.
            return unsafe { visit_quantised_avx512::<SITE>(self, r, t_max, tmin_out) };
        } else if ISA >= ISA_AVX2 {
            // SAFETY: `ISA` is only AVX2 in code reached after checking for AVX2 support.
            return unsafe { visit_quantised_avx2::<SITE>(self, r, t_max, tmin_out) };
        }
        let adj_dir_inv = (self.step() * r.inv_d).to_array();
        let adj_orig = ((Vec3A::from(self.p) - r.o) * r.inv_d).to_array();
        let [nx, fx, ny, fy, nz, fz] = r.planes.map(|k| &self.planes[k]);
        let (mut inner, mut leaves) = (0, 0);
        for i in 0..8 {
            let t = |q: &[u8; 8], k: usize| (q[i] as f32).mul_add(adj_dir_inv[k], adj_orig[k]);
            let tmin = max_ps(max_ps(t(nx, 0), t(ny, 1)), max_ps(t(nz, 2), 0.0));
            let tmax = min_ps(min_ps(t(fx, 0), t(fy, 1)), min_ps(t(fz, 2), t_max));
            tmin_out[i] = tmin;
            if tmin <= tmax {
                if self.meta[i] & QLEAF != 0 {
                    leaves |= 1 << i;
                } else if self.meta[i] == QINNER {
                    inner |= 1 << i;
                }
            }
        }
        Visit { inner, leaves }
    }

    /// `child_base` plus the number of internal slots below each slot.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn children_avx2(&self) -> std::arch::x86_64::__m256i {
        use std::arch::x86_64::*;
        let rank = INNER_RANK[self.imask as usize].as_ptr() as *const __m128i;
        // SAFETY: reads one `[u8; 8]` row of the table (AVX2: the caller's promise).
        unsafe {
            _mm256_add_epi32(
                _mm256_cvtepu8_epi32(_mm_loadl_epi64(rank)),
                _mm256_set1_epi32(self.child_base as i32),
            )
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

/// The entry and exit distances of `$r` into the 8 child boxes of the quantised node `$node`
/// (AVX2 intrinsics, shared by the AVX2 and AVX-512 visits): each plane's distance is one
/// fused multiply-add.
#[cfg(target_arch = "x86_64")]
macro_rules! quantised_slabs {
    ($node:expr, $r:expr, $t_max:expr) => {{
        use std::arch::x86_64::*;
        let adj_dir_inv = $node.step() * $r.inv_d;
        let adj_orig = (Vec3A::from($node.p) - $r.o) * $r.inv_d;
        let [nx, fx, ny, fy, nz, fz] = $r.planes.map(|k| $node.planes[k].as_ptr());
        let q = |p: *const u8| {
            _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(p as *const __m128i)))
        };
        let t = |p: *const u8, d: f32, o: f32| {
            _mm256_fmadd_ps(q(p), _mm256_set1_ps(d), _mm256_set1_ps(o))
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
            _mm256_min_ps(t(fz, adj_dir_inv.z, adj_orig.z), _mm256_set1_ps($t_max)),
        );
        (tmin, tmax)
    }};
}

/// AVX2 [`QNode8::visit`]: the same operations, all 8 slots at once, no branch per slot. One
/// copy per `SITE` (`WideNode::visit`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
fn visit_quantised_avx2<const SITE: u8>(
    node: &QNode8,
    r: &TRay,
    t_max: f32,
    tmin_out: &mut [f32; 8],
) -> Visit {
    use std::arch::x86_64::*;
    // SAFETY: AVX2 and FMA are enabled for this function; the 8-byte loads read one `[u8; 8]`
    // field each.
    unsafe {
        let (tmin, tmax) = quantised_slabs!(node, r, t_max);
        _mm256_storeu_ps(tmin_out.as_mut_ptr(), tmin);
        let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32;
        // the top bits of `meta` are the leaf slots
        let leaf = _mm_movemask_epi8(_mm_loadl_epi64(node.meta.as_ptr() as *const __m128i)) as u32;
        Visit {
            inner: hit & node.imask as u32,
            leaves: hit & leaf & 0xff,
        }
    }
}

/// AVX-512 [`QNode8::visit`]: the AVX2 visit's arithmetic, compared into mask registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512bw,avx2,fma")]
#[inline]
fn visit_quantised_avx512<const SITE: u8>(
    node: &QNode8,
    r: &TRay,
    t_max: f32,
    tmin_out: &mut [f32; 8],
) -> Visit {
    use std::arch::x86_64::*;
    // SAFETY: AVX-512 (F, VL, BW), AVX2 and FMA are enabled for this function; the 8-byte
    // loads read one `[u8; 8]` field each.
    unsafe {
        let (tmin, tmax) = quantised_slabs!(node, r, t_max);
        _mm256_storeu_ps(tmin_out.as_mut_ptr(), tmin);
        let hit = _mm256_cmp_ps_mask::<_CMP_LE_OQ>(tmin, tmax) as u32;
        // the top bits of `meta` are the leaf slots
        let leaf = _mm_movepi8_mask(_mm_loadl_epi64(node.meta.as_ptr() as *const __m128i)) as u32;
        Visit {
            inner: hit & node.imask as u32,
            leaves: hit & leaf & 0xff,
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
