//! Experiments: configs, runs against a reference, error metrics and paper-style figures.
//!
//! `stokes experiment CONFIG.json` renders every variant at every budget snapshot and writes
//! `results/<name>/runs/<timestamp>/` with `metrics.csv`, `summary.json`, `run.json`, the
//! reference and snapshot EXRs, `figures/` and `report.html` ([`report`]). `stokes figures
//! RUN_DIR` rebuilds the figures from those files without rendering, `stokes report RUN_DIR` the
//! report.

pub mod cluster;
pub mod config;
pub mod figures;
pub mod latex_table;
pub mod metrics;
pub mod record;
pub mod report;
pub mod runner;

// The steps of a run, which `runner` takes in the order setup, reference, regions, variants,
// grid (once per value of a `sweep`); `progress` is the bar they share, `overrides` changes the
// scene JSON for the grid and the sweep.
mod grid;
pub mod overrides;
pub mod progress;
mod reference;
mod regions;
mod setup;
mod sweep;
mod variants;

pub use config::Config;
pub use metrics::{ErrorMetrics, compare};
pub use record::RunInfo;
pub use runner::{run_experiment, run_experiment_from};
pub use setup::Source;
