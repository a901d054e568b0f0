//! The free-flight pdfs that the bidirectional tracers' MIS weights use are the pdfs the
//! sub-paths actually sampled with.
//!
//! In a homogeneous medium each sampled segment keeps the weight W = T(λ)·ρ/p of its free
//! flight, with p the pdf of the tracking that sampled it, at the wavelength it carried. The MIS
//! weights evaluate the same segment's pdf again, from the stored stretches, in the direction and
//! with the coefficients (camera: column sum, light: row sum) of the sub-path that sampled it.
//! Where the reset left a segment's wavelength unchanged, W·p_MIS must therefore equal the
//! analytic transmittance T(λ) = exp(−Σ σ̂t(λ)·len) of its stretches, for every tracking mode
//! (the aware density needs the distance past medium vertices, which this checks too).

use crate::geometry::Ray;
use crate::integrator::bdpt::evaluate::connect_for_test;
use crate::integrator::bdpt::{Bdpt, ResetMode, VertexKind};
use crate::integrator::{Integrator, IntegratorOptions, Sampler, Stats};
use crate::medium::Tracking;
use crate::scene::Scene;
use std::path::Path;

#[test]
fn segment_pdfs_match_the_sampling() {
    let mut scene = Scene::load(Path::new("scenes/media-scattering.json")).unwrap();
    // Forward scattering: a phase function's pdfs depend on both neighbours of a vertex.
    scene.media[0].g = 0.7;
    for tracking in [Tracking::Exponential, Tracking::Max, Tracking::Aware] {
        for mode in [ResetMode::Forward, ResetMode::Backward] {
            let opts = IntegratorOptions {
                max_depth: 6,
                tracking,
                ..Default::default()
            };
            let b = Bdpt::new(&scene, &opts, mode).unwrap();
            let mut scratch = b.scratch(&scene);
            let mut stats = Stats::default();
            let mut sampler = Sampler::from_seed(3);
            let (mut camera_side, mut light_side, mut collisions) = (0, 0, 0);
            let mut fars = 0;
            for i in 0..3000 {
                let (x, y) = (
                    (i % 16) as f32 * 8.0 + 3.0,
                    (i / 16 % 16) as f32 * 8.0 + 3.0,
                );
                b.trace_subpaths(&scene, (x, y), &mut sampler, &mut scratch, &mut stats);
                let (nc, nl) = (scratch.camera().len(), scratch.light().len());
                for s in 1..=nc {
                    for t in 0..=nl {
                        let k = s + t;
                        if !(2..=7).contains(&k) || (t == 0 && s < 2) {
                            continue;
                        }
                        let Some(p) = connect_for_test(&b, &scene, &scratch, s, t, &mut sampler)
                        else {
                            continue;
                        };
                        if tracking == Tracking::Aware {
                            far_distances_are_right(&scene, &p);
                            fars += 1;
                        }
                        pdfs_are_functions_of_the_path(&scene, &p, s, t);
                        for i in 0..k - 1 {
                            if t >= 1 && i + 1 == s {
                                continue; // the connection: not sampled
                            }
                            let seg = p.seg[i];
                            if seg.lambda != p.lambda[i] {
                                continue; // re-targeted by the reset
                            }
                            let st = seg.stretches(&p.stretches);
                            let tr: f64 = st
                                .iter()
                                .map(|x| {
                                    let m = scene.medium(x.medium).unwrap();
                                    let c = m.coefficients.at(1, p.lambda[i]).hat_t;
                                    (-(c as f64) * x.len as f64).exp()
                                })
                                .product();
                            let camera_sampled = i + 1 < s;
                            let pdf = if camera_sampled {
                                p.dist_fwd[i]
                            } else {
                                p.dist_rev[i]
                            };
                            let got = seg.w as f64 * pdf;
                            assert!(
                                (got - tr).abs() <= 2e-3 * tr.max(1e-6),
                                "{tracking:?} {mode:?} s={s} t={t} segment {i}: W·p = {got}, T = {tr}"
                            );
                            if camera_sampled {
                                camera_side += 1;
                            } else {
                                light_side += 1;
                            }
                            let end = if camera_sampled { i + 1 } else { i };
                            if p.v[end].kind == VertexKind::Medium {
                                collisions += 1;
                            }
                        }
                    }
                }
            }
            eprintln!(
                "{tracking:?} {mode:?}: {camera_side} camera and {light_side} light segments, \
                 {collisions} ending at a collision"
            );
            assert!(camera_side > 1000 && light_side > 1000 && collisions > 1000);
            assert!(tracking != Tracking::Aware || fars > 1000);
        }
    }
}

