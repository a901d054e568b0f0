//! Hua et al. 2022's figures of the fits, from the data (`stokes gmm figures DIR -o OUT`): every
//! matrix of DIR is fitted and compared as `stokes gmm eval` does ([`super::evaluate`]), then
//!
//! - [`fig4`]: the conditional pdf of λo given λi of one material, matrix against mixtures;
//! - [`fig5`]: colour bands and patches of the worst fits under monochromatic light;
//! - [`fig6`]: those matrices beside their fits, with absorption and emission spectra;
//! - [`fig7a`]: mean ΔE00 over the matrices per monochromatic wavelength;
//! - [`fig8a`]: box plots of ΔE00 under the ten worst CIE illuminants.
//!
//! Figs. 7b and 8b are `gmm eval`'s box plots. Each figure is written as SVG and PNG
//! ([`super::canvas`]). Colours are compared with the cleaned matrix (Hua §5.1), the matrix
//! that was fitted, as in `gmm eval`.

pub mod fig4;
pub mod fig5;
pub mod fig6;
pub mod fig7a;
pub mod fig8a;

use super::evaluate::{Run, check_output_folder, compare_all, load_inputs};
use super::inputs::Measurement;
use super::summary::{Row, summarise};
use crate::Error;
use crate::material::mixture::{FitMethod, FitOptions, GmmFile, fit_matrix};
use crate::material::reradiation::BfcMatrix;
use std::path::PathBuf;

/// The default material and excitation wavelength of Fig. 4 (Hua's "HERPICH", the RIT file
/// HERPICHA.BFC, at 440 nm).
pub const FIG4_MATERIAL: &str = "HERPICH";
pub const FIG4_EXCITATION: f32 = 440.0;

/// What `stokes gmm figures` draws.
#[derive(Clone, Debug)]
pub struct Options<'a> {
    /// The evaluation: matrices, numbers of components, method, seed, illuminants; `out` is the
    /// figures' folder.
    pub run: Run<'a>,
    /// Fig. 4's material: a file stem of `run.dir`, any case, or a prefix of exactly one.
    pub material: &'a str,
    /// Fig. 4's excitation wavelength, nm.
    pub excitation: f32,
    /// How many of the worst materials Figs. 5 and 6 show, and of the worst illuminants Fig. 5.
    pub worst: usize,
}

/// What was drawn.
#[derive(Clone, Debug)]
pub struct Drawn {
    /// The number of components of Figs. 5 and 8a (4, as Hua, when it is fitted).
    pub components: usize,
    /// Fig. 4's material (the file stem).
    pub material: String,
    /// Figs. 5 and 6: the worst materials by mean ΔE00 under monochromatic light.
    pub worst_materials: Vec<(String, f64)>,
    /// Fig. 8a: the ten worst CIE illuminants by mean ΔE00 over the materials.
    pub worst_illuminants: Vec<(String, f64)>,
    pub outputs: Vec<PathBuf>,
    /// Wall time, fits included.
    pub seconds: f64,
}

/// The number of components Figs. 5 and 8a are drawn at: 4 (Hua) when fitted, else the middle
/// of the list.
pub fn main_components(components: &[usize]) -> usize {
    if components.contains(&4) {
        4
    } else {
        components[components.len() / 2]
    }
}

/// The fit of the figures: the same as `gmm eval`'s.
pub fn fit_model(m: &BfcMatrix, k: usize, run: &Run) -> Result<GmmFile, String> {
    let mut opt = FitOptions::new(k, run.method, run.seed);
    opt.restarts = run.restarts;
    fit_matrix(m, &opt)
}

