//! Dense linear algebra on faer (DESIGN §4): thin SVD, singular values and products, all
//! with `Par::Seq` inside one decomposition (rayon runs independent ones side by side), so
//! the same input gives the same bits for any thread count.
//!
//! SVDs are canonicalised: singular values in descending order, and each singular pair's sign
//! fixed so that the entry of largest magnitude of the left vector is positive (the first such
//! entry on exact ties).

use crate::TransportError;
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{ComputeEigenvectors, self_adjoint_evd, self_adjoint_evd_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::svd::{ComputeSvdVectors, svd, svd_scratch};
use faer::{Accum, Mat, MatRef, Par};

/// A thin SVD `A = U diag(s) Vᵀ` (`U`: m×k, `V`: n×k, k = min(m, n)).
#[derive(Debug, Clone)]
pub struct ThinSvd {
    /// Left singular vectors (columns).
    pub u: Mat<f64>,
    /// Singular values, descending.
    pub s: Vec<f64>,
    /// Right singular vectors (columns).
    pub v: Mat<f64>,
}

/// The canonical thin SVD of `a`.
pub fn thin_svd(a: MatRef<'_, f64>) -> Result<ThinSvd, TransportError> {
    svd_impl(a, true)
}

/// The canonical thin SVD of `a` without the right singular vectors (`v` is empty: 0 columns),
/// for when only `U` and `σ` are used (a prior): cheaper when `a` is wide or square-ish.
pub fn left_svd(a: MatRef<'_, f64>) -> Result<ThinSvd, TransportError> {
    svd_impl(a, false)
}

fn svd_impl(a: MatRef<'_, f64>, right: bool) -> Result<ThinSvd, TransportError> {
    let (m, n) = a.shape();
    let k = m.min(n);
    let mut u = Mat::<f64>::zeros(m, k);
    let mut v = Mat::<f64>::zeros(n, if right { k } else { 0 });
    let mut s = Diag::<f64>::zeros(k);
    let par = Par::Seq;
    let cv = if right { ComputeSvdVectors::Thin } else { ComputeSvdVectors::No };
    let req = svd_scratch::<f64>(m, n, ComputeSvdVectors::Thin, cv, par, Default::default());
    let mut mem = MemBuffer::new(req);
    let vm = if right { Some(v.as_mut()) } else { None };
    svd(a, s.as_mut(), Some(u.as_mut()), vm, par, MemStack::new(&mut mem), Default::default())
        .map_err(|e| TransportError::Svd(format!("{m}×{n}: {e:?}")))?;
    let s: Vec<f64> = (0..k).map(|i| s[i]).collect();
    let mut out = ThinSvd { u, s, v };
    canonicalise(&mut out);
    Ok(out)
}

/// Singular values of `a`, descending (no vectors).
pub fn singular_values(a: MatRef<'_, f64>) -> Result<Vec<f64>, TransportError> {
    let (m, n) = a.shape();
    let k = m.min(n);
    let mut s = Diag::<f64>::zeros(k);
    let par = Par::Seq;
    let req = svd_scratch::<f64>(m, n, ComputeSvdVectors::No, ComputeSvdVectors::No, par, Default::default());
    let mut mem = MemBuffer::new(req);
    svd(a, s.as_mut(), None, None, par, MemStack::new(&mut mem), Default::default())
        .map_err(|e| TransportError::Svd(format!("{m}×{n}: {e:?}")))?;
    let mut v: Vec<f64> = (0..k).map(|i| s[i]).collect();
    v.sort_by(|a, b| b.total_cmp(a));
    Ok(v)
}

/// Singular values of `a` from the eigenvalues of the Gram matrix `A Aᵀ` (or `Aᵀ A`, the
/// smaller): `σᵢ = √λᵢ`. Squaring loses the singular values below ~10⁻⁸·σ₁ to rounding, which
/// is harmless where only energy fractions of `Σσ²` are wanted (Table 3.2), and a symmetric
/// eigensolve of the Gram matrix is cheaper than a bidiagonal SVD.
pub fn singular_values_gram(a: MatRef<'_, f64>) -> Result<Vec<f64>, TransportError> {
    let g = if a.nrows() <= a.ncols() { mul(a, a.transpose()) } else { mul_tn(a, a) };
    let n = g.nrows();
    let mut s = Diag::<f64>::zeros(n);
    let par = Par::Seq;
    let req = self_adjoint_evd_scratch::<f64>(n, ComputeEigenvectors::No, par, Default::default());
    let mut mem = MemBuffer::new(req);
    self_adjoint_evd(g.as_ref(), s.as_mut(), None, par, MemStack::new(&mut mem), Default::default())
        .map_err(|e| TransportError::Svd(format!("Gram {n}×{n}: {e:?}")))?;
    let mut v: Vec<f64> = (0..n).map(|i| s[i].max(0.0).sqrt()).collect();
    v.sort_by(|a, b| b.total_cmp(a));
    Ok(v)
}

/// Eigenvalues (descending) and eigenvectors (columns, same order) of the symmetric matrix
/// `g` (its lower triangle is read).
pub fn sym_eigen(g: MatRef<'_, f64>) -> Result<(Vec<f64>, Mat<f64>), TransportError> {
    let n = g.nrows();
    let mut s = Diag::<f64>::zeros(n);
    let mut u = Mat::<f64>::zeros(n, n);
    let par = Par::Seq;
    let req = self_adjoint_evd_scratch::<f64>(n, ComputeEigenvectors::Yes, par, Default::default());
    let mut mem = MemBuffer::new(req);
    self_adjoint_evd(g, s.as_mut(), Some(u.as_mut()), par, MemStack::new(&mut mem), Default::default())
        .map_err(|e| TransportError::Svd(format!("eigen {n}×{n}: {e:?}")))?;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| s[b].total_cmp(&s[a]).then(a.cmp(&b)));
    let vals = order.iter().map(|&i| s[i]).collect();
    let vecs = Mat::from_fn(n, n, |r, c| u[(r, order[c])]);
    Ok((vals, vecs))
}

