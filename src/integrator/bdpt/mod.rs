//! `bdpt-forward` and `bdpt-backward`: bidirectional path tracing with one wavelength per path
//! segment, camera and light sub-paths that sample wavelengths independently, the forward or
//! backward wavelength reset at connections, and wavelength-aware MIS (Jung ch. 6); and
//! `bdpt-allbins` (Jung 6.5) in `allbins/`. docs/design.md §3.3 draws how they share the core.
//!
//! The core every BDPT stands on:
//! - `geometric`: the wavelength-free random walk; vertices with area pdfs in both directions,
//!   lobes, light sampling and transmittance come from `crate::transport`.
//! - `connection`: the connecting segment, its two ends' lobes and the pdfs it changes, the
//!   camera's importance, the shadow ray, the splat and the delivery to the film.
//! - `weight`: the one MIS ratio walk, with each integrator's pdfs and wavelength pdf ratios.
//!
//! What makes bdpt-forward and bdpt-backward different:
//! - `wavelength`: how a sub-path's first wavelength is drawn, and cache keys;
//! - `subpath`: camera (Alg. 1) and light (Alg. 3) sub-paths with per-vertex wavelengths;
//! - `reset`: forward (Alg. 4) and backward (Alg. 5) resets;
//! - `mis`: the connected path with its wavelengths, and p_Λ(ŝ) of every strategy;
//! - `evaluate`: connections for all (s, t) and the throughput (eqs. 6.18, 6.19);
//! - `media`: the segments of a connected path through media;
//! - `combined`: `bdpt-combined`, both resets of a connection weighted among all 2k
//!   techniques (ŝ, reset); `adaptive`: its per-pixel choice of one reset from a pilot;
//! - `plain` and `cache`: the fast evaluation of paths that cannot shift the wavelength, which
//!   keeps only its product caches.

pub mod adaptive;
pub mod allbins;
pub(crate) mod cache;
pub mod combined;
pub mod connection;
pub mod evaluate;
pub mod geometric;
pub mod media;
pub mod mis;
pub(crate) mod plain;
pub mod reset;
pub mod subpath;
#[cfg(test)]
mod tests;
pub mod wavelength;
pub mod weight;

pub use crate::transport::VertexKind;
pub use evaluate::strategy_layer;
pub use geometric::SegmentLog;
pub use mis::{FullPath, ResetMode};
pub use subpath::{Buffers, Sampling, Vertex, camera_subpath, light_subpath};

use crate::integrator::{
    Integrator, IntegratorOptions, LightWavelengths, MisHeuristic, ResetChoice, SampleSink, Sampler,
};
use crate::material::ShiftSampling;
use crate::medium::Tracking;
use crate::scene::{NONE, Scene};
use crate::spectrum::cie::CameraWavelengths;
use wavelength::camera_wavelength;

pub struct Bdpt {
    /// The reset of bdpt-forward and bdpt-backward (bdpt-combined: the one its plain
    /// connections' single-reset code paths take, unused otherwise).
    pub(crate) mode: ResetMode,
    /// bdpt-combined: which resets each connection evaluates (`combined`).
    pub(crate) combined: Option<ResetChoice>,
    /// bdpt-combined `--reset-choice adaptive`: the pilot and each pixel's reset.
    pub(crate) adaptive: Option<adaptive::Adaptive>,
    pub(crate) depth: Depth,
    pub(crate) camera_wavelengths: CameraWavelengths,
    pub(crate) shift: ShiftSampling,
    pub(crate) light_wavelengths: LightWavelengths,
    pub(crate) mis: MisHeuristic,
    pub(crate) tracking: Tracking,
    pub(crate) strategy_images: bool,
    /// Render only this strategy (s, t), unweighted (test hook for the per-strategy check).
    pub(crate) only: Option<(usize, usize)>,
}

