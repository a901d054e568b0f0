//! Single-threaded ray throughput on the stored ray sets (for A/B runs and callgrind):
//! `target/release/examples/raybench SET [N_RAYS] [REPS] [occ]`.
//!
//! The BVH is built as scenes build it (`Accel::build`, quality `auto`) unless `PRESET` says
//! otherwise: `auto`, `high` or `medium` (the scene's `accel.quality`), or one of obvhs' other
//! presets (`fastest`, `very_fast`, `fast`, `slow`, `very_slow`), which `LEAF`, `REINS`,
//! `NOSPLIT` and `LAYOUT=full|quantised|tiered[:TOP_NODES]` modify for experiments (with `auto`
//! or `high` they are an error).
//! `STOKES_ISA=avx512|avx2|portable` forces a lower instruction set than the CPU's best; the one
//! in use is printed. So are the tree's fingerprint and a fingerprint of every ray's answer (the
//! closest hit's t, primitive, u and v to the bit, or the any-hit result), so that two builds
//! can be shown to give the same trees and the same hits.
#[path = "../tests/common/ray_sets.rs"]
mod ray_sets;

use stokes::geometry::{Accel, BuildQuality, Layout, Ray};

// The allocator of the `stokes` binary (src/main.rs), so that the build times are its.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[inline(never)]
fn trace_all(accel: &Accel, rays: &[Ray], occ: bool) -> f64 {
    let mut s = 0.0f64;
    for r in rays {
        if occ {
            s += accel.occluded(r, 1.0) as u32 as f64;
        } else if let Some(h) = accel.intersect(r, f32::INFINITY) {
            s += h.t as f64;
        }
    }
    s
}

/// A fingerprint of every ray's answer, to compare builds to the bit: the closest hit's t,
/// primitive, u and v (or none), or whether the ray is occluded.
fn hits_fingerprint(accel: &Accel, rays: &[Ray], occ: bool) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for r in rays {
        if occ {
            accel.occluded(r, 1.0).hash(&mut h);
        } else {
            let hit = accel.intersect(r, f32::INFINITY);
            hit.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
                .hash(&mut h);
        }
    }
    h.finish()
}

const USAGE: &str = "usage: raybench SET [N_RAYS] [REPS] [occ] (SET: soup100k, cbox, or one \
    that examples/make_rayset writes; env PRESET, LEAF, REINS, NOSPLIT, LAYOUT, STOKES_ISA: see \
    examples/raybench.rs)";

/// The experiment variables, which modify an obvhs preset's build.
const EXPERIMENT_VARS: [&str; 4] = ["LEAF", "REINS", "NOSPLIT", "LAYOUT"];

/// The first experiment variable that is set, if any.
fn experiment_var() -> Option<&'static str> {
    EXPERIMENT_VARS
        .into_iter()
        .find(|v| std::env::var(v).is_ok())
}

/// Exit 2 with `msg` and the usage.
fn fail(msg: &str) -> ! {
    eprintln!("error: {msg}\n{USAGE}");
    std::process::exit(2);
}

