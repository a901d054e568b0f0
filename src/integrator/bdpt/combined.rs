//! `bdpt-combined`: the forward (Jung Alg. 4) and the backward (Alg. 5) wavelength reset of
//! every connection as two sampling techniques of one estimator, weighted among all 2k
//! techniques (ŝ, reset) of the connected path (docs/bdpt.md, "bdpt-combined").
//!
//! Both resets of strategy (s, t) start from the same pair of sub-paths, neither of which ends
//! at zero throughput (`Bdpt::trace_subpaths`), and share the assembled path, the connection, its
//! shadow ray and, in media, the segment's stretches. Each reset then draws its own wavelengths
//! and is weighted by p_r(s)^β / Σ_{ŝ,r'} p_r'(ŝ)^β (`FullPath::combined_weight`; plain paths:
//! `plain`). Light tracing (s = 1) keeps the light sub-path's wavelengths under both resets: the
//! two techniques make the same path with the same pdf, so it is evaluated once with their two
//! weights. With `--reset-choice random` each connection with s ≥ 2 evaluates one reset, chosen
//! with probability 1/2, and divides by that probability (one-sample MIS, Veach §9.2.4).

use super::connection::{Connection, Contribution, splat_position, weighted, xyz_weight};
use super::evaluate::{Subpaths, fill_pdfs, measurement_cached};
use super::mis::{FullPath, ResetMode};
use super::subpath::Lambdas;
use super::wavelength::light_wavelength;
use super::{Bdpt, Scratch};
use crate::integrator::{ResetChoice, SampleSink, Sampler, Stats};
use crate::medium::Tracking;
use crate::scene::{NONE, Scene};
use crate::transport::Transmittance;
use crate::transport::segment::retarget;

/// What one connection of bdpt-combined evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluate {
    /// Light tracing (s = 1): one path standing for both resets' techniques.
    LightTracing,
    /// Both resets, each weighted as its own technique.
    Both,
    /// One reset, chosen with probability 1/2 (`--reset-choice random`).
    One(ResetMode),
    /// One reset: the other keeps a sub-path prefix of zero throughput, so its contribution is
    /// 0 and it is not evaluated.
    Only(ResetMode),
    /// The one reset of the sample's pixel, taken with probability 1 (`--reset-choice
    /// adaptive`).
    Chosen(ResetMode),
}

impl Evaluate {
    /// What strategy (s, t) evaluates under `choice`; `None` when every reset's contribution
    /// is 0. The forward reset keeps the camera sub-path's wavelengths on x0 … x(s−1) (t = 0:
    /// up to x(s−2)), the backward reset with t ≥ 2 and light tracing the light sub-path's on
    /// its first t vertices: where that sub-path's throughput is already zero (`cam_zero`,
    /// `light_zero`: the first vertex after which it is), so is the contribution.
    #[inline]
    pub fn of(
        (s, t): (usize, usize),
        choice: ResetChoice,
        (cam_zero, light_zero): (usize, usize),
        sample_reset: ResetMode,
        sampler: &mut Sampler,
    ) -> Option<Self> {
        let light_ok = t <= 1 || t - 1 < light_zero;
        if s == 1 {
            return light_ok.then_some(Evaluate::LightTracing);
        }
        let cam_ok = if t == 0 { s - 2 } else { s - 1 } < cam_zero;
        Some(match (cam_ok, light_ok, choice) {
            (true, true, ResetChoice::Both) => Evaluate::Both,
            (true, true, ResetChoice::Random) if sampler.next() < 0.5 => {
                Evaluate::One(ResetMode::Forward)
            }
            (true, true, ResetChoice::Random) => Evaluate::One(ResetMode::Backward),
            (cam, light, ResetChoice::Sample) => match sample_reset {
                ResetMode::Forward if cam => Evaluate::One(ResetMode::Forward),
                ResetMode::Backward if light => Evaluate::One(ResetMode::Backward),
                _ => return None,
            },
            (cam, light, ResetChoice::Adaptive) => match sample_reset {
                ResetMode::Forward if cam => Evaluate::Chosen(ResetMode::Forward),
                ResetMode::Backward if light => Evaluate::Chosen(ResetMode::Backward),
                _ => return None,
            },
            (true, false, _) => Evaluate::Only(ResetMode::Forward),
            (false, true, _) => Evaluate::Only(ResetMode::Backward),
            (false, false, _) => return None,
        })
    }

