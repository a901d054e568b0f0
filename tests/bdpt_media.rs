//! Participating media in the bidirectional integrators (docs/design.md §4, "Media in the
//! bidirectional tracers"; src/integrator/bdpt/media.rs):
//!
//! - every BDPT agrees with pt-hero per image quadrant on every scene with media;
//! - the closed media furnace (scenes/furnace-medium.json) converges to the walls' emission Le
//!   with every tracking mode;
//! - the grey Cornell-box medium agrees with pt-hero;
//! - the MIS weights of all strategies sum to 1 on paths with medium vertices, wavelength shifts
//!   at medium vertices and connections through media;
//! - each strategy (s, t) alone, unweighted, converges to the MIS-combined light of its path
//!   length, and the strategy images add up to the image.
//!
//! bdpt-allbins is checked by every rendering test as soon as it renders scenes with media:
//! [`bdpts`] drops it only while its render returns the "does not support participating media"
//! error.

mod common;

use common::{
    Quadrants, assert_agree, assert_agree_within, load, load_sized, mean_xyz, media_scenes,
    quadrant_stats, quadrant_y, quadrants,
};
use std::path::Path;
use std::time::Instant;
use stokes::integrator::allbins::BdptAllbins;
use stokes::integrator::bdpt::{Bdpt, ResetMode, strategy_layer};
use stokes::integrator::render::{RenderOutput, run};
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::medium::Tracking;
use stokes::scene::Scene;
use stokes::spectrum::xyz_to_linear_srgb;

/// The bidirectional integrators under test. bdpt-allbins is listed here and skipped by [`bdpts`]
/// while it refuses scenes with media.
const BDPTS: [IntegratorKind; 4] = [
    IntegratorKind::BdptForward,
    IntegratorKind::BdptBackward,
    IntegratorKind::BdptCombined,
    IntegratorKind::BdptAllbins,
];

const MODES: [(IntegratorKind, ResetMode); 2] = [
    (IntegratorKind::BdptForward, ResetMode::Forward),
    (IntegratorKind::BdptBackward, ResetMode::Backward),
];

/// The integrators of [`BDPTS`] that render `scene`: a one-sample render must succeed, except
/// that bdpt-allbins may still answer that it does not support participating media (then it is
/// skipped, with a note on stderr). Any other error fails the test.
fn bdpts(scene: &Scene) -> Vec<IntegratorKind> {
    let opts = IntegratorOptions {
        max_depth: 2,
        ..Default::default()
    };
    let settings = RenderSettings {
        first_sample: 0,
        spp: 1,
        ..Default::default()
    };
    let kinds: Vec<_> = BDPTS
        .into_iter()
        .filter(|&kind| match render(scene, kind, &opts, &settings, None) {
            Ok(_) => true,
            Err(e)
                if kind == IntegratorKind::BdptAllbins
                    && e.contains("does not support participating media") =>
            {
                eprintln!("skipping {}: {e}", kind.name());
                false
            }
            Err(e) => panic!("{} refuses a scene with media: {e}", kind.name()),
        })
        .collect();
    assert!(kinds.len() >= 2, "{kinds:?}");
    kinds
}

/// Seeds per quadrant estimate. The standard errors are estimated from the spread over the
/// seeds; with more seeds a 3σ bound comes closer to its normal-theory false-alarm rate.
const SEEDS: u64 = 12;

/// Relative standard error per quadrant that one estimate aims at: two of them then pass
/// `noise_ok` (5 % for the difference).
const REL_SE: f64 = 0.035;

/// Run `estimate(spp)` (per-quadrant means and standard errors) with growing samples per pixel,
/// from `spp` until the standard error is below [`REL_SE`] of the mean in every quadrant or
/// `max_spp` is reached. The next spp is predicted from the measured error (a power of two, at
/// least double, at most 16×). Returns the estimate and its spp.
fn converge(
    what: &str,
    mut spp: u32,
    max_spp: u32,
    estimate: impl Fn(u32) -> Quadrants,
) -> (Quadrants, u32) {
    let t = Instant::now();
    loop {
        let q = estimate(spp);
        let worst = (0..4)
            .map(|r| q.1[r] / q.0[r].abs().max(1e-3))
            .fold(0.0, f64::max);
        eprintln!(
            "{what}: {spp} spp × {SEEDS} seeds, worst relative SE {worst:.4}, {:.1} s",
            t.elapsed().as_secs_f64()
        );
        if worst < REL_SE || spp >= max_spp {
            return (q, spp);
        }
        let factor = ((worst / (0.9 * REL_SE)).powi(2).ceil() as u32)
            .clamp(2, 16)
            .next_power_of_two();
        spp = (spp * factor).min(max_spp);
    }
}

