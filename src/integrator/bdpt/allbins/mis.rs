//! Directional-only MIS for the all-bins BDPT (Jung 6.4.2): the wavelength pdfs drop out because
//! no strategy samples wavelengths, so the weights are pbrt-v4's `MISWeight` on area pdfs.

use super::Vertex;
use crate::integrator::MisHeuristic;
use crate::scene::Scene;

/// Pdf overrides for the four vertices next to the connection (pbrt's `ScopedAssignment`s).
struct Overrides {
    pt: f32,
    pt_minus: f32,
    qs: f32,
    qs_minus: f32,
}

/// MIS weight of strategy (s, t): w = 1 / Σ_i (p_i / p_s)^β (Veach eq. 10.9 via pbrt ratios).
/// `sampled` replaces the light vertex when s = 1 or the camera vertex when t = 1.
pub fn weight(
    scene: &Scene,
    heuristic: MisHeuristic,
    light: &[Vertex],
    camera: &[Vertex],
    s: usize,
    t: usize,
    sampled: Option<&Vertex>,
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

    let o = Overrides {
        pt: match qs {
            Some(qs) => qs.pdf(scene, qs_minus, pt),
            None => pt.pdf_light_origin(scene),
        },
        pt_minus: match (pt_minus, qs) {
            (Some(pm), Some(qs)) => pt.pdf(scene, Some(qs), pm),
            (Some(pm), None) => pt.pdf_emit(scene, pm),
            _ => 0.0,
        },
        qs: match qs {
            Some(qs) => pt.pdf(scene, pt_minus, qs),
            None => 0.0,
        },
        qs_minus: match (qs, qs_minus) {
            (Some(qs), Some(qm)) => qs.pdf(scene, Some(pt), qm),
            _ => 0.0,
        },
    };
    let e = heuristic.exponent();
    let powr = |r: f32| if e == 1.0 { r } else { r * r };
    let remap = |f: f32| if f != 0.0 { f } else { 1.0 };
    let mut sum = 0.0f32;
    // Camera side: vertices t−1 … 1 (the pinhole is never hit).
    let mut ri = 1.0f32;
    for i in (1..t).rev() {
        let rev = if i == t - 1 {
            o.pt
        } else if i + 2 == t {
            o.pt_minus
        } else {
            camera[i].pdf_rev
        };
        ri *= remap(rev) / remap(camera[i].pdf_fwd);
        sum += powr(ri);
    }
    // Light side: vertices s−1 … 0 (area lights only, no δ vertices).
    let mut ri = 1.0f32;
    for i in (0..s).rev() {
        let (rev, fwd) = if i == s - 1 {
            (o.qs, qs.map_or(1.0, |v| v.pdf_fwd))
        } else if i + 2 == s {
            (o.qs_minus, light[i].pdf_fwd)
        } else {
            (light[i].pdf_rev, light[i].pdf_fwd)
        };
        ri *= remap(rev) / remap(fwd);
        sum += powr(ri);
    }
    1.0 / (1.0 + sum)
}
