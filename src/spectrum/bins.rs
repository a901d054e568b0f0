//! Wavelength bins of a given width over a domain (the last bin may be narrower).

use super::Domain;

#[derive(Clone, Debug, PartialEq)]
pub struct BinGrid {
    pub domain: Domain,
    pub width: f32,
    n: usize,
}

impl BinGrid {
    pub fn new(domain: Domain, width: f32) -> Self {
        let n = ((domain.width() / width) - 1e-4).ceil().max(1.0) as usize;
        BinGrid { domain, width, n }
    }
    pub fn len(&self) -> usize {
        self.n
    }
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
    /// Lower edge of bin `i` (`edge(len())` is the domain's upper end).
    pub fn edge(&self, i: usize) -> f32 {
        (self.domain.min + i as f32 * self.width).min(self.domain.max)
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
        Some((((l - self.domain.min) / self.width) as usize).min(self.n - 1))
    }
}
