//! The truncated conditional mixtures λo | λi (light paths) and λi | λo (camera paths) of Hua §6,
//! with the corrections of docs/design.md §4:
//! - the conditional weight of component k uses the *known* wavelength: π_k N(λi | μ_ka, σ_kaa)
//!   (eq. 11 writes λo);
//! - the conditional variance is τ_bb⁻¹ = σ_bb − σ_ab²/σ_aa (eq. 12, a variance);
//! - the component is the first whose cumulative weight exceeds the uniform number (Alg. 1
//!   breaks one step early);
//! - the conditional is truncated to the physical side of the diagonal and to the measured
//!   support, and renormalised: each component's weight is multiplied by its mass inside the
//!   interval and the normal is sampled there by its inverse CDF (no rejection loop).
//!
//! The resulting density is exactly ρ(λi → λo) / ∫ρ dλo, so a sampled shift carries the weight
//! ∫ρ dλo of its known wavelength whatever the mixture looks like.

use super::Component;
use crate::spectrum::gaussian::{interval_mass, sample_truncated, std_pdf};

/// Largest number of components a model may have (the samplers keep weights on the stack).
pub const MAX_COMPONENTS: usize = 32;

/// One component, prepared for evaluation and for conditioning on either axis.
#[derive(Clone, Copy, Debug)]
struct Prepared {
    weight: f64,
    mean: [f64; 2],
    /// Marginal standard deviations √σaa, √σbb.
    sd: [f64; 2],
    /// Regression slopes σab/σaa (λo on λi) and σab/σbb (λi on λo).
    slope: [f64; 2],
    /// Conditional standard deviations √(|Σ|/σaa) (λo | λi) and √(|Σ|/σbb) (λi | λo).
    sd_given: [f64; 2],
    /// Σ⁻¹ as (τaa, τab, τbb) and 1 / (2π √|Σ|).
    inv: [f64; 3],
    norm: f64,
}

/// The conditional mixture given one wavelength, ready to draw from.
#[derive(Clone, Copy, Debug)]
struct Slice {
    /// Per component: (weight, conditional mean, conditional standard deviation).
    parts: [(f64, f64, f64); MAX_COMPONENTS],
    /// ∫ρ over the interval (S times the sum of the weights).
    total: f64,
    interval: (f64, f64),
}

/// A new wavelength drawn from a conditional, with its density per nm and the kernel value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditionalDraw {
    pub lambda: f64,
    pub density: f64,
    pub kernel: f64,
}

/// The kernel ρ(λi → λo) = S·p(λi, λo) on λo > λi inside the support, and its conditionals.
#[derive(Clone, Debug)]
pub struct ConditionalMixture {
    comps: Vec<Prepared>,
    scale: f64,
    /// Support of λi and of λo.
    ex: (f64, f64),
    em: (f64, f64),
    /// ∫ρ dλo at 1 nm steps of λi from `ex.0`, and ∫ρ dλi at 1 nm steps of λo from `em.0`
    /// (Hua §6.3's two 1-D arrays): the fluorescence probabilities P_l and P_c interpolate
    /// them, which spares the K normal masses per vertex.
    tables: [Vec<f32>; 2],
}

impl ConditionalMixture {
    /// `components` must be valid ([`Component::is_valid`]) and at most [`MAX_COMPONENTS`].
    pub fn new(components: &[Component], scale: f64, ex: (f64, f64), em: (f64, f64)) -> Self {
        assert!(components.len() <= MAX_COMPONENTS);
        let comps = components
            .iter()
            .map(|c| {
                let det = c.det();
                let (saa, sab, sbb) = (c.cov[0][0], c.cov[0][1], c.cov[1][1]);
                Prepared {
                    weight: c.weight,
                    mean: c.mean,
                    sd: [saa.sqrt(), sbb.sqrt()],
                    slope: [sab / saa, sab / sbb],
                    sd_given: [(det / saa).sqrt(), (det / sbb).sqrt()],
                    inv: [sbb / det, -sab / det, saa / det],
                    norm: 1.0 / (2.0 * std::f64::consts::PI * det.sqrt()),
                }
            })
            .collect();
        let mut m = ConditionalMixture {
            comps,
            scale,
            ex,
            em,
            tables: [vec![], vec![]],
        };
        for axis in 0..2 {
            let (a, b) = if axis == 0 { ex } else { em };
            if a < b && !m.comps.is_empty() {
                let n = (b - a).ceil() as usize + 1;
                m.tables[axis] = (0..n)
                    .map(|j| m.total((a + j as f64).min(b), axis) as f32)
                    .collect();
            }
        }
        m
    }

