//! Connecting sub-paths for every strategy (s, t), the measurement contribution f_j (eq. 6.2)
//! and the weighted throughput w · f / p (eqs. 6.18, 6.19).

use super::cache::{SpectralCache, SubpathCache};
use super::connection::{
    Connection, Contribution, End, Seg, camera_term, splat, splat_position, weighted, xyz_weight,
};
use super::mis::{FullPath, ResetMode};
use super::reset;
use super::subpath::{Lambdas, Vertex, sample_light_vertex};
use super::wavelength::light_wavelength;
use super::{Bdpt, Scratch};
use crate::integrator::{SampleSink, Sampler, Stats};
use crate::material::{Bbrrdf, PathSide, ShiftSampling};
use crate::scene::{NONE, Scene};
use crate::transport::VertexKind;
use crate::transport::spectral::with_spectrum;

/// The measurement contribution f_j of the path (eq. 6.2) without visibility and without the
/// transmittance of its segments, with the pinhole importance We = 1 / (A cos⁴θ) of the whole
/// film at unit distance (the camera strategies' pixel sample and the light-tracing splat then
/// both estimate the pixel's average radiance). A medium vertex contributes its collision
/// coefficient per unit density and its phase function (no cosines); its density is part of the
/// free-flight weight of the segment that sampled it.
#[cfg(test)]
fn measurement(scene: &Scene, path: &FullPath) -> f64 {
    let k = path.k;
    let v = &path.v;
    let e = &v[k - 1];
    let light = &scene.lights[e.light as usize];
    let we = (v[k - 2].p - e.p).normalize();
    let mut f = light.le(path.lambda[k - 2], e.n, we) as f64;
    if f <= 0.0 {
        return 0.0;
    }
    // x0 → x1: the pinhole importance and the geometry term without a cosine at the pinhole
    let (mut w, d2) = v[0].towards(&v[1]);
    let head = camera_term(scene, w, d2, &v[1]);
    if head <= 0.0 {
        return 0.0;
    }
    f *= head;
    // Each interior vertex: f = f_λ · f_dir, then the segment towards the light.
    for i in 1..=k - 2 {
        let x = &v[i];
        let (lambda_in, lambda_out, shifted) = (path.lambda[i], path.lambda[i - 1], path.shift[i]);
        let (wi, d2) = x.towards(&v[i + 1]);
        let f_l =
            with_spectrum!(scene, x, m => m.eval(lambda_in, lambda_out, shifted), else return 0.0);
        let (f_dir, cos) = (x.scattering(scene).eval(-w, wi), x.abs_cos(wi));
        if f_dir == 0.0 {
            return 0.0;
        }
        f *= f_l as f64 * f_dir as f64;
        f *= cos as f64 * v[i + 1].abs_cos(wi) as f64 / d2 as f64;
        if f <= 0.0 {
            return 0.0;
        }
        w = wi;
    }
    f
}

/// The sub-paths of a sample and their caches, built on first use.
pub(super) struct Subpaths<'a> {
    pub cam: &'a mut SubpathCache,
    pub cam_v: &'a [Vertex],
    pub lc: &'a mut SubpathCache,
    pub light_v: &'a [Vertex],
}

/// One interior vertex of [`measurement`]: f_λ (`None`: the vertex has no spectral part), f_dir
/// and the geometry factor of the segment that leaves it towards the light. False when f is 0
/// (NaN goes on, as in [`measurement`]).
#[inline(always)]
fn vertex_factor(f: &mut f64, f_l: Option<f32>, f_dir: f32, g: f64) -> bool {
    let Some(f_l) = f_l else { return false };
    if f_dir == 0.0 {
        return false;
    }
    // eq. 6.2: f_λ · f_dir, then G of the next segment
    *f *= f_l as f64 * f_dir as f64;
    *f *= g;
    *f > 0.0 || f.is_nan()
}

