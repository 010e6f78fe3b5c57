//! Small dense linear algebra in f64 (row-major), for matrices up to a few hundred rows.
//!
//! Large decompositions (the MRT SVDs) use faer in the transport crate; the SH bakes need
//! only symmetric eigendecompositions of product matrices (at most 64×64 for order 8),
//! where cyclic Jacobi is simple, deterministic and accurate to a few ulps in every
//! eigenvalue — including the tiny and negative ones that SH log clipping inspects.

/// Symmetric eigendecomposition `A = V · diag(λ) · Vᵀ`.
#[derive(Debug, Clone)]
pub struct SymEigen {
    /// Dimension.
    pub n: usize,
    /// Eigenvalues in descending order.
    pub values: Vec<f64>,
    /// Eigenvectors as columns, row-major `n × n`: `vectors[r * n + c]` is component `r`
    /// of eigenvector `c`. Sign canonicalised: the component of largest magnitude
    /// (first on ties) is positive.
    pub vectors: Vec<f64>,
}

impl SymEigen {
    /// Decomposes the symmetric matrix `a` (row-major `n × n`; only symmetric input is
    /// meaningful — the upper triangle is used).
    pub fn new(a: &[f64], n: usize) -> Self {
        assert_eq!(a.len(), n * n);
        let mut m = a.to_vec();
        for i in 0..n {
            for j in 0..i {
                m[i * n + j] = m[j * n + i];
            }
        }
        let mut v = vec![0.0; n * n];
        for i in 0..n {
            v[i * n + i] = 1.0;
        }
        let scale = m.iter().map(|x| x * x).sum::<f64>().sqrt();
        if scale > 0.0 && n > 1 {
            for _sweep in 0..100 {
                let off: f64 = (0..n)
                    .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
                    .map(|(i, j)| m[i * n + j] * m[i * n + j])
                    .sum();
                if off.sqrt() <= 1e-17 * scale {
                    break;
                }
                for p in 0..n {
                    for q in p + 1..n {
                        let apq = m[p * n + q];
                        if apq.abs() <= 1e-300 {
                            continue;
                        }
                        let app = m[p * n + p];
                        let aqq = m[q * n + q];
                        // Rutishauser's stable rotation.
                        let theta = (aqq - app) / (2.0 * apq);
                        let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                        let t = if theta == 0.0 { 1.0 } else { t };
                        let c = 1.0 / (t * t + 1.0).sqrt();
                        let s = t * c;
                        let tau = s / (1.0 + c);
                        m[p * n + p] = app - t * apq;
                        m[q * n + q] = aqq + t * apq;
                        m[p * n + q] = 0.0;
                        m[q * n + p] = 0.0;
                        for r in 0..n {
                            if r != p && r != q {
                                let arp = m[r * n + p];
                                let arq = m[r * n + q];
                                let nrp = arp - s * (arq + tau * arp);
                                let nrq = arq + s * (arp - tau * arq);
                                m[r * n + p] = nrp;
                                m[p * n + r] = nrp;
                                m[r * n + q] = nrq;
                                m[q * n + r] = nrq;
                            }
                        }
                        for r in 0..n {
                            let vrp = v[r * n + p];
                            let vrq = v[r * n + q];
                            v[r * n + p] = vrp - s * (vrq + tau * vrp);
                            v[r * n + q] = vrq + s * (vrp - tau * vrq);
                        }
                    }
                }
            }
        }
        // Sort descending (stable on index for determinism).
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| m[b * n + b].total_cmp(&m[a * n + a]).then(a.cmp(&b)));
        let values: Vec<f64> = order.iter().map(|&k| m[k * n + k]).collect();
        let mut vectors = vec![0.0; n * n];
        for (c, &k) in order.iter().enumerate() {
            let mut best = 0usize;
            for r in 0..n {
                if v[r * n + k].abs() > v[best * n + k].abs() + 1e-14 {
                    best = r;
                }
            }
            let sign = if v[best * n + k] < 0.0 { -1.0 } else { 1.0 };
            for r in 0..n {
                vectors[r * n + c] = sign * v[r * n + k];
            }
        }
        Self { n, values, vectors }
    }

    /// Largest eigenvalue.
    pub fn max_value(&self) -> f64 {
        self.values.first().copied().unwrap_or(0.0)
    }

    /// Computes `V · diag(h(λ)) · Vᵀ · x` without forming the matrix.
    pub fn apply_fn(&self, x: &[f64], mut h: impl FnMut(f64) -> f64, out: &mut [f64]) {
        let n = self.n;
        out[..n].iter_mut().for_each(|o| *o = 0.0);
        for c in 0..n {
            let mut proj = 0.0;
            for r in 0..n {
                proj += self.vectors[r * n + c] * x[r];
            }
            let w = h(self.values[c]) * proj;
            if w != 0.0 {
                for r in 0..n {
                    out[r] += w * self.vectors[r * n + c];
                }
            }
        }
    }
}

