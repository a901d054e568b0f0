//! Bidirectional integrator throughput, 2 threads, 2 spp per iteration, no Russian roulette:
//! scenes/cornell-box.json (256×256, max depth 8; no media: the media code must not cost here)
//! and scenes/cornell-box-medium.json (256×256, max depth 8, homogeneous medium). Throughput is
//! in samples (camera sub-paths) per second; compare with pt-hero in `benches/pt.rs`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

const SPP: u32 = 2;

fn bench_bdpt(c: &mut Criterion) {
    bench_scene(c, "cornell-box", "bdpt_cornell_box_256_depth8_2threads");
    bench_scene(
        c,
        "cornell-box-medium",
        "bdpt_cornell_box_medium_256_depth8_2threads",
    );
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
