//! Hua Fig. 5: the worst fits under monochromatic light, as colour bands and colour patches.
//!
//! Per material a band of three strips over the excitation wavelength (Hua §7.4): the colour of
//! the measured (cleaned) matrix under unit monochromatic light, the colour of the fit, and
//! ΔE00 between the two on a heat scale. Beside it one patch per CIE illuminant with the
//! largest mean ΔE00 over the dataset: the fit's colour inside the matrix's, both divided by the
//! Y of the illuminant (so a white reflector would have Y = 1; no chromatic adaptation, as Hua),
//! with ΔE00 under it.

use super::super::canvas::{Figure, Raster, de, write_figure};
use super::super::colour::{LightColour, LightKind, colours, compare_colours};
use super::super::evaluate::Run;
use super::super::inputs::{Illuminant, Measurement};
use super::fig8a::short_name;
use super::{fit_model, method_title, srgb8};
use crate::experiment::figures::ramp;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One material's row.
#[derive(Clone, Debug)]
pub struct Band {
    pub name: String,
    /// Per monochromatic light: wavelength, matrix colour, fit colour (sRGB), ΔE00.
    pub mono: Vec<(f64, [u8; 3], [u8; 3], f64)>,
    /// Per shown illuminant: matrix colour, fit colour, ΔE00.
    pub patches: Vec<([u8; 3], [u8; 3], f64)>,
}

impl Band {
    pub fn mean_mono(&self) -> f64 {
        self.mono.iter().map(|m| m.3).sum::<f64>() / self.mono.len().max(1) as f64
    }
}

/// XYZ divided by the white's Y, as a display colour.
fn display(c: &LightColour) -> [u8; 3] {
    srgb8(c.xyz.map(|v| v / c.white[1]))
}

/// The row of one material fitted with `k` components, with patches under `lights`.
pub fn band(
    m: &Measurement,
    illuminants: &[Illuminant],
    lights: &[&str],
    k: usize,
    run: &Run,
) -> Result<Band, String> {
    let err = |e: String| format!("{}: {e}", m.path.display());
    let fit = fit_model(&m.cleaned, k, run)
        .map_err(|e| err(format!("fitting {k} components: {e}")))?
        .to_matrix();
    let (cm, cf) = (
        colours(&m.cleaned, illuminants).map_err(err)?,
        colours(&fit, illuminants).map_err(err)?,
    );
    let de = compare_colours(&cm, &cf).map_err(err)?;
    let mut mono = Vec::new();
    let mut patches = vec![None; lights.len()];
    for ((a, b), d) in cm.iter().zip(&cf).zip(&de) {
        if a.kind == LightKind::Mono {
            let nm: f64 = a
                .light
                .trim_start_matches("mono-")
                .parse()
                .unwrap_or(f64::NAN);
            mono.push((nm, display(a), display(b), d.de00));
        } else if let Some(j) = lights.iter().position(|l| *l == a.light) {
            patches[j] = Some((display(a), display(b), d.de00));
        }
    }
    Ok(Band {
        name: m.name.clone(),
        mono,
        patches: patches.into_iter().flatten().collect(),
    })
}

struct Fig5 {
    title: String,
    bands: Vec<Band>,
    lights: Vec<String>,
    /// ΔE00 at the top of the heat scale.
    scale: f64,
}

/// ΔE00 at the top of the heat scale (larger values are drawn as it).
pub const HEAT_TOP: f64 = 10.0;

const LEFT: i32 = 96;
const CELL: i32 = 12;
const STRIP: i32 = 22;
const ROW: i32 = 128;
const TOP: i32 = 70;
const PATCH: i32 = 76;

impl Fig5 {
    fn cols(&self) -> i32 {
        self.bands.first().map_or(1, |b| b.mono.len().max(1)) as i32
    }
    fn patch_x(&self, j: usize) -> i32 {
        LEFT + self.cols() * CELL + 40 + j as i32 * (PATCH + 40)
    }
    fn heat(&self, d: f64) -> [u8; 3] {
        ramp((d / self.scale) as f32)
    }
}

