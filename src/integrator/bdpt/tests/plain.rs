//! Plain connections (`bdpt::plain`: paths that cannot shift the wavelength, in scenes without
//! media) give the same contribution as the full-path evaluation, connection by connection:
//! the same XYZ up to rounding (the products are taken in another order), the same splat
//! position, the same statistics and the same random numbers drawn.

use crate::integrator::bdpt::connection::Contribution;
use crate::integrator::bdpt::{Bdpt, ResetMode, Scratch};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, Sampler, Stats};
use crate::scene::{NONE, Scene};
use std::path::Path;

/// One connection evaluated both ways by [`plain_for_test`]: the contribution, the statistics
/// it added, and the next random number after it (both must draw the same numbers).
#[derive(Clone, Debug)]
struct PlainTrial {
    contribution: Option<Contribution>,
    stats: Stats,
    next_random: f32,
}

/// Connect strategy (s, t) of the sub-paths in `scratch` as a plain path and on the full path,
/// each from a copy of `sampler` (test hook); `None` when the path is not plain.
fn plain_for_test(
    b: &Bdpt,
    scene: &Scene,
    scratch: &mut Scratch,
    s: usize,
    t: usize,
    sampler: &Sampler,
) -> Option<[PlainTrial; 2]> {
    if scene.has_media || !scratch.plain.covers(s, t) {
        return None;
    }
    let mut run = |plain: bool| {
        let (mut sampler, mut stats) = (sampler.clone(), Stats::default());
        let contribution = if plain {
            b.connect_plain(scene, (s, t), &mut sampler, scratch, &mut stats)
        } else {
            b.connect_full(scene, (s, t), &mut sampler, scratch, &mut stats)
        };
        PlainTrial {
            contribution,
            stats,
            next_random: sampler.next(),
        }
    };
    Some([run(true), run(false)])
}

fn load(name: &str) -> Scene {
    Scene::load(Path::new(&format!("scenes/{name}.json"))).unwrap()
}

/// The strategies `Bdpt::sample` connects for sub-paths of `nc` camera and `nl` light vertices
/// (`scatters(i)`: camera vertex i has a material; `emitter(i)`: it is on a light).
fn strategies(
    nc: usize,
    nl: usize,
    md: usize,
    scatters: impl Fn(usize) -> bool,
    emitter: impl Fn(usize) -> bool,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    out.extend((2..=nc).filter(|&s| emitter(s - 1)).map(|s| (s, 0)));
    out.extend(
        (2..=nc.min(md))
            .filter(|&s| scatters(s - 1))
            .map(|s| (s, 1)),
    );
    out.extend((1..=nl.min(md)).map(|t| (1, t)));
    for s in 2..=nc {
        if !scatters(s - 1) {
            break;
        }
        out.extend((2..=nl).take_while(|&t| s + t - 1 <= md).map(|t| (s, t)));
    }
    out
}

fn same_stats(a: &Stats, b: &Stats) -> bool {
    (a.rays, a.nan_inf_rejected, a.dropped_strategy_pdfs)
        == (b.rays, b.nan_inf_rejected, b.dropped_strategy_pdfs)
}

/// Compare the two evaluations of one connection; returns whether it carried light.
fn check(trial: &[PlainTrial; 2], what: &str) -> bool {
    let [plain, full] = trial;
    assert!(
        same_stats(&plain.stats, &full.stats),
        "{what}: statistics {:?} vs {:?}",
        plain.stats,
        full.stats
    );
    assert_eq!(
        plain.next_random, full.next_random,
        "{what}: random numbers"
    );
    match (plain.contribution, full.contribution) {
        (None, None) => false,
        (Some((a, sa, (la, ra))), Some((b, sb, (lb, rb)))) => {
            assert_eq!(sa, sb, "{what}: splat position");
            assert_eq!(la, lb, "{what}: camera wavelength");
            assert!(
                (ra - rb).abs() <= 1e-5 * rb.abs(),
                "{what}: spectral radiance plain {ra} vs full {rb}"
            );
            let err = (a - b).abs().max_element() / b.abs().max_element();
            assert!(
                err <= 1e-5,
                "{what}: plain {a} vs full {b} (relative {err:e})"
            );
            true
        }
        (a, b) => panic!("{what}: plain {a:?} vs full {b:?}"),
    }
}

/// Every plain connection of many sampled sub-paths; returns the number of plain connections,
/// of those that carried light, and of connections that were not plain.
fn compare(name: &str, mode: ResetMode, mis: MisHeuristic) -> [usize; 3] {
    let scene = load(name);
    let opts = IntegratorOptions {
        max_depth: 7,
        mis,
        ..Default::default()
    };
    let b = Bdpt::new(&scene, &opts, mode).unwrap();
    let mut scratch = b.scratch(&scene);
    let (mut stats, mut sampler) = (Stats::default(), Sampler::from_seed(11));
    let (mut plain, mut lit, mut other) = (0, 0, 0);
    for i in 0..3000 {
        let (x, y) = (
            (i % 64) as f32 * 4.0 + 0.5,
            (i / 64 % 64) as f32 * 4.0 + 0.5,
        );
        b.trace_subpaths(&scene, (x, y), &mut sampler, &mut scratch, &mut stats);
        let (cam, light) = (scratch.camera().to_vec(), scratch.light().len());
        let list = strategies(
            cam.len(),
            light,
            7,
            |i| cam[i].material != NONE,
            |i| cam[i].light != NONE,
        );
        for (s, t) in list {
            let what = format!("{name} {mode:?} {mis:?} sample {i} (s, t) = ({s}, {t})");
            match plain_for_test(&b, &scene, &mut scratch, s, t, &sampler) {
                Some(trial) => {
                    plain += 1;
                    lit += check(&trial, &what) as usize;
                }
                None => other += 1,
            }
            sampler.next();
        }
    }
    [plain, lit, other]
}

#[test]
fn plain_connections_match_the_full_path() {
    for mode in [ResetMode::Forward, ResetMode::Backward] {
        for mis in [MisHeuristic::Balance, MisHeuristic::Power] {
            // no fluorescence: every connection is plain
            for name in ["cornell-box", "furnace-lambert-box"] {
                let [_, lit, other] = compare(name, mode, mis);
                assert_eq!(other, 0, "{name}: every path is plain");
                assert!(
                    lit > 5000,
                    "{name} {mode:?}: only {lit} connections carried light"
                );
            }
            // fluorescent spheres beside plain diffuse ones: both kinds of connection carry light
            let [_, lit, other] = compare("green-spheres", mode, mis);
            assert!(
                lit > 500 && other > 500,
                "green-spheres {mode:?}: {lit}, {other}"
            );
            // the walls are lit in the UV: plain paths (by the back wall) carry nothing visible
            let [plain, _, other] = compare("fluorescent-walls", mode, mis);
            assert!(
                plain > 500 && other > 500,
                "walls {mode:?}: {plain} plain, {other} not"
            );
        }
    }
}
