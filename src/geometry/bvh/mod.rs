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
//! (2 MiB) they keep the child boxes in full precision ([`nodes::Node8`], 256 bytes, no decoding
//! per visit). Larger trees are tiered: their top levels, as many as fit in those 2 MiB, stay
//! in full precision (they are visited by every ray and stay cached), the deeper nodes are
//! quantised to 8 bits per plane ([`nodes::QNode8`], 80 bytes), whose smaller footprint pays
//! once the nodes no longer fit in the caches. All layouts give the same hits (up to ties
//! between coincident primitives, which they may meet in another order).
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
//!
//! Files: this one holds the [`Accel`] type, its queries ([`Accel::intersect`],
//! [`Accel::occluded`], the profiling accessors) and [`BuildQuality`]; `build.rs` builds an
//! `Accel` (the binary BVH, coincident boxes spread for it, the leaf packets); `collapse.rs`
//! collapses the binary BVH to 8-wide nodes, whose two layouts and visits are in `nodes.rs`;
//! `traverse.rs` holds the closest-hit and any-hit traversal loops; `leaf.rs` the primitive
//! records, the leaf packets and their intersection kernels (AVX2 and portable, and the
//! brute-force reference); `flat.rs` the flat loops of tiny scenes; `isa.rs` the instruction set
//! ([`Isa`]: AVX-512, AVX2 or portable, chosen once per process, `STOKES_ISA` forces a lower
//! one); `pages.rs` the arrays of nodes and packets, in memory advised for transparent huge
//! pages once they fill one (as Embree's; the 1M-triangle meshes trace 1.01–1.06× as fast);
//! `tests.rs` the tests against brute force, on every instruction set the CPU has.

use obvhs::BvhBuildParams;

use super::{Hit, Ray};

