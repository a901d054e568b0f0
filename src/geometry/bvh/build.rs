//! Building an [`Accel`]: the binary BVH, its collapse to wide nodes and the leaf packets.

use glam::Vec3A;
use obvhs::{
    BvhBuildParams, aabb::Aabb, bvh2::reinsertion::ReinsertionOptimizer, ploc::PlocBuilder,
    splits::split_aabbs_preset,
};
use rayon::prelude::*;

use super::collapse::{Plan, collapse};
use super::flat::Flat;
use super::leaf::{Prim, TriBlock};
use super::nodes::{FULL_NODES_MAX, Node8, QNode8};
use super::{Accel, BuildQuality, Isa, Kernel, Layout, Nodes, PagedArray};
use crate::geometry::{Sphere, Triangle};

impl Accel {
    /// Build with the default quality ([`BuildQuality::Auto`]).
    pub fn build(triangles: &[Triangle], spheres: &[Sphere]) -> Accel {
        Self::build_quality(triangles, spheres, BuildQuality::Auto)
    }

    /// Build with `quality`.
    pub fn build_quality(triangles: &[Triangle], spheres: &[Sphere], q: BuildQuality) -> Accel {
        let n = triangles.len() + spheres.len();
        let mut a = Self::build_with(triangles, spheres, q.params(n), true);
        a.quality = Some((q, q.resolve(n)));
        a
    }

    /// Build with explicit obvhs parameters (`pre_split`: split large triangles' boxes).
    #[doc(hidden)]
    pub fn build_with(
        triangles: &[Triangle],
        spheres: &[Sphere],
        params: BvhBuildParams,
        pre_split: bool,
    ) -> Accel {
        Self::build_with_layout(triangles, spheres, params, pre_split, Layout::Auto)
    }

