//! `stokes experiment`, `job`, `figures` and `report`: runs, planned and Slurm runs, stored runs.

use crate::Error;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct ExperimentArgs {
    /// Experiment config JSON.
    #[arg(required_unless_present = "collect")]
    pub config: Option<PathBuf>,
    /// Results root (default `results`, `results/quick` with --quick); the run goes to
    /// `<out>/<name>/runs/<timestamp>/`. With --plan or --slurm: the run folder itself, new or
    /// empty (default: a new `<root>/<name>/runs/<timestamp>/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Small resolution, few spp, one repeat: a smoke test.
    #[arg(long)]
    pub quick: bool,
    /// Do not render: write the run folder and its job list (`jobs.jsonl`), one independent
    /// render per line, for `stokes job` (docs/cluster.md).
    #[arg(long, conflicts_with = "slurm")]
    pub plan: bool,
    /// With --plan or --slurm: split the rendered reference's samples into this many shard
    /// jobs (default 8).
    #[arg(long, value_name = "K")]
    pub reference_shards: Option<u32>,
    /// Finish a planned run whose jobs have all run: merge, metrics, figures.
    #[arg(long, value_name = "RUN_DIR", conflicts_with_all = ["config", "plan", "slurm", "quick", "out", "reference_shards", "partition", "time", "cpus_per_task", "dry_run"])]
    pub collect: Option<PathBuf>,
    /// Plan the run and submit it to Slurm: an array of its jobs, then a collect job that
    /// depends on the array (afterok).
    #[arg(long)]
    pub slurm: bool,
    /// Slurm partition (default: the cluster's default).
    #[arg(long)]
    pub partition: Option<String>,
    /// Slurm time limit per job, e.g. 30, 1:00:00 or 1-00:00:00.
    #[arg(long)]
    pub time: Option<String>,
    /// CPUs per job (its worker threads); default: the config's `threads`, else 1.
    #[arg(long)]
    pub cpus_per_task: Option<u32>,
    /// Write and print the Slurm scripts without submitting them.
    #[arg(long)]
    pub dry_run: bool,
}

pub fn experiment(a: &ExperimentArgs) -> Result<(), Error> {
    use crate::experiment::cluster;
    if let Some(dir) = &a.collect {
        cluster::collect(dir)?;
        return Ok(());
    }
    let config = a.config.as_deref().expect("clap requires CONFIG");
    check_cluster_options(a)?;
    if !(a.plan || a.slurm) {
        crate::experiment::run_experiment(config, a.out.as_deref(), a.quick)?;
        return Ok(());
    }
    let opts = crate::experiment::cluster::slurm::SlurmOptions {
        partition: a.partition.clone(),
        time: a.time.clone(),
        cpus_per_task: a.cpus_per_task,
        dry_run: a.dry_run,
    };
    if a.slurm {
        crate::experiment::cluster::slurm::validate(&opts)?;
    }
    let (run_dir, plan, jobs) = cluster::write_plan(
        config,
        a.out.as_deref(),
        a.quick,
        a.reference_shards.unwrap_or(8),
    )?;
    let shards = jobs
        .iter()
        .filter(|j| matches!(j.work, cluster::plan::Work::ReferenceShard { .. }))
        .count();
    eprintln!(
        "planned {} jobs into {}: {shards} reference shards of {} spp, {} renders",
        jobs.len(),
        run_dir.display(),
        plan.shard_spp,
        jobs.len() - shards
    );
    if !a.slurm {
        eprintln!(
            "run each job with `stokes job {d} INDEX` (INDEX 0–{}; `--all` runs them one after the other), then `stokes experiment --collect {d}`",
            jobs.len() - 1,
            d = run_dir.display()
        );
        println!("{}", run_dir.display());
        return Ok(());
    }
    slurm_submit(&run_dir, &plan, jobs.len(), opts)
}

