//! The full pdf p_A · p_Λ of a path for every strategy ŝ that could have produced it
//! (Jung eqs. 6.3, 6.9–6.14 with the corrections of docs/design.md §4), and the MIS weights.
//!
//! Strategy ŝ means ŝ camera vertices x0 … x(ŝ−1) and t̂ = k − ŝ light vertices; ŝ = 1 is light
//! tracing (the light path's wavelengths reach the camera unchanged, Jung 6.3.2), ŝ = k is a
//! camera path that hits the emitter. ŝ = 0 (light paths hitting the pinhole) cannot happen.

use super::subpath::Vertex;
use super::weight::{mis_walk, mis_walk_shared};
use crate::integrator::MisHeuristic;
use crate::transport::{Segment, Stretch};
use std::cell::RefCell;

/// Which wavelength reset the integrator applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetMode {
    Forward,
    Backward,
}

impl ResetMode {
    /// "forward" or "backward".
    pub fn name(self) -> &'static str {
        match self {
            ResetMode::Forward => "forward",
            ResetMode::Backward => "backward",
        }
    }
}

/// A complete path x0 … x(k−1) with its wavelengths and all pdfs needed for MIS.
#[derive(Clone, Debug, Default)]
pub struct FullPath {
    pub k: usize,
    pub v: Vec<Vertex>,
    /// λi on the segment x(i+1) → xi, i = 0 … k−2.
    pub lambda: Vec<f32>,
    /// shift[i]: xi changes the wavelength (λi ≠ λ(i−1)); i = 1 … k−2.
    pub shift: Vec<bool>,
    /// Area pdf of xi sampled from x(i−1) (camera direction), i = 1 … k−1.
    pub pa_fwd: Vec<f64>,
    /// Area pdf of xi sampled from x(i+1) (light direction); pa_rev[k−1] is the light point pdf.
    pub pa_rev: Vec<f64>,
    /// Camera-side wavelength pdf at xi of the actual pair (eq. 6.6).
    pub pc: Vec<f64>,
    /// P_c(fluorescent interaction at xi | λ(i−1)) (eq. 5.12).
    pub big_pc: Vec<f64>,
    /// Light-side wavelength pdf at xi of the actual pair (eq. 6.7).
    pub pl: Vec<f64>,
    /// P_l(fluorescent interaction at xi | λi) (eq. 5.10).
    pub big_pl: Vec<f64>,
    /// p_c(λ0 | x0) under the camera's wavelength sampling (eq. 6.4).
    pub pc0: f64,
    /// p_l(λ(k−2) | x(k−1)) under the light's wavelength sampling (eq. 6.5).
    pub ple: f64,
    /// Media scenes: `seg[i]` is the segment x_i → x(i+1), its stretches in `stretches` from x_i.
    pub seg: Vec<Segment>,
    pub stretches: Vec<Stretch>,
    /// Media scenes: the media on the front and back side of each vertex.
    pub media: Vec<[u32; 2]>,
    /// Media scenes: the free-flight pdf of segment i sampled from x_i (camera direction, part of
    /// `pa_fwd[i+1]`) and from x(i+1) (light direction, part of `pa_rev[i]`).
    pub dist_fwd: Vec<f64>,
    pub dist_rev: Vec<f64>,
    /// Media scenes: where `seg[i]` comes from ([`SegmentSource`]), for the memo of its
    /// free-flight pdfs.
    pub seg_source: Vec<SegmentSource>,
    /// Work arrays of the O(k) MIS sums, reused between connections.
    products: RefCell<Products>,
}

/// Where a full path's segment comes from: the camera or light sub-path's segment arriving at
/// its vertex `j` (the light one turned around), or the connection (and a fresh light point's
/// empty segments), which is new for every connection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentSource {
    Camera(u32),
    Light(u32),
    Connection,
}

/// Work arrays of `FullPath::strategy_pdfs`: prefix or suffix products, and p(ŝ) at index ŝ − 1.
#[derive(Clone, Debug, Default)]
struct Products {
    a: Vec<f64>,
    b: Vec<f64>,
    /// p_Λ(ŝ) at index ŝ − 1.
    lam: Vec<f64>,
    /// `bdpt-combined`: p_Λ(ŝ) of the other reset, at index ŝ − 1.
    other: Vec<f64>,
    out: Vec<f64>,
}

