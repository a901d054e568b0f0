//! A diffuse surface whose bispectral reflectance is a measured reradiation matrix (Labsphere
//! BFC-450 file, RIT database).
//!
//! Layout: rows are emission λo, columns excitation λi, 10 nm steps; the diagonal is the plain
//! reflectance and an off-diagonal entry is the kernel times the excitation bin width:
//! ρ(λi→λo) = D[o][i] / Δλ (docs/design.md §2). Each entry covers a cell of ±Δλ/2 around its
//! wavelength, clipped to the domain. The loader cleans the data as Hua §5.1 does: entries below
//! the diagonal (λo < λi) and every negative value are set to zero. Reflectance is not measured
//! below the first emission wavelength (380 nm) and is taken as zero there.

pub(crate) use super::bfc::lerp_on_grid;
pub use super::bfc::{BfcMatrix, MAX_BFC_ALBEDO, MAX_BFC_CELLS, MAX_BFC_ENTRY, MIN_BFC_STEP};
use super::mixture::{ConditionalMixture, GmmFile};
use super::{Bbrrdf, BinOperator, PathSide, ShiftDraw, average_fn};
use crate::spectrum::{BinGrid, Domain};

/// Sampling-only use of a fitted mixture (Hua abstract, §7.6): the new wavelength of a shift is
/// drawn from the defensive mixture q = α·p_matrix + (1 − α)·p_gmm of the matrix's own tabulated
/// conditional and the mixture's truncated conditional, while the kernel stays the measured
/// matrix's, so a shift carries f_matrix / q. The α·p_matrix part keeps q positive wherever the
/// matrix is, whatever the mixture's tails do; where the mixture's conditional is empty, α is 1.
#[derive(Clone, Debug)]
pub struct MixtureSampler {
    cond: ConditionalMixture,
    /// α, in (0, 1].
    defensive: f32,
    components: usize,
}

impl MixtureSampler {
    /// The sampler of a validated model file, with defensive share `defensive` in (0, 1].
    pub fn new(f: &GmmFile, domain: Domain, defensive: f32) -> Self {
        assert!(defensive > 0.0 && defensive <= 1.0);
        MixtureSampler {
            cond: f.conditional(domain),
            defensive,
            components: f.components.len(),
        }
    }

    /// Number of Gaussians.
    pub fn components(&self) -> usize {
        self.components
    }

    /// The defensive share α.
    pub fn defensive(&self) -> f32 {
        self.defensive
    }

    /// Heap and inline bytes of the prepared mixture.
    pub fn render_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.cond.heap_bytes()
    }

    /// q = α·p_tables + (1 − α)·p_mixture for the new wavelength `new` given `known`, from the
    /// tables' density `table` and the mixture's conditional total ∫ρ_gmm (α is 1 where that
    /// total is zero, the conditional being empty).
    #[inline]
    fn mix(&self, known: f32, new: f32, axis: usize, table: f32, total: f64) -> f32 {
        if !(total > 0.0) {
            return table;
        }
        let (li, lo) = if axis == 0 {
            (known, new)
        } else {
            (new, known)
        };
        let p = (self.cond.kernel(li as f64, lo as f64) / total) as f32;
        self.defensive * table + (1.0 - self.defensive) * p
    }
}

#[derive(Clone, Debug)]
pub struct Reradiation {
    m: BfcMatrix,
    domain: Domain,
    /// Draws shifts from a fitted mixture instead of the tables (`None`: the tables alone).
    sampler: Option<MixtureSampler>,
    /// Per excitation column: Σ_o D[o][i]·w_o/Δλ (∫ρ dλo) and the CDF over o.
    col_total: Vec<f32>,
    col_cdf: Vec<Vec<f32>>,
    /// Per emission row: ∫ρ dλi and the CDF over i.
    row_total: Vec<f32>,
    row_cdf: Vec<Vec<f32>>,
}

impl Reradiation {
    /// Parse and clean a BFC-450 file ([`BfcMatrix::parse`]) and build the sampling tables.
    pub fn parse_bfc(text: &str, domain: Domain) -> Result<Self, String> {
        Ok(Self::new(BfcMatrix::parse(text)?, domain))
    }

