//! Agreement with Mitsuba 3: the Cornell-box comparison scenes rendered by stokes match the mean
//! luminance (whole image and quadrants) that Mitsuba 3's `path`/`volpath` produced
//! (tests/data/mitsuba-cornell-box.json, with the command that made it) within 2 %.
//!
//! The mean over the pixels of a box-filtered image is the film integral over its area, so it
//! does not depend on the resolution: stokes renders at 64×64 to keep the test short.

use glam::Vec3;
use std::path::Path;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

/// (mean Y, quadrant means) of a render of `name` at 64×64.
fn render_means(name: &str, max_depth: u32, spp: u32) -> (f64, [f64; 4]) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut scene = Scene::load(&root.join("scenes").join(format!("{name}.json"))).unwrap();
    scene.camera.width = 64;
    scene.camera.height = 64;
    let opts = IntegratorOptions {
        max_depth,
        ..Default::default()
    };
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 5,
        ..Default::default()
    };
    let out = render(&scene, IntegratorKind::PtHero, &opts, &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0);
    let xyz: Vec<Vec3> = out.film.xyz();
    let mut q = [0.0f64; 4];
    for y in 0..64 {
        for x in 0..64 {
            q[(y / 32) * 2 + x / 32] += xyz[y * 64 + x].y as f64 / 1024.0;
        }
    }
    (q.iter().sum::<f64>() / 4.0, q)
}

fn check(name: &str, spp: u32) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let data: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("tests/data/mitsuba-cornell-box.json")).unwrap(),
    )
    .unwrap();
    let m = &data["scenes"][name];
    let depth = m["max_depth"].as_u64().unwrap() as u32;
    let (mean, q) = render_means(name, depth, spp);
    let want = m["mean_Y"].as_f64().unwrap();
    eprintln!(
        "{name}: stokes Y {mean:.5}, Mitsuba {want:.5}, quadrants {q:.5?} vs {}",
        m["quadrants"]
    );
    assert!(
        (mean - want).abs() < 0.02 * want,
        "{name}: Y {mean} vs Mitsuba {want}"
    );
    for (k, got) in q.iter().enumerate() {
        let w = m["quadrants"][k].as_f64().unwrap();
        assert!(
            (got - w).abs() < 0.02 * w,
            "{name} quadrant {k}: {got} vs Mitsuba {w}"
        );
    }
}

#[test]
fn cornell_box_medium_matches_mitsuba_volpath() {
    check("cornell-box-medium", 256);
}

#[test]
fn cornell_box_matches_mitsuba_path() {
    check("cornell-box", 64);
}

#[test]
fn cornell_box_grid_matches_mitsuba_volpath() {
    check("cornell-box-grid", 256);
}
