//! pt-hero against pt-mono: agreement within statistical error on fluorescent and
//! non-fluorescent scenes, numerical stability on stiff fluorescent variants, and colour noise.

use glam::Vec3;
use serde_json::{Value, json};
use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::material::WavelengthSampling;
use stokes::scene::Scene;
use stokes::spectrum::cie::CameraWavelengths;
use stokes::spectrum::xyz_to_linear_srgb;

const RES: u32 = 48;

/// The scene at RES×RES with the same viewpoint and field of view (the scenes are square).
fn load_small(path: &str) -> Scene {
    let mut scene = Scene::load(Path::new(path)).unwrap();
    let c = &scene.camera;
    assert_eq!(c.width, c.height);
    let fov = 2.0 * c.tan_half_x.atan().to_degrees();
    scene.camera = Camera::look_at(c.origin, c.origin + c.forward, c.up, fov, true, RES, RES);
    scene
}

fn render_xyz(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    spp: u32,
    seed: u64,
) -> Vec<Vec3> {
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed,
        ..Default::default()
    };
    let out = render(scene, kind, opts, &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0, "{}", kind.name());
    let xyz = out.film.xyz();
    assert!(xyz.iter().all(|v| v.is_finite()), "{}", kind.name());
    xyz
}

/// Mean XYZ over the whole image and its four quadrants.
fn region_means(img: &[Vec3]) -> [Vec3; 5] {
    let h = RES / 2;
    let mut sums = [Vec3::ZERO; 5];
    let mut counts = [0u32; 5];
    for y in 0..RES {
        for x in 0..RES {
            let v = img[(y * RES + x) as usize];
            let q = 1 + (y / h) as usize * 2 + (x / h) as usize;
            sums[0] += v;
            counts[0] += 1;
            sums[q] += v;
            counts[q] += 1;
        }
    }
    std::array::from_fn(|i| sums[i] / counts[i] as f32)
}

/// Mean and standard error over seeds of each region's mean XYZ.
fn seed_stats(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    spp: u32,
    seeds: u64,
) -> Vec<(Vec3, Vec3)> {
    let per: Vec<[Vec3; 5]> = (0..seeds)
        .map(|s| region_means(&render_xyz(scene, kind, opts, spp, 1000 + s)))
        .collect();
    let n = seeds as f32;
    (0..5)
        .map(|r| {
            let mean = per.iter().map(|p| p[r]).sum::<Vec3>() / n;
            let var = per
                .iter()
                .map(|p| (p[r] - mean) * (p[r] - mean))
                .sum::<Vec3>()
                / (n - 1.0);
            (mean, (var / n).powf(0.5))
        })
        .collect()
}

/// pt-mono and pt-hero agree: |Δ| < 4·sqrt(se1² + se2²) for every region and XYZ channel.
fn assert_agree(path: &str, spp: u32, seeds: u64) {
    let scene = load_small(path);
    let opts = IntegratorOptions::default();
    let mono = seed_stats(&scene, IntegratorKind::PtMono, &opts, spp, seeds);
    let hero = seed_stats(&scene, IntegratorKind::PtHero, &opts, spp, seeds);
    assert!(mono[0].0.y > 0.0, "{path}: black image");
    for (r, ((m1, s1), (m2, s2))) in mono.iter().zip(&hero).enumerate() {
        let tol = (*s1 * *s1 + *s2 * *s2).powf(0.5) * 4.0;
        let d = (*m1 - *m2).abs();
        eprintln!(
            "{path} region {r}: mono {m1} ± {s1}, hero {m2} ± {s2}, |Δ|/σ = {}",
            d / (tol / 4.0)
        );
        assert!(
            d.cmple(tol).all(),
            "{path} region {r}: mono {m1} ± {s1} vs hero {m2} ± {s2}"
        );
    }
}

#[test]
fn agree_fluorescent_walls() {
    // 16 seeds × 4 spp at 48×48 (147k paths per integrator and seed set).
    assert_agree("scenes/fluorescent-walls.json", 4, 16);
}

#[test]
fn agree_green_spheres() {
    assert_agree("scenes/green-spheres.json", 4, 16);
}

