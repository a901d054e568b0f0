//! Piecewise-constant 1-D sampling tables: sample λ proportionally to a spectrum and return the
//! pdf of any λ.

use super::{Domain, Spectrum};

/// A piecewise-constant distribution over [lo, hi] in equal cells.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    lo: f32,
    hi: f32,
    cell: f32,
    /// The density of each cell: its value (the bin average of the source function, ≥ 0) over
    /// the integral, or uniform where the integral is 0.
    pdf: Vec<f32>,
    /// Normalised CDF, `cdf[0] = 0`, `cdf[n] = 1`.
    cdf: Vec<f32>,
    /// ∫ f over [lo, hi].
    integral: f64,
    /// Guide table: `guide[j]` is the number of CDF entries ≤ j / G for the G = `guide.len() − 1`
    /// equal parts of [0, 1] (the cutpoint method), so that `sample` searches only the CDF
    /// entries between two neighbouring cutpoints; the same index as searching the whole CDF.
    guide: Vec<u32>,
}

impl Distribution1D {
    /// Tabulate `spectrum` over `domain` with cells of about `cell_nm` (bin averages, so narrow
    /// features are never missed) and build the CDF. Negative values are treated as zero.
    pub fn from_spectrum(spectrum: &Spectrum, domain: Domain, cell_nm: f32) -> Self {
        let n = ((domain.width() / cell_nm).round() as usize).max(1);
        let cell = domain.width() / n as f32;
        let func: Vec<f32> = (0..n)
            .map(|i| {
                let a = domain.min + i as f32 * cell;
                spectrum.bin_average(a, a + cell).max(0.0)
            })
            .collect();
        Self::from_cells(domain, func)
    }

    /// Build from `n` non-negative cell values over `domain`.
    pub fn from_cells(domain: Domain, func: Vec<f32>) -> Self {
        let n = func.len();
        let cell = domain.width() / n as f32;
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0f64);
        for f in &func {
            acc += *f as f64 * cell as f64;
            cdf.push(acc);
        }
        let integral = acc;
        let cdf: Vec<f32> = cdf
            .into_iter()
            .enumerate()
            .map(|(i, c)| {
                if integral > 0.0 {
                    (c / integral) as f32
                } else {
                    i as f32 / n as f32
                }
            })
            .collect();
        let guide = guide_table(&cdf, n);
        let pdf = func
            .iter()
            .map(|&f| {
                if integral > 0.0 {
                    (f as f64 / integral) as f32
                } else {
                    1.0 / (domain.max - domain.min)
                }
            })
            .collect();
        Distribution1D {
            lo: domain.min,
            hi: domain.max,
            cell,
            pdf,
            cdf,
            integral,
            guide,
        }
    }

    /// ∫ f over the domain (zero means the distribution falls back to uniform).
    pub fn integral(&self) -> f64 {
        self.integral
    }

    pub fn domain(&self) -> Domain {
        Domain {
            min: self.lo,
            max: self.hi,
        }
    }

    /// Sample λ from uniform `u` in [0, 1); returns (λ, pdf).
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32) {
        let n = self.pdf.len();
        // Largest i with cdf[i] <= u, and a cell with non-zero mass.
        let mut i = self.count_at_most(u).saturating_sub(1).min(n - 1);
        while i + 1 < n && self.cdf[i + 1] <= self.cdf[i] {
            i += 1;
        }
        let c0 = self.cdf[i];
        let dc = self.cdf[i + 1] - c0;
        let t = if dc > 0.0 {
            ((u - c0) / dc).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let mut l = (self.lo + (i as f32 + t) * self.cell).min(self.hi);
        if self.cell_index(l) != i {
            // Rounding put λ on a cell edge: keep it inside the sampled cell.
            l = self.lo + (i as f32 + 0.5) * self.cell;
        }
        (l, self.pdf_cell(i))
    }

    /// The number of CDF entries ≤ `u` (`partition_point` over the whole CDF), searched only
    /// between the guide's two cutpoints around `u`.
    #[inline]
    fn count_at_most(&self, u: f32) -> usize {
        let (cdf, g) = (&self.cdf[..], self.guide.len() - 1);
        let j = ((u * g as f32) as usize).min(g - 1);
        let (a, b) = (self.guide[j] as usize, self.guide[j + 1] as usize);
        // the count is at least a if entry a − 1 is ≤ u and at most b if entry b is > u; where
        // rounding put u beside its part (or u is NaN), the whole CDF
        if (a == 0 || cdf[a - 1] <= u) && (b == cdf.len() || cdf[b] > u) {
            a + cdf[a..b].partition_point(|&c| c <= u)
        } else {
            cdf.partition_point(|&c| c <= u)
        }
    }

    #[inline]
    fn pdf_cell(&self, i: usize) -> f32 {
        self.pdf[i]
    }

    /// Density at λ (zero outside the domain).
    #[inline]
    pub fn pdf(&self, l: f32) -> f32 {
        if !(l >= self.lo && l <= self.hi) {
            return 0.0;
        }
        self.pdf_cell(self.cell_index(l))
    }

    #[inline]
    fn cell_index(&self, l: f32) -> usize {
        (((l - self.lo) / self.cell) as usize).min(self.pdf.len() - 1)
    }
}

