//! Strategy (2, 2) alone near concave corners: bias, or a heavy tail?
//!
//! docs/bdpt.md left open why strategy (2, 2) of the BDPTs, rendered alone and unweighted, came
//! out 2–4 % low in the bottom half of cornell-box and green-spheres, up to 39 % in the 4×4-pixel
//! block at a corner. It is the one strategy of 4 vertices whose connection joins two points
//! sampled on surfaces (the camera's first hit and the light path's first hit), so its
//! contribution carries G = cos θ₁ cos θ₂ / d² unweighted. Where two walls meet, both points can
//! lie near the edge: in the model of two perpendicular planes, with both points' densities
//! bounded there, P(G > x) falls as x^(-3/2), so the estimator has a finite mean and an infinite
//! variance. A mean of N such samples is then usually below the true mean, by a fraction that
//! shrinks like N^(-1/3), and its standard error, estimated from the samples, is too small. A
//! bias (a wrong shadow-ray offset, say) would stay as N grows.
//!
//! This program renders strategies (2, 2), (1, 3) and (3, 1) alone (paths of exactly 4
//! vertices, bdpt-forward) at increasing sample counts, each level from fresh seeds, and prints
//! for the whole image and for the blocks where (2, 2) falls lowest its ratio to the mean of the
//! other two (whose connections are bounded), with its standard error over the seeds.
//!
//! `cargo run --release --example corner_tail -- [scene] [res] [seeds] [spp,spp,...]`
//! (defaults: scenes/cornell-box.json 32 24 16,64,256,1024)

use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::bdpt::{Bdpt, ResetMode};
use stokes::integrator::render::run;
use stokes::integrator::{IntegratorOptions, RenderSettings};
use stokes::scene::Scene;

/// Block size in pixels.
const B: usize = 4;

/// Per seed, the mean luminance (Y) of each B×B block and of the whole image (last entry).
fn block_means(scene: &Scene, res: usize, s: usize, t: usize, spp: u32, seed: u64) -> Vec<f64> {
    let opts = IntegratorOptions {
        max_depth: (s + t - 1) as u32,
        ..Default::default()
    };
    let b = Bdpt::new(scene, &opts, ResetMode::Forward)
        .expect("integrator")
        .single_strategy(s, t);
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed,
        ..Default::default()
    };
    let out = run(scene, &b, &settings, None).expect("render");
    let xyz = out.film.xyz();
    let nb = res / B;
    let mut m = vec![0.0f64; nb * nb + 1];
    for y in 0..res {
        for x in 0..res {
            let v = xyz[y * res + x].y as f64;
            m[(y / B) * nb + x / B] += v / (B * B) as f64;
            m[nb * nb] += v / (res * res) as f64;
        }
    }
    m
}

/// Mean and standard error over seeds, per entry.
fn mean_se(per_seed: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    let n = per_seed.len() as f64;
    let k = per_seed[0].len();
    let mean: Vec<f64> = (0..k)
        .map(|i| per_seed.iter().map(|v| v[i]).sum::<f64>() / n)
        .collect();
    let se = (0..k)
        .map(|i| {
            let var = per_seed
                .iter()
                .map(|v| (v[i] - mean[i]).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            (var / n).sqrt()
        })
        .collect();
    (mean, se)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fail = |msg: String| -> ! {
        eprintln!("error: {msg}\nusage: corner_tail [scene] [res] [seeds] [spp,spp,...]");
        std::process::exit(2)
    };
    let num = |i: usize, what: &str, default: u64| -> u64 {
        a.get(i).map_or(default, |s| {
            s.parse()
                .unwrap_or_else(|_| fail(format!("{what} '{s}': not a whole number")))
        })
    };
    let name = a.get(1).map_or("scenes/cornell-box.json", |s| s.as_str());
    let res = num(2, "res", 32) as usize;
    let seeds = num(3, "seeds", 24);
    let levels: Vec<u32> = a.get(4).map_or(vec![16, 64, 256, 1024], |s| {
        s.split(',')
            .map(|x| match x.parse() {
                Ok(n) if n > 0 => n,
                _ => fail(format!("spp '{x}' in '{s}': not a positive whole number")),
            })
            .collect()
    });
    if res < B || !res.is_multiple_of(B) || res > 4096 {
        fail(format!("res {res}: a multiple of {B} from {B} to 4096"));
    }
    if seeds < 2 {
        fail(format!(
            "seeds {seeds}: at least 2 (the standard error needs two)"
        ));
    }
    let mut scene = Scene::load(Path::new(name)).unwrap_or_else(|e| fail(e.to_string()));
    let c = scene.camera.clone();
    let fov = 2.0 * c.tan_half_x.atan().to_degrees();
    scene.camera = Camera::look_at(
        c.origin,
        c.origin + c.forward,
        c.up,
        fov,
        true,
        res as u32,
        res as u32,
    );
    let nb = res / B;
    let strategies = [(2usize, 2usize), (1, 3), (3, 1)];
    // results[level][strategy] = (mean, se) per block (+ whole image)
    let mut results = vec![];
    for (li, &spp) in levels.iter().enumerate() {
        let per: Vec<(Vec<f64>, Vec<f64>)> = strategies
            .iter()
            .map(|&(s, t)| {
                let runs: Vec<Vec<f64>> = (0..seeds)
                    .map(|i| block_means(&scene, res, s, t, spp, 1000 * li as u64 + i))
                    .collect();
                mean_se(&runs)
            })
            .collect();
        eprintln!("level {spp} spp x {seeds} seeds done");
        results.push(per);
    }
    // reference: (1, 3) and (3, 1) at the last level
    let last = results.last().expect("a level");
    let reference: Vec<f64> = (0..=nb * nb)
        .map(|i| 0.5 * (last[1].0[i] + last[2].0[i]))
        .collect();
    // the blocks where (2, 2) is lowest at the first level, among those with light
    let mut order: Vec<usize> = (0..nb * nb).filter(|&i| reference[i] > 0.0).collect();
    let ratio = |lv: usize, st: usize, i: usize| results[lv][st].0[i] / reference[i];
    order.sort_by(|&i, &j| ratio(0, 0, i).total_cmp(&ratio(0, 0, j)));
    let shown: Vec<usize> = std::iter::once(nb * nb)
        .chain(order.iter().copied().take(4))
        .collect();
    println!(
        "{name} {res}x{res}, strategies alone (paths of 4 vertices), {seeds} seeds a level; \
         ratio to the mean of (1, 3) and (3, 1) at {} spp; ± one standard error over seeds",
        levels.last().expect("a level")
    );
    for &i in &shown {
        let label = if i == nb * nb {
            "whole image".to_string()
        } else {
            format!(
                "block x {}..{}, y {}..{}",
                (i % nb) * B,
                (i % nb) * B + B,
                (i / nb) * B,
                (i / nb) * B + B
            )
        };
        println!("{label}:");
        for (lv, spp) in levels.iter().enumerate() {
            let row: Vec<String> = strategies
                .iter()
                .enumerate()
                .map(|(st, (s, t))| {
                    let (m, se) = (&results[lv][st].0, &results[lv][st].1);
                    format!(
                        "({s}, {t}) {:.3} ± {:.3}",
                        m[i] / reference[i],
                        se[i] / reference[i]
                    )
                })
                .collect();
            println!("  {:>6} spp: {}", spp, row.join("   "));
        }
    }
}
