//! Directional-only MIS for the all-bins BDPT (Jung 6.4.2): the wavelength pdfs drop out because
//! no strategy samples wavelengths, so the weight is the ratio walk of every BDPT
//! (`bdpt::weight`) on area pdfs, with the pdfs across the connection replaced.

use super::Vertex;
use crate::integrator::MisHeuristic;
use crate::integrator::bdpt::connection::{Connection, End};
use crate::integrator::bdpt::weight::mis_walk;
use crate::scene::Scene;

/// Media: the free-flight pdfs next to the connection that the sub-paths' stored pdfs lack (1
/// without media): the connection sampled from the camera end towards the light end and back,
/// and the segments reaching the two end vertices sampled in reverse.
#[derive(Clone, Copy, Debug)]
pub struct MediaPdfs {
    pub conn_to_light: f32,
    pub conn_to_camera: f32,
    pub cam_rev: f32,
    pub light_rev: f32,
}

impl Default for MediaPdfs {
    fn default() -> Self {
        MediaPdfs {
            conn_to_light: 1.0,
            conn_to_camera: 1.0,
            cam_rev: 1.0,
            light_rev: 1.0,
        }
    }
}

/// Pdf overrides for the four vertices next to the connection (pbrt's `ScopedAssignment`s).
struct Overrides {
    pt: f32,
    pt_minus: f32,
    qs: f32,
    qs_minus: f32,
}

/// MIS weight of strategy (s, t) (s light vertices, t camera vertices): w = 1 / Σ_i (p_i / p_s)^β
/// (Veach eq. 10.9).
/// `sampled` replaces the light vertex when s = 1 or the camera vertex when t = 1; `media`
/// holds the free-flight pdfs of the connection and of the segments next to it.
#[allow(clippy::too_many_arguments)]
pub fn weight(
    scene: &Scene,
    heuristic: MisHeuristic,
    light: &[Vertex],
    camera: &[Vertex],
    s: usize,
    t: usize,
    sampled: Option<&Vertex>,
    media: MediaPdfs,
) -> f32 {
    if s + t == 2 {
        return 1.0;
    }
    let qs = if s == 1 {
        sampled.or(light.first())
    } else if s > 1 {
        Some(&light[s - 1])
    } else {
        None
    };
    let pt = if t == 1 {
        sampled.or(camera.first())
    } else {
        Some(&camera[t - 1])
    };
    let pt = pt.expect("t >= 1");
    let qs_minus = if s > 1 { Some(&light[s - 2]) } else { None };
    let pt_minus = if t > 1 { Some(&camera[t - 2]) } else { None };

    let m = media;
    // the pdfs across the connection pt ↔ qs (`Connection::pdfs`)
    let conn = qs.map(|qs| {
        let (a, b) = (End::of(scene, pt, pt_minus), End::of(scene, qs, qs_minus));
        Connection::new(pt, qs).pdfs(scene, &a, &b)
    });
    let o = Overrides {
        pt: match conn {
            Some((_, rev)) => rev * m.conn_to_camera,
            None => pt.pdf_light_origin(scene),
        },
        pt_minus: match (pt_minus, qs) {
            (Some(pm), Some(qs)) => pt.pdf(scene, Some(qs), pm) * m.cam_rev,
            (Some(pm), None) => pt.pdf_emit(scene, pm) * m.cam_rev,
            _ => 0.0,
        },
        qs: match conn {
            Some((fwd, _)) => fwd * m.conn_to_light,
            None => 0.0,
        },
        qs_minus: match (qs, qs_minus) {
            (Some(qs), Some(qm)) => qs.pdf(scene, Some(pt), qm) * m.light_rev,
            _ => 0.0,
        },
    };
    // The path in path order x0 … x(k−1) has the t camera vertices first, then the s light
    // vertices turned around; the walk of every BDPT (`super::super::weight`) with the pdfs
    // across the connection replaced and the wavelength pdfs left out (Jung 6.4.2).
    let cam_rev = |i: usize| {
        if i == t - 1 {
            o.pt
        } else if i + 2 == t {
            o.pt_minus
        } else {
            camera[i].pdf_rev
        }
    };
    let lower = (1..t).map(|i| (camera[i].pdf_fwd as f64, cam_rev(i) as f64));
    let upper = (0..s).rev().map(|i| {
        let (fwd, rev) = if i == s - 1 {
            (o.qs, qs.map_or(1.0, |v| v.pdf_fwd))
        } else if i + 2 == s {
            (o.qs_minus, light[i].pdf_fwd)
        } else {
            (light[i].pdf_rev, light[i].pdf_fwd)
        };
        (fwd as f64, rev as f64)
    });
    // f64: the ratios of pdfs through media (1/d² of close collisions) can exceed f32's range.
    let (_, w) = mis_walk(lower, upper, t, |_| 1.0, heuristic);
    if w.is_nan() { 0.0 } else { w as f32 }
}
