"""Gaussian-mixture reradiation models (Hua et al. 2022).

A measured bispectral matrix (BFC) is fitted by a mixture p(λi, λo) of 2-D Gaussians, with
ρ(λi → λo) = S·p(λi, λo) on λo > λi; the renderer samples new wavelengths from its truncated
conditionals. ``fit`` is ``stokes gmm fit``; ``Mixture.save`` writes the same bytes.
"""

from __future__ import annotations

import os
from typing import Union

import numpy as np

from . import _stokes
from ._stokes import Mixture

__all__ = ["Mixture", "fit", "load"]


def fit(
    bfc_path: Union[str, "os.PathLike[str]"],
    components: Union[int, str] = 8,
    seed: int = 0,
    *,
    method: str = "em",
    restarts: int = 8,
    max_iterations: int = 1000,
    tolerance: float = 1e-7,
    scale: str = "integral",
) -> Mixture:
    """Fit a BFC matrix as ``stokes gmm fit`` does, with the same defaults.

    Args:
        bfc_path: the measured matrix (BFC file).
        components: Gaussians per mixture (1–32), or ``"auto"`` / ``"auto:MAX"`` to choose by BIC.
        seed: seed of the k-means++ initialisation; fits are deterministic for a seed.
        method: ``"em"`` (weighted EM) or ``"bayes"`` (weighted variational Bayes).
        restarts: seeded starts; the best final log-likelihood is kept.
        max_iterations, tolerance: the fit's stopping rule.
        scale: how S is set: ``"integral"`` (Hua eq. 5) or ``"error"`` (eq. 4).
    """
    return _stokes.gmm_fit(
        os.fspath(bfc_path), components, seed, method, restarts, max_iterations, tolerance, scale
    )


def load(path: Union[str, "os.PathLike[str]"]) -> Mixture:
    """Read a model file written by ``stokes gmm fit`` or :meth:`Mixture.save`."""
    return _stokes.gmm_load(os.fspath(path))


def _pairs(a, b):
    a, b = np.broadcast_arrays(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    shape = a.shape
    return np.ascontiguousarray(a.ravel()), np.ascontiguousarray(b.ravel()), shape


def _pdf(self: Mixture, lambda_in, lambda_out) -> np.ndarray:
    """The mixture density p(λi, λo) (Hua eq. 1), per nm², at broadcast arrays of wavelengths."""
    a, b, shape = _pairs(lambda_in, lambda_out)
    return self._evaluate("pdf", a, b).reshape(shape)


def _kernel(self: Mixture, lambda_in, lambda_out) -> np.ndarray:
    """The reradiation kernel ρ(λi → λo) = S·p(λi, λo) on λo > λi inside the measured support
    (zero elsewhere), per nm."""
    a, b, shape = _pairs(lambda_in, lambda_out)
    return self._evaluate("kernel", a, b).reshape(shape)


def _pdf_out(self: Mixture, lambda_in, lambda_out) -> np.ndarray:
    """The density of :meth:`sample_out`: λo given λi, per nm."""
    a, b, shape = _pairs(lambda_in, lambda_out)
    return self._evaluate("pdf_out", a, b).reshape(shape)


def _pdf_in(self: Mixture, lambda_out, lambda_in) -> np.ndarray:
    """The density of :meth:`sample_in`: λi given λo, per nm."""
    a, b, shape = _pairs(lambda_out, lambda_in)
    return self._evaluate("pdf_in", a, b).reshape(shape)


def _total_out(self: Mixture, lambda_in) -> np.ndarray:
    """∫ρ(λi → λo) dλo: the fraction of the light at λi that is reradiated."""
    a = np.asarray(lambda_in, dtype=np.float64)
    return self._total_out(np.ascontiguousarray(a.ravel())).reshape(a.shape)


# the array-shaped methods, written over the compiled 1-D ones
Mixture.pdf = _pdf
Mixture.kernel = _kernel
Mixture.pdf_out = _pdf_out
Mixture.pdf_in = _pdf_in
Mixture.total_out = _total_out
