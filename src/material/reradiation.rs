//! A diffuse surface whose bispectral reflectance is a measured reradiation matrix (Labsphere
//! BFC-450 file, RIT database).
//!
//! Layout: rows are emission λo, columns excitation λi, 10 nm steps; the diagonal is the plain
//! reflectance and an off-diagonal entry is the kernel times the excitation bin width:
//! ρ(λi→λo) = D[o][i] / Δλ (docs/design.md §2). Each entry covers a cell of ±Δλ/2 around its
//! wavelength, clipped to the domain. The loader cleans the data as Hua §5.1 does: entries below
//! the diagonal (λo < λi) and every negative value are set to zero. Reflectance is not measured
//! below the first emission wavelength (380 nm) and is taken as zero there.

use super::mixture::{ConditionalMixture, GmmFile};
use super::{Bbrrdf, BinOperator, PathSide, ShiftDraw, average_fn};
use crate::spectrum::{BinGrid, Domain};

/// A measured reradiation matrix as loaded and cleaned (Hua §5.1), before any rendering
/// tables: what the `reradiation` material renders and what `stokes gmm fit` fits.
#[derive(Clone, Debug, PartialEq)]
pub struct BfcMatrix {
    /// First emission wavelength (row 0), nm.
    pub em_lo: f32,
    /// First excitation wavelength (column 0), nm.
    pub ex_lo: f32,
    /// Grid step of both axes, nm.
    pub step: f32,
    pub n_em: usize,
    pub n_ex: usize,
    /// Cleaned matrix, row-major [o][i]: the diagonal is the reflectance, an off-diagonal entry
    /// the kernel times the excitation step.
    pub d: Vec<f32>,
}

impl BfcMatrix {
    /// Emission wavelength of row `o`.
    #[inline]
    pub fn em(&self, o: usize) -> f32 {
        self.em_lo + o as f32 * self.step
    }
    /// Excitation wavelength of column `i`.
    #[inline]
    pub fn ex(&self, i: usize) -> f32 {
        self.ex_lo + i as f32 * self.step
    }
    /// Whether cell (o, i) is on the diagonal (λo = λi).
    #[inline]
    pub fn is_diagonal(&self, o: usize, i: usize) -> bool {
        (self.em(o) - self.ex(i)).abs() < 1e-3
    }
    /// Off-diagonal entry (zero on the diagonal cell).
    #[inline]
    pub fn off(&self, o: usize, i: usize) -> f32 {
        if self.is_diagonal(o, i) {
            0.0
        } else {
            self.d[o * self.n_ex + i]
        }
    }
    /// The reflectance (diagonal) at emission row `o`; zero where the excitation grid has no
    /// such wavelength.
    pub fn reflectance(&self, o: usize) -> f32 {
        let i = ((self.em(o) - self.ex_lo) / self.step).round();
        if i < 0.0 || i as usize >= self.n_ex {
            0.0
        } else {
            self.d[o * self.n_ex + i as usize]
        }
    }

    /// The matrix as a BFC-450 file that [`BfcMatrix::parse`] reads back unchanged.
    pub fn to_bfc(&self, title: &str) -> String {
        let mut t = format!(
            "BFC-450 Matrix File\n;{title}\n{} {} {} {} {} {}\nr:c:",
            self.em_lo,
            self.em(self.n_em - 1),
            self.step,
            self.n_ex,
            self.ex_lo,
            self.step
        );
        for i in 0..self.n_ex {
            t += &format!(" {}", self.ex(i));
        }
        for o in 0..self.n_em {
            t += &format!("\n{}", self.em(o));
            for i in 0..self.n_ex {
                t += &format!(" {:e}", self.d[o * self.n_ex + i]);
            }
        }
        t + "\nEOD\n"
    }

    /// Parse a BFC-450 matrix file and clean it (Hua §5.1). Errors name the line and what is
    /// wrong.
    pub fn parse(text: &str) -> Result<Self, String> {
        Self::parse_with(text, true)
    }

