"""Time a render through Python against the same render by the CLI: paired, alternating rounds.

    python python/bench/render_vs_cli.py [--rounds 10] [--spp 64] [--scene scenes/cornell-box.json]

Each round runs the CLI (`stokes render ... --stats`) and then a fresh Python process that loads
the scene, renders and saves the EXR (the order alternates between rounds). Two times are
compared per round: the render's time (the CLI's `stats["seconds"]`; on the Python side the
wall time of the whole `Scene.render` call, its thread and GIL handling included; scene
loading and file writing excluded on both) and the whole command's wall time (process start, scene load, BVH
build, render, EXR). Prints per-round ratios and their medians; Python/CLI < 1 is faster.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

PY = """
import json, sys, time, stokes
s = stokes.load_scene(sys.argv[1])
t = time.perf_counter()
r = s.render("pt-hero", spp=int(sys.argv[2]), seed=0)
call = time.perf_counter() - t
r.save_exr(sys.argv[3])
print(json.dumps(dict(r.stats, call_seconds=call)))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--scene", default=str(REPO / "scenes" / "cornell-box.json"))
    ap.add_argument("--cli", default=os.environ.get("STOKES_BIN", str(REPO / "target/release/stokes")))
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    rows = []
    for i in range(a.rounds):
        order = ["cli", "py"] if i % 2 == 0 else ["py", "cli"]
        got = {}
        for side in order:
            exr = tmp / f"{side}.exr"
            t = time.perf_counter()
            if side == "cli":
                stats = tmp / "stats.json"
                subprocess.run([a.cli, "render", a.scene, "--integrator", "pt-hero", "--spp",
                                str(a.spp), "--seed", "0", "-o", str(exr), "--stats",
                                str(stats), "--quiet"], check=True, capture_output=True)
                wall = time.perf_counter() - t
                secs = json.loads(stats.read_text())["seconds"]
            else:
                p = subprocess.run([sys.executable, "-c", PY, a.scene, str(a.spp), str(exr)],
                                   check=True, capture_output=True, text=True)
                wall = time.perf_counter() - t
                # the whole `render` call as Python sees it (thread, GIL release, arrays)
                secs = json.loads(p.stdout)["call_seconds"]
            got[side] = (secs, wall)
        same = (tmp / "cli.exr").read_bytes() == (tmp / "py.exr").read_bytes()
        r = (got["py"][0] / got["cli"][0], got["py"][1] / got["cli"][1])
        rows.append(r)
        print(f"round {i + 1}: render cli {got['cli'][0]:.3f} s py {got['py'][0]:.3f} s "
              f"(py/cli {r[0]:.3f}); wall cli {got['cli'][1]:.3f} s py {got['py'][1]:.3f} s "
              f"(py/cli {r[1]:.3f}); same EXR: {same}", flush=True)
        if not same:
            sys.exit("the two EXRs differ")
    print(f"median Python/CLI over {a.rounds} rounds: render {statistics.median(x for x, _ in rows):.3f}, "
          f"wall {statistics.median(y for _, y in rows):.3f}")


if __name__ == "__main__":
    main()
