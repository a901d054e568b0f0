//! `stokes gmm robustness`: how much the colour of an EM fit depends on its seed, with one
//! k-means++ start and with several (`--restarts`), and which number of Gaussians BIC chooses
//! (Hua §5.2) against the number at which ΔE00 stops improving.
//!
//! The measure is the one of `stokes gmm eval`: the mean ΔE00 under the CIE illuminants of the
//! fitted matrix against the measured (cleaned) one. For each matrix of a folder, each K and
//! each seed 0..n, the fit is made with one start and with `restarts` starts; a matrix's spread
//! at K is max − min of its ΔE00 over the seeds (and their standard deviation, n − 1). For the
//! choice of K, the matrix is fitted with K = 1..=max (seed 0, `restarts` starts): BIC's K is
//! the one of smallest BIC ([`crate::material::mixture::select`]); the K where ΔE00 stops
//! improving is the smallest K whose ΔE00 is within [`PLATEAU_ABS`] or [`PLATEAU_REL`] of the
//! best over K = 1..=max, whichever is looser.
//!
//! Outputs (in `-o`): `spread.csv` (one row per material, K and number of starts: ΔE00 per
//! seed, min, max, spread, std), `bic.csv` (one row per material: positive cells, BIC and ΔE00
//! per K, BIC's K, the plateau K), `summary.json` and `summary.md` (the tables of
//! results/README.md).

use super::colour::{LightKind, compare};
use super::inputs::{Illuminant, embedded_illuminants, load_illuminants, load_matrices};
use super::summary::{Stats, stats};
use crate::Error;
use crate::material::mixture::{FitMethod, FitOptions, GmmFile, fit_matrix, select};
use crate::material::reradiation::BfcMatrix;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Where `stokes gmm robustness` writes by default.
pub const DEFAULT_OUT: &str = "results/gmm-robust";

/// ΔE00 within this of the best over K counts as no longer improving…
pub const PLATEAU_ABS: f64 = 0.1;
/// …or within this fraction of the best, whichever is looser.
pub const PLATEAU_REL: f64 = 0.1;

/// What to measure.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    /// Numbers of Gaussians of the seed spread.
    pub components: Vec<usize>,
    /// Seeds 0..seeds.
    pub seeds: u64,
    /// Starts of the robust fits (the other fits use one).
    pub restarts: usize,
    /// BIC chooses among 1..=max_components.
    pub max_components: usize,
}

/// The mean ΔE00 of a model's matrix against `measured` under the CIE illuminants of `ill`.
pub fn cie_mean_de00(
    measured: &BfcMatrix,
    model: &GmmFile,
    ill: &[Illuminant],
) -> Result<f64, String> {
    let c = compare(measured, &model.to_matrix(), ill)?;
    let cie: Vec<f64> = c
        .iter()
        .filter(|c| c.kind == LightKind::Cie)
        .map(|c| c.de00)
        .collect();
    if cie.is_empty() {
        return Err("no CIE illuminant to compare under".into());
    }
    Ok(cie.iter().sum::<f64>() / cie.len() as f64)
}

/// One matrix's results.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialResult {
    pub material: String,
    /// Per K of [`Settings::components`]: ΔE00 per seed with one start (`[0]`) and with
    /// `restarts` starts (`[1]`).
    pub de: Vec<[Vec<f64>; 2]>,
    /// Positive off-diagonal cells (BIC's n).
    pub cells: usize,
    /// BIC and ΔE00 of K = 1..=max (seed 0, `restarts` starts).
    pub bic: Vec<f64>,
    pub de_by_k: Vec<f64>,
    /// BIC's K and the K where ΔE00 stops improving.
    pub bic_k: usize,
    pub plateau_k: usize,
}

/// The smallest K (1-based) whose ΔE00 is within the plateau tolerance of the best.
pub fn plateau_k(de_by_k: &[f64]) -> usize {
    let best = de_by_k.iter().cloned().fold(f64::INFINITY, f64::min);
    let tol = PLATEAU_ABS.max(PLATEAU_REL * best);
    de_by_k.iter().position(|&d| d <= best + tol).unwrap_or(0) + 1
}