/// [`measurement`] of strategy (s, t) with the factors its sub-paths fix taken from their caches
/// (`cache`): the same products in the same order, so the same value to the bit. Only the
/// connection segment, f_dir at its two ends, the emitter and f_λ at wavelengths not seen
/// before are evaluated.
pub(super) fn measurement_cached(
    scene: &Scene,
    path: &FullPath,
    s: usize,
    sub: Subpaths,
    spec: &mut SpectralCache,
) -> f64 {
    let Subpaths {
        cam,
        cam_v,
        lc,
        light_v,
    } = sub;
    let k = path.k;
    let (v, lambda, shift) = (&path.v[..k], &path.lambda[..k], &path.shift[..k]);
    let e = &v[k - 1];
    let light = &scene.lights[e.light as usize];
    let we = (v[k - 2].p - e.p).normalize();
    let mut f = light.le(lambda[k - 2], e.n, we) as f64;
    if f <= 0.0 {
        return 0.0;
    }
    // x0 → x1: the pinhole importance and the geometry term without a cosine at the pinhole
    let (head, mut w) = if s >= 2 {
        cam.camera(scene, cam_v);
        (cam.head, cam.seg(s - 2).w)
    } else {
        let (w, d2) = v[0].towards(&v[1]);
        (camera_term(scene, w, d2, &v[1]), w)
    };
    if head <= 0.0 {
        return 0.0;
    }
    f *= head;
    // Interior vertices in path order: x1 … x(s−2) inside the camera prefix, x(s−1) and x_s at
    // the connection, x(s+1) … x(k−2) inside the light suffix (light vertex k − 1 − i).
    for i in 1..s.saturating_sub(1) {
        let f_l = spec.f_lambda(scene, &v[i], lambda[i], lambda[i - 1], shift[i]);
        if !vertex_factor(&mut f, f_l, cam.dir(i), cam.seg(i).g) {
            return 0.0;
        }
    }
    if s >= 2 && s < k {
        let (i, x) = (s - 1, &v[s - 1]);
        let f_l = spec.f_lambda(scene, x, lambda[i], lambda[i - 1], shift[i]);
        let seg = Seg::new(x, &v[s]);
        let f_dir = x.scattering(scene).eval(-w, seg.w);
        if !vertex_factor(&mut f, f_l, f_dir, seg.g) {
            return 0.0;
        }
        w = seg.w;
    }
    if s + 2 <= k {
        lc.light(scene, light_v);
        let (j, x) = (k - 1 - s, &v[s]);
        let f_l = spec.f_lambda(scene, x, lambda[s], lambda[s - 1], shift[s]);
        let seg = lc.seg(j);
        let f_dir = x.scattering(scene).eval(-w, seg.w);
        if !vertex_factor(&mut f, f_l, f_dir, seg.g) {
            return 0.0;
        }
    }
    for i in s + 1..k.saturating_sub(1) {
        let j = k - 1 - i;
        let f_l = spec.f_lambda(scene, &v[i], lambda[i], lambda[i - 1], shift[i]);
        if !vertex_factor(&mut f, f_l, lc.dir(j), lc.seg(j).g) {
            return 0.0;
        }
    }
    f
}

