//! The closed Lambertian furnace: L = Le / (1 − ρ) everywhere, so Y = 2 for Le = 1, ρ = 0.5.

use std::path::Path;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;
use stokes::spectrum::{Spectrum, xyz_to_linear_srgb};

#[test]
fn pt_mono_converges_to_closed_form() {
    let scene = Scene::load(Path::new("scenes/furnace-lambert.json")).unwrap();
    // ρ^40 ≈ 1e-12: truncation at 40 segments is far below the tolerance.
    let opts = IntegratorOptions {
        max_depth: 40,
        camera_wavelengths: stokes::spectrum::cie::CameraWavelengths::Cmf,
        ..Default::default()
    };
    // 32×32 pixels × 256 spp = 262k paths; wavelengths ∝ x̄+ȳ+z̄ keep the colour noise low.
    let settings = RenderSettings {
        first_sample: 0,
        spp: 256,
        seed: 1,
        ..Default::default()
    };
    let out = render(&scene, IntegratorKind::PtMono, &opts, &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0);
    let xyz = out.film.xyz();
    let mean = xyz.iter().copied().sum::<glam::Vec3>() / xyz.len() as f32;
    let want = scene.observer.spectrum_to_xyz(&Spectrum::Constant(2.0));
    assert!((mean.y - 2.0).abs() < 0.01 * 2.0, "Y = {}", mean.y);
    let (rgb, want_rgb) = (xyz_to_linear_srgb(mean), xyz_to_linear_srgb(want));
    for c in 0..3 {
        assert!(
            (rgb[c] - want_rgb[c]).abs() < 0.01 * want_rgb[c],
            "channel {c}: {} vs {}",
            rgb[c],
            want_rgb[c]
        );
    }
}
