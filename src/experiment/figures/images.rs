//! The labelled raster figures of a run: the image grid (reference and each variant at the final
//! budget over their relative error maps, with the error colour bar), the zoomed crops and the
//! parameter grid. Each PNG is complete by itself: title, column headings (the method), row
//! labels (the budget) and per tile the SNR of metrics.csv are drawn into it. A small SVG next
//! to each shows the PNG and carries its text as title and description.

use super::colour::{error_bar, error_colour, exposure, relative_error, to_srgb8};
use super::sheet::{Sheet, SheetRow, svg_wrapper, tile, zoom_for};
use super::{Final, check_size, save_png};
use crate::error::Error;
use crate::experiment::config::{BudgetMode, Crop, Grid};
use crate::experiment::record::RunInfo;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Images are enlarged (nearest neighbour) to at least this many pixels on their longer side,
/// so that the headings and captions fit over them.
pub const MIN_TILE: u32 = 192;

/// Write `sheet` as `<stem>.png` and `<stem>.svg` into `fig`; `what` names the figure in a
/// size error.
pub fn write_sheet(
    sheet: &Sheet,
    fig: &Path,
    stem: &str,
    what: &str,
) -> Result<Vec<PathBuf>, Error> {
    let (w, h) = sheet.size().map_err(Error::runtime)?;
    check_size(what, w as u64, h as u64)?;
    let img = sheet.render().map_err(Error::runtime)?;
    let png = fig.join(format!("{stem}.png"));
    save_png(&img, &png)?;
    let svg = fig.join(format!("{stem}.svg"));
    let text = svg_wrapper(sheet, &format!("{stem}.png"), (w, h));
    std::fs::write(&svg, text)
        .map_err(|e| Error::runtime(format!("cannot write '{}': {e}", svg.display())))?;
    Ok(vec![png, svg])
}

/// An input error, before any tile is drawn, when `cols`×`rows` tiles of `tile` pixels would
/// make a figure too large.
fn precheck(what: &str, cols: usize, rows: usize, tile: (u32, u32)) -> Result<(), Error> {
    let w = cols as u64 * (tile.0 as u64 + 4);
    let h = rows as u64 * (tile.1 as u64 + 4);
    check_size(what, w, h)
}

/// The caption of a variant's image tile: its SNR over the whole image (and the spp it reached,
/// at equal time), from metrics.csv; empty when the run has no row for it.
pub fn snr_caption(f: &Final, variant: &str) -> String {
    match f.metrics(variant) {
        Some(r) if r.snr_db.is_finite() && f.time_mode() => {
            format!("SNR {:.1} dB · {} spp", r.snr_db, r.spp)
        }
        Some(r) if r.snr_db.is_finite() => format!("SNR {:.1} dB", r.snr_db),
        _ => String::new(),
    }
}

/// The columns of the image figures: the reference (when the run has one), then the variants.
fn columns<'a>(f: &'a Final) -> Vec<(&'a str, &'a [Vec3])> {
    let mut all: Vec<(&str, &[Vec3])> = Vec::new();
    if let Some(r) = &f.reference {
        all.push(("reference", r));
    }
    for (n, i) in &f.imgs {
        all.push((n, i));
    }
    all
}

/// The image grid: one column per image, images on top, relative error maps under them with
/// the colour bar of the error.
pub fn image_grid(f: &Final, fig: &Path) -> Result<Vec<PathBuf>, Error> {
    let (w, h) = (f.info.width, f.info.height);
    let zoom = zoom_for(w, h, MIN_TILE);
    let k = exposure(f.reference.as_deref().unwrap_or(&f.imgs[0].1));
    let cols = columns(f);
    precheck("image grid", cols.len(), 2, (w * zoom, h * zoom))?;
    let mut images = SheetRow {
        label: vec![f.budget_label(), f.mode_label().into()],
        ..Default::default()
    };
    for (name, img) in &cols {
        images.tiles.push(Some(tile(w, h, zoom, |x, y| {
            to_srgb8(img[(y * w + x) as usize], k)
        })));
        images
            .captions
            .push(if *name == "reference" && f.reference.is_some() {
                f.reference_caption()
            } else {
                snr_caption(f, name)
            });
    }
    let mut rows = vec![images];
    if let Some(r) = &f.reference {
        let mut not_finite = false;
        let mut errors = SheetRow {
            label: vec!["rel. error".into(), f.budget_label()],
            tiles: vec![None],
            captions: vec![String::new()],
            bar: None,
        };
        for (name, img) in &f.imgs {
            not_finite |= img
                .iter()
                .zip(r)
                .any(|(a, b)| !relative_error(*a, *b).is_finite());
            errors.tiles.push(Some(tile(w, h, zoom, |x, y| {
                let i = (y * w + x) as usize;
                error_colour(img[i], r[i])
            })));
            errors.captions.push(match f.metrics(name) {
                Some(m) if m.rel_mse.is_finite() => format!("relMSE {:.2e}", m.rel_mse),
                _ => String::new(),
            });
        }
        errors.bar = Some(error_bar(not_finite));
        rows.push(errors);
    }
    let sheet = Sheet {
        title: vec![
            format!("{}: {}, repeat 0", f.info.config.name, f.budget_title()),
            f.reference_line(),
        ],
        columns: cols.iter().map(|c| c.0.to_string()).collect(),
        tile: (w * zoom, h * zoom),
        rows,
    };
    write_sheet(&sheet, fig, "image-grid", "image grid")
}

