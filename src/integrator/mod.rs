//! Integrators and the interfaces they share: options, statistics, the per-sample random number
//! stream and the sink that receives contributions. One integrator per file; the render loop is
//! in `render.rs`.

pub mod bdpt;
/// `bdpt-allbins` lives in `bdpt::allbins`; this path is kept for existing callers.
pub use bdpt::allbins;
pub mod pt;
pub mod render;

pub use render::{
    CANCELLED, Cancel, RenderOutput, RenderSettings, check, render, shard_info, with_threads,
};

use crate::film::spectral::SpectralBins;
use crate::material::WavelengthSampling;
use crate::medium::Tracking;
pub use crate::scene::LightWavelengths;
use crate::scene::Scene;
use crate::spectrum::cie::CameraWavelengths;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

named_enum! {
    /// The integrators stokes offers.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    pub enum IntegratorKind {
        /// Uni-directional path tracer, one wavelength per path (Mojzík §6; Jung 5.3 at fluorescent vertices).
        PtMono = "pt-mono",
        /// Uni-directional path tracer with hero wavelength spectral sampling (Mojzík §6.2).
        PtHero = "pt-hero",
        /// Bidirectional path tracer with the forward wavelength reset (Jung 6.3.1.1).
        BdptForward = "bdpt-forward",
        /// Bidirectional path tracer with the backward wavelength reset (Jung 6.3.1.2).
        BdptBackward = "bdpt-backward",
        /// Bidirectional path tracer with both wavelength resets combined by MIS (docs/bdpt.md).
        BdptCombined = "bdpt-combined",
        /// Geometric BDPT evaluated for every wavelength bin (Jung 6.5).
        BdptAllbins = "bdpt-allbins",
    }
}

impl IntegratorKind {
    /// Whether the integrator can make a spectral image, and why not: bdpt-allbins carries the
    /// camera's three CIE importance rows through the path, not per-bin radiance.
    pub fn spectral_support(&self) -> Result<(), String> {
        match self {
            IntegratorKind::BdptAllbins => Err(
                "bdpt-allbins cannot make a spectral image: it carries the camera's three CIE \
                 importance rows through the path, not per-bin radiance (use bdpt-forward, \
                 bdpt-backward, pt-hero or pt-mono)"
                    .into(),
            ),
            _ => Ok(()),
        }
    }

    /// Every integrator ([`IntegratorKind::ALL`]).
    pub fn all() -> [IntegratorKind; 6] {
        Self::ALL
    }
}

named_enum! {
    /// MIS heuristic.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub enum MisHeuristic {
        #[default]
        Balance = "balance",
        Power = "power",
    }
}

impl MisHeuristic {
    /// Weight of a strategy with pdf `a` against one other strategy with pdf `b`.
    #[inline]
    pub fn weight2(&self, a: f32, b: f32) -> f32 {
        match self {
            MisHeuristic::Balance => a / (a + b),
            MisHeuristic::Power => {
                let (a2, b2) = (a * a, b * b);
                if a2.is_infinite() {
                    1.0
                } else {
                    a2 / (a2 + b2)
                }
            }
        }
    }
    /// Exponent applied to pdf ratios.
    #[inline]
    pub fn exponent(&self) -> f32 {
        match self {
            MisHeuristic::Balance => 1.0,
            MisHeuristic::Power => 2.0,
        }
    }
}

named_enum! {
    /// Which wavelength resets bdpt-combined evaluates at each connection (docs/bdpt.md).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub enum ResetChoice {
        /// Both: the forward and the backward reset, each weighted among all 2k techniques.
        #[default]
        Both = "both",
        /// One, forward or backward with probability 1/2, weighted by the same combined pdfs.
        Random = "random",
        /// One for the whole sample, forward or backward with probability 1/2; the sub-path whose
        /// wavelengths that reset keeps may then end at zero throughput, as in bdpt-forward or
        /// bdpt-backward.
        Sample = "sample",
        /// One for the whole sample, chosen per pixel: the first 8 passes take forward and
        /// backward in turn, then each group of pixels that sees one shape keeps the reset with
        /// the lower variance times cost in rays (weights: the chosen reset's techniques only).
        Adaptive = "adaptive",
    }
}

