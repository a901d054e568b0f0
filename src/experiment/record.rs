//! The on-disk run record that the runner writes and the figures read: `run.json` ([`RunInfo`]),
//! the rows of `metrics.csv` ([`Row`]), `summary.json` ([`SummaryEntry`]) and the names of the
//! snapshot images; and the run folder itself (a new timestamped folder per run, atomic writes).

use super::config::{BudgetMode, Config, Crop, Scanline};
use super::metrics::{self, Spread};
use crate::error::Error;
use crate::film::output::read_exr;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Everything the figures need besides `metrics.csv` and the images, written as `run.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunInfo {
    pub config: Config,
    pub config_file: PathBuf,
    pub quick: bool,
    pub width: u32,
    pub height: u32,
    /// Crop and scanline in this run's pixels (scaled for `--quick`).
    pub crop: Option<Crop>,
    pub scanline: Option<Scanline>,
    pub region_names: Vec<String>,
    /// Budgets per mode, in snapshot order.
    pub modes: Vec<ModeBudgets>,
    pub reference_file: Option<String>,
    /// Parameter grid cells (row, column, EXR file), when the config has a grid.
    pub grid_cells: Vec<GridCell>,
    pub started: String,
    pub threads: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModeBudgets {
    pub mode: BudgetMode,
    pub budgets: Vec<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GridCell {
    pub row: usize,
    pub column: usize,
    pub file: String,
    /// Mean luminance Y of the pixels that see the grid's material (none when none does).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material_mean_y: Option<f64>,
}

/// Most budgets of one mode, grid cells, variants and regions a stored run may list.
const MAX_ITEMS: usize = 4096;

impl RunInfo {
    /// Read `run.json` of the run folder `dir` and check it (see [`RunInfo::check`]).
    pub fn read(dir: &Path) -> Result<RunInfo, Error> {
        let p = dir.join("run.json");
        let text =
            crate::io::input::read_text(&p, crate::io::input::RUN_RECORD).map_err(Error::input)?;
        let info: RunInfo = crate::io::json::from_json_str(&p, &text)?;
        info.check(&p)?;
        Ok(info)
    }

    /// What the figures rely on, checked as untrusted input: the size, the budgets (each mode's
    /// non-empty, finite, positive), crop and scanline inside the image, safe relative file names,
    /// grid cells inside the grid. Errors name `file` (run.json) and the field.
    pub fn check(&self, file: &Path) -> Result<(), Error> {
        let bad = |field: &str, m: String| {
            Error::input(format!("{}: field `{field}`: {m}", file.display()))
        };
        let (w, h) = (self.width as u64, self.height as u64);
        if w == 0 || h == 0 || w * h > crate::film::output::MAX_READ_PIXELS as u64 {
            return Err(bad("width", format!("{w}×{h} is not a valid image size")));
        }
        for (i, m) in self.modes.iter().enumerate() {
            let b = &m.budgets;
            if b.is_empty() || b.len() > MAX_ITEMS {
                return Err(bad(
                    &format!("modes[{i}].budgets"),
                    format!("must list 1–{MAX_ITEMS} budgets"),
                ));
            }
            if b.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return Err(bad(
                    &format!("modes[{i}].budgets"),
                    "budgets must be positive and finite".into(),
                ));
            }
        }
        if let Some(c) = self.crop {
            let fits =
                c.w > 0 && c.h > 0 && c.x as u64 + c.w as u64 <= w && c.y as u64 + c.h as u64 <= h;
            if !fits {
                return Err(bad(
                    "crop",
                    format!(
                        "{}×{} at ({}, {}) is not inside the {w}×{h} image",
                        c.w, c.h, c.x, c.y
                    ),
                ));
            }
        }
        if let Some(s) = self.scanline {
            let ok = match (s.row, s.column) {
                (Some(r), None) => (r as u64) < h,
                (None, Some(c)) => (c as u64) < w,
                _ => false,
            };
            if !ok {
                return Err(bad(
                    "scanline",
                    format!("needs one row < {h} or one column < {w}"),
                ));
            }
        }
        self.check_names(&bad)
    }

    /// Variant and region names, the reference file and the grid cells.
    fn check_names(&self, bad: &dyn Fn(&str, String) -> Error) -> Result<(), Error> {
        let vs = &self.config.variants;
        if vs.len() > MAX_ITEMS || self.region_names.len() > MAX_ITEMS {
            return Err(bad(
                "config.variants",
                "too many variants or regions".into(),
            ));
        }
        for (i, v) in vs.iter().enumerate() {
            if !super::config::name_ok(&v.name) {
                return Err(bad(
                    &format!("config.variants[{i}].name"),
                    format!("{:?} is not a valid variant name", v.name),
                ));
            }
        }
        if let Some(f) = &self.reference_file
            && !safe_relative(f)
        {
            return Err(bad(
                "reference_file",
                format!("{f:?} is not a file name inside the run folder"),
            ));
        }
        if self.grid_cells.len() > MAX_ITEMS {
            return Err(bad("grid_cells", "too many cells".into()));
        }
        let dims = self
            .config
            .grid
            .as_ref()
            .map(|g| (g.rows.values.len(), g.columns.values.len()));
        for (i, c) in self.grid_cells.iter().enumerate() {
            let field = format!("grid_cells[{i}]");
            let Some((nr, nc)) = dims else {
                return Err(bad(&field, "grid cells without `config.grid`".into()));
            };
            if c.row >= nr || c.column >= nc {
                return Err(bad(
                    &field,
                    format!(
                        "cell ({}, {}) is outside the {nr}×{nc} grid",
                        c.row, c.column
                    ),
                ));
            }
            if !safe_relative(&c.file) {
                return Err(bad(
                    &format!("{field}.file"),
                    format!("{:?} is not a file name inside the run folder", c.file),
                ));
            }
        }
        Ok(())
    }
}

/// Whether `p` is a relative path that stays inside its base (`io::tree::safe_relative`).
pub use crate::io::tree::safe_relative;

/// The marker file of a run folder that is being written or whose run failed or was
/// interrupted: written before anything renders, removed when the run completes.
pub const INCOMPLETE: &str = "INCOMPLETE";

/// Mark `run_dir` incomplete, saying what runs; also the first write into it (so an unwritable
/// results folder is found before anything renders).
pub fn mark_incomplete(run_dir: &Path, what: &str) -> Result<(), Error> {
    write_text(
        &run_dir.join(INCOMPLETE),
        &format!(
            "{what}\nstarted {} UTC by process {}. This run has not completed: it is still running, \
             or it failed or was interrupted. Its results may be partial; results written so far \
             are kept.\n",
            timestamp(),
            std::process::id()
        ),
    )
}

/// The run completed: remove its marker.
pub fn mark_complete(run_dir: &Path) -> Result<(), Error> {
    std::fs::remove_file(run_dir.join(INCOMPLETE)).map_err(|e| {
        Error::runtime(format!(
            "cannot remove '{}': {e}",
            run_dir.join(INCOMPLETE).display()
        ))
    })
}

/// An input error when `run_dir`, or the sweep run it is a value of (`<run>/sweep/<i>`), holds
/// the marker of an incomplete run.
pub fn check_complete(run_dir: &Path) -> Result<(), Error> {
    let mut dirs = vec![run_dir.to_path_buf()];
    if let Some(sweep) = run_dir.parent()
        && sweep.file_name().is_some_and(|n| n == "sweep")
        && let Some(run) = sweep.parent()
    {
        dirs.push(run.to_path_buf());
    }
    for d in dirs {
        let m = d.join(INCOMPLETE);
        if m.exists() {
            let what =
                crate::io::input::read_text(&m, crate::io::input::RUN_RECORD).unwrap_or_default();
            return Err(Error::input(format!(
                "'{}' is an incomplete run (marker '{}': {}); run the experiment again",
                d.display(),
                m.display(),
                what.lines().next().unwrap_or("no description")
            )));
        }
    }
    Ok(())
}

/// One line of `metrics.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub variant: String,
    pub integrator: String,
    pub mode: String,
    pub budget: f64,
    pub repeat: u32,
    pub seed: u64,
    pub spp: u32,
    pub seconds: f64,
    pub samples_per_second: f64,
    pub region: String,
    pub pixels: usize,
    pub mse: f64,
    pub rel_mse: f64,
    pub snr_db: f64,
    pub efficiency: f64,
}

