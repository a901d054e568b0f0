//! Runs an experiment config, one step after the other: load the config and scene and check the
//! integrators ([`Setup`]), make the run folder, get the reference, render the variants at their
//! budgets with metrics, render the parameter grid, then write the results and figures. A sweep
//! takes those steps once per value, each into a run folder of its own under `sweep/<index>/`.

use super::config::Sweep;
use super::record::{
    GridCell, Row, RunInfo, SummaryEntry, mark_complete, mark_incomplete, metrics_csv, mkdir,
    new_run_dir, summarize, timestamp, write_text,
};
use super::regions::{self, Region};
use super::setup::{Setup, Source};
use super::sweep::{self, Point, SweepRecord};
use super::variants::Runs;
use super::{figures, grid, progress, reference};
use crate::error::Error;
use crate::film::output::write_exr;
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};

/// Run the experiment in `config_path`; results go under `root` (default `results`).
/// Returns the run folder.
pub fn run_experiment(
    config_path: &Path,
    root: Option<&Path>,
    quick: bool,
) -> Result<PathBuf, Error> {
    run_experiment_from(&Source::file(config_path), root, quick)
}

/// [`run_experiment`] of a config file or of a config's text ([`Source`]).
pub fn run_experiment_from(
    src: &Source,
    root: Option<&Path>,
    quick: bool,
) -> Result<PathBuf, Error> {
    let config_path = src.path;
    let (setup, points) = checked_setup_from(src, root, quick)?;
    setup.check_writable()?;
    let runs = points.len().max(1) as u64;
    let bar = progress::bar(progress::total(&setup.cfg, &setup.modes) * runs);
    let (run_dir, run_name) = new_run_dir(&setup.root, &setup.cfg.name)?;
    let started = timestamp();
    // The marker stays when the run fails or is interrupted (docs: experiments/README.md).
    mark_incomplete(
        &run_dir,
        &format!(
            "experiment '{}' ({}{})",
            setup.cfg.name,
            config_path.display(),
            if quick { ", --quick" } else { "" }
        ),
    )?;
    match &setup.cfg.sweep {
        None => {
            let rows = run_steps(&setup, &run_dir, &bar, started)?;
            bar.finish_and_clear();
            print_summary(&rows);
        }
        Some(sw) => run_sweep(&setup, sw, &points, &run_dir, &bar, started)?,
    }
    // Only now is the run complete, and only then does `latest` move to it.
    mark_complete(&run_dir)?;
    write_text(
        &setup.root.join(&setup.cfg.name).join("latest"),
        &format!("runs/{run_name}\n"),
    )?;
    super::report::write(&run_dir)?;
    eprintln!("results: {}", run_dir.display());
    Ok(run_dir)
}

/// The experiment's setup and its sweep's values, with everything checked before the first
/// sample: the config, every scene (variants', the sweep's values, the grid's cells), the
/// integrators and the size of the region masks.
pub(super) fn checked_setup(
    config_path: &Path,
    root: Option<&Path>,
    quick: bool,
) -> Result<(Setup, Vec<Point>), Error> {
    checked_setup_from(&Source::file(config_path), root, quick)
}

fn checked_setup_from(
    src: &Source,
    root: Option<&Path>,
    quick: bool,
) -> Result<(Setup, Vec<Point>), Error> {
    let setup = Setup::load_from(src, root, quick)?;
    setup.check_integrators()?;
    let points = sweep::points(&setup)?;
    grid::check_cells(&setup)?;
    regions::check(&setup)?;
    for p in &points {
        regions::check(&p.setup)?;
    }
    Ok((setup, points))
}

/// One run into `run_dir`: reference, regions, variants at their budgets, parameter grid, then
/// `metrics.csv`, `summary.json`, `run.json` and the figures. Returns the metrics rows.
fn run_steps(
    setup: &Setup,
    run_dir: &Path,
    bar: &ProgressBar,
    started: String,
) -> Result<Vec<Row>, Error> {
    mkdir(&run_dir.join("images"))?;
    let reference = reference::get(setup, bar)?;
    if let Some(img) = &reference {
        write_exr(
            &run_dir.join("reference.exr"),
            setup.width,
            setup.height,
            img,
        )
        .map_err(Error::runtime)?;
    }
    let regions = regions::masks(setup, run_dir)?;
    let rows = Runs {
        setup,
        run_dir,
        reference: reference.as_deref(),
        regions: &regions,
        bar,
        keep_all: false,
    }
    .render_all()?;
    let grid_cells = grid::render_cells(setup, run_dir, bar)?;
    let info = run_info(setup, reference.is_some(), &regions, grid_cells, started);
    write_results(run_dir, &rows, &info)?;
    figures::make_all(run_dir)?;
    Ok(rows)
}

/// The sweep: one run per value into `sweep/<index>/`, then `sweep.json`, the sweep's own
/// `run.json` (the config with its sweep) and the summary figure.
fn run_sweep(
    setup: &Setup,
    sw: &Sweep,
    points: &[Point],
    run_dir: &Path,
    bar: &ProgressBar,
    started: String,
) -> Result<(), Error> {
    let mut results = Vec::new();
    for p in points {
        let dir = run_dir.join(&p.dir);
        mkdir(&dir)?;
        let rows = run_steps(&p.setup, &dir, bar, timestamp())?;
        results.push((p, rows));
    }
    bar.finish_and_clear();
    let record = SweepRecord::new(sw, &results);
    write_text(
        &run_dir.join("sweep.json"),
        &serde_json::to_string_pretty(&record).unwrap(),
    )?;
    let info = run_info(setup, false, &[], Vec::new(), started);
    write_text(
        &run_dir.join("run.json"),
        &serde_json::to_string_pretty(&info).unwrap(),
    )?;
    figures::sweep_summary(run_dir)?;
    for (p, rows) in &results {
        eprintln!("{} = {}:", sw.label(), sweep::compact(&p.value));
        print_summary(rows);
    }
    Ok(())
}

/// The `run.json` record of a run.
pub(super) fn run_info(
    s: &Setup,
    has_reference: bool,
    regions: &[Region],
    grid_cells: Vec<GridCell>,
    started: String,
) -> RunInfo {
    RunInfo {
        config: s.cfg.clone(),
        config_file: s.config_path.clone(),
        quick: s.quick,
        width: s.width,
        height: s.height,
        crop: s.crop,
        scanline: s.scanline,
        region_names: regions.iter().map(|r| r.name.clone()).collect(),
        modes: s.modes.clone(),
        reference_file: has_reference.then(|| "reference.exr".to_string()),
        grid_cells,
        started,
        threads: s.cfg.threads.unwrap_or_else(rayon::current_num_threads),
    }
}

/// Write `metrics.csv`, `summary.json` and `run.json` into the run folder.
pub(super) fn write_results(run_dir: &Path, rows: &[Row], info: &RunInfo) -> Result<(), Error> {
    write_text(&run_dir.join("metrics.csv"), &metrics_csv(rows))?;
    write_text(
        &run_dir.join("summary.json"),
        &serde_json::to_string_pretty(&summarize(rows)).unwrap(),
    )?;
    write_text(
        &run_dir.join("run.json"),
        &serde_json::to_string_pretty(info).unwrap(),
    )
}

pub(super) fn print_summary(rows: &[Row]) {
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