    /// ∫ρ given `known` on `axis`, linearly interpolated between 1 nm knots: positive wherever
    /// the exact total is, zero off the support.
    #[inline]
    pub fn tabulated_total(&self, known: f32, axis: usize) -> f32 {
        let t = &self.tables[axis];
        let (a, b) = if axis == 0 { self.ex } else { self.em };
        let x = known as f64;
        if t.is_empty() || !(x >= a && x <= b) {
            return 0.0;
        }
        let f = (x - a) as f32;
        let j = (f as usize).min(t.len() - 2);
        let w = f - j as f32;
        t[j] * (1.0 - w) + t[j + 1] * w
    }

    /// Heap bytes: prepared components and tables.
    pub fn heap_bytes(&self) -> usize {
        self.comps.len() * std::mem::size_of::<Prepared>()
            + (self.tables[0].len() + self.tables[1].len()) * 4
    }

    /// The closed intervals of λi and of λo outside which the kernel is zero.
    pub fn support(&self) -> ((f64, f64), (f64, f64)) {
        (self.ex, self.em)
    }

    /// Whether the kernel is zero everywhere.
    pub fn is_empty(&self) -> bool {
        self.comps.is_empty() || self.scale <= 0.0 || self.ex.0 >= self.ex.1
    }

    /// ρ(λi → λo) per nm (Hua eq. 3), zero off the support and for λo ≤ λi.
    #[inline]
    pub fn kernel(&self, li: f64, lo: f64) -> f64 {
        if !(lo > li && self.inside(li, lo)) {
            return 0.0;
        }
        self.scale
            * self
                .comps
                .iter()
                .map(|c| {
                    let (dx, dy) = (li - c.mean[0], lo - c.mean[1]);
                    let q = c.inv[0] * dx * dx + 2.0 * c.inv[1] * dx * dy + c.inv[2] * dy * dy;
                    c.weight * c.norm * (-0.5 * q).exp()
                })
                .sum::<f64>()
    }

    #[inline]
    fn inside(&self, li: f64, lo: f64) -> bool {
        li >= self.ex.0 && li <= self.ex.1 && lo >= self.em.0 && lo <= self.em.1
    }

    /// The interval of the unknown wavelength given the known one: λo ∈ (λi, em] given λi
    /// (`axis` 0 known), λi ∈ [ex, λo) given λo (`axis` 1 known).
    #[inline]
    fn interval(&self, known: f64, axis: usize) -> (f64, f64) {
        if axis == 0 {
            (known.max(self.em.0), self.em.1)
        } else {
            (self.ex.0, known.min(self.ex.1))
        }
    }

    /// The conditional given `known` on `axis`: per component the weight π_k N(known |
    /// marginal) times its conditional's mass inside the interval (eq. 11 corrected and
    /// renormalised), the conditional mean (eq. 9) and standard deviation (eq. 12).
    #[inline]
    fn slice(&self, known: f64, axis: usize) -> Slice {
        let (a, b) = self.interval(known, axis);
        let mut s = Slice {
            parts: [(0.0, 0.0, 0.0); MAX_COMPONENTS],
            total: 0.0,
            interval: (a, b),
        };
        let known_ok = if axis == 0 {
            known >= self.ex.0 && known <= self.ex.1
        } else {
            known >= self.em.0 && known <= self.em.1
        };
        if !known_ok || a >= b {
            return s;
        }
        let other = 1 - axis;
        for (c, o) in self.comps.iter().zip(s.parts.iter_mut()) {
            let z = (known - c.mean[axis]) / c.sd[axis];
            let marginal = c.weight * std_pdf(z) / c.sd[axis];
            let mean = c.mean[other] + c.slope[axis] * (known - c.mean[axis]);
            let sd = c.sd_given[axis];
            let w = marginal * interval_mass(mean, sd, a, b);
            s.total += w;
            *o = (w, mean, sd);
        }
        s.total *= self.scale;
        s
    }

    /// ∫ρ dλo given λi (`axis` 0) or ∫ρ dλi given λo (`axis` 1).
    #[inline]
    pub fn total(&self, known: f64, axis: usize) -> f64 {
        self.slice(known, axis).total
    }