/// Solves the square system `A x = b` by Gaussian elimination with partial pivoting.
/// Returns `None` for a (numerically) singular matrix.
pub fn solve(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut x = b.to_vec();
    let scale = m.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| m[i * n + col].abs().total_cmp(&m[j * n + col].abs()))?;
        if m[piv * n + col].abs() <= 1e-14 * scale {
            return None;
        }
        if piv != col {
            for k in 0..n {
                m.swap(piv * n + k, col * n + k);
            }
            x.swap(piv, col);
        }
        for r in col + 1..n {
            let f = m[r * n + col] / m[col * n + col];
            if f != 0.0 {
                for k in col..n {
                    m[r * n + k] -= f * m[col * n + k];
                }
                x[r] -= f * x[col];
            }
        }
    }
    for col in (0..n).rev() {
        let mut s = x[col];
        for k in col + 1..n {
            s -= m[col * n + k] * x[k];
        }
        x[col] = s / m[col * n + col];
    }
    Some(x)
}

/// Linear least squares `min ‖A c − y‖₂` for a tall `rows × cols` matrix via the normal
/// equations in f64 (fine for the tiny, well-conditioned polynomial fits it is used for).
pub fn least_squares(a: &[f64], y: &[f64], rows: usize, cols: usize) -> Option<Vec<f64>> {
    let mut ata = vec![0.0; cols * cols];
    let mut aty = vec![0.0; cols];
    for r in 0..rows {
        for i in 0..cols {
            aty[i] += a[r * cols + i] * y[r];
            for j in 0..cols {
                ata[i * cols + j] += a[r * cols + i] * a[r * cols + j];
            }
        }
    }
    solve(&ata, &aty, cols)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::ItemRng;

    fn random_sym(n: usize, seed: u64) -> Vec<f64> {
        let mut r = ItemRng::new(seed, 99, n as u64);
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in i..n {
                let v = r.next_f64() * 2.0 - 1.0;
                a[i * n + j] = v;
                a[j * n + i] = v;
            }
        }
        a
    }

    #[test]
    fn reconstructs_and_orthonormal() {
        for n in [1usize, 2, 5, 16, 49, 64] {
            let a = random_sym(n, 3);
            let e = SymEigen::new(&a, n);
            for w in e.values.windows(2) {
                assert!(w[0] >= w[1]);
            }
            for i in 0..n {
                for j in 0..n {
                    let mut rec = 0.0;
                    let mut dot = 0.0;
                    for k in 0..n {
                        rec += e.vectors[i * n + k] * e.values[k] * e.vectors[j * n + k];
                        dot += e.vectors[k * n + i] * e.vectors[k * n + j];
                    }
                    assert!((rec - a[i * n + j]).abs() < 1e-12, "n={n}");
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((dot - want).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn known_spectrum_and_rank_deficiency() {
        // rank-1 matrix u uᵀ: one eigenvalue ‖u‖², the rest exactly ~0.
        let u = [1.0, 2.0, 3.0, 4.0];
        let n = 4;
        let mut a = vec![0.0; 16];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = u[i] * u[j];
            }
        }
        let e = SymEigen::new(&a, n);
        assert!((e.values[0] - 30.0).abs() < 1e-12);
        for v in &e.values[1..] {
            assert!(v.abs() < 1e-12);
        }
        // Eigenvector sign canonical: largest component positive.
        assert!(e.vectors[3 * n] > 0.0);
    }

    #[test]
    fn solve_and_lstsq() {
        let a = [4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0];
        let x = solve(&a, &[1.0, 2.0, 3.0], 3).unwrap();
        for r in 0..3 {
            let s: f64 = (0..3).map(|c| a[r * 3 + c] * x[c]).sum();
            assert!((s - [1.0, 2.0, 3.0][r]).abs() < 1e-13);
        }
        assert!(solve(&[1.0, 2.0, 2.0, 4.0], &[1.0, 1.0], 2).is_none());
        // exact quadratic fit
        let xs: Vec<f64> = (0..20).map(|i| i as f64 / 19.0).collect();
        let mut a = vec![];
        let mut y = vec![];
        for &x in &xs {
            a.extend_from_slice(&[1.0, x, x * x]);
            y.push(0.5 - 2.0 * x + 3.0 * x * x);
        }
        let c = least_squares(&a, &y, 20, 3).unwrap();
        assert!((c[0] - 0.5).abs() < 1e-10 && (c[1] + 2.0).abs() < 1e-10 && (c[2] - 3.0).abs() < 1e-10);
    }
}
