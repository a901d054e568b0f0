//! Wavelength bins over a domain: uniform bins of a given width (the last bin may be narrower),
//! or a scene-following grid with edges at the spectra's discontinuities, refined where a
//! spectrum changes fast within a bin (docs/allbins.md, "Bins that follow the scene").

use super::{Domain, Spectrum};

/// Breakpoints closer than this (nm) are merged; no bin is refined below it.
pub const MIN_BIN_WIDTH: f32 = 0.05;

#[derive(Clone, Debug, PartialEq)]
pub struct BinGrid {
    pub domain: Domain,
    /// The nominal (largest) bin width.
    pub width: f32,
    /// n + 1 increasing edges from `domain.min` to `domain.max`.
    edges: Vec<f32>,
}

impl BinGrid {
    /// Uniform bins of `width` from `domain.min` (the last one may be narrower).
    pub fn new(domain: Domain, width: f32) -> Self {
        let n = ((domain.width() / width) - 1e-4).ceil().max(1.0) as usize;
        let edges = (0..=n)
            .map(|i| (domain.min + i as f32 * width).min(domain.max))
            .collect();
        BinGrid {
            domain,
            width,
            edges,
        }
    }

    /// The uniform grid of [`BinGrid::new`] with the breakpoints `breaks` (inside the domain,
    /// any order) added as edges (a lattice edge closer than [`MIN_BIN_WIDTH`] to a breakpoint
    /// gives way to it); then every bin whose `variation(lo, hi)` exceeds `tol` is cut into
    /// ⌈variation/tol⌉ equal bins, again until it does not, down to [`MIN_BIN_WIDTH`] and up to
    /// `max_bins` bins in all.
    pub fn adaptive(
        domain: Domain,
        width: f32,
        breaks: &[f32],
        variation: impl Fn(f32, f32) -> f32,
        tol: f32,
        max_bins: usize,
    ) -> Self {
        let mut knots: Vec<f32> = breaks
            .iter()
            .copied()
            .filter(|&l| l > domain.min && l < domain.max)
            .collect();
        knots.sort_by(f32::total_cmp);
        knots.dedup_by(|b, a| *b - *a < MIN_BIN_WIDTH);
        let near = |e: f32| {
            let i = knots.partition_point(|&k| k < e);
            [i.wrapping_sub(1), i]
                .iter()
                .any(|&j| knots.get(j).is_some_and(|k| (k - e).abs() < MIN_BIN_WIDTH))
        };
        let uniform = BinGrid::new(domain, width);
        let last = uniform.len();
        let mut base: Vec<f32> = (0..=last)
            .filter(|&i| i == 0 || i == last || !near(uniform.edges[i]))
            .map(|i| uniform.edges[i])
            .collect();
        base.extend(
            knots
                .iter()
                .copied()
                .filter(|&k| k - domain.min >= MIN_BIN_WIDTH && domain.max - k >= MIN_BIN_WIDTH),
        );
        base.sort_by(f32::total_cmp);
        base.dedup();
        let mut edges = vec![base[0]];
        let mut budget = max_bins.saturating_sub(base.len() - 1);
        for b in base.windows(2) {
            refine(b[0], b[1], &variation, tol, &mut budget, &mut edges);
        }
        BinGrid {
            domain,
            width,
            edges,
        }
    }

    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Lower edge of bin `i` (`edge(len())` is the domain's upper end).
    pub fn edge(&self, i: usize) -> f32 {
        self.edges[i]
    }
    pub fn bin_width(&self, i: usize) -> f32 {
        self.edge(i + 1) - self.edge(i)
    }
    pub fn center(&self, i: usize) -> f32 {
        0.5 * (self.edge(i) + self.edge(i + 1))
    }
    /// Bin containing `l`, if inside the domain.
    pub fn index(&self, l: f32) -> Option<usize> {
        if !self.domain.contains(l) {
            return None;
        }
        Some(
            self.edges
                .partition_point(|&e| e <= l)
                .saturating_sub(1)
                .min(self.len() - 1),
        )
    }
    /// The narrowest bin's width.
    pub fn min_bin_width(&self) -> f32 {
        (0..self.len())
            .map(|i| self.bin_width(i))
            .fold(f32::INFINITY, f32::min)
    }
}

/// Push the upper edges of [a, b] cut until `variation ≤ tol` (or the limits) onto `edges`.
fn refine(
    a: f32,
    b: f32,
    variation: &impl Fn(f32, f32) -> f32,
    tol: f32,
    budget: &mut usize,
    edges: &mut Vec<f32>,
) {
    let v = variation(a, b);
    let k = if v > tol {
        ((v / tol).ceil() as usize).clamp(2, 64)
    } else {
        1
    };
    let k = k.min((((b - a) / MIN_BIN_WIDTH) as usize).max(1));
    if k == 1 || *budget < k - 1 {
        edges.push(b);
        return;
    }
    *budget -= k - 1;
    let h = (b - a) / k as f32;
    for j in 0..k {
        let hi = if j + 1 == k {
            b
        } else {
            a + (j + 1) as f32 * h
        };
        refine(a + j as f32 * h, hi, variation, tol, budget, edges);
    }
}

/// Wavelengths where `s` jumps: a box's edges, the ends of a tabulated spectrum (zero outside),
/// the steps of a binned one. Analytic kinds have none.
pub fn discontinuities(s: &Spectrum, out: &mut Vec<f32>) {
    match s {
        Spectrum::Constant(_) | Spectrum::Gaussian { .. } => {}
        Spectrum::Box { lo, hi, value } => {
            if *value != 0.0 {
                out.extend([*lo, *hi]);
            }
        }
        Spectrum::Tabulated { xs, ys } => {
            if let (Some(x0), Some(y0)) = (xs.first(), ys.first())
                && *y0 != 0.0
            {
                out.push(*x0);
            }
            if let (Some(x1), Some(y1)) = (xs.last(), ys.last())
                && *y1 != 0.0
            {
                out.push(*x1);
            }
        }
        Spectrum::Binned { lo, width, values } => {
            let mut prev = 0.0;
            for (i, v) in values.iter().chain([&0.0]).enumerate() {
                if *v != prev {
                    out.push(lo + i as f32 * width);
                }
                prev = *v;
            }
        }
    }
}

/// Oscillation (max − min) of `s` on the open interval (a, b), exact for every kind.
pub fn oscillation(s: &Spectrum, a: f32, b: f32) -> f32 {
    // Range of the values at the points `vals` plus zero when `outside`.
    let span = |vals: &mut dyn Iterator<Item = f32>, outside: bool| {
        let init = if outside {
            (0.0f32, 0.0f32)
        } else {
            (f32::INFINITY, f32::NEG_INFINITY)
        };
        let (lo, hi) = vals.fold(init, |(l, h), v| (l.min(v), h.max(v)));
        if hi >= lo { hi - lo } else { 0.0 }
    };
    match s {
        Spectrum::Constant(_) => 0.0,
        Spectrum::Box { lo, hi, value } => {
            if a < *hi && b > *lo && (a < *lo || b > *hi) {
                value.abs()
            } else {
                0.0
            }
        }
        Spectrum::Gaussian { center, .. } => {
            let top = s.eval(center.clamp(a, b));
            (top - s.eval(a).min(s.eval(b))).abs()
        }
        Spectrum::Tabulated { xs, .. } => {
            let (Some(&x0), Some(&x1)) = (xs.first(), xs.last()) else {
                return 0.0;
            };
            if b <= x0 || a >= x1 {
                return 0.0;
            }
            let (l, h) = (a.max(x0), b.min(x1));
            let inner = xs.iter().copied().filter(|&x| x > a && x < b);
            let mut vals = [l, h].into_iter().chain(inner).map(|x| s.eval(x));
            span(&mut vals, a < x0 || b > x1)
        }
        Spectrum::Binned { lo, width, values } => {
            let end = lo + values.len() as f32 * width;
            if b <= *lo || a >= end {
                return 0.0;
            }
            let i0 = (((a - lo) / width).floor().max(0.0)) as usize;
            let i1 = ((((b - lo) / width).ceil()) as usize).min(values.len());
            let mut vals = values[i0.min(i1)..i1].iter().copied();
            span(&mut vals, a < *lo || b > end)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::DEFAULT_DOMAIN;

    #[test]
    fn adaptive_grid_without_features_is_the_uniform_grid() {
        for w in [1.0, 2.5, 5.0, 7.0, 10.0, 20.0, 50.0] {
            let g = BinGrid::adaptive(DEFAULT_DOMAIN, w, &[], |_, _| 0.0, 0.25, 4096);
            assert_eq!(g, BinGrid::new(DEFAULT_DOMAIN, w), "width {w}");
        }
        // Breakpoints on the lattice change nothing either.
        let g = BinGrid::adaptive(DEFAULT_DOMAIN, 5.0, &[300.0, 400.0], |_, _| 0.0, 0.25, 4096);
        assert_eq!(g, BinGrid::new(DEFAULT_DOMAIN, 5.0));
    }

    #[test]
    fn box_edges_become_bin_edges_and_averages_are_exact() {
        let a = Spectrum::Box {
            lo: 350.3,
            hi: 351.3,
            value: 1.0,
        };
        let mut br = Vec::new();
        discontinuities(&a, &mut br);
        let g = BinGrid::adaptive(
            DEFAULT_DOMAIN,
            20.0,
            &br,
            |x, y| oscillation(&a, x, y),
            0.25,
            4096,
        );
        let i = g.index(350.8).unwrap();
        assert_eq!((g.edge(i), g.edge(i + 1)), (350.3, 351.3));
        for b in 0..g.len() {
            assert_eq!(oscillation(&a, g.edge(b), g.edge(b + 1)), 0.0);
            assert!(g.bin_width(b) <= 20.0 + 1e-4);
        }
    }

    #[test]
    fn narrow_gaussian_is_refined_until_it_varies_less_than_tol() {
        let s = Spectrum::gaussian_fwhm(500.0, 2.0, 1.0);
        let v = |x, y| oscillation(&s, x, y);
        let g = BinGrid::adaptive(DEFAULT_DOMAIN, 5.0, &[], v, 0.25, 4096);
        for b in 0..g.len() {
            assert!(v(g.edge(b), g.edge(b + 1)) <= 0.25, "bin {b}");
        }
        // A bounded number of extra bins per feature.
        assert!(g.len() < 100 + 40, "{}", g.len());
        // The budget stops refinement.
        let g = BinGrid::adaptive(DEFAULT_DOMAIN, 5.0, &[], v, 0.25, 101);
        assert!(g.len() <= 101);
    }

    #[test]
    fn oscillation_of_each_kind() {
        let t = Spectrum::Tabulated {
            xs: vec![400.0, 410.0, 420.0],
            ys: vec![1.0, 3.0, 2.0],
        };
        assert_eq!(oscillation(&t, 400.0, 420.0), 2.0);
        assert_eq!(oscillation(&t, 390.0, 405.0), 2.0);
        assert_eq!(oscillation(&t, 390.0, 400.0), 0.0);
        assert_eq!(oscillation(&t, 415.0, 420.0), 0.5);
        let b = Spectrum::Binned {
            lo: 400.0,
            width: 10.0,
            values: vec![1.0, 2.0, 4.0],
        };
        assert_eq!(oscillation(&b, 400.0, 410.0), 0.0);
        assert_eq!(oscillation(&b, 405.0, 425.0), 3.0);
        assert_eq!(oscillation(&b, 425.0, 440.0), 4.0);
        let mut br = Vec::new();
        discontinuities(&b, &mut br);
        assert_eq!(br, vec![400.0, 410.0, 420.0, 430.0]);
        let g = Spectrum::Gaussian {
            center: 500.0,
            sigma: 10.0,
            peak: 1.0,
        };
        assert!((oscillation(&g, 490.0, 500.0) - (1.0 - (-0.5f32).exp())).abs() < 1e-6);
    }
}
