//! bdpt-allbins (Jung 6.5): closed-form furnaces, agreement with pt-mono and bdpt-forward per
//! image region, refusal of participating media (all three BDPTs), strategy images,
//! single-strategy consistency (light tracing W_e) and the rank-one bin operator of the scenes'
//! fluorescent materials against the bin-averaged kernel.

use glam::Vec3;
use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::allbins::BdptAllbins;
use stokes::integrator::render::run;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::material::{Bbrrdf, BinOperator, Material};
use stokes::scene::Scene;
use stokes::spectrum::BinGrid;

fn load(name: &str) -> Scene {
    Scene::load(Path::new(&format!("scenes/{name}.json"))).unwrap()
}

/// The scenes' Cornell camera at a small resolution.
fn small(mut scene: Scene, res: u32) -> Scene {
    let c = &scene.camera;
    let target = c.origin + c.forward;
    let fov = 2.0 * c.tan_half_x.atan().to_degrees();
    scene.camera = Camera::look_at(c.origin, target, c.up, fov, true, res, res);
    scene
}

fn mean_xyz(img: &[Vec3]) -> Vec3 {
    img.iter().copied().sum::<Vec3>() / img.len() as f32
}

fn furnace_mean(scene: &Scene, spp: u32) -> Vec3 {
    let opts = IntegratorOptions {
        max_depth: 64,
        ..Default::default()
    };
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 3,
        ..Default::default()
    };
    let out = render(scene, IntegratorKind::BdptAllbins, &opts, &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0);
    mean_xyz(&out.film.xyz())
}

fn assert_close(got: Vec3, want: Vec3, rel: f32) {
    eprintln!("got {got:?} want {want:?} rel {:?}", (got - want) / want);
    for c in 0..3 {
        assert!(
            (got[c] - want[c]).abs() <= rel * want[c].abs(),
            "channel {c}: got {got:?}, want {want:?}"
        );
    }
}

#[test]
fn furnace_lambert_closed_form() {
    let scene = small(load("furnace-lambert"), 16);
    let want = scene.observer.function_to_xyz(|_| 2.0);
    let got = furnace_mean(&scene, 16);
    assert_close(got, want, 0.005);
}

#[test]
fn furnace_fluorescent_closed_form() {
    let scene = small(load("furnace-fluorescent"), 16);
    let Material::Fluorescent(m) = &scene.materials[0] else {
        panic!("the furnace material is fluorescent-diffuse");
    };
    // L = (Le + Φ e s) / (1 − d), d = r(1 − c a), s = c ∫a Le/(1−d) / (1 − cΦ ∫ a e/(1−d)).
    let d = |l: f32| (m.r.eval(l) * (1.0 - m.c * m.a.eval(l))) as f64;
    let (lo, hi) = (scene.domain.min as f64, scene.domain.max as f64);
    let integ = |f: &dyn Fn(f32) -> f64| {
        let n = 100_000;
        let h = (hi - lo) / n as f64;
        (0..n)
            .map(|i| f((lo + (i as f64 + 0.5) * h) as f32))
            .sum::<f64>()
            * h
    };
    let num = m.c as f64 * integ(&|l| m.a.eval(l) as f64 / (1.0 - d(l)));
    let den =
        1.0 - (m.c * m.phi) as f64 * integ(&|l| (m.a.eval(l) * m.e.eval(l)) as f64 / (1.0 - d(l)));
    let s = num / den;
    let want = scene
        .observer
        .function_to_xyz(|l| (1.0 + m.phi as f64 * m.e.eval(l) as f64 * s) / (1.0 - d(l)));
    let got = furnace_mean(&scene, 16);
    assert_close(got, want, 0.005);
}

/// Pixel rectangles [x0, x1) × [y0, y1) as fractions of the image, for the Cornell-camera box.
const REGIONS: [(&str, [f32; 4]); 5] = [
    ("floor", [0.35, 0.65, 0.84, 0.97]),
    ("ceiling", [0.35, 0.65, 0.03, 0.1]),
    ("left", [0.03, 0.16, 0.35, 0.65]),
    ("right", [0.84, 0.97, 0.35, 0.65]),
    ("back", [0.4, 0.6, 0.4, 0.6]),
];

fn region_means(img: &[Vec3], res: u32) -> Vec<Vec3> {
    REGIONS
        .iter()
        .map(|(_, r)| {
            let f = |v: f32| (v * res as f32) as u32;
            let (mut acc, mut k) = (Vec3::ZERO, 0);
            for y in f(r[2])..f(r[3]) {
                for x in f(r[0])..f(r[1]) {
                    acc += img[(y * res + x) as usize];
                    k += 1;
                }
            }
            acc / k as f32
        })
        .collect()
}

