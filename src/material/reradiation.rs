//! A diffuse surface whose bispectral reflectance is a measured reradiation matrix (Labsphere
//! BFC-450 file, RIT database).
//!
//! Layout: rows are emission λo, columns excitation λi, 10 nm steps; the diagonal is the plain
//! reflectance and an off-diagonal entry is the kernel times the excitation bin width:
//! ρ(λi→λo) = D[o][i] / Δλ (docs/design.md §2). Each entry covers a cell of ±Δλ/2 around its
//! wavelength, clipped to the domain. The loader cleans the data as Hua §5.1 does: entries below
//! the diagonal (λo < λi) and every negative value are set to zero. Reflectance is not measured
//! below the first emission wavelength (380 nm) and is taken as zero there.

use super::{Bbrrdf, BinOperator, PathSide, ShiftDraw, average_fn};
use crate::spectrum::{BinGrid, Domain};

#[derive(Clone, Debug)]
pub struct Reradiation {
    em_lo: f32,
    ex_lo: f32,
    step: f32,
    n_em: usize,
    n_ex: usize,
    /// Cleaned matrix, row-major [o][i].
    d: Vec<f32>,
    domain: Domain,
    /// Per excitation column: Σ_o D[o][i]·w_o/Δλ (∫ρ dλo) and the CDF over o.
    col_total: Vec<f32>,
    col_cdf: Vec<Vec<f32>>,
    /// Per emission row: ∫ρ dλi and the CDF over i.
    row_total: Vec<f32>,
    row_cdf: Vec<Vec<f32>>,
}

