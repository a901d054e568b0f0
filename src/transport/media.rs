//! Travel through participating media, for every wavelength lane at once: free-flight sampling
//! along a ray (the hero lane decides, every lane gets its pdf) and spectral transmittance
//! between two vertices through index-matched boundaries.
//!
//! A ray in medium `m` up to the next surface at distance `d` either collides at t < d or
//! passes. With the hero lane h choosing, lane j's throughput is multiplied by f_j / p_h and the
//! per-lane pdf ratio p_k / p_h is returned, so that the integrator can combine the lanes with
//! the HWSS balance heuristic over the lanes' full path pdfs (Mojzík §6.2; docs/design.md §4).

use crate::geometry::Ray;
pub use crate::geometry::ray::cross_boundary_ray;
use crate::geometry::ray::spawn_ray_to;
use crate::medium::{Density, Flight, FreeFlight, GridDensity, Medium, Tracking};
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
/// surface at `t_max` (∞ if none), for a camera path (`light` false: σ̂s is the column sum) or a
/// light path (`light` true: the row sum; [`crate::medium::Coefficients::at_side`]); `u` gives
/// uniform numbers.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn travel<L: Lanes>(
    medium: &Medium,
    ray: &Ray,
    t_max: f32,
    lambda: L,
    n: usize,
    mode: Tracking,
    light: bool,
    u: &mut impl FnMut() -> f32,
) -> Travel<L> {
    match &medium.density {
        Density::Homogeneous => travel_homogeneous(medium, t_max, lambda, n, mode, light, u()),
        Density::Grid(g) => travel_grid(medium, g, ray, t_max, lambda, n, mode, light, u),
    }
}

/// The majorant coefficient per unit density of each lane: σ̂t for exponential tracking, the
/// max(σ̂t, σ̂s) hot-fix otherwise (Mojzík §7.5; the aware density has no grid form).
#[inline(always)]
fn majorant_coefficient(mode: Tracking, hat_t: f32, hat_s: f32) -> f32 {
    match mode {
        Tracking::Exponential => hat_t,
        Tracking::Max | Tracking::Aware => hat_t.max(hat_s),
    }
}

/// Grid medium: delta tracking against a majorant from the majorant grid's DDA cells, common to
/// all lanes (the largest lane's), in the null-collision form: at a tentative collision with
/// density ρ each lane has the collision coefficient s_k = σ̂s,k·ρ and the null coefficient
/// n_k = μ − σ̂t,k·ρ ≥ 0; the hero collides with probability s_h / (s_h + n_h). Lane j's
/// factor is its coefficient over the hero's probability of the event (the exponentials cancel
/// because the majorant is common), and the ratios are the lanes' event probabilities over the
/// hero's (Woodcock tracking; Novák et al. 2014 for the null-collision form).
#[allow(clippy::too_many_arguments)]
#[inline]
fn travel_grid<L: Lanes>(
    medium: &Medium,
    g: &GridDensity,
    ray: &Ray,
    t_max: f32,
    lambda: L,
    n: usize,
    mode: Tracking,
    light: bool,
    u: &mut impl FnMut() -> f32,
) -> Travel<L> {
    let c = medium.coefficients.at_side(n, lambda, light);
    let c_max = (0..n)
        .map(|j| majorant_coefficient(mode, c.hat_t.lane(j), c.hat_s.lane(j)))
        .fold(0.0f32, f32::max);
    let one = L::splat_n(n, 1.0);
    let (mut factor, mut ratio) = (one, one);
    let mut collision = None;
    tentative_collisions(g, ray, t_max, c_max, u, |t, rho, mu, u| {
        let s = c.hat_s * rho;
        let null = L::from_fn(n, |j| (mu - c.hat_t.lane(j) * rho).max(0.0));
        let p_collide = L::from_fn(n, |j| {
            let total = s.lane(j) + null.lane(j);
            if total > 0.0 { s.lane(j) / total } else { 0.0 }
        });
        let p_h = p_collide.lane(0);
        if u < p_h {
            factor *= rho / (mu * p_h);
            ratio *= p_collide * (1.0 / p_h);
            collision = Some(t);
            return false;
        }
        let q_h = 1.0 - p_h;
        factor *= null * (1.0 / (mu * q_h));
        ratio *= L::from_fn(n, |j| (1.0 - p_collide.lane(j)) / q_h);
        true
    });
    if let Some(t) = collision {
        return Travel::Collision { t, factor, ratio };
    }
    Travel::Pass {
        factor,
        ratio,
        // Not analytic here: the NEE weights take 1 (any fixed choice keeps them summing to 1).
        pass: one,
    }
}