/// Per-thread vertex buffers.
pub struct Scratch {
    pub(crate) cam: Vec<Vertex>,
    pub(crate) light: Vec<Vertex>,
    pub(crate) path: FullPath,
    /// The sub-paths' segments (media scenes).
    pub(crate) cam_log: SegmentLog,
    pub(crate) light_log: SegmentLog,
    /// The measurement factors each sub-path fixes (`cache`).
    pub(crate) cam_cache: cache::SubpathCache,
    pub(crate) light_cache: cache::SubpathCache,
    /// The sub-path vertices' wavelength pdfs at the wavelengths last seen (`fill_pdfs`).
    pub(crate) pdf_memo: cache::VertexPdfMemo,
    /// f_λ of the materials at the wavelengths last seen (the walks and the connections).
    pub(crate) spectral: cache::SpectralCache,
    /// The light sub-path in path order (reversed), whose tails the connections copy.
    pub(crate) light_rev: Vec<Vertex>,
    /// The CIE weight at the last λ0 (its bits).
    pub(crate) xyz: Option<(u32, glam::Vec3)>,
    /// The first camera and light sub-path vertex after which the sub-path's throughput is zero
    /// (`usize::MAX`: none); bdpt-combined skips the reset that would keep it.
    pub(crate) cam_zero: usize,
    pub(crate) light_zero: usize,
    /// bdpt-combined with `--reset-choice sample` or `adaptive`: the reset of this sample.
    pub(crate) sample_reset: ResetMode,
    /// bdpt-combined: how many samples of each reset's (forward, backward) techniques this pixel
    /// sample takes, up to a common factor (`FullPath::combined_weight`): (1, 1) but for
    /// `--reset-choice adaptive`, where the pixel's reset is taken with probability 1.
    pub(crate) counts: [f64; 2],
    /// The pixel of the current sample (`--reset-choice adaptive`; the film position may round
    /// to the next pixel's edge).
    pub(crate) pixel: u32,
    /// `path.v` starts with the camera prefix of this many vertices (0: none).
    pub(crate) prefix: usize,
    /// The products and pdfs of the plain connections (`plain`).
    pub(crate) plain: plain::PlainCache,
    /// bdpt-combined: the plain connections' products at the backward reset's wavelength.
    pub(crate) plain_backward: plain::PlainCache,
}

impl Bdpt {
    pub fn new(scene: &Scene, o: &IntegratorOptions, mode: ResetMode) -> Result<Self, String> {
        let name = match mode {
            ResetMode::Forward => "bdpt-forward",
            ResetMode::Backward => "bdpt-backward",
        };
        Self::checked(scene, o, name, mode, None)
    }

    /// `bdpt-combined`: both resets combined by MIS over all 2k techniques (`combined`),
    /// evaluating both at each connection or one chosen at random (`o.reset_choice`).
    pub fn combined(scene: &Scene, o: &IntegratorOptions) -> Result<Self, String> {
        let choice = Some(o.reset_choice);
        let mut b = Self::checked(scene, o, "bdpt-combined", ResetMode::Forward, choice)?;
        if o.reset_choice == ResetChoice::Adaptive {
            b.adaptive = Some(adaptive::Adaptive::new(scene));
        }
        Ok(b)
    }

    fn checked(
        scene: &Scene,
        o: &IntegratorOptions,
        name: &str,
        mode: ResetMode,
        combined: Option<ResetChoice>,
    ) -> Result<Self, String> {
        if let Some(f) = scene.wavelength_dependent_feature() {
            return Err(format!(
                "{name} refuses this scene: it has {f}; the wavelength reset needs directional \
                 sampling that does not depend on wavelength (Jung 8.1)"
            ));
        }
        if scene.lights.is_empty() {
            return Err(format!("{name}: the scene has no lights"));
        }
        Ok(Bdpt {
            mode,
            combined,
            adaptive: None,
            depth: Depth::new(o),
            camera_wavelengths: o.camera_wavelengths,
            shift: ShiftSampling::new(o.wavelength_sampling, scene.domain),
            light_wavelengths: o.light_wavelengths,
            mis: o.mis,
            tracking: o.tracking,
            strategy_images: o.strategy_images,
            only: None,
        })
    }

    /// Render only strategy (s, t), without MIS weight (each strategy alone must converge to the
    /// light carried by paths of s + t vertices).
    pub fn single_strategy(mut self, s: usize, t: usize) -> Self {
        self.only = Some((s, t));
        self
    }

    pub fn mode(&self) -> ResetMode {
        self.mode
    }

    #[inline]
    fn wanted(&self, s: usize, t: usize) -> bool {
        self.only.is_none_or(|o| o == (s, t))
    }

