//! Figures from stored results only (`run.json`, `metrics.csv`, the EXRs): convergence plots
//! (plotters, SVG backend, no system fonts), an image grid with false-colour error maps and zoomed
//! crops (PNG via the image crate, labelled by a small SVG that references the PNG), scanline plots
//! and the parameter-grid composite.

use super::config::BudgetMode;
use super::record::{Row, RunInfo, image_file, read_metrics, safe_relative};
use super::sweep::{SweepRecord, compact, final_entries};
use crate::error::Error;
use crate::film::output::read_exr;
use crate::spectrum::cie::srgb_encode;
use glam::Vec3;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

type R<T> = Result<T, String>;

fn de<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Accept a run folder, or an experiment folder with a `latest` file (which must name a folder
/// inside the experiment folder).
pub fn resolve_run_dir(dir: &Path) -> Result<PathBuf, Error> {
    if dir.join("run.json").is_file() {
        return Ok(dir.to_path_buf());
    }
    let latest = dir.join("latest");
    if let Ok(t) = std::fs::read_to_string(&latest) {
        if !safe_relative(t.trim()) {
            return Err(Error::input(format!(
                "'{}': {:?} is not a run folder inside '{}'",
                latest.display(),
                t.trim(),
                dir.display()
            )));
        }
        let d = dir.join(t.trim());
        if d.join("run.json").is_file() {
            return Ok(d);
        }
    }
    Err(Error::input(format!(
        "'{}' holds no run.json (nor a `latest` pointing at a run)",
        dir.display()
    )))
}

/// Most pixels of a composite figure (image grid, crops, parameter grid).
const MAX_FIGURE_PIXELS: u64 = 1 << 28;

/// Regenerate every figure of a run into `<run>/figures/`. Everything read back (`run.json`,
/// `metrics.csv`, `sweep.json`, the EXRs) is checked first: a malformed or inconsistent file is an
/// input error naming it; a figure that cannot be written is a runtime error.
pub fn make_all(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let dir = resolve_run_dir(dir)?;
    let info = RunInfo::read(&dir)?;
    if info.config.sweep.is_some() {
        // A sweep: every value's folder is a run of its own, plus the summary.
        let mut out = Vec::new();
        for p in SweepRecord::read(&dir)?.points {
            out.extend(make_all(&dir.join(&p.dir))?);
        }
        out.extend(sweep_summary(&dir)?);
        return Ok(out);
    }
    let rows = read_metrics(&dir.join("metrics.csv"))?;
    let fig = dir.join("figures");
    std::fs::create_dir_all(&fig)
        .map_err(|e| Error::runtime(format!("cannot create '{}': {e}", fig.display())))?;
    let mut out = Vec::new();
    if !rows.is_empty() {
        let mut regions = vec!["all".to_string()];
        regions.extend(info.region_names.iter().cloned());
        for region in &regions {
            let suffix = region_suffix(region);
            for (time_plot, name) in [(true, "relmse-vs-seconds"), (false, "snr-vs-spp")] {
                let p = fig.join(format!("{name}{suffix}.svg"));
                convergence(&info, &rows, region, time_plot, &p).map_err(Error::runtime)?;
                out.push(p);
            }
        }
    }
    out.extend(image_figures(&dir, &info, &fig)?);
    if !info.grid_cells.is_empty() {
        out.extend(parameter_grid(&dir, &info, &fig)?);
    }
    Ok(out)
}

/// Read the EXR `file` of the run folder `dir`: it must exist and be `info`'s size; a reference
/// must be finite everywhere. Errors name the file.
fn load_image(dir: &Path, file: &str, info: &RunInfo, reference: bool) -> Result<Vec<Vec3>, Error> {
    let p = dir.join(file);
    let what = if reference {
        "the run's reference, `reference_file` of run.json"
    } else {
        "an image run.json lists"
    };
    let (w, h, px) = read_exr(&p).map_err(|e| Error::input(format!("{e} ({what})")))?;
    if (w, h) != (info.width, info.height) {
        return Err(Error::input(format!(
            "'{}' is {w}×{h}, but run.json (`width`, `height`) says {}×{}",
            p.display(),
            info.width,
            info.height
        )));
    }
    if reference && let Some(i) = px.iter().position(|c| !c.is_finite()) {
        return Err(Error::input(format!(
            "reference image '{}': pixel ({}, {}) is not finite ({}): metrics against it would be NaN",
            p.display(),
            i % w as usize,
            i / w as usize,
            px[i]
        )));
    }
    Ok(px)
}

/// An input error when a composite figure of `w`×`h` pixels would be too large.
fn check_size(what: &str, w: u64, h: u64) -> Result<(), Error> {
    if w.saturating_mul(h) > MAX_FIGURE_PIXELS || w > u32::MAX as u64 || h > u32::MAX as u64 {
        return Err(Error::input(format!(
            "the {what} figure would be {w}×{h} pixels (at most {MAX_FIGURE_PIXELS}): too many images in run.json"
        )));
    }
    Ok(())
}

/// The image grid, crops and scanline at the final budget (equal time preferred), repeat 0.
fn image_figures(dir: &Path, info: &RunInfo, fig: &Path) -> Result<Vec<PathBuf>, Error> {
    let mut out = Vec::new();
    let Some(mb) = info
        .modes
        .iter()
        .find(|m| m.mode == BudgetMode::Time)
        .or(info.modes.first())
    else {
        return Ok(out);
    };
    let idx = mb.budgets.len() - 1;
    let reference = match &info.reference_file {
        Some(f) => Some(load_image(dir, f, info, true)?),
        None => None,
    };
    let mut imgs = Vec::new();
    for v in &info.config.variants {
        let f = image_file(&v.name, mb.mode, idx, 0);
        if dir.join(&f).is_file() {
            imgs.push((v.name.clone(), load_image(dir, &f, info, false)?));
        }
    }
    let label = match mb.mode {
        BudgetMode::Time => format!("equal time {} s", mb.budgets[idx]),
        BudgetMode::Spp => format!("{} spp", mb.budgets[idx]),
    };
    if imgs.is_empty() || !info.grid_cells.is_empty() {
        return Ok(out);
    }
    let cols = imgs.len() as u64 + reference.is_some() as u64;
    let (w, h) = (info.width as u64, info.height as u64);
    check_size("image grid", cols * (w + GAP as u64), 2 * (h + GAP as u64))?;
    let r = reference.as_deref();
    out.extend(image_grid(info, r, &imgs, &label, fig).map_err(Error::runtime)?);
    if let Some(c) = info.crop {
        let zoom = (192 / c.w.max(c.h)).max(1) as u64;
        check_size(
            "crops",
            cols * (c.w as u64 * zoom + GAP as u64),
            c.h as u64 * zoom,
        )?;
        out.extend(crops(info, r, &imgs, c, &label, fig).map_err(Error::runtime)?);
    }
    if let Some(s) = info.scanline {
        let p = fig.join("scanline.svg");
        scanline(info, r, &imgs, s, &label, &p).map_err(Error::runtime)?;
        out.push(p);
    }
    Ok(out)
}

struct Line {
    name: String,
    /// (x, mean y, min y, max y)
    pts: Vec<(f64, f64, f64, f64)>,
}

fn lines(info: &RunInfo, rows: &[Row], region: &str, time_plot: bool) -> Vec<Line> {
    // relMSE vs seconds prefers equal-time snapshots; SNR vs spp prefers the spp ladder.
    let want = if time_plot { "time" } else { "spp" };
    let mode = if rows.iter().any(|r| r.mode == want) {
        want
    } else {
        rows[0].mode.as_str()
    };
    let mut out = Vec::new();
    for v in &info.config.variants {
        let mut budgets: Vec<f64> = rows
            .iter()
            .filter(|r| r.variant == v.name && r.mode == mode && r.region == region)
            .map(|r| r.budget)
            .collect();
        budgets.sort_by(f64::total_cmp);
        budgets.dedup();
        let mut pts = Vec::new();
        for b in budgets {
            let g: Vec<&Row> = rows
                .iter()
                .filter(|r| {
                    r.variant == v.name && r.mode == mode && r.region == region && r.budget == b
                })
                .collect();
            let n = g.len() as f64;
            let x = g
                .iter()
                .map(|r| if time_plot { r.seconds } else { r.spp as f64 })
                .sum::<f64>()
                / n;
            let ys: Vec<f64> = g
                .iter()
                .map(|r| if time_plot { r.rel_mse } else { r.snr_db })
                .filter(|y| y.is_finite())
                .collect();
            if ys.is_empty() || x.is_nan() || x <= 0.0 {
                continue;
            }
            let mean = ys.iter().sum::<f64>() / ys.len() as f64;
            let lo = ys.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if time_plot && (lo.is_nan() || lo <= 0.0) {
                continue;
            }
            pts.push((x, mean, lo, hi));
        }
        if !pts.is_empty() {
            out.push(Line {
                name: v.name.clone(),
                pts,
            });
        }
    }
    out
}

fn convergence(info: &RunInfo, rows: &[Row], region: &str, time_plot: bool, path: &Path) -> R<()> {
    let ls = lines(info, rows, region, time_plot);
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(de)?;
    let title = format!(
        "{}: {} ({})",
        info.config.name,
        if time_plot {
            "relMSE vs time"
        } else {
            "SNR vs spp"
        },
        region
    );
    let all: Vec<&(f64, f64, f64, f64)> = ls.iter().flat_map(|l| &l.pts).collect();
    if all.is_empty() {
        root.titled(&format!("{title}: no data"), ("sans-serif", 18))
            .map_err(de)?;
        root.present().map_err(de)?;
        return Ok(());
    }
    let x0 = all.iter().map(|p| p.0).fold(f64::INFINITY, f64::min) / 1.2;
    let x1 = all.iter().map(|p| p.0).fold(0.0, f64::max) * 1.2;
    let y0 = all.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
    let y1 = all.iter().map(|p| p.3).fold(f64::NEG_INFINITY, f64::max);
    let mut chart = ChartBuilder::on(&root);
    chart
        .caption(&title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    if time_plot {
        let mut c = chart
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
                (y0 / 1.5..y1 * 1.5)
                    .log_scale()
                    .with_key_points(log_ticks(y0 / 1.5, y1 * 1.5)),
            )
            .map_err(de)?;
        c.configure_mesh()
            .x_desc("seconds")
            .y_desc("relMSE")
            .x_labels(8)
            .y_labels(8)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(de)?;
        draw_lines(&mut c, &ls, SeriesLabelPosition::LowerLeft)?;
    } else {
        let pad = ((y1 - y0) * 0.1).max(0.5);
        let mut c = chart
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
                (y0 - pad)..(y1 + pad),
            )
            .map_err(de)?;
        c.configure_mesh()
            .x_desc("samples per pixel")
            .y_desc("SNR (dB)")
            .x_labels(8)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(de)?;
        draw_lines(&mut c, &ls, SeriesLabelPosition::UpperLeft)?;
    }
    root.present().map_err(de)?;
    Ok(())
}

