//! Acceleration structure: one wide BVH8 over triangles and analytic spheres, from the binary
//! BVH that `obvhs` builds (PLOC with pre-split triangles, then reinsertion).
//!
//! Build quality ([`BuildQuality`]): the reinsertion pass can revisit a few nodes (`medium`) or
//! every node (`high`, 5–10× the build time for a tree traced 4–12 % faster);
//! `auto`, the default, takes `high` up to [`AUTO_HIGH_MAX`] primitives, where that build stays
//! under about a second.
//!
//! Nodes ([`nodes`]): the binary BVH is collapsed ([`collapse`]) to 8-wide nodes with leaves of
//! up to 8 primitives, one packet each. While that takes at most [`nodes::FULL_NODES_MAX`] nodes
//! they keep the child boxes in full precision ([`nodes::Node8`], 256 bytes, no decoding per
//! visit); larger trees quantise them to 8 bits per plane ([`nodes::QNode8`], 80 bytes), whose
//! smaller footprint pays once the nodes no longer fit in the caches. Both give the same hits
//! (up to ties between coincident primitives, which they may meet in another order).
//!
//! Traversal: a visit returns the hit internal slots and the hit leaves; internal children go
//! onto the stack with one left-pack, ordered far to near, and the nearest is visited next.
//! Branches depend on the data as little as possible (a mispredicted branch costs more than a
//! node test).
//!
//! Leaves: primitives are stored as 8-lane SoA packets ([`TriBlock`], the idea of Embree's
//! `Triangle4v`/`Triangle8v`), each tested with one branch-free 8-wide Möller–Trumbore instead of
//! one scalar test per primitive. A lane's original primitive id is in its packet, so traversal
//! never needs `primitive_indices`.
//!
//! Notes on `obvhs` 0.4: its CWBVH node test clamps the ray's `tmin` to a hard-coded `1e-4`, and
//! `Triangle::compute_barycentric` is wrong; neither is used (our own node visits use
//! `tmin = 0`, our own intersector computes the barycentrics).

use glam::Vec3A;
use obvhs::{
    BvhBuildParams, aabb::Aabb, bvh2::reinsertion::ReinsertionOptimizer, ploc::PlocBuilder,
    splits::split_aabbs_preset,
};
use std::mem::MaybeUninit;

use super::{Hit, Ray, Sphere, Triangle};

mod collapse;
mod nodes;
use collapse::{Plan, collapse};
use nodes::{Entry, FULL_NODES_MAX, Node8, QNode8, TRay, Visit, WideNode};
use rayon::prelude::*;

/// Precomputed primitive record (one per BVH primitive slot).
///
/// Triangle: `a = v0`, `b = v0 - v1`, `c = v2 - v0`, `d = b x c` (layout of madmann91's `bvh` /
/// `obvhs::rt_triangle::RtTriangle`). Sphere: `a = center`, `b = (r, r^2, 0)`.
/// Aligned to a cache line (one line per record).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Prim {
    a: Vec3A,
    b: Vec3A,
    c: Vec3A,
    d: Vec3A,
}

impl Prim {
    fn triangle(t: &Triangle) -> Prim {
        let v0 = Vec3A::from(t.v[0]);
        let e1 = v0 - Vec3A::from(t.v[1]);
        let e2 = Vec3A::from(t.v[2]) - v0;
        Prim {
            a: v0,
            b: e1,
            c: e2,
            d: e1.cross(e2),
        }
    }

    fn sphere(s: &Sphere) -> Prim {
        Prim {
            a: Vec3A::from(s.center),
            b: Vec3A::new(s.radius, s.radius * s.radius, 0.0),
            c: Vec3A::ZERO,
            d: Vec3A::ZERO,
        }
    }

    /// Möller–Trumbore (no culling). Returns `t` (or a value failing `0 < t < t_max`, possibly NaN)
    /// and the barycentrics of v1 and v2.
    #[inline(always)]
    fn intersect_triangle(&self, r: &TRay) -> (f32, f32, f32) {
        let c = self.a - r.o;
        let rr = r.d.cross(c);
        let inv_det = 1.0 / self.d.dot(r.d);
        let u = rr.dot(self.c) * inv_det;
        let v = rr.dot(self.b) * inv_det;
        let w = 1.0 - u - v;
        // Sign bits: rejects negative values and -0; NaN (degenerate / parallel) gives NaN t below.
        if (u.to_bits() | v.to_bits() | w.to_bits()) & 0x8000_0000 != 0 {
            return (f32::NAN, 0.0, 0.0);
        }
        (self.d.dot(c) * inv_det, u, v)
    }

    /// Nearest root in `(0, t_max)` of a ray/sphere intersection, using the numerically robust
    /// form of Ray Tracing Gems, ch. 7 (discriminant from the closest-approach vector and the
    /// `q = b + sign(b) sqrt(...)` root pair). Returns NaN/inf/<=0 on miss.
    #[inline(always)]
    fn intersect_sphere(&self, r: &TRay, t_max: f32) -> f32 {
        let r2 = self.b.y;
        let f = r.o - self.a;
        let a = r.d.length_squared();
        let b = -f.dot(r.d); // b' (half of -b in the textbook form)
        let c = f.length_squared() - r2;
        let l = f + (b / a) * r.d;
        let disc = r2 - l.length_squared();
        if disc < 0.0 {
            return f32::NAN;
        }
        let q = b + (a * disc).sqrt().copysign(b);
        let t0 = c / q;
        let t1 = q / a;
        let (t_near, t_far) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        if t_near > 0.0 && t_near < t_max {
            t_near
        } else {
            t_far
        }
    }
}

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

/// How much time the build spends on the tree's quality (as Embree's `RTC_BUILD_QUALITY_*`);
/// a scene sets it with `"accel": {"quality": ...}` (docs/scene-format.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BuildQuality {
    /// `High` up to [`AUTO_HIGH_MAX`] primitives, `Medium` above.
    #[default]
    Auto,
    /// obvhs' medium preset: PLOC, then reinsertion of 5 % of the nodes.
    Medium,
    /// obvhs' very-slow preset: a finer PLOC sort, then reinsertion of every node.
    High,
}

/// Largest scene (triangles and spheres) that [`BuildQuality::Auto`] builds with `High`: about
/// a second of build at this size (0.2–0.3 s for 100 000 triangles, 1.3–1.9 s for 300 000 on
/// the machine of docs/performance.md).
pub const AUTO_HIGH_MAX: usize = 250_000;

impl BuildQuality {
    /// `Medium` or `High`: the quality `Auto` takes for `n` primitives, or `self`.
    pub fn resolve(self, n: usize) -> BuildQuality {
        match self {
            BuildQuality::Auto if n <= AUTO_HIGH_MAX => BuildQuality::High,
            BuildQuality::Auto => BuildQuality::Medium,
            q => q,
        }
    }

