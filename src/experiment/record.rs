//! The on-disk run record that the runner writes and the figures read: `run.json` ([`RunInfo`]),
//! the rows of `metrics.csv` ([`Row`]), `summary.json` ([`SummaryEntry`]) and the names of the
//! snapshot images; and the run folder itself (a new timestamped folder per run, atomic writes).

use super::config::{BudgetMode, Config, Crop, Scanline};
use super::metrics::{self, Spread};
use crate::error::Error;
use crate::film::output::write_atomic;
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
}

impl RunInfo {
    /// Read `run.json` of the run folder `dir`.
    pub fn read(dir: &Path) -> Result<RunInfo, String> {
        let p = dir.join("run.json");
        let text = std::fs::read_to_string(&p).map_err(|e| format!("run.json: {e}"))?;
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", p.display()))
    }
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
    pub fn from_csv(line: &str) -> Option<Row> {
        let f: Vec<&str> = line.trim().split(',').collect();
        if f.len() != 15 {
            return None;
        }
        let p = |s: &str| s.parse::<f64>().ok();
        Some(Row {
            variant: f[0].into(),
            integrator: f[1].into(),
            mode: f[2].into(),
            budget: p(f[3])?,
            repeat: f[4].parse().ok()?,
            seed: f[5].parse().ok()?,
            spp: f[6].parse().ok()?,
            seconds: p(f[7])?,
            samples_per_second: p(f[8])?,
            region: f[9].into(),
            pixels: f[10].parse().ok()?,
            mse: p(f[11])?,
            rel_mse: p(f[12])?,
            snr_db: p(f[13])?,
            efficiency: p(f[14])?,
        })
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

pub fn read_metrics(path: &Path) -> Result<Vec<Row>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let mut rows = Vec::new();
    for (i, l) in text.lines().enumerate().skip(1) {
        if l.trim().is_empty() {
            continue;
        }
        rows.push(
            Row::from_csv(l).ok_or_else(|| format!("{}: bad line {}", path.display(), i + 1))?,
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
    write_atomic(p, |tmp| {
        std::fs::write(tmp, text).map_err(|e| format!("cannot write '{}': {e}", p.display()))
    })
    .map_err(Error::runtime)
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
        assert_eq!(Row::from_csv(&r.to_csv()), Some(r));
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
