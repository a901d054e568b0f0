//! Bidirectional path tracers with wavelength resets (Jung ch. 6): closed-form furnaces,
//! agreement with pt-mono per region, MIS weights, per-strategy convergence, stiff cases.

use glam::Vec3;
use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::bdpt::{Bdpt, ResetMode};
use stokes::integrator::render::run;
use stokes::integrator::{
    Integrator, IntegratorKind, IntegratorOptions, LightWavelengths, MisHeuristic, RenderSettings,
    ResetChoice, Stats, render,
};
use stokes::material::{Bbrrdf, Material};
use stokes::scene::Scene;
use stokes::spectrum::cie::CameraWavelengths;

const MODES: [(IntegratorKind, ResetMode); 2] = [
    (IntegratorKind::BdptForward, ResetMode::Forward),
    (IntegratorKind::BdptBackward, ResetMode::Backward),
];

fn load(name: &str) -> Scene {
    Scene::load(Path::new(&format!("scenes/{name}.json"))).unwrap()
}

fn small_camera(scene: &mut Scene, w: u32, h: u32) {
    let c = &scene.camera;
    let target = c.origin + c.forward;
    let fov = 2.0 * c.tan_half_x.atan().to_degrees();
    scene.camera = Camera::look_at(c.origin, target, c.up, fov, true, w, h);
}

fn mean_xyz(xyz: &[Vec3]) -> Vec3 {
    xyz.iter().copied().sum::<Vec3>() / xyz.len() as f32
}

/// bdpt-forward, bdpt-backward and bdpt-combined with each reset choice.
fn bdpt_variants() -> Vec<(IntegratorKind, ResetChoice)> {
    let mut v: Vec<_> = MODES.iter().map(|m| (m.0, ResetChoice::Both)).collect();
    for choice in ResetChoice::ALL {
        v.push((IntegratorKind::BdptCombined, choice));
    }
    v
}

fn furnace_check(scene: &Scene, want: Vec3, max_depth: u32, spp: u32) {
    for (kind, choice) in bdpt_variants() {
        let opts = IntegratorOptions {
            max_depth,
            camera_wavelengths: CameraWavelengths::Cmf,
            reset_choice: choice,
            ..Default::default()
        };
        let settings = RenderSettings {
            first_sample: 0,
            spp,
            seed: 3,
            ..Default::default()
        };
        let out = render(scene, kind, &opts, &settings, None).unwrap();
        assert_eq!(out.stats.nan_inf_rejected, 0, "{}", kind.name());
        let m = mean_xyz(&out.film.xyz());
        for c in 0..3 {
            assert!(
                (m[c] - want[c]).abs() < 0.01 * want[c],
                "{} {} channel {c}: {} vs {}",
                kind.name(),
                choice.name(),
                m[c],
                want[c]
            );
        }
    }
}

#[test]
fn furnace_lambert_converges() {
    let mut scene = load("furnace-lambert");
    small_camera(&mut scene, 16, 16);
    let want = scene.observer.function_to_xyz(|_| 2.0);
    // truncation after 12 segments: ρ^12 / (1 − ρ) ≈ 5e-4 relative
    furnace_check(&scene, want, 10, 320);
}

#[test]
fn furnace_fluorescent_converges() {
    let mut scene = load("furnace-fluorescent");
    small_camera(&mut scene, 16, 16);
    // Closed form from the scene comment: L = (Le + Φ e s) / (1 − r(1 − c a)).
    let (r, c, phi) = (0.5f64, 0.8f64, 0.9f64);
    let a = |l: f64| {
        if (300.0..400.0).contains(&l) {
            1.0
        } else {
            0.0
        }
    };
    let e = |l: f64| {
        if (500.0..550.0).contains(&l) {
            0.02
        } else {
            0.0
        }
    };
    let d = |l: f64| r * (1.0 - c * a(l));
    let integ = |f: &dyn Fn(f64) -> f64| {
        let (lo, hi, n) = (280.0, 780.0, 50_000);
        let h = (hi - lo) / n as f64;
        (0..n).map(|i| f(lo + (i as f64 + 0.5) * h)).sum::<f64>() * h
    };
    let num = c * integ(&|l| a(l) * 1.0 / (1.0 - d(l)));
    let den = 1.0 - c * phi * integ(&|l| a(l) * e(l) / (1.0 - d(l)));
    let s = num / den;
    let want = scene
        .observer
        .function_to_xyz(|l| (1.0 + phi * e(l as f64) * s) / (1.0 - d(l as f64)));
    assert!((want.y - 0.0).abs() > 1.0);
    furnace_check(&scene, want, 14, 256);
}

