//! The random walk of the uni-directional tracers, written once for any number of wavelength
//! lanes `L` (1: pt-mono; N: pt-hero).
//!
//! The first lane is the hero: it makes every directional decision. All directional pdfs are
//! wavelength independent (diffuse lobes, no media), so every lane is an unbiased
//! single-wavelength estimator along the same path and the HWSS balance heuristic over the lanes
//! reduces to weighting lane j by 1 / Σ_k p(λ_k) ([`SampledWavelengths::balance_pdf`]). At a
//! fluorescent vertex each lane samples its own incident wavelength (Jung 5.3, own random
//! numbers); with the correction term t* of Mojzík §6.2 each lane keeps f_j / (p_dir · p_shift,j),
//! and the path ends when any lane's shift probability is zero. Emitters hit by a scattered ray
//! and next-event estimation are combined with MIS over directions.

use crate::geometry::ray::spawn_ray;
use crate::integrator::{IntegratorOptions, MisHeuristic, SampleSink, Sampler};
use crate::material::{Bbrrdf, Material, PathSide, ShiftSampling};
use crate::scene::{Interaction, NONE, Scene};
use crate::spectrum::cie::{CameraWavelengths, cmf};
use crate::spectrum::{Lanes, SampledWavelengths};
use crate::transport::{Endpoint, Scattering, transmittance};
use glam::Vec3;

/// `x > 0`, false for NaN.
#[inline(always)]
fn positive(x: f32) -> bool {
    x > 0.0
}

/// The settings of one uni-directional tracer.
pub struct Walk {
    pub max_depth: u32,
    pub lanes: usize,
    pub camera_wavelengths: CameraWavelengths,
    pub shift: ShiftSampling,
    pub mis: MisHeuristic,
    pub rr_depth: Option<u32>,
}

impl Walk {
    /// A walk carrying `lanes` wavelengths; `name` is the integrator's, for messages.
    pub fn new(
        name: &str,
        scene: &Scene,
        o: &IntegratorOptions,
        lanes: usize,
    ) -> Result<Self, String> {
        if scene.has_media {
            return Err(format!("{name} does not support participating media yet"));
        }
        Ok(Walk {
            max_depth: o.max_depth,
            lanes,
            camera_wavelengths: o.camera_wavelengths,
            shift: ShiftSampling::new(o.wavelength_sampling, scene.domain),
            mis: o.mis,
            rr_depth: o.rr_depth,
        })
    }

    /// One camera path through film position (x, y) carrying `self.lanes` wavelengths in `L`.
    #[inline(always)]
    pub fn trace<L: Lanes>(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) {
        let n = self.lanes;
        let obs = &scene.observer;
        let Some(wl) =
            SampledWavelengths::<L>::sample_hero(obs, self.camera_wavelengths, sampler.next(), n)
        else {
            return;
        };
        let pdf_sum = wl.balance_pdf();
        if !positive(pdf_sum) {
            return;
        }
        let cam_scale = obs.inv_y_integral / pdf_sum;
        // Colour-matching weights of the camera lanes.
        let [wx, wy, wz] = L::from_fn3(n, |j| cmf(wl.lambda.lane(j)));
        let mut lambda = wl.lambda;
        let mut beta = L::splat_n(n, 1.0);
        let mut radiance = L::ZERO;
        let mut pdf_dir_prev = 0.0f32;
        let mut ray = scene.camera.generate_ray(x, y);
        let mut prev_p = ray.o;
        for depth in 0..self.max_depth {
            sink.stats.rays += 1;
            let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
                break;
            };
            let wo = -ray.d;
            let segments = depth as usize + 1;
            if it.light != NONE {
                let le = self.emitted(scene, &it, wo, lambda);
                if le.max_lane() > 0.0 {
                    let w = if depth == 0 {
                        1.0
                    } else {
                        let light = it.light as usize;
                        let pdf_light = scene.lights.pdf_li(prev_p, light, it.p, it.n);
                        self.mis.weight2(pdf_dir_prev, pdf_light)
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
            match self.scatter_wavelengths(scene, m, lambda, sampler) {
                Some((new_lambda, w)) => {
                    beta *= w;
                    lambda = new_lambda;
                }
                None => break,
            }
            if !positive(beta.max_lane()) {
                break;
            }
            let lobe = Scattering::Diffuse { n: it.n };
            let c = self.next_event(scene, &it, wo, lobe, beta, lambda, sampler, sink);
            if c.max_lane() > 0.0 {
                radiance += c;
                sink.stats.contribution(segments + 1);
            }
            // Continue with the hero's direction.
            let s = lobe.sample(wo, sampler.next2());
            beta *= s.weight;
            pdf_dir_prev = s.pdf;
            prev_p = it.p;
            ray = spawn_ray(it.p, it.n, s.wi);
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

    /// Radiance leaving the emitter hit `it` towards `wo` at every lane.
    #[inline(always)]
    fn emitted<L: Lanes>(&self, scene: &Scene, it: &Interaction, wo: Vec3, lambda: L) -> L {
        let light = &scene.lights[it.light as usize];
        if light.emits_towards(it.n, wo) {
            light.spectrum.eval_lanes(self.lanes, lambda)
        } else {
            L::ZERO
        }
    }

    /// The spectral part of scattering at a camera-path vertex: the new incident wavelengths
    /// and the factor f / p of each lane, or `None` when the path must end (Mojzík §6.2: some
    /// lane cannot shift).
    #[inline(always)]
    fn scatter_wavelengths<L: Lanes>(
        &self,
        scene: &Scene,
        m: &Material,
        lambda: L,
        sampler: &mut Sampler,
    ) -> Option<(L, L)> {
        let n = self.lanes;
        if !(scene.has_fluorescence && m.is_fluorescent()) {
            return Some((lambda, m.diagonal_lanes(n, lambda)));
        }
        // Each lane samples its own λin (Jung 5.3) with its own random numbers.
        let mut valid = true;
        let (new_lambda, w) = L::from_fn2(n, |j| {
            let s = m.sample(
                lambda.lane(j),
                sampler.next2(),
                PathSide::Camera,
                self.shift,
            );
            let w = s.weight();
            if !positive(s.pdf) || !w.is_finite() {
                valid = false;
            }
            (s.lambda, w)
        });
        valid.then_some((new_lambda, w))
    }

    /// Next-event estimation at every lane with the hero's light sample, weighted by MIS against
    /// the lobe's sampling, times the throughput `beta` (sampler: four values).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn next_event<L: Lanes>(
        &self,
        scene: &Scene,
        it: &Interaction,
        wo: Vec3,
        lobe: Scattering,
        beta: L,
        lambda: L,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) -> L {
        let (ul, up, u2) = (sampler.next(), sampler.next(), sampler.next2());
        let Some(ls) = scene.lights.sample_li(it.p, ul, up, u2) else {
            return L::ZERO;
        };
        let f = lobe.eval(wo, ls.wi);
        if f == 0.0 {
            return L::ZERO;
        }
        let (a, b) = (Endpoint { p: it.p, n: it.n }, Endpoint { p: ls.p, n: ls.n });
        let tr = transmittance(scene, a, b, &mut sink.stats.rays);
        if tr.is_zero() {
            return L::ZERO;
        }
        let n = self.lanes;
        let le = scene.lights[ls.light].spectrum.eval_lanes(n, lambda) * tr.at_lanes(n, lambda);
        let w = self.mis.weight2(ls.pdf, lobe.pdf(wo, ls.wi));
        beta * le * (f * lobe.abs_cos(ls.wi) / ls.pdf * w)
    }
}
