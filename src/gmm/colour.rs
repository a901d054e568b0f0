//! The colour of a reradiation matrix under each light, and ΔE00 between measured and fitted.
//!
//! **Colour of a matrix.** Hua eq. 15 on the matrix grid: XYZ = Σ_o CMF(λo) · Σ_i D[o][i] · L(λi),
//! with the diagonal of D the reflectance and an off-diagonal entry the kernel × Δλ, L sampled at
//! the excitation wavelengths (300–780 nm for the RIT files) and the emission rows at 380–780 nm.
//! The sums carry no Δλ and no ∫ȳ normalisation; the white below is summed the same way, so both
//! cancel in L*a*b*.
//!
//! **CIE illuminants** (every `*.csv` of the illuminant folder, "λ, value" rows): the table is
//! interpolated linearly onto the grid and is zero outside its range (so the ISO 7589 tables,
//! which end at 560 or 690 nm, light nothing above). The white is the illuminant itself as seen
//! by a perfect reflector: Σ_o L(λo)·CMF(λo) over the emission grid, so a non-fluorescent white
//! is L*a*b* = (100, 0, 0) under every illuminant (Hua: "divided by the Y value of the used
//! illuminant").
//!
//! **Monochromatic light** at each excitation wavelength (unit power in that one column). There
//! is no natural white for a single line, and using the line itself would turn every colour's
//! hue into noise near the ends of the visible range. The white is the equal-energy white
//! normalised to Y = 1: (Σx̄, Σȳ, Σz̄) / Σȳ over the emission grid. A perfect reflector under the
//! line at λ then has Y = ȳ(λ): L* = 99.8 at 550 and 560 nm (ȳ = 0.995), and light that lands
//! outside the eye's range (UV) is dark. Large ΔE00 at the UV end, where both colours are nearly
//! black, is what Hua Fig. 7a shows too.

use super::inputs::Illuminant;
use crate::material::reradiation::BfcMatrix;
use crate::spectrum::colorimetry::{
    bispectral_xyz, bispectral_xyz_mono, cmf_at, delta_e00, spectrum_xyz, xyz_to_lab,
};
use serde::Serialize;

/// The kind of light a comparison was made under.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightKind {
    /// A CIE standard illuminant.
    Cie,
    /// Unit power at one excitation wavelength.
    Mono,
}

impl LightKind {
    pub fn name(self) -> &'static str {
        match self {
            LightKind::Cie => "cie",
            LightKind::Mono => "mono",
        }
    }
}

/// One colour comparison of a measured and a fitted matrix under one light.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// The illuminant's name, or `mono-<nm>`.
    pub light: String,
    pub kind: LightKind,
    pub lab_measured: [f64; 3],
    pub lab_fitted: [f64; 3],
    pub de00: f64,
}

/// The colour of one matrix under one light: XYZ (Hua eq. 15 on the grid) and the white it is
/// seen against (see the module notes).
#[derive(Clone, Debug, PartialEq)]
pub struct LightColour {
    /// The illuminant's name, or `mono-<nm>`.
    pub light: String,
    pub kind: LightKind,
    pub white: [f64; 3],
    pub xyz: [f64; 3],
}

impl LightColour {
    /// L*a*b* relative to the light's white.
    pub fn lab(&self) -> [f64; 3] {
        xyz_to_lab(self.xyz, self.white)
    }
}

