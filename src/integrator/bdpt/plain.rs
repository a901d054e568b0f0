//! Connections of plain paths: no vertex of the connected path can shift the wavelength (no
//! fluorescent material on it) and the scene has no media. Every vertex then sees one wavelength
//! λ*, the resets draw no numbers, and every interior vertex has the wavelength pdfs of a vertex
//! that cannot shift, so Jung's estimator (eqs. 6.2, 6.14, 6.15) simplifies:
//!
//! - the measurement f_j is a camera prefix C(s) (pinhole importance and the factors of x1 …
//!   x(s−2)) times the connection's two vertices times a light suffix L(t) (emission and the
//!   factors of y1 … y(t−2)); C and L are products kept per sub-path at λ* and extended as s
//!   and t grow, so a connection costs O(1) instead of O(k);
//! - p_Λ(ŝ) is p_c(λ*) for the camera strategies of the forward reset (eqs. 6.9/6.10 with no
//!   shift) and p_l(λ*) for light tracing and every strategy of the backward reset (eqs.
//!   6.11/6.13), and the MIS weight is the ratio walk of every BDPT (`weight::mis_walk`) over
//!   the sub-paths' stored area pdfs, so no full path is assembled.
//!
//! What stays here is what makes it fast: the product caches (C, L, the emitter's spectrum and
//! wavelength pdfs); the connection, its lobes and pdfs, the camera's importance and the MIS
//! weight are the shared ones of `connection` and `weight`. The same estimator as `evaluate`,
//! with the same random numbers; equal up to rounding, since the products are taken in another
//! order (`tests/plain.rs` compares them connection by connection).

use super::cache::{SpectralCache, SubpathCache};
use super::combined::Evaluate;
use super::connection::{
    Connection, Contribution, camera_term, splat_position, weighted, xyz_weight,
};
use super::mis::ResetMode;
use super::subpath::{Lambdas, Vertex, sample_light_vertex};
use super::wavelength::{LambdaKey, light_wavelength};
use super::weight::{mis_walk, mis_walk_shared};
use super::{Bdpt, Scratch};
use crate::integrator::{MisHeuristic, Sampler, Stats};
use crate::scene::Scene;
use glam::Vec3;

/// Products of one sub-path's measurement factors at the wavelength `key`; entry n is C(n + 2)
/// (camera) or L(n + 2) (light).
#[derive(Clone, Debug, Default)]
struct Products {
    key: Option<LambdaKey>,
    f: Vec<f64>,
}

impl Products {
    /// Entry `n` at wavelength `lambda`: `first` is entry 0, `factor(i)` the factor of sub-path vertex
    /// i (entry i = entry i − 1 · factor(i)); a product that reached 0 stays 0, as the direct
    /// measurement stops there.
    #[inline(always)]
    fn get(
        &mut self,
        lambda: f32,
        n: usize,
        first: impl FnOnce() -> f64,
        mut factor: impl FnMut(usize) -> f64,
    ) -> f64 {
        if self.key == Some(LambdaKey::of(lambda)) && n < self.f.len() {
            return self.f[n];
        }
        if self.key != Some(LambdaKey::of(lambda)) {
            self.key = Some(LambdaKey::of(lambda));
            self.f.clear();
        }
        if self.f.is_empty() {
            self.f.push(first());
        }
        while self.f.len() <= n {
            let (i, prev) = (self.f.len(), self.f[self.f.len() - 1]);
            let next = if prev > 0.0 || prev.is_nan() {
                prev * factor(i)
            } else {
                0.0
            };
            self.f.push(next);
        }
        self.f[n]
    }
}

/// Per-sample state of the plain connections.
#[derive(Clone, Debug, Default)]
pub struct PlainCache {
    cam: Products,
    light: Products,
    emit: Emitters,
    /// Index of the first sub-path vertex that can shift the wavelength (the length if none).
    cam_plain: usize,
    light_plain: usize,
}

impl PlainCache {
    /// Forget the products and find the first shifting vertices of new sub-paths.
    pub fn reset(&mut self, cam: &[Vertex], light: &[Vertex]) {
        self.cam.key = None;
        self.light.key = None;
        let first = |v: &[Vertex]| v.iter().position(|x| x.fluorescent).unwrap_or(v.len());
        (self.cam_plain, self.light_plain) = (first(cam), first(light));
    }

