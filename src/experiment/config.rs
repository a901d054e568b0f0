//! Experiment configs: the JSON format (serde, unknown keys rejected) and the checks serde
//! cannot make. Errors name the file and the JSON path of the field, like scene errors.

use crate::integrator::{IntegratorKind, IntegratorOptions};
use crate::io::InputError;
use crate::io::json::from_json_str;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Experiment name: results go to `<root>/<name>/runs/<timestamp>/`.
    pub name: String,
    /// Free text; by convention names the paper figure the experiment reproduces.
    #[serde(default)]
    pub comment: String,
    /// Scene file, relative to the config file.
    pub scene: PathBuf,
    /// Ground truth. Required unless `grid` is given.
    #[serde(default)]
    pub reference: Option<Reference>,
    pub variants: Vec<Variant>,
    pub budget: Budget,
    /// Independent runs per variant; repeat r uses seed `seed + r`.
    #[serde(default = "one")]
    pub repeats: u32,
    /// Base seed of the variants.
    #[serde(default)]
    pub seed: u64,
    /// Worker threads (all cores when absent).
    #[serde(default)]
    pub threads: Option<usize>,
    #[serde(default)]
    pub regions: Option<Regions>,
    /// Zoom region in pixels of the scene's full resolution.
    #[serde(default)]
    pub crop: Option<Crop>,
    #[serde(default)]
    pub scanline: Option<Scanline>,
    /// Material parameter grid (Jung Fig. 7.13): renders the first variant once per cell.
    #[serde(default)]
    pub grid: Option<Grid>,
    /// One scene parameter stepped through values (Mojzík Figs. 18, 19): the whole experiment
    /// runs once per value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<Sweep>,
    /// A signed difference figure of two variants (Mojzík 2018 Fig. 11d/f).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub difference: Option<Difference>,
    /// Also write each variant's final image of repeat 0 as a spectral EXR of this many bins
    /// (`images/<name>__<mode><i>__r0.spectral.exr`, the layout of `stokes render --spectral`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectral: Option<usize>,
}

fn one() -> u32 {
    1
}

use crate::io::limits::{MAX_SECONDS, MAX_SPP, MAX_THREADS};
/// Most budgets per kind, variants, and values of a sweep.
pub const MAX_LIST: usize = 1000;
/// Most values along each axis of a parameter grid.
pub const MAX_GRID_AXIS: usize = 32;

/// Either `{"exr": path}` or `{"integrator", "spp", "seed", "options"}`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reference {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exr: Option<PathBuf>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub integrator: Option<IntegratorKind>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp: Option<u32>,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub options: IntegratorOptions,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    pub name: String,
    pub integrator: IntegratorKind,
    #[serde(default)]
    pub options: IntegratorOptions,
    /// A scene file (relative to the config) that replaces the config's scene for this variant
    /// only, e.g. another material in the same layout; the reference and the regions still come
    /// from the config's scene. Its camera resolution must be the config scene's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<PathBuf>,
}

/// Snapshots at an spp ladder, at equal-time budgets, or both (each is run separately).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budget {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp: Option<Vec<u32>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seconds: Option<Vec<f64>>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum RegionBy {
    Material,
    Shape,
}

impl RegionBy {
    /// What a region is, in messages.
    pub fn noun(self) -> &'static str {
        match self {
            RegionBy::Material => "material",
            RegionBy::Shape => "shape",
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Regions {
    pub by: RegionBy,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Crop {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scanline {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub column: Option<u32>,
}

/// Two material parameters swept over a grid; one composite image.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Material name in the scene.
    pub material: String,
    /// Parameter varied along rows (a field of the material, e.g. `concentration`).
    pub rows: GridAxis,
    /// Parameter varied along columns (e.g. `quantum_yield`).
    pub columns: GridAxis,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridAxis {
    pub field: String,
    pub values: Vec<f64>,
}

/// A scene parameter at a dot path (`media.fluid.sigma_a`) set to each value in turn.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Dot path of object keys into the scene JSON; the last key must exist in the scene.
    pub path: String,
    /// The values, any JSON (a number, a spectrum object, …).
    pub values: Vec<serde_json::Value>,
    /// Axis label of the summary figure (default: the path).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
}

impl Sweep {
    pub fn label(&self) -> &str {
        self.label.as_deref().unwrap_or(&self.path)
    }
}

/// `figures/difference.png`: the luminance of variant `a` minus that of variant `b` (the
/// reference when `b` is absent) at the final budget, repeat 0.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Difference {
    pub a: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<String>,
}

/// Which budget kind a snapshot belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BudgetMode {
    Spp,
    Time,
}

impl BudgetMode {
    pub fn name(&self) -> &'static str {
        match self {
            BudgetMode::Spp => "spp",
            BudgetMode::Time => "time",
        }
    }
}

