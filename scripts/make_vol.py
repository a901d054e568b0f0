#!/usr/bin/env python3
"""Write a procedural smoke plume as a Mitsuba 3 `.vol` density grid (pure Python 3, no numpy).

Usage:
    python3 scripts/make_vol.py scenes/media/smoke.vol      # the committed grid: all defaults
    python3 scripts/make_vol.py out.vol --res 48 56 48 --min -0.6 -1 -0.6 --max 0.6 0.4 0.6 \
        --seed 7 --octaves 5
    python3 scripts/make_vol.py --help

The plume stands on the box's bottom face (y = min y) and rises along +y: a soft Gaussian
column that widens and drifts with height, thinning towards the top, modulated by fBm value
noise (deterministic for a given seed). Densities are scaled so the maximum is exactly 1 (a
scene's `density_scale` sets the real extinction). The outermost voxel layer on the four sides
and the top is 0, so Mitsuba 3's clamp-to-edge lookup and a zero-outside lookup agree there.

Format (Mitsuba 3 `src/volumes/grid.cpp`, `VolumeGrid::write` in `src/render/volumegrid.cpp`),
all little-endian: b"VOL", version byte 3, int32 encoding 1 (float32), int32 xres, yres, zres,
int32 channels 1, 6 float32 bounding box (xmin ymin zmin xmax ymax zmax), then xres*yres*zres
float32 with x fastest: data[(z*yres + y)*xres + x]. Samples sit at voxel centres.
"""

import argparse
import array
import math
import struct
import sys

MASK = 0xFFFFFFFF


def hash01(ix, iy, iz, seed):
    """A lattice value in [0, 1): integer hash of the cell (multiply–xorshift mixing)."""
    h = (ix * 73856093 ^ iy * 19349663 ^ iz * 83492791 ^ seed * 2654435761) & MASK
    h ^= h >> 16
    h = (h * 0x7FEB352D) & MASK
    h ^= h >> 15
    h = (h * 0x846CA68B) & MASK
    h ^= h >> 16
    return h / 4294967296.0


def smooth(t):
    """Cubic smoothstep weight on [0, 1]."""
    return t * t * (3.0 - 2.0 * t)


def smoothstep(a, b, x):
    t = min(1.0, max(0.0, (x - a) / (b - a)))
    return smooth(t)


def value_noise(x, y, z, seed):
    """Value noise in [0, 1): trilinear blend of lattice values with smoothstep weights."""
    ix, iy, iz = math.floor(x), math.floor(y), math.floor(z)
    fx, fy, fz = smooth(x - ix), smooth(y - iy), smooth(z - iz)
    acc = 0.0
    for dz in (0, 1):
        wz = fz if dz else 1.0 - fz
        for dy in (0, 1):
            wy = fy if dy else 1.0 - fy
            for dx in (0, 1):
                wx = fx if dx else 1.0 - fx
                acc += wx * wy * wz * hash01(ix + dx, iy + dy, iz + dz, seed)
    return acc


def fbm(x, y, z, seed, octaves):
    """Fractional Brownian motion: octaves of value noise, lacunarity 2, gain 0.5, in [0, 1)."""
    total, amp, norm = 0.0, 1.0, 0.0
    for o in range(octaves):
        total += amp * value_noise(x, y, z, seed + 101 * o)
        norm += amp
        amp *= 0.5
        x, y, z = 2.0 * x + 17.3, 2.0 * y + 5.1, 2.0 * z + 11.7
    return total / norm


def plume(u, v, w, seed, octaves):
    """Unnormalised density at unit-box coordinates (u, v, w); v is the height."""
    # Horizontal position in [-1, 1] about a centre that drifts with height.
    cx = 0.18 * v * math.sin(2.6 * v + 0.4)
    cz = 0.12 * v * math.sin(1.9 * v + 1.7)
    dx, dz = 2.0 * u - 1.0 - cx, 2.0 * w - 1.0 - cz
    radius = 0.3 + 0.45 * v
    column = math.exp(-2.5 * (dx * dx + dz * dz) / (radius * radius))
    height = (1.0 - smoothstep(0.5, 0.97, v)) * (1.0 - 0.45 * v)
    profile = column * height
    if profile < 1e-4:
        return 0.0
    # Noise stretched along the height and sheared upwards, so wisps rise.
    n = fbm(4.5 * u, 3.5 * v - 0.8 * u, 4.5 * w, seed, octaves)
    return profile * smoothstep(0.36, 0.68, n)


def make_grid(res, seed, octaves):
    nx, ny, nz = res
    data = array.array("f", bytes(4 * nx * ny * nz))
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                edge = x in (0, nx - 1) or z in (0, nz - 1) or y == ny - 1
                if not edge:
                    u, v, w = (x + 0.5) / nx, (y + 0.5) / ny, (z + 0.5) / nz
                    data[i] = plume(u, v, w, seed, octaves)
                i += 1
    peak = max(data)
    if peak <= 0.0:
        sys.exit("make_vol.py: the grid is empty; try other parameters")
    for k in range(len(data)):
        data[k] = data[k] / peak
    return data


def write_vol(path, res, lo, hi, data):
    head = b"VOL" + struct.pack("<B5i6f", 3, 1, res[0], res[1], res[2], 1, *lo, *hi)
    if sys.byteorder == "big":
        data = array.array("f", data)
        data.byteswap()
    with open(path, "wb") as f:
        f.write(head)
        f.write(data.tobytes())


def main():
    p = argparse.ArgumentParser(
        description="Write a procedural smoke plume as a Mitsuba 3 .vol density grid "
        "(float32, one channel, max density 1).")
    p.add_argument("output", help="the .vol file to write")
    p.add_argument("--res", type=int, nargs=3, default=[56, 64, 56], metavar=("X", "Y", "Z"),
                   help="voxels per axis (default 56 64 56)")
    p.add_argument("--min", type=float, nargs=3, default=[-0.6, -1.0, -0.6],
                   metavar=("X", "Y", "Z"), help="box minimum (default -0.6 -1 -0.6)")
    p.add_argument("--max", type=float, nargs=3, default=[0.6, 0.4, 0.6],
                   metavar=("X", "Y", "Z"), help="box maximum (default 0.6 0.4 0.6)")
    p.add_argument("--seed", type=int, default=7, help="noise seed (default 7)")
    p.add_argument("--octaves", type=int, default=5, help="fBm octaves (default 5)")
    a = p.parse_args()
    if min(a.res) < 3 or a.res[0] * a.res[1] * a.res[2] > 512 ** 3:
        p.error("--res: each axis at least 3, at most 512³ voxels in all")
    if not all(l < h for l, h in zip(a.min, a.max)):
        p.error("--min must be below --max on every axis")
    data = make_grid(a.res, a.seed, a.octaves)
    write_vol(a.output, a.res, a.min, a.max, data)
    mean = sum(data) / len(data)
    print(f"{a.output}: {a.res[0]}×{a.res[1]}×{a.res[2]} voxels, box {a.min} .. {a.max}, "
          f"max {max(data):.3f}, mean {mean:.4f}")


if __name__ == "__main__":
    main()