    /// Whether strategy (s, t) connects a plain path: its interior vertices x1 … x(k−2) cannot
    /// shift (t = 0: the camera vertices up to x(s−2); otherwise up to x(s−1) and the light
    /// vertices y(t−1) … y1).
    #[inline]
    pub fn covers(&self, s: usize, t: usize) -> bool {
        let cam_last = if t == 0 { s - 2 } else { s - 1 };
        cam_last < self.cam_plain && t.saturating_sub(1) < self.light_plain
    }
}

/// The factor of an interior vertex: f_λ · f_dir, then the geometry factor of the segment that
/// leaves it towards the light (eq. 6.2); 0 where the vertex has no spectral part or f_dir = 0.
#[inline(always)]
fn factor(f_l: Option<f32>, f_dir: f32, g: f64) -> f64 {
    match f_l {
        Some(f_l) if f_dir != 0.0 => f_l as f64 * f_dir as f64 * g,
        _ => 0.0,
    }
}

/// f_λ at λ* of a vertex that keeps the wavelength.
#[inline(always)]
fn f_lambda(scene: &Scene, spec: &mut SpectralCache, x: &Vertex, lambda: f32) -> Option<f32> {
    spec.f_lambda(scene, x, lambda, lambda, false)
}

/// The emission spectrum and wavelength pdfs at the wavelength and light last seen (most
/// connections of a sample share both).
#[derive(Clone, Copy, Debug, Default)]
struct Emitters {
    /// (light, bits of λ) → L_e(λ) of that light's spectrum.
    le: Option<((u32, LambdaKey), f32)>,
    /// (light, bits of λ) → p_l(λ | light) (eq. 6.5).
    ple: Option<((u32, LambdaKey), f64)>,
    /// bits of λ → p_c(λ) (eq. 6.4).
    pc0: Option<(LambdaKey, f64)>,
}

/// A cached value of `key`, computed by `eval` on a miss.
#[inline(always)]
fn cached<K: PartialEq + Copy, V: Copy>(
    slot: &mut Option<(K, V)>,
    key: K,
    eval: impl FnOnce() -> V,
) -> V {
    match *slot {
        Some((k, v)) if k == key => v,
        _ => {
            let v = eval();
            *slot = Some((key, v));
            v
        }
    }
}

/// L_e at λ* of emitter vertex `e` towards `to`.
#[inline(always)]
fn emitted(scene: &Scene, cache: &mut Emitters, e: &Vertex, to: Vec3, lambda: f32) -> f64 {
    let light = &scene.lights[e.light as usize];
    // the emitter's directional profile needs only the side of `to`, not a unit vector
    if !light.emits_towards(e.n, to - e.p) {
        return 0.0;
    }
    let f = cached(&mut cache.le, (e.light, LambdaKey::of(lambda)), || {
        light.spectrum.eval(lambda)
    }) as f64;
    if f > 0.0 { f } else { 0.0 }
}

/// C(s) at λ: the pinhole importance and geometry term of x0 → x1 (`SubpathCache::head`) and
/// the factors of the camera vertices x1 … x(s−2).
fn camera_prefix(
    scene: &Scene,
    products: &mut Products,
    cam: &mut SubpathCache,
    v: &[Vertex],
    spec: &mut SpectralCache,
    s: usize,
    lambda: f32,
) -> f64 {
    cam.camera(scene, v);
    let first = || {
        let head = cam.head;
        if head <= 0.0 { 0.0 } else { head }
    };
    let factor = |i: usize| {
        factor(
            f_lambda(scene, spec, &v[i], lambda),
            cam.dir(i),
            cam.seg(i).g,
        )
    };
    products.get(lambda, s - 2, first, factor)
}

