//! Cost per wavelength-shift sample of a measured reradiation matrix (RIT `GOLFYE.BFC`):
//! tabulated-CDF sampling of the matrix (`reradiation`) against the truncated conditional
//! Gaussian mixture (`reradiation-gmm`, Hua 2022 §6) with 2, 4 and 8 components. One sample is
//! the whole one-shot choice of `Bbrrdf::sample`: P_l or P_c, then the new wavelength with its
//! pdf and kernel value, on light paths (λo | λi) and camera paths (λi | λo). Known wavelengths
//! cycle through 1024 values so no branch predictor learns one.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use stokes::material::mixture::{FitMethod, FitOptions, fit_matrix};
use stokes::material::reradiation::BfcMatrix;
use stokes::material::{
    Bbrrdf, Material, PathSide, Reradiation, ReradiationGmm, ShiftSampling, WavelengthSampling,
};
use stokes::spectrum::DEFAULT_DOMAIN;

// The allocator of the `stokes` binary (src/main.rs), so that these figures are its figures.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const N: usize = 1024;

fn bench_gmm(c: &mut Criterion) {
    let text = include_str!("../data/bispectral/GOLFYE.BFC");
    let m = BfcMatrix::parse(text).unwrap();
    let mut materials = vec![(
        "matrix".to_string(),
        Material::Reradiation(Reradiation::new(m.clone(), DEFAULT_DOMAIN)),
    )];
    for k in [2, 4, 8] {
        let f = fit_matrix(&m, &FitOptions::new(k, FitMethod::Em, 0)).unwrap();
        materials.push((
            format!("gmm-{k}"),
            Material::ReradiationGmm(ReradiationGmm::new(&f, DEFAULT_DOMAIN)),
        ));
    }
    let s = ShiftSampling::new(WavelengthSampling::Importance, DEFAULT_DOMAIN);
    // Known wavelengths and uniform numbers: light paths start in the UV-blue excitation band,
    // camera paths in the visible emission band.
    let u: Vec<[f32; 3]> = (0..N)
        .map(|j| {
            let h = |x: u64| {
                ((x.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 40) as f32) / (1u64 << 24) as f32
            };
            [
                h(3 * j as u64 + 1),
                h(3 * j as u64 + 2),
                h(3 * j as u64 + 3),
            ]
        })
        .collect();
    for (side, lo, hi, name) in [
        (
            PathSide::Light,
            300.0,
            480.0,
            "light_path_lambda_o_given_lambda_i",
        ),
        (
            PathSide::Camera,
            420.0,
            700.0,
            "camera_path_lambda_i_given_lambda_o",
        ),
    ] {
        let mut group = c.benchmark_group(name);
        group.sample_size(20);
        group.warm_up_time(Duration::from_millis(500));
        group.measurement_time(Duration::from_secs(2));
        group.throughput(Throughput::Elements(N as u64));
        for (mname, mat) in &materials {
            group.bench_function(mname.as_str(), |b| {
                b.iter(|| {
                    let mut acc = 0.0f32;
                    for x in &u {
                        let l = lo + (hi - lo) * x[0];
                        let w = mat.sample(l, [x[1], x[2]], side, s);
                        acc += w.weight();
                    }
                    black_box(acc)
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_gmm);
criterion_main!(benches);
