#!/usr/bin/env python3
"""Generate the swatch scenes of the gmm-vs-matrix experiment (Hua 2022).

Writes scenes/gmm-swatches.json (every swatch the measured matrix, material `reradiation`) and
scenes/gmm-swatches-2.json, -4.json, -8.json (the same swatches as `reradiation-gmm` fitted at
load with K = 2, 4, 8 Gaussians, weighted EM, seed 0 and one start (`"restarts": 1`, as when the
gmm-vs-matrix and gmm-sampling results were made); fits are cached, see src/scene/gmm.rs) and
scenes/gmm-swatches-sampled-2.json, -4.json, -8.json (the measured matrices again, their shifts
drawn from those mixtures: `"sampling": {"type": "mixture"}`, the tables' share 0.1).

The 24 materials come from the 144 RIT matrices in data/bispectral/rit/ (IXCAXORA is left out, as
Hua §7.1 does). Each matrix is cleaned as the loader does (Hua §5.1: entries with λo < λi and
negative entries become zero) and ranked by its off-diagonal energy, Σ D over the off-diagonal
cells. Its colour is the one the chart's light gives it (D65 + the UV lamp, the matrix applied
once, CIE 1931 2°, CIELAB relative to the light's white). Then:

  1. 16 strongly fluorescent swatches: from the 40 matrices with the most off-diagonal energy,
     greedily the one whose hue is farthest from the hues already taken (chromatic swatches,
     C*ab >= 21), starting with the most fluorescent; near-neutral fluorescent whites (optical
     brighteners) compete on lightness instead of hue and at most two are taken;
  2. 8 more swatches of any fluorescence that fill the largest remaining hue gaps (C*ab >= 20),
     so that the chart also has weakly or non-fluorescent inks of varied hue.

The chart is ordered by hue (neutrals last). Usage: python3 scripts/make_gmm_swatches.py [--list]
(--list prints every matrix's energy, Lab and hue and does not write the scenes). Python 3,
standard library only.
"""

import csv
import json
import math
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RIT = os.path.join(ROOT, "data", "bispectral", "rit")
EXCLUDED = {"IXCAXORA"}  # Hua §7.1: incorrect measurement
COLS, ROWS = 6, 4
WIDTH, HEIGHT = 384, 256
COMPONENTS = [2, 4, 8]
# Below this CIELAB chroma a swatch counts as neutral (the brightened whites reach C*ab ≈ 20).
NEUTRAL_C = 21.0

# The light: D65 (CSV, scaled) on a large quad, plus a UV lamp (box 300-400 nm) on a smaller one.
D65_FILE = "../data/spectra/illuminants/illuminant_D65.csv"
D65_SCALE = 0.03
UV = {"lo": 300.0, "hi": 400.0, "value": 3.0}
D65_QUAD = (-8.0, 8.0, -4.0, 8.0, 14.0)  # x0, x1, y0, y1, z
UV_QUAD = (-4.0, 4.0, 0.0, 6.0, 13.0)


def area(q):
    return (q[1] - q[0]) * (q[3] - q[2])


def parse_bfc(path):
    """(em_lo, ex_lo, step, D[o][i]) cleaned like BfcMatrix::parse."""
    with open(path, encoding="latin-1") as f:
        lines = [l.strip() for l in f if l.strip()]
    k = 0
    while True:
        l = lines[k]
        k += 1
        if l.startswith(";") or l.startswith("VEC") or l.startswith("BFC"):
            continue
        h = [float(x) for x in l.split()]
        break
    em_lo, em_hi, step, n_ex, ex_lo = h[0], h[1], h[2], int(h[3]), h[4]
    n_em = int(round((em_hi - em_lo) / step)) + 1
    k += 1  # r:c:
    d = [[0.0] * n_ex for _ in range(n_em)]
    for l in lines[k:]:
        if l.upper() == "EOD":
            break
        v = [float(x) for x in l.split()]
        o = int(round((v[0] - em_lo) / step))
        for i in range(n_ex):
            li = ex_lo + i * step
            x = v[i + 1]
            d[o][i] = 0.0 if (v[0] < li - 1e-3 or x < 0) else x
    return em_lo, ex_lo, step, d


def load_cmf():
    cmf = {}
    with open(os.path.join(ROOT, "data", "spectra", "cie1931_2deg_xyz_1nm.csv")) as f:
        r = csv.reader(f)
        next(r)
        for row in r:
            cmf[int(float(row[0]))] = tuple(float(x) for x in row[1:4])
    return cmf


def load_d65():
    xs, ys = [], []
    with open(os.path.join(ROOT, "data", "spectra", "illuminants", "illuminant_D65.csv")) as f:
        for row in csv.reader(f):
            try:
                xs.append(float(row[0]))
                ys.append(float(row[1]))
            except ValueError:
                continue
    return xs, ys


def lerp(xs, ys, x):
    if x < xs[0] or x > xs[-1]:
        return 0.0
    for j in range(1, len(xs)):
        if x <= xs[j]:
            t = (x - xs[j - 1]) / (xs[j] - xs[j - 1])
            return ys[j - 1] * (1 - t) + ys[j] * t
    return ys[-1]


