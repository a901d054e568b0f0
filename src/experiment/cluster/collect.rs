//! `stokes experiment --collect RUN_DIR`: the last step of a planned run. It waits for nothing:
//! every job must have finished (the missing and failed ones are named), then it merges the
//! reference's shards, computes the metrics from the jobs' snapshots and writes `metrics.csv`,
//! `summary.json`, `run.json`, the images and the figures exactly as a run on one machine does,
//! plus `jobs.csv`: where and how fast each job ran.

use super::super::record::{
    GridCell, Row, image_file, mark_complete, mark_incomplete, mkdir, write_text,
};
use super::super::regions;
use super::super::runner::{print_summary, run_info, write_results};
use super::super::setup::Setup;
use super::super::sweep::{self, Point, SweepRecord};
use super::super::variants::{RowKey, metric_rows};
use super::super::{figures, reference};
use super::job::{JobRecord, failure, finished, job_dir};
use super::plan::{Job, Plan, Work, inputs_hash, ranges, read_plan};
use crate::error::Error;
use crate::film::output::{read_exr, write_exr};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Collect the planned run in `run_dir`. Returns the run folder.
pub fn collect(run_dir: &Path) -> Result<PathBuf, Error> {
    let run = read_plan(run_dir)?;
    let (plan, jobs, run_dir) = (&run.plan, &run.jobs, run.dir.clone());
    let records = finished_jobs(&run_dir, jobs)?;
    let setup = Setup::load(&plan.config_file, run.root.as_deref(), plan.quick)?;
    if run.root.is_some() {
        // `<name>/latest` and the reference cache: no link, FIFO or device on the way
        setup.check_writable()?;
    }
    if inputs_hash(&setup)? != plan.inputs_hash {
        return Err(Error::input(format!(
            "the config '{}' or its scene changed since the run was planned: its jobs rendered another experiment",
            plan.config_file.display()
        )));
    }
    mark_incomplete(
        &run_dir,
        &format!("collecting planned experiment '{}'", plan.name),
    )?;
    let done: Vec<(&Job, &JobRecord)> = jobs.iter().zip(&records).collect();
    write_timings(&run_dir, &done)?;
    let c = Collect {
        plan,
        run_dir: &run_dir,
        cache_reference: run.root.is_some(),
    };
    match &setup.cfg.sweep {
        None => {
            let rows = c.point(&setup, &run_dir, &done, None)?;
            print_summary(&rows);
        }
        Some(sw) => {
            let points = sweep::points(&setup)?;
            let mut results: Vec<(&Point, Vec<Row>)> = Vec::new();
            for p in &points {
                let dir = run_dir.join(&p.dir);
                mkdir(&dir)?;
                results.push((p, c.point(&p.setup, &dir, &done, Some(p.index))?));
            }
            write_text(
                &run_dir.join("sweep.json"),
                &serde_json::to_string_pretty(&SweepRecord::new(sw, &results)).unwrap(),
            )?;
            let info = run_info(&setup, false, &[], Vec::new(), plan.started.clone());
            write_text(
                &run_dir.join("run.json"),
                &serde_json::to_string_pretty(&info).unwrap(),
            )?;
            figures::sweep_summary(&run_dir)?;
            for (p, rows) in &results {
                eprintln!("{} = {}:", sw.label(), sweep::compact(&p.value));
                print_summary(rows);
            }
        }
    }
    mark_complete(&run_dir)?;
    if let (Some(root), Some(name)) = (&run.root, &plan.run_name) {
        write_text(
            &root.join(&plan.name).join("latest"),
            &format!("runs/{name}\n"),
        )?;
    }
    super::super::report::write(&run_dir)?;
    eprintln!("results: {}", run_dir.display());
    Ok(run_dir)
}

/// The records of every job, or an error naming the missing and the failed ones.
fn finished_jobs(run_dir: &Path, jobs: &[Job]) -> Result<Vec<JobRecord>, Error> {
    let mut records = Vec::new();
    let (mut missing, mut failed) = (Vec::new(), Vec::new());
    for j in jobs {
        match finished(run_dir, j) {
            Some(r) => records.push(r),
            None => match failure(run_dir, j) {
                Some(f) => failed.push(format!(
                    "  job {} ({}) failed on {} at {}: {}",
                    j.index,
                    j.describe(),
                    f.host,
                    f.time,
                    f.error
                )),
                None => missing.push(j.index),
            },
        }
    }
    if missing.is_empty() && failed.is_empty() {
        return Ok(records);
    }
    let mut m = format!(
        "'{}': {} of {} jobs have not finished",
        run_dir.display(),
        missing.len() + failed.len(),
        jobs.len()
    );
    if !missing.is_empty() {
        m += &format!(
            "\n  missing (never ran, still running, or killed): {}",
            ranges(&missing)
        );
    }
    if !failed.is_empty() {
        m += &format!("\n{}", failed.join("\n"));
    }
    m += &format!(
        "\nrun them with `stokes job {} INDEX` (finished jobs are skipped)",
        run_dir.display()
    );
    let submit = run_dir.join("slurm").join("submit.sh");
    if submit.is_file() {
        m += &format!(", or re-submit with `bash {}`", submit.display());
    }
    Err(Error::input(m))
}