/// L(t) at λ: the emission of y0 towards y1 and the factors of the light vertices y1 … y(t−2)
/// (each with the segment towards its predecessor on the light sub-path). `COPY` makes one copy
/// per caller (`spectral_part`), whose closures then have one call site each and stay inlined.
#[inline(always)]
fn light_suffix<const COPY: bool>(
    scene: &Scene,
    products: &mut Products,
    lc: &mut SubpathCache,
    v: &[Vertex],
    (spec, emit): (&mut SpectralCache, &mut Emitters),
    t: usize,
    lambda: f32,
) -> f64 {
    lc.light(scene, v);
    let first = || emitted(scene, emit, &v[0], v[1].p, lambda);
    let factor = |j: usize| factor(f_lambda(scene, spec, &v[j], lambda), lc.dir(j), lc.seg(j).g);
    products.get(lambda, t - 2, first, factor)
}

/// The pdfs that the connection changes (pbrt `Vertex::Pdf`): pa_fwd of x_s, pa_rev of x(s−1)
/// and, for t = 0 only, of x(s−2) (the emitter's light point and emission pdfs).
#[derive(Clone, Copy)]
struct Changed {
    fwd_s: f64,
    rev_last: f64,
    rev_prev: Option<f64>,
}

/// The wavelength pdf ratios a plain path's MIS walk takes: a path that does not shift has one
/// value for light tracing (ŝ = 1) and one for every other strategy.
trait RatioWalk {
    fn walk(
        &self,
        lower: impl Iterator<Item = (f64, f64)>,
        upper: impl Iterator<Item = (f64, f64)>,
        s: usize,
    ) -> (f64, f64);
}

/// One reset: p_Λ(ŝ) is `below` (ŝ = 1) or `above` (ŝ ≥ 2), the own strategy's among them.
struct OneReset {
    below: f64,
    above: f64,
    h: MisHeuristic,
}

impl RatioWalk for OneReset {
    #[inline(always)]
    fn walk(
        &self,
        lower: impl Iterator<Item = (f64, f64)>,
        upper: impl Iterator<Item = (f64, f64)>,
        s: usize,
    ) -> (f64, f64) {
        let own = if s == 1 { self.below } else { self.above };
        let (below, above) = (self.below / own, self.above / own);
        let lambda_ratio = |s_hat: usize| if s_hat == 1 { below } else { above };
        mis_walk(lower, upper, s, lambda_ratio, self.h)
    }
}

/// bdpt-combined: both resets' techniques share each strategy; Σ_r (p_Λ,r(ŝ)/p_Λ(s))^β is
/// `below` (ŝ = 1) or `above` (ŝ ≥ 2), already divided by the sampling technique's p_Λ(s)^β.
struct BothResets {
    below: f64,
    above: f64,
    h: MisHeuristic,
}

impl RatioWalk for BothResets {
    #[inline(always)]
    fn walk(
        &self,
        lower: impl Iterator<Item = (f64, f64)>,
        upper: impl Iterator<Item = (f64, f64)>,
        s: usize,
    ) -> (f64, f64) {
        let (below, above) = (self.below, self.above);
        let own = if s == 1 { below } else { above };
        let lambda_pow = |s_hat: usize| if s_hat == 1 { below } else { above };
        mis_walk_shared(lower, upper, (s, own), lambda_pow, self.h)
    }
}

