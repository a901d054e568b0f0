//! Single-threaded ray throughput on the stored ray sets (for A/B runs and callgrind):
//! `target/release/examples/raybench SET [N_RAYS] [REPS] [occ]`.
//!
//! The BVH is built as scenes build it (`Accel::build`, quality `auto`) unless `PRESET` says
//! otherwise: `auto`, `high` or `medium` (the scene's `accel.quality`), or one of obvhs' other
//! presets (`fastest`, `very_fast`, `fast`, `slow`, `very_slow`), which `LEAF`, `REINS`,
//! `NOSPLIT` and `LAYOUT=full|quantised|tiered[:TOP_NODES]` modify for experiments.
//! `STOKES_ISA=avx512|avx2|portable` forces a lower instruction set than the CPU's best; the one
//! in use is printed.
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

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if let Err(e) = stokes::geometry::Isa::from_env() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
    let set = ray_sets::load(&a[1]);
    let n: usize = a
        .get(2)
        .map_or(set.rays.len(), |s| s.parse().unwrap())
        .min(set.rays.len());
    let reps: usize = a.get(3).map_or(5, |s| s.parse().unwrap());
    let occ = a.get(4).is_some_and(|s| s == "occ");
    let preset = std::env::var("PRESET")
        .ok()
        .filter(|p| !p.is_empty())
        .unwrap_or_else(|| "auto".into());
    let t0 = std::time::Instant::now();
    let quality = match preset.as_str() {
        "auto" => Some(BuildQuality::Auto),
        "high" => Some(BuildQuality::High),
        "medium"
            if ["LEAF", "REINS", "NOSPLIT", "LAYOUT"]
                .iter()
                .all(|v| std::env::var(v).is_err()) =>
        {
            Some(BuildQuality::Medium)
        }
        _ => None,
    };
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
                _ => panic!("PRESET: unknown preset {preset}"),
            };
            if let Ok(l) = std::env::var("LEAF") {
                params.max_prims_per_leaf = l.parse().unwrap();
            }
            if let Ok(l) = std::env::var("REINS") {
                params.reinsertion_batch_ratio = l.parse().unwrap();
            }
            let split = std::env::var("NOSPLIT").is_err();
            // LAYOUT=full|quantised|tiered[:TOP_NODES] forces the node layout (default: by
            // size)
            let layout = match std::env::var("LAYOUT").ok().as_deref() {
                None => Layout::Auto,
                Some("full") => Layout::Full,
                Some("quantised") => Layout::Quantised,
                Some(t) if t.starts_with("tiered") => Layout::Tiered {
                    top_nodes: t
                        .strip_prefix("tiered:")
                        .map_or(8192, |n| n.parse().expect("LAYOUT=tiered:TOP_NODES")),
                },
                Some(l) => panic!("LAYOUT: unknown layout {l}"),
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
        let [v, p, l] = stokes::geometry::bvh::stats::totals();
        let nr = (n * reps) as f64;
        eprintln!(
            "per ray: {:.2} nodes, {:.2} packets, {:.2} lanes",
            v as f64 / nr,
            p as f64 / nr,
            l as f64 / nr
        );
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    println!(
        "{} n={n} occ={occ}: best {:.3} Mrays/s, median {:.3} Mrays/s (1 thread) chk {chk:.3}",
        a[1],
        n as f64 / best * 1e-6,
        n as f64 / times[times.len() / 2] * 1e-6
    );
}