/// Per-seed means of the XYZ of pixel rectangles (x0, x1, y0, y1), for one render each.
fn region_means(
    scene: &Scene,
    render_one: &dyn Fn(u64) -> (Vec<Vec3>, Stats),
    regions: &[(&str, [u32; 4])],
    seeds: std::ops::Range<u64>,
) -> Vec<Vec<Vec3>> {
    let w = scene.camera.width;
    let mut out = vec![Vec::new(); regions.len()];
    for seed in seeds {
        let (img, stats) = render_one(seed);
        assert_eq!(stats.nan_inf_rejected, 0);
        for (r, (_, [x0, x1, y0, y1])) in regions.iter().enumerate() {
            let mut acc = Vec3::ZERO;
            for y in *y0..*y1 {
                for x in *x0..*x1 {
                    acc += img[(y * w + x) as usize];
                }
            }
            out[r].push(acc / ((x1 - x0) * (y1 - y0)) as f32);
        }
    }
    out
}

fn mean_se(v: &[Vec3]) -> (Vec3, Vec3) {
    let n = v.len() as f32;
    let m = v.iter().copied().sum::<Vec3>() / n;
    let var = v.iter().map(|x| (*x - m) * (*x - m)).sum::<Vec3>() / (n - 1.0);
    (m, (var / n).powf(0.5))
}

/// |a − b| within `k` combined standard errors (plus a tiny absolute slack) per channel.
fn assert_agree(what: &str, a: &[Vec3], b: &[Vec3], k: f32) {
    let ((ma, sa), (mb, sb)) = (mean_se(a), mean_se(b));
    println!("{what}: {ma} ± {sa} vs {mb} ± {sb}");
    for c in 0..3 {
        let tol =
            k * (sa[c] * sa[c] + sb[c] * sb[c]).sqrt() + 1e-4 * (ma[c].abs() + mb[c].abs()) + 1e-6;
        assert!(
            (ma[c] - mb[c]).abs() <= tol,
            "{what} channel {c}: {} ± {} vs {} ± {}",
            ma[c],
            sa[c],
            mb[c],
            sb[c]
        );
    }
}

/// bdpt-forward, bdpt-backward, bdpt-combined and pt-mono agree per region (floor, walls, ceiling, back).
fn agree_with_pt_mono(name: &str, spp_bdpt: u32, spp_pt: u32) {
    let mut scene = load(name);
    small_camera(&mut scene, 32, 32);
    let regions = [
        ("floor", [10, 22, 27, 32]),
        ("ceiling", [10, 22, 0, 5]),
        ("left", [0, 5, 10, 22]),
        ("right", [27, 32, 10, 22]),
        ("back", [11, 21, 11, 21]),
    ];
    let opts = IntegratorOptions::default();
    let r = |kind: IntegratorKind, spp: u32| {
        let scene = &scene;
        let opts = &opts;
        move |seed: u64| {
            let settings = RenderSettings {
                first_sample: 0,
                spp,
                seed,
                ..Default::default()
            };
            let out = render(scene, kind, opts, &settings, None).unwrap();
            (out.film.xyz(), out.stats)
        }
    };
    let seeds = 0..6;
    let pt = region_means(
        &scene,
        &r(IntegratorKind::PtMono, spp_pt),
        &regions,
        seeds.clone(),
    );
    let fw = region_means(
        &scene,
        &r(IntegratorKind::BdptForward, spp_bdpt),
        &regions,
        seeds.clone(),
    );
    let bw = region_means(
        &scene,
        &r(IntegratorKind::BdptBackward, spp_bdpt),
        &regions,
        seeds.clone(),
    );
    let cb = region_means(
        &scene,
        &r(IntegratorKind::BdptCombined, spp_bdpt),
        &regions,
        seeds,
    );
    for (i, (reg, _)) in regions.iter().enumerate() {
        assert_agree(
            &format!("{name} {reg} forward/pt-mono"),
            &fw[i],
            &pt[i],
            4.5,
        );
        assert_agree(
            &format!("{name} {reg} backward/pt-mono"),
            &bw[i],
            &pt[i],
            4.5,
        );
        assert_agree(
            &format!("{name} {reg} forward/backward"),
            &fw[i],
            &bw[i],
            4.5,
        );
        assert_agree(
            &format!("{name} {reg} combined/pt-mono"),
            &cb[i],
            &pt[i],
            4.5,
        );
    }
}

