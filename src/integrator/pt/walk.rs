//! The random walk of the uni-directional tracers, written once for any number of wavelength
//! lanes `L` (1: pt-mono; N: pt-hero).
//!
//! The first lane is the hero: it makes every directional and distance decision. Directional
//! pdfs are wavelength independent (diffuse lobes, phase functions); without media the HWSS
//! balance heuristic over the lanes reduces to weighting lane j by 1 / Σ_k p(λ_k)
//! ([`SampledWavelengths::balance_pdf`]). In media the distance pdfs depend on each lane's
//! coefficients, so the walk carries each lane's path pdf over the hero's (r_k) and weights lane
//! j by 1 / Σ_k p(λ_k)·r_k (docs/design.md §4). At a fluorescent vertex (surface or medium) each
//! lane samples its own incident wavelength (own random numbers); with the correction term t* of
//! Mojzík §6.2 each lane keeps f_j / (p_dir · p_shift,j), and the path ends when any lane's shift
//! probability is zero. Emitters hit by a scattered ray and next-event estimation are combined
//! with MIS whose pdfs are summed over the lanes. Index-matched boundaries are crossed without a
//! vertex. A scene without media runs the walk instantiated without medium code.

use crate::geometry::Ray;
use crate::geometry::ray::{cross_boundary_ray, spawn_ray};
use crate::integrator::{IntegratorOptions, LaneWeighting, MisHeuristic, SampleSink, Sampler};
use crate::material::{Bbrrdf, Material, PathSide, ShiftSampling};
use crate::medium::Tracking;
use crate::scene::{Interaction, MediumInterface, NONE, Scene};
use crate::spectrum::cie::CameraWavelengths;
use crate::spectrum::{Lanes, SampledWavelengths};
use crate::transport::media::{MAX_CROSSINGS, NO_NORMAL};
use crate::transport::{Endpoint, Scattering, Travel, transmittance, transmittance_lanes, travel};
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
    pub tracking: Tracking,
    /// Mojzík's HWSS: lanes weighted without their distance pdfs (`LaneWeighting::Hero`).
    pub hero_distances: bool,
}

impl Walk {
    /// A walk carrying `lanes` wavelengths.
    pub fn new(scene: &Scene, o: &IntegratorOptions, lanes: usize) -> Self {
        Walk {
            max_depth: o.max_depth,
            lanes,
            camera_wavelengths: o.camera_wavelengths,
            shift: ShiftSampling::new(o.wavelength_sampling, scene.domain),
            mis: o.mis,
            rr_depth: o.rr_depth,
            tracking: o.tracking,
            hero_distances: o.lane_weighting == LaneWeighting::Hero,
        }
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
        // A scene without media never runs medium code (none exists without the `media` feature).
        if cfg!(feature = "media") && scene.has_media {
            self.trace_media::<L>(scene, x, y, sampler, sink)
        } else {
            // The walk draws from a copy of the stream, which does not escape the inlined walk
            // (the compiler keeps it in registers), and hands the stream back at the end.
            let mut local = sampler.clone();
            self.trace_in::<L, false>(scene, x, y, &mut local, sink);
            *sampler = local;
        }
    }

    /// [`Walk::trace`] in a scene with media (out of line, so that the walk without media keeps
    /// its sampler in registers).
    #[inline(never)]
    fn trace_media<L: Lanes>(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) {
        self.trace_in::<L, true>(scene, x, y, sampler, sink)
    }

