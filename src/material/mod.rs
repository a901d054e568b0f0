//! Spectral materials behind one BBRRDF interface (DESIGN.md §3.1).
//!
//! A material's reflectance is split into a wavelength-preserving part (the diagonal of the
//! reradiation matrix, a δ(λin − λout) term) and a wavelength-shifting kernel ρ(λin → λout)
//! per nm. The directional part is a separate lobe, so a path's geometry never depends on its
//! wavelengths. Every model here is perfectly diffuse and two-sided: f = spectral · 1/π.

pub mod binop;
pub mod fluorescent;
pub mod lambert;
pub mod reradiation;

pub use binop::BinOperator;
pub use fluorescent::FluorescentDiffuse;
pub use lambert::Lambert;
pub use reradiation::Reradiation;

use crate::spectrum::BinGrid;

/// How the new wavelength is chosen at a fluorescent vertex (Jung 7.1.2).
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum WavelengthSampling {
    /// Emission spectrum on light paths, absorption spectrum on camera paths (Jung 5.3.2).
    #[default]
    Importance,
    /// Uniform over the wavelength domain.
    Uniform,
}

/// A sampled wavelength at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftSample {
    /// The new wavelength (equal to the old one when `shifted` is false).
    pub lambda: f32,
    /// Probability of this outcome: `1 − P` (discrete) when not shifted, `P · density` when shifted.
    pub pdf: f32,
    pub shifted: bool,
    /// Spectral part of f divided by `pdf` (the diagonal coefficient, or the kernel value).
    pub weight: f32,
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
    /// Density of the new λout given a fluorescent interaction on a light path.
    fn shift_density_light(&self, l_in: f32, l_out: f32, mode: WavelengthSampling) -> f32;
    /// Density of the new λin given a fluorescent interaction on a camera path.
    fn shift_density_camera(&self, l_out: f32, l_in: f32, mode: WavelengthSampling) -> f32;
    /// Sample λout from a distribution of `shift_density_light` (given a shift happens).
    fn sample_shift_density_light(&self, l_in: f32, u: f32, mode: WavelengthSampling) -> f32;
    /// Sample λin from a distribution of `shift_density_camera` (given a shift happens).
    fn sample_shift_density_camera(&self, l_out: f32, u: f32, mode: WavelengthSampling) -> f32;
    /// The bin operator for the all-bins evaluator (light transport direction).
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator;
}

/// A material of the scene (enum dispatch keeps the hot path free of virtual calls).
#[derive(Clone, Debug)]
pub enum Material {
    Lambert(Lambert),
    Fluorescent(FluorescentDiffuse),
    Reradiation(Reradiation),
}

macro_rules! dispatch {
    ($self:ident, $m:ident => $e:expr) => {
        match $self {
            Material::Lambert($m) => $e,
            Material::Fluorescent($m) => $e,
            Material::Reradiation($m) => $e,
        }
    };
}

impl Material {
    /// The directional factor of the diffuse lobe, 1/π.
    pub const DIFFUSE: f32 = std::f32::consts::FRAC_1_PI;

    /// Whether directional sampling or scattering depends on wavelength (never, for these
    /// diffuse models). The reset algorithms and the all-bins evaluator require `false`.
    pub fn wavelength_dependent_directions(&self) -> bool {
        false
    }

    /// Spectral part of f(λin → λout) for a continuous (non-δ) pair of wavelengths, including
    /// the diagonal when `same` is true (the δ term's coefficient).
    #[inline]
    pub fn spectral(&self, l_in: f32, l_out: f32, same: bool) -> f32 {
        if same {
            self.diagonal(l_in)
        } else {
            self.kernel(l_in, l_out)
        }
    }