#[test]
fn agree_fluorescent_walls() {
    agree_with_pt_mono("fluorescent-walls", 64, 1024);
}

#[test]
fn agree_green_spheres() {
    agree_with_pt_mono("green-spheres", 16, 96);
}

#[test]
fn agree_cornell_box() {
    agree_with_pt_mono("cornell-box", 16, 96);
}

/// For a fixed vertex count k, every strategy (s, t) with s + t = k on its own and unweighted
/// converges to the same mean (the light of paths with exactly k vertices).
#[test]
fn each_strategy_alone_converges_to_the_same_image() {
    let mut scene = load("green-spheres");
    small_camera(&mut scene, 12, 12);
    for (_, mode) in MODES {
        for k in [3usize, 4] {
            let opts = IntegratorOptions {
                max_depth: k as u32 - 1,
                ..Default::default()
            };
            let means: Vec<Vec<Vec3>> = (1..=k)
                .map(|s| {
                    (0..8)
                        .map(|seed| {
                            let b = Bdpt::new(&scene, &opts, mode)
                                .unwrap()
                                .single_strategy(s, k - s);
                            let settings = RenderSettings {
                                first_sample: 0,
                                spp: 160,
                                seed,
                                ..Default::default()
                            };
                            let out = run(&scene, &b, &settings, None).unwrap();
                            assert_eq!(out.stats.nan_inf_rejected, 0);
                            mean_xyz(&out.film.xyz())
                        })
                        .collect()
                })
                .collect();
            for s in 1..=k {
                for s2 in s + 1..=k {
                    assert_agree(
                        &format!("{mode:?} k={k} s={s} vs s={s2}"),
                        &means[s - 1],
                        &means[s2 - 1],
                        4.5,
                    );
                }
            }
        }
    }
}

/// Stiff cases (docs/design.md §5): purely fluorescent walls (r = 0), c = Φ = 1, one-bin (5 nm)
/// absorption and emission spectra. No NaN or Inf may reach the film.
#[test]
fn stiff_fluorescent_walls_stay_finite() {
    let text = std::fs::read_to_string("scenes/fluorescent-walls.json").unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let chain = [
        ("floor", 300.0, 400.0),
        ("left", 400.0, 480.0),
        ("ceiling", 480.0, 560.0),
        ("right", 560.0, 620.0),
    ];
    for (name, abs_lo, em_lo) in chain {
        let m = &mut v["materials"][name];
        m["reflectance"] = serde_json::json!(0.0);
        m["absorption"] =
            serde_json::json!({"type": "box", "lo": abs_lo, "hi": abs_lo + 5.0, "value": 1.0});
        m["emission"] =
            serde_json::json!({"type": "box", "lo": em_lo, "hi": em_lo + 5.0, "value": 0.2});
        m["quantum_yield"] = serde_json::json!(1.0);
        m["concentration"] = serde_json::json!(1.0);
    }
    let mut scene = Scene::from_str(Path::new("scenes/stiff.json"), &v.to_string()).unwrap();
    small_camera(&mut scene, 24, 24);
    // r = 0 and c = 1: P_c = P_l = 1 inside the band.
    let floor = scene
        .material_names
        .iter()
        .position(|n| n == "floor")
        .unwrap();
    let m: &Material = &scene.materials[floor];
    assert!(m.fluorescence_probability_light(302.0) > 0.999);
    for kind in [
        IntegratorKind::BdptForward,
        IntegratorKind::BdptBackward,
        IntegratorKind::BdptCombined,
        IntegratorKind::PtMono,
    ] {
        for ws in [
            stokes::material::WavelengthSampling::Importance,
            stokes::material::WavelengthSampling::Uniform,
        ] {
            let opts = IntegratorOptions {
                wavelength_sampling: ws,
                ..Default::default()
            };
            let settings = RenderSettings {
                first_sample: 0,
                spp: 16,
                seed: 2,
                ..Default::default()
            };
            let out = render(&scene, kind, &opts, &settings, None).unwrap();
            assert_eq!(out.stats.nan_inf_rejected, 0, "{} {ws:?}", kind.name());
            let img = out.film.xyz();
            assert!(img.iter().all(|p| p.is_finite()), "{}", kind.name());
            if kind != IntegratorKind::PtMono {
                assert!(mean_xyz(&img).y > 0.0, "{} sees nothing", kind.name());
            }
        }
    }
}