/// The smallest K (1-based) of smallest BIC.
fn argmin_k(bic: &[f64]) -> usize {
    let mut k = 0;
    for (j, b) in bic.iter().enumerate() {
        if *b < bic[k] {
            k = j;
        }
    }
    k + 1
}

fn options(k: usize, seed: u64, restarts: usize) -> FitOptions {
    let mut o = FitOptions::new(k, FitMethod::Em, seed);
    o.restarts = restarts;
    o
}

/// Every fit of one matrix.
fn one_material(
    name: &str,
    m: &BfcMatrix,
    s: &Settings,
    ill: &[Illuminant],
) -> Result<MaterialResult, String> {
    let de = |o: &FitOptions| -> Result<(f64, GmmFile), String> {
        let f = fit_matrix(m, o)
            .map_err(|e| format!("{} components, seed {}: {e}", o.components, o.seed))?;
        Ok((cie_mean_de00(m, &f, ill)?, f))
    };
    let mut per_k = Vec::with_capacity(s.components.len());
    for &k in &s.components {
        let mut two: [Vec<f64>; 2] = Default::default();
        for (j, restarts) in [1, s.restarts].into_iter().enumerate() {
            for seed in 0..s.seeds {
                two[j].push(de(&options(k, seed, restarts))?.0);
            }
        }
        per_k.push(two);
    }
    let data = crate::material::mixture::fit::points(m);
    let cells = data.w.len();
    let (mut bic, mut de_by_k) = (Vec::new(), Vec::new());
    for k in 1..=s.max_components {
        let (d, f) = de(&options(k, 0, s.restarts))?;
        bic.push(select::bic(f.fit.log_likelihood, cells, f.components.len()));
        de_by_k.push(d);
    }
    Ok(MaterialResult {
        material: name.to_string(),
        de: per_k,
        cells,
        bic_k: argmin_k(&bic),
        plateau_k: plateau_k(&de_by_k),
        bic,
        de_by_k,
    })
}

/// Spread of ΔE00 over the seeds at one K and number of starts.
#[derive(Clone, Debug, Serialize)]
pub struct SpreadSummary {
    pub components: usize,
    pub restarts: usize,
    /// Of the per-matrix spread max − min over the seeds.
    pub spread: Stats,
    /// Mean over the matrices of the standard deviation over the seeds.
    pub std_mean: f64,
    /// The mean over the matrices of ΔE00, per seed.
    pub seed_means: Vec<f64>,
    /// The five matrices with the largest spread, largest first.
    pub widest: Vec<(String, f64)>,
}

/// BIC's choice against where ΔE00 stops improving.
#[derive(Clone, Debug, Serialize)]
pub struct BicSummary {
    pub max_components: usize,
    pub restarts: usize,
    /// How many matrices BIC gives K = 1, 2, …, max.
    pub bic_k_counts: Vec<usize>,
    /// How many matrices stop improving at K = 1, 2, …, max.
    pub plateau_k_counts: Vec<usize>,
    /// Matrices where BIC's K is equal to, below and above the plateau K.
    pub equal: usize,
    pub below: usize,
    pub above: usize,
    /// Mean ΔE00 over the matrices at BIC's K, at the plateau K and at K = max.
    pub de_at_bic_k: f64,
    pub de_at_plateau_k: f64,
    pub de_at_max: f64,
    /// Mean BIC's K and mean plateau K.
    pub mean_bic_k: f64,
    pub mean_plateau_k: f64,
}

/// What `summary.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub settings: Settings,
    pub materials: usize,
    pub illuminants: usize,
    pub spread: Vec<SpreadSummary>,
    pub bic: BicSummary,
    /// Wall time, seconds.
    pub seconds: f64,
    pub outputs: Vec<PathBuf>,
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Sample standard deviation (n − 1; 0 for fewer than two values).
fn std_dev(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = mean(v);
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        })
}

