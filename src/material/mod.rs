//! Spectral materials behind one BBRRDF interface (docs/design.md §3.1).
//!
//! A material's reflectance is split into a wavelength-preserving part (the diagonal of the
//! reradiation matrix, a δ(λin − λout) term) and a wavelength-shifting kernel ρ(λin → λout)
//! per nm. The directional part is a separate lobe, so a path's geometry never depends on its
//! wavelengths (`transport::Scattering`). Every model here is diffuse.
//!
//! Sampling is one-shot: [`Material::sample`] makes Jung's two-step choice (fluorescent or not,
//! then the new wavelength) and returns the wavelength, its pdf and the spectral value together;
//! [`Material::pdf`] and [`Material::eval`] match it.

pub mod bfc;
pub mod binop;
pub mod fluorescent;
pub mod lambert;
pub mod mixture;
pub mod reradiation;
pub mod reradiation_gmm;

pub use binop::BinOperator;
pub use fluorescent::FluorescentDiffuse;
pub use lambert::Lambert;
pub use reradiation::{MixtureSampler, Reradiation};
pub use reradiation_gmm::ReradiationGmm;

use crate::spectrum::{BinGrid, Domain, Lanes};

named_enum! {
    /// How the new wavelength is chosen at a fluorescent vertex (Jung 7.1.2).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
    pub enum WavelengthSampling {
        /// Emission spectrum on light paths, absorption spectrum on camera paths (Jung 5.3.2).
        #[default]
        Importance = "importance",
        /// Uniform over the wavelength domain.
        Uniform = "uniform",
    }
}

/// Which sub-path arrives at a vertex (Jung 5.3). A camera path knows the exitant wavelength
/// λout and samples the incident λin; a light path knows λin and samples λout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathSide {
    Camera,
    Light,
}

/// How an integrator chooses new wavelengths: the option and the domain that `uniform` covers.
/// The uniform mode is implemented here, once, for every material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftSampling {
    pub mode: WavelengthSampling,
    pub domain: Domain,
}

impl ShiftSampling {
    pub fn new(mode: WavelengthSampling, domain: Domain) -> Self {
        ShiftSampling { mode, domain }
    }
}

/// A material's own importance sample of the new wavelength of a fluorescent interaction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftDraw {
    /// The new wavelength (λout on a light path, λin on a camera path).
    pub lambda: f32,
    /// Its density per nm, given that a shift happens.
    pub density: f32,
    /// The kernel ρ(λin → λout) of the pair.
    pub kernel: f32,
}

impl ShiftDraw {
    /// Jung 5.3.2's importance sampling of a rank-one kernel k(λin → λout) ∝ a(λin)·e(λout):
    /// the emitted wavelength from `e_dist` on light paths, the absorbed one from `a_dist` on
    /// camera paths, given the known wavelength `l`; `kernel` evaluates k for the pair.
    #[inline]
    pub fn rank_one(
        a_dist: &crate::spectrum::Distribution1D,
        e_dist: &crate::spectrum::Distribution1D,
        kernel: impl Fn(f32, f32) -> f32,
        l: f32,
        u: f32,
        side: PathSide,
    ) -> ShiftDraw {
        let (lambda, density) = match side {
            PathSide::Light => e_dist.sample(u),
            PathSide::Camera => a_dist.sample(u),
        };
        let kernel = match side {
            PathSide::Light => kernel(l, lambda),
            PathSide::Camera => kernel(lambda, l),
        };
        ShiftDraw {
            lambda,
            density,
            kernel,
        }
    }
}

/// A wavelength chosen at a vertex by the two-step choice of Jung 5.3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WavelengthSample {
    /// The new wavelength (equal to the old one when `fluorescent` is false).
    pub lambda: f32,
    /// Probability of this outcome: `1 − P` (discrete) when not fluorescent, `P · density` when
    /// fluorescent.
    pub pdf: f32,
    /// The spectral part of f for the pair: the diagonal, or the kernel value.
    pub value: f32,
    /// Whether the interaction shifted the wavelength.
    pub fluorescent: bool,
}

impl WavelengthSample {
    /// `value / pdf`, zero when the pdf is.
    #[inline]
    pub fn weight(&self) -> f32 {
        if self.pdf > 0.0 {
            self.value / self.pdf
        } else {
            0.0
        }
    }
}

