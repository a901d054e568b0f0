//! Bidirectional integrator throughput, 2 threads, 2 spp per iteration, no Russian roulette:
//! scenes/cornell-box.json (256×256, max depth 8; no media: the media code must not cost here)
//! and scenes/cornell-box-medium.json (256×256, max depth 8, homogeneous medium). Throughput is
//! in samples (camera sub-paths) per second; compare with pt-hero in `benches/pt.rs`.
//!
//! Depth sweep: bdpt-forward/backward on scenes/furnace-fluorescent.json (closed, so every
//! sub-path reaches the maximum depth) with the film cut to 4×4, 1 thread, 1 spp per iteration,
//! max depth 8, 32 and 128 (docs/bdpt.md has the table).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

// The allocator of the `stokes` binary (src/main.rs), so that these figures are its figures.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const SPP: u32 = 2;

fn bench_bdpt(c: &mut Criterion) {
    bench_scene(c, "cornell-box", "bdpt_cornell_box_256_depth8_2threads");
    bench_scene(
        c,
        "cornell-box-medium",
        "bdpt_cornell_box_medium_256_depth8_2threads",
    );
    bench_depths(c);
}

fn bench_depths(c: &mut Criterion) {
    let mut scene = Scene::load(Path::new("scenes/furnace-fluorescent.json")).unwrap();
    (scene.camera.width, scene.camera.height) = (4, 4);
    let settings = RenderSettings {
        first_sample: 0,
        spp: 1,
        seed: 0,
        threads: Some(1),
        ..Default::default()
    };
    let mut group = c.benchmark_group("bdpt_furnace_fluorescent_4x4_1thread");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(4));
    group.throughput(Throughput::Elements(16));
    for depth in [8, 32, 128] {
        let opts = IntegratorOptions {
            max_depth: depth,
            rr_depth: None,
            ..Default::default()
        };
        for kind in [IntegratorKind::BdptForward, IntegratorKind::BdptBackward] {
            let id = format!("{}_depth{depth}", kind.name());
            group.bench_function(id, |b| {
                b.iter(|| {
                    let out = render(&scene, kind, &opts, &settings, None).unwrap();
                    black_box(out.film.spp)
                })
            });
        }
    }
    group.finish();
}

fn bench_scene(c: &mut Criterion, file: &str, group: &str) {
    let scene = Scene::load(&Path::new("scenes").join(file).with_extension("json")).unwrap();
    assert_eq!((scene.camera.width, scene.camera.height), (256, 256));
    let opts = IntegratorOptions {
        max_depth: 8,
        rr_depth: None,
        ..Default::default()
    };
    let settings = RenderSettings {
        first_sample: 0,
        spp: SPP,
        seed: 0,
        threads: Some(2),
        ..Default::default()
    };
    let mut group = c.benchmark_group(group);
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(8));
    group.throughput(Throughput::Elements(256 * 256 * SPP as u64));
    for kind in [
        IntegratorKind::PtHero,
        IntegratorKind::BdptForward,
        IntegratorKind::BdptBackward,
        IntegratorKind::BdptAllbins,
    ] {
        group.bench_function(kind.name(), |b| {
            b.iter(|| {
                let out = render(&scene, kind, &opts, &settings, None).unwrap();
                black_box(out.film.spp)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_bdpt);
criterion_main!(benches);