/// The strategy's own area pdf p_A(s) (eq. 6.3) and its MIS weight among ŝ = 1 … k
/// (`super::weight::mis_walk`) over the sub-paths' stored pdfs with the ones the connection
/// changed put in: the camera prefix keeps its sub-path's pdfs and the light suffix (x_s …
/// x(k−1)) is turned around; `ratios` gives the wavelength pdfs.
#[inline(always)]
fn area_and_weight(ends: &Ends, changed: &Changed, ratios: &impl RatioWalk) -> (f64, f64) {
    let s = ends.s;
    // x1 … x(s−1): the camera sub-path's own pdfs, then the last one or two (`tail`), whose
    // pa_rev the connection changed; none at s = 1, whose x0 the walk does not visit. (One
    // test of the index a vertex, where looking both changed indices up cost 0.1 % of
    // bdpt-forward's instructions; a chained iterator cost 0.3 % more.)
    let (cam, mut tail, mut n) = (ends.cam, [(0.0, 0.0); 2], 0);
    if s >= 2 {
        if let Some(rev) = changed.rev_prev.filter(|_| s >= 3) {
            tail[0] = (cam[s - 2].pdf_fwd as f64, rev);
            n = 1;
        }
        tail[n] = (cam[s - 1].pdf_fwd as f64, changed.rev_last);
        n += 1;
    }
    let own_end = s - n;
    let lower = cam[1..s].iter().enumerate().map(|(i, v)| {
        // vertex x(i + 1)
        if i + 1 < own_end {
            (v.pdf_fwd as f64, v.pdf_rev as f64)
        } else {
            tail[i + 1 - own_end]
        }
    });
    match ends.fresh {
        Some(v) => {
            let upper = std::iter::once((changed.fwd_s, v.pdf_fwd as f64));
            ratios.walk(lower, upper, s)
        }
        None => {
            let upper = ends.light[..ends.t].iter().rev().enumerate().map(|(j, v)| {
                let fwd = if j == 0 {
                    changed.fwd_s
                } else {
                    v.pdf_rev as f64
                };
                (fwd, v.pdf_fwd as f64)
            });
            ratios.walk(lower, upper, s)
        }
    }
}

/// The per-sample caches a plain connection reads and extends.
struct Caches<'a> {
    cam: &'a mut SubpathCache,
    light: &'a mut SubpathCache,
    spectral: &'a mut SpectralCache,
    plain: &'a mut PlainCache,
}

/// The vertices of one connection: camera prefix, light suffix (in light sub-path order) or the
/// fresh light vertex of next-event estimation, and the three the connection reads most: its
/// ends x(s−1) and x_s and the emitter x(k−1), looked up once.
struct Ends<'a> {
    s: usize,
    t: usize,
    cam: &'a [Vertex],
    light: &'a [Vertex],
    fresh: Option<&'a Vertex>,
    /// x(s−1), x_s (for t = 0 also x(s−1), the emitter) and x(k−1).
    a: &'a Vertex,
    b: &'a Vertex,
    e: &'a Vertex,
}

impl<'a> Ends<'a> {
    #[inline(always)]
    fn new(
        (s, t): (usize, usize),
        cam: &'a [Vertex],
        light: &'a [Vertex],
        fresh: Option<&'a Vertex>,
    ) -> Self {
        let a = &cam[s - 1];
        // x_s and x(k−1): the fresh light vertex, or light vertices t − 1 and 0
        let (b, e) = match (t, fresh) {
            (0, _) => (a, a),
            (_, Some(v)) => (v, v),
            _ => (&light[t - 1], &light[0]),
        };
        Ends {
            s,
            t,
            cam,
            light,
            fresh,
            a,
            b,
            e,
        }
    }
}

