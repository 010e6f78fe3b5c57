//! Reduced direct-to-indirect transfer (MRT thesis §3.3) and basis enrichment (App. A).
//!
//! - Prior: `L_d = U_d Σ_d V_dᵀ`, `P = Ũ_d` (k_d columns), `S = Σ̃_d` (§3.3, §4.1.1).
//! - Light-space indirect operator `M = F P S`, `M = U_m Σ_m V_mᵀ` (eq. 3.2).
//! - `U_b = Ũ_m Σ̃_m` (k_b columns), `T_d→b = Ṽ_mᵀ S⁻¹ Pᵀ` (eq. 3.3), implicit lights
//!   `L_imp = P S Ṽ_m` with `U_b = F L_imp` (§3.3.1.1).
//! - Enrichment (App. A): rescale `P S`, the fallback basis ([`fallback_basis`]: face
//!   constants and face-restricted prior vectors) and `U_b` to unit Frobenius norm each,
//!   concatenate, SVD; the leading left singular vectors and values are the new `P`, `S`.
//!
//! `k_d` is capped at the numerical rank of `L_d` (σ > 10⁻¹²·σ₁): `S⁻¹` of a zero singular
//! value is meaningless, and a rank-1 prior must give a rank-1 `M`.

use crate::TransportError;
use crate::shape::Texels;
use crate::svd::{frobenius, left_svd, mul, numerical_rank, thin_svd};
use faer::{Mat, MatRef};

/// Relative threshold of the numerical rank.
pub const RANK_TOL: f64 = 1e-12;

/// A light prior: orthonormal `P` (n×k) and its scales `S` (k).
#[derive(Debug, Clone)]
pub struct Prior {
    /// `P`, orthonormal columns.
    pub p: Mat<f64>,
    /// `S` = the retained singular values.
    pub s: Vec<f64>,
}

impl Prior {
    /// `P S` (columns scaled).
    pub fn scaled(&self) -> Mat<f64> {
        Mat::from_fn(self.p.nrows(), self.p.ncols(), |i, j| self.p[(i, j)] * self.s[j])
    }

    /// Number of prior vectors.
    pub fn k(&self) -> usize {
        self.s.len()
    }
}

/// The prior of a sample matrix `L_d` (one light per column), keeping `k_d` vectors (fewer
/// when `L_d`'s numerical rank is lower). Returns the prior and every singular value of `L_d`.
pub fn prior_from_samples(l_d: MatRef<'_, f64>, k_d: usize) -> Result<(Prior, Vec<f64>), TransportError> {
    let d = left_svd(l_d)?;
    let k = k_d.min(numerical_rank(&d.s, RANK_TOL));
    let p = Mat::from_fn(l_d.nrows(), k, |i, j| d.u[(i, j)]);
    Ok((Prior { p, s: d.s[..k].to_vec() }, d.s))
}

/// The operators of one shape in indirect light space.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// Every singular value of `M` (descending).
    pub sigma_m: Vec<f64>,
    /// `U_b = Ũ_m Σ̃_m` (n × k_b).
    pub u_b: Mat<f64>,
    /// `T_d→b = Ṽ_mᵀ S⁻¹ Pᵀ` (k_b × n).
    pub t_d2b: Mat<f64>,
    /// Implicit lights `L_imp = P S Ṽ_m` (n × k_b).
    pub l_imp: Mat<f64>,
}

/// `M = F P S`, its SVD, and `U_b`, `T_d→b`, `L_imp` with `k_b` modes (capped at `k_d`).
pub fn reduce(f: MatRef<'_, f64>, prior: &Prior, k_b: usize) -> Result<Reduced, TransportError> {
    let n = f.nrows();
    let ps = prior.scaled();
    let m = mul(f, ps.as_ref());
    let d = thin_svd(m.as_ref())?;
    let kb = k_b.min(d.s.len());
    let u_b = Mat::from_fn(n, kb, |i, j| d.u[(i, j)] * d.s[j]);
    let vk = Mat::from_fn(prior.k(), kb, |i, j| d.v[(i, j)]);
    // Ṽ_mᵀ S⁻¹ (k_b × k_d), then times Pᵀ
    let vs = Mat::from_fn(kb, prior.k(), |i, j| vk[(j, i)] / prior.s[j]);
    let t_d2b = mul(vs.as_ref(), prior.p.transpose());
    let l_imp = mul(ps.as_ref(), vk.as_ref());
    Ok(Reduced { sigma_m: d.s, u_b, t_d2b, l_imp })
}

