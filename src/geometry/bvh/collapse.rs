//! The BVH8 collapsed from the binary BVH, with leaves of up to [`LEAF_MAX`]
//! primitives, each leaf one packet of its own. Top down, as Embree's BVH8 builders do: a node
//! takes the two children of a binary node and opens the child with the largest surface area
//! until it has 8 children or none can be opened; a child holding at most [`LEAF_MAX`]
//! primitives is not opened but becomes a leaf. Leaves that large cost one 8-wide packet test,
//! while leaves of at most 3 primitives (obvhs' CWBVH conversion) cost a level of nodes more.

use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;

use super::nodes::Encode;

/// Most primitives in a leaf: one packet.
pub(super) const LEAF_MAX: usize = 8;

/// The collapsed tree: its nodes (root first; the internal children of a node are consecutive
/// nodes, its leaves consecutive packets, both in slot order), the BVH2 primitive slots of each
/// leaf (leaf `k` is packet `k`), and its depth.
pub(super) struct Collapsed<N> {
    pub nodes: Vec<N>,
    pub leaves: Vec<Vec<u32>>,
    pub depth: usize,
}

/// Collapse `bvh2` (not empty); `None` once it needs more than `max_nodes` nodes.
pub(super) fn collapse<N: Encode>(bvh2: &Bvh2, max_nodes: usize) -> Option<Collapsed<N>> {
    let b = &bvh2.nodes;
    let count = subtree_counts(bvh2);
    let children = |n: usize| {
        let f = b[n].first_index as usize;
        [f, f + 1]
    };
    let is_leaf = |n: usize| b[n].prim_count > 0;
    let mut out = Collapsed {
        nodes: vec![N::new(b[0].aabb())],
        leaves: Vec::new(),
        depth: 1,
    };
    // (BVH2 node, its Node8, depth)
    let mut todo = vec![(0usize, 0usize, 1usize)];
    while let Some((n, at, depth)) = todo.pop() {
        out.depth = out.depth.max(depth);
        let mut kids: Vec<usize> = if is_leaf(n) || count[n] <= LEAF_MAX {
            vec![n]
        } else {
            children(n).to_vec()
        };
        while kids.len() < 8 {
            let open = (0..kids.len())
                .filter(|&k| !is_leaf(kids[k]) && count[kids[k]] > LEAF_MAX)
                .max_by(|&x, &y| {
                    let a = |k: usize| b[kids[k]].aabb().half_area();
                    a(x).total_cmp(&a(y))
                });
            let Some(k) = open else { break };
            let [l, r] = children(kids[k]);
            kids[k] = l;
            kids.push(r);
        }
        let (first_child, first_packet) = (out.nodes.len() as u32, out.leaves.len() as u32);
        out.nodes[at].bases(first_child, first_packet);
        for (slot, &k) in kids.iter().enumerate() {
            let aabb: &Aabb = b[k].aabb();
            if count[k] <= LEAF_MAX {
                out.nodes[at].set_leaf(slot, aabb, out.leaves.len() as u32);
                out.leaves.push(leaf_slots(bvh2, k));
            } else {
                let child = out.nodes.len();
                if child >= max_nodes {
                    return None;
                }
                out.nodes.push(N::new(aabb));
                out.nodes[at].set_inner(slot, aabb, child as u32);
                todo.push((k, child, depth + 1));
            }
        }
    }
    Some(out)
}

/// Primitives under each BVH2 node.
fn subtree_counts(bvh2: &Bvh2) -> Vec<usize> {
    let b = &bvh2.nodes;
    let mut count = vec![0usize; b.len()];
    // children come after their parent in a depth-first pre-order of the tree; visit the
    // tree explicitly, parents after children
    let mut order = Vec::with_capacity(b.len());
    let mut stack = vec![0usize];
    while let Some(n) = stack.pop() {
        order.push(n);
        if b[n].prim_count == 0 {
            let f = b[n].first_index as usize;
            stack.extend([f, f + 1]);
        }
    }
    for &n in order.iter().rev() {
        count[n] = if b[n].prim_count > 0 {
            b[n].prim_count as usize
        } else {
            let f = b[n].first_index as usize;
            count[f] + count[f + 1]
        };
    }
    count
}

/// The BVH2 primitive slots under node `n`.
fn leaf_slots(bvh2: &Bvh2, n: usize) -> Vec<u32> {
    let b = &bvh2.nodes;
    let mut slots = Vec::new();
    let mut stack = vec![n];
    while let Some(n) = stack.pop() {
        let (first, count) = (b[n].first_index, b[n].prim_count);
        if count > 0 {
            slots.extend(first..first + count);
        } else {
            stack.extend([first as usize + 1, first as usize]);
        }
    }
    slots
}
