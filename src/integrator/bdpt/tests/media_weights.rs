//! The MIS weights of connected paths with medium vertices: they sum to 1 over the strategies,
//! and the walk's weight of the sampling strategy equals its entry.

use super::{assert_weights, dye_box, load};
use crate::integrator::bdpt::evaluate::connect_for_test;
use crate::integrator::bdpt::{Bdpt, ResetMode, VertexKind};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, Sampler, Stats};

/// What the MIS check saw, so that it cannot pass vacuously.
#[derive(Debug, Default)]
struct MisCounts {
    /// Paths whose weights were checked.
    checked: usize,
    /// Checked paths by vertex count.
    lengths: [usize; 9],
    /// Paths with a medium vertex.
    medium: usize,
    /// Paths with a medium vertex that shifts the wavelength, on the camera sub-path (i < s) and
    /// on the light sub-path.
    medium_shift_camera: usize,
    medium_shift_light: usize,
    /// Paths with both an interior surface vertex and a medium vertex.
    mixed: usize,
    /// Paths with medium vertices on both sub-paths.
    medium_both_sides: usize,
    /// Connections (t ≥ 1) with a medium vertex at one of their ends.
    medium_connection: usize,
    /// Connections (t ≥ 1) that cross a medium (a stretch on the connecting segment).
    through_medium: usize,
    /// Paths skipped because their own strategy's pdf is 0.
    own_pdf_zero: usize,
}

/// The MIS weights of all strategies for one path sum to 1, the weight of the sampling strategy
/// computed from its own pdf equals its entry, and every strategy's pdf is finite and
/// non-negative, on paths with medium vertices (camera and light sub-paths), wavelength shifts at
/// fluorescent medium vertices and connections through media; forward and backward resets,
/// balance and power heuristics, on media-scattering.json (isotropic fluorescent fog with a
/// block) and the dye box of tests/common (Henyey–Greenstein fluorescent medium in a grey room).
/// Only paths the render would use are checked (a visible camera wavelength, light tracing onto
/// the film). Each configuration must check more than 1000 paths, every length of 3–8 vertices,
/// and thousands of paths of each medium kind of [`MisCounts`].
#[test]
fn mis_weights_sum_to_one_with_medium_vertices() {
    let scenes = [
        ("media-scattering", load("media-scattering.json")),
        ("dye-box", dye_box()),
    ];
    for (name, scene) in &scenes {
        assert!(scene.has_media);
        let (w_px, h_px) = (scene.camera.width as f32, scene.camera.height as f32);
        for mode in [ResetMode::Forward, ResetMode::Backward] {
            for h in [MisHeuristic::Balance, MisHeuristic::Power] {
                let opts = IntegratorOptions {
                    max_depth: 7,
                    mis: h,
                    ..Default::default()
                };
                let b = Bdpt::new(scene, &opts, mode).unwrap();
                let mut scratch = b.scratch(scene);
                let mut stats = Stats::default();
                let mut sampler = Sampler::from_seed(7);
                let mut n = MisCounts::default();
                let mut w = Vec::new();
                for i in 0..12000 {
                    let x = (i % 32) as f32 / 32.0 * w_px + 0.5;
                    let y = (i / 32 % 32) as f32 / 32.0 * h_px + 0.5;
                    b.trace_subpaths(scene, (x, y), &mut sampler, &mut scratch, &mut stats);
                    let (nc, nl) = (scratch.camera().len(), scratch.light().len());
                    for s in 1..=nc {
                        for t in 0..=nl {
                            let k = s + t;
                            if !(2..=8).contains(&k) || (t == 0 && s < 2) {
                                continue;
                            }
                            let Some(p) = connect_for_test(&b, scene, &scratch, s, t, &mut sampler)
                            else {
                                continue;
                            };
                            // Only paths the render would use: a camera wavelength the observer
                            // sees, and light tracing onto the film.
                            if scene.observer.xyz_weight(p.lambda[0]) == glam::Vec3::ZERO {
                                continue;
                            }
                            let to_x1 = (p.v[1].p - p.v[0].p).normalize();
                            if s == 1 && scene.camera.project(to_x1).is_none() {
                                continue;
                            }
                            let ps = p.strategy_pdf(s, mode);
                            let pdfs: Vec<f64> =
                                (1..=k).map(|sh| p.strategy_pdf(sh, mode)).collect();
                            assert!(
                                pdfs.iter().all(|x| x.is_finite() && *x >= 0.0),
                                "{name} {mode:?} k={k} s={s}: strategy pdfs {pdfs:?}"
                            );
                            if ps <= 0.0 {
                                n.own_pdf_zero += 1;
                                continue;
                            }
                            let what = format!("{name} {mode:?} {h:?} k={k} s={s}");
                            assert_weights(&p, s, (mode, h), &mut w, &what);
                            n.checked += 1;
                            n.lengths[k] += 1;
                            let medium = |i: usize| p.v[i].kind == VertexKind::Medium;
                            let interior = 1..k - 1;
                            if interior.clone().any(medium) {
                                n.medium += 1;
                            }
                            if (1..s.min(k - 1)).any(|i| medium(i) && p.shift[i]) {
                                n.medium_shift_camera += 1;
                            }
                            if (s..k - 1).any(|i| medium(i) && p.shift[i]) {
                                n.medium_shift_light += 1;
                            }
                            if interior.clone().any(medium)
                                && interior.clone().any(|i| p.v[i].kind == VertexKind::Surface)
                            {
                                n.mixed += 1;
                            }
                            if (1..s).any(medium) && (s..k - 1).any(medium) {
                                n.medium_both_sides += 1;
                            }
                            if t >= 1 {
                                if medium(s - 1) || medium(s) {
                                    n.medium_connection += 1;
                                }
                                let seg = p.seg[s - 1];
                                if seg.last > seg.first {
                                    n.through_medium += 1;
                                }
                            }
                        }
                    }
                }
                eprintln!("{name} {mode:?} {h:?}: {n:?}");
                let what = format!("{name} {mode:?} {h:?}: {n:?}");
                assert!(n.checked > 1000, "{what}");
                assert!(n.lengths[3..=8].iter().all(|&c| c > 0), "{what}");
                assert!(n.medium > 20_000, "{what}");
                assert!(n.medium_shift_camera > 1000, "{what}");
                assert!(n.medium_shift_light > 1000, "{what}");
                assert!(n.mixed > 20_000, "{what}");
                assert!(n.medium_both_sides > 1000, "{what}");
                assert!(n.medium_connection > 10_000, "{what}");
                assert!(n.through_medium > 20_000, "{what}");
            }
        }
    }
}
