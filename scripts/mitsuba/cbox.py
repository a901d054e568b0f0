#!/usr/bin/env python3
"""Mitsuba 3 reference renders of the stokes Cornell box (plain or with a participating medium).

The scene is built in memory from the shared geometry description
(``scripts/mitsuba/cornell_box_geometry.json``, the Mitsuba 3 benchmark's description that
scenes/cornell-box.json was rebuilt from): the wall/box/light quads as
triangle meshes (triangulated (c0,c1,c2), (c0,c2,c3)), two-sided Lambertian
materials with piecewise-linear ``irregular`` reflectance spectra, a one-sided
``area`` light with ``uniform`` radiance 10 on the light quad (which faces -y),
a look-at ``perspective`` pinhole camera (fov along x), an ``independent``
sampler and a 256x256 ``hdrfilm`` (rgb, box filter).

Scenes:
  default      plain Cornell box, integrator ``path``, max_depth 8, rr_depth 1000.
  --medium     adds the cube [bounds_min, bounds_max] of ``medium_variant`` with a
               ``null`` BSDF (index-matched, invisible boundary) whose interior is a
               ``homogeneous`` medium (sigma_t 0.75, albedo 0.8, isotropic phase);
               integrator ``volpath``, max_depth 16, rr_depth 1000.
  --grid F.vol same boundary cube, but the interior is a ``heterogeneous`` medium
               whose sigma_t is a ``gridvolume`` loaded from F.vol, multiplied by
               --density-scale (the medium's ``scale``), constant --albedo,
               isotropic phase. The grid is placed on the bounding box stored in
               the .vol header (Mitsuba itself would put it on [0,1]^3).

Output: one JSON object on stdout with the variant, spp, render seconds (of a
second, timed render: a warm-up render with the same settings runs first so
that JIT compilation / kernel loading is excluded), samples_per_second
(= width*height*spp/seconds), cpu_seconds (process CPU time of that render, all
threads; wall-clock numbers suffer if the machine is shared) and mean Y = 0.2126 R + 0.7152 G + 0.0722 B of the
linear sRGB image over the whole image and its four quadrants (row 0 = top).
With --seeds K>1, K renders with seeds S..S+K-1 are made and the mean and
standard error of mean Y across seeds are reported as well.

Install (Debian, Python 3):
  pip install mitsuba==3.9.1 numpy  # add --break-system-packages if pip refuses
  apt-get update && apt-get install -y libllvm19     # for the llvm_* variants
  export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so

Example (from the repository root):
  python3 scripts/mitsuba/cbox.py --medium --variant llvm_ad_spectral \\
      --spp 256 --seed 0 --threads 2 --out /tmp/cbox-medium.exr
"""

import argparse
import json
import math
import os
import struct
import sys
import time

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT_GEOMETRY = os.path.join(REPO_ROOT, "scripts", "mitsuba", "cornell_box_geometry.json")


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("geometry_pos", nargs="?", default=None, metavar="GEOMETRY",
                   help="scene JSON (default: %s)" % DEFAULT_GEOMETRY)
    p.add_argument("--geometry", default=None, help="scene JSON (same as the positional)")
    p.add_argument("--variant", default="llvm_ad_spectral",
                   help="Mitsuba variant (llvm_ad_spectral, scalar_spectral, ...)")
    p.add_argument("--medium", action="store_true", help="add the homogeneous-medium cube")
    p.add_argument("--grid", default=None, metavar="FILE.vol",
                   help="heterogeneous medium: sigma_t grid (Mitsuba .vol, 1 channel)")
    p.add_argument("--density-scale", type=float, default=1.0,
                   help="multiplier of the grid's sigma_t (--grid only)")
    p.add_argument("--albedo", type=float, default=None,
                   help="single-scattering albedo (--grid; default: medium_variant.albedo)")
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--seeds", type=int, default=1,
                   help="number of independent renders (seeds seed..seed+K-1)")
    p.add_argument("--spp-per-pass", type=int, default=0,
                   help="split each render into passes of this many spp (llvm memory; 0 = one pass)")
    p.add_argument("--max-depth", type=int, default=None,
                   help="override the integrator's max_depth")
    p.add_argument("--threads", type=int, default=0, help="CPU threads (0 = all cores)")
    p.add_argument("--no-warmup", action="store_true", help="skip the warm-up render")
    p.add_argument("--out", default=None, metavar="FILE.exr",
                   help="write the image (with --seeds K>1: the average of the K renders)")
    a = p.parse_args(argv)
    if a.geometry and a.geometry_pos and a.geometry != a.geometry_pos:
        p.error("geometry given twice")
    a.geometry = a.geometry or a.geometry_pos or DEFAULT_GEOMETRY
    if a.grid and a.medium:
        p.error("--medium and --grid are exclusive")
    return a