pub const CSV_HEADER: &str = "variant,integrator,mode,budget,repeat,seed,spp,seconds,samples_per_second,region,pixels,mse,rel_mse,snr_db,efficiency";

impl Row {
    pub fn to_csv(&self) -> String {
        format!(
            "{},{},{},{},{},{},{},{:.6},{:.1},{},{},{:e},{:e},{:.4},{:e}",
            self.variant,
            self.integrator,
            self.mode,
            self.budget,
            self.repeat,
            self.seed,
            self.spp,
            self.seconds,
            self.samples_per_second,
            self.region,
            self.pixels,
            self.mse,
            self.rel_mse,
            self.snr_db,
            self.efficiency
        )
    }
    /// Parse one line; the error names the column that is wrong.
    pub fn from_csv(line: &str) -> Result<Row, String> {
        let f: Vec<&str> = line.trim().split(',').collect();
        if f.len() != 15 {
            return Err(format!("{} fields, expected 15", f.len()));
        }
        let col = |i: usize| CSV_HEADER.split(',').nth(i).unwrap_or("?");
        let num = |i: usize| -> Result<f64, String> {
            match f[i].parse::<f64>() {
                Ok(x) if !x.is_nan() => Ok(x),
                _ => Err(format!("column `{}`: {:?} is not a number", col(i), f[i])),
            }
        };
        let int = |i: usize| -> Result<u64, String> {
            f[i].parse::<u64>()
                .map_err(|_| format!("column `{}`: {:?} is not a count", col(i), f[i]))
        };
        let small = |i: usize| -> Result<u32, String> {
            u32::try_from(int(i)?)
                .map_err(|_| format!("column `{}`: {} is too large", col(i), f[i]))
        };
        let row = Row {
            variant: f[0].into(),
            integrator: f[1].into(),
            mode: f[2].into(),
            budget: num(3)?,
            repeat: small(4)?,
            seed: int(5)?,
            spp: small(6)?,
            seconds: num(7)?,
            samples_per_second: num(8)?,
            region: f[9].into(),
            pixels: int(10)? as usize,
            mse: num(11)?,
            rel_mse: num(12)?,
            snr_db: num(13)?,
            efficiency: num(14)?,
        };
        if row.mode != "spp" && row.mode != "time" {
            return Err(format!(
                "column `mode`: {:?} is not `spp` or `time`",
                row.mode
            ));
        }
        for (i, x) in [
            (3, row.budget),
            (7, row.seconds),
            (11, row.mse),
            (12, row.rel_mse),
        ] {
            if x < 0.0 || x.is_infinite() && i != 11 && i != 12 {
                return Err(format!("column `{}`: {x} is out of range", col(i)));
            }
        }
        Ok(row)
    }
}

