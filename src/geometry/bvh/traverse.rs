//! The closest-hit and any-hit traversal loops over the wide nodes: portable, AVX2 and AVX-512
//! (one generic loop each, compiled once per instruction set).

use std::mem::MaybeUninit;

use super::isa::{ISA_AVX2, ISA_AVX512, ISA_PORTABLE};
use super::nodes::{Entry, Node8, QNode8, TRay, Visit, WideNode};
#[cfg(feature = "bvh-stats")]
use super::stats;
use super::{Accel, Nodes, STACK, prefetch};
use crate::geometry::{Hit, Ray};

/// Order traversal entries far to near by entry distance, stably (entries of equal distance
/// keep their slot order, so the later slot is visited first). Two entries, the common case,
/// take one compare and no branch.
#[inline(always)]
fn sort_far_to_near(s: &mut [Entry]) {
    if s.len() == 2 {
        let (a, b) = (s[0], s[1]);
        let swap = a.t < b.t;
        s[0] = if swap { b } else { a };
        s[1] = if swap { a } else { b };
        return;
    }
    for k in 1..s.len() {
        let e = s[k];
        let mut j = k;
        while j > 0 && s[j - 1].t < e.t {
            s[j] = s[j - 1];
            j -= 1;
        }
        s[j] = e;
    }
}

/// The lowest of the lanes in `h` (non-empty) with the smallest `t`.
#[inline(always)]
fn nearest_lane(mut h: u32, t: &[f32; 8]) -> usize {
    let mut best = h.trailing_zeros() as usize;
    h &= h - 1;
    while h != 0 {
        let l = h.trailing_zeros() as usize;
        h &= h - 1;
        if t[l] < t[best] {
            best = l;
        }
    }
    best
}

impl Accel {
    /// The traversal without AVX2, out of line: inlined, its stack frame and register saves
    /// would be paid by every ray of the AVX2 paths too.
    #[inline(never)]
    pub(super) fn intersect_portable(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.intersect_dispatch::<ISA_PORTABLE>(ray, t_max)
    }

    ray_entry!(
        intersect_avx2,
        "avx2,popcnt,bmi1,fma",
        Option<Hit>,
        |a, ray, t_max| a.intersect_dispatch::<ISA_AVX2>(&ray, t_max)
    );

    ray_entry!(
        /// [`Self::intersect_avx2`] compiled for AVX-512: the same loop with the AVX-512 node
        /// visits (and EVEX encodings, 32 vector registers).
        intersect_avx512,
        "avx512f,avx512vl,avx512dq,avx512bw,avx2,popcnt,bmi1,fma",
        Option<Hit>,
        |a, ray, t_max| a.intersect_dispatch::<ISA_AVX512>(&ray, t_max)
    );

    #[inline(always)]
    fn intersect_dispatch<const ISA: u8>(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        match &self.nodes {
            Nodes::Full(n) => self.intersect_stack::<Node8, ISA>(n, ray, t_max),
            Nodes::Quantised(n) => self.intersect_stack::<QNode8, ISA>(n, ray, t_max),
        }
    }

    #[inline(always)]
    fn intersect_stack<N: WideNode, const ISA: u8>(
        &self,
        nodes: &[N],
        ray: &Ray,
        t_max: f32,
    ) -> Option<Hit> {
        // Each call of a traversal loop passes its own `SITE` (`WideNode::visit`: the node visits
        // are inlined only when each copy has a single caller).
        if self.stack_size <= STACK {
            let mut stack = [const { MaybeUninit::<Entry>::uninit() }; STACK];
            if self.n_spheres == 0 {
                self.intersect_impl::<N, false, ISA, 0>(nodes, ray, t_max, &mut stack)
            } else {
                self.intersect_impl::<N, true, ISA, 1>(nodes, ray, t_max, &mut stack)
            }
        } else {
            // rare: one instantiation, the general one (spheres or not), for deep trees
            let mut stack = vec![MaybeUninit::<Entry>::uninit(); self.stack_size];
            self.intersect_impl::<N, true, ISA, 2>(nodes, ray, t_max, &mut stack)
        }
    }

