//! `--reset-choice adaptive`: bdpt-combined with one reset per sample, chosen per pixel from a
//! pilot (docs/bdpt.md, "bdpt-combined", adaptive choice).
//!
//! The resets are two sampling techniques of one estimator; a pixel sample takes reset r with
//! probability c_r(p), a function of the pixel p the path reaches the film at, and weighs every
//! technique (ŝ, r) by its expected count per pixel sample (Veach's one-sample model: the
//! balance heuristic over c_r · p_{ŝ,r}). Here c is 0 or 1: each pixel takes the one reset that
//! is cheaper for its error. The first [`PILOT_PASSES`] passes of a render take the forward and
//! the backward reset in turn on every pixel (each pass is bdpt-forward's or bdpt-backward's
//! estimate, with its weights); from their samples each group of pixels (those that see the same
//! shape through their centres) gets the reset with the lower variance × cost, and keeps it for
//! the rest of the render. The choice depends only on the pilot's samples, never on the samples
//! it is used for, so every pass stays unbiased.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};
use std::sync::{Mutex, OnceLock};

use super::ResetMode;
use crate::film::Film;
use crate::integrator::Stats;
use crate::scene::Scene;

/// Passes of the pilot: forward on the even ones, backward on the odd ones.
pub const PILOT_PASSES: u32 = 8;

/// The pilot's sums per pixel and reset (forward, backward): Σ Y and Σ Y² of the pixel's
/// luminance estimate of one pass (its own sample and the light-tracing splats that landed on
/// it), and the pixel's value before the current pass.
#[derive(Clone, Copy, Default)]
struct PixelSums {
    y: [f64; 2],
    y2: [f64; 2],
    last: f64,
}

/// The adaptive choice's state: the pixels' groups, the pilot's sums and, after the pilot, the
/// reset of each group.
pub struct Adaptive {
    /// Per pixel: its group (the shape its centre's primary ray sees first; `names.len() - 1`:
    /// nothing).
    group: Vec<u32>,
    /// The groups' names (the shapes', then "nothing").
    names: Vec<String>,
    /// Passes this render has finished.
    passes: AtomicU32,
    /// Per pixel: the rays its pilot samples cast, per reset (f64 bits). A pixel's sample runs
    /// on one thread in a pass and passes are ordered, so plain loads and stores suffice.
    rays: Vec<[AtomicU64; 2]>,
    sums: Mutex<Vec<PixelSums>>,
    /// Per group, the reset chosen at the end of the pilot.
    choice: OnceLock<Vec<ResetMode>>,
}

