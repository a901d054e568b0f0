#!/usr/bin/env python3
"""What a closest-hit ray costs in instructions and cache misses, stokes against Embree 3, counted
by a cache simulator instead of timed: the same numbers on a quiet machine and a noisy one.

    python3 scripts/embree/cachesim.py [--install] [--l2 SIZE[,SIZE]] [--l1 SIZE] [-n N]
                                       [--stokes BIN[,BIN]] [--no-embree] [--json FILE]
                                       [RAYSET ...]

  --install    apt-get install valgrind (and libembree-dev) first if missing
  --l2 SIZE    the second-level caches to simulate, comma separated (512K, 1M, 2M; default: this
               processor's L2 a core, from /sys)
  --l1 SIZE    the first-level data and instruction caches (default 32K)
  -n N         the first N rays of each set (default all)
  --stokes BIN other builds of examples/raybench to count beside this checkout's (to compare a
               change without timing it); the first column is always this checkout's
  --no-embree  stokes only (no Embree 3 needed)
  --json FILE  also write the rows there (default target/cachesim.json)
  RAYSET       names in benches/data/rays or target/rays (default soup100k)

Both harnesses run under `valgrind --tool=callgrind --cache-sim=yes`, which counts only inside
the traversal (stokes' `Accel::intersect_*` kernels, Embree's `rtcIntersect1`) and divides by the
calls made: the instructions, data reads, first-level misses and second-level misses of one ray.
The simulated caches are 8-way with 64-byte lines, and there are two levels: the second plays the
processor's L2, and what misses it is served by the L3 (not simulated; soup100k's whole tree fits
any L3 of these machines). Hardware and software prefetches are not simulated: a miss here is a
line the ray had to have, whether a prefetch hid its wait or not. valgrind does not emulate
AVX-512, so both run their AVX2 kernels whatever the processor (stokes prints which). Masked loads
(`vmaskmovps`) are not counted as reads by valgrind's simulator: a kernel that loads with them
cannot be judged here.
About a minute a set and harness for soup100k's 250 000 rays (traced twice by each harness: the
timed pass and the check).
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
EVENTS = ("Ir", "Dr", "D1mr", "DLmr")
FIELDS = ("instructions", "data_reads", "l1_misses", "l2_misses")


def fail(msg):
    print(f"cachesim: {msg}", file=sys.stderr)
    sys.exit(1)


def size_bytes(text, what):
    m = re.fullmatch(r"\s*(\d+)\s*([KkMm]?)(i?[Bb])?\s*", text)
    if not m:
        fail(f"{what} '{text}' is not a size (for example 512K or 1M)")
    n = int(m.group(1)) * {"": 1, "k": 1 << 10, "m": 1 << 20}[m.group(2).lower()]
    if n < 4096 or n & (n - 1):
        fail(f"{what} '{text}' must be a power of two of at least 4K")
    return n


def label(n):
    return f"{n >> 20}M" if n >= 1 << 20 and n % (1 << 20) == 0 else f"{n >> 10}K"


def this_l2():
    try:
        with open("/sys/devices/system/cpu/cpu0/cache/index2/size") as f:
            return f.read().strip()
    except OSError:
        return None


def data_of(s):
    for d in (os.path.join(ROOT, "benches", "data", "rays"), os.path.join(TARGET, "rays")):
        if os.path.exists(os.path.join(d, f"{s}_tris.bin")):
            return d
    fail(f"no ray set '{s}': neither benches/data/rays/{s}_tris.bin nor "
         f"{os.path.relpath(TARGET, ROOT)}/rays/{s}_tris.bin (examples/make_rayset writes "
         f"soup1m, sphere1m and grid1m there)")


def totals(out_file, callee):
    """Summed events inside the toggled functions and the calls into them, from a callgrind
    output file (name compression: `fn=(id) name` the first time, `fn=(id)` after)."""
    names, ev, tot, calls = {}, None, None, 0
    pending_calls = None
    with open(out_file) as f:
        for line in f:
            if line.startswith("events:"):
                ev = line.split()[1:]
            elif line.startswith("totals:") or line.startswith("summary:"):
                tot = dict(zip(ev, map(int, line.split()[1:])))
            elif line.startswith(("fn=", "cfn=")):
                m = re.match(r"c?fn=\((\d+)\)(?: (.*))?", line.rstrip("\n"))
                if m and m.group(2):
                    names[m.group(1)] = m.group(2)
                if line.startswith("cfn=") and m:
                    pending_calls = names.get(m.group(1), "")
            elif line.startswith("calls=") and pending_calls is not None:
                if callee.search(pending_calls):
                    calls += int(line.split("=")[1].split()[0])
                pending_calls = None
    if tot is None or ev is None:
        fail(f"{out_file}: no totals line (did valgrind finish?)")
    return {e: tot.get(e, 0) for e in EVENTS}, calls


def simulate(name, cmd, toggle, callee, l1, l2, env=None):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "callgrind.out")
        full = ["valgrind", "--tool=callgrind", "--cache-sim=yes", f"--I1={l1},8,64",
                f"--D1={l1},8,64", f"--LL={l2},8,64", "--collect-atstart=no",
                f"--toggle-collect={toggle}", f"--callgrind-out-file={out}"] + cmd
        p = subprocess.run(full, cwd=ROOT, env=env, capture_output=True, text=True)
        if p.returncode != 0:
            sys.stderr.write(p.stdout + p.stderr)
            fail(f"{name}: {' '.join(cmd)} failed under valgrind (exit {p.returncode})")
        ev, calls = totals(out, callee)
        isa = re.search(r"^isa (\S+)", p.stderr, re.M)
    if calls == 0:
        fail(f"{name}: no call into {toggle} was counted")
    # per ray: instructions, data reads, L1 and L2 data read misses (callgrind's Ir, Dr, D1mr,
    # DLmr)
    row = {k: ev[e] / calls for k, e in zip(FIELDS, EVENTS)}
    row["calls"] = calls
    # stokes prints its instruction set; Embree does not say which of its kernels it took
    row["isa"] = isa.group(1) if isa else None
    return row


def embree_flags():
    """The compiler flags for Embree 3 as run.sh finds it: from pkg-config, else Debian's
    header with -lembree3; None when neither is there."""
    if shutil.which("pkg-config"):
        r = subprocess.run(["pkg-config", "--cflags", "--libs", "embree3"],
                           capture_output=True, text=True)
        if r.returncode == 0:
            return r.stdout.split()
    if os.path.exists("/usr/include/embree3/rtcore.h"):
        return ["-lembree3"]
    return None


def main():
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--install", action="store_true")
    ap.add_argument("--l2")
    ap.add_argument("--l1", default="32K")
    ap.add_argument("-n", type=int)
    ap.add_argument("--stokes", default="")
    ap.add_argument("--no-embree", action="store_true")
    ap.add_argument("--json", default=os.path.join(TARGET, "cachesim.json"))
    ap.add_argument("-h", "--help", action="store_true")
    ap.add_argument("sets", nargs="*")
    a = ap.parse_args()
    if a.help:
        print(__doc__.strip())
        return
    if a.n is not None and a.n < 1:
        fail(f"-n {a.n}: the number of rays must be at least 1")
    l1 = size_bytes(a.l1, "--l1")
    l2s = a.l2 or this_l2()
    if not l2s:
        fail("this processor's L2 size is not in /sys; give it with --l2 (for example 512K)")
    l2s = [size_bytes(s, "--l2") for s in l2s.split(",")]
    sets = a.sets or ["soup100k"]

    have_embree = embree_flags() is not None
    missing = [p for p, ok in (("valgrind", shutil.which("valgrind")),
                               ("libembree-dev", a.no_embree or have_embree)) if not ok]
    if missing and a.install:
        sudo = [] if os.geteuid() == 0 else ["sudo"]
        if subprocess.run(sudo + ["apt-get", "install", "-y"] + missing).returncode != 0:
            fail(f"apt-get install {' '.join(missing)} failed")
    elif missing:
        alone = "; --no-embree counts stokes alone" if "libembree-dev" in missing else ""
        print(f"{' and '.join(missing)} not installed (apt-get install {' '.join(missing)}, or "
              f"run with --install{alone}); skipped")
        return
    for s in sets:
        data_of(s)
    stokes = [os.path.join(TARGET, "release", "examples", "raybench")]
    for b in filter(None, a.stokes.split(",")):
        if not os.access(b, os.X_OK):
            fail(f"--stokes {b}: not an executable file")
        stokes.append(os.path.abspath(b))
    if subprocess.run(["cargo", "build", "--release", "--quiet", "--example", "raybench"],
                      cwd=ROOT).returncode != 0:
        fail("cargo build --release --example raybench failed")
    ebin = os.path.join(TARGET, "embree-raybench")
    if not a.no_embree:
        src = os.path.join(ROOT, "scripts", "embree", "raybench.c")
        # looked up again: --install may have just installed it
        eflags = embree_flags() or ["-lembree3"]
        if subprocess.run(["cc", "-O3", "-march=native", "-Wall", src, "-o", ebin] + eflags
                          + ["-lm"]).returncode != 0:
            fail(f"cc {os.path.relpath(src, ROOT)} failed")

    n = str(a.n) if a.n else "100000000"
    env = dict(os.environ, PRESET=os.environ.get("STOKES_PRESET", "auto"), RAYON_NUM_THREADS="1")
    for k in ("LEAF", "REINS", "NOSPLIT", "LAYOUT"):
        env.pop(k, None)
    stokes_fn = re.compile(r"Accel>::(intersect_(avx2|avx512|portable)|intersect_flat)")
    rows = []
    for s in sets:
        for l2 in l2s:
            for i, b in enumerate(stokes):
                who = "stokes" if i == 0 else f"stokes {b}"
                print(f"{s}, L2 {label(l2)}: {who} ...", file=sys.stderr, flush=True)
                r = simulate(who, [b, s, n, "1"], "*Accel*intersect_*", stokes_fn, l1, l2, env)
                rows.append(dict(set=s, l2=label(l2), harness=who, **r))
            if not a.no_embree:
                print(f"{s}, L2 {label(l2)}: Embree medium ...", file=sys.stderr, flush=True)
                cmd = [ebin, "-d", data_of(s), "-c", "threads=1", "-q", "medium", "-r", "1"]
                cmd += (["-n", n] if a.n else []) + [s]
                r = simulate("Embree", cmd, "rtcIntersect1", re.compile(r"^rtcIntersect1$"),
                             l1, l2, None)
                rows.append(dict(set=s, l2=label(l2), harness="Embree 3 medium", **r))

    print(f"Closest hit, per ray, simulated: L1 {label(l1)} (data and instructions), L2 as listed; "
          f"8-way, 64-byte lines; stokes' instruction set {rows[0]['isa'] or 'not printed'}")
    print(f"{'ray set':<10} {'L2':>5} {'instructions':>12} {'data reads':>10} {'L1 misses':>9} "
          f"{'L2 misses':>9}  harness")
    for r in rows:
        print(f"{r['set']:<10} {r['l2']:>5} {r['instructions']:12.0f} {r['data_reads']:10.0f} "
              f"{r['l1_misses']:9.1f} {r['l2_misses']:9.1f}  {r['harness']}")
    os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
    with open(a.json, "w") as f:
        json.dump(rows, f, indent=1)
    print(f"rows written to {a.json}")


if __name__ == "__main__":
    main()
