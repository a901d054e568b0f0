//! Per-lane spectral arithmetic: one value per sampled wavelength of a path.
//!
//! A path carries 1 wavelength (`f32`, pt-mono), 4 (`Vec4`, the hero hot path) or up to
//! [`MAX_LANES`] ([`LaneArr`]). The integrators are written once, generic over [`Lanes`]; lanes
//! past the active count are kept at zero.

use super::Spectrum;
use super::cie::{cmf, cmf4};
use glam::{BVec4A, Vec3, Vec4};
use std::ops::{Add, AddAssign, Mul, MulAssign};

/// Largest lane count (`IntegratorOptions::validate` allows 1–16).
pub const MAX_LANES: usize = 16;

/// Values at the sampled wavelengths of a path.
pub trait Lanes:
    Copy
    + Add<Output = Self>
    + AddAssign
    + Mul<Output = Self>
    + MulAssign
    + Mul<f32, Output = Self>
    + MulAssign<f32>
{
    const ZERO: Self;
    fn splat_n(n: usize, v: f32) -> Self;
    /// Build from `f(j)` for the first `n` lanes, evaluated in lane order.
    fn from_fn(n: usize, f: impl FnMut(usize) -> f32) -> Self;
    /// Like `from_fn` for a function returning two values per lane.
    fn from_fn2(n: usize, f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self);
    /// `v` where lo ≤ λ ≤ hi, else 0 (a box spectrum).
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self;
    fn lane(&self, j: usize) -> f32;
    fn max_lane(self) -> f32;
    fn dot(self, o: Self) -> f32;
    /// The short piecewise-linear table (`xs`, `ys`) at every lane (the first `n`): the same
    /// values as [`tabulated_short`] lane by lane.
    fn tabulated_short(self, n: usize, xs: &[f32], ys: &[f32]) -> Self;

    /// Three values per lane (e.g. the colour-matching functions), one call of `f` per lane.
    fn from_fn3(n: usize, f: impl FnMut(usize) -> Vec3) -> [Self; 3];

    /// The colour-matching functions (x̄, ȳ, z̄) at every lane: [`cmf`] lane by lane.
    #[inline(always)]
    fn cmf(self, n: usize) -> [Self; 3] {
        Self::from_fn3(n, |j| cmf(self.lane(j)))
    }
}

impl Lanes for f32 {
    const ZERO: Self = 0.0;
    #[inline(always)]
    fn splat_n(_: usize, v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn from_fn(_: usize, mut f: impl FnMut(usize) -> f32) -> Self {
        f(0)
    }
    #[inline(always)]
    fn from_fn2(_: usize, mut f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self) {
        f(0)
    }
    #[inline(always)]
    fn from_fn3(_: usize, mut f: impl FnMut(usize) -> Vec3) -> [Self; 3] {
        f(0).to_array()
    }
    #[inline(always)]
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self {
        if self >= lo && self <= hi { v } else { 0.0 }
    }
    #[inline(always)]
    fn lane(&self, _: usize) -> f32 {
        *self
    }
    #[inline(always)]
    fn max_lane(self) -> f32 {
        self
    }
    #[inline(always)]
    fn dot(self, o: Self) -> f32 {
        self * o
    }
    #[inline(always)]
    fn tabulated_short(self, _: usize, xs: &[f32], ys: &[f32]) -> Self {
        tabulated_short(xs, ys, self)
    }
}

impl Lanes for Vec4 {
    const ZERO: Self = Vec4::ZERO;
    #[inline(always)]
    fn splat_n(_: usize, v: f32) -> Self {
        Vec4::splat(v)
    }
    #[inline(always)]
    fn from_fn(_: usize, mut f: impl FnMut(usize) -> f32) -> Self {
        let a = f(0);
        let b = f(1);
        let c = f(2);
        let d = f(3);
        Vec4::new(a, b, c, d)
    }
    #[inline(always)]
    fn from_fn2(_: usize, mut f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self) {
        let a = f(0);
        let b = f(1);
        let c = f(2);
        let d = f(3);
        (Vec4::new(a.0, b.0, c.0, d.0), Vec4::new(a.1, b.1, c.1, d.1))
    }
    #[inline(always)]
    fn from_fn3(_: usize, mut f: impl FnMut(usize) -> Vec3) -> [Self; 3] {
        let (a, b, c, d) = (f(0), f(1), f(2), f(3));
        [
            Vec4::new(a.x, b.x, c.x, d.x),
            Vec4::new(a.y, b.y, c.y, d.y),
            Vec4::new(a.z, b.z, c.z, d.z),
        ]
    }
    #[inline(always)]
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self {
        let inside = self.cmpge(Vec4::splat(lo)) & self.cmple(Vec4::splat(hi));
        Vec4::select(inside, Vec4::splat(v), Vec4::ZERO)
    }
    #[inline(always)]
    fn lane(&self, j: usize) -> f32 {
        self[j]
    }
    #[inline(always)]
    fn max_lane(self) -> f32 {
        self.max_element()
    }
    #[inline(always)]
    fn dot(self, o: Self) -> f32 {
        Vec4::dot(self, o)
    }
    #[inline(always)]
    fn tabulated_short(self, _: usize, xs: &[f32], ys: &[f32]) -> Self {
        tabulated_short4(xs, ys, self)
    }
    #[inline(always)]
    fn cmf(self, _: usize) -> [Self; 3] {
        cmf4(self)
    }
}

/// Up to 16 lanes for lane counts other than 1 and 4 (the generic fallback).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneArr(pub [f32; MAX_LANES]);

impl Add for LaneArr {
    type Output = Self;
    #[inline]
    fn add(mut self, o: Self) -> Self {
        self += o;
        self
    }
}
impl AddAssign for LaneArr {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
    }
}
impl Mul for LaneArr {
    type Output = Self;
    #[inline]
    fn mul(mut self, o: Self) -> Self {
        self *= o;
        self
    }
}
impl MulAssign for LaneArr {
    #[inline]
    fn mul_assign(&mut self, o: Self) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a *= b;
        }
    }
}
impl Mul<f32> for LaneArr {
    type Output = Self;
    #[inline]
    fn mul(mut self, s: f32) -> Self {
        self *= s;
        self
    }
}
impl MulAssign<f32> for LaneArr {
    #[inline]
    fn mul_assign(&mut self, s: f32) {
        for a in &mut self.0 {
            *a *= s;
        }
    }
}

