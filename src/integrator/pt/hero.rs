//! `pt-hero`: hero wavelength spectral sampling (Wilkie et al. 2014) with fluorescent vertices
//! (bispectral HWSS, Mojzík §6.2).
//!
//! The hero wavelength is sampled over the camera range and the other lanes are rotated from it
//! (`HeroWavelengths::rotate`). The hero lane makes every directional decision; since all
//! directional pdfs are wavelength independent here (diffuse lobes, no media), every lane is an
//! unbiased single-wavelength estimator along the same path, and the HWSS balance heuristic over
//! the lanes reduces to weighting lane j by 1 / Σ_k p(λ_k) (for uniform hero sampling that is
//! |range| / N, the plain average). At a fluorescent vertex each lane samples its own incident
//! wavelength (Jung 5.3, own random numbers); with the correction term t* of Mojzík §6.2 each
//! lane keeps f_j / (p_dir · p_shift,j), and the whole vector is zeroed when any lane's shift
//! probability is zero.
//!
//! The 4-lane hot path runs on glam `Vec4`; other lane counts use a fixed 16-wide array.

use super::{light_pdf_solid, sample_diffuse, sample_light_connection};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, SampleSink, Sampler};
use crate::material::{Bbrrdf, Material, WavelengthSampling};
use crate::scene::{NONE, Scene};
use crate::spectrum::cie::{CameraWavelengths, cmf};
use crate::spectrum::hero::HeroWavelengths;
use crate::spectrum::{Domain, Spectrum};
use glam::{Vec3, Vec4};
use std::ops::{Add, AddAssign, Mul, MulAssign};

/// Largest lane count (`IntegratorOptions::validate` allows 1–16).
pub const MAX_LANES: usize = 16;

/// Per-lane arithmetic of the hero path: `Vec4` for 4 lanes, [`LaneArr`] otherwise. Lanes past
/// the active count are kept at zero.
pub trait Lanes:
    Copy
    + Add<Output = Self>
    + AddAssign
    + Mul<Output = Self>
    + MulAssign
    + Mul<f32, Output = Self>
    + MulAssign<f32>
{
    const ZERO: Self;
    fn splat_n(n: usize, v: f32) -> Self;
    /// Build from `f(j)` for the first `n` lanes, evaluated in lane order.
    fn from_fn(n: usize, f: impl FnMut(usize) -> f32) -> Self;
    /// Like `from_fn` for a function returning two values per lane.
    fn from_fn2(n: usize, f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self);
    /// The hero set: λ_j = lo + ((λ_h − lo) + j·W/n) mod W (`HeroWavelengths::rotate`).
    fn rotate(n: usize, hero: f32, range: Domain) -> Self;
    /// `v` where lo ≤ λ ≤ hi, else 0 (a box spectrum).
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self;
    fn lane(&self, j: usize) -> f32;
    fn max_lane(self) -> f32;
    fn dot(self, o: Self) -> f32;
}

impl Lanes for Vec4 {
    const ZERO: Self = Vec4::ZERO;
    #[inline(always)]
    fn splat_n(_: usize, v: f32) -> Self {
        Vec4::splat(v)
    }
    #[inline(always)]
    fn from_fn(_: usize, mut f: impl FnMut(usize) -> f32) -> Self {
        let a = f(0);
        let b = f(1);
        let c = f(2);
        let d = f(3);
        Vec4::new(a, b, c, d)
    }
    #[inline(always)]
    fn from_fn2(_: usize, mut f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self) {
        let a = f(0);
        let b = f(1);
        let c = f(2);
        let d = f(3);
        (Vec4::new(a.0, b.0, c.0, d.0), Vec4::new(a.1, b.1, c.1, d.1))
    }
    #[inline(always)]
    fn rotate(_: usize, hero: f32, range: Domain) -> Self {
        let w = range.width();
        let x = Vec4::splat(hero - range.min) + Vec4::new(0.0, 0.25, 0.5, 0.75) * w;
        let x = Vec4::select(x.cmpge(Vec4::splat(w)), x - Vec4::splat(w), x);
        x + Vec4::splat(range.min)
    }
    #[inline(always)]
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self {
        let inside = self.cmpge(Vec4::splat(lo)) & self.cmple(Vec4::splat(hi));
        Vec4::select(inside, Vec4::splat(v), Vec4::ZERO)
    }
    #[inline(always)]
    fn lane(&self, j: usize) -> f32 {
        self[j]
    }
    #[inline(always)]
    fn max_lane(self) -> f32 {
        self.max_element()
    }
    #[inline(always)]
    fn dot(self, o: Self) -> f32 {
        Vec4::dot(self, o)
    }
}

