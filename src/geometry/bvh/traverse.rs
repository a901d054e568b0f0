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
            Nodes::Full(n) => self.intersect_stack::<Node8, Node8, false, ISA>(n, &[], ray, t_max),
            Nodes::Quantised(n) => {
                self.intersect_stack::<QNode8, QNode8, false, ISA>(n, &[], ray, t_max)
            }
            Nodes::Tiered { top, rest } => {
                self.intersect_stack::<Node8, QNode8, true, ISA>(top, rest, ray, t_max)
            }
        }
    }

    /// `top` and `rest`: the nodes of the tree, numbered in that order (`rest` empty when not
    /// `TIERED`).
    #[inline(always)]
    fn intersect_stack<A: WideNode, B: WideNode, const TIERED: bool, const ISA: u8>(
        &self,
        top: &[A],
        rest: &[B],
        ray: &Ray,
        t_max: f32,
    ) -> Option<Hit> {
        let tree = Tree::<A, B, TIERED>::new(top, rest);
        // Each call of a traversal loop passes its own `SITE`, 0-2 (6-8 tiered) (`WideNode::visit`:
        // the node visits are inlined only when each copy has a single caller).
        if self.stack_size <= STACK {
            let mut stack = [const { MaybeUninit::<Entry>::uninit() }; STACK];
            if self.n_spheres == 0 {
                if TIERED {
                    self.intersect_impl::<A, B, TIERED, false, ISA, 6>(tree, ray, t_max, &mut stack)
                } else {
                    self.intersect_impl::<A, B, TIERED, false, ISA, 0>(tree, ray, t_max, &mut stack)
                }
            } else {
                if TIERED {
                    self.intersect_impl::<A, B, TIERED, true, ISA, 7>(tree, ray, t_max, &mut stack)
                } else {
                    self.intersect_impl::<A, B, TIERED, true, ISA, 1>(tree, ray, t_max, &mut stack)
                }
            }
        } else {
            // rare: one instantiation, the general one (spheres or not), for deep trees
            let mut stack = vec![MaybeUninit::<Entry>::uninit(); self.stack_size];
            if TIERED {
                self.intersect_impl::<A, B, TIERED, true, ISA, 8>(tree, ray, t_max, &mut stack)
            } else {
                self.intersect_impl::<A, B, TIERED, true, ISA, 2>(tree, ray, t_max, &mut stack)
            }
        }
    }

    /// Closest-hit traversal: internal children are visited nearest first (sorted by entry
    /// distance), popped entries farther than the current hit are skipped, and a quantised
    /// node's hit leaves are tested one step late ([`WideNode::LEAVES_LATE`]), after the next
    /// node's visit (the last node's when the stack runs out), so that their packets arrive
    /// meanwhile. The packets are still tested in the order of their nodes' visits, each from
    /// the t_best of the nodes before it; a node visited only because those leaves were not yet
    /// tested lies beyond their hit and adds no nearer one, so the hits, ties included, are
    /// those of testing each node's leaves at once.
    #[inline(always)]
    fn intersect_impl<
        A: WideNode,
        B: WideNode,
        const TIERED: bool,
        const MIXED: bool,
        const ISA: u8,
        const SITE: u8,
    >(
        &self,
        tree: Tree<A, B, TIERED>,
        ray: &Ray,
        t_max: f32,
        stack: &mut [MaybeUninit<Entry>],
    ) -> Option<Hit> {
        let mut st = Closest {
            pending: [0; 8],
            n_pending: 0,
            r: TRay::new(ray),
            t_best: t_max,
            lane_best: u32::MAX,
            u_best: 0.0,
            v_best: 0.0,
            sp: 0,
            tmins: [0.0; 8],
            tuv: [[0.0; 8]; 3],
            stack,
        };
        let mut cur = 0u32;
        loop {
            let next = if tree.in_top(cur) {
                // SAFETY: child indices produced by the collapse are in bounds.
                self.closest_step::<A, A, B, TIERED, MIXED, ISA, SITE>(
                    unsafe { tree.top(cur) },
                    &mut st,
                    tree,
                )
            } else {
                // SAFETY: as above; indices from `top.len()` on are `rest`'s.
                self.closest_step::<B, A, B, TIERED, MIXED, ISA, SITE>(
                    unsafe { tree.rest(cur) },
                    &mut st,
                    tree,
                )
            };
            match next {
                Some(n) => cur = n,
                None => {
                    #[cfg(feature = "bvh-stats")]
                    stats::ray_end(st.t_best);
                    return (st.lane_best != u32::MAX).then(|| Hit {
                        t: st.t_best,
                        prim: self.blocks[st.lane_best as usize / 8].ids[st.lane_best as usize % 8],
                        u: st.u_best,
                        v: st.v_best,
                    });
                }
            }
        }
    }

    /// One node of [`Self::intersect_impl`]: visit `node`, test its hit leaves, push its hit
    /// internal children; the next node to visit, or `None` when the stack is empty.
    #[inline(always)]
    fn closest_step<
        N: WideNode,
        A: WideNode,
        B: WideNode,
        const TIERED: bool,
        const MIXED: bool,
        const ISA: u8,
        const SITE: u8,
    >(
        &self,
        node: &N,
        st: &mut Closest,
        tree: Tree<A, B, TIERED>,
    ) -> Option<u32> {
        #[cfg(feature = "bvh-stats")]
        stats::count(0, 1);
        let blocks = self.blocks.as_ptr() as *const u8;
        // The node's first packet is needed whenever a leaf child is hit: fetch it while the
        // boxes are tested (nodes without leaves point at packet 0, without a branch).
        node.prefetch_leaves(blocks);
        // Every hit child has its entry distance <= t_best.
        let Visit {
            inner: inner_hits,
            leaves,
        } = node.visit::<ISA, SITE>(&st.r, st.t_best, &mut st.tmins);
        // The hit leaves' packets: a quantised node's load while the next node is visited, a
        // full node's (tested below) while the inner children are written.
        node.prefetch_hit_leaves(leaves, blocks);
        // Inner children onto the stack in slot order (not yet counted in `sp`); their boxes
        // load while the previous node's leaves are tested.
        let sp = st.sp;
        let n_inner = inner_hits.count_ones() as usize;
        if n_inner > 0 {
            node.write_inner::<ISA>(inner_hits, &st.tmins, &mut st.stack[sp..sp + 8]);
            // the first two (all 8 entries are written; a prefetch never faults)
            for k in 0..2 {
                // SAFETY: written just above.
                let e = unsafe { st.stack[sp + k].assume_init() };
                tree.prefetch::<N>(e.node);
            }
        }
        // The previous node's late leaves (their packets arrived during this visit), then this
        // node's: kept for the next step, or tested now.
        self.test_pending::<MIXED, ISA>(st);
        #[cfg(feature = "bvh-stats")]
        {
            let mut m = leaves;
            while m != 0 {
                stats::leaf_entry(st.tmins[m.trailing_zeros() as usize]);
                m &= m - 1;
            }
        }
        st.n_pending = node.hit_packets(leaves, &mut st.pending);
        if !N::LEAVES_LATE {
            self.test_pending::<MIXED, ISA>(st);
        }
        // The inner children ordered far to near (stable), and the nearest taken off again to
        // descend into directly. Entries the leaves have put beyond t_best stay and are
        // skipped when popped.
        if n_inner > 0 {
            // SAFETY: the `n_inner` entries from `sp` on were written above.
            let top = unsafe {
                let s = &mut *(&mut st.stack[sp..sp + n_inner] as *mut [MaybeUninit<Entry>]
                    as *mut [Entry]);
                sort_far_to_near(s);
                s[n_inner - 1]
            };
            if top.t <= st.t_best {
                st.sp = sp + n_inner - 1;
                return Some(top.node);
            }
        }
        // Pop the nearest stacked entry still in range (`Closest::pending` are leaf packets).
        loop {
            if st.sp == 0 {
                // the last node's leaves
                self.test_pending::<MIXED, ISA>(st);
                return None;
            }
            st.sp -= 1;
            // SAFETY: entries below `sp` have been written.
            let e = unsafe { st.stack[st.sp].assume_init() };
            if e.t <= st.t_best {
                return Some(e.node);
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
            Nodes::Full(n) => self.occluded_stack::<Node8, Node8, false, ISA>(n, &[], ray, t_max),
            Nodes::Quantised(n) => {
                self.occluded_stack::<QNode8, QNode8, false, ISA>(n, &[], ray, t_max)
            }
            Nodes::Tiered { top, rest } => {
                self.occluded_stack::<Node8, QNode8, true, ISA>(top, rest, ray, t_max)
            }
        }
    }

    #[inline(always)]
    fn occluded_stack<A: WideNode, B: WideNode, const TIERED: bool, const ISA: u8>(
        &self,
        top: &[A],
        rest: &[B],
        ray: &Ray,
        t_max: f32,
    ) -> bool {
        let tree = Tree::<A, B, TIERED>::new(top, rest);
        // `SITE` 3-5 (9-11 tiered): see `intersect_stack`.
        if self.stack_size <= STACK {
            let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK];
            if self.n_spheres == 0 {
                if TIERED {
                    self.occluded_impl::<A, B, TIERED, false, ISA, 9>(tree, ray, t_max, &mut stack)
                } else {
                    self.occluded_impl::<A, B, TIERED, false, ISA, 3>(tree, ray, t_max, &mut stack)
                }
            } else {
                if TIERED {
                    self.occluded_impl::<A, B, TIERED, true, ISA, 10>(tree, ray, t_max, &mut stack)
                } else {
                    self.occluded_impl::<A, B, TIERED, true, ISA, 4>(tree, ray, t_max, &mut stack)
                }
            }
        } else {
            // rare: one instantiation, the general one (spheres or not), for deep trees
            let mut stack = vec![MaybeUninit::<u32>::uninit(); self.stack_size];
            if TIERED {
                self.occluded_impl::<A, B, TIERED, true, ISA, 11>(tree, ray, t_max, &mut stack)
            } else {
                self.occluded_impl::<A, B, TIERED, true, ISA, 5>(tree, ray, t_max, &mut stack)
            }
        }
    }

    /// Any-hit traversal: no ordering, exit on the first hit.
    #[inline(always)]
    fn occluded_impl<
        A: WideNode,
        B: WideNode,
        const TIERED: bool,
        const MIXED: bool,
        const ISA: u8,
        const SITE: u8,
    >(
        &self,
        tree: Tree<A, B, TIERED>,
        ray: &Ray,
        t_max: f32,
        stack: &mut [MaybeUninit<u32>],
    ) -> bool {
        let mut st = AnyHit {
            pending: [0; 8],
            n_pending: 0,
            r: TRay::new(ray),
            t_max,
            sp: 0,
            tmins: [0.0; 8],
            tuv: [[0.0; 8]; 3],
            stack,
        };
        let mut cur = 0u32;
        loop {
            let next = if tree.in_top(cur) {
                // SAFETY: see `intersect_impl`.
                self.occluded_step::<A, A, B, TIERED, MIXED, ISA, SITE>(
                    unsafe { tree.top(cur) },
                    &mut st,
                    tree,
                )
            } else {
                // SAFETY: see `intersect_impl`.
                self.occluded_step::<B, A, B, TIERED, MIXED, ISA, SITE>(
                    unsafe { tree.rest(cur) },
                    &mut st,
                    tree,
                )
            };
            match next {
                Step::Next(n) => cur = n,
                Step::Hit => return true,
                Step::Done => return false,
            }
        }
    }

    /// One node of [`Self::occluded_impl`].
    #[inline(always)]
    fn occluded_step<
        N: WideNode,
        A: WideNode,
        B: WideNode,
        const TIERED: bool,
        const MIXED: bool,
        const ISA: u8,
        const SITE: u8,
    >(
        &self,
        node: &N,
        st: &mut AnyHit,
        tree: Tree<A, B, TIERED>,
    ) -> Step {
        let blocks = self.blocks.as_ptr() as *const u8;
        node.prefetch_leaves(blocks);
        let Visit { inner, leaves } = node.visit::<ISA, SITE>(&st.r, st.t_max, &mut st.tmins);
        if N::LEAVES_LATE {
            node.prefetch_hit_leaves(leaves, blocks);
        }
        // inner children on the stack in slot order; the last one is visited next
        let mut m = inner;
        for k in 0..inner.count_ones() as usize {
            let child = node.inner_child(m.trailing_zeros() as usize);
            m &= m - 1;
            tree.prefetch::<N>(child);
            st.stack[st.sp + k] = MaybeUninit::new(child);
        }
        st.sp += inner.count_ones() as usize;
        if self.any_pending::<MIXED, ISA>(st) {
            return Step::Hit;
        }
        if N::LEAVES_LATE {
            st.n_pending = node.hit_packets(leaves, &mut st.pending);
        } else {
            let (r, t_max, tuv) = (&st.r, st.t_max, &mut st.tuv);
            let hit =
                |b: usize, lanes: u32| self.test_block::<MIXED, ISA>(b, lanes, r, t_max, tuv) != 0;
            if leaves != 0 && node.leaf_packets(leaves, hit) {
                return Step::Hit;
            }
        }
        if st.sp == 0 {
            return if self.any_pending::<MIXED, ISA>(st) {
                Step::Hit
            } else {
                Step::Done
            };
        }
        st.sp -= 1;
        // SAFETY: entries below `sp` have been written.
        Step::Next(unsafe { st.stack[st.sp].assume_init() })
    }
}