/// Exposure scale mapping the 99th percentile of the max channel to 1.
fn exposure(img: &[Vec3]) -> f32 {
    let mut v: Vec<f32> = img
        .iter()
        .map(|c| c.max_element())
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(f32::total_cmp);
    1.0 / v[(v.len() as f64 * 0.99) as usize].max(1e-12)
}

fn to_srgb8(c: Vec3, k: f32) -> [u8; 3] {
    let f = |x: f32| {
        let x = if x.is_finite() { x * k } else { 0.0 };
        (srgb_encode(x.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8
    };
    [f(c.x), f(c.y), f(c.z)]
}

/// A perceptual-ish false-colour ramp (black → purple → orange → yellow), t in [0, 1].
fn ramp(t: f32) -> [u8; 3] {
    const S: [[f32; 3]; 5] = [
        [0.0, 0.0, 0.02],
        [0.34, 0.06, 0.43],
        [0.73, 0.21, 0.33],
        [0.98, 0.55, 0.04],
        [0.99, 1.0, 0.64],
    ];
    let t = t.clamp(0.0, 1.0) * 4.0;
    let i = (t as usize).min(3);
    let f = t - i as f32;
    let c = |k: usize| ((S[i][k] * (1.0 - f) + S[i + 1][k] * f) * 255.0) as u8;
    [c(0), c(1), c(2)]
}

/// Per-pixel relative error sqrt(mean_c (img − ref)² / (ref² + 1e-2)), mapped log10 over
/// [1e-3, 1].
fn error_colour(a: Vec3, r: Vec3) -> [u8; 3] {
    let mut e = 0.0f32;
    for c in 0..3 {
        let d = a[c] - r[c];
        e += d * d / (r[c] * r[c] + 1e-2);
    }
    let e = (e / 3.0).sqrt();
    if !e.is_finite() {
        return [255, 0, 255];
    }
    ramp((e.max(1e-3).log10() + 3.0) / 3.0)
}

const GAP: u32 = 4;

fn blit(
    dst: &mut image::RgbImage,
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    f: impl Fn(u32, u32) -> [u8; 3],
) {
    for y in 0..h {
        for x in 0..w {
            dst.put_pixel(x0 + x, y0 + y, image::Rgb(f(x, y)));
        }
    }
}

fn save_png(img: &image::RgbImage, p: &Path) -> R<()> {
    img.save(p)
        .map_err(|e| format!("cannot write '{}': {e}", p.display()))
}

fn svg_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A labelled SVG referencing `png` with a header band of `band` pixels.
fn label_svg(
    path: &Path,
    png: &str,
    pw: u32,
    ph: u32,
    band: u32,
    labels: &[(u32, u32, String)],
    title: &str,
) -> R<()> {
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\" width=\"{pw}\" height=\"{}\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"4\" y=\"14\" font-family=\"sans-serif\" font-size=\"12\">{}</text>\n<image x=\"0\" y=\"{band}\" width=\"{pw}\" height=\"{ph}\" xlink:href=\"{png}\" href=\"{png}\"/>\n",
        ph + band,
        svg_escape(title)
    );
    for (x, y, t) in labels {
        s += &format!(
            "<text x=\"{x}\" y=\"{y}\" font-family=\"sans-serif\" font-size=\"11\">{}</text>\n",
            svg_escape(t)
        );
    }
    s += "</svg>\n";
    std::fs::write(path, s).map_err(|e| format!("cannot write '{}': {e}", path.display()))
}

fn image_grid(
    info: &RunInfo,
    reference: Option<&[Vec3]>,
    imgs: &[(String, Vec<Vec3>)],
    label: &str,
    fig: &Path,
) -> R<Vec<PathBuf>> {
    let (w, h) = (info.width, info.height);
    let k = exposure(reference.unwrap_or(&imgs[0].1));
    let cols = imgs.len() as u32 + reference.is_some() as u32;
    let rows = if reference.is_some() { 2 } else { 1 };
    let (gw, gh) = (cols * w + (cols - 1) * GAP, rows * h + (rows - 1) * GAP);
    let mut g = image::RgbImage::from_pixel(gw, gh, image::Rgb([255, 255, 255]));
    let mut labels = Vec::new();
    let band = 20;
    let mut col = 0;
    if let Some(r) = reference {
        blit(&mut g, 0, 0, w, h, |x, y| {
            to_srgb8(r[(y * w + x) as usize], k)
        });
        labels.push((2, band - 4, "reference".to_string()));
        col = 1;
    }
    for (name, img) in imgs {
        let x0 = col * (w + GAP);
        blit(&mut g, x0, 0, w, h, |x, y| {
            to_srgb8(img[(y * w + x) as usize], k)
        });
        if let Some(r) = reference {
            blit(&mut g, x0, h + GAP, w, h, |x, y| {
                let i = (y * w + x) as usize;
                error_colour(img[i], r[i])
            });
        }
        labels.push((x0 + 2, band - 4, name.clone()));
        col += 1;
    }
    let png = fig.join("image-grid.png");
    save_png(&g, &png)?;
    let svg = fig.join("image-grid.svg");
    label_svg(
        &svg,
        "image-grid.png",
        gw,
        gh,
        band + 16,
        &labels
            .into_iter()
            .map(|(x, y, t)| (x, y + 16, t))
            .collect::<Vec<_>>(),
        &format!(
            "{} at {label}; bottom row: relative error sqrt(mean (img-ref)^2/(ref^2+0.01)), log colour 1e-3 (black) to 1 (yellow)",
            info.config.name
        ),
    )?;
    Ok(vec![png, svg])
}

fn crops(
    info: &RunInfo,
    reference: Option<&[Vec3]>,
    imgs: &[(String, Vec<Vec3>)],
    c: super::config::Crop,
    label: &str,
    fig: &Path,
) -> R<Vec<PathBuf>> {
    let w = info.width;
    let k = exposure(reference.unwrap_or(&imgs[0].1));
    let zoom = (192 / c.w.max(c.h)).max(1);
    let (cw, ch) = (c.w * zoom, c.h * zoom);
    let mut all: Vec<(&str, &[Vec3])> = Vec::new();
    if let Some(r) = reference {
        all.push(("reference", r));
    }
    for (n, i) in imgs {
        all.push((n, i));
    }
    let n = all.len() as u32;
    let gw = n * cw + (n - 1) * GAP;
    let mut g = image::RgbImage::from_pixel(gw, ch, image::Rgb([255, 255, 255]));
    let mut labels = Vec::new();
    for (j, (name, img)) in all.iter().enumerate() {
        let x0 = j as u32 * (cw + GAP);
        blit(&mut g, x0, 0, cw, ch, |x, y| {
            let (sx, sy) = (c.x + x / zoom, c.y + y / zoom);
            to_srgb8(img[(sy * w + sx) as usize], k)
        });
        labels.push((x0 + 2, 32, name.to_string()));
    }
    let png = fig.join("crops.png");
    save_png(&g, &png)?;
    let svg = fig.join("crops.svg");
    label_svg(
        &svg,
        "crops.png",
        gw,
        ch,
        36,
        &labels,
        &format!(
            "{}: crop {}x{} at ({}, {}), {label}, zoom {zoom}x",
            info.config.name, c.w, c.h, c.x, c.y
        ),
    )?;
    Ok(vec![png, svg])
}

fn luminance(c: Vec3) -> f64 {
    (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64
}

fn scanline(
    info: &RunInfo,
    reference: Option<&[Vec3]>,
    imgs: &[(String, Vec<Vec3>)],
    s: super::config::Scanline,
    label: &str,
    path: &Path,
) -> R<()> {
    let (w, h) = (info.width, info.height);
    let (n, at): (u32, Box<dyn Fn(u32) -> usize>) = match (s.row, s.column) {
        (Some(r), _) => (w, Box::new(move |i| (r * w + i) as usize)),
        (_, Some(c)) => (h, Box::new(move |i| (i * w + c) as usize)),
        _ => return Err("scanline needs a row or a column".into()),
    };
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    if let Some(r) = reference {
        series.push((
            "reference".into(),
            (0..n).map(|i| (i as f64, luminance(r[at(i)]))).collect(),
        ));
    }
    for (name, img) in imgs {
        series.push((
            name.clone(),
            (0..n).map(|i| (i as f64, luminance(img[at(i)]))).collect(),
        ));
    }
    let ymax = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let ymin = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(0.0, f64::min);
    let root = SVGBackend::new(path, (720, 400)).into_drawing_area();
    root.fill(&WHITE).map_err(de)?;
    let what = match (s.row, s.column) {
        (Some(r), _) => format!("row {r}"),
        (_, Some(c)) => format!("column {c}"),
        _ => unreachable!(),
    };
    let mut c = ChartBuilder::on(&root)
        .caption(
            format!("{}: luminance along {what}, {label}", info.config.name),
            ("sans-serif", 16),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..(n as f64 - 1.0).max(1.0), ymin..ymax)
        .map_err(de)?;
    c.configure_mesh()
        .x_desc("pixel")
        .y_desc("Y (linear)")
        .draw()
        .map_err(de)?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let col = if i == 0 && reference.is_some() {
            BLACK.to_rgba()
        } else {
            Palette99::pick(i - reference.is_some() as usize).to_rgba()
        };
        c.draw_series(LineSeries::new(
            pts.iter().copied().filter(|p| p.1.is_finite()),
            col.stroke_width(if i == 0 { 2 } else { 1 }),
        ))
        .map_err(de)?
        .label(name.clone())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(de)?;
    root.present().map_err(de)?;
    Ok(())
}

fn parameter_grid(dir: &Path, info: &RunInfo, fig: &Path) -> Result<Vec<PathBuf>, Error> {
    // RunInfo::check has made sure the cells lie inside the config's grid.
    let Some(g) = info.config.grid.as_ref() else {
        return Ok(Vec::new());
    };
    let (w, h) = (info.width, info.height);
    let (nr, nc) = (g.rows.values.len() as u32, g.columns.values.len() as u32);
    check_size(
        "parameter grid",
        nc as u64 * (w as u64 + GAP as u64),
        nr as u64 * (h as u64 + GAP as u64),
    )?;
    let mut cells = Vec::new();
    for c in &info.grid_cells {
        cells.push((
            c.row as u32,
            c.column as u32,
            load_image(dir, &c.file, info, false)?,
        ));
    }
    // One exposure for the whole grid so the cells compare.
    let all: Vec<Vec3> = cells.iter().flat_map(|c| c.2.iter().copied()).collect();
    let k = exposure(&all);
    let left = 0;
    let (gw, gh) = (nc * w + (nc - 1) * GAP, nr * h + (nr - 1) * GAP);
    let mut img = image::RgbImage::from_pixel(gw, gh, image::Rgb([255, 255, 255]));
    for (r, c, px) in &cells {
        blit(
            &mut img,
            left + c * (w + GAP),
            r * (h + GAP),
            w,
            h,
            |x, y| to_srgb8(px[(y * w + x) as usize], k),
        );
    }
    let png = fig.join("parameter-grid.png");
    save_png(&img, &png).map_err(Error::runtime)?;
    let band = 36;
    let mut labels = Vec::new();
    for (j, v) in g.columns.values.iter().enumerate() {
        labels.push((
            j as u32 * (w + GAP) + 2,
            band - 4,
            format!("{} = {v}", g.columns.field),
        ));
    }
    for (i, v) in g.rows.values.iter().enumerate() {
        labels.push((
            2,
            band + i as u32 * (h + GAP) + 12,
            format!("{} = {v}", g.rows.field),
        ));
    }
    let svg = fig.join("parameter-grid.svg");
    label_svg(
        &svg,
        "parameter-grid.png",
        gw,
        gh,
        band,
        &labels,
        &format!("{}: material {}", info.config.name, g.material),
    )
    .map_err(Error::runtime)?;
    Ok(vec![png, svg])
}

/// Compact tick label for log axes: 3 significant digits, scientific outside [1e-3, 1e4).
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e4).contains(&a) {
        return format!("{v:.1e}");
    }
    let digits = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Tick positions for a log axis: 1-2-5 per decade, or every integer multiple when the range
/// spans less than about a decade.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo) {
        return vec![];
    }
    let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let pick = |ms: &[f64]| -> Vec<f64> {
        (d0..=d1)
            .flat_map(|d| ms.iter().map(move |m| m * 10f64.powi(d)))
            .filter(|v| *v >= lo && *v <= hi)
            .collect()
    };
    let t = pick(&[1.0, 2.0, 5.0]);
    if t.len() >= 3 {
        t
    } else {
        pick(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    }
}

