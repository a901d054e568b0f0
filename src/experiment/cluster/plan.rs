//! The plan of a run: `plan.json` (what the run is) and `jobs.jsonl` (one independent render
//! per line), written by `stokes experiment CONFIG --plan` and read back, as untrusted input, by
//! every job and by the collect step.

use super::super::config::{BudgetMode, Config};
use super::super::record::{
    ModeBudgets, mark_incomplete, mkdir, new_run_dir, timestamp, write_text,
};
use super::super::reference;
use super::super::runner::checked_setup;
use super::super::setup::Setup;
use super::super::sweep::Point;
use crate::error::Error;
use crate::integrator::{IntegratorKind, IntegratorOptions};
use crate::io::limits::{MAX_SECONDS, MAX_SPP};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format tag of `plan.json`.
pub const FORMAT: &str = "stokes-plan-1";
/// The plan's file names in the run folder.
pub const PLAN_FILE: &str = "plan.json";
pub const JOBS_FILE: &str = "jobs.jsonl";
/// Most jobs a plan may hold (Slurm's own array limit is usually far lower).
pub const MAX_JOBS: usize = 1 << 20;
/// Most shards a reference may be split into.
pub const MAX_SHARDS: u32 = 4096;
/// Most budgets of one mode a job may list.
const MAX_BUDGETS: usize = 4096;

/// What a planned run is: `plan.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    pub format: String,
    /// The experiment config, absolute.
    pub config_file: PathBuf,
    /// Hash of the config's and its scene's text at planning: a job refuses to run if they
    /// changed since.
    pub inputs_hash: String,
    pub quick: bool,
    pub name: String,
    pub started: String,
    /// Number of jobs in `jobs.jsonl`.
    pub jobs: usize,
    /// Samples per reference shard.
    pub shard_spp: u32,
    /// Results root of a run in the default place (`<root>/<name>/runs/<ts>`): collect then
    /// points `<root>/<name>/latest` at the run and caches the merged reference there.
    pub root: Option<PathBuf>,
    /// The run's folder name under `<root>/<name>/runs/`, with `root`.
    pub run_name: Option<String>,
}

/// One render that runs alone: a line of `jobs.jsonl`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    pub index: usize,
    /// Index of the sweep's value, for a sweep.
    pub point: Option<usize>,
    /// The scene it renders (absolute; the sweep's value, the grid's cell or `--quick` size
    /// are applied to it from the config).
    pub scene: PathBuf,
    pub integrator: IntegratorKind,
    pub options: IntegratorOptions,
    pub seed: u64,
    pub work: Work,
    /// Its folder, relative to the run folder: `jobs/<index>`.
    pub output: String,
}

/// What a job renders.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Work {
    /// Samples `samples[0]..samples[1]` of the reference.
    ReferenceShard { samples: [u32; 2] },
    /// A variant at every budget of a mode, one repeat (each job measures its own time).
    Variant {
        variant: usize,
        name: String,
        mode: BudgetMode,
        budgets: Vec<f64>,
        repeat: u32,
    },
    /// A cell of the parameter grid.
    GridCell { row: usize, column: usize },
}

impl Job {
    /// A one-line description for messages and the timing table.
    pub fn describe(&self) -> String {
        let p = self
            .point
            .map(|p| format!("sweep {p}: "))
            .unwrap_or_default();
        match &self.work {
            Work::ReferenceShard { samples } => format!(
                "{p}reference {} samples {}..{}",
                self.integrator.name(),
                samples[0],
                samples[1]
            ),
            Work::Variant {
                name, mode, repeat, ..
            } => format!("{p}{name} {} budget repeat {repeat}", mode.name()),
            Work::GridCell { row, column } => format!("{p}grid cell ({row}, {column})"),
        }
    }
}

