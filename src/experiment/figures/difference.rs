//! The signed difference figure (as Mojzík 2018 Fig. 11d/f): the luminance of variant `a` minus
//! that of `b` (or of the reference) at the final budget, repeat 0, on a red/green diverging map
//! with a symmetric scale, next to the two images it compares.

use super::colour::{diverging, diverging_colour, exposure, luminance, robust_max, to_srgb8};
use super::images::{MIN_TILE, snr_caption, write_sheet};
use super::plots::tick;
use super::sheet::{Bar, Sheet, SheetRow, tile, zoom_for};
use super::{Final, check_size};
use crate::error::Error;
use crate::experiment::config::Difference;
use crate::experiment::record::image_file;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// The image of variant `name` at the final budget, or an input error naming the field and the
/// missing file.
fn variant_image<'a>(f: &'a Final, name: &str, field: &str) -> Result<&'a [Vec3], Error> {
    f.imgs
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, i)| i.as_slice())
        .ok_or_else(|| {
            Error::input(format!(
                "run.json: `config.difference.{field}` names {name:?}, but the run has no image \
                 '{}' (its final budget, repeat 0)",
                image_file(name, f.mode, f.idx, 0)
            ))
        })
}

/// The colour bar of the difference: ±m at the ends, 0 in the middle.
fn bar(a: &str, b: &str, m: f64, not_finite: bool) -> Bar {
    let label = |x: f64| {
        if x > 0.0 {
            format!("+{}", tick(x))
        } else if x < 0.0 {
            format!("−{}", tick(-x))
        } else {
            "0".into()
        }
    };
    let ticks = [-1.0, -0.5, 0.0, 0.5, 1.0]
        .iter()
        .map(|&s| ((0.5 + 0.5 * s) as f32, label(s * m)))
        .collect();
    let mut title = format!(
        "luminance difference Y({a}) − Y({b}), linear; green: {a} brighter, red: {b} brighter; \
         scale ±{} = 99th percentile of |difference|",
        tick(m)
    );
    if not_finite {
        title += "; magenta: not finite";
    }
    Bar {
        map: diverging,
        ticks,
        title,
    }
}

/// The sheet of `a`, `b` and Y(a) − Y(b) (`names` head the columns and the colour bar,
/// `captions` go under `a` and `b`), and the scale: the 99th percentile of |difference|.
fn difference_sheet(
    (a, b): (&[Vec3], &[Vec3]),
    (w, h): (u32, u32),
    (a_name, b_name): (&str, &str),
    captions: [String; 2],
    (title, label): (Vec<String>, Vec<String>),
) -> Result<(Sheet, f64), Error> {
    let diff: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(x, y)| luminance(*x) - luminance(*y))
        .collect();
    let m = robust_max(&diff);
    let not_finite = diff.iter().any(|x| !x.is_finite());
    let zoom = zoom_for(w, h, MIN_TILE);
    check_size("difference", 3 * (w * zoom) as u64, (h * zoom) as u64)?;
    let k = exposure(b);
    let [ca, cb] = captions;
    let row = SheetRow {
        label,
        tiles: vec![
            Some(tile(w, h, zoom, |x, y| {
                to_srgb8(a[(y * w + x) as usize], k)
            })),
            Some(tile(w, h, zoom, |x, y| {
                to_srgb8(b[(y * w + x) as usize], k)
            })),
            Some(tile(w, h, zoom, |x, y| {
                diverging_colour(diff[(y * w + x) as usize], m)
            })),
        ],
        captions: vec![ca, cb, format!("scale ±{}", tick(m))],
        bar: Some(bar(a_name, b_name, m, not_finite)),
    };
    let sheet = Sheet {
        title,
        columns: vec![
            a_name.to_string(),
            b_name.to_string(),
            format!("{a_name} − {b_name}"),
        ],
        tile: (w * zoom, h * zoom),
        rows: vec![row],
    };
    Ok((sheet, m))
}

/// Write `figures/difference.png` (and its `.svg`).
pub fn difference(f: &Final, d: &Difference, fig: &Path) -> Result<Vec<PathBuf>, Error> {
    let a = variant_image(f, &d.a, "a")?;
    let (b_name, b) = match &d.b {
        Some(n) => (n.as_str(), variant_image(f, n, "b")?),
        None => (
            "reference",
            f.reference.as_deref().ok_or_else(|| {
                Error::input(
                    "run.json: `config.difference` has no `b`, which means the reference, but the \
                     run has none (`reference_file`)",
                )
            })?,
        ),
    };
    let caption = |name: &str| {
        if d.b.is_none() && name == "reference" {
            f.reference_caption()
        } else {
            snr_caption(f, name)
        }
    };
    let title = vec![
        format!(
            "{}: signed difference {} − {b_name}",
            f.info.config.name, d.a
        ),
        format!(
            "luminance at {}, repeat 0; one exposure for both images",
            f.budget_title()
        ),
    ];
    let label = vec![f.budget_label(), f.mode_label().into()];
    let (sheet, _) = difference_sheet(
        (a, b),
        (f.info.width, f.info.height),
        (&d.a, b_name),
        [caption(&d.a), caption(b_name)],
        (title, label),
    )?;
    write_sheet(&sheet, fig, "difference", "difference")
}

/// A signed difference sheet of two images outside a run (`stokes diff`): `a`, `b` and the
/// luminance of `a` minus that of `b`, written as `<dir>/<stem>.png` (and `.svg`). Returns the
/// paths and the scale (the 99th percentile of |difference|).
pub fn difference_of_images(
    (a_name, a): (&str, &[Vec3]),
    (b_name, b): (&str, &[Vec3]),
    size: (u32, u32),
    title: &str,
    (dir, stem): (&Path, &str),
) -> Result<(Vec<PathBuf>, f64), Error> {
    let title = vec![
        title.to_string(),
        "luminance; one exposure for both images".into(),
    ];
    let (sheet, m) = difference_sheet(
        (a, b),
        size,
        (a_name, b_name),
        [a_name.into(), b_name.into()],
        (title, vec![]),
    )?;
    Ok((write_sheet(&sheet, dir, stem, "difference")?, m))
}