    /// The matrix as measured, without Hua §5.1's cleaning: the values below the diagonal and
    /// the negative ones are kept. A file is accepted exactly when [`BfcMatrix::parse`] accepts
    /// it (the bounds are checked on the cleaned values), and the two differ only on the
    /// cleaned cells. For comparisons with the measurement (`stokes gmm eval`), not rendering.
    pub fn parse_raw(text: &str) -> Result<Self, String> {
        Self::parse_with(text, false)
    }

    /// Whether Hua §5.1's cleaning zeroes the value `x` at emission `lo`, excitation `li`: below
    /// the diagonal (λo < λi is unphysical) or negative (noise).
    #[inline]
    pub fn is_cleaned(lo: f32, li: f32, x: f32) -> bool {
        lo < li - 1e-3 || x < 0.0
    }

    fn parse_with(text: &str, clean: bool) -> Result<Self, String> {
        // A UTF-8 byte-order mark (some editors write one) is skipped, as the other readers do.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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
        let (em_lo, step, ex_lo) = (h[0], h[2], h[4]);
        let (n_ex, n_em) = check_header(&h).map_err(|m| format!("line {hno}: header {m}"))?;
        let (cno, cols) = lines.next().ok_or("missing the 'r:c:' column line")?;
        let cols: Vec<&str> = cols.split_whitespace().collect();
        if cols.first() != Some(&"r:c:") || cols.len() != n_ex + 1 {
            return Err(format!(
                "line {cno}: expected 'r:c:' followed by {n_ex} excitation wavelengths"
            ));
        }
        // The column labels are the header's excitation grid, in order.
        for (i, label) in cols[1..].iter().enumerate() {
            let want = ex_lo + i as f32 * step;
            match label.parse::<f32>() {
                Ok(x) if (x - want).abs() <= 1e-3 * step.max(1.0) => {}
                _ => {
                    return Err(format!(
                        "line {cno}: column {} of 'r:c:' is '{label}', but the header's \
                         excitation grid puts {want} nm there",
                        i + 1
                    ));
                }
            }
        }
        let mut d = vec![0.0f32; n_em * n_ex];
        let mut row_line = vec![0; n_em];
        let mut rows_seen = 0;
        let mut seen = vec![false; n_em];
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
            if std::mem::replace(&mut seen[o], true) {
                return Err(format!("line {no}: emission wavelength {lo} appears twice"));
            }
            for i in 0..n_ex {
                let x = v[i + 1];
                if !x.is_finite() {
                    return Err(format!("line {no}: value {} is not finite", i + 1));
                }
                d[o * n_ex + i] = x;
            }
            row_line[o] = no;
            rows_seen += 1;
        }
        if rows_seen != n_em {
            return Err(format!("expected {n_em} emission rows, found {rows_seen}"));
        }
        let raw = BfcMatrix {
            em_lo,
            ex_lo,
            step,
            n_em,
            n_ex,
            d,
        };
        let mut m = raw.clone();
        for o in 0..n_em {
            for i in 0..n_ex {
                if Self::is_cleaned(m.em(o), m.ex(i), m.d[o * n_ex + i]) {
                    m.d[o * n_ex + i] = 0.0;
                }
            }
        }
        m.check_bounds(&row_line)?;
        Ok(if clean { m } else { raw })
    }

    /// The cleaned entries are at most [`MAX_BFC_ENTRY`] and every excitation column's albedo
    /// (diagonal plus Σ_o D[o][i] = ∫ρ dλo) at most [`MAX_BFC_ALBEDO`]; errors name the line,
    /// the row (emission) and the column (excitation) wavelengths.
    fn check_bounds(&self, row_line: &[usize]) -> Result<(), String> {
        for (o, line) in row_line.iter().enumerate() {
            for i in 0..self.n_ex {
                let x = self.d[o * self.n_ex + i];
                if x > MAX_BFC_ENTRY {
                    let x = if x < 1e6 {
                        x.to_string()
                    } else {
                        format!("{x:e}")
                    };
                    return Err(format!(
                        "line {line}: the entry of row {} nm (emission), column {} nm (excitation) \
                         is {x}, above {MAX_BFC_ENTRY} (a reradiation matrix holds fractions of \
                         the light, about 1 at most)",
                        self.em(o),
                        self.ex(i)
                    ));
                }
            }
        }
        for i in 0..self.n_ex {
            let total: f64 = (0..self.n_em)
                .map(|o| self.d[o * self.n_ex + i] as f64)
                .sum();
            if total > MAX_BFC_ALBEDO as f64 {
                return Err(format!(
                    "column {} nm (excitation): its entries sum to {total:.4} (the light reflected \
                     and reradiated per unit of light at that wavelength), above {MAX_BFC_ALBEDO}",
                    self.ex(i)
                ));
            }
        }
        Ok(())
    }
}

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