/// The bispectral bidirectional reflectance and reradiation function (BBRRDF), spectral part.
pub trait Bbrrdf {
    /// Diagonal (wavelength-preserving) coefficient at λ, dimensionless.
    fn diagonal(&self, l: f32) -> f32;
    /// Wavelength-shifting kernel ρ(λin → λout) per nm.
    fn kernel(&self, l_in: f32, l_out: f32) -> f32;
    /// Whether the material can shift wavelengths at all.
    fn is_fluorescent(&self) -> bool;
    /// P_l(fluorescent interaction | λin) (Jung eq. 5.10).
    fn fluorescence_probability_light(&self, l_in: f32) -> f32;
    /// P_c(fluorescent interaction | λout) (Jung eq. 5.12).
    fn fluorescence_probability_camera(&self, l_out: f32) -> f32;
    /// Importance-sample the new wavelength of a fluorescent interaction given the known one,
    /// `l` (emission side on light paths, absorption side on camera paths), from two uniform
    /// numbers; one lookup gives the wavelength, its density and the kernel value.
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw;
    /// Density of [`Bbrrdf::sample_shift`] choosing `l_new` given `l`.
    fn shift_density(&self, l: f32, l_new: f32, side: PathSide) -> f32;
    /// The bin operator for the all-bins evaluator (light transport direction).
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator;

    /// P_l or P_c, by the side of the path.
    #[inline]
    fn fluorescence_probability(&self, l: f32, side: PathSide) -> f32 {
        match side {
            PathSide::Light => self.fluorescence_probability_light(l),
            PathSide::Camera => self.fluorescence_probability_camera(l),
        }
    }

    /// Spectral part of f(λin → λout): the diagonal's coefficient for the δ (non-fluorescent)
    /// event, the kernel for a fluorescent one.
    #[inline]
    fn eval(&self, l_in: f32, l_out: f32, fluorescent: bool) -> f32 {
        if fluorescent {
            self.kernel(l_in, l_out)
        } else {
            self.diagonal(l_in)
        }
    }

    /// Choose the wavelength on the other side of a vertex whose known wavelength is `l`
    /// (Jung 5.3): a fluorescent interaction with probability P (eq. 5.10 on light paths, 5.12
    /// on camera paths) using `u[0]`, then the new wavelength from `u[0]` rescaled and `u[1]`;
    /// otherwise keep `l`, weighed by the diagonal.
    #[inline]
    fn sample(&self, l: f32, u: [f32; 2], side: PathSide, s: ShiftSampling) -> WavelengthSample {
        let p = self.fluorescence_probability(l, side);
        if p > 0.0 && u[0] < p {
            let u0 = (u[0] / p).min(ONE_MINUS_EPSILON);
            let d = match s.mode {
                WavelengthSampling::Importance => self.sample_shift(l, [u0, u[1]], side),
                WavelengthSampling::Uniform => {
                    let x = s.domain.sample_uniform(u[1]);
                    let kernel = match side {
                        PathSide::Camera => self.kernel(x, l),
                        PathSide::Light => self.kernel(l, x),
                    };
                    ShiftDraw {
                        lambda: x,
                        density: s.domain.uniform_pdf(x),
                        kernel,
                    }
                }
            };
            WavelengthSample {
                lambda: d.lambda,
                pdf: p * d.density,
                value: d.kernel,
                fluorescent: true,
            }
        } else {
            WavelengthSample {
                lambda: l,
                pdf: 1.0 - p,
                value: self.diagonal(l),
                fluorescent: false,
            }
        }
    }

    /// Probability (discrete, or density per nm when `fluorescent`) that [`Material::sample`]
    /// chooses `l_new` given `l`.
    #[inline]
    fn pdf(&self, l: f32, l_new: f32, fluorescent: bool, side: PathSide, s: ShiftSampling) -> f32 {
        let p = self.fluorescence_probability(l, side);
        if !fluorescent {
            return 1.0 - p;
        }
        p * match s.mode {
            WavelengthSampling::Importance => self.shift_density(l, l_new, side),
            WavelengthSampling::Uniform => s.domain.uniform_pdf(l_new),
        }
    }
}

/// A material of the scene (enum dispatch keeps the hot path free of virtual calls).
#[derive(Clone, Debug)]
/// Without the `fluorescence` feature only the Lambertian variant exists.
pub enum Material {
    Lambert(Lambert),
    #[cfg(feature = "fluorescence")]
    Fluorescent(FluorescentDiffuse),
    #[cfg(feature = "fluorescence")]
    Reradiation(Reradiation),
    #[cfg(feature = "fluorescence")]
    ReradiationGmm(ReradiationGmm),
}