/// Environment variable `var` parsed as a `T`, if set.
fn env_parse<T: std::str::FromStr>(var: &str, what: &str) -> Option<T> {
    let v = std::env::var(var).ok()?;
    Some(
        v.parse()
            .unwrap_or_else(|_| fail(&format!("{var}={v}: not {what}"))),
    )
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if let Err(e) = stokes::geometry::Isa::from_env() {
        fail(&e.to_string());
    }
    let Some(name) = a.get(1) else {
        fail("no ray set given")
    };
    let set = ray_sets::try_load(name).unwrap_or_else(|e| fail(&e));
    let arg = |i: usize, what: &str| {
        a.get(i).map(|s| {
            s.parse::<usize>()
                .ok()
                .filter(|&x| x > 0)
                .unwrap_or_else(|| fail(&format!("{what} {s:?}: not a positive whole number")))
        })
    };
    let n = arg(2, "N_RAYS")
        .unwrap_or(set.rays.len())
        .min(set.rays.len());
    let reps = arg(3, "REPS").unwrap_or(5);
    let occ = match a.get(4).map(String::as_str) {
        None => false,
        Some("occ") => true,
        Some(x) => fail(&format!(
            "fourth argument {x:?}: only `occ` (any hit) is known"
        )),
    };
    if a.len() > 5 {
        fail("too many arguments");
    }
    let preset = std::env::var("PRESET")
        .ok()
        .filter(|p| !p.is_empty())
        .unwrap_or_else(|| "auto".into());
    let t0 = std::time::Instant::now();
    let quality = match preset.as_str() {
        "auto" => Some(BuildQuality::Auto),
        "high" => Some(BuildQuality::High),
        "medium" if experiment_var().is_none() => Some(BuildQuality::Medium),
        _ => None,
    };
    if quality.is_some_and(|q| q != BuildQuality::Medium)
        && let Some(v) = experiment_var()
    {
        fail(&format!(
            "{v} needs an obvhs preset (PRESET=medium, very_slow, ...), not PRESET={preset}"
        ));
    }
    let accel = match quality {
        Some(q) => Accel::build_quality(&set.tris, &[], q),
        None => {
            use obvhs::BvhBuildParams as B;
            let mut params = match preset.as_str() {
                "fastest" => B::fastest_build(),
                "very_fast" => B::very_fast_build(),
                "fast" => B::fast_build(),
                "medium" => B::medium_build(),
                "slow" => B::slow_build(),
                "very_slow" => B::very_slow_build(),
                _ => fail(&format!(
                    "PRESET={preset}: not one of auto, high, medium, fastest, very_fast, fast, \
                     slow, very_slow"
                )),
            };
            if let Some(l) = env_parse("LEAF", "a whole number of primitives") {
                params.max_prims_per_leaf = l;
            }
            if let Some(r) = env_parse("REINS", "a ratio (a number)") {
                params.reinsertion_batch_ratio = r;
            }
            let split = std::env::var("NOSPLIT").is_err();
            // LAYOUT=full|quantised|tiered[:TOP_NODES] forces the node layout (default: by
            // size)
            let layout = match std::env::var("LAYOUT").ok().as_deref() {
                None => Layout::Auto,
                Some("full") => Layout::Full,
                Some("quantised") => Layout::Quantised,
                Some("tiered") => Layout::Tiered { top_nodes: 8192 },
                Some(t) if t.starts_with("tiered:") => Layout::Tiered {
                    top_nodes: t["tiered:".len()..].parse().unwrap_or_else(|_| {
                        fail(&format!("LAYOUT={t}: TOP_NODES is not a whole number"))
                    }),
                },
                Some(l) => fail(&format!(
                    "LAYOUT={l}: not full, quantised, tiered or tiered:TOP_NODES"
                )),
            };
            Accel::build_with_layout(&set.tris, &[], params, split, layout)
        }
    };
    let label = accel
        .quality()
        .map_or(preset.clone(), |q| q.1.name().to_string());
    eprintln!("build {label} {:.1} ms", t0.elapsed().as_secs_f64() * 1e3);
    eprintln!("isa {}", accel.isa());
    let mut best = f64::INFINITY;
    let mut times = vec![];
    let mut chk = 0.0;
    for _ in 0..reps {
        let t0 = std::time::Instant::now();
        chk = trace_all(&accel, &set.rays[..n], occ);
        let t = t0.elapsed().as_secs_f64();
        best = best.min(t);
        times.push(t);
    }
    let (nodes, packets, lanes, bytes) = accel.layout();
    eprintln!(
        "{nodes} nodes ({}), {packets} packets ({:.0} % of lanes used), {:.1} bytes per primitive",
        accel.node_layout(),
        100.0 * lanes as f64 / (8 * packets).max(1) as f64,
        bytes as f64 / set.tris.len() as f64
    );
    // The BVH's arrays of 2 MiB and more are advised for transparent huge pages (bvh/pages.rs);
    // what the kernel gave the whole process, as it reports it.
    if let Some(kib) = std::fs::read_to_string("/proc/self/smaps_rollup")
        .ok()
        .and_then(|s| {
            let l = s.lines().find(|l| l.starts_with("AnonHugePages:"))?;
            l.split_whitespace().nth(1)?.parse::<f64>().ok()
        })
    {
        eprintln!(
            "huge pages: {:.1} MiB of the process (BVH {:.1} MiB)",
            kib / 1024.0,
            bytes as f64 / (1 << 20) as f64
        );
    }
    eprintln!("fingerprint {:016x}", accel.fingerprint());
    let [sah_nodes, sah_packets] = accel.sah();
    eprintln!(
        "surface-area model, per ray through the root box: {sah_nodes:.3} node visits, \
         {sah_packets:.3} packet tests"
    );
    #[cfg(feature = "bvh-stats")]
    {
        let [v, p, l, beyond] = stokes::geometry::bvh::stats::totals();
        let nr = (n * reps) as f64;
        eprintln!(
            "per ray: {:.2} nodes, {:.2} packets, {:.2} lanes; {:.2} of the packets in leaves \
             beginning beyond the final hit",
            v as f64 / nr,
            p as f64 / nr,
            l as f64 / nr,
            beyond as f64 / nr
        );
    }
    // (after the counts above, which are of the timed passes only)
    eprintln!(
        "hits fingerprint {:016x}",
        hits_fingerprint(&accel, &set.rays[..n], occ)
    );
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    println!(
        "{} n={n} occ={occ}: best {:.3} Mrays/s, median {:.3} Mrays/s (1 thread) chk {chk:.3}",
        a[1],
        n as f64 / best * 1e-6,
        n as f64 / times[times.len() / 2] * 1e-6
    );
}