    /// Trace both sub-paths of one sample into `scratch`.
    pub(crate) fn trace_subpaths(
        &self,
        scene: &Scene,
        (x, y): (f32, f32),
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        stats: &mut crate::integrator::Stats,
    ) {
        let lambda0 = camera_wavelength(scene, self.camera_wavelengths, sampler).lambda;
        let media = scene.has_media;
        let how = |stop_on_zero| Sampling {
            shift: self.shift,
            tracking: self.tracking,
            stop_on_zero,
        };
        // A sub-path may end at zero spectral throughput only where its wavelengths are final
        // for every reset evaluated: the camera's under the forward reset, the light's under
        // the backward one, neither when both are combined (docs/bdpt.md).
        let forward = match self.combined {
            Some(ResetChoice::Sample) => {
                // `--reset-choice sample`: this sample's one reset
                let forward = sampler.next() < 0.5;
                scratch.sample_reset = if forward {
                    ResetMode::Forward
                } else {
                    ResetMode::Backward
                };
                forward
            }
            Some(ResetChoice::Adaptive) => {
                // `--reset-choice adaptive`: the pixel's one reset, taken with probability 1
                let a = self.adaptive.as_ref().expect("adaptive state");
                scratch.sample_reset = a.reset(scratch.pixel);
                scratch.counts = counts(scratch.sample_reset);
                scratch.sample_reset == ResetMode::Forward
            }
            _ => self.mode == ResetMode::Forward,
        };
        let (cam_stop, light_stop) = match self.combined {
            None | Some(ResetChoice::Sample | ResetChoice::Adaptive) => (forward, !forward),
            Some(_) => (false, false),
        };
        let cam = Buffers {
            out: &mut scratch.cam,
            log: media.then_some(&mut scratch.cam_log),
            spectral: &mut scratch.spectral,
        };
        let n = self.depth.camera_vertices();
        let rng = (&mut *sampler, &mut *stats);
        scratch.cam_zero = camera_subpath(scene, (x, y), lambda0, n, how(cam_stop), rng, cam);
        let light = Buffers {
            out: &mut scratch.light,
            log: media.then_some(&mut scratch.light_log),
            spectral: &mut scratch.spectral,
        };
        let (n, mode) = (self.depth.light_vertices(), self.light_wavelengths);
        scratch.light_zero =
            light_subpath(scene, n, mode, how(light_stop), (sampler, stats), light);
        scratch.cam_cache.invalidate();
        scratch.light_cache.invalidate();
        scratch.pdf_memo.invalidate();
        scratch.prefix = 0;
        scratch.light_rev.clear();
        scratch.light_rev.extend(scratch.light.iter().rev());
        if !media {
            // plain connections need scenes without media (`plain`)
            scratch.plain.reset(&scratch.cam, &scratch.light);
            if self.combined.is_some() {
                scratch.plain_backward.reset(&scratch.cam, &scratch.light);
            }
        }
    }
}

/// The length limit of a bidirectional integrator's paths, `--max-depth` segments, and what it
/// means for its sub-paths; written once here instead of at each call site.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Depth {
    /// The most segments a path may have.
    pub segments: usize,
}

impl Depth {
    pub fn new(o: &IntegratorOptions) -> Self {
        Depth {
            segments: o.max_depth as usize,
        }
    }

    /// A camera sub-path's most vertices: the pinhole, and one past the last scattering
    /// vertex, which only a camera hit on an emitter (t = 0) uses.
    #[inline]
    pub fn camera_vertices(self) -> usize {
        self.segments + 1
    }

    /// A light sub-path's most vertices.
    #[inline]
    pub fn light_vertices(self) -> usize {
        self.segments
    }

    /// Whether strategy (s, t) makes a path short enough: s + t vertices, s + t − 1 segments.
    #[inline]
    pub fn allows(self, s: usize, t: usize) -> bool {
        s + t - 1 <= self.segments
    }

    /// The capacity of the per-thread vertex buffers.
    pub fn capacity(self) -> usize {
        self.segments + 2
    }
}

/// The auxiliary layers of a BDPT: the strategy images when asked for (`--strategy-images`).
pub fn strategy_images(wanted: bool, depth: Depth) -> Vec<String> {
    if wanted {
        strategy_layer_names(depth.segments)
    } else {
        Vec::new()
    }
}

/// Names of the strategy images `s{s}_t{t}` (s camera vertices, t light vertices) for paths of
/// up to `max_depth` segments, in the order of [`strategy_layer`]; shared with `bdpt-allbins`.
pub fn strategy_layer_names(max_depth: usize) -> Vec<String> {
    let mut names = Vec::new();
    for k in 2..=max_depth + 1 {
        for s in 1..=k {
            debug_assert_eq!(strategy_layer(s, k - s), names.len());
            names.push(format!("s{}_t{}", s, k - s));
        }
    }
    names
}