fn spread_summaries(s: &Settings, rs: &[MaterialResult]) -> Vec<SpreadSummary> {
    let mut out = Vec::new();
    for (j, &k) in s.components.iter().enumerate() {
        for (t, restarts) in [1, s.restarts].into_iter().enumerate() {
            let spreads: Vec<f64> = rs
                .iter()
                .map(|r| {
                    let (a, b) = min_max(&r.de[j][t]);
                    b - a
                })
                .collect();
            let stds: Vec<f64> = rs.iter().map(|r| std_dev(&r.de[j][t])).collect();
            let seed_means = (0..s.seeds as usize)
                .map(|seed| mean(&rs.iter().map(|r| r.de[j][t][seed]).collect::<Vec<_>>()))
                .collect();
            let mut widest: Vec<(String, f64)> = rs
                .iter()
                .zip(&spreads)
                .map(|(r, &x)| (r.material.clone(), x))
                .collect();
            widest.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
            widest.truncate(5);
            out.push(SpreadSummary {
                components: k,
                restarts,
                spread: stats(&spreads).unwrap_or(Stats {
                    n: 0,
                    mean: f64::NAN,
                    median: f64::NAN,
                    p95: f64::NAN,
                    max: f64::NAN,
                }),
                std_mean: mean(&stds),
                seed_means,
                widest,
            });
        }
    }
    out
}

fn bic_summary(s: &Settings, rs: &[MaterialResult]) -> BicSummary {
    let max = s.max_components;
    let counts = |f: &dyn Fn(&MaterialResult) -> usize| -> Vec<usize> {
        (1..=max)
            .map(|k| rs.iter().filter(|r| f(r) == k).count())
            .collect()
    };
    let at = |f: &dyn Fn(&MaterialResult) -> usize| -> f64 {
        mean(&rs.iter().map(|r| r.de_by_k[f(r) - 1]).collect::<Vec<_>>())
    };
    let ks = |f: &dyn Fn(&MaterialResult) -> usize| -> f64 {
        mean(&rs.iter().map(|r| f(r) as f64).collect::<Vec<_>>())
    };
    BicSummary {
        max_components: max,
        restarts: s.restarts,
        bic_k_counts: counts(&|r| r.bic_k),
        plateau_k_counts: counts(&|r| r.plateau_k),
        equal: rs.iter().filter(|r| r.bic_k == r.plateau_k).count(),
        below: rs.iter().filter(|r| r.bic_k < r.plateau_k).count(),
        above: rs.iter().filter(|r| r.bic_k > r.plateau_k).count(),
        de_at_bic_k: at(&|r| r.bic_k),
        de_at_plateau_k: at(&|r| r.plateau_k),
        de_at_max: at(&|_| max),
        mean_bic_k: ks(&|r| r.bic_k),
        mean_plateau_k: ks(&|r| r.plateau_k),
    }
}

/// Check the settings, fit every `*.BFC` matrix of `dir` (in parallel, under a progress bar)
/// and write the outputs into `out`.
pub fn robustness(
    dir: &Path,
    s: &Settings,
    out: &Path,
    illuminants_dir: Option<&Path>,
) -> Result<Report, Error> {
    let max = crate::material::mixture::conditional::MAX_COMPONENTS;
    if s.components.is_empty() || s.components.iter().any(|&k| k == 0 || k > max) {
        return Err(Error::input(format!(
            "--components: {:?}: each must be in 1..={max}",
            s.components
        )));
    }
    if s.max_components == 0 || s.max_components > max {
        return Err(Error::input(format!(
            "--max-components: {} is not in 1..={max}",
            s.max_components
        )));
    }
    if s.seeds == 0 || s.seeds > 1000 {
        return Err(Error::input(format!(
            "--seeds: {} is not in 1..=1000",
            s.seeds
        )));
    }
    options(1, 0, s.restarts)
        .check()
        .map_err(|e| Error::input(format!("--{e}")))?;
    let ill = match illuminants_dir {
        Some(d) => load_illuminants(d)?,
        None => embedded_illuminants()?,
    };
    let materials = load_matrices(dir)?;
    std::fs::create_dir_all(out)
        .map_err(|e| format!("cannot create the folder: {e}"))
        .and_then(|()| crate::io::output::check_folder(out))
        .map_err(|e| Error::input(format!("-o/--output '{}': {e}", out.display())))?;
    let start = std::time::Instant::now();
    let bar = crate::experiment::progress::bar(materials.len() as u64);
    let rs: Vec<MaterialResult> = materials
        .par_iter()
        .map(|(path, name, m)| {
            let r = one_material(name, m, s, &ill)
                .map_err(|e| Error::runtime(format!("{}: {e}", path.display())));
            bar.inc(1);
            r
        })
        .collect::<Result<_, Error>>()?;
    bar.finish_and_clear();
    let mut report = Report {
        settings: s.clone(),
        materials: rs.len(),
        illuminants: ill.len(),
        spread: spread_summaries(s, &rs),
        bic: bic_summary(s, &rs),
        seconds: start.elapsed().as_secs_f64(),
        outputs: Vec::new(),
    };
    write_outputs(out, s, &rs, &mut report).map_err(Error::runtime)?;
    Ok(report)
}