/// The sweep's summary: final-budget SNR (mean line, min–max band over repeats) per variant
/// against the swept value, `figures/snr-vs-sweep[-region].svg`, from each value's
/// `metrics.csv`. The values are evenly spaced and labelled with their text, so a value may be
/// any JSON.
pub fn sweep_summary(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let info = RunInfo::read(dir)?;
    let rec = SweepRecord::read(dir)?;
    let fig = dir.join("figures");
    std::fs::create_dir_all(&fig)
        .map_err(|e| Error::runtime(format!("cannot create '{}': {e}", fig.display())))?;
    let mut finals = Vec::new();
    for p in &rec.points {
        finals.push(final_entries(&read_metrics(
            &dir.join(&p.dir).join("metrics.csv"),
        )?));
    }
    let mut regions: Vec<String> = Vec::new();
    for e in finals.iter().flatten() {
        if !regions.contains(&e.region) {
            regions.push(e.region.clone());
        }
    }
    let mut out = Vec::new();
    for region in &regions {
        let suffix = region_suffix(region);
        let p = fig.join(format!("snr-vs-sweep{suffix}.svg"));
        let ls = sweep_lines(&finals, region);
        let labels: Vec<String> = rec
            .points
            .iter()
            .map(|p| short(&compact(&p.value)))
            .collect();
        let title = format!(
            "{}: SNR at the final budget vs {} ({region})",
            info.config.name, rec.label
        );
        sweep_plot(&ls, &labels, &rec.label, &title, &p).map_err(Error::runtime)?;
        out.push(p);
    }
    Ok(out)
}