    /// Closest-hit traversal: leaf children are tested as soon as their node is, internal
    /// children are visited nearest first (sorted by entry distance), and popped entries farther
    /// than the current hit are skipped.
    #[inline(always)]
    fn intersect_impl<N: WideNode, const MIXED: bool, const ISA: u8, const SITE: u8>(
        &self,
        nodes: &[N],
        ray: &Ray,
        t_max: f32,
        stack: &mut [MaybeUninit<Entry>],
    ) -> Option<Hit> {
        let r = TRay::new(ray);
        let mut t_best = t_max;
        let mut lane_best = u32::MAX;
        let (mut u_best, mut v_best) = (0.0, 0.0);
        let mut sp = 0usize;
        let mut cur = 0u32;
        let mut tmins = [0.0f32; 8];
        let mut tuv = [[0.0f32; 8]; 3];
        loop {
            // SAFETY: child indices produced by the collapse are in bounds.
            let node = unsafe { nodes.get_unchecked(cur as usize) };
            #[cfg(feature = "bvh-stats")]
            stats::count(0, 1);
            // The node's first packet is needed whenever a leaf child is hit: fetch it while the
            // boxes are tested (nodes without leaves point at packet 0, without a branch).
            node.prefetch_leaves(self.blocks.as_ptr() as *const u8);
            // Every hit child has its entry distance <= t_best.
            let Visit {
                inner: inner_hits,
                leaves,
            } = node.visit::<ISA, SITE>(&r, t_best, &mut tmins);
            // Inner children onto the stack in slot order (not yet counted in `sp`); their boxes
            // load while the leaves are tested.
            let n_inner = inner_hits.count_ones() as usize;
            if n_inner > 0 {
                node.write_inner::<ISA>(inner_hits, &tmins, &mut stack[sp..sp + 8]);
                // the first two (all 8 entries are written; a prefetch never faults)
                for k in 0..2 {
                    // SAFETY: written just above.
                    let e = unsafe { stack[sp + k].assume_init() };
                    prefetch(nodes.as_ptr().wrapping_add(e.node as usize), N::LINES);
                }
            }
            // Leaves first (they can shrink t_best before the inner children are ordered): all
            // hit leaf children at once, one packet test per 8 lanes; the nearest hit wins, the
            // lowest lane on ties.
            if leaves != 0 {
                node.leaf_packets(leaves, |b, lanes| {
                    #[cfg(feature = "bvh-stats")]
                    stats::count(1, lanes.count_ones() as u64);
                    let h = self.test_block::<MIXED, ISA>(b, lanes, &r, t_best, &mut tuv);
                    if h != 0 {
                        // every hit is nearer than t_best; one hit is the common case
                        let l = if h & (h - 1) == 0 {
                            h.trailing_zeros() as usize
                        } else {
                            nearest_lane(h, &tuv[0])
                        };
                        t_best = tuv[0][l];
                        lane_best = (b * 8 + l) as u32;
                        u_best = tuv[1][l];
                        v_best = tuv[2][l];
                    }
                    false
                });
            }
            // The inner children ordered far to near (stable), and the nearest taken off again to
            // descend into directly. Entries the leaves have put beyond t_best stay and are
            // skipped when popped.
            if n_inner > 0 {
                // SAFETY: the `n_inner` entries from `sp` on were written above.
                let top = unsafe {
                    let s = &mut *(&mut stack[sp..sp + n_inner] as *mut [MaybeUninit<Entry>]
                        as *mut [Entry]);
                    sort_far_to_near(s);
                    s[n_inner - 1]
                };
                if top.t <= t_best {
                    sp += n_inner - 1;
                    cur = top.node;
                    continue;
                }
            }
            // Pop the nearest pending entry still in range.
            loop {
                if sp == 0 {
                    return (lane_best != u32::MAX).then(|| Hit {
                        t: t_best,
                        prim: self.blocks[lane_best as usize / 8].ids[lane_best as usize % 8],
                        u: u_best,
                        v: v_best,
                    });
                }
                sp -= 1;
                // SAFETY: entries below `sp` have been written.
                let e = unsafe { stack[sp].assume_init() };
                if e.t <= t_best {
                    cur = e.node;
                    break;
                }
            }
        }
    }

