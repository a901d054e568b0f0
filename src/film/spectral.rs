//! Spectral images: radiance in uniform wavelength bins over the camera range, accumulated beside
//! the XYZ film and written as OpenEXR in the layout of Fichet, Pacanowski and Wilkie 2021
//! (JCGT 10(3), "An OpenEXR Layout for Spectral Images"): one channel `S0.<λ>nm` per bin (the
//! bin's centre, a comma for the decimal point), the attribute `spectralLayoutVersion` = "1.0",
//! and the RGB preview in `R`, `G`, `B`.

use crate::spectrum::Domain;
use glam::Vec3;
use std::path::Path;

/// Most bins of a spectral image.
pub const MAX_BINS: usize = 1024;

/// `n` bins of equal width over a wavelength range. Bin b holds (1/Δλ) ∫ L dλ over
/// [min + b·Δλ, min + (b+1)·Δλ): the bin's mean spectral radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectralBins {
    pub min: f32,
    pub max: f32,
    pub n: usize,
}

impl SpectralBins {
    pub fn new(range: Domain, n: usize) -> Result<Self, String> {
        if n == 0 || n > MAX_BINS {
            return Err(format!("spectral bins must be 1–{MAX_BINS}, got {n}"));
        }
        if !(range.width() > 0.0) {
            return Err(format!(
                "the camera's wavelength range [{}, {}] nm is empty",
                range.min, range.max
            ));
        }
        Ok(SpectralBins {
            min: range.min,
            max: range.max,
            n,
        })
    }

    /// The width of every bin, nm.
    #[inline]
    pub fn width(&self) -> f32 {
        (self.max - self.min) / self.n as f32
    }

    /// The bin holding λ (the last bin is closed), `None` outside the range or for NaN.
    #[inline]
    pub fn bin(&self, l: f32) -> Option<usize> {
        if !(l >= self.min && l <= self.max) {
            return None;
        }
        let f = (l - self.min) / (self.max - self.min) * self.n as f32;
        Some((f as usize).min(self.n - 1))
    }

    /// The centre of bin `b`, nm.
    pub fn centre(&self, b: usize) -> f64 {
        let w = (self.max as f64 - self.min as f64) / self.n as f64;
        self.min as f64 + (b as f64 + 0.5) * w
    }

    /// The Fichet 2021 channel name of bin `b`: `S0.550,000000nm`.
    pub fn channel(&self, b: usize) -> String {
        format!("S0.{:.6}nm", self.centre(b))
            .replace('.', ",")
            .replacen(',', ".", 1)
    }
}

/// A spectral film: for every pixel `n` sums (samples and light-tracing splats together), each
/// divided by the film's spp when read.
#[derive(Clone, Debug)]
pub struct SpectralFilm {
    pub bins: SpectralBins,
    /// Pixel-major: `sum[pixel · n + b]`.
    pub sum: Vec<f64>,
}

impl SpectralFilm {
    pub fn new(bins: SpectralBins, pixels: usize) -> Self {
        SpectralFilm {
            bins,
            sum: vec![0.0; pixels * bins.n],
        }
    }

    /// The estimate of every bin of every pixel (pixel-major) after `spp` samples.
    pub fn values(&self, spp: u32) -> Vec<f32> {
        let k = if spp > 0 { 1.0 / spp as f64 } else { 0.0 };
        self.sum.iter().map(|v| (v * k) as f32).collect()
    }
}

/// Write a spectral image: the bins of `values` (pixel-major, `bins.n` per pixel) as `S0.*`
/// channels, the preview `rgb` as `R`, `G`, `B`, and the text attributes `extra`.
pub fn write_spectral_exr(
    path: &Path,
    (width, height): (u32, u32),
    bins: &SpectralBins,
    values: &[f32],
    rgb: &[Vec3],
    extra: &[(String, String)],
) -> Result<(), String> {
    use exr::prelude::*;
    let px = width as usize * height as usize;
    if values.len() != px * bins.n || rgb.len() != px {
        return Err(format!(
            "cannot write the spectral EXR '{}': {} values and {} pixels for a {width}×{height} \
             image of {} bins",
            path.display(),
            values.len(),
            rgb.len(),
            bins.n
        ));
    }
    let mut list: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v: Vec<f32> = rgb.iter().map(|p| p.to_array()[c]).collect();
        list.push(AnyChannel::new(*name, FlatSamples::F32(v)));
    }
    for b in 0..bins.n {
        let v: Vec<f32> = (0..px).map(|p| values[p * bins.n + b]).collect();
        list.push(AnyChannel::new(
            bins.channel(b).as_str(),
            FlatSamples::F32(v),
        ));
    }
    let mut text = vec![
        ("spectralLayoutVersion".to_string(), "1.0".to_string()),
        ("emissiveUnits".to_string(), "W.m^-2.sr^-1".to_string()),
    ];
    text.extend(extra.iter().cloned());
    super::output::write_channels(path, (width, height), list, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_names_follow_fichet_2021() {
        let b = SpectralBins::new(
            Domain {
                min: 400.0,
                max: 700.0,
            },
            3,
        )
        .unwrap();
        assert_eq!(b.channel(0), "S0.450,000000nm");
        assert_eq!(b.channel(2), "S0.650,000000nm");
        let b = SpectralBins::new(
            Domain {
                min: 360.0,
                max: 830.0,
            },
            47,
        )
        .unwrap();
        assert_eq!(b.channel(0), "S0.365,000000nm");
    }

    #[test]
    fn bins_cover_the_range_once() {
        let b = SpectralBins::new(
            Domain {
                min: 380.0,
                max: 780.0,
            },
            40,
        )
        .unwrap();
        assert_eq!(b.bin(380.0), Some(0));
        assert_eq!(b.bin(389.999), Some(0));
        assert_eq!(b.bin(390.0), Some(1));
        assert_eq!(b.bin(780.0), Some(39));
        assert_eq!(b.bin(379.9), None);
        assert_eq!(b.bin(780.1), None);
        assert_eq!(b.bin(f32::NAN), None);
        assert!(
            SpectralBins::new(
                Domain {
                    min: 380.0,
                    max: 780.0
                },
                0
            )
            .is_err()
        );
        assert!(
            SpectralBins::new(
                Domain {
                    min: 380.0,
                    max: 780.0
                },
                MAX_BINS + 1
            )
            .is_err()
        );
    }
}