    /// Sample the incident wavelength at a camera-path vertex whose exitant wavelength is
    /// `l_out` (Jung 5.3: decide with P_c, then sample the absorption side).
    #[inline]
    pub fn sample_wavelength_camera(
        &self,
        l_out: f32,
        u: [f32; 2],
        mode: WavelengthSampling,
    ) -> ShiftSample {
        let p = self.fluorescence_probability_camera(l_out);
        self.sample_shift(l_out, p, u, |u| {
            let l_in = self.sample_shift_density_camera(l_out, u, mode);
            (
                l_in,
                self.shift_density_camera(l_out, l_in, mode),
                self.kernel(l_in, l_out),
            )
        })
    }

    /// Sample the exitant wavelength at a light-path vertex whose incident wavelength is `l_in`
    /// (Jung 5.3: decide with P_l, then sample the emission side).
    #[inline]
    pub fn sample_wavelength_light(
        &self,
        l_in: f32,
        u: [f32; 2],
        mode: WavelengthSampling,
    ) -> ShiftSample {
        let p = self.fluorescence_probability_light(l_in);
        self.sample_shift(l_in, p, u, |u| {
            let l_out = self.sample_shift_density_light(l_in, u, mode);
            (
                l_out,
                self.shift_density_light(l_in, l_out, mode),
                self.kernel(l_in, l_out),
            )
        })
    }

    /// The two-step choice of Jung 5.3 on either kind of path: with probability `p` a
    /// fluorescent interaction, whose new wavelength, density and kernel value `shift` returns;
    /// otherwise keep `l` and weigh the δ part by the diagonal.
    #[inline(always)]
    fn sample_shift(
        &self,
        l: f32,
        p: f32,
        u: [f32; 2],
        shift: impl FnOnce(f32) -> (f32, f32, f32),
    ) -> ShiftSample {
        if p > 0.0 && u[0] < p {
            let (lambda, density, f) = shift(u[1]);
            let pdf = p * density;
            let weight = if pdf > 0.0 { f / pdf } else { 0.0 };
            ShiftSample {
                lambda,
                pdf,
                shifted: true,
                weight,
            }
        } else {
            let pdf = 1.0 - p;
            let weight = if pdf > 0.0 {
                self.diagonal(l) / pdf
            } else {
                0.0
            };
            ShiftSample {
                lambda: l,
                pdf,
                shifted: false,
                weight,
            }
        }
    }

    /// Probability (discrete or density) that a camera path at this vertex chooses `l_in` given
    /// `l_out`; `same` tells whether the pair is the δ (no-shift) event.
    #[inline]
    pub fn pdf_wavelength_camera(
        &self,
        l_out: f32,
        l_in: f32,
        same: bool,
        mode: WavelengthSampling,
    ) -> f32 {
        let p = self.fluorescence_probability_camera(l_out);
        if same {
            1.0 - p
        } else {
            p * self.shift_density_camera(l_out, l_in, mode)
        }
    }

    /// Probability (discrete or density) that a light path at this vertex chooses `l_out` given
    /// `l_in`.
    #[inline]
    pub fn pdf_wavelength_light(
        &self,
        l_in: f32,
        l_out: f32,
        same: bool,
        mode: WavelengthSampling,
    ) -> f32 {
        let p = self.fluorescence_probability_light(l_in);
        if same {
            1.0 - p
        } else {
            p * self.shift_density_light(l_in, l_out, mode)
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
    fn shift_density_light(&self, l_in: f32, l_out: f32, mode: WavelengthSampling) -> f32 {
        dispatch!(self, m => m.shift_density_light(l_in, l_out, mode))
    }
    #[inline]
    fn shift_density_camera(&self, l_out: f32, l_in: f32, mode: WavelengthSampling) -> f32 {
        dispatch!(self, m => m.shift_density_camera(l_out, l_in, mode))
    }
    #[inline]
    fn sample_shift_density_light(&self, l_in: f32, u: f32, mode: WavelengthSampling) -> f32 {
        dispatch!(self, m => m.sample_shift_density_light(l_in, u, mode))
    }
    #[inline]
    fn sample_shift_density_camera(&self, l_out: f32, u: f32, mode: WavelengthSampling) -> f32 {
        dispatch!(self, m => m.sample_shift_density_camera(l_out, u, mode))
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
