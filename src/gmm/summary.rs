//! The rows of `delta-e00.csv` and their statistics in `summary.json`, per light in
//! `delta-e00-mono.csv` and `delta-e00-illuminants.csv` (Hua Figs. 7a and 8a).
//!
//! **The reference.** Each fit is compared with the matrix it was fitted to, the measurement as
//! cleaned by Hua §5.1 (values below the diagonal and negative ones zeroed): `de00`, and every
//! statistic not otherwise named. Beside it, `vs_raw` compares the same fit with the uncleaned
//! measurement, and `cleaning` the cleaned matrix with the uncleaned one (what the cleaning alone
//! changes, the same for every number of components).

use super::boxplot::{BoxStats, box_stats, quantile};
use super::colour::{Comparison, LightKind};
use crate::material::mixture::FitMethod;
use serde::Serialize;
use std::path::PathBuf;

/// One row of `delta-e00.csv`.
#[derive(Clone, Debug)]
pub struct Row {
    pub material: String,
    pub components: usize,
    /// The fit against the cleaned matrix (the reference).
    pub c: Comparison,
    /// Against the uncleaned measurement.
    pub raw: VsRaw,
}

/// The uncleaned measurement under one light: its colour, and ΔE00 of the fit and of the cleaned
/// matrix against it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VsRaw {
    pub lab_raw: [f64; 3],
    pub de00_fit: f64,
    pub de00_cleaning: f64,
}

/// The name of the reference in `summary.json`, and what it means.
pub const REFERENCE: &str = "cleaned";
pub const REFERENCE_NOTE: &str = "ΔE00 of each fit against the measured matrix as cleaned by \
Hua §5.1 (values below the diagonal and negative values zeroed), the matrix that was fitted; \
vs_raw: the same fits against the uncleaned measurement; cleaning: the cleaned matrix against \
the uncleaned measurement";

/// Statistics under the CIE illuminants and under monochromatic light.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct KindStats {
    pub cie: Stats,
    pub mono: Stats,
}

/// A light and its mean ΔE00 over the materials.
#[derive(Clone, Debug, Serialize)]
pub struct LightMean {
    pub light: String,
    pub mean: f64,
}

/// Mean, median, 95th percentile and maximum of a set of ΔE00.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Stats {
    pub n: usize,
    pub mean: f64,
    pub median: f64,
    pub p95: f64,
    pub max: f64,
}

/// A material and its mean ΔE00 under the CIE illuminants.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialMean {
    pub material: String,
    pub mean: f64,
}

/// The results for one number of components.
#[derive(Clone, Debug, Serialize)]
pub struct ComponentsSummary {
    pub components: usize,
    pub cie: Stats,
    pub mono: Stats,
    /// The box of each kind as drawn.
    pub cie_box: BoxStats,
    pub mono_box: BoxStats,
    /// The ten materials with the largest mean ΔE00 under the CIE illuminants, worst first.
    pub worst_cie: Vec<MaterialMean>,
    /// The ten CIE illuminants with the largest mean ΔE00 over the materials, worst first (Hua
    /// Fig. 8a).
    pub worst_illuminants: Vec<LightMean>,
    /// The ten materials with the largest mean ΔE00 under monochromatic light, worst first (Hua
    /// Figs. 5 and 6).
    pub worst_mono: Vec<MaterialMean>,
    /// The same fits against the uncleaned measurement.
    pub vs_raw: KindStats,
}

/// What `summary.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// What the fits are compared with: [`REFERENCE`], explained by `reference_note`.
    pub reference: String,
    pub reference_note: String,
    pub method: FitMethod,
    pub seed: u64,
    pub materials: Vec<String>,
    pub illuminants: Vec<String>,
    pub mono_wavelengths: Vec<f32>,
    pub per_components: Vec<ComponentsSummary>,
    /// The cleaned matrices against the uncleaned measurements (no fit involved).
    pub cleaning: KindStats,
    /// Wall time of the fits and comparisons, seconds.
    pub seconds: f64,
    /// The files written.
    pub outputs: Vec<PathBuf>,
    /// Seeded k-means++ starts per fit.
    pub restarts: usize,
}