/// A traversal entry point compiled for one instruction set (`$features`). The ray comes in
/// registers, not behind a reference: loaded whole from a ray its caller has just stored piece
/// by piece, it would wait for the stores to complete (`flat.rs`). `$body` sees it as `$ray`,
/// with the accelerator as `$accel` and the distance bound `$t_max`.
macro_rules! ray_entry {
    ($(#[$attr:meta])* $name:ident, $features:literal, $ret:ty,
     |$accel:ident, $ray:ident, $t_max:ident| $body:expr) => {
        $(#[$attr])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        #[allow(clippy::too_many_arguments)]
        pub(super) fn $name(
            &self,
            ox: f32,
            oy: f32,
            oz: f32,
            dx: f32,
            dy: f32,
            dz: f32,
            $t_max: f32,
        ) -> $ret {
            let $accel = self;
            let $ray = $crate::geometry::Ray::new(
                glam::Vec3::new(ox, oy, oz),
                glam::Vec3::new(dx, dy, dz),
            );
            $body
        }
    };
}

mod build;
mod collapse;
mod flat;
mod isa;
mod leaf;
mod nodes;
mod pages;
mod traverse;
use flat::Flat;
pub use isa::{ISA_VAR, Isa, IsaError};
use leaf::TriBlock;
pub use leaf::brute_force_intersect;
use nodes::{Node8, QNode8};
use pages::PagedArray;

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

/// The node layout of a build ([`Accel::build_with_layout`], for tests and profiling; scenes
/// take `Auto`).
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Full precision up to [`nodes::FULL_NODES_MAX`] nodes, else tiered with that many full
    /// nodes at most.
    Auto,
    /// Every node in full precision.
    Full,
    /// Every node quantised.
    Quantised,
    /// The top levels in full precision, as many as fit in `top_nodes` nodes, the rest
    /// quantised.
    Tiered { top_nodes: usize },
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

/// The BVH's nodes in the layouts of [`nodes`]: full precision while they fit in the caches;
/// beyond, the top levels in full precision (the nodes every ray visits, which stay cached and
/// need no decoding) and the rest quantised, numbered top first.
enum Nodes {
    Full(PagedArray<Node8>),
    Quantised(PagedArray<QNode8>),
    Tiered {
        top: PagedArray<Node8>,
        rest: PagedArray<QNode8>,
    },
}

impl Nodes {
    fn len(&self) -> usize {
        match self {
            Nodes::Full(n) => n.len(),
            Nodes::Quantised(n) => n.len(),
            Nodes::Tiered { top, rest } => top.len() + rest.len(),
        }
    }

    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn bytes(&self) -> usize {
        match self {
            Nodes::Full(n) => std::mem::size_of_val(&n[..]),
            Nodes::Quantised(n) => std::mem::size_of_val(&n[..]),
            Nodes::Tiered { top, rest } => {
                std::mem::size_of_val(&top[..]) + std::mem::size_of_val(&rest[..])
            }
        }
    }
}

/// The scene's acceleration structure (triangles and spheres in one BVH8).
pub struct Accel {
    /// The nodes (root first), in the layout that suits the BVH's size.
    nodes: Nodes,
    /// The leaves' primitives, one 8-lane packet a leaf, each node's leaves consecutive (the
    /// node layouts address them).
    blocks: PagedArray<TriBlock>,
    /// Per packet: the lanes that hold spheres (empty when the scene has none; the traversal
    /// for scenes with spheres, which trees too deep for the stack array take in any scene,
    /// reads it with a bounds check).
    sphere_lanes: Vec<u8>,
    n_tris: u32,
    n_spheres: u32,
    /// Upper bound on the traversal stack depth (7 entries per level).
    stack_size: usize,
    /// The instruction set of the kernels ([`Isa::active`] when built).
    isa: Isa,
    /// The traversal every ray takes, from `isa` and the layout (`Kernel::of`).
    kernel: Kernel,
    /// The tree's node visits and packet tests per ray through the root box, in the
    /// surface-area model (`Collapsed::sah`).
    sah: [f64; 2],
    /// Tiny scenes (a few dozen triangles and a few spheres, AVX2 and AVX-512 only): all
    /// primitives in original order, tested with a flat loop, 8 triangles at a time (faster
    /// than any traversal at this size).
    flat: Flat,
    /// The quality asked for and the one it was built with (`Medium` or `High`); `None` for
    /// explicit obvhs parameters. Then the build's wall time in seconds.
    quality: Option<(BuildQuality, BuildQuality)>,
    build_seconds: f64,
}

/// The traversal a ray takes: the empty scene's, the flat loop of tiny scenes or the tree's, in
/// the accelerator's instruction set. Chosen once ([`Kernel::of`]), so that a ray pays one load
/// and one jump for the choice instead of three tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    Empty,
    Portable,
    Avx2Tree,
    Avx2Flat,
    Avx2FlatSpheres,
    Avx512Tree,
    Avx512Flat,
    Avx512FlatSpheres,
}

impl Kernel {
    fn of(a: &Accel) -> Kernel {
        let flat = a.flat.on;
        let spheres = a.n_spheres > 0;
        match a.isa {
            _ if a.nodes.is_empty() => Kernel::Empty,
            Isa::Avx512 if flat && spheres => Kernel::Avx512FlatSpheres,
            Isa::Avx512 if flat => Kernel::Avx512Flat,
            Isa::Avx512 => Kernel::Avx512Tree,
            Isa::Avx2 if flat && spheres => Kernel::Avx2FlatSpheres,
            Isa::Avx2 if flat => Kernel::Avx2Flat,
            Isa::Avx2 => Kernel::Avx2Tree,
            Isa::Portable => Kernel::Portable,
        }
    }
}

impl Accel {
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
        self.flat.on && self.isa >= Isa::Avx2
    }

    /// The instruction set rays are traced with.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Trace with `isa` from now on (for tests and timings; a build takes [`Isa::active`]).
    /// Refused when the CPU lacks it.
    #[doc(hidden)]
    pub fn set_isa(&mut self, isa: Isa) -> Result<(), IsaError> {
        if !isa.supported() {
            return Err(IsaError::Unsupported(isa));
        }
        self.isa = isa;
        self.kernel = Kernel::of(self);
        Ok(())
    }

    /// `self` with its `kernel` chosen.
    fn with_kernel(mut self) -> Self {
        self.kernel = Kernel::of(&self);
        self
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
            Nodes::Tiered { top, rest } => {
                top.hash(&mut h);
                rest.hash(&mut h);
            }
        }
        self.blocks.hash(&mut h);
        self.sphere_lanes.hash(&mut h);
        h.finish()
    }

    /// The node layout in words: `full precision`, `quantised`, or `tiered: N in full precision,
    /// M quantised`.
    #[doc(hidden)]
    pub fn node_layout(&self) -> String {
        match &self.nodes {
            Nodes::Full(_) => "full precision".into(),
            Nodes::Quantised(_) => "quantised".into(),
            Nodes::Tiered { top, rest } => {
                format!(
                    "tiered: {} in full precision, {} quantised",
                    top.len(),
                    rest.len()
                )
            }
        }
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
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if t_max.is_nan() || t_max <= 0.0 {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        let (o, d) = (ray.o, ray.d);
        // SAFETY (every kernel but the portable one): `Kernel::of` chooses an instruction set
        // only where the CPU supports it (`Isa::supported`).
        match self.kernel {
            Kernel::Empty => None,
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512Tree => unsafe {
                self.intersect_avx512(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512Flat => unsafe {
                self.intersect_flat_avx512(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512FlatSpheres => unsafe {
                self.intersect_flat_spheres_avx512(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2Tree => unsafe { self.intersect_avx2(o.x, o.y, o.z, d.x, d.y, d.z, t_max) },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2Flat => unsafe {
                self.intersect_flat::<false>(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2FlatSpheres => unsafe {
                self.intersect_flat::<true>(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            _ => self.intersect_portable(ray, t_max),
        }
    }

    /// Any hit with t in (0, t_max).
    #[inline(always)]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if t_max.is_nan() || t_max <= 0.0 {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        let (o, d) = (ray.o, ray.d);
        // SAFETY: see `intersect`.
        match self.kernel {
            Kernel::Empty => false,
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512Tree => unsafe {
                self.occluded_avx512(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512Flat => unsafe {
                self.occluded_flat_avx512(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512FlatSpheres => unsafe {
                self.occluded_flat_spheres_avx512(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2Tree => unsafe { self.occluded_avx2(o.x, o.y, o.z, d.x, d.y, d.z, t_max) },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2Flat => unsafe {
                self.occluded_flat::<false>(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2FlatSpheres => unsafe {
                self.occluded_flat::<true>(o.x, o.y, o.z, d.x, d.y, d.z, t_max)
            },
            _ => self.occluded_portable(ray, t_max),
        }
    }
}

/// Traversal counters for profiling (`--features bvh-stats`; off in normal builds): closest-hit
/// node visits, packet tests, lanes tested, and packet tests of leaves whose box begins beyond
/// the ray's final hit (which a perfect order of the leaves would have skipped).
#[cfg(feature = "bvh-stats")]
pub mod stats {
    use std::cell::RefCell;
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    static C: [AtomicU64; 4] = [const { AtomicU64::new(0) }; 4];
    thread_local! {
        /// The entry distances of the leaves the current ray has tested.
        static ENTRIES: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
    }

    pub(super) fn count(what: usize, lanes: u64) {
        C[what].fetch_add(1, Relaxed);
        if what == 1 {
            C[2].fetch_add(lanes, Relaxed);
        }
    }

    /// A closest-hit packet test of a leaf the ray enters at `t`.
    pub(super) fn leaf_entry(t: f32) {
        ENTRIES.with_borrow_mut(|e| e.push(t));
    }

    /// The end of a closest-hit traversal whose final hit (or `t_max`) is at `t`.
    pub(super) fn ray_end(t: f32) {
        let beyond = ENTRIES.with_borrow_mut(|e| {
            let n = e.iter().filter(|&&x| x > t).count();
            e.clear();
            n
        });
        C[3].fetch_add(beyond as u64, Relaxed);
    }

    /// (node visits, packet tests, lanes tested, packet tests beyond the final hit) since the
    /// start.
    pub fn totals() -> [u64; 4] {
        C.each_ref().map(|c| c.load(Relaxed))
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

#[cfg(test)]
mod tests;
