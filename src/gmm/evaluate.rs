//! Colour accuracy of Gaussian-mixture fits of measured reradiation matrices (Hua et al. 2022
//! §7.2–7.5): every BFC matrix of a folder is fitted with each number of components, and the
//! colour of the measured matrix is compared with the colour of the fitted one by CIEDE2000.
//!
//! **The reference** is the measured matrix as cleaned by Hua §5.1 (the matrix that is fitted);
//! every row also compares the fit with the uncleaned measurement, and the cleaned matrix with
//! it (`super::summary` explains the names).
//!
//! Outputs (written to a temporary file and renamed): `delta-e00.csv` (one row per material,
//! number of components and light), `delta-e00-mono.csv` and `delta-e00-illuminants.csv` (per
//! light and number of components, statistics over the materials: Hua Figs. 7a and 8a),
//! `summary.json` (per number of components and kind of light: mean, median, 95th percentile and
//! maximum of ΔE00 over all material × light pairs, against the cleaned and the raw matrices; the
//! ten materials with the largest mean ΔE00 under the CIE illuminants and under monochromatic
//! light, and the ten worst illuminants) and the box plots `boxplot-cie.{svg,png}`,
//! `boxplot-mono.{svg,png}` over the same pairs (Hua Figs. 8b and 7b).
//!
//! The colours and their whites are computed by [`super::colour`], the matrices and illuminant
//! tables read by [`super::inputs`], and the statistics of `summary.json` formed by
//! [`super::summary`].

use super::boxplot::{BoxFigure, BoxStats, write_box_figure};
use super::colour::{LightKind, check_grid, colours, compare_colours};
use super::inputs::{
    Illuminant, Measurement, embedded_illuminants, load_illuminants, load_measurements,
};
use super::summary::{
    REFERENCE, REFERENCE_NOTE, Row, Summary, VsRaw, cleaning, field, per_light, per_light_csv,
    summarise,
};
use crate::Error;
use crate::material::mixture::{FitMethod, FitOptions, fit_matrix};
use crate::material::reradiation::BfcMatrix;
use rayon::prelude::*;
use std::path::Path;

/// Where `stokes gmm eval` writes by default.
pub const DEFAULT_OUT: &str = "results/gmm-eval";

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
        restarts: crate::material::mixture::fit::DEFAULT_RESTARTS,
    };
    evaluate_with(&run, &fit)
}