/// Hash of what a plan depends on: the text of the config, its scene and the variants' own
/// scenes (not of the data files they name).
pub fn inputs_hash(s: &Setup) -> Result<String, Error> {
    let read = |p: &Path, kind| crate::io::input::read_text(p, kind).map_err(Error::input);
    let mut text = read(&s.config_path, crate::io::input::CONFIG)?;
    text.push('\0');
    text += &s.scene_text;
    for i in 0..s.cfg.variants.len() {
        if let Some(p) = s.cfg.variant_scene_path(&s.config_path, i) {
            text.push('\0');
            text += &read(&p, crate::io::input::SCENE)?;
        }
    }
    Ok(crate::io::hash::text_hash(&text))
}

/// `stokes experiment CONFIG --plan`: check the experiment as a run would, make the run folder
/// (`out`, new or empty, or a new `<root>/<name>/runs/<timestamp>`) and write its plan. Returns
/// the run folder and the plan.
pub fn write_plan(
    config_path: &Path,
    out: Option<&Path>,
    quick: bool,
    shards: u32,
) -> Result<(PathBuf, Plan, Vec<Job>), Error> {
    if !(1..=MAX_SHARDS).contains(&shards) {
        return Err(Error::input(format!(
            "--reference-shards must be 1–{MAX_SHARDS}, got {shards}"
        )));
    }
    let config_path = std::path::absolute(config_path)
        .map_err(|e| Error::input(format!("config '{}': {e}", config_path.display())))?;
    let (setup, points) = checked_setup(&config_path, None, quick)?;
    let (run_dir, root, run_name) = match out {
        Some(d) => (empty_run_dir(d)?, None, None),
        None => {
            setup.check_writable()?;
            let (d, n) = new_run_dir(&setup.root, &setup.cfg.name)?;
            (
                d,
                Some(std::path::absolute(&setup.root).unwrap_or(setup.root.clone())),
                Some(n),
            )
        }
    };
    let run_dir = std::fs::canonicalize(&run_dir).unwrap_or(run_dir);
    let shard_spp = setup
        .cfg
        .reference
        .as_ref()
        .and_then(|r| r.spp)
        .map_or(1, |n| n.div_ceil(shards).max(1));
    let jobs = jobs(&setup, &points, shard_spp, root.is_some())?;
    if jobs.len() > MAX_JOBS {
        return Err(Error::input(format!(
            "{}: the experiment makes {} jobs, at most {MAX_JOBS}",
            config_path.display(),
            jobs.len()
        )));
    }
    let plan = Plan {
        format: FORMAT.into(),
        config_file: config_path.clone(),
        inputs_hash: inputs_hash(&setup)?,
        quick,
        name: setup.cfg.name.clone(),
        started: timestamp(),
        jobs: jobs.len(),
        shard_spp,
        root,
        run_name,
    };
    mark_incomplete(
        &run_dir,
        &format!(
            "planned experiment '{}' ({}{}): run its jobs (`stokes job`), then `stokes experiment --collect`",
            plan.name,
            config_path.display(),
            if quick { ", --quick" } else { "" }
        ),
    )?;
    mkdir(&run_dir.join("jobs"))?;
    let lines: String = jobs
        .iter()
        .map(|j| serde_json::to_string(j).unwrap() + "\n")
        .collect();
    write_text(&run_dir.join(JOBS_FILE), &lines)?;
    write_text(
        &run_dir.join(PLAN_FILE),
        &serde_json::to_string_pretty(&plan).unwrap(),
    )?;
    Ok((run_dir, plan, jobs))
}

/// The folder `d` for a planned run: created, or existing and empty.
fn empty_run_dir(d: &Path) -> Result<PathBuf, Error> {
    let bad = |m: String| Error::input(format!("--out '{}': {m}", d.display()));
    if d.exists() {
        let mut it =
            std::fs::read_dir(d).map_err(|e| bad(format!("cannot read the folder: {e}")))?;
        if it.next().is_some() {
            return Err(bad(
                "the folder is not empty; a planned run needs a new or empty folder".into(),
            ));
        }
    } else {
        std::fs::create_dir_all(d).map_err(|e| bad(format!("cannot create the folder: {e}")))?;
    }
    crate::io::output::check_folder(d).map_err(bad)?;
    Ok(d.to_path_buf())
}

