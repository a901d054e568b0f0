//! The O(k) MIS sums of bdpt-forward/backward (`FullPath::strategy_pdfs`, `mis_weight`,
//! `strategy_weights`: prefix and suffix products, the nearest shifting vertex tracked while
//! walking ŝ) against the O(k²) sums they replaced, which evaluate every strategy's pdf
//! (`FullPath::strategy_pdf`, eqs. 6.3, 6.9–6.14) on its own. They are kept here as the reference.
//!
//! Tolerance: 1e-12 relative, in f64. Both compute every strategy's pdf as a product of at most
//! 2k + 4 factors and differ only in the order of the multiplications (suffixes right to left
//! instead of left to right), each of which rounds once by at most 2⁻⁵³, so the pdfs agree to
//! (2k + 4)·2⁻⁵³ ≈ 3·10⁻¹⁴ at k = 130, and a weight 1 / Σ r to twice that; zeros must agree
//! exactly.

use super::{dye_box, load};
use crate::integrator::bdpt::evaluate::connect_for_test;
use crate::integrator::bdpt::{Bdpt, FullPath, ResetMode};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, Sampler, Stats};
use crate::scene::Scene;
use crate::transport::VertexKind;

const TOL: f64 = 1e-12;
const MODES: [ResetMode; 2] = [ResetMode::Forward, ResetMode::Backward];
const HEURISTICS: [MisHeuristic; 2] = [MisHeuristic::Balance, MisHeuristic::Power];

/// The O(k²) MIS weight of strategy s that the renderer used before (each ŝ a product over the
/// path).
fn quadratic_mis_weight(p: &FullPath, s: usize, p_s: f64, mode: ResetMode, h: MisHeuristic) -> f64 {
    let e = h.exponent() as f64;
    let mut sum = 0.0;
    for s_hat in 1..=p.k {
        if s_hat == s {
            sum += 1.0;
            continue;
        }
        let r = p.strategy_pdf(s_hat, mode) / p_s;
        sum += if e == 1.0 { r } else { r * r };
    }
    1.0 / sum
}

/// The O(k²) weights of all strategies that the renderer used before.
fn quadratic_strategy_weights(p: &FullPath, mode: ResetMode, h: MisHeuristic) -> Vec<f64> {
    let e = h.exponent() as f64;
    let mut out: Vec<f64> = (1..=p.k)
        .map(|s_hat| p.strategy_pdf(s_hat, mode).powf(e))
        .collect();
    let sum: f64 = out.iter().sum();
    if sum > 0.0 {
        for w in out.iter_mut() {
            *w /= sum;
        }
    }
    out
}

fn close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= TOL * a.abs().max(b.abs())
}

