//! Spectrum descriptions in scene files: numbers, names, and typed objects.

use crate::io::InputError;
use crate::io::json::from_tagged_value;
use crate::spectrum::{Domain, Spectrum};
use serde::Deserialize;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
// Written `{"type": "<kind>", …}`, read with `from_tagged_value` (field paths kept).
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
enum SpectrumDesc {
    Constant {
        value: f32,
    },
    Box {
        lo: f32,
        hi: f32,
        value: f32,
    },
    Gaussian {
        center: f32,
        fwhm: f32,
        peak: f32,
    },
    Tabulated {
        #[serde(default)]
        pairs: Option<Vec<[f32; 2]>>,
        #[serde(default)]
        file: Option<String>,
        #[serde(default)]
        scale: Option<f32>,
    },
    Binned {
        lo: f32,
        width: f32,
        values: Vec<f32>,
    },
    /// A ColorChecker patch (1–24, in the usual order; 11 is yellow-green).
    Colorchecker {
        patch: u32,
    },
}

/// Context for resolving spectra: the scene file, its folder and the named spectra.
pub struct SpectrumContext<'a> {
    pub file: &'a Path,
    pub dir: PathBuf,
    pub named: BTreeMap<String, Spectrum>,
    pub domain: Domain,
}

impl SpectrumContext<'_> {
    /// Parse the named spectra `descs` (the file's `spectra`) into `self.named`. A spectrum may
    /// be another's name, defined before or after it: each is parsed after the one it names, and
    /// names that refer to each other in a cycle are an error that lists the cycle.
    pub fn add_named(&mut self, descs: &BTreeMap<String, Value>) -> Result<(), InputError> {
        for start in descs.keys() {
            // Follow the names from `start` to one already parsed or one that is not a name.
            let mut chain: Vec<&str> = Vec::new();
            let mut on_chain = std::collections::HashSet::new();
            let mut name = start.as_str();
            while !self.named.contains_key(name) {
                if !on_chain.insert(name) {
                    let i = chain.iter().position(|n| *n == name).unwrap_or(0);
                    let cycle: Vec<&str> = chain[i..].iter().copied().chain([name]).collect();
                    return Err(InputError::new(
                        self.file,
                        format!("spectra.{name}"),
                        format!(
                            "named spectra refer to each other in a cycle: {}",
                            cycle.join(" → ")
                        ),
                    ));
                }
                chain.push(name);
                match &descs[name] {
                    Value::String(next) if descs.contains_key(next) => name = next,
                    Value::String(next) => {
                        return Err(InputError::new(
                            self.file,
                            format!("spectra.{name}"),
                            format!(
                                "unknown spectrum name '{next}' (named spectra: {})",
                                descs.keys().cloned().collect::<Vec<_>>().join(", ")
                            ),
                        ));
                    }
                    _ => break,
                }
            }
            for n in chain.into_iter().rev() {
                let s = self.parse(&descs[n], &format!("spectra.{n}"))?;
                self.named.insert(n.to_string(), s);
            }
        }
        Ok(())
    }

    /// Parse a spectrum at JSON path `path`. Values must be finite and non-negative.
    pub fn parse(&self, v: &Value, path: &str) -> Result<Spectrum, InputError> {
        let err = |m: String| InputError::new(self.file, path, m);
        let s = match v {
            Value::Number(n) => Spectrum::Constant(n.as_f64().unwrap_or(f64::NAN) as f32),
            Value::String(name) => self.named.get(name).cloned().ok_or_else(|| {
                err(format!(
                    "unknown spectrum name '{name}' (named spectra: {})",
                    self.named.keys().cloned().collect::<Vec<_>>().join(", ")
                ))
            })?,
            Value::Object(_) => {
                match from_tagged_value::<SpectrumDesc>(self.file, path, "type", v)? {
                    SpectrumDesc::Constant { value } => Spectrum::Constant(value),
                    SpectrumDesc::Box { lo, hi, value } => {
                        if !(lo < hi) {
                            return Err(err(format!(
                                "box spectrum needs lo < hi, got lo = {lo}, hi = {hi}"
                            )));
                        }
                        Spectrum::Box { lo, hi, value }
                    }
                    SpectrumDesc::Gaussian { center, fwhm, peak } => {
                        if !(fwhm > 0.0) || !center.is_finite() {
                            return Err(err(format!(
                                "gaussian spectrum needs fwhm > 0, got {fwhm}"
                            )));
                        }
                        Spectrum::gaussian_fwhm(center, fwhm, peak)
                    }
                    SpectrumDesc::Tabulated { pairs, file, scale } => {
                        let (xs, ys) = match (pairs, file) {
                            (Some(p), None) => p.into_iter().map(|[a, b]| (a, b)).unzip(),
                            (None, Some(f)) => {
                                let full = self.dir.join(&f);
                                let text = crate::io::input::read_text(
                                    &full,
                                    crate::io::input::SPECTRUM_CSV,
                                )
                                .map_err(|e| {
                                    InputError::new(self.file, format!("{path}.file"), e)
                                })?;
                                parse_csv(&text).map_err(|m| {
                                    InputError::new(
                                        self.file,
                                        format!("{path}.file"),
                                        format!("malformed CSV '{}': {m}", full.display()),
                                    )
                                })?
                            }
                            _ => {
                                return Err(err(
                                    "a tabulated spectrum needs exactly one of `pairs` or `file`"
                                        .into(),
                                ));
                            }
                        };
                        check_increasing(&xs).map_err(err)?;
                        let k = scale.unwrap_or(1.0);
                        let ys: Vec<f32> = ys.into_iter().map(|y: f32| y * k).collect();
                        if !(k.is_finite() && k >= 0.0) || ys.iter().any(|y| !y.is_finite()) {
                            return Err(InputError::new(
                                self.file,
                                format!("{path}.scale"),
                                format!(
                                    "must be finite and non-negative, with every value × scale \
                                 finite in f32; got scale {k}"
                                ),
                            ));
                        }
                        Spectrum::Tabulated { xs, ys }
                    }
                    SpectrumDesc::Binned { lo, width, values } => {
                        if !(width > 0.0) || values.is_empty() {
                            return Err(err(
                                "a binned spectrum needs width > 0 and at least one value".into(),
                            ));
                        }
                        Spectrum::Binned { lo, width, values }
                    }
                    SpectrumDesc::Colorchecker { patch } => colorchecker(patch).map_err(err)?,
                }
            }
            _ => {
                return Err(err(
                    "expected a spectrum: a number, a spectrum name or an object with a `type`"
                        .into(),
                ));
            }
        };
        check_values(&s).map_err(err)?;
        Ok(s)
    }
}

