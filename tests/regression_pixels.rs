//! Pinned pixel sums of small fixed-seed renders, so that a refactor that changes what an
//! integrator computes is caught. Every integrator renders a 24×24 crop of the Cornell box and
//! of the fluorescent walls (4 spp, seed 5, 2 threads) and the sum of XYZ over each image
//! quadrant is compared with the value recorded when the transport layer was introduced
//! (bdpt-combined's when it was added).
//!
//! The tolerance, 1e-5 relative, admits a different order of float operations (which moves
//! these sums by about 1e-7) but not a change in sampling, random-number use or an estimator.
//! When a change is meant to alter results, re-record: run with `STOKES_PRINT_PINS=1` and
//! paste the printed table, and say why in the commit.

use glam::Vec3;
use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

const SIZE: u32 = 24;

fn small(name: &str) -> Scene {
    let mut s = Scene::load(Path::new(&format!("scenes/{name}.json"))).unwrap();
    let c = &s.camera;
    s.camera = Camera::look_at(
        c.origin,
        c.origin + c.forward,
        c.up,
        39.3077,
        true,
        SIZE,
        SIZE,
    );
    s
}

/// XYZ summed over the four quadrants (top-left, top-right, bottom-left, bottom-right), pt-hero
/// with `lanes` wavelengths a path.
fn quadrant_sums(scene: &Scene, kind: IntegratorKind, lanes: u32) -> [Vec3; 4] {
    let opts = IntegratorOptions {
        max_depth: 6,
        lanes,
        ..Default::default()
    };
    let st = RenderSettings {
        first_sample: 0,
        spp: 4,
        seed: 5,
        threads: Some(2),
        ..Default::default()
    };
    let out = render(scene, kind, &opts, &st, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0);
    let img = out.film.xyz();
    let mut q = [Vec3::ZERO; 4];
    for y in 0..SIZE {
        for x in 0..SIZE {
            let k = (y >= SIZE / 2) as usize * 2 + (x >= SIZE / 2) as usize;
            q[k] += img[(y * SIZE + x) as usize];
        }
    }
    q
}

/// Quadrant sums as a pin table's entry (`STOKES_PRINT_PINS`).
fn pin_text(got: &[Vec3; 4]) -> String {
    let q: Vec<String> = got
        .iter()
        .map(|v| format!("[{:e}, {:e}, {:e}]", v.x, v.y, v.z))
        .collect();
    format!("[{}]", q.join(", "))
}

/// Compare quadrant sums with their pins (1e-5 relative), noting each mismatch in `failures`;
/// the number of values compared.
fn compare(got: &[Vec3; 4], want: &[[f32; 3]; 4], what: &str, failures: &mut Vec<String>) -> usize {
    let mut n = 0;
    for (g, w) in got.iter().zip(want) {
        for (a, b) in g.to_array().iter().zip(w) {
            n += 1;
            if (a - b).abs() > 1e-5 * b.abs().max(1e-3) {
                failures.push(format!("{what}: {a} vs pinned {b}"));
            }
        }
    }
    n
}

#[rustfmt::skip]
const PINS: &[(&str, &str, [[f32; 3]; 4])] = &[
    ("cornell-box", "pt-mono", [[3.9950466e1, 4.2130436e1, 2.538577e1], [2.2131037e1, 3.1219921e1, 1.1012493e1], [6.77188e0, 5.9456005e0, 6.1559324e0], [6.74998e0, 8.198614e0, 5.2791796e0]]),
    ("cornell-box", "pt-hero", [[3.382093e1, 3.0723883e1, 2.9406572e1], [2.4069996e1, 2.7063206e1, 1.6447443e1], [8.3086405e0, 7.48936e0, 5.34887e0], [7.405237e0, 9.169459e0, 5.535513e0]]),
    ("cornell-box", "bdpt-forward", [[2.9816465e1, 2.971701e1, 2.6770409e1], [2.8766901e1, 3.0802094e1, 2.6397842e1], [7.662652e0, 7.013283e0, 5.599047e0], [7.4519463e0, 9.621292e0, 5.3752756e0]]),
    ("cornell-box", "bdpt-backward", [[2.943469e1, 2.8973892e1, 2.6342342e1], [2.9620802e1, 3.1337688e1, 2.7707403e1], [8.185444e0, 7.238739e0, 5.5972404e0], [8.22382e0, 9.740555e0, 5.4888353e0]]),
    ("cornell-box", "bdpt-combined", [[2.949501e1, 2.913743e1, 2.6519695e1], [2.9022297e1, 3.0851599e1, 2.7165308e1], [7.9772525e0, 7.074781e0, 5.5230956e0], [7.7866364e0, 9.624163e0, 5.3466797e0]]),
    ("cornell-box", "bdpt-allbins", [[3.2550148e1, 3.1241165e1, 2.7950348e1], [2.5975716e1, 2.818631e1, 2.3451122e1], [9.127535e0, 8.249277e0, 6.3163557e0], [7.9044094e0, 9.448455e0, 6.2257953e0]]),
    ("fluorescent-walls", "pt-mono", [[4.8101765e-1, 4.939763e-1, 2.5150075e0], [0e0, 0e0, 0e0], [2.8931878e0, 6.3714427e-1, 1.4850355e1], [2.6012943e0, 1.2695295e-1, 1.2800732e1]]),
    ("fluorescent-walls", "pt-hero", [[2.0805752e-1, 8.365966e-1, 1.2920133e0], [6.524789e-1, 3.2557687e-1, 8.462829e-1], [2.187191e0, 1.0715219e0, 1.1593917e1], [1.9507694e0, 1.66764e-1, 9.679644e0]]),
    ("fluorescent-walls", "bdpt-forward", [[1.0044452e0, 1.8281015e0, 1.8377445e0], [6.11858e-1, 5.067744e-1, 1.1962234e0], [2.485143e0, 1.5298358e0, 1.28378935e1], [2.5737474e0, 2.9321024e-1, 1.2660582e1]]),
    ("fluorescent-walls", "bdpt-backward", [[7.0935076e-1, 1.302334e0, 1.9437807e0], [7.346433e-1, 6.430498e-1, 1.1343203e0], [2.6835003e0, 1.532856e0, 1.3872089e1], [2.69436e0, 2.3426782e-1, 1.315596e1]]),
    ("fluorescent-walls", "bdpt-combined", [[7.150628e-1, 1.310331e0, 1.9494741e0], [7.241196e-1, 6.47875e-1, 1.2240096e0], [2.6943805e0, 1.5135431e0, 1.3949245e1], [2.684595e0, 2.3718227e-1, 1.3111e1]]),
    ("fluorescent-walls", "bdpt-allbins", [[7.9222775e-1, 1.2641431e0, 1.563434e0], [5.6967443e-1, 4.3007028e-1, 9.145073e-1], [2.6627395e0, 1.5271844e0, 1.3518235e1], [2.4205136e0, 2.083891e-1, 1.1639366e1]]),
];

