//! Hua Fig. 4: the conditional pdf of the re-emitted wavelength λo given the excitation λi, of
//! the measured (cleaned) matrix against the mixtures' truncated conditional density (Hua eq.
//! 10, `ConditionalMixture::density`), for each number of components.
//!
//! The matrix's pdf is its column at λi without the diagonal, normalised to integrate to 1 and
//! constant over each emission cell (±Δλ/2). The mixture's is defined on (λi, end of the
//! emission support], so it starts half a cell before the matrix's first cell above the
//! diagonal.

use super::super::canvas::{Figure, Raster, de, write_figure};
use super::super::evaluate::Run;
use super::super::inputs::Measurement;
use super::{draw_component_curves, fit_model, method_title};
use crate::Error;
use crate::material::mixture::{ConditionalMixture, GmmFile};
use crate::material::reradiation::BfcMatrix;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The matrix column of excitation `l` (the nearest).
fn column(m: &BfcMatrix, l: f32) -> usize {
    (((l - m.ex_lo) / m.step).round().max(0.0) as usize).min(m.n_ex - 1)
}

/// That `l` lies on the excitation grid's range of `m` and that `m` fluoresces there; errors
/// name the flag.
pub fn check_excitation(m: &BfcMatrix, name: &str, l: f32) -> Result<(), Error> {
    let (lo, hi) = (m.ex(0), m.ex(m.n_ex - 1));
    if !(l >= lo && l <= hi) {
        return Err(Error::input(format!(
            "--excitation {l}: outside the excitation range of {name}, {lo}–{hi} nm"
        )));
    }
    let i = column(m, l);
    if (0..m.n_em).all(|o| m.off(o, i) <= 0.0) {
        return Err(Error::input(format!(
            "--excitation {l}: {name} does not fluoresce there (its column at {} nm has nothing \
             off the diagonal)",
            m.ex(i)
        )));
    }
    Ok(())
}

/// The curves of the figure.
#[derive(Clone, Debug)]
pub struct Curves {
    /// The matrix: (from, to, density per nm) per emission cell above the diagonal.
    pub matrix: Vec<(f64, f64, f64)>,
    /// Per number of components: (λo, density per nm) on a 0.5 nm grid over the mixture's
    /// interval.
    pub mixtures: Vec<(usize, Vec<(f64, f64)>)>,
}

/// The matrix's conditional pdf of λo at excitation `l`.
pub fn matrix_pdf(m: &BfcMatrix, l: f32) -> Vec<(f64, f64, f64)> {
    let i = column(m, l);
    let total: f64 = (0..m.n_em).map(|o| m.off(o, i) as f64).sum();
    let h = 0.5 * m.step as f64;
    (0..m.n_em)
        .filter(|&o| m.em(o) > m.ex(i))
        .map(|o| {
            let c = m.em(o) as f64;
            (c - h, c + h, m.off(o, i) as f64 / (total * m.step as f64))
        })
        .collect()
}

/// A model's truncated conditional pdf of λo given λi = `l`, on points 0.5 nm apart from just
/// above max(λi, start of the emission support) to its end (zero when it has no mass there).
pub fn mixture_pdf(f: &GmmFile, l: f32) -> Vec<(f64, f64)> {
    let (ex, em) = (f.grid.ex_support(), f.grid.em_support());
    let cm = ConditionalMixture::new(&f.components, f.scale, ex, em);
    let li = l as f64;
    let (a, b) = (li.max(em.0) + 1e-6, em.1);
    let n = ((b - a) / 0.5).ceil().max(1.0) as usize;
    (0..=n)
        .map(|j| {
            let x = a + (b - a) * j as f64 / n as f64;
            (x, cm.density(li, x, 0))
        })
        .collect()
}

struct Fig4 {
    title: String,
    curves: Curves,
    em: (f64, f64),
}

impl Figure for Fig4 {
    fn size(&self) -> (u32, u32) {
        (760, 480)
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<Vec<Raster>, String> {
        root.fill(&WHITE).map_err(de)?;
        let top = self
            .curves
            .matrix
            .iter()
            .map(|c| c.2)
            .chain(
                self.curves
                    .mixtures
                    .iter()
                    .flat_map(|(_, p)| p.iter().map(|p| p.1)),
            )
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let top = if top > 0.0 { top * 1.1 } else { 1.0 };
        let mut c = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(self.em.0..self.em.1, 0.0..top)
            .map_err(de)?;
        c.configure_mesh()
            .light_line_style(WHITE.mix(0.0))
            .x_desc("re-emitted wavelength λo, nm")
            .y_desc("p(λo | λi), per nm")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.3}"))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(de)?;
        // The matrix as steps.
        let mut steps = Vec::new();
        for &(a, b, p) in &self.curves.matrix {
            if steps.is_empty() {
                steps.push((a, 0.0));
            }
            steps.extend([(a, p), (b, p)]);
        }
        if let Some(&(_, b, _)) = self.curves.matrix.last() {
            steps.push((b, 0.0));
        }
        c.draw_series(LineSeries::new(steps, BLACK.stroke_width(2)))
            .map_err(de)?
            .label("matrix (cleaned), normalised column")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(2)));
        draw_component_curves(&mut c, &self.curves.mixtures, |k| {
            format!("{k} Gaussians, truncated conditional")
        })?;
        Ok(Vec::new())
    }
}

/// The curves of material `m` at excitation `l` for each number of components of `run`.
pub fn curves(m: &BfcMatrix, l: f32, run: &Run) -> Result<Curves, String> {
    let mut mixtures = Vec::new();
    for &k in run.components {
        let f = fit_model(m, k, run).map_err(|e| format!("fitting {k} components: {e}"))?;
        mixtures.push((k, mixture_pdf(&f, l)));
    }
    Ok(Curves {
        matrix: matrix_pdf(m, l),
        mixtures,
    })
}

/// Write `fig4-conditional.{svg,png}` into `out`.
pub fn write(out: &Path, m: &Measurement, l: f32, run: &Run) -> Result<[PathBuf; 2], String> {
    let curves = curves(&m.cleaned, l, run).map_err(|e| format!("{}: {e}", m.path.display()))?;
    let g = crate::material::mixture::file::Grid::of(&m.cleaned);
    let fig = Fig4 {
        title: format!(
            "{} at λi = {l} nm: pdf of λo, matrix against {} fits",
            m.name,
            method_title(run.method)
        ),
        curves,
        em: g.em_support(),
    };
    write_figure(&out.join("fig4-conditional"), &fig)
}
