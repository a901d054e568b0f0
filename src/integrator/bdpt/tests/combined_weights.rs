//! bdpt-combined's MIS weights (`FullPath::combined_weight`): on sampled paths with fluorescent
//! vertices, the weights of all 2k techniques (ŝ, reset) sum to 1, and each equals its pdf's
//! power over the sum of every technique's, each pdf evaluated on its own (eq. 6.14); with
//! technique counts (`--reset-choice adaptive`), each pdf times its reset's count, and with one
//! reset's count 0 the weights are that of the other reset's integrator alone.

use crate::integrator::bdpt::evaluate::connect_for_test;
use crate::integrator::bdpt::{Bdpt, FullPath, ResetMode};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, Sampler, Stats};
use crate::scene::Scene;
use std::path::Path;

const RESETS: [ResetMode; 2] = [ResetMode::Forward, ResetMode::Backward];

/// Every technique's weight by the definition: (n_r p_r(ŝ))^β / Σ_{ŝ',r'} (n_r' p_r'(ŝ'))^β,
/// index 2(ŝ − 1) + r, with the techniques' counts `n`.
fn by_definition(p: &FullPath, h: MisHeuristic, n: [f64; 2]) -> Vec<f64> {
    let e = h.exponent() as i32;
    let pdfs: Vec<f64> = (1..=p.k)
        .flat_map(|s| RESETS.map(|r| (n[r as usize] * p.strategy_pdf(s, r)).powi(e)))
        .collect();
    let sum: f64 = pdfs.iter().sum();
    pdfs.iter().map(|x| x / sum).collect()
}

/// Check one path: returns the number of techniques with a positive pdf.
fn check(p: &FullPath, h: MisHeuristic, what: &str) -> usize {
    let mut n = 0;
    for counts in [[1.0, 1.0], [0.3, 0.7], [1.0, 0.0], [0.0, 1.0]] {
        n = check_counts(p, h, counts, what);
    }
    // one reset's count 0: the weights of bdpt-forward or bdpt-backward alone
    for (r, counts) in [
        (ResetMode::Forward, [1.0, 0.0]),
        (ResetMode::Backward, [0.0, 1.0]),
    ] {
        for s in 1..=p.k {
            if !(p.strategy_pdf(s, r) > 0.0) {
                continue;
            }
            let w = p.combined_weight(s, r, s == 1, h, counts);
            let alone = p.mis_weight(s, r, h);
            assert!(
                (w - alone).abs() <= 1e-12,
                "{what}: ŝ = {s} {r:?} alone: {w} vs the single reset's {alone}"
            );
        }
    }
    n
}

/// [`check`] with the technique counts `counts`.
fn check_counts(p: &FullPath, h: MisHeuristic, counts: [f64; 2], what: &str) -> usize {
    let want = by_definition(p, h, counts);
    let mut sum = 0.0;
    let mut n = 0;
    for s in 1..=p.k {
        for (r, &mode) in RESETS.iter().enumerate() {
            // a technique the pixel sample does not take is never evaluated
            if !(p.strategy_pdf(s, mode) > 0.0) || counts[r] == 0.0 {
                continue;
            }
            let w = p.combined_weight(s, mode, false, h, counts);
            let d = want[2 * (s - 1) + r];
            assert!(
                (w - d).abs() <= 1e-12,
                "{what} {counts:?}: ŝ = {s} {mode:?}: walk {w} vs definition {d}"
            );
            sum += w;
            n += 1;
        }
        // light tracing: both resets make the same path, and one evaluation stands for both
        if s == 1 && p.strategy_pdf(1, ResetMode::Forward) > 0.0 {
            let both = p.combined_weight(1, ResetMode::Forward, true, h, counts);
            let d = want[0] + want[1];
            assert!(
                (both - d).abs() <= 1e-12,
                "{what} {counts:?}: s = 1, both: {both} vs {d}"
            );
        }
    }
    assert!((sum - 1.0).abs() <= 1e-12, "{what} {counts:?}: Σw = {sum}");
    n
}

#[test]
fn combined_weights_sum_to_one() {
    for name in ["fluorescent-walls", "furnace-fluorescent"] {
        let scene = Scene::load(Path::new(&format!("scenes/{name}.json"))).unwrap();
        for h in [MisHeuristic::Balance, MisHeuristic::Power] {
            let opts = IntegratorOptions {
                max_depth: 7,
                mis: h,
                ..Default::default()
            };
            let mut checked = 0;
            for mode in RESETS {
                let b = Bdpt::new(&scene, &opts, mode).unwrap();
                let mut scratch = b.scratch(&scene);
                let (mut stats, mut sampler) = (Stats::default(), Sampler::from_seed(11));
                for i in 0..4000 {
                    let (x, y) = ((i % 32) as f32 * 8.0, (i / 32 % 32) as f32 * 8.0);
                    b.trace_subpaths(&scene, (x, y), &mut sampler, &mut scratch, &mut stats);
                    let (nc, nl) = (scratch.camera().len(), scratch.light().len());
                    for s in 1..=nc {
                        for t in 0..=nl.min(8 - s.min(8)) {
                            if s + t < 2 || (t == 0 && s < 2) {
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
                            let what = format!("{name} {mode:?} {h:?} s={s} t={t}");
                            checked += (check(&p, h, &what) > 2) as usize;
                        }
                    }
                }
            }
            assert!(checked > 1000, "{name} {h:?}: only {checked} paths");
        }
    }
}
