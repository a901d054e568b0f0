//! Bin operators for the all-bins evaluator (Jung 6.5): a material acting on a spectrum that
//! holds one value per wavelength bin. `apply` moves light (λin → λout); `apply_transposed` moves
//! importance the other way.

/// out = M · t with M[o][i] the bin-averaged transfer from bin i to bin o.
#[derive(Clone, Debug)]
pub enum BinOperator {
    /// Wavelength-preserving reflectance.
    Diagonal { diag: Vec<f32> },
    /// M = diag(d) + emit ⊗ absorb (Jung eq. 5.7): O(bins).
    RankOne {
        diag: Vec<f32>,
        absorb: Vec<f32>,
        emit: Vec<f32>,
    },
    /// M = diag(d) + K, K[o·n + i] non-zero only for o > i (upper triangle of the measured
    /// matrix in (excitation, emission) order).
    Dense {
        diag: Vec<f32>,
        n: usize,
        k: Vec<f32>,
    },
}

impl BinOperator {
    pub fn len(&self) -> usize {
        match self {
            BinOperator::Diagonal { diag }
            | BinOperator::RankOne { diag, .. }
            | BinOperator::Dense { diag, .. } => diag.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// out = M · t.
    #[inline]
    pub fn apply(&self, t: &[f32], out: &mut [f32]) {
        match self {
            BinOperator::Diagonal { diag } => {
                for ((o, d), x) in out.iter_mut().zip(diag).zip(t) {
                    *o = d * x;
                }
            }
            BinOperator::RankOne { diag, absorb, emit } => {
                let s: f32 = absorb.iter().zip(t).map(|(a, x)| a * x).sum();
                for (((o, d), x), e) in out.iter_mut().zip(diag).zip(t).zip(emit) {
                    *o = d * x + e * s;
                }
            }
            BinOperator::Dense { diag, n, k } => {
                for o in 0..*n {
                    let row = &k[o * n..o * n + o];
                    let s: f32 = row.iter().zip(&t[..o]).map(|(a, b)| a * b).sum();
                    out[o] = diag[o] * t[o] + s;
                }
            }
        }
    }

    /// out = Mᵀ · w.
    #[inline]
    pub fn apply_transposed(&self, w: &[f32], out: &mut [f32]) {
        match self {
            BinOperator::Diagonal { .. } => self.apply(w, out),
            BinOperator::RankOne { diag, absorb, emit } => {
                let s: f32 = emit.iter().zip(w).map(|(e, x)| e * x).sum();
                for (((o, d), x), a) in out.iter_mut().zip(diag).zip(w).zip(absorb) {
                    *o = d * x + a * s;
                }
            }
            BinOperator::Dense { diag, n, k } => {
                for (i, o) in out.iter_mut().enumerate().take(*n) {
                    *o = diag[i] * w[i];
                }
                for o in 0..*n {
                    let wo = w[o];
                    if wo == 0.0 {
                        continue;
                    }
                    for i in 0..o {
                        out[i] += k[o * n + i] * wo;
                    }
                }
            }
        }
    }

    /// The dense n×n matrix (row = output bin), for tests and inspection.
    pub fn to_dense(&self) -> Vec<f32> {
        let n = self.len();
        let mut m = vec![0.0; n * n];
        let mut e = vec![0.0; n];
        let mut col = vec![0.0; n];
        for i in 0..n {
            e.iter_mut().for_each(|x| *x = 0.0);
            e[i] = 1.0;
            self.apply(&e, &mut col);
            for o in 0..n {
                m[o * n + i] = col[o];
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn rank_one_matches_dense_form() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        for n in [1usize, 7, 100] {
            let r: Vec<f32> = (0..n).map(|_| rng.random()).collect();
            let a: Vec<f32> = (0..n).map(|_| rng.random()).collect();
            let e: Vec<f32> = (0..n).map(|_| rng.random()).collect();
            let op = BinOperator::RankOne {
                diag: r.clone(),
                absorb: a.clone(),
                emit: e.clone(),
            };
            // Explicit dense M = diag(r) + e aᵀ.
            let mut m = vec![0.0f64; n * n];
            for o in 0..n {
                for i in 0..n {
                    m[o * n + i] =
                        e[o] as f64 * a[i] as f64 + if o == i { r[i] as f64 } else { 0.0 };
                }
            }
            let t: Vec<f32> = (0..n).map(|_| rng.random::<f32>() * 3.0).collect();
            let mut out = vec![0.0; n];
            op.apply(&t, &mut out);
            let mut outt = vec![0.0; n];
            op.apply_transposed(&t, &mut outt);
            for o in 0..n {
                let want: f64 = (0..n).map(|i| m[o * n + i] * t[i] as f64).sum();
                let want_t: f64 = (0..n).map(|i| m[i * n + o] * t[i] as f64).sum();
                assert!((out[o] as f64 - want).abs() < 1e-4 * want.abs().max(1.0));
                assert!((outt[o] as f64 - want_t).abs() < 1e-4 * want_t.abs().max(1.0));
            }
            let dense = op.to_dense();
            let k: Vec<f32> = (0..n * n)
                .map(|j| if j / n > j % n { dense[j] } else { 0.0 })
                .collect();
            let diag: Vec<f32> = (0..n).map(|i| dense[i * n + i]).collect();
            // Dense form of only the upper-triangle part agrees on lower-triangular inputs.
            let d = BinOperator::Dense { diag, n, k };
            let mut o1 = vec![0.0; n];
            d.apply(&t, &mut o1);
            for o in 0..n {
                let want: f64 = (0..=o).map(|i| m[o * n + i] * t[i] as f64).sum();
                assert!((o1[o] as f64 - want).abs() < 1e-4 * want.abs().max(1.0));
            }
            // Transposition identity: wᵀ(M t) = (Mᵀ w)ᵀ t.
            let w: Vec<f32> = (0..n).map(|_| rng.random()).collect();
            let mut dt = vec![0.0; n];
            d.apply_transposed(&w, &mut dt);
            let lhs: f32 = w.iter().zip(&o1).map(|(a, b)| a * b).sum();
            let rhs: f32 = dt.iter().zip(&t).map(|(a, b)| a * b).sum();
            assert!((lhs - rhs).abs() < 1e-3 * lhs.abs().max(1.0));
        }
    }
}
