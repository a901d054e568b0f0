//! Colour accuracy of Gaussian-mixture fits of measured reradiation matrices (Hua et al. 2022
//! §7.2–7.5): every BFC matrix of a folder is fitted with each number of components, and the
//! colour of the measured matrix is compared with the colour of the fitted one by CIEDE2000.
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
//!
//! Outputs (written to a temporary file and renamed): `delta-e00.csv` (one row per material,
//! number of components and light), `summary.json` (per number of components and kind of light:
//! mean, median, 95th percentile and maximum of ΔE00 over all material × light pairs, and the ten
//! materials with the largest mean ΔE00 under the CIE illuminants) and the box plots
//! `boxplot-cie.{svg,png}`, `boxplot-mono.{svg,png}` over the same pairs (Hua Figs. 8b and 7b).

use super::boxplot::{BoxFigure, BoxStats, box_stats, quantile, write_box_figure};
use crate::Error;
use crate::material::mixture::{FitMethod, FitOptions, fit_matrix};
use crate::material::reradiation::BfcMatrix;
use crate::spectrum::Spectrum;
use crate::spectrum::colorimetry::{
    bispectral_xyz, bispectral_xyz_mono, cmf_at, delta_e00, spectrum_xyz, xyz_to_lab,
};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Where the illuminant tables live, relative to the crate root.
/// Where `stokes gmm eval` writes by default.
pub const DEFAULT_OUT: &str = "results/gmm-eval";

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

/// A named illuminant spectrum (piecewise linear, zero outside its table).
#[derive(Clone, Debug)]
pub struct Illuminant {
    pub name: String,
    pub spectrum: Spectrum,
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
}

/// Fit every `*.BFC` matrix of `dir` (sorted by name) with each number of `components` by
/// `method` and compare measured and fitted colours under the illuminants of `illuminants_dir`
/// (the illuminants built into stokes when `None`) and under monochromatic light; write the
/// CSV, the summary and the box plots into `out`.
pub fn evaluate(
    dir: &Path,
    components: &[usize],
    method: FitMethod,
    seed: u64,
    out: &Path,
    illuminants_dir: Option<&Path>,
) -> Result<Summary, Error> {
    let fit = |m: &BfcMatrix, k: usize| -> Result<BfcMatrix, String> {
        Ok(fit_matrix(m, &FitOptions::new(k, method, seed))?.to_matrix())
    };
    let run = Run {
        dir,
        components,
        method,
        seed,
        out,
        illuminants_dir,
    };
    evaluate_with(&run, &fit)
}

/// The inputs of one evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Run<'a> {
    pub dir: &'a Path,
    pub components: &'a [usize],
    /// Recorded in the outputs; the fitting itself is `fit`'s business in [`evaluate_with`].
    pub method: FitMethod,
    pub seed: u64,
    pub out: &'a Path,
    /// A folder of illuminant tables; `None`: the CIE illuminants built into stokes.
    pub illuminants_dir: Option<&'a Path>,
}

/// [`evaluate`] with the fit given as a function from a matrix and a number of components to
/// the fitted matrix on the same grid.
pub fn evaluate_with<F>(run: &Run, fit: &F) -> Result<Summary, Error>
where
    F: Fn(&BfcMatrix, usize) -> Result<BfcMatrix, String> + Sync,
{
    if run.components.is_empty() || run.components.contains(&0) {
        return Err(Error::input(format!(
            "the numbers of components must be at least 1, got {:?}",
            run.components
        )));
    }
    let illuminants = match run.illuminants_dir {
        Some(d) => load_illuminants(d)?,
        None => embedded_illuminants()?,
    };
    let materials = load_matrices(run.dir)?;
    check_output_folder(run.out)?;
    let start = std::time::Instant::now();
    let bar = crate::experiment::progress::bar(materials.len() as u64);
    let per_material: Vec<Vec<Row>> = materials
        .par_iter()
        .map(|(path, name, m)| {
            let mut rows = Vec::new();
            for &k in run.components {
                let fitted = fit(m, k).map_err(|e| {
                    Error::runtime(format!("{}: fitting {k} components: {e}", path.display()))
                })?;
                let cs = compare(m, &fitted, &illuminants).map_err(|e| {
                    Error::runtime(format!("{}: {k} components: {e}", path.display()))
                })?;
                rows.extend(cs.into_iter().map(|c| Row {
                    material: name.clone(),
                    components: k,
                    c,
                }));
            }
            bar.inc(1);
            Ok(rows)
        })
        .collect::<Result<_, Error>>()?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let rows: Vec<Row> = per_material.into_iter().flatten().collect();
    let mut summary = Summary {
        method: run.method,
        seed: run.seed,
        materials: materials.iter().map(|(_, n, _)| n.clone()).collect(),
        illuminants: illuminants.iter().map(|i| i.name.clone()).collect(),
        mono_wavelengths: materials
            .first()
            .map(|(_, _, m)| (0..m.n_ex).map(|i| m.ex(i)).collect())
            .unwrap_or_default(),
        per_components: summarise(&rows, run.components),
        seconds,
        outputs: Vec::new(),
    };
    write_outputs(run, &rows, &mut summary).map_err(Error::runtime)?;
    Ok(summary)
}