/// The options of planned and Slurm runs are refused where they would be ignored.
fn check_cluster_options(a: &ExperimentArgs) -> Result<(), Error> {
    let slurm_only = [
        ("--partition", a.partition.is_some()),
        ("--time", a.time.is_some()),
        ("--cpus-per-task", a.cpus_per_task.is_some()),
        ("--dry-run", a.dry_run),
    ];
    if !a.slurm
        && let Some((opt, _)) = slurm_only.iter().find(|(_, given)| *given)
    {
        return Err(Error::input(format!(
            "{opt} is an option of --slurm submissions; it does nothing {}",
            if a.plan {
                "with --plan (edit the run's scripts, or use --slurm)"
            } else {
                "without --slurm"
            }
        )));
    }
    if a.reference_shards.is_some() && !(a.plan || a.slurm) {
        return Err(Error::input(
            "--reference-shards splits the reference of a planned run: use it with --plan or --slurm",
        ));
    }
    Ok(())
}

/// Write the Slurm scripts of a planned run and submit them (or print them with `--dry-run`).
fn slurm_submit(
    run_dir: &Path,
    plan: &crate::experiment::cluster::plan::Plan,
    jobs: usize,
    mut opts: crate::experiment::cluster::slurm::SlurmOptions,
) -> Result<(), Error> {
    use crate::experiment::cluster::slurm;
    if opts.cpus_per_task.is_none() {
        let cfg = crate::experiment::Config::load(&plan.config_file)?;
        opts.cpus_per_task = Some(cfg.threads.unwrap_or(1).min(1024) as u32);
    }
    let exe = std::env::current_exe()
        .map_err(|e| Error::runtime(format!("cannot find the stokes binary: {e}")))?;
    let scripts = slurm::write_scripts(run_dir, jobs, &plan.name, &exe, &opts)?;
    // After the scripts are written: an oversized run is then submitted in parts with them.
    let fits = slurm::check_array_size(jobs, slurm::max_array_size());
    if opts.dry_run {
        if let Err(e) = fits {
            eprintln!("warning: {}", e.message);
        }
        for p in [&scripts.array, &scripts.collect] {
            let text =
                crate::io::input::read_text(p, crate::io::input::RUN_RECORD).unwrap_or_default();
            println!("# {}\n{text}", p.display());
        }
        eprintln!(
            "dry run: nothing submitted; submit with `bash {}`",
            scripts.submit.display()
        );
        return Ok(());
    }
    fits?;
    let (array, collect) = slurm::submit(&scripts)?;
    eprintln!(
        "submitted array job {array} ({jobs} tasks) and collect job {collect} (afterok:{array}); results: {}",
        run_dir.display()
    );
    println!("{array} {collect}");
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct JobArgs {
    /// Run folder planned with `stokes experiment CONFIG --plan` (or `--slurm`).
    pub run_dir: PathBuf,
    /// Job index (line of jobs.jsonl, from 0); default: SLURM_ARRAY_TASK_ID.
    #[arg(conflicts_with = "all")]
    pub index: Option<usize>,
    /// Run every job that has not finished, one after the other.
    #[arg(long)]
    pub all: bool,
}

/// `stokes job`: run one job of a planned run (skipped when it already finished), or all.
pub fn job(a: &JobArgs) -> Result<(), Error> {
    use crate::experiment::cluster;
    if a.all {
        return cluster::run_all(&a.run_dir);
    }
    cluster::run_job(&a.run_dir, cluster::job_index(a.index)?)
}

/// `stokes figures`: regenerate the figures of a stored run (only the plots with `plots_only`).
pub fn figures(dir: &Path, plots_only: bool) -> Result<(), Error> {
    // An interrupted run has no run.json yet: look for its marker first.
    crate::experiment::record::check_complete(dir)?;
    let run = crate::experiment::figures::resolve_run_dir(dir)?;
    crate::experiment::record::check_complete(&run)?;
    crate::io::tree::check_run_folder(&run).map_err(Error::input)?;
    let files = crate::experiment::figures::make(&run, !plots_only)?;
    for f in files {
        println!("{}", f.display());
    }
    Ok(())
}

/// `stokes report`: write `report.html` into a stored run folder and print its path.
pub fn report(dir: &Path) -> Result<(), Error> {
    let w = crate::experiment::report::write(dir)?;
    eprintln!(
        "report: {} images, {} figures, {:.1} MB",
        w.images,
        w.figures,
        w.bytes as f64 / 1e6
    );
    println!("{}", w.file.display());
    Ok(())
}
