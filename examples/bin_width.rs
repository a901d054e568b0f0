//! Bin-width study (Jung 8.2): image error of bdpt-allbins at 10, 20 and 50 nm bins against 5 nm
//! bins on green-spheres, with the same seed so the geometric sub-paths are identical and the
//! difference is the bin discretisation alone; plus each width against a high-spp pt-mono
//! (wavelength-sampled) reference.
//!
//! `cargo run --release --example bin_width -- [scene] [res] [spp] [ref_spp]`

use glam::Vec3;
use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;
use stokes::spectrum::xyz_to_linear_srgb;

/// SNR_dB = 10·log10(Σ ref² / Σ (img − ref)²) and relMSE = mean((img − ref)² / (ref² + 1e-2))
/// over pixels and linear-RGB channels (docs/design.md §6).
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
    let scene_name = args
        .get(1)
        .map_or("scenes/green-spheres.json", |s| s.as_str());
    let res: u32 = args.get(2).map_or(64, |s| s.parse().unwrap());
    let spp: u32 = args.get(3).map_or(64, |s| s.parse().unwrap());
    let ref_spp: u32 = args.get(4).map_or(1024, |s| s.parse().unwrap());
    let mut scene = Scene::load(Path::new(scene_name)).unwrap();
    let c = scene.camera.clone();
    let fov = 2.0 * c.tan_half_x.atan().to_degrees();
    scene.camera = Camera::look_at(c.origin, c.origin + c.forward, c.up, fov, true, res, res);
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 1,
        ..Default::default()
    };
    let reference = render(
        &scene,
        IntegratorKind::PtMono,
        &IntegratorOptions::default(),
        &RenderSettings {
            first_sample: 0,
            spp: ref_spp,
            seed: 999,
            ..Default::default()
        },
        None,
    )
    .unwrap()
    .film
    .xyz();
    let mut images = Vec::new();
    for width in [5.0f32, 10.0, 20.0, 50.0] {
        let opts = IntegratorOptions {
            bin_width: width,
            ..Default::default()
        };
        let out = render(&scene, IntegratorKind::BdptAllbins, &opts, &settings, None).unwrap();
        images.push((width, out.film.xyz(), out.seconds));
    }
    println!(
        "{scene_name} {res}x{res}, bdpt-allbins {spp} spp (seed 1), pt-mono reference {ref_spp} spp"
    );
    println!(
        "width_nm  seconds  SNR_vs_5nm_dB  relMSE_vs_5nm  meanY_rel_diff  SNR_vs_ref_dB  relMSE_vs_ref"
    );
    let base = images[0].1.clone();
    let mean_y = |img: &[Vec3]| img.iter().map(|v| v.y as f64).sum::<f64>() / img.len() as f64;
    for (w, img, secs) in &images {
        let (snr5, rel5) = metrics(img, &base);
        let (snr_r, rel_r) = metrics(img, &reference);
        println!(
            "{w:8}  {secs:7.2}  {snr5:13.2}  {rel5:13.3e}  {:14.3e}  {snr_r:13.2}  {rel_r:13.3e}",
            mean_y(img) / mean_y(&base) - 1.0
        );
    }
}