/// The relative difference |a − b| / max(|a|, |b|) (0 when equal).
fn rel(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

/// Compare the incremental and the quadratic pdfs and weights of one path for both resets and
/// both heuristics: every strategy's pdf and weight, and the own-strategy weight of the
/// strategies in `own` (all of them when `None`). Returns how many own-strategy weights were
/// compared and the largest relative difference of any pdf or weight.
fn compare(p: &FullPath, own: Option<&[usize]>, what: &str) -> (usize, f64) {
    let (mut n, mut worst) = (0, 0.0f64);
    let mut v = Vec::new();
    for mode in MODES {
        p.strategy_pdfs(mode, &mut v);
        assert_eq!(v.len(), p.k);
        for (i, &x) in v.iter().enumerate() {
            let want = p.strategy_pdf(i + 1, mode);
            worst = worst.max(rel(x, want));
            assert!(
                close(x, want),
                "{what} {mode:?} k={} ŝ={}: {x} vs {want}",
                p.k,
                i + 1
            );
        }
        for h in HEURISTICS {
            p.strategy_weights(mode, h, &mut v);
            let want = quadratic_strategy_weights(p, mode, h);
            for (i, (&x, &y)) in v.iter().zip(&want).enumerate() {
                worst = worst.max(rel(x, y));
                assert!(
                    close(x, y),
                    "{what} {mode:?} {h:?} k={} ŝ={}: {x} vs {y}",
                    p.k,
                    i + 1
                );
            }
            let all: Vec<usize> = (1..=p.k).collect();
            for &s in own.unwrap_or(&all) {
                let ps = p.strategy_pdf(s, mode);
                if !(ps > 0.0 && ps.is_finite()) {
                    continue;
                }
                let (x, y) = (
                    p.mis_weight(s, mode, h),
                    quadratic_mis_weight(p, s, ps, mode, h),
                );
                worst = worst.max(rel(x, y));
                assert!(
                    close(x, y),
                    "{what} {mode:?} {h:?} k={} s={s}: {x} vs {y}",
                    p.k
                );
                n += 1;
            }
        }
    }
    (n, worst)
}

/// A random full path of `k` vertices: area pdfs log-uniform over six decades (as 1/d² and
/// cosines make them), a fluorescent interior vertex with probability `fl` (wavelength pdfs
/// log-uniform over four decades, P_c and P_l uniform) that shifts with probability `sh`, and
/// each pdf exactly 0 with probability 1 % (strategies that cannot make the path).
fn random_path(u: &mut Sampler, k: usize, fl: f32, sh: f32) -> FullPath {
    let log_uniform = |u: &mut Sampler, lo: f64, hi: f64| {
        if u.next() < 0.01 {
            0.0
        } else {
            (lo.ln() + u.next() as f64 * (hi / lo).ln()).exp()
        }
    };
    let mut p = FullPath::with_capacity(k);
    p.reset(k);
    for i in 0..k {
        p.pa_fwd[i] = log_uniform(u, 1e-3, 1e3);
        p.pa_rev[i] = log_uniform(u, 1e-3, 1e3);
        let (pc, pl) = (log_uniform(u, 1e-3, 10.0), log_uniform(u, 1e-3, 10.0));
        let (big_pc, big_pl) = (log_uniform(u, 1e-2, 1.0), log_uniform(u, 1e-2, 1.0));
        let (r1, r2) = (u.next(), u.next());
        let fluorescent = (1..k - 1).contains(&i) && r1 < fl;
        p.shift[i] = fluorescent && r2 < sh;
        (p.pc[i], p.pl[i], p.big_pc[i], p.big_pl[i]) = if fluorescent {
            (pc, pl, big_pc, big_pl)
        } else {
            (1.0, 1.0, 0.0, 0.0)
        };
    }
    p.pc0 = log_uniform(u, 1e-3, 1e-1);
    p.ple = log_uniform(u, 1e-3, 1e-1);
    p
}

/// 2000 random paths of 2 to 130 vertices (most below 40), with no, few, many or only
/// fluorescent vertices and shifts: every strategy's pdf and weight, and the own-strategy weight
/// of strategies 1, 2, k − 1, k and three random ones, for both resets and both heuristics.
#[test]
fn incremental_weights_match_the_quadratic_sums_on_random_paths() {
    let mut u = Sampler::from_seed(13);
    let (mut compared, mut worst) = (0, 0.0f64);
    let mut deep = 0;
    for i in 0..2000 {
        let k = if i % 10 == 0 {
            2 + (u.next() * 129.0) as usize
        } else {
            2 + (u.next() * 39.0) as usize
        };
        let (fl, sh) = [(0.0, 0.0), (0.3, 0.2), (0.8, 0.5), (1.0, 1.0)][i % 4];
        let p = random_path(&mut u, k.min(130), fl, sh);
        let mut own = vec![1, 2, p.k - 1, p.k];
        for _ in 0..3 {
            own.push(1 + (u.next() * p.k as f32) as usize % p.k);
        }
        own.retain(|&s| (1..=p.k).contains(&s));
        let (n, r) = compare(&p, Some(&own), &format!("random path {i}"));
        (compared, worst) = (compared + n, worst.max(r));
        deep += (p.k > 64) as usize;
    }
    eprintln!("{compared} own-strategy weights, largest relative difference {worst:.1e}");
    assert!(compared > 30_000, "{compared} weights");
    assert!(deep > 50, "{deep} paths deeper than 64 vertices");
}

/// How many of the sampled paths had what.
#[derive(Default, Debug)]
struct Coverage {
    paths: usize,
    /// A shift on the camera side (x1 … x(s−1)) and on the light side (x_s … x(k−2)).
    shifted_camera: usize,
    shifted_light: usize,
    medium_vertex: usize,
    longest: usize,
}

/// Paths sampled and connected by the renderer's own code (`connect_for_test`: sub-paths,
/// resets, connection, free-flight pdfs folded in): the weights of every strategy (s, t) of
/// every connection of 600 to 4000 samples per scene and reset, at max depth 16, on the
/// fluorescent furnace and walls, the green spheres, media-scattering.json (fluorescent fog) and the dye
/// box of tests/common (fluorescent Henyey–Greenstein medium).
#[test]
fn incremental_weights_match_the_quadratic_sums_on_sampled_paths() {
    let scenes: [(&str, Scene, usize); 5] = [
        ("furnace-fluorescent", load("furnace-fluorescent.json"), 600),
        ("fluorescent-walls", load("fluorescent-walls.json"), 4000),
        ("green-spheres", load("green-spheres.json"), 4000),
        ("media-scattering", load("media-scattering.json"), 2000),
        ("dye-box", dye_box(), 2000),
    ];
    let (mut media_paths, mut worst) = (0, 0.0f64);
    for (name, scene, samples) in &scenes {
        for mode in MODES {
            let opts = IntegratorOptions {
                max_depth: 16,
                ..Default::default()
            };
            let b = Bdpt::new(scene, &opts, mode).unwrap();
            let mut scratch = b.scratch(scene);
            let mut stats = Stats::default();
            let mut sampler = Sampler::from_seed(29);
            let mut c = Coverage::default();
            let (w, h) = (scene.camera.width as f32, scene.camera.height as f32);
            for i in 0..*samples {
                let (x, y) = ((i % 24) as f32 / 24.0 * w, (i / 24 % 24) as f32 / 24.0 * h);
                b.trace_subpaths(scene, (x, y), &mut sampler, &mut scratch, &mut stats);
                let (nc, nl) = (scratch.camera().len(), scratch.light().len());
                for s in 1..=nc {
                    for t in 0..=nl {
                        let k = s + t;
                        if k < 2 || (t == 0 && s < 2) || k > 17 {
                            continue;
                        }
                        let Some(p) = connect_for_test(&b, scene, &scratch, s, t, &mut sampler)
                        else {
                            continue;
                        };
                        let (_, r) = compare(&p, Some(&[s]), &format!("{name} ({s}, {t})"));
                        worst = worst.max(r);
                        c.paths += 1;
                        c.longest = c.longest.max(k);
                        let shifts = |r: std::ops::Range<usize>| r.into_iter().any(|i| p.shift[i]);
                        c.shifted_camera += shifts(1..s) as usize;
                        c.shifted_light += shifts(s..k - 1) as usize;
                        let medium = p.v.iter().any(|v| v.kind == VertexKind::Medium);
                        c.medium_vertex += medium as usize;
                    }
                }
            }
            eprintln!("{name} {mode:?}: {c:?}");
            assert!(c.paths > 2000 && c.longest >= 9, "{name} {mode:?}: {c:?}");
            assert!(c.shifted_camera > 10, "{name} {mode:?}: {c:?}");
            assert!(c.shifted_light > 10, "{name} {mode:?}: {c:?}");
            media_paths += c.medium_vertex;
        }
    }
    eprintln!("largest relative difference {worst:.1e}");
    assert!(
        media_paths > 1000,
        "{media_paths} paths with medium vertices"
    );
}
