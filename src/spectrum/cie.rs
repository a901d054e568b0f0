//! The CIE 1931 2° standard observer and XYZ → linear sRGB (D65).
//!
//! Normalisation: XYZ = ∫ L(λ) x̄(λ) dλ / ∫ ȳ(λ) dλ over the camera range, so a constant spectral
//! radiance of 1 gives Y = 1 (the convention of pbrt-v4 and Mitsuba 3).

use super::{Distribution1D, Domain, Spectrum};
use glam::{IVec4, Mat3, Mat4, Vec3, Vec3A, Vec4};
use std::sync::OnceLock;

const CMF_CSV: &str = include_str!("../../data/spectra/cie1931_2deg_xyz_1nm.csv");
/// The observer table covers [360, 830] nm at 1 nm.
pub const CMF_DOMAIN: Domain = Domain {
    min: 360.0,
    max: 830.0,
};

struct CmfTable {
    /// (x̄, ȳ, z̄) at 360 + i nm, as 16-byte rows (one load each in [`cmf4`]).
    xyz: Vec<Vec3A>,
}

fn table() -> &'static CmfTable {
    static T: OnceLock<CmfTable> = OnceLock::new();
    T.get_or_init(|| {
        let xyz = CMF_CSV
            .lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                let v: Vec<f32> = l
                    .split(',')
                    .map(|x| x.trim().parse().expect("CIE table is valid"))
                    .collect();
                Vec3A::new(v[1], v[2], v[3])
            })
            .collect::<Vec<_>>();
        assert_eq!(xyz.len(), 471, "CIE table has 471 rows (360–830 nm)");
        CmfTable { xyz }
    })
}

/// Colour-matching functions (x̄, ȳ, z̄) at λ, linearly interpolated; zero outside 360–830 nm.
#[inline]
pub fn cmf(l: f32) -> Vec3 {
    let t = table();
    let f = l - CMF_DOMAIN.min;
    if !(0.0..=470.0).contains(&f) {
        return Vec3::ZERO;
    }
    let i = (f as usize).min(469);
    let w = f - i as f32;
    (t.xyz[i] * (1.0 - w) + t.xyz[i + 1] * w).into()
}

/// [`cmf`] at four wavelengths, as the x̄, ȳ and z̄ of the four lanes: the same values, each
/// lane's knot and weight found as [`cmf`] finds them (four at once) and its two rows
/// interpolated with the same operations (x̄, ȳ, z̄ at once).
#[inline]
pub fn cmf4(l: Vec4) -> [Vec4; 3] {
    let t = table();
    let f = l - Vec4::splat(CMF_DOMAIN.min);
    // `(0.0..=470.0).contains(&f)`, false for NaN; other lanes read row 0 and end up zero.
    let inside = f.cmpge(Vec4::ZERO) & f.cmple(Vec4::splat(470.0));
    let f = Vec4::select(inside, f, Vec4::ZERO);
    // `f as usize` for f in [0, 470].
    let i = f.as_ivec4().min(IVec4::splat(469));
    let w = f - i.as_vec4();
    let v = 1.0 - w;
    let row = |j: usize| {
        let k = i[j] as usize;
        (t.xyz[k] * v[j] + t.xyz[k + 1] * w[j]).extend(0.0)
    };
    let m = Mat4::from_cols(row(0), row(1), row(2), row(3)).transpose();
    let zero = Vec4::ZERO;
    [
        Vec4::select(inside, m.x_axis, zero),
        Vec4::select(inside, m.y_axis, zero),
        Vec4::select(inside, m.z_axis, zero),
    ]
}

/// What the camera integrates: the CIE 1931 observer, or a sensor with one spectral response.
#[derive(Clone, Debug, PartialEq)]
pub enum Sensor {
    /// The CIE 1931 2° colour-matching functions: the image is XYZ.
    Cie1931,
    /// One response curve r(λ) (a band is a box): the image is grey, every sRGB channel
    /// ∫ L r dλ / ∫ r dλ, so a constant spectral radiance of 1 gives 1.
    Response(Spectrum),
}

/// The observer restricted to a camera range, with its normalisation.
#[derive(Clone, Debug)]
pub struct Observer {
    /// Camera range: the scene domain intersected with the sensor's support (for the CIE
    /// observer, its 360–830 nm table).
    pub range: Domain,
    /// 1 / ∫ ȳ dλ over `range` (a sensor: 1 / ∫ r dλ).
    pub inv_y_integral: f32,
    /// Distribution ∝ x̄ + ȳ + z̄ (a sensor: ∝ r) for `--camera-wavelengths cmf`.
    cmf_dist: Distribution1D,
    /// The response curve of a sensor other than the CIE observer.
    response: Option<Spectrum>,
}