/// Fig. 4's material among the measurements: the file stem, any case, or a prefix of exactly
/// one (Hua name HERPICHA "HERPICH").
pub fn find_material<'m>(ms: &'m [Measurement], name: &str) -> Result<&'m Measurement, Error> {
    let bad = |m: String| Error::input(format!("--material '{name}': {m}"));
    if let Some(m) = ms.iter().find(|m| m.name.eq_ignore_ascii_case(name)) {
        return Ok(m);
    }
    let up = name.to_uppercase();
    let hits: Vec<&Measurement> = ms
        .iter()
        .filter(|m| !name.is_empty() && m.name.to_uppercase().starts_with(&up))
        .collect();
    match hits.as_slice() {
        [one] => Ok(one),
        [] => Err(bad("no BFC file of the folder has this name".into())),
        many => Err(bad(format!(
            "the start of {} files' names ({}): give one",
            many.len(),
            many.iter()
                .map(|m| m.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// Draw every figure into `opt.run.out`. The inputs and Fig. 4's options are checked before
/// anything is fitted.
pub fn figures(opt: &Options) -> Result<Drawn, Error> {
    let start = std::time::Instant::now();
    let run = &opt.run;
    if opt.worst == 0 {
        return Err(Error::input("--worst: must be at least 1"));
    }
    let (materials, illuminants) = load_inputs(run)?;
    let m4 = find_material(&materials, opt.material)?;
    fig4::check_excitation(&m4.cleaned, &m4.name, opt.excitation)?;
    check_output_folder(run.out)?;
    let rows: Vec<Row> = compare_all(run, &materials, &illuminants, &|m, k| {
        Ok(fit_model(m, k, run)?.to_matrix())
    })?;
    let k = main_components(run.components);
    let summary = summarise(&rows, &[k]);
    let s = &summary[0];
    let mut worst_materials: Vec<(String, f64)> = s
        .worst_mono
        .iter()
        .map(|w| (w.material.clone(), w.mean))
        .collect();
    worst_materials.truncate(opt.worst);
    let worst_illuminants: Vec<(String, f64)> = s
        .worst_illuminants
        .iter()
        .map(|w| (w.light.clone(), w.mean))
        .collect();
    let out = run.out;
    let runtime = Error::runtime;
    let mut outputs = Vec::new();
    outputs.extend(fig4::write(out, m4, opt.excitation, run).map_err(runtime)?);
    let worst: Vec<&Measurement> = worst_materials
        .iter()
        .filter_map(|(n, _)| materials.iter().find(|m| &m.name == n))
        .collect();
    let shown_lights: Vec<&str> = worst_illuminants
        .iter()
        .take(opt.worst)
        .map(|(n, _)| n.as_str())
        .collect();
    outputs.extend(fig5::write(out, &worst, &illuminants, &shown_lights, k, run).map_err(runtime)?);
    outputs.extend(fig6::write(out, &worst, run).map_err(runtime)?);
    outputs.extend(fig7a::write(out, &rows, run).map_err(runtime)?);
    outputs.extend(fig8a::write(out, &rows, &worst_illuminants, k, run).map_err(runtime)?);
    Ok(Drawn {
        components: k,
        material: m4.name.clone(),
        worst_materials,
        worst_illuminants,
        outputs,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The name a figure gives the fitting method.
pub fn method_title(m: FitMethod) -> &'static str {
    match m {
        FitMethod::Em => "EM",
        FitMethod::Bayes => "variational Bayes",
    }
}

/// A display colour of XYZ relative to a white of Y = 1 (Hua Fig. 5: "divided by the Y value of
/// the used illuminant"; no chromatic adaptation): linear sRGB clipped to [0, 1], encoded.
pub fn srgb8(xyz: [f64; 3]) -> [u8; 3] {
    let m = crate::spectrum::cie::xyz_to_srgb_matrix().to_cols_array();
    // Column-major: m[3c + r] is row r, column c.
    let lin = |r: usize| (0..3).map(|c| m[3 * c + r] as f64 * xyz[c]).sum::<f64>();
    let enc = |v: f64| {
        let e = crate::spectrum::cie::srgb_encode(v.clamp(0.0, 1.0) as f32);
        (e * 255.0).round().clamp(0.0, 255.0) as u8
    };
    [enc(lin(0)), enc(lin(1)), enc(lin(2))]
}

/// The colour of the `j`-th number of components in the line figures.
pub fn series_colour(j: usize) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    const C: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
    ];
    C[j % C.len()]
}

#[cfg(test)]
mod tests;

/// The curves of the line figures (Figs. 4 and 7a): one line per number of components, coloured
/// by [`series_colour`] in order and labelled by `label`, then the legend box of every series
/// drawn on `c` so far.
pub fn draw_component_curves<'a, DB: plotters::prelude::DrawingBackend + 'a>(
    c: &mut plotters::prelude::ChartContext<
        'a,
        DB,
        plotters::prelude::Cartesian2d<
            plotters::coord::types::RangedCoordf64,
            plotters::coord::types::RangedCoordf64,
        >,
    >,
    curves: &[(usize, Vec<(f64, f64)>)],
    label: impl Fn(usize) -> String,
) -> Result<(), String> {
    use super::canvas::de;
    use plotters::prelude::*;
    for (j, (k, p)) in curves.iter().enumerate() {
        let colour = series_colour(j);
        c.draw_series(LineSeries::new(p.iter().copied(), colour.stroke_width(2)))
            .map_err(de)?
            .label(label(*k))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(de)?;
    Ok(())
}
