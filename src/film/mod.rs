//! Film: progressive accumulation of XYZ with a box pixel filter, light-tracing splats and
//! auxiliary layers; OpenEXR and PNG output written atomically.

pub mod output;
pub mod shard;
pub mod spectral;

use glam::Vec3;

pub use output::{write_exr, write_png};

/// Accumulated XYZ estimates. A pixel's value is (Σ pixel samples + Σ splats) / spp.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Completed samples per pixel.
    pub spp: u32,
    pub sum: Vec<[f64; 3]>,
    pub splat: Vec<[f64; 3]>,
    /// Named auxiliary layers (e.g. one per BDPT strategy), same normalisation as the image.
    pub aux_names: Vec<String>,
    pub aux: Vec<Vec<[f64; 3]>>,
    /// The spectral image, when one is made.
    pub spectral: Option<spectral::SpectralFilm>,
}

impl Film {
    pub fn new(width: u32, height: u32, aux_names: Vec<String>) -> Self {
        let n = (width * height) as usize;
        Film {
            width,
            height,
            spp: 0,
            sum: vec![[0.0; 3]; n],
            splat: vec![[0.0; 3]; n],
            aux: aux_names.iter().map(|_| vec![[0.0; 3]; n]).collect(),
            aux_names,
            spectral: None,
        }
    }

    #[inline]
    pub fn add(buf: &mut [f64; 3], v: Vec3) {
        buf[0] += v.x as f64;
        buf[1] += v.y as f64;
        buf[2] += v.z as f64;
    }

    /// Pixel index of film position (x, y) in pixels, if inside.
    #[inline]
    pub fn pixel_index(&self, x: f32, y: f32) -> Option<usize> {
        if x >= 0.0 && y >= 0.0 && x < self.width as f32 && y < self.height as f32 {
            Some(y as usize * self.width as usize + x as usize)
        } else {
            None
        }
    }

    /// The current estimate in XYZ.
    pub fn xyz(&self) -> Vec<Vec3> {
        let k = if self.spp > 0 {
            1.0 / self.spp as f64
        } else {
            0.0
        };
        self.sum
            .iter()
            .zip(&self.splat)
            .map(|(a, b)| {
                Vec3::new(
                    ((a[0] + b[0]) * k) as f32,
                    ((a[1] + b[1]) * k) as f32,
                    ((a[2] + b[2]) * k) as f32,
                )
            })
            .collect()
    }

    /// The current estimate in linear sRGB (D65).
    pub fn rgb(&self) -> Vec<Vec3> {
        self.xyz()
            .into_iter()
            .map(crate::spectrum::xyz_to_linear_srgb)
            .collect()
    }

    /// An auxiliary layer in linear sRGB.
    pub fn aux_rgb(&self, layer: usize) -> Vec<Vec3> {
        let k = if self.spp > 0 {
            1.0 / self.spp as f64
        } else {
            0.0
        };
        self.aux[layer]
            .iter()
            .map(|a| {
                crate::spectrum::xyz_to_linear_srgb(Vec3::new(
                    (a[0] * k) as f32,
                    (a[1] * k) as f32,
                    (a[2] * k) as f32,
                ))
            })
            .collect()
    }

    /// Merge another film's sums (same size).
    pub fn merge(&mut self, o: &Film) {
        for (a, b) in self.sum.iter_mut().zip(&o.sum) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for (a, b) in self.splat.iter_mut().zip(&o.splat) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for (la, lb) in self.aux.iter_mut().zip(&o.aux) {
            for (a, b) in la.iter_mut().zip(lb) {
                for c in 0..3 {
                    a[c] += b[c];
                }
            }
        }
        self.spp += o.spp;
    }
}
