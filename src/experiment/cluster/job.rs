//! `stokes job RUN_DIR [INDEX]`: run one job of a planned run. Its outputs are written
//! atomically into `jobs/<index>/`, and `done.json` (timing, host, CPU model, threads) last, so
//! a job killed at any point leaves nothing the collect step accepts. A job that finished is
//! skipped, so Slurm requeues and re-submitted arrays are safe.

use super::super::grid;
use super::super::record::{image_file, mkdir, timestamp, write_text};
use super::super::reference;
use super::super::setup::Setup;
use super::super::sweep;
use super::super::variants::{Runs, SnapshotStat};
use super::plan::{Job, Plan, PlannedRun, Work, inputs_hash, mode_budgets, read_plan};
use crate::error::Error;
use crate::integrator::with_threads;
use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The record of a finished job: `jobs/<index>/done.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobRecord {
    pub index: usize,
    pub host: String,
    pub cpu_model: String,
    pub threads: usize,
    pub started: String,
    /// Wall-clock seconds of the whole job: loading, rendering and writing (the metrics use
    /// the snapshots' render times).
    pub seconds: f64,
    /// `SLURM_JOB_ID` (and array task) when it ran under Slurm.
    pub slurm_job: Option<String>,
    /// What each snapshot of a variant job measured.
    pub snapshots: Vec<SnapshotStat>,
    /// Its output files, relative to its folder.
    pub files: Vec<String>,
}

/// The record of a failed job: `jobs/<index>/failed.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobFailure {
    pub index: usize,
    pub host: String,
    pub time: String,
    pub error: String,
}

pub const DONE_FILE: &str = "done.json";
pub const FAILED_FILE: &str = "failed.json";

/// The job index to run: `index`, or `SLURM_ARRAY_TASK_ID`.
pub fn job_index(index: Option<usize>) -> Result<usize, Error> {
    if let Some(i) = index {
        return Ok(i);
    }
    // STOKES_JOB_OFFSET shifts the task ids, for plans larger than the cluster's MaxArraySize
    // submitted in parts (docs/cluster.md).
    let var = |k: &str, v: String| {
        v.trim()
            .parse::<usize>()
            .map_err(|_| Error::input(format!("{k} is '{v}', not a job index")))
    };
    let offset = match std::env::var("STOKES_JOB_OFFSET") {
        Ok(v) => var("STOKES_JOB_OFFSET", v)?,
        Err(_) => 0,
    };
    match std::env::var("SLURM_ARRAY_TASK_ID") {
        Ok(v) => var("SLURM_ARRAY_TASK_ID", v)?
            .checked_add(offset)
            .ok_or_else(|| Error::input("SLURM_ARRAY_TASK_ID + STOKES_JOB_OFFSET overflows")),
        Err(_) => Err(Error::input(
            "no job index: give INDEX, or run inside a Slurm array job (SLURM_ARRAY_TASK_ID), or use --all",
        )),
    }
}

/// The finished record of job `j` in `run_dir`, when it is complete: `done.json` readable, of
/// this job, and every file it lists present.
pub fn finished(run_dir: &Path, j: &Job) -> Option<JobRecord> {
    let dir = run_dir.join(&j.output);
    let text =
        crate::io::input::read_text(&dir.join(DONE_FILE), crate::io::input::RUN_RECORD).ok()?;
    let r: JobRecord = serde_json::from_str(&text).ok()?;
    (r.index == j.index
        && r.files
            .iter()
            .all(|f| super::super::record::safe_relative(f) && dir.join(f).is_file()))
    .then_some(r)
}

/// The failure record of job `j`, when its last run failed.
pub fn failure(run_dir: &Path, j: &Job) -> Option<JobFailure> {
    let p = run_dir.join(&j.output).join(FAILED_FILE);
    let text = crate::io::input::read_text(&p, crate::io::input::RUN_RECORD).ok()?;
    serde_json::from_str(&text).ok()
}

/// Run job `index` of the planned run in `run_dir` (skipped when it already finished).
pub fn run_job(run_dir: &Path, index: usize) -> Result<(), Error> {
    let run = read_plan(run_dir)?;
    let j = run.jobs.get(index).ok_or_else(|| {
        Error::input(format!(
            "job {index}: '{}' plans jobs 0–{}",
            run_dir.display(),
            run.jobs.len() - 1
        ))
    })?;
    run_planned(&run, j)
}

