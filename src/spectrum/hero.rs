//! Hero wavelength sets (Wilkie et al. 2014): N lanes equally rotated over the camera range.

use super::Domain;

/// Wavelengths of N lanes: λ_j = lo + ((λ_h − lo) + j·W/N) mod W.
#[derive(Clone, Copy, Debug)]
pub struct HeroWavelengths;

impl HeroWavelengths {
    /// Fill `out` with the rotated set for hero wavelength `hero` over `range`.
    #[inline]
    pub fn rotate(hero: f32, range: Domain, out: &mut [f32]) {
        let n = out.len() as f32;
        let w = range.width();
        for (j, o) in out.iter_mut().enumerate() {
            let mut x = hero - range.min + j as f32 * w / n;
            if x >= w {
                x -= w;
            }
            *o = range.min + x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn lanes_are_equally_spaced_and_inside() {
        let r = Domain {
            min: 360.0,
            max: 780.0,
        };
        let mut l = [0.0; 4];
        HeroWavelengths::rotate(700.0, r, &mut l);
        assert_eq!(l[0], 700.0);
        assert!(
            (l[1] - 385.0).abs() < 1e-4
                && (l[2] - 490.0).abs() < 1e-4
                && (l[3] - 595.0).abs() < 1e-4
        );
        assert!(l.iter().all(|x| r.contains(*x)));
    }
}