/// The text of `metrics.csv`: the header, then one line per row.
pub fn metrics_csv(rows: &[Row]) -> String {
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for r in rows {
        csv.push_str(&r.to_csv());
        csv.push('\n');
    }
    csv
}

/// Read `metrics.csv` (a UTF-8 BOM is skipped); the header must be ours. Errors are input
/// errors naming the file, the line and the column.
pub fn read_metrics(path: &Path) -> Result<Vec<Row>, Error> {
    let text =
        crate::io::input::read_text(path, crate::io::input::RUN_TABLE).map_err(Error::input)?;
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == CSV_HEADER => {}
        _ => {
            return Err(Error::input(format!(
                "{}: line 1: the header is not `{CSV_HEADER}`",
                path.display()
            )));
        }
    }
    let mut rows = Vec::new();
    for (i, l) in lines {
        if l.trim().is_empty() {
            continue;
        }
        rows.push(
            Row::from_csv(l)
                .map_err(|e| Error::input(format!("{}: line {}: {e}", path.display(), i + 1)))?,
        );
    }
    Ok(rows)
}

/// Snapshot image file of `variant` at budget index `idx` of `mode`, repeat `r`.
pub fn image_file(variant: &str, mode: BudgetMode, idx: usize, r: u32) -> String {
    format!("images/{variant}__{}{idx}__r{r}.exr", mode.name())
}

/// Mean and spread over repeats, per variant × mode × budget × region.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SummaryEntry {
    pub variant: String,
    pub integrator: String,
    pub mode: String,
    pub budget: f64,
    pub region: String,
    pub repeats: usize,
    pub spp: Spread,
    pub seconds: Spread,
    pub samples_per_second: Spread,
    pub mse: Spread,
    pub rel_mse: Spread,
    pub snr_db: Spread,
    pub efficiency: Spread,
}