/// Largest number of rows or columns a BFC header may announce.
pub const MAX_BFC_CELLS: usize = 1000;

/// Largest entry of a cleaned BFC matrix. A passive surface reflects and reradiates at most the
/// light it receives, so a physical entry is about 1 at most; of the 144 RIT files the largest
/// diagonal entry is 1.015 (GOLFYE) and the largest off-diagonal one 2.95 (IXCAXORA, which Hua
/// §7.1 leave out as a measurement artefact); the bound keeps a margin over both (docs/gmm.md).
pub const MAX_BFC_ENTRY: f32 = 10.0;

/// Largest albedo of an excitation column (its diagonal plus Σ_o D[o][i], the reflected and
/// reradiated light per unit of light at that wavelength). The RIT files reach 1.07 (GOLFYE),
/// and 35.5 for IXCAXORA; above the bound the path throughputs of a few bounces overflow
/// single precision.
pub const MAX_BFC_ALBEDO: f32 = 100.0;

/// Finest grid step of a BFC file or a model's grid, nm (no spectrometer resolves less, and
/// `stokes gmm dense` writes 1-nm matrices).
pub const MIN_BFC_STEP: f32 = 0.1;

/// Check a BFC header `em_lo em_hi step n_ex ex_lo ex_step` before anything is allocated from
/// it; returns (n_ex, n_em). Errors name the field.
fn check_header(h: &[f32]) -> Result<(usize, usize), String> {
    const NAMES: [&str; 6] = ["em_lo", "em_hi", "step", "n_ex", "ex_lo", "ex_step"];
    if let Some(k) = h.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "field {}: {} is not a finite number",
            NAMES[k], h[k]
        ));
    }
    for k in [0, 1, 4] {
        if !(0.0..=1e5).contains(&h[k]) {
            return Err(format!(
                "field {}: {} nm is not in [0, 1e5]",
                NAMES[k], h[k]
            ));
        }
    }
    let (em_lo, em_hi, step, n_ex, ex_step) = (h[0], h[1], h[2], h[3], h[5]);
    if !(MIN_BFC_STEP..=1e3).contains(&step) {
        return Err(format!(
            "field step: {step} nm is not in [{MIN_BFC_STEP}, 1000]"
        ));
    }
    if (step - ex_step).abs() > 1e-6 {
        return Err(format!("field ex_step: {ex_step} differs from step {step}"));
    }
    if n_ex.fract() != 0.0 || !(1.0..=MAX_BFC_CELLS as f32).contains(&n_ex) {
        return Err(format!(
            "field n_ex: {n_ex} is not a whole number in 1..={MAX_BFC_CELLS}"
        ));
    }
    let rows = (em_hi - em_lo) / step;
    if !(0.0..MAX_BFC_CELLS as f32).contains(&rows) || (rows - rows.round()).abs() > 1e-3 {
        return Err(format!(
            "fields em_lo, em_hi: [{em_lo}, {em_hi}] is not 1..={MAX_BFC_CELLS} rows of {step} nm"
        ));
    }
    Ok((n_ex as usize, rows.round() as usize + 1))
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

/// Linear interpolation of values tabulated at lo + k·step (k < n), zero outside the table.
#[inline]
pub(crate) fn lerp_on_grid(lo: f32, step: f32, n: usize, v: impl Fn(usize) -> f32, l: f32) -> f32 {
    let f = (l - lo) / step;
    if !(f >= 0.0 && f <= (n - 1) as f32) {
        return 0.0;
    }
    if n == 1 {
        return v(0);
    }
    let o = (f as usize).min(n - 2);
    let t = f - o as f32;
    v(o) * (1.0 - t) + v(o + 1) * t
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
