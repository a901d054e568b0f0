//! Sample-range shards: a render split into ranges and merged equals the render of the whole
//! range, for every integrator, and the merge refuses shards that do not belong together.

mod common;

use stokes::film::shard::{ShardInfo, merge, read_shard, write_shard};
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};

fn settings(from: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        first_sample: from,
        spp,
        seed: 7,
        threads: Some(2),
        time_limit: None,
        progress: false,
        spectral: None,
        cancel: None,
    }
}

fn info(kind: IntegratorKind, from: u32, to: u32) -> ShardInfo {
    ShardInfo {
        scene: "fluorescent-walls".into(),
        scene_hash: "0".into(),
        integrator: kind.name().into(),
        options: "{}".into(),
        seed: 7,
        from,
        to,
    }
}

/// 4 shards of 16 spp merge into the 64-spp render: pixels bit-identical, for every integrator
/// (through the EXR files, so the sums survive writing and reading).
#[test]
fn four_shards_of_sixteen_merge_into_sixty_four() {
    let scene = common::load_sized("fluorescent-walls.json", 24);
    let dir = common::temp_dir("shards-merge");
    let opts = IntegratorOptions::default();
    for kind in [
        IntegratorKind::PtMono,
        IntegratorKind::PtHero,
        IntegratorKind::BdptForward,
        IntegratorKind::BdptBackward,
        IntegratorKind::BdptCombined,
        IntegratorKind::BdptAllbins,
    ] {
        let whole = render(&scene, kind, &opts, &settings(0, 64), None).unwrap();
        let mut shards = Vec::new();
        for k in (0..4).rev() {
            let out = render(&scene, kind, &opts, &settings(16 * k, 16), None).unwrap();
            let p = dir.join(format!("{}-{k}.exr", kind.name()));
            write_shard(&p, &out.film, &info(kind, 16 * k, 16 * k + 16)).unwrap();
            shards.push(read_shard(&p).unwrap());
        }
        let m = merge(shards).unwrap();
        assert_eq!((m.info.from, m.info.to), (0, 64));
        let (a, b) = (whole.film.rgb(), m.film().rgb());
        let differ = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| x.to_array().map(f32::to_bits) != y.to_array().map(f32::to_bits))
            .count();
        assert_eq!(differ, 0, "{}: {differ} pixels differ", kind.name());
        // The sums themselves: equal up to f64 summation order.
        for (x, y) in whole.film.sum.iter().zip(&m.sum) {
            for c in 0..3 {
                assert!(
                    (x[c] - y[c]).abs() <= 1e-12 * x[c].abs().max(1e-300),
                    "{}",
                    kind.name()
                );
            }
        }
    }
}
