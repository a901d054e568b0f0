//! Thread scaling: every integrator on scenes/cornell-box.json (256×256, max depth 8, no Russian
//! roulette) at 1 and 2 threads; samples (camera paths) per second. The ratio of the two is the
//! scaling goal of docs/performance.md (`scripts/performance.py --only scaling` measures the
//! same from the command line, with a control of two independent 1-thread processes).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

// The allocator of the `stokes` binary (src/main.rs), so that these figures are its figures.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn bench_scaling(c: &mut Criterion) {
    let scene = Scene::load(Path::new("scenes/cornell-box.json")).unwrap();
    let opts = IntegratorOptions {
        max_depth: 8,
        rr_depth: None,
        ..Default::default()
    };
    for (kind, spp) in [
        (IntegratorKind::PtMono, 8),
        (IntegratorKind::PtHero, 4),
        (IntegratorKind::BdptForward, 1),
        (IntegratorKind::BdptBackward, 1),
        (IntegratorKind::BdptAllbins, 1),
    ] {
        let mut group = c.benchmark_group(format!("scaling_{}_cornell_box", kind.name()));
        group.sample_size(10);
        group.warm_up_time(Duration::from_secs(1));
        group.measurement_time(Duration::from_secs(5));
        group.throughput(Throughput::Elements(256 * 256 * spp as u64));
        for threads in [1, 2] {
            let settings = RenderSettings {
                spp,
                threads: Some(threads),
                ..Default::default()
            };
            group.bench_function(format!("{threads}thread"), |b| {
                b.iter(|| {
                    let out = render(&scene, kind, &opts, &settings, None).unwrap();
                    black_box(out.film.spp)
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_scaling);
criterion_main!(benches);