/// Fill the directional and wavelength pdfs of the path for MIS (eqs. 6.3, 6.4–6.8).
pub(super) fn fill_pdfs(
    b: &Bdpt,
    scene: &Scene,
    path: &mut FullPath,
    (s, t): (usize, usize),
    memo: &mut super::cache::VertexPdfMemo,
) {
    let k = path.k;
    let FullPath {
        v,
        lambda,
        shift,
        pa_fwd,
        pa_rev,
        pc,
        big_pc,
        pl,
        big_pl,
        ..
    } = path;
    let (v, lambda, shift) = (&v[..k], &lambda[..k], &shift[..k]);
    let (pa_fwd, pa_rev) = (&mut pa_fwd[..k], &mut pa_rev[..k]);
    // the camera prefix keeps its sub-path's directions, the light suffix is turned around
    for i in 0..s {
        (pa_fwd[i], pa_rev[i]) = (v[i].pdf_fwd as f64, v[i].pdf_rev as f64);
    }
    for i in s..k {
        (pa_fwd[i], pa_rev[i]) = (v[i].pdf_rev as f64, v[i].pdf_fwd as f64);
    }
    // the pdfs across the connection, from the transport layer (pbrt `Vertex::Pdf`)
    if t == 0 {
        // the camera path hit the emitter: light point and emission pdfs at x(k−1)
        let e = &v[k - 1];
        pa_rev[k - 1] = e.pdf_light_origin(scene) as f64;
        pa_rev[k - 2] = e.pdf_emit(scene, &v[k - 2]) as f64;
    } else {
        // the connection segment x(s−1) ↔ x_s
        let a = End::of(scene, &v[s - 1], s.checked_sub(2).map(|i| &v[i]));
        let b = End::of(scene, &v[s], v.get(s + 1));
        let (fwd, rev) = Connection::new(&v[s - 1], &v[s]).pdfs(scene, &a, &b);
        (pa_fwd[s], pa_rev[s - 1]) = (fwd as f64, rev as f64);
        // One vertex further: a phase function's pdf depends on the other neighbour, which the
        // connection changed (a diffuse lobe's does not: the stored pdfs stand).
        if s >= 2 && v[s - 1].kind == VertexKind::Medium {
            pa_rev[s - 2] = v[s - 1].pdf(scene, Some(&v[s]), &v[s - 2]) as f64;
        }
        if s + 1 < k && v[s].kind == VertexKind::Medium {
            pa_fwd[s + 1] = v[s].pdf(scene, Some(&v[s - 1]), &v[s + 1]) as f64;
        }
    }
    // wavelength pdfs of each interior vertex (eqs. 6.6–6.8; media: transport::spectral)
    for i in 1..=k.saturating_sub(2) {
        let x = &v[i];
        let p = if x.fluorescent {
            let pair = (lambda[i], lambda[i - 1], shift[i]);
            // vertex i is the camera sub-path's x_i or the light sub-path's y(k−1−i)
            let (side, j) = if i < s { (false, i) } else { (true, k - 1 - i) };
            let eval = || {
                let (lambda_in, lambda_out, shifted) = pair;
                with_spectrum!(scene, x, m => Some(wavelength_pdfs(m, lambda_in, lambda_out, shifted, b.shift)), else None)
            };
            match memo.get(side, j, pair, eval) {
                Some(p) => p,
                None => continue,
            }
        } else if x.scatters() {
            NO_SHIFT
        } else {
            continue;
        };
        (pc[i], big_pc[i], pl[i], big_pl[i]) = (p[0], p[1], p[2], p[3]);
    }
    path.pc0 = scene
        .observer
        .pdf_wavelength(b.camera_wavelengths, path.lambda[0]) as f64;
    path.ple = scene.lights.pdf_wavelength(
        path.v[k - 1].light as usize,
        path.lambda[k - 2],
        b.light_wavelengths,
    ) as f64;
}

/// [`wavelength_pdfs`] of a vertex that cannot shift: p_c = p_l = 1, P_c = P_l = 0.
const NO_SHIFT: [f64; 4] = [1.0, 0.0, 1.0, 0.0];