/// Every area pdf that the MIS weights use is the pdf of its vertex given its neighbours on the
/// final path (times the segment's free-flight pdf), whichever strategy built the path: the
/// stored sub-path pdfs and the ones recomputed at the connection agree with a direct
/// evaluation, including the reverse pdfs next to the connection, which at a phase function
/// depend on the connection's other end.
fn pdfs_are_functions_of_the_path(
    scene: &Scene,
    p: &crate::integrator::bdpt::FullPath,
    s: usize,
    t: usize,
) {
    let k = p.k;
    let v = &p.v;
    // Directions re-derived from vertex positions differ from the sampled ones by the ray offsets
    // at surfaces and boundaries (2e-4 each, laterally): on segments shorter than 0.2, or at
    // grazing angles to a surface (|cos| < 0.2, where a diffuse pdf's relative error is the
    // angle error times tan θ), that is up to a few per cent of a pdf, so those are skipped, and
    // elsewhere 5 % is allowed (the largest seen is 1 %). A wrong neighbour changes a pdf by tens of per cent.
    let close = |a: f64, b: f64| (a - b).abs() <= 5e-2 * b.abs().max(1e-30);
    let long = |a: usize, b: usize| {
        let d = v[b].p - v[a].p;
        let w = d.normalize();
        let steep = |x: &crate::integrator::bdpt::Vertex| {
            x.kind != VertexKind::Surface || x.n.dot(w).abs() > 0.2
        };
        d.length() > 0.2 && steep(&v[a]) && steep(&v[b])
    };
    for i in 1..k {
        if !long(i - 1, i) || (i >= 2 && !long(i - 2, i - 1)) {
            continue;
        }
        let prev = (i >= 2).then(|| &v[i - 2]);
        let want = v[i - 1].pdf(scene, prev, &v[i]) as f64 * p.dist_fwd[i - 1];
        assert!(
            close(p.pa_fwd[i], want),
            "s={s} t={t} pa_fwd[{i}] = {} vs {want}",
            p.pa_fwd[i]
        );
    }
    for i in 1..k - 1 {
        if !long(i, i + 1) || (i + 2 < k && !long(i + 1, i + 2)) {
            continue;
        }
        let want = if i == k - 2 {
            v[k - 1].pdf_emit(scene, &v[k - 2]) as f64
        } else {
            v[i + 1].pdf(scene, Some(&v[i + 2]), &v[i]) as f64
        } * p.dist_rev[i];
        assert!(
            close(p.pa_rev[i], want),
            "s={s} t={t} pa_rev[{i}] = {} vs {want}; {:?}",
            p.pa_rev[i],
            v.iter().map(|x| (x.kind, x.p)).collect::<Vec<_>>()
        );
    }
}

/// The aware density's distances past medium vertices (stored by the sub-paths, or cast at the
/// connection) equal a direct ray cast past each medium end of each segment, along the
/// segment's stretch that holds the vertex.
fn far_distances_are_right(scene: &Scene, p: &crate::integrator::bdpt::FullPath) {
    let dist = |o: glam::Vec3, d: glam::Vec3| {
        let ray = Ray::new(o, d);
        scene
            .intersect(&ray, f32::INFINITY)
            .map_or(f32::INFINITY, |h| h.t)
    };
    let close = |a: f32, b: f32| a == b || (a - b).abs() <= 1e-4 * b.abs().max(1.0);
    for i in 0..p.k - 1 {
        let (a, b) = (&p.v[i], &p.v[i + 1]);
        let seg = p.seg[i];
        let st = seg.stretches(&p.stretches);
        if b.kind == VertexKind::Medium {
            let want = dist(b.p, st[st.len() - 1].d);
            assert!(
                close(seg.far_end, want),
                "segment {i}: far end {} vs {want}",
                seg.far_end
            );
        }
        if a.kind == VertexKind::Medium {
            let want = dist(a.p, -st[0].d);
            let got = seg.far_start;
            assert!(close(got, want), "segment {i}: far start {got} vs {want}");
        }
    }
}