impl FullPath {
    pub fn with_capacity(n: usize) -> Self {
        FullPath {
            k: 0,
            v: Vec::with_capacity(n),
            lambda: vec![0.0; n],
            shift: vec![false; n],
            pa_fwd: vec![0.0; n],
            pa_rev: vec![0.0; n],
            pc: vec![1.0; n],
            big_pc: vec![0.0; n],
            pl: vec![1.0; n],
            big_pl: vec![0.0; n],
            pc0: 0.0,
            ple: 0.0,
            seg: Vec::with_capacity(n),
            stretches: Vec::new(),
            media: Vec::with_capacity(n),
            dist_fwd: vec![1.0; n],
            dist_rev: vec![1.0; n],
            seg_source: Vec::with_capacity(n),
            products: RefCell::default(),
        }
    }

    /// Make room for a path of `k` vertices (no allocation once the capacity is reached).
    pub fn reset(&mut self, k: usize) {
        self.reset_keeping(k, 0);
    }

    /// [`Self::reset`] that keeps the first `keep` vertices.
    pub(crate) fn reset_keeping(&mut self, k: usize, keep: usize) {
        self.k = k;
        self.v.truncate(keep);
        if self.lambda.len() >= k
            && self.shift.len() >= k
            && [
                &self.pa_fwd,
                &self.pa_rev,
                &self.pc,
                &self.big_pc,
                &self.pl,
                &self.big_pl,
            ]
            .iter()
            .chain([&self.dist_fwd, &self.dist_rev].iter())
            .all(|a| a.len() >= k)
        {
            return;
        }
        for a in [&mut self.lambda] {
            if a.len() < k {
                a.resize(k, 0.0);
            }
        }
        if self.shift.len() < k {
            self.shift.resize(k, false);
        }
        for a in [
            &mut self.pa_fwd,
            &mut self.pa_rev,
            &mut self.pc,
            &mut self.big_pc,
            &mut self.pl,
            &mut self.big_pl,
            &mut self.dist_fwd,
            &mut self.dist_rev,
        ] {
            if a.len() < k {
                a.resize(k, 0.0);
            }
        }
    }

    #[inline]
    fn prod(a: &[f64], lo: usize, hi: usize) -> f64 {
        // ∏_{i=lo}^{hi} a[i] (empty when hi < lo)
        if hi < lo {
            1.0
        } else {
            a[lo..=hi].iter().product()
        }
    }

    /// Directional pdf of strategy ŝ in area measure, eq. 6.3.
    pub fn area_pdf(&self, s_hat: usize) -> f64 {
        let k = self.k;
        // camera generates x1 … x(ŝ−1); the light generates x(k−1) … xŝ
        Self::prod(&self.pa_fwd, 1, s_hat.wrapping_sub(1).min(k))
            * if s_hat < k {
                Self::prod(&self.pa_rev, s_hat, k - 1)
            } else {
                1.0
            }
    }

    /// ∏ light-side pdfs of x(j+1) … x(k−2) times the light's λ pdf.
    #[inline]
    fn light_tail(&self, j: usize) -> f64 {
        Self::prod(&self.pl, j + 1, self.k.saturating_sub(2)) * self.ple
    }

    /// Wavelength pdf of strategy ŝ.
    pub fn wavelength_pdf(&self, s_hat: usize, mode: ResetMode) -> f64 {
        let k = self.k;
        let last = k.saturating_sub(2); // last interior vertex
        if s_hat == 1 {
            // light tracing: every wavelength from the light sub-path (Jung 6.3.2)
            return self.light_tail(0);
        }
        match mode {
            ResetMode::Forward => {
                // eqs. 6.9/6.10 (docs/design.md §4): walk from xŝ; no-shift vertices give 1 − P_c, the first
                // shifting vertex j gives P_c and the light sub-path's pdfs apply beyond it.
                match (s_hat..=last).find(|&i| self.shift[i]) {
                    Some(j) => {
                        self.pc0
                            * Self::prod(&self.pc, 1, j - 1)
                            * self.big_pc[j]
                            * self.light_tail(j)
                    }
                    None => self.pc0 * Self::prod(&self.pc, 1, last),
                }
            }
            ResetMode::Backward => {
                // eqs. 6.11/6.13 with the corrected index: walk x(ŝ−1) … x1; no-shift vertices
                // give 1 − P_l, the first shifting vertex j gives P_l, the camera's pdfs below it.
                let hi = (s_hat - 1).min(last);
                match (1..=hi).rev().find(|&i| self.shift[i]) {
                    Some(j) => {
                        self.pc0
                            * Self::prod(&self.pc, 1, j - 1)
                            * self.big_pl[j]
                            * self.light_tail(j)
                    }
                    None => self.light_tail(0),
                }
            }
        }
    }

