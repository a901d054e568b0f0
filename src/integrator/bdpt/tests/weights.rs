//! The MIS weights of the full-path evaluation (`FullPath::mis_weight`, the ratio walk of
//! `weight.rs`) against every strategy's pdf evaluated on its own (`FullPath::strategy_weights`).

use super::assert_weights;
use crate::integrator::bdpt::evaluate::connect_for_test;
use crate::integrator::bdpt::{Bdpt, ResetMode};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, Sampler, Stats};
use crate::scene::Scene;
use std::path::Path;

fn load(name: &str) -> Scene {
    Scene::load(Path::new(&format!("scenes/{name}.json"))).unwrap()
}

/// MIS weights of all strategies for one path sum to 1, on many sampled paths of several
/// lengths, with fluorescent vertices on both sub-paths.
#[test]
fn mis_weights_sum_to_one() {
    for name in ["fluorescent-walls", "furnace-fluorescent", "green-spheres"] {
        let scene = load(name);
        for mode in [ResetMode::Forward, ResetMode::Backward] {
            for h in [MisHeuristic::Balance, MisHeuristic::Power] {
                let opts = IntegratorOptions {
                    max_depth: 7,
                    mis: h,
                    ..Default::default()
                };
                let b = Bdpt::new(&scene, &opts, mode).unwrap();
                let mut scratch = b.scratch(&scene);
                let mut stats = Stats::default();
                let mut sampler = Sampler::from_seed(7);
                let (mut checked, mut both) = (0, 0);
                let mut lengths = [0usize; 9];
                let mut w = Vec::new();
                for i in 0..12000 {
                    let (x, y) = ((i % 32) as f32 * 8.0, (i / 32 % 32) as f32 * 8.0);
                    b.trace_subpaths(&scene, (x, y), &mut sampler, &mut scratch, &mut stats);
                    let (nc, nl) = (scratch.camera().len(), scratch.light().len());
                    for s in 1..=nc {
                        for t in 0..=nl {
                            let k = s + t;
                            if !(2..=8).contains(&k) || (t == 0 && s < 2) {
                                continue;
                            }
                            let Some(p) =
                                connect_for_test(&b, &scene, &scratch, s, t, &mut sampler)
                            else {
                                continue;
                            };
                            if p.strategy_pdf(s, mode) <= 0.0 {
                                continue;
                            }
                            let what = format!("{name} {mode:?} {h:?} k={k} s={s}");
                            assert_weights(&p, s, (mode, h), &mut w, &what);
                            checked += 1;
                            lengths[k] += 1;
                            if (1..s).any(|i| p.shift[i]) && (s..k - 1).any(|i| p.shift[i]) {
                                both += 1;
                            }
                        }
                    }
                }
                assert!(checked > 1000, "{name}: only {checked} paths");
                assert!(lengths[3..=8].iter().all(|&n| n > 0), "{lengths:?}");
                if name == "fluorescent-walls" {
                    assert!(both > 50, "{name}: {both} paths shift on both sub-paths");
                }
            }
        }
    }
}