    #[inline(always)]
    fn trace_in<L: Lanes, const MEDIA: bool>(
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
        let lanes = LaneBalance {
            pdf: wl.pdf,
            pdf_sum,
        };
        let mut ray = scene.camera.generate_ray(x, y);
        let mut s = PathState::new(wl.lambda, n, ray.o, scene.camera_medium);
        let mut depth = 0u32;
        let mut crossings = 0usize;
        while depth < self.max_depth {
            sink.stats.rays += 1;
            let hit = scene.intersect(&ray, f32::INFINITY);
            if MEDIA && let Some(m) = scene.medium(s.medium) {
                let t_max = hit.map_or(f32::INFINITY, |h| h.t);
                let mut u = || sampler.next();
                match travel(m, &ray, t_max, s.lambda, n, self.tracking, false, &mut u) {
                    Travel::Collision { t, factor, ratio } => {
                        s.beta *= factor;
                        s.track(ratio, self.hero_distances);
                        depth += 1;
                        if depth >= self.max_depth {
                            break;
                        }
                        let p = ray.at(t);
                        match self
                            .medium_vertex(scene, p, -ray.d, &mut s, lanes, depth, sampler, sink)
                        {
                            Some(r) => ray = r,
                            None => break,
                        }
                        continue;
                    }
                    Travel::Pass {
                        factor,
                        ratio,
                        pass,
                    } => {
                        s.beta *= factor;
                        s.track(ratio, self.hero_distances);
                        s.pass *= pass;
                    }
                }
                if !positive(s.beta.max_lane()) {
                    break;
                }
            }
            let Some(it) = hit else {
                break;
            };
            if MEDIA && it.material == NONE && it.light == NONE {
                // An index-matched boundary: not a vertex of the path.
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    break;
                }
                s.medium = scene.medium_after(&it, ray.d, s.medium);
                ray = cross_boundary_ray(it.p, it.n, ray.d);
                continue;
            }
            depth += 1;
            let wo = -ray.d;
            let segments = depth as usize;
            s.segments = segments;
            if it.light != NONE {
                let c = self.emitter_hit::<L, MEDIA>(scene, &it, wo, &s, lanes, depth);
                if c.max_lane() > 0.0 {
                    s.radiance += c;
                    sink.stats.contribution(segments);
                }
            }
            if it.material == NONE || depth >= self.max_depth {
                break;
            }
            match self.surface_vertex::<L, MEDIA>(scene, &it, wo, &mut s, lanes, sampler, sink) {
                Some(r) => ray = r,
                None => break,
            }
            if let Some(rr) = self.rr_depth
                && depth >= rr
            {
                // Wavelength-set-wide roulette on the largest lane.
                let q = s.beta.max_lane().min(0.95);
                if sampler.next() >= q {
                    break;
                }
                s.beta *= 1.0 / q;
            }
        }
        let r = s.radiance;
        // Colour-matching weights (or the sensor's response) of the camera lanes.
        let [wx, wy, wz] = obs.response_lanes(wl.lambda, n);
        let xyz = Vec3::new(r.dot(wx), r.dot(wy), r.dot(wz)) * (obs.inv_y_integral / pdf_sum);
        if sink.add(xyz) && sink.spectral.is_some() {
            // the spectral image: each lane's radiance at its own wavelength
            for j in 0..n {
                sink.spectral(wl.lambda.lane(j), r.lane(j) / pdf_sum);
            }
        }
    }

    /// Scatter at the surface `it` (direction back `wo`): the lanes' wavelengths, next-event
    /// estimation and the hero's new direction; `None` ends the path.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn surface_vertex<L: Lanes, const MEDIA: bool>(
        &self,
        scene: &Scene,
        it: &Interaction,
        wo: Vec3,
        s: &mut PathState<L>,
        lanes: LaneBalance<L>,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) -> Option<Ray> {
        let m: &Material = &scene.materials[it.material as usize];
        let (new_lambda, w) = self.scatter_wavelengths(scene, m, s.lambda, sampler)?;
        s.beta *= w;
        s.lambda = new_lambda;
        if !positive(s.beta.max_lane()) {
            return None;
        }
        s.vertex(it.p, self.lanes);
        let lobe = Scattering::Diffuse { n: it.n };
        let a = Endpoint { p: it.p, n: it.n };
        let iface = if MEDIA { scene.interface(it) } else { None };
        let c = self.next_event::<L, MEDIA>(scene, a, iface, wo, lobe, s, lanes, sampler, sink);
        if c.max_lane() > 0.0 {
            s.radiance += c;
            sink.stats.contribution(s.segments + 1);
        }
        // Continue with the hero's direction.
        let d = lobe.sample(wo, sampler.next2());
        s.beta *= d.weight;
        s.pdf_dir_prev = d.pdf;
        if MEDIA {
            s.medium = scene.medium_after(it, d.wi, s.medium);
        }
        Some(spawn_ray(it.p, it.n, d.wi))
    }

    /// The contribution of the emitter hit at `it` (the path's `depth`-th vertex), weighted by
    /// MIS against next-event estimation and, in media, by the balance over the lanes.
    #[inline(always)]
    fn emitter_hit<L: Lanes, const MEDIA: bool>(
        &self,
        scene: &Scene,
        it: &Interaction,
        wo: Vec3,
        s: &PathState<L>,
        lanes: LaneBalance<L>,
        depth: u32,
    ) -> L {
        let le = self.emitted(scene, it, wo, s.lambda);
        if !(le.max_lane() > 0.0) {
            return L::ZERO;
        }
        let pdf_light = |s: &PathState<L>| {
            let light = it.light as usize;
            scene.lights.pdf_li(s.prev_p, light, it.p, it.n)
        };
        if !MEDIA {
            let w = if depth == 1 {
                1.0
            } else {
                self.mis.weight2(s.pdf_dir_prev, pdf_light(s))
            };
            return s.beta * le * w;
        }
        let w = if depth == 1 {
            1.0
        } else {
            // Both strategies' pdfs summed over the lanes (docs/design.md §4).
            let unidirectional = s.pdf_dir_prev * lanes.pdf.dot(s.ratio_vertex * s.pass);
            let light = pdf_light(s) * lanes.pdf.dot(s.ratio_vertex);
            self.mis.weight2(unidirectional, light)
        };
        s.beta * le * (w * lanes.scale(s.ratio))
    }

    /// Scatter at the medium collision `p` (direction back `wo`): the lanes' in-shifts, next-event
    /// estimation with the phase function, and the hero's new direction; `None` ends the path.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn medium_vertex<L: Lanes>(
        &self,
        scene: &Scene,
        p: Vec3,
        wo: Vec3,
        s: &mut PathState<L>,
        lanes: LaneBalance<L>,
        depth: u32,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) -> Option<Ray> {
        let n = self.lanes;
        let m = scene.medium(s.medium)?;
        let coeff = &m.coefficients;
        if coeff.is_fluorescent() {
            // Each lane draws its own incident wavelength (Mojzík §6.2).
            let mut valid = true;
            let (new_lambda, w) = L::from_fn2(n, |j| {
                let d = coeff.sample_in_shift(s.lambda.lane(j), sampler.next2());
                if !positive(d.pdf) || !d.weight.is_finite() {
                    valid = false;
                }
                (d.lambda, d.weight)
            });
            if !valid {
                return None;
            }
            s.beta *= w;
            s.lambda = new_lambda;
        } else {
            s.beta *= coeff.sigma_s.eval_lanes(n, s.lambda);
        }
        if !positive(s.beta.max_lane()) {
            return None;
        }
        s.vertex(p, n);
        let lobe = Scattering::HenyeyGreenstein { g: m.g };
        let a = Endpoint { p, n: NO_NORMAL };
        let c = self.next_event::<L, true>(scene, a, None, wo, lobe, s, lanes, sampler, sink);
        if c.max_lane() > 0.0 {
            s.radiance += c;
            sink.stats.contribution(depth as usize + 1);
        }
        let d = lobe.sample(wo, sampler.next2());
        s.beta *= d.weight;
        s.pdf_dir_prev = d.pdf;
        Some(Ray::new(p, d.wi))
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
        if !(cfg!(feature = "fluorescence") && scene.has_fluorescence && m.is_fluorescent()) {
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

    /// Next-event estimation at every lane with the hero's light sample from vertex `a` (a
    /// surface with medium interface `iface`, or a point in medium `s.medium`), weighted by MIS
    /// against the lobe's sampling, times the throughput (sampler: four values).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn next_event<L: Lanes, const MEDIA: bool>(
        &self,
        scene: &Scene,
        a: Endpoint,
        iface: Option<MediumInterface>,
        wo: Vec3,
        lobe: Scattering,
        s: &PathState<L>,
        lanes: LaneBalance<L>,
        sampler: &mut Sampler,
        sink: &mut SampleSink,
    ) -> L {
        let (ul, up, u2) = (sampler.next(), sampler.next(), sampler.next2());
        let Some(ls) = scene.lights.sample_li(a.p, ul, up, u2) else {
            return L::ZERO;
        };
        let f = lobe.eval(wo, ls.wi);
        if f == 0.0 {
            return L::ZERO;
        }
        let b = Endpoint { p: ls.p, n: ls.n };
        let n = self.lanes;
        let (tr, w) = if MEDIA {
            // The shadow ray leaves into the medium on the light's side of a surface.
            let medium = iface.map_or(s.medium, |i| i.towards(a.n, ls.wi));
            let rays = &mut sink.stats.rays;
            let mut u = || sampler.next();
            let Some((tr, pass)) = transmittance_lanes(
                scene,
                a,
                b,
                medium,
                s.lambda,
                n,
                self.tracking,
                rays,
                &mut u,
                None,
            ) else {
                return L::ZERO;
            };
            let light = ls.pdf * lanes.pdf.dot(s.ratio);
            let unidirectional = lobe.pdf(wo, ls.wi) * lanes.pdf.dot(s.ratio * pass);
            (
                tr * lanes.scale(s.ratio),
                self.mis.weight2(light, unidirectional),
            )
        } else {
            let tr = transmittance(scene, a, b, &mut sink.stats.rays);
            if tr.is_zero() {
                return L::ZERO;
            }
            let w = self.mis.weight2(ls.pdf, lobe.pdf(wo, ls.wi));
            (tr.at_lanes(n, s.lambda), w)
        };
        let le = scene.lights[ls.light].spectrum.eval_lanes(n, s.lambda) * tr;
        s.beta * le * (f * lobe.abs_cos(ls.wi) / ls.pdf * w)
    }
}

