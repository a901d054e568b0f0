//! The wavelength domain, the camera and its sensor, checked as they are built.

use super::checks::{at, finite3};
use super::format::{CameraDesc, FovAxis};
use super::limits::{MAX_WAVELENGTH, MIN_FOV};
use super::spectra::SpectrumContext;
use crate::geometry::Camera;
use crate::io::InputError;
use crate::io::limits::{MAX_PIXELS, MAX_SIDE};
use crate::spectrum::cie::Sensor;
use crate::spectrum::{DEFAULT_DOMAIN, Domain, Spectrum};
use glam::Vec3;
use std::path::Path;

/// The wavelength domain: the file's, checked, or the default.
pub(super) fn domain(path: &Path, d: Option<[f32; 2]>) -> Result<Domain, InputError> {
    match d {
        None => Ok(DEFAULT_DOMAIN),
        Some([a, b]) => {
            if !(a.is_finite() && b.is_finite() && a >= 0.0 && a < b) {
                return Err(at(
                    path,
                    "domain",
                    format!("needs 0 ≤ min < max, got [{a}, {b}]"),
                ));
            }
            if b > MAX_WAVELENGTH {
                return Err(at(
                    path,
                    "domain",
                    format!(
                        "must lie within [0, {MAX_WAVELENGTH}] nm (spectra are tabulated in 1-nm \
                         cells over it), got [{a:?}, {b:?}]"
                    ),
                ));
            }
            Ok(Domain { min: a, max: b })
        }
    }
}

pub(super) fn camera(path: &Path, c: &CameraDesc) -> Result<Camera, InputError> {
    let origin = finite3(path, "camera.origin", c.origin)?;
    let target = finite3(path, "camera.target", c.target)?;
    let up = finite3(path, "camera.up", c.up)?;
    let forward = (target - origin).normalize_or_zero();
    if forward == Vec3::ZERO {
        return Err(at(
            path,
            "camera.target",
            "must differ from camera.origin".into(),
        ));
    }
    if up.normalize_or_zero() == Vec3::ZERO {
        return Err(at(path, "camera.up", "must not be zero".into()));
    }
    if forward.cross(up.normalize()).length() < 1e-6 {
        return Err(at(
            path,
            "camera.up",
            "must not be parallel to the viewing direction".into(),
        ));
    }
    if !(c.fov >= MIN_FOV && c.fov < 180.0) {
        // Below MIN_FOV the film's area underflows in f32 and the camera's pdfs overflow.
        return Err(at(
            path,
            "camera.fov",
            format!("must be in [{MIN_FOV}, 180) degrees, got {}", c.fov),
        ));
    }
    for (v, field) in [(c.width, "camera.width"), (c.height, "camera.height")] {
        if !(1..=MAX_SIDE).contains(&v) {
            return Err(at(
                path,
                field,
                format!("must be 1–{MAX_SIDE} pixels, got {v}"),
            ));
        }
    }
    if c.width as u64 * c.height as u64 > MAX_PIXELS {
        return Err(at(
            path,
            "camera.height",
            format!(
                "{}×{} is more than {MAX_PIXELS} pixels (the film would not fit in memory)",
                c.width, c.height
            ),
        ));
    }
    Ok(Camera::look_at(
        origin,
        target,
        up,
        c.fov,
        c.fov_axis == FovAxis::X,
        c.width,
        c.height,
    ))
}

/// The camera's `sensor`: absent or `"cie-1931"`, `{"band": [lo, hi]}` (nm, lo < hi) or
/// `{"response": SPECTRUM}` (any spectrum the scene format takes).
pub(super) fn sensor(
    ctx: &SpectrumContext,
    v: Option<&serde_json::Value>,
) -> Result<Sensor, InputError> {
    use serde_json::Value;
    const FIELD: &str = "camera.sensor";
    let err = |field: &str, m: &str| Err(InputError::new(ctx.file, field, m.to_string()));
    let Some(v) = v else {
        return Ok(Sensor::Cie1931);
    };
    match v {
        Value::String(s) if s == "cie-1931" => Ok(Sensor::Cie1931),
        Value::Object(o) if o.len() == 1 && o.contains_key("band") => {
            let band = &o["band"];
            let pair = band.as_array().and_then(|a| {
                let lo = a.first()?.as_f64()?;
                let hi = a.get(1)?.as_f64()?;
                (a.len() == 2).then_some((lo as f32, hi as f32))
            });
            match pair {
                Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo < hi => {
                    Ok(Sensor::Response(Spectrum::Box { lo, hi, value: 1.0 }))
                }
                Some((lo, hi)) => err(
                    "camera.sensor.band",
                    &format!("needs finite wavelengths lo < hi in nm, got [{lo}, {hi}]"),
                ),
                None => err(
                    "camera.sensor.band",
                    "must be two wavelengths in nm, [lo, hi]",
                ),
            }
        }
        Value::Object(o) if o.len() == 1 && o.contains_key("response") => Ok(Sensor::Response(
            ctx.parse(&o["response"], "camera.sensor.response")?,
        )),
        _ => err(
            FIELD,
            "must be \"cie-1931\", {\"band\": [lo, hi]} or {\"response\": SPECTRUM}",
        ),
    }
}
