//! Path tracer throughput, 256×256, no Russian roulette, 2 threads, 4 spp per iteration:
//! scenes/cornell-box.json at max depth 8 segments, and scenes/cornell-box-medium.json (the
//! Mitsuba 3 `volpath` comparison: homogeneous medium, max depth 16). Throughput is reported in
//! samples (camera paths) per second; each `pt-hero` sample carries 4 wavelengths (Mitsuba 3's
//! spectral variants carry 4), each `pt-hero-8-lanes` sample 8 (the default since 2026-12-06).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

// The allocator of the `stokes` binary (src/main.rs), so that these figures are its figures.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const SPP: u32 = 4;

fn bench_pt(c: &mut Criterion) {
    bench_scene(c, "cornell-box", "cornell_box_256_depth8_2threads", 8);
    bench_scene(
        c,
        "cornell-box-medium",
        "cornell_box_medium_256_depth16_2threads",
        16,
    );
}

fn bench_scene(c: &mut Criterion, file: &str, group: &str, max_depth: u32) {
    let scene = Scene::load(&Path::new("scenes").join(file).with_extension("json")).unwrap();
    assert_eq!((scene.camera.width, scene.camera.height), (256, 256));
    let opts = |lanes| IntegratorOptions {
        max_depth,
        rr_depth: None,
        lanes,
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
    group.measurement_time(Duration::from_secs(5));
    group.throughput(Throughput::Elements(256 * 256 * SPP as u64));
    let runs = [
        ("pt-mono", IntegratorKind::PtMono, opts(4)),
        ("pt-hero", IntegratorKind::PtHero, opts(4)),
        ("pt-hero-8-lanes", IntegratorKind::PtHero, opts(8)),
    ];
    for (name, kind, opts) in runs {
        group.bench_function(name, |b| {
            b.iter(|| {
                let out = render(&scene, kind, &opts, &settings, None).unwrap();
                assert_eq!(out.stats.nan_inf_rejected, 0);
                black_box(out.film.spp)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_pt);
criterion_main!(benches);