/// A bar over the matrices, hidden when stderr is not a terminal (as the experiment runner's).
/// The `*.csv` illuminant tables of `dir`, sorted by file name; a file `illuminant_D65.csv` is
/// named `D65`.
pub fn load_illuminants(dir: &Path) -> Result<Vec<Illuminant>, Error> {
    let mut out = Vec::new();
    for path in files_with_extension(dir, "csv", "illuminant")? {
        let text = crate::io::input::read_text(&path, crate::io::input::SPECTRUM_CSV)
            .map_err(|e| Error::input(format!("cannot read an illuminant: {e}")))?;
        out.push(parse_illuminant(&path, &text)?);
    }
    Ok(out)
}

/// The CIE illuminants built into stokes (`data/spectra/illuminants/`), sorted by file name.
pub fn embedded_illuminants() -> Result<Vec<Illuminant>, Error> {
    crate::spectrum::illuminants::EMBEDDED
        .iter()
        .map(|(name, text)| parse_illuminant(Path::new(name), text))
        .collect()
}

/// One illuminant table (`path` names it in errors and gives its name: the file stem without
/// `illuminant_`).
fn parse_illuminant(path: &Path, text: &str) -> Result<Illuminant, Error> {
    let bad = |m: String| Error::input(format!("illuminant '{}': {m}", path.display()));
    let (xs, ys) = crate::scene::spectra::parse_csv(text).map_err(bad)?;
    if let Some(w) = xs.windows(2).find(|w| !(w[1] > w[0])) {
        return Err(bad(format!(
            "wavelengths must increase ({} then {})",
            w[0], w[1]
        )));
    }
    if let Some(v) = ys.iter().find(|v| **v < 0.0) {
        return Err(bad(format!("values must not be negative (found {v})")));
    }
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let name = stem
        .strip_prefix("illuminant_")
        .unwrap_or(&stem)
        .to_string();
    Ok(Illuminant {
        name,
        spectrum: Spectrum::Tabulated { xs, ys },
    })
}

/// The `*.BFC` files of `dir` (any case), parsed and cleaned, sorted by file name, with the
/// material name (the file stem).
pub fn load_matrices(dir: &Path) -> Result<Vec<(PathBuf, String, BfcMatrix)>, Error> {
    let mut out = Vec::new();
    for path in files_with_extension(dir, "bfc", "BFC matrix")? {
        let text =
            crate::io::input::read_text(&path, crate::io::input::BFC).map_err(Error::input)?;
        let m = BfcMatrix::parse(&text)
            .map_err(|e| Error::input(format!("{}: {e}", path.display())))?;
        let name = path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string();
        out.push((path, name, m));
    }
    Ok(out)
}

/// The files of `dir` whose extension is `ext` (any case), sorted by name; an error if there is
/// none.
pub(crate) fn files_with_extension(
    dir: &Path,
    ext: &str,
    what: &str,
) -> Result<Vec<PathBuf>, Error> {
    let entries = std::fs::read_dir(dir).map_err(|e| {
        Error::input(format!(
            "cannot read the {what} folder '{}': {e}",
            dir.display()
        ))
    })?;
    let mut files = Vec::new();
    for e in entries {
        let p = e
            .map_err(|e| Error::input(format!("cannot list '{}': {e}", dir.display())))?
            .path();
        if p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case(ext)) {
            files.push(p);
        }
    }
    files.sort();
    if files.is_empty() {
        return Err(Error::input(format!(
            "no *.{ext} {what} files in '{}'",
            dir.display()
        )));
    }
    Ok(files)
}

