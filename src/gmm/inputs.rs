//! The inputs of an evaluation: the BFC matrices of a folder and the illuminant tables.

use crate::Error;
use crate::material::reradiation::BfcMatrix;
use crate::spectrum::Spectrum;
use std::path::{Path, PathBuf};

/// A named illuminant spectrum (piecewise linear, zero outside its table).
#[derive(Clone, Debug)]
pub struct Illuminant {
    pub name: String,
    pub spectrum: Spectrum,
}

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
    Ok(load_measurements(dir)?
        .into_iter()
        .map(|m| (m.path, m.name, m.cleaned))
        .collect())
}

/// One measured matrix: as cleaned by Hua §5.1 (what is fitted, and the reference of the
/// comparisons by default) and as measured ([`BfcMatrix::parse_raw`]).
#[derive(Clone, Debug)]
pub struct Measurement {
    pub path: PathBuf,
    /// The file stem.
    pub name: String,
    pub cleaned: BfcMatrix,
    pub raw: BfcMatrix,
}

/// The `*.BFC` files of `dir` (any case), sorted by file name, each parsed both ways.
pub fn load_measurements(dir: &Path) -> Result<Vec<Measurement>, Error> {
    let mut out = Vec::new();
    for path in files_with_extension(dir, "bfc", "BFC matrix")? {
        let text =
            crate::io::input::read_text(&path, crate::io::input::BFC).map_err(Error::input)?;
        let bad = |e: String| Error::input(format!("{}: {e}", path.display()));
        let cleaned = BfcMatrix::parse(&text).map_err(bad)?;
        let raw = BfcMatrix::parse_raw(&text).map_err(bad)?;
        let name = path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string();
        out.push(Measurement {
            path,
            name,
            cleaned,
            raw,
        });
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
