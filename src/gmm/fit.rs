//! `stokes gmm fit`: fit one BFC file, or every BFC file of a folder, and write model files
//! (docs/gmm.md).

use crate::Error;
use crate::io::hash::sha256_hex;
use crate::io::output::write_bytes;
use crate::material::mixture::{FitOptions, GmmFile, fit_matrix};
use crate::material::reradiation::BfcMatrix;
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// One fitted file.
#[derive(Clone, Debug)]
pub struct Fitted {
    pub input: PathBuf,
    pub output: PathBuf,
    pub model: GmmFile,
}

/// Read, clean and fit one BFC file; the model's `source` names it.
pub fn fit_file(path: &Path, opt: &FitOptions) -> Result<GmmFile, Error> {
    let bytes = crate::io::input::read_bytes(path, crate::io::input::BFC).map_err(Error::input)?;
    let m = std::str::from_utf8(&bytes)
        .map_err(|e| e.to_string())
        .and_then(BfcMatrix::parse)
        .map_err(|m| Error::input(format!("malformed BFC file '{}': {m}", path.display())))?;
    let mut f = fit_matrix(&m, opt)
        .map_err(|m| Error::input(format!("cannot fit '{}': {m}", path.display())))?;
    f.source.file = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    f.source.sha256 = sha256_hex(&bytes);
    Ok(f)
}

/// The (input, output) pairs of `stokes gmm fit INPUT -o OUT`: `out` itself for a file (or
/// `out/<STEM>.json` when `out` is an existing folder), `out/<STEM>.json` for every BFC file of
/// a folder. Two inputs that would write the same output are an error.
pub fn targets(input: &Path, out: &Path) -> Result<Vec<(PathBuf, PathBuf)>, Error> {
    let files = if input.is_dir() {
        super::inputs::files_with_extension(input, "bfc", "BFC matrix")?
    } else {
        vec![input.to_path_buf()]
    };
    let into_folder = input.is_dir() || out.is_dir();
    let mut jobs: Vec<(PathBuf, PathBuf)> = Vec::with_capacity(files.len());
    for f in files {
        let target = if into_folder {
            let stem = f.file_stem().unwrap_or_default().to_string_lossy();
            out.join(format!("{stem}.json"))
        } else {
            out.to_path_buf()
        };
        if let Some((other, _)) = jobs.iter().find(|(_, t)| *t == target) {
            return Err(Error::input(format!(
                "'{}' and '{}' would both be fitted into '{}': rename one of them",
                other.display(),
                f.display(),
                target.display()
            )));
        }
        jobs.push((f, target));
    }
    Ok(jobs)
}

/// Fit every (input, output) pair of [`targets`] and write the models. Files are fitted in
/// parallel under a progress bar; a file that fails is named and the others are still
/// written.
pub fn fit(jobs: &[(PathBuf, PathBuf)], opt: &FitOptions) -> Result<Vec<Fitted>, Error> {
    let files = jobs;
    let bar = if files.len() > 1 {
        crate::experiment::progress::bar(files.len() as u64)
    } else {
        ProgressBar::hidden()
    };
    let results: Vec<Result<Fitted, Error>> = files
        .par_iter()
        .map(|(f, output)| {
            let model = fit_file(f, opt)?;
            let output = output.clone();
            write_bytes(&output, model.to_json().as_bytes()).map_err(Error::runtime)?;
            bar.inc(1);
            Ok(Fitted {
                input: f.clone(),
                output,
                model,
            })
        })
        .collect();
    bar.finish_and_clear();
    let (ok, failed): (Vec<_>, Vec<_>) = results.into_iter().partition(|r| r.is_ok());
    if let Some(first) = failed
        .into_iter()
        .map(|r| r.unwrap_err())
        .reduce(|a, b| Error {
            kind: a.kind,
            message: format!("{}\n{}", a.message, b.message),
        })
    {
        return Err(first);
    }
    Ok(ok.into_iter().map(|r| r.unwrap()).collect())
}
