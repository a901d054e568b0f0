//! The JSON file of a fitted model (`stokes gmm fit -o OUT`; docs/gmm.md describes it).
//!
//! Units settle the factor of ten between a 10-nm matrix and a per-nm density: the mixture p is
//! a density per nm² over (λi, λo) in nm, and the kernel it stands for, ρ(λi → λo) = S·p per
//! nm of excitation (Hua eq. 3), is the matrix's off-diagonal entry divided by its step
//! (D[o][i] = Δλ·ρ, docs/design.md §2). S is therefore in nm: the matrix's energy
//! ∬ρ = Σ D·Δλ over the mixture's mass on the measured support above the diagonal (eq. 5).

use super::{Component, ConditionalMixture, FitOptions, conditional::MAX_COMPONENTS};
use crate::material::bfc::{BfcMatrix, MAX_BFC_ALBEDO, MAX_BFC_ENTRY, MIN_BFC_STEP, lerp_on_grid};
use crate::spectrum::Domain;
use serde::{Deserialize, Serialize};

/// The format tag of version 1.
pub const FORMAT: &str = "stokes-gmm-1";

/// A fitted reradiation model as stored on disk.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GmmFile {
    /// Always [`FORMAT`].
    pub format: String,
    /// The measured matrix that was fitted.
    pub source: Source,
    /// How it was fitted.
    pub fit: FitInfo,
    /// The source's wavelength grid: the measured support is the grid's cells (±step/2).
    pub grid: Grid,
    /// The measured reflectance (the matrix's diagonal), one value per emission row.
    pub reflectance: Vec<f32>,
    /// S of Hua eq. 3, nm: ρ(λi → λo) = S·p(λi, λo).
    pub scale: f64,
    /// The mixture p over (λi, λo); empty for a matrix without fluorescence.
    pub components: Vec<Component>,
}

/// Where a model came from.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Source {
    /// The BFC file's name as given to the fit.
    pub file: String,
    /// SHA-256 of the BFC file's bytes, hex.
    pub sha256: String,
}

/// The settings and outcome of a fit.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FitInfo {
    pub options: FitOptions,
    pub iterations: usize,
    /// Mean log-likelihood per unit weight (EM) or lower bound (Bayes) at the end.
    pub log_likelihood: f64,
    pub converged: bool,
    /// Which of the `options.restarts` starts was kept (0: the one from `options.seed`; omitted
    /// when 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub restart: usize,
    /// With `options.auto_components` and EM: the BIC of K = 1, 2, … (`select`), the smallest
    /// chosen; omitted otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bic: Vec<f64>,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// A BFC grid: emission rows from `em_lo`, excitation columns from `ex_lo`, one step.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    pub em_lo: f32,
    pub ex_lo: f32,
    pub step: f32,
    pub n_em: usize,
    pub n_ex: usize,
}

/// Largest grid dimension accepted from a file.
pub const MAX_GRID: usize = 1000;

/// Largest wavelength of a model's grid and means, nm (as for a BFC header).
const MAX_NM: f64 = 1e5;

/// Largest `scale` S, nm. S = ∬ρ / (the mixture's mass on the support): the RIT fits reach
/// about 1.8e3 nm (IXCAXORA); the albedo check below is the physical bound.
pub const MAX_SCALE: f64 = 1e6;

/// Largest variance of a component along any direction, nm² (a standard deviation of 1e5 nm).
const MAX_VARIANCE: f64 = 1e10;

impl Grid {
    pub fn of(m: &BfcMatrix) -> Grid {
        Grid {
            em_lo: m.em_lo,
            ex_lo: m.ex_lo,
            step: m.step,
            n_em: m.n_em,
            n_ex: m.n_ex,
        }
    }
    /// The measured support of λi: the excitation cells.
    pub fn ex_support(&self) -> (f64, f64) {
        let h = 0.5 * self.step as f64;
        let lo = self.ex_lo as f64;
        (lo - h, lo + (self.n_ex as f64 - 1.0) * self.step as f64 + h)
    }
    /// The measured support of λo: the emission cells.
    pub fn em_support(&self) -> (f64, f64) {
        let h = 0.5 * self.step as f64;
        let lo = self.em_lo as f64;
        (lo - h, lo + (self.n_em as f64 - 1.0) * self.step as f64 + h)
    }
    fn check(&self) -> Result<(), String> {
        let ok = |x: f32| x.is_finite() && (0.0..=MAX_NM as f32).contains(&x);
        if !ok(self.em_lo) || !ok(self.ex_lo) {
            return Err(format!(
                "grid: em_lo and ex_lo must be wavelengths in [0, {MAX_NM:e}] nm"
            ));
        }
        if !(self.step.is_finite() && self.step >= MIN_BFC_STEP && self.step <= 1e3) {
            return Err(format!(
                "grid.step: {} is not in [{MIN_BFC_STEP}, 1000] nm",
                self.step
            ));
        }
        for (n, name) in [(self.n_em, "n_em"), (self.n_ex, "n_ex")] {
            if n == 0 || n > MAX_GRID {
                return Err(format!("grid.{name}: {n} is not in 1..={MAX_GRID}"));
            }
        }
        let hi = self.em_support().1.max(self.ex_support().1);
        if hi > MAX_NM {
            return Err(format!(
                "grid.step: the grid reaches {hi} nm, beyond {MAX_NM:e} nm"
            ));
        }
        Ok(())
    }
}