/// Cutpoint j of G equal parts of [0, 1].
#[inline(always)]
fn cutpoint(j: usize, g: usize) -> f32 {
    j as f32 / g as f32
}

/// The guide table of `cdf` with `parts` equal parts of [0, 1]: entry j counts the CDF entries
/// ≤ cutpoint j. An entry ≤ u is ≤ every cutpoint above u and one > u is > every cutpoint
/// below, so the count at u lies between the counts at the two cutpoints around it.
fn guide_table(cdf: &[f32], parts: usize) -> Vec<u32> {
    (0..=parts)
        .map(|j| {
            let c = cutpoint(j, parts);
            cdf.partition_point(|&x| x <= c) as u32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn check(spec: &Spectrum) {
        let d = Domain {
            min: 280.0,
            max: 780.0,
        };
        let dist = Distribution1D::from_spectrum(spec, d, 1.0);
        // pdf integrates to one (fine midpoint rule).
        let n = 50_000;
        let integ: f64 = (0..n)
            .map(|i| dist.pdf(280.0 + 500.0 * (i as f32 + 0.5) / n as f32) as f64)
            .sum::<f64>()
            * 500.0
            / n as f64;
        assert!((integ - 1.0).abs() < 1e-3, "pdf integrates to {integ}");
        // Histogram of samples matches the pdf in 10 nm bins (chi-square style bound).
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let m = 200_000;
        let mut hist = [0u32; 50];
        for _ in 0..m {
            let (l, p) = dist.sample(rng.random());
            assert!(
                p > 0.0 && (p - dist.pdf(l)).abs() <= 1e-4 * p,
                "returned pdf {p} vs pdf(l) {}",
                dist.pdf(l)
            );
            hist[(((l - 280.0) / 10.0) as usize).min(49)] += 1;
        }
        for (b, &h) in hist.iter().enumerate() {
            let a = 280.0 + 10.0 * b as f32;
            let expected = (0..100)
                .map(|k| dist.pdf(a + 0.1 * (k as f32 + 0.5)))
                .sum::<f32>()
                * 0.1
                * m as f32;
            let sd = expected.max(1.0).sqrt();
            assert!(
                (h as f32 - expected).abs() < 5.0 * sd + 1.0,
                "bin {b}: {h} vs {expected}"
            );
        }
    }

    /// The guided search finds the index of a search over the whole CDF, at and beside every
    /// CDF entry and cutpoint and on a fine grid, for smooth, boxed, sparse and flat tables.
    #[test]
    fn guided_search_is_the_whole_search() {
        let d = Domain {
            min: 280.0,
            max: 780.0,
        };
        let spectra = [
            Spectrum::gaussian_fwhm(515.0, 30.0, 1.0),
            Spectrum::gaussian_fwhm(515.0, 0.3, 1.0),
            Spectrum::Box {
                lo: 402.5,
                hi: 437.3,
                value: 3.0,
            },
            Spectrum::Constant(1.0),
            Spectrum::Constant(0.0),
        ];
        for spec in &spectra {
            for cell in [1.0, 7.0, 500.0] {
                let dist = Distribution1D::from_spectrum(spec, d, cell);
                let g = dist.guide.len() - 1;
                let mut us: Vec<f32> = (0..=100_000).map(|k| k as f32 / 100_000.0).collect();
                us.extend((0..=g).map(|j| cutpoint(j, g)));
                us.extend(dist.cdf.iter().copied());
                let near: Vec<f32> = us
                    .iter()
                    .flat_map(|u| [u.next_up(), u.next_down()])
                    .collect();
                us.extend(near);
                us.extend([-0.0, -1e-30, 1.0, 1.5, f32::NAN, f32::INFINITY]);
                for u in us {
                    let want = dist.cdf.partition_point(|&c| c <= u);
                    assert_eq!(
                        dist.count_at_most(u),
                        want,
                        "u = {u:e}, {spec:?}, cell {cell}"
                    );
                }
            }
        }
    }

    #[test]
    fn histogram_matches_pdf() {
        check(&Spectrum::gaussian_fwhm(515.0, 30.0, 1.0));
        check(&Spectrum::Box {
            lo: 402.5,
            hi: 437.3,
            value: 3.0,
        });
        check(&Spectrum::Tabulated {
            xs: vec![300.0, 500.0, 700.0],
            ys: vec![0.0, 2.0, 0.5],
        });
        check(&Spectrum::Constant(1.0));
    }

    #[test]
    fn pdf_is_zero_where_spectrum_is_zero_on_whole_cells() {
        let d = Domain {
            min: 280.0,
            max: 780.0,
        };
        let dist = Distribution1D::from_spectrum(
            &Spectrum::Box {
                lo: 400.0,
                hi: 405.0,
                value: 1.0,
            },
            d,
            1.0,
        );
        assert_eq!(dist.pdf(399.5), 0.0);
        assert_eq!(dist.pdf(406.5), 0.0);
        assert!((dist.pdf(402.0) - 0.2).abs() < 1e-6);
        for i in 0..1000 {
            let (l, _) = dist.sample(i as f32 / 1000.0);
            assert!((400.0..=405.0).contains(&l));
        }
    }
}