fn write(path: PathBuf, text: &str, report: &mut Report) -> Result<(), String> {
    crate::io::output::write_bytes(&path, text.as_bytes())?;
    report.outputs.push(path);
    Ok(())
}

fn write_outputs(
    out: &Path,
    s: &Settings,
    rs: &[MaterialResult],
    report: &mut Report,
) -> Result<(), String> {
    let mut csv = String::from("material,components,restarts");
    for seed in 0..s.seeds {
        csv.push_str(&format!(",seed{seed}"));
    }
    csv.push_str(",min,max,spread,std\n");
    for r in rs {
        for (j, &k) in s.components.iter().enumerate() {
            for (t, restarts) in [1, s.restarts].into_iter().enumerate() {
                let v = &r.de[j][t];
                let (a, b) = min_max(v);
                csv.push_str(&format!("{},{k},{restarts}", r.material));
                for x in v {
                    csv.push_str(&format!(",{x:.4}"));
                }
                csv.push_str(&format!(",{a:.4},{b:.4},{:.4},{:.4}\n", b - a, std_dev(v)));
            }
        }
    }
    write(out.join("spread.csv"), &csv, report)?;
    let mut csv = String::from("material,cells");
    for k in 1..=s.max_components {
        csv.push_str(&format!(",bic{k}"));
    }
    for k in 1..=s.max_components {
        csv.push_str(&format!(",de{k}"));
    }
    csv.push_str(",bic_k,plateau_k\n");
    for r in rs {
        csv.push_str(&format!("{},{}", r.material, r.cells));
        for b in &r.bic {
            csv.push_str(&format!(",{b:.2}"));
        }
        for d in &r.de_by_k {
            csv.push_str(&format!(",{d:.4}"));
        }
        csv.push_str(&format!(",{},{}\n", r.bic_k, r.plateau_k));
    }
    write(out.join("bic.csv"), &csv, report)?;
    let md = markdown(report);
    write(out.join("summary.md"), &md, report)?;
    let path = out.join("summary.json");
    report.outputs.push(path.clone());
    let json = serde_json::to_string_pretty(report).map_err(|e| format!("summary: {e}"))?;
    crate::io::output::write_bytes(&path, (json + "\n").as_bytes())
}