    /// The unknown wavelength drawn from a slice: the component by `u[0]` (the first whose
    /// cumulative weight exceeds it), then its truncated normal by `u[1]`; `None` when the
    /// slice is empty.
    #[inline]
    fn draw(&self, s: &Slice, u: [f64; 2]) -> Option<f64> {
        if !(s.total > 0.0) {
            return None;
        }
        let n = self.comps.len();
        let target = u[0] * s.total / self.scale;
        let mut acc = 0.0;
        let mut k = n - 1;
        for (j, (w, _, _)) in s.parts[..n].iter().enumerate() {
            acc += w;
            if acc > target && *w > 0.0 {
                k = j;
                break;
            }
        }
        while s.parts[k].0 <= 0.0 && k > 0 {
            k -= 1; // u[0] rounded past the last non-empty component
        }
        let (_, mean, sd) = s.parts[k];
        Some(sample_truncated(mean, sd, s.interval.0, s.interval.1, u[1]))
    }

    /// Draw the unknown wavelength given the known one on `axis` (0: λi known, draw λo; 1: λo
    /// known, draw λi), rounded to f32 as the renderer carries it, with the density and kernel
    /// of that rounded wavelength.
    pub fn sample(&self, known: f64, axis: usize, u: [f64; 2]) -> Option<ConditionalDraw> {
        self.sample_and_total(known, axis, u).1
    }

    /// [`ConditionalMixture::sample`] and [`ConditionalMixture::total`] from one slice: the
    /// total (zero where the conditional is empty) and the draw.
    pub fn sample_and_total(
        &self,
        known: f64,
        axis: usize,
        u: [f64; 2],
    ) -> (f64, Option<ConditionalDraw>) {
        let s = self.slice(known, axis);
        (s.total, self.draw_from(&s, known, axis, u))
    }

    fn draw_from(
        &self,
        s: &Slice,
        known: f64,
        axis: usize,
        u: [f64; 2],
    ) -> Option<ConditionalDraw> {
        let lambda = self.draw(s, u)? as f32 as f64;
        let (li, lo) = if axis == 0 {
            (known, lambda)
        } else {
            (lambda, known)
        };
        let kernel = self.kernel(li, lo);
        Some(ConditionalDraw {
            lambda,
            density: kernel / s.total,
            kernel,
        })
    }

    /// Density per nm of [`ConditionalMixture::sample`] drawing `new` given `known` on `axis`.
    pub fn density(&self, known: f64, new: f64, axis: usize) -> f64 {
        let (li, lo) = if axis == 0 {
            (known, new)
        } else {
            (new, known)
        };
        let k = self.kernel(li, lo);
        if k <= 0.0 {
            return 0.0;
        }
        k / self.total(known, axis)
    }

