//! Figures from stored results only (`run.json`, `metrics.csv`, the EXRs): convergence plots
//! (plotters, SVG backend, no system fonts; [`plots`]), and raster figures whose PNG is complete
//! by itself ([`images`], [`difference`]): the image grid with false-colour error maps and their
//! colour bar, zoomed crops, the parameter-grid composite and the signed difference of two
//! images. Their text is drawn with the font compiled into the binary ([`text`]), as is that of
//! the Gaussian-mixture box plots' PNGs.

mod colour;
mod difference;
mod images;
mod plots;
mod sheet;
pub mod text;

pub use colour::{exposure, luminance, ramp};
pub use difference::difference_of_images;
pub use plots::sweep_summary;

use super::config::BudgetMode;
use super::record::{Row, RunInfo, image_file, read_metrics, read_run_image, safe_relative};
use super::sweep::SweepRecord;
use crate::error::Error;
use crate::io::output::write_atomic;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Accept a run folder, or an experiment folder with a `latest` file (which must name a folder
/// inside the experiment folder).
pub fn resolve_run_dir(dir: &Path) -> Result<PathBuf, Error> {
    if dir.join("run.json").is_file() {
        return Ok(dir.to_path_buf());
    }
    let latest = dir.join("latest");
    if latest.exists() {
        let t =
            crate::io::input::read_text(&latest, crate::io::input::LATEST).map_err(Error::input)?;
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

/// Most pixels of a composite figure (image grid, crops, parameter grid, difference).
const MAX_FIGURE_PIXELS: u64 = 1 << 28;

/// Regenerate every figure of a run into `<run>/figures/`. Everything read back (`run.json`,
/// `metrics.csv`, `sweep.json`, the EXRs) is checked first: a malformed or inconsistent file is an
/// input error naming it; a figure that cannot be written is a runtime error.
pub fn make_all(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    make(dir, true)
}

/// [`make_all`], or only the plots that `metrics.csv` alone gives (`images` false: a run whose
/// images were not kept, such as a committed one).
pub fn make(dir: &Path, images: bool) -> Result<Vec<PathBuf>, Error> {
    let dir = resolve_run_dir(dir)?;
    let info = RunInfo::read(&dir)?;
    if info.config.sweep.is_some() {
        // A sweep: every value's folder is a run of its own, plus the summary.
        let mut out = Vec::new();
        for p in SweepRecord::read(&dir)?.points {
            out.extend(make(&dir.join(&p.dir), images)?);
        }
        out.extend(sweep_summary(&dir)?);
        return Ok(out);
    }
    let rows = read_metrics(&dir.join("metrics.csv"))?;
    if images {
        // Before anything is written: a run without its images keeps its old figures.
        check_images(&dir, &info)?;
    }
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
                plots::convergence(&info, &rows, region, time_plot, &p).map_err(Error::runtime)?;
                out.push(p);
            }
        }
    }
    if images {
        out.extend(image_figures(&dir, &info, &rows, &fig)?);
        if !info.grid_cells.is_empty() {
            out.extend(parameter_grid(&dir, &info, &fig)?);
        }
    }
    // For papers: the final-budget SNR table (booktabs); docs/figures.md puts it and the SVGs
    // into LaTeX.
    out.extend(super::latex_table::write_summary_table(&dir)?);
    Ok(out)
}

/// An input error naming the first image the image figures need that is not in the run folder:
/// the reference, every variant's final image of repeat 0, the grid's cells.
fn check_images(dir: &Path, info: &RunInfo) -> Result<(), Error> {
    let mut need: Vec<String> = info.reference_file.iter().cloned().collect();
    if info.grid_cells.is_empty()
        && let Some(mb) = final_mode(info)
    {
        let idx = mb.budgets.len() - 1;
        need.extend(
            info.config
                .variants
                .iter()
                .map(|v| image_file(&v.name, mb.mode, idx, 0)),
        );
    }
    need.extend(info.grid_cells.iter().map(|c| c.file.clone()));
    match need.iter().find(|f| !dir.join(f).is_file()) {
        None => Ok(()),
        Some(f) => Err(Error::input(format!(
            "'{}' is missing: the image figures need the run's images, and none was written \
             (`stokes figures --plots-only` redraws the plots from metrics.csv alone)",
            dir.join(f).display()
        ))),
    }
}

/// The budget mode whose final budget the image figures show: equal time, else the first.
fn final_mode(info: &RunInfo) -> Option<&super::record::ModeBudgets> {
    info.modes
        .iter()
        .find(|m| m.mode == BudgetMode::Time)
        .or(info.modes.first())
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

/// Write `img` as a PNG at `p` (through a temporary file).
fn save_png(img: &image::RgbImage, p: &Path) -> Result<(), Error> {
    write_atomic(p, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|e| format!("cannot write '{}': {e}", p.display()))
    })
    .map_err(Error::runtime)
}

