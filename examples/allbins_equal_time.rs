//! Equal-time comparison of bdpt-allbins against pt-mono and bdpt-forward:
//! SNR_dB and relMSE against a high-spp reference, each integrator given the same wall time on
//! one thread.
//!
//! `cargo run --release --example allbins_equal_time -- [scene] [res] [seconds] [ref_spp]`

use glam::Vec3;
use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;
use stokes::spectrum::xyz_to_linear_srgb;

/// SNR_dB = 10·log10(Σ ref² / Σ (img − ref)²), relMSE = mean((img − ref)² / (ref² + 1e-2)).
fn metrics(img: &[Vec3], reference: &[Vec3]) -> (f64, f64) {
    let (mut s2, mut e2, mut rel) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in img.iter().zip(reference) {
        let (a, b) = (xyz_to_linear_srgb(*a), xyz_to_linear_srgb(*b));
        for c in 0..3 {
            let (x, r) = (a[c] as f64, b[c] as f64);
            s2 += r * r;
            e2 += (x - r) * (x - r);
            rel += (x - r) * (x - r) / (r * r + 1e-2);
        }
    }
    (10.0 * (s2 / e2).log10(), rel / (3 * img.len()) as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args
        .get(1)
        .map_or("scenes/fluorescent-walls.json", |s| s.as_str());
    let res: u32 = args.get(2).map_or(64, |s| s.parse().unwrap());
    let secs: f64 = args.get(3).map_or(2.0, |s| s.parse().unwrap());
    let ref_spp: u32 = args.get(4).map_or(4096, |s| s.parse().unwrap());
    let mut scene = Scene::load(Path::new(name)).unwrap();
    let c = scene.camera.clone();
    let fov = 2.0 * c.tan_half_x.atan().to_degrees();
    scene.camera = Camera::look_at(c.origin, c.origin + c.forward, c.up, fov, true, res, res);
    let opts = IntegratorOptions::default();
    // Reference: bdpt-allbins at many spp (exact in λ for box spectra on 5 nm bins; its
    // agreement with pt-mono is tested in tests/allbins.rs).
    let reference = render(
        &scene,
        IntegratorKind::BdptAllbins,
        &opts,
        &RenderSettings {
            first_sample: 0,
            spp: ref_spp,
            seed: 12345,
            ..Default::default()
        },
        None,
    )
    .unwrap()
    .film
    .xyz();
    println!("{name} {res}x{res}, {secs} s on 1 thread, reference bdpt-allbins {ref_spp} spp");
    println!("integrator     spp   seconds  samples/s   SNR_dB   relMSE");
    for kind in [
        IntegratorKind::PtMono,
        IntegratorKind::BdptForward,
        IntegratorKind::BdptAllbins,
    ] {
        let out = render(
            &scene,
            kind,
            &opts,
            &RenderSettings {
                first_sample: 0,
                spp: 1 << 20,
                seed: 1,
                threads: Some(1),
                time_limit: Some(secs),
                ..Default::default()
            },
            None,
        )
        .unwrap();
        let (snr, rel) = metrics(&out.film.xyz(), &reference);
        println!(
            "{:12} {:5} {:9.2} {:10.0} {:8.2} {:9.3e}",
            kind.name(),
            out.film.spp,
            out.seconds,
            out.stats.paths as f64 / out.seconds,
            snr,
            rel
        );
    }
}