impl Adaptive {
    pub fn new(scene: &Scene) -> Adaptive {
        let (w, h) = (scene.camera.width, scene.camera.height);
        let nothing = scene.shapes.len() as u32;
        // (one primary ray a pixel, on this thread: 65 536 rays at 256², a few milliseconds)
        let group: Vec<u32> = (0..w * h)
            .map(|p| {
                let (x, y) = ((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
                let ray = scene.camera.generate_ray(x, y);
                scene
                    .first_visible(&ray)
                    .map(|hit| scene.prims[hit.prim as usize].shape)
                    .filter(|&s| s < nothing)
                    .unwrap_or(nothing)
            })
            .collect();
        let mut names: Vec<String> = scene.shapes.iter().map(|s| s.name.clone()).collect();
        names.push("nothing".into());
        Adaptive {
            rays: (0..group.len()).map(|_| Default::default()).collect(),
            sums: Mutex::new(vec![PixelSums::default(); group.len()]),
            group,
            names,
            passes: AtomicU32::new(0),
            choice: OnceLock::new(),
        }
    }

    /// The reset of a sample at `pixel` in the current pass (a pixel off the film, which no
    /// caller passes, takes the group of those that see nothing).
    #[inline]
    pub fn reset(&self, pixel: u32) -> ResetMode {
        match self.choice.get() {
            Some(c) => {
                let nothing = self.names.len() as u32 - 1;
                c[self.group.get(pixel as usize).copied().unwrap_or(nothing) as usize]
            }
            None if self.passes.load(Relaxed).is_multiple_of(2) => ResetMode::Forward,
            None => ResetMode::Backward,
        }
    }

    /// The reset of the pixel at film position (x, y) of a film `width` pixels wide in the
    /// current pass; `None` off the film.
    #[inline]
    pub fn reset_at(&self, (x, y): (f32, f32), width: u32) -> Option<ResetMode> {
        let on = x >= 0.0 && y >= 0.0 && x < width as f32;
        let pixel = y as u32 * width + x as u32;
        (on && (pixel as usize) < self.group.len()).then(|| self.reset(pixel))
    }

    /// Whether the current pass belongs to the pilot.
    #[inline]
    pub fn in_pilot(&self) -> bool {
        self.choice.get().is_none()
    }

    /// Add the rays of one pilot sample at `pixel`, made by reset `mode`.
    pub fn record(&self, pixel: u32, mode: ResetMode, rays: u64) {
        if let Some(r) = self.rays.get(pixel as usize) {
            let a = &r[mode as usize];
            a.store(
                (f64::from_bits(a.load(Relaxed)) + rays as f64).to_bits(),
                Relaxed,
            );
        }
    }

    /// After each pilot pass: add its pixel values (the film's change) to the sums; at the end
    /// of the pilot, choose each group's reset and write the choice into `stats`.
    pub fn end_pass(&self, film: &Film, stats: &mut Stats) {
        let pass = self.passes.fetch_add(1, Relaxed);
        let r = (pass % 2) as usize;
        let mut sums = self.sums.lock().unwrap_or_else(|e| e.into_inner());
        for ((s, a), b) in sums.iter_mut().zip(&film.sum).zip(&film.splat) {
            let now = a[1] + b[1];
            let y = now - s.last;
            s.last = now;
            s.y[r] += y;
            s.y2[r] += y * y;
        }
        if pass + 1 != PILOT_PASSES {
            return;
        }
        let choice = self.decide(&sums);
        stats.reset_choices = (self.names.iter().zip(&choice))
            .filter_map(|(n, c)| c.map(|c| format!("{n}: {}", c.name())))
            .collect();
        let all = choice
            .into_iter()
            .map(|c| c.unwrap_or(ResetMode::Forward))
            .collect();
        let _ = self.choice.set(all);
    }

    /// Each group's reset (`None` for groups without pixels): the one with the lower variance
    /// of a pixel's pass times its cost in rays, both summed over the group's pixels. The
    /// squared mean a variance subtracts is estimated without bias by the product of the two
    /// resets' independent means.
    fn decide(&self, sums: &[PixelSums]) -> Vec<Option<ResetMode>> {
        let n = self.names.len();
        // per group: Σ_p M_F, Σ_p M_B, Σ_p μ², rays F, rays B, pixels
        let mut g = vec![[0.0f64; 6]; n];
        let (nf, nb) = (PILOT_PASSES.div_ceil(2) as f64, (PILOT_PASSES / 2) as f64);
        for ((s, rays), &k) in sums.iter().zip(&self.rays).zip(&self.group) {
            let rays = rays.each_ref().map(|a| f64::from_bits(a.load(Relaxed)));
            let acc = &mut g[k as usize];
            acc[0] += s.y2[0] / nf;
            acc[1] += s.y2[1] / nb;
            acc[2] += (s.y[0] / nf) * (s.y[1] / nb);
            acc[3] += rays[0];
            acc[4] += rays[1];
            acc[5] += 1.0;
        }
        g.iter()
            .map(|a| {
                if a[5] == 0.0 {
                    return None;
                }
                // variance (never below 0, plus a floor so that equal variances compare costs)
                let var = |m: f64| (m - a[2]).max(0.0) + 1e-30;
                let (cost_f, cost_b) = (a[3] / nf + 1.0, a[4] / nb + 1.0);
                Some(if var(a[1]) * cost_b < var(a[0]) * cost_f {
                    ResetMode::Backward
                } else {
                    ResetMode::Forward
                })
            })
            .collect()
    }
}