/// The colours of `m` under every illuminant, then under unit monochromatic light in each
/// excitation column, in that order.
pub fn colours(m: &BfcMatrix, illuminants: &[Illuminant]) -> Result<Vec<LightColour>, String> {
    let em_wl: Vec<f32> = (0..m.n_em).map(|o| m.em(o)).collect();
    let ex_wl: Vec<f32> = (0..m.n_ex).map(|i| m.ex(i)).collect();
    let em_cmf = cmf_at(&em_wl);
    let mut out = Vec::with_capacity(illuminants.len() + ex_wl.len());
    for il in illuminants {
        let on_ex: Vec<f64> = ex_wl.iter().map(|&l| il.spectrum.eval(l) as f64).collect();
        let on_em: Vec<f64> = em_wl.iter().map(|&l| il.spectrum.eval(l) as f64).collect();
        let white = spectrum_xyz(&em_wl, &on_em);
        if !(white[1] > 0.0) {
            return Err(format!(
                "illuminant {} has no visible light on the emission grid",
                il.name
            ));
        }
        out.push(LightColour {
            light: il.name.clone(),
            kind: LightKind::Cie,
            white,
            xyz: bispectral_xyz(&m.d, &em_cmf, &on_ex),
        });
    }
    let ee = spectrum_xyz(&em_wl, &vec![1.0; em_wl.len()]);
    let mono_white = ee.map(|c| c / ee[1]);
    for (i, &l) in ex_wl.iter().enumerate() {
        out.push(LightColour {
            light: format!("mono-{l:.0}"),
            kind: LightKind::Mono,
            white: mono_white,
            xyz: bispectral_xyz_mono(&m.d, &em_cmf, m.n_ex, i),
        });
    }
    Ok(out)
}

/// The grid of a matrix, (em_lo, ex_lo, step, n_em, n_ex).
fn grid(m: &BfcMatrix) -> (f32, f32, f32, usize, usize) {
    (m.em_lo, m.ex_lo, m.step, m.n_em, m.n_ex)
}

/// That `fitted` is on the grid of `measured`.
pub fn check_grid(measured: &BfcMatrix, fitted: &BfcMatrix) -> Result<(), String> {
    if grid(measured) != grid(fitted) || fitted.d.len() != measured.d.len() {
        return Err(format!(
            "the fitted matrix's grid (em_lo, ex_lo, step, n_em, n_ex) = {:?} differs from the measured {:?}",
            grid(fitted),
            grid(measured)
        ));
    }
    Ok(())
}

/// Compare the colours of `measured` and `fitted` (same grid) under every illuminant and under
/// unit monochromatic light in each excitation column (see the module notes for the whites).
pub fn compare(
    measured: &BfcMatrix,
    fitted: &BfcMatrix,
    illuminants: &[Illuminant],
) -> Result<Vec<Comparison>, String> {
    check_grid(measured, fitted)?;
    compare_colours(
        &colours(measured, illuminants)?,
        &colours(fitted, illuminants)?,
    )
}