impl Bdpt {
    /// [`super::evaluate`]'s connection of strategy (s, t) for a plain path (module doc): the
    /// weighted contribution w · f / p (eqs. 6.18, 6.19) in XYZ, drawing the same random numbers.
    pub(super) fn connect_plain(
        &self,
        scene: &Scene,
        (s, t): (usize, usize),
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        stats: &mut Stats,
    ) -> Option<Contribution> {
        // NEE: a fresh light vertex per camera vertex (Jung 6.3.4)
        let fresh = (t == 1 && s >= 2).then(|| self.fresh_light_vertex(scene, sampler));
        let Scratch {
            cam,
            light,
            cam_cache,
            light_cache,
            spectral,
            xyz,
            plain,
            ..
        } = scratch;
        let (cam, light) = (&cam[..], &light[..]);
        let mut caches = Caches {
            cam: cam_cache,
            light: light_cache,
            spectral,
            plain,
        };
        let ends = Ends::new((s, t), cam, light, fresh.as_ref());
        let e = ends.e;
        // λ* (Jung 6.3): light tracing keeps the light's, the forward reset the camera's, the
        // backward reset the emitter's (t = 0: sampled from its emission, Jung 6.3.3)
        let lambda = self.plain_lambda(scene, &ends, self.mode, sampler);
        let xyz_w = xyz_weight(scene, lambda, xyz);
        if xyz_w == Vec3::ZERO {
            return None;
        }
        let (mut f, conn) = measurement(scene, &ends, lambda, &mut caches)?;
        let splat = if s == 1 {
            Some(splat_position(scene, &cam[0], ends.b)?)
        } else {
            None
        };
        // p_Λ(ŝ) of a path that does not shift (eqs. 6.4, 6.5, 6.9–6.13): the camera's for the
        // forward reset's camera strategies, the emitter's otherwise
        let emit = &mut caches.plain.emit;
        let (cw, lw) = (self.camera_wavelengths, self.light_wavelengths);
        let pc0 = cached(&mut emit.pc0, LambdaKey::of(lambda), || {
            scene.observer.pdf_wavelength(cw, lambda) as f64
        });
        let ple = cached(&mut emit.ple, (e.light, LambdaKey::of(lambda)), || {
            scene.lights.pdf_wavelength(e.light as usize, lambda, lw) as f64
        });
        let wl = match self.mode {
            ResetMode::Forward => (ple, pc0),
            ResetMode::Backward => (ple, ple),
        };
        let changed = changed_pdfs(scene, &ends, conn);
        let ratios = OneReset {
            below: wl.0,
            above: wl.1,
            h: self.mis,
        };
        let (area, w) = area_and_weight(&ends, &changed, &ratios);
        // the strategy's own pdf (eq. 6.14)
        let p = area * if s == 1 { wl.0 } else { wl.1 };
        // the shadow ray last, so that the weight's divisions overlap its traversal (bdpt-forward
        // on cornell-box 1.013× faster than with the ray first)
        if t >= 1 {
            let tr = Connection::shadow(scene, ends.a, ends.b, s == 1, &mut stats.rays);
            if tr.is_zero() {
                return None;
            }
            f *= tr.at(lambda) as f64;
        }
        // zero, NaN or infinite p is a lost contribution
        if !(p > 0.0 && p.is_finite()) {
            stats.dropped_strategy_pdfs += (f != 0.0) as u64;
            return None;
        }
        let w = if self.only.is_some() { 1.0 } else { w };
        // eqs. 6.18/6.19: w · f / (p_A p_Λ), in XYZ with the CIE weight at λ0 = λ*
        weighted(xyz_w, lambda, w * f / p, splat, stats)
    }
}

impl Bdpt {
    /// λ* of a plain path under reset `mode` (Jung 6.3): light tracing keeps the light's, the
    /// forward reset the camera's, the backward reset the emitter's (t = 0: sampled from its
    /// emission, Jung 6.3.3; sampler: one value then).
    #[inline(always)]
    fn plain_lambda(
        &self,
        scene: &Scene,
        ends: &Ends,
        mode: ResetMode,
        sampler: &mut Sampler,
    ) -> f32 {
        let (cam, light, e) = (ends.cam, ends.light, ends.e);
        match (ends.s, ends.t, mode) {
            (1, ..) => light[0].data.lambda_out,
            (_, _, ResetMode::Forward) => cam[0].data.lambda_in,
            (_, 0, ResetMode::Backward) => {
                light_wavelength(scene, e.light, self.light_wavelengths, sampler).lambda
            }
            (_, 1, ResetMode::Backward) => e.data.lambda_out,
            (_, _, ResetMode::Backward) => light[0].data.lambda_out,
        }
    }

