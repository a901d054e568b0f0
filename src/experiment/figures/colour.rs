//! Pixel colours of the raster figures: display exposure and sRGB encoding, the log false-colour
//! ramp of the relative error maps, and the red/green diverging map of signed differences, each
//! with the colour bar that explains it.

use super::sheet::Bar;
use crate::spectrum::cie::srgb_encode;
use glam::Vec3;

/// The colour of a pixel that is not a finite number.
pub const NOT_FINITE: [u8; 3] = [255, 0, 255];

/// Exposure scale mapping the 99th percentile of the max channel to 1.
pub fn exposure(img: &[Vec3]) -> f32 {
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

/// Linear sRGB scaled by `k`, clamped and encoded to 8 bits.
pub fn to_srgb8(c: Vec3, k: f32) -> [u8; 3] {
    let f = |x: f32| {
        let x = if x.is_finite() { x * k } else { 0.0 };
        (srgb_encode(x.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8
    };
    [f(c.x), f(c.y), f(c.z)]
}

/// Rec. 709 luminance of linear sRGB.
pub fn luminance(c: Vec3) -> f64 {
    (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64
}

/// A perceptual-ish false-colour ramp (black → purple → orange → yellow), t in [0, 1].
pub fn ramp(t: f32) -> [u8; 3] {
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

/// Per-pixel relative error sqrt(mean_c (img − ref)² / (ref² + 1e-2)) (the per-pixel form of
/// the relMSE of metrics.csv).
pub fn relative_error(a: Vec3, r: Vec3) -> f32 {
    let mut e = 0.0f32;
    for c in 0..3 {
        let d = a[c] - r[c];
        e += d * d / (r[c] * r[c] + 1e-2);
    }
    (e / 3.0).sqrt()
}

/// Decades of the error map: log10 of the relative error from −3 (black) to 0 (yellow).
const ERROR_DECADES: f32 = 3.0;

/// The relative error mapped log10 over [1e-3, 1]; magenta when not finite.
pub fn error_colour(a: Vec3, r: Vec3) -> [u8; 3] {
    let e = relative_error(a, r);
    if !e.is_finite() {
        return NOT_FINITE;
    }
    ramp((e.max(1e-3).log10() + ERROR_DECADES) / ERROR_DECADES)
}

/// The colour bar of [`error_colour`]: a tick per decade. `not_finite` adds the magenta note.
pub fn error_bar(not_finite: bool) -> Bar {
    let ticks = [(0.0, "≤ 0.001"), (1.0, "0.01"), (2.0, "0.1"), (3.0, "≥ 1")]
        .iter()
        .map(|&(d, l)| (d / ERROR_DECADES, l.to_string()))
        .collect();
    let mut title =
        "relative error √(mean over R, G, B of (x − r)² / (r² + 0.01)), r = reference, log scale"
            .to_string();
    if not_finite {
        title += "; magenta: not finite";
    }
    Bar {
        map: ramp,
        ticks,
        title,
    }
}

/// A signed value `d` on the symmetric scale ±`m`: green for d > 0, red for d < 0, black at 0,
/// brightness sRGB-encoded |d| / m (saturating beyond ±m); magenta when not finite.
pub fn diverging_colour(d: f64, m: f64) -> [u8; 3] {
    if !d.is_finite() {
        return NOT_FINITE;
    }
    diverging((0.5 + 0.5 * d / m) as f32)
}

/// The diverging map at t ∈ [0, 1] (0: −m, ½: 0, 1: +m).
pub fn diverging(t: f32) -> [u8; 3] {
    let s = (2.0 * t.clamp(0.0, 1.0) - 1.0).clamp(-1.0, 1.0);
    let c = (srgb_encode(s.abs()) * 255.0 + 0.5) as u8;
    if s >= 0.0 { [0, c, 0] } else { [c, 0, 0] }
}

/// The robust scale of signed differences: the 99th percentile (nearest rank) of the finite
/// |d|; the largest |d| when that is 0, and 1 when every difference is 0 (or none is finite).
pub fn robust_max(d: &[f64]) -> f64 {
    let mut a: Vec<f64> = d
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    if a.is_empty() {
        return 1.0;
    }
    a.sort_by(f64::total_cmp);
    let rank = ((a.len() as f64 * 0.99).ceil() as usize).clamp(1, a.len());
    let m = a[rank - 1];
    let top = a[a.len() - 1];
    if m > 0.0 {
        m
    } else if top > 0.0 {
        top
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diverging_map_is_green_above_red_below_black_at_zero() {
        let g = diverging_colour(0.5, 1.0);
        assert!(g[1] > 150 && g[0] == 0 && g[2] == 0, "{g:?}");
        let r = diverging_colour(-0.5, 1.0);
        assert!(r[0] > 150 && r[1] == 0 && r[2] == 0, "{r:?}");
        assert_eq!(diverging_colour(0.0, 1.0), [0, 0, 0]);
        // Symmetric, saturating beyond the scale.
        assert_eq!(g[1], r[0]);
        assert_eq!(diverging_colour(7.0, 1.0), [0, 255, 0]);
        assert_eq!(diverging_colour(-7.0, 1.0), [255, 0, 0]);
        assert_eq!(diverging_colour(f64::NAN, 1.0), NOT_FINITE);
        // The colour bar runs from red through black to green.
        assert_eq!(diverging(0.0), [255, 0, 0]);
        assert_eq!(diverging(0.5), [0, 0, 0]);
        assert_eq!(diverging(1.0), [0, 255, 0]);
    }

    #[test]
    fn robust_max_is_the_99th_percentile_of_the_magnitudes() {
        // 1..=100 with signs alternating: the 99th of 100 ranks is 99.
        let d: Vec<f64> = (1..=100)
            .map(|i| if i % 2 == 0 { i as f64 } else { -(i as f64) })
            .collect();
        assert_eq!(robust_max(&d), 99.0);
        let mut sparse = vec![0.0; 1000];
        sparse[3] = -2.0;
        assert_eq!(robust_max(&sparse), 2.0);
        assert_eq!(robust_max(&[0.0, f64::NAN]), 1.0);
    }

    #[test]
    fn error_map_spans_three_decades() {
        let r = Vec3::splat(1.0);
        assert_eq!(error_colour(r, r), ramp(0.0));
        assert_eq!(error_colour(Vec3::splat(10.0), r), ramp(1.0));
        assert_eq!(error_colour(Vec3::splat(f32::NAN), r), NOT_FINITE);
        let b = error_bar(false);
        assert_eq!(b.ticks.first().unwrap().0, 0.0);
        assert_eq!(b.ticks.last().unwrap().0, 1.0);
    }
}