/// Rows per chunk of the chunked products below: fixed (not tied to the thread count), so
/// the sums are the same bits for any `--threads`.
pub const ROW_CHUNK: usize = 4096;

/// `Aᵀ·B` for tall `A`, `B` (same rows): per-chunk products in parallel, summed in chunk order.
pub fn gram_tn(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    use rayon::prelude::*;
    let m = a.nrows();
    let parts: Vec<Mat<f64>> = (0..m.div_ceil(ROW_CHUNK))
        .into_par_iter()
        .map(|c| {
            let r0 = c * ROW_CHUNK;
            let len = ROW_CHUNK.min(m - r0);
            mul_tn(a.subrows(r0, len), b.subrows(r0, len))
        })
        .collect();
    let mut out = Mat::<f64>::zeros(a.ncols(), b.ncols());
    for p in parts {
        out += p;
    }
    out
}

/// `A·B` for tall `A`: row chunks in parallel (each chunk's rows are independent).
pub fn mul_tall(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    use rayon::prelude::*;
    let m = a.nrows();
    let parts: Vec<Mat<f64>> = (0..m.div_ceil(ROW_CHUNK))
        .into_par_iter()
        .map(|c| {
            let r0 = c * ROW_CHUNK;
            mul(a.subrows(r0, ROW_CHUNK.min(m - r0)), b)
        })
        .collect();
    let mut out = Mat::<f64>::zeros(m, b.ncols());
    for (c, p) in parts.into_iter().enumerate() {
        out.as_mut().subrows_mut(c * ROW_CHUNK, p.nrows()).copy_from(p.as_ref());
    }
    out
}

