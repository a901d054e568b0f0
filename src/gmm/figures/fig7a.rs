//! Hua Fig. 7a: mean ΔE00 over the matrices under monochromatic light at each excitation
//! wavelength, one curve per number of components (the data of `delta-e00-mono.csv`).

use super::super::canvas::{Figure, Raster, de, write_figure};
use super::super::colour::LightKind;
use super::super::evaluate::Run;
use super::super::summary::{Row, per_light};
use super::{draw_component_curves, method_title};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One curve: the number of components and (wavelength, mean ΔE00) points.
pub type Curve = (usize, Vec<(f64, f64)>);

/// The curves of the figure: per number of components, the mean over the materials at each
/// monochromatic wavelength, in wavelength order.
pub fn curves(rows: &[Row], components: &[usize]) -> Vec<Curve> {
    let lights = per_light(rows, components);
    components
        .iter()
        .map(|&k| {
            let mut pts: Vec<(f64, f64)> = lights
                .iter()
                .filter(|l| l.kind == LightKind::Mono && l.components == k)
                .filter_map(|l| {
                    let nm: f64 = l.light.trim_start_matches("mono-").parse().ok()?;
                    Some((nm, l.stats.mean))
                })
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            (k, pts)
        })
        .collect()
}

struct Fig7a {
    title: String,
    curves: Vec<Curve>,
}

impl Figure for Fig7a {
    fn size(&self) -> (u32, u32) {
        (760, 480)
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<Vec<Raster>, String> {
        root.fill(&WHITE).map_err(de)?;
        let pts = self.curves.iter().flat_map(|(_, p)| p.iter());
        let (x0, x1) = pts
            .clone()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
        let top = pts
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let (x0, x1) = if x0 < x1 { (x0, x1) } else { (300.0, 780.0) };
        let top = if top > 0.0 { top * 1.1 } else { 1.0 };
        let mut c = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1, 0.0..top)
            .map_err(de)?;
        c.configure_mesh()
            .light_line_style(WHITE.mix(0.0))
            .x_desc("excitation wavelength λi, nm (monochromatic light)")
            .y_desc("mean ΔE00 over the matrices")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.1}"))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(de)?;
        draw_component_curves(&mut c, &self.curves, |k| format!("{k} Gaussians"))?;
        Ok(Vec::new())
    }
}

/// Write `fig7a-mono-mean.{svg,png}` into `out`.
pub fn write(out: &Path, rows: &[Row], run: &Run) -> Result<[PathBuf; 2], String> {
    let n = rows
        .iter()
        .map(|r| r.material.as_str())
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let fig = Fig7a {
        title: format!(
            "Mean ΔE00 of {} fits over {n} matrices, per monochromatic light",
            method_title(run.method)
        ),
        curves: curves(rows, run.components),
    };
    write_figure(&out.join("fig7a-mono-mean"), &fig)
}