def read_vol_header(path):
    """Returns (xres, yres, zres, channels, bbox_min, bbox_max) of a Mitsuba .vol file."""
    with open(path, "rb") as f:
        head = f.read(48)
    if len(head) < 48 or head[:3] != b"VOL":
        raise ValueError("%s: not a Mitsuba .vol file" % path)
    enc, xres, yres, zres, ch = struct.unpack("<5i", head[4:24])
    if enc != 1:
        raise ValueError("%s: encoding %d unsupported (only 1 = float32)" % (path, enc))
    bb = struct.unpack("<6f", head[24:48])
    return xres, yres, zres, ch, list(bb[:3]), list(bb[3:])


def irregular(knots):
    if all(float(v) == 0.0 for _, v in knots):
        # Mitsuba's irregular spectrum refuses zero mass
        return {"type": "uniform", "value": 0.0}
    return {"type": "irregular",
            "wavelengths": ", ".join(repr(float(w)) for w, _ in knots),
            "values": ", ".join(repr(float(v)) for _, v in knots)}


def build_scene_dict(mi, geo, args):
    T = mi.ScalarTransform4f
    cam = geo["camera"]
    film = geo.get("film", {})
    width = int(film.get("width", cam["width"]))
    height = int(film.get("height", cam["height"]))
    with_medium = args.medium or args.grid is not None
    integ = geo["integrator"]["medium" if with_medium else "cbox"]
    max_depth = args.max_depth if args.max_depth is not None else int(integ["max_depth"])

    integrator = {"type": integ["type"], "max_depth": max_depth,
                  "rr_depth": int(integ["rr_depth"]), "hide_emitters": False}
    if args.spp_per_pass:
        integrator["samples_per_pass"] = args.spp_per_pass

    scene = {
        "type": "scene",
        "integrator": integrator,
        "sensor": {
            "type": "perspective",
            "fov": float(cam["fov_deg"]),
            "fov_axis": cam.get("fov_axis", "x"),
            "near_clip": 1e-3,
            "far_clip": 1e4,
            "to_world": T().look_at(origin=cam["origin"], target=cam["target"], up=cam["up"]),
            "sampler": {"type": geo.get("sampler", {}).get("type", "independent"),
                        "sample_count": args.spp},
            "film": {
                "type": "hdrfilm",
                "width": width,
                "height": height,
                "pixel_format": film.get("pixel_format", "rgb"),
                "component_format": "float32",
                "rfilter": {"type": film.get("rfilter", "box")},
            },
        },
    }

    # Materials: two-sided Lambertian with piecewise-linear spectra.
    bsdfs = {}
    for name, m in geo["materials"].items():
        if m["type"] not in ("lambertian_twosided", "lambertian"):
            raise ValueError("material %s: unsupported type %s" % (name, m["type"]))
        d = {"type": "diffuse", "reflectance": irregular(m["reflectance"])}
        if m["type"] == "lambertian_twosided":
            d = {"type": "twosided", "bsdf": d}
        bsdfs[name] = mi.load_dict(d)

    # One triangle mesh per quad (separate vertices, face normals from the winding).
    for q in geo["quads"]:
        c = [list(map(float, v)) for v in q["corners"]]
        props = mi.Properties()
        props["bsdf"] = bsdfs[q["material"]]
        if "emission" in q:
            e = geo["emitters"][q["emission"]]
            if e["type"] != "area":
                raise ValueError("emitter %s: unsupported type" % q["emission"])
            # Mitsuba's area emitter radiates only on the front side of the
            # surface (geometric normal = cross(p1-p0, p2-p0)), so it is one-sided.
            if not e.get("one_sided", True):
                raise ValueError("two-sided emitters are not supported here")
            props["emitter"] = mi.load_dict({
                "type": "area",
                "radiance": {"type": "uniform", "value": float(e["radiance_constant"])}})
        mesh = mi.Mesh(q["name"], 4, 2, props=props)
        params = mi.traverse(mesh)
        # buffer types differ between scalar and JIT variants: reuse the mesh's own
        params["vertex_positions"] = type(params["vertex_positions"])([x for v in c for x in v])
        params["faces"] = type(params["faces"])([0, 1, 2, 0, 2, 3])
        params.update()
        # check the winding reproduces the stated normal
        e1 = [c[1][i] - c[0][i] for i in range(3)]
        e2 = [c[3][i] - c[0][i] for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
             e1[0] * e2[1] - e1[1] * e2[0]]
        if sum(n[i] * q["normal"][i] for i in range(3)) <= 0:
            raise ValueError("quad %s: winding disagrees with its normal" % q["name"])
        scene["quad_" + q["name"]] = mesh

    if with_medium:
        mv = geo["medium_variant"]
        if mv.get("phase", "isotropic") != "isotropic":
            raise ValueError("only an isotropic phase function is supported")
        bmin, bmax = mv["bounds_min"], mv["bounds_max"]
        center = [(bmin[i] + bmax[i]) / 2 for i in range(3)]
        half = [(bmax[i] - bmin[i]) / 2 for i in range(3)]
        if args.grid is None:
            medium = {
                "type": "homogeneous",
                "sigma_t": {"type": "constvolume",
                            "value": {"type": "uniform", "value": float(mv["sigma_t"])}},
                "albedo": {"type": "constvolume",
                           "value": {"type": "uniform", "value": float(mv["albedo"])}},
                "phase": {"type": "isotropic"},
            }
        else:
            xr, yr, zr, ch, gmin, gmax = read_vol_header(args.grid)
            if ch != 1:
                raise ValueError("%s: %d channels, need 1" % (args.grid, ch))
            albedo = args.albedo if args.albedo is not None else float(mv["albedo"])
            ext = [gmax[i] - gmin[i] for i in range(3)]
            medium = {
                "type": "heterogeneous",
                "sigma_t": {"type": "gridvolume",
                            "filename": os.path.abspath(args.grid),
                            # gridvolume maps [0,1]^3 through to_world; use the header bbox
                            "to_world": T().translate(gmin).scale(ext)},
                "scale": float(args.density_scale),
                "albedo": {"type": "constvolume",
                           "value": {"type": "uniform", "value": float(albedo)}},
                "phase": {"type": "isotropic"},
            }
        scene["medium_boundary"] = {
            "type": "cube",  # mesh of [-1,1]^3 with outward normals
            "to_world": T().translate(center).scale(half),
            "bsdf": {"type": "null"},
            "interior": medium,
        }
    return scene, width, height