/// Every job of the run, in the order a run on one machine renders: per sweep value (or once),
/// the reference's shards, the variants (mode, variant, repeat), the grid's cells.
fn jobs(s: &Setup, points: &[Point], shard_spp: u32, use_cache: bool) -> Result<Vec<Job>, Error> {
    let mut out = Vec::new();
    if points.is_empty() {
        point_jobs(s, None, shard_spp, use_cache, &mut out)?;
    }
    for p in points {
        point_jobs(&p.setup, Some(p.index), shard_spp, use_cache, &mut out)?;
    }
    Ok(out)
}

fn point_jobs(
    s: &Setup,
    point: Option<usize>,
    shard_spp: u32,
    use_cache: bool,
    out: &mut Vec<Job>,
) -> Result<(), Error> {
    let abs = |p: &Path| {
        std::fs::canonicalize(p)
            .or_else(|_| std::path::absolute(p))
            .unwrap_or(p.to_path_buf())
    };
    let mut push = |scene: &Path, kind, options: &IntegratorOptions, seed, work| {
        let index = out.len();
        out.push(Job {
            index,
            point,
            scene: abs(scene),
            integrator: kind,
            options: options.clone(),
            seed,
            work,
            output: job_dir_name(index),
        });
    };
    let cfg: &Config = &s.cfg;
    if let Some(r) = &cfg.reference
        && let (Some(kind), Some(spp)) = (r.integrator, r.spp)
        && !(use_cache && reference::cached(s))
    {
        let mut from = 0;
        while from < spp {
            let to = (from + shard_spp).min(spp);
            push(
                &s.scene_path,
                kind,
                &r.options,
                r.seed,
                Work::ReferenceShard {
                    samples: [from, to],
                },
            );
            from = to;
        }
    }
    for mb in &s.modes {
        for (i, v) in cfg.variants.iter().enumerate() {
            let scene = cfg.variant_scene_path(&s.config_path, i);
            for rep in 0..cfg.repeats {
                push(
                    scene.as_deref().unwrap_or(&s.scene_path),
                    v.integrator,
                    &v.options,
                    cfg.seed + rep as u64,
                    Work::Variant {
                        variant: i,
                        name: v.name.clone(),
                        mode: mb.mode,
                        budgets: mb.budgets.clone(),
                        repeat: rep,
                    },
                );
            }
        }
    }
    if let Some(g) = &cfg.grid {
        let v = &cfg.variants[0];
        for row in 0..g.rows.values.len() {
            for column in 0..g.columns.values.len() {
                push(
                    &s.scene_path,
                    v.integrator,
                    &v.options,
                    cfg.seed,
                    Work::GridCell { row, column },
                );
            }
        }
    }
    Ok(())
}

/// Indices as compact ranges: `0-3, 7, 9-12`.
pub fn ranges(ix: &[usize]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < ix.len() {
        let mut k = i;
        while k + 1 < ix.len() && ix[k + 1] == ix[k] + 1 {
            k += 1;
        }
        out.push(if k == i {
            ix[i].to_string()
        } else {
            format!("{}-{}", ix[i], ix[k])
        });
        i = k + 1;
    }
    out.join(", ")
}

/// A job's folder relative to the run folder.
pub fn job_dir_name(index: usize) -> String {
    format!("jobs/{index:05}")
}

/// A planned run folder, read and checked as untrusted input ([`read_plan`]).
#[derive(Clone, Debug)]
pub struct PlannedRun {
    /// The run folder, canonical.
    pub dir: PathBuf,
    pub plan: Plan,
    pub jobs: Vec<Job>,
    /// The results root the run folder lies in (`<root>/<name>/runs/<run_name>`), when it was
    /// planned in one: the merged reference is cached there and `<name>/latest` points at the run.
    pub root: Option<PathBuf>,
}

