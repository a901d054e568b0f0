//! The viewer's data: the reference, repeat 0's snapshot of every variant at every budget and
//! the parameter grid's cells, read from the run's EXRs (each checked: present, readable, the run's size) and stored as
//! compressed half floats, with what metrics.csv measured for each snapshot.

use super::encode::{base64, pixels_f16_deflate};
use crate::error::Error;
use crate::experiment::config::BudgetMode;
use crate::experiment::metrics::REL_EPS;
use crate::experiment::record::{Row, RunInfo, image_file, read_run_image};
use serde_json::{Value, json};
use std::path::Path;

/// A budget's label: `0.5 s` or `64 spp`.
pub fn budget_label(mode: BudgetMode, b: f64) -> String {
    match mode {
        BudgetMode::Time => format!("{b} s"),
        BudgetMode::Spp => format!("{b} spp"),
    }
}

/// What repeat 0 measured at one snapshot, from its `all` row of metrics.csv.
fn snapshot_info(rows: &[Row], variant: &str, mode: BudgetMode, budget: f64) -> Value {
    let r = rows.iter().find(|r| {
        r.variant == variant
            && r.mode == mode.name()
            && r.budget == budget
            && r.repeat == 0
            && r.region == "all"
    });
    match r {
        Some(r) => json!({
            "spp": r.spp,
            "seconds": r.seconds,
            "snr_db": finite_or_null(r.snr_db),
            "rel_mse": finite_or_null(r.rel_mse),
        }),
        None => Value::Null,
    }
}

/// How the reference was made: `bdpt-allbins at 2048 spp`, or the EXR it was read from.
fn reference_about(info: &RunInfo) -> String {
    match &info.config.reference {
        Some(r) => match (&r.exr, r.integrator, r.spp) {
            (Some(f), _, _) => format!("read from {}", f.display()),
            (None, Some(k), Some(spp)) => format!("{} at {spp} spp", k.name()),
            (None, Some(k), None) => k.name().to_string(),
            _ => String::new(),
        },
        None => String::new(),
    }
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// The viewer's JSON and the number of images in it.
pub fn viewer_data(dir: &Path, info: &RunInfo, rows: &[Row]) -> Result<(Value, usize), Error> {
    let mut count = 0;
    let mut encode = |file: &str| -> Result<String, Error> {
        count += 1;
        Ok(base64(&pixels_f16_deflate(&read_run_image(
            dir, file, info, false,
        )?)))
    };
    let reference = match &info.reference_file {
        Some(f) => {
            json!({
                "file": f,
                "data": encode(f)?,
                "about": reference_about(info),
            })
        }
        None => Value::Null,
    };
    let budgets: Vec<Value> = info
        .modes
        .iter()
        .flat_map(|m| {
            m.budgets
                .iter()
                .map(|&b| json!({ "mode": m.mode.name(), "label": budget_label(m.mode, b) }))
        })
        .collect();
    let mut variants = Vec::new();
    for v in &info.config.variants {
        let mut images = Vec::new();
        for m in &info.modes {
            for (idx, &b) in m.budgets.iter().enumerate() {
                let file = image_file(&v.name, m.mode, idx, 0);
                images.push(json!({
                    "file": file,
                    "data": encode(&file)?,
                    "metrics": snapshot_info(rows, &v.name, m.mode, b),
                }));
            }
        }
        variants.push(json!({
            "name": v.name,
            "integrator": v.integrator.name(),
            "images": images,
        }));
    }
    // The parameter grid's cells, one image each.
    let mut cells = Vec::new();
    if let Some(g) = &info.config.grid {
        for c in &info.grid_cells {
            let (Some(r), Some(k)) = (g.rows.values.get(c.row), g.columns.values.get(c.column))
            else {
                continue; // RunInfo::read checked the cells against the grid
            };
            cells.push(json!({
                "name": format!("{} {r}, {} {k}", g.rows.field, g.columns.field),
                "about": format!("parameter grid cell ({}, {}) of material {}", c.row, c.column, g.material),
                "file": c.file,
                "data": encode(&c.file)?,
            }));
        }
    }
    let data = json!({
        "width": info.width,
        "height": info.height,
        "encoding": "f16, planar RGB, high bytes then low bytes, zlib",
        "rel_eps": REL_EPS,
        "reference": reference,
        "budgets": budgets,
        "variants": variants,
        "cells": cells,
    });
    Ok((data, count))
}