impl Accel {
    /// Whether a packet `st.pending` holds is hit.
    #[inline(always)]
    fn any_pending<const MIXED: bool, const ISA: u8>(&self, st: &mut AnyHit) -> bool {
        let n = std::mem::take(&mut st.n_pending);
        (0..n).any(|k| {
            let b = st.pending[k] as usize;
            self.test_block::<MIXED, ISA>(b, 0xff, &st.r, st.t_max, &mut st.tuv) != 0
        })
    }

    /// Test the packets `st.pending` holds, in order: all 8 lanes of each at once; the nearest
    /// hit wins, the lowest lane on ties.
    #[inline(always)]
    fn test_pending<const MIXED: bool, const ISA: u8>(&self, st: &mut Closest) {
        for k in 0..st.n_pending {
            let b = st.pending[k] as usize;
            #[cfg(feature = "bvh-stats")]
            stats::count(1, 8);
            let h = self.test_block::<MIXED, ISA>(b, 0xff, &st.r, st.t_best, &mut st.tuv);
            if h != 0 {
                // every hit is nearer than t_best; one hit is the common case
                let l = if h & (h - 1) == 0 {
                    h.trailing_zeros() as usize
                } else {
                    nearest_lane(h, &st.tuv[0])
                };
                st.t_best = st.tuv[0][l];
                st.lane_best = (b * 8 + l) as u32;
                st.u_best = st.tuv[1][l];
                st.v_best = st.tuv[2][l];
            }
        }
        st.n_pending = 0;
    }
}