#[test]
fn agree_cornell_box_non_fluorescent() {
    assert_agree("scenes/cornell-box.json", 2, 16);
}

// ---------------------------------------------------------------------------------------------
// Numerical stability (docs/design.md §5).

fn furnace_json() -> Value {
    serde_json::from_str(&std::fs::read_to_string("scenes/furnace-fluorescent.json").unwrap())
        .unwrap()
}

fn walls_json() -> Value {
    serde_json::from_str(&std::fs::read_to_string("scenes/fluorescent-walls.json").unwrap())
        .unwrap()
}

fn small_camera(v: &mut Value, res: u32) {
    v["camera"]["width"] = json!(res);
    v["camera"]["height"] = json!(res);
}

fn boxspec(lo: f32, hi: f32, value: f32) -> Value {
    json!({ "type": "box", "lo": lo, "hi": hi, "value": value })
}

/// Render with pt-mono and pt-hero (4 lanes, 3 lanes = generic path, cmf wavelengths) in both
/// wavelength-sampling modes; no NaN/Inf may reach the film.
fn assert_stable(name: &str, v: &Value) {
    let scene = Scene::from_str(Path::new("scenes/inline.json"), &v.to_string())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    for ws in [WavelengthSampling::Importance, WavelengthSampling::Uniform] {
        let base = IntegratorOptions {
            max_depth: 24,
            wavelength_sampling: ws,
            ..Default::default()
        };
        let variants = [
            (IntegratorKind::PtMono, base.clone()),
            (IntegratorKind::PtHero, base.clone()),
            (
                IntegratorKind::PtHero,
                IntegratorOptions {
                    lanes: 3,
                    camera_wavelengths: CameraWavelengths::Cmf,
                    ..base.clone()
                },
            ),
        ];
        for (kind, opts) in variants {
            let settings = RenderSettings {
                first_sample: 0,
                spp: 8,
                seed: 3,
                ..Default::default()
            };
            let out = render(&scene, kind, &opts, &settings, None).unwrap();
            assert_eq!(
                out.stats.nan_inf_rejected,
                0,
                "{name} {} {ws:?}",
                kind.name()
            );
            let xyz = out.film.xyz();
            assert!(
                xyz.iter().all(|p| p.is_finite()),
                "{name} {} {ws:?}",
                kind.name()
            );
        }
    }
}

#[test]
fn stable_c1_phi1() {
    let mut f = furnace_json();
    small_camera(&mut f, 16);
    f["materials"]["dye"]["concentration"] = json!(1.0);
    f["materials"]["dye"]["quantum_yield"] = json!(1.0);
    assert_stable("furnace c=1 Φ=1", &f);
    let mut w = walls_json();
    small_camera(&mut w, 24);
    for m in ["floor", "left", "ceiling", "right"] {
        w["materials"][m]["concentration"] = json!(1.0);
        w["materials"][m]["quantum_yield"] = json!(1.0);
    }
    assert_stable("walls c=1 Φ=1", &w);
}

#[test]
fn stable_purely_fluorescent() {
    let mut f = furnace_json();
    small_camera(&mut f, 16);
    f["materials"]["dye"]["reflectance"] = json!(0.0);
    f["materials"]["dye"]["concentration"] = json!(1.0);
    f["materials"]["dye"]["quantum_yield"] = json!(1.0);
    assert_stable("furnace r=0", &f);
    let mut w = walls_json();
    small_camera(&mut w, 24);
    for m in ["floor", "left", "ceiling", "right"] {
        w["materials"][m]["reflectance"] = json!(0.0);
    }
    assert_stable("walls r=0", &w);
}