impl Reradiation {
    /// Parse a BFC-450 matrix file. Errors name the line and what is wrong.
    pub fn parse_bfc(text: &str, domain: Domain) -> Result<Self, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty());
        // Header: find the "em_lo em_hi step n_ex ex_lo ex_step" line.
        let mut header = None;
        for (no, l) in lines.by_ref() {
            if l.starts_with(';') || l.starts_with("VEC") || l.starts_with("BFC") {
                continue;
            }
            let v: Result<Vec<f32>, _> = l.split_whitespace().map(|x| x.parse::<f32>()).collect();
            match v {
                Ok(v) if v.len() == 6 => {
                    header = Some((no, v));
                    break;
                }
                _ => {
                    return Err(format!(
                        "line {no}: expected the header 'em_lo em_hi step n_ex ex_lo ex_step', found '{l}'"
                    ));
                }
            }
        }
        let (hno, h) =
            header.ok_or("no header line 'em_lo em_hi step n_ex ex_lo ex_step' found")?;
        let (em_lo, em_hi, step, n_ex, ex_lo, ex_step) =
            (h[0], h[1], h[2], h[3] as usize, h[4], h[5]);
        if step <= 0.0 || (step - ex_step).abs() > 1e-6 || em_hi < em_lo || n_ex == 0 || n_ex > 1000
        {
            return Err(format!("line {hno}: inconsistent header {h:?}"));
        }
        let n_em = ((em_hi - em_lo) / step).round() as usize + 1;
        let (cno, cols) = lines.next().ok_or("missing the 'r:c:' column line")?;
        let cols: Vec<&str> = cols.split_whitespace().collect();
        if cols.first() != Some(&"r:c:") || cols.len() != n_ex + 1 {
            return Err(format!(
                "line {cno}: expected 'r:c:' followed by {n_ex} excitation wavelengths"
            ));
        }
        let mut d = vec![0.0f32; n_em * n_ex];
        let mut rows_seen = 0;
        for (no, l) in lines {
            if l.eq_ignore_ascii_case("EOD") {
                break;
            }
            let v: Result<Vec<f32>, _> = l.split_whitespace().map(|x| x.parse::<f32>()).collect();
            let v = v.map_err(|_| format!("line {no}: a value is not a number"))?;
            if v.len() != n_ex + 1 {
                return Err(format!(
                    "line {no}: expected {} values, found {}",
                    n_ex + 1,
                    v.len()
                ));
            }
            let lo = v[0];
            let o = ((lo - em_lo) / step).round();
            if o < 0.0 || o as usize >= n_em || (em_lo + o * step - lo).abs() > 1e-3 {
                return Err(format!(
                    "line {no}: emission wavelength {lo} is not on the header's grid"
                ));
            }
            let o = o as usize;
            for i in 0..n_ex {
                let x = v[i + 1];
                if !x.is_finite() {
                    return Err(format!("line {no}: value {} is not finite", i + 1));
                }
                let li = ex_lo + i as f32 * step;
                // Hua §5.1 cleaning: λo < λi is unphysical, negative values are noise.
                d[o * n_ex + i] = if lo < li - 1e-3 || x < 0.0 { 0.0 } else { x };
            }
            rows_seen += 1;
        }
        if rows_seen != n_em {
            return Err(format!("expected {n_em} emission rows, found {rows_seen}"));
        }
        Ok(Self::from_matrix(em_lo, ex_lo, step, n_em, n_ex, d, domain))
    }

    fn from_matrix(
        em_lo: f32,
        ex_lo: f32,
        step: f32,
        n_em: usize,
        n_ex: usize,
        d: Vec<f32>,
        domain: Domain,
    ) -> Self {
        let mut m = Reradiation {
            em_lo,
            ex_lo,
            step,
            n_em,
            n_ex,
            d,
            domain,
            col_total: vec![],
            col_cdf: vec![],
            row_total: vec![],
            row_cdf: vec![],
        };
        let em_w: Vec<f32> = (0..n_em)
            .map(|o| m.cell_width(em_lo + o as f32 * step))
            .collect();
        let ex_w: Vec<f32> = (0..n_ex)
            .map(|i| m.cell_width(ex_lo + i as f32 * step))
            .collect();
        for i in 0..n_ex {
            let w: Vec<f32> = (0..n_em).map(|o| m.off(o, i) * em_w[o] / step).collect();
            let (t, c) = cdf(&w);
            m.col_total.push(t);
            m.col_cdf.push(c);
        }
        for o in 0..n_em {
            let w: Vec<f32> = (0..n_ex).map(|i| m.off(o, i) * ex_w[i] / step).collect();
            let (t, c) = cdf(&w);
            m.row_total.push(t);
            m.row_cdf.push(c);
        }
        m
    }

    /// Off-diagonal entry (zero on the diagonal cell).
    #[inline]
    fn off(&self, o: usize, i: usize) -> f32 {
        let lo = self.em_lo + o as f32 * self.step;
        let li = self.ex_lo + i as f32 * self.step;
        if (lo - li).abs() < 1e-3 {
            0.0
        } else {
            self.d[o * self.n_ex + i]
        }
    }

    fn cell_width(&self, center: f32) -> f32 {
        let lo = (center - 0.5 * self.step).max(self.domain.min);
        let hi = (center + 0.5 * self.step).min(self.domain.max);
        (hi - lo).max(0.0)
    }

    #[inline]
    fn em_index(&self, l: f32) -> Option<usize> {
        let f = ((l - self.em_lo) / self.step + 0.5).floor();
        (f >= 0.0 && (f as usize) < self.n_em && self.domain.contains(l)).then_some(f as usize)
    }
    #[inline]
    fn ex_index(&self, l: f32) -> Option<usize> {
        let f = ((l - self.ex_lo) / self.step + 0.5).floor();
        (f >= 0.0 && (f as usize) < self.n_ex && self.domain.contains(l)).then_some(f as usize)
    }

    /// Sample within cell `k` of a grid starting at `lo`, clipped to the domain.
    fn sample_in_cell(&self, lo: f32, k: usize, u: f32) -> f32 {
        let c = lo + k as f32 * self.step;
        let a = (c - 0.5 * self.step).max(self.domain.min);
        let b = (c + 0.5 * self.step).min(self.domain.max);
        (a + u * (b - a)).min(b)
    }

    /// Dimensions (emission rows, excitation columns).
    pub fn shape(&self) -> (usize, usize) {
        (self.n_em, self.n_ex)
    }
}

/// Total and normalised CDF of non-negative weights.
fn cdf(w: &[f32]) -> (f32, Vec<f32>) {
    let total: f32 = w.iter().sum();
    let mut acc = 0.0;
    let c = w
        .iter()
        .map(|x| {
            acc += x;
            if total > 0.0 { acc / total } else { 0.0 }
        })
        .collect();
    (total, c)
}

fn sample_cdf(c: &[f32], u: f32) -> (usize, f32) {
    let k = c.partition_point(|&x| x <= u).min(c.len() - 1);
    let lo = if k == 0 { 0.0 } else { c[k - 1] };
    let hi = c[k];
    let t = if hi > lo {
        ((u - lo) / (hi - lo)).clamp(0.0, 0.999_999)
    } else {
        0.5
    };
    (k, t)
}