/// `jobs.csv`: every job's host, CPU model, threads and seconds; prints the table and warns
/// when the jobs of one comparison (a mode of a sweep value) ran on different CPU models.
fn write_timings(run_dir: &Path, done: &[(&Job, &JobRecord)]) -> Result<(), Error> {
    let mut csv = String::from("index,job,host,cpu_model,threads,seconds,slurm_job\n");
    eprintln!(
        "{:>5}  {:<44} {:<16} {:>7} {:>9}",
        "job", "what", "host", "threads", "seconds"
    );
    for (j, r) in done {
        let q = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
        csv += &format!(
            "{},{},{},{},{},{:.6},{}\n",
            j.index,
            q(&j.describe()),
            q(&r.host),
            q(&r.cpu_model),
            r.threads,
            r.seconds,
            r.slurm_job.clone().unwrap_or_default()
        );
        eprintln!(
            "{:>5}  {:<44} {:<16} {:>7} {:>9.2}",
            j.index,
            j.describe(),
            r.host,
            r.threads,
            r.seconds
        );
    }
    let mut groups: std::collections::BTreeMap<String, std::collections::BTreeSet<&str>> =
        Default::default();
    for (j, r) in done {
        if let Work::Variant { mode, .. } = &j.work {
            let key = format!(
                "{}{} budget",
                j.point.map(|p| format!("sweep {p}, ")).unwrap_or_default(),
                mode.name()
            );
            groups.entry(key).or_default().insert(&r.cpu_model);
        }
    }
    for (k, models) in groups {
        if models.len() > 1 {
            eprintln!(
                "warning: the {k} comparison ran on {} CPU models ({}): its times are not comparable across them",
                models.len(),
                models.into_iter().collect::<Vec<_>>().join("; ")
            );
        }
    }
    write_text(&run_dir.join("jobs.csv"), &csv)
}

/// What the collection of every sweep value shares.
struct Collect<'a> {
    plan: &'a Plan,
    run_dir: &'a Path,
    /// Whether the run lies in a results root, whose reference cache takes the merged shards.
    cache_reference: bool,
}