/// [`evaluate`] with `restarts` seeded starts per fit instead of the default.
pub fn evaluate_restarts(
    dir: &Path,
    components: &[usize],
    method: FitMethod,
    seed: u64,
    out: &Path,
    illuminants_dir: Option<&Path>,
    restarts: usize,
) -> Result<Summary, Error> {
    let fit = |m: &BfcMatrix, k: usize| -> Result<BfcMatrix, String> {
        let mut o = FitOptions::new(k, method, seed);
        o.restarts = restarts;
        Ok(fit_matrix(m, &o)?.to_matrix())
    };
    let run = Run {
        dir,
        components,
        method,
        seed,
        out,
        illuminants_dir,
        restarts,
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
    /// Recorded in the outputs: the seeded starts per fit.
    pub restarts: usize,
}

/// [`evaluate`] with the fit given as a function from a matrix and a number of components to
/// the fitted matrix on the same grid.
pub fn evaluate_with<F>(run: &Run, fit: &F) -> Result<Summary, Error>
where
    F: Fn(&BfcMatrix, usize) -> Result<BfcMatrix, String> + Sync,
{
    let (materials, illuminants) = load_inputs(run)?;
    check_output_folder(run.out)?;
    let start = std::time::Instant::now();
    let rows = compare_all(run, &materials, &illuminants, fit)?;
    let seconds = start.elapsed().as_secs_f64();
    let mut summary = Summary {
        reference: REFERENCE.to_string(),
        reference_note: REFERENCE_NOTE.to_string(),
        method: run.method,
        seed: run.seed,
        materials: materials.iter().map(|m| m.name.clone()).collect(),
        illuminants: illuminants.iter().map(|i| i.name.clone()).collect(),
        mono_wavelengths: materials
            .first()
            .map(|m| (0..m.cleaned.n_ex).map(|i| m.cleaned.ex(i)).collect())
            .unwrap_or_default(),
        per_components: summarise(&rows, run.components),
        cleaning: cleaning(&rows, run.components),
        seconds,
        outputs: Vec::new(),
        restarts: run.restarts,
    };
    write_outputs(run, &rows, &mut summary).map_err(Error::runtime)?;
    Ok(summary)
}

/// The matrices of `run.dir` (cleaned and raw) and the illuminants, after checking the numbers
/// of components.
pub fn load_inputs(run: &Run) -> Result<(Vec<Measurement>, Vec<Illuminant>), Error> {
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
    Ok((load_measurements(run.dir)?, illuminants))
}

/// Fit every material with each number of components and compare the colours: one row per
/// material, number of components and light, against the cleaned matrix and the raw one.
pub fn compare_all<F>(
    run: &Run,
    materials: &[Measurement],
    illuminants: &[Illuminant],
    fit: &F,
) -> Result<Vec<Row>, Error>
where
    F: Fn(&BfcMatrix, usize) -> Result<BfcMatrix, String> + Sync,
{
    let bar = crate::experiment::progress::bar(materials.len() as u64);
    let per_material: Vec<Vec<Row>> = materials
        .par_iter()
        .map(|m| {
            let rows = material_rows(run, m, illuminants, fit);
            bar.inc(1);
            rows
        })
        .collect::<Result<_, Error>>()?;
    bar.finish_and_clear();
    Ok(per_material.into_iter().flatten().collect())
}

/// The rows of one material.
fn material_rows<F>(
    run: &Run,
    m: &Measurement,
    illuminants: &[Illuminant],
    fit: &F,
) -> Result<Vec<Row>, Error>
where
    F: Fn(&BfcMatrix, usize) -> Result<BfcMatrix, String>,
{
    let path = m.path.display();
    let err = |e: String| Error::runtime(format!("{path}: {e}"));
    let cleaned = colours(&m.cleaned, illuminants).map_err(err)?;
    let raw = colours(&m.raw, illuminants).map_err(err)?;
    let cleaning = compare_colours(&raw, &cleaned).map_err(err)?;
    let mut rows = Vec::new();
    for &k in run.components {
        let fitted = fit(&m.cleaned, k)
            .map_err(|e| Error::runtime(format!("{path}: fitting {k} components: {e}")))?;
        let err = |e: String| Error::runtime(format!("{path}: {k} components: {e}"));
        check_grid(&m.cleaned, &fitted).map_err(err)?;
        let fc = colours(&fitted, illuminants).map_err(err)?;
        let vs_cleaned = compare_colours(&cleaned, &fc).map_err(err)?;
        let vs_raw = compare_colours(&raw, &fc).map_err(err)?;
        for ((c, r), e) in vs_cleaned.into_iter().zip(vs_raw).zip(&cleaning) {
            rows.push(Row {
                material: m.name.clone(),
                components: k,
                raw: VsRaw {
                    lab_raw: r.lab_measured,
                    de00_fit: r.de00,
                    de00_cleaning: e.de00,
                },
                c,
            });
        }
    }
    Ok(rows)
}

/// The text of `delta-e00.csv`: per row the colours of the cleaned matrix (the reference), of
/// the raw measurement and of the fit, and ΔE00 of the fit against each and of the cleaned
/// matrix against the raw one.
pub fn csv_text(rows: &[Row], method: FitMethod) -> String {
    let method = method_name(method);
    let mut s = String::from(
        "material,method,components,illuminant,kind,L_cleaned,a_cleaned,b_cleaned,L_raw,a_raw,b_raw,L_fitted,a_fitted,b_fitted,de00_fit_cleaned,de00_fit_raw,de00_cleaned_raw\n",
    );
    for r in rows {
        let (m, w, f) = (r.c.lab_measured, r.raw.lab_raw, r.c.lab_fitted);
        s.push_str(&format!(
            "{},{method},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            field(&r.material),
            r.components,
            field(&r.c.light),
            r.c.kind.name(),
            m[0],
            m[1],
            m[2],
            w[0],
            w[1],
            w[2],
            f[0],
            f[1],
            f[2],
            r.c.de00,
            r.raw.de00_fit,
            r.raw.de00_cleaning,
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
/// nothing the evaluation writes there (`delta-e00*.csv`, `summary.json`, the `.svg` and `.png`
/// box plots) is anything but a regular file.
pub(crate) fn check_output_folder(out: &Path) -> Result<(), Error> {
    let bad = |e: String| Error::input(format!("-o/--output '{}': {e}", out.display()));
    std::fs::create_dir_all(out)
        .map_err(|e| format!("cannot create the folder: {e}"))
        .and_then(|()| crate::io::output::check_folder(out))
        .map_err(bad)?;
    let rd = std::fs::read_dir(out).map_err(|e| bad(format!("cannot list the folder: {e}")))?;
    for e in rd.flatten() {
        let p = e.path();
        let n = e.file_name().to_string_lossy().into_owned();
        let ours = (n.starts_with("delta-e00") && n.ends_with(".csv"))
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
    let lights = per_light(rows, run.components);
    for (kind, name) in [
        (LightKind::Mono, "delta-e00-mono.csv"),
        (LightKind::Cie, "delta-e00-illuminants.csv"),
    ] {
        let path = run.out.join(name);
        write_text(&path, &per_light_csv(&lights, kind))?;
        summary.outputs.push(path);
    }
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
    use std::path::PathBuf;

    fn root() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("stokes-gmm-eval-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
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
            restarts: 1,
        };
        let s = evaluate_with(&run, &|m, _| Ok(m.clone())).unwrap();
        assert_eq!(s.materials, ["GOLFORA", "INCWHITE"]);
        let csv = std::fs::read_to_string(out.join("delta-e00.csv")).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 1 + 2 * 2 * (59 + 49));
        assert!(lines[1].starts_with("GOLFORA,em,2,A,cie,"), "{}", lines[1]);
        let header: Vec<&str> = lines[0].split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        let (fc, fr, cr) = (
            col("de00_fit_cleaned"),
            col("de00_fit_raw"),
            col("de00_cleaned_raw"),
        );
        // The "fit" is the cleaned matrix itself: no difference against the reference, and
        // against the raw measurement exactly what the cleaning moves, which is not nothing.
        let mut moved = 0;
        for l in &lines[1..] {
            let v: Vec<&str> = l.split(',').collect();
            assert_eq!(v[fc], "0.000000", "{l}");
            assert_eq!(v[fr], v[cr], "{l}");
            moved += (v[cr] != "0.000000") as usize;
        }
        assert!(moved > 100, "{moved}");
        assert_eq!(s.reference, "cleaned");
        assert!(s.cleaning.cie.mean > 0.0 && s.cleaning.cie.n == 2 * 59);
        assert_eq!(s.per_components[0].vs_raw.cie.mean, s.cleaning.cie.mean);
        assert_eq!(s.per_components[0].worst_illuminants.len(), 10);
        assert_eq!(s.per_components[0].worst_mono.len(), 2);
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
        assert_eq!(json["reference"], "cleaned");
        assert!(json["cleaning"]["mono"]["mean"].as_f64().unwrap() > 0.0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The per-light CSVs hold the means over the materials of delta-e00.csv's rows, with their
    /// wavelength or illuminant.
    #[test]
    fn per_light_csvs_agree_with_the_rows() {
        let dir = two_files("per-light");
        let out = dir.join("out");
        let run = Run {
            dir: &dir,
            components: &[2, 4],
            method: FitMethod::Em,
            seed: 0,
            out: &out,
            illuminants_dir: None,
            restarts: 1,
        };
        // A fit that differs by light: the cleaned matrix, scaled per number of components.
        evaluate_with(&run, &|m, k| {
            let mut f = m.clone();
            f.d.iter_mut().for_each(|x| *x *= 1.0 + 0.05 * k as f32);
            Ok(f)
        })
        .unwrap();
        let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
        let all = read("delta-e00.csv");
        let mut sums: std::collections::HashMap<(String, String), (f64, f64, usize)> =
            Default::default();
        for l in all.lines().skip(1) {
            let v: Vec<&str> = l.split(',').collect();
            let light = v[3].trim_start_matches("mono-").to_string();
            let e = sums.entry((light, v[2].to_string())).or_default();
            e.0 += v[14].parse::<f64>().unwrap();
            e.1 += v[15].parse::<f64>().unwrap();
            e.2 += 1;
        }
        let mut checked = 0;
        for (f, n) in [
            ("delta-e00-mono.csv", 49),
            ("delta-e00-illuminants.csv", 59),
        ] {
            let text = read(f);
            let lines: Vec<&str> = text.lines().collect();
            assert_eq!(lines.len(), 1 + 2 * n, "{f}");
            for l in &lines[1..] {
                let v: Vec<&str> = l.split(',').collect();
                let (sum, sum_raw, count) = sums[&(v[0].to_string(), v[1].to_string())];
                assert_eq!(v[2], "2");
                assert_eq!(count, 2);
                let mean: f64 = v[3].parse().unwrap();
                assert!((mean - sum / 2.0).abs() < 2e-6, "{f}: {l}");
                let mean_raw: f64 = v[7].parse().unwrap();
                assert!((mean_raw - sum_raw / 2.0).abs() < 2e-6, "{f}: {l}");
                checked += (mean > 0.0) as usize;
            }
        }
        assert!(checked > 50, "{checked}");
        assert!(read("delta-e00-mono.csv").contains("\n550,4,2,"));
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
                restarts: 1,
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
            restarts: 1,
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
