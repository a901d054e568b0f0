"""Spectra and colour: the CIE 1931 observer and the XYZ → linear sRGB conversion that the
renderer's films use."""

from __future__ import annotations

import numpy as np

from . import _stokes

__all__ = ["cie_xyz", "xyz_to_srgb", "XYZ_TO_SRGB"]

#: The 3×3 XYZ → linear sRGB (D65) matrix (from the sRGB primaries and white point).
XYZ_TO_SRGB: np.ndarray = _stokes.xyz_to_srgb_matrix()


def cie_xyz(wavelengths) -> np.ndarray:
    """The CIE 1931 2° colour-matching functions at ``wavelengths`` (nm, any shape).

    Returns an array of shape ``wavelengths.shape + (3,)`` (x̄, ȳ, z̄), float64: the renderer's
    1 nm table, linearly interpolated, zero outside 360–830 nm.
    """
    w = np.asarray(wavelengths, dtype=np.float64)
    out = _stokes.cie_xyz(np.ascontiguousarray(w.ravel()))
    return out.reshape(w.shape + (3,))


def xyz_to_srgb(xyz) -> np.ndarray:
    """Convert CIE XYZ to linear sRGB (D65); the last axis holds the three components.

    Float32 input (e.g. ``Render.xyz``) gives float32, as the renderer computes it; other input
    gives float64.
    """
    x = np.asarray(xyz)
    if x.shape[-1:] != (3,):
        raise ValueError(f"xyz_to_srgb: the last axis must have length 3, got shape {x.shape}")
    dtype = np.float32 if x.dtype == np.float32 else np.float64
    return np.ascontiguousarray(x.astype(dtype, copy=False) @ XYZ_TO_SRGB.T.astype(dtype))