/// Compare the colours of `measured` and `fitted` (same grid) under every illuminant and under
/// unit monochromatic light in each excitation column (see the module notes for the whites).
pub fn compare(
    measured: &BfcMatrix,
    fitted: &BfcMatrix,
    illuminants: &[Illuminant],
) -> Result<Vec<Comparison>, String> {
    let grid = |m: &BfcMatrix| (m.em_lo, m.ex_lo, m.step, m.n_em, m.n_ex);
    if grid(measured) != grid(fitted) || fitted.d.len() != measured.d.len() {
        return Err(format!(
            "the fitted matrix's grid (em_lo, ex_lo, step, n_em, n_ex) = {:?} differs from the measured {:?}",
            grid(fitted),
            grid(measured)
        ));
    }
    let em_wl: Vec<f32> = (0..measured.n_em).map(|o| measured.em(o)).collect();
    let ex_wl: Vec<f32> = (0..measured.n_ex).map(|i| measured.ex(i)).collect();
    let em_cmf = cmf_at(&em_wl);
    let mut out = Vec::with_capacity(illuminants.len() + ex_wl.len());
    let mut push = |light: String, kind, white: [f64; 3], xm: [f64; 3], xf: [f64; 3]| {
        let (lm, lf) = (xyz_to_lab(xm, white), xyz_to_lab(xf, white));
        out.push(Comparison {
            light,
            kind,
            lab_measured: lm,
            lab_fitted: lf,
            de00: delta_e00(lm, lf),
        });
    };
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
        let xm = bispectral_xyz(&measured.d, &em_cmf, &on_ex);
        let xf = bispectral_xyz(&fitted.d, &em_cmf, &on_ex);
        push(il.name.clone(), LightKind::Cie, white, xm, xf);
    }
    let ee = spectrum_xyz(&em_wl, &vec![1.0; em_wl.len()]);
    let mono_white = ee.map(|c| c / ee[1]);
    for (i, &l) in ex_wl.iter().enumerate() {
        let xm = bispectral_xyz_mono(&measured.d, &em_cmf, measured.n_ex, i);
        let xf = bispectral_xyz_mono(&fitted.d, &em_cmf, fitted.n_ex, i);
        push(format!("mono-{l:.0}"), LightKind::Mono, mono_white, xm, xf);
    }
    if let Some(c) = out.iter().find(|c| !c.de00.is_finite()) {
        return Err(format!(
            "ΔE00 under {} is not finite (fitted L*a*b* {:?})",
            c.light, c.lab_fitted
        ));
    }
    Ok(out)
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