pub fn summarize(rows: &[Row]) -> Vec<SummaryEntry> {
    let mut keys: Vec<(String, String, String, f64, String)> = Vec::new();
    for r in rows {
        let k = (
            r.variant.clone(),
            r.integrator.clone(),
            r.mode.clone(),
            r.budget,
            r.region.clone(),
        );
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(variant, integrator, mode, budget, region)| {
            let g: Vec<&Row> = rows
                .iter()
                .filter(|r| {
                    r.variant == variant
                        && r.mode == mode
                        && r.budget == budget
                        && r.region == region
                })
                .collect();
            let s = |f: &dyn Fn(&Row) -> f64| {
                metrics::spread(&g.iter().map(|r| f(r)).collect::<Vec<_>>())
            };
            SummaryEntry {
                repeats: g.len(),
                spp: s(&|r| r.spp as f64),
                seconds: s(&|r| r.seconds),
                samples_per_second: s(&|r| r.samples_per_second),
                mse: s(&|r| r.mse),
                rel_mse: s(&|r| r.rel_mse),
                snr_db: s(&|r| r.snr_db),
                efficiency: s(&|r| r.efficiency),
                variant,
                integrator,
                mode,
                budget,
                region,
            }
        })
        .collect()
}

/// UTC time as `YYYYMMDD-HHMMSS`.
pub fn timestamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0) as i64;
    let (days, rem) = (secs.div_euclid(86400), secs.rem_euclid(86400));
    // Civil from days (H. Hinnant).
    let z = days + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    format!(
        "{y:04}{m:02}{d:02}-{:02}{:02}{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// Create `p` and its parents.
pub fn mkdir(p: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(p)
        .map_err(|e| Error::runtime(format!("cannot create folder '{}': {e}", p.display())))
}

/// Write `text` to `p` atomically (a temporary file, then a rename).
pub fn write_text(p: &Path, text: &str) -> Result<(), Error> {
    crate::io::output::write_bytes(p, text.as_bytes()).map_err(Error::runtime)
}

/// Create a new, empty run folder under `<root>/<name>/runs/`; never reuses an existing one.
pub fn new_run_dir(root: &Path, name: &str) -> Result<(PathBuf, String), Error> {
    let runs = root.join(name).join("runs");
    mkdir(&runs)?;
    let ts = timestamp();
    for i in 0..1000 {
        let n = if i == 0 {
            ts.clone()
        } else {
            format!("{ts}-{i}")
        };
        let d = runs.join(&n);
        match std::fs::create_dir(&d) {
            Ok(()) => return Ok((d, n)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(Error::runtime(format!(
                    "cannot create run folder '{}': {e}",
                    d.display()
                )));
            }
        }
    }
    Err(Error::runtime("too many runs in the same second"))
}

/// Read the EXR `file` of the run folder `dir` (for the figures and the report): it must exist,
/// be an OpenEXR image of the run's size, and a `reference` must be finite everywhere. Errors
/// name the file and say what is wrong.
pub fn read_run_image(
    dir: &Path,
    file: &str,
    info: &RunInfo,
    reference: bool,
) -> Result<Vec<Vec3>, Error> {
    let p = dir.join(file);
    let what = if reference {
        "the run's reference, `reference_file` of run.json"
    } else {
        "an image run.json lists"
    };
    if !p.is_file() {
        return Err(Error::input(format!(
            "'{}' is missing: {what}, but the file is not there",
            p.display()
        )));
    }
    let (w, h, px) = read_exr(&p).map_err(|e| {
        Error::input(format!(
            "{e} ({what}): the file is damaged or not an OpenEXR image; run the experiment again"
        ))
    })?;
    if (w, h) != (info.width, info.height) {
        return Err(Error::input(format!(
            "'{}' is {w}×{h} pixels, but run.json (`width`, `height`) says {}×{}",
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_row_round_trips() {
        let r = Row {
            variant: "a".into(),
            integrator: "pt-mono".into(),
            mode: "time".into(),
            budget: 2.5,
            repeat: 1,
            seed: 7,
            spp: 12,
            seconds: 2.5,
            samples_per_second: 1000.0,
            region: "floor".into(),
            pixels: 10,
            mse: 0.125,
            rel_mse: 0.5,
            snr_db: 3.25,
            efficiency: 0.8,
        };
        assert_eq!(Row::from_csv(&r.to_csv()), Ok(r));
        assert_eq!(CSV_HEADER.split(',').count(), 15);
    }

    #[test]
    fn timestamp_shape() {
        let t = timestamp();
        assert_eq!(t.len(), 15);
        assert_eq!(&t[8..9], "-");
        assert!(t.starts_with("20"));
    }
}