/// XYZ of the D65 white with Y = 1: the linear sRGB (1, 1, 1), so a sensor's grey image reads
/// the same value in every channel.
pub fn grey_xyz() -> Vec3 {
    static G: OnceLock<Vec3> = OnceLock::new();
    *G.get_or_init(|| xyz_to_srgb_matrix().inverse() * Vec3::ONE)
}

impl Observer {
    pub fn new(domain: Domain) -> Self {
        let range = domain.intersect(&CMF_DOMAIN);
        let y = integrate(|l| cmf(l).y, range);
        let sum = cmf_sum_spectrum();
        Observer {
            range,
            inv_y_integral: (1.0 / y) as f32,
            cmf_dist: Distribution1D::from_spectrum(&sum, range, 1.0),
            response: None,
        }
    }

    /// The observer of `sensor` over the scene's `domain`; an error when the sensor sees nothing
    /// there (the message is for the scene's `camera.sensor`).
    pub fn with_sensor(domain: Domain, sensor: &Sensor) -> Result<Self, String> {
        let r = match sensor {
            Sensor::Cie1931 => {
                let o = Observer::new(domain);
                if o.range.width() <= 0.0 {
                    return Err(format!(
                        "the CIE observer's 360–830 nm do not overlap the scene's domain \
                         [{}, {}] nm",
                        domain.min, domain.max
                    ));
                }
                return Ok(o);
            }
            Sensor::Response(r) => r,
        };
        let range = domain.intersect(&support(r));
        let integral = if range.width() > 0.0 {
            integrate(|l| r.eval(l), range)
        } else {
            0.0
        };
        if !(integral > 0.0 && integral.is_finite()) {
            return Err(format!(
                "the sensor's response is zero over the scene's domain [{}, {}] nm",
                domain.min, domain.max
            ));
        }
        Ok(Observer {
            range,
            inv_y_integral: (1.0 / integral) as f32,
            cmf_dist: Distribution1D::from_spectrum(r, range, 1.0),
            response: Some(r.clone()),
        })
    }

    /// Whether this is the CIE 1931 observer.
    pub fn is_cie(&self) -> bool {
        self.response.is_none()
    }

    /// The response curve of a sensor other than the CIE observer.
    pub fn sensor_response(&self) -> Option<&Spectrum> {
        self.response.as_ref()
    }

    /// The camera's response at λ before normalisation: (x̄, ȳ, z̄), or a sensor's r(λ) times
    /// [`grey_xyz`].
    #[inline]
    pub fn response(&self, l: f32) -> Vec3 {
        match &self.response {
            None => cmf(l),
            Some(r) => {
                if self.range.contains(l) {
                    grey_xyz() * r.eval(l)
                } else {
                    Vec3::ZERO
                }
            }
        }
    }

    /// [`Observer::response`] at every lane, as the x, y and z of the lanes.
    #[inline(always)]
    pub fn response_lanes<L: super::Lanes>(&self, lambda: L, n: usize) -> [L; 3] {
        if self.response.is_none() {
            lambda.cmf(n)
        } else {
            L::from_fn3(n, |j| self.response(lambda.lane(j)))
        }
    }

    /// Weight turning a radiance sample at λ into XYZ: cmf(λ) / ∫ȳ (divide by the λ pdf too).
    #[inline]
    pub fn xyz_weight(&self, l: f32) -> Vec3 {
        self.response(l) * self.inv_y_integral
    }

    /// Sample a camera wavelength; returns (λ, pdf).
    #[inline]
    pub fn sample_wavelength(&self, mode: CameraWavelengths, u: f32) -> (f32, f32) {
        match mode {
            CameraWavelengths::Uniform => (self.range.sample_uniform(u), 1.0 / self.range.width()),
            CameraWavelengths::Cmf => self.cmf_dist.sample(u),
        }
    }

    #[inline]
    pub fn pdf_wavelength(&self, mode: CameraWavelengths, l: f32) -> f32 {
        match mode {
            CameraWavelengths::Uniform => self.range.uniform_pdf(l),
            CameraWavelengths::Cmf => self.cmf_dist.pdf(l),
        }
    }

