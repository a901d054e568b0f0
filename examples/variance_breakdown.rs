//! Where an estimator's variance comes from, by camera wavelength: renders a scene many times
//! with different seeds, each with a spectral image, and reports per wavelength bin the mean
//! radiance and the variance of one render (per pixel, averaged over the pixels), for pt-mono and
//! pt-hero with exponential and fluorescence-aware tracking. Made for Mojzík Fig. 18's reversal
//! at σa = 0.2 (results/REPRODUCTION.md).
//!
//!     cargo run --release --example variance_breakdown -- SCENE [--set PATH=JSON]... \
//!         [--spp 128] [--seeds 8] [--bins 8] [--size 64] [--csv OUT.csv]

use std::path::PathBuf;
use stokes::experiment::overrides::{Missing, apply};
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::medium::Tracking;
use stokes::scene::Scene;

struct Args {
    scene: PathBuf,
    sets: Vec<(String, serde_json::Value)>,
    spp: u32,
    seeds: u64,
    bins: usize,
    size: u32,
    csv: Option<PathBuf>,
}

fn args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut a = Args {
        scene: it
            .next()
            .ok_or("usage: variance_breakdown SCENE [options]")?
            .into(),
        sets: Vec::new(),
        spp: 128,
        seeds: 8,
        bins: 8,
        size: 64,
        csv: None,
    };
    while let Some(k) = it.next() {
        let v = it.next().ok_or(format!("{k} needs a value"))?;
        let num = |v: &str| v.parse::<u64>().map_err(|e| format!("{k} {v}: {e}"));
        match k.as_str() {
            // the same PATH=JSON syntax and checks as `stokes render --set`
            "--set" => a
                .sets
                .extend(stokes::cli::parse_sets(&[v]).map_err(|e| e.to_string())?),
            "--spp" => a.spp = num(&v)? as u32,
            "--seeds" => a.seeds = num(&v)?,
            "--bins" => a.bins = num(&v)? as usize,
            "--size" => a.size = num(&v)? as u32,
            "--csv" => a.csv = Some(v.into()),
            _ => return Err(format!("unknown option {k}")),
        }
    }
    Ok(a)
}

/// Per pixel and bin: Σ x and Σ x² over the seeds; and the same for luminance Y.
struct Moments {
    s: Vec<f64>,
    s2: Vec<f64>,
    y: Vec<f64>,
    y2: Vec<f64>,
    seconds: f64,
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let a = args()?;
    let text = std::fs::read_to_string(&a.scene)
        .map_err(|e| format!("cannot read '{}': {e}", a.scene.display()))?;
    let mut sets = a.sets.clone();
    sets.push(("camera.width".into(), a.size.into()));
    sets.push(("camera.height".into(), a.size.into()));
    let text = apply(&text, &a.scene, &sets, Missing::Insert)?;
    let scene = Scene::from_str(&a.scene, &text).map_err(|e| e.to_string())?;
    let configs = [
        (IntegratorKind::PtMono, Tracking::Exponential),
        (IntegratorKind::PtMono, Tracking::Aware),
        (IntegratorKind::PtHero, Tracking::Exponential),
        (IntegratorKind::PtHero, Tracking::Aware),
    ];
    let mut results = Vec::new();
    let mut bins = None;
    for (kind, tracking) in configs {
        // pt-hero with Mojzík's 4 wavelengths a path (the default is 8)
        let opts = IntegratorOptions {
            tracking,
            lanes: 4,
            ..Default::default()
        };
        let mut m: Option<Moments> = None;
        for seed in 0..a.seeds {
            let settings = RenderSettings {
                spp: a.spp,
                seed: 7000 + seed,
                spectral: Some(a.bins),
                ..Default::default()
            };
            let out = render(&scene, kind, &opts, &settings, None)?;
            let sf = out.film.spectral.as_ref().ok_or("no spectral film")?;
            bins = Some(sf.bins);
            let v = sf.values(out.film.spp);
            let y: Vec<f64> = out.film.xyz().iter().map(|c| c.y as f64).collect();
            let m = m.get_or_insert_with(|| Moments {
                s: vec![0.0; v.len()],
                s2: vec![0.0; v.len()],
                y: vec![0.0; y.len()],
                y2: vec![0.0; y.len()],
                seconds: 0.0,
            });
            for (i, x) in v.iter().enumerate() {
                m.s[i] += *x as f64;
                m.s2[i] += (*x as f64).powi(2);
            }
            for (i, x) in y.iter().enumerate() {
                m.y[i] += x;
                m.y2[i] += x * x;
            }
            m.seconds += out.seconds;
        }
        results.push(((kind, tracking), m.unwrap()));
    }
    let bins = bins.unwrap();
    let n = a.seeds as f64;
    // variance of one render from the seeds' sample variance
    let var = |s: f64, s2: f64| ((s2 - s * s / n) / (n - 1.0)).max(0.0);
    let label = |(k, t): (IntegratorKind, Tracking)| format!("{} {t:?}", k.name()).to_lowercase();
    println!(
        "{} spp, {} seeds, {}x{} pixels, {} bins over [{}, {}] nm",
        a.spp, a.seeds, a.size, a.size, bins.n, bins.min, bins.max
    );
    let mut csv = String::from("integrator,tracking,bin_centre_nm,mean_radiance,variance\n");
    print!("| bin (nm) | mean L |");
    for (c, _) in &results {
        print!(" var {} |", label(*c));
    }
    println!();
    println!("|---|---|{}", "---|".repeat(results.len()));
    let px = (a.size * a.size) as usize;
    for b in 0..bins.n {
        let mean = (0..px).map(|p| results[0].1.s[p * bins.n + b]).sum::<f64>() / (n * px as f64);
        print!("| {:.0} | {mean:.4} |", bins.centre(b));
        for ((kind, tracking), m) in &results {
            let v = (0..px)
                .map(|p| var(m.s[p * bins.n + b], m.s2[p * bins.n + b]))
                .sum::<f64>()
                / px as f64;
            print!(" {v:.3e} |");
            csv += &format!(
                "{},{tracking:?},{:.1},{mean:.6},{v:.6e}\n",
                kind.name(),
                bins.centre(b)
            );
        }
        println!();
    }
    print!("| luminance Y | |");
    for ((kind, tracking), m) in &results {
        let v = (0..px).map(|p| var(m.y[p], m.y2[p])).sum::<f64>() / px as f64;
        print!(" {v:.3e} |");
        csv += &format!("{},{tracking:?},Y,,{v:.6e}\n", kind.name());
    }
    println!();
    print!("| seconds per render | |");
    for (_, m) in &results {
        print!(" {:.3} |", m.seconds / n);
    }
    println!();
    if let Some(p) = &a.csv {
        std::fs::write(p, csv).map_err(|e| format!("cannot write '{}': {e}", p.display()))?;
    }
    Ok(())
}
