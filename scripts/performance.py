#!/usr/bin/env python3
"""Measure the speed goals of docs/performance.md, back to back on this machine.

Every comparison alternates its two sides for --rounds rounds and reports the median of each
side and the median of the per-round ratios a_i / b_i: each round's two runs follow each other,
so a slow spell of a shared machine hits both sides of a round alike, and the verdict uses that
paired ratio (the ratio of the two medians is printed next to it). Results go to stdout as a
Markdown table and to target/performance.json. Every row records the CPU model and the
instruction set stokes traced rays with (`stokes inspect`; STOKES_ISA=avx512|avx2|portable forces
a lower one), since the ratios depend on both: docs/performance.md keeps one table per machine
kind.

Goals (--only NAME[,NAME]; default all):
  rays      closest-hit Mrays/s against Embree 3 medium, 1 thread, on soup100k, the
            1M-triangle sets of examples/make_rayset (written to target/rays when missing) and
            cbox, by scripts/embree/run.sh over --rounds rounds (skipped without
            libembree-dev): at least 1x Embree on the meshes, 2x on cbox
  mitsuba   pt-hero against Mitsuba 3 llvm_ad_spectral `path` on scenes/cornell-box.json
            (256², depth 8, no Russian roulette, 2 threads) and against `volpath` on
            scenes/cornell-box-medium.json (depth 16); skipped when `import mitsuba` or
            `import numpy` fails
  bdpt      per-sample cost of bdpt-forward against pt-hero (cornell-box) and of bdpt-backward
            against bdpt-forward (fluorescent-walls), 2 threads
  scaling   samples/s at 2 threads over 1 thread for every integrator on cornell-box
  features  pt-hero on cornell-box (no fluorescent material, no medium) with the default build
            against builds that compile the fluorescence or media code paths out
            (`--no-default-features`, target/lean-*)

Usage (from anywhere):  python3 scripts/performance.py [--rounds 3] [--only bdpt,scaling]
Mitsuba: pip install mitsuba==3.9.1 numpy (the wheel does not pull in numpy, which
scripts/mitsuba/cbox.py needs), apt-get install libllvm19 and
DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so (set here when that file exists).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
INTEGRATORS = ["pt-mono", "pt-hero", "bdpt-forward", "bdpt-backward", "bdpt-allbins"]
# Samples per pixel per render, chosen so that a render takes about 1-4 s at 2 threads.
WALLS_SPP = 48
SPP = {"pt-mono": 128, "pt-hero": 64, "bdpt-forward": 16, "bdpt-backward": 16, "bdpt-allbins": 16}


def run(cmd, **kw):
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.exit("command failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr[-2000:]))
    return r.stdout


def build(target_dir=None, features=None):
    cmd = ["cargo", "build", "--release", "--bin", "stokes"]
    if target_dir:
        cmd += ["--target-dir", target_dir, "--no-default-features"]
        if features:
            cmd += ["--features", features]
    run(cmd)
    return os.path.join(target_dir or "target", "release", "stokes")


# pt-hero's lanes in every row: Mitsuba 3's spectral variants carry 4 wavelengths a path, and
# the goal tables of docs/performance.md were measured with 4 (the default is 8 since 2026-12-06)
HERO_LANES = ["--lanes", "4"]


def stokes(binary, scene, integrator, spp, threads=2, depth=8, extra=()):
    """Samples per second of one render (render time only, from --stats)."""
    lanes = HERO_LANES if integrator == "pt-hero" else []
    with tempfile.TemporaryDirectory() as d:
        stats = os.path.join(d, "s.json")
        run([binary, "render", "scenes/%s.json" % scene, "--integrator", integrator,
             "--spp", str(spp), "--threads", str(threads), "--max-depth", str(depth),
             "-o", os.path.join(d, "x.exr"), "--stats", stats, "--quiet", *lanes, *extra])
        with open(stats) as f:
            return json.load(f)["samples_per_second"]


def mitsuba(medium, spp):
    cmd = [sys.executable, "scripts/mitsuba/cbox.py", "--variant", "llvm_ad_spectral",
           "--spp", str(spp), "--threads", "2"]
    cmd += ["--medium", "--max-depth", "16"] if medium else ["--max-depth", "8"]
    return json.loads(run(cmd))["samples_per_second"]


def compare(rounds, a, b):
    """Medians of a() and b() alternated over `rounds` rounds, the median of the per-round
    ratios a_i / b_i (`ratio`, the verdict's) and median(a) / median(b) (`ratio_of_medians`)."""
    xs, ys = [], []
    for _ in range(rounds):
        xs.append(a())
        ys.append(b())
    ma, mb = statistics.median(xs), statistics.median(ys)
    paired = statistics.median(x / y for x, y in zip(xs, ys))
    return {"a": ma, "b": mb, "ratio": paired, "ratio_of_medians": ma / mb, "a_runs": xs,
            "b_runs": ys}


# The CPU model and stokes' instruction set, filled in by main() and written into every row.
MACHINE = {"cpu": "unknown", "isa": "unknown"}


def cpu_model():
    """The model name with its family, model and L2 size: virtual machines often report a bare
    "AMD EPYC" for processors of different generations (docs/performance.md has tables for
    three of them), and the L2 size decides how much of a tree stays near the core."""
    fields = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                key = key.strip()
                if key in ("model name", "cpu family", "model") and key not in fields:
                    fields[key] = value.strip()
                if not line.strip() and fields:
                    break
    except OSError:
        pass
    if "model name" not in fields:
        import platform
        return platform.processor() or platform.machine()
    extra = []
    if "cpu family" in fields and "model" in fields:
        extra.append("family %s model %s" % (fields["cpu family"], fields["model"]))
    try:
        with open("/sys/devices/system/cpu/cpu0/cache/index2/size") as f:
            extra.append("L2 %s a core" % f.read().strip())
    except OSError:
        pass
    return fields["model name"] + (" (%s)" % ", ".join(extra) if extra else "")


def stokes_isa(exe):
    """The instruction set `stokes inspect` reports (after STOKES_ISA, if set)."""
    out = run([exe, "inspect", "scenes/cornell-box.json"])
    for line in out.splitlines():
        if line.startswith("instruction set: "):
            return line.split(": ", 1)[1].split(" ")[0].rstrip(",")
    return "unknown"


def row(goal, what, r, a_name, b_name, target, unit="M samples/s", met=None):
    line = "| %s | %s | %s %.3f | %s %.3f | %.2f× (%.2f×) | %s |" % (
        goal, what, a_name, r["a"] / 1e6, b_name, r["b"] / 1e6, r["ratio"],
        r["ratio_of_medians"], target)
    line += " %s |" % ("" if met is None else "met" if met else "not met")
    line += " %s |" % MACHINE["isa"]
    print(line, flush=True)
    r.update(goal=goal, what=what, a_name=a_name, b_name=b_name, target=target, unit=unit,
             **MACHINE)
    return r


def goal_mitsuba(rounds, exe):
    # scripts/mitsuba/cbox.py needs numpy too, which the mitsuba wheel does not install
    missing = [m for m in ("mitsuba", "numpy")
               if subprocess.run([sys.executable, "-c", "import " + m],
                                 capture_output=True).returncode != 0]
    if missing:
        print("| 2 | %s not installed (pip install mitsuba==3.9.1 numpy): skipped |"
              % " and ".join(missing))
        return []
    out = []
    # On AVX-512 machines Dr.Jit's LLVM back end generates 16-wide code, and the goals are
    # those measured against it there (docs/performance.md, "The goals").
    path_goal, volpath_goal = (1.4, 1.8) if MACHINE["isa"] == "avx512" else (1.3, 1.0)
    r = compare(rounds, lambda: stokes(exe, "cornell-box", "pt-hero", 64),
                lambda: mitsuba(False, 64))
    out.append(row("2", "pt-hero vs Mitsuba `path`, cornell-box", r, "stokes", "Mitsuba",
                   "≥ %g×" % path_goal, met=r["ratio"] >= path_goal))
    r = compare(rounds, lambda: stokes(exe, "cornell-box-medium", "pt-hero", 32, depth=16),
                lambda: mitsuba(True, 32))
    out.append(row("2", "pt-hero vs Mitsuba `volpath`, cornell-box-medium", r, "stokes",
                   "Mitsuba", "≥ %g×" % volpath_goal, met=r["ratio"] >= volpath_goal))
    return out


def goal_bdpt(rounds, exe):
    out = []
    r = compare(rounds, lambda: stokes(exe, "cornell-box", "pt-hero", 64),
                lambda: stokes(exe, "cornell-box", "bdpt-forward", 16))
    out.append(row("3", "bdpt-forward cost per sample / pt-hero's, cornell-box", r, "pt-hero",
                   "bdpt-forward", "≤ 3.5×", met=r["ratio"] <= 3.5))
    # 48 spp: at 16 the walls' renders took 0.5-0.7 s, short enough for a slow second of the
    # shared machine to move single rounds by 40 %.
    r = compare(rounds, lambda: stokes(exe, "fluorescent-walls", "bdpt-forward", WALLS_SPP),
                lambda: stokes(exe, "fluorescent-walls", "bdpt-backward", WALLS_SPP))
    out.append(row("3", "bdpt-backward cost per sample / bdpt-forward's, fluorescent-walls", r,
                   "forward", "backward", "≤ 1.1×", met=r["ratio"] <= 1.1))
    return out


def two_processes(exe, integrator, spp):
    """Sum of the samples/s of two 1-thread renders run at the same time."""
    with tempfile.TemporaryDirectory() as d:
        procs, stats = [], []
        for k in range(2):
            stats.append(os.path.join(d, "s%d.json" % k))
            procs.append(subprocess.Popen(
                [exe, "render", "scenes/cornell-box.json", "--integrator", integrator, "--spp",
                 str(spp), "--threads", "1", "-o", os.path.join(d, "x%d.exr" % k), "--stats",
                 stats[k], "--quiet", *(HERO_LANES if integrator == "pt-hero" else [])], cwd=ROOT, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL))
        if any(p.wait() != 0 for p in procs):
            sys.exit("a 1-thread render failed")
        total = 0.0
        for f in stats:
            with open(os.path.join(ROOT, f)) as fh:
                total += json.load(fh)["samples_per_second"]
        return total


def goal_scaling(rounds, exe):
    # The machine's own ceiling: two independent 1-thread processes against one.
    r = compare(rounds, lambda: two_processes(exe, "pt-hero", 32),
                lambda: stokes(exe, "cornell-box", "pt-hero", 32, threads=1))
    out = [row("4", "control: two 1-thread pt-hero processes at once / one alone", r,
               "two", "one", "(machine)")]
    for i in INTEGRATORS:
        spp = SPP[i]
        r = compare(rounds, lambda: stokes(exe, "cornell-box", i, spp, threads=2),
                    lambda: stokes(exe, "cornell-box", i, spp, threads=1))
        out.append(row("4", "%s, 2 threads / 1 thread, cornell-box" % i, r, "2 threads",
                       "1 thread", "≥ 1.9×", met=r["ratio"] >= 1.9))
    return out


def goal_features(rounds, exe):
    out = []
    for feature, other in [("fluorescence", "media"), ("media", "fluorescence")]:
        lean = build("target/lean-no-" + feature, other)
        r = compare(rounds, lambda: stokes(lean, "cornell-box", "pt-hero", 64),
                    lambda: stokes(exe, "cornell-box", "pt-hero", 64))
        out.append(row("5", "pt-hero, cornell-box: build without `%s` / default build" % feature,
                       r, "without", "default", "≤ 1.03×", met=r["ratio"] <= 1.03))
    return out


def goal_rays(rounds, _exe):
    run(["cargo", "build", "--release", "--example", "raybench", "--example", "make_rayset"])
    for name in ["soup1m", "sphere1m", "grid1m"]:
        if not os.path.exists(os.path.join(ROOT, "target", "rays", name + "_rays.bin")):
            run([os.path.join("target", "release", "examples", "make_rayset"), name])
    sets = ["soup100k", "soup1m", "sphere1m", "grid1m", "cbox"]
    r = subprocess.run(["bash", "scripts/embree/run.sh", "--quality", "medium,high",
                        "--rounds", str(rounds), *sets], cwd=ROOT, text=True,
                       capture_output=True)
    if r.returncode != 0:
        sys.exit("scripts/embree/run.sh failed (%d):\n%s" % (r.returncode, r.stderr[-2000:]))
    if "skipped" in r.stdout and "Paired ratio" not in r.stdout:
        print("| 1 | %s |" % r.stdout.strip())
        return []
    out = []
    for s in sets:
        medians, paired = parse_embree(r.stdout, s)
        goal = 2.0 if s == "cbox" else 1.0
        res = {"a": medians[1] * 1e6, "b": medians[0] * 1e6, "ratio": paired,
               "ratio_of_medians": medians[1] / medians[0]}
        what = "closest hit, `%s`, 1 thread%s" % (s, " (32 triangles)" if s == "cbox" else "")
        out.append(row("1", what, res, "stokes", "Embree medium", "≥ %g×" % goal,
                       unit="M rays/s", met=paired >= goal))
    out.append({"goal": "1", "embree_output": r.stdout, **MACHINE})
    return out


def parse_embree(text, name):
    """From scripts/embree/run.sh's output (run with --quality medium,high): the medians of
    Embree medium and of stokes on ray set `name`, and the paired ratio against medium."""
    medians = paired = None
    for line in text.splitlines():
        f = line.split()
        if len(f) == 7 and f[0] == name and f[1].isdigit():
            # ray set, tris, Embree medium, Embree high, stokes, stokes/medium, stokes/high
            medians = (float(f[2]), float(f[4]))
        if len(f) > 2 and f[0] == name and f[1] == "medium":
            paired = float(f[2])
    if medians is None or paired is None:
        sys.exit("scripts/embree/run.sh printed no result for %s:\n%s" % (name, text[-2000:]))
    return medians, paired


GOALS = {"rays": goal_rays, "mitsuba": goal_mitsuba, "bdpt": goal_bdpt,
         "scaling": goal_scaling, "features": goal_features}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--only", default=",".join(GOALS))
    a = p.parse_args()
    names = [n for n in a.only.split(",") if n]
    for n in names:
        if n not in GOALS:
            sys.exit("unknown goal %r (known: %s)" % (n, ", ".join(GOALS)))
    if os.path.exists(LLVM):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    exe = build()
    MACHINE.update(cpu=cpu_model(), isa=stokes_isa(exe))
    print("Machine: %s, %d CPUs; stokes traces rays with %s" % (
        MACHINE["cpu"], os.cpu_count() or 0, MACHINE["isa"]))
    print()
    print("| goal | what | A | B | A / B: paired (of medians) | target | | isa |")
    print("|---|---|---|---|---|---|---|---|")
    results = []
    for n in names:
        results += GOALS[n](a.rounds, exe)
    os.makedirs(os.path.join(ROOT, "target"), exist_ok=True)
    with open(os.path.join(ROOT, "target", "performance.json"), "w") as f:
        json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