    /// bdpt-combined on a plain path at λ* = `lambda` made by reset `mode`: the technique's own
    /// pdf p_A(s) · p_Λ(s) (eq. 6.14) and its weight among both resets' techniques. p_Λ at λ*
    /// (eqs. 6.4, 6.5, 6.9–6.13): light tracing's and the backward reset's are the emitter's
    /// pdf, the forward reset's camera strategies' the camera's; light tracing stands for both
    /// resets' techniques and gets their two weights.
    #[inline(always)]
    fn both_resets_weight(
        &self,
        scene: &Scene,
        emit: &mut Emitters,
        ends: &Ends,
        changed: &Changed,
        (mode, lambda): (ResetMode, f32),
        [n_f, n_b]: [f64; 2],
    ) -> (f64, f64) {
        let (s, light) = (ends.s, ends.e.light);
        let (cw, lw) = (self.camera_wavelengths, self.light_wavelengths);
        let pc0 = cached(&mut emit.pc0, LambdaKey::of(lambda), || {
            scene.observer.pdf_wavelength(cw, lambda) as f64
        });
        let ple = cached(&mut emit.ple, (light, LambdaKey::of(lambda)), || {
            scene.lights.pdf_wavelength(light as usize, lambda, lw) as f64
        });
        // q: the evaluated technique's p_Λ(s)
        let q = if s >= 2 && mode == ResetMode::Forward {
            pc0
        } else {
            ple
        };
        let power = |x: f64| {
            if self.mis == MisHeuristic::Power {
                x * x
            } else {
                x
            }
        };
        // (n_r p_Λ,r / q)^β; a reset whose techniques this sample does not take adds nothing
        // (`FullPath::combined_weight`)
        let term = |n: f64, x: f64| if n == 0.0 { 0.0 } else { power(n * x) };
        let (pl_f, pl_b, pc_f) = (term(n_f, ple / q), term(n_b, ple / q), term(n_f, pc0 / q));
        let ratios = BothResets {
            below: pl_f + pl_b,
            above: pc_f + pl_b,
            h: self.mis,
        };
        let (area, w) = area_and_weight(ends, changed, &ratios);
        let n_own = if mode == ResetMode::Forward { n_f } else { n_b };
        let w = if s == 1 {
            w * ratios.below
        } else {
            w * power(n_own)
        };
        (area * q, w)
    }

    /// bdpt-combined's connection of a plain path (`super::combined`): the connection, its
    /// changed pdfs and its shadow ray once, then each reset's λ*, products and weight among
    /// both resets' techniques. Light tracing and the backward reset read their products from
    /// `Scratch::plain_backward` (both at the light's wavelength), the forward reset from
    /// `Scratch::plain` (the camera's), so that neither evicts the other.
    pub(super) fn combined_plain(
        &self,
        scene: &Scene,
        (s, t): (usize, usize),
        how: Evaluate,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        stats: &mut Stats,
    ) -> [Option<Contribution>; 2] {
        let mut out = [None, None];
        // NEE: one fresh light vertex for both resets, its wavelength for the backward one
        let fresh = (t == 1 && s >= 2).then(|| {
            let mut v = sample_light_vertex(scene, sampler);
            if how.has_backward() {
                let lambda = light_wavelength(scene, v.light, self.light_wavelengths, sampler);
                v.data = Lambdas::both(lambda.lambda);
            }
            v
        });
        let scratch_counts = scratch.counts;
        let Scratch {
            cam,
            light,
            cam_cache,
            light_cache,
            spectral,
            xyz,
            plain,
            plain_backward,
            ..
        } = scratch;
        let (cam, light) = (&cam[..], &light[..]);
        let ends = Ends::new((s, t), cam, light, fresh.as_ref());
        let mut caches = Caches {
            cam: cam_cache,
            light: light_cache,
            spectral,
            plain,
        };
        let Some(geo) = geometry(scene, &ends, &mut caches) else {
            return out;
        };
        let splat = if s == 1 {
            match splat_position(scene, &cam[0], ends.b) {
                Some(at) => Some(at),
                None => return out,
            }
        } else {
            None
        };
        let changed = changed_pdfs(scene, &ends, geo.conn);
        let mut shadow = None;
        for (slot, &mode) in out.iter_mut().zip(how.resets()) {
            let lambda = self.plain_lambda(scene, &ends, mode, sampler);
            let xyz_w = xyz_weight(scene, lambda, xyz);
            if xyz_w == Vec3::ZERO {
                continue;
            }
            let table = if s == 1 || mode == ResetMode::Backward {
                &mut *plain_backward
            } else {
                &mut *caches.plain
            };
            let mut at = Caches {
                cam: &mut *caches.cam,
                light: &mut *caches.light,
                spectral: &mut *caches.spectral,
                plain: table,
            };
            let Some(mut f) = spectral_part::<true>(scene, &ends, &geo, lambda, &mut at) else {
                continue;
            };
            let n = self.counts_of(scene, splat, scratch_counts);
            let (p, w) = self.both_resets_weight(
                scene,
                &mut at.plain.emit,
                &ends,
                &changed,
                (mode, lambda),
                n,
            );
            if t >= 1 {
                let tr = *shadow.get_or_insert_with(|| {
                    Connection::shadow(scene, ends.a, ends.b, s == 1, &mut stats.rays)
                });
                if tr.is_zero() {
                    return out;
                }
                f *= tr.at(lambda) as f64;
            }
            if !(p > 0.0 && p.is_finite()) {
                stats.dropped_strategy_pdfs += (f != 0.0) as u64;
                continue;
            }
            let w = if self.only.is_some() {
                how.unweighted()
            } else {
                w * how.inverse_choice()
            };
            // eqs. 6.18/6.19: w · f / (p_A p_Λ), in XYZ with the CIE weight at λ0 = λ*
            *slot = weighted(xyz_w, lambda, w * f / p, splat, stats);
        }
        out
    }
}

