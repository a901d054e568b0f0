//! `figures/summary-table.tex`: the final-budget SNR of a run as a LaTeX `booktabs` table, to
//! `\input` into a paper's `table` environment (see docs/figures.md).
//!
//! One row per variant, one column per region (`all` first, then the run's regions), the mean
//! SNR in dB over repeats with one decimal. A run with both an spp and a time mode gets one
//! tabular with a block per mode, each headed by its budget and separated by `\midrule`; the best
//! value of each column within a block is bold. Ties are judged on the printed (rounded) values,
//! so every value that reads as the best is bold. A cell with no finite value reads `--`.
//!
//! The numbers come from `metrics.csv` through [`read_metrics`] and [`summarize`], which is what
//! `summary.json` holds, so the file is checked as untrusted input like the figures' inputs.

use super::config::BudgetMode;
use super::record::{RunInfo, SummaryEntry, read_metrics, summarize, write_text};
use crate::error::Error;
use std::path::{Path, PathBuf};

/// File name of the table inside the run's `figures/` folder.
pub const TABLE_FILE: &str = "summary-table.tex";

/// The table of a run: its experiment and regions, and a block per budget mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub experiment: String,
    /// Column headers, in order.
    pub regions: Vec<String>,
    pub blocks: Vec<Block>,
}

/// The variants of one budget mode at its final budget.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// Such as `equal time, 40 s` or `equal spp, 128 spp`.
    pub label: String,
    /// Fewest and most repeats behind a value of the block.
    pub repeats: (usize, usize),
    /// Variant name and its mean SNR (dB) per region, `None` where it has none.
    pub rows: Vec<(String, Vec<Option<f64>>)>,
}

/// Write `<run_dir>/figures/summary-table.tex` and return its path; `None` when the run has no
/// metrics (no reference, or a sweep's top folder, whose values are run folders of their own).
/// `run.json` and `metrics.csv` are read and checked; a malformed file is an input error naming
/// it, a table that cannot be written is a runtime error.
pub fn write_summary_table(run_dir: &Path) -> Result<Option<PathBuf>, Error> {
    let info = RunInfo::read(run_dir)?;
    let metrics = run_dir.join("metrics.csv");
    if !metrics.is_file() {
        return Ok(None);
    }
    let rows = read_metrics(&metrics)?;
    let Some(table) = Table::new(&info, &summarize(&rows)) else {
        return Ok(None);
    };
    let p = run_dir.join("figures").join(TABLE_FILE);
    write_text(&p, &table.to_tex())?;
    Ok(Some(p))
}

fn mode_label(mode: BudgetMode, budget: f64) -> String {
    match mode {
        BudgetMode::Time => format!("equal time, {budget} s"),
        BudgetMode::Spp => format!("equal spp, {budget} spp"),
    }
}

/// First appearance order of `key` over `entries`.
fn unique<'a>(
    entries: impl Iterator<Item = &'a SummaryEntry>,
    key: fn(&SummaryEntry) -> &str,
) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for e in entries {
        if !out.iter().any(|x| x == key(e)) {
            out.push(key(e).to_string());
        }
    }
    out
}

impl Table {
    /// The table of `entries` (the run's summary) at the final budget of each mode of `info`, in
    /// the order of `info.modes`; `None` when no mode has an entry at its final budget.
    pub fn new(info: &RunInfo, entries: &[SummaryEntry]) -> Option<Table> {
        let regions = unique(entries.iter(), |e| &e.region);
        let mut blocks = Vec::new();
        for mb in &info.modes {
            let Some(&last) = mb.budgets.last() else {
                continue;
            };
            let fin: Vec<&SummaryEntry> = entries
                .iter()
                .filter(|e| e.mode == mb.mode.name() && e.budget == last)
                .collect();
            if fin.is_empty() {
                continue;
            }
            let rows = unique(fin.iter().copied(), |e| &e.variant)
                .into_iter()
                .map(|v| {
                    let cells = regions
                        .iter()
                        .map(|r| {
                            fin.iter()
                                .find(|e| e.variant == v && &e.region == r)
                                .map(|e| e.snr_db.mean)
                                .filter(|x| !x.is_nan())
                        })
                        .collect();
                    (v, cells)
                })
                .collect();
            let reps = fin.iter().map(|e| e.repeats);
            blocks.push(Block {
                label: mode_label(mb.mode, last),
                repeats: (reps.clone().min().unwrap_or(0), reps.max().unwrap_or(0)),
                rows,
            });
        }
        (!blocks.is_empty()).then(|| Table {
            experiment: info.config.name.clone(),
            regions,
            blocks,
        })
    }