/// Per-region (mean, standard error) of XYZ over independent seeds.
fn region_stats(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    spp: u32,
    seeds: u64,
) -> Vec<(Vec3, Vec3)> {
    let res = scene.camera.width;
    let runs: Vec<Vec<Vec3>> = (0..seeds)
        .map(|seed| {
            let settings = RenderSettings {
                first_sample: 0,
                spp,
                seed: 100 + seed,
                ..Default::default()
            };
            let out = render(scene, kind, opts, &settings, None).unwrap();
            assert_eq!(out.stats.nan_inf_rejected, 0, "{}", kind.name());
            region_means(&out.film.xyz(), res)
        })
        .collect();
    (0..REGIONS.len())
        .map(|r| {
            let m = runs.iter().map(|v| v[r]).sum::<Vec3>() / seeds as f32;
            let var =
                runs.iter().map(|v| (v[r] - m) * (v[r] - m)).sum::<Vec3>() / (seeds - 1) as f32;
            (m, (var / seeds as f32).powf(0.5))
        })
        .collect()
}

/// bdpt-allbins against a reference integrator, region by region: |Δ| ≤ 4σ of the difference
/// (plus 1 % of the value for the bin discretisation of smooth spectra).
fn agrees_with(name: &str, reference: IntegratorKind, spp_ref: u32, spp: u32) {
    let scene = small(load(name), 24);
    let opts = IntegratorOptions {
        max_depth: 8,
        ..Default::default()
    };
    let a = region_stats(&scene, IntegratorKind::BdptAllbins, &opts, spp, 8);
    let b = region_stats(&scene, reference, &opts, spp_ref, 8);
    for (r, ((ma, sa), (mb, sb))) in a.iter().zip(&b).enumerate() {
        for c in 0..3 {
            let sigma = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
            let tol = 4.0 * sigma + 0.01 * mb[c].abs() + 1e-6;
            eprintln!(
                "{name} {:8} ch{c}: allbins {:.5} ± {:.5}   {} {:.5} ± {:.5}",
                REGIONS[r].0,
                ma[c],
                sa[c],
                reference.name(),
                mb[c],
                sb[c]
            );
            assert!(
                (ma[c] - mb[c]).abs() <= tol,
                "{name}, region {}, channel {c}: {} vs {} (tol {tol})",
                REGIONS[r].0,
                ma[c],
                mb[c]
            );
        }
    }
}

#[test]
fn agrees_with_pt_mono_fluorescent_walls() {
    agrees_with("fluorescent-walls", IntegratorKind::PtMono, 256, 16);
}

#[test]
fn agrees_with_pt_mono_green_spheres() {
    agrees_with("green-spheres", IntegratorKind::PtMono, 128, 16);
}

#[test]
fn agrees_with_pt_mono_cornell_box() {
    agrees_with("cornell-box", IntegratorKind::PtMono, 128, 16);
}

// bdpt-forward samples the same geometric paths with one wavelength per segment: the two BDPTs
// must agree region by region (issue 5).
#[test]
fn agrees_with_bdpt_forward_fluorescent_walls() {
    agrees_with("fluorescent-walls", IntegratorKind::BdptForward, 64, 16);
}

#[test]
fn agrees_with_bdpt_forward_green_spheres() {
    agrees_with("green-spheres", IntegratorKind::BdptForward, 64, 16);
}

#[test]
fn agrees_with_bdpt_forward_cornell_box() {
    agrees_with("cornell-box", IntegratorKind::BdptForward, 64, 16);
}

/// Light tracing (s, 1) with W_e = N_pixels / (A cos⁴θ) estimates the same image as next-event
/// estimation (1, t) and the camera path hitting the light (0, t), strategy by strategy.
#[test]
fn light_tracing_importance_matches_other_strategies() {
    let scene = small(load("cornell-box"), 16);
    let opts = IntegratorOptions {
        max_depth: 2,
        ..Default::default()
    };
    let mean = |only: (usize, usize), spp: u32| {
        let mut it = BdptAllbins::new(&scene, &opts).unwrap();
        it.only = Some(only);
        let settings = RenderSettings {
            first_sample: 0,
            spp,
            seed: 7,
            ..Default::default()
        };
        let out = run(&scene, &it, &settings, None).unwrap();
        mean_xyz(&out.film.xyz())
    };
    // Paths of two segments: camera → surface → light.
    let lt = mean((2, 1), 128);
    let nee = mean((1, 2), 128);
    let hit = mean((0, 3), 1024);
    eprintln!("(2,1) {lt:?}  (1,2) {nee:?}  (0,3) {hit:?}");
    assert_close(lt, nee, 0.03);
    assert_close(hit, nee, 0.05);
}