/// Up to 16 lanes for lane counts other than 4 (the generic fallback).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneArr(pub [f32; MAX_LANES]);

impl Add for LaneArr {
    type Output = Self;
    #[inline]
    fn add(mut self, o: Self) -> Self {
        self += o;
        self
    }
}
impl AddAssign for LaneArr {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
    }
}
impl Mul for LaneArr {
    type Output = Self;
    #[inline]
    fn mul(mut self, o: Self) -> Self {
        self *= o;
        self
    }
}
impl MulAssign for LaneArr {
    #[inline]
    fn mul_assign(&mut self, o: Self) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a *= b;
        }
    }
}
impl Mul<f32> for LaneArr {
    type Output = Self;
    #[inline]
    fn mul(mut self, s: f32) -> Self {
        self *= s;
        self
    }
}
impl MulAssign<f32> for LaneArr {
    #[inline]
    fn mul_assign(&mut self, s: f32) {
        for a in &mut self.0 {
            *a *= s;
        }
    }
}

impl Lanes for LaneArr {
    const ZERO: Self = LaneArr([0.0; MAX_LANES]);
    #[inline]
    fn splat_n(n: usize, v: f32) -> Self {
        let mut a = [0.0; MAX_LANES];
        a[..n].fill(v);
        LaneArr(a)
    }
    #[inline]
    fn from_fn(n: usize, mut f: impl FnMut(usize) -> f32) -> Self {
        let mut a = [0.0; MAX_LANES];
        for (j, x) in a[..n].iter_mut().enumerate() {
            *x = f(j);
        }
        LaneArr(a)
    }
    #[inline]
    fn from_fn2(n: usize, mut f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self) {
        let (mut a, mut b) = ([0.0; MAX_LANES], [0.0; MAX_LANES]);
        for j in 0..n {
            (a[j], b[j]) = f(j);
        }
        (LaneArr(a), LaneArr(b))
    }
    #[inline]
    fn rotate(n: usize, hero: f32, range: Domain) -> Self {
        let mut a = [0.0; MAX_LANES];
        HeroWavelengths::rotate(hero, range, &mut a[..n]);
        LaneArr(a)
    }
    #[inline]
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self {
        LaneArr(self.0.map(|l| if l >= lo && l <= hi { v } else { 0.0 }))
    }
    #[inline]
    fn lane(&self, j: usize) -> f32 {
        self.0[j]
    }
    #[inline]
    fn max_lane(self) -> f32 {
        self.0.iter().fold(0.0f32, |m, &x| m.max(x))
    }
    #[inline]
    fn dot(self, o: Self) -> f32 {
        self.0.iter().zip(o.0).map(|(a, b)| a * b).sum()
    }
}

/// `x > 0`, false for NaN.
#[inline(always)]
fn positive(x: f32) -> bool {
    x > 0.0
}

/// A spectrum at every lane; constant and box spectra without per-lane work.
#[inline(always)]
fn eval_lanes<L: Lanes>(s: &Spectrum, n: usize, lambda: L) -> L {
    match s {
        Spectrum::Constant(v) => L::splat_n(n, *v),
        Spectrum::Box { lo, hi, value } => lambda.box_mask(*lo, *hi, *value),
        Spectrum::Tabulated { xs, ys } if xs.len() <= 16 => {
            L::from_fn(n, |j| tabulated_short(xs, ys, lambda.lane(j)))
        }
        _ => L::from_fn(n, |j| s.eval(lambda.lane(j))),
    }
}

/// `Spectrum::Tabulated` evaluation for short tables: an inlined linear scan, same result as
/// `Spectrum::eval` (first knot above λ, clamped to 1..n−1).
#[inline(always)]
fn tabulated_short(xs: &[f32], ys: &[f32], l: f32) -> f32 {
    let n = xs.len();
    if n == 0 || l < xs[0] || l > xs[n - 1] {
        return 0.0;
    }
    if n == 1 {
        return ys[0];
    }
    let mut i = 1;
    while i < n - 1 && xs[i] <= l {
        i += 1;
    }
    let (x0, x1) = (xs[i - 1], xs[i]);
    let t = (l - x0) / (x1 - x0);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}