/// Run every job of the planned run in `run_dir` that has not finished, one after the other.
/// Failures are reported together at the end.
pub fn run_all(run_dir: &Path) -> Result<(), Error> {
    let run = read_plan(run_dir)?;
    let jobs = &run.jobs;
    let mut failed = Vec::new();
    let mut kind = crate::error::ErrorKind::Input;
    for j in jobs {
        if let Err(e) = run_planned(&run, j) {
            eprintln!("job {} failed: {}", j.index, e.message);
            failed.push(j.index);
            // Exit 2 only when every failure was bad input, as for one job.
            if e.kind == crate::error::ErrorKind::Runtime {
                kind = e.kind;
            }
        }
    }
    if failed.is_empty() {
        return Ok(());
    }
    Err(Error {
        kind,
        message: format!(
            "{} of {} jobs failed: {}",
            failed.len(),
            jobs.len(),
            super::plan::ranges(&failed)
        ),
    })
}

fn run_planned(run: &PlannedRun, j: &Job) -> Result<(), Error> {
    let (run_dir, plan) = (run.dir.as_path(), &run.plan);
    if let Some(r) = finished(run_dir, j) {
        eprintln!(
            "job {} ({}) already finished on {} in {:.2} s: skipped",
            j.index,
            j.describe(),
            r.host,
            r.seconds
        );
        return Ok(());
    }
    let dir = run_dir.join(&j.output);
    mkdir(&dir)?;
    let _ = std::fs::remove_file(dir.join(FAILED_FILE));
    eprintln!("job {} ({}) on {}", j.index, j.describe(), host());
    let started = timestamp();
    let t0 = Instant::now();
    let work = || {
        setup_for(plan, j).and_then(|s| {
            check_work(&s, plan, j)?;
            let threads = s.cfg.threads.unwrap_or_else(rayon::current_num_threads);
            render(&s, j, &dir).map(|out| (out, threads))
        })
    };
    // A panic (a bug) still leaves failed.json, so that collect names the job and the cause.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).unwrap_or_else(|p| {
        let what = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(Error::runtime(format!(
            "the job panicked (a bug in stokes): {what}"
        )))
    });
    match result {
        Ok(((files, snapshots), threads)) => {
            let rec = JobRecord {
                index: j.index,
                host: host(),
                cpu_model: cpu_model(),
                threads,
                started,
                seconds: t0.elapsed().as_secs_f64(),
                slurm_job: slurm_job(),
                snapshots,
                files,
            };
            // Last, and atomic: only now does the collect step accept the job.
            write_text(
                &dir.join(super::job::DONE_FILE),
                &serde_json::to_string_pretty(&rec).unwrap(),
            )?;
            eprintln!("job {} done in {:.2} s", j.index, rec.seconds);
            Ok(())
        }
        Err(e) => {
            let f = JobFailure {
                index: j.index,
                host: host(),
                time: timestamp(),
                error: e.message.clone(),
            };
            let _ = write_text(
                &dir.join(FAILED_FILE),
                &serde_json::to_string_pretty(&f).unwrap(),
            );
            Err(e)
        }
    }
}

/// The setup a job renders with: the plan's config (unchanged since planning), at its `--quick`
/// size, the sweep's value applied, with the job's thread count.
fn setup_for(plan: &Plan, j: &Job) -> Result<Setup, Error> {
    // without the config's `threads`, the scene's BVH build keeps to Slurm's CPUs, as the render
    let load = || Setup::load(&plan.config_file, None, plan.quick);
    let mut s = with_threads(slurm_cpus(), load).map_err(Error::runtime)??;
    if inputs_hash(&s)? != plan.inputs_hash {
        return Err(Error::input(format!(
            "the config '{}', its scene '{}' or a variant's scene changed since the run was planned: plan a new run",
            plan.config_file.display(),
            s.scene_path.display()
        )));
    }
    if s.cfg.threads.is_none() {
        s.cfg.threads = slurm_cpus();
    }
    match j.point {
        None => Ok(s),
        Some(p) => sweep::points(&s)?
            .into_iter()
            .nth(p)
            .map(|pt| pt.setup)
            .ok_or_else(|| {
                Error::input(format!(
                    "job {}: the config has no sweep value {p}",
                    j.index
                ))
            }),
    }
}

