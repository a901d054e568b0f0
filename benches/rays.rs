//! Closest-hit throughput on the stored ray sets (`benches/data/rays/`) and, when
//! `cargo run --release --example make_rayset NAME` has written them to `target/rays/`, the
//! mid-size (`soup300k`, `sphere300k`, `grid300k`, `soup600k`, `grid600k`) and 1M-triangle
//! (`soup1m`, `sphere1m`, `grid1m`) sets; 1 thread (the Embree 3 comparison of
//! scripts/embree/run.sh and docs/performance.md) and 2 threads via rayon.
//!
//! Before timing, the hits are verified against the stored reference hits (t relative 1e-4,
//! primitive ids equal or tied) and the match rates printed.
//!
//! The groups `build` and `closest_hit_quality` time the two BVH build qualities on soup100k
//! (`accel.quality` `medium` and `high`; docs/performance.md §1): the build, and 1-thread
//! closest hits on each tree. `build` also times the default build of the generated 1M sets on
//! 1 and 2 threads. `closest_hit_isa` times every instruction set this CPU has (AVX-512, AVX2,
//! portable; `Accel::set_isa`) on cbox, soup100k and the 1M sets, 1 thread.

#[path = "../tests/common/ray_sets.rs"]
mod ray_sets;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Duration;
use stokes::geometry::{Accel, BuildQuality, Isa};

// The allocator of the `stokes` binary (src/main.rs), so that these figures are its figures.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const CHUNK: usize = 1024;

/// The sum of the closest hits' t over `rays`, one thread.
fn closest_hits(accel: &Accel, rays: &[stokes::geometry::Ray]) -> f64 {
    rays.iter()
        .map(|r| {
            accel
                .intersect(r, f32::INFINITY)
                .map_or(0.0, |h| h.t as f64)
        })
        .sum()
}

fn bench_rays(c: &mut Criterion) {
    let mut sets = vec!["cbox", "soup100k"];
    let generated = concat!(env!("CARGO_MANIFEST_DIR"), "/target/rays");
    let optional = [
        "soup300k",
        "sphere300k",
        "grid300k",
        "soup600k",
        "grid600k",
        "soup1m",
        "sphere1m",
        "grid1m",
    ];
    for name in optional {
        if std::path::Path::new(&format!("{generated}/{name}_rays.bin")).exists() {
            sets.push(name);
        } else {
            println!("{name}: not generated (cargo run --release --example make_rayset {name})");
        }
    }
    for threads in [1, 2] {
        bench_threads(c, &sets, threads);
    }
    bench_quality(c);
    bench_build_1m(c, &sets);
    bench_isa(c, &sets);
}

/// Closest hits, 1 thread, with each instruction set the CPU has (the portable path on cbox and
/// soup100k only: it is several times slower).
fn bench_isa(c: &mut Criterion, sets: &[&str]) {
    let mut group = c.benchmark_group("closest_hit_isa");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    for &name in sets
        .iter()
        .filter(|n| ["cbox", "soup100k", "soup1m", "sphere1m", "grid1m"].contains(n))
    {
        let set = ray_sets::load(name);
        let mut accel = Accel::build(&set.tris, &[]);
        group.throughput(Throughput::Elements(set.rays.len() as u64));
        for isa in Isa::available() {
            if isa == Isa::Portable && name.ends_with("1m") {
                continue;
            }
            accel.set_isa(isa).unwrap();
            let accel = &accel;
            group.bench_function(format!("{name}/{isa}"), |b| {
                b.iter(|| black_box(closest_hits(accel, &set.rays)))
            });
        }
    }
    group.finish();
}

/// The default (medium) build of the generated 1M-triangle sets on 1 and 2 worker threads (the
/// build's parallel parts; the tree is the same either way).
fn bench_build_1m(c: &mut Criterion, sets: &[&str]) {
    let mut build = c.benchmark_group("build");
    build.sample_size(10);
    build.warm_up_time(Duration::from_secs(1));
    for &name in sets.iter().filter(|s| s.ends_with("1m")) {
        let set = ray_sets::load(name);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            build.bench_function(format!("{name}/medium/{threads}thread"), |b| {
                b.iter(|| pool.install(|| black_box(Accel::build(&set.tris, &[]))))
            });
        }
    }
    build.finish();
}

/// soup100k built at each quality: the build's time, and 1-thread closest hits on the tree.
fn bench_quality(c: &mut Criterion) {
    let set = ray_sets::load("soup100k");
    let qualities = [BuildQuality::Medium, BuildQuality::High];
    let mut build = c.benchmark_group("build");
    build.sample_size(10);
    for q in qualities {
        build.bench_function(format!("soup100k/{}", q.name()), |b| {
            b.iter(|| black_box(Accel::build_quality(&set.tris, &[], q)))
        });
    }
    build.finish();
    let mut group = c.benchmark_group("closest_hit_quality");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    group.throughput(Throughput::Elements(set.rays.len() as u64));
    for q in qualities {
        let accel = Accel::build_quality(&set.tris, &[], q);
        let s = ray_sets::compare(&set, &accel, 0..set.rays.len());
        println!(
            "soup100k, {} build: t match {:.4}%, prim match {:.4}% ({} ties)",
            q.name(),
            100.0 * s.t_rate(),
            100.0 * s.prim_rate(),
            s.ties
        );
        group.bench_function(format!("soup100k/{}", q.name()), |b| {
            b.iter(|| black_box(closest_hits(&accel, &set.rays)))
        });
    }
    group.finish();
}

fn bench_threads(c: &mut Criterion, sets: &[&str], threads: usize) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut group = c.benchmark_group(format!("closest_hit_{threads}thread"));
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));

    for &name in sets {
        let set = ray_sets::load(name);
        let t0 = std::time::Instant::now();
        let accel = Accel::build(&set.tris, &[]);
        let build = t0.elapsed();
        let s = ray_sets::compare(&set, &accel, 0..set.rays.len());
        println!(
            "{name}: {} tris, build {:.1} ms; {} rays: t match {:.4}% (strict rel 1e-4: {:.4}%), \
             prim match {:.4}% ({} ties)",
            set.tris.len(),
            build.as_secs_f64() * 1e3,
            s.n,
            100.0 * s.t_rate(),
            100.0 * s.t_match_strict as f64 / s.n as f64,
            100.0 * s.prim_rate(),
            s.ties,
        );

        let mut out = vec![0.0f32; set.rays.len()];
        group.throughput(Throughput::Elements(set.rays.len() as u64));
        group.bench_function(name, |b| {
            b.iter(|| {
                pool.install(|| {
                    out.par_chunks_mut(CHUNK)
                        .zip(set.rays.par_chunks(CHUNK))
                        .for_each(|(o, rays)| {
                            for (o, r) in o.iter_mut().zip(rays) {
                                *o = accel
                                    .intersect(r, f32::INFINITY)
                                    .map_or(f32::INFINITY, |h| h.t);
                            }
                        })
                });
                black_box(&out);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_rays);
criterion_main!(benches);
