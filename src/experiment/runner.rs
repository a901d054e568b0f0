//! Runs an experiment config: reference (rendered and cached, or loaded), every variant at every
//! snapshot and repeat, metrics per region, and the stored results the figures are built from.

use super::config::{BudgetMode, Config, RegionBy, resolve};
use super::metrics::{self, ErrorMetrics};
use super::record::{
    GridCell, ModeBudgets, Row, RunInfo, SummaryEntry, image_file, metrics_csv, summarize,
};
use crate::error::Error;
use crate::film::output::{read_exr, write_atomic, write_exr};
use crate::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use crate::scene::Scene;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// UTC time as `YYYYMMDD-HHMMSS`.
pub fn timestamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0) as i64;
    let (days, rem) = (secs.div_euclid(86400), secs.rem_euclid(86400));
    // Civil from days (H. Hinnant).
    let z = days + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    format!(
        "{y:04}{m:02}{d:02}-{:02}{:02}{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// FNV-1a, stable across builds (for the reference cache key).
fn fnv1a(parts: &[&[u8]]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in parts {
        for b in p.iter().chain(&[0xffu8]) {
            h ^= *b as u64;
            h = h.wrapping_mul(0x100_0000_01b3);
        }
    }
    h
}

/// Resolution used by `--quick`: at most 64×48, keeping the aspect ratio.
pub fn quick_size(w: u32, h: u32) -> (u32, u32) {
    let s = (64.0 / w as f64).min(48.0 / h as f64).min(1.0);
    (
        ((w as f64 * s).round() as u32).max(1),
        ((h as f64 * s).round() as u32).max(1),
    )
}

fn resize_camera(scene: &mut Scene, w: u32, h: u32) {
    scene.camera.width = w;
    scene.camera.height = h;
}

/// Nearest-neighbour resample (for an EXR reference at another resolution under `--quick`).
fn resample(px: &[Vec3], w: u32, h: u32, nw: u32, nh: u32) -> Vec<Vec3> {
    let mut out = Vec::with_capacity((nw * nh) as usize);
    for y in 0..nh {
        for x in 0..nw {
            let sx = ((x as f64 + 0.5) * w as f64 / nw as f64) as u32;
            let sy = ((y as f64 + 0.5) * h as f64 / nh as f64) as u32;
            out.push(px[(sy.min(h - 1) * w + sx.min(w - 1)) as usize]);
        }
    }
    out
}

/// Region of each pixel (index into `names`), from a primary ray through the pixel centre.
pub fn region_ids(scene: &Scene, by: RegionBy) -> (Vec<String>, Vec<Option<u16>>) {
    let names: Vec<String> = match by {
        RegionBy::Material => scene.material_names.clone(),
        RegionBy::Shape => scene.shapes.iter().map(|s| s.name.clone()).collect(),
    };
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut ids = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let ray = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
            let id = scene.intersect(&ray, f32::INFINITY).map(|hit| {
                let p = scene.prims[hit.prim as usize];
                match by {
                    RegionBy::Material => p.material as u16,
                    RegionBy::Shape => p.shape as u16,
                }
            });
            ids.push(id.filter(|&i| (i as usize) < names.len()));
        }
    }
    (names, ids)
}

struct Progress {
    bar: indicatif::ProgressBar,
}

impl Progress {
    fn new(total: u64) -> Self {
        let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            let b = indicatif::ProgressBar::new(total);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {percent:>3}%  eta {eta}  {msg}",
                )
                .unwrap()
                .progress_chars("=> "),
            );
            b
        } else {
            indicatif::ProgressBar::hidden()
        };
        Progress { bar }
    }
}

fn mkdir(p: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(p)
        .map_err(|e| Error::runtime(format!("cannot create folder '{}': {e}", p.display())))
}

fn write_text(p: &Path, text: &str) -> Result<(), Error> {
    write_atomic(p, |tmp| {
        std::fs::write(tmp, text).map_err(|e| format!("cannot write '{}': {e}", p.display()))
    })
    .map_err(Error::runtime)
}