macro_rules! dispatch {
    ($self:ident, $m:ident => $e:expr) => {
        match $self {
            Material::Lambert($m) => $e,
            #[cfg(feature = "fluorescence")]
            Material::Fluorescent($m) => $e,
            #[cfg(feature = "fluorescence")]
            Material::Reradiation($m) => $e,
            #[cfg(feature = "fluorescence")]
            Material::ReradiationGmm($m) => $e,
        }
    };
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl Material {
    /// Whether directional sampling or scattering depends on wavelength (never, for these
    /// diffuse models). The reset algorithms and the all-bins evaluator require `false`.
    pub fn wavelength_dependent_directions(&self) -> bool {
        false
    }

    /// The diagonal (wavelength-preserving) coefficient at every lane.
    #[inline(always)]
    pub fn diagonal_lanes<L: Lanes>(&self, n: usize, lambda: L) -> L {
        match self {
            Material::Lambert(l) => l.reflectance.eval_lanes(n, lambda),
            #[cfg(feature = "fluorescence")]
            _ => L::from_fn(n, |j| self.diagonal(lambda.lane(j))),
        }
    }
}

impl Bbrrdf for Material {
    #[inline]
    fn diagonal(&self, l: f32) -> f32 {
        dispatch!(self, m => m.diagonal(l))
    }
    #[inline]
    fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        dispatch!(self, m => m.kernel(l_in, l_out))
    }
    #[inline]
    fn is_fluorescent(&self) -> bool {
        dispatch!(self, m => m.is_fluorescent())
    }
    #[inline]
    fn fluorescence_probability_light(&self, l_in: f32) -> f32 {
        dispatch!(self, m => m.fluorescence_probability_light(l_in))
    }
    #[inline]
    fn fluorescence_probability_camera(&self, l_out: f32) -> f32 {
        dispatch!(self, m => m.fluorescence_probability_camera(l_out))
    }
    #[inline]
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        dispatch!(self, m => m.sample_shift(l, u, side))
    }
    #[inline]
    fn shift_density(&self, l: f32, l_new: f32, side: PathSide) -> f32 {
        dispatch!(self, m => m.shift_density(l, l_new, side))
    }
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator {
        dispatch!(self, m => m.bin_operator(grid))
    }
}