/// A connection of a strategy with t ≥ 1 and the solid-angle pdfs of its scattering ends
/// towards each other (x(s−1) for s ≥ 2, x_s for t ≥ 2), which its changed pdfs reuse.
#[derive(Clone, Copy)]
struct Conn {
    c: Connection,
    pdf_a: Option<f32>,
    pdf_b: Option<f32>,
}

/// f_dir and the solid-angle pdf of the lobe at scattering end `x` towards `wi` (cosine
/// `cos_i`), whose other neighbour on its sub-path lies in the unit direction `wo`
/// (`Scattering::eval_pdf_with_cosines`).
#[inline(always)]
fn lobe(scene: &Scene, x: &Vertex, wo: Vec3, (wi, cos_i): (Vec3, f32)) -> (f32, f32) {
    let lobe = x.scattering(scene);
    lobe.eval_pdf_with_cosines((wo, x.n.dot(wo)), (wi, cos_i))
}

/// What a connection fixes whatever the wavelength: the segment and f_dir at its scattering ends
/// with their pdfs (`None` for t = 0, where the camera sub-path reached the emitter itself).
#[derive(Clone, Copy)]
struct Geometry {
    conn: Option<Conn>,
    f_a: f32,
    f_b: f32,
}

/// The measurement f of the connection at λ* = `lambda` (eq. 6.2): C(s) · [x(s−1), x_s] ·
/// L(t), with the connection's factors first, so that a zero f_dir ends it before the products
/// are looked up. `None` where f is 0; else f and the connection (t ≥ 1).
#[inline(always)]
fn measurement(
    scene: &Scene,
    ends: &Ends,
    lambda: f32,
    caches: &mut Caches,
) -> Option<(f64, Option<Conn>)> {
    let geo = geometry(scene, ends, caches)?;
    let f = spectral_part::<false>(scene, ends, &geo, lambda, caches)?;
    Some((f, geo.conn))
}

/// The wavelength-independent part of [`measurement`]: the connection and f_dir and the pdf of
/// the lobes at its scattering ends, with the sub-paths' cached directions to their other
/// neighbours (the pinhole's and the emitter's factors are W_e and L_e, their pdfs come in
/// `changed_pdfs`). `None` where an f_dir is 0.
#[inline(always)]
fn geometry(scene: &Scene, ends: &Ends, caches: &mut Caches) -> Option<Geometry> {
    let (s, t) = (ends.s, ends.t);
    if t == 0 {
        return Some(Geometry {
            conn: None,
            f_a: 1.0,
            f_b: 1.0,
        });
    }
    let (cam, light) = (ends.cam, ends.light);
    let (a, b) = (ends.a, ends.b);
    let c = Connection::new(a, b);
    let w = c.seg.w;
    // (`if` rather than `bool::then`: its closures stayed out of line once the combined
    // connection also inlined this function, +9 % instructions in bdpt-forward)
    let end_a = if s >= 2 {
        caches.cam.camera(scene, cam);
        Some(lobe(scene, a, -caches.cam.seg(s - 2).w, (w, c.cos_a)))
    } else {
        None
    };
    let end_b = if t >= 2 {
        caches.light.light(scene, light);
        Some(lobe(scene, b, caches.light.seg(t - 1).w, (-w, -c.cos_b)))
    } else {
        None
    };
    let (f_a, f_b) = (end_a.map_or(1.0, |e| e.0), end_b.map_or(1.0, |e| e.0));
    if f_a == 0.0 || f_b == 0.0 {
        return None;
    }
    let conn = Conn {
        c,
        pdf_a: end_a.map(|e| e.1),
        pdf_b: end_b.map(|e| e.1),
    };
    Some(Geometry {
        conn: Some(conn),
        f_a,
        f_b,
    })
}

