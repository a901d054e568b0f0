//! Hua Fig. 6: the worst matrices beside their fits. Per material, heat maps of the measured
//! (cleaned) matrix and of the matrices the fits evaluate to (Hua §7.3), off the diagonal only
//! and on one colour scale per material (black 0 to pale yellow at the largest entry of the
//! four), then the absorption spectrum Σ_λo D(λi, λo) and the emission spectrum Σ_λi D(λi, λo)
//! of each.

use super::super::canvas::{Figure, Raster, de, write_figure};
use super::super::evaluate::Run;
use super::super::inputs::Measurement;
use super::{fit_model, method_title, series_colour};
use crate::experiment::figures::ramp;
use crate::material::reradiation::BfcMatrix;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// A spectrum: (wavelength, value) points.
pub type Spectrum = Vec<(f64, f64)>;

/// A spectrum of the matrix (`None`) or of a fit with that many components.
type Curve = (Option<usize>, Spectrum);

/// One material: the matrix, then its fits (with their numbers of components).
struct Row {
    name: String,
    matrices: Vec<(Option<usize>, BfcMatrix)>,
}

/// Σ over emission of the off-diagonal entries per excitation column (absorbed and re-emitted),
/// and Σ over excitation per emission row.
pub fn spectra(m: &BfcMatrix) -> (Spectrum, Spectrum) {
    let a = (0..m.n_ex)
        .map(|i| {
            (
                m.ex(i) as f64,
                (0..m.n_em).map(|o| m.off(o, i) as f64).sum(),
            )
        })
        .collect();
    let e = (0..m.n_em)
        .map(|o| {
            (
                m.em(o) as f64,
                (0..m.n_ex).map(|i| m.off(o, i) as f64).sum(),
            )
        })
        .collect();
    (a, e)
}

/// The heat map's cells, top row the last emission wavelength.
fn cells(m: &BfcMatrix, top: f32) -> Vec<u8> {
    (0..m.n_em)
        .rev()
        .flat_map(|o| (0..m.n_ex).map(move |i| (o, i)))
        .flat_map(|(o, i)| ramp(m.off(o, i) / top))
        .collect()
}

struct Fig6 {
    title: String,
    rows: Vec<Row>,
}

const PANEL: (u32, u32) = (230, 230);

impl Fig6 {
    fn panels(&self) -> usize {
        self.rows.first().map_or(1, |r| r.matrices.len()) + 2
    }
}

fn heat_map<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    m: &BfcMatrix,
    top: f32,
) -> Result<Raster, String> {
    let h = 0.5 * m.step as f64;
    let (x0, x1) = (m.ex(0) as f64 - h, m.ex(m.n_ex - 1) as f64 + h);
    let (y0, y1) = (m.em(0) as f64 - h, m.em(m.n_em - 1) as f64 + h);
    let mut c = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 13))
        .margin(6)
        .x_label_area_size(30)
        .y_label_area_size(36)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(de)?;
    c.configure_mesh()
        .disable_mesh()
        .x_labels(5)
        .y_labels(5)
        .x_desc("λi, nm")
        .y_desc("λo, nm")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style(("sans-serif", 10))
        .axis_desc_style(("sans-serif", 11))
        .draw()
        .map_err(de)?;
    Ok(Raster::between(
        c.backend_coord(&(x0, y1)),
        c.backend_coord(&(x1, y0)),
        m.n_ex as u32,
        m.n_em as u32,
        cells(m, top),
    ))
}

fn spectrum_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_desc: &str,
    curves: &[Curve],
) -> Result<(), String> {
    let pts = curves.iter().flat_map(|c| c.1.iter());
    let (x0, x1) = pts
        .clone()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let top = pts.map(|p| p.1).fold(0.0, f64::max);
    let top = if top > 0.0 { top * 1.1 } else { 1.0 };
    let mut c = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 13))
        .margin(6)
        .x_label_area_size(30)
        .y_label_area_size(44)
        .build_cartesian_2d(x0..x1, 0.0..top)
        .map_err(de)?;
    c.configure_mesh()
        .disable_mesh()
        .x_labels(5)
        .y_labels(5)
        .x_desc(x_desc)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.2}"))
        .label_style(("sans-serif", 10))
        .axis_desc_style(("sans-serif", 11))
        .draw()
        .map_err(de)?;
    for (k, p) in curves {
        let style = match k {
            None => BLACK.stroke_width(2),
            Some(_) => {
                let j = curves.iter().position(|c| c.0 == *k).unwrap_or(1);
                series_colour(j - 1).stroke_width(1)
            }
        };
        let s = c
            .draw_series(LineSeries::new(p.iter().copied(), style))
            .map_err(de)?;
        let label = match k {
            None => "matrix".to_string(),
            Some(k) => format!("K = {k}"),
        };
        s.label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], style));
    }
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .label_font(("sans-serif", 10))
        .draw()
        .map_err(de)?;
    Ok(())
}

impl Figure for Fig6 {
    fn size(&self) -> (u32, u32) {
        (
            PANEL.0 * self.panels() as u32,
            PANEL.1 * self.rows.len().max(1) as u32 + 40,
        )
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<Vec<Raster>, String> {
        root.fill(&WHITE).map_err(de)?;
        let area = root.titled(&self.title, ("sans-serif", 17)).map_err(de)?;
        let panels = area.split_evenly((self.rows.len().max(1), self.panels()));
        let mut rasters = Vec::new();
        for (r, row) in self.rows.iter().enumerate() {
            let p = &panels[r * self.panels()..(r + 1) * self.panels()];
            let top = row
                .matrices
                .iter()
                .flat_map(|(_, m)| {
                    (0..m.n_em).flat_map(move |o| (0..m.n_ex).map(move |i| m.off(o, i)))
                })
                .fold(0.0f32, f32::max)
                .max(f32::MIN_POSITIVE);
            let mut absorption = Vec::new();
            let mut emission = Vec::new();
            for (j, (k, m)) in row.matrices.iter().enumerate() {
                let caption = match k {
                    None => format!("{}: matrix (max {top:.3})", row.name),
                    Some(k) => format!("{k} Gaussians"),
                };
                rasters.push(heat_map(&p[j], &caption, m, top)?);
                let (a, e) = spectra(m);
                absorption.push((*k, a));
                emission.push((*k, e));
            }
            let n = row.matrices.len();
            spectrum_panel(&p[n], "absorption Σλo", "λi, nm", &absorption)?;
            spectrum_panel(&p[n + 1], "emission Σλi", "λo, nm", &emission)?;
        }
        Ok(rasters)
    }
}

/// Write `fig6-matrices.{svg,png}` into `out`: `worst`'s matrices and their fits with each number
/// of components of `run`.
pub fn write(out: &Path, worst: &[&Measurement], run: &Run) -> Result<[PathBuf; 2], String> {
    let mut rows = Vec::new();
    for m in worst {
        let mut matrices = vec![(None, m.cleaned.clone())];
        for &k in run.components {
            let f = fit_model(&m.cleaned, k, run)
                .map_err(|e| format!("{}: fitting {k} components: {e}", m.path.display()))?;
            matrices.push((Some(k), f.to_matrix()));
        }
        rows.push(Row {
            name: m.name.clone(),
            matrices,
        });
    }
    let fig = Fig6 {
        title: format!(
            "The worst matrices under monochromatic light and their {} fits (off the diagonal, one colour scale per row)",
            method_title(run.method)
        ),
        rows,
    };
    write_figure(&out.join("fig6-matrices"), &fig)
}