fn check_increasing(xs: &[f32]) -> Result<(), String> {
    if xs.len() < 2 {
        // Piecewise linear through one point is zero everywhere but at that point: black.
        return Err(format!(
            "a tabulated spectrum needs at least two (wavelength, value) pairs, got {}",
            xs.len()
        ));
    }
    for w in xs.windows(2) {
        if !(w[1] > w[0]) {
            return Err(format!(
                "wavelengths must increase strictly ({} then {})",
                w[0], w[1]
            ));
        }
    }
    Ok(())
}

fn check_values(s: &Spectrum) -> Result<(), String> {
    let vals: Vec<f32> = match s {
        Spectrum::Constant(v) => vec![*v],
        Spectrum::Box { lo, hi, value } => vec![*lo, *hi, *value],
        Spectrum::Gaussian {
            center,
            sigma,
            peak,
        } => vec![*center, *sigma, *peak],
        Spectrum::Tabulated { xs, ys } => xs.iter().chain(ys).copied().collect(),
        Spectrum::Binned { lo, width, values } => std::iter::once(*lo)
            .chain([*width])
            .chain(values.iter().copied())
            .collect(),
    };
    if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
        return Err(format!("spectrum contains a non-finite value ({v})"));
    }
    let values: Vec<f32> = match s {
        Spectrum::Constant(v) => vec![*v],
        Spectrum::Box { value, .. } => vec![*value],
        Spectrum::Gaussian { peak, .. } => vec![*peak],
        Spectrum::Tabulated { ys, .. } => ys.clone(),
        Spectrum::Binned { values, .. } => values.clone(),
    };
    if let Some(v) = values.iter().find(|v| **v < 0.0) {
        return Err(format!("spectrum values must not be negative (found {v})"));
    }
    Ok(())
}

/// Parse `wavelength, value` lines; a non-numeric first line is a header, `#` starts a comment.
pub fn parse_csv(text: &str) -> Result<(Vec<f32>, Vec<f32>), String> {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    // A byte-order mark (spreadsheets write one) would make the first line a "header".
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (i, line) in text.lines().enumerate() {
        let l = line.split('#').next().unwrap_or("").trim();
        if l.is_empty() {
            continue;
        }
        let parts: Vec<&str> = l
            .split([',', ';', '\t', ' '])
            .filter(|s| !s.is_empty())
            .collect();
        let nums: Result<Vec<f32>, _> = parts.iter().map(|p| p.parse::<f32>()).collect();
        match nums {
            Ok(v) if v.len() >= 2 => {
                if !v[0].is_finite() || !v[1].is_finite() {
                    return Err(format!("line {}: non-finite value", i + 1));
                }
                xs.push(v[0]);
                ys.push(v[1]);
            }
            Ok(_) => return Err(format!("line {}: expected 'wavelength, value'", i + 1)),
            Err(_) if xs.is_empty() && i == 0 => continue, // header
            Err(_) => return Err(format!("line {}: '{}' is not a pair of numbers", i + 1, l)),
        }
    }
    if xs.is_empty() {
        return Err("no data lines".into());
    }
    Ok((xs, ys))
}

const MACBETH: &str = include_str!("../../data/spectra/macbeth_patches.csv");

/// ColorChecker patch reflectance (380–730 nm at 10 nm; held constant to the domain's ends so
/// UV and deep red are not black).
pub fn colorchecker(patch: u32) -> Result<Spectrum, String> {
    let mut lines = MACBETH.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<f32> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let rows: Vec<&str> = lines.collect();
    if patch < 1 || patch as usize > rows.len() {
        return Err(format!(
            "ColorChecker patch must be 1–{}, got {patch}",
            rows.len()
        ));
    }
    let ys: Vec<f32> = rows[patch as usize - 1]
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let mut xs = vec![200.0];
    xs.extend(&header);
    xs.push(1000.0);
    let mut y2 = vec![ys[0]];
    y2.extend(&ys);
    y2.push(*ys.last().unwrap());
    Ok(Spectrum::Tabulated { xs, ys: y2 })
}