    /// Multiply the free-flight pdfs of every segment into the area pdfs of the vertices they
    /// reach (media scenes), after the strategy's own directional pdf has been taken.
    pub fn fold_distances(&mut self) {
        for i in 0..self.k.saturating_sub(1) {
            self.pa_fwd[i + 1] *= self.dist_fwd[i];
            self.pa_rev[i] *= self.dist_rev[i];
        }
    }

    /// Full pdf p_A · p_Λ of strategy ŝ (eq. 6.14).
    #[inline]
    pub fn strategy_pdf(&self, s_hat: usize, mode: ResetMode) -> f64 {
        self.area_pdf(s_hat) * self.wavelength_pdf(s_hat, mode)
    }

    /// The full pdf p(ŝ) of every strategy ŝ = 1 … k (index ŝ − 1) in O(k) (eq. 6.14): each is
    /// a camera prefix times a light suffix of area pdfs (eq. 6.3), and its wavelength pdf needs
    /// only the first shifting vertex at or after ŝ (forward, eqs. 6.9/6.10) or the last one
    /// before ŝ (backward, eqs. 6.11/6.13), tracked while walking ŝ down or up. Equal to
    /// [`Self::strategy_pdf`] up to rounding (products taken in another order).
    pub fn strategy_pdfs(&self, mode: ResetMode, out: &mut Vec<f64>) {
        let mut pr = self.products.borrow_mut();
        self.fill_products(mode, &mut pr);
        out.clear();
        out.extend_from_slice(&pr.out);
    }

    /// The wavelength pdf p_Λ(ŝ) of every strategy ŝ = 1 … k (index ŝ − 1) under `mode`, in
    /// O(k) (eqs. 6.9–6.13): what a reset contributes to the MIS weights.
    pub fn wavelength_pdfs(&self, mode: ResetMode, out: &mut Vec<f64>) {
        out.clear();
        if self.k >= 2 {
            let mut pr = self.products.borrow_mut();
            self.fill_wavelength_pdfs(mode, &mut pr);
            out.extend_from_slice(&pr.lam);
        }
    }

    /// p_Λ(ŝ) for every ŝ into `pr.lam` (index ŝ − 1) in O(k): forward stores the camera's
    /// prefix products and walks ŝ down, backward stores the light's suffix products and walks
    /// ŝ up (the direction in which its stopping vertex is met first).
    fn fill_wavelength_pdfs(&self, mode: ResetMode, pr: &mut Products) {
        let k = self.k;
        let last = k - 2; // last interior vertex
        if pr.a.len() <= k {
            pr.a.resize(k + 1, 0.0);
            pr.b.resize(k + 1, 0.0);
        }
        pr.lam.clear();
        pr.lam.resize(k, 0.0);
        let (b, lam) = (&mut pr.b[..=k], &mut pr.lam[..k]);
        let (pc, pl, shift) = (&self.pc[..k], &self.pl[..k], &self.shift[..k]);
        let (pc0, ple) = (self.pc0, self.ple);
        match mode {
            ResetMode::Forward => {
                // b[i] = ∏_{m=1}^{i} pc[m] (left to right, as `prod`)
                b[0] = 1.0;
                for i in 1..=last {
                    b[i] = b[i - 1] * pc[i];
                }
                // eqs. 6.9/6.10: j = first shifting vertex in [ŝ, k−2], the last one met walking
                // ŝ down; light = ∏_{m=ŝ+1}^{k−2} pl[m] at a shift
                let mut light = 1.0;
                let mut wl = pc0 * b[last];
                for s_hat in (2..=k).rev() {
                    if s_hat <= last {
                        if shift[s_hat] {
                            wl = pc0 * b[s_hat - 1] * self.big_pc[s_hat] * (light * ple);
                        }
                        light *= pl[s_hat];
                    }
                    lam[s_hat - 1] = wl;
                }
                // ŝ = 1: light tracing, every wavelength from the light sub-path (Jung 6.3.2)
                let light = if last >= 1 { pl[1] * light } else { light };
                lam[0] = light * ple;
            }
            ResetMode::Backward => {
                // b[j] = ∏_{m=j+1}^{k−2} pl[m] · ple
                let mut light = 1.0;
                for j in (0..=last).rev() {
                    b[j] = light * ple;
                    light *= pl[j];
                }
                // ŝ = 1: light tracing (Jung 6.3.2)
                lam[0] = b[0];
                // eqs. 6.11/6.13: j = last shifting vertex in [1, min(ŝ−1, k−2)], the last one
                // met walking ŝ up; cam = ∏_{m=1}^{j−1} pc[m]
                let mut cam = 1.0;
                let mut wl = b[0];
                for s_hat in 2..=k {
                    let i = s_hat - 1;
                    if i <= last {
                        if shift[i] {
                            wl = pc0 * cam * self.big_pl[i] * b[i];
                        }
                        cam *= pc[i];
                    }
                    lam[s_hat - 1] = wl;
                }
            }
        }
    }