/// The camera- and light-side wavelength pdfs of an interior vertex whose pair is (λ_i = `li`,
/// λ(i−1) = `lo`) and its P_c, P_l: [p_c, P_c, p_l, P_l].
#[inline(always)]
fn wavelength_pdfs(
    m: &impl Bbrrdf,
    lambda_in: f32,
    lambda_out: f32,
    shifted: bool,
    ws: ShiftSampling,
) -> [f64; 4] {
    if m.is_fluorescent() {
        let big_pc = m.fluorescence_probability_camera(lambda_out);
        let big_pl = m.fluorescence_probability_light(lambda_in);
        let (pc, pl) = if shifted {
            (
                m.pdf(lambda_out, lambda_in, true, PathSide::Camera, ws),
                m.pdf(lambda_in, lambda_out, true, PathSide::Light, ws),
            )
        } else {
            // no fluorescent interaction: 1 − P_c and 1 − P_l, as `Bbrrdf::pdf` gives them
            (1.0 - big_pc, 1.0 - big_pl)
        };
        [pc as f64, big_pc as f64, pl as f64, big_pl as f64]
    } else {
        NO_SHIFT
    }
}

/// Index of the strategy image of (s, t): ordered by k = s + t, then s.
pub fn strategy_layer(s: usize, t: usize) -> usize {
    let k = s + t;
    (k - 1) * k / 2 - 1 + (s - 1)
}

impl Bdpt {
    /// Set the wavelengths of the connected path (Jung 6.3): light tracing keeps the light
    /// sub-path's, camera hits and forward NEE keep the camera's, otherwise the forward or
    /// backward reset walks from the connection.
    #[inline(always)]
    pub(super) fn reset(
        &self,
        mode: ResetMode,
        scene: &Scene,
        path: &mut FullPath,
        (s, t): (usize, usize),
        sampler: &mut Sampler,
    ) {
        let k = path.k;
        match (mode, s, t) {
            (_, 1, _) => reset::light_only(path),
            (ResetMode::Forward, _, 0 | 1) => reset::camera_only(path),
            (ResetMode::Forward, _, _) => reset::forward_reset(scene, path, s, sampler),
            (ResetMode::Backward, _, 0) => {
                // camera hit the emitter: λ(k−2) from its emission, then walk (Jung 6.3.3)
                let (light, mode) = (path.v[k - 1].light, self.light_wavelengths);
                path.lambda[k - 2] = light_wavelength(scene, light, mode, sampler).lambda;
                reset::backward_reset(scene, path, k - 1, sampler);
            }
            (ResetMode::Backward, _, _) => {
                reset::backward_reset_light_path(scene, path, s, sampler)
            }
        }
    }

    /// A fresh light vertex for next-event estimation (Jung 6.3.4); the backward reset first
    /// draws its wavelength from the chosen light (then walks the camera path).
    #[inline(always)]
    pub(super) fn fresh_light_vertex(&self, scene: &Scene, sampler: &mut Sampler) -> Vertex {
        let mut lv = sample_light_vertex(scene, sampler);
        if self.mode == ResetMode::Backward {
            let lambda = light_wavelength(scene, lv.light, self.light_wavelengths, sampler).lambda;
            lv.data = Lambdas::both(lambda);
        }
        lv
    }

    /// Put the vertices of strategy (s, t) into `scratch.path` (t = 1, s ≥ 2: a fresh light
    /// vertex, returns true); the camera prefix of the previous connection stays when it has
    /// the same s.
    #[inline(always)]
    pub(super) fn assemble(
        &self,
        scene: &Scene,
        (s, t): (usize, usize),
        sampler: &mut Sampler,
        scratch: &mut Scratch,
    ) -> bool {
        let path = &mut scratch.path;
        if scratch.prefix == s {
            path.reset_keeping(s + t, s);
        } else {
            path.reset(s + t);
            path.v.extend_from_slice(&scratch.cam[..s]);
            scratch.prefix = s;
        }
        let fresh = t == 1 && s >= 2;
        if fresh {
            path.v.push(self.fresh_light_vertex(scene, sampler));
        } else {
            // the light sub-path's first t vertices, in path order
            let nl = scratch.light.len();
            path.v.extend_from_slice(&scratch.light_rev[nl - t..]);
        }
        fresh
    }