/// The RankOne operator of each fluorescent material of the scenes equals the dense bin-averaged
/// operator: M[o][i] = δ_oi·avg_o(diag) + (1/Δλ_o)∫_o∫_i ρ(λi → λo) dλi dλo.
#[test]
fn rank_one_operator_matches_bin_averaged_kernel() {
    let mut checked = 0;
    for name in ["fluorescent-walls", "green-spheres", "furnace-fluorescent"] {
        let scene = load(name);
        for width in [5.0, 20.0] {
            let grid = BinGrid::new(scene.domain, width);
            let n = grid.len();
            for m in scene.materials.iter().filter(|m| m.is_fluorescent()) {
                let op = m.bin_operator(&grid);
                assert!(matches!(op, BinOperator::RankOne { .. }));
                let dense = op.to_dense();
                // Fine integration of the kernel: 8 points per nm... per bin side.
                let k = 40;
                let pts = |b: usize| {
                    let (lo, hi) = (grid.edge(b), grid.edge(b + 1));
                    (0..k).map(move |j| lo + (j as f32 + 0.5) * (hi - lo) / k as f32)
                };
                let mut max_err = 0.0f32;
                let mut max_val = 0.0f32;
                for o in 0..n {
                    for i in 0..n {
                        let wi = grid.bin_width(i);
                        let mut acc = 0.0f64;
                        for lo_ in pts(o) {
                            for li in pts(i) {
                                acc += m.kernel(li, lo_) as f64;
                            }
                        }
                        // Average over λo, integral over λi.
                        let mut want = (acc / (k * k) as f64 * wi as f64) as f32;
                        if o == i {
                            want += pts(o).map(|l| m.diagonal(l)).sum::<f32>() / k as f32;
                        }
                        max_err = max_err.max((dense[o * n + i] - want).abs());
                        max_val = max_val.max(want.abs());
                    }
                }
                assert!(
                    max_err <= 2e-3 * max_val,
                    "{name} @ {width} nm: max |M − K| = {max_err} (max {max_val})"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 4);
}

/// The power heuristic (`mis: power`) changes only the weights: same image as balance.
#[test]
fn power_heuristic_agrees_with_balance() {
    let scene = small(load("cornell-box"), 16);
    let mean = |mis| {
        let opts = IntegratorOptions {
            max_depth: 6,
            mis,
            ..Default::default()
        };
        let settings = RenderSettings {
            first_sample: 0,
            spp: 256,
            seed: 9,
            ..Default::default()
        };
        let out = render(&scene, IntegratorKind::BdptAllbins, &opts, &settings, None).unwrap();
        assert_eq!(out.stats.nan_inf_rejected, 0);
        mean_xyz(&out.film.xyz())
    };
    let (b, p) = (
        mean(stokes::integrator::MisHeuristic::Balance),
        mean(stokes::integrator::MisHeuristic::Power),
    );
    eprintln!("balance {b:?} power {p:?}");
    assert_close(p, b, 0.02);
}

/// The strategy images of bdpt-allbins (bdpt's `s{s}_t{t}` names; splats at their film position)
/// add up to the image.
#[test]
fn strategy_images_sum_to_the_image() {
    use stokes::integrator::Integrator;
    let scene = small(load("green-spheres"), 16);
    let opts = IntegratorOptions {
        max_depth: 4,
        strategy_images: true,
        ..Default::default()
    };
    let it = BdptAllbins::new(&scene, &opts).unwrap();
    let names = it.aux_layers();
    assert_eq!(names.len(), 2 + 3 + 4 + 5);
    assert_eq!(names[0], "s1_t1");
    assert_eq!(names[2], "s1_t2");
    let settings = RenderSettings {
        first_sample: 0,
        spp: 8,
        seed: 4,
        ..Default::default()
    };
    let out = run(&scene, &it, &settings, None).unwrap();
    let f = &out.film;
    let mut nonzero = 0;
    for (l, layer) in f.aux.iter().enumerate() {
        if layer.iter().any(|v| v[1] != 0.0) {
            nonzero += 1;
        } else {
            eprintln!("empty layer {}", names[l]);
        }
    }
    // Only s1_t1 (the pinhole connected to a light point) is not a bdpt-allbins strategy.
    assert_eq!(nonzero, names.len() - 1);
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