/// The tables of `summary.md`.
pub fn markdown(r: &Report) -> String {
    let s = &r.settings;
    let mut t = format!(
        "Spread of the mean ΔE00 under the CIE illuminants over seeds 0–{}, {} matrices \
         (EM):\n\n| K | starts | spread mean | median | max | std mean | 144-mean ΔE00 over \
         the seeds (min–max) | widest |\n|---|---|---|---|---|---|---|---|\n",
        s.seeds - 1,
        r.materials
    )
    .replace("144-mean", &format!("{}-mean", r.materials));
    for x in &r.spread {
        let (a, b) = min_max(&x.seed_means);
        t.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {a:.3}–{b:.3} | {} |\n",
            x.components,
            x.restarts,
            x.spread.mean,
            x.spread.median,
            x.spread.max,
            x.std_mean,
            x.widest
                .iter()
                .take(3)
                .map(|(m, v)| format!("{m} {v:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let b = &r.bic;
    let counts = |v: &[usize]| {
        v.iter()
            .enumerate()
            .filter(|(_, n)| **n > 0)
            .map(|(k, n)| format!("K={}: {n}", k + 1))
            .collect::<Vec<_>>()
            .join(", ")
    };
    t.push_str(&format!(
        "\nThe number of Gaussians, K = 1..={} (seed 0, {} starts): BIC's K against the \
         smallest K whose ΔE00 is within {PLATEAU_ABS} or {:.0} % of the best.\n\n\
         | | mean K | matrices per K | mean ΔE00 there |\n|---|---|---|---|\n\
         | BIC | {:.2} | {} | {:.3} |\n| ΔE00 plateau | {:.2} | {} | {:.3} |\n\
         | K = {} | | | {:.3} |\n\nBIC's K equals the plateau K for {} matrices, is below it \
         for {} and above it for {}.\n",
        b.max_components,
        b.restarts,
        100.0 * PLATEAU_REL,
        b.mean_bic_k,
        counts(&b.bic_k_counts),
        b.de_at_bic_k,
        b.mean_plateau_k,
        counts(&b.plateau_k_counts),
        b.de_at_plateau_k,
        b.max_components,
        b.de_at_max,
        b.equal,
        b.below,
        b.above
    ));
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateau_and_bic_choices() {
        // Best 0.30 at K = 4: K = 3 (0.38) is within 0.1, K = 2 (0.45) is not.
        assert_eq!(plateau_k(&[2.0, 0.45, 0.38, 0.30, 0.31]), 3);
        // Relative tolerance for large ΔE00: best 3.0, 10 % = 0.3.
        assert_eq!(plateau_k(&[5.0, 3.25, 3.0]), 2);
        assert_eq!(plateau_k(&[0.2]), 1);
        assert_eq!(argmin_k(&[10.0, 4.0, 4.0, 5.0]), 2);
        assert!((std_dev(&[1.0, 3.0]) - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(std_dev(&[1.0]), 0.0);
    }

    /// Two RIT matrices, K = 2, three seeds, BIC up to 3: one row per material, K and
    /// number of starts; the spreads are max − min of the seeds; BIC's K matches a fit with
    /// `auto_components`; the summary counts every matrix once.
    #[test]
    fn a_small_report() {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        let dir = std::env::temp_dir().join(format!("stokes-gmm-robust-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for f in ["GOLFYE.BFC", "INCWHITE.BFC"] {
            std::fs::copy(root.join("data/bispectral").join(f), dir.join(f)).unwrap();
        }
        let s = Settings {
            components: vec![2],
            seeds: 3,
            restarts: 2,
            max_components: 3,
        };
        let out = dir.join("out");
        let r = robustness(&dir, &s, &out, None).unwrap();
        assert_eq!(r.materials, 2);
        assert_eq!(r.spread.len(), 2);
        assert_eq!((r.spread[0].restarts, r.spread[1].restarts), (1, 2));
        let csv = std::fs::read_to_string(out.join("spread.csv")).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 1 + 2 * 2);
        for l in &lines[1..] {
            let v: Vec<f64> = l.split(',').skip(3).map(|x| x.parse().unwrap()).collect();
            let (a, b) = min_max(&v[..3]);
            assert!((v[3] - a).abs() < 1e-4 && (v[4] - b).abs() < 1e-4, "{l}");
            assert!((v[5] - (b - a)).abs() < 2e-4, "{l}");
        }
        let b = &r.bic;
        assert_eq!(b.bic_k_counts.iter().sum::<usize>(), 2);
        assert_eq!(b.equal + b.below + b.above, 2);
        let bic = std::fs::read_to_string(out.join("bic.csv")).unwrap();
        let golfye = bic.lines().find(|l| l.starts_with("GOLFYE,")).unwrap();
        let bic_k: usize = golfye.split(',').nth(8).unwrap().parse().unwrap();
        let m = BfcMatrix::parse(include_str!("../../data/bispectral/GOLFYE.BFC")).unwrap();
        let mut o = options(3, 0, 2);
        o.auto_components = true;
        let f = fit_matrix(&m, &o).unwrap();
        assert_eq!(f.components.len(), bic_k, "{:?} vs {golfye}", f.fit.bic);
        for f in ["summary.json", "summary.md"] {
            assert!(out.join(f).is_file(), "{f}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
