//! The BVH8 collapsed from the binary BVH, with leaves of up to [`LEAF_MAX`] primitives, each
//! leaf one packet of its own: a subtree of at most [`LEAF_MAX`] primitives is a leaf, and which
//! binary subtrees fill the 8 slots of each node is the choice of least expected cost in the
//! surface-area model ([`Plan`], by dynamic programming over the binary tree, as Ylitie et al.
//! 2017 do for their 8-wide BVH). Leaves that large cost one 8-wide packet test, while leaves of
//! at most 3 primitives (obvhs' CWBVH conversion) cost a level of nodes more.

use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;

use super::nodes::Encode;

/// Most primitives in a leaf: one packet.
pub(super) const LEAF_MAX: usize = 8;

/// The collapsed tree: its nodes (root first; the internal children of a node are consecutive
/// nodes, its leaves consecutive packets, both in slot order), the nodes down to a depth in
/// one layout (`top`) and the deeper ones in another (`rest`, numbered after `top`'s), the BVH2
/// node of each leaf (leaf `k` is packet `k`; [`Plan::pieces`] gives its primitives), its
/// depth, and its cost in the surface-area model: the node visits and the packet tests of a ray
/// through the root's box (each box's area over the root's, summed over the nodes and over the
/// leaves).
pub(super) struct Collapsed<T, R> {
    pub top: Vec<T>,
    pub rest: Vec<R>,
    pub leaves: Vec<u32>,
    pub depth: usize,
    pub sah: [f64; 2],
}

/// Collapse `bvh2` (not empty) as `plan` says, the nodes down to depth `top_depth` (the root's
/// is 1) as `T`s and the deeper ones as `R`s; `None` once it needs more than `max_nodes`
/// nodes.
pub(super) fn collapse<T: Encode, R: Encode>(
    plan: &Plan,
    max_nodes: usize,
    top_depth: usize,
) -> Option<Collapsed<T, R>> {
    let bvh2 = plan.bvh2;
    let b = &bvh2.nodes;
    // the nodes down to `top_depth` are numbered first
    let n_top = if top_depth == usize::MAX {
        usize::MAX
    } else {
        plan.levels(top_depth, usize::MAX).iter().sum()
    };
    let mut out = Collapsed {
        top: Vec::new(),
        rest: Vec::new(),
        leaves: Vec::new(),
        depth: 1,
        sah: [1.0, 0.0],
    };
    // a new node at `depth`: its number
    let push = |out: &mut Collapsed<T, R>, aabb: &Aabb, depth: usize| {
        if depth <= top_depth {
            out.top.push(T::new(aabb));
            out.top.len() - 1
        } else {
            out.rest.push(R::new(aabb));
            n_top + out.rest.len() - 1
        }
    };
    // node `i`, to write its slots
    fn at<T: Encode, R: Encode>(
        out: &mut Collapsed<T, R>,
        n_top: usize,
        i: usize,
    ) -> &mut dyn Encode {
        if i < n_top {
            &mut out.top[i]
        } else {
            &mut out.rest[i - n_top]
        }
    }
    push(&mut out, b[0].aabb(), 1);
    let root = b[0].aabb().half_area() as f64;
    // (BVH2 node, its number, depth)
    let mut todo = vec![(0usize, 0usize, 1usize)];
    let mut kids = Vec::with_capacity(8);
    while let Some((n, node, depth)) = todo.pop() {
        out.depth = out.depth.max(depth);
        kids.clear();
        plan.slots(n, &mut kids);
        let first_packet = out.leaves.len() as u32;
        // the children are numbered consecutively in their layout: from the next free number
        let first_child = if depth < top_depth {
            out.top.len()
        } else {
            n_top.saturating_add(out.rest.len())
        };
        at(&mut out, n_top, node).bases(first_child as u32, first_packet);
        for (slot, &k) in kids.iter().enumerate() {
            let aabb: &Aabb = b[k].aabb();
            let leaf = plan.is_leaf(k);
            out.sah[leaf as usize] += aabb.half_area() as f64 / root;
            if leaf {
                let packet = out.leaves.len() as u32;
                at(&mut out, n_top, node).set_leaf(slot, aabb, packet);
                out.leaves.push(k as u32);
            } else {
                if out.top.len() + out.rest.len() >= max_nodes {
                    return None;
                }
                let child = push(&mut out, aabb, depth + 1);
                at(&mut out, n_top, node).set_inner(slot, aabb, child as u32);
                todo.push((k, child, depth + 1));
            }
        }
    }
    debug_assert!(top_depth == usize::MAX || out.top.len() == n_top);
    Some(out)
}