/// Mean, median, 95th percentile and maximum (`None` for no data).
pub fn stats(values: &[f64]) -> Option<Stats> {
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    Some(Stats {
        n: s.len(),
        mean: s.iter().sum::<f64>() / s.len().max(1) as f64,
        median: quantile(&s, 0.5)?,
        p95: quantile(&s, 0.95)?,
        max: *s.last()?,
    })
}

const NO_STATS: Stats = Stats {
    n: 0,
    mean: f64::NAN,
    median: f64::NAN,
    p95: f64::NAN,
    max: f64::NAN,
};

/// The statistics of `value` over the rows at `k` components, per kind of light. Never empty with
/// at least one material and one illuminant; NaN (JSON null) otherwise.
fn kind_stats(rows: &[Row], k: usize, value: impl Fn(&Row) -> f64) -> KindStats {
    let of = |kind| -> Vec<f64> {
        rows.iter()
            .filter(|r| r.components == k && r.c.kind == kind)
            .map(&value)
            .collect()
    };
    KindStats {
        cie: stats(&of(LightKind::Cie)).unwrap_or(NO_STATS),
        mono: stats(&of(LightKind::Mono)).unwrap_or(NO_STATS),
    }
}

/// The cleaned matrices against the uncleaned ones (rows of the first number of components; the
/// value is the same at every one).
pub(super) fn cleaning(rows: &[Row], components: &[usize]) -> KindStats {
    let k = components.first().copied().unwrap_or(0);
    kind_stats(rows, k, |r| r.raw.de00_cleaning)
}

pub(super) fn summarise(rows: &[Row], components: &[usize]) -> Vec<ComponentsSummary> {
    let nan = f64::NAN;
    let no_box = BoxStats {
        n: 0,
        mean: nan,
        q1: nan,
        median: nan,
        q3: nan,
        whisker_lo: nan,
        whisker_hi: nan,
        min: nan,
        max: nan,
        outliers: 0,
    };
    let mut out = Vec::new();
    for &k in components {
        let of = |kind| -> Vec<f64> {
            rows.iter()
                .filter(|r| r.components == k && r.c.kind == kind)
                .map(|r| r.c.de00)
                .collect()
        };
        let (cie, mono) = (of(LightKind::Cie), of(LightKind::Mono));
        let by_material = |kind| worst(rows, k, kind, 10, |r| &r.material);
        let mat = |v: Vec<(String, f64)>| {
            v.into_iter()
                .map(|(material, mean)| MaterialMean { material, mean })
                .collect()
        };
        out.push(ComponentsSummary {
            components: k,
            cie: stats(&cie).unwrap_or(NO_STATS),
            mono: stats(&mono).unwrap_or(NO_STATS),
            cie_box: box_stats(&cie).unwrap_or(no_box),
            mono_box: box_stats(&mono).unwrap_or(no_box),
            worst_cie: mat(by_material(LightKind::Cie)),
            worst_illuminants: worst(rows, k, LightKind::Cie, 10, |r| &r.c.light)
                .into_iter()
                .map(|(light, mean)| LightMean { light, mean })
                .collect(),
            worst_mono: mat(by_material(LightKind::Mono)),
            vs_raw: kind_stats(rows, k, |r| r.raw.de00_fit),
        });
    }
    out
}

