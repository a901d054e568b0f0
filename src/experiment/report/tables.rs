//! The metrics tables of the report, from summary.json: one table per budget mode and region,
//! a group of rows per budget with a row per variant (the mean over repeats), the best value of
//! each column within a budget highlighted.

use super::encode::html;
use super::images::budget_label;
use crate::error::Error;
use crate::experiment::config::BudgetMode;
use crate::experiment::record::RunInfo;
use serde::Deserialize;
use std::fmt::Write;
use std::path::Path;

/// A statistic over repeats as stored; `null` (a NaN or infinite mean) reads as not a number.
#[derive(Deserialize)]
struct Stat {
    mean: Option<f64>,
    #[serde(default)]
    std: Option<f64>,
}

impl Stat {
    fn value(&self) -> f64 {
        self.mean.unwrap_or(f64::NAN)
    }
}

/// The fields of a summary.json entry the tables show.
#[derive(Deserialize)]
struct Entry {
    variant: String,
    mode: String,
    budget: f64,
    region: String,
    repeats: usize,
    spp: Stat,
    seconds: Stat,
    rel_mse: Stat,
    snr_db: Stat,
    efficiency: Stat,
}

/// Read summary.json of the run folder `dir`.
fn read_summary(dir: &Path) -> Result<Vec<Entry>, Error> {
    let p = dir.join("summary.json");
    let text =
        crate::io::input::read_text(&p, crate::io::input::RUN_RECORD).map_err(Error::input)?;
    Ok(crate::io::json::from_json_array_str(&p, &text)?)
}

/// A column: heading, the value of an entry, whether larger is better (`None`: not ranked),
/// and its number format.
struct Column {
    head: &'static str,
    get: fn(&Entry) -> &Stat,
    larger_is_better: Option<bool>,
    fmt: fn(f64) -> String,
}

fn columns(mode: BudgetMode) -> [Column; 5] {
    let sci = |x: f64| format!("{x:.3e}");
    [
        // At equal time more samples is faster; at equal spp fewer seconds is.
        Column {
            head: "spp",
            get: |e| &e.spp,
            larger_is_better: (mode == BudgetMode::Time).then_some(true),
            fmt: |x| format!("{x:.0}"),
        },
        Column {
            head: "seconds",
            get: |e| &e.seconds,
            larger_is_better: (mode == BudgetMode::Spp).then_some(false),
            fmt: |x| format!("{x:.3}"),
        },
        Column {
            head: "SNR dB",
            get: |e| &e.snr_db,
            larger_is_better: Some(true),
            fmt: |x| format!("{x:.2}"),
        },
        Column {
            head: "relMSE",
            get: |e| &e.rel_mse,
            larger_is_better: Some(false),
            fmt: sci,
        },
        Column {
            head: "efficiency",
            get: |e| &e.efficiency,
            larger_is_better: Some(true),
            fmt: sci,
        },
    ]
}

/// The best value of column `c` among `rows` (finite values only).
fn best(rows: &[&Entry], c: &Column) -> Option<f64> {
    let better = c.larger_is_better?;
    rows.iter()
        .map(|e| (c.get)(e).value())
        .filter(|x| x.is_finite())
        .reduce(|a, b| if (b > a) == better { b } else { a })
}

/// One table: the rows of `mode` and `region`, grouped by budget.
fn table(info: &RunInfo, entries: &[Entry], mode: BudgetMode, region: &str, out: &mut String) {
    let budgets = info
        .modes
        .iter()
        .find(|m| m.mode == mode)
        .map(|m| m.budgets.clone())
        .unwrap_or_default();
    let cols = columns(mode);
    let _ = write!(
        out,
        "<table class=\"metrics\" data-region=\"{}\"><caption>{} budget, region <b>{}</b></caption>\
         <thead><tr><th>budget</th><th>variant</th>",
        html(region),
        mode.name(),
        html(region)
    );
    for c in &cols {
        let _ = write!(out, "<th>{}</th>", c.head);
    }
    out.push_str("</tr></thead>");
    for b in budgets {
        let rows: Vec<&Entry> = info
            .config
            .variants
            .iter()
            .filter_map(|v| {
                entries.iter().find(|e| {
                    e.variant == v.name
                        && e.mode == mode.name()
                        && e.budget == b
                        && e.region == region
                })
            })
            .collect();
        if rows.is_empty() {
            continue;
        }
        let bests: Vec<Option<f64>> = cols.iter().map(|c| best(&rows, c)).collect();
        out.push_str("<tbody>");
        for (i, e) in rows.iter().enumerate() {
            out.push_str("<tr>");
            if i == 0 {
                let _ = write!(
                    out,
                    "<th rowspan=\"{}\">{}</th>",
                    rows.len(),
                    html(&budget_label(mode, b))
                );
            }
            let _ = write!(out, "<td class=\"name\">{}</td>", html(&e.variant));
            for (c, best) in cols.iter().zip(&bests) {
                cell(e, c, *best, out);
            }
            out.push_str("</tr>");
        }
        out.push_str("</tbody>");
    }
    out.push_str("</table>\n");
}

/// A value cell: the mean, with the spread over repeats as its tooltip; `best` highlighted.
fn cell(e: &Entry, c: &Column, best: Option<f64>, out: &mut String) {
    let s = (c.get)(e);
    let x = s.value();
    let text = if x.is_finite() {
        (c.fmt)(x)
    } else if x.is_nan() {
        "–".to_string()
    } else {
        format!("{x}")
    };
    let class = if best == Some(x) {
        " class=\"best\""
    } else {
        ""
    };
    let tip = match s.std {
        Some(sd) if e.repeats > 1 => format!(
            " title=\"mean of {} repeats, standard deviation {}\"",
            e.repeats,
            (c.fmt)(sd)
        ),
        _ => String::new(),
    };
    let _ = write!(out, "<td{class}{tip}>{text}</td>");
}

/// The tables section: a region selector, then every table. Empty when the run has no metrics
/// (no reference).
pub fn section(dir: &Path, info: &RunInfo) -> Result<String, Error> {
    let entries = read_summary(dir)?;
    if entries.is_empty() {
        return Ok("<p>No metrics: this run has no reference.</p>".to_string());
    }
    let mut regions = vec!["all".to_string()];
    regions.extend(info.region_names.iter().cloned());
    let mut out = String::from(
        "<p class=\"note\">Mean over repeats (hover a value for its spread). Highlighted: the best \
         value of a column within a budget — highest SNR and efficiency, lowest relMSE, most spp at \
         equal time, fewest seconds at equal spp. SNR is in dB over linear sRGB; relMSE = mean((x − \
         ref)² / (ref² + 0.01)); efficiency = 1 / (relMSE · seconds).</p>\n",
    );
    if regions.len() > 1 {
        out.push_str("<p><label>Region <select id=\"region-select\">");
        for r in &regions {
            let _ = write!(out, "<option>{}</option>", html(r));
        }
        out.push_str("</select></label></p>\n");
    }
    for m in &info.modes {
        for r in &regions {
            table(info, &entries, m.mode, r, &mut out);
        }
    }
    Ok(out)
}