impl Collect<'_> {
    /// Collect one run folder `dir` (the run, or a sweep value's) from its jobs.
    fn point(
        &self,
        s: &Setup,
        dir: &Path,
        done: &[(&Job, &JobRecord)],
        point: Option<usize>,
    ) -> Result<Vec<Row>, Error> {
        let mine: Vec<(&Job, &JobRecord)> = done
            .iter()
            .copied()
            .filter(|(j, _)| j.point == point)
            .collect();
        mkdir(&dir.join("images"))?;
        let reference = self.reference(s, &mine)?;
        if let Some(img) = &reference {
            write_exr(&dir.join("reference.exr"), s.width, s.height, img)
                .map_err(Error::runtime)?;
        }
        let regions = regions::masks(s, dir)?;
        let mut rows = Vec::new();
        for mb in &s.modes {
            for (i, v) in s.cfg.variants.iter().enumerate() {
                for rep in 0..s.cfg.repeats {
                    let (j, r) = mine
                        .iter()
                        .find(|(j, _)| {
                            matches!(&j.work, Work::Variant { variant, mode, repeat, .. }
                                if *variant == i && *mode == mb.mode && *repeat == rep)
                        })
                        .ok_or_else(|| self.unplanned(&format!("{} repeat {rep}", v.name)))?;
                    let key = RowKey {
                        variant: v,
                        mode: mb,
                        repeat: rep,
                        seed: j.seed,
                    };
                    for st in &r.snapshots {
                        let f = image_file(&v.name, mb.mode, st.budget, rep);
                        let src = job_dir(self.run_dir, j).join(&f);
                        let (w, h, img) = read_exr(&src).map_err(Error::input)?;
                        if (w, h) != (s.width, s.height) || st.budget >= mb.budgets.len() {
                            return Err(Error::input(format!(
                                "'{}': {w}×{h} image of budget {}, the run is {}×{} with {} budgets",
                                src.display(),
                                st.budget,
                                s.width,
                                s.height,
                                mb.budgets.len()
                            )));
                        }
                        if let Some(refimg) = &reference {
                            metric_rows(&key, st, &img, refimg, &regions, &mut rows);
                        }
                        if rep == 0 || st.budget + 1 == mb.budgets.len() {
                            copy(&src, &dir.join(&f))?;
                        }
                        // the spectral image of the final budget (`spectral`), as a run on one
                        // machine writes it
                        let spectral = src.with_extension("spectral.exr");
                        if s.cfg.spectral.is_some()
                            && rep == 0
                            && st.budget + 1 == mb.budgets.len()
                            && spectral.is_file()
                        {
                            copy(&spectral, &dir.join(&f).with_extension("spectral.exr"))?;
                        }
                    }
                }
            }
        }
        let cells = self.grid(s, dir, &mine)?;
        let info = run_info(
            s,
            reference.is_some(),
            &regions,
            cells,
            self.plan.started.clone(),
        );
        write_results(dir, &rows, &info)?;
        figures::make_all(dir)?;
        Ok(rows)
    }

    /// The reference: the merged shards (cached for later runs when the run is in the results
    /// root), or the config's EXR or the cached render.
    fn reference(
        &self,
        s: &Setup,
        mine: &[(&Job, &JobRecord)],
    ) -> Result<Option<Vec<Vec3>>, Error> {
        let shards: Vec<&Job> = mine
            .iter()
            .filter(|(j, _)| matches!(j.work, Work::ReferenceShard { .. }))
            .map(|(j, _)| *j)
            .collect();
        if shards.is_empty() {
            return reference::get(s, &indicatif::ProgressBar::hidden());
        }
        let read = shards
            .iter()
            .map(|j| {
                crate::film::shard::read_shard(&job_dir(self.run_dir, j).join("reference.exr"))
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(Error::input)?;
        let merged = crate::film::shard::merge(read).map_err(Error::input)?;
        let spp = s.cfg.reference.as_ref().and_then(|r| r.spp).unwrap_or(0);
        if (merged.info.from, merged.info.to) != (0, spp)
            || (merged.width, merged.height) != (s.width, s.height)
        {
            return Err(Error::input(format!(
                "the reference shards of '{}' merge into samples {}..{} at {}×{}, the config asks for 0..{spp} at {}×{}",
                self.run_dir.display(),
                merged.info.from,
                merged.info.to,
                merged.width,
                merged.height,
                s.width,
                s.height
            )));
        }
        let img = merged.film().rgb();
        if self.cache_reference
            && let Some(r) = &s.cfg.reference
        {
            write_exr(&reference::cache_file(s, r), s.width, s.height, &img)
                .map_err(Error::runtime)?;
        }
        Ok(Some(img))
    }

    /// Copy the grid cells' images into `dir/grid/`, with each cell's mean over the grid's
    /// material and `grid.csv` as a run on one machine writes them.
    fn grid(
        &self,
        s: &Setup,
        dir: &Path,
        mine: &[(&Job, &JobRecord)],
    ) -> Result<Vec<GridCell>, Error> {
        let mut cells = Vec::new();
        for (j, r) in mine {
            if let Work::GridCell { row, column } = j.work {
                let file = r
                    .files
                    .first()
                    .cloned()
                    .ok_or_else(|| self.unplanned(&format!("grid cell ({row}, {column})")))?;
                mkdir(&dir.join("grid"))?;
                copy(&job_dir(self.run_dir, j).join(&file), &dir.join(&file))?;
                let (g, rgb) = (s.cfg.grid.as_ref(), read_exr(&dir.join(&file)));
                let material_mean_y = match (g, rgb) {
                    (Some(g), Ok((_, _, rgb))) => {
                        super::super::grid::material_mean_y(&s.scene, &g.material, &rgb)
                    }
                    _ => None,
                };
                cells.push(GridCell {
                    row,
                    column,
                    file,
                    material_mean_y,
                });
            }
        }
        if let Some(g) = s.cfg.grid.as_ref().filter(|_| !cells.is_empty()) {
            let csv = super::super::grid::cells_csv(g, &cells);
            write_text(&dir.join("grid.csv"), &csv)?;
        }
        Ok(cells)
    }

    fn unplanned(&self, what: &str) -> Error {
        Error::input(format!(
            "'{}': the plan has no job for {what} of the config: plan the run again",
            self.run_dir.join(super::plan::JOBS_FILE).display()
        ))
    }
}

/// Copy `from` to `to` atomically.
fn copy(from: &Path, to: &Path) -> Result<(), Error> {
    crate::io::output::write_atomic(to, |tmp| {
        std::fs::copy(from, tmp).map(drop).map_err(|e| {
            format!(
                "cannot copy '{}' to '{}': {e}",
                from.display(),
                to.display()
            )
        })
    })
    .map_err(Error::runtime)
}
