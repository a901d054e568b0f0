//! Connections of the all-bins BDPT: the directional factors (f_dir = 1/π, G, W_e) are scalars
//! and the spectral factor is an inner product of an importance row with a light spectrum, so a
//! connection costs O(bins) whatever the path length.

use super::Vertex;
use crate::scene::Scene;
use crate::transport::VertexKind;
use glam::Vec3;

/// Σ a[i]·b[i], with eight independent partial sums so the loop vectorises.
#[inline]
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    acc.iter().sum::<f32>() + s
}

/// XYZ = (w_X·t, w_Y·t, w_Z·t) for importance rows stored as [X | Y | Z], each `t.len()` long.
#[inline]
pub fn dot3(rows: &[f32], t: &[f32]) -> Vec3 {
    let n = t.len();
    Vec3::new(
        dot(&rows[..n], t),
        dot(&rows[n..2 * n], t),
        dot(&rows[2 * n..3 * n], t),
    )
}

/// The bins [lo, hi) outside which a spectrum or importance row is zero. Narrow spectra
/// (fluorescent bands, UV lights) make most connections disjoint: they cost O(1) and no ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Support {
    pub lo: u32,
    pub hi: u32,
}

impl Support {
    pub const EMPTY: Support = Support { lo: 0, hi: 0 };
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.hi <= self.lo
    }
    #[inline]
    pub fn intersect(self, o: Support) -> Support {
        Support {
            lo: self.lo.max(o.lo),
            hi: self.hi.min(o.hi),
        }
    }
    #[inline]
    pub fn union(self, o: Support) -> Support {
        if self.is_empty() {
            o
        } else if o.is_empty() {
            self
        } else {
            Support {
                lo: self.lo.min(o.lo),
                hi: self.hi.max(o.hi),
            }
        }
    }
    /// Support of one vector (empty when it is zero in every bin).
    #[inline]
    pub fn of(v: &[f32]) -> Support {
        match v.iter().position(|&x| x != 0.0) {
            None => Support::EMPTY,
            Some(lo) => {
                let hi = v.iter().rposition(|&x| x != 0.0).unwrap() + 1;
                Support {
                    lo: lo as u32,
                    hi: hi as u32,
                }
            }
        }
    }
    /// Union of the supports of three rows [X | Y | Z] of length `n`.
    #[inline]
    pub fn of_rows(rows: &[f32], n: usize) -> Support {
        Support::of(&rows[..n])
            .union(Support::of(&rows[n..2 * n]))
            .union(Support::of(&rows[2 * n..3 * n]))
    }
}

/// `dot3` restricted to the bins of `on`.
#[inline]
pub fn dot3_on(rows: &[f32], t: &[f32], on: Support) -> Vec3 {
    let n = t.len();
    let (lo, hi) = (on.lo as usize, on.hi as usize);
    Vec3::new(
        dot(&rows[lo..hi], &t[lo..hi]),
        dot(&rows[n + lo..n + hi], &t[lo..hi]),
        dot(&rows[2 * n + lo..2 * n + hi], &t[lo..hi]),
    )
}

/// Directional factor of vertex `v` for light leaving (or importance arriving) in the unit
/// direction `wi`, given the other neighbour `prev` on its own sub-path: the vertex's lobe for a
/// scattering vertex, the emitter's directional profile (1 on an emitting side) for a light
/// origin.
#[inline]
pub fn f_dir(scene: &Scene, v: &Vertex, prev: Option<&Vertex>, wi: Vec3) -> f32 {
    match v.kind {
        VertexKind::Light => {
            let l = &scene.lights[v.light as usize];
            if l.emits_towards(v.n, wi) { 1.0 } else { 0.0 }
        }
        VertexKind::Surface | VertexKind::Medium => {
            let Some(prev) = prev else { return 0.0 };
            let (wo, _) = v.towards(prev);
            v.scattering(scene).eval(wo, wi)
        }
        VertexKind::Camera => 0.0,
    }
}