    /// [`Accel::build_with`] with the node layout forced.
    #[doc(hidden)]
    pub fn build_with_layout(
        triangles: &[Triangle],
        spheres: &[Sphere],
        params: BvhBuildParams,
        pre_split: bool,
        layout: Layout,
    ) -> Accel {
        let start = std::time::Instant::now();
        let n_tris = triangles.len();
        let n = n_tris + spheres.len();
        assert!(n < u32::MAX as usize, "too many primitives");
        if n == 0 {
            return Accel {
                nodes: Nodes::Quantised(PagedArray::new(Vec::new())),
                blocks: PagedArray::filled(0, TriBlock::UNUSED),
                sphere_lanes: Vec::new(),
                n_tris: 0,
                n_spheres: 0,
                stack_size: 0,
                sah: [0.0; 2],
                isa: Isa::active(),
                kernel: Kernel::Empty,
                flat: Flat::default(),
                quality: None,
                build_seconds: 0.0,
            };
        }

        // Pre-splitting large triangles (obvhs' precise triangle splits) pays off a lot on soups of
        // long thin triangles; it needs the obvhs triangle type, so only keep those alive briefly.
        let pre_split = pre_split && n_tris > 0;

        let mut aabbs: Vec<Aabb> = Vec::with_capacity(n + n / 4);
        let mut indices: Vec<u32> = Vec::with_capacity(n + n / 4);
        if pre_split {
            let otris: Vec<obvhs::triangle::Triangle> = triangles
                .iter()
                .map(|t| obvhs::triangle::Triangle {
                    v0: t.v[0].into(),
                    v1: t.v[1].into(),
                    v2: t.v[2].into(),
                })
                .collect();
            let mut largest = 0.0f32;
            let mut avg = 0.0f64;
            for t in &otris {
                let aabb = t.aabb();
                let ha = aabb.half_area();
                largest = largest.max(ha);
                avg += ha as f64;
                aabbs.push(aabb);
            }
            indices.extend(0..n_tris as u32);
            let avg = (avg / n_tris as f64) as f32;
            split_aabbs_preset(&mut aabbs, &mut indices, &otris, avg, largest);
        } else {
            aabbs.extend(
                triangles
                    .iter()
                    .map(|t| Aabb::from_points(&[t.v[0].into(), t.v[1].into(), t.v[2].into()])),
            );
            indices.extend(0..n_tris as u32);
        }
        for (i, s) in spheres.iter().enumerate() {
            let c = Vec3A::from(s.center);
            let r = Vec3A::splat(s.radius.abs());
            aabbs.push(Aabb::new(c - r, c + r));
            indices.push((n_tris + i) as u32);
        }

        // obvhs quirk: PLOC leaves store the *value* of `indices[i]` as their index into
        // `primitive_indices` (which is `indices`), so non-identity index lists (as produced by the
        // splits, plus our appended spheres) get mangled. Build over piece positions instead and
        // map pieces back to primitives ourselves.
        let piece_to_prim = indices;
        let true_aabbs = spread_coincident(&mut aabbs);
        let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
            params.ploc_search_distance,
            &aabbs,
            (0..aabbs.len() as u32).collect(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        drop(aabbs);
        bvh2.uses_spatial_splits = pre_split;
        // Reinsertion still sees coincident boxes spread: among identical boxes every move is
        // free, and reinserting them all (`BuildQuality::High`) chained them into a deep tree.
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        if let Some(true_aabbs) = true_aabbs {
            restore_aabbs(&mut bvh2, &true_aabbs);
        }
        let (nodes, (blocks, sphere_lanes), depth, sah) =
            Self::wide(&bvh2, &piece_to_prim, triangles, spheres, layout);
        Accel {
            nodes,
            blocks,
            sphere_lanes,
            n_tris: n_tris as u32,
            n_spheres: spheres.len() as u32,
            stack_size: 7 * depth + 1,
            sah,
            isa: Isa::active(),
            kernel: Kernel::Empty,
            flat: Flat::new(triangles, spheres),
            quality: None,
            build_seconds: start.elapsed().as_secs_f64(),
        }
        .with_kernel()
    }

    /// The 8-wide nodes and the leaf packets for the binary BVH over primitive pieces
    /// (`piece_to_prim`), in `layout`, the tree's depth and its cost in the surface-area model.
    fn wide(
        bvh2: &obvhs::bvh2::Bvh2,
        piece_to_prim: &[u32],
        triangles: &[Triangle],
        spheres: &[Sphere],
        layout: Layout,
    ) -> (Nodes, Packets, usize, [f64; 2]) {
        let n_tris = triangles.len();
        let mixed = !spheres.is_empty();
        let prim = |piece: u32| {
            let id = piece_to_prim[piece as usize];
            let p = id as usize;
            let p = if p < n_tris {
                Prim::triangle(&triangles[p])
            } else {
                Prim::sphere(&spheres[p - n_tris])
            };
            (id, p)
        };
        let plan = Plan::new(bvh2);
        let packets = |leaves: &[u32]| {
            let pieces = |k: usize| plan.pieces(leaves[k]);
            pack_collapsed(leaves.len(), pieces, n_tris as u32, mixed, prim)
        };
        let max_full = match layout {
            Layout::Auto => FULL_NODES_MAX,
            Layout::Full => usize::MAX,
            Layout::Quantised | Layout::Tiered { .. } => 0,
        };
        if max_full > 0
            && let Some(c) = collapse::<Node8, Node8>(&plan, max_full, usize::MAX)
        {
            return (
                Nodes::Full(PagedArray::new(c.top)),
                packets(&c.leaves),
                c.depth,
                c.sah,
            );
        }
        // The levels from the root down that fit in `top_nodes` full nodes (none when all are
        // quantised).
        let top_nodes = match layout {
            Layout::Tiered { top_nodes } => top_nodes,
            Layout::Quantised => 0,
            _ => FULL_NODES_MAX,
        };
        let top_depth = plan.levels(usize::MAX, top_nodes).len();
        let c = collapse::<Node8, QNode8>(&plan, usize::MAX, top_depth).expect("no node limit");
        let nodes = if c.top.is_empty() {
            Nodes::Quantised(PagedArray::new(c.rest))
        } else if c.rest.is_empty() {
            Nodes::Full(PagedArray::new(c.top))
        } else {
            Nodes::Tiered {
                top: PagedArray::new(c.top),
                rest: PagedArray::new(c.rest),
            }
        };
        (nodes, packets(&c.leaves), c.depth, c.sah)
    }
}

/// The leaf packets and, in scenes with spheres, each packet's sphere lanes (a bit mask).
type Packets = (PagedArray<TriBlock>, Vec<u8>);

/// One packet per leaf of a collapsed BVH ([`collapse`]), its lanes the pieces that `pieces`
/// gives for the leaf (a primitive split into several pieces of one leaf takes one lane). The
/// packets are independent, so they are filled in parallel, each the same on any thread, and in
/// their final memory ([`PagedArray`]: no copy of tens of megabytes at the peak of the build).
fn pack_collapsed<'a>(
    n_leaves: usize,
    pieces: impl Fn(usize) -> &'a [u32] + Sync,
    n_tris: u32,
    mixed: bool,
    prim: impl Fn(u32) -> (u32, Prim) + Sync,
) -> Packets {
    let pack = |b: usize, blk: &mut TriBlock| {
        let mut spheres = 0u8;
        let mut l = 0;
        for &piece in pieces(b) {
            let (id, p) = prim(piece);
            if blk.ids[..l].contains(&id) {
                continue;
            }
            blk.set(l, &p);
            blk.ids[l] = id;
            spheres |= ((id >= n_tris) as u8) << l;
            l += 1;
        }
        spheres
    };
    let mut blocks = PagedArray::filled(n_leaves, TriBlock::UNUSED);
    let sphere_lanes: Vec<u8> = blocks
        .as_mut_slice()
        .par_iter_mut()
        .enumerate()
        .map(|(b, blk)| pack(b, blk))
        .collect();
    (blocks, if mixed { sphere_lanes } else { Vec::new() })
}