/// [`quadrants`] of a render over [`SEEDS`] seeds, converged with [`converge`].
fn converged(
    what: &str,
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    spp: u32,
    max_spp: u32,
) -> Quadrants {
    let what = format!("{what} {}", kind.name());
    converge(&what, spp, max_spp, |spp| {
        quadrants(scene, kind, opts, spp, SEEDS)
    })
    .0
}

/// Every BDPT agrees with pt-hero per image quadrant within 3σ (12 seeds each, samples raised
/// until each estimate's standard error is below 3.5 % in every quadrant: pt-hero up to 4096 spp,
/// the BDPTs up to 128 spp, 16 times what bdpt-forward and bdpt-backward need) on every scene file
/// with media but the two that have their own tests below (the furnace and the Cornell-box
/// medium), at 16×16 pixels and 8 segments (so that the integrators' path-length truncation
/// must match as well). Every comparison runs; the failures are listed at the end.
#[test]
fn every_bdpt_agrees_with_pt_hero_on_every_media_scene() {
    let scenes = media_scenes(16);
    assert!(
        scenes.len() >= 8,
        "only {} media scenes found",
        scenes.len()
    );
    let opts = IntegratorOptions {
        max_depth: 8,
        ..Default::default()
    };
    let skip = ["furnace-medium", "cornell-box-medium"];
    let (mut compared, mut failures) = (0, Vec::new());
    for (stem, scene) in scenes {
        if skip.contains(&stem.as_str()) {
            continue;
        }
        let hero = converged(&stem, &scene, IntegratorKind::PtHero, &opts, 64, 4096);
        for kind in bdpts(&scene) {
            let what = format!("{stem}: {} vs pt-hero", kind.name());
            compared += 1;
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                let b = converged(&stem, &scene, kind, &opts, 8, 128);
                assert_agree(&what, b, hero);
            }));
            if let Err(e) = r {
                let msg = e
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                failures.push(format!("[{stem}, {}] {msg}", kind.name()));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {compared} comparisons failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The closed media furnace (scenes/furnace-medium.json; its comment derives that every pixel
/// sees the walls' emission Le): every BDPT with exponential, max and aware tracking reproduces
/// Le within 1 % in Y and in each linear-sRGB channel (relative to the brightest), and within 4
/// standard errors in Y. 16×16 pixels × 512 spp; 32 segments (the BDPTs have no Russian
/// roulette; 24 and 48 segments give the same mean, 16 segments lose 0.6 %).
#[test]
fn furnace_medium_holds_for_every_bdpt_and_tracking_mode() {
    let scene = load("furnace-medium.json");
    let le = scene.lights[0].spectrum.clone();
    let want = scene.observer.function_to_xyz(|l| le.eval(l) as f64);
    let want_rgb = xyz_to_linear_srgb(want);
    for kind in bdpts(&scene) {
        for tracking in [Tracking::Exponential, Tracking::Max, Tracking::Aware] {
            let opts = IntegratorOptions {
                max_depth: 32,
                tracking,
                ..Default::default()
            };
            let t = Instant::now();
            let (got, se) = mean_xyz(&scene, kind, &opts, 512, 11);
            let rgb = xyz_to_linear_srgb(got);
            let ey = (got.y - want.y).abs() / want.y;
            eprintln!(
                "{} {tracking:?}: Y {} ± {se} vs {} (rel {ey:.4}, {:.2}σ); rgb {rgb} vs \
                 {want_rgb}; {:.1} s",
                kind.name(),
                got.y,
                want.y,
                (got.y - want.y).abs() / se,
                t.elapsed().as_secs_f64()
            );
            assert!(
                ey < 0.01,
                "{} {tracking:?}: Y {} vs {} (rel {ey}, se {se})",
                kind.name(),
                got.y,
                want.y
            );
            assert!(
                (got.y - want.y).abs() < 4.0 * se,
                "{} {tracking:?}: Y {} vs {} beyond 4σ (σ {se})",
                kind.name(),
                got.y,
                want.y
            );
            let scale = want_rgb.abs().max_element();
            for c in 0..3 {
                let e = (rgb[c] - want_rgb[c]).abs() / scale;
                assert!(
                    e < 0.01,
                    "{} {tracking:?}: channel {c} {} vs {}",
                    kind.name(),
                    rgb[c],
                    want_rgb[c]
                );
            }
        }
    }
}

/// The grey Cornell-box medium (the Mitsuba comparison scene, non-fluorescent): every BDPT agrees
/// with pt-hero per quadrant within 3σ at 32×32 pixels and 16 segments (the scene's depth).
#[test]
fn bdpts_agree_with_pt_hero_in_the_cornell_box_medium() {
    let scene = load_sized("cornell-box-medium.json", 32);
    let opts = IntegratorOptions {
        max_depth: 16,
        ..Default::default()
    };
    let what = "cornell-box-medium";
    let hero = converged(what, &scene, IntegratorKind::PtHero, &opts, 32, 4096);
    for kind in bdpts(&scene) {
        let b = converged(what, &scene, kind, &opts, 4, 512);
        assert_agree(&format!("{what}: {} vs pt-hero", kind.name()), b, hero);
    }
}

/// Render strategy (s, t) alone (s camera vertices, t light vertices), without MIS weight.
fn render_single(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    (s, t): (usize, usize),
    settings: &RenderSettings,
) -> RenderOutput {
    let out = match kind {
        IntegratorKind::BdptForward | IntegratorKind::BdptBackward => {
            let mode = MODES.iter().find(|m| m.0 == kind).unwrap().1;
            let b = Bdpt::new(scene, opts, mode).unwrap().single_strategy(s, t);
            run(scene, &b, settings, None)
        }
        IntegratorKind::BdptCombined => {
            let b = Bdpt::combined(scene, opts).unwrap().single_strategy(s, t);
            run(scene, &b, settings, None)
        }
        IntegratorKind::BdptAllbins => {
            // bdpt-allbins counts (light vertices, camera vertices).
            let mut b = BdptAllbins::new(scene, opts).unwrap();
            b.only = Some((t, s));
            run(scene, &b, settings, None)
        }
        _ => unreachable!(),
    }
    .unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0, "{} ({s}, {t})", kind.name());
    out
}

/// Mean Y per quadrant of the sum of some strategy layers of a film.
fn layers_quadrants(scene: &Scene, out: &RenderOutput, layers: &[usize]) -> [f64; 4] {
    let f = &out.film;
    let img: Vec<glam::Vec3> = (0..f.sum.len())
        .map(|p| {
            let y: f64 = layers.iter().map(|&l| f.aux[l][p][1]).sum();
            glam::Vec3::new(0.0, (y / f.spp as f64) as f32, 0.0)
        })
        .collect();
    quadrant_y(scene, &img)
}

/// media-scattering.json at 16×16 pixels with its ceiling light enlarged from 0.6 × 0.6 to
/// 1.6 × 1.6, so that camera paths hit it often enough for the strategies t = 0.
fn strategy_scene() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/media-scattering.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let light = v["shapes"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|s| s["name"] == "light")
        .unwrap();
    light["corners"] = serde_json::json!([
        [-0.8, 0.99, -0.8],
        [0.8, 0.99, -0.8],
        [0.8, 0.99, 0.8],
        [-0.8, 0.99, 0.8]
    ]);
    let mut scene = Scene::from_str(&path, &v.to_string()).unwrap();
    assert!(scene.has_media);
    scene.camera.width = 16;
    scene.camera.height = 16;
    scene
}