    /// p(ŝ) for every ŝ into `pr.out`: the area pdf (eq. 6.3) as a camera prefix times a light
    /// suffix, times p_Λ(ŝ) (`fill_wavelength_pdfs`).
    fn fill_products(&self, mode: ResetMode, pr: &mut Products) {
        let k = self.k;
        pr.out.clear();
        if k < 2 {
            return;
        }
        self.fill_wavelength_pdfs(mode, pr);
        pr.out.resize(k, 0.0);
        let (a, lam, out) = (&mut pr.a[..=k], &pr.lam[..k], &mut pr.out[..k]);
        let (pa_fwd, pa_rev) = (&self.pa_fwd[..k], &self.pa_rev[..k]);
        match mode {
            ResetMode::Forward => {
                // a[i] = ∏_{m=1}^{i} pa_fwd[m]; rev = ∏_{m=ŝ}^{k−1} pa_rev[m] walking ŝ down
                a[0] = 1.0;
                for i in 1..k {
                    a[i] = a[i - 1] * pa_fwd[i];
                }
                let mut rev = 1.0;
                for s_hat in (2..=k).rev() {
                    if s_hat < k {
                        rev *= pa_rev[s_hat];
                    }
                    out[s_hat - 1] = a[s_hat - 1] * rev * lam[s_hat - 1];
                }
                out[0] = (pa_rev[1] * rev) * lam[0];
            }
            ResetMode::Backward => {
                // a[i] = ∏_{m=i}^{k−1} pa_rev[m]; fwd = ∏_{m=1}^{ŝ−1} pa_fwd[m] walking ŝ up
                a[k] = 1.0;
                for i in (1..k).rev() {
                    a[i] = pa_rev[i] * a[i + 1];
                }
                out[0] = a[1] * lam[0];
                let mut fwd = 1.0;
                for s_hat in 2..=k {
                    fwd *= pa_fwd[s_hat - 1];
                    out[s_hat - 1] = fwd * a[s_hat] * lam[s_hat - 1];
                }
            }
        }
    }

    /// Whether some strategy has a positive, finite pdf (eq. 6.14), i.e. the MIS weights of
    /// the path can sum to 1. O(k).
    pub fn any_strategy(&self, mode: ResetMode) -> bool {
        let mut pr = self.products.borrow_mut();
        self.fill_products(mode, &mut pr);
        pr.out.iter().any(|&p| p > 0.0 && p.is_finite())
    }

    /// MIS weights of all strategies ŝ = 1 … k (index ŝ − 1), eq. 6.15 generalised to the power
    /// heuristic; they sum to 1 whenever any strategy has a non-zero pdf. O(k).
    pub fn strategy_weights(&self, mode: ResetMode, h: MisHeuristic, out: &mut Vec<f64>) {
        let e = h.exponent() as f64;
        self.strategy_pdfs(mode, out);
        let mut sum = 0.0;
        for p in out.iter_mut() {
            *p = p.powf(e);
            sum += *p;
        }
        if sum > 0.0 {
            for w in out.iter_mut() {
                *w /= sum;
            }
        }
    }