fn err(file: &Path, path: &str, m: impl Into<String>) -> InputError {
    InputError::new(file, path, m)
}

/// Longest name (of the experiment, a variant or a region), in bytes: names become folder
/// and file names with up to about 40 bytes of prefix and suffix, and most file systems allow
/// 255 bytes per name.
pub const MAX_NAME_BYTES: usize = 100;

/// Names (of the experiment and of variants) become folder and file names.
pub(crate) fn name_ok(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= MAX_NAME_BYTES
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.+".contains(c))
        && !s.starts_with('.')
}

fn bad_name(s: &str) -> String {
    if s.len() > MAX_NAME_BYTES {
        let head: String = s.chars().take(20).collect();
        return format!(
            "is {} bytes long ({head:?}…); a name becomes a file name and may have at most \
             {MAX_NAME_BYTES} bytes",
            s.len()
        );
    }
    format!("must be non-empty and use only letters, digits, '-', '_', '.', '+', got {s:?}")
}

impl Config {
    /// Read, parse and validate a config file.
    pub fn load(path: &Path) -> Result<Config, InputError> {
        // (a UTF-8 byte-order mark, which some editors write, is dropped)
        let text = crate::io::input::read_text(path, crate::io::input::CONFIG)
            .map_err(|e| err(path, "", format!("cannot read the config: {e}")))?;
        Self::from_text(path, &text)
    }

    /// Parse and validate a config from JSON text; `path` names it in errors and resolves its
    /// relative paths (the Python API's configs given as a dict).
    pub fn from_text(path: &Path, text: &str) -> Result<Config, InputError> {
        let c: Config = from_json_str(path, text)?;
        c.validate(path)?;
        Ok(c)
    }

    /// The scene path resolved against the config's folder.
    pub fn scene_path(&self, config_file: &Path) -> PathBuf {
        resolve(config_file, &self.scene)
    }

    /// The checks serde cannot make, in field order; the first failure is returned.
    pub fn validate(&self, file: &Path) -> Result<(), InputError> {
        if !name_ok(&self.name) {
            return Err(err(file, "name", bad_name(&self.name)));
        }
        let sp = self.scene_path(file);
        if !sp.is_file() {
            return Err(err(
                file,
                "scene",
                format!("scene file '{}' not found", sp.display()),
            ));
        }
        self.validate_variants(file)?;
        self.validate_reference(file)?;
        self.validate_budget(file)?;
        self.validate_rest(file)?;
        self.validate_difference(file)?;
        self.validate_spectral(file)
    }

    /// `spectral` is 1–1024 bins, and every variant's integrator makes spectral images (not
    /// bdpt-allbins); not with `grid` (a grid run has no variant images).
    fn validate_spectral(&self, file: &Path) -> Result<(), InputError> {
        let Some(n) = self.spectral else {
            return Ok(());
        };
        let max = crate::film::spectral::MAX_BINS;
        if !(1..=max).contains(&n) {
            return Err(err(
                file,
                "spectral",
                format!("must be 1–{max} bins, got {n}"),
            ));
        }
        if self.grid.is_some() {
            return Err(err(file, "spectral", "cannot be combined with `grid`"));
        }
        for (i, v) in self.variants.iter().enumerate() {
            v.integrator
                .spectral_support()
                .map_err(|m| err(file, "spectral", format!("variant {i} ({:?}): {m}", v.name)))?;
        }
        Ok(())
    }

    /// `difference.a` and `difference.b` name two different variants; not with `grid` (a grid
    /// run has no variant images).
    fn validate_difference(&self, file: &Path) -> Result<(), InputError> {
        let Some(d) = &self.difference else {
            return Ok(());
        };
        if self.grid.is_some() {
            return Err(err(file, "difference", "cannot be combined with `grid`"));
        }
        let names: Vec<&str> = self.variants.iter().map(|v| v.name.as_str()).collect();
        for (field, name) in [("difference.a", Some(&d.a)), ("difference.b", d.b.as_ref())] {
            if let Some(n) = name
                && !names.contains(&n.as_str())
            {
                return Err(err(
                    file,
                    field,
                    format!(
                        "{n:?} is not a variant name (variants: {})",
                        names.join(", ")
                    ),
                ));
            }
        }
        if d.b.as_ref() == Some(&d.a) {
            return Err(err(
                file,
                "difference.b",
                format!("must differ from `difference.a` ({:?})", d.a),
            ));
        }
        Ok(())
    }

