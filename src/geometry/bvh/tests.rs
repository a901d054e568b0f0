//! Tests of the BVH's builds, node layouts and traversals against brute force.

use super::build::COINCIDENT_MIN;
use super::collapse::{Plan, collapse};
use super::*;
use crate::geometry::{Sphere, Triangle};
use glam::{Vec3, Vec3A};
use obvhs::{aabb::Aabb, ploc::PlocBuilder};
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
fn check_quality(q: BuildQuality, tris: &[Triangle], spheres: &[Sphere], n_rays: usize, seed: u64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut accel = Accel::build_quality(tris, spheres, q);
    assert_eq!(accel.num_primitives(), tris.len() + spheres.len());
    // Both node layouts, on every instruction set this CPU has, must agree with the default
    // build and layout (the best instruction set: the flat loop of tiny scenes with AVX2 or
    // AVX-512).
    let layout = |layout: Layout| {
        // the default build's parameters, so that ties among coincident primitives break
        // alike
        let params = q.params(tris.len() + spheres.len());
        Accel::build_with_layout(tris, spheres, params, true, layout)
    };
    let (mut quantised, mut full) = (layout(Layout::Quantised), layout(Layout::Full));
    // the root and its children in full precision, the rest quantised
    let mut tiered = layout(Layout::Tiered { top_nodes: 9 });
    let isas = Isa::available();
    assert!(isas.contains(&Isa::Portable) && isas.contains(&accel.isa()));
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
        accel.set_isa(Isa::best()).unwrap();
        let got = accel.intersect(&ray, t_max);
        hits += got.is_some() as usize;
        verify(got, "default");
        quantised.set_isa(Isa::best()).unwrap();
        let q_best = quantised.intersect(&ray, t_max);
        verify(q_best, "quantised nodes");
        tiered.set_isa(Isa::best()).unwrap();
        let t_best = tiered.intersect(&ray, t_max);
        verify(t_best, "tiered nodes");
        // every other instruction set takes the best one's path exactly
        let key = |h: Option<Hit>| h.map(|h| (h.t, h.prim, h.u, h.v));
        for &isa in &isas {
            for a in [&mut accel, &mut quantised, &mut full, &mut tiered] {
                a.set_isa(isa).unwrap();
            }
            assert_eq!(
                key(accel.intersect(&ray, t_max)),
                key(got),
                "ray {k} ({isa})"
            );
            assert_eq!(
                key(full.intersect(&ray, t_max)),
                key(got),
                "ray {k} ({isa}, full)"
            );
            let q = quantised.intersect(&ray, t_max);
            assert_eq!(key(q), key(q_best), "ray {k} ({isa}, quantised)");
            let t = tiered.intersect(&ray, t_max);
            assert_eq!(key(t), key(t_best), "ray {k} ({isa}, tiered)");
            for (j, a) in [&accel, &quantised, &full, &tiered].into_iter().enumerate() {
                assert_eq!(
                    a.occluded(&ray, t_max),
                    bf.is_some(),
                    "ray {k} ({isa}, {j}): occlusion"
                );
            }
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
        let c = collapse::<Node8, Node8>(&plan, usize::MAX, usize::MAX).expect("no node limit");
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
    let c = collapse::<Node8, Node8>(&plan, usize::MAX, usize::MAX).expect("no node limit");
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

/// Tiny scenes with a few spheres take the flat loop too (up to `FLAT_SPHERES_MAX` spheres
/// and `FLAT_MAX_WITH_SPHERES` triangles, on AVX2 and AVX-512), spheres alone as well; with more
/// they take the tree. Either way: brute
/// force's hits, on every instruction set (the portable one traverses the tree).
#[test]
fn tiny_scenes_with_spheres() {
    for (n, m, flat, seed) in [
        (12, 2, true, 41),
        (0, 1, true, 42),
        (5, 4, true, 43),
        (32, 4, true, 44),
        (1, 3, true, 45),
        (12, 5, false, 46),
        (33, 1, false, 47),
        (64, 0, true, 48),
    ] {
        let mut rng = Pcg64::seed_from_u64(seed);
        let (t, s) = scene(&mut rng, n, m);
        let mut accel = Accel::build(&t, &s);
        if Isa::Avx2.supported() {
            accel.set_isa(Isa::Avx2).unwrap();
            assert_eq!(accel.is_flat(), flat, "{n} triangles, {m} spheres");
        }
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
        Accel::build_with_layout(&tris, &[], params, true, Layout::Quantised),
        Accel::build_with_layout(&tris, &[], params, true, Layout::Tiered { top_nodes: 20 }),
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

#[test]
fn instruction_set_names_and_errors() {
    for isa in Isa::ALL {
        assert_eq!(Isa::parse(isa.name()), Some(isa));
    }
    assert_eq!(Isa::parse("AVX2"), None);
    assert!(Isa::Portable.supported());
    assert_eq!(Isa::available()[0], Isa::best());
    // best first, and each set implies the ones below it
    let a = Isa::available();
    assert!(a.windows(2).all(|w| w[0] > w[1]));
    assert_eq!(a.len(), 1 + Isa::best() as usize);
    let e = IsaError::Unknown("avx9".into()).to_string();
    assert!(
        e.contains("STOKES_ISA=avx9") && e.contains("avx512, avx2, portable"),
        "{e}"
    );
    let e = IsaError::Unsupported(Isa::Avx512).to_string();
    assert!(
        e.contains("does not support avx512") && e.contains("portable"),
        "{e}"
    );
}

/// A tiered tree keeps its top levels (here the root and its children) in full precision and
/// the rest quantised, numbered top first, and traces as brute force does (`check` traces
/// every layout).
#[test]
fn tiered_layout_splits_at_a_level() {
    let mut rng = Pcg64::seed_from_u64(21);
    let (tris, _) = scene(&mut rng, 3000, 0);
    let params = BuildQuality::Medium.params(tris.len());
    let a = Accel::build_with_layout(&tris, &[], params, true, Layout::Tiered { top_nodes: 9 });
    let Nodes::Tiered { top, rest } = &a.nodes else {
        panic!("not tiered");
    };
    // the root and its internal children (at most 8), every other node quantised
    assert!((2..=9).contains(&top.len()), "{} top nodes", top.len());
    assert!(rest.len() > top.len(), "{} quantised nodes", rest.len());
    let all = Accel::build_with_layout(&tris, &[], params, true, Layout::Quantised);
    assert_eq!(top.len() + rest.len(), all.nodes.len());
    assert_eq!(a.blocks.len(), all.blocks.len());
    // the tiers by depth: a budget below the root's level quantises everything, one that
    // holds the whole tree keeps it in full precision
    let none = Accel::build_with_layout(&tris, &[], params, true, Layout::Tiered { top_nodes: 0 });
    assert!(matches!(none.nodes, Nodes::Quantised(_)));
    let every = Layout::Tiered {
        top_nodes: usize::MAX,
    };
    let every = Accel::build_with_layout(&tris, &[], params, true, every);
    assert!(matches!(every.nodes, Nodes::Full(_)));
    check_quality(BuildQuality::Medium, &tris, &[], 3000, 22);
}

/// The flat loop of tiny scenes reports a tie (coincident copies of one triangle) as a linear
/// scan does, at the lowest index, whether the copies share a lane of different packets or sit
/// in different lanes (index 6 in lane 6 of the first packet wins over index 9 in lane 1 of the
/// second), with brute force's t, u and v; and the same triangle further along the ray (index 0)
/// never wins.
#[test]
fn flat_loop_ties_go_to_the_lowest_index() {
    let mut rng = Pcg64::seed_from_u64(31);
    let (tris, _) = scene(&mut rng, 40, 0);
    let target = Triangle::new(
        Vec3::new(-1.0, -1.0, 20.0),
        Vec3::new(1.0, -1.0, 20.0),
        Vec3::new(0.0, 1.5, 20.0),
    );
    let behind = Triangle::new(
        Vec3::new(-1.0, -1.0, 19.0),
        Vec3::new(1.0, -1.0, 19.0),
        Vec3::new(0.0, 1.5, 19.0),
    );
    for (copies, lowest) in [(&[9, 6, 33][..], 6), (&[3, 11, 19, 35], 3), (&[30, 38], 30)] {
        let mut t = tris.clone();
        for &i in copies {
            t[i] = target;
        }
        t[0] = behind;
        let mut accel = Accel::build(&t, &[]);
        for isa in Isa::available() {
            accel.set_isa(isa).unwrap();
            if !accel.is_flat() {
                continue;
            }
            for k in 0..200 {
                let s = 0.5 * (k as f32 / 200.0) - 0.25;
                let ray = Ray::new(
                    Vec3::new(s, 0.1 - s * 0.5, 40.0),
                    Vec3::new(0.01 * s, 0.02, -1.0).normalize(),
                );
                let bf = brute_force_intersect(&t, &[], &ray, f32::INFINITY).unwrap();
                assert_eq!(bf.prim, lowest, "ray {k}: brute force");
                let got = accel.intersect(&ray, f32::INFINITY).unwrap();
                let key = |h: Hit| (h.t, h.prim, h.u, h.v);
                assert_eq!(key(got), key(bf), "ray {k} ({isa}, copies {copies:?})");
            }
        }
    }
}