/// What the image figures show: every image at the final budget of one budget mode (equal time
/// preferred), repeat 0, with its metrics.
struct Final<'a> {
    info: &'a RunInfo,
    rows: &'a [Row],
    mode: BudgetMode,
    idx: usize,
    budget: f64,
    reference: Option<Vec<Vec3>>,
    /// (variant, image) for every variant whose image exists, in config order.
    imgs: Vec<(String, Vec<Vec3>)>,
}

impl Final<'_> {
    fn time_mode(&self) -> bool {
        self.mode == BudgetMode::Time
    }

    /// The budget, e.g. "2.5 s" or "64 spp".
    fn budget_label(&self) -> String {
        match self.mode {
            BudgetMode::Time => format!("{} s", self.budget),
            BudgetMode::Spp => format!("{} spp", self.budget),
        }
    }

    /// The budget with its kind, e.g. "equal time 2.5 s" or "64 spp".
    fn budget_title(&self) -> String {
        match self.mode {
            BudgetMode::Time => format!("equal time {} s", self.budget),
            BudgetMode::Spp => format!("{} spp", self.budget),
        }
    }

    fn mode_label(&self) -> &'static str {
        match self.mode {
            BudgetMode::Time => "equal time",
            BudgetMode::Spp => "equal spp",
        }
    }

    /// The metrics.csv row of `variant` at this budget, repeat 0, whole image.
    fn metrics(&self, variant: &str) -> Option<&Row> {
        self.rows.iter().find(|r| {
            r.variant == variant
                && r.mode == self.mode.name()
                && r.budget == self.budget
                && r.repeat == 0
                && r.region == "all"
        })
    }

    /// How the reference was made, e.g. "bdpt-allbins, 2048 spp".
    fn reference_caption(&self) -> String {
        match &self.info.config.reference {
            Some(r) => match (&r.exr, r.integrator, r.spp) {
                (Some(p), _, _) => p
                    .file_name()
                    .map(|n| n.to_string_lossy().to_string())
                    .unwrap_or_default(),
                (None, Some(i), Some(spp)) => format!("{}, {spp} spp", i.name()),
                _ => String::new(),
            },
            None => String::new(),
        }
    }

    fn reference_line(&self) -> String {
        if self.reference.is_none() {
            return "no reference".into();
        }
        let c = self.reference_caption();
        if c.is_empty() {
            "reference".into()
        } else {
            format!("reference: {c}")
        }
    }
}

/// The image grid, crops, scanline and difference at the final budget (equal time preferred),
/// repeat 0.
fn image_figures(
    dir: &Path,
    info: &RunInfo,
    rows: &[Row],
    fig: &Path,
) -> Result<Vec<PathBuf>, Error> {
    let mut out = Vec::new();
    let Some(mb) = final_mode(info) else {
        return Ok(out);
    };
    if !info.grid_cells.is_empty() {
        return Ok(out);
    }
    let idx = mb.budgets.len() - 1;
    let reference = match &info.reference_file {
        Some(f) => Some(read_run_image(dir, f, info, true)?),
        None => None,
    };
    let mut imgs = Vec::new();
    for v in &info.config.variants {
        let f = image_file(&v.name, mb.mode, idx, 0);
        imgs.push((v.name.clone(), read_run_image(dir, &f, info, false)?));
    }
    if imgs.is_empty() {
        return Ok(out);
    }
    let f = Final {
        info,
        rows,
        mode: mb.mode,
        idx,
        budget: mb.budgets[idx],
        reference,
        imgs,
    };
    out.extend(images::image_grid(&f, fig)?);
    if let Some(c) = info.crop {
        out.extend(images::crops(&f, c, fig)?);
    }
    if let Some(s) = info.scanline {
        let p = fig.join("scanline.svg");
        let label = f.budget_title();
        plots::scanline(info, f.reference.as_deref(), &f.imgs, s, &label, &p)
            .map_err(Error::runtime)?;
        out.push(p);
    }
    if let Some(d) = &info.config.difference {
        out.extend(difference::difference(&f, d, fig)?);
    }
    Ok(out)
}

fn parameter_grid(dir: &Path, info: &RunInfo, fig: &Path) -> Result<Vec<PathBuf>, Error> {
    // RunInfo::check has made sure the cells lie inside the config's grid.
    let Some(g) = info.config.grid.as_ref() else {
        return Ok(Vec::new());
    };
    let (w, h) = (info.width as u64, info.height as u64);
    let (nr, nc) = (g.rows.values.len() as u64, g.columns.values.len() as u64);
    check_size("parameter grid", nc * (w + 4), nr * (h + 4))?;
    let mut cells = Vec::new();
    for c in &info.grid_cells {
        cells.push((c.row, c.column, read_run_image(dir, &c.file, info, false)?));
    }
    images::parameter_grid(info, g, &cells, fig)
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
