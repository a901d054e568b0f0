//! The `reradiation-gmm` material's model: a fitted file, or a BFC matrix fitted at load time
//! and cached by the SHA-256 of the matrix file and the fit settings (the number of starts
//! included, so a new default number of starts fits again).
//!
//! The cache folder is `$STOKES_CACHE_DIR`, else `$XDG_CACHE_HOME/stokes`, else
//! `$HOME/.cache/stokes`; its `gmm/` subfolder holds one model file per key. A cache entry that
//! does not parse, or whose source hash or settings differ, is fitted again and replaced. A
//! cache that cannot be written costs only a warning.

use crate::io::InputError;
use crate::io::hash::sha256_hex;
use crate::material::MixtureSampler;
use crate::material::mixture::fit::MAX_RESTARTS;
use crate::material::mixture::{FitMethod, FitOptions, GmmFile, fit_matrix};
use crate::material::reradiation::BfcMatrix;
use crate::scene::format::ShiftSamplingDesc;
use crate::spectrum::Domain;
use std::path::{Path, PathBuf};

/// Components fitted when a scene gives a `bfc` without `components` (Hua §7.4's advice).
pub const DEFAULT_COMPONENTS: usize = 8;

/// The JSON fields of a `reradiation-gmm` material.
pub struct GmmSource {
    pub file: Option<String>,
    pub bfc: Option<String>,
    pub components: Option<usize>,
    pub method: Option<FitMethod>,
    pub seed: Option<u64>,
    pub restarts: Option<usize>,
}

/// The model of the material at JSON path `base` of scene `scene`, resolved from `dir`.
pub fn load(
    scene: &Path,
    dir: &Path,
    base: &str,
    src: GmmSource,
    warnings: &mut Vec<String>,
) -> Result<GmmFile, InputError> {
    let err = |field: &str, m: String| InputError::new(scene, format!("{base}.{field}"), m);
    match (&src.file, &src.bfc) {
        (Some(file), None) => {
            for (set, name) in [
                (src.components.is_some(), "components"),
                (src.method.is_some(), "method"),
                (src.seed.is_some(), "seed"),
                (src.restarts.is_some(), "restarts"),
            ] {
                if set {
                    return Err(err(
                        name,
                        "only applies with `bfc` (a fitted `file` already has its settings)"
                            .to_string(),
                    ));
                }
            }
            let full = dir.join(file);
            let text = crate::io::input::read_text(&full, crate::io::input::GMM_MODEL)
                .map_err(|e| err("file", e))?;
            GmmFile::parse(&text).map_err(|m| {
                err(
                    "file",
                    format!("malformed GMM file '{}': {m}", full.display()),
                )
            })
        }
        (None, Some(bfc)) => {
            let full = dir.join(bfc);
            let bytes = crate::io::input::read_bytes(&full, crate::io::input::BFC)
                .map_err(|e| err("bfc", e))?;
            let m = std::str::from_utf8(&bytes)
                .map_err(|e| e.to_string())
                .and_then(BfcMatrix::parse)
                .map_err(|m| {
                    err(
                        "bfc",
                        format!("malformed BFC file '{}': {m}", full.display()),
                    )
                })?;
            let opt = options(src.components, src.method, src.seed, src.restarts, err)?;
            fitted(&m, &bytes, bfc, &opt, warnings)
                .map_err(|m| err("bfc", format!("cannot fit '{}': {m}", full.display())))
        }
        (Some(_), Some(_)) => Err(err(
            "bfc",
            "give only one of `file` (a fitted model) and `bfc` (a matrix to fit)".to_string(),
        )),
        (None, None) => Err(err(
            "file",
            "missing: give `file` (a fitted model) or `bfc` (a matrix to fit)".to_string(),
        )),
    }
}

/// The fit settings of a material's `components`, `method`, `seed` and `restarts` (defaults: 8,
/// EM, 0, the default starts);
/// `err` places an error at one of those fields.
fn options(
    components: Option<usize>,
    method: Option<FitMethod>,
    seed: Option<u64>,
    restarts: Option<usize>,
    err: impl Fn(&str, String) -> InputError,
) -> Result<FitOptions, InputError> {
    let max = crate::material::mixture::conditional::MAX_COMPONENTS;
    if let Some(k) = components
        && !(1..=max).contains(&k)
    {
        return Err(err("components", format!("{k} is not in 1..={max}")));
    }
    let mut opt = FitOptions::new(
        components.unwrap_or(DEFAULT_COMPONENTS),
        method.unwrap_or_default(),
        seed.unwrap_or(0),
    );
    if let Some(r) = restarts {
        if !(1..=MAX_RESTARTS).contains(&r) {
            return Err(err("restarts", format!("{r} is not in 1..={MAX_RESTARTS}")));
        }
        opt.restarts = r;
    }
    Ok(opt)
}

