//! Hua Fig. 8a: box plots of ΔE00 over the matrices under each of the ten CIE illuminants with
//! the largest mean, at one number of components (4, as Hua), worst first.

use super::super::boxplot::{BoxFigure, BoxStats, box_stats, write_box_figure_sized};
use super::super::colour::LightKind;
use super::super::evaluate::Run;
use super::super::summary::Row;
use super::method_title;
use std::path::{Path, PathBuf};

/// A short axis label of an illuminant's name: `ISO_7589_Sensitometric_Studio_Tungsten` →
/// `ISO Sens. St. Tungsten`.
pub fn short_name(name: &str) -> String {
    name.replace("ISO_7589_", "ISO ")
        .replace("Sensitometric_", "Sens. ")
        .replace("Photographic_", "Photo. ")
        .replace("Studio_", "St. ")
        .replace('_', " ")
}

/// The boxes: per illuminant of `worst` (in that order), ΔE00 over the materials at `k`
/// components.
pub fn boxes(rows: &[Row], worst: &[(String, f64)], k: usize) -> Vec<(String, BoxStats)> {
    worst
        .iter()
        .filter_map(|(light, _)| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r.components == k && r.c.kind == LightKind::Cie && &r.c.light == light)
                .map(|r| r.c.de00)
                .collect();
            Some((short_name(light), box_stats(&v)?))
        })
        .collect()
}

/// Write `fig8a-worst-illuminants.{svg,png}` into `out`.
pub fn write(
    out: &Path,
    rows: &[Row],
    worst: &[(String, f64)],
    k: usize,
    run: &Run,
) -> Result<[PathBuf; 2], String> {
    let boxes = boxes(rows, worst, k);
    let n = boxes.first().map_or(0, |b| b.1.n);
    let title = format!(
        "ΔE00 over {n} matrices, {k} Gaussians ({}): the {} CIE illuminants with the largest mean",
        method_title(run.method),
        boxes.len()
    );
    let fig = BoxFigure {
        title: &title,
        x_desc: "illuminant",
        y_desc: "ΔE00",
        boxes: &boxes,
    };
    write_box_figure_sized(&out.join("fig8a-worst-illuminants"), &fig, (1240, 520))
}
