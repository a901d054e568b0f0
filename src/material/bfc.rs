//! A measured bispectral matrix as read from a Labsphere BFC-450 file and cleaned as Hua §5.1
//! does, with its bounds and the linear interpolation on its grid: the data that the
//! `reradiation` material renders and that `stokes gmm` fits. It depends on nothing else in
//! `material`, so both the material and the mixtures (`mixture`) build on it.

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