fn summarise(rows: &[Row], components: &[usize]) -> Vec<ComponentsSummary> {
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

/// A CSV field, quoted when it holds a comma or a quote.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The text of `delta-e00.csv`.
pub fn csv_text(rows: &[Row], method: FitMethod) -> String {
    let method = method_name(method);
    let mut s = String::from(
        "material,method,components,illuminant,kind,L_measured,a_measured,b_measured,L_fitted,a_fitted,b_fitted,de00\n",
    );
    for r in rows {
        let (m, f) = (r.c.lab_measured, r.c.lab_fitted);
        s.push_str(&format!(
            "{},{method},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            field(&r.material),
            r.components,
            field(&r.c.light),
            r.c.kind.name(),
            m[0],
            m[1],
            m[2],
            f[0],
            f[1],
            f[2],
            r.c.de00
        ));
    }
    s
}

fn method_name(m: FitMethod) -> String {
    match serde_json::to_value(m) {
        Ok(serde_json::Value::String(s)) => s,
        _ => format!("{m:?}").to_lowercase(),
    }
}

fn write_text(path: &Path, text: &str) -> Result<(), String> {
    crate::io::output::write_bytes(path, text.as_bytes())
}

/// Before anything is fitted: the output folder exists (it is created) and takes new files, and
/// nothing the evaluation writes there (`delta-e00.csv`, `summary.json`, the `.svg` and `.png`
/// box plots) is anything but a regular file.
fn check_output_folder(out: &Path) -> Result<(), Error> {
    let bad = |e: String| Error::input(format!("-o/--output '{}': {e}", out.display()));
    std::fs::create_dir_all(out)
        .map_err(|e| format!("cannot create the folder: {e}"))
        .and_then(|()| crate::io::output::check_folder(out))
        .map_err(bad)?;
    let rd = std::fs::read_dir(out).map_err(|e| bad(format!("cannot list the folder: {e}")))?;
    for e in rd.flatten() {
        let p = e.path();
        let n = e.file_name().to_string_lossy().into_owned();
        let ours = n == "delta-e00.csv"
            || n == "summary.json"
            || n.ends_with(".svg")
            || n.ends_with(".png");
        if ours {
            crate::io::output::refuse_non_regular(&p).map_err(bad)?;
        }
    }
    Ok(())
}

fn write_outputs(run: &Run, rows: &[Row], summary: &mut Summary) -> Result<(), String> {
    std::fs::create_dir_all(run.out).map_err(|e| {
        format!(
            "cannot create the output folder '{}': {e}",
            run.out.display()
        )
    })?;
    let csv = run.out.join("delta-e00.csv");
    write_text(&csv, &csv_text(rows, run.method))?;
    summary.outputs.push(csv);
    let method = method_name(run.method);
    for (kind, title) in [
        (LightKind::Cie, "CIE standard illuminants"),
        (LightKind::Mono, "monochromatic light"),
    ] {
        let title = match (
            kind,
            summary.mono_wavelengths.first(),
            summary.mono_wavelengths.last(),
        ) {
            (LightKind::Mono, Some(a), Some(b)) => format!("{title}, {a:.0}–{b:.0} nm"),
            _ => title.to_string(),
        };
        let boxes: Vec<(String, BoxStats)> = summary
            .per_components
            .iter()
            .map(|c| {
                let b = if kind == LightKind::Cie {
                    c.cie_box
                } else {
                    c.mono_box
                };
                (c.components.to_string(), b)
            })
            .filter(|(_, b)| b.n > 0)
            .collect();
        let shown = match method.as_str() {
            "em" => "EM",
            "bayes" => "variational Bayes",
            m => m,
        };
        let n = summary.materials.len();
        let matrices = if n == 1 { "matrix" } else { "matrices" };
        let title = format!("ΔE00 of {shown} fits, {n} {matrices}: {title}");
        let fig = BoxFigure {
            title: &title,
            x_desc: "number of Gaussians",
            y_desc: "ΔE00",
            boxes: &boxes,
        };
        let stem = run.out.join(format!("boxplot-{}", kind.name()));
        summary.outputs.extend(write_box_figure(&stem, &fig)?);
    }
    let json_path = run.out.join("summary.json");
    summary.outputs.push(json_path.clone());
    let json = serde_json::to_string_pretty(summary).map_err(|e| format!("summary: {e}"))?;
    write_text(&json_path, &(json + "\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("stokes-gmm-eval-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
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

    /// A folder with two RIT matrices.
    fn two_files(name: &str) -> PathBuf {
        let d = tmp(name);
        for f in ["GOLFORA.BFC", "INCWHITE.BFC"] {
            std::fs::copy(root().join("data/bispectral").join(f), d.join(f)).unwrap();
        }
        d
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

    #[test]
    fn evaluate_writes_one_row_per_material_components_and_light() {
        let dir = two_files("rows");
        let out = dir.join("out");
        let run = Run {
            dir: &dir,
            components: &[2, 3],
            method: FitMethod::Em,
            seed: 1,
            out: &out,
            illuminants_dir: None,
        };
        let s = evaluate_with(&run, &|m, _| Ok(m.clone())).unwrap();
        assert_eq!(s.materials, ["GOLFORA", "INCWHITE"]);
        let csv = std::fs::read_to_string(out.join("delta-e00.csv")).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 1 + 2 * 2 * (59 + 49));
        assert!(lines[1].starts_with("GOLFORA,em,2,A,cie,"), "{}", lines[1]);
        assert!(lines.iter().skip(1).all(|l| l.ends_with(",0.000000")));
        assert_eq!(s.per_components.len(), 2);
        assert_eq!(s.per_components[0].cie.n, 2 * 59);
        assert_eq!(s.per_components[0].mono.n, 2 * 49);
        assert_eq!(s.per_components[1].worst_cie.len(), 2);
        for f in [
            "summary.json",
            "boxplot-cie.svg",
            "boxplot-cie.png",
            "boxplot-mono.png",
        ] {
            assert!(out.join(f).is_file(), "{f}");
        }
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(json["per_components"][1]["components"], 3);
        assert_eq!(json["per_components"][0]["cie"]["max"], 0.0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_missing_folder_or_a_malformed_file_is_an_input_error_naming_it() {
        let ill = root().join("data/spectra/illuminants");
        let missing = root().join("data/no-such-folder");
        let run = |dir: &Path, out: &Path| -> Result<Summary, Error> {
            let r = Run {
                dir,
                components: &[2],
                method: FitMethod::Em,
                seed: 0,
                out,
                illuminants_dir: Some(&ill),
            };
            evaluate_with(&r, &|m, _| Ok(m.clone()))
        };
        let e = run(&missing, &missing.join("out")).unwrap_err();
        assert_eq!(e.kind, crate::ErrorKind::Input);
        assert!(e.message.contains("no-such-folder"), "{}", e.message);

        let dir = two_files("malformed");
        std::fs::write(
            dir.join("BROKEN.BFC"),
            "BFC-450 Matrix File\n380 780 10 49 300 10\nr:c: 1 2\n",
        )
        .unwrap();
        let e = run(&dir, &dir.join("out")).unwrap_err();
        assert_eq!(e.kind, crate::ErrorKind::Input);
        assert!(
            e.message.contains("BROKEN.BFC") && e.message.contains("r:c:"),
            "{}",
            e.message
        );
        assert!(!dir.join("out").exists(), "nothing written");

        let empty = tmp("empty");
        let e = run(&empty, &empty.join("out")).unwrap_err();
        assert!(e.message.contains("no *.bfc") && e.message.contains(&*empty.to_string_lossy()));

        // A fit whose matrix has another grid is reported with the file.
        let dir2 = two_files("grid");
        let r = Run {
            dir: &dir2,
            components: &[2],
            method: FitMethod::Em,
            seed: 0,
            out: &dir2.join("out"),
            illuminants_dir: Some(&ill),
        };
        let e = evaluate_with(&r, &|m, _| {
            let mut f = m.clone();
            f.n_ex -= 1;
            Ok(f)
        })
        .unwrap_err();
        assert_eq!(e.kind, crate::ErrorKind::Runtime);
        assert!(
            e.message.contains(".BFC") && e.message.contains("grid"),
            "{}",
            e.message
        );
        let e = evaluate_with(&r, &|_, _| Err("did not converge".into())).unwrap_err();
        assert!(
            e.message
                .contains(".BFC: fitting 2 components: did not converge"),
            "{}",
            e.message
        );
        for d in [dir, empty, dir2] {
            let _ = std::fs::remove_dir_all(d);
        }
    }

    #[test]
    fn a_bad_illuminant_is_named() {
        let d = tmp("illuminant");
        std::fs::write(d.join("illuminant_X.csv"), "400, 1\n390, 2\n").unwrap();
        let e = load_illuminants(&d).unwrap_err();
        assert!(e.message.contains("illuminant_X.csv") && e.message.contains("increase"));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn stats_of_known_data() {
        let s = stats(&[4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!((s.n, s.mean, s.median, s.max), (4, 2.5, 2.5, 4.0));
        assert!((s.p95 - 3.85).abs() < 1e-12);
        assert!(stats(&[]).is_none());
    }

    /// Real fits of two matrices at two components (needs `fit_matrix`).
    #[test]
    fn real_fits_of_two_matrices() {
        let dir = two_files("fit");
        let out = dir.join("out");
        let s = evaluate(&dir, &[2], FitMethod::Em, 0, &out, None).unwrap();
        let k = &s.per_components[0];
        assert_eq!((k.cie.n, k.mono.n), (2 * 59, 2 * 49));
        // Hua §7.5: below 1.1 on average over the dataset with two Gaussians (these two give
        // about 0.3); an approximate fit is not exact.
        assert!(k.cie.mean > 0.0 && k.cie.mean < 1.0, "{k:?}");
        assert!(k.mono.mean > 0.0 && k.mono.max.is_finite(), "{k:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The whole RIT set: `cargo test --release --lib gmm::evaluate -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn all_rit_matrices() {
        let out = root().join(DEFAULT_OUT);
        let ks = [2, 4, 8];
        let s = evaluate(
            &root().join("data/bispectral/rit"),
            &ks,
            FitMethod::Em,
            0,
            &out,
            None,
        )
        .unwrap();
        eprintln!("{} matrices in {:.1} s", s.materials.len(), s.seconds);
        for k in &s.per_components {
            eprintln!(
                "K = {}: CIE mean {:.4} median {:.4} p95 {:.4} max {:.3}; mono mean {:.4} median {:.4} p95 {:.4} max {:.3}; worst {:?}",
                k.components,
                k.cie.mean,
                k.cie.median,
                k.cie.p95,
                k.cie.max,
                k.mono.mean,
                k.mono.median,
                k.mono.p95,
                k.mono.max,
                k.worst_cie
                    .iter()
                    .take(3)
                    .map(|w| (&w.material, w.mean))
                    .collect::<Vec<_>>()
            );
        }
    }
}