/// Per path length k (vertices, camera included) of 3 and 4: the sum of the MIS-weighted strategy
/// images (s, k − s) — the light of paths of exactly k vertices — equals each strategy (s, k − s)
/// rendered alone and unweighted, per quadrant within 4σ (12 seeds each; 6 strategies × 4
/// quadrants per integrator are compared, hence 4σ rather than 3σ), on a fluorescent,
/// scattering fog where every strategy can sample every path (area light, diffuse surfaces,
/// isotropic phase; [`strategy_scene`]). Strategy (2, 2) is left out: alone it connects two
/// medium vertices with the unbounded factor 1/r², whose second moment ∫ r⁻⁴ r² dr diverges,
/// so its standard error does not mean anything (it is still part of the MIS-combined sum).
#[test]
fn each_strategy_alone_matches_the_mis_combined_light_of_its_length() {
    let scene = strategy_scene();
    for kind in bdpts(&scene) {
        let opts = IntegratorOptions {
            max_depth: 3,
            strategy_images: true,
            ..Default::default()
        };
        for k in [3usize, 4] {
            let layers: Vec<usize> = (1..=k).map(|s| strategy_layer(s, k - s)).collect();
            let what = format!("{} k={k} MIS-combined", kind.name());
            // At least 32 spp per seed: the standard error of a handful of samples of these
            // heavy-tailed estimators is itself too uncertain to test against.
            let (combined, _) = converge(&what, 32, 256, |spp| {
                let per_seed: Vec<[f64; 4]> = (0..SEEDS)
                    .map(|seed| {
                        let settings = RenderSettings {
                            first_sample: 0,
                            spp,
                            seed: 1000 + seed,
                            ..Default::default()
                        };
                        let out = render(&scene, kind, &opts, &settings, None).unwrap();
                        assert_eq!(out.stats.nan_inf_rejected, 0);
                        layers_quadrants(&scene, &out, &layers)
                    })
                    .collect();
                quadrant_stats(&per_seed)
            });
            let single_opts = IntegratorOptions {
                max_depth: k as u32 - 1,
                ..Default::default()
            };
            for s in (1..=k).filter(|&s| s < 2 || k - s < 2) {
                let what = format!("{} k={k} ({s}, {}) alone", kind.name(), k - s);
                // Twice the seeds: a single strategy is heavy-tailed (NEE from a medium vertex
                // near the light), and 12 seeds underestimate its standard error too often.
                let (alone, _) = converge(&what, 32, 1024, |spp| {
                    let per_seed: Vec<[f64; 4]> = (0..2 * SEEDS)
                        .map(|seed| {
                            let settings = RenderSettings {
                                first_sample: 0,
                                spp,
                                seed: 10_000 + 1000 * k as u64 + 100 * s as u64 + seed,
                                ..Default::default()
                            };
                            let out =
                                render_single(&scene, kind, &single_opts, (s, k - s), &settings);
                            quadrant_y(&scene, &out.film.xyz())
                        })
                        .collect();
                    quadrant_stats(&per_seed)
                });
                assert_agree_within(&what, alone, combined, 4.0);
            }
        }
    }
}

