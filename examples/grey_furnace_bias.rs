//! High-precision bias measurement in a closed grey furnace (scenes/furnace-lambert.json, the
//! sphere, or another such scene named by `SCENE`, e.g. scenes/furnace-lambert-box.json): mean Y
//! over many seeds against the closed form Σ_{k<D} ρ^k Le, with its z-score.
//!
//!     [SCENE=…] [DOMAIN=lo,hi] [MAXDEPTH=d] cargo run --release --example grey_furnace_bias -- \
//!         [integrator] [seeds] [spp] [res] [lanes] [cw]

use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;
use stokes::spectrum::cie::CameraWavelengths;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let kind = match a.get(1).map(String::as_str).unwrap_or("pt-hero") {
        "pt-mono" => IntegratorKind::PtMono,
        "pt-hero" => IntegratorKind::PtHero,
        "bdpt-forward" => IntegratorKind::BdptForward,
        "bdpt-backward" => IntegratorKind::BdptBackward,
        k => panic!("unknown integrator {k}"),
    };
    let arg = |i: usize, d: u32| a.get(i).map_or(d, |s| s.parse().unwrap());
    let (seeds, spp, res, lanes) = (arg(2, 16), arg(3, 256), arg(4, 8), arg(5, 4));
    let cw = match a.get(6).map(String::as_str).unwrap_or("uniform") {
        "cmf" => CameraWavelengths::Cmf,
        _ => CameraWavelengths::Uniform,
    };
    let file = std::env::var("SCENE").unwrap_or_else(|_| "scenes/furnace-lambert.json".into());
    let text = std::fs::read_to_string(&file).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    if let Ok(d) = std::env::var("DOMAIN") {
        let d: Vec<f32> = d.split(',').map(|x| x.parse().unwrap()).collect();
        v["domain"] = serde_json::json!(d);
    }
    let mut scene = Scene::from_str(Path::new(&file), &v.to_string()).unwrap();
    let c = &scene.camera;
    scene.camera = Camera::look_at(c.origin, c.origin + c.forward, c.up, 60.0, true, res, res);
    let opts = IntegratorOptions {
        lanes,
        camera_wavelengths: cw,
        max_depth: std::env::var("MAXDEPTH").map_or(8, |v| v.parse().unwrap()),
        ..Default::default()
    };
    let exact: f64 = (0..opts.max_depth).map(|k| 0.5f64.powi(k as i32)).sum();
    let t = std::time::Instant::now();
    let per: Vec<f64> = (0..seeds as u64)
        .map(|s| {
            let settings = RenderSettings {
                first_sample: 0,
                spp,
                seed: 5000 + s,
                ..Default::default()
            };
            let out = render(&scene, kind, &opts, &settings, None).unwrap();
            assert_eq!(out.stats.nan_inf_rejected, 0);
            if std::env::var("STATS").is_ok() {
                eprintln!("{:?}", out.stats);
            }
            let n = out.film.sum.len() as f64;
            (out.film.sum.iter().map(|v| v[1]).sum::<f64>()
                + out.film.splat.iter().map(|v| v[1]).sum::<f64>())
                / (n * spp as f64)
        })
        .collect();
    let n = per.len() as f64;
    let mean = per.iter().sum::<f64>() / n;
    let var = per.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    println!(
        "{} lanes {lanes} {cw:?}: Y = {mean:.7} ± {se:.2e} (exact {exact}), rel {:+.2e} ± {:.1e}, z = {:+.2}  [{:.1} s]",
        kind.name(),
        (mean - exact) / exact,
        se / exact,
        (mean - exact) / se,
        t.elapsed().as_secs_f64()
    );
}