/// The state of a closest-hit traversal ([`Accel::intersect_impl`]).
struct Closest<'a> {
    /// The packets of the last visited node's hit leaves, tested after the next visit
    /// ([`Accel::test_pending`]).
    pending: [u32; 8],
    n_pending: usize,
    r: TRay,
    t_best: f32,
    lane_best: u32,
    u_best: f32,
    v_best: f32,
    sp: usize,
    tmins: [f32; 8],
    tuv: [[f32; 8]; 3],
    stack: &'a mut [MaybeUninit<Entry>],
}

/// The state of an any-hit traversal ([`Accel::occluded_impl`]).
struct AnyHit<'a> {
    /// The packets of the last visited quantised node's hit leaves, tested after the next
    /// visit ([`Accel::any_pending`]); a full node's are tested at once.
    pending: [u32; 8],
    n_pending: usize,
    r: TRay,
    t_max: f32,
    sp: usize,
    tmins: [f32; 8],
    tuv: [[f32; 8]; 3],
    stack: &'a mut [MaybeUninit<u32>],
}

/// What an any-hit step found.
enum Step {
    Next(u32),
    Hit,
    Done,
}

/// The nodes a traversal reads: one layout (`TIERED` false: all in `top`), or the top levels
/// in full precision and the rest quantised (`Nodes::Tiered`), numbered top first.
struct Tree<'a, A, B, const TIERED: bool> {
    top: *const A,
    /// `rest`'s first node's address minus `top.len()` nodes: node `i` of the tree at
    /// `rest + i` for `i >= top.len()`.
    rest: *const B,
    n_top: u32,
    _nodes: std::marker::PhantomData<(&'a [A], &'a [B])>,
}