    /// Connect the camera prefix of length `s` with the light suffix of length `t` (t = 1: a
    /// fresh light vertex) and add the weighted contribution: plain paths (`plain`) without
    /// assembling them, the others with the wavelength reset of the full path.
    pub(super) fn connect(
        &self,
        scene: &Scene,
        s: usize,
        t: usize,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        sink: &mut SampleSink,
    ) {
        if let Some(choice) = self.combined {
            return self.connect_combined(scene, (s, t), choice, sampler, scratch, sink);
        }
        let c = if !scene.has_media && scratch.plain.covers(s, t) {
            self.connect_plain(scene, (s, t), sampler, scratch, sink.stats)
        } else {
            self.connect_full(scene, (s, t), sampler, scratch, sink.stats)
        };
        if let Some(c) = c {
            self.deliver(s, t, c, sink);
        }
    }

    /// Connect strategy (s, t) on the full path: reset wavelengths (Jung 6.3), then the
    /// weighted contribution w · f / p (eqs. 6.18, 6.19) in XYZ.
    pub(super) fn connect_full(
        &self,
        scene: &Scene,
        (s, t): (usize, usize),
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        stats: &mut Stats,
    ) -> Option<Contribution> {
        let k = s + t;
        let fresh = self.assemble(scene, (s, t), sampler, scratch);
        let path = &mut scratch.path;
        if path.v[k - 1].light == NONE {
            return None;
        }
        let media = scene.has_media;
        if media {
            let (cam, light) = (&scratch.cam_log, &scratch.light_log);
            super::media::gather(scene, path, cam, light, s, fresh);
        }
        self.reset(self.mode, scene, path, (s, t), sampler);
        let xyz_w = xyz_weight(scene, path.lambda[0], &mut scratch.xyz);
        if xyz_w == glam::Vec3::ZERO {
            return None;
        }
        let sub = Subpaths {
            cam: &mut scratch.cam_cache,
            cam_v: &scratch.cam,
            lc: &mut scratch.light_cache,
            light_v: &scratch.light,
        };
        let f = measurement_cached(scene, path, s, sub, &mut scratch.spectral);
        if f <= 0.0 {
            return None;
        }
        let splat = if s == 1 {
            Some(splat_position(scene, &path.v[0], &path.v[1])?)
        } else {
            None
        };
        // transmittance of the connecting segment (shadow rays start on the surface side)
        let mut f = f;
        if t >= 1 {
            let rays = &mut stats.rays;
            if media {
                let mode = self.tracking;
                let tr = super::media::connection(scene, path, s, mode, rays, sampler)?;
                f *= tr as f64;
            } else {
                let tr = Connection::shadow(scene, &path.v[s - 1], &path.v[s], s == 1, rays);
                if tr.is_zero() {
                    return None;
                }
                f *= tr.at(path.lambda[s - 1]) as f64;
            }
        }
        fill_pdfs(self, scene, path, (s, t), &mut scratch.pdf_memo);
        // The strategy's own directional and wavelength pdf (eq. 6.14). This strategy has just
        // sampled the path and the path carries light, so a zero, NaN or infinite pdf is a lost
        // contribution, not a path the strategy cannot make: counted (docs/bdpt.md).
        let p = path.strategy_pdf(s, self.mode);
        if !(p > 0.0 && p.is_finite()) {
            stats.dropped_strategy_pdfs += (f != 0.0) as u64;
            return None;
        }
        // Media: the sampled free flights' weights, and their pdfs in the MIS weights.
        let p_mis = if media {
            f *= super::media::flight_weight(scene, path, s, sampler);
            let (cam, light) = (&scratch.cam_log, &scratch.light_log);
            super::media::distance_pdfs(scene, path, self.tracking, cam, light);
            path.fold_distances();
            path.strategy_pdf(s, self.mode)
        } else {
            p
        };
        let w = if self.only.is_some() {
            1.0
        } else if p_mis > 0.0 && p_mis.is_finite() {
            path.mis_weight(s, self.mode, self.mis)
        } else {
            // With the free-flight pdfs at the final wavelengths folded in, p(s) may be 0 where
            // the reset moved a segment to a wavelength its sub-path could not collide at; the
            // weight is then 0 (the limit of eq. 6.15), and a loss only if no strategy is left.
            let lost = p_mis != 0.0 || !path.any_strategy(self.mode);
            stats.dropped_strategy_pdfs += (lost && f != 0.0) as u64;
            return None;
        };
        // eqs. 6.18/6.19: w · f / (p_A p_Λ), turned into XYZ with the CIE weight at λ0
        weighted(xyz_w, path.lambda[0], w * f / p, splat, stats)
    }