impl ResetChoice {
    fn is_default(&self) -> bool {
        *self == ResetChoice::default()
    }
}

named_enum! {
    /// How pt-hero weights its lanes in media, where each lane's distance pdf differs.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub enum LaneWeighting {
        /// The balance heuristic over every lane's path pdf, distance decisions included
        /// (docs/design.md §4): lane j is weighted by 1 / Σ_k p(λ_k)·r_k.
        #[default]
        Balance = "balance",
        /// Mojzík's HWSS (§6.2): the hero's distance decisions alone, every lane weighted by
        /// 1 / Σ_k p(λ_k) as without media; each lane keeps its own f / p_hero.
        Hero = "hero",
    }
}

/// Options shared by the integrators; each integrator reads the ones it needs. In experiment
/// configs these are the variant's `options` object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IntegratorOptions {
    /// Maximum number of path segments (1 = emitters seen directly).
    pub max_depth: u32,
    pub camera_wavelengths: CameraWavelengths,
    pub wavelength_sampling: WavelengthSampling,
    /// Hero wavelength lanes (pt-hero). 8 by default: at equal time 8 lanes gave more SNR than
    /// 4 on the fluorescent walls, the green spheres and the medium box, and as much as 16, on
    /// both machine kinds measured (results/README.md, `hero-lanes-*`).
    pub lanes: u32,
    pub light_wavelengths: LightWavelengths,
    pub mis: MisHeuristic,
    /// Bin width in nm (bdpt-allbins).
    pub bin_width: f32,
    /// Russian roulette from this many segments on (pt-mono, pt-hero); off when absent.
    pub rr_depth: Option<u32>,
    /// Distance tracking in participating media.
    pub tracking: Tracking,
    /// Lane weighting of pt-hero in media.
    pub lane_weighting: LaneWeighting,
    /// Accumulate one image per BDPT strategy (s, t).
    pub strategy_images: bool,
    /// The resets bdpt-combined evaluates per connection (left out of the JSON when "both", so
    /// the options of the other integrators read as before).
    #[serde(skip_serializing_if = "ResetChoice::is_default")]
    pub reset_choice: ResetChoice,
}

impl Default for IntegratorOptions {
    fn default() -> Self {
        IntegratorOptions {
            max_depth: 8,
            camera_wavelengths: CameraWavelengths::Uniform,
            wavelength_sampling: WavelengthSampling::Importance,
            lanes: 8,
            light_wavelengths: LightWavelengths::Emission,
            mis: MisHeuristic::Balance,
            bin_width: 5.0,
            rr_depth: None,
            tracking: Tracking::Aware,
            lane_weighting: LaneWeighting::Balance,
            strategy_images: false,
            reset_choice: ResetChoice::Both,
        }
    }
}

impl IntegratorOptions {
    /// Check the options that only one integrator reads against the integrator `kind`: a
    /// reset choice other than "both" means bdpt-combined.
    pub fn validate_for(&self, kind: IntegratorKind) -> Result<(), String> {
        if kind != IntegratorKind::BdptCombined && !self.reset_choice.is_default() {
            return Err(format!(
                "reset_choice {:?} applies only to bdpt-combined, not to {}",
                self.reset_choice.name(),
                kind.name()
            ));
        }
        self.validate()
    }

    /// Check values that serde cannot; the message names the option.
    pub fn validate(&self) -> Result<(), String> {
        if self.max_depth == 0 || self.max_depth > 1024 {
            return Err(format!("max_depth must be 1–1024, got {}", self.max_depth));
        }
        if self.lanes == 0 || self.lanes > 16 {
            return Err(format!("lanes must be 1–16, got {}", self.lanes));
        }
        if !(self.bin_width >= 1.0 && self.bin_width <= 100.0) {
            return Err(format!(
                "bin_width must be 1–100 nm, got {}",
                self.bin_width
            ));
        }
        Ok(())
    }
}