impl GmmFile {
    /// Parse and validate a model file; errors name the field and what is wrong.
    pub fn parse(text: &str) -> Result<GmmFile, String> {
        let f: GmmFile = crate::io::json::read_document(text, "{").map_err(|(path, m)| {
            if path.is_empty() {
                m
            } else {
                format!("{path}: {m}")
            }
        })?;
        f.check()?;
        Ok(f)
    }

    fn check(&self) -> Result<(), String> {
        if self.format != FORMAT {
            return Err(format!(
                "format: '{}' is not '{FORMAT}' (not a stokes GMM file, or a newer version)",
                self.format
            ));
        }
        self.grid.check()?;
        if self.reflectance.len() != self.grid.n_em {
            return Err(format!(
                "reflectance: {} values, but grid.n_em is {}",
                self.reflectance.len(),
                self.grid.n_em
            ));
        }
        if let Some(i) = self
            .reflectance
            .iter()
            .position(|r| !(r.is_finite() && (0.0..=MAX_BFC_ENTRY).contains(r)))
        {
            let r = self.reflectance[i];
            let r = if r.abs() < 1e6 {
                r.to_string()
            } else {
                format!("{r:e}")
            };
            return Err(format!(
                "reflectance[{i}]: {r} is not a number in [0, {MAX_BFC_ENTRY}] (a measured \
                 reflectance is about 1 at most)"
            ));
        }
        if !(self.scale.is_finite() && (0.0..=MAX_SCALE).contains(&self.scale)) {
            return Err(format!(
                "scale: {} is not a number in [0, {MAX_SCALE:e}] nm",
                self.scale
            ));
        }
        self.check_components()?;
        self.check_albedo()
    }

    /// At most [`MAX_COMPONENTS`], each valid, with a weight in [0, 1], a mean inside the
    /// wavelength range and a covariance whose variances lie between the cell covariance
    /// step²/12 that every fit adds and [`MAX_VARIANCE`]; the weights sum to 1.
    fn check_components(&self) -> Result<(), String> {
        if self.components.len() > MAX_COMPONENTS {
            return Err(format!(
                "components: {} components, at most {MAX_COMPONENTS} are supported",
                self.components.len()
            ));
        }
        if let Some(k) = self.components.iter().position(|c| !c.is_valid()) {
            return Err(format!(
                "components[{k}]: the weight must be finite and non-negative, the mean finite and \
                 the covariance symmetric positive definite (found {:?})",
                self.components[k]
            ));
        }
        let floor = self.grid.step as f64 * self.grid.step as f64 / 12.0 * (1.0 - 1e-3);
        for (k, c) in self.components.iter().enumerate() {
            if c.weight > 1.0 {
                return Err(format!(
                    "components[{k}].weight: {} is not in [0, 1]",
                    c.weight
                ));
            }
            if let Some(m) = c.mean.iter().find(|m| !(0.0..=MAX_NM).contains(*m)) {
                return Err(format!(
                    "components[{k}].mean: {m} nm is not a wavelength in [0, {MAX_NM:e}] nm"
                ));
            }
            // Eigenvalues of the symmetric 2×2 covariance.
            let [[a, b], [_, d]] = c.cov;
            let (mid, r) = (0.5 * (a + d), (0.25 * (a - d) * (a - d) + b * b).sqrt());
            let (lo, hi) = (mid - r, mid + r);
            if !(lo >= floor && hi <= MAX_VARIANCE) {
                return Err(format!(
                    "components[{k}].cov: variances from {lo} to {hi} nm², outside \
                     [step²/12 = {floor:.4}, {MAX_VARIANCE:e}] (every fit adds the covariance of \
                     a grid cell)"
                ));
            }
        }
        let w: f64 = self.components.iter().map(|c| c.weight).sum();
        if !self.components.is_empty() && (w - 1.0).abs() > 1e-6 {
            return Err(format!("components: the weights sum to {w}, not 1"));
        }
        Ok(())
    }