    /// XYZ of a spectral radiance distribution (numerical, 0.1 nm midpoint rule).
    pub fn spectrum_to_xyz(&self, s: &Spectrum) -> Vec3 {
        self.function_to_xyz(|l| s.eval(l) as f64)
    }

    /// XYZ of any function of λ (numerical, 0.1 nm midpoint rule, f64).
    pub fn function_to_xyz(&self, f: impl Fn(f32) -> f64) -> Vec3 {
        let n = (self.range.width() * 10.0).round() as usize;
        let h = self.range.width() as f64 / n as f64;
        let mut acc = [0.0f64; 3];
        for i in 0..n {
            let l = self.range.min + ((i as f64 + 0.5) * h) as f32;
            let v = f(l);
            let c = self.response(l);
            acc[0] += v * c.x as f64;
            acc[1] += v * c.y as f64;
            acc[2] += v * c.z as f64;
        }
        let k = h * self.inv_y_integral as f64;
        Vec3::new(
            (acc[0] * k) as f32,
            (acc[1] * k) as f32,
            (acc[2] * k) as f32,
        )
    }
}

named_enum! {
    /// How camera paths choose their wavelength.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
    pub enum CameraWavelengths {
        /// Uniform over the camera range.
        #[default]
        Uniform = "uniform",
        /// Proportional to x̄ + ȳ + z̄.
        Cmf = "cmf",
    }
}

fn cmf_sum_spectrum() -> Spectrum {
    let t = table();
    Spectrum::Tabulated {
        xs: (0..471).map(|i| 360.0 + i as f32).collect(),
        ys: t.xyz.iter().map(|v| v.x + v.y + v.z).collect(),
    }
}

/// Where a response curve can be non-zero (unbounded for a constant or a Gaussian).
fn support(r: &Spectrum) -> Domain {
    let (min, max) = match r {
        Spectrum::Constant(_) | Spectrum::Gaussian { .. } => (f32::NEG_INFINITY, f32::INFINITY),
        Spectrum::Box { lo, hi, .. } => (*lo, *hi),
        Spectrum::Tabulated { xs, .. } => (xs[0], xs[xs.len() - 1]),
        Spectrum::Binned { lo, width, values } => (*lo, lo + width * values.len() as f32),
    };
    Domain { min, max }
}

/// ∫ f over a domain with a 0.1 nm midpoint rule in f64.
fn integrate(f: impl Fn(f32) -> f32, d: Domain) -> f64 {
    let n = (d.width() * 10.0).round().max(1.0) as usize;
    let h = d.width() as f64 / n as f64;
    (0..n)
        .map(|i| f(d.min + ((i as f64 + 0.5) * h) as f32) as f64)
        .sum::<f64>()
        * h
}

/// The XYZ → linear sRGB matrix, derived from the sRGB primaries and the D65 white point
/// (IEC 61966-2-1 chromaticities), not a rounded copy.
pub fn xyz_to_srgb_matrix() -> Mat3 {
    static M: OnceLock<Mat3> = OnceLock::new();
    *M.get_or_init(|| {
        let xy = [(0.64f64, 0.33f64), (0.30, 0.60), (0.15, 0.06)];
        let (wx, wy) = (0.3127f64, 0.3290f64);
        let col = |(x, y): (f64, f64)| [x / y, 1.0, (1.0 - x - y) / y];
        let p = [col(xy[0]), col(xy[1]), col(xy[2])];
        let w = col((wx, wy));
        // Solve P · s = W for the channel scales s (P has primaries as columns).
        let m = |r: usize, c: usize| p[c][r];
        let det = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1))
            - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
            + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
        let inv = |r: usize, c: usize| {
            // Adjugate transpose / det.
            let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
            let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
            (m(r1, c1) * m(r2, c2) - m(r1, c2) * m(r2, c1)) / det
        };
        let s: Vec<f64> = (0..3)
            .map(|r| (0..3).map(|c| inv(r, c) * w[c]).sum())
            .collect();
        // RGB→XYZ = P · diag(s); invert it.
        let rgb2xyz = |r: usize, c: usize| m(r, c) * s[c];
        let det2 = rgb2xyz(0, 0) * (rgb2xyz(1, 1) * rgb2xyz(2, 2) - rgb2xyz(1, 2) * rgb2xyz(2, 1))
            - rgb2xyz(0, 1) * (rgb2xyz(1, 0) * rgb2xyz(2, 2) - rgb2xyz(1, 2) * rgb2xyz(2, 0))
            + rgb2xyz(0, 2) * (rgb2xyz(1, 0) * rgb2xyz(2, 1) - rgb2xyz(1, 1) * rgb2xyz(2, 0));
        let inv2 = |r: usize, c: usize| {
            let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
            let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
            ((rgb2xyz(r1, c1) * rgb2xyz(r2, c2) - rgb2xyz(r1, c2) * rgb2xyz(r2, c1)) / det2) as f32
        };
        Mat3::from_cols(
            Vec3::new(inv2(0, 0), inv2(1, 0), inv2(2, 0)),
            Vec3::new(inv2(0, 1), inv2(1, 1), inv2(2, 1)),
            Vec3::new(inv2(0, 2), inv2(1, 2), inv2(2, 2)),
        )
    })
}

