//! A diffuse surface whose reradiation is a fitted Gaussian mixture (Hua 2022): the measured
//! reflectance on the diagonal, and the kernel ρ(λi → λo) = S·p(λi, λo) above it (eq. 3),
//! sampled through its truncated conditionals (§6, [`ConditionalMixture`]).
//!
//! Light paths draw λo | λi, camera paths λi | λo; P_l and P_c are the shares of ∫ρ among the
//! total reradiation (Jung eqs. 5.10, 5.12), exactly as for the tabulated matrix, so every
//! integrator renders this material through the same [`Bbrrdf`] interface.

use super::mixture::{ConditionalMixture, GmmFile};
use super::reradiation::{bins_meeting, lerp_on_grid};
use super::{Bbrrdf, BinOperator, PathSide, ShiftDraw, average_fn};
use crate::spectrum::{BinGrid, Domain};

#[derive(Clone, Debug)]
pub struct ReradiationGmm {
    em_lo: f32,
    step: f32,
    reflectance: Vec<f32>,
    domain: Domain,
    cond: ConditionalMixture,
    components: usize,
}

impl ReradiationGmm {
    /// The material of a validated model file ([`GmmFile::parse`]).
    pub fn new(f: &GmmFile, domain: Domain) -> Self {
        ReradiationGmm {
            em_lo: f.grid.em_lo,
            step: f.grid.step,
            reflectance: f.reflectance.clone(),
            domain,
            cond: f.conditional(domain),
            components: f.components.len(),
        }
    }

    /// Number of Gaussians.
    pub fn components(&self) -> usize {
        self.components
    }

    /// Bytes of the model: 1 + 7N numbers (Hua §7.6, f64) plus the reflectance (f32).
    pub fn model_bytes(&self) -> usize {
        (1 + 7 * self.components) * 8 + self.reflectance.len() * 4
    }

    /// Bytes it renders with: the model, each component prepared for both conditionals, and
    /// the two 1-D tables of ∫ρ.
    pub fn render_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.reflectance.len() * 4 + self.cond.heap_bytes()
    }

    #[inline]
    fn axis(side: PathSide) -> usize {
        match side {
            PathSide::Light => 0,
            PathSide::Camera => 1,
        }
    }
}

impl Bbrrdf for ReradiationGmm {
    /// Measured reflectance, linearly interpolated.
    #[inline]
    fn diagonal(&self, l: f32) -> f32 {
        if !self.domain.contains(l) {
            return 0.0;
        }
        let n = self.reflectance.len();
        lerp_on_grid(self.em_lo, self.step, n, |o| self.reflectance[o], l)
    }
    /// S·p(λi, λo) for λo > λi on the measured support inside the domain.
    #[inline]
    fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        self.cond.kernel(l_in as f64, l_out as f64) as f32
    }
    fn is_fluorescent(&self) -> bool {
        !self.cond.is_empty()
    }
    fn fluorescence_probability_light(&self, l_in: f32) -> f32 {
        let f = self.cond.tabulated_total(l_in, 0);
        if f > 0.0 {
            f / (f + self.diagonal(l_in))
        } else {
            0.0
        }
    }
    fn fluorescence_probability_camera(&self, l_out: f32) -> f32 {
        let g = self.cond.tabulated_total(l_out, 1);
        if g > 0.0 {
            g / (g + self.diagonal(l_out))
        } else {
            0.0
        }
    }
    /// The conditional mixture's component by `u[0]`, its truncated normal by `u[1]`; the
    /// density and kernel are those of the wavelength as rounded to f32.
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        match self
            .cond
            .sample(l as f64, Self::axis(side), [u[0] as f64, u[1] as f64])
        {
            Some(d) => ShiftDraw {
                lambda: d.lambda as f32,
                density: d.density as f32,
                kernel: d.kernel as f32,
            },
            None => ShiftDraw {
                lambda: l,
                density: 0.0,
                kernel: 0.0,
            },
        }
    }
    fn shift_density(&self, l: f32, l_new: f32, side: PathSide) -> f32 {
        self.cond.density(l as f64, l_new as f64, Self::axis(side)) as f32
    }
    /// Dense operator: K[o][i] = (1/Δo) ∫_o ∫_i ρ (1 nm midpoint rule between bins); the shift
    /// inside one bin (λo > λi within it) joins that bin's diagonal (0.1 nm rule). Only bins that
    /// meet the kernel's support are integrated (the rest are exactly zero), so the cost does
    /// not grow with the domain outside the measured range.
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator {
        let n = grid.len();
        let cells = |b: usize, h: f32| {
            let (a, z) = (grid.edge(b), grid.edge(b + 1));
            let m = (((z - a) / h).round() as usize).max(1);
            let h = (z - a) / m as f32;
            (0..m).map(move |j| ((a + (j as f32 + 0.5) * h) as f64, h as f64))
        };
        let block = |o: usize, i: usize, h: f32| -> f32 {
            let mut s = 0.0f64;
            for (lo, ho) in cells(o, h) {
                for (li, hi) in cells(i, h) {
                    s += self.cond.kernel(li, lo) * ho * hi;
                }
            }
            (s / grid.bin_width(o) as f64) as f32
        };
        let (ex, em) = if self.cond.is_empty() {
            (0..0, 0..0)
        } else {
            // A hundredth of a nm wider against the rounding of the cells' midpoints.
            let wider = |(a, b): (f64, f64)| (a - 0.01, b + 0.01);
            let (ex, em) = self.cond.support();
            (bins_meeting(grid, wider(ex)), bins_meeting(grid, wider(em)))
        };
        let diag: Vec<f32> = (0..n)
            .map(|b| {
                let shift = if ex.contains(&b) && em.contains(&b) {
                    block(b, b, 0.1)
                } else {
                    0.0
                };
                average_fn(|l| self.diagonal(l), grid.edge(b), grid.edge(b + 1)) + shift
            })
            .collect();
        let mut k = vec![0.0f32; n * n];
        for o in em {
            for i in ex.start..o.min(ex.end) {
                k[o * n + i] = block(o, i, 1.0);
            }
        }
        BinOperator::Dense { diag, n, k }
    }
}