/// `strategy_images` on a scene with media: the strategy layers add up to the image in every
/// pixel and channel, and every layer of bdpt-forward/backward (every layer but s1_t1 for
/// bdpt-allbins, which has no such strategy) receives light, on media-scattering.json at 16×16
/// pixels and 4 segments.
#[test]
fn strategy_images_sum_to_the_image_in_a_medium() {
    let scene = load_sized("media-scattering.json", 16);
    let opts = IntegratorOptions {
        max_depth: 4,
        strategy_images: true,
        ..Default::default()
    };
    let settings = RenderSettings {
        first_sample: 0,
        spp: 16,
        seed: 4,
        ..Default::default()
    };
    for kind in bdpts(&scene) {
        let out = render(&scene, kind, &opts, &settings, None).unwrap();
        assert_eq!(out.stats.nan_inf_rejected, 0);
        let f = &out.film;
        assert_eq!(f.aux_names.len(), 2 + 3 + 4 + 5, "{:?}", f.aux_names);
        for (l, name) in f.aux_names.iter().enumerate() {
            let lit = f.aux[l].iter().any(|v| v[1] != 0.0);
            let expected = !(kind == IntegratorKind::BdptAllbins && name == "s1_t1");
            assert_eq!(lit, expected, "{}: layer {name}", kind.name());
        }
        for p in 0..f.sum.len() {
            for c in 0..3 {
                let total = f.sum[p][c] + f.splat[p][c];
                let layers: f64 = f.aux.iter().map(|l| l[p][c]).sum();
                assert!(
                    (total - layers).abs() <= 1e-4 * total.abs() + 1e-9,
                    "{} pixel {p} channel {c}: {total} vs {layers}",
                    kind.name()
                );
            }
        }
        let total: f64 = f.sum.iter().chain(&f.splat).map(|v| v[1]).sum();
        assert!(total > 0.0, "{}", kind.name());
    }
}
