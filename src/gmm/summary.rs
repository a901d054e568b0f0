//! The rows of `delta-e00.csv` and their statistics in `summary.json`.

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
    pub c: Comparison,
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
}

/// What `summary.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub method: FitMethod,
    pub seed: u64,
    pub materials: Vec<String>,
    pub illuminants: Vec<String>,
    pub mono_wavelengths: Vec<f32>,
    pub per_components: Vec<ComponentsSummary>,
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

pub(super) fn summarise(rows: &[Row], components: &[usize]) -> Vec<ComponentsSummary> {
    // Never used with at least one material and one illuminant; NaN (JSON null) otherwise.
    let nan = f64::NAN;
    let no_stats = Stats {
        n: 0,
        mean: nan,
        median: nan,
        p95: nan,
        max: nan,
    };
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
        out.push(ComponentsSummary {
            components: k,
            cie: stats(&cie).unwrap_or(no_stats),
            mono: stats(&mono).unwrap_or(no_stats),
            cie_box: box_stats(&cie).unwrap_or(no_box),
            mono_box: box_stats(&mono).unwrap_or(no_box),
            worst_cie: worst_materials(rows, k, 10),
        });
    }
    out
}

/// The `n` materials with the largest mean ΔE00 under the CIE illuminants at `k` components.
fn worst_materials(rows: &[Row], k: usize, n: usize) -> Vec<MaterialMean> {
    let mut sums: std::collections::BTreeMap<&str, (f64, usize)> = Default::default();
    for r in rows
        .iter()
        .filter(|r| r.components == k && r.c.kind == LightKind::Cie)
    {
        let e = sums.entry(&r.material).or_default();
        e.0 += r.c.de00;
        e.1 += 1;
    }
    let mut v: Vec<MaterialMean> = sums
        .into_iter()
        .map(|(m, (s, c))| MaterialMean {
            material: m.to_string(),
            mean: s / c as f64,
        })
        .collect();
    v.sort_by(|a, b| {
        b.mean
            .total_cmp(&a.mean)
            .then_with(|| a.material.cmp(&b.material))
    });
    v.truncate(n);
    v
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
