"""Sweep the fluorophore concentration of the fluorescent walls and plot the image mean.

    pip install ./python matplotlib
    python examples/python/sweep_concentration.py [--spp 64] [--out sweep_concentration.png]

The scene is loaded once as a dict; each value of the sweep changes the `concentration` of
the four fluorescent walls in that dict and renders it with `stokes.Scene.from_dict`: no JSON
files are written. The plot shows the mean linear sRGB of the image against the
concentration, and a table is printed. The light is ultraviolet only (300-360 nm, which the
camera does not see) and each wall is lit by the one before it in the chain, so at c = 0 the
image is black.
"""

import argparse
from pathlib import Path

import numpy as np

import stokes

REPO = Path(__file__).resolve().parents[2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=str(REPO / "scenes" / "fluorescent-walls.json"))
    ap.add_argument("--values", default="0,0.05,0.1,0.2,0.3,0.5,0.7,1",
                    help="concentrations in [0, 1], comma-separated")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=128, help="image width and height")
    ap.add_argument("--integrator", default="pt-hero")
    ap.add_argument("--out", default="sweep_concentration.png")
    a = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene_file = Path(a.scene)
    base = stokes.load_scene(scene_file).to_dict()
    base["camera"]["width"] = base["camera"]["height"] = a.size
    fluorescent = [n for n, m in base["materials"].items() if "concentration" in m]
    values = [float(v) for v in a.values.split(",")]
    means = []
    print(f"{'concentration':>13}  {'R':>8} {'G':>8} {'B':>8}  seconds")
    for c in values:
        d = dict(base, materials={n: dict(m) for n, m in base["materials"].items()})
        for n in fluorescent:
            d["materials"][n]["concentration"] = c
        r = stokes.Scene.from_dict(d, base_dir=scene_file.parent).render(
            a.integrator, spp=a.spp, seed=1)
        m = r.rgb.reshape(-1, 3).mean(axis=0)
        means.append(m)
        print(f"{c:13.3f}  {m[0]:8.4f} {m[1]:8.4f} {m[2]:8.4f}  {r.seconds:.2f}")
    means = np.array(means)
    fig, ax = plt.subplots(figsize=(5, 3.4), dpi=120)
    for i, (name, col) in enumerate(zip("RGB", ("tab:red", "tab:green", "tab:blue"))):
        ax.plot(values, means[:, i], "o-", color=col, label=name)
    ax.set_xlabel("concentration c of the four fluorescent walls")
    ax.set_ylabel("image mean (linear sRGB)")
    ax.set_title(f"fluorescent walls, {a.integrator}, {a.spp} spp")
    ax.legend()
    fig.tight_layout()
    fig.savefig(a.out)
    print(f"wrote {a.out} ({', '.join(fluorescent)} swept)")


if __name__ == "__main__":
    main()
