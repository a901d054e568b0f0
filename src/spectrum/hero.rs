//! Sampled wavelengths of a camera path (pbrt-v4's `SampledWavelengths`): the lanes' wavelengths
//! and their pdfs. A hero wavelength is sampled and the other lanes are rotated from it
//! (Wilkie et al. 2014, hero wavelength spectral sampling).

use super::Domain;
use super::cie::{CameraWavelengths, Observer};
use super::lanes::Lanes;

/// The wavelengths of the first `n` lanes and each lane's pdf.
#[derive(Clone, Copy, Debug)]
pub struct SampledWavelengths<L> {
    pub lambda: L,
    /// p(λ_j) of lane j under the camera's wavelength sampling.
    pub pdf: L,
    pub n: usize,
    mode: CameraWavelengths,
    range: Domain,
}

/// The hero set: λ_j = lo + ((λ_h − lo) + j·W/n) mod W over the camera range of width W.
#[inline]
pub fn rotate(hero: f32, range: Domain, n: usize, j: usize) -> f32 {
    let w = range.width();
    let mut x = hero - range.min + j as f32 * w / n as f32;
    if x >= w {
        x -= w;
    }
    range.min + x
}

impl<L: Lanes> SampledWavelengths<L> {
    /// Sample the hero wavelength from `u` and rotate the other `n − 1` lanes from it; `None`
    /// when the hero's pdf is zero.
    #[inline(always)]
    pub fn sample_hero(
        observer: &Observer,
        mode: CameraWavelengths,
        u: f32,
        n: usize,
    ) -> Option<Self> {
        let (hero, pdf_hero) = observer.sample_wavelength(mode, u);
        if !(pdf_hero > 0.0) {
            return None;
        }
        let range = observer.range;
        let lambda = L::from_fn(n, |j| rotate(hero, range, n, j));
        let pdf = match mode {
            // Every lane lies inside the range.
            CameraWavelengths::Uniform => L::splat_n(n, pdf_hero),
            CameraWavelengths::Cmf => L::from_fn(n, |j| {
                if j == 0 {
                    pdf_hero
                } else {
                    observer.pdf_wavelength(mode, lambda.lane(j))
                }
            }),
        };
        Some(SampledWavelengths {
            lambda,
            pdf,
            n,
            mode,
            range,
        })
    }

    /// Σ_k p(λ_k): with the HWSS balance heuristic over the lanes (Wilkie et al. 2014, eq. 9)
    /// lane j's estimate is weighted by 1 / Σ_k p(λ_k) (the rotated set is the same whichever
    /// lane is the hero). For uniform sampling that is n / W.
    #[inline]
    pub fn balance_pdf(&self) -> f32 {
        match self.mode {
            CameraWavelengths::Uniform => self.n as f32 / self.range.width(),
            CameraWavelengths::Cmf => (0..self.n).map(|j| self.pdf.lane(j)).sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::lanes::LaneArr;
    use glam::Vec4;

    #[test]
    fn lanes_are_equally_spaced_and_inside() {
        let r = Domain {
            min: 360.0,
            max: 780.0,
        };
        let l: Vec<f32> = (0..4).map(|j| rotate(700.0, r, 4, j)).collect();
        assert_eq!(l[0], 700.0);
        assert!(
            (l[1] - 385.0).abs() < 1e-4
                && (l[2] - 490.0).abs() < 1e-4
                && (l[3] - 595.0).abs() < 1e-4
        );
        assert!(l.iter().all(|x| r.contains(*x)));
    }

    #[test]
    fn every_lane_type_holds_the_same_set() {
        let obs = Observer::new(crate::spectrum::DEFAULT_DOMAIN);
        for mode in [CameraWavelengths::Uniform, CameraWavelengths::Cmf] {
            for u in [0.0, 0.1, 0.37, 0.5, 0.999] {
                let v = SampledWavelengths::<Vec4>::sample_hero(&obs, mode, u, 4).unwrap();
                let a = SampledWavelengths::<LaneArr>::sample_hero(&obs, mode, u, 4).unwrap();
                let s = SampledWavelengths::<f32>::sample_hero(&obs, mode, u, 1).unwrap();
                assert_eq!(s.lambda, v.lambda.lane(0));
                for j in 0..4 {
                    assert_eq!(v.lambda.lane(j), a.lambda.lane(j));
                    assert_eq!(v.pdf.lane(j), a.pdf.lane(j));
                    assert!(obs.range.contains(v.lambda.lane(j)));
                    assert_eq!(v.pdf.lane(j), obs.pdf_wavelength(mode, v.lambda.lane(j)));
                }
                let sum: f32 = (0..4).map(|j| v.pdf.lane(j)).sum();
                assert!((v.balance_pdf() - sum).abs() < 1e-6 * sum);
            }
        }
    }
}