impl<A, B, const TIERED: bool> Clone for Tree<'_, A, B, TIERED> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<A, B, const TIERED: bool> Copy for Tree<'_, A, B, TIERED> {}

impl<'a, A: WideNode, B: WideNode, const TIERED: bool> Tree<'a, A, B, TIERED> {
    #[inline(always)]
    fn new(top: &'a [A], rest: &'a [B]) -> Self {
        Tree {
            top: top.as_ptr(),
            rest: rest.as_ptr().wrapping_sub(top.len()),
            n_top: top.len() as u32,
            _nodes: std::marker::PhantomData,
        }
    }

    /// Whether node `i` is in `top` (always, untiered).
    #[inline(always)]
    fn in_top(&self, i: u32) -> bool {
        !TIERED || i < self.n_top
    }

    /// # Safety
    /// `i` is a node of `top`.
    #[inline(always)]
    unsafe fn top(&self, i: u32) -> &'a A {
        // SAFETY: the caller's promise.
        unsafe { &*self.top.add(i as usize) }
    }

    /// # Safety
    /// `i` is a node of `rest` (numbered after `top`'s).
    #[inline(always)]
    unsafe fn rest(&self, i: u32) -> &'a B {
        // SAFETY: the caller's promise; `self.rest + i` is within `rest`.
        unsafe { &*self.rest.wrapping_add(i as usize) }
    }

    /// Ask for node `i`, a child of a node of layout `N` (its lines; a child of a top node
    /// may be a rest node, which takes fewer).
    #[inline(always)]
    fn prefetch<N: WideNode>(&self, i: u32) {
        if TIERED {
            let p = if i < self.n_top {
                self.top.wrapping_add(i as usize) as *const u8
            } else {
                self.rest.wrapping_add(i as usize) as *const u8
            };
            prefetch(p, N::LINES);
        } else {
            prefetch(self.top.wrapping_add(i as usize), A::LINES);
        }
    }
}