    /// Add the contribution `xyz` of strategy (s, t) to the pixel, or splat it at `splat` (light
    /// tracing), and to its strategy image.
    #[inline(always)]
    pub(super) fn deliver(&self, s: usize, t: usize, c: Contribution, sink: &mut SampleSink) {
        let (xyz, splat, (lambda0, radiance)) = c;
        let ok = match splat {
            Some(at) => {
                let ok = self::splat(sink, (s, t), at, xyz, self.strategy_images);
                if ok {
                    sink.spectral_splat(at.0, at.1, lambda0, radiance);
                }
                ok
            }
            None => {
                let ok = sink.add(xyz);
                if ok {
                    sink.spectral(lambda0, radiance);
                }
                if ok && self.strategy_images {
                    sink.aux(strategy_layer(s, t), sink.pixel, xyz);
                }
                ok
            }
        };
        if ok {
            sink.stats.contribution(s + t - 1);
        }
    }
}

/// Build the full path of strategy (s, t) from the sub-paths in `scratch` (t = 1 uses the
/// light sub-path's first vertex instead of a fresh one), apply the integrator's reset and fill
/// all pdfs, free-flight pdfs included (test hook: MIS weights of all strategies for one path).
/// Returns `None` when the path carries no light.
#[cfg(test)]
pub(crate) fn connect_for_test(
    b: &Bdpt,
    scene: &Scene,
    scratch: &Scratch,
    s: usize,
    t: usize,
    sampler: &mut Sampler,
) -> Option<FullPath> {
    assert!(s >= 1 && (t >= 1 || s >= 2));
    let k = s + t;
    let mut path = FullPath::with_capacity(k);
    path.reset(k);
    path.v.extend_from_slice(&scratch.cam[..s]);
    path.v.extend(scratch.light[..t].iter().rev());
    if path.v[k - 1].light == NONE {
        return None;
    }
    if scene.has_media {
        let (cam, light) = (&scratch.cam_log, &scratch.light_log);
        super::media::gather(scene, &mut path, cam, light, s, false);
    }
    b.reset(b.mode, scene, &mut path, (s, t), sampler);
    let f = measurement(scene, &path);
    // the cached evaluation is the same to the bit, from the walks' cache and from its own
    let (mut cam, mut lc) = (scratch.cam_cache.clone(), scratch.light_cache.clone());
    let mut spec = scratch.spectral.clone();
    for _ in 0..2 {
        let sub = Subpaths {
            cam: &mut cam,
            cam_v: &scratch.cam,
            lc: &mut lc,
            light_v: &scratch.light,
        };
        let cached = measurement_cached(scene, &path, s, sub, &mut spec);
        assert_eq!(
            f.to_bits(),
            cached.to_bits(),
            "cached measurement, s = {s}, t = {t}"
        );
    }
    if f <= 0.0 {
        return None;
    }
    if scene.has_media && t >= 1 {
        let mut rays = 0;
        super::media::connection(scene, &mut path, s, b.tracking, &mut rays, sampler)?;
    }
    fill_pdfs(b, scene, &mut path, (s, t), &mut Default::default());
    if scene.has_media {
        let (cam, light) = (&scratch.cam_log, &scratch.light_log);
        super::media::distance_pdfs(scene, &mut path, b.tracking, cam, light);
        path.fold_distances();
    }
    Some(path)
}