/// The camera wavelengths' pdfs, for the balance heuristic over the lanes.
#[derive(Clone, Copy)]
struct LaneBalance<L> {
    /// p(λ_k) of each camera lane.
    pdf: L,
    /// Σ_k p(λ_k): the film divides by it.
    pdf_sum: f32,
}

impl<L: Lanes> LaneBalance<L> {
    /// The factor turning the film's 1 / Σ_k p(λ_k) into 1 / Σ_k p(λ_k)·r_k, where r_k is lane
    /// k's path pdf over the hero's (HWSS balance heuristic with wavelength-dependent distance
    /// pdfs, Mojzík §6.2).
    #[inline(always)]
    fn scale(&self, ratio: L) -> f32 {
        self.pdf_sum / self.pdf.dot(ratio)
    }
}

/// The state of a camera path between vertices.
struct PathState<L> {
    lambda: L,
    /// Lane j's f / p, p the hero's pdf of the path (without the camera wavelength pdf).
    beta: L,
    radiance: L,
    /// p_k / p_h of the path so far (1 without media).
    ratio: L,
    /// `ratio` at the last vertex, and each lane's probability of having passed every stretch
    /// of medium since it (for the MIS weight of an emitter hit).
    ratio_vertex: L,
    pass: L,
    pdf_dir_prev: f32,
    /// The last vertex.
    prev_p: Vec3,
    /// The medium the path is in.
    medium: u32,
    /// Segments of the path up to its last surface vertex (for the statistics).
    segments: usize,
}

impl<L: Lanes> PathState<L> {
    fn new(lambda: L, n: usize, origin: Vec3, medium: u32) -> Self {
        let one = L::splat_n(n, 1.0);
        PathState {
            lambda,
            beta: one,
            radiance: L::ZERO,
            ratio: one,
            ratio_vertex: one,
            pass: one,
            pdf_dir_prev: 0.0,
            prev_p: origin,
            medium,
            segments: 0,
        }
    }

    /// A stretch of medium whose lanes' distance pdfs over the hero's are `ratio`. Mojzík's HWSS
    /// (`hero`) leaves them out of the lane weights: each lane keeps its own f / p_hero, which is
    /// unbiased wherever the hero's distance pdf is positive, and every lane's weight
    /// p(λ_j) / Σ_k p(λ_k) still sums to one over the rotations.
    #[inline(always)]
    fn track(&mut self, ratio: L, hero: bool) {
        if !hero {
            self.ratio *= ratio;
        }
    }

    /// The path reached a vertex at `p`.
    #[inline(always)]
    fn vertex(&mut self, p: Vec3, n: usize) {
        self.ratio_vertex = self.ratio;
        self.pass = L::splat_n(n, 1.0);
        self.prev_p = p;
    }
}