/// The diagonal (wavelength-preserving) coefficient at every lane.
#[inline(always)]
fn diagonal_lanes<L: Lanes>(m: &Material, n: usize, lambda: L) -> L {
    match m {
        Material::Lambert(l) => eval_lanes(&l.reflectance, n, lambda),
        _ => L::from_fn(n, |j| m.diagonal(lambda.lane(j))),
    }
}

pub struct PtHero {
    max_depth: u32,
    lanes: usize,
    camera_wavelengths: CameraWavelengths,
    wavelength_sampling: WavelengthSampling,
    mis: MisHeuristic,
    rr_depth: Option<u32>,
}

impl PtHero {
    pub fn new(scene: &Scene, o: &IntegratorOptions) -> Result<Self, String> {
        if scene.has_media {
            return Err("pt-hero does not support participating media yet".into());
        }
        if o.lanes == 0 || o.lanes as usize > MAX_LANES {
            return Err(format!("lanes must be 1–{MAX_LANES}, got {}", o.lanes));
        }
        if scene
            .materials
            .iter()
            .any(|m| m.wavelength_dependent_directions())
        {
            return Err(
                "pt-hero assumes wavelength-independent directional sampling (diffuse lobes)"
                    .into(),
            );
        }
        Ok(PtHero {
            max_depth: o.max_depth,
            lanes: o.lanes as usize,
            camera_wavelengths: o.camera_wavelengths,
            wavelength_sampling: o.wavelength_sampling,
            mis: o.mis,
            rr_depth: o.rr_depth,
        })
    }

    /// One camera path carrying `self.lanes` wavelengths in `L`.
    #[inline(always)]
    fn trace<L: Lanes>(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) {
        let n = self.lanes;
        let obs = &scene.observer;
        let (hero, pdf_hero) = obs.sample_wavelength(self.camera_wavelengths, sampler.next());
        if !positive(pdf_hero) {
            return;
        }
        let mut lambda = L::rotate(n, hero, obs.range);
        // HWSS balance heuristic over the lanes (Wilkie et al. 2014, eq. 9): lane j gets
        // 1 / Σ_k p(λ_k); the rotated set is the same whichever lane is the hero.
        let pdf_sum: f32 = match self.camera_wavelengths {
            CameraWavelengths::Uniform => n as f32 / obs.range.width(),
            CameraWavelengths::Cmf => (0..n)
                .map(|j| obs.pdf_wavelength(CameraWavelengths::Cmf, lambda.lane(j)))
                .sum(),
        };
        if !positive(pdf_sum) {
            return;
        }
        let cam_scale = obs.inv_y_integral / pdf_sum;
        // Colour-matching weights of the camera lanes.
        let (wx, wy) = L::from_fn2(n, |j| {
            let c = cmf(lambda.lane(j));
            (c.x, c.y)
        });
        let wz = L::from_fn(n, |j| cmf(lambda.lane(j)).z);
        let mut beta = L::splat_n(n, 1.0);
        let mut radiance = L::ZERO;
        let mut pdf_dir_prev = 0.0f32;
        let mut ray = scene.camera.generate_ray(x, y);
        let mut prev_p = ray.o;
        let fluorescent = scene.has_fluorescence;
        for depth in 0..self.max_depth {
            sink.stats.rays += 1;
            let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
                break;
            };
            let wo = -ray.d;
            let segments = depth as usize + 1;
            // Emitter hit by the camera ray or a BSDF-sampled ray (MIS against NEE, scalar:
            // directional pdfs do not depend on the lane).
            if it.light != NONE {
                let light = &scene.lights[it.light as usize];
                if light.emits_towards(it.n, wo) {
                    let le = eval_lanes(&light.spectrum, n, lambda);
                    let w = if depth == 0 {
                        1.0
                    } else {
                        self.mis
                            .weight2(pdf_dir_prev, light_pdf_solid(scene, prev_p, &it))
                    };
                    let c = beta * le * w;
                    if c.max_lane() > 0.0 {
                        radiance += c;
                        sink.stats.contribution(segments);
                    }
                }
            }
            if it.material == NONE || segments >= self.max_depth as usize {
                break;
            }
            let m: &Material = &scene.materials[it.material as usize];
            if fluorescent && m.is_fluorescent() {
                // Each lane samples its own λin (Jung 5.3) with its own random numbers.
                // Correction term t* (Mojzík §6.2): lane j keeps f_j / (p_dir · p_shift,j), and
                // the vector is zeroed if any lane's shift probability is zero.
                let mut valid = true;
                let (new_lambda, w) = L::from_fn2(n, |j| {
                    let s = m.sample_wavelength_camera(
                        lambda.lane(j),
                        sampler.next2(),
                        self.wavelength_sampling,
                    );
                    if !positive(s.pdf) || !s.weight.is_finite() {
                        valid = false;
                    }
                    (s.lambda, s.weight)
                });
                if !valid {
                    break;
                }
                beta *= w;
                lambda = new_lambda;
            } else {
                beta *= diagonal_lanes(m, n, lambda);
            }
            if !positive(beta.max_lane()) {
                break;
            }
            // Next-event estimation at every lane's λin; the hero's light sample serves all.
            if let Some(c) = sample_light_connection(scene, &it, wo, sampler, sink.stats) {
                let light = &scene.lights[c.light];
                let le = eval_lanes(&light.spectrum, n, lambda);
                let pdf_bsdf = c.cos_surface * Material::DIFFUSE;
                let w = self.mis.weight2(c.pdf_solid, pdf_bsdf);
                let contrib = beta * le * (Material::DIFFUSE * c.cos_surface / c.pdf_solid * w);
                if contrib.max_lane() > 0.0 {
                    radiance += contrib;
                    sink.stats.contribution(segments + 1);
                }
            }
            // Continue with the hero's cosine sample: f·cos/pdf = 1 for the diffuse lobe.
            let (next, _wi, pdf) = sample_diffuse(&it, wo, sampler.next2());
            pdf_dir_prev = pdf;
            prev_p = it.p;
            ray = next;
            if let Some(rr) = self.rr_depth
                && depth + 1 >= rr
            {
                // Wavelength-set-wide roulette on the largest lane.
                let q = beta.max_lane().min(0.95);
                if sampler.next() >= q {
                    break;
                }
                beta *= 1.0 / q;
            }
        }
        let xyz = Vec3::new(radiance.dot(wx), radiance.dot(wy), radiance.dot(wz)) * cam_scale;
        sink.add(xyz);
    }
}