def light(d65, l):
    """Irradiance spectrum of the chart's light up to a constant: D65 and UV by their areas."""
    e = D65_SCALE * lerp(d65[0], d65[1], l) * area(D65_QUAD)
    if UV["lo"] <= l <= UV["hi"]:
        e += UV["value"] * area(UV_QUAD)
    return e


def xyz_to_lab(xyz, white):
    def f(t):
        return t ** (1 / 3) if t > (6 / 29) ** 3 else t / (3 * (6 / 29) ** 2) + 4 / 29

    fx, fy, fz = (f(xyz[c] / white[c]) for c in range(3))
    return (116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz))


def analyse():
    cmf = load_cmf()
    d65 = load_d65()
    out = []
    for name in sorted(os.listdir(RIT)):
        if not name.upper().endswith(".BFC"):
            continue
        stem = name[:-4]
        if stem.upper() in EXCLUDED:
            continue
        em_lo, ex_lo, step, d = parse_bfc(os.path.join(RIT, name))
        energy = 0.0
        xyz = [0.0, 0.0, 0.0]
        white = [0.0, 0.0, 0.0]
        for o, row in enumerate(d):
            lo = em_lo + o * step
            radiance = 0.0
            for i, x in enumerate(row):
                li = ex_lo + i * step
                if abs(lo - li) > 1e-3:
                    energy += x
                radiance += x * light(d65, li)
            c = cmf.get(int(round(lo)))
            if c is None:
                continue
            for k in range(3):
                xyz[k] += radiance * c[k]
                white[k] += light(d65, lo) * c[k]
        lab = xyz_to_lab(xyz, white)
        chroma = math.hypot(lab[1], lab[2])
        hue = math.degrees(math.atan2(lab[2], lab[1])) % 360
        out.append({"stem": stem, "file": name, "energy": energy, "lab": lab, "chroma": chroma, "hue": hue})
    return out


def hue_gap(h, taken):
    if not taken:
        return 360.0
    return min(min(abs(h - t), 360 - abs(h - t)) for t in taken)


def choose(all_m):
    by_energy = sorted(all_m, key=lambda m: -m["energy"])
    pool = by_energy[:40]
    chosen = []
    neutrals = 0
    # 1. strongly fluorescent, hue-diverse.
    while len(chosen) < 16:
        best, best_score = None, -1.0
        for m in pool:
            if m in chosen:
                continue
            if m["chroma"] >= NEUTRAL_C:
                score = hue_gap(m["hue"], [c["hue"] for c in chosen if c["chroma"] >= NEUTRAL_C])
            else:
                if neutrals >= 2:
                    continue
                # Neutral whites: keep them apart in lightness; rank below any hue gap > 10°.
                ls = [c["lab"][0] for c in chosen if c["chroma"] < NEUTRAL_C]
                score = min([abs(m["lab"][0] - l) for l in ls], default=100.0) / 10.0
            # Ties (and the first pick) go to the more fluorescent.
            score += 1e-6 * m["energy"]
            if score > best_score:
                best, best_score = m, score
        if best["chroma"] < NEUTRAL_C:
            neutrals += 1
        chosen.append(best)
    # 2. fill the hue gaps with any chromatic matrix.
    rest = [m for m in all_m if m not in chosen and m["chroma"] >= 20]
    while len(chosen) < COLS * ROWS:
        best = max(
            rest,
            key=lambda m: hue_gap(m["hue"], [c["hue"] for c in chosen if c["chroma"] >= NEUTRAL_C])
            + 1e-3 * m["chroma"],
        )
        rest.remove(best)
        chosen.append(best)
    chromatic = sorted([m for m in chosen if m["chroma"] >= NEUTRAL_C], key=lambda m: m["hue"])
    neutral = sorted([m for m in chosen if m["chroma"] < NEUTRAL_C], key=lambda m: -m["lab"][0])
    return chromatic + neutral, by_energy


def quad(x0, x1, y0, y1, z):
    # Counter-clockwise seen from +z: the normal points at the camera.
    return [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]]


def quad_facing_minus_z(x0, x1, y0, y1, z):
    return [[x0, y0, z], [x0, y1, z], [x1, y1, z], [x1, y0, z]]