/// The `n` keys (materials or lights, by `key`) with the largest mean ΔE00 under lights of
/// `kind` at `k` components, worst first (ties by name).
fn worst<'a>(
    rows: &'a [Row],
    k: usize,
    kind: LightKind,
    n: usize,
    key: impl Fn(&'a Row) -> &'a String,
) -> Vec<(String, f64)> {
    let mut sums: std::collections::BTreeMap<&str, (f64, usize)> = Default::default();
    for r in rows
        .iter()
        .filter(|r| r.components == k && r.c.kind == kind)
    {
        let e = sums.entry(key(r)).or_default();
        e.0 += r.c.de00;
        e.1 += 1;
    }
    let mut v: Vec<(String, f64)> = sums
        .into_iter()
        .map(|(m, (s, c))| (m.to_string(), s / c as f64))
        .collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    v.truncate(n);
    v
}

/// The statistics of one light at one number of components over the materials.
#[derive(Clone, Debug)]
pub struct LightStats {
    pub light: String,
    pub kind: LightKind,
    pub components: usize,
    /// Of the fits against the cleaned matrices.
    pub stats: Stats,
    /// Mean of the fits against the uncleaned measurements.
    pub mean_vs_raw: f64,
    /// Mean of the cleaned matrices against the uncleaned measurements.
    pub mean_cleaning: f64,
}

/// Per light (in the order of the rows) and number of components, the statistics over the
/// materials.
pub fn per_light(rows: &[Row], components: &[usize]) -> Vec<LightStats> {
    let mut lights: Vec<(&str, LightKind)> = Vec::new();
    let mut index: std::collections::HashMap<&str, usize> = Default::default();
    for r in rows {
        index.entry(&r.c.light).or_insert_with(|| {
            lights.push((&r.c.light, r.c.kind));
            lights.len() - 1
        });
    }
    // Per (light, components): the rows' values.
    let mut groups: Vec<Vec<&Row>> = vec![Vec::new(); lights.len() * components.len()];
    for r in rows {
        if let Some(j) = components.iter().position(|&k| k == r.components) {
            groups[index[r.c.light.as_str()] * components.len() + j].push(r);
        }
    }
    let mut out = Vec::with_capacity(groups.len());
    for (g, group) in groups.iter().enumerate() {
        if group.is_empty() {
            continue;
        }
        let (light, kind) = lights[g / components.len()];
        let mean = |f: fn(&Row) -> f64| -> f64 {
            group.iter().map(|r| f(r)).sum::<f64>() / group.len().max(1) as f64
        };
        let de: Vec<f64> = group.iter().map(|r| r.c.de00).collect();
        out.push(LightStats {
            light: light.to_string(),
            kind,
            components: components[g % components.len()],
            stats: stats(&de).unwrap_or(NO_STATS),
            mean_vs_raw: mean(|r| r.raw.de00_fit),
            mean_cleaning: mean(|r| r.raw.de00_cleaning),
        });
    }
    out
}

/// A CSV field, quoted when it holds a comma or a quote.
pub(super) fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The text of `delta-e00-mono.csv` (`kind` mono: a wavelength column) or
/// `delta-e00-illuminants.csv` (cie: the illuminant's name): one row per light and number of
/// components, statistics over the materials.
pub fn per_light_csv(lights: &[LightStats], kind: LightKind) -> String {
    let first = match kind {
        LightKind::Mono => "wavelength_nm",
        LightKind::Cie => "illuminant",
    };
    let mut s = format!(
        "{first},components,materials,mean_fit_cleaned,median_fit_cleaned,p95_fit_cleaned,max_fit_cleaned,mean_fit_raw,mean_cleaned_raw\n"
    );
    for l in lights.iter().filter(|l| l.kind == kind) {
        let name = match kind {
            LightKind::Mono => l.light.trim_start_matches("mono-").to_string(),
            LightKind::Cie => field(&l.light),
        };
        let t = &l.stats;
        s.push_str(&format!(
            "{name},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            l.components, t.n, t.mean, t.median, t.p95, t.max, l.mean_vs_raw, l.mean_cleaning
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_known_data() {
        let s = stats(&[4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!((s.n, s.mean, s.median, s.max), (4, 2.5, 2.5, 4.0));
        assert!((s.p95 - 3.85).abs() < 1e-12);
        assert!(stats(&[]).is_none());
    }
}