/// The crops: the crop of every image, enlarged, side by side.
pub fn crops(f: &Final, c: Crop, fig: &Path) -> Result<Vec<PathBuf>, Error> {
    let w = f.info.width;
    let k = exposure(f.reference.as_deref().unwrap_or(&f.imgs[0].1));
    let zoom = zoom_for(c.w, c.h, MIN_TILE);
    let cols = columns(f);
    precheck("crops", cols.len(), 1, (c.w * zoom, c.h * zoom))?;
    let mut row = SheetRow {
        label: vec![f.budget_label(), format!("crop, {zoom}×")],
        ..Default::default()
    };
    for (name, img) in &cols {
        row.tiles.push(Some(tile(c.w, c.h, zoom, |x, y| {
            to_srgb8(img[((c.y + y) * w + c.x + x) as usize], k)
        })));
        row.captions
            .push(if *name == "reference" && f.reference.is_some() {
                String::new()
            } else {
                match f.metrics(name) {
                    Some(r) if r.snr_db.is_finite() => format!("SNR {:.1} dB", r.snr_db),
                    _ => String::new(),
                }
            });
    }
    let sheet = Sheet {
        title: vec![
            format!("{}: crop at {}", f.info.config.name, f.budget_title()),
            format!(
                "{}×{} pixels at ({}, {}), repeat 0; SNR of the whole image",
                c.w, c.h, c.x, c.y
            ),
        ],
        columns: cols.iter().map(|c| c.0.to_string()).collect(),
        tile: (c.w * zoom, c.h * zoom),
        rows: vec![row],
    };
    write_sheet(&sheet, fig, "crops", "crops")
}

/// Widest row of parameter-grid tiles, pixels, before the tiles are averaged down.
const GRID_WIDTH: u32 = 1024;

/// The parameter grid: one cell per (row value, column value), one exposure for all.
pub fn parameter_grid(
    info: &RunInfo,
    g: &Grid,
    cells: &[(usize, usize, Vec<Vec3>)],
    fig: &Path,
) -> Result<Vec<PathBuf>, Error> {
    let (nr, nc) = (g.rows.values.len(), g.columns.values.len());
    // Tiles averaged down (s × s boxes, linear values) so that a row of them is at most
    // GRID_WIDTH pixels: a 6 × 6 grid of 256² cells would be a 5 MB PNG of noise.
    let s = (nc as u32 * info.width).div_ceil(GRID_WIDTH).max(1);
    let (w, h) = (info.width / s, info.height / s);
    let (w, h) = (w.max(1), h.max(1));
    let zoom = zoom_for(w, h, MIN_TILE);
    precheck("parameter grid", nc, nr, (w * zoom, h * zoom))?;
    // One exposure for the whole grid so the cells compare.
    let all: Vec<Vec3> = cells.iter().flat_map(|c| c.2.iter().copied()).collect();
    let k = exposure(&all);
    let mut rows: Vec<SheetRow> = g
        .rows
        .values
        .iter()
        .map(|v| SheetRow {
            label: vec![format!("{} = {v}", g.rows.field)],
            tiles: vec![None; g.columns.values.len()],
            ..Default::default()
        })
        .collect();
    let full_w = info.width;
    for (r, c, px) in cells {
        let shrunk: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let (x0, y0) = ((i % w) * s, (i / w) * s);
                let mut acc = Vec3::ZERO;
                for y in y0..y0 + s {
                    for x in x0..x0 + s {
                        acc += px[(y * full_w + x) as usize];
                    }
                }
                acc / (s * s) as f32
            })
            .collect();
        rows[*r].tiles[*c] = Some(tile(w, h, zoom, |x, y| {
            to_srgb8(shrunk[(y * w + x) as usize], k)
        }));
    }
    let budget = info.modes.first().map(|m| {
        let b = m.budgets[m.budgets.len() - 1];
        match m.mode {
            BudgetMode::Time => format!("{b} s"),
            BudgetMode::Spp => format!("{b} spp"),
        }
    });
    let variant = info.config.variants.first().map_or("", |v| v.name.as_str());
    let sheet = Sheet {
        title: vec![
            format!("{}: material {}", info.config.name, g.material),
            format!(
                "{variant} at {}; rows: {}, columns: {}",
                budget.unwrap_or_default(),
                g.rows.field,
                g.columns.field
            ),
        ],
        columns: g
            .columns
            .values
            .iter()
            .map(|v| format!("{} = {v}", g.columns.field))
            .collect(),
        tile: (w * zoom, h * zoom),
        rows,
    };
    write_sheet(&sheet, fig, "parameter-grid", "parameter grid")
}
