//! The progress bar of a run (shown on a terminal only). Its units: passes for the reference
//! and spp budgets, centiseconds for time budgets.

use super::config::{BudgetMode, Config};
use super::record::ModeBudgets;
use indicatif::{ProgressBar, ProgressStyle};

/// A bar over `total` units; hidden when stderr is not a terminal.
pub fn bar(total: u64) -> ProgressBar {
    if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let b = ProgressBar::new(total);
        b.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {percent:>3}%  eta {eta}  {msg}",
            )
            .unwrap()
            .progress_chars("=> "),
        );
        b
    } else {
        ProgressBar::hidden()
    }
}

/// Units of one render job (one variant and repeat, or one grid cell) at the budgets `mb`.
pub fn per_job(mb: &ModeBudgets) -> u64 {
    match mb.mode {
        BudgetMode::Spp => *mb.budgets.last().unwrap() as u64,
        BudgetMode::Time => (*mb.budgets.last().unwrap() * 100.0).ceil() as u64,
    }
}

/// Units of the whole run: reference, variants at every mode and repeat, grid cells.
pub fn total(cfg: &Config, modes: &[ModeBudgets]) -> u64 {
    let ref_units = cfg
        .reference
        .as_ref()
        .and_then(|r| r.spp)
        .map(|s| s as u64)
        .unwrap_or(0);
    let grid_units = cfg
        .grid
        .as_ref()
        .map(|g| (g.rows.values.len() * g.columns.values.len()) as u64 * per_job(&modes[0]))
        .unwrap_or(0);
    ref_units
        + grid_units
        + modes
            .iter()
            .map(|mb| per_job(mb) * cfg.variants.len() as u64 * cfg.repeats as u64)
            .sum::<u64>()
}