/// ΔE00 between two lists of [`colours`] of matrices on the same grid under the same lights.
pub fn compare_colours(
    measured: &[LightColour],
    fitted: &[LightColour],
) -> Result<Vec<Comparison>, String> {
    if measured.len() != fitted.len() {
        return Err(format!(
            "{} colours against {} (not the same lights)",
            measured.len(),
            fitted.len()
        ));
    }
    let mut out = Vec::with_capacity(measured.len());
    for (m, f) in measured.iter().zip(fitted) {
        if m.light != f.light {
            return Err(format!(
                "the lights differ: {} against {}",
                m.light, f.light
            ));
        }
        let (lm, lf) = (m.lab(), xyz_to_lab(f.xyz, m.white));
        let c = Comparison {
            light: m.light.clone(),
            kind: m.kind,
            lab_measured: lm,
            lab_fitted: lf,
            de00: delta_e00(lm, lf),
        };
        if !c.de00.is_finite() {
            return Err(format!(
                "ΔE00 under {} is not finite (fitted L*a*b* {:?})",
                c.light, c.lab_fitted
            ));
        }
        out.push(c);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gmm::inputs::{embedded_illuminants, load_illuminants};
    use std::path::PathBuf;

    fn root() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }

    fn matrix(file: &str) -> BfcMatrix {
        BfcMatrix::parse(&std::fs::read_to_string(root().join(file)).unwrap()).unwrap()
    }

    fn illuminants() -> Vec<Illuminant> {
        let from_folder = load_illuminants(&root().join("data/spectra/illuminants")).unwrap();
        let embedded = embedded_illuminants().unwrap();
        assert_eq!(from_folder.len(), embedded.len());
        for (a, b) in from_folder.iter().zip(&embedded) {
            assert_eq!(a.name, b.name);
        }
        embedded
    }

    #[test]
    fn a_matrix_compared_with_itself_has_no_difference() {
        let il = illuminants();
        assert_eq!(il.len(), 59);
        let m = matrix("data/bispectral/GOLFORA.BFC");
        let cs = compare(&m, &m, &il).unwrap();
        assert_eq!(cs.len(), 59 + m.n_ex);
        for c in &cs {
            assert_eq!(c.de00, 0.0, "{}", c.light);
            assert_eq!(c.lab_measured, c.lab_fitted);
        }
        assert_eq!(cs.iter().filter(|c| c.kind == LightKind::Mono).count(), 49);
        assert_eq!(cs[59].light, "mono-300");
        assert_eq!(cs.last().unwrap().light, "mono-780");
    }

    #[test]
    fn the_whites_follow_the_documented_conventions() {
        // A perfect reflector (diagonal 1) on the RIT grid.
        let m = matrix("data/bispectral/GOLFORA.BFC");
        let mut white = m.clone();
        white.d.fill(0.0);
        for o in 0..m.n_em {
            let i = ((m.em(o) - m.ex_lo) / m.step).round() as usize;
            white.d[o * m.n_ex + i] = 1.0;
        }
        let cs = compare(&white, &white, &illuminants()).unwrap();
        for c in cs.iter().filter(|c| c.kind == LightKind::Cie) {
            let l = c.lab_measured;
            assert!(
                (l[0] - 100.0).abs() < 1e-9 && l[1].abs() < 1e-9 && l[2].abs() < 1e-9,
                "{}: {l:?}",
                c.light
            );
        }
        // Monochromatic at 550 nm: Y = ȳ(550) relative to the equal-energy white with Y = 1.
        let c550 = cs.iter().find(|c| c.light == "mono-550").unwrap();
        let y = crate::spectrum::cie::cmf(550.0).y as f64;
        assert!((c550.lab_measured[0] - (116.0 * y.cbrt() - 16.0)).abs() < 1e-9);
        assert!(
            (c550.lab_measured[0] - 99.8).abs() < 0.1,
            "{:?}",
            c550.lab_measured
        );
        // No reflectance below 380 nm: black.
        let c300 = cs.iter().find(|c| c.light == "mono-300").unwrap();
        assert!(
            c300.lab_measured.iter().all(|x| x.abs() < 1e-12),
            "{c300:?}"
        );
    }

    #[test]
    fn removing_fluorescence_changes_only_the_fluorescent_columns() {
        let m = matrix("data/bispectral/GOLFORA.BFC");
        let mut plain = m.clone();
        for o in 0..m.n_em {
            for i in 0..m.n_ex {
                if !m.is_diagonal(o, i) {
                    plain.d[o * m.n_ex + i] = 0.0;
                }
            }
        }
        let cs = compare(&m, &plain, &illuminants()).unwrap();
        let mut fluorescent_columns = 0;
        for (i, c) in cs.iter().filter(|c| c.kind == LightKind::Mono).enumerate() {
            let shifts = (0..m.n_em).any(|o| m.off(o, i) > 0.0);
            fluorescent_columns += shifts as usize;
            assert_eq!(c.de00 > 0.0, shifts, "{}: ΔE00 {}", c.light, c.de00);
        }
        assert!(fluorescent_columns > 5);
        // A fluorescent orange loses a visible amount of colour under daylight.
        let d65 = cs.iter().find(|c| c.light == "D65").unwrap();
        assert!(d65.de00 > 1.0, "{d65:?}");
    }
}