    /// The model's albedo at each excitation wavelength, reflectance plus ∫ρ dλo (sampled at a
    /// quarter of the grid step), is at most [`MAX_BFC_ALBEDO`], as for a BFC column.
    fn check_albedo(&self) -> Result<(), String> {
        let g = self.grid;
        let (a, b) = g.ex_support();
        let cond = ConditionalMixture::new(&self.components, self.scale, (a, b), g.em_support());
        let r = &self.reflectance;
        let n = 4 * g.n_ex;
        for j in 0..=n {
            let li = a + (b - a) * j as f64 / n as f64;
            let refl = lerp_on_grid(g.em_lo, g.step, r.len(), |k| r[k], li as f32) as f64;
            let fl = cond.total(li, 0);
            if !(refl + fl <= MAX_BFC_ALBEDO as f64) {
                return Err(format!(
                    "scale: the model reflects and reradiates {:.4} (reflectance {refl:.4} + \
                     reradiation {fl:.4}) of the light at excitation {li:.1} nm, above \
                     {MAX_BFC_ALBEDO}: scale or components are out of range",
                    refl + fl
                ));
            }
        }
        Ok(())
    }

    /// The file's text (pretty JSON).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a GMM file serialises")
    }

    /// The conditional mixtures of this model, restricted to the measured support and `domain`.
    pub fn conditional(&self, domain: Domain) -> ConditionalMixture {
        let clip = |(a, b): (f64, f64)| (a.max(domain.min as f64), b.min(domain.max as f64));
        ConditionalMixture::new(
            &self.components,
            self.scale,
            clip(self.grid.ex_support()),
            clip(self.grid.em_support()),
        )
    }

    /// The matrix this model evaluates to on its source's grid: the stored reflectance on the
    /// diagonal, Δλ · S · p(λi, λo) at every cell centre with λo > λi, zero elsewhere (Hua
    /// §7.3).
    pub fn to_matrix(&self) -> BfcMatrix {
        self.to_matrix_at(self.grid.step)
            .expect("the source grid has at most MAX_GRID cells per axis")
    }

    /// The same on a grid of cells of side `step` nm covering the measured support, with the
    /// reflectance interpolated linearly onto its diagonal: `step` = 1 gives the dense matrix
    /// that renders like the mixture itself, up to the cells that straddle the diagonal.
    pub fn to_matrix_at(&self, step: f32) -> Result<BfcMatrix, String> {
        let g = self.grid;
        let cells = |(a, b): (f64, f64)| -> Result<usize, String> {
            let n = (b - a) / step as f64;
            if !(step.is_finite() && step > 0.0) || (n - n.round()).abs() > 1e-6 {
                return Err(format!(
                    "step: {step} nm does not divide the measured support [{a}, {b}] nm"
                ));
            }
            let n = n.round() as usize;
            if n == 0 || n > MAX_GRID {
                return Err(format!(
                    "step: {step} nm gives {n} cells, at most {MAX_GRID}"
                ));
            }
            Ok(n)
        };
        let (n_em, n_ex) = (cells(g.em_support())?, cells(g.ex_support())?);
        let mut m = BfcMatrix {
            em_lo: (g.em_support().0 + 0.5 * step as f64) as f32,
            ex_lo: (g.ex_support().0 + 0.5 * step as f64) as f32,
            step,
            n_em,
            n_ex,
            d: vec![0.0; n_em * n_ex],
        };
        let cond =
            ConditionalMixture::new(&self.components, self.scale, g.ex_support(), g.em_support());
        let r = &self.reflectance;
        for o in 0..n_em {
            for i in 0..n_ex {
                let (lo, li) = (m.em(o), m.ex(i));
                m.d[o * n_ex + i] = if m.is_diagonal(o, i) {
                    lerp_on_grid(g.em_lo, g.step, r.len(), |k| r[k], lo)
                } else {
                    (step as f64 * cond.kernel(li as f64, lo as f64)) as f32
                };
            }
        }
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::mixture::{FitMethod, fit_matrix};

    fn model() -> GmmFile {
        let m = BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap();
        let mut f = fit_matrix(&m, &FitOptions::new(3, FitMethod::Em, 0)).unwrap();
        f.source.file = "GOLFYE.BFC".into();
        f
    }

    /// The source grid gives back the stored reflectance; a 1 nm grid keeps the model's energy
    /// up to the half cells along the diagonal.
    #[test]
    fn dense_matrices_of_a_model() {
        let f = model();
        let m = f.to_matrix();
        assert_eq!((m.n_em, m.n_ex, m.em_lo, m.ex_lo), (41, 49, 380.0, 300.0));
        assert!((0..41).all(|o| m.reflectance(o) == f.reflectance[o]));
        let fine = f.to_matrix_at(1.0).unwrap();
        assert_eq!((fine.n_em, fine.n_ex, fine.em_lo), (410, 490, 375.5));
        let energy = |m: &BfcMatrix| -> f64 {
            let mut s = 0.0;
            for o in 0..m.n_em {
                for i in 0..m.n_ex {
                    s += m.off(o, i) as f64 * m.step as f64;
                }
            }
            s
        };
        let g = f.grid;
        let want = f.scale
            * ConditionalMixture::new(&f.components, 1.0, g.ex_support(), g.em_support()).mass();
        let e = energy(&fine);
        eprintln!("1 nm matrix: {e} vs the model's {want}");
        assert!((e / want - 1.0).abs() < 5e-3, "{e} vs {want}");
        assert!(f.to_matrix_at(3.0).unwrap_err().contains("step"));
        assert!(f.to_matrix_at(0.125).unwrap_err().contains("at most"));
    }

    #[test]
    fn round_trips_through_json() {
        let f = model();
        assert_eq!(GmmFile::parse(&f.to_json()).unwrap(), f);
    }

    /// The fields added with restarts, automatic K and the error scale: a file without them
    /// (as written before they existed) reads as one start, the integral ratio and a fixed K;
    /// with them it round-trips; a bad value names its field.
    #[test]
    fn files_without_the_newer_options_read_as_before() {
        let mut f = model();
        f.fit.options.restarts = 5;
        f.fit.options.scale_method = crate::material::mixture::ScaleMethod::Error;
        f.fit.options.auto_components = true;
        f.fit.restart = 3;
        f.fit.bic = vec![10.0, 9.0, 9.5];
        assert_eq!(GmmFile::parse(&f.to_json()).unwrap(), f);
        let mut v: serde_json::Value = serde_json::from_str(&f.to_json()).unwrap();
        for k in ["restarts", "scale_method", "auto_components"] {
            v["fit"]["options"].as_object_mut().unwrap().remove(k);
        }
        for k in ["restart", "bic"] {
            v["fit"].as_object_mut().unwrap().remove(k);
        }
        let old = GmmFile::parse(&v.to_string()).unwrap();
        let o = old.fit.options;
        assert_eq!((o.restarts, o.auto_components), (1, false));
        assert_eq!(
            o.scale_method,
            crate::material::mixture::ScaleMethod::Integral
        );
        assert_eq!((old.fit.restart, old.fit.bic.len()), (0, 0));
        v["fit"]["options"]["scale_method"] = "l1".into();
        let e = GmmFile::parse(&v.to_string()).unwrap_err();
        assert!(e.contains("fit.options.scale_method"), "{e}");
    }

    /// Every malformed model names its field.
    #[test]
    fn malformed_files_name_the_field() {
        let f = model();
        let v: serde_json::Value = serde_json::from_str(&f.to_json()).unwrap();
        let edit = |path: &[&str], x: serde_json::Value| {
            let mut v = v.clone();
            let mut p = &mut v;
            for k in &path[..path.len() - 1] {
                p = match k.parse::<usize>() {
                    Ok(i) => &mut p[i],
                    Err(_) => &mut p[*k],
                };
            }
            let last = path[path.len() - 1];
            match last.parse::<usize>() {
                Ok(i) => p[i] = x,
                Err(_) => p[last] = x,
            }
            GmmFile::parse(&v.to_string()).unwrap_err()
        };
        use serde_json::json;
        let cases = [
            (edit(&["format"], json!("other")), "format"),
            (edit(&["scale"], json!(-1.0)), "scale"),
            (edit(&["scale"], json!("x")), "scale"),
            (
                edit(&["grid", "n_em"], json!(1_000_000_000u64)),
                "grid.n_em",
            ),
            (edit(&["grid", "step"], json!(0.0)), "grid.step"),
            (edit(&["reflectance", "3"], json!(-0.5)), "reflectance[3]"),
            (
                edit(&["components", "0", "weight"], json!(-0.1)),
                "components[0]",
            ),
            (
                edit(&["components", "1", "cov", "0", "1"], json!(1e6)),
                "components[1]",
            ),
            (
                edit(&["components", "0", "mean", "0"], json!(null)),
                "components[0].mean[0]",
            ),
            (
                edit(&["components", "0", "weight"], json!(0.9)),
                "components",
            ),
        ];
        for (e, field) in cases {
            assert!(e.contains(field), "{field}: {e}");
        }
        let mut g = f.clone();
        g.reflectance.pop();
        assert!(
            GmmFile::parse(&g.to_json())
                .unwrap_err()
                .contains("reflectance")
        );
        assert!(GmmFile::parse("{").is_err());
        assert!(GmmFile::parse("").is_err());
    }
}
