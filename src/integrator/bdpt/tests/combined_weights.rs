//! bdpt-combined's MIS weights (`FullPath::combined_weight`): on sampled paths with fluorescent
//! vertices, the weights of all 2k techniques (ŝ, reset) sum to 1, and each equals its pdf's
//! power over the sum of every technique's, each pdf evaluated on its own (eq. 6.14).

use crate::integrator::bdpt::evaluate::connect_for_test;
use crate::integrator::bdpt::{Bdpt, FullPath, ResetMode};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, Sampler, Stats};
use crate::scene::Scene;
use std::path::Path;

const RESETS: [ResetMode; 2] = [ResetMode::Forward, ResetMode::Backward];

/// Every technique's weight by the definition: p_r(ŝ)^β / Σ_{ŝ',r'} p_r'(ŝ')^β, index
/// 2(ŝ − 1) + r.
fn by_definition(p: &FullPath, h: MisHeuristic) -> Vec<f64> {
    let e = h.exponent() as i32;
    let pdfs: Vec<f64> = (1..=p.k)
        .flat_map(|s| RESETS.map(|r| p.strategy_pdf(s, r).powi(e)))
        .collect();
    let sum: f64 = pdfs.iter().sum();
    pdfs.iter().map(|x| x / sum).collect()
}

/// Check one path: returns the number of techniques with a positive pdf.
fn check(p: &FullPath, h: MisHeuristic, what: &str) -> usize {
    let want = by_definition(p, h);
    let mut sum = 0.0;
    let mut n = 0;
    for s in 1..=p.k {
        for (r, &mode) in RESETS.iter().enumerate() {
            if !(p.strategy_pdf(s, mode) > 0.0) {
                continue;
            }
            let w = p.combined_weight(s, mode, false, h);
            let d = want[2 * (s - 1) + r];
            assert!(
                (w - d).abs() <= 1e-12,
                "{what}: ŝ = {s} {mode:?}: walk {w} vs definition {d}"
            );
            sum += w;
            n += 1;
        }
        // light tracing: both resets make the same path, and one evaluation stands for both
        if s == 1 && p.strategy_pdf(1, ResetMode::Forward) > 0.0 {
            let both = p.combined_weight(1, ResetMode::Forward, true, h);
            let d = want[0] + want[1];
            assert!(
                (both - d).abs() <= 1e-12,
                "{what}: s = 1, both: {both} vs {d}"
            );
        }
    }
    assert!((sum - 1.0).abs() <= 1e-12, "{what}: Σw = {sum}");
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