impl Lanes for LaneArr {
    const ZERO: Self = LaneArr([0.0; MAX_LANES]);
    #[inline]
    fn splat_n(n: usize, v: f32) -> Self {
        let mut a = [0.0; MAX_LANES];
        a[..n].fill(v);
        LaneArr(a)
    }
    #[inline]
    fn from_fn(n: usize, mut f: impl FnMut(usize) -> f32) -> Self {
        let mut a = [0.0; MAX_LANES];
        for (j, x) in a[..n].iter_mut().enumerate() {
            *x = f(j);
        }
        LaneArr(a)
    }
    #[inline]
    fn from_fn2(n: usize, mut f: impl FnMut(usize) -> (f32, f32)) -> (Self, Self) {
        let (mut a, mut b) = ([0.0; MAX_LANES], [0.0; MAX_LANES]);
        for j in 0..n {
            (a[j], b[j]) = f(j);
        }
        (LaneArr(a), LaneArr(b))
    }
    #[inline]
    fn from_fn3(n: usize, mut f: impl FnMut(usize) -> Vec3) -> [Self; 3] {
        let [mut x, mut y, mut z] = [[0.0; MAX_LANES]; 3];
        let lanes = x.iter_mut().zip(&mut y).zip(&mut z).take(n);
        for (j, ((x, y), z)) in lanes.enumerate() {
            let v = f(j);
            (*x, *y, *z) = (v.x, v.y, v.z);
        }
        [LaneArr(x), LaneArr(y), LaneArr(z)]
    }
    #[inline]
    fn box_mask(self, lo: f32, hi: f32, v: f32) -> Self {
        LaneArr(self.0.map(|l| if l >= lo && l <= hi { v } else { 0.0 }))
    }
    #[inline]
    fn lane(&self, j: usize) -> f32 {
        self.0[j]
    }
    #[inline]
    fn max_lane(self) -> f32 {
        self.0.iter().fold(0.0f32, |m, &x| m.max(x))
    }
    #[inline]
    fn dot(self, o: Self) -> f32 {
        self.0.iter().zip(o.0).map(|(a, b)| a * b).sum()
    }
    #[inline]
    fn tabulated_short(self, n: usize, xs: &[f32], ys: &[f32]) -> Self {
        Self::from_fn(n, |j| tabulated_short(xs, ys, self.0[j]))
    }
}

impl Spectrum {
    /// The spectrum at every lane of `lambda` (the first `n` lanes); constant and box spectra
    /// without per-lane work. Equal to [`Spectrum::eval`] lane by lane.
    #[inline(always)]
    pub fn eval_lanes<L: Lanes>(&self, n: usize, lambda: L) -> L {
        match self {
            Spectrum::Constant(v) => L::splat_n(n, *v),
            Spectrum::Box { lo, hi, value } => lambda.box_mask(*lo, *hi, *value),
            Spectrum::Tabulated { xs, ys } if xs.len() <= 16 => lambda.tabulated_short(n, xs, ys),
            _ => L::from_fn(n, |j| self.eval(lambda.lane(j))),
        }
    }
}

