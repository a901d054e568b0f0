//! The scene's materials, built from their descriptions, with the reflectance of a passive
//! surface checked.

use super::checks::at;
use super::format::MaterialDesc;
use super::gmm;
use super::limits::MAX_REFLECTANCE;
use super::spectra::SpectrumContext;
use crate::io::InputError;
use crate::material::{FluorescentDiffuse, Lambert, Material, Reradiation};
use crate::spectrum::Spectrum;

/// A passive surface reflects at most the light it receives: the reflectance of material
/// `base` may not exceed [`MAX_REFLECTANCE`] anywhere on the domain (beyond f32 rounding), or
/// path throughputs grow with every bounce until they overflow. The fluorescent material's
/// total albedo, r(1 − c·a) + c·a·Φ·∫e, is then at most 1 too, since a ≤ 1, ∫e = 1 and c, Φ ≤ 1.
pub(super) fn check_reflectance(
    ctx: &SpectrumContext,
    base: &str,
    r: &Spectrum,
) -> Result<(), InputError> {
    let d = ctx.domain;
    let max = r.max_value(d);
    if max <= MAX_REFLECTANCE * (1.0 + 1e-6) {
        return Ok(());
    }
    let shown = if max < 1e6 {
        max.to_string()
    } else {
        format!("{max:e}")
    };
    // Where it is largest, to a quarter nm.
    let n = ((d.width() * 4.0) as usize).max(1);
    let at_max = (0..=n)
        .map(|i| d.min + d.width() * i as f32 / n as f32)
        .fold((d.min, f32::MIN), |best, l| {
            let v = r.eval(l);
            if v > best.1 { (l, v) } else { best }
        })
        .0;
    Err(at(
        ctx.file,
        &format!("{base}.reflectance"),
        format!(
            "is {shown} at {at_max} nm, above {MAX_REFLECTANCE}: a passive surface reflects at most \
             the light it receives"
        ),
    ))
}

/// The material `desc` found at JSON path `base`; warnings about it go to `warnings`.
pub(super) fn material(
    ctx: &SpectrumContext,
    base: &str,
    desc: MaterialDesc,
    warnings: &mut Vec<String>,
) -> Result<Material, InputError> {
    let err = |p: &str, m: String| at(ctx.file, p, m);
    let domain = ctx.domain;
    if !cfg!(feature = "fluorescence") && !matches!(desc, MaterialDesc::Lambert { .. }) {
        return Err(err(
            &format!("{base}.type"),
            "this build of stokes has no fluorescent materials (built without the \
             `fluorescence` cargo feature); rebuild with the default features"
                .into(),
        ));
    }
    Ok(match desc {
        MaterialDesc::Lambert { reflectance } => {
            let r = ctx.parse(&reflectance, &format!("{base}.reflectance"))?;
            check_reflectance(ctx, base, &r)?;
            Material::Lambert(Lambert { reflectance: r })
        }
        #[cfg(feature = "fluorescence")]
        MaterialDesc::FluorescentDiffuse {
            reflectance,
            absorption,
            emission,
            quantum_yield,
            concentration,
        } => {
            for (v, n) in [
                (quantum_yield, "quantum_yield"),
                (concentration, "concentration"),
            ] {
                if !(0.0..=1.0).contains(&v) {
                    return Err(err(
                        &format!("{base}.{n}"),
                        format!("must be in [0, 1], got {v}"),
                    ));
                }
            }
            let r = ctx.parse(&reflectance, &format!("{base}.reflectance"))?;
            let a = ctx.parse(&absorption, &format!("{base}.absorption"))?;
            let e = ctx.parse(&emission, &format!("{base}.emission"))?;
            check_reflectance(ctx, base, &r)?;
            let (m, w) = FluorescentDiffuse::new(r, a, e, quantum_yield, concentration, domain)
                .map_err(|(f, m)| err(&format!("{base}.{f}"), m))?;
            warnings.extend(w.into_iter().map(|w| format!("{base}: {w}")));
            Material::Fluorescent(m)
        }
        #[cfg(feature = "fluorescence")]
        MaterialDesc::Reradiation { file, sampling } => {
            let full = ctx.dir.join(&file);
            let bytes = crate::io::input::read_bytes(&full, crate::io::input::BFC)
                .map_err(|e| err(&format!("{base}.file"), e))?;
            let m = std::str::from_utf8(&bytes)
                .map_err(|e| e.to_string())
                .and_then(crate::material::reradiation::BfcMatrix::parse)
                .map_err(|m| {
                    err(
                        &format!("{base}.file"),
                        format!("malformed BFC file '{}': {m}", full.display()),
                    )
                })?;
            let sampler = match sampling {
                None => None,
                Some(v) => {
                    let at = format!("{base}.sampling");
                    let desc = crate::io::json::from_tagged_value(ctx.file, &at, "type", &v)?;
                    let src = (&m, bytes.as_slice(), file.as_str());
                    gmm::sampler(ctx.file, &ctx.dir, &at, desc, src, domain, warnings)?
                }
            };
            let r = Reradiation::new(m, domain);
            Material::Reradiation(match sampler {
                Some(s) => r.with_sampler(s),
                None => r,
            })
        }
        #[cfg(feature = "fluorescence")]
        MaterialDesc::ReradiationGmm {
            file,
            bfc,
            components,
            method,
            seed,
            restarts,
        } => {
            let src = gmm::GmmSource {
                file,
                bfc,
                components,
                method,
                seed,
                restarts,
            };
            let f = gmm::load(ctx.file, &ctx.dir, base, src, warnings)?;
            Material::ReradiationGmm(crate::material::ReradiationGmm::new(&f, domain))
        }
        #[cfg(not(feature = "fluorescence"))]
        _ => unreachable!("refused above"),
    })
}