/// Cost of a node visit against a leaf packet test, in the surface-area model of [`Plan`].
const NODE_COST: f32 = 1.0;
const PACKET_COST: f32 = 1.0;

/// Which BVH2 subtrees fill the slots of each 8-wide node: the choice of least expected cost in
/// the surface-area model (Ylitie et al. 2017, §3), by dynamic programming bottom up over the
/// BVH2. A subtree of at most [`LEAF_MAX`] primitives is one leaf, as in the greedy collapse:
/// splitting it into smaller leaves lowered the model's cost a little more but filled the
/// packets less (22–34 % more memory for at most 2 % fewer instructions a ray;
/// docs/performance.md, section 1).
pub(super) struct Plan<'a> {
    bvh2: &'a Bvh2,
    /// Per BVH2 node, its [`Choice::split`].
    at: Vec<[u8; 8]>,
    /// The BVH2's primitives (`primitive_indices`) leaf by leaf in post-order, left first, so
    /// that every subtree's are consecutive.
    pieces: Vec<u32>,
    /// Per BVH2 node of at most [`LEAF_MAX`] primitives, where its primitives start in
    /// `pieces` and how many there are (unused for larger subtrees).
    span: Vec<[u32; 2]>,
    /// The least cost of the whole tree given one slot (its root's `Choice::cost[0]`).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) cost: f32,
}

/// What [`Plan`] finds for a BVH2 subtree.
#[derive(Clone, Copy)]
struct Choice {
    /// `cost[i − 1]`: the least expected cost of the subtree given at most `i` slots of its
    /// parent, a node visit costing [`NODE_COST`] and a packet test [`PACKET_COST`] times the
    /// surface area of the box tested.
    cost: [f32; 8],
    /// `split[i − 1]` for i ≥ 2 slots: 0 to keep the subtree whole in one slot, else how many of
    /// the `i` slots go to the left child (the rest to the right). `split[0]`: 0 if the
    /// subtree is a leaf, else it is a node of its own and this is how many of its 8 slots go
    /// to the left child.
    split: [u8; 8],
    /// Primitives in the subtree.
    count: u32,
}