    /// The rendering tables of a cleaned matrix: per-column and per-row totals and CDFs.
    pub fn new(m: BfcMatrix, domain: Domain) -> Self {
        let (n_em, n_ex, step) = (m.n_em, m.n_ex, m.step);
        let mut r = Reradiation {
            m,
            domain,
            sampler: None,
            col_total: vec![],
            col_cdf: vec![],
            row_total: vec![],
            row_cdf: vec![],
        };
        let em_w: Vec<f32> = (0..n_em).map(|o| r.cell_width(r.m.em(o))).collect();
        let ex_w: Vec<f32> = (0..n_ex).map(|i| r.cell_width(r.m.ex(i))).collect();
        for i in 0..n_ex {
            let w: Vec<f32> = (0..n_em).map(|o| r.m.off(o, i) * em_w[o] / step).collect();
            let (t, c) = cdf(&w);
            r.col_total.push(t);
            r.col_cdf.push(c);
        }
        for o in 0..n_em {
            let w: Vec<f32> = (0..n_ex).map(|i| r.m.off(o, i) * ex_w[i] / step).collect();
            let (t, c) = cdf(&w);
            r.row_total.push(t);
            r.row_cdf.push(c);
        }
        r
    }

    /// Sample shifts with a fitted mixture (defensively mixed with the tables) while evaluating
    /// the matrix.
    pub fn with_sampler(mut self, s: MixtureSampler) -> Self {
        self.sampler = Some(s);
        self
    }

    /// The mixture that draws shifts, if any.
    pub fn sampler(&self) -> Option<&MixtureSampler> {
        self.sampler.as_ref()
    }

    /// The cleaned matrix.
    pub fn matrix(&self) -> &BfcMatrix {
        &self.m
    }

    fn cell_width(&self, center: f32) -> f32 {
        let lo = (center - 0.5 * self.m.step).max(self.domain.min);
        let hi = (center + 0.5 * self.m.step).min(self.domain.max);
        (hi - lo).max(0.0)
    }

    #[inline]
    fn em_index(&self, l: f32) -> Option<usize> {
        let f = ((l - self.m.em_lo) / self.m.step + 0.5).floor();
        (f >= 0.0 && (f as usize) < self.m.n_em && self.domain.contains(l)).then_some(f as usize)
    }
    #[inline]
    fn ex_index(&self, l: f32) -> Option<usize> {
        let f = ((l - self.m.ex_lo) / self.m.step + 0.5).floor();
        (f >= 0.0 && (f as usize) < self.m.n_ex && self.domain.contains(l)).then_some(f as usize)
    }

    /// Sample within cell `k` of a grid starting at `lo`, clipped to the domain.
    fn sample_in_cell(&self, lo: f32, k: usize, u: f32) -> f32 {
        let c = lo + k as f32 * self.m.step;
        let a = (c - 0.5 * self.m.step).max(self.domain.min);
        let b = (c + 0.5 * self.m.step).min(self.domain.max);
        (a + u * (b - a)).min(b)
    }

