//! Closed furnaces: pt-mono and pt-hero converge to the closed form.
//!
//! Lambert furnace: L = Le / (1 − ρ) = 2.
//! Fluorescent furnace (scenes/furnace-fluorescent.json): with d = r(1 − c a), the radiance is the
//! same everywhere and solves L = Le + d L + Φ e c∫a L, so
//!   L(λ) = (Le + Φ e s) / (1 − d),  s = c∫a Le/(1 − d) / (1 − cΦ∫ a e/(1 − d)),
//! computed here from the parsed material parameters.
//!
//! Sample counts: 32×32 pixels × 1024 spp = 1M camera paths per render (Lambert: 256 spp) (hero: ×4 lanes); the
//! relative error of Y and of each linear-sRGB channel must stay below 1 %.
//! max_depth = 64: each segment multiplies the throughput by at most max d = 0.5 (the
//! fluorescent loop gain cΦ∫ a e/(1 − d) is 0 because absorption and emission do not overlap,
//! so at most one shift happens), so truncation leaves < 0.5^63 ≈ 1e-19 of L. In a closed
//! furnace no path escapes, so Russian roulette from segment 6 on (unbiased) keeps the cost at a
//! few segments per path instead of 64.

use glam::Vec3;
use std::path::Path;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::material::Material;
use stokes::scene::Scene;
use stokes::spectrum::cie::CameraWavelengths;
use stokes::spectrum::{Spectrum, xyz_to_linear_srgb};

fn mean_xyz(scene: &Scene, kind: IntegratorKind, cw: CameraWavelengths, spp: u32) -> Vec3 {
    mean_xyz_lanes(scene, kind, cw, spp, 4)
}

fn mean_xyz_lanes(
    scene: &Scene,
    kind: IntegratorKind,
    cw: CameraWavelengths,
    spp: u32,
    lanes: u32,
) -> Vec3 {
    let opts = IntegratorOptions {
        lanes,
        max_depth: 64,
        rr_depth: Some(6),
        camera_wavelengths: cw,
        ..Default::default()
    };
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 7,
        ..Default::default()
    };
    let out = render(scene, kind, &opts, &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0);
    let xyz = out.film.xyz();
    assert!(xyz.iter().all(|v| v.is_finite()));
    xyz.iter().copied().sum::<Vec3>() / xyz.len() as f32
}

fn assert_close(what: &str, got: Vec3, want: Vec3) {
    let ey = (got.y - want.y).abs() / want.y;
    let (rgb, want_rgb) = (xyz_to_linear_srgb(got), xyz_to_linear_srgb(want));
    let e: Vec<f32> = (0..3)
        .map(|c| (rgb[c] - want_rgb[c]).abs() / want_rgb[c].abs())
        .collect();
    eprintln!("{what}: Y rel err {ey:.4}, rgb rel err {e:.4?} (rgb {rgb} vs {want_rgb})");
    assert!(ey < 0.01, "{what}: Y {} vs {}", got.y, want.y);
    for (c, e) in e.iter().enumerate() {
        assert!(
            *e < 0.01,
            "{what}: channel {c}: {} vs {}",
            rgb[c],
            want_rgb[c]
        );
    }
}

/// Closed form of the fluorescent furnace (module docs), as XYZ.
fn fluorescent_furnace_xyz(scene: &Scene) -> Vec3 {
    let Material::Fluorescent(f) = &scene.materials[0] else {
        panic!("furnace material is not fluorescent-diffuse");
    };
    let le = &scene.lights[0].spectrum;
    let (c, phi) = (f.c as f64, f.phi as f64);
    let d = |l: f32| f.r.eval(l) as f64 * (1.0 - c * f.a.eval(l) as f64);
    // Midpoint rule over the scene domain at 0.01 nm: box edges sit on 5 nm bins.
    let (lo, hi) = (scene.domain.min as f64, scene.domain.max as f64);
    let n = ((hi - lo) * 100.0).round() as usize;
    let h = (hi - lo) / n as f64;
    let (mut i_ale, mut i_ae) = (0.0, 0.0);
    for i in 0..n {
        let l = (lo + (i as f64 + 0.5) * h) as f32;
        let a = f.a.eval(l) as f64;
        let inv = 1.0 / (1.0 - d(l));
        i_ale += a * le.eval(l) as f64 * inv * h;
        i_ae += a * f.e.eval(l) as f64 * inv * h;
    }
    let s = c * i_ale / (1.0 - c * phi * i_ae);
    let radiance = |l: f32| (le.eval(l) as f64 + phi * f.e.eval(l) as f64 * s) / (1.0 - d(l));
    // Spot check against the scene comment: 5.2 in the emission band, 1/0.9 in the UV band.
    assert!((radiance(525.0) - 5.2).abs() < 1e-4, "{}", radiance(525.0));
    assert!((radiance(350.0) - 1.0 / 0.9).abs() < 1e-4);
    scene.observer.function_to_xyz(radiance)
}

#[test]
fn lambert_furnace_pt_hero() {
    let scene = Scene::load(Path::new("scenes/furnace-lambert.json")).unwrap();
    let want = scene.observer.spectrum_to_xyz(&Spectrum::Constant(2.0));
    for cw in [CameraWavelengths::Uniform, CameraWavelengths::Cmf] {
        let got = mean_xyz(&scene, IntegratorKind::PtHero, cw, 256);
        assert_close(&format!("lambert pt-hero {cw:?}"), got, want);
    }
    // The generic (non-Vec4) lane path.
    let got = mean_xyz_lanes(
        &scene,
        IntegratorKind::PtHero,
        CameraWavelengths::Cmf,
        256,
        3,
    );
    assert_close("lambert pt-hero 3 lanes cmf", got, want);
}

#[test]
fn fluorescent_furnace_pt_mono() {
    let scene = Scene::load(Path::new("scenes/furnace-fluorescent.json")).unwrap();
    let want = fluorescent_furnace_xyz(&scene);
    let got = mean_xyz(&scene, IntegratorKind::PtMono, CameraWavelengths::Cmf, 1024);
    assert_close("fluorescent pt-mono cmf", got, want);
}

#[test]
fn fluorescent_furnace_pt_hero() {
    let scene = Scene::load(Path::new("scenes/furnace-fluorescent.json")).unwrap();
    let want = fluorescent_furnace_xyz(&scene);
    for cw in [CameraWavelengths::Uniform, CameraWavelengths::Cmf] {
        let got = mean_xyz(&scene, IntegratorKind::PtHero, cw, 1024);
        assert_close(&format!("fluorescent pt-hero {cw:?}"), got, want);
    }
}
