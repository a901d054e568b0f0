//! Wavelength resets after connecting a camera and a light sub-path (Jung 6.3.1).
//!
//! Fluorescent medium vertices reset exactly as fluorescent surfaces do, with the medium's P_c
//! and P_l (`crate::transport::spectral`).
//!
//! `path.v` holds the full path x0 … x(k−1); `path.lambda[i]` is λi on the segment
//! x(i+1) → xi and `path.shift[i]` whether xi changes the wavelength (λi ≠ λ(i−1)).

use super::mis::FullPath;
use super::subpath::Vertex;
use crate::integrator::Sampler;
use crate::material::{Bbrrdf, PathSide};
use crate::scene::Scene;
use crate::transport::spectral::with_spectrum;

/// P_c or P_l of a vertex that can shift (the reset draws a number for it), `None` otherwise.
#[inline(always)]
fn fluorescence(m: &impl Bbrrdf, lambda: f32, side: PathSide) -> Option<f32> {
    m.is_fluorescent()
        .then(|| m.fluorescence_probability(lambda, side))
}

/// [`fluorescence`] of interior vertex `v` of a path; the sub-path walk flagged the vertices
/// that can shift, so the others need no material lookup.
#[inline(always)]
fn vertex_fluorescence(scene: &Scene, v: &Vertex, lambda: f32, side: PathSide) -> Option<f32> {
    if !v.fluorescent {
        return None;
    }
    with_spectrum!(scene, v, m => fluorescence(m, lambda, side), else None)
}

/// Wavelengths of the camera vertices x0 … x(s−1) as sampled (λ0 … λ(s−1)).
#[inline]
fn copy_camera(path: &mut FullPath, s: usize) {
    for i in 0..s.min(path.k - 1) {
        path.lambda[i] = path.v[i].data.lambda_in;
        if i >= 1 {
            path.shift[i] = path.v[i].shift;
        }
    }
}

/// Wavelengths of the light vertices x(from) … x(k−1) as sampled (λ(from−1) … λ(k−2)).
#[inline]
fn copy_light(path: &mut FullPath, from: usize) {
    let k = path.k;
    for i in from.max(1)..k {
        path.lambda[i - 1] = path.v[i].data.lambda_out;
        if i <= k - 2 {
            path.shift[i] = path.v[i].shift;
        }
    }
}

/// No reset: the camera sub-path chose every wavelength (t = 0, forward t = 1).
pub fn camera_only(path: &mut FullPath) {
    let k = path.k;
    copy_camera(path, k - 1);
}

/// No reset: the light sub-path chose every wavelength (s = 1, Jung 6.3.2).
pub fn light_only(path: &mut FullPath) {
    copy_light(path, 1);
}

/// Forward reset, Jung Alg. 4: λ(s−1) from the camera, then walk x_s … x(k−2) toward the light,
/// keeping the wavelength while `P_c` says "no fluorescent interaction".
pub fn forward_reset(scene: &Scene, path: &mut FullPath, s: usize, sampler: &mut Sampler) {
    let k = path.k;
    copy_camera(path, s);
    for i in s..=k - 2 {
        let cur = path.lambda[i - 1];
        let p = vertex_fluorescence(scene, &path.v[i], cur, PathSide::Camera);
        if let Some(p) = p
            && sampler.next() < p
        {
            // Fluorescent interaction at x_i (prob. P_c): keep the light path's wavelengths.
            path.shift[i] = true;
            copy_light(path, i + 1);
            return;
        }
        path.shift[i] = false;
        path.lambda[i] = cur;
    }
}

/// Backward reset, Jung Alg. 5: λ(s−1) from the light side (already in `path.lambda[s−1]`), then
/// walk x(s−1) … x1 toward the camera, keeping the wavelength while `P_l` says "no fluorescent
/// interaction". The light-side wavelengths λ(s−1) … λ(k−2) must be set by the caller.
pub fn backward_reset(scene: &Scene, path: &mut FullPath, s: usize, sampler: &mut Sampler) {
    for i in (1..s).rev() {
        let cur = path.lambda[i];
        let p = vertex_fluorescence(scene, &path.v[i], cur, PathSide::Light);
        if let Some(p) = p
            && sampler.next() < p
        {
            // Fluorescent interaction at x_i (prob. P_l): keep the camera path's wavelengths.
            path.shift[i] = true;
            copy_camera(path, i);
            return;
        }
        path.shift[i] = false;
        path.lambda[i - 1] = cur;
    }
}

/// Backward with the light sub-path's wavelengths (t ≥ 2).
pub fn backward_reset_light_path(
    scene: &Scene,
    path: &mut FullPath,
    s: usize,
    sampler: &mut Sampler,
) {
    copy_light(path, s);
    backward_reset(scene, path, s, sampler);
}
