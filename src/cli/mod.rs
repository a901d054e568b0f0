//! The `stokes` command line: the top-level parser, what the commands share, and one file per
//! command or close group. Kept in the library so tests can call it; errors are the library's
//! [`Error`], whose kind `main.rs` turns into the exit code.

mod choice;
mod diff;
mod experiment;
mod gmm;
mod gmm_robust;
mod inspect;
mod merge;
mod png;
mod render;
#[cfg(test)]
mod tests;

pub use choice::{Choice, ChoiceParser, choice};
pub use diff::{DiffArgs, diff};
pub use experiment::{ExperimentArgs, JobArgs, experiment, figures, job, report};
pub use gmm::{
    GmmDenseArgs, GmmEvalArgs, GmmFigsArgs, GmmFitArgs, gmm_dense, gmm_eval, gmm_figures, gmm_fit,
};
pub use gmm_robust::{GmmRobustnessArgs, gmm_robustness};
pub use inspect::inspect;
pub use merge::{MergeArgs, merge};
pub use png::{PngArgs, png};
pub use render::{RenderArgs, RenderOutputs, render, render_cmd_validate};

use crate::Error;
use crate::io::text::show_path;
use crate::scene::Scene;
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "stokes",
    version,
    about = "A research testbed for fluorescence in spectral light transport"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene to OpenEXR (and optionally PNG and a stats JSON).
    Render(Box<RenderArgs>),
    /// Merge sample-range shards of one render (`render --samples`) into one EXR, exactly.
    Merge(MergeArgs),
    /// Run an experiment config: variants against a reference, metrics and figures.
    Experiment(ExperimentArgs),
    /// Run one job of a planned experiment (`experiment --plan`/`--slurm`); in a Slurm array
    /// job the index comes from SLURM_ARRAY_TASK_ID.
    Job(JobArgs),
    /// Regenerate every figure of a stored run (a run folder, or an experiment folder with `latest`).
    Figures {
        /// Run folder (results/<name>/runs/<timestamp>) or experiment folder (results/<name>).
        results_dir: PathBuf,
        /// Only the plots that metrics.csv gives (convergence, sweep, the SNR table), for a run
        /// whose images were not kept; without it a missing image is an error.
        #[arg(long)]
        plots_only: bool,
    },
    /// Write report.html into a stored run folder: one self-contained page with an HDR image
    /// viewer (exposure, relative error, zoom), the metrics tables, the figures and the config.
    Report {
        /// Run folder (results/<name>/runs/<timestamp>) or experiment folder (results/<name>).
        run_dir: PathBuf,
    },
    /// Gaussian-mixture reradiation models (Hua 2022): fit measured matrices, evaluate the fits.
    Gmm {
        #[command(subcommand)]
        command: GmmCommand,
    },
    /// The signed luminance difference of two EXRs as a figure (both images and Y(a) − Y(b)).
    Diff(DiffArgs),
    /// Write an sRGB PNG of an EXR (fixed exposure, or the 99th percentile to white).
    Png(PngArgs),
    /// Print what a scene contains (materials, lights, fluorescence) after validation.
    Inspect {
        /// Scene JSON file.
        scene: PathBuf,
    },
}

#[derive(Subcommand)]
pub enum GmmCommand {
    /// Fit a BFC file, or every BFC file of a folder, with a Gaussian mixture.
    Fit(GmmFitArgs),
    /// Write the dense matrix a fitted model evaluates to, as a BFC file.
    Dense(GmmDenseArgs),
    /// ΔE00 of fits against the measured matrices of a folder (Hua §7), with box plots.
    Eval(GmmEvalArgs),
    /// Hua's Figs. 4, 5, 6, 7a and 8a from the fits of a folder of BFC files.
    Figures(GmmFigsArgs),
    /// How much a fit's ΔE00 depends on its seed, with one start and with restarts, and the
    /// number of Gaussians BIC chooses against where ΔE00 stops improving.
    Robustness(GmmRobustnessArgs),
}

/// Run a parsed command.
pub fn run(command: Command) -> Result<(), Error> {
    // An instruction set the user forces but cannot have is refused before any work.
    crate::geometry::Isa::from_env().map_err(|e| Error::input(e.to_string()))?;
    match command {
        Command::Render(a) => render(&a),
        Command::Inspect { scene } => inspect(&scene),
        Command::Diff(a) => diff(&a),
        Command::Png(a) => png(&a),
        Command::Merge(a) => merge(&a),
        Command::Job(a) => job(&a),
        Command::Experiment(a) => experiment(&a),
        Command::Figures {
            results_dir,
            plots_only,
        } => figures(&results_dir, plots_only),
        Command::Report { run_dir } => report(&run_dir),
        Command::Gmm { command } => match command {
            GmmCommand::Fit(a) => gmm_fit(&a),
            GmmCommand::Dense(a) => gmm_dense(&a),
            GmmCommand::Eval(a) => gmm_eval(&a),
            GmmCommand::Figures(a) => gmm_figures(&a),
            GmmCommand::Robustness(a) => gmm_robustness(&a),
        },
    }
}

/// The `--set PATH=JSON` arguments as (dot path, value), or an input error naming the argument.
pub fn parse_sets(sets: &[String]) -> Result<Vec<(String, serde_json::Value)>, Error> {
    sets.iter()
        .map(|a| {
            let (k, v) = a.split_once('=').ok_or_else(|| {
                Error::input(format!(
                    "--set '{a}': expected PATH=JSON, e.g. media.dye.fluorescence.concentration=0"
                ))
            })?;
            if k.is_empty() || k.split('.').any(str::is_empty) {
                return Err(Error::input(format!(
                    "--set '{a}': '{k}' is not a dot path of object keys"
                )));
            }
            let v: serde_json::Value = serde_json::from_str(v)
                .map_err(|e| Error::input(format!("--set '{a}': the value is not JSON: {e}")))?;
            Ok((k.to_string(), v))
        })
        .collect()
}

/// Load a scene and print its warnings.
pub fn load_scene(path: &Path, quiet: bool) -> Result<Scene, Error> {
    let scene = Scene::load(path)?;
    print_warnings(path, &scene, quiet);
    Ok(scene)
}

/// Print a scene's warnings (their text comes from the scene: control bytes are escaped).
fn print_warnings(path: &Path, scene: &Scene, quiet: bool) {
    if !quiet {
        for w in &scene.warnings {
            eprintln!(
                "warning: {}: {}",
                show_path(path),
                crate::io::text::escape_control(w, false)
            );
        }
    }
}

/// Largest `--exposure` magnitude, stops.
pub const MAX_EXPOSURE: f32 = 64.0;

/// The input error of the output option `opt` given `p`, from the message `e` of its check (which
/// names the path itself when it is about the path, so it is not named twice).
fn output_error(opt: &str, p: &Path, e: String) -> Error {
    if e.starts_with(&format!("'{}'", show_path(p))) {
        Error::input(format!("{opt} {e}"))
    } else {
        Error::input(format!("{opt} '{}': {e}", show_path(p)))
    }
}

/// What the camera of `scene` integrates, for the spectral EXR's `stokes.sensor` attribute.
fn sensor_label(scene: &Scene) -> String {
    let r = scene.observer.range;
    match scene.observer.sensor_response() {
        None => format!("cie-1931 over [{}, {}] nm", r.min, r.max),
        Some(crate::spectrum::Spectrum::Box { .. }) => format!("band [{}, {}] nm", r.min, r.max),
        Some(_) => format!("response curve over [{}, {}] nm", r.min, r.max),
    }
}
