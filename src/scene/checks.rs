//! Checks shared by the scene's builders: an error at a JSON field, and points that f32 ray
//! tracing can carry.

use super::limits::MAX_COORD;
use crate::io::InputError;
use glam::Vec3;
use std::path::Path;

/// An error at JSON path `field` of `file`.
pub(super) fn at(file: &Path, field: &str, message: String) -> InputError {
    InputError::new(file, field, message)
}

pub(super) fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// The point `a`, found at JSON path `path`, if its coordinates are finite and within
/// ±[`MAX_COORD`].
pub(super) fn finite3(file: &Path, path: &str, a: [f32; 3]) -> Result<Vec3, InputError> {
    check_point(a)
        .map(|()| v3(a))
        .map_err(|m| InputError::new(file, path, m))
}

/// Why point `a` cannot be traced in f32, if it cannot.
pub(super) fn check_point(a: [f32; 3]) -> Result<(), String> {
    if !a.iter().all(|x| x.is_finite()) {
        Err(format!("coordinates must be finite numbers, got {a:?}"))
    } else if !a.iter().all(|x| x.abs() <= MAX_COORD) {
        Err(format!(
            "coordinates must be within ±{MAX_COORD:e} (larger ones overflow f32 ray tracing), got {a:?}"
        ))
    } else {
        Ok(())
    }
}

/// An error at field `field` of the shape at JSON path `base` (the shape itself if empty).
pub(super) fn shape_err(file: &Path, base: &str, field: &str, m: String) -> InputError {
    if field.is_empty() {
        InputError::new(file, base, m)
    } else {
        InputError::new(file, format!("{base}.{field}"), m)
    }
}