/// `Spectrum::Tabulated` evaluation for short tables: the knot found by an inlined linear scan,
/// the same knot as `Spectrum::eval`'s (first knot above λ, clamped to 1..n−1).
#[inline(always)]
fn tabulated_short(xs: &[f32], ys: &[f32], l: f32) -> f32 {
    super::tabulated(xs, ys, l, |xs, l| {
        let mut i = 1;
        while i < xs.len() - 1 && xs[i] <= l {
            i += 1;
        }
        i
    })
}

/// [`tabulated_short`] at four wavelengths at once, with the same operations per lane (so the
/// same bits): each lane's segment is the one the scalar scan stops at (it advances while
/// `xs[i] <= λ`), selected knot by knot instead of by a branchy scan per lane.
#[inline(always)]
fn tabulated_short4(xs: &[f32], ys: &[f32], l: Vec4) -> Vec4 {
    let n = xs.len();
    if n == 0 {
        return Vec4::ZERO;
    }
    // `l < xs[0] || l > xs[n - 1]`: false for NaN, as in the scalar test.
    let outside = l.cmplt(Vec4::splat(xs[0])) | l.cmpgt(Vec4::splat(xs[n - 1]));
    if n == 1 {
        return Vec4::select(outside, Vec4::ZERO, Vec4::splat(ys[0]));
    }
    let (mut x0, mut x1) = (Vec4::splat(xs[0]), Vec4::splat(xs[1]));
    let (mut y0, mut y1) = (Vec4::splat(ys[0]), Vec4::splat(ys[1]));
    // Lanes whose scan is still advancing (at knot i: xs[1..=i] all <= λ).
    let mut going = BVec4A::splat(true);
    for i in 1..n - 1 {
        going &= Vec4::splat(xs[i]).cmple(l);
        x0 = Vec4::select(going, Vec4::splat(xs[i]), x0);
        x1 = Vec4::select(going, Vec4::splat(xs[i + 1]), x1);
        y0 = Vec4::select(going, Vec4::splat(ys[i]), y0);
        y1 = Vec4::select(going, Vec4::splat(ys[i + 1]), y1);
    }
    let t = (l - x0) / (x1 - x0);
    let v = y0 * (1.0 - t) + y1 * t;
    Vec4::select(outside, Vec4::ZERO, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_lane_tables_are_the_scalar_tables() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
        for n in 1..=16 {
            for _ in 0..200 {
                let mut x = rng.random_range(300.0..500.0f32);
                let xs: Vec<f32> = (0..n)
                    .map(|_| {
                        x += rng.random_range(0.01..60.0f32);
                        x
                    })
                    .collect();
                let ys: Vec<f32> = (0..n).map(|_| rng.random::<f32>()).collect();
                // Knots, the ends, outside and NaN as well as random wavelengths.
                let mut ls = xs.clone();
                ls.extend([xs[0] - 1.0, xs[n - 1] + 1.0, f32::NAN, 0.0]);
                ls.extend((0..40).map(|_| rng.random_range(xs[0] - 5.0..xs[n - 1] + 5.0)));
                for w in ls.windows(4) {
                    let l = Vec4::from_slice(w);
                    let got = l.tabulated_short(4, &xs, &ys);
                    for j in 0..4 {
                        let want = tabulated_short(&xs, &ys, l[j]);
                        assert_eq!(got[j].to_bits(), want.to_bits(), "{xs:?} {}", l[j]);
                    }
                }
            }
        }
    }

    #[test]
    fn lane_types_agree_with_scalar_evaluation() {
        let s = Spectrum::Tabulated {
            xs: vec![360.0, 470.0, 510.0, 570.0, 610.0, 830.0],
            ys: vec![0.05, 0.05, 0.6, 0.6, 0.05, 0.05],
        };
        let b = Spectrum::Box {
            lo: 450.0,
            hi: 600.0,
            value: 2.0,
        };
        for k in 0..=600 {
            let l = 300.0 + k as f32;
            for spec in [&s, &b] {
                let want = spec.eval(l);
                assert_eq!(spec.eval_lanes(1, l), want, "{l}");
                assert_eq!(spec.eval_lanes(4, Vec4::splat(l)).lane(3), want, "{l}");
                let arr = LaneArr::splat_n(3, l);
                assert_eq!(spec.eval_lanes(3, arr).lane(2), want, "{l}");
            }
        }
        // Inactive generic lanes stay zero.
        assert_eq!(LaneArr::splat_n(3, 1.0).lane(3), 0.0);
        let [x, y, z] = Vec4::from_fn3(4, |j| Vec3::new(j as f32, 10.0 * j as f32, -1.0));
        assert_eq!((x.lane(2), y.lane(3), z.lane(1)), (2.0, 30.0, -1.0));
        let [x, _, z] = LaneArr::from_fn3(2, |j| Vec3::new(j as f32, 0.0, 5.0));
        assert_eq!((x.lane(1), z.lane(1), z.lane(2)), (1.0, 5.0, 0.0));
    }
}
