//! Build the acceleration structure over a 1M-triangle random mesh (for peak-RSS measurement:
//! `/usr/bin/time -v target/release/examples/bvh_1m`).
use glam::Vec3;
use rand::{Rng, SeedableRng};
use stokes::geometry::{Accel, Ray, Triangle};

fn main() {
    let n = 1_000_000;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    let mut v = || Vec3::new(rng.random(), rng.random(), rng.random());
    let tris: Vec<Triangle> = (0..n)
        .map(|_| {
            let c = v();
            Triangle::new(c, c + (v() - 0.5) * 0.02, c + (v() - 0.5) * 0.02)
        })
        .collect();
    let t0 = std::time::Instant::now();
    let accel = Accel::build(&tris, &[]);
    println!(
        "built {} prims in {:.2} s",
        accel.num_primitives(),
        t0.elapsed().as_secs_f64()
    );
    let hit = accel.intersect(
        &Ray::new(Vec3::splat(-1.0), Vec3::ONE.normalize()),
        f32::INFINITY,
    );
    println!("{hit:?}");
}
