//! Write a large generated ray set in the format of `benches/data/rays/` (see
//! tests/common/ray_sets.rs) into `target/rays/`, for examples/raybench and scripts/embree:
//! `target/release/examples/make_rayset NAME` with NAME one of
//! - `soup1m`: 1M random triangles in the unit cube (soup100k's distribution, edges scaled by
//!   10^(-1/3)), rays from random points in the cube in random directions;
//! - `sphere1m`: an icosphere subdivided 8 times (1,310,720 triangles) with a smooth radial
//!   displacement, rays from a shell around it towards random points near its centre;
//! - `grid1m`: a 708 × 708 height field (1,002,528 triangles), rays from above it downwards;
//! - mid-size sets of the same kinds, between soup100k and the 1M sets, on which the node
//!   layout changes (`FULL_NODES_MAX` in src/geometry/bvh/nodes.rs): `soup300k` and `soup600k`
//!   (300,000 and 600,000 triangles), `sphere300k` (subdivided 7 times, 327,680),
//!   `grid300k` and `grid600k` (387 × 387 and 548 × 548: 299,538 and 600,608).
//!
//! The reference hits are this build's closest hits (`Accel::intersect`); scripts/embree/run.sh
//! checks them against Embree's.
use glam::Vec3;
use rand::{Rng, SeedableRng};
use stokes::geometry::{Accel, Ray, Triangle};

const RAYS: usize = 250_000;

fn unit(rng: &mut impl Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v / l.sqrt();
        }
    }
}

fn soup(rng: &mut impl Rng, n: usize) -> (Vec<Triangle>, Vec<Ray>) {
    // soup100k's edges at 100 000 triangles, scaled with the mean spacing
    let s = 0.1 * (1e5 / n as f32).powf(1.0 / 3.0);
    let mut p = || Vec3::new(rng.random(), rng.random(), rng.random());
    let tris = (0..n)
        .map(|_| {
            let c = p();
            Triangle::new(c, c + (p() - 0.5) * s, c + (p() - 0.5) * s)
        })
        .collect();
    let rays = (0..RAYS)
        .map(|_| {
            let o = Vec3::new(rng.random(), rng.random(), rng.random());
            Ray::new(o, unit(rng))
        })
        .collect();
    (tris, rays)
}

fn sphere(rng: &mut impl Rng, levels: usize) -> (Vec<Triangle>, Vec<Ray>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut m = |a: usize, b: usize, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (m(a, b, &mut v), m(b, c, &mut v), m(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let d = |p: Vec3| p * (1.0 + 0.05 * (7.0 * p.x).sin() * (5.0 * p.y).cos() * (6.0 * p.z).sin());
    let tris = f
        .iter()
        .map(|&[a, b, c]| Triangle::new(d(v[a]), d(v[b]), d(v[c])))
        .collect();
    let rays = (0..RAYS)
        .map(|_| {
            let o = unit(rng) * rng.random_range(1.2f32..3.0);
            let target = unit(rng) * rng.random_range(0.0f32..0.9);
            Ray::new(o, (target - o).normalize())
        })
        .collect();
    (tris, rays)
}

fn grid(rng: &mut impl Rng, n: usize) -> (Vec<Triangle>, Vec<Ray>) {
    let h = |i: usize, j: usize| {
        let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
        let z = 0.1 * (11.0 * x).sin() * (9.0 * y).cos() + 0.02 * (53.0 * x + 37.0 * y).sin();
        Vec3::new(x, y, z)
    };
    let mut tris = Vec::with_capacity(2 * n * n);
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (h(i, j), h(i + 1, j), h(i + 1, j + 1), h(i, j + 1));
            tris.push(Triangle::new(a, b, c));
            tris.push(Triangle::new(a, c, d));
        }
    }
    let rays = (0..RAYS)
        .map(|_| {
            let o = Vec3::new(rng.random(), rng.random(), 0.5);
            let target = Vec3::new(rng.random(), rng.random(), 0.0);
            Ray::new(o, (target - o).normalize())
        })
        .collect();
    (tris, rays)
}

fn write(path: &std::path::Path, words: impl Iterator<Item = [u8; 4]>) {
    let bytes: Vec<u8> = words.flatten().collect();
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

fn main() {
    let name = std::env::args().nth(1).unwrap_or_default();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(16);
    let (tris, rays) = match name.as_str() {
        "soup1m" => soup(&mut rng, 1_000_000),
        "sphere1m" => sphere(&mut rng, 8),
        "grid1m" => grid(&mut rng, 708),
        "soup300k" => soup(&mut rng, 300_000),
        "sphere300k" => sphere(&mut rng, 7),
        "grid300k" => grid(&mut rng, 387),
        "soup600k" => soup(&mut rng, 600_000),
        "grid600k" => grid(&mut rng, 548),
        _ => {
            eprintln!(
                "usage: make_rayset soup1m|sphere1m|grid1m|soup300k|soup600k|sphere300k|grid300k|grid600k"
            );
            std::process::exit(2);
        }
    };
    let t0 = std::time::Instant::now();
    let accel = Accel::build(&tris, &[]);
    let build = t0.elapsed().as_secs_f64();
    let hits: Vec<Option<stokes::geometry::Hit>> = rays
        .iter()
        .map(|r| accel.intersect(r, f32::INFINITY))
        .collect();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/rays");
    std::fs::create_dir_all(&dir).unwrap();
    let f = |x: f32| x.to_le_bytes();
    write(
        &dir.join(format!("{name}_tris.bin")),
        tris.iter()
            .flat_map(|t| t.v.iter().flat_map(|p| p.to_array().map(f))),
    );
    write(
        &dir.join(format!("{name}_rays.bin")),
        rays.iter()
            .flat_map(|r| r.o.to_array().into_iter().chain(r.d.to_array()).map(f)),
    );
    write(
        &dir.join(format!("{name}_hits_t.bin")),
        hits.iter().map(|h| f(h.map_or(f32::INFINITY, |h| h.t))),
    );
    write(
        &dir.join(format!("{name}_hits_prim.bin")),
        hits.iter()
            .map(|h| h.map_or(-1, |h| h.prim as i32).to_le_bytes()),
    );
    let n_hit = hits.iter().filter(|h| h.is_some()).count();
    println!(
        "{name}: {} triangles, {} rays ({:.0} % hit), build {build:.2} s, written to {}",
        tris.len(),
        rays.len(),
        100.0 * n_hit as f64 / rays.len() as f64,
        dir.display()
    );
}
