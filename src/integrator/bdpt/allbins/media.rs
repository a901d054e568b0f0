//! Participating media in `bdpt-allbins`: free flights that do not depend on wavelength, the
//! per-bin free-flight weight of every segment, per-bin transmittance of connections, and the
//! medium's collision coefficient as a bin operator.
//!
//! All-bins sub-paths carry no wavelength, so free flights are sampled by a density that does
//! not depend on it. In homogeneous media that is the even mixture of exponentials at the
//! smallest σ̂t of the bins and at c, the largest σ̂t, camera-side σ̂s and light-side σ̂s over the
//! domain ([`MixtureFlight`]): every bin's collisions are sampled, and each bin's weight
//! T_b/p stays bounded (a single rate c would weigh a nearly clear bin by e^((c − σ̂t,b)·d) when
//! passing, and render chromatic media such as the teaser's UV absorber with enormous
//! variance). In grids delta tracking uses the majorant c·ρ_max with the null-collision weights
//! (μ − σ̂t,b·ρ)/(μ − c·ρ) (Kutz et al. 2017, spectral tracking with a grey majorant). σ̂t,b is the bin average of σ̂t, as every bin operator uses
//! bin averages. The bin operator of a collision is σs on the diagonal plus c·a ⊗ Φ·e (rank
//! one), per unit density, applied in O(bins).

use super::binops::SupportedOp;
use crate::geometry::Ray;
use crate::material::Bbrrdf;
use crate::medium::{Density, Medium, MixtureFlight};
use crate::scene::Scene;
use crate::spectrum::BinGrid;
use crate::transport::media::{cross_segment, tentative_collisions};
use crate::transport::{Endpoint, Stretch};

/// Per-medium tables of the all-bins evaluator.
pub struct BinMedia {
    /// The tracking rate c of each medium (the grid majorant's coefficient).
    pub rate: Vec<f32>,
    /// The free-flight density of each homogeneous medium.
    pub flight: Vec<MixtureFlight>,
    /// σ̂t per bin of each medium.
    hat_t: Vec<Vec<f32>>,
    /// σ̂t of each medium whose σ̂t is the same in every bin (one exponential per segment).
    grey: Vec<Option<f32>>,
    /// The collision operator of each medium per unit density (light direction).
    pub ops: Vec<SupportedOp>,
}

impl BinMedia {
    pub fn new(scene: &Scene, grid: &BinGrid) -> Self {
        let n = grid.len();
        let mut rate = Vec::new();
        let mut flight = Vec::new();
        let mut hat_t: Vec<Vec<f32>> = Vec::new();
        let mut ops = Vec::new();
        for m in &scene.media {
            let c = &m.coefficients;
            rate.push(c.majorant_over(scene.domain));
            hat_t.push(
                (0..n)
                    .map(|b| {
                        let (lo, hi) = (grid.edge(b), grid.edge(b + 1));
                        crate::material::average_fn(|l| c.at(1, l).hat_t, lo, hi)
                    })
                    .collect(),
            );
            ops.push(SupportedOp::new(c.bin_operator(grid)));
            let lo = hat_t
                .last()
                .unwrap()
                .iter()
                .copied()
                .fold(f32::INFINITY, f32::min);
            flight.push(MixtureFlight::new(lo, *rate.last().unwrap()));
        }
        let grey = hat_t
            .iter()
            .map(|h: &Vec<f32>| h.iter().all(|&x| x == h[0]).then(|| h[0]))
            .collect();
        BinMedia {
            rate,
            flight,
            hat_t,
            grey,
            ops,
        }
    }

    /// Sample a free flight in medium `id` along `ray` up to `t_max`; multiplies each bin of `w`
    /// by its weight. `Some(t)` for a collision.
    #[inline]
    pub fn travel(
        &self,
        id: u32,
        medium: &Medium,
        ray: &Ray,
        t_max: f32,
        w: &mut [f32],
        u: &mut impl FnMut() -> f32,
    ) -> Option<f32> {
        let c = self.rate[id as usize];
        let hat_t = &self.hat_t[id as usize];
        match &medium.density {
            Density::Homogeneous => {
                let f = self.flight[id as usize];
                let t = f.sample([u(), u()]);
                let (d, p) = if t < t_max {
                    (t, f.pdf_collision(t))
                } else {
                    (t_max, f.pdf_pass(t_max))
                };
                let inv = 1.0 / p;
                match self.grey[id as usize] {
                    Some(s) => {
                        let x = (-s * d).exp() * inv;
                        w.iter_mut().for_each(|v| *v *= x);
                    }
                    None => {
                        for (v, s) in w.iter_mut().zip(hat_t) {
                            *v *= (-s * d).exp() * inv;
                        }
                    }
                }
                (t < t_max).then_some(t)
            }
            Density::Grid(g) => {
                let mut collision = None;
                tentative_collisions(g, ray, t_max, c, u, |t, rho, mu, u| {
                    if u * mu < c * rho {
                        for x in w.iter_mut() {
                            *x /= c;
                        }
                        collision = Some(t);
                        return false;
                    }
                    let q = 1.0 / (mu - c * rho);
                    for (x, s) in w.iter_mut().zip(hat_t) {
                        *x *= (mu - s * rho) * q;
                    }
                    true
                });
                collision
            }
        }
    }

    /// The per-bin transmittance from `a` (in medium `medium`) to `b` into `out`, through
    /// index-matched boundaries (false: blocked), appending the stretches to `log`: exact in
    /// homogeneous media, ratio tracking against c·ρ_max in grids.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn transmittance(
        &self,
        scene: &Scene,
        a: Endpoint,
        b: Endpoint,
        medium: u32,
        out: &mut [f32],
        log: &mut Vec<Stretch>,
        rays: &mut u64,
        u: &mut impl FnMut() -> f32,
    ) -> bool {
        out.fill(1.0);
        cross_segment(scene, a, b, medium, rays, |id, m, ray, len| {
            log.push(Stretch {
                medium: id,
                o: ray.o,
                d: ray.d,
                len,
            });
            let hat_t = &self.hat_t[id as usize];
            match &m.density {
                Density::Homogeneous => match self.grey[id as usize] {
                    Some(s) => {
                        let f = (-s * len).exp();
                        out.iter_mut().for_each(|x| *x *= f);
                    }
                    None => {
                        for (x, s) in out.iter_mut().zip(hat_t) {
                            *x *= (-s * len).exp();
                        }
                    }
                },
                Density::Grid(g) => {
                    let c = self.rate[id as usize];
                    tentative_collisions(g, ray, len, c, u, |_, rho, mu, _| {
                        for (x, s) in out.iter_mut().zip(hat_t) {
                            *x *= 1.0 - s * rho / mu;
                        }
                        true
                    });
                }
            }
        })
    }
}