/// Read and check the planned run folder `dir`: the folder holds only folders and regular files
/// (no link could take a write outside it), `plan.json` and `jobs.jsonl` are well-formed, their
/// names and numbers within the bounds the command line has, and a run planned in a results
/// root still lies at `<root>/<name>/runs/<run_name>`. Errors name the file, the line and the
/// field.
pub fn read_plan(dir: &Path) -> Result<PlannedRun, Error> {
    if !dir.is_dir() {
        return Err(Error::input(format!(
            "run folder '{}' does not exist (plan one with `stokes experiment CONFIG --plan --out {}`)",
            dir.display(),
            dir.display()
        )));
    }
    let dir = std::fs::canonicalize(dir)
        .map_err(|e| Error::input(format!("run folder '{}': {e}", dir.display())))?;
    crate::io::tree::check_run_folder(&dir).map_err(Error::input)?;
    let pf = dir.join(PLAN_FILE);
    let text = crate::io::input::read_text(&pf, crate::io::input::RUN_RECORD).map_err(|e| {
        Error::input(format!(
            "{e} (is '{}' a run folder planned with `stokes experiment CONFIG --plan`?)",
            dir.display()
        ))
    })?;
    let plan: Plan = crate::io::json::from_json_str(&pf, &text)?;
    let bad =
        |field: &str, m: String| Error::input(format!("{}: field `{field}`: {m}", pf.display()));
    if plan.format != FORMAT {
        return Err(bad(
            "format",
            format!("'{}' is not '{FORMAT}'", plan.format),
        ));
    }
    if plan.jobs == 0 || plan.jobs > MAX_JOBS {
        return Err(bad(
            "jobs",
            format!("must be 1–{MAX_JOBS}, got {}", plan.jobs),
        ));
    }
    if !(1..=MAX_SPP).contains(&plan.shard_spp) {
        return Err(bad(
            "shard_spp",
            format!("must be 1–{MAX_SPP}, got {}", plan.shard_spp),
        ));
    }
    if !super::super::config::name_ok(&plan.name) {
        return Err(bad(
            "name",
            format!(
                "{:?} is not an experiment name (letters, digits, '-', '_', '.', '+')",
                plan.name
            ),
        ));
    }
    if !plan.config_file.is_absolute() {
        return Err(bad(
            "config_file",
            format!(
                "'{}' is not an absolute path (the planner writes the config's absolute path)",
                plan.config_file.display()
            ),
        ));
    }
    let root = results_root(&dir, &plan, &bad)?;
    let jf = dir.join(JOBS_FILE);
    let text =
        crate::io::input::read_text(&jf, crate::io::input::RUN_TABLE).map_err(Error::input)?;
    let mut jobs = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let what = format!("{}: line {}", jf.display(), n + 1);
        if jobs.len() == plan.jobs {
            return Err(Error::input(format!(
                "{what}: more jobs than '{}' says (`jobs` = {})",
                pf.display(),
                plan.jobs
            )));
        }
        let job: Job = crate::io::json::from_json_str(Path::new(&what), line)?;
        check_job(&job, jobs.len(), &what)?;
        jobs.push(job);
    }
    if jobs.len() != plan.jobs {
        return Err(Error::input(format!(
            "{}: holds {} jobs, but '{}' says `jobs` = {}",
            jf.display(),
            jobs.len(),
            pf.display(),
            plan.jobs
        )));
    }
    Ok(PlannedRun {
        dir,
        plan,
        jobs,
        root,
    })
}