/// The job's work is what the config (unchanged since planning) asks for: a reference shard is
/// one of the plan's shards of the config's reference, a variant's budgets are the config's. A
/// hand-edited `jobs.jsonl` cannot make a job render more than the experiment does.
fn check_work(s: &Setup, plan: &Plan, j: &Job) -> Result<(), Error> {
    let bad = |m: String| {
        Error::input(format!(
            "job {}: field `work` of its line in jobs.jsonl: {m}; plan the run again",
            j.index
        ))
    };
    match &j.work {
        Work::ReferenceShard { samples: [a, b] } => {
            let spp = s.cfg.reference.as_ref().and_then(|r| r.spp).unwrap_or(0);
            let k = plan.shard_spp;
            if *b > spp || a % k != 0 || *b != (a + k).min(spp) {
                return Err(bad(format!(
                    "samples {a}..{b} are not a shard of the reference's {spp} samples in shards of {k}"
                )));
            }
        }
        Work::Variant { mode, budgets, .. } => {
            let planned = s.modes.iter().find(|m| m.mode == *mode);
            if planned.is_none_or(|m| m.budgets != *budgets) {
                return Err(bad(format!(
                    "the {} budgets {budgets:?} are not the config's",
                    mode.name()
                )));
            }
        }
        Work::GridCell { .. } => {}
    }
    Ok(())
}

/// Render the job's work into `dir`: its files (relative to `dir`) and snapshot measurements.
fn render(s: &Setup, j: &Job, dir: &Path) -> Result<(Vec<String>, Vec<SnapshotStat>), Error> {
    match &j.work {
        Work::ReferenceShard { samples: [a, b] } => {
            let (film, info) = reference::render_shard(s, *a, *b)?;
            crate::film::shard::write_shard(&dir.join("reference.exr"), &film, &info)
                .map_err(Error::runtime)?;
            Ok((vec!["reference.exr".into()], Vec::new()))
        }
        Work::Variant {
            variant,
            name,
            mode,
            budgets,
            repeat,
        } => {
            let v = s.cfg.variants.get(*variant).filter(|v| &v.name == name);
            if v.is_none() || s.cfg.seed + *repeat as u64 != j.seed {
                return Err(Error::input(format!(
                    "job {}: variant {variant} `{name}` with seed {} is not in the config",
                    j.index, j.seed
                )));
            }
            mkdir(&dir.join("images"))?;
            let mb = mode_budgets(*mode, budgets);
            let bar = ProgressBar::hidden();
            let runs = Runs {
                setup: s,
                run_dir: dir,
                reference: None,
                regions: &[],
                bar: &bar,
                keep_all: true,
            };
            let stats = runs.render_one(&mb, *variant, *repeat, &mut Vec::new())?;
            let files = stats
                .iter()
                .map(|st| image_file(name, *mode, st.budget, *repeat))
                .collect();
            Ok((files, stats))
        }
        Work::GridCell { row, column } => {
            let g =
                s.cfg.grid.as_ref().ok_or_else(|| {
                    Error::input(format!("job {}: the config has no grid", j.index))
                })?;
            let (rv, cv) = match (g.rows.values.get(*row), g.columns.values.get(*column)) {
                (Some(r), Some(c)) => (*r, *c),
                _ => {
                    return Err(Error::input(format!(
                        "job {}: grid cell ({row}, {column}) is outside the config's grid",
                        j.index
                    )));
                }
            };
            mkdir(&dir.join("grid"))?;
            let cell = grid::render_cell(s, g, (*row, rv), (*column, cv), dir)?;
            Ok((vec![cell.file], Vec::new()))
        }
    }
}

/// Worker threads Slurm gave the job (`SLURM_CPUS_PER_TASK`).
fn slurm_cpus() -> Option<usize> {
    std::env::var("SLURM_CPUS_PER_TASK")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .filter(|&n: &usize| n >= 1)
}

fn slurm_job() -> Option<String> {
    let id = std::env::var("SLURM_ARRAY_JOB_ID")
        .or_else(|_| std::env::var("SLURM_JOB_ID"))
        .ok()?;
    Some(match std::env::var("SLURM_ARRAY_TASK_ID") {
        Ok(t) => format!("{id}_{t}"),
        Err(_) => id,
    })
}

/// This machine's name.
pub fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .or_else(|_| std::env::var("HOSTNAME"))
        .map(|s| s.trim().to_string())
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// This machine's CPU model (`model name` of /proc/cpuinfo).
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// The output folder of job `j`.
pub fn job_dir(run_dir: &Path, j: &Job) -> PathBuf {
    run_dir.join(&j.output)
}