    /// The obvhs parameters of the resolved quality.
    fn params(self, n: usize) -> BvhBuildParams {
        match self.resolve(n) {
            BuildQuality::High => BvhBuildParams::very_slow_build(),
            _ => BvhBuildParams::medium_build(),
        }
    }

    /// The name in scene files.
    pub fn name(self) -> &'static str {
        match self {
            BuildQuality::Auto => "auto",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        }
    }
}

/// Stack size for the on-stack traversal stack; deeper BVHs use a heap stack.
const STACK: usize = 192;

/// Largest triangle-only scene traced with the flat AVX2 loop instead of the BVH.
const FLAT_MAX: usize = 64;

/// 8 triangles in SoA form (same quantities as [`Prim::triangle`]). A sphere lane holds its
/// centre in `a` and (r, r²) in `b.x`, `b.y` ([`Prim::sphere`]); unused lanes are all zero, which
/// no ray hits (t = 0 · ∞ = NaN).
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct TriBlock {
    /// v0, v0 - v1, v2 - v0; per axis, per lane. The normal (v0 - v1) x (v2 - v0) is computed
    /// in the test, with the operations of `Vec3A::cross`, so it is the same to the bit.
    a: [[f32; 8]; 3],
    b: [[f32; 8]; 3],
    c: [[f32; 8]; 3],
    /// Original primitive id per lane (`u32::MAX` if unused); in the packet's last cache line,
    /// which the test has loaded.
    ids: [u32; 8],
}

impl std::hash::Hash for TriBlock {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        for v in [&self.a, &self.b, &self.c] {
            v.map(|row| row.map(f32::to_bits)).hash(h);
        }
        self.ids.hash(h);
    }
}

// the packet size the node layouts prefetch by
const _: () = assert!(std::mem::size_of::<TriBlock>() == nodes::PACKET_BYTES);

impl TriBlock {
    /// No primitive in any lane (all zero, which no ray hits; ids `u32::MAX`).
    const UNUSED: TriBlock = TriBlock {
        a: [[0.0; 8]; 3],
        b: [[0.0; 8]; 3],
        c: [[0.0; 8]; 3],
        ids: [u32::MAX; 8],
    };

    fn set(&mut self, l: usize, p: &Prim) {
        for k in 0..3 {
            self.a[k][l] = p.a[k];
            self.b[k][l] = p.b[k];
            self.c[k][l] = p.c[k];
        }
    }

    /// The sphere in lane `l`.
    #[inline(always)]
    fn sphere(&self, l: usize) -> Prim {
        Prim {
            a: Vec3A::new(self.a[0][l], self.a[1][l], self.a[2][l]),
            b: Vec3A::new(self.b[0][l], self.b[1][l], 0.0),
            c: Vec3A::ZERO,
            d: Vec3A::ZERO,
        }
    }
}

/// A packet of the flat loop of tiny scenes, with its normals stored: there the data stay in
/// the L1 cache and the arithmetic decides.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct FlatBlock {
    tri: TriBlock,
    n: [[f32; 8]; 3],
}

/// The BVH's nodes in one of the two layouts of [`nodes`]: full precision while they fit in
/// the caches, quantised beyond.
enum Nodes {
    Full(Vec<Node8>),
    Quantised(Vec<QNode8>),
}

impl Nodes {
    fn len(&self) -> usize {
        match self {
            Nodes::Full(n) => n.len(),
            Nodes::Quantised(n) => n.len(),
        }
    }

    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn bytes(&self) -> usize {
        match self {
            Nodes::Full(n) => std::mem::size_of_val(&n[..]),
            Nodes::Quantised(n) => std::mem::size_of_val(&n[..]),
        }
    }
}

