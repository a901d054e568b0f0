//! Pinned pixel sums of small fixed-seed renders, so that a refactor that changes what an
//! integrator computes is caught. Every integrator renders a 24×24 crop of the Cornell box and
//! of the fluorescent walls (4 spp, seed 5, 2 threads) and the sum of XYZ over each image
//! quadrant is compared with the value recorded when the transport layer was introduced.
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

/// XYZ summed over the four quadrants (top-left, top-right, bottom-left, bottom-right).
fn quadrant_sums(scene: &Scene, kind: IntegratorKind) -> [Vec3; 4] {
    let opts = IntegratorOptions {
        max_depth: 6,
        ..Default::default()
    };
    let st = RenderSettings {
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

#[rustfmt::skip]
const PINS: &[(&str, &str, [[f32; 3]; 4])] = &[
    ("cornell-box", "pt-mono", [[3.995228e1, 4.2132484e1, 2.5387169e1], [2.215933e1, 3.1243837e1, 1.101303e1], [6.772004e0, 5.945678e0, 6.1558795e0], [6.7501655e0, 8.198777e0, 5.2793264e0]]),
    ("cornell-box", "pt-hero", [[3.3822372e1, 3.0725136e1, 2.9407597e1], [2.4062975e1, 2.7057098e1, 1.6454933e1], [8.309038e0, 7.489602e0, 5.348878e0], [7.3941517e0, 9.156634e0, 5.5334597e0]]),
    ("cornell-box", "bdpt-forward", [[2.9812305e1, 2.971067e1, 2.6769253e1], [2.8844389e1, 3.082963e1, 2.6330353e1], [7.661963e0, 7.015808e0, 5.5983152e0], [7.4471493e0, 9.616313e0, 5.375237e0]]),
    ("cornell-box", "bdpt-backward", [[2.943109e1, 2.8970354e1, 2.63412e1], [2.9731361e1, 3.1397282e1, 2.7709223e1], [8.163738e0, 7.226555e0, 5.568016e0], [8.222392e0, 9.751471e0, 5.4900117e0]]),
    ("cornell-box", "bdpt-allbins", [[3.2551414e1, 3.124249e1, 2.7951633e1], [2.5976969e1, 2.8188074e1, 2.345191e1], [9.130526e0, 8.253041e0, 6.317902e0], [7.9019656e0, 9.44615e0, 6.2232165e0]]),
    ("fluorescent-walls", "pt-mono", [[4.809743e-1, 4.9404848e-1, 2.5148156e0], [0e0, 0e0, 0e0], [2.8932292e0, 6.371666e-1, 1.4850586e1], [2.6013196e0, 1.2695433e-1, 1.2800856e1]]),
    ("fluorescent-walls", "pt-hero", [[2.0804614e-1, 8.366332e-1, 1.2919779e0], [6.525237e-1, 3.256013e-1, 8.463267e-1], [2.187286e0, 1.0716109e0, 1.159444e1], [1.9508078e0, 1.6675913e-1, 9.67982e0]]),
    ("fluorescent-walls", "bdpt-forward", [[9.9964964e-1, 1.8211468e0, 1.8366946e0], [6.146873e-1, 5.102125e-1, 1.1959016e0], [2.48448e0, 1.5280324e0, 1.2834356e1], [2.573625e0, 2.9301766e-1, 1.2659834e1]]),
    ("fluorescent-walls", "bdpt-backward", [[7.090611e-1, 1.3018669e0, 1.9432915e0], [7.426435e-1, 6.4929575e-1, 1.128179e0], [2.6829093e0, 1.5322292e0, 1.3869204e1], [2.6927407e0, 2.3413178e-1, 1.3148171e1]]),
    ("fluorescent-walls", "bdpt-allbins", [[7.923353e-1, 1.26429e0, 1.5635511e0], [5.698426e-1, 4.3021828e-1, 9.1457677e-1], [2.666403e0, 1.5274395e0, 1.3536161e1], [2.4174294e0, 2.0835777e-1, 1.16243105e1]]),
];

#[test]
fn pixel_sums_match_the_pinned_values() {
    let print = std::env::var_os("STOKES_PRINT_PINS").is_some();
    let mut failures = Vec::new();
    let mut checked = 0;
    for scene_name in ["cornell-box", "fluorescent-walls"] {
        let scene = small(scene_name);
        for kind in IntegratorKind::all() {
            let got = quadrant_sums(&scene, kind);
            if print {
                let q: Vec<String> = got
                    .iter()
                    .map(|v| format!("[{:e}, {:e}, {:e}]", v.x, v.y, v.z))
                    .collect();
                println!(
                    "    (\"{scene_name}\", \"{}\", [{}]),",
                    kind.name(),
                    q.join(", ")
                );
                continue;
            }
            let pin = PINS
                .iter()
                .find(|(s, k, _)| *s == scene_name && *k == kind.name())
                .unwrap_or_else(|| panic!("no pinned value for {scene_name} {}", kind.name()));
            for (g, want) in got.iter().zip(pin.2) {
                for (a, b) in g.to_array().iter().zip(want) {
                    checked += 1;
                    if (a - b).abs() > 1e-5 * b.abs().max(1e-3) {
                        failures.push(format!("{scene_name} {}: {a} vs pinned {b}", kind.name()));
                    }
                }
            }
        }
    }
    assert!(print || checked == 2 * 5 * 12, "checked {checked} values");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