impl<'a> Plan<'a> {
    pub(super) fn new(bvh2: &'a Bvh2) -> Plan<'a> {
        let b = &bvh2.nodes;
        let mut at = vec![[0u8; 8]; b.len()];
        let mut span = vec![[0u32; 2]; b.len()];
        let mut pieces = Vec::with_capacity(bvh2.primitive_indices.len());
        // the children's choices, left below right (the order is a post-order, left first)
        let mut done: Vec<Choice> = Vec::new();
        // the nodes in pre-order, right child first, read in one tight pass (the nodes are
        // scattered in memory, and the next node's address is known early); backwards, that is
        // a post-order, left first
        for &(n, area, prims, first) in pre_order(bvh2).iter().rev() {
            let n = n as usize;
            let count = if prims > 0 {
                assert!(prims as usize <= LEAF_MAX, "BVH2 leaf over a packet");
                let first = first as usize;
                pieces.extend_from_slice(&bvh2.primitive_indices[first..first + prims as usize]);
                prims
            } else {
                let r = done.pop().expect("right child");
                let l = done.pop().expect("left child");
                let count = l.count + r.count;
                if count as usize > LEAF_MAX {
                    let c = Self::node(&l, &r, area, count);
                    at[n] = c.split;
                    done.push(c);
                    continue;
                }
                count
            };
            // a leaf: one slot, whatever the slots given; its primitives are the last `count`
            span[n] = [(pieces.len() - count as usize) as u32, count];
            done.push(Choice {
                cost: [PACKET_COST * area; 8],
                split: [0; 8],
                count,
            });
        }
        let cost = done.pop().expect("the root").cost[0];
        Plan {
            bvh2,
            at,
            pieces,
            span,
            cost,
        }
    }

    /// The choice for a subtree of more than [`LEAF_MAX`] primitives with box area `area`,
    /// from its children's.
    fn node(l: &Choice, r: &Choice, area: f32, count: u32) -> Choice {
        // shared[i]: the two children share i + 1 slots (i >= 1), the best division (one slot
        // each side when no cost is finite, so a node never passes for a leaf)
        let mut shared = [(f32::INFINITY, 1u8); 8];
        for (i, best) in shared.iter_mut().enumerate().skip(1) {
            for k in 1..=i {
                let c = l.cost[k - 1] + r.cost[i - k];
                if c < best.0 {
                    *best = (c, k as u8);
                }
            }
        }
        // a node of its own in one slot; with more slots, the children in them if cheaper
        let one = NODE_COST * area + shared[7].0;
        let mut c = Choice {
            cost: [one; 8],
            split: [shared[7].1, 0, 0, 0, 0, 0, 0, 0],
            count,
        };
        for (i, &(cost, k)) in shared.iter().enumerate().skip(1) {
            if cost < one {
                (c.cost[i], c.split[i]) = (cost, k);
            }
        }
        c
    }

    fn children(&self, n: usize) -> [usize; 2] {
        let f = self.bvh2.nodes[n].first_index as usize;
        [f, f + 1]
    }

    /// Whether the subtree `n` is a leaf.
    pub(super) fn is_leaf(&self, n: usize) -> bool {
        self.at[n][0] == 0
    }

    /// The primitives (BVH2 `primitive_indices`) of leaf subtree `n`, left to right.
    #[inline]
    pub(super) fn pieces(&self, n: u32) -> &[u32] {
        let [first, count] = self.span[n as usize];
        &self.pieces[first as usize..(first + count) as usize]
    }

    /// The number of nodes of the collapsed tree at each depth from 1 (the root) on, for at most
    /// `max_depth` levels and while all of them together are at most `max_nodes` nodes (only
    /// those levels are walked).
    pub(super) fn levels(&self, max_depth: usize, max_nodes: usize) -> Vec<usize> {
        let mut counts = Vec::new();
        let (mut level, mut next, mut kids) = (vec![0usize], Vec::new(), Vec::new());
        let mut total = 0usize;
        while !level.is_empty() && counts.len() < max_depth {
            total += level.len();
            if total > max_nodes {
                break;
            }
            counts.push(level.len());
            next.clear();
            for &n in &level {
                kids.clear();
                self.slots(n, &mut kids);
                next.extend(kids.iter().filter(|&&k| !self.is_leaf(k)));
            }
            std::mem::swap(&mut level, &mut next);
        }
        counts
    }

    /// The slots of the 8-wide node for subtree `n` (a leaf only at the root: one slot).
    fn slots(&self, n: usize, out: &mut Vec<usize>) {
        if self.is_leaf(n) {
            out.push(n);
            return;
        }
        let [l, r] = self.children(n);
        let k = self.at[n][0] as usize;
        self.gather(l, k, out);
        self.gather(r, 8 - k, out);
    }

    /// The subtrees that fill at most `i` slots for subtree `n`.
    fn gather(&self, n: usize, i: usize, out: &mut Vec<usize>) {
        let k = if i == 1 {
            0
        } else {
            self.at[n][i - 1] as usize
        };
        if k == 0 {
            out.push(n);
        } else {
            let [l, r] = self.children(n);
            self.gather(l, k, out);
            self.gather(r, i - k, out);
        }
    }
}

/// The BVH2's nodes in pre-order with the right child first (the node, its right child's
/// subtree, then its left child's), each with its box's half area, primitive count and first
/// primitive slot.
fn pre_order(bvh2: &Bvh2) -> Vec<(u32, f32, u32, u32)> {
    let b = &bvh2.nodes;
    let mut order = Vec::with_capacity(b.len());
    let mut stack = vec![0u32];
    while let Some(n) = stack.pop() {
        let node = &b[n as usize];
        let (first, prims) = (node.first_index, node.prim_count);
        order.push((n, node.aabb().half_area(), prims, first));
        if prims == 0 {
            stack.extend([first, first + 1]);
        }
    }
    order
}
