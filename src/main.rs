//! The `stokes` command line.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use stokes::cli;

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
    /// Print what a scene contains (materials, lights, fluorescence) after validation.
    Inspect {
        /// Scene JSON file.
        scene: PathBuf,
    },
}

fn main() -> ExitCode {
    let args = Cli::parse();
    let r = match args.command {
        Command::Render(a) => cli::render(&a),
        Command::Inspect { scene } => cli::inspect(&scene),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.message);
            ExitCode::from(e.code)
        }
    }
}