/// Counters written with every render (`--stats`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Stats {
    /// Pixel samples (camera paths) traced.
    pub paths: u64,
    /// Path contributions that were non-zero (each strategy's connection counts once).
    pub contributing_paths: u64,
    /// Non-zero contributions by number of path segments (index = segments).
    pub contributing_by_length: Vec<u64>,
    /// Rays cast (closest hit and occlusion).
    pub rays: u64,
    /// Samples that would have put a NaN or Inf on the film, and were dropped.
    pub nan_inf_rejected: u64,
    /// bdpt-forward/backward: connections that carried light (f > 0) but whose own strategy's
    /// pdf was NaN, infinite or zero, and were dropped (docs/bdpt.md).
    #[serde(default)]
    pub dropped_strategy_pdfs: u64,
    /// bdpt-combined `--reset-choice adaptive`: the reset each group of pixels chose at the end
    /// of the pilot ("shape: forward"); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reset_choices: Vec<String>,
}

impl Stats {
    pub fn merge(&mut self, o: &Stats) {
        self.paths += o.paths;
        self.contributing_paths += o.contributing_paths;
        self.rays += o.rays;
        self.nan_inf_rejected += o.nan_inf_rejected;
        self.dropped_strategy_pdfs += o.dropped_strategy_pdfs;
        if self.contributing_by_length.len() < o.contributing_by_length.len() {
            self.contributing_by_length
                .resize(o.contributing_by_length.len(), 0);
        }
        for (a, b) in self
            .contributing_by_length
            .iter_mut()
            .zip(&o.contributing_by_length)
        {
            *a += b;
        }
    }

    /// Record one non-zero contribution of a path with `segments` segments.
    #[inline]
    pub fn contribution(&mut self, segments: usize) {
        self.contributing_paths += 1;
        if self.contributing_by_length.len() <= segments {
            self.contributing_by_length.resize(segments + 1, 0);
        }
        self.contributing_by_length[segments] += 1;
    }
}

/// The random stream of one pixel sample: a PCG stream derived from (seed, pixel, sample index),
/// so renders are reproducible whatever the thread count.
#[derive(Clone)]
pub struct Sampler {
    rng: rand_pcg::Pcg32,
}

impl Sampler {
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let state =
            splitmix64(seed ^ splitmix64(pixel ^ splitmix64(sample ^ 0x9E37_79B9_7F4A_7C15)));
        let stream = splitmix64(pixel.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ seed);
        Sampler {
            rng: rand_pcg::Pcg32::new(state, stream),
        }
    }
    /// A seeded stream for tests and tools.
    pub fn from_seed(seed: u64) -> Self {
        Sampler {
            rng: rand_pcg::Pcg32::seed_from_u64(seed),
        }
    }
    /// Uniform in [0, 1).
    #[allow(clippy::should_implement_trait)]
    #[inline]
    pub fn next(&mut self) -> f32 {
        // 24 random bits: exactly representable, never 1.0.
        (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
    #[inline]
    pub fn next2(&mut self) -> [f32; 2] {
        [self.next(), self.next()]
    }
    #[inline]
    pub fn rng(&mut self) -> &mut impl Rng {
        &mut self.rng
    }
}

use rand::RngCore;

#[inline]
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Light-tracing splats of one row of pixel samples, by bands of [`Splats::BAND_ROWS`] film rows,
/// so that the render loop adds the bands to the film in parallel while every pixel still
/// receives its splats in the order they were made.
pub struct Splats {
    pub bands: Vec<Vec<(u32, Vec3)>>,
    band_pixels: u32,
}

impl Splats {
    pub const BAND_ROWS: u32 = 16;

    /// No splats yet, for a film `width` × `height`.
    pub fn new(width: u32, height: u32) -> Self {
        let band_pixels = Self::BAND_ROWS * width;
        let bands = (width * height).div_ceil(band_pixels.max(1)) as usize;
        Splats {
            bands: (0..bands).map(|_| Vec::new()).collect(),
            band_pixels,
        }
    }

    /// No splats, keeping the bands' capacity.
    pub fn clear(&mut self) {
        self.bands.iter_mut().for_each(Vec::clear);
    }

    /// Add `xyz` at pixel index `pixel`.
    #[inline]
    pub fn push(&mut self, pixel: u32, xyz: Vec3) {
        self.bands[(pixel / self.band_pixels) as usize].push((pixel, xyz));
    }
}

/// Receives the contributions of one pixel sample. Non-finite values are counted and dropped.
pub struct SampleSink<'a> {
    /// XYZ accumulated for the sample's own pixel.
    pub value: Vec3,
    pub width: u32,
    pub height: u32,
    pub splats: &'a mut Splats,
    pub aux: &'a mut Vec<(u16, u32, Vec3)>,
    pub stats: &'a mut Stats,
    /// The pixel this sample belongs to (index), for auxiliary layers.
    pub pixel: u32,
    /// The spectral image, when one is made (`--spectral`).
    pub spectral: Option<SpectralSink<'a>>,
}