/// Bin average of a function of λ over [a, b] (64-point midpoint rule).
pub(crate) fn average_fn(f: impl Fn(f32) -> f32, a: f32, b: f32) -> f32 {
    let n = 64;
    let h = (b - a) / n as f32;
    (0..n)
        .map(|i| f(a + (i as f32 + 0.5) * h) as f64)
        .sum::<f64>() as f32
        / n as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::{DEFAULT_DOMAIN, Spectrum};
    use rand::{Rng, SeedableRng};

    fn materials() -> Vec<(&'static str, Material)> {
        let fl = FluorescentDiffuse::new(
            Spectrum::Constant(0.3),
            Spectrum::gaussian_fwhm(400.0, 40.0, 1.0),
            Spectrum::gaussian_fwhm(520.0, 30.0, 1.0),
            0.9,
            0.7,
            DEFAULT_DOMAIN,
        )
        .unwrap()
        .0;
        let golf = include_str!("../../data/bispectral/GOLFYE.BFC");
        vec![
            (
                "lambert",
                Material::Lambert(Lambert {
                    reflectance: Spectrum::Constant(0.6),
                }),
            ),
            ("fluorescent-diffuse", Material::Fluorescent(fl)),
            (
                "reradiation",
                Material::Reradiation(Reradiation::parse_bfc(golf, DEFAULT_DOMAIN).unwrap()),
            ),
            ("reradiation-gmm", Material::ReradiationGmm(gmm(golf, 4))),
            (
                "reradiation sampled by its mixture",
                Material::Reradiation(sampled_by(golf, golf, 2, 0.1)),
            ),
            (
                "reradiation sampled by another's mixture",
                Material::Reradiation(sampled_by(
                    golf,
                    include_str!("../../data/bispectral/rit/TEXTBLUE.BFC"),
                    4,
                    0.25,
                )),
            ),
        ]
    }

    /// The matrix of `bfc` with its shifts drawn from the `k`-Gaussian mixture of `fit_bfc`,
    /// the tables' share `alpha`.
    fn sampled_by(bfc: &str, fit_bfc: &str, k: usize, alpha: f32) -> Reradiation {
        use mixture::{FitMethod, FitOptions, fit_matrix};
        let m = reradiation::BfcMatrix::parse(fit_bfc).unwrap();
        let f = fit_matrix(&m, &FitOptions::new(k, FitMethod::Em, 0)).unwrap();
        Reradiation::parse_bfc(bfc, DEFAULT_DOMAIN)
            .unwrap()
            .with_sampler(MixtureSampler::new(&f, DEFAULT_DOMAIN, alpha))
    }

    fn gmm(bfc: &str, k: usize) -> ReradiationGmm {
        use mixture::{FitMethod, FitOptions, fit_matrix};
        let m = reradiation::BfcMatrix::parse(bfc).unwrap();
        let f = fit_matrix(&m, &FitOptions::new(k, FitMethod::Em, 0)).unwrap();
        ReradiationGmm::new(&f, DEFAULT_DOMAIN)
    }

    /// The GMM's bin operator moves the kernel's mass: a unit spectrum in one excitation bin
    /// comes out with ∫_bin ∫ρ dλo dλi, part of it inside the bin itself (on the diagonal).
    #[test]
    fn gmm_bin_operator_conserves_kernel_mass() {
        let m = gmm(include_str!("../../data/bispectral/GOLFYE.BFC"), 4);
        for w in [5.0, 10.0] {
            let g = BinGrid::new(DEFAULT_DOMAIN, w);
            let op = m.bin_operator(&g);
            for l in [352.0, 420.0, 447.0] {
                let i = g.index(l).unwrap();
                let mut t = vec![0.0; g.len()];
                t[i] = 1.0;
                let mut out = vec![0.0; g.len()];
                op.apply(&t, &mut out);
                let total: f64 = (0..g.len()).map(|o| (out[o] * g.bin_width(o)) as f64).sum();
                let (a, b) = (g.edge(i) as f64, g.edge(i + 1) as f64);
                let n = 2000;
                let h = (b - a) / n as f64;
                let want: f64 = (0..n)
                    .map(|j| {
                        let li = (a + (j as f64 + 0.5) * h) as f32;
                        m.diagonal(li) as f64 + {
                            let k = 4000;
                            let hh = (DEFAULT_DOMAIN.max - li) as f64 / k as f64;
                            (0..k)
                                .map(|q| m.kernel(li, li + ((q as f64 + 0.5) * hh) as f32) as f64)
                                .sum::<f64>()
                                * hh
                        }
                    })
                    .sum::<f64>()
                    * h;
                assert!(
                    (total - want).abs() < 3e-3 * want,
                    "bin {w} nm at {l}: {total} vs {want}"
                );
            }
        }
    }

    /// The one-shot sampler reports the pdf that `pdf` gives for its outcome and the value that
    /// `eval` gives; the no-shift frequency is 1 − P and the histogram of shifted wavelengths
    /// matches the density (10 nm bins, 5σ); the density integrates to 1.
    #[test]
    fn one_shot_sampler_matches_its_pdf() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        for (name, m) in materials() {
            for mode in [WavelengthSampling::Importance, WavelengthSampling::Uniform] {
                let s = ShiftSampling::new(mode, DEFAULT_DOMAIN);
                for (side, l0) in [(PathSide::Camera, 560.0), (PathSide::Light, 360.0)] {
                    let n = 200_000;
                    let mut hist = [0u32; 50];
                    let mut stays = 0;
                    for _ in 0..n {
                        let w = m.sample(l0, [rng.random(), rng.random()], side, s);
                        let pdf = m.pdf(l0, w.lambda, w.fluorescent, side, s);
                        assert!((pdf - w.pdf).abs() <= 1e-6 * pdf.max(1e-6), "{name}");
                        let (li, lo) = match side {
                            PathSide::Camera => (w.lambda, l0),
                            PathSide::Light => (l0, w.lambda),
                        };
                        assert_eq!(w.value, m.eval(li, lo, w.fluorescent), "{name}");
                        if w.fluorescent {
                            hist[(((w.lambda - 280.0) / 10.0) as usize).min(49)] += 1;
                        } else {
                            assert_eq!(w.lambda, l0);
                            stays += 1;
                        }
                    }
                    let p = m.fluorescence_probability(l0, side);
                    let exp_stay = (1.0 - p) * n as f32;
                    assert!(
                        (stays as f32 - exp_stay).abs() < 5.0 * exp_stay.max(1.0).sqrt() + 1.0,
                        "{name} {mode:?} {side:?}: {stays} stays, want {exp_stay}"
                    );
                    let density = |l: f32| m.pdf(l0, l, true, side, s);
                    let total: f32 = (0..5000)
                        .map(|k| density(280.0 + 0.1 * (k as f32 + 0.5)))
                        .sum::<f32>()
                        * 0.1;
                    if p > 0.0 {
                        assert!(
                            (total / p - 1.0).abs() < 2e-3,
                            "{name} {mode:?} {side:?}: ∫ = {}",
                            total / p
                        );
                    }
                    for (b, &h) in hist.iter().enumerate() {
                        let a = 280.0 + 10.0 * b as f32;
                        let mass: f32 = (0..100)
                            .map(|k| density(a + 0.1 * (k as f32 + 0.5)))
                            .sum::<f32>()
                            * 0.1;
                        let e = mass * n as f32;
                        assert!(
                            (h as f32 - e).abs() < 5.0 * e.max(1.0).sqrt() + 2.0,
                            "{name} {mode:?} {side:?} bin {b}: {h} vs {e}"
                        );
                    }
                }
            }
        }
    }
}