/// The leading `k` left singular vectors and all singular values of a tall `A`, from the
/// eigen-decomposition of its Gram matrix `AᵀA` (`u_i = A v_i / σ_i`): far cheaper than a
/// bidiagonal SVD when `A` has many more rows than columns (the 82944-row lightfields), and
/// accurate for the singular values that matter (squaring loses those below ~10⁻⁸σ₁; `k` is
/// capped at the numerical rank). Signs canonical: the largest-magnitude entry of each `u_i`
/// is positive.
pub fn left_basis_gram(a: MatRef<'_, f64>, k: usize) -> Result<(Mat<f64>, Vec<f64>), TransportError> {
    let g = gram_tn(a, a);
    let (vals, vecs) = sym_eigen(g.as_ref())?;
    let sigma: Vec<f64> = vals.iter().map(|&l| l.max(0.0).sqrt()).collect();
    let k = k.min(numerical_rank(&sigma, 1e-7));
    let vk = Mat::from_fn(a.ncols(), k, |i, j| vecs[(i, j)] / sigma[j]);
    let mut u = mul_tall(a, vk.as_ref());
    canonical_columns(&mut u);
    Ok((u, sigma))
}

/// Flips each column's sign so that its largest-magnitude entry (first on ties) is positive.
pub fn canonical_columns(u: &mut Mat<f64>) {
    for j in 0..u.ncols() {
        let mut best = 0usize;
        let mut mag = -1.0f64;
        for r in 0..u.nrows() {
            let a = u[(r, j)].abs();
            if a > mag {
                mag = a;
                best = r;
            }
        }
        if u.nrows() > 0 && u[(best, j)] < 0.0 {
            for r in 0..u.nrows() {
                u[(r, j)] = -u[(r, j)];
            }
        }
    }
}

/// Descending order, then a fixed sign per singular pair.
fn canonicalise(d: &mut ThinSvd) {
    let k = d.s.len();
    let mut order: Vec<usize> = (0..k).collect();
    // stable: faer already returns non-increasing values; this only guards the contract
    order.sort_by(|&a, &b| d.s[b].total_cmp(&d.s[a]));
    if order.iter().enumerate().any(|(i, &o)| i != o) {
        let (u, v) = (d.u.clone(), d.v.clone());
        let s = d.s.clone();
        for (i, &o) in order.iter().enumerate() {
            d.s[i] = s[o];
            d.u.col_mut(i).copy_from(u.col(o));
            if v.ncols() == k {
                d.v.col_mut(i).copy_from(v.col(o));
            }
        }
    }
    for i in 0..k {
        let col = d.u.col(i);
        let mut best = 0usize;
        let mut mag = -1.0f64;
        for r in 0..col.nrows() {
            let a = col[r].abs();
            if a > mag {
                mag = a;
                best = r;
            }
        }
        if col.nrows() > 0 && col[best] < 0.0 {
            for r in 0..d.u.nrows() {
                d.u[(r, i)] = -d.u[(r, i)];
            }
            if d.v.ncols() == k {
                for r in 0..d.v.nrows() {
                    d.v[(r, i)] = -d.v[(r, i)];
                }
            }
        }
    }
}