    /// See [`Self::intersect_portable`].
    #[inline(never)]
    pub(super) fn occluded_portable(&self, ray: &Ray, t_max: f32) -> bool {
        self.occluded_dispatch::<ISA_PORTABLE>(ray, t_max)
    }

    ray_entry!(
        occluded_avx2,
        "avx2,popcnt,bmi1,fma",
        bool,
        |a, ray, t_max| a.occluded_dispatch::<ISA_AVX2>(&ray, t_max)
    );

    ray_entry!(
        /// [`Self::occluded_avx2`] compiled for AVX-512, as [`Self::intersect_avx512`].
        occluded_avx512,
        "avx512f,avx512vl,avx512dq,avx512bw,avx2,popcnt,bmi1,fma",
        bool,
        |a, ray, t_max| a.occluded_dispatch::<ISA_AVX512>(&ray, t_max)
    );

    #[inline(always)]
    fn occluded_dispatch<const ISA: u8>(&self, ray: &Ray, t_max: f32) -> bool {
        match &self.nodes {
            Nodes::Full(n) => self.occluded_stack::<Node8, ISA>(n, ray, t_max),
            Nodes::Quantised(n) => self.occluded_stack::<QNode8, ISA>(n, ray, t_max),
        }
    }

    #[inline(always)]
    fn occluded_stack<N: WideNode, const ISA: u8>(
        &self,
        nodes: &[N],
        ray: &Ray,
        t_max: f32,
    ) -> bool {
        // `SITE` 3-5: see `intersect_stack`.
        if self.stack_size <= STACK {
            let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK];
            if self.n_spheres == 0 {
                self.occluded_impl::<N, false, ISA, 3>(nodes, ray, t_max, &mut stack)
            } else {
                self.occluded_impl::<N, true, ISA, 4>(nodes, ray, t_max, &mut stack)
            }
        } else {
            // rare: one instantiation, the general one (spheres or not), for deep trees
            let mut stack = vec![MaybeUninit::<u32>::uninit(); self.stack_size];
            self.occluded_impl::<N, true, ISA, 5>(nodes, ray, t_max, &mut stack)
        }
    }

    /// Any-hit traversal: no ordering, exit on the first hit.
    #[inline(always)]
    fn occluded_impl<N: WideNode, const MIXED: bool, const ISA: u8, const SITE: u8>(
        &self,
        nodes: &[N],
        ray: &Ray,
        t_max: f32,
        stack: &mut [MaybeUninit<u32>],
    ) -> bool {
        let r = TRay::new(ray);
        let mut sp = 0usize;
        let mut cur = 0u32;
        let mut tmins = [0.0f32; 8];
        let mut tuv = [[0.0f32; 8]; 3];
        loop {
            // SAFETY: see `intersect_impl`.
            let node = unsafe { nodes.get_unchecked(cur as usize) };
            node.prefetch_leaves(self.blocks.as_ptr() as *const u8);
            let Visit { inner, leaves } = node.visit::<ISA, SITE>(&r, t_max, &mut tmins);
            // inner children on the stack in slot order; the last one is visited next
            let mut m = inner;
            for k in 0..inner.count_ones() as usize {
                let child = node.inner_child(m.trailing_zeros() as usize);
                m &= m - 1;
                prefetch(nodes.as_ptr().wrapping_add(child as usize), N::LINES);
                stack[sp + k] = MaybeUninit::new(child);
            }
            sp += inner.count_ones() as usize;
            let hit = |b: usize, lanes: u32| {
                self.test_block::<MIXED, ISA>(b, lanes, &r, t_max, &mut tuv) != 0
            };
            if leaves != 0 && node.leaf_packets(leaves, hit) {
                return true;
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            // SAFETY: entries below `sp` have been written.
            cur = unsafe { stack[sp].assume_init() };
        }
    }
}