    /// The resets to evaluate, in order (`LightTracing`: either, both give the same path).
    #[inline]
    pub fn resets(self) -> &'static [ResetMode] {
        match self {
            Evaluate::Both => &[ResetMode::Forward, ResetMode::Backward],
            Evaluate::LightTracing => &[ResetMode::Forward],
            Evaluate::One(ResetMode::Forward)
            | Evaluate::Only(ResetMode::Forward)
            | Evaluate::Chosen(ResetMode::Forward) => &[ResetMode::Forward],
            Evaluate::One(ResetMode::Backward)
            | Evaluate::Only(ResetMode::Backward)
            | Evaluate::Chosen(ResetMode::Backward) => &[ResetMode::Backward],
        }
    }

    /// Whether the backward reset is among them (it needs the light's wavelength at a fresh
    /// next-event vertex).
    #[inline]
    pub fn has_backward(self) -> bool {
        self.resets().contains(&ResetMode::Backward)
    }

    /// The factor of an evaluated reset's contribution besides its weight: 1 / (the probability
    /// that it was chosen).
    #[inline]
    pub fn inverse_choice(self) -> f64 {
        match self {
            Evaluate::One(_) => 2.0,
            _ => 1.0,
        }
    }

    /// The weight of an evaluated reset when strategies are rendered alone without MIS (test
    /// hook `Bdpt::single_strategy`): the mean of the two techniques of (s, t).
    #[inline]
    pub fn unweighted(self) -> f64 {
        match self {
            Evaluate::Both | Evaluate::Only(_) => 0.5,
            Evaluate::One(_) | Evaluate::LightTracing | Evaluate::Chosen(_) => 1.0,
        }
    }
}

/// The transmittance of the connecting segment, computed once per connection: a surface scene's
/// shadow ray (every wavelength at once), or in media the segment's stretches traced at the first
/// wavelength asked for and carried to others by `transport::segment::retarget`.
enum Shadow {
    NotYet,
    /// No segment to trace (t = 0: the camera sub-path reached the emitter itself).
    Clear,
    Surface(Transmittance),
    Media {
        lambda: f32,
        tr: f32,
    },
    Blocked,
}

impl Shadow {
    /// The transmittance of the connecting segment x(s−1) → x_s of `path` at its λ(s−1):
    /// traced the first time (a surface scene's shadow ray, or the segment through media at
    /// this wavelength, recording its stretches), carried from the first wavelength to this one
    /// afterwards. `Blocked` after a blocked segment.
    #[inline]
    fn at(
        &mut self,
        scene: &Scene,
        path: &mut FullPath,
        s: usize,
        (tracking, rays): (Tracking, &mut u64),
        sampler: &mut Sampler,
    ) -> f32 {
        let lambda = path.lambda[s - 1];
        match *self {
            Shadow::NotYet if scene.has_media => {
                match super::media::connection(scene, path, s, tracking, rays, sampler) {
                    Some(tr) => {
                        *self = Shadow::Media { lambda, tr };
                        tr
                    }
                    None => {
                        *self = Shadow::Blocked;
                        0.0
                    }
                }
            }
            Shadow::NotYet => {
                let (a, b) = (&path.v[s - 1], &path.v[s]);
                let tr = Connection::shadow(scene, a, b, s == 1, rays);
                *self = if tr.is_zero() {
                    Shadow::Blocked
                } else {
                    Shadow::Surface(tr)
                };
                tr.at(lambda)
            }
            Shadow::Surface(tr) => tr.at(lambda),
            Shadow::Clear => 1.0,
            Shadow::Media { lambda: first, tr } => {
                let st = path.seg[s - 1].stretches(&path.stretches);
                let mut u = || sampler.next();
                tr * retarget(scene, st, first, lambda, &mut u)
            }
            Shadow::Blocked => 0.0,
        }
    }
}

impl Bdpt {
    /// Connect strategy (s, t) under the resets `choice` asks for and deliver each weighted
    /// contribution. Out of line: inlined into `Bdpt::connect`, its code changed what the
    /// compiler inlines in bdpt-forward's and bdpt-backward's connections (+9 % instructions
    /// on cornell-box).
    #[inline(never)]
    pub(super) fn connect_combined(
        &self,
        scene: &Scene,
        (s, t): (usize, usize),
        choice: ResetChoice,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        sink: &mut SampleSink,
    ) {
        let zero = (scratch.cam_zero, scratch.light_zero);
        let Some(how) = Evaluate::of((s, t), choice, zero, scratch.sample_reset, sampler) else {
            return;
        };
        let c = if !scene.has_media && scratch.plain.covers(s, t) {
            self.combined_plain(scene, (s, t), how, sampler, scratch, sink.stats)
        } else {
            self.combined_full(scene, (s, t), how, sampler, scratch, sink.stats)
        };
        for c in c.into_iter().flatten() {
            self.deliver(s, t, c, sink);
        }
    }

