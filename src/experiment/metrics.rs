//! Error metrics against a reference (docs/design.md §6), over linear-RGB pixels, optionally
//! restricted to a region mask.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The ε of relMSE = mean((img − ref)² / (ref² + ε)).
pub const REL_EPS: f64 = 1e-2;

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorMetrics {
    /// Pixels counted.
    pub pixels: usize,
    pub mse: f64,
    pub rel_mse: f64,
    /// 10·log10(Σ ref² / Σ (img − ref)²); +∞ for an exact image.
    pub snr_db: f64,
}

/// Metrics over the pixels where `mask` is true (all pixels when `mask` is `None`), summing
/// over the three channels. Non-finite image values count as an infinite error; so do
/// non-finite reference values (callers reject such references on load), which also add no
/// signal: the metrics are never NaN.
pub fn compare(img: &[Vec3], reference: &[Vec3], mask: Option<&[bool]>) -> ErrorMetrics {
    assert_eq!(
        img.len(),
        reference.len(),
        "image and reference sizes differ"
    );
    let (mut sig, mut noise, mut rel, mut n) = (0f64, 0f64, 0f64, 0usize);
    for (i, (a, r)) in img.iter().zip(reference).enumerate() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        n += 1;
        for c in 0..3 {
            let (a, r) = (a[c] as f64, r[c] as f64);
            if !r.is_finite() {
                noise = f64::INFINITY;
                rel = f64::INFINITY;
                continue;
            }
            let d = if a.is_finite() { a - r } else { f64::INFINITY };
            sig += r * r;
            noise += d * d;
            rel += d * d / (r * r + REL_EPS);
        }
    }
    let k = (3 * n.max(1)) as f64;
    ErrorMetrics {
        pixels: n,
        mse: noise / k,
        rel_mse: rel / k,
        snr_db: snr_db(sig, noise),
    }
}

/// SNR in dB from the signal and noise energies.
pub fn snr_db(signal: f64, noise: f64) -> f64 {
    if noise == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (signal / noise).log10()
    }
}

/// efficiency = 1 / (relMSE · seconds).
pub fn efficiency(rel_mse: f64, seconds: f64) -> f64 {
    1.0 / (rel_mse * seconds)
}

/// Mean, sample standard deviation, min and max of a set of values (non-finite ones skipped).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    pub mean: f64,
    pub std: f64,
    pub min: f64,
    pub max: f64,
    pub n: usize,
}

pub fn spread(values: &[f64]) -> Spread {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return Spread {
            mean: f64::NAN,
            std: f64::NAN,
            min: f64::NAN,
            max: f64::NAN,
            n: 0,
        };
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    Spread {
        mean,
        std: var.sqrt(),
        min: v.iter().copied().fold(f64::INFINITY, f64::min),
        max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        n: v.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_image_has_zero_error() {
        let r = vec![Vec3::new(0.5, 0.2, 0.1); 10];
        let m = compare(&r, &r, None);
        assert_eq!(m.mse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert!(m.snr_db.is_infinite());
    }

    #[test]
    fn constant_offset() {
        let r = vec![Vec3::splat(1.0); 4];
        let img = vec![Vec3::splat(1.1); 4];
        let m = compare(&img, &r, None);
        assert!((m.mse - 0.01).abs() < 1e-6);
        assert!((m.rel_mse - 0.01 / 1.01).abs() < 1e-6);
        // Σref² / Σd² = 1 / 0.01 → 20 dB.
        assert!((m.snr_db - 20.0).abs() < 1e-3);
    }

    #[test]
    fn mask_restricts_pixels() {
        let r = vec![Vec3::ONE, Vec3::ONE];
        let img = vec![Vec3::ONE, Vec3::splat(2.0)];
        let m = compare(&img, &r, Some(&[true, false]));
        assert_eq!(m.pixels, 1);
        assert_eq!(m.mse, 0.0);
    }

    #[test]
    fn nan_counts_as_infinite_error() {
        let r = vec![Vec3::ONE];
        let img = vec![Vec3::new(f32::NAN, 1.0, 1.0)];
        assert!(compare(&img, &r, None).mse.is_infinite());
    }

    #[test]
    fn non_finite_reference_gives_infinite_error_not_nan() {
        let r = vec![
            Vec3::new(f32::NAN, 1.0, 1.0),
            Vec3::new(f32::INFINITY, 1.0, 1.0),
        ];
        let m = compare(&[Vec3::ONE, Vec3::ONE], &r, None);
        assert!(m.mse.is_infinite() && m.rel_mse.is_infinite(), "{m:?}");
        assert!(!m.snr_db.is_nan(), "{m:?}");
    }

    #[test]
    fn spread_of_values() {
        let s = spread(&[1.0, 2.0, 3.0]);
        assert_eq!(s.mean, 2.0);
        assert_eq!(s.std, 1.0);
        assert_eq!((s.min, s.max, s.n), (1.0, 3.0, 3));
    }
}