def scene(chosen, rank, k, sampled=False):
    size, gap = 1.0, 0.25
    w = COLS * size + (COLS - 1) * gap
    h = ROWS * size + (ROWS - 1) * gap
    names = ", ".join(f"{m['stem'].lower()} (#{rank[m['stem']] + 1})" for m in chosen)
    if k is None:
        kind = "the measured matrices (material `reradiation`)"
    elif sampled:
        kind = (
            "the measured matrices (material `reradiation`, evaluated exactly) with their shifts drawn from Gaussian "
            f"mixtures of K = {k} fitted at load by weighted EM, seed 0, one start (`sampling`: `mixture`, cached), the tables' "
            "share 0.1 (Hua's sampling-only use)"
        )
    else:
        kind = f"Gaussian mixtures of K = {k} fitted at load by weighted EM, seed 0, one start (material `reradiation-gmm`, cached)"

    comment = (
        "gmm-vs-matrix (Hua 2022): 24 RIT bispectral swatches laid out like a ColorChecker (6×4 quads "
        "on a dark Lambertian backdrop, reflectance 0.05), each swatch named after its material (the "
        f"BFC file's stem in lower case); here {kind}. Light: D65 (illuminant_D65.csv × {D65_SCALE}) on a "
        f"16×12 quad behind the camera plus a UV lamp (box {UV['lo']:.0f}–{UV['hi']:.0f} nm, {UV['value']}) on an "
        "8×6 quad in front of it; domain [280, 780] nm. How the 24 were chosen (scripts/make_gmm_swatches.py): "
        "the 143 RIT matrices (IXCAXORA left out, as Hua §7.1) are ranked by off-diagonal energy Σ D over the "
        "off-diagonal cells after cleaning (Hua §5.1); 16 come from the 40 most fluorescent, picked greedily to "
        "spread their CIELAB hue under this light (at most two near-neutral brightened whites); 8 more, of any "
        "fluorescence, fill the largest remaining hue gaps. Ordered by hue, neutrals last; (#n) is the energy rank: "
        + names
        + "."
    )
    materials = {}
    shapes = []
    x_left = -w / 2
    y_top = h / 2
    for idx, m in enumerate(chosen):
        r, c = divmod(idx, COLS)
        x0 = x_left + c * (size + gap)
        y1 = y_top - r * (size + gap)
        name = m["stem"].lower()
        path = f"../data/bispectral/rit/{m['file']}"
        if k is None:
            materials[name] = {"type": "reradiation", "file": path}
        elif sampled:
            materials[name] = {
                "type": "reradiation",
                "file": path,
                "sampling": {"type": "mixture", "components": k, "method": "em", "seed": 0, "restarts": 1, "defensive": 0.1},
            }
        else:
            materials[name] = {"type": "reradiation-gmm", "bfc": path, "components": k, "method": "em", "seed": 0, "restarts": 1}
        shapes.append({"type": "quad", "name": name, "material": name, "corners": quad(x0, x0 + size, y1 - size, y1, 0.0)})
    materials["backdrop"] = {"type": "lambert", "reflectance": 0.05}
    materials["black"] = {"type": "lambert", "reflectance": 0.0}
    shapes.append({"type": "quad", "name": "backdrop", "material": "backdrop", "corners": quad(-w / 2 - 0.6, w / 2 + 0.6, -h / 2 - 0.6, h / 2 + 0.6, -0.01)})
    shapes.append(
        {
            "type": "quad",
            "name": "lamp-uv",
            "material": "black",
            "corners": quad_facing_minus_z(*UV_QUAD),
            "emission": {"spectrum": {"type": "box", **UV}},
        }
    )
    shapes.append(
        {
            "type": "quad",
            "name": "lamp-d65",
            "material": "black",
            "corners": quad_facing_minus_z(*D65_QUAD),
            "emission": {"spectrum": {"type": "tabulated", "file": D65_FILE}, "scale": D65_SCALE},
        }
    )
    # The chart (7.25 × 4.75) fills the 3:2 frame with a margin of backdrop.
    fov = 2 * math.degrees(math.atan((w / 2 + 0.45) / 10.0))
    return {
        "comment": comment,
        "domain": [280, 780],
        "camera": {"origin": [0, 0, 10], "target": [0, 0, 0], "fov": round(fov, 4), "fov_axis": "x", "width": WIDTH, "height": HEIGHT},
        "materials": materials,
        "shapes": shapes,
    }


def main():
    all_m = analyse()
    chosen, by_energy = choose(all_m)
    rank = {m["stem"]: i for i, m in enumerate(by_energy)}
    if "--list" in sys.argv:
        for i, m in enumerate(by_energy):
            mark = "*" if m in chosen else " "
            L, a, b = m["lab"]
            print(f"{mark} {i + 1:3d} {m['stem']:10s} energy {m['energy']:8.3f}  L {L:5.1f} a {a:6.1f} b {b:6.1f}  C {m['chroma']:5.1f} h {m['hue']:5.1f}")
        return
    out = os.path.join(ROOT, "scenes")
    for k, sampled in [(None, False)] + [(k, False) for k in COMPONENTS] + [(k, True) for k in COMPONENTS]:
        if k is None:
            name = "gmm-swatches.json"
        elif sampled:
            name = f"gmm-swatches-sampled-{k}.json"
        else:
            name = f"gmm-swatches-{k}.json"
        with open(os.path.join(out, name), "w") as f:
            json.dump(scene(chosen, rank, k, sampled), f, indent=1, ensure_ascii=False)
            f.write("\n")
        print(f"wrote scenes/{name}")
    for m in chosen:
        print(f"  {m['stem']:10s} rank {rank[m['stem']] + 1:3d} energy {m['energy']:7.3f} C {m['chroma']:5.1f} h {m['hue']:5.1f}")


if __name__ == "__main__":
    main()