impl Scratch {
    pub fn camera(&self) -> &[Vertex] {
        &self.cam
    }
    pub fn light(&self) -> &[Vertex] {
        &self.light
    }
}

impl Integrator for Bdpt {
    type Scratch = Scratch;

    fn scratch(&self, scene: &Scene) -> Scratch {
        let n = self.depth.capacity();
        Scratch {
            cam: Vec::with_capacity(n),
            light: Vec::with_capacity(n),
            path: FullPath::with_capacity(2 * n),
            cam_log: SegmentLog::default(),
            light_log: SegmentLog::default(),
            cam_cache: cache::SubpathCache::default(),
            pdf_memo: cache::VertexPdfMemo::default(),
            light_cache: cache::SubpathCache::default(),
            spectral: cache::SpectralCache::new(scene),
            light_rev: Vec::with_capacity(n),
            xyz: None,
            cam_zero: usize::MAX,
            light_zero: usize::MAX,
            sample_reset: ResetMode::Forward,
            counts: [1.0, 1.0],
            pixel: 0,
            prefix: 0,
            plain: plain::PlainCache::default(),
            plain_backward: plain::PlainCache::default(),
        }
    }

    fn aux_layers(&self) -> Vec<String> {
        strategy_images(self.strategy_images, self.depth)
    }

    fn sample(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        sink: &mut SampleSink,
    ) {
        let rays = sink.stats.rays;
        scratch.pixel = sink.pixel;
        self.trace_subpaths(scene, (x, y), sampler, scratch, sink.stats);
        let md = self.depth.segments;
        let (nc, nl) = (scratch.cam.len(), scratch.light.len());
        // t = 0: the camera path hits an emitter
        for s in 2..=nc {
            if scratch.cam[s - 1].light != NONE && self.wanted(s, 0) {
                self.connect(scene, s, 0, sampler, scratch, sink);
            }
        }
        // t = 1: next-event estimation with a fresh light vertex (kept out of the sub-path)
        for s in 2..=nc.min(md) {
            if scratch.cam[s - 1].material != NONE && self.wanted(s, 1) {
                self.connect(scene, s, 1, sampler, scratch, sink);
            }
        }
        // s = 1: light tracing, splatted onto the film
        for t in 1..=nl.min(md) {
            if self.wanted(1, t) {
                self.connect(scene, 1, t, sampler, scratch, sink);
            }
        }
        // s, t ≥ 2
        for s in 2..=nc {
            if scratch.cam[s - 1].material == NONE {
                break;
            }
            for t in 2..=nl {
                if !self.depth.allows(s, t) {
                    break;
                }
                if self.wanted(s, t) {
                    self.connect(scene, s, t, sampler, scratch, sink);
                }
            }
        }
        if let Some(a) = &self.adaptive
            && a.in_pilot()
        {
            a.record(sink.pixel, scratch.sample_reset, sink.stats.rays - rays);
        }
    }

    fn adapting(&self) -> bool {
        self.adaptive.as_ref().is_some_and(|a| a.in_pilot())
    }

    fn end_pass(&self, film: &crate::film::Film, stats: &mut crate::integrator::Stats) {
        if let Some(a) = &self.adaptive {
            a.end_pass(film, stats);
        }
    }
}

impl Bdpt {
    /// The technique counts (`Scratch::counts`) of a connection's path: those of the sample's
    /// pixel, or for light tracing (`splat`) those of the pixel it lands on.
    #[inline]
    pub(crate) fn counts_of(
        &self,
        scene: &Scene,
        splat: Option<(f32, f32)>,
        own: [f64; 2],
    ) -> [f64; 2] {
        match (splat, &self.adaptive) {
            (Some(at), Some(a)) => a.reset_at(at, scene.camera.width).map_or(own, counts),
            _ => own,
        }
    }
}

/// The technique counts of a pixel sample that takes reset `r` with probability 1
/// (`Scratch::counts`).
#[inline]
pub(crate) fn counts(r: ResetMode) -> [f64; 2] {
    match r {
        ResetMode::Forward => [1.0, 0.0],
        ResetMode::Backward => [0.0, 1.0],
    }
}