/// The spectral rest of [`measurement`] at λ* = `lambda`: the camera prefix, the spectral factors of the
/// connection's ends and the light suffix. `None` where f is 0. `COMBINED`: bdpt-combined's
/// copy (`light_suffix`).
#[inline(always)]
fn spectral_part<const COMBINED: bool>(
    scene: &Scene,
    ends: &Ends,
    geo: &Geometry,
    lambda: f32,
    caches: &mut Caches,
) -> Option<f64> {
    let (s, t) = (ends.s, ends.t);
    let Caches {
        cam: cam_cache,
        light: light_cache,
        spectral,
        plain,
    } = caches;
    let (cam, light) = (ends.cam, ends.light);
    let Some(Conn { c, .. }) = geo.conn else {
        let e = ends.a;
        let c = camera_prefix(scene, &mut plain.cam, cam_cache, cam, spectral, s, lambda);
        let f = emitted(scene, &mut plain.emit, e, cam[s - 2].p, lambda) * c;
        return (f > 0.0 || f.is_nan()).then_some(f);
    };
    let (a, b) = (ends.a, ends.b);
    let cam_part = if s == 1 {
        // x0 → x1: the pinhole importance and the geometry term without the pinhole's cosine
        let f = camera_term(scene, c.seg.w, c.seg.d2, b);
        if f <= 0.0 {
            return None;
        }
        f
    } else {
        let cp = camera_prefix(scene, &mut plain.cam, cam_cache, cam, spectral, s, lambda);
        cp * factor(f_lambda(scene, spectral, a, lambda), geo.f_a, c.seg.g)
    };
    let light_part = if t == 1 {
        emitted(scene, &mut plain.emit, b, a.p, lambda)
    } else {
        let (products, sp) = (&mut plain.light, (&mut **spectral, &mut plain.emit));
        let lf = light_suffix::<COMBINED>(scene, products, light_cache, light, sp, t, lambda);
        let g = light_cache.seg(t - 1).g;
        lf * factor(f_lambda(scene, spectral, b, lambda), geo.f_b, g)
    };
    let f = cam_part * light_part;
    (f > 0.0 || f.is_nan()).then_some(f)
}

/// The pdfs the connection changes (`Connection::pdfs`; t = 0: the emitter's light point and
/// emission pdfs).
#[inline(always)]
fn changed_pdfs(scene: &Scene, ends: &Ends, conn: Option<Conn>) -> Changed {
    let s = ends.s;
    let Some(Conn { c, pdf_a, pdf_b }) = conn else {
        // t = 0: the light point and emission pdfs at the emitter x(s−1)
        let e = ends.a;
        return Changed {
            fwd_s: 0.0,
            rev_last: e.pdf_light_origin(scene) as f64,
            rev_prev: Some(e.pdf_emit(scene, &ends.cam[s - 2]) as f64),
        };
    };
    // the pinhole's and the emitter's own directional pdfs where the end does not scatter
    let (a, b, w) = (ends.a, ends.b, c.seg.w);
    let pdf_a = pdf_a.unwrap_or_else(|| scene.camera.pdf_dir_towards(a.n, w).unwrap_or(0.0));
    let pdf_b = pdf_b.unwrap_or_else(|| scene.lights.pdf_le_direction(b.light as usize, b.n, -w));
    let (fwd, rev) = c.area_pdfs(pdf_a, pdf_b);
    Changed {
        fwd_s: fwd as f64,
        rev_last: rev as f64,
        rev_prev: None,
    }
}
