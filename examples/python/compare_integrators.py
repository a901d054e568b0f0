"""Render the fluorescent walls with every integrator at equal time and plot relMSE against time.

    pip install ./python matplotlib
    python examples/python/compare_integrators.py [--budgets 0.25,0.5,1,2] [--out compare_integrators.png]

A reference is rendered first (bdpt-allbins at 8192 spp, about a minute on 2 cores; cached as a
.npy beside the plot: the walls' spectra are boxes aligned to its 5 nm bins, so it has no
wavelength noise, as in experiments/walls-integrators.json), then
each integrator renders the scene once per time budget (`time_limit`). relMSE is the
experiment runner's: the mean over pixels and channels of (x − ref)² / (ref² + 0.01). The
runner (`stokes experiment experiments/walls-integrators.json`) does this with repeats, regions
and figures; this script shows the same comparison in a few lines of Python.
"""

import argparse
from pathlib import Path

import numpy as np

import stokes

REPO = Path(__file__).resolve().parents[2]
REL_EPS = 1e-2


def rel_mse(img, ref):
    return float(np.mean((img.astype(np.float64) - ref) ** 2 / (ref * ref + REL_EPS)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=str(REPO / "scenes" / "fluorescent-walls.json"))
    ap.add_argument("--budgets", default="0.25,0.5,1,2", help="seconds, comma-separated")
    ap.add_argument("--size", type=int, default=128, help="image width and height")
    ap.add_argument("--reference-spp", type=int, default=8192)
    ap.add_argument("--integrators", default=",".join(stokes.integrators()))
    ap.add_argument("--out", default="compare_integrators.png")
    a = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene_file = Path(a.scene)
    d = stokes.load_scene(scene_file).to_dict()
    d["camera"]["width"] = d["camera"]["height"] = a.size
    scene = stokes.Scene.from_dict(d, base_dir=scene_file.parent, name=scene_file.name)
    cache = Path(a.out).with_suffix(f".reference-{a.size}-{a.reference_spp}.npy")
    if cache.is_file():
        ref = np.load(cache)
    else:
        print(f"reference: bdpt-allbins, {a.reference_spp} spp ...", flush=True)
        ref = scene.render("bdpt-allbins", spp=a.reference_spp, seed=1_000_000).rgb
        ref = ref.astype(np.float64)
        np.save(cache, ref)
    budgets = [float(b) for b in a.budgets.split(",")]
    fig, ax = plt.subplots(figsize=(5.5, 3.8), dpi=120)
    print(f"{'integrator':>14}  {'budget s':>8}  {'spp':>5}  {'relMSE':>10}")
    for name in a.integrators.split(","):
        times, errs = [], []
        for b in budgets:
            r = scene.render(name, spp=1_000_000, seed=7, time_limit=b)
            e = rel_mse(r.rgb, ref)
            times.append(r.seconds)
            errs.append(e)
            print(f"{name:>14}  {b:8.2f}  {r.spp:5d}  {e:10.3e}", flush=True)
        ax.loglog(times, errs, "o-", label=name)
    from matplotlib.ticker import FixedLocator, NullFormatter

    ax.xaxis.set_major_locator(FixedLocator(budgets))
    ax.xaxis.set_major_formatter(lambda x, _: f"{x:g}")
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("render time (s)")
    ax.set_ylabel("relMSE")
    ax.set_title(f"fluorescent walls {a.size}², equal time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