impl Bbrrdf for Reradiation {
    /// Measured reflectance: the diagonal, linearly interpolated.
    #[inline]
    fn diagonal(&self, l: f32) -> f32 {
        if !self.domain.contains(l) {
            return 0.0;
        }
        let f = (l - self.em_lo) / self.step;
        if f < 0.0 || f > (self.n_em - 1) as f32 {
            return 0.0;
        }
        let o = (f as usize).min(self.n_em - 2);
        let t = f - o as f32;
        let diag = |o: usize| {
            let li = self.em_lo + o as f32 * self.step;
            let i = ((li - self.ex_lo) / self.step).round() as usize;
            self.d[o * self.n_ex + i]
        };
        diag(o) * (1.0 - t) + diag(o + 1) * t
    }
    /// ρ(λi→λo) = D[o][i] / Δλ.
    #[inline]
    fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        match (self.em_index(l_out), self.ex_index(l_in)) {
            (Some(o), Some(i)) => self.off(o, i) / self.step,
            _ => 0.0,
        }
    }
    fn is_fluorescent(&self) -> bool {
        self.col_total.iter().any(|&t| t > 0.0)
    }
    fn fluorescence_probability_light(&self, l_in: f32) -> f32 {
        let Some(i) = self.ex_index(l_in) else {
            return 0.0;
        };
        let f = self.col_total[i];
        if f <= 0.0 {
            0.0
        } else {
            f / (f + self.diagonal(l_in))
        }
    }
    fn fluorescence_probability_camera(&self, l_out: f32) -> f32 {
        let Some(o) = self.em_index(l_out) else {
            return 0.0;
        };
        let g = self.row_total[o];
        if g <= 0.0 {
            0.0
        } else {
            g / (g + self.diagonal(l_out))
        }
    }
    /// Sample the measured kernel's column (light paths: λout given λin) or row (camera paths:
    /// λin given λout) by its CDF, uniformly inside the chosen cell.
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        let none = ShiftDraw {
            lambda: l,
            density: 0.0,
            kernel: 0.0,
        };
        let (cdf, total, lo) = match side {
            PathSide::Light => match self.ex_index(l) {
                Some(i) => (&self.col_cdf[i], self.col_total[i], self.em_lo),
                None => return none,
            },
            PathSide::Camera => match self.em_index(l) {
                Some(o) => (&self.row_cdf[o], self.row_total[o], self.ex_lo),
                None => return none,
            },
        };
        if total <= 0.0 {
            return none;
        }
        let (k, t) = sample_cdf(cdf, u[1]);
        let lambda = self.sample_in_cell(lo, k, t);
        let kernel = match side {
            PathSide::Light => self.kernel(l, lambda),
            PathSide::Camera => self.kernel(lambda, l),
        };
        ShiftDraw {
            lambda,
            density: kernel / total,
            kernel,
        }
    }
    fn shift_density(&self, l: f32, l_new: f32, side: PathSide) -> f32 {
        let (total, kernel) = match side {
            PathSide::Light => match self.ex_index(l) {
                Some(i) => (self.col_total[i], self.kernel(l, l_new)),
                None => return 0.0,
            },
            PathSide::Camera => match self.em_index(l) {
                Some(o) => (self.row_total[o], self.kernel(l_new, l)),
                None => return 0.0,
            },
        };
        if total <= 0.0 { 0.0 } else { kernel / total }
    }
    /// Dense upper-triangle operator: K[o][i] = (1/Δo) ∫_o ∫_i ρ (1 nm midpoint rule, exact for
    /// the piecewise-constant cells on an integer-nm grid).
    fn bin_operator(&self, grid: &BinGrid) -> BinOperator {
        let n = grid.len();
        let diag: Vec<f32> = (0..n)
            .map(|b| average_fn(|l| self.diagonal(l), grid.edge(b), grid.edge(b + 1)))
            .collect();
        let mut k = vec![0.0f32; n * n];
        let nm = |b: usize| {
            let (a, z) = (grid.edge(b), grid.edge(b + 1));
            let m = ((z - a).round() as usize).max(1);
            let h = (z - a) / m as f32;
            (0..m).map(move |j| (a + (j as f32 + 0.5) * h, h))
        };
        for o in 0..n {
            let wo = grid.bin_width(o);
            for i in 0..o {
                let mut s = 0.0f64;
                for (lo, ho) in nm(o) {
                    for (li, hi) in nm(i) {
                        s += (self.kernel(li, lo) * ho * hi) as f64;
                    }
                }
                k[o * n + i] = (s / wo as f64) as f32;
            }
        }
        BinOperator::Dense { diag, n, k }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::DEFAULT_DOMAIN;

    const GOLFYE: &str = include_str!("../../data/bispectral/GOLFYE.BFC");

    #[test]
    fn parses_and_cleans_rit_file() {
        let m = Reradiation::parse_bfc(GOLFYE, DEFAULT_DOMAIN).unwrap();
        assert_eq!(m.shape(), (41, 49));
        assert!(m.d.iter().all(|&x| x >= 0.0));
        // Nothing below the diagonal survives.
        assert_eq!(m.kernel(500.0, 450.0), 0.0);
        // Diagonal at 380 nm is the reflectance 0.313414 of the file.
        assert!((m.diagonal(380.0) - 0.313414).abs() < 1e-6);
        // The yellow golf ball fluoresces: UV excitation shifts into the visible.
        assert!(m.is_fluorescent());
        assert!(m.fluorescence_probability_light(360.0) > 0.5);
    }

    #[test]
    fn malformed_files_give_errors() {
        assert!(Reradiation::parse_bfc("", DEFAULT_DOMAIN).is_err());
        let bad = GOLFYE.replacen("0.313414", "abc", 1);
        let e = Reradiation::parse_bfc(&bad, DEFAULT_DOMAIN).unwrap_err();
        assert!(e.contains("line"), "{e}");
        let short: String = GOLFYE.lines().take(20).collect::<Vec<_>>().join("\n");
        assert!(
            Reradiation::parse_bfc(&short, DEFAULT_DOMAIN)
                .unwrap_err()
                .contains("rows")
        );
    }

    #[test]
    fn shift_densities_integrate_to_one() {
        let m = Reradiation::parse_bfc(GOLFYE, DEFAULT_DOMAIN).unwrap();
        for l in [330.0, 400.0, 450.0] {
            let s: f32 = (0..5000)
                .map(|k| m.shift_density(l, 280.0 + 0.1 * (k as f32 + 0.5), PathSide::Light))
                .sum::<f32>()
                * 0.1;
            assert!((s - 1.0).abs() < 1e-3, "{l}: {s}");
            for j in 0..200 {
                let d = m.sample_shift(l, [0.5, (j as f32 + 0.5) / 200.0], PathSide::Light);
                assert!(d.density > 0.0);
                assert_eq!(d.density, m.shift_density(l, d.lambda, PathSide::Light));
            }
        }
        for l in [520.0, 600.0] {
            let s: f32 = (0..5000)
                .map(|k| m.shift_density(l, 280.0 + 0.1 * (k as f32 + 0.5), PathSide::Camera))
                .sum::<f32>()
                * 0.1;
            assert!((s - 1.0).abs() < 1e-3, "{l}: {s}");
        }
    }

    #[test]
    fn bin_operator_conserves_kernel_mass() {
        let m = Reradiation::parse_bfc(GOLFYE, DEFAULT_DOMAIN).unwrap();
        let g = BinGrid::new(DEFAULT_DOMAIN, 10.0);
        let op = m.bin_operator(&g);
        // A unit spectrum in one UV excitation bin (no diagonal below 380 nm): the output energy is
        // ∫_bin ∫ ρ dλo dλi.
        let i = g.index(362.0).unwrap();
        let mut t = vec![0.0; g.len()];
        t[i] = 1.0;
        let mut out = vec![0.0; g.len()];
        op.apply(&t, &mut out);
        let total: f32 = (0..g.len()).map(|o| out[o] * g.bin_width(o)).sum();
        let want = (0..g.len())
            .map(|o| {
                average_fn(
                    |lo| average_fn(|li| m.kernel(li, lo), g.edge(i), g.edge(i + 1)),
                    g.edge(o),
                    g.edge(o + 1),
                ) * g.bin_width(o)
            })
            .sum::<f32>()
            * g.bin_width(i);
        assert!(
            (total - want).abs() < 2e-3 * want.max(1e-3),
            "{total} vs {want}"
        );
    }
}