impl Figure for Fig5 {
    fn size(&self) -> (u32, u32) {
        let w = self.patch_x(self.lights.len()) + 10;
        (
            w.max(760) as u32,
            (TOP + ROW * self.bands.len() as i32 + 70) as u32,
        )
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<Vec<Raster>, String> {
        root.fill(&WHITE).map_err(de)?;
        let text = |s: &str, x: i32, y: i32, px: u32| -> Result<(), String> {
            root.draw_text(s, &("sans-serif", px).into_font().color(&BLACK), (x, y))
                .map_err(de)
        };
        text(&self.title, 10, 8, 17)?;
        let cols = self.cols();
        text("monochromatic light (excitation wavelength)", LEFT, 44, 13)?;
        for (j, l) in self.lights.iter().enumerate() {
            text(&short_name(l), self.patch_x(j) - 12, 44, 12)?;
        }
        let mut rasters = Vec::new();
        for (r, b) in self.bands.iter().enumerate() {
            let y = TOP + r as i32 * ROW;
            text(
                &format!(
                    "{}: mean ΔE00 {:.2} under monochromatic light",
                    b.name,
                    b.mean_mono()
                ),
                LEFT,
                y,
                13,
            )?;
            let strips: [(&str, Vec<u8>); 3] = [
                ("matrix", b.mono.iter().flat_map(|m| m.1).collect()),
                ("fit", b.mono.iter().flat_map(|m| m.2).collect()),
                ("ΔE00", b.mono.iter().flat_map(|m| self.heat(m.3)).collect()),
            ];
            for (s, (label, rgb)) in strips.into_iter().enumerate() {
                let sy = y + 18 + s as i32 * (STRIP + 2);
                text(label, 10, sy + 4, 12)?;
                let x0 = LEFT;
                rasters.push(Raster::between(
                    (x0, sy),
                    (x0 + cols * CELL, sy + STRIP),
                    cols as u32,
                    1,
                    rgb,
                ));
            }
            let ty = y + 18 + 3 * (STRIP + 2) + 2;
            for (i, m) in b.mono.iter().enumerate() {
                if (m.0 as i64) % 100 == 0 || i + 1 == b.mono.len() {
                    text(&format!("{:.0}", m.0), LEFT + i as i32 * CELL - 6, ty, 11)?;
                }
            }
            for (j, (cm, cf, d)) in b.patches.iter().enumerate() {
                let (px, py) = (self.patch_x(j), y + 16);
                let q = PATCH / 4;
                let rect = |a: (i32, i32), b: (i32, i32), c: [u8; 3]| {
                    root.draw(&Rectangle::new([a, b], RGBColor(c[0], c[1], c[2]).filled()))
                        .map_err(de)
                };
                rect((px, py), (px + PATCH, py + PATCH), *cm)?;
                rect((px + q, py + q), (px + PATCH - q, py + PATCH - q), *cf)?;
                text(&format!("ΔE00 {d:.2}"), px + 4, py + PATCH + 4, 11)?;
            }
        }
        // The heat scale.
        let y = TOP + ROW * self.bands.len() as i32 + 10;
        let n = 64;
        let rgb: Vec<u8> = (0..n)
            .flat_map(|i| self.heat(self.scale * i as f64 / (n - 1) as f64))
            .collect();
        rasters.push(Raster::between((LEFT, y), (LEFT + 300, y + 14), n, 1, rgb));
        text("ΔE00 0", 10, y, 12)?;
        text(&format!("{:.0} and above", self.scale), LEFT + 306, y, 12)?;
        text(
            "patches: the fit inside the matrix, XYZ divided by the illuminant's Y",
            LEFT + 440,
            y,
            12,
        )?;
        Ok(rasters)
    }
}

/// Write `fig5-bands.{svg,png}` into `out`: the rows of `worst` at `k` components, with patches
/// under `lights`.
pub fn write(
    out: &Path,
    worst: &[&Measurement],
    illuminants: &[Illuminant],
    lights: &[&str],
    k: usize,
    run: &Run,
) -> Result<[PathBuf; 2], String> {
    let bands: Vec<Band> = worst
        .iter()
        .map(|m| band(m, illuminants, lights, k, run))
        .collect::<Result<_, _>>()?;
    let fig = Fig5 {
        title: format!(
            "The {} worst {} fits with {k} Gaussians under monochromatic light, and under the worst CIE illuminants",
            bands.len(),
            method_title(run.method)
        ),
        lights: lights.iter().map(|l| l.to_string()).collect(),
        scale: HEAT_TOP,
        bands,
    };
    write_figure(&out.join("fig5-bands"), &fig)
}