    /// [`Self::connect_combined`] on the full path (`evaluate::connect_full` for each reset).
    fn combined_full(
        &self,
        scene: &Scene,
        (s, t): (usize, usize),
        how: Evaluate,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        stats: &mut Stats,
    ) -> [Option<Contribution>; 2] {
        let k = s + t;
        let mut out = [None, None];
        // a fresh next-event vertex is drawn once, its light wavelength only for the backward reset
        let fresh = self.assemble(scene, (s, t), sampler, scratch);
        let path = &mut scratch.path;
        if path.v[k - 1].light == NONE {
            return out;
        }
        if fresh && how.has_backward() {
            let (light, mode) = (path.v[k - 1].light, self.light_wavelengths);
            path.v[k - 1].data =
                Lambdas::both(light_wavelength(scene, light, mode, sampler).lambda);
        }
        let media = scene.has_media;
        if media {
            let (cam, light) = (&scratch.cam_log, &scratch.light_log);
            super::media::gather(scene, path, cam, light, s, fresh);
        }
        let splat = if s == 1 {
            match splat_position(scene, &path.v[0], &path.v[1]) {
                Some(at) => Some(at),
                None => return out,
            }
        } else {
            None
        };
        let mut shadow = if t == 0 {
            Shadow::Clear
        } else {
            Shadow::NotYet
        };
        for (slot, &mode) in out.iter_mut().zip(how.resets()) {
            let path = &mut scratch.path;
            self.reset(mode, scene, path, (s, t), sampler);
            let xyz_w = xyz_weight(scene, path.lambda[0], &mut scratch.xyz);
            if xyz_w == glam::Vec3::ZERO {
                continue;
            }
            let sub = Subpaths {
                cam: &mut scratch.cam_cache,
                cam_v: &scratch.cam,
                lc: &mut scratch.light_cache,
                light_v: &scratch.light,
            };
            let mut f = measurement_cached(scene, path, s, sub, &mut scratch.spectral);
            if f <= 0.0 {
                continue;
            }
            // the connecting segment's transmittance, traced once for both resets
            let tracing = (self.tracking, &mut stats.rays);
            let tr = shadow.at(scene, path, s, tracing, sampler);
            if matches!(shadow, Shadow::Blocked) {
                break;
            }
            f *= tr as f64;
            fill_pdfs(self, scene, path, (s, t), &mut scratch.pdf_memo);
            // the technique's own pdf (eq. 6.14); a zero, NaN or infinite one is a lost
            // contribution, as in `evaluate::connect_full`
            let p = path.strategy_pdf(s, mode);
            if !(p > 0.0 && p.is_finite()) {
                stats.dropped_strategy_pdfs += (f != 0.0) as u64;
                continue;
            }
            let p_mis = if media {
                f *= super::media::flight_weight(scene, path, s, sampler);
                let (cam, light) = (&scratch.cam_log, &scratch.light_log);
                super::media::distance_pdfs(scene, path, self.tracking, cam, light);
                path.fold_distances();
                path.strategy_pdf(s, mode)
            } else {
                p
            };
            let w = if self.only.is_some() {
                how.unweighted()
            } else if p_mis > 0.0 && p_mis.is_finite() {
                let both = how == Evaluate::LightTracing;
                let n = self.counts_of(scene, splat, scratch.counts);
                let w = match n {
                    // one reset only (`--reset-choice adaptive`): its own weight, which needs
                    // only its wavelength pdf table (`combined_weights.rs`: the same to 1e-12)
                    [1.0, 0.0] => path.mis_weight(s, ResetMode::Forward, self.mis),
                    [0.0, 1.0] => path.mis_weight(s, ResetMode::Backward, self.mis),
                    _ => path.combined_weight(s, mode, both, self.mis, n),
                };
                w * how.inverse_choice()
            } else {
                // as in `evaluate::connect_full`: weight 0, a loss only if no technique is left
                let lost = p_mis != 0.0 || !path.any_technique();
                stats.dropped_strategy_pdfs += (lost && f != 0.0) as u64;
                continue;
            };
            // eqs. 6.18/6.19: w · f / (p_A p_Λ) in XYZ with the CIE weight at λ0
            *slot = weighted(xyz_w, path.lambda[0], w * f / p, splat, stats);
        }
        out
    }
}
