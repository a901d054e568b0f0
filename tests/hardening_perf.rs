//! Legal input that used to hang or take minutes (issue 13, fuzz classes E and F). The tests
//! check results, not times; the times are in docs/hardening.md.
//! - bdpt-allbins on a domain far wider than the measured reradiation matrices: the materials'
//!   bin operators were integrated over every pair of bins of the domain (quadratic in its
//!   width), now only over the bins that meet the matrix's or mixture's support.
//! - Many coincident copies of one shape: the PLOC build merged one pair per pass (quadratic,
//!   and a tree as deep as the number of copies).

mod common;

use serde_json::{Value, json};
use std::path::Path;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

/// `scenes/<name>` as JSON, its relative file names made absolute, `edit` applied, written to a
/// temporary folder and loaded.
fn load_edited(tag: &str, name: &str, edit: impl FnOnce(&mut Value)) -> Scene {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenes").join(name)).unwrap();
    let text = text.replace("\"../", &format!("\"{}/", root.display()));
    let mut v: Value = serde_json::from_str(&text).unwrap();
    edit(&mut v);
    let p = common::temp_dir(&format!("hardening-perf-{tag}")).join("scene.json");
    std::fs::write(&p, v.to_string()).unwrap();
    Scene::load(&p).unwrap()
}

/// The XYZ pixels of a one-thread, fixed-seed render, checked to be finite.
fn pixels(scene: &Scene, kind: IntegratorKind, spp: u32) -> Vec<glam::Vec3> {
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 3,
        threads: Some(1),
        ..Default::default()
    };
    let out = render(scene, kind, &IntegratorOptions::default(), &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0);
    let xyz = out.film.xyz();
    assert!(xyz.iter().all(|p| p.is_finite()));
    xyz
}

/// The swatch scenes on the domain [280, 10000] render the image of the default domain [280,
/// 780]. Every light of these scenes is zero above 780 nm (D65 is tabulated to 780, the UV lamp
/// is a 300–400 box) and reradiation only lengthens wavelengths, so the bins the wide domain adds
/// carry no light: the observer's wider range (360–830 instead of 360–780) meets only zeros,
/// the sub-paths are the same (allbins samples no wavelengths) and the images agree to float
/// rounding. The wide domain has about 20 times as many bins; the materials' dense operators
/// used to cost 0.3 s each to build on it.
#[test]
fn allbins_on_a_wide_domain_renders_the_default_domain_image() {
    for name in ["gmm-swatches.json", "gmm-swatches-2.json"] {
        let image = |tag: &str, hi: u32| {
            let scene = load_edited(tag, name, |v| {
                v["domain"] = json!([280, hi]);
                v["camera"]["width"] = json!(24);
                v["camera"]["height"] = json!(16);
            });
            pixels(&scene, IntegratorKind::BdptAllbins, 2)
        };
        let narrow = image(&format!("{name}-780"), 780);
        let wide = image(&format!("{name}-10000"), 10_000);
        let peak = narrow.iter().map(|p| p.max_element()).fold(0.0, f32::max);
        assert!(peak > 0.0, "{name}: black image");
        for (k, (a, b)) in narrow.iter().zip(&wide).enumerate() {
            let d = (*a - *b).abs().max_element();
            assert!(d <= 1e-5 * peak, "{name}: pixel {k}: {a} vs {b}");
        }
    }
}

/// The Cornell box with 20,000 extra copies of its floor quad loads, renders a 4×4 image in
/// pt-mono and bdpt-allbins, and renders exactly the image of the box without the copies (a ray meets
/// one of the identical floors at the same distance, whichever it is).
#[test]
fn twenty_thousand_coincident_quads_render_the_plain_image() {
    let scene = |tag: &str, copies: usize| {
        load_edited(tag, "cornell-box.json", |v| {
            let shapes = v["shapes"].as_array_mut().unwrap();
            let i = shapes.iter().position(|s| s["name"] == "floor").unwrap();
            let mut floor = shapes[i].clone();
            floor.as_object_mut().unwrap().remove("name");
            shapes.extend(std::iter::repeat_n(floor, copies));
            v["camera"]["width"] = json!(4);
            v["camera"]["height"] = json!(4);
        })
    };
    let (plain, many) = (scene("plain", 0), scene("20k", 20_000));
    for kind in [IntegratorKind::PtMono, IntegratorKind::BdptAllbins] {
        assert_eq!(pixels(&plain, kind, 2), pixels(&many, kind, 2), "{kind:?}");
    }
}
