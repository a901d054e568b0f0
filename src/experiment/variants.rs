//! Renders every variant at every budget mode and repeat, taking snapshots as the budgets are
//! reached: each snapshot's EXR (repeat 0, and the last budget of every repeat) and its metrics
//! against the reference over the whole image and per region.

use super::config::{BudgetMode, Variant};
use super::metrics::{self, ErrorMetrics};
use super::progress::per_job;
use super::record::{ModeBudgets, Row, image_file};
use super::regions::Region;
use super::setup::Setup;
use crate::error::Error;
use crate::film::Film;
use crate::film::output::write_exr;
use crate::film::spectral::write_spectral_exr;
use crate::integrator::{RenderSettings, Stats, render};
use glam::Vec3;
use indicatif::ProgressBar;
use std::path::Path;
use std::time::Instant;

/// What every variant render shares.
pub struct Runs<'a> {
    pub setup: &'a Setup,
    pub run_dir: &'a Path,
    pub reference: Option<&'a [Vec3]>,
    pub regions: &'a [Region],
    pub bar: &'a ProgressBar,
    /// Write every snapshot's EXR (a cluster job, whose metrics are computed at collect), not
    /// only repeat 0's and each repeat's last.
    pub keep_all: bool,
}

/// What a snapshot measured: the samples done and the render time at that budget.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct SnapshotStat {
    /// Index of the budget in its mode.
    pub budget: usize,
    pub spp: u32,
    /// Render seconds (snapshot overhead excluded).
    pub seconds: f64,
    pub samples_per_second: f64,
}

impl Runs<'_> {
    /// Render every variant at every mode and repeat; the metrics rows in that order.
    pub fn render_all(&self) -> Result<Vec<Row>, Error> {
        let mut rows = Vec::new();
        for mb in &self.setup.modes {
            for i in 0..self.setup.cfg.variants.len() {
                for rep in 0..self.setup.cfg.repeats {
                    self.render_one(mb, i, rep, &mut rows)?;
                }
            }
        }
        Ok(rows)
    }

    /// Variant `i` at the budgets `mb`, repeat `rep` (seed `seed + rep`), in its own scene
    /// when it has one. Adds its metrics rows (with a reference) and returns what each
    /// snapshot measured.
    pub fn render_one(
        &self,
        mb: &ModeBudgets,
        i: usize,
        rep: u32,
        rows: &mut Vec<Row>,
    ) -> Result<Vec<SnapshotStat>, Error> {
        let cfg = &self.setup.cfg;
        let v = &cfg.variants[i];
        let seed = cfg.seed + rep as u64;
        self.bar.set_message(format!(
            "{} ({} budget, repeat {}/{})",
            v.name,
            mb.mode.name(),
            rep + 1,
            cfg.repeats
        ));
        let settings = RenderSettings {
            first_sample: 0,
            spp: match mb.mode {
                BudgetMode::Spp => *mb.budgets.last().unwrap() as u32,
                BudgetMode::Time => u32::MAX,
            },
            seed,
            threads: cfg.threads,
            time_limit: None,
            progress: false,
            spectral: cfg.spectral,
            cancel: self.setup.cancel.clone(),
        };
        let mut snap = Snapshots {
            runs: self,
            mb,
            variant: v,
            rep,
            seed,
            next: 0,
            overhead: 0.0,
            failure: None,
            done_units: 0,
            rows,
            stats: Vec::new(),
        };
        let mut cb = |film: &Film, stats: &Stats, secs: f64| snap.on_pass(film, stats, secs);
        render(
            self.setup.variant_scene(i),
            v.integrator,
            &v.options,
            &settings,
            Some(&mut cb),
        )
        .map_err(|e| {
            Error::runtime(format!(
                "variant `{}`: integrator `{}`: {e}",
                v.name,
                v.integrator.name()
            ))
        })?;
        if let Some(e) = snap.failure {
            return Err(Error::runtime(e));
        }
        self.bar.inc(per_job(mb).saturating_sub(snap.done_units));
        Ok(snap.stats)
    }
}

/// The state of one render between passes: which budget is next and what has been measured.
struct Snapshots<'a, 'r> {
    runs: &'a Runs<'a>,
    mb: &'a ModeBudgets,
    variant: &'a Variant,
    rep: u32,
    seed: u64,
    /// Index of the next budget to snapshot.
    next: usize,
    /// Seconds spent in snapshots, not counted as render time.
    overhead: f64,
    /// A snapshot that could not be written (stops the render).
    failure: Option<String>,
    /// Progress units reported so far.
    done_units: u64,
    rows: &'r mut Vec<Row>,
    stats: Vec<SnapshotStat>,
}