/// Fallback basis of App. A: one column per present face, 1 on that face's texels and 0
/// elsewhere (the thesis's), then, for `modes > 0`, the leading `modes` columns of `P S`
/// restricted to one face at a time (zero elsewhere).
///
/// Why the restricted prior vectors: per-face albedo (App. A's five red faces and a white
/// one) multiplies the direct light face by face, so a coloured channel is a prior pattern
/// masked to some faces. Face constants capture only the mean of such a pattern on its face;
/// the rest leaks onto the other faces when projected on `P` and bounces back (docs/mrt.md
/// measures it). The masked prior vectors contain the face constant's role (the leading
/// prior vector is smooth and positive) and the pattern's variation across the face.
pub fn fallback_basis(tex: &Texels, prior: &Prior, modes: usize) -> Mat<f64> {
    let m = modes.min(prior.k());
    let nf = tex.faces.len();
    let ps = prior.scaled();
    let mut c = Mat::<f64>::zeros(tex.len(), nf * (1 + m));
    for (slot, &f) in tex.faces.iter().enumerate() {
        for t in tex.face_range(f) {
            c[(t, slot)] = 1.0;
            for j in 0..m {
                c[(t, nf + slot * m + j)] = ps[(t, j)];
            }
        }
    }
    c
}

/// One enrichment step (App. A): `[P S, C, U_b]`, each rescaled to unit Frobenius norm,
/// concatenated; the SVD's leading `k` left singular vectors and values (`k` capped at the
/// numerical rank) become the new prior.
pub fn enrich(
    prior: &Prior,
    fallback: MatRef<'_, f64>,
    u_b: MatRef<'_, f64>,
    k: usize,
) -> Result<Prior, TransportError> {
    let ps = prior.scaled();
    let blocks: [MatRef<'_, f64>; 3] = [ps.as_ref(), fallback, u_b];
    let n = ps.nrows();
    let cols: usize = blocks.iter().map(|b| b.ncols()).sum();
    let mut cat = Mat::<f64>::zeros(n, cols);
    let mut at = 0;
    for b in blocks {
        let norm = frobenius(b);
        let s = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        for j in 0..b.ncols() {
            for i in 0..n {
                cat[(i, at + j)] = b[(i, j)] * s;
            }
        }
        at += b.ncols();
    }
    let (p, _) = prior_from_samples(cat.as_ref(), k)?;
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::svd::mul;
    use penumbra_math::rng::ItemRng;

    fn random(m: usize, n: usize, seed: u64) -> Mat<f64> {
        let mut r = ItemRng::new(seed, 77, 0);
        Mat::from_fn(m, n, |_, _| r.next_f64())
    }

    #[test]
    fn implicit_lights_reproduce_u_b_and_full_rank_reconstructs_f_on_the_prior() {
        let n = 30;
        let f = random(n, n, 1);
        let l_d = random(n, 12, 2);
        let (prior, _) = prior_from_samples(l_d.as_ref(), 12).unwrap();
        let r = reduce(f.as_ref(), &prior, 12).unwrap();
        // U_b = F L_imp (§3.3.1.1)
        let fl = mul(f.as_ref(), r.l_imp.as_ref());
        assert!(frobenius((fl - &r.u_b).as_ref()) < 1e-10 * frobenius(r.u_b.as_ref()));
        // keeping every mode, U_b T_d→b = F P Pᵀ: exact on every sampled light
        let rec = mul(r.u_b.as_ref(), mul(r.t_d2b.as_ref(), l_d.as_ref()).as_ref());
        let truth = mul(f.as_ref(), l_d.as_ref());
        assert!(frobenius((rec - &truth).as_ref()) < 1e-9 * frobenius(truth.as_ref()));
    }

    #[test]
    fn enrichment_spans_the_fallback_and_u_b() {
        use crate::shape::{CLOSED, Texels};
        let tex = Texels::new(CLOSED, 2);
        let n = tex.len();
        let l_d = random(n, 6, 3);
        let (prior, _) = prior_from_samples(l_d.as_ref(), 6).unwrap();
        let c = fallback_basis(&tex, &prior, 0);
        let ub = random(n, 2, 4);
        let e = enrich(&prior, c.as_ref(), ub.as_ref(), 14).unwrap();
        assert_eq!(e.k(), 14);
        // every input column lies in the enriched span: P Pᵀ x = x
        for b in [prior.p.as_ref(), c.as_ref(), ub.as_ref()] {
            let proj = mul(e.p.as_ref(), mul(e.p.transpose(), b).as_ref());
            assert!(frobenius((proj - b).as_ref()) < 1e-9 * frobenius(b));
        }
    }
}
