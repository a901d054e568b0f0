//! Path tracer throughput on scenes/cornell-box.json: 256×256, max depth 8 segments, no Russian
//! roulette, 2 threads, 4 spp per iteration. Throughput is reported in samples (camera paths) per
//! second; each pt-hero sample carries 4 wavelengths.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

const SPP: u32 = 4;

fn bench_pt(c: &mut Criterion) {
    let scene = Scene::load(Path::new("scenes/cornell-box.json")).unwrap();
    assert_eq!((scene.camera.width, scene.camera.height), (256, 256));
    let opts = IntegratorOptions {
        max_depth: 8,
        rr_depth: None,
        lanes: 4,
        ..Default::default()
    };
    let settings = RenderSettings {
        spp: SPP,
        seed: 0,
        threads: Some(2),
        ..Default::default()
    };
    let mut group = c.benchmark_group("cornell_box_256_depth8_2threads");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(5));
    group.throughput(Throughput::Elements(256 * 256 * SPP as u64));
    for kind in [IntegratorKind::PtMono, IntegratorKind::PtHero] {
        group.bench_function(kind.name(), |b| {
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