#[test]
fn pixel_sums_match_the_pinned_values() {
    let print = std::env::var_os("STOKES_PRINT_PINS").is_some();
    let mut failures = Vec::new();
    let mut checked = 0;
    for scene_name in ["cornell-box", "fluorescent-walls"] {
        let scene = small(scene_name);
        for kind in IntegratorKind::all() {
            // pt-hero's pins were recorded with 4 lanes, the default until 2026-12-06
            let got = quadrant_sums(&scene, kind, 4);
            if print {
                println!(
                    "    (\"{scene_name}\", \"{}\", {}),",
                    kind.name(),
                    pin_text(&got)
                );
                continue;
            }
            let pin = PINS
                .iter()
                .find(|(s, k, _)| *s == scene_name && *k == kind.name())
                .unwrap_or_else(|| panic!("no pinned value for {scene_name} {}", kind.name()));
            let what = format!("{scene_name} {}", kind.name());
            checked += compare(&got, &pin.2, &what, &mut failures);
        }
    }
    assert!(print || checked == 2 * 6 * 12, "checked {checked} values");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// pt-hero with its default lanes (8, on the generic lane array rather than `Vec4`), pinned when
/// the default changed from 4.
#[test]
fn hero_default_lanes_sums_match_the_pinned_values() {
    #[rustfmt::skip]
    const HERO8: [(&str, [[f32; 3]; 4]); 2] = [
        ("cornell-box", [[3.194583e1, 3.086253e1, 2.7138376e1], [2.5831242e1, 2.7895046e1, 2.4200508e1], [8.429104e0, 7.497089e0, 5.515273e0], [7.39592e0, 9.041126e0, 5.758504e0]]),
        ("fluorescent-walls", [[8.7001324e-1, 1.7386239e0, 2.102133e0], [5.648926e-1, 6.032165e-1, 5.8320135e-1], [2.40066e0, 1.4928963e0, 1.2648371e1], [2.3725665e0, 2.8260604e-1, 1.1160566e1]]),
    ];
    let lanes = IntegratorOptions::default().lanes;
    let print = std::env::var_os("STOKES_PRINT_PINS").is_some();
    let mut failures = Vec::new();
    for (scene_name, want) in HERO8 {
        let got = quadrant_sums(&small(scene_name), IntegratorKind::PtHero, lanes);
        if print {
            println!("        (\"{scene_name}\", {}),", pin_text(&got));
            continue;
        }
        let what = format!("{scene_name} pt-hero {lanes} lanes");
        compare(&got, &want, &what, &mut failures);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The BDPTs in a dense fluorescent medium (scenes/furnace-medium.json with σs = 4 per unit,
/// 8×8 pixels, 2 spp, depth 64: paths of about 20 segments, about 200 connections a sample).
/// Each sub-path segment's free-flight pdfs and each vertex's wavelength pdfs are remembered
/// between connections (`media::distance_pdfs`, `cache::VertexPdfMemo`); a memo that returned
/// a value for the wrong segment, vertex or wavelength would move these sums. Pinned with the
/// build before the memos (the same images to the bit).
#[test]
fn dense_medium_sums_match_the_pinned_values() {
    const DENSE: [(&str, f32); 3] = [
        ("bdpt-forward", 2.1900616e1),
        ("bdpt-backward", 2.2937962e1),
        ("bdpt-combined", 2.2143337e1),
    ];
    let path = Path::new("scenes/furnace-medium.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["media"]["fluid"]["sigma_s"] = serde_json::json!(4.0);
    v["camera"]["width"] = serde_json::json!(8);
    v["camera"]["height"] = serde_json::json!(8);
    let scene = Scene::from_str(path, &v.to_string()).unwrap();
    let opts = IntegratorOptions {
        max_depth: 64,
        ..Default::default()
    };
    let st = RenderSettings {
        spp: 2,
        seed: 5,
        threads: Some(2),
        ..Default::default()
    };
    let print = std::env::var_os("STOKES_PRINT_PINS").is_some();
    for (name, want) in DENSE {
        let kind = IntegratorKind::all()
            .into_iter()
            .find(|k| k.name() == name)
            .unwrap();
        let out = render(&scene, kind, &opts, &st, None).unwrap();
        let y: f64 = out.film.xyz().iter().map(|p| p.y as f64).sum();
        if print {
            println!("        (\"{name}\", {:e}),", y as f32);
            continue;
        }
        assert!(
            (y as f32 - want).abs() <= 1e-5 * want.abs(),
            "{name}: Y sum {y} vs pinned {want}"
        );
    }
}
