"""stokes: fluorescence in spectral light transport, from Python.

Load a scene, render it into NumPy arrays, run experiments and fit Gaussian-mixture
reradiation models, over the same library the ``stokes`` command line uses (no subprocess)::

    import stokes
    scene = stokes.load_scene("scenes/cornell-box.json")
    r = scene.render("pt-hero", spp=64, seed=0)
    r.rgb            # (H, W, 3) float32, linear sRGB
    r.save_exr("out.exr")

Bad input raises :class:`InputError` (a ``ValueError``) naming the file and the field.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Union

import numpy as np

from . import _stokes
from ._stokes import InputError, Render, Scene, __version__
from . import gmm, spectrum

__all__ = [
    "InputError",
    "Scene",
    "Render",
    "Run",
    "load_scene",
    "read_exr",
    "integrators",
    "default_options",
    "run_experiment",
    "load_run",
    "gmm",
    "spectrum",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]


def _srgb(self: Render, exposure: float = 0.0) -> np.ndarray:
    """The image display-encoded: linear sRGB times 2**exposure, clipped to [0, 1], through
    the sRGB transfer curve; (H, W, 3) float32, ready for ``matplotlib.pyplot.imshow``."""
    x = np.clip(self.rgb * np.float32(2.0 ** exposure), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055).astype(
        np.float32
    )


def _repr_png_(self: Render) -> bytes:
    """The image as PNG bytes (sRGB, 8 bits): Jupyter shows a Render as its image."""
    import struct
    import zlib

    px = np.round(_srgb(self) * 255.0).astype(np.uint8)
    h, w, _ = px.shape
    raw = b"".join(b"\x00" + px[y].tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data) & 0xFFFFFFFF
        )

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 6))
            + chunk(b"IEND", b""))


# display helpers, written over the compiled class
Render.srgb = _srgb
Render._repr_png_ = _repr_png_


def load_scene(path: PathLike) -> Scene:
    """Load and check a scene file (JSON; docs/scene-format.md) and build its BVH.

    Raises :class:`InputError` with ``file`` and ``field`` set when the scene is malformed.
    """
    return _stokes.load_scene(os.fspath(path))


def read_exr(path: PathLike) -> np.ndarray:
    """Read an RGB OpenEXR (e.g. one the CLI wrote) as an (H, W, 3) float32 array."""
    return _stokes.read_exr(os.fspath(path))


def integrators() -> List[str]:
    """The names of the integrators ``Scene.render`` takes."""
    return list(_stokes.integrators())


def default_options() -> Dict[str, Any]:
    """The integrator options ``Scene.render`` takes as keywords, with their defaults."""
    return dict(_stokes.default_options())


#: The columns of a run's metrics, as in ``metrics.csv``, and their NumPy types.
METRICS_DTYPE = np.dtype(
    [
        ("variant", "U64"),
        ("integrator", "U32"),
        ("mode", "U8"),
        ("budget", "f8"),
        ("repeat", "u4"),
        ("seed", "u8"),
        ("spp", "u4"),
        ("seconds", "f8"),
        ("samples_per_second", "f8"),
        ("region", "U64"),
        ("pixels", "u8"),
        ("mse", "f8"),
        ("rel_mse", "f8"),
        ("snr_db", "f8"),
        ("efficiency", "f8"),
    ]
)


class Run:
    """A stored experiment run, read by :func:`load_run` or returned by :func:`run_experiment`.

    Attributes:
        path: the run folder.
        info: the run record (``run.json``) as a dict: the config, size, budgets, regions.
        metrics: one dict per (variant, budget, repeat, region): ``metrics.csv``'s rows.
        summary: mean and spread over the repeats (``summary.json``), a list of dicts.
        images: the snapshot EXRs, sorted by name.
        reference: the reference EXR, or None.
        figures: the figure files (SVG, PNG), sorted by name.
        report: ``report.html``, or None.
        sweep: for a sweep, its record (``sweep.json``); None otherwise.
        points: for a sweep, the run folder of each value (load each with :func:`load_run`).
    """

    def __init__(self, d: Dict[str, Any]):
        self.path: Path = Path(d["path"])
        self.info: Dict[str, Any] = d["info"]
        self.metrics: List[Dict[str, Any]] = list(d["metrics"])
        self.summary: List[Dict[str, Any]] = list(d["summary"])
        self.images: List[Path] = [Path(p) for p in d["images"]]
        self.reference: Optional[Path] = Path(d["reference"]) if d["reference"] else None
        self.figures: List[Path] = [Path(p) for p in d["figures"]]
        self.report: Optional[Path] = Path(d["report"]) if d["report"] else None
        self.sweep: Optional[Dict[str, Any]] = d.get("sweep")
        self.points: List[Path] = [Path(p) for p in d["points"]]

    @property
    def name(self) -> str:
        """The experiment's name (the config's ``name``)."""
        return str(self.info["config"]["name"])

    def metrics_array(self) -> np.ndarray:
        """The metrics as a structured NumPy array (one record per row; see ``METRICS_DTYPE``)."""
        names = METRICS_DTYPE.names
        return np.array([tuple(r[n] for n in names) for r in self.metrics], dtype=METRICS_DTYPE)

    def __repr__(self) -> str:
        return f"Run('{self.path}', {len(self.metrics)} metric rows, {len(self.images)} images)"


def run_experiment(
    config: Union[PathLike, Dict[str, Any]],
    quick: bool = False,
    out: Optional[PathLike] = None,
    base_dir: Optional[PathLike] = None,
) -> Run:
    """Run an experiment config as ``stokes experiment`` does and return the run.

    Args:
        config: a config file, or the config as a dict (experiments/README.md). A dict's
            relative paths (its ``scene``) resolve from ``base_dir`` (default: the current
            folder).
        quick: small resolution, few samples, one repeat (a smoke test); results go to
            ``results/quick`` unless ``out`` is given.
        out: the results root (default ``results``); the run goes to
            ``<out>/<name>/runs/<timestamp>/``.

    The GIL is released while it runs. Ctrl-C stops it and raises ``KeyboardInterrupt``; the
    run folder then keeps its marker of an incomplete run. Raises :class:`InputError` for a
    malformed config.
    """
    if isinstance(config, dict):
        cfg: Any = config
    else:
        cfg = os.fspath(config)
    run_dir = _stokes.run_experiment(
        cfg,
        quick,
        None if out is None else os.fspath(out),
        None if base_dir is None else os.fspath(base_dir),
    )
    return load_run(run_dir)


def load_run(path: PathLike) -> Run:
    """Read a stored run folder, or an experiment's folder (through its ``latest``).

    The folder is checked as the CLI checks it before trusting it: complete (no marker of an
    interrupted run), no links out of it, a well-formed ``run.json``, ``metrics.csv`` and
    ``summary.json``.
    """
    return Run(_stokes.load_run(os.fspath(path)))
