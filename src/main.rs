//! The `stokes` command line.

use clap::Parser;
use std::process::ExitCode;
use stokes::cli;

/// The memory allocator: mimalloc. The system's (glibc) grows each worker thread's heap with
/// thousands of `mprotect` calls, and with it 2-thread renders scaled worse and varied more from
/// run to run (docs/performance.md, §4).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

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
            stokes::io::output::remove_in_flight();
            eprintln!("interrupted (signal {sig}): temporary files removed");
            std::process::exit(128 + sig);
        }
    });
}

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    handle_signals();
    let r = cli::run(args.command);
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