/// The strategy images (one per (s, t), splats at their film position) add up to the image.
#[test]
fn strategy_images_sum_to_the_image() {
    let mut scene = load("green-spheres");
    small_camera(&mut scene, 16, 16);
    let opts = IntegratorOptions {
        max_depth: 4,
        strategy_images: true,
        ..Default::default()
    };
    let b = Bdpt::new(&scene, &opts, ResetMode::Forward).unwrap();
    let names = b.aux_layers();
    assert_eq!(names.len(), 2 + 3 + 4 + 5);
    assert_eq!(names[0], "s1_t1");
    assert_eq!(names[2], "s1_t2");
    let settings = RenderSettings {
        first_sample: 0,
        spp: 8,
        seed: 4,
        ..Default::default()
    };
    let out = run(&scene, &b, &settings, None).unwrap();
    let f = &out.film;
    for p in 0..f.sum.len() {
        for c in 0..3 {
            let total = f.sum[p][c] + f.splat[p][c];
            let layers: f64 = f.aux.iter().map(|l| l[p][c]).sum();
            assert!(
                (total - layers).abs() <= 1e-4 * total.abs() + 1e-9,
                "pixel {p}: {total} vs {layers}"
            );
        }
    }
}

/// Light sub-paths with uniform wavelengths (Jung 6.2.1 option 1) and the power heuristic give
/// the same regions as the defaults.
#[test]
fn uniform_light_wavelengths_and_power_heuristic_agree() {
    let mut scene = load("fluorescent-walls");
    small_camera(&mut scene, 24, 24);
    let regions = [
        ("floor", [6, 18, 20, 24]),
        ("left", [0, 4, 8, 16]),
        ("back", [8, 16, 8, 16]),
    ];
    for (kind, _) in MODES {
        let r = |opts: IntegratorOptions| {
            let scene = &scene;
            move |seed: u64| {
                let settings = RenderSettings {
                    first_sample: 0,
                    spp: 32,
                    seed,
                    ..Default::default()
                };
                let out = render(scene, kind, &opts, &settings, None).unwrap();
                (out.film.xyz(), out.stats)
            }
        };
        let base = region_means(&scene, &r(IntegratorOptions::default()), &regions, 0..6);
        let uni = IntegratorOptions {
            light_wavelengths: LightWavelengths::Uniform,
            ..Default::default()
        };
        let uni = region_means(&scene, &r(uni), &regions, 10..16);
        let pow = IntegratorOptions {
            mis: MisHeuristic::Power,
            ..Default::default()
        };
        let pow = region_means(&scene, &r(pow), &regions, 20..26);
        for (i, (reg, _)) in regions.iter().enumerate() {
            assert_agree(
                &format!("{} {reg} uniform light λ", kind.name()),
                &uni[i],
                &base[i],
                4.5,
            );
            assert_agree(
                &format!("{} {reg} power", kind.name()),
                &pow[i],
                &base[i],
                4.5,
            );
        }
    }
}