    /// The LaTeX text: comments with the caption (experiment, budgets, repeats), then a
    /// `tabular` with `\toprule`, `\midrule` and `\bottomrule`.
    pub fn to_tex(&self) -> String {
        let n = self.regions.len();
        let mut t = String::new();
        let finals: Vec<String> = self
            .blocks
            .iter()
            .map(|b| format!("{}, mean over {} repeats", b.label, repeats_text(b.repeats)))
            .collect();
        t.push_str(&format!(
            "% {TABLE_FILE}, written by stokes; needs \\usepackage{{booktabs}}.\n\
             % Caption: SNR (dB) per region of the experiment {} at the final budget ({}); \
             the best value of each column in bold.\n",
            comment_text(&self.experiment),
            comment_text(&finals.join("; ")),
        ));
        t.push_str(&format!(
            "\\begin{{tabular}}{{l{}}}\n\\toprule\n",
            " r".repeat(n)
        ));
        t.push_str(&format!(
            " & \\multicolumn{{{n}}}{{c}}{{SNR (dB)}} \\\\\n\\cmidrule(l){{2-{}}}\n",
            n + 1
        ));
        t.push_str("variant");
        for r in &self.regions {
            t.push_str(&format!(" & {}", escape(r)));
        }
        t.push_str(" \\\\\n");
        for b in &self.blocks {
            t.push_str("\\midrule\n");
            if self.blocks.len() > 1 {
                t.push_str(&format!(
                    "\\multicolumn{{{}}}{{l}}{{\\emph{{{}}}}} \\\\\n",
                    n + 1,
                    escape(&b.label)
                ));
            }
            t.push_str(&b.rows_tex(n));
        }
        t.push_str("\\bottomrule\n\\end{tabular}\n");
        t
    }
}

impl Block {
    /// The block's rows, the best printed value of each of the `n` columns in bold.
    fn rows_tex(&self, n: usize) -> String {
        let best: Vec<Option<f64>> = (0..n)
            .map(|c| {
                self.rows
                    .iter()
                    .filter_map(|(_, v)| v.get(c).copied().flatten().map(printed))
                    .reduce(f64::max)
            })
            .collect();
        let mut t = String::new();
        for (name, cells) in &self.rows {
            t.push_str(&escape(name));
            for (c, best) in best.iter().enumerate() {
                let v = cells.get(c).copied().flatten();
                let s = number(v);
                let bold = matches!((v, best), (Some(x), Some(b)) if printed(x) == *b);
                if bold {
                    t.push_str(&format!(" & \\textbf{{{s}}}"));
                } else {
                    t.push_str(&format!(" & {s}"));
                }
            }
            t.push_str(" \\\\\n");
        }
        t
    }
}

fn repeats_text((lo, hi): (usize, usize)) -> String {
    if lo == hi {
        lo.to_string()
    } else {
        format!("{lo}–{hi}")
    }
}

/// The value as printed (one decimal), for finding the best and its ties.
fn printed(x: f64) -> f64 {
    if x.is_finite() {
        format!("{x:.1}").parse().unwrap_or(x)
    } else {
        x
    }
}

/// A table cell: one decimal with a true minus sign, `$\infty$` for an infinite SNR (an exact
/// image), `--` for no value.
pub fn number(v: Option<f64>) -> String {
    match v {
        None => "--".into(),
        Some(x) if x.is_nan() => "--".into(),
        Some(x) if x == f64::INFINITY => "$\\infty$".into(),
        Some(x) if x == f64::NEG_INFINITY => "$-\\infty$".into(),
        Some(x) => {
            let p = printed(x);
            if p == 0.0 {
                "0.0".into()
            } else if p < 0.0 {
                format!("$-${:.1}", -p)
            } else {
                format!("{p:.1}")
            }
        }
    }
}

/// `s` as LaTeX text: the special characters `\ { } _ & % # $ ~ ^` (and `< >`, which the
/// default font encoding does not print as such) escaped.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\\' => out.push_str("\\textbackslash{}"),
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '<' => out.push_str("\\textless{}"),
            '>' => out.push_str("\\textgreater{}"),
            '_' | '&' | '%' | '#' | '$' | '{' | '}' => {
                out.push('\\');
                out.push(c);
            }
            '\n' | '\r' | '\t' => out.push(' '),
            _ => out.push(c),
        }
    }
    out
}

/// `s` on one comment line (LaTeX ignores the rest of a line after `%`).
fn comment_text(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}