/// `A·B` (sequential inside; deterministic).
pub fn mul(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut c = Mat::<f64>::zeros(a.nrows(), b.ncols());
    matmul(c.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    c
}

/// `Aᵀ·B` (sequential inside; deterministic).
pub fn mul_tn(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut c = Mat::<f64>::zeros(a.ncols(), b.ncols());
    matmul(c.as_mut(), Accum::Replace, a.transpose(), b, 1.0, Par::Seq);
    c
}

/// Number of leading singular values whose squares hold at least `fraction` of `Σσ²`
/// ("energy", MRT thesis Table 3.2).
pub fn energy_count(s: &[f64], fraction: f64) -> usize {
    let total: f64 = s.iter().map(|x| x * x).sum();
    if total <= 0.0 {
        return 0;
    }
    let mut acc = 0.0;
    for (i, x) in s.iter().enumerate() {
        acc += x * x;
        if acc >= fraction * total {
            return i + 1;
        }
    }
    s.len()
}

/// Number of singular values above `rel · σ₁` (the numerical rank).
pub fn numerical_rank(s: &[f64], rel: f64) -> usize {
    let top = s.first().copied().unwrap_or(0.0);
    s.iter().take_while(|&&x| x > rel * top && x > 0.0).count()
}

/// Frobenius norm.
pub fn frobenius(a: MatRef<'_, f64>) -> f64 {
    let mut s = 0.0;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            s += a[(i, j)] * a[(i, j)];
        }
    }
    s.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_math::rng::ItemRng;

    fn random(m: usize, n: usize, seed: u64) -> Mat<f64> {
        let mut r = ItemRng::new(seed, 99, 0);
        Mat::from_fn(m, n, |_, _| r.next_f64() - 0.5)
    }

    #[test]
    fn reconstruction_orthogonality_order_and_sign() {
        for (m, n) in [(40, 7), (7, 40), (33, 33)] {
            let a = random(m, n, (m * 100 + n) as u64);
            let d = thin_svd(a.as_ref()).unwrap();
            let k = m.min(n);
            assert!(d.s.windows(2).all(|w| w[0] >= w[1]));
            let mut us = d.u.clone();
            for j in 0..k {
                for i in 0..m {
                    us[(i, j)] *= d.s[j];
                }
            }
            let rec = us * d.v.transpose();
            assert!(frobenius((rec - &a).as_ref()) < 1e-12 * frobenius(a.as_ref()));
            let utu = d.u.transpose() * &d.u;
            let vtv = d.v.transpose() * &d.v;
            for i in 0..k {
                for j in 0..k {
                    let e = if i == j { 1.0 } else { 0.0 };
                    assert!((utu[(i, j)] - e).abs() < 1e-12 && (vtv[(i, j)] - e).abs() < 1e-12);
                }
                // canonical sign: the largest-magnitude entry of each left vector is positive
                let col = d.u.col(i);
                let big = (0..m).max_by(|&x, &y| col[x].abs().total_cmp(&col[y].abs())).unwrap();
                assert!(col[big] > 0.0);
            }
            let l = left_svd(a.as_ref()).unwrap();
            assert_eq!(l.s, d.s);
            assert_eq!(l.v.ncols(), 0);
            for j in 0..k {
                // the same canonical left vectors up to rounding
                let dot: f64 = (0..m).map(|i| l.u[(i, j)] * d.u[(i, j)]).sum();
                assert!(dot > 1.0 - 1e-9 || d.s[j] - d.s.get(j + 1).copied().unwrap_or(0.0) < 1e-9);
            }
            let sv = singular_values(a.as_ref()).unwrap();
            let sg = singular_values_gram(a.as_ref()).unwrap();
            for ((x, y), z) in sv.iter().zip(&d.s).zip(&sg) {
                assert!((x - y).abs() < 1e-12 * d.s[0]);
                // squaring: absolute error ~ ε·σ₁²/σ
                assert!((z - y).abs() < 1e-12 * d.s[0] * d.s[0] / y.max(1e-3 * d.s[0]), "{z} vs {y}");
            }
        }
    }

    #[test]
    fn energy_counts() {
        let s = [3.0, 2.0, 1.0, 1.0, 0.5];
        // squares 9, 4, 1, 1, 0.25 of 15.25
        assert_eq!(energy_count(&s, 0.5), 1);
        assert_eq!(energy_count(&s, 0.8), 2);
        assert_eq!(energy_count(&s, 0.9), 3);
        assert_eq!(energy_count(&s, 0.95), 4);
        assert_eq!(energy_count(&s, 1.0), 5);
        assert_eq!(numerical_rank(&[1.0, 1e-3, 1e-14, 0.0], 1e-12), 2);
    }
}