/// Create a new, empty run folder under `<root>/<name>/runs/`; never reuses an existing one.
fn new_run_dir(root: &Path, name: &str) -> Result<(PathBuf, String), Error> {
    let runs = root.join(name).join("runs");
    mkdir(&runs)?;
    let ts = timestamp();
    for i in 0..1000 {
        let n = if i == 0 {
            ts.clone()
        } else {
            format!("{ts}-{i}")
        };
        let d = runs.join(&n);
        match std::fs::create_dir(&d) {
            Ok(()) => return Ok((d, n)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(Error::runtime(format!(
                    "cannot create run folder '{}': {e}",
                    d.display()
                )));
            }
        }
    }
    Err(Error::runtime("too many runs in the same second"))
}

/// Fail early, naming the integrator, when it does not accept the scene or the options.
fn check_available(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    what: &str,
) -> Result<(), Error> {
    crate::integrator::render::check(scene, kind, opts)
        .map_err(|e| Error::input(format!("{what}: integrator `{}`: {e}", kind.name())))
}

/// Load a scene with one material parameter overridden (parameter grids).
fn scene_with_override(
    path: &Path,
    text: &str,
    material: &str,
    overrides: &[(&str, f64)],
) -> Result<Scene, Error> {
    let mut v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| Error::input(format!("{}: {e}", path.display())))?;
    let m = v
        .get_mut("materials")
        .and_then(|m| m.get_mut(material))
        .and_then(|m| m.as_object_mut())
        .ok_or_else(|| {
            Error::input(format!(
                "grid.material: no material {material:?} in '{}'",
                path.display()
            ))
        })?;
    for (k, x) in overrides {
        m.insert((*k).to_string(), serde_json::json!(x));
    }
    Ok(Scene::from_str(path, &v.to_string())?)
}