    /// MIS weight of strategy s (eq. 6.15 generalised to the power heuristic) by the ratio walk
    /// of every BDPT (`super::weight::mis_walk`) over the path's area pdfs, with the
    /// wavelength pdfs p_Λ(ŝ) of the reset (`fill_wavelength_pdfs`). The strategy's own pdf
    /// must be positive and finite. O(k).
    pub fn mis_weight(&self, s: usize, mode: ResetMode, h: MisHeuristic) -> f64 {
        let mut pr = self.products.borrow_mut();
        self.fill_wavelength_pdfs(mode, &mut pr);
        let (k, lam) = (self.k, &pr.lam);
        let inv_own = 1.0 / lam[s - 1];
        let lower = (1..s).map(|m| (self.pa_fwd[m], self.pa_rev[m]));
        let upper = (s..k).map(|m| (self.pa_fwd[m], self.pa_rev[m]));
        mis_walk(lower, upper, s, |s_hat| lam[s_hat - 1] * inv_own, h).1
    }
}

impl FullPath {
    /// `bdpt-combined`: the MIS weight of the path as made by strategy s under reset `mode`
    /// among all 2k techniques (ŝ, r), ŝ = 1 … k, r ∈ {forward, backward}: p_r(s)^β / Σ_{ŝ,r'}
    /// p_r'(ŝ)^β with p_r(ŝ) = p_A(ŝ) · p_Λ,r(ŝ) (eqs. 6.3, 6.9–6.14). With `both`, the weight
    /// of (s, forward) and (s, backward) together, for light tracing (s = 1), where the two
    /// resets make the same path with the same pdf. p_Λ,mode(s) must be positive. O(k).
    ///
    /// `[n_f, n_b]`: how many samples of each reset's techniques a pixel sample takes, up to a
    /// common factor (Veach's one-sample model: each term is (n_r p_r(ŝ))^β); (1, 1) for
    /// `--reset-choice both`, `random` and `sample` (the ½ of the last two cancels), one-hot for
    /// `adaptive`, where a pixel takes one reset, which must then be `mode`'s (light tracing
    /// counts once whatever the pixel's reset).
    pub fn combined_weight(
        &self,
        s: usize,
        mode: ResetMode,
        both: bool,
        h: MisHeuristic,
        [n_f, n_b]: [f64; 2],
    ) -> f64 {
        let mut guard = self.products.borrow_mut();
        let pr = &mut *guard;
        self.fill_wavelength_pdfs(ResetMode::Forward, pr);
        std::mem::swap(&mut pr.lam, &mut pr.other);
        self.fill_wavelength_pdfs(ResetMode::Backward, pr);
        let (fwd, bwd) = (&pr.other, &pr.lam);
        let k = self.k;
        let inv_own = 1.0
            / match mode {
                ResetMode::Forward => fwd[s - 1],
                ResetMode::Backward => bwd[s - 1],
            };
        let e = h.exponent() as i32;
        // a reset whose techniques this sample does not take adds nothing (not even a NaN)
        let term = |n: f64, x: f64| if n == 0.0 { 0.0 } else { (n * x).powi(e) };
        // Σ_r (n_r p_Λ,r(ŝ) / p_Λ,mode(s))^β
        let shared = |s_hat: usize| {
            term(n_f, fwd[s_hat - 1] * inv_own) + term(n_b, bwd[s_hat - 1] * inv_own)
        };
        let own = shared(s);
        let lower = (1..s).map(|m| (self.pa_fwd[m], self.pa_rev[m]));
        let upper = (s..k).map(|m| (self.pa_fwd[m], self.pa_rev[m]));
        let w = mis_walk_shared(lower, upper, (s, own), shared, h).1;
        let n_own = match mode {
            ResetMode::Forward => n_f,
            ResetMode::Backward => n_b,
        };
        if both { w * own } else { w * n_own.powi(e) }
    }

