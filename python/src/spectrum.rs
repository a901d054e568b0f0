//! The CIE 1931 observer and the XYZ → linear sRGB matrix the renderer uses.

use numpy::{PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;

/// _cie_xyz(wavelengths) -> numpy.ndarray
///
/// The CIE 1931 2° colour-matching functions x̄, ȳ, z̄ at each wavelength (nm) of a 1-D array,
/// as an (N, 3) float64 array: the renderer's table, linearly interpolated, zero outside
/// 360–830 nm.
#[pyfunction]
#[pyo3(name = "cie_xyz")]
pub fn cie_xyz<'py>(
    py: Python<'py>,
    wavelengths: PyReadonlyArray1<'py, f64>,
) -> Bound<'py, PyArray2<f64>> {
    let l = wavelengths.as_array();
    let a = PyArray2::<f64>::zeros(py, [l.len(), 3], false);
    // SAFETY: the array was just created here and is not shared yet
    let s = unsafe { a.as_slice_mut() }.expect("a new array is contiguous");
    for (d, &w) in s.chunks_mut(3).zip(l.iter()) {
        let c = if w.is_finite() {
            stokes::spectrum::cie::cmf(w as f32)
        } else {
            glam::Vec3::ZERO
        };
        d.copy_from_slice(&[c.x as f64, c.y as f64, c.z as f64]);
    }
    a
}

/// _xyz_to_srgb_matrix() -> numpy.ndarray
///
/// The 3×3 XYZ → linear sRGB (D65) matrix of the renderer's films.
#[pyfunction]
#[pyo3(name = "xyz_to_srgb_matrix")]
pub fn xyz_to_srgb_matrix<'py>(py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
    let m = stokes::spectrum::cie::xyz_to_srgb_matrix();
    let a = PyArray2::<f64>::zeros(py, [3, 3], false);
    // SAFETY: the array was just created here and is not shared yet
    let s = unsafe { a.as_slice_mut() }.expect("a new array is contiguous");
    for r in 0..3 {
        for c in 0..3 {
            s[r * 3 + c] = m.col(c)[r] as f64;
        }
    }
    a
}
