//! Colour science for comparing spectra and bispectral matrices: CIE 1976 L*a*b*, the CIEDE2000
//! colour difference and the XYZ of light reradiated by a bispectral matrix (Hua eq. 15 on the
//! matrix grid).
//!
//! The XYZ sums here are plain sums over the grid, without the step Δλ and without normalising
//! by ∫ȳ: they are only meant to be divided by a white computed the same way (L*a*b* is relative
//! to its white), so both factors cancel.

use super::cie::cmf;
use palette::color_difference::Ciede2000;
use palette::{Lab, white_point::D65};

/// ε = (6/29)³ = 216/24389: the CIE 1976 threshold between the cube root and the linear branch.
pub const LAB_EPSILON: f64 = 216.0 / 24389.0;
/// κ = (29/3)³ = 24389/27: the slope of the linear branch of L* (L* = κ·Y/Yn below ε).
pub const LAB_KAPPA: f64 = 24389.0 / 27.0;

/// f(t) of CIE 1976: t^(1/3) above ε, (κ t + 16) / 116 below (the exact ε, κ form, continuous
/// in value and slope at ε).
#[inline]
fn lab_f(t: f64) -> f64 {
    if t > LAB_EPSILON {
        t.cbrt()
    } else {
        (LAB_KAPPA * t + 16.0) / 116.0
    }
}

/// CIE 1976 L*a*b* of `xyz` relative to the reference white `white` (both in the same units;
/// the white's Y maps to L* = 100).
pub fn xyz_to_lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let fx = lab_f(xyz[0] / white[0]);
    let fy = lab_f(xyz[1] / white[1]);
    let fz = lab_f(xyz[2] / white[2]);
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIEDE2000 colour difference ΔE00 (kL = kC = kH = 1) between two L*a*b* colours, by the
/// `palette` crate's `Ciede2000` (not its "improved" power-law variant). The white point type
/// is a formality: the formula works on L*a*b* values alone.
pub fn delta_e00(lab1: [f64; 3], lab2: [f64; 3]) -> f64 {
    let a = Lab::<D65, f64>::new(lab1[0], lab1[1], lab1[2]);
    let b = Lab::<D65, f64>::new(lab2[0], lab2[1], lab2[2]);
    a.difference(b)
}

/// The colour-matching functions (x̄, ȳ, z̄) at each wavelength, in f64.
pub fn cmf_at(wavelengths: &[f32]) -> Vec<[f64; 3]> {
    wavelengths
        .iter()
        .map(|&l| {
            let c = cmf(l);
            [c.x as f64, c.y as f64, c.z as f64]
        })
        .collect()
}

/// XYZ = Σ_k L(λk)·(x̄, ȳ, z̄)(λk) of a spectrum sampled at `wavelengths` (a plain sum: see the
/// module notes).
pub fn spectrum_xyz(wavelengths: &[f32], values: &[f64]) -> [f64; 3] {
    assert_eq!(wavelengths.len(), values.len(), "one value per wavelength");
    let mut xyz = [0.0; 3];
    for (c, &v) in cmf_at(wavelengths).iter().zip(values) {
        for k in 0..3 {
            xyz[k] += c[k] * v;
        }
    }
    xyz
}

/// XYZ of the light a bispectral matrix sends out under the light `light`:
/// XYZ = Σ_o CMF(λo) · Σ_i D[o][i] · L(λi) (Hua eq. 15 on the grid).
///
/// `d` is row-major [emission o][excitation i] with `light.len()` columns and one row per entry
/// of `em_cmf` (the colour-matching functions at the emission wavelengths, from [`cmf_at`]);
/// `light` is sampled at the excitation wavelengths. The diagonal entries are reflectances and the
/// off-diagonal ones kernel × Δλ, so no further step factor enters.
pub fn bispectral_xyz(d: &[f32], em_cmf: &[[f64; 3]], light: &[f64]) -> [f64; 3] {
    let n_ex = light.len();
    assert_eq!(
        d.len(),
        em_cmf.len() * n_ex,
        "matrix is n_em × n_ex = {} × {n_ex}",
        em_cmf.len()
    );
    let mut xyz = [0.0; 3];
    for (row, c) in d.chunks_exact(n_ex).zip(em_cmf) {
        let out: f64 = row.iter().zip(light).map(|(&x, &l)| x as f64 * l).sum();
        for k in 0..3 {
            xyz[k] += c[k] * out;
        }
    }
    xyz
}