/// One line per variant (and mode, when there are two) through the values' final-budget SNR.
fn sweep_lines(finals: &[Vec<super::record::SummaryEntry>], region: &str) -> Vec<Line> {
    let modes: Vec<&str> = {
        let mut m: Vec<&str> = finals.iter().flatten().map(|e| e.mode.as_str()).collect();
        m.sort();
        m.dedup();
        m
    };
    let mut out: Vec<Line> = Vec::new();
    for (i, entries) in finals.iter().enumerate() {
        for e in entries.iter().filter(|e| e.region == region) {
            let s = e.snr_db;
            if !s.mean.is_finite() {
                continue;
            }
            let name = if modes.len() > 1 {
                format!("{} ({})", e.variant, e.mode)
            } else {
                e.variant.clone()
            };
            let pt = (i as f64, s.mean, s.min, s.max);
            match out.iter_mut().find(|l| l.name == name) {
                Some(l) => l.pts.push(pt),
                None => out.push(Line {
                    name,
                    pts: vec![pt],
                }),
            }
        }
    }
    out
}

fn short(s: &str) -> String {
    if s.chars().count() <= 24 {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(23).collect::<String>())
    }
}

fn sweep_plot(ls: &[Line], labels: &[String], xlabel: &str, title: &str, path: &Path) -> R<()> {
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(de)?;
    let all: Vec<&(f64, f64, f64, f64)> = ls.iter().flat_map(|l| &l.pts).collect();
    if all.is_empty() {
        root.titled(&format!("{title}: no data"), ("sans-serif", 18))
            .map_err(de)?;
        root.present().map_err(de)?;
        return Ok(());
    }
    let y0 = all.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
    let y1 = all.iter().map(|p| p.3).fold(f64::NEG_INFINITY, f64::max);
    let pad = ((y1 - y0) * 0.1).max(0.5);
    let n = labels.len();
    let mut c = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..n as f64 - 0.5, (y0 - pad)..(y1 + pad))
        .map_err(de)?;
    c.configure_mesh()
        .x_desc(xlabel)
        .y_desc("SNR (dB)")
        .x_labels(n + 2)
        .x_label_formatter(&|v| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(de)?;
    draw_lines(&mut c, ls, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(de)?;
    Ok(())
}

/// One line per variant with its repeat spread shaded, markers and a legend.
fn draw_lines<'a, DB, X, Y>(
    c: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    ls: &[Line],
    legend: SeriesLabelPosition,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for (i, l) in ls.iter().enumerate() {
        let col = Palette99::pick(i).to_rgba();
        let mut band: Vec<(f64, f64)> = l.pts.iter().map(|p| (p.0, p.3)).collect();
        band.extend(l.pts.iter().rev().map(|p| (p.0, p.2)));
        c.draw_series(std::iter::once(Polygon::new(band, col.mix(0.2))))
            .map_err(de)?;
        c.draw_series(LineSeries::new(
            l.pts.iter().map(|p| (p.0, p.1)),
            col.stroke_width(2),
        ))
        .map_err(de)?
        .label(l.name.clone())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        c.draw_series(
            l.pts
                .iter()
                .map(|p| Circle::new((p.0, p.1), 3, col.filled())),
        )
        .map_err(de)?;
    }
    c.configure_series_labels()
        .position(legend)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(de)?;
    Ok(())
}

/// The file-name suffix of a region's figure: none for the whole image, `-name` otherwise, with
/// any character but letters, digits, '-', '_', '.' and '+' replaced by '_' (a region name is a
/// shape or material name and must not lead out of `figures/`).
fn region_suffix(region: &str) -> String {
    if region == "all" {
        String::new()
    } else {
        let safe: String = region
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "-_.+".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        format!("-{safe}")
    }
}
