//! Bin operators restricted to the non-zero bins of their input (see `evaluate::Support`): the
//! all-bins evaluator then pays for the bins a path actually carries, not for the whole domain.

use super::evaluate::{Support, dot};
use crate::material::BinOperator;

/// A material's bin operator with the supports of its parts.
pub struct SupportedOp {
    pub op: BinOperator,
    diag: Support,
    absorb: Support,
    emit: Support,
}

#[inline]
fn range(v: &mut [f32], s: Support) -> &mut [f32] {
    &mut v[s.lo as usize..s.hi as usize]
}

impl SupportedOp {
    pub fn new(op: BinOperator) -> Self {
        let (diag, absorb, emit) = match &op {
            BinOperator::Diagonal { diag } => (Support::of(diag), Support::EMPTY, Support::EMPTY),
            BinOperator::RankOne { diag, absorb, emit } => {
                (Support::of(diag), Support::of(absorb), Support::of(emit))
            }
            BinOperator::Dense { diag, .. } => (Support::of(diag), Support::EMPTY, Support::EMPTY),
        };
        SupportedOp {
            op,
            diag,
            absorb,
            emit,
        }
    }

    /// out = M·t (light direction), given the support of t; returns the support of out (a
    /// superset of its non-zero bins; empty means out = 0).
    #[inline]
    pub fn apply(&self, t: &[f32], ts: Support, out: &mut [f32]) -> Support {
        match &self.op {
            BinOperator::Diagonal { diag } => {
                out.fill(0.0);
                let s = ts.intersect(self.diag);
                if s.is_empty() {
                    return Support::EMPTY;
                }
                let (lo, hi) = (s.lo as usize, s.hi as usize);
                for ((o, d), x) in out[lo..hi].iter_mut().zip(&diag[lo..hi]).zip(&t[lo..hi]) {
                    *o = d * x;
                }
                s
            }
            // M·t = d∘t + e·(aᵀt) (docs/design.md §4, corrected Alg. 6 line 4).
            BinOperator::RankOne { diag, absorb, emit } => {
                out.fill(0.0);
                let sd = ts.intersect(self.diag);
                if !sd.is_empty() {
                    let (lo, hi) = (sd.lo as usize, sd.hi as usize);
                    for ((o, d), x) in out[lo..hi].iter_mut().zip(&diag[lo..hi]).zip(&t[lo..hi]) {
                        *o = d * x;
                    }
                }
                let sa = ts.intersect(self.absorb);
                let k = if sa.is_empty() {
                    0.0
                } else {
                    let (lo, hi) = (sa.lo as usize, sa.hi as usize);
                    dot(&absorb[lo..hi], &t[lo..hi])
                };
                if k == 0.0 {
                    return sd;
                }
                let (lo, hi) = (self.emit.lo as usize, self.emit.hi as usize);
                for (o, e) in range(out, self.emit).iter_mut().zip(&emit[lo..hi]) {
                    *o += e * k;
                }
                sd.union(self.emit)
            }
            BinOperator::Dense { .. } => {
                self.op.apply(t, out);
                Support::of(out)
            }
        }
    }