impl Integrator for PtHero {
    type Scratch = ();
    fn scratch(&self, _: &Scene) {}

    fn sample(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        _: &mut (),
        sink: &mut SampleSink,
    ) {
        if self.lanes == 4 {
            self.trace::<Vec4>(scene, x, y, sampler, sink)
        } else {
            self.trace::<LaneArr>(scene, x, y, sampler, sink)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec4_and_generic_lanes_agree() {
        let range = Domain {
            min: 360.0,
            max: 780.0,
        };
        for hero in [360.0, 400.0, 569.9, 700.0, 779.99] {
            let v = Vec4::rotate(4, hero, range);
            let a = LaneArr::rotate(4, hero, range);
            let mut h = [0.0; 4];
            HeroWavelengths::rotate(hero, range, &mut h);
            for (j, &hj) in h.iter().enumerate() {
                assert!((v.lane(j) - hj).abs() < 1e-3 && (a.lane(j) - hj).abs() < 1e-3);
                assert!(range.contains(v.lane(j)));
            }
            let (bv, ba) = (v.box_mask(450.0, 600.0, 2.0), a.box_mask(450.0, 600.0, 2.0));
            for j in 0..4 {
                assert_eq!(bv.lane(j), ba.lane(j));
            }
        }
        // The short-table scan matches Spectrum::eval.
        let s = Spectrum::Tabulated {
            xs: vec![360.0, 470.0, 510.0, 570.0, 610.0, 830.0],
            ys: vec![0.05, 0.05, 0.6, 0.6, 0.05, 0.05],
        };
        for k in 0..=600 {
            let l = 300.0 + k as f32;
            let v = eval_lanes(&s, 4, Vec4::splat(l));
            assert_eq!(v.lane(0), s.eval(l), "{l}");
        }
        // Inactive generic lanes stay zero.
        assert_eq!(LaneArr::splat_n(3, 1.0).lane(3), 0.0);
    }
}