#[test]
fn stable_one_bin_spectra() {
    let mut f = furnace_json();
    small_camera(&mut f, 16);
    f["materials"]["dye"]["absorption"] = boxspec(330.0, 335.0, 1.0);
    f["materials"]["dye"]["emission"] = boxspec(520.0, 525.0, 0.2);
    f["materials"]["dye"]["concentration"] = json!(1.0);
    f["materials"]["dye"]["quantum_yield"] = json!(1.0);
    assert_stable("furnace one bin", &f);
    let mut w = walls_json();
    small_camera(&mut w, 24);
    let chain = [
        ("floor", 330.0, 420.0),
        ("left", 420.0, 500.0),
        ("ceiling", 500.0, 580.0),
        ("right", 580.0, 650.0),
    ];
    for (m, a, e) in chain {
        w["materials"][m]["absorption"] = boxspec(a, a + 5.0, 1.0);
        w["materials"][m]["emission"] = boxspec(e, e + 5.0, 0.2);
        w["materials"][m]["reflectance"] = boxspec(e, e + 5.0, 0.5);
    }
    assert_stable("walls one bin", &w);
}

#[test]
fn stable_unexcited_emission() {
    // The light emits only where nothing absorbs, so no emission band is ever excited.
    let mut f = furnace_json();
    small_camera(&mut f, 16);
    f["shapes"][0]["emission"]["spectrum"] = boxspec(450.0, 780.0, 1.0);
    assert_stable("furnace unexcited", &f);
    let mut w = walls_json();
    small_camera(&mut w, 24);
    w["shapes"][5]["emission"]["spectrum"] = boxspec(700.0, 780.0, 1.0);
    assert_stable("walls unexcited", &w);
}

// ---------------------------------------------------------------------------------------------
// Colour noise on green-spheres.

/// (chromatic MSE, SNR_dB) of `img` against `reference`, both XYZ. The chromatic error is the
/// linear-RGB error with the part explained by a luminance error removed:
/// e = Δrgb − ΔY · rgb_ref / Y_ref (pixels with Y_ref ≤ 1e-4 skipped).
fn colour_errors(img: &[Vec3], reference: &[Vec3]) -> (f64, f64) {
    let (mut chroma, mut n) = (0.0f64, 0usize);
    let (mut sig, mut noise) = (0.0f64, 0.0f64);
    for (v, r) in img.iter().zip(reference) {
        let (rgb, rgb_ref) = (xyz_to_linear_srgb(*v), xyz_to_linear_srgb(*r));
        sig += rgb_ref.length_squared() as f64;
        noise += (rgb - rgb_ref).length_squared() as f64;
        if r.y > 1e-4 {
            let e = (rgb - rgb_ref) - (v.y - r.y) * rgb_ref / r.y;
            chroma += e.length_squared() as f64;
            n += 1;
        }
    }
    (chroma / n as f64, 10.0 * (sig / noise).log10())
}

#[test]
fn colour_noise_green_spheres() {
    let scene = load_small("scenes/green-spheres.json");
    let opts = IntegratorOptions::default();
    // Reference: pt-mono and pt-hero at 128 spp each, averaged (both unbiased, see above).
    let rm = render_xyz(&scene, IntegratorKind::PtMono, &opts, 128, 99);
    let rh = render_xyz(&scene, IntegratorKind::PtHero, &opts, 128, 98);
    let reference: Vec<Vec3> = rm.iter().zip(&rh).map(|(a, b)| 0.5 * (*a + *b)).collect();
    let spp = 4;
    let mut sums = [(0.0, 0.0); 2];
    let seeds = 4;
    for s in 0..seeds {
        for (i, kind) in [IntegratorKind::PtMono, IntegratorKind::PtHero]
            .into_iter()
            .enumerate()
        {
            let (c, snr) = colour_errors(&render_xyz(&scene, kind, &opts, spp, s), &reference);
            sums[i].0 += c / seeds as f64;
            sums[i].1 += snr / seeds as f64;
        }
    }
    eprintln!(
        "green-spheres 48×48 @ {spp} spp (mean over {seeds} seeds): chromatic MSE mono {:.4e} hero {:.4e} (ratio {:.2}); SNR mono {:.2} dB hero {:.2} dB",
        sums[0].0,
        sums[1].0,
        sums[0].0 / sums[1].0,
        sums[0].1,
        sums[1].1
    );
    assert!(sums[1].0 < sums[0].0, "hero chromatic error not lower");
    assert!(sums[1].1 > sums[0].1, "hero SNR not higher");
}