def image_stats(img):
    """img: HxWx3 numpy array of linear sRGB. Returns mean Y overall and per quadrant."""
    y = 0.2126 * img[:, :, 0] + 0.7152 * img[:, :, 1] + 0.0722 * img[:, :, 2]
    h, w = y.shape
    h2, w2 = h // 2, w // 2
    return {
        "mean_Y": float(y.mean(dtype="float64")),
        "quadrants": {
            "top_left": float(y[:h2, :w2].mean(dtype="float64")),
            "top_right": float(y[:h2, w2:].mean(dtype="float64")),
            "bottom_left": float(y[h2:, :w2].mean(dtype="float64")),
            "bottom_right": float(y[h2:, w2:].mean(dtype="float64")),
        },
    }


def mean_se(xs):
    n = len(xs)
    m = sum(xs) / n
    if n < 2:
        return m, float("nan")
    var = sum((x - m) ** 2 for x in xs) / (n - 1)
    return m, math.sqrt(var / n)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    import numpy as np
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    mi.set_log_level(mi.LogLevel.Warn)
    threads = args.threads if args.threads > 0 else (os.cpu_count() or 1)
    dr.set_thread_count(threads)

    with open(args.geometry) as f:
        geo = json.load(f)
    scene_dict, width, height = build_scene_dict(mi, geo, args)
    scene = mi.load_dict(scene_dict)

    def render(seed):
        img = mi.render(scene, seed=seed, spp=args.spp)
        arr = np.array(img, dtype=np.float32)  # forces evaluation
        return arr

    if not args.no_warmup:
        t0 = time.perf_counter()
        render(args.seed)
        warmup_s = time.perf_counter() - t0
    else:
        warmup_s = None

    per_seed = []
    acc = None
    for k in range(args.seeds):
        seed = args.seed + k
        c0 = time.process_time()
        t0 = time.perf_counter()
        arr = render(seed)
        secs = time.perf_counter() - t0
        cpu = time.process_time() - c0
        st = image_stats(arr)
        st.update({"seed": seed, "seconds": secs, "cpu_seconds": cpu,
                   "samples_per_second": width * height * args.spp / secs})
        per_seed.append(st)
        acc = arr.astype(np.float64) if acc is None else acc + arr

    first = per_seed[0]
    out = {
        "variant": args.variant,
        "scene": "grid" if args.grid else ("medium" if args.medium else "cbox"),
        "integrator": scene_dict["integrator"],
        "width": width,
        "height": height,
        "spp": args.spp,
        "threads": threads,
        "seed": args.seed,
        "seconds": first["seconds"],
        "seconds_note": "render time of one timed render (mi.render + readback), "
                        "after a warm-up render with the same settings, so JIT "
                        "compilation is excluded" if warmup_s is not None else
                        "no warm-up: may include JIT compilation",
        "warmup_seconds": warmup_s,
        "samples_per_second": first["samples_per_second"],
        "cpu_seconds": first["cpu_seconds"],
        "load_average": os.getloadavg(),
        "mean_Y": first["mean_Y"],
        "quadrants": first["quadrants"],
    }
    if args.grid:
        out.update({"grid": os.path.abspath(args.grid), "density_scale": args.density_scale,
                    "albedo": args.albedo})
    if args.seeds > 1:
        secs = sorted(s["seconds"] for s in per_seed)
        out["seeds"] = args.seeds
        out["per_seed"] = per_seed
        m, se = mean_se([s["mean_Y"] for s in per_seed])
        out["across_seeds"] = {
            "mean_Y": m, "stderr_Y": se,
            "quadrants": {q: dict(zip(("mean", "stderr"),
                                      mean_se([s["quadrants"][q] for s in per_seed])))
                          for q in first["quadrants"]},
            "median_seconds": secs[len(secs) // 2],
            "median_samples_per_second": width * height * args.spp / secs[len(secs) // 2],
            "median_samples_per_cpu_second": width * height * args.spp / sorted(
                s["cpu_seconds"] for s in per_seed)[len(per_seed) // 2],
        }
    if args.out:
        img = (acc / args.seeds).astype(np.float32)
        bmp = mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB)
        bmp.write(args.out)
        out["out"] = os.path.abspath(args.out)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
