//! Travel through participating media, for every wavelength lane at once: free-flight sampling
//! along a ray (the hero lane decides, every lane gets its pdf) and spectral transmittance
//! between two vertices through index-matched boundaries.
//!
//! A ray in medium `m` up to the next surface at distance `d` either collides at t < d or
//! passes. With the hero lane h choosing, lane j's throughput is multiplied by f_j / p_h and the
//! per-lane pdf ratio p_k / p_h is returned, so that the integrator can combine the lanes with
//! the HWSS balance heuristic over the lanes' full path pdfs (Mojzík §6.2; docs/design.md §4).

use crate::geometry::Ray;
use crate::geometry::ray::spawn_ray_to;
use crate::medium::{Density, Flight, FreeFlight, Medium, Tracking};
use crate::scene::{NONE, Scene};
use crate::spectrum::Lanes;
use glam::Vec3;

use super::Endpoint;

/// The outcome of free-flight sampling along one stretch of medium.
#[derive(Clone, Copy, Debug)]
pub enum Travel<L> {
    /// A collision at distance `t`: multiply lane j's throughput by `factor` (T_j / p_h, times
    /// the density; the collision coefficient per unit density comes from the vertex).
    Collision { t: f32, factor: L, ratio: L },
    /// No collision before the surface: multiply by `factor` (T_j / P_h); `pass` is each lane's
    /// pass probability, for the MIS weights of next-event estimation.
    Pass { factor: L, ratio: L, pass: L },
}

/// Sample a free flight for lanes `lambda` (the first `n`) along `ray` in `medium` up to the
/// surface at `t_max` (∞ if none); `u` gives uniform numbers.
#[inline]
pub fn travel<L: Lanes>(
    medium: &Medium,
    ray: &Ray,
    t_max: f32,
    lambda: L,
    n: usize,
    mode: Tracking,
    u: &mut impl FnMut() -> f32,
) -> Travel<L> {
    match &medium.density {
        Density::Homogeneous => travel_homogeneous(medium, t_max, lambda, n, mode, u()),
    }
}

/// Homogeneous medium: one analytic free flight (Mojzík eq. 6 and its variants).
#[inline]
fn travel_homogeneous<L: Lanes>(
    medium: &Medium,
    d: f32,
    lambda: L,
    n: usize,
    mode: Tracking,
    u: f32,
) -> Travel<L> {
    if let Some((hat_t, hat_s)) = medium.coefficients.grey {
        // Every lane tracks alike: ratios are 1.
        let one = L::splat_n(n, 1.0);
        let f = FreeFlight::new(mode, hat_t, hat_s);
        return match f.sample(d, u) {
            Flight::Collision { t, pdf } => Travel::Collision {
                t,
                factor: L::splat_n(n, (-hat_t * t).exp() / pdf),
                ratio: one,
            },
            Flight::Pass { prob } => Travel::Pass {
                factor: L::splat_n(n, transmittance(hat_t, d) / prob),
                ratio: one,
                pass: L::splat_n(n, prob),
            },
        };
    }
    let c = medium.coefficients.at(n, lambda);
    let flight = |j: usize| FreeFlight::new(mode, c.hat_t.lane(j), c.hat_s.lane(j));
    match flight(0).sample(d, u) {
        Flight::Collision { t, pdf } => {
            let inv = 1.0 / pdf;
            Travel::Collision {
                t,
                factor: L::from_fn(n, |j| (-c.hat_t.lane(j) * t).exp() * inv),
                ratio: L::from_fn(n, |j| {
                    if j == 0 {
                        1.0
                    } else {
                        flight(j).pdf_collision(t, d) * inv
                    }
                }),
            }
        }
        Flight::Pass { prob } => {
            let pass = L::from_fn(n, |j| if j == 0 { prob } else { flight(j).pdf_pass(d) });
            let inv = 1.0 / prob;
            Travel::Pass {
                factor: L::from_fn(n, |j| transmittance(c.hat_t.lane(j), d) * inv),
                ratio: pass * inv,
                pass,
            }
        }
    }
}

/// e^(−σ·d), 0 for an infinite stretch (nothing comes back from infinity).
#[inline(always)]
fn transmittance(sigma: f32, d: f32) -> f32 {
    if d.is_infinite() {
        0.0
    } else {
        (-sigma * d).exp()
    }
}

/// The transmittance of one stretch of `medium` of length `len` along `ray` at every lane, and
/// the lanes' pass probabilities under free-flight sampling (for MIS).
#[inline]
fn stretch<L: Lanes>(medium: &Medium, len: f32, lambda: L, n: usize, mode: Tracking) -> (L, L) {
    match &medium.density {
        Density::Homogeneous => {
            if let Some((hat_t, hat_s)) = medium.coefficients.grey {
                let pass = FreeFlight::new(mode, hat_t, hat_s).pdf_pass(len);
                return (
                    L::splat_n(n, transmittance(hat_t, len)),
                    L::splat_n(n, pass),
                );
            }
            let c = medium.coefficients.at(n, lambda);
            (
                L::from_fn(n, |j| transmittance(c.hat_t.lane(j), len)),
                L::from_fn(n, |j| {
                    FreeFlight::new(mode, c.hat_t.lane(j), c.hat_s.lane(j)).pdf_pass(len)
                }),
            )
        }
    }
}

/// Transmittance from `a` (in medium `medium`) to `b` at every lane, through index-matched
/// boundaries; `None` when a surface blocks the segment. Also returns the product of the
/// lanes' pass probabilities (the pdf of reaching `b` by free-flight sampling, per lane, for the
/// MIS weights of next-event estimation). Each shadow ray is counted in `rays`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn transmittance_lanes<L: Lanes>(
    scene: &Scene,
    a: Endpoint,
    b: Endpoint,
    mut medium: u32,
    lambda: L,
    n: usize,
    mode: Tracking,
    rays: &mut u64,
) -> Option<(L, L)> {
    let mut tr = L::splat_n(n, 1.0);
    let mut pass = L::splat_n(n, 1.0);
    let mut from = a;
    for _ in 0..MAX_CROSSINGS {
        *rays += 1;
        let (ray, tmax) = spawn_ray_to(from.p, from.n, b.p, b.n);
        let hit = scene.intersect(&ray, tmax);
        let len = hit.map_or(tmax, |h| h.t);
        if let Some(m) = scene.medium(medium) {
            let (t, q) = stretch(m, len, lambda, n, mode);
            tr *= t;
            pass *= q;
        }
        let Some(it) = hit else {
            return Some((tr, pass));
        };
        if it.material != NONE || it.light != NONE {
            return None;
        }
        medium = scene.medium_after(&it, ray.d, medium);
        from = Endpoint { p: it.p, n: it.n };
    }
    None
}

/// The most index-matched boundaries a ray crosses before the path gives up.
pub const MAX_CROSSINGS: usize = 256;

/// A point inside a medium has no surface to offset from.
pub const NO_NORMAL: Vec3 = Vec3::ZERO;