    /// `bdpt-combined`: whether some technique (ŝ, r) has a positive, finite pdf. O(k).
    pub fn any_technique(&self) -> bool {
        self.any_strategy(ResetMode::Forward) || self.any_strategy(ResetMode::Backward)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// k = 4: x0 camera, x1 and x2 fluorescent, x3 light. Only x1 shifts.
    fn path() -> FullPath {
        let mut p = FullPath::with_capacity(4);
        p.reset(4);
        p.shift[1] = true;
        p.shift[2] = false;
        p.pc = vec![1.0, 0.3, 0.6, 1.0];
        p.big_pc = vec![0.0, 0.2, 0.4, 0.0];
        p.pl = vec![1.0, 0.05, 0.7, 1.0];
        p.big_pl = vec![0.0, 0.5, 0.3, 0.0];
        p.pc0 = 0.01;
        p.ple = 0.02;
        p
    }

    #[test]
    fn backward_walk_of_two_vertices_by_hand() {
        // ŝ = 3 (x0, x1, x2 camera; x3 light): the walk starts at x2 = x(s−1) (no shift:
        // 1 − P_l(x2) = 0.7) and stops at x1 (P_l(x1) = 0.5); below it the camera's p_c(λ0).
        // The printed upper index s − 2 of eq. 6.11 would drop the factor of x2 (docs/design.md §4).
        let p = path();
        let want = 0.01 * 0.5 * 0.7 * 0.02;
        assert!((p.wavelength_pdf(3, ResetMode::Backward) - want).abs() < 1e-15);
        // NEE and t = 0 walk from x2 as well.
        assert!((p.wavelength_pdf(4, ResetMode::Backward) - want).abs() < 1e-15);
        // ŝ = 2: walk from x1, which shifts: P_l(x1), light pdf of x2.
        assert!((p.wavelength_pdf(2, ResetMode::Backward) - want).abs() < 1e-15);
        // ŝ = 1: all light-side pdfs.
        assert!((p.wavelength_pdf(1, ResetMode::Backward) - 0.05 * 0.7 * 0.02).abs() < 1e-15);
    }

    #[test]
    fn all_strategies_at_once_match_each_alone() {
        let mut p = path();
        p.pa_fwd = vec![0.0, 2.0, 0.5, 3.0];
        p.pa_rev = vec![0.7, 1.5, 4.0, 0.25];
        let mut v = Vec::new();
        for shift2 in [false, true] {
            p.shift[2] = shift2;
            for mode in [ResetMode::Forward, ResetMode::Backward] {
                p.strategy_pdfs(mode, &mut v);
                for (i, x) in v.iter().enumerate() {
                    let want = p.strategy_pdf(i + 1, mode);
                    assert!((x - want).abs() <= 1e-15 * want, "{mode:?} ŝ={}", i + 1);
                }
                p.wavelength_pdfs(mode, &mut v);
                for (i, x) in v.iter().enumerate() {
                    let want = p.wavelength_pdf(i + 1, mode);
                    assert!((x - want).abs() <= 1e-15 * want, "{mode:?} ŝ={}", i + 1);
                }
            }
        }
    }

    #[test]
    fn forward_walk_by_hand() {
        let p = path();
        // ŝ = 2: walk from x2 (no shift, 1 − P_c = 0.6) to the light: camera-only pdfs.
        let cam = 0.01 * 0.3 * 0.6;
        assert!((p.wavelength_pdf(2, ResetMode::Forward) - cam).abs() < 1e-15);
        assert!((p.wavelength_pdf(3, ResetMode::Forward) - cam).abs() < 1e-15);
        assert!((p.wavelength_pdf(4, ResetMode::Forward) - cam).abs() < 1e-15);
        // ŝ = 1 is light tracing.
        assert!((p.wavelength_pdf(1, ResetMode::Forward) - 0.05 * 0.7 * 0.02).abs() < 1e-15);
        // With x2 shifting too, ŝ = 2 stops at x2: p_c(λ0) p_c(x1) P_c(x2) · p_l(λ2).
        let mut q = path();
        q.shift[2] = true;
        let want = 0.01 * 0.3 * 0.4 * 0.02;
        assert!((q.wavelength_pdf(2, ResetMode::Forward) - want).abs() < 1e-15);
    }
}