/// XYZ of a bispectral matrix under unit light in excitation column `i` alone:
/// Σ_o CMF(λo) · D[o][i]. Same layout as [`bispectral_xyz`].
pub fn bispectral_xyz_mono(d: &[f32], em_cmf: &[[f64; 3]], n_ex: usize, i: usize) -> [f64; 3] {
    assert!(i < n_ex && d.len() == em_cmf.len() * n_ex);
    let mut xyz = [0.0; 3];
    for (o, c) in em_cmf.iter().enumerate() {
        let x = d[o * n_ex + i] as f64;
        for k in 0..3 {
            xyz[k] += c[k] * x;
        }
    }
    xyz
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHARMA: &str = include_str!("../../data/colour/ciede2000_sharma2005.csv");

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn ciede2000_matches_sharma_2005() {
        let mut n = 0;
        for line in SHARMA.lines() {
            let l = line.trim();
            if l.is_empty() || l.starts_with('#') || l.starts_with("L1") {
                continue;
            }
            let v: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            assert_eq!(v.len(), 7, "{l}");
            let (p, q) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
            let e = delta_e00(p, q);
            assert!((e - v[6]).abs() < 1e-4, "pair {}: {e} vs {}", n + 1, v[6]);
            // Symmetric in its arguments.
            assert!((delta_e00(q, p) - e).abs() < 1e-12, "pair {}", n + 1);
            n += 1;
        }
        assert_eq!(n, 33, "the file holds 33 pairs");
        // Sharma's pair 14, left out of the file: its hue angles differ by 180° in exact
        // arithmetic, where implementations may pick either mean hue; palette gives the
        // published 4.8045.
        let e14 = delta_e00([50.0, -0.001, 2.49], [50.0, 0.001, -2.49]);
        assert!((e14 - 4.8045).abs() < 1e-4, "pair 14: {e14}");
    }

    #[test]
    fn ciede2000_of_identical_colours_is_zero() {
        for c in [[50.0, 2.5, 0.0], [0.0, 0.0, 0.0], [100.0, -30.0, 60.0]] {
            assert_eq!(delta_e00(c, c), 0.0);
        }
    }

    #[test]
    fn lab_of_the_white_is_100_0_0() {
        let w = [0.95047, 1.0, 1.08883];
        let lab = xyz_to_lab(w, w);
        assert!(close(lab, [100.0, 0.0, 0.0], 1e-12), "{lab:?}");
        // Any scale of the white.
        let w2 = w.map(|x| x * 37.5);
        assert!(close(xyz_to_lab(w2, w2), [100.0, 0.0, 0.0], 1e-12));
    }

    #[test]
    fn lab_of_srgb_red_under_d65() {
        let lab = xyz_to_lab([0.412456, 0.212673, 0.019334], [0.95047, 1.0, 1.08883]);
        assert!(close(lab, [53.2408, 80.0925, 67.2032], 1e-3), "{lab:?}");
    }

    #[test]
    fn lab_of_a_dark_colour_uses_the_linear_branch() {
        // Every ratio below ε = 0.008856, so f(t) = (κ t + 16) / 116 with κ = 903.296296…:
        //   X/Xn = 0.004: fx = (3.613185… + 16)/116 = 0.169079…
        //   Y/Yn = 0.005: fy = (4.516481… + 16)/116 = 0.176866…, L* = κ·0.005 = 4.516481…
        //   Z/Zn = 0.002: fz = (1.806592… + 16)/116 = 0.153505…
        //   a* = 500 (fx − fy) = −3.893518…, b* = 200 (fy − fz) = 4.672222…
        let w = [0.95047, 1.0, 1.08883];
        let xyz = [0.004 * w[0], 0.005 * w[1], 0.002 * w[2]];
        let (l, a, b) = (4.516481, -3.893518, 4.672222);
        let lab = xyz_to_lab(xyz, w);
        assert!(close(lab, [l, a, b], 1e-6), "{lab:?} vs {:?}", [l, a, b]);
    }

    #[test]
    fn lab_is_continuous_at_epsilon() {
        let w = [1.0, 1.0, 1.0];
        let lo = xyz_to_lab([LAB_EPSILON * (1.0 - 1e-12); 3], w);
        let hi = xyz_to_lab([LAB_EPSILON * (1.0 + 1e-12); 3], w);
        assert!((lo[0] - 8.0).abs() < 1e-6 && (hi[0] - 8.0).abs() < 1e-6);
    }

    #[test]
    fn a_diagonal_matrix_gives_the_reflected_light() {
        // Emission and excitation on the same 3-point grid, diagonal = reflectance r.
        let wl = [500.0f32, 550.0, 600.0];
        let r = [0.2f32, 0.5, 0.9];
        let mut d = vec![0.0f32; 9];
        for k in 0..3 {
            d[k * 3 + k] = r[k];
        }
        let light = [1.0, 2.0, 3.0];
        let em = cmf_at(&wl);
        let got = bispectral_xyz(&d, &em, &light);
        let reflected: Vec<f64> = (0..3).map(|k| r[k] as f64 * light[k]).collect();
        let want = spectrum_xyz(&wl, &reflected);
        assert!(close(got, want, 1e-12), "{got:?} vs {want:?}");
        // Monochromatic light in column 1 alone: r(550)·CMF(550).
        let m = bispectral_xyz_mono(&d, &em, 3, 1);
        assert!(close(m, em[1].map(|c| c * 0.5), 1e-12));
    }

    #[test]
    fn an_off_diagonal_entry_moves_light_to_its_row() {
        // Excitation at 400 and 450 nm, emission at 500 and 550 nm; D[1][0] shifts 400 → 550.
        let d = [0.0f32, 0.0, 0.3, 0.0];
        let em_wl = [500.0f32, 550.0];
        let em = cmf_at(&em_wl);
        let got = bispectral_xyz(&d, &em, &[2.0, 5.0]);
        assert!(close(got, em[1].map(|c| c * 0.6), 1e-7), "{got:?}");
        assert!(close(bispectral_xyz_mono(&d, &em, 2, 1), [0.0; 3], 0.0));
    }
}