impl Snapshots<'_, '_> {
    /// After each pass: snapshot every budget now reached. Returns whether to go on.
    fn on_pass(&mut self, film: &Film, stats: &Stats, secs: f64) -> bool {
        let t0 = Instant::now();
        let mb = self.mb;
        let eff = (secs - self.overhead).max(1e-9);
        let units = match mb.mode {
            BudgetMode::Spp => film.spp as u64,
            BudgetMode::Time => ((eff * 100.0) as u64).min(per_job(mb)),
        };
        if units > self.done_units {
            self.runs.bar.inc(units - self.done_units);
            self.done_units = units;
        }
        let mut rgb: Option<Vec<Vec3>> = None;
        while self.next < mb.budgets.len() {
            let due = match mb.mode {
                BudgetMode::Spp => film.spp as f64 >= mb.budgets[self.next],
                BudgetMode::Time => eff >= mb.budgets[self.next],
            };
            if !due {
                break;
            }
            let img = rgb.get_or_insert_with(|| film.rgb());
            if let Err(e) = self.snapshot(film, stats, img, eff) {
                self.failure = Some(e);
                return false;
            }
            self.next += 1;
        }
        self.overhead += t0.elapsed().as_secs_f64();
        self.next < mb.budgets.len()
    }

    /// Snapshot budget `next`: write its EXR when kept and measure it against the reference.
    fn snapshot(
        &mut self,
        film: &Film,
        stats: &Stats,
        img: &[Vec3],
        eff: f64,
    ) -> Result<(), String> {
        let (mb, v, rep, next) = (self.mb, self.variant, self.rep, self.next);
        let is_last = next + 1 == mb.budgets.len();
        let stat = SnapshotStat {
            budget: next,
            spp: film.spp,
            seconds: eff,
            samples_per_second: stats.paths as f64 / eff,
        };
        self.stats.push(stat);
        if rep == 0 || is_last || self.runs.keep_all {
            let f = self
                .runs
                .run_dir
                .join(image_file(&v.name, mb.mode, next, rep));
            write_exr(&f, film.width, film.height, img)?;
        }
        if let Some(sf) = film.spectral.as_ref().filter(|_| rep == 0 && is_last) {
            let f = self
                .runs
                .run_dir
                .join(image_file(&v.name, mb.mode, next, rep))
                .with_extension("spectral.exr");
            let values = sf.values(film.spp);
            let size = (film.width, film.height);
            write_spectral_exr(&f, size, &sf.bins, &values, img, &[])?;
        }
        if let Some(r) = self.runs.reference {
            let key = RowKey {
                variant: v,
                mode: mb,
                repeat: rep,
                seed: self.seed,
            };
            metric_rows(&key, &stat, img, r, self.runs.regions, self.rows);
        }
        Ok(())
    }
}

/// Which render a snapshot belongs to.
pub struct RowKey<'a> {
    pub variant: &'a Variant,
    pub mode: &'a ModeBudgets,
    pub repeat: u32,
    pub seed: u64,
}

/// The metrics rows of one snapshot `img` against the reference `r`: the whole image, then each
/// region, in that order.
pub fn metric_rows(
    key: &RowKey,
    stat: &SnapshotStat,
    img: &[Vec3],
    r: &[Vec3],
    regions: &[Region],
    rows: &mut Vec<Row>,
) {
    let v = key.variant;
    let mut push = |region: &str, m: ErrorMetrics| {
        rows.push(Row {
            variant: v.name.clone(),
            integrator: v.integrator.name().into(),
            mode: key.mode.mode.name().into(),
            budget: key.mode.budgets[stat.budget],
            repeat: key.repeat,
            seed: key.seed,
            spp: stat.spp,
            seconds: stat.seconds,
            samples_per_second: stat.samples_per_second,
            region: region.into(),
            pixels: m.pixels,
            mse: m.mse,
            rel_mse: m.rel_mse,
            snr_db: m.snr_db,
            efficiency: metrics::efficiency(m.rel_mse, stat.seconds),
        })
    };
    push("all", metrics::compare(img, r, None));
    for g in regions {
        push(&g.name, metrics::compare(img, r, Some(&g.mask)));
    }
}