/// Homogeneous medium: one analytic free flight (Mojzík eq. 6 and its variants).
#[allow(clippy::too_many_arguments)]
#[inline]
fn travel_homogeneous<L: Lanes>(
    medium: &Medium,
    d: f32,
    lambda: L,
    n: usize,
    mode: Tracking,
    light: bool,
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
    let c = medium.coefficients.at_side(n, lambda, light);
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
fn stretch<L: Lanes>(
    medium: &Medium,
    ray: &Ray,
    len: f32,
    lambda: L,
    n: usize,
    mode: Tracking,
    u: &mut impl FnMut() -> f32,
) -> (L, L) {
    match &medium.density {
        Density::Grid(g) => (
            ratio_tracking(medium, g, ray, len, lambda, n, u),
            L::splat_n(n, 1.0),
        ),
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

/// Ratio tracking through a grid for every lane against a common majorant (the largest lane's
/// σ̂t): each tentative collision multiplies lane j by 1 − σ̂t,j·ρ/μ (Novák et al. 2014).
#[inline]
fn ratio_tracking<L: Lanes>(
    medium: &Medium,
    g: &GridDensity,
    ray: &Ray,
    len: f32,
    lambda: L,
    n: usize,
    u: &mut impl FnMut() -> f32,
) -> L {
    let c = medium.coefficients.at(n, lambda);
    let c_max = (0..n).map(|j| c.hat_t.lane(j)).fold(0.0f32, f32::max);
    let mut tr = L::splat_n(n, 1.0);
    tentative_collisions(g, ray, len, c_max, u, |_, rho, mu, _| {
        tr *= L::from_fn(n, |j| 1.0 - c.hat_t.lane(j) * rho / mu);
        tr.max_lane() > 0.0
    });
    tr
}

/// exp(−δ·∫ρ) along `ray` up to `len` for a coefficient `delta` per unit density of either sign,
/// by ratio tracking against the majorant |δ|·ρ_max: each tentative collision multiplies by
/// 1 − δ·ρ/μ ∈ [0, 2] (the estimator is unbiased for any real δ).
#[inline]
pub fn signed_ratio_tracking(
    g: &GridDensity,
    ray: &Ray,
    len: f32,
    delta: f32,
    u: &mut impl FnMut() -> f32,
) -> f32 {
    let mut tr = 1.0f32;
    tentative_collisions(g, ray, len, delta.abs(), u, |_, rho, mu, _| {
        tr *= 1.0 - delta * rho / mu;
        tr != 0.0
    });
    tr
}

/// The tentative collisions of delta and ratio tracking along `ray` up to `t_max` in a grid:
/// exponential steps against the majorant μ = (max density of the DDA cell) × `c_max`; `visit`
/// gets (t, density, μ, a uniform number for its decision) and returns false to stop.
#[inline(always)]
pub fn tentative_collisions(
    g: &GridDensity,
    ray: &Ray,
    t_max: f32,
    c_max: f32,
    u: &mut impl FnMut() -> f32,
    mut visit: impl FnMut(f32, f32, f32, f32) -> bool,
) {
    for (t0, t1, max_density) in g.majorant.segments(ray.o, ray.d, 0.0, t_max) {
        let mu = max_density * g.scale * c_max;
        if !(mu > 0.0) {
            continue;
        }
        let mut t = t0;
        loop {
            t -= (1.0 - u()).ln() / mu;
            if t >= t1 {
                break;
            }
            let rho = g.grid.density(ray.at(t)) * g.scale;
            if !visit(t, rho, mu, u()) {
                return;
            }
        }
    }
}

/// Transmittance from `a` (in medium `medium`) to `b` at every lane, through index-matched
/// boundaries; `None` when a surface blocks the segment. Also returns the product of the
/// lanes' pass probabilities (the pdf of reaching `b` by free-flight sampling, per lane, for the
/// MIS weights of next-event estimation). Each shadow ray is counted in `rays`; with `log`, the
/// stretches of medium crossed are appended to it (for the pdfs of a BDPT connection).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn transmittance_lanes<L: Lanes>(
    scene: &Scene,
    a: Endpoint,
    b: Endpoint,
    medium: u32,
    lambda: L,
    n: usize,
    mode: Tracking,
    rays: &mut u64,
    u: &mut impl FnMut() -> f32,
    mut log: Option<&mut Vec<Stretch>>,
) -> Option<(L, L)> {
    let mut tr = L::splat_n(n, 1.0);
    let mut pass = L::splat_n(n, 1.0);
    let clear = cross_segment(scene, a, b, medium, rays, |id, m, ray, len| {
        let (t, q) = stretch(m, ray, len, lambda, n, mode, u);
        tr *= t;
        pass *= q;
        if let Some(log) = log.as_deref_mut() {
            log.push(Stretch {
                medium: id,
                o: ray.o,
                d: ray.d,
                len,
            });
        }
    });
    clear.then_some((tr, pass))
}

/// Follow the segment from `a` (in medium `medium`) to `b` through index-matched boundaries,
/// calling `stretch(id, medium, ray, len)` for each stretch of medium on the way; false when a
/// surface blocks it. Each ray cast is counted in `rays`.
#[inline]
pub fn cross_segment(
    scene: &Scene,
    a: Endpoint,
    b: Endpoint,
    mut medium: u32,
    rays: &mut u64,
    mut stretch: impl FnMut(u32, &Medium, &Ray, f32),
) -> bool {
    let mut from = a;
    for _ in 0..MAX_CROSSINGS {
        *rays += 1;
        let (ray, tmax) = spawn_ray_to(from.p, from.n, b.p, b.n);
        let hit = scene.intersect(&ray, tmax);
        let len = hit.map_or(tmax, |h| h.t);
        if let Some(m) = scene.medium(medium) {
            stretch(medium, m, &ray, len);
        }
        let Some(it) = hit else {
            return true;
        };
        if it.material != NONE || it.light != NONE {
            return false;
        }
        medium = scene.medium_after(&it, ray.d, medium);
        from = Endpoint { p: it.p, n: it.n };
    }
    false
}

/// The part of a segment inside one medium: it starts at `o` and runs `len` along unit `d`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stretch {
    pub medium: u32,
    pub o: Vec3,
    pub d: Vec3,
    pub len: f32,
}

impl Stretch {
    /// The same stretch walked the other way.
    #[inline]
    pub fn reversed(&self) -> Stretch {
        Stretch {
            medium: self.medium,
            o: self.o + self.d * self.len,
            d: -self.d,
            len: self.len,
        }
    }
}

/// The most index-matched boundaries a ray crosses before the path gives up.
pub const MAX_CROSSINGS: usize = 256;

/// A point inside a medium has no surface to offset from.
pub const NO_NORMAL: Vec3 = Vec3::ZERO;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid::{DensityGrid, ray_marched_transmittance};
    use crate::medium::{Coefficients, Density};
    use crate::spectrum::Spectrum;
    use glam::Vec4;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;

    /// A grid medium whose σ̂t differs per lane; ratio tracking of all four lanes against the
    /// common majorant matches a dense ray-marched reference per lane within 3 standard errors.
    #[test]
    fn lane_ratio_tracking_matches_ray_marching() {
        let grid = DensityGrid::from_fn(
            [12, 10, 8],
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(1.0, 0.8, 1.2),
            |p| (1.0 + (3.0 * p.x).sin() * (2.0 * p.y + p.z).cos()) * 0.5,
        );
        let medium = Medium {
            coefficients: Coefficients::new(
                Spectrum::Tabulated {
                    xs: vec![400.0, 700.0],
                    ys: vec![0.2, 2.0],
                },
                Spectrum::Constant(0.5),
                None,
            ),
            g: 0.0,
            density: Density::Grid(Box::new(GridDensity::new(grid.clone(), 1.5))),
        };
        let Density::Grid(g) = &medium.density else {
            unreachable!()
        };
        let lambda = Vec4::new(410.0, 500.0, 600.0, 690.0);
        let mut rng = Pcg32::seed_from_u64(3);
        for (o, d) in [
            (Vec3::new(-2.0, 0.1, 0.0), Vec3::new(1.0, 0.05, 0.1)),
            (Vec3::new(0.3, -1.5, -0.2), Vec3::new(-0.2, 1.0, 0.3)),
        ] {
            let ray = Ray::new(o, d.normalize());
            let len = 4.0;
            const N: usize = 20_000;
            let (mut sum, mut sq) = (Vec4::ZERO, Vec4::ZERO);
            for _ in 0..N {
                let mut u = || rng.random::<f32>();
                let t: Vec4 = ratio_tracking(&medium, g, &ray, len, lambda, 4, &mut u);
                sum += t;
                sq += t * t;
            }
            let mean = sum / N as f32;
            let se = ((sq / N as f32 - mean * mean) / N as f32)
                .max(Vec4::ZERO)
                .sqrt();
            let c = medium.coefficients.at(4, lambda);
            for j in 0..4 {
                let sigma = c.hat_t.lane(j) * 1.5;
                let want = ray_marched_transmittance(&grid, ray.o, ray.d, 0.0, len, sigma, 20_000);
                let (m, e) = (mean.lane(j), se.lane(j));
                assert!(
                    (m - want).abs() < 3.0 * e + 1e-4,
                    "lane {j}: {m} ± {e} vs {want}"
                );
                assert!(
                    want > 0.01 && want < 0.99,
                    "lane {j}: a trivial case ({want})"
                );
            }
        }
    }
}