/// Where one pixel sample's spectral radiance samples go: its own pixel's bins, and light-tracing
/// splats as (pixel, bin, value).
pub struct SpectralSink<'a> {
    pub bins: SpectralBins,
    /// 1 / the bins' width: a sample at λ of value v adds v / Δλ to λ's bin.
    pub inv_width: f32,
    pub own: &'a mut [f64],
    pub splats: &'a mut Vec<(u32, u32, f32)>,
}

impl SampleSink<'_> {
    /// Add XYZ to the sample's pixel.
    #[inline]
    pub fn add(&mut self, xyz: Vec3) -> bool {
        if xyz.is_finite() {
            self.value += xyz;
            true
        } else {
            self.stats.nan_inf_rejected += 1;
            false
        }
    }

    /// The pixel index of film position (x, y), if on the film.
    #[inline]
    fn film_pixel(&self, x: f32, y: f32) -> Option<u32> {
        (x >= 0.0 && y >= 0.0 && x < self.width as f32 && y < self.height as f32)
            .then(|| y as u32 * self.width + x as u32)
    }

    /// Splat XYZ at film position (x, y) in pixels (light tracing). Pixel value = (samples +
    /// splats) / spp, so a splat must be that pixel's estimate for one pixel sample.
    #[inline]
    pub fn splat(&mut self, x: f32, y: f32, xyz: Vec3) -> bool {
        if !xyz.is_finite() {
            self.stats.nan_inf_rejected += 1;
            return false;
        }
        match self.film_pixel(x, y) {
            Some(p) => {
                self.splats.push(p, xyz);
                true
            }
            None => false,
        }
    }

    /// Add the spectral radiance sample `v` at camera wavelength λ to the sample's pixel in the
    /// spectral image (nothing without one). Call it with the values whose XYZ was accepted.
    #[inline]
    pub fn spectral(&mut self, l: f32, v: f32) {
        if let Some(sp) = &mut self.spectral
            && let Some(b) = sp.bins.bin(l)
            && v.is_finite()
        {
            sp.own[b] += (v * sp.inv_width) as f64;
        }
    }

    /// [`SampleSink::spectral`] for a light-tracing splat at film position (x, y).
    #[inline]
    pub fn spectral_splat(&mut self, x: f32, y: f32, l: f32, v: f32) {
        let pixel = self.film_pixel(x, y);
        if let Some(sp) = &mut self.spectral
            && let Some(b) = sp.bins.bin(l)
            && let Some(pixel) = pixel
            && v.is_finite()
        {
            sp.splats.push((pixel, b as u32, v * sp.inv_width));
        }
    }

    /// Add to auxiliary layer `layer` at pixel index `pixel`.
    #[inline]
    pub fn aux(&mut self, layer: usize, pixel: u32, xyz: Vec3) {
        if xyz.is_finite() {
            self.aux.push((layer as u16, pixel, xyz));
        }
    }
}

/// An integrator: turns one pixel sample into contributions.
pub trait Integrator: Sync {
    /// Per-thread scratch memory (path vertex buffers), reused across samples.
    type Scratch: Send;
    fn scratch(&self, scene: &Scene) -> Self::Scratch;
    /// Names of auxiliary layers this integrator writes (e.g. BDPT strategies).
    fn aux_layers(&self) -> Vec<String> {
        Vec::new()
    }
    /// Whether the integrator learns from the passes it renders ([`Integrator::end_pass`]): the
    /// render loop then adds each pass's light-tracing splats to the film before calling it.
    fn adapting(&self) -> bool {
        false
    }
    /// Called after every pass, on the calling thread, with the film and the statistics so far
    /// (an integrator that adapts between passes updates itself here).
    fn end_pass(&self, _film: &crate::film::Film, _stats: &mut Stats) {}
    /// Trace one sample through film position (x, y) (pixels, continuous).
    fn sample(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        scratch: &mut Self::Scratch,
        sink: &mut SampleSink,
    );
}