/// Run the experiment in `config_path`; results go under `root` (default `results`).
/// Returns the run folder.
pub fn run_experiment(
    config_path: &Path,
    root: Option<&Path>,
    quick: bool,
) -> Result<PathBuf, Error> {
    let mut cfg = Config::load(config_path)?;
    if quick {
        cfg.quicken();
    }
    // Quick runs default to their own root so they never become a full run's `latest`.
    let root = root.map(Path::to_path_buf).unwrap_or_else(|| {
        if quick {
            "results/quick".into()
        } else {
            "results".into()
        }
    });
    let scene_path = cfg.scene_path(config_path);
    let scene_text = std::fs::read_to_string(&scene_path).map_err(|e| {
        Error::input(format!(
            "{}: field `scene`: cannot read '{}': {e}",
            config_path.display(),
            scene_path.display()
        ))
    })?;
    let mut scene = Scene::from_str(&scene_path, &scene_text)?;
    let (fw, fh) = (scene.camera.width, scene.camera.height);
    let (w, h) = if quick { quick_size(fw, fh) } else { (fw, fh) };
    resize_camera(&mut scene, w, h);
    let (sx, sy) = (w as f64 / fw as f64, h as f64 / fh as f64);
    let crop = match cfg.crop {
        Some(c) => {
            if c.x + c.w > fw || c.y + c.h > fh {
                return Err(Error::input(format!(
                    "{}: field `crop`: {}×{} at ({}, {}) exceeds the {fw}×{fh} image",
                    config_path.display(),
                    c.w,
                    c.h,
                    c.x,
                    c.y
                )));
            }
            let x = ((c.x as f64 * sx) as u32).min(w - 1);
            let y = ((c.y as f64 * sy) as u32).min(h - 1);
            Some(super::config::Crop {
                x,
                y,
                w: ((c.w as f64 * sx).round() as u32).clamp(1, w - x),
                h: ((c.h as f64 * sy).round() as u32).clamp(1, h - y),
            })
        }
        None => None,
    };
    let scanline = match cfg.scanline {
        Some(s) => {
            if s.row.is_some_and(|r| r >= fh) || s.column.is_some_and(|c| c >= fw) {
                return Err(Error::input(format!(
                    "{}: field `scanline`: outside the {fw}×{fh} image",
                    config_path.display()
                )));
            }
            Some(super::config::Scanline {
                row: s.row.map(|r| ((r as f64 * sy) as u32).min(h - 1)),
                column: s.column.map(|c| ((c as f64 * sx) as u32).min(w - 1)),
            })
        }
        None => None,
    };

    // Preflight: every integrator named must exist in this build.
    for v in &cfg.variants {
        check_available(
            &scene,
            v.integrator,
            &v.options,
            &format!("variant `{}`", v.name),
        )?;
    }
    if let Some(r) = &cfg.reference
        && let Some(k) = r.integrator
    {
        check_available(&scene, k, &r.options, "reference")?;
    }

    let threads = cfg.threads;
    let n_threads = threads.unwrap_or_else(rayon::current_num_threads);
    let modes = cfg.modes();
    let mode_budgets: Vec<ModeBudgets> = modes
        .iter()
        .map(|&m| ModeBudgets {
            mode: m,
            budgets: match m {
                BudgetMode::Spp => cfg
                    .budget
                    .spp
                    .as_ref()
                    .unwrap()
                    .iter()
                    .map(|&s| s as f64)
                    .collect(),
                BudgetMode::Time => cfg.budget.seconds.clone().unwrap(),
            },
        })
        .collect();

    // Progress: spp mode counts passes, time mode counts centiseconds.
    let per_job = |mb: &ModeBudgets| -> u64 {
        match mb.mode {
            BudgetMode::Spp => *mb.budgets.last().unwrap() as u64,
            BudgetMode::Time => (*mb.budgets.last().unwrap() * 100.0).ceil() as u64,
        }
    };
    let ref_units = cfg
        .reference
        .as_ref()
        .and_then(|r| r.spp)
        .map(|s| s as u64)
        .unwrap_or(0);
    let grid_units = cfg
        .grid
        .as_ref()
        .map(|g| (g.rows.values.len() * g.columns.values.len()) as u64 * per_job(&mode_budgets[0]))
        .unwrap_or(0);
    let total: u64 = ref_units
        + grid_units
        + mode_budgets
            .iter()
            .map(|mb| per_job(mb) * cfg.variants.len() as u64 * cfg.repeats as u64)
            .sum::<u64>();
    let progress = Progress::new(total);
    let bar = progress.bar.clone();

    let (run_dir, run_name) = new_run_dir(&root, &cfg.name)?;
    mkdir(&run_dir.join("images"))?;
    let started = timestamp();

    // Reference.
    let mut reference: Option<Vec<Vec3>> = None;
    if let Some(r) = &cfg.reference {
        let img = if let Some(p) = &r.exr {
            let p = resolve(config_path, p);
            let (rw, rh, px) = read_exr(&p).map_err(Error::input)?;
            if (rw, rh) == (w, h) {
                px
            } else if quick || (rw, rh) == (fw, fh) && (w, h) != (fw, fh) {
                resample(&px, rw, rh, w, h)
            } else {
                return Err(Error::input(format!(
                    "{}: field `reference.exr`: image is {rw}×{rh}, the scene renders {w}×{h}",
                    config_path.display()
                )));
            }
        } else {
            let kind = r.integrator.unwrap();
            let spp = r.spp.unwrap();
            let opts_json = serde_json::to_string(&r.options).unwrap();
            let key = fnv1a(&[
                scene_text.as_bytes(),
                kind.name().as_bytes(),
                opts_json.as_bytes(),
                spp.to_string().as_bytes(),
                r.seed.to_string().as_bytes(),
                format!("{w}x{h}").as_bytes(),
            ]);
            let cache = root.join("references").join(format!("{key:016x}.exr"));
            match read_exr(&cache) {
                Ok((cw, ch, px)) if (cw, ch) == (w, h) => {
                    bar.inc(spp as u64);
                    px
                }
                _ => {
                    bar.set_message(format!("reference ({}, {spp} spp)", kind.name()));
                    let settings = RenderSettings {
                        spp,
                        seed: r.seed,
                        threads,
                        time_limit: None,
                        progress: false,
                    };
                    let b = bar.clone();
                    let mut cb =
                        move |_: &crate::film::Film, _: &crate::integrator::Stats, _: f64| {
                            b.inc(1);
                            true
                        };
                    let out = render(&scene, kind, &r.options, &settings, Some(&mut cb))
                        .map_err(|e| Error::runtime(format!("reference: {e}")))?;
                    let px = out.film.rgb();
                    write_exr(&cache, w, h, &px).map_err(Error::runtime)?;
                    px
                }
            }
        };
        write_exr(&run_dir.join("reference.exr"), w, h, &img).map_err(Error::runtime)?;
        reference = Some(img);
    }

    // Regions.
    let (region_names, masks): (Vec<String>, Vec<(String, Vec<bool>)>) = match &cfg.regions {
        Some(r) => {
            let (names, ids) = region_ids(&scene, r.by);
            let mut masks = Vec::new();
            let mut used = Vec::new();
            for (i, n) in names.iter().enumerate() {
                let m: Vec<bool> = ids.iter().map(|&id| id == Some(i as u16)).collect();
                if m.iter().any(|&b| b) && !used.contains(n) {
                    used.push(n.clone());
                    masks.push((n.clone(), m));
                }
            }
            let json = serde_json::json!({
                "by": r.by,
                "names": names,
                "ids": ids.iter().map(|i| i.map(|v| v as i64).unwrap_or(-1)).collect::<Vec<_>>(),
            });
            write_text(&run_dir.join("regions.json"), &json.to_string())?;
            (used, masks)
        }
        None => (Vec::new(), Vec::new()),
    };

    // Variants.
    let mut rows: Vec<Row> = Vec::new();
    for mb in &mode_budgets {
        for v in &cfg.variants {
            for rep in 0..cfg.repeats {
                let seed = cfg.seed + rep as u64;
                bar.set_message(format!(
                    "{} ({} budget, repeat {}/{})",
                    v.name,
                    mb.mode.name(),
                    rep + 1,
                    cfg.repeats
                ));
                let last = *mb.budgets.last().unwrap();
                let settings = RenderSettings {
                    spp: match mb.mode {
                        BudgetMode::Spp => last as u32,
                        BudgetMode::Time => u32::MAX,
                    },
                    seed,
                    threads,
                    time_limit: None,
                    progress: false,
                };
                let mut next = 0usize;
                let mut overhead = 0.0f64;
                let mut failure: Option<String> = None;
                let mut done_units = 0u64;
                let b = bar.clone();
                let reference = reference.as_deref();
                let masks = &masks;
                let rows_ref = &mut rows;
                let run_dir_ref = &run_dir;
                let mut cb =
                    |film: &crate::film::Film, stats: &crate::integrator::Stats, secs: f64| {
                        let t0 = Instant::now();
                        let eff = (secs - overhead).max(1e-9);
                        let units = match mb.mode {
                            BudgetMode::Spp => film.spp as u64,
                            BudgetMode::Time => ((eff * 100.0) as u64).min(per_job(mb)),
                        };
                        if units > done_units {
                            b.inc(units - done_units);
                            done_units = units;
                        }
                        let mut rgb: Option<Vec<Vec3>> = None;
                        while next < mb.budgets.len() {
                            let due = match mb.mode {
                                BudgetMode::Spp => film.spp as f64 >= mb.budgets[next],
                                BudgetMode::Time => eff >= mb.budgets[next],
                            };
                            if !due {
                                break;
                            }
                            let img = rgb.get_or_insert_with(|| film.rgb());
                            let is_last = next + 1 == mb.budgets.len();
                            if rep == 0 || is_last {
                                let f = run_dir_ref.join(image_file(&v.name, mb.mode, next, rep));
                                if let Err(e) = write_exr(&f, film.width, film.height, img) {
                                    failure = Some(e);
                                    return false;
                                }
                            }
                            if let Some(r) = reference {
                                let sps = stats.paths as f64 / eff;
                                let mut push = |region: &str, m: ErrorMetrics| {
                                    rows_ref.push(Row {
                                        variant: v.name.clone(),
                                        integrator: v.integrator.name().into(),
                                        mode: mb.mode.name().into(),
                                        budget: mb.budgets[next],
                                        repeat: rep,
                                        seed,
                                        spp: film.spp,
                                        seconds: eff,
                                        samples_per_second: sps,
                                        region: region.into(),
                                        pixels: m.pixels,
                                        mse: m.mse,
                                        rel_mse: m.rel_mse,
                                        snr_db: m.snr_db,
                                        efficiency: metrics::efficiency(m.rel_mse, eff),
                                    })
                                };
                                push("all", metrics::compare(img, r, None));
                                for (n, mask) in masks {
                                    push(n, metrics::compare(img, r, Some(mask)));
                                }
                            }
                            next += 1;
                        }
                        overhead += t0.elapsed().as_secs_f64();
                        next < mb.budgets.len()
                    };
                render(&scene, v.integrator, &v.options, &settings, Some(&mut cb)).map_err(
                    |e| {
                        Error::runtime(format!(
                            "variant `{}`: integrator `{}`: {e}",
                            v.name,
                            v.integrator.name()
                        ))
                    },
                )?;
                if let Some(e) = failure {
                    return Err(Error::runtime(e));
                }
                bar.inc(per_job(mb).saturating_sub(done_units));
            }
        }
    }

    // Parameter grid.
    let mut grid_cells = Vec::new();
    if let Some(g) = &cfg.grid {
        mkdir(&run_dir.join("grid"))?;
        let v = &cfg.variants[0];
        let mb = &mode_budgets[0];
        let last = *mb.budgets.last().unwrap();
        for (i, rv) in g.rows.values.iter().enumerate() {
            for (j, cv) in g.columns.values.iter().enumerate() {
                bar.set_message(format!(
                    "grid {}={rv} {}={cv}",
                    g.rows.field, g.columns.field
                ));
                let mut s = scene_with_override(
                    &scene_path,
                    &scene_text,
                    &g.material,
                    &[(&g.rows.field, *rv), (&g.columns.field, *cv)],
                )
                .map_err(|e| Error::input(format!("grid cell ({i}, {j}): {}", e.message)))?;
                resize_camera(&mut s, w, h);
                let settings = RenderSettings {
                    spp: match mb.mode {
                        BudgetMode::Spp => last as u32,
                        BudgetMode::Time => u32::MAX,
                    },
                    seed: cfg.seed,
                    threads,
                    time_limit: match mb.mode {
                        BudgetMode::Spp => None,
                        BudgetMode::Time => Some(last),
                    },
                    progress: false,
                };
                let out = render(&s, v.integrator, &v.options, &settings, None)
                    .map_err(|e| Error::runtime(format!("grid: {e}")))?;
                let file = format!("grid/r{i}_c{j}.exr");
                write_exr(&run_dir.join(&file), w, h, &out.film.rgb()).map_err(Error::runtime)?;
                grid_cells.push(GridCell {
                    row: i,
                    column: j,
                    file,
                });
                bar.inc(per_job(mb));
            }
        }
    }
    bar.finish_and_clear();

    // Results.
    write_text(&run_dir.join("metrics.csv"), &metrics_csv(&rows))?;
    write_text(
        &run_dir.join("summary.json"),
        &serde_json::to_string_pretty(&summarize(&rows)).unwrap(),
    )?;
    let info = RunInfo {
        config: cfg.clone(),
        config_file: config_path.to_path_buf(),
        quick,
        width: w,
        height: h,
        crop,
        scanline,
        region_names,
        modes: mode_budgets,
        reference_file: reference.as_ref().map(|_| "reference.exr".to_string()),
        grid_cells,
        started,
        threads: n_threads,
    };
    write_text(
        &run_dir.join("run.json"),
        &serde_json::to_string_pretty(&info).unwrap(),
    )?;
    super::figures::make_all(&run_dir).map_err(Error::runtime)?;
    print_summary(&rows);
    // Only now does `latest` move to this run.
    write_text(
        &root.join(&cfg.name).join("latest"),
        &format!("runs/{run_name}\n"),
    )?;
    eprintln!("results: {}", run_dir.display());
    Ok(run_dir)
}