    /// The tables' own draw: the column (light paths) or row (camera paths) by its CDF from
    /// `u[1]`, uniformly inside the chosen cell.
    fn sample_table(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        let none = ShiftDraw {
            lambda: l,
            density: 0.0,
            kernel: 0.0,
        };
        let (cdf, total, lo) = match side {
            PathSide::Light => match self.ex_index(l) {
                Some(i) => (&self.col_cdf[i], self.col_total[i], self.m.em_lo),
                None => return none,
            },
            PathSide::Camera => match self.em_index(l) {
                Some(o) => (&self.row_cdf[o], self.row_total[o], self.m.ex_lo),
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
    /// Density of [`Reradiation::sample_table`]: the kernel over its column's or row's total.
    fn table_density(&self, l: f32, l_new: f32, side: PathSide) -> f32 {
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

    /// Dimensions (emission rows, excitation columns).
    /// Bytes it renders with: the matrix, the per-column and per-row CDFs and totals.
    pub fn render_bytes(&self) -> usize {
        let cdfs: usize = self.col_cdf.iter().chain(&self.row_cdf).map(Vec::len).sum();
        std::mem::size_of::<Self>()
            + 4 * (self.m.d.len() + cdfs + self.col_total.len() + self.row_total.len())
            + self
                .sampler
                .as_ref()
                .map_or(0, MixtureSampler::render_bytes)
    }

    pub fn shape(&self) -> (usize, usize) {
        (self.m.n_em, self.m.n_ex)
    }
}

/// The bins of `grid` that meet the closed interval [a, b] (empty when a > b).
pub(crate) fn bins_meeting(grid: &BinGrid, (a, b): (f64, f64)) -> std::ops::Range<usize> {
    let n = grid.len();
    let start = (0..n)
        .position(|j| grid.edge(j + 1) as f64 >= a)
        .unwrap_or(n);
    let end = (0..n)
        .rposition(|j| grid.edge(j) as f64 <= b)
        .map_or(0, |j| j + 1);
    start..end.max(start)
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

/// The mixture's axis of the known wavelength: λi (0) on light paths, λo (1) on camera paths.
#[inline]
fn side_axis(side: PathSide) -> usize {
    match side {
        PathSide::Light => 0,
        PathSide::Camera => 1,
    }
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

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
        lerp_on_grid(
            self.m.em_lo,
            self.m.step,
            self.m.n_em,
            |o| self.m.reflectance(o),
            l,
        )
    }
    /// ρ(λi→λo) = D[o][i] / Δλ.
    #[inline]
    fn kernel(&self, l_in: f32, l_out: f32) -> f32 {
        match (self.em_index(l_out), self.ex_index(l_in)) {
            (Some(o), Some(i)) => self.m.off(o, i) / self.m.step,
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
    /// λin given λout) by its CDF, uniformly inside the chosen cell; with a [`MixtureSampler`],
    /// `u[0]` first chooses between the tables (probability α) and the mixture.
    fn sample_shift(&self, l: f32, u: [f32; 2], side: PathSide) -> ShiftDraw {
        let Some(s) = &self.sampler else {
            return self.sample_table(l, u, side);
        };
        let axis = side_axis(side);
        let alpha = s.defensive;
        if u[0] < alpha {
            let mut d = self.sample_table(l, u, side);
            if d.density > 0.0 {
                let total = s.cond.total(l as f64, axis);
                d.density = s.mix(l, d.lambda, axis, d.density, total);
            }
            return d;
        }
        let u0 = ((u[0] - alpha) / (1.0 - alpha)).min(ONE_BELOW);
        match s
            .cond
            .sample_and_total(l as f64, axis, [u0 as f64, u[1] as f64])
        {
            (total, Some(g)) => {
                let lambda = g.lambda as f32;
                let table = self.table_density(l, lambda, side);
                let kernel = match side {
                    PathSide::Light => self.kernel(l, lambda),
                    PathSide::Camera => self.kernel(lambda, l),
                };
                ShiftDraw {
                    lambda,
                    density: s.mix(l, lambda, axis, table, total),
                    kernel,
                }
            }
            // The mixture's conditional is empty here, so α is 1: the tables draw.
            (_, None) => self.sample_table(l, u, side),
        }
    }
    fn shift_density(&self, l: f32, l_new: f32, side: PathSide) -> f32 {
        let table = self.table_density(l, l_new, side);
        match &self.sampler {
            None => table,
            Some(s) => {
                let axis = side_axis(side);
                s.mix(l, l_new, axis, table, s.cond.total(l as f64, axis))
            }
        }
    }
    /// Dense upper-triangle operator: K[o][i] = (1/Δo) ∫_o ∫_i ρ (1 nm midpoint rule, exact for
    /// the piecewise-constant cells on an integer-nm grid). Only bins that meet the matrix's
    /// cells are integrated (the rest are exactly zero), so the cost does not grow with the
    /// domain outside the measured range.
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
        // The cells of `cells` values from `lo` (`em_index`, `ex_index`), one step wider on
        // each side against rounding.
        let support = |lo: f32, cells: usize| {
            let s = self.m.step as f64;
            (lo as f64 - 1.5 * s, lo as f64 + (cells as f64 + 0.5) * s)
        };
        let rows = bins_meeting(grid, support(self.m.em_lo, self.m.n_em));
        let cols = bins_meeting(grid, support(self.m.ex_lo, self.m.n_ex));
        for o in rows {
            let wo = grid.bin_width(o);
            for i in cols.start..o.min(cols.end) {
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

    /// Every BFC file of `data/bispectral` (the 144 RIT matrices and the daily repeats) parses,
    /// its column labels on the header's grid; reversed or non-numeric labels are refused, and a
    /// byte-order mark is skipped.
    #[test]
    fn every_shipped_bfc_parses_and_labels_are_checked() {
        fn walk(d: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for e in std::fs::read_dir(d).unwrap().flatten() {
                let p = e.path();
                if p.is_dir() {
                    walk(&p, out);
                } else if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("bfc")) {
                    out.push(p);
                }
            }
        }
        let mut files = Vec::new();
        walk(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/bispectral"),
            &mut files,
        );
        assert!(files.len() > 144, "{}", files.len());
        for f in &files {
            let text = std::fs::read_to_string(f).unwrap();
            BfcMatrix::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        }
        let lines: Vec<&str> = GOLFYE.lines().collect();
        let c = lines.iter().position(|l| l.starts_with("r:c:")).unwrap();
        let mut labels: Vec<&str> = lines[c].split_whitespace().collect();
        labels[1..].reverse();
        let reversed = lines
            .iter()
            .enumerate()
            .map(|(i, l)| {
                if i == c {
                    labels.join(" ")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let e = BfcMatrix::parse(&reversed).unwrap_err();
        assert!(e.contains("column 1 of 'r:c:' is '780'"), "{e}");
        let junk = GOLFYE.replacen("r:c:\t300", "r:c:\tabc", 1);
        assert!(BfcMatrix::parse(&junk).unwrap_err().contains("'abc'"));
        assert!(BfcMatrix::parse(&format!("\u{feff}{GOLFYE}")).is_ok());
    }

    #[test]
    fn parses_and_cleans_rit_file() {
        let m = Reradiation::parse_bfc(GOLFYE, DEFAULT_DOMAIN).unwrap();
        assert_eq!(m.shape(), (41, 49));
        assert!(m.m.d.iter().all(|&x| x >= 0.0));
        // Nothing below the diagonal survives.
        assert_eq!(m.kernel(500.0, 450.0), 0.0);
        // Diagonal at 380 nm is the reflectance 0.313414 of the file.
        assert!((m.diagonal(380.0) - 0.313414).abs() < 1e-6);
        // The yellow golf ball fluoresces: UV excitation shifts into the visible.
        assert!(m.is_fluorescent());
        assert!(m.fluorescence_probability_light(360.0) > 0.5);
    }

    /// Headers are checked before anything is allocated from them, and errors name the field.
    #[test]
    fn absurd_headers_are_refused_by_field() {
        let header = "380\t780\t10\t49\t300\t10";
        for (bad, field) in [
            ("nan\t780\t10\t49\t300\t10", "em_lo"),
            ("380\tinf\t10\t49\t300\t10", "em_hi"),
            ("380\t1e30\t10\t49\t300\t10", "em_hi"),
            ("380\t780\t10\t1e9\t300\t10", "n_ex"),
            ("380\t780\t10\t48.5\t300\t10", "n_ex"),
            ("380\t780\t0\t49\t300\t0", "step"),
            ("380\t780\t0.2\t49\t300\t0.2", "rows of"),
            ("380\t780\t1e-7\t49\t300\t1e-7", "step"),
            ("380\t780\t10\t49\t300\t5", "ex_step"),
            ("780\t380\t10\t49\t300\t10", "em_hi"),
            ("380\t99999\t0.5\t49\t300\t0.5", "em_hi"),
        ] {
            assert!(GOLFYE.contains(header));
            let e = BfcMatrix::parse(&GOLFYE.replacen(header, bad, 1)).unwrap_err();
            assert!(e.contains("header") && e.contains(field), "{bad}: {e}");
        }
        // A repeated emission row is not a complete matrix.
        let rows: Vec<&str> = GOLFYE.lines().collect();
        let r0 = rows.iter().position(|l| l.starts_with("380\t-")).unwrap();
        let dup = GOLFYE.replacen(rows[r0 + 1], rows[r0], 1);
        assert!(BfcMatrix::parse(&dup).unwrap_err().contains("twice"));
    }

    /// The raw parse keeps the measurement; the cleaned one differs from it exactly on the cells
    /// below the diagonal and the negative ones, which it zeroes (Hua §5.1).
    #[test]
    fn raw_and_cleaned_parses_differ_exactly_on_the_cleaned_cells() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/bispectral");
        let (mut below, mut negative) = (0, 0);
        for f in ["GOLFYE.BFC", "rit/HERPICHA.BFC", "rit/IXCAXORA.BFC"] {
            let text = std::fs::read_to_string(dir.join(f)).unwrap();
            let (m, raw) = (
                BfcMatrix::parse(&text).unwrap(),
                BfcMatrix::parse_raw(&text).unwrap(),
            );
            assert_eq!(
                (m.n_em, m.n_ex, m.em_lo, m.ex_lo),
                (raw.n_em, raw.n_ex, 380.0, 300.0)
            );
            for o in 0..m.n_em {
                for i in 0..m.n_ex {
                    let (c, r) = (m.d[o * m.n_ex + i], raw.d[o * m.n_ex + i]);
                    let under = m.em(o) < m.ex(i);
                    below += (under && r != 0.0) as usize;
                    negative += (!under && r < 0.0) as usize;
                    if under || r < 0.0 {
                        assert_eq!(c, 0.0, "{f} ({}, {})", m.em(o), m.ex(i));
                    } else {
                        assert_eq!(c, r, "{f} ({}, {})", m.em(o), m.ex(i));
                    }
                }
            }
        }
        // The files do hold values the cleaning removes, on both counts.
        assert!(
            below > 100 && negative > 10,
            "{below} below, {negative} negative"
        );
        // What the cleaned parse refuses, the raw parse refuses too.
        let bad = GOLFYE.replacen("0.313414", "2e9", 1);
        assert!(BfcMatrix::parse(&bad).is_err() && BfcMatrix::parse_raw(&bad).is_err());
    }

    #[test]
    fn to_bfc_round_trips() {
        let m = BfcMatrix::parse(GOLFYE).unwrap();
        assert_eq!(BfcMatrix::parse(&m.to_bfc("round trip")).unwrap(), m);
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

    /// The mixture of another material (TEXTBLUE, K = 2) drawing GOLFYE's shifts: the density
    /// is positive wherever GOLFYE's kernel is (the tables' share α keeps it so), matches the
    /// density reported by each draw, and the mean of kernel / density over draws is ∫ρ, the
    /// weight a shift must carry (6σ).
    #[test]
    fn a_mixture_sampler_is_positive_where_the_matrix_is_and_unbiased() {
        use crate::material::mixture::{FitMethod, FitOptions, fit_matrix};
        use rand::{Rng, SeedableRng};
        let other =
            BfcMatrix::parse(include_str!("../../data/bispectral/rit/TEXTBLUE.BFC")).unwrap();
        let f = fit_matrix(&other, &FitOptions::new(2, FitMethod::Em, 0)).unwrap();
        let m = Reradiation::parse_bfc(GOLFYE, DEFAULT_DOMAIN)
            .unwrap()
            .with_sampler(MixtureSampler::new(&f, DEFAULT_DOMAIN, 0.1));
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        for (side, known) in [
            (PathSide::Light, [330.0f32, 400.0, 450.0]),
            (PathSide::Camera, [480.0, 520.0, 600.0]),
        ] {
            for l in known {
                for k in 0..5000 {
                    let x = 280.0 + 0.1 * (k as f32 + 0.5);
                    let kernel = match side {
                        PathSide::Light => m.kernel(l, x),
                        PathSide::Camera => m.kernel(x, l),
                    };
                    if kernel > 0.0 {
                        assert!(m.shift_density(l, x, side) > 0.0, "{side:?} {l} → {x}");
                    }
                }
                let total = match side {
                    PathSide::Light => m.col_total[m.ex_index(l).unwrap()],
                    PathSide::Camera => m.row_total[m.em_index(l).unwrap()],
                } as f64;
                let n = 200_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let d = m.sample_shift(l, [rng.random(), rng.random()], side);
                    let want = m.shift_density(l, d.lambda, side);
                    assert!((d.density - want).abs() <= 1e-5 * want, "{d:?} vs {want}");
                    let w = if d.density > 0.0 {
                        (d.kernel / d.density) as f64
                    } else {
                        0.0
                    };
                    sum += w;
                    sum2 += w * w;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                assert!(
                    (mean - total).abs() < 6.0 * se + 1e-6 * total,
                    "{side:?} {l}: E[ρ/q] = {mean} ± {se}, ∫ρ = {total}"
                );
            }
        }
    }
}
