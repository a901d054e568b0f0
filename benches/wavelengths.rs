//! Jung Fig. 7.14, first row: the cost of drawing a wavelength uniformly on [280, 780] nm against
//! drawing it from a tabulated spectrum of 101 values (5-nm cells over [280, 780], the thesis's
//! benchmark; here the fluorescein absorption of scenes/green-spheres.json, tabulated per 5 nm),
//! with `Distribution1D::sample` as the integrators use it. The thesis: 16 s against 101 s for
//! 10⁹ draws (6.3×). Uniform numbers cycle through 4096 precomputed values.
//!
//!     cargo bench --bench wavelengths

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use stokes::spectrum::{DEFAULT_DOMAIN, Distribution1D, Spectrum};

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const N: usize = 4096;

fn bench_wavelengths(c: &mut Criterion) {
    let us: Vec<f32> = (0..N)
        .map(|i| ((i as u64 * 2654435761) % 16_777_216) as f32 / 16_777_216.0)
        .collect();
    let d = DEFAULT_DOMAIN;
    let absorption = Spectrum::gaussian_fwhm(490.0, 40.0, 1.0);
    let dist = Distribution1D::from_spectrum(&absorption, d, 5.0);
    let mut g = c.benchmark_group("wavelengths");
    g.throughput(Throughput::Elements(N as u64));
    g.measurement_time(Duration::from_secs(3));
    g.bench_function("uniform-280-780", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for &u in &us {
                let l = d.sample_uniform(black_box(u));
                acc += l * d.uniform_pdf(l);
            }
            acc
        })
    });
    g.bench_function("tabulated-101-cells", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for &u in &us {
                let (l, p) = dist.sample(black_box(u));
                acc += l * p;
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, bench_wavelengths);
criterion_main!(benches);