    /// ∬ S·p over the support above the diagonal: with S = 1, the denominator of Hua eq. 5.
    pub fn mass(&self) -> f64 {
        let (a, b) = self.ex;
        if a >= b || self.comps.is_empty() {
            return 0.0;
        }
        // Midpoint rule in λi over steps of at most 0.1 nm (the integrand is smooth).
        let n = ((b - a) / 0.1).ceil().max(1.0) as usize;
        let h = (b - a) / n as f64;
        (0..n)
            .map(|j| self.slice(a + (j as f64 + 0.5) * h, 0).total * h)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::mixture::mixture_density;
    use rand::{Rng, SeedableRng};

    fn model() -> ConditionalMixture {
        let c = |w, m: [f64; 2], a: f64, b: f64, r: f64| Component {
            weight: w,
            mean: m,
            cov: [[a, r * (a * b).sqrt()], [r * (a * b).sqrt(), b]],
        };
        ConditionalMixture::new(
            &[
                c(0.5, [360.0, 450.0], 400.0, 600.0, 0.3),
                c(0.3, [420.0, 520.0], 900.0, 300.0, -0.4),
                c(0.2, [600.0, 640.0], 200.0, 150.0, 0.8),
            ],
            37.0,
            (295.0, 785.0),
            (375.0, 780.0),
        )
    }

    /// The known wavelengths of the tests: in the bulk, near the truncation edges, and where
    /// almost no mass is left on the allowed side.
    const CASES: [(f64, usize); 8] = [
        (360.0, 0),
        (450.0, 0),
        (690.0, 0),
        (770.0, 0),
        (520.0, 1),
        (390.0, 1),
        (379.0, 1),
        (700.0, 1),
    ];

    #[test]
    fn conditional_density_integrates_to_one() {
        let m = model();
        for (known, axis) in CASES {
            let (a, b) = m.interval(known, axis);
            let n = 200_000;
            let h = (b - a) / n as f64;
            let s: f64 = (0..n)
                .map(|j| m.density(known, a + (j as f64 + 0.5) * h, axis) * h)
                .sum();
            assert!((s - 1.0).abs() < 1e-6, "{known} {axis}: ∫ = {s}");
        }
    }

    /// χ² (20 equal cells, 99.9 %) of 200 000 draws against the density, and every draw reports
    /// the density and kernel of its own wavelength.
    #[test]
    fn conditional_sampler_matches_its_density() {
        let m = model();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        for (known, axis) in CASES {
            let (a, b) = m.interval(known, axis);
            let n = 200_000;
            let mut hist = [0u32; 20];
            for _ in 0..n {
                let d = m.sample(known, axis, [rng.random(), rng.random()]).unwrap();
                assert!(d.lambda >= a && d.lambda <= b, "{d:?}");
                let (li, lo) = if axis == 0 {
                    (known, d.lambda)
                } else {
                    (d.lambda, known)
                };
                assert_eq!(d.kernel, m.kernel(li, lo));
                let want = m.density(known, d.lambda, axis);
                assert!((d.density - want).abs() <= 1e-12 * want, "{d:?} vs {want}");
                hist[(((d.lambda - a) / (b - a) * 20.0) as usize).min(19)] += 1;
            }
            let chi2: f64 = hist
                .iter()
                .enumerate()
                .map(|(c, &h)| {
                    let (x0, x1) = (
                        a + (b - a) * c as f64 / 20.0,
                        a + (b - a) * (c + 1) as f64 / 20.0,
                    );
                    let k = 2000;
                    let p: f64 = (0..k)
                        .map(|j| {
                            m.density(known, x0 + (x1 - x0) * (j as f64 + 0.5) / k as f64, axis)
                        })
                        .sum::<f64>()
                        * (x1 - x0)
                        / k as f64;
                    let e = p * n as f64;
                    (h as f64 - e).powi(2) / e.max(1e-9)
                })
                .sum();
            assert!(chi2 < 43.82, "{known} {axis}: χ² = {chi2}, {hist:?}");
        }
    }

    /// The mass above the diagonal matches a brute-force 2-D sum of the mixture, and ∫ρ over
    /// a column times the column's width sums back to S times that mass.
    #[test]
    fn mass_matches_brute_force() {
        let m = model();
        let comps: Vec<Component> = (0..3)
            .map(|k| {
                let c = m.comps[k];
                let sab = c.slope[0] * c.sd[0] * c.sd[0];
                Component {
                    weight: c.weight,
                    mean: c.mean,
                    cov: [[c.sd[0] * c.sd[0], sab], [sab, c.sd[1] * c.sd[1]]],
                }
            })
            .collect();
        let h = 0.25;
        let mut brute = 0.0;
        let mut li = m.ex.0 + 0.5 * h;
        while li < m.ex.1 {
            let mut lo = m.em.0 + 0.5 * h;
            while lo < m.em.1 {
                if lo > li {
                    brute += mixture_density(&comps, [li, lo]) * h * h;
                }
                lo += h;
            }
            li += h;
        }
        let mass = m.mass() / m.scale;
        assert!((mass - brute).abs() < 2e-3 * brute, "{mass} vs {brute}");
        assert!((0.0..1.0).contains(&mass));
    }

    #[test]
    fn outside_the_support_nothing_is_sampled() {
        let m = model();
        assert_eq!(m.total(290.0, 0), 0.0);
        assert_eq!(m.total(790.0, 0), 0.0);
        assert_eq!(m.total(370.0, 1), 0.0);
        assert!(m.sample(290.0, 0, [0.5, 0.5]).is_none());
        assert_eq!(m.kernel(500.0, 450.0), 0.0);
        assert_eq!(m.density(500.0, 450.0, 0), 0.0);
        // u[0] at the top of its range still finds a component.
        assert!(m.sample(450.0, 0, [1.0 - 1e-16, 0.3]).is_some());
    }
}