/// The scene's acceleration structure (triangles and spheres in one BVH8).
pub struct Accel {
    /// The nodes (root first), in the layout that suits the BVH's size.
    nodes: Nodes,
    /// The leaves' primitives, one 8-lane packet a leaf, each node's leaves consecutive (the
    /// node layouts address them).
    blocks: Vec<TriBlock>,
    /// Per packet: the lanes that hold spheres (empty when the scene has none; the traversal
    /// for scenes with spheres, which trees too deep for the stack array take in any scene,
    /// reads it with a bounds check).
    sphere_lanes: Vec<u8>,
    n_tris: u32,
    n_spheres: u32,
    /// Upper bound on the traversal stack depth (7 entries per level).
    stack_size: usize,
    /// Use the AVX2 traversal (detected at build time).
    avx2: bool,
    /// The tree's node visits and packet tests per ray through the root box, in the
    /// surface-area model (`Collapsed::sah`).
    sah: [f64; 2],
    /// Tiny triangle-only scenes (<= `FLAT_MAX`, AVX2 only): all triangles in original order,
    /// tested with a flat 8-wide loop (faster than any traversal at this size).
    flat: Vec<FlatBlock>,
    /// The quality asked for and the one it was built with (`Medium` or `High`); `None` for
    /// explicit obvhs parameters. Then the build's wall time in seconds.
    quality: Option<(BuildQuality, BuildQuality)>,
    build_seconds: f64,
}

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

    /// The quality asked for and the one the BVH was built with (`Medium` or `High`); `None`
    /// for explicit obvhs parameters.
    pub fn quality(&self) -> Option<(BuildQuality, BuildQuality)> {
        self.quality
    }

    /// The build's wall time in seconds.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// Whether rays are traced with the flat loop of tiny scenes instead of the BVH.
    pub fn is_flat(&self) -> bool {
        !self.flat.is_empty()
    }

    /// Build with explicit obvhs parameters (`pre_split`: split large triangles' boxes).
    #[doc(hidden)]
    pub fn build_with(
        triangles: &[Triangle],
        spheres: &[Sphere],
        params: BvhBuildParams,
        pre_split: bool,
    ) -> Accel {
        Self::build_with_layout(triangles, spheres, params, pre_split, None)
    }

    /// [`Accel::build_with`] with the node layout forced (`full`: [`Node8`], or [`QNode8`];
    /// `None`: by size, [`FULL_NODES_MAX`]).
    #[doc(hidden)]
    pub fn build_with_layout(
        triangles: &[Triangle],
        spheres: &[Sphere],
        params: BvhBuildParams,
        pre_split: bool,
        full: Option<bool>,
    ) -> Accel {
        let start = std::time::Instant::now();
        let n_tris = triangles.len();
        let n = n_tris + spheres.len();
        assert!(n < u32::MAX as usize, "too many primitives");
        if n == 0 {
            return Accel {
                nodes: Nodes::Quantised(Vec::new()),
                blocks: Vec::new(),
                sphere_lanes: Vec::new(),
                n_tris: 0,
                n_spheres: 0,
                stack_size: 0,
                sah: [0.0; 2],
                avx2: false,
                flat: Vec::new(),
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
            Self::wide(&bvh2, &piece_to_prim, triangles, spheres, full);
        Accel {
            nodes,
            blocks,
            sphere_lanes,
            n_tris: n_tris as u32,
            n_spheres: spheres.len() as u32,
            stack_size: 7 * depth + 1,
            sah,
            avx2: has_avx2(),
            flat: Self::flat_blocks(triangles, spheres),
            quality: None,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// The 8-wide nodes and the leaf packets for the binary BVH over primitive pieces
    /// (`piece_to_prim`), in the layout `full` asks for (`None`: by size), the tree's depth and
    /// its cost in the surface-area model.
    fn wide(
        bvh2: &obvhs::bvh2::Bvh2,
        piece_to_prim: &[u32],
        triangles: &[Triangle],
        spheres: &[Sphere],
        full: Option<bool>,
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
        let max_full = if full == Some(true) {
            usize::MAX
        } else {
            FULL_NODES_MAX
        };
        let plan = Plan::new(bvh2);
        let packets = |leaves: &[u32]| {
            let pieces = |k: usize| plan.pieces(leaves[k]);
            pack_collapsed(leaves.len(), pieces, n_tris as u32, mixed, prim)
        };
        let collapsed = (full != Some(false))
            .then(|| collapse::<Node8>(&plan, max_full))
            .flatten();
        match collapsed {
            Some(c) => (Nodes::Full(c.nodes), packets(&c.leaves), c.depth, c.sah),
            None => {
                let c = collapse::<QNode8>(&plan, usize::MAX).expect("no node limit");
                (
                    Nodes::Quantised(c.nodes),
                    packets(&c.leaves),
                    c.depth,
                    c.sah,
                )
            }
        }
    }

    /// The tree's cost in the surface-area model, for profiling: the node visits and the packet
    /// tests of a ray through the root's box (each box's area over the root's, summed over the
    /// nodes and over the leaves; Embree's `verbose=2` statistics give the same for its trees).
    #[doc(hidden)]
    pub fn sah(&self) -> [f64; 2] {
        self.sah
    }

    /// A digest of the tree (nodes, packets and sphere lanes, every value to the bit), to
    /// compare builds: two builds with the same digest trace every ray alike. (The hash is
    /// std's `DefaultHasher`, stable within one toolchain, not across Rust releases.)
    #[doc(hidden)]
    pub fn fingerprint(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        match &self.nodes {
            Nodes::Full(n) => n.hash(&mut h),
            Nodes::Quantised(n) => n.hash(&mut h),
        }
        self.blocks.hash(&mut h);
        self.sphere_lanes.hash(&mut h);
        h.finish()
    }

    /// Sizes for profiling: (nodes, packets, lanes in use, bytes of nodes + packets + ids).
    #[doc(hidden)]
    pub fn layout(&self) -> (usize, usize, usize, usize) {
        let used = self
            .blocks
            .iter()
            .flat_map(|b| b.ids)
            .filter(|&i| i != u32::MAX)
            .count();
        let bytes =
            self.nodes.bytes() + std::mem::size_of_val(&self.blocks[..]) + self.sphere_lanes.len();
        (self.nodes.len(), self.blocks.len(), used, bytes)
    }

    pub fn num_primitives(&self) -> usize {
        (self.n_tris + self.n_spheres) as usize
    }

    /// Closest hit with t in (0, t_max). Primitive ids `0..triangles.len()` are triangles
    /// (u, v = barycentrics of v1 and v2), then spheres (u, v unused, 0).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if self.nodes.is_empty() || t_max.is_nan() || t_max <= 0.0 {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is only set when the CPU supports AVX2, FMA, POPCNT and BMI1.
            return unsafe {
                let (o, d) = (ray.o, ray.d);
                if self.flat.is_empty() {
                    self.intersect_avx2(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
                } else {
                    self.intersect_flat(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
                }
            };
        }
        self.intersect_portable(ray, t_max)
    }

    /// The traversal without AVX2, out of line: inlined, its stack frame and register saves
    /// would be paid by every ray of the AVX2 paths too.
    #[inline(never)]
    fn intersect_portable(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.intersect_dispatch::<false>(ray, t_max)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi1,fma")]
    #[allow(clippy::too_many_arguments)]
    fn intersect_avx2(
        &self,
        ox: f32,
        oy: f32,
        oz: f32,
        dx: f32,
        dy: f32,
        dz: f32,
        t_max: f32,
    ) -> Option<Hit> {
        // the ray in registers, as for `intersect_flat`
        let ray = Ray::new(glam::Vec3::new(ox, oy, oz), glam::Vec3::new(dx, dy, dz));
        self.intersect_dispatch::<true>(&ray, t_max)
    }

    #[inline(always)]
    fn intersect_dispatch<const AVX: bool>(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        match &self.nodes {
            Nodes::Full(n) => self.intersect_stack::<Node8, AVX>(n, ray, t_max),
            Nodes::Quantised(n) => self.intersect_stack::<QNode8, AVX>(n, ray, t_max),
        }
    }

    #[inline(always)]
    fn intersect_stack<N: WideNode, const AVX: bool>(
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
                self.intersect_impl::<N, false, AVX, 0>(nodes, ray, t_max, &mut stack)
            } else {
                self.intersect_impl::<N, true, AVX, 1>(nodes, ray, t_max, &mut stack)
            }
        } else {
            // rare: one instantiation, the general one (spheres or not), for deep trees
            let mut stack = vec![MaybeUninit::<Entry>::uninit(); self.stack_size];
            self.intersect_impl::<N, true, AVX, 2>(nodes, ray, t_max, &mut stack)
        }
    }

    fn flat_blocks(triangles: &[Triangle], spheres: &[Sphere]) -> Vec<FlatBlock> {
        if !spheres.is_empty() || triangles.len() > FLAT_MAX || !has_avx2() {
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

    /// 8-wide Möller–Trumbore over one block: hit lane mask (0 < t < t_max) and t, u, v per lane.
    /// Same operations in the same order as [`Prim::intersect_triangle`], so results are
    /// bit-identical to it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn flat_block(
        blk: &TriBlock,
        normal: Option<&[[f32; 8]; 3]>,
        o: [f32; 3],
        d: [f32; 3],
        t_max: f32,
        out: Option<&mut [[f32; 8]; 3]>,
    ) -> u32 {
        use std::arch::x86_64::*;
        // SAFETY: AVX2 is enabled for this function; all loads read whole `[f32; 8]` fields.
        unsafe {
            let ld = |a: &[f32; 8]| _mm256_loadu_ps(a.as_ptr());
            let (mul, add, sub) = (_mm256_mul_ps, _mm256_add_ps, _mm256_sub_ps);
            let (dx, dy, dz) = (
                _mm256_set1_ps(d[0]),
                _mm256_set1_ps(d[1]),
                _mm256_set1_ps(d[2]),
            );
            let cx = sub(ld(&blk.a[0]), _mm256_set1_ps(o[0]));
            let cy = sub(ld(&blk.a[1]), _mm256_set1_ps(o[1]));
            let cz = sub(ld(&blk.a[2]), _mm256_set1_ps(o[2]));
            // rr = d x c
            let rx = sub(mul(dy, cz), mul(cy, dz));
            let ry = sub(mul(dz, cx), mul(cz, dx));
            let rz = sub(mul(dx, cy), mul(cx, dy));
            let dotv = |ax, ay, az, bx, by, bz| add(add(mul(ax, bx), mul(ay, by)), mul(az, bz));
            let dot = |ax, ay, az, bx: &[f32; 8], by: &[f32; 8], bz: &[f32; 8]| {
                dotv(ax, ay, az, ld(bx), ld(by), ld(bz))
            };
            // n = b x c, stored or computed as `Vec3A::cross` computes it.
            let (nx, ny, nz) = match normal {
                Some(n) => (ld(&n[0]), ld(&n[1]), ld(&n[2])),
                None => {
                    let (bx, by, bz) = (ld(&blk.b[0]), ld(&blk.b[1]), ld(&blk.b[2]));
                    let (ex, ey, ez) = (ld(&blk.c[0]), ld(&blk.c[1]), ld(&blk.c[2]));
                    (
                        sub(mul(by, ez), mul(ey, bz)),
                        sub(mul(bz, ex), mul(ez, bx)),
                        sub(mul(bx, ey), mul(ex, by)),
                    )
                }
            };
            let det = dotv(dx, dy, dz, nx, ny, nz);
            let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
            let u = mul(dot(rx, ry, rz, &blk.c[0], &blk.c[1], &blk.c[2]), inv_det);
            let v = mul(dot(rx, ry, rz, &blk.b[0], &blk.b[1], &blk.b[2]), inv_det);
            let w = sub(sub(_mm256_set1_ps(1.0), u), v);
            let neg = _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(u, v), w)) as u32;
            let t = mul(dotv(cx, cy, cz, nx, ny, nz), inv_det);
            let ok = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(t, _mm256_setzero_ps()),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(t_max)),
            );
            let hits = _mm256_movemask_ps(ok) as u32 & !neg;
            if hits != 0
                && let Some(out) = out
            {
                _mm256_storeu_ps(out[0].as_mut_ptr(), t);
                _mm256_storeu_ps(out[1].as_mut_ptr(), u);
                _mm256_storeu_ps(out[2].as_mut_ptr(), v);
            }
            hits
        }
    }

    /// Closest hit over the flat blocks (a scene of at most `FLAT_MAX` triangles). The ray
    /// comes in registers, not behind a reference: loaded whole from a ray its caller has just
    /// stored piece by piece, it would wait for the stores to complete (a failed store-to-load
    /// forward; pt-hero on cornell-box ran 4–6 % slower that way).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi1")]
    #[allow(clippy::too_many_arguments)]
    fn intersect_flat(
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
    fn occluded_flat(
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

    /// Test the lanes `lanes` (bits 0..8) of packet `b` against `r`: the mask of lanes hit in
    /// (0, t_max), their t, u, v in `tuv`. Spheres (in mixed scenes) are tested one by one.
    #[inline(always)]
    fn test_block<const MIXED: bool, const AVX: bool>(
        &self,
        b: usize,
        lanes: u32,
        r: &TRay,
        t_max: f32,
        tuv: &mut [[f32; 8]; 3],
    ) -> u32 {
        // SAFETY: node lane bases and leaf offsets address packets the build wrote.
        let blk = unsafe { self.blocks.get_unchecked(b) };
        // (the heap-stack traversal of a deep tree takes this path in scenes without spheres
        // too, whose table is empty)
        let spheres = if MIXED {
            self.sphere_lanes.get(b).map_or(0, |&m| m as u32)
        } else {
            0
        };
        let mut hits = 0;
        if lanes & !spheres != 0 {
            #[cfg(target_arch = "x86_64")]
            if AVX {
                // SAFETY: AVX is only true on the AVX2 path (`has_avx2`).
                hits = unsafe {
                    Self::flat_block(blk, None, r.o.to_array(), r.d.to_array(), t_max, Some(tuv))
                };
            } else {
                hits = block_portable(blk, r, t_max, tuv);
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                hits = block_portable(blk, r, t_max, tuv);
            }
            hits &= lanes & !spheres;
        }
        let mut s = lanes & spheres;
        while s != 0 {
            let l = s.trailing_zeros() as usize;
            s &= s - 1;
            let t = blk.sphere(l).intersect_sphere(r, t_max);
            if t > 0.0 && t < t_max {
                hits |= 1 << l;
                tuv[0][l] = t;
                tuv[1][l] = 0.0;
                tuv[2][l] = 0.0;
            }
        }
        hits
    }

    /// Closest-hit traversal: leaf children are tested as soon as their node is, internal
    /// children are visited nearest first (sorted by entry distance), and popped entries farther
    /// than the current hit are skipped.
    #[inline(always)]
    fn intersect_impl<N: WideNode, const MIXED: bool, const AVX: bool, const SITE: u8>(
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
            } = node.visit::<AVX, SITE>(&r, t_best, &mut tmins);
            // Inner children onto the stack in slot order (not yet counted in `sp`); their boxes
            // load while the leaves are tested.
            let n_inner = inner_hits.count_ones() as usize;
            if n_inner > 0 {
                node.write_inner::<AVX>(inner_hits, &tmins, &mut stack[sp..sp + 8]);
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
                    let h = self.test_block::<MIXED, AVX>(b, lanes, &r, t_best, &mut tuv);
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

    /// Any hit with t in (0, t_max).
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if self.nodes.is_empty() || t_max.is_nan() || t_max <= 0.0 {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: see `intersect`.
            return unsafe {
                let (o, d) = (ray.o, ray.d);
                if self.flat.is_empty() {
                    self.occluded_avx2(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
                } else {
                    self.occluded_flat(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
                }
            };
        }
        self.occluded_portable(ray, t_max)
    }

    /// See [`Self::intersect_portable`].
    #[inline(never)]
    fn occluded_portable(&self, ray: &Ray, t_max: f32) -> bool {
        self.occluded_dispatch::<false>(ray, t_max)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi1,fma")]
    #[allow(clippy::too_many_arguments)]
    fn occluded_avx2(
        &self,
        ox: f32,
        oy: f32,
        oz: f32,
        dx: f32,
        dy: f32,
        dz: f32,
        t_max: f32,
    ) -> bool {
        // the ray in registers, as for `intersect_flat`
        let ray = Ray::new(glam::Vec3::new(ox, oy, oz), glam::Vec3::new(dx, dy, dz));
        self.occluded_dispatch::<true>(&ray, t_max)
    }

    #[inline(always)]
    fn occluded_dispatch<const AVX: bool>(&self, ray: &Ray, t_max: f32) -> bool {
        match &self.nodes {
            Nodes::Full(n) => self.occluded_stack::<Node8, AVX>(n, ray, t_max),
            Nodes::Quantised(n) => self.occluded_stack::<QNode8, AVX>(n, ray, t_max),
        }
    }

    #[inline(always)]
    fn occluded_stack<N: WideNode, const AVX: bool>(
        &self,
        nodes: &[N],
        ray: &Ray,
        t_max: f32,
    ) -> bool {
        // `SITE` 3-5: see `intersect_stack`.
        if self.stack_size <= STACK {
            let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK];
            if self.n_spheres == 0 {
                self.occluded_impl::<N, false, AVX, 3>(nodes, ray, t_max, &mut stack)
            } else {
                self.occluded_impl::<N, true, AVX, 4>(nodes, ray, t_max, &mut stack)
            }
        } else {
            // rare: one instantiation, the general one (spheres or not), for deep trees
            let mut stack = vec![MaybeUninit::<u32>::uninit(); self.stack_size];
            self.occluded_impl::<N, true, AVX, 5>(nodes, ray, t_max, &mut stack)
        }
    }

    /// Any-hit traversal: no ordering, exit on the first hit.
    #[inline(always)]
    fn occluded_impl<N: WideNode, const MIXED: bool, const AVX: bool, const SITE: u8>(
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
            let Visit { inner, leaves } = node.visit::<AVX, SITE>(&r, t_max, &mut tmins);
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
                self.test_block::<MIXED, AVX>(b, lanes, &r, t_max, &mut tuv) != 0
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

/// The leaf packets and, in scenes with spheres, each packet's sphere lanes (a bit mask).
type Packets = (Vec<TriBlock>, Vec<u8>);

/// One packet per leaf of a collapsed BVH ([`collapse`]), its lanes the pieces that `pieces`
/// gives for the leaf (a primitive split into several pieces of one leaf takes one lane). The
/// packets are independent, so they are filled in parallel, each the same on any thread.
fn pack_collapsed<'a>(
    n_leaves: usize,
    pieces: impl Fn(usize) -> &'a [u32] + Sync,
    n_tris: u32,
    mixed: bool,
    prim: impl Fn(u32) -> (u32, Prim) + Sync,
) -> Packets {
    let pack = |b: usize| {
        let (mut blk, mut spheres) = (TriBlock::UNUSED, 0u8);
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
        (blk, spheres)
    };
    let (mut blocks, mut sphere_lanes) = (Vec::new(), Vec::new());
    (0..n_leaves)
        .into_par_iter()
        .map(pack)
        .unzip_into_vecs(&mut blocks, &mut sphere_lanes);
    (blocks, if mixed { sphere_lanes } else { Vec::new() })
}

/// [`Accel::flat_block`] without AVX2: the same operations in the same order, lane by lane, so
/// the results are bit-identical.
#[inline(always)]
fn block_portable(blk: &TriBlock, r: &TRay, t_max: f32, out: &mut [[f32; 8]; 3]) -> u32 {
    let (o, d) = (r.o.to_array(), r.d.to_array());
    let mut hits = 0;
    for l in 0..8 {
        let (cx, cy, cz) = (blk.a[0][l] - o[0], blk.a[1][l] - o[1], blk.a[2][l] - o[2]);
        let rx = d[1] * cz - cy * d[2];
        let ry = d[2] * cx - cz * d[0];
        let rz = d[0] * cy - cx * d[1];
        let dot = |ax: f32, ay: f32, az: f32, b: &[[f32; 8]; 3]| {
            ax * b[0][l] + ay * b[1][l] + az * b[2][l]
        };
        let (b, c) = (&blk.b, &blk.c);
        let n = [
            b[1][l] * c[2][l] - c[1][l] * b[2][l],
            b[2][l] * c[0][l] - c[2][l] * b[0][l],
            b[0][l] * c[1][l] - c[0][l] * b[1][l],
        ];
        let inv_det = 1.0 / (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]);
        let u = dot(rx, ry, rz, &blk.c) * inv_det;
        let v = dot(rx, ry, rz, &blk.b) * inv_det;
        let w = 1.0 - u - v;
        let t = (cx * n[0] + cy * n[1] + cz * n[2]) * inv_det;
        let neg = (u.to_bits() | v.to_bits() | w.to_bits()) & 0x8000_0000 != 0;
        if !neg && t > 0.0 && t < t_max {
            hits |= 1 << l;
            out[0][l] = t;
            out[1][l] = u;
            out[2][l] = v;
        }
    }
    hits
}

/// Traversal counters for profiling (`--features bvh-stats`; off in normal builds): closest-hit
/// node visits, packet tests, lanes tested.
#[cfg(feature = "bvh-stats")]
pub mod stats {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    static C: [AtomicU64; 3] = [const { AtomicU64::new(0) }; 3];

    pub(super) fn count(what: usize, lanes: u64) {
        C[what].fetch_add(1, Relaxed);
        if what == 1 {
            C[2].fetch_add(lanes, Relaxed);
        }
    }

    /// (node visits, packet tests, lanes tested) since the start.
    pub fn totals() -> [u64; 3] {
        [C[0].load(Relaxed), C[1].load(Relaxed), C[2].load(Relaxed)]
    }
}
/// Ask for the `lines` cache lines from `p` on (a hint: no effect on results, none off x86-64).
#[inline(always)]
fn prefetch<T>(p: *const T, lines: usize) {
    #[cfg(target_arch = "x86_64")]
    for k in 0..lines {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch never faults, whatever the address.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((p as *const i8).wrapping_add(64 * k)) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, lines);
}

/// Whether the AVX2 traversal can be used on this CPU.
/// Smallest group of primitive boxes with one centre that [`spread_coincident`] separates.
const COINCIDENT_MIN: usize = 8;

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

fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
            && std::is_x86_feature_detected!("fma")
            && std::is_x86_feature_detected!("popcnt")
            && std::is_x86_feature_detected!("bmi1")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Brute-force reference intersection (same primitive intersectors, no BVH); for tests.
#[doc(hidden)]
pub fn brute_force_intersect(
    triangles: &[Triangle],
    spheres: &[Sphere],
    ray: &Ray,
    t_max: f32,
) -> Option<Hit> {
    let r = TRay::new(ray);
    let mut best: Option<Hit> = None;
    let mut t_best = t_max;
    for (i, tri) in triangles.iter().enumerate() {
        let (t, u, v) = Prim::triangle(tri).intersect_triangle(&r);
        if t > 0.0 && t < t_best {
            t_best = t;
            best = Some(Hit {
                t,
                prim: i as u32,
                u,
                v,
            });
        }
    }
    for (i, s) in spheres.iter().enumerate() {
        let t = Prim::sphere(s).intersect_sphere(&r, t_best);
        if t > 0.0 && t < t_best {
            t_best = t;
            best = Some(Hit {
                t,
                prim: (triangles.len() + i) as u32,
                u: 0.0,
                v: 0.0,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn rand_vec(rng: &mut Pcg64, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
        )
    }

    fn rand_dir(rng: &mut Pcg64) -> Vec3 {
        loop {
            let v = rand_vec(rng, -1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }

    fn scene(rng: &mut Pcg64, n_tris: usize, n_spheres: usize) -> (Vec<Triangle>, Vec<Sphere>) {
        let tris = (0..n_tris)
            .map(|_| {
                let c = rand_vec(rng, -10.0, 10.0);
                let s = rng.random_range(0.05..2.0);
                Triangle::new(
                    c + rand_vec(rng, -s, s),
                    c + rand_vec(rng, -s, s),
                    c + rand_vec(rng, -s, s),
                )
            })
            .collect();
        let spheres = (0..n_spheres)
            .map(|_| Sphere {
                center: rand_vec(rng, -10.0, 10.0),
                radius: rng.random_range(0.05..2.5),
            })
            .collect();
        (tris, spheres)
    }

    fn check(tris: &[Triangle], spheres: &[Sphere], n_rays: usize, seed: u64) {
        check_quality(BuildQuality::Auto, tris, spheres, n_rays, seed);
    }

    /// Built at quality `q`, in both layouts and both traversals: brute force's hits.
    fn check_quality(
        q: BuildQuality,
        tris: &[Triangle],
        spheres: &[Sphere],
        n_rays: usize,
        seed: u64,
    ) {
        let mut rng = Pcg64::seed_from_u64(seed);
        let accel = Accel::build_quality(tris, spheres, q);
        assert_eq!(accel.num_primitives(), tris.len() + spheres.len());
        // Both node layouts, and the portable traversal, must agree with the AVX2 one where
        // both exist.
        let layout = |full: bool, avx2: bool| {
            // the default build's parameters, so that ties among coincident primitives break
            // alike
            let params = q.params(tris.len() + spheres.len());
            let mut a = Accel::build_with_layout(tris, spheres, params, true, Some(full));
            a.avx2 &= avx2;
            a
        };
        let others = [
            layout(false, true),
            layout(true, false),
            layout(false, false),
        ];
        let mut hits = 0;
        for k in 0..n_rays {
            // Mix of rays from outside, rays from inside spheres, and short rays.
            let o = if !spheres.is_empty() && k % 4 == 0 {
                let s = spheres[rng.random_range(0..spheres.len())];
                s.center + rand_dir(&mut rng) * s.radius * rng.random_range(0.0..0.99)
            } else {
                rand_vec(&mut rng, -14.0, 14.0)
            };
            let d = if k % 3 == 0 {
                // aim at something
                let target = if !tris.is_empty() && (spheres.is_empty() || k % 2 == 0) {
                    tris[rng.random_range(0..tris.len())].sample_uniform(rng.random(), rng.random())
                } else if !spheres.is_empty() {
                    spheres[rng.random_range(0..spheres.len())].center
                } else {
                    Vec3::ZERO
                };
                (target - o).try_normalize().unwrap_or(Vec3::X)
            } else {
                rand_dir(&mut rng)
            };
            let ray = Ray::new(o, d);
            let t_max = if k % 5 == 0 {
                rng.random_range(0.1..20.0)
            } else {
                f32::INFINITY
            };
            let bf = brute_force_intersect(tris, spheres, &ray, t_max);
            // the closest hit, or one at the same distance (a tie between coincident primitives;
            // the two layouts may meet them in another order)
            let verify = |got: Option<Hit>, what: &str| match (bf, got) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    assert_eq!(a.t, b.t, "ray {k} ({what}): t mismatch {a:?} vs {b:?}");
                    if a.prim != b.prim {
                        // tie: the reported primitive must have the same distance
                        let only = |p: u32| {
                            let p = p as usize;
                            if p < tris.len() {
                                brute_force_intersect(&tris[p..p + 1], &[], &ray, t_max)
                            } else {
                                let s = p - tris.len();
                                brute_force_intersect(&[], &spheres[s..s + 1], &ray, t_max)
                            }
                        };
                        assert_eq!(only(b.prim).map(|h| h.t), Some(a.t), "ray {k} ({what})");
                    }
                    assert_eq!((a.u, a.v), (b.u, b.v), "ray {k} ({what})");
                    if (b.prim as usize) < tris.len() {
                        let p = tris[b.prim as usize].point(b.u, b.v);
                        let q = ray.at(b.t);
                        assert!((p - q).length() < 1e-3 * (1.0 + q.length()), "{p} vs {q}");
                    } else {
                        let s = spheres[b.prim as usize - tris.len()];
                        let dist = (ray.at(b.t) - s.center).length();
                        assert!((dist - s.radius).abs() < 1e-3 * (1.0 + s.radius));
                    }
                }
                (a, b) => panic!("ray {k} ({what}): brute force {a:?}, bvh {b:?}"),
            };
            let got = accel.intersect(&ray, t_max);
            hits += got.is_some() as usize;
            verify(got, "default");
            let quantised = others[0].intersect(&ray, t_max);
            verify(quantised, "quantised nodes");
            // the portable traversal takes the AVX2 one's path exactly
            let key = |h: Option<Hit>| h.map(|h| (h.t, h.prim, h.u, h.v));
            assert_eq!(key(others[1].intersect(&ray, t_max)), key(got), "ray {k}");
            assert_eq!(
                key(others[2].intersect(&ray, t_max)),
                key(quantised),
                "ray {k}"
            );
            for (j, a) in std::iter::once(&accel).chain(&others).enumerate() {
                assert_eq!(
                    a.occluded(&ray, t_max),
                    bf.is_some(),
                    "ray {k} ({j}): occlusion"
                );
            }
        }
        if n_rays > 100 && tris.len() + spheres.len() > 10 {
            assert!(hits > n_rays / 10, "too few hits to be meaningful: {hits}");
        }
    }

    /// Thousands of copies of one triangle and of one sphere, and of concentric spheres, among a
    /// random soup: the build spreads them (`spread_coincident`), the tree stays shallow and traces them exactly.
    #[test]
    fn coincident_copies_build_a_shallow_exact_tree() {
        let mut rng = Pcg64::seed_from_u64(9);
        let (mut tris, mut spheres) = scene(&mut rng, 500, 50);
        tris.extend(std::iter::repeat_n(tris[0], 3000));
        spheres.extend(std::iter::repeat_n(spheres[0], 3000));
        // Concentric spheres: nested boxes with one centre.
        let c = spheres[1];
        spheres.extend((1..=2000).map(|k| Sphere {
            center: c.center,
            radius: c.radius * (1.0 + 1e-4 * k as f32),
        }));
        // the traversal stack is sized from the depth: 7 entries per level, plus one
        let depth = (Accel::build(&tris, &spheres).stack_size - 1) / 7;
        assert!(depth < 40, "depth {depth}");
        check(&tris, &spheres, 2000, 9);
    }

    /// The surface-area model's cost of obvhs' greedy collapse (before [`Plan`]): a node takes
    /// the two children of a binary node and opens the child with the largest area until it
    /// has 8, a subtree of at most 8 primitives is a leaf. As `Collapsed::sah`, summed.
    fn greedy_sah(bvh2: &obvhs::bvh2::Bvh2) -> f64 {
        let b = &bvh2.nodes;
        let count = |n: usize| {
            let (mut c, mut stack) = (0, vec![n]);
            while let Some(n) = stack.pop() {
                let f = b[n].first_index as usize;
                match b[n].prim_count {
                    0 => stack.extend([f, f + 1]),
                    k => c += k as usize,
                }
            }
            c
        };
        let area = |n: usize| b[n].aabb().half_area() as f64 / b[0].aabb().half_area() as f64;
        let children = |n: usize| [b[n].first_index as usize, b[n].first_index as usize + 1];
        let (mut sah, mut todo) = (1.0, vec![0usize]);
        while let Some(n) = todo.pop() {
            let mut kids = if count(n) <= 8 {
                vec![n]
            } else {
                children(n).to_vec()
            };
            while kids.len() < 8 {
                let open = (0..kids.len())
                    .filter(|&k| count(kids[k]) > 8)
                    .max_by(|&x, &y| area(kids[x]).total_cmp(&area(kids[y])));
                let Some(k) = open else { break };
                let [l, r] = children(kids[k]);
                kids[k] = l;
                kids.push(r);
            }
            for k in kids {
                sah += area(k);
                if count(k) > 8 {
                    todo.push(k);
                }
            }
        }
        sah
    }

    /// The collapse is the surface-area-optimal one: the tree it builds costs what its plan
    /// says, never more than the greedy collapse's over the same binary tree, and holds every
    /// primitive in exactly one leaf of 1 to 8.
    #[test]
    fn collapse_is_surface_area_optimal() {
        for (seed, n) in [(3u64, 3000usize), (4, 300), (5, 9), (6, 8), (7, 1)] {
            let mut rng = Pcg64::seed_from_u64(seed);
            let (tris, _) = scene(&mut rng, n, 0);
            let aabbs: Vec<Aabb> = tris
                .iter()
                .map(|t| Aabb::from_points(&[t.v[0].into(), t.v[1].into(), t.v[2].into()]))
                .collect();
            let p = BvhBuildParams::medium_build();
            let bvh2 = PlocBuilder::with_capacity(n).build(
                p.ploc_search_distance,
                &aabbs,
                (0..n as u32).collect(),
                p.sort_precision,
                p.search_depth_threshold,
            );
            let plan = Plan::new(&bvh2);
            let c = collapse::<Node8>(&plan, usize::MAX).expect("no node limit");
            let mut seen = vec![0u32; n];
            for &leaf in &c.leaves {
                let pieces = plan.pieces(leaf);
                assert!((1..=8).contains(&pieces.len()), "leaf of {}", pieces.len());
                for &p in pieces {
                    seen[p as usize] += 1;
                }
            }
            assert!(seen.iter().all(|&k| k == 1), "n = {n}: {seen:?}");
            let sah = c.sah[0] + c.sah[1];
            // the root's wide node is there even when the whole tree is one leaf
            let planned = plan.cost as f64 / bvh2.nodes[0].aabb().half_area() as f64
                + plan.is_leaf(0) as u32 as f64;
            assert!(
                (sah - planned).abs() <= 1e-5 * sah,
                "n = {n}: {sah} against {planned}"
            );
            let greedy = greedy_sah(&bvh2);
            assert!(
                sah <= greedy * (1.0 + 1e-5),
                "n = {n}: {sah} against greedy {greedy}"
            );
            if n == 3000 {
                assert!(sah < 0.99 * greedy, "{sah} against greedy {greedy}");
            }
        }
    }

    /// Boxes so large that their areas overflow f32 (beyond the scene loader's `MAX_COORD`,
    /// which `Accel::build` does not check) make every cost infinite; the plan still divides
    /// each node's slots between its children and keeps every leaf within one packet.
    #[test]
    fn collapse_with_overflowing_costs_keeps_leaves_in_packets() {
        let mut rng = Pcg64::seed_from_u64(11);
        let (tris, _) = scene(&mut rng, 500, 0);
        let aabbs: Vec<Aabb> = tris
            .iter()
            .map(|t| {
                let p = t.v.map(|v| Vec3A::from(v * 1e21));
                Aabb::from_points(&p)
            })
            .collect();
        assert!(aabbs[0].half_area().is_infinite());
        let p = BvhBuildParams::medium_build();
        let bvh2 = PlocBuilder::with_capacity(500).build(
            p.ploc_search_distance,
            &aabbs,
            (0..500).collect(),
            p.sort_precision,
            p.search_depth_threshold,
        );
        let plan = Plan::new(&bvh2);
        let c = collapse::<Node8>(&plan, usize::MAX).expect("no node limit");
        let lens: Vec<usize> = c.leaves.iter().map(|&l| plan.pieces(l).len()).collect();
        assert_eq!(lens.iter().sum::<usize>(), 500);
        assert!(lens.iter().all(|l| (1..=8).contains(l)));
    }

    #[test]
    fn random_soup_with_spheres() {
        let mut rng = Pcg64::seed_from_u64(1);
        let (t, s) = scene(&mut rng, 3000, 200);
        check(&t, &s, 5000, 2);
    }

    #[test]
    fn random_triangles_only() {
        let mut rng = Pcg64::seed_from_u64(3);
        let (t, s) = scene(&mut rng, 5000, 0);
        check(&t, &s, 5000, 4);
    }

    /// `Auto` builds `High` up to `AUTO_HIGH_MAX` primitives and `Medium` above; an `Accel`
    /// records what was asked and built. The `High` tree of a soup costs less in the
    /// surface-area model than the `Medium` one (its purpose); both give brute force's hits
    /// (the other tests check `Auto` builds, here `High`).
    #[test]
    fn build_quality() {
        use BuildQuality::*;
        assert_eq!(Auto.resolve(AUTO_HIGH_MAX), High);
        assert_eq!(Auto.resolve(AUTO_HIGH_MAX + 1), Medium);
        assert_eq!(Medium.resolve(10), Medium);
        assert_eq!(High.resolve(AUTO_HIGH_MAX + 1), High);
        let mut rng = Pcg64::seed_from_u64(7);
        let (t, s) = scene(&mut rng, 4000, 0);
        let sah = |q| {
            let a = Accel::build_quality(&t, &s, q);
            assert_eq!(a.quality(), Some((q, q.resolve(t.len()))));
            assert!(a.build_seconds() > 0.0);
            a.sah()[0] + a.sah()[1]
        };
        let (high, medium) = (sah(High), sah(Medium));
        assert!(high < medium, "high {high} medium {medium}");
        assert_eq!(Accel::build(&t, &s).quality(), Some((Auto, High)));
        // the other tests check the default (here `High`) builds
        let (t, s) = scene(&mut rng, 2000, 100);
        check_quality(Medium, &t, &s, 3000, 8);
    }

    /// The build's parallel parts give the same tree on any number of threads, byte for byte
    /// (`Accel::fingerprint`), for both qualities, with spheres and with a group of coincident
    /// triangles (whose boxes are spread); and the fingerprint tells different trees apart.
    #[test]
    fn builds_are_the_same_on_any_number_of_threads() {
        let mut rng = Pcg64::seed_from_u64(31);
        let (mut t, s) = scene(&mut rng, 20_000, 300);
        t.extend(std::iter::repeat_n(t[0], 3 * COINCIDENT_MIN));
        let build = |threads: usize, q: BuildQuality| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| Accel::build_quality(&t, &s, q).fingerprint())
        };
        for q in [BuildQuality::Medium, BuildQuality::High] {
            let one = build(1, q);
            assert_eq!(build(2, q), one, "{q:?}");
            assert_eq!(build(3, q), one, "{q:?}");
        }
        assert_ne!(build(2, BuildQuality::Medium), build(2, BuildQuality::High));
    }

    #[test]
    fn tiny_triangle_scenes() {
        for (n, seed) in [(2, 21), (7, 22), (8, 23), (33, 24), (64, 25), (65, 26)] {
            let mut rng = Pcg64::seed_from_u64(seed);
            let (t, s) = scene(&mut rng, n, 0);
            check(&t, &s, 3000, seed + 100);
        }
    }

    /// Triangles shrinking geometrically towards a point build a tree too deep for the
    /// traversal's stack array, so the heap stack is used, in a scene without spheres: rays at
    /// each triangle's scale hit what brute force hits, in both node layouts. (The heap-stack
    /// traversal read the scene's empty sphere-lane table out of bounds, a crash.) Rays from
    /// far away are not compared: the slab test's rounding of p − o at |o| ≫ the box's size can
    /// miss a box that small, as in any BVH without a robust box test.
    #[test]
    fn deep_tree_without_spheres() {
        let tris: Vec<Triangle> = (0..240)
            .map(|k| {
                let s = 0.7f32.powi(k);
                let c = Vec3::new(s, 0.0, 0.0);
                Triangle::new(c, c + Vec3::Y * (0.5 * s), c + Vec3::Z * (0.5 * s))
            })
            .collect();
        let params = BvhBuildParams::medium_build();
        let accels = [
            Accel::build(&tris, &[]),
            Accel::build_with_layout(&tris, &[], params, true, Some(false)),
        ];
        for a in &accels {
            assert!(a.stack_size > STACK, "depth {}", a.stack_size / 7);
        }
        let mut hits = 0;
        for k in 0..120 {
            let s = 0.7f32.powi(k);
            for (dy, dz) in [(0.1, 0.1), (0.3, 0.1), (0.1, 0.35), (0.2, 0.2), (0.6, 0.6)] {
                let o = Vec3::new(2.0 * s, 0.05 * s, 0.05 * s);
                let ray = Ray::new(o, (Vec3::new(s, dy * s, dz * s) - o).normalize());
                let bf = brute_force_intersect(&tris, &[], &ray, f32::INFINITY);
                hits += bf.is_some() as usize;
                let key = |h: Option<Hit>| h.map(|h| (h.t, h.prim, h.u, h.v));
                for a in &accels {
                    assert_eq!(key(a.intersect(&ray, f32::INFINITY)), key(bf), "k {k}");
                    assert_eq!(a.occluded(&ray, f32::INFINITY), bf.is_some(), "k {k}");
                }
            }
        }
        assert!(hits > 300, "{hits} hits");
    }

    #[test]
    fn random_spheres_only() {
        let mut rng = Pcg64::seed_from_u64(5);
        let (t, s) = scene(&mut rng, 0, 500);
        check(&t, &s, 5000, 6);
    }

    #[test]
    fn single_primitives() {
        let mut rng = Pcg64::seed_from_u64(7);
        let (t, _) = scene(&mut rng, 1, 0);
        check(&t, &[], 2000, 8);
        let (_, s) = scene(&mut rng, 0, 1);
        check(&[], &s, 2000, 9);
        let (t, s) = scene(&mut rng, 1, 1);
        check(&t, &s, 2000, 10);
    }

    #[test]
    fn empty_scene() {
        let accel = Accel::build(&[], &[]);
        assert_eq!(accel.num_primitives(), 0);
        let ray = Ray::new(Vec3::ZERO, Vec3::Z);
        assert!(accel.intersect(&ray, f32::INFINITY).is_none());
        assert!(!accel.occluded(&ray, f32::INFINITY));
    }

    #[test]
    fn inside_sphere_hits_far_side() {
        let s = Sphere {
            center: Vec3::new(1.0, 2.0, 3.0),
            radius: 2.0,
        };
        let accel = Accel::build(&[], &[s]);
        let ray = Ray::new(s.center, Vec3::X);
        let h = accel.intersect(&ray, f32::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-5);
        assert_eq!(h.prim, 0);
        assert!(accel.intersect(&ray, 1.9).is_none());
        assert!(accel.occluded(&ray, 2.1));
        assert!(!accel.occluded(&ray, 1.9));
    }

    #[test]
    fn both_sides_and_barycentrics() {
        let tri = Triangle::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        let accel = Accel::build(&[tri], &[]);
        for dz in [-1.0f32, 1.0] {
            let ray = Ray::new(Vec3::new(0.25, 0.5, -dz), Vec3::new(0.0, 0.0, dz));
            let h = accel.intersect(&ray, f32::INFINITY).unwrap();
            assert!((h.t - 1.0).abs() < 1e-6);
            assert!(
                (h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6,
                "{h:?}"
            );
        }
        // Very close hit (t < 1e-4) must not be culled.
        let ray = Ray::new(Vec3::new(0.25, 0.25, -1e-6), Vec3::Z);
        let h = accel.intersect(&ray, f32::INFINITY).unwrap();
        assert!(h.t > 0.0 && h.t < 2e-6);
    }

    #[test]
    fn send_sync() {
        fn is<T: Send + Sync>() {}
        is::<Accel>();
    }
}