fn print_summary(rows: &[Row]) {
    let sum = summarize(rows);
    let mut last: Vec<&SummaryEntry> = Vec::new();
    for e in &sum {
        if e.region != "all" {
            continue;
        }
        if let Some(p) = last
            .iter_mut()
            .find(|p| p.variant == e.variant && p.mode == e.mode)
        {
            if e.budget > p.budget {
                *p = e;
            }
        } else {
            last.push(e);
        }
    }
    for e in last {
        eprintln!(
            "{:<24} {:>4} budget {:>8}: {:>6.0} spp {:>8.2} s  SNR {:>6.2} dB  relMSE {:.3e}  efficiency {:.3e}",
            e.variant,
            e.mode,
            e.budget,
            e.spp.mean,
            e.seconds.mean,
            e.snr_db.mean,
            e.rel_mse.mean,
            e.efficiency.mean
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_size_keeps_aspect() {
        assert_eq!(quick_size(256, 256), (48, 48));
        assert_eq!(quick_size(640, 480), (64, 48));
        assert_eq!(quick_size(32, 16), (32, 16));
    }

    #[test]
    fn timestamp_shape() {
        let t = timestamp();
        assert_eq!(t.len(), 15);
        assert_eq!(&t[8..9], "-");
        assert!(t.starts_with("20"));
    }
}