/// Smallest group of primitive boxes with one centre that [`spread_coincident`] separates.
pub(super) const COINCIDENT_MIN: usize = 8;

/// Separate groups of boxes with one centre (coincident copies, concentric shapes) for the PLOC
/// build. PLOC merges two nodes only when each is the other's cheapest neighbour. Among
/// identical boxes every cost ties, each node picks its farthest neighbour (obvhs keeps the last
/// of equal costs) and only the last pair of the sorted run agrees; among nested ones each node
/// ties with all the smaller ones and picks the next smaller, so only the two smallest agree.
/// Either way the build merges one pair per pass: quadratic in the group's size, with a tree as
/// deep as the group (5000 copies of one quad took 2.4 s, 70,000 aborted after ten minutes).
/// Each box of a group of at least [`COINCIDENT_MIN`] is therefore translated by a deterministic
/// pseudo-random offset of up to 1e-3 of the group's largest box for the PLOC build and the
/// reinsertion, which spreads the group like a small point cloud; returns the true boxes when
/// any box was moved (the caller puts them back with [`restore_aabbs`]). Scenes without such
/// groups build exactly as before.
fn spread_coincident(aabbs: &mut [Aabb]) -> Option<Vec<Aabb>> {
    let key = |b: &Aabb| (b.min + b.max).to_array().map(|x| (x + 0.0).to_bits());
    // First the keys' 64-bit hashes, sorted (in parallel, the same order on any thread count):
    // a group of equal keys is a run of equal hashes, so without such runs, as in most meshes,
    // there is no group, and the exact sort below is skipped.
    let mut hashes: Vec<u64> = aabbs
        .par_iter()
        .map(|b| {
            let [x, y, z] = key(b);
            splitmix64(splitmix64((x as u64) << 32 | y as u64) ^ z as u64)
        })
        .collect();
    hashes.par_sort_unstable();
    if !hashes
        .chunk_by(|a, b| a == b)
        .any(|run| run.len() >= COINCIDENT_MIN)
    {
        return None;
    }
    drop(hashes);
    let mut order: Vec<u32> = (0..aabbs.len() as u32).collect();
    order.sort_unstable_by_key(|&i| key(&aabbs[i as usize]));
    let runs: Vec<&[u32]> = order
        .chunk_by(|&a, &b| key(&aabbs[a as usize]) == key(&aabbs[b as usize]))
        .filter(|run| run.len() >= COINCIDENT_MIN)
        .collect();
    if runs.is_empty() {
        return None;
    }
    let true_aabbs = aabbs.to_vec();
    for run in runs {
        let (mut size, mut magnitude) = (0.0f32, 0.0f32);
        for &i in run {
            let b = &aabbs[i as usize];
            size = size.max((b.max - b.min).max_element());
            magnitude = magnitude.max(b.min.abs().max(b.max.abs()).max_element());
        }
        let delta = 1e-3 * size.max(1e-4 * magnitude).max(1e-6);
        for &i in run {
            let h = |axis: u64| {
                let x = splitmix64((i as u64) * 3 + axis);
                (x >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
            };
            let t = Vec3A::new(h(0), h(1), h(2)) * delta;
            let a = &mut aabbs[i as usize];
            *a = Aabb::new(a.min + t, a.max + t);
        }
    }
    Some(true_aabbs)
}

/// Put the primitives' true boxes back into the leaves of a BVH built over moved ones
/// ([`spread_coincident`]) and refit the inner nodes.
fn restore_aabbs(bvh2: &mut obvhs::bvh2::Bvh2, true_aabbs: &[Aabb]) {
    for k in 0..bvh2.nodes.len() {
        let node = bvh2.nodes[k];
        if node.is_leaf() {
            let first = node.first_index as usize;
            let mut b = Aabb::empty();
            for &p in &bvh2.primitive_indices[first..first + node.prim_count as usize] {
                b = b.union(&true_aabbs[p as usize]);
            }
            bvh2.nodes[k].set_aabb(b);
        }
    }
    bvh2.refit_all();
}

fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