    fn validate_variants(&self, file: &Path) -> Result<(), InputError> {
        if self.variants.is_empty() || self.variants.len() > MAX_LIST {
            return Err(err(
                file,
                "variants",
                format!("must list 1–{MAX_LIST} variants"),
            ));
        }
        for (i, v) in self.variants.iter().enumerate() {
            if !name_ok(&v.name) {
                return Err(err(file, &format!("variants[{i}].name"), bad_name(&v.name)));
            }
            if self.variants[..i].iter().any(|o| o.name == v.name) {
                return Err(err(
                    file,
                    &format!("variants[{i}].name"),
                    format!("duplicate variant name {:?}", v.name),
                ));
            }
            v.options
                .validate_for(v.integrator)
                .map_err(|m| err(file, &format!("variants[{i}].options"), m))?;
            if let Some(p) = &v.scene {
                let field = format!("variants[{i}].scene");
                let sp = resolve(file, p);
                if !sp.is_file() {
                    return Err(err(
                        file,
                        &field,
                        format!("scene file '{}' not found", sp.display()),
                    ));
                }
                // A sweep or a grid changes the config's scene: which scene a variant with its
                // own would then render is ambiguous.
                for (set, key) in [
                    (self.sweep.is_some(), "sweep"),
                    (self.grid.is_some(), "grid"),
                ] {
                    if set {
                        return Err(err(
                            file,
                            &field,
                            format!("a variant's own scene cannot be combined with `{key}`"),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The scene path of variant `i` resolved against the config's folder, if it has its own.
    pub fn variant_scene_path(&self, config_file: &Path, i: usize) -> Option<PathBuf> {
        self.variants[i]
            .scene
            .as_ref()
            .map(|p| resolve(config_file, p))
    }

    fn validate_reference(&self, file: &Path) -> Result<(), InputError> {
        if self.sweep.is_some() && self.reference.as_ref().is_some_and(|r| r.exr.is_some()) {
            return Err(err(
                file,
                "reference.exr",
                "a sweep renders a reference per value: give `integrator` and `spp`",
            ));
        }
        let Some(r) = &self.reference else {
            if self.grid.is_none() {
                return Err(err(
                    file,
                    "reference",
                    "missing field `reference` (an {\"exr\": path} or {\"integrator\", \"spp\"})",
                ));
            }
            return Ok(());
        };
        match (&r.exr, r.integrator, r.spp) {
            (Some(p), None, None) => {
                let p = resolve(file, p);
                if !p.is_file() {
                    return Err(err(
                        file,
                        "reference.exr",
                        format!("reference image '{}' not found", p.display()),
                    ));
                }
            }
            (None, Some(kind), Some(spp)) => {
                if spp == 0 || spp > MAX_SPP {
                    return Err(err(
                        file,
                        "reference.spp",
                        format!("must be 1–{MAX_SPP}, got {spp}"),
                    ));
                }
                r.options
                    .validate_for(kind)
                    .map_err(|m| err(file, "reference.options", m))?;
            }
            (None, None, _) => {
                return Err(err(
                    file,
                    "reference",
                    "give either `exr` or `integrator` and `spp`",
                ));
            }
            (None, Some(_), None) => {
                return Err(err(file, "reference.spp", "missing field `spp`"));
            }
            (Some(_), _, _) => {
                return Err(err(
                    file,
                    "reference",
                    "give either `exr` or `integrator` and `spp`, not both",
                ));
            }
        }
        Ok(())
    }

    fn validate_budget(&self, file: &Path) -> Result<(), InputError> {
        let (spp, secs) = (&self.budget.spp, &self.budget.seconds);
        if spp.is_none() && secs.is_none() {
            return Err(err(
                file,
                "budget",
                "give `spp` (a ladder such as [1, 2, 4]) and/or `seconds` (equal-time budgets)",
            ));
        }
        if let Some(l) = spp {
            if l.is_empty() || l.len() > MAX_LIST {
                return Err(err(
                    file,
                    "budget.spp",
                    format!("must list 1–{MAX_LIST} budgets"),
                ));
            }
            if l[0] == 0 || l.windows(2).any(|w| w[1] <= w[0]) || l[l.len() - 1] > MAX_SPP {
                return Err(err(
                    file,
                    "budget.spp",
                    format!("must be positive, strictly increasing and at most {MAX_SPP}"),
                ));
            }
        }
        if let Some(l) = secs {
            if l.is_empty() || l.len() > MAX_LIST {
                return Err(err(
                    file,
                    "budget.seconds",
                    format!("must list 1–{MAX_LIST} budgets"),
                ));
            }
            if l.iter().any(|s| !(*s > 0.0 && *s <= MAX_SECONDS))
                || l.windows(2).any(|w| w[1] <= w[0])
            {
                return Err(err(
                    file,
                    "budget.seconds",
                    format!("must be positive, strictly increasing and at most {MAX_SECONDS:e}"),
                ));
            }
        }
        Ok(())
    }

    /// Repeats, threads, crop, scanline, grid and sweep.
    fn validate_rest(&self, file: &Path) -> Result<(), InputError> {
        if self.repeats == 0 || self.repeats > 1000 {
            return Err(err(file, "repeats", "must be 1–1000"));
        }
        if self.seed.checked_add(self.repeats as u64).is_none() {
            return Err(err(file, "seed", "seed + repeats must fit in 64 bits"));
        }
        if let Some(n) = self.threads
            && !(1..=MAX_THREADS).contains(&n)
        {
            return Err(err(
                file,
                "threads",
                format!("must be 1–{MAX_THREADS}, got {n}"),
            ));
        }
        if let Some(c) = &self.crop {
            if c.w == 0 || c.h == 0 {
                return Err(err(file, "crop", "w and h must be at least 1"));
            }
            if c.x.checked_add(c.w).is_none() || c.y.checked_add(c.h).is_none() {
                return Err(err(
                    file,
                    "crop",
                    format!(
                        "{}×{} at ({}, {}) reaches past the largest image",
                        c.w, c.h, c.x, c.y
                    ),
                ));
            }
        }
        if let Some(s) = &self.scanline
            && s.row.is_some() == s.column.is_some()
        {
            return Err(err(
                file,
                "scanline",
                "give exactly one of `row` or `column`",
            ));
        }
        if let Some(g) = &self.grid {
            for (n, a) in [("rows", &g.rows), ("columns", &g.columns)] {
                if a.values.is_empty() || a.values.len() > MAX_GRID_AXIS {
                    return Err(err(
                        file,
                        &format!("grid.{n}.values"),
                        format!("must list 1–{MAX_GRID_AXIS} values"),
                    ));
                }
            }
        }
        if let Some(sw) = &self.sweep {
            if self.grid.is_some() {
                return Err(err(file, "sweep", "cannot be combined with `grid`"));
            }
            if sw.path.is_empty() || sw.path.split('.').any(str::is_empty) {
                return Err(err(
                    file,
                    "sweep.path",
                    format!("{:?} is not a dot path of object keys", sw.path),
                ));
            }
            if sw.values.is_empty() || sw.values.len() > MAX_LIST {
                return Err(err(
                    file,
                    "sweep.values",
                    format!("must list 1–{MAX_LIST} values"),
                ));
            }
        }
        Ok(())
    }

    /// The budget modes to run, in order.
    pub fn modes(&self) -> Vec<BudgetMode> {
        let mut m = Vec::new();
        if self.budget.spp.is_some() {
            m.push(BudgetMode::Spp);
        }
        if self.budget.seconds.is_some() {
            m.push(BudgetMode::Time);
        }
        m
    }

    /// Scale the config down for `--quick` smoke runs.
    pub fn quicken(&mut self) {
        self.repeats = 1;
        if let Some(l) = &mut self.budget.spp {
            let kept: Vec<u32> = l.iter().copied().filter(|&s| s <= 8).collect();
            *l = if kept.is_empty() {
                vec![l[0].min(8)]
            } else {
                kept
            };
        }
        if let Some(l) = &mut self.budget.seconds {
            let n = l.len().min(3);
            *l = l[..n].iter().map(|s| (s * 0.05).clamp(0.05, 0.5)).collect();
            for i in 1..l.len() {
                if l[i] <= l[i - 1] {
                    l[i] = l[i - 1] * 2.0;
                }
            }
        }
        if let Some(s) = self.reference.as_mut().and_then(|r| r.spp.as_mut()) {
            *s = (*s / 16).clamp(16, 64);
        }
    }
}

/// A path in a config, relative to the config file's folder.
pub fn resolve(config_file: &Path, p: &Path) -> PathBuf {
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        config_file.parent().unwrap_or(Path::new(".")).join(p)
    }
}