    /// rows_out = Mᵀ·rows_in for three rows [X | Y | Z] of length n (importance direction).
    #[inline]
    pub fn apply_transposed3(
        &self,
        rows_in: &[f32],
        ws: Support,
        rows_out: &mut [f32],
        n: usize,
    ) -> Support {
        match &self.op {
            BinOperator::RankOne { diag, absorb, emit } => {
                rows_out.fill(0.0);
                let sd = ws.intersect(self.diag);
                let se = ws.intersect(self.emit);
                let mut any_k = false;
                for c in 0..3 {
                    let w = &rows_in[c * n..(c + 1) * n];
                    let out = &mut rows_out[c * n..(c + 1) * n];
                    if !sd.is_empty() {
                        let (lo, hi) = (sd.lo as usize, sd.hi as usize);
                        for ((o, d), x) in out[lo..hi].iter_mut().zip(&diag[lo..hi]).zip(&w[lo..hi])
                        {
                            *o = d * x;
                        }
                    }
                    // Mᵀ·w = d∘w + a·(eᵀw).
                    let k = if se.is_empty() {
                        0.0
                    } else {
                        let (lo, hi) = (se.lo as usize, se.hi as usize);
                        dot(&emit[lo..hi], &w[lo..hi])
                    };
                    if k != 0.0 {
                        any_k = true;
                        let (lo, hi) = (self.absorb.lo as usize, self.absorb.hi as usize);
                        for (o, a) in range(out, self.absorb).iter_mut().zip(&absorb[lo..hi]) {
                            *o += a * k;
                        }
                    }
                }
                if any_k { sd.union(self.absorb) } else { sd }
            }
            BinOperator::Diagonal { diag } => {
                rows_out.fill(0.0);
                let s = ws.intersect(self.diag);
                if s.is_empty() {
                    return s;
                }
                let (lo, hi) = (s.lo as usize, s.hi as usize);
                for c in 0..3 {
                    let (w, out) = (&rows_in[c * n..(c + 1) * n], &mut rows_out[c * n..]);
                    for ((o, d), x) in out[lo..hi].iter_mut().zip(&diag[lo..hi]).zip(&w[lo..hi]) {
                        *o = d * x;
                    }
                }
                s
            }
            BinOperator::Dense { .. } => {
                for c in 0..3 {
                    self.op.apply_transposed(
                        &rows_in[c * n..(c + 1) * n],
                        &mut rows_out[c * n..(c + 1) * n],
                    );
                }
                Support::of_rows(rows_out, n)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The support-restricted operators equal the full ones on vectors with zero bands.
    #[test]
    fn supported_ops_match_full_ops() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let n = 40;
        let band = |rng: &mut rand_pcg::Pcg64Mcg, lo: usize, hi: usize| -> Vec<f32> {
            (0..n)
                .map(|i| {
                    if (lo..hi).contains(&i) {
                        rng.random()
                    } else {
                        0.0
                    }
                })
                .collect()
        };
        for _ in 0..50 {
            let (a0, e0, d0, t0) = (
                rng.random_range(0..30),
                rng.random_range(0..30),
                rng.random_range(0..30),
                rng.random_range(0..30),
            );
            let ops = [
                BinOperator::RankOne {
                    diag: band(&mut rng, d0, d0 + 10),
                    absorb: band(&mut rng, a0, a0 + 10),
                    emit: band(&mut rng, e0, e0 + 10),
                },
                BinOperator::Diagonal {
                    diag: band(&mut rng, d0, d0 + 10),
                },
                BinOperator::Dense {
                    diag: band(&mut rng, d0, d0 + 10),
                    n,
                    k: (0..n * n)
                        .map(|j| if j / n > j % n { rng.random() } else { 0.0 })
                        .collect(),
                },
            ];
            for op in ops {
                let so = SupportedOp::new(op.clone());
                let t = band(&mut rng, t0, t0 + 10);
                let (mut want, mut got) = (vec![0.0; n], vec![1.0; n]);
                op.apply(&t, &mut want);
                let s = so.apply(&t, Support::of(&t), &mut got);
                for (a, b) in want.iter().zip(&got) {
                    assert!((a - b).abs() <= 1e-5 * a.abs().max(1.0), "{a} vs {b}");
                }
                assert!(Support::of(&want).is_empty() || s.union(Support::of(&want)) == s);
                let rows: Vec<f32> = (0..3).flat_map(|_| band(&mut rng, t0, t0 + 10)).collect();
                let mut want = vec![0.0; 3 * n];
                for c in 0..3 {
                    op.apply_transposed(&rows[c * n..(c + 1) * n], &mut want[c * n..(c + 1) * n]);
                }
                let mut got = vec![1.0; 3 * n];
                so.apply_transposed3(&rows, Support::of_rows(&rows, n), &mut got, n);
                for (a, b) in want.iter().zip(&got) {
                    assert!((a - b).abs() <= 1e-5 * a.abs().max(1.0));
                }
            }
        }
    }
}
