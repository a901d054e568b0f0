//! The `stokes` command line.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use stokes::cli;

/// The memory allocator: mimalloc. The system's (glibc) grows each worker thread's heap with
/// thousands of `mprotect` calls, and with it 2-thread renders scaled worse and varied more from
/// run to run (docs/performance.md, §4).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[derive(Parser)]
#[command(
    name = "stokes",
    version,
    about = "A research testbed for fluorescence in spectral light transport"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to OpenEXR (and optionally PNG and a stats JSON).
    Render(Box<cli::RenderArgs>),
    /// Merge sample-range shards of one render (`render --samples`) into one EXR, exactly.
    Merge(cli::MergeArgs),
    /// Run an experiment config: variants against a reference, metrics and figures.
    Experiment(cli::ExperimentArgs),
    /// Run one job of a planned experiment (`experiment --plan`/`--slurm`); in a Slurm array
    /// job the index comes from SLURM_ARRAY_TASK_ID.
    Job(cli::JobArgs),
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
    Diff(cli::DiffArgs),
    /// Write an sRGB PNG of an EXR (fixed exposure, or the 99th percentile to white).
    Png(cli::PngArgs),
    /// Print what a scene contains (materials, lights, fluorescence) after validation.
    Inspect {
        /// Scene JSON file.
        scene: PathBuf,
    },
}

#[derive(Subcommand)]
enum GmmCommand {
    /// Fit a BFC file, or every BFC file of a folder, with a Gaussian mixture.
    Fit(cli::GmmFitArgs),
    /// Write the dense matrix a fitted model evaluates to, as a BFC file.
    Dense(cli::GmmDenseArgs),
    /// ΔE00 of fits against the measured matrices of a folder (Hua §7), with box plots.
    Eval(cli::GmmEvalArgs),
}

/// On SIGINT, SIGTERM or SIGHUP: delete the temporary output files being written (finished
/// outputs are never touched) and exit with 128 + the signal number (130, 143, 129).
fn handle_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        eprintln!(
            "warning: cannot install the signal handler; an interrupted write may leave a temporary file"
        );
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            stokes::film::output::remove_in_flight();
            eprintln!("interrupted (signal {sig}): temporary files removed");
            std::process::exit(128 + sig);
        }
    });
}

fn main() -> ExitCode {
    let args = Cli::parse();
    handle_signals();
    let r = match args.command {
        Command::Render(a) => cli::render(&a),
        Command::Inspect { scene } => cli::inspect(&scene),
        Command::Diff(a) => cli::diff(&a),
        Command::Png(a) => cli::png(&a),
        Command::Merge(a) => cli::merge(&a),
        Command::Job(a) => cli::job(&a),
        Command::Experiment(a) => cli::experiment(&a),
        Command::Figures {
            results_dir,
            plots_only,
        } => cli::figures(&results_dir, plots_only),
        Command::Report { run_dir } => cli::report(&run_dir),
        Command::Gmm { command } => match command {
            GmmCommand::Fit(a) => cli::gmm_fit(&a),
            GmmCommand::Dense(a) => cli::gmm_dense(&a),
            GmmCommand::Eval(a) => cli::gmm_eval(&a),
        },
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Messages quote names and values from files: their control bytes are escaped.
            eprintln!(
                "error: {}",
                stokes::io::text::escape_control(&e.message, true)
            );
            ExitCode::from(e.exit_code())
        }
    }
}