/// The tables' share α of the draws of a sampling-only mixture when a scene does not give one.
pub const DEFAULT_DEFENSIVE: f32 = 0.1;

/// The `sampling` of a `reradiation` material at JSON path `base` (its own matrix `m`, read
/// from file bytes `bytes` named `name`): `None` for the matrix's tables, else the mixture that
/// draws its shifts, from a fitted `file` or fitted at load like a `reradiation-gmm` `bfc`.
#[allow(clippy::too_many_arguments)]
pub fn sampler(
    scene: &Path,
    dir: &Path,
    base: &str,
    desc: ShiftSamplingDesc,
    (m, bytes, name): (&BfcMatrix, &[u8], &str),
    domain: Domain,
    warnings: &mut Vec<String>,
) -> Result<Option<MixtureSampler>, InputError> {
    let err = |field: &str, msg: String| InputError::new(scene, format!("{base}.{field}"), msg);
    let ShiftSamplingDesc::Mixture {
        file,
        components,
        method,
        seed,
        restarts,
        defensive,
    } = desc
    else {
        return Ok(None);
    };
    let alpha = defensive.unwrap_or(DEFAULT_DEFENSIVE);
    if !(alpha > 0.0 && alpha <= 1.0) {
        return Err(err(
            "defensive",
            format!(
                "{alpha} is not in (0, 1]: it is the tables' share of the draws, and only a \
                 positive share keeps the sampling density positive wherever the matrix is"
            ),
        ));
    }
    let f = match file {
        Some(file) => {
            for (set, name) in [
                (components.is_some(), "components"),
                (method.is_some(), "method"),
                (seed.is_some(), "seed"),
                (restarts.is_some(), "restarts"),
            ] {
                if set {
                    return Err(err(
                        name,
                        "only applies without `file` (a fitted `file` already has its settings)"
                            .to_string(),
                    ));
                }
            }
            let full = dir.join(&file);
            let text = crate::io::input::read_text(&full, crate::io::input::GMM_MODEL)
                .map_err(|e| err("file", e))?;
            let f = GmmFile::parse(&text).map_err(|e| {
                err(
                    "file",
                    format!("malformed GMM file '{}': {e}", full.display()),
                )
            })?;
            if f.source.sha256 != sha256_hex(bytes) {
                warnings.push(format!(
                    "{base}.file: the model '{}' was not fitted to '{name}' (its source is \
                     '{}'): it still samples without bias, but less well",
                    full.display(),
                    f.source.file
                ));
            }
            f
        }
        None => {
            let opt = options(components, method, seed, restarts, err)?;
            fitted(m, bytes, name, &opt, warnings)
                .map_err(|e| err("components", format!("cannot fit '{name}': {e}")))?
        }
    };
    Ok(Some(MixtureSampler::new(&f, domain, alpha)))
}

/// The folder of cached fits, if the environment names one.
fn cache_dir() -> Option<PathBuf> {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    env("STOKES_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("stokes")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("stokes")))
        .map(|d| d.join("gmm"))
}

/// The fit of `m` (file bytes `bytes`, named `name`) with `opt`, from the cache when it holds
/// this exact fit.
fn fitted(
    m: &BfcMatrix,
    bytes: &[u8],
    name: &str,
    opt: &FitOptions,
    warnings: &mut Vec<String>,
) -> Result<GmmFile, String> {
    let hash = sha256_hex(bytes);
    let key = sha256_hex(format!("{hash}{}", serde_json::to_string(opt).unwrap()).as_bytes());
    let path = cache_dir().map(|d| d.join(format!("{}.json", &key[..32])));
    if let Some(p) = &path
        && let Ok(text) = crate::io::input::read_text(p, crate::io::input::GMM_MODEL)
    {
        match GmmFile::parse(&text) {
            Ok(f) if f.source.sha256 == hash && f.fit.options == *opt => return Ok(f),
            _ => warnings.push(format!(
                "the cached fit '{}' is stale or damaged: fitting again",
                p.display()
            )),
        }
    }
    let mut f = fit_matrix(m, opt)?;
    f.source.file = name.to_string();
    f.source.sha256 = hash;
    if let Some(p) = &path
        && let Err(e) = crate::io::output::write_bytes(p, f.to_json().as_bytes())
    {
        warnings.push(format!("cannot cache the fit: {e}"));
    }
    Ok(f)
}