/// The results root of the run folder `dir` (canonical) when `plan` says it was planned in one:
/// the folder three levels up, after checking that `dir` is `<root>/<name>/runs/<run_name>`.
/// The root is where the run folder lies, not the `root` the plan names: a run folder copied to
/// another machine writes into the root it was copied into, and an edited `root` cannot send a
/// write elsewhere.
fn results_root(
    dir: &Path,
    plan: &Plan,
    bad: &dyn Fn(&str, String) -> Error,
) -> Result<Option<PathBuf>, Error> {
    let (planned, run_name) = match (&plan.root, &plan.run_name) {
        (None, None) => return Ok(None),
        (Some(r), Some(n)) => (r, n),
        _ => {
            return Err(bad(
                "root",
                "`root` and `run_name` go together: give both or neither".into(),
            ));
        }
    };
    if !crate::io::tree::plain_name(run_name) {
        return Err(bad(
            "run_name",
            format!("{run_name:?} is not a folder name"),
        ));
    }
    let name_of = |p: Option<&Path>| p.and_then(Path::file_name).map(|n| n.to_os_string());
    let runs = dir.parent();
    let exp = runs.and_then(Path::parent);
    let fits = name_of(Some(dir)).is_some_and(|n| n == run_name.as_str())
        && name_of(runs).is_some_and(|n| n == "runs")
        && name_of(exp).is_some_and(|n| n == plan.name.as_str());
    let Some(root) = exp.and_then(Path::parent).filter(|_| fits) else {
        return Err(bad(
            "run_name",
            format!(
                "the run folder '{}' is not `<root>/{}/runs/{run_name}` (moved or renamed, or plan.json edited): collect it where it was planned, or plan the run again",
                dir.display(),
                plan.name
            ),
        ));
    };
    if std::fs::canonicalize(planned).ok().as_deref() != Some(root) {
        eprintln!(
            "note: the run was planned in the results root '{}' and now lies in '{}': its reference cache and `latest` are written there",
            crate::io::text::show_path(planned),
            root.display()
        );
    }
    Ok(Some(root.to_path_buf()))
}

/// A job line's own checks: its index is its line, its folder is `jobs/<index>`, its ranges and
/// budgets make sense and stay within the bounds of the command line (at most 2²⁴ samples per
/// render, budgets of at most 2²⁴ spp or 10⁷ s).
fn check_job(j: &Job, index: usize, what: &str) -> Result<(), Error> {
    let bad = |field: &str, m: String| Error::input(format!("{what}: field `{field}`: {m}"));
    if j.index != index {
        return Err(bad(
            "index",
            format!("is {}, the line holds job {index}", j.index),
        ));
    }
    if j.output != job_dir_name(index) {
        return Err(bad(
            "output",
            format!("is '{}', must be '{}'", j.output, job_dir_name(index)),
        ));
    }
    match &j.work {
        Work::ReferenceShard { samples: [a, b] } if a >= b => {
            Err(bad("work.samples", format!("{a}..{b} is an empty range")))
        }
        Work::ReferenceShard { samples: [a, b] } if b - a > MAX_SPP => Err(bad(
            "work.samples",
            format!(
                "{a}..{b} holds {} samples, at most {MAX_SPP} in one job",
                b - a
            ),
        )),
        Work::Variant { budgets, .. }
            if budgets.is_empty() || budgets.iter().any(|b| !(b.is_finite() && *b > 0.0)) =>
        {
            Err(bad(
                "work.budgets",
                "must list positive, finite budgets".into(),
            ))
        }
        Work::Variant { budgets, mode, .. } if budgets.len() > MAX_BUDGETS => Err(bad(
            "work.budgets",
            format!(
                "lists {} budgets of the {} mode, at most {MAX_BUDGETS}",
                budgets.len(),
                mode.name()
            ),
        )),
        Work::Variant { budgets, mode, .. } => {
            let max = match mode {
                BudgetMode::Spp => MAX_SPP as f64,
                BudgetMode::Time => MAX_SECONDS,
            };
            match budgets.iter().find(|b| **b > max) {
                Some(b) => Err(bad(
                    "work.budgets",
                    format!("{b} is above the largest {} budget, {max:e}", mode.name()),
                )),
                None => Ok(()),
            }
        }
        _ => Ok(()),
    }
}

/// The budgets of a variant job as the run's mode budgets.
pub fn mode_budgets(mode: BudgetMode, budgets: &[f64]) -> ModeBudgets {
    ModeBudgets {
        mode,
        budgets: budgets.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_compact() {
        assert_eq!(ranges(&[]), "");
        assert_eq!(ranges(&[4]), "4");
        assert_eq!(ranges(&[0, 1, 2, 3, 7, 9, 10, 11, 12]), "0-3, 7, 9-12");
    }
}