#[inline]
pub fn xyz_to_linear_srgb(xyz: Vec3) -> Vec3 {
    xyz_to_srgb_matrix() * xyz
}

/// Linear → sRGB transfer function (display encoding).
pub fn srgb_encode(c: f32) -> f32 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::DEFAULT_DOMAIN;

    #[test]
    fn cmf4_is_cmf_lane_by_lane() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(9);
        let edges = [
            359.9,
            360.0,
            360.5,
            400.0,
            829.0,
            829.99,
            830.0,
            830.01,
            -1.0,
            f32::NAN,
            f32::INFINITY,
        ];
        let random = (0..4000).map(|_| rng.random_range(300.0..900.0f32));
        let ls: Vec<f32> = edges.into_iter().chain(random).collect();
        for w in ls.windows(4) {
            let l = Vec4::from_slice(w);
            let [x, y, z] = cmf4(l);
            for j in 0..4 {
                let c = cmf(l[j]);
                let got = [x[j], y[j], z[j]];
                assert_eq!(
                    got.map(f32::to_bits),
                    c.to_array().map(f32::to_bits),
                    "{}",
                    l[j]
                );
            }
        }
    }

    fn d65() -> Spectrum {
        let csv = include_str!("../../data/spectra/illuminants/illuminant_D65.csv");
        let (xs, ys): (Vec<f32>, Vec<f32>) = csv
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                let mut it = l.split(',').map(|v| v.trim().parse::<f32>().unwrap());
                (it.next().unwrap(), it.next().unwrap())
            })
            .unzip();
        Spectrum::Tabulated { xs, ys }
    }

    #[test]
    fn d65_chromaticity() {
        let obs = Observer::new(Domain {
            min: 300.0,
            max: 830.0,
        });
        let xyz = obs.spectrum_to_xyz(&d65());
        let s = xyz.x + xyz.y + xyz.z;
        let (x, y) = (xyz.x / s, xyz.y / s);
        assert!(
            (x - 0.3127).abs() < 1e-3 && (y - 0.3290).abs() < 1e-3,
            "D65 xy = ({x}, {y})"
        );
        // D65 maps to equal linear sRGB channels.
        let rgb = xyz_to_linear_srgb(xyz / xyz.y);
        assert!((rgb - Vec3::ONE).abs().max_element() < 5e-3, "{rgb:?}");
    }

    #[test]
    fn constant_one_gives_y_one() {
        for d in [
            DEFAULT_DOMAIN,
            Domain {
                min: 360.0,
                max: 830.0,
            },
        ] {
            let obs = Observer::new(d);
            let xyz = obs.spectrum_to_xyz(&Spectrum::Constant(1.0));
            assert!((xyz.y - 1.0).abs() < 1e-5, "Y = {}", xyz.y);
        }
        // Mitsuba's value for a unit constant spectrum over 360–830 nm.
        let obs = Observer::new(Domain {
            min: 360.0,
            max: 830.0,
        });
        let rgb = xyz_to_linear_srgb(obs.spectrum_to_xyz(&Spectrum::Constant(1.0)));
        assert!(
            (rgb - Vec3::new(1.20488, 0.948229, 0.909267))
                .abs()
                .max_element()
                < 2e-3,
            "{rgb:?}"
        );
    }

    #[test]
    fn cmf_sampling_pdf_consistent() {
        let obs = Observer::new(DEFAULT_DOMAIN);
        for i in 0..1000 {
            let (l, p) = obs.sample_wavelength(CameraWavelengths::Cmf, (i as f32 + 0.5) / 1000.0);
            assert!(obs.range.contains(l));
            assert!((p - obs.pdf_wavelength(CameraWavelengths::Cmf, l)).abs() <= 1e-5 * p);
        }
    }
}
