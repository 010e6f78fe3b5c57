//! SH logarithm (SHEXP §5): naive clipped projection (eq. 25) and eigen-inversion of the
//! product matrix with eigenvalue clipping (eq. 30–32).

use crate::exp::SQRT_4PI;
use crate::gamma::TripleProduct;
use penumbra_math::linalg::SymEigen;
use penumbra_math::quadrature::{SphereQuadrature, gauss_legendre_cached};
use penumbra_math::sh::{ShEval, eval_zonal, lm_of};

/// The paper's clipping threshold, relative to the largest eigenvalue (SHEXP §5).
pub const EPS_REL: f64 = 0.02;

/// Absolute floor on the clipping threshold: when `g` is (numerically) nowhere positive —
/// a blocker covering the whole sphere — the largest eigenvalue is ≤ 0 and a relative
/// threshold is meaningless. Clipping at 1e-6 gives `exp(log g) ≈ 1e-6 · 1`: fully
/// shadowed, finite, no NaN.
pub const EPS_FLOOR: f64 = 1e-6;

/// Naive SH log (SHEXP eq. 25): `f = ∫ log(max(g̃(s), ε)) y(s) ds` where `g̃` is the
/// reconstruction of `g`. The clip `ε` is absolute here; [`naive_eps`] gives the value the
/// tables use. Integrated with a dense product rule (the integrand has kinks where the
/// clip engages, so no finite rule is exact; 96×192 points give ~1e-6).
pub fn log_naive(order: usize, g: &[f64], eps: f64) -> Vec<f64> {
    let n2 = order * order;
    let q = SphereQuadrature::new(96, 192);
    let e = ShEval::new(order);
    let mut y = vec![0.0; n2];
    let mut f = vec![0.0; n2];
    for (d, w) in q.iter() {
        e.eval_into(d, &mut y);
        let gv: f64 = g.iter().zip(&y).map(|(a, b)| a * b).sum();
        let lv = gv.max(eps).ln();
        for i in 0..n2 {
            f[i] += w * lv * y[i];
        }
    }
    f
}

/// Naive SH log of a *zonal* vector (ZH coefficients, axis +z), by 1D Gauss–Legendre in
/// `z` with 4096 nodes (the clipped integrand is only piecewise smooth).
pub fn log_naive_zonal(order: usize, g_zh: &[f64], eps: f64) -> Vec<f64> {
    let gl = gauss_legendre_cached(4096);
    let mut y = vec![0.0; order];
    let mut f = vec![0.0; order];
    for (z, w) in gl.on_interval(-1.0, 1.0) {
        eval_zonal(order, z, &mut y);
        let gv: f64 = g_zh.iter().zip(&y).map(|(a, b)| a * b).sum();
        let lv = gv.max(eps).ln();
        for l in 0..order {
            f[l] += 2.0 * core::f64::consts::PI * w * lv * y[l];
        }
    }
    f
}

/// The clip used by the tables for the naive log: `EPS_REL · max_s g̃(s)` (the spatial
/// analogue of the eigenvalue threshold), floored at [`EPS_FLOOR`].
pub fn naive_eps_zonal(order: usize, g_zh: &[f64]) -> f64 {
    let gl = gauss_legendre_cached(512);
    let mut y = vec![0.0; order];
    let mut max = f64::MIN;
    for (z, _) in gl.on_interval(-1.0, 1.0).chain([(-1.0, 0.0), (1.0, 0.0)]) {
        eval_zonal(order, z, &mut y);
        max = max.max(g_zh.iter().zip(&y).map(|(a, b)| a * b).sum());
    }
    (EPS_REL * max).max(EPS_FLOOR)
}

/// Which reading of eq. 30–32 the eigen log evaluates once clipping engages (they agree
/// exactly while no eigenvalue is clipped).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LogForm {
    /// As SHEXP writes it: `log g = Rᵀ q'(D̃) R (g − 1)`, `q'(x) = log x/(x − 1)`,
    /// `D̃ = max(D, ε)` (eq. 30 with the clipped eigenvalues of eq. 32). Default.
    #[default]
    Paper,
    /// `log(M̃_g)·1 = Rᵀ log(D̃) R · 1`: eq. 30 applied to the clipped matrix `M̃_g`, so a
    /// clipped eigenvalue contributes exactly `log ε` (the form used before issue #14).
    Matrix,
}

impl LogForm {
    /// Name used in metadata and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LogForm::Paper => "paper",
            LogForm::Matrix => "matrix",
        }
    }
}

/// `log(λ)` of an eigenvalue given as `μ = λ − 1`, with clipping at `eps` (SHEXP eq. 32).
#[inline]
fn clipped_log(mu: f64, eps: f64) -> f64 {
    if 1.0 + mu >= eps { mu.ln_1p() } else { eps.ln() }
}

/// `q'(λ̃) = log λ̃/(λ̃ − 1)` (SHEXP eq. 30) of `λ̃ = max(1 + μ, eps)` (eq. 32), given `μ`.
/// Unclipped, `λ̃ − 1 = μ` exactly and `q' = ln_1p(μ)/μ` (→ 1 − μ/2 at μ → 0).
#[inline]
fn clipped_q_prime(mu: f64, eps: f64) -> f64 {
    if 1.0 + mu >= eps {
        if mu.abs() < 1e-8 { 1.0 - 0.5 * mu } else { mu.ln_1p() / mu }
    } else {
        eps.ln() / (eps - 1.0)
    }
}

/// Applies the clipped eigen log to the eigendecomposition of `M_{g−1} = M_g − I`, given
/// `g − 1 = −o` (`gm1`), in the chosen [`LogForm`].
fn apply_log(eig: &SymEigen, gm1: &[f64], eps: f64, form: LogForm, out: &mut [f64]) {
    match form {
        LogForm::Paper => eig.apply_fn(gm1, |mu| clipped_q_prime(mu, eps), out),
        LogForm::Matrix => {
            let mut one = vec![0.0; gm1.len()];
            one[0] = SQRT_4PI;
            eig.apply_fn(&one, |mu| clipped_log(mu, eps), out);
        }
    }
}

/// Eigen-inversion SH log (SHEXP eq. 30–32) of a general SH vector `g`, in the paper's form.
///
/// With `M_g = Rᵀ D R`, eq. 30 gives `log g = Rᵀ q'(D) R (g − 1)`, `q'(x) = log x/(x−1)`,
/// evaluated with the clipped eigenvalues `D̃ = max(D, ε)` (eq. 32). We decompose
/// `M_g − I = M_{g−1}` instead of `M_g` so that eigenvalues near 1 (tiny blockers) keep
/// full relative precision in `log(1 + μ)/μ`. [`log_eigen_with`] selects the form.
pub fn log_eigen(t: &TripleProduct, g: &[f64], eps_rel: f64) -> Vec<f64> {
    log_eigen_with(t, g, eps_rel, LogForm::Paper)
}

/// [`log_eigen`] in a chosen [`LogForm`].
pub fn log_eigen_with(t: &TripleProduct, g: &[f64], eps_rel: f64, form: LogForm) -> Vec<f64> {
    let mut occ: Vec<f64> = g.iter().map(|v| -v).collect();
    occ[0] += SQRT_4PI;
    log_eigen_occlusion_with(t, &occ, eps_rel, form)
}

/// [`log_eigen`] of `g = 1 − o` given the occlusion `o` directly: `M_{g−1} = −M_o`, so a
/// tiny blocker's log keeps full relative precision (no `1 − o` rounding).
pub fn log_eigen_occlusion(t: &TripleProduct, occlusion: &[f64], eps_rel: f64) -> Vec<f64> {
    log_eigen_occlusion_with(t, occlusion, eps_rel, LogForm::Paper)
}

/// [`log_eigen_occlusion`] in a chosen [`LogForm`].
pub fn log_eigen_occlusion_with(t: &TripleProduct, occlusion: &[f64], eps_rel: f64, form: LogForm) -> Vec<f64> {
    let n = t.len();
    let gm1: Vec<f64> = occlusion.iter().map(|v| -v).collect();
    let m = t.product_matrix(&gm1);
    let eig = SymEigen::new(&m, n);
    let eps = (eps_rel * (1.0 + eig.max_value())).max(EPS_FLOOR);
    let mut f = vec![0.0; n];
    apply_log(&eig, &gm1, eps, form, &mut f);
    f
}

/// Fast path of [`log_eigen`] for a *zonal* `g` (ZH coefficients, axis +z).
///
/// The product matrix of a zonal function preserves the SH index `m`, so `M_g` is block
/// diagonal with one block per `m` of size `n − |m|` (blocks `m` and `−m` are equal). The
/// clip needs the largest eigenvalue over all blocks; the log itself only needs the `m = 0`
/// block, because `1` and `g − 1` live there. Order 8: blocks of size ≤ 8 instead of one 64×64.
pub fn log_eigen_zonal(t: &TripleProduct, g_zh: &[f64], eps_rel: f64) -> Vec<f64> {
    let mut occ: Vec<f64> = g_zh.iter().map(|v| -v).collect();
    occ[0] += SQRT_4PI;
    log_eigen_zonal_occlusion(t, &occ, eps_rel)
}

/// [`log_eigen_zonal`] given the zonal occlusion `o = 1 − g` directly (full relative
/// precision for tiny blockers; the tables pass [`crate::zonal::cap_indicator`]).
pub fn log_eigen_zonal_occlusion(t: &TripleProduct, occ_zh: &[f64], eps_rel: f64) -> Vec<f64> {
    log_eigen_zonal_occlusion_with(t, occ_zh, eps_rel, LogForm::Paper)
}

/// [`log_eigen_zonal_occlusion`] in a chosen [`LogForm`].
pub fn log_eigen_zonal_occlusion_with(t: &TripleProduct, occ_zh: &[f64], eps_rel: f64, form: LogForm) -> Vec<f64> {
    let n = t.order();
    let gm1: Vec<f64> = occ_zh.iter().map(|v| -v).collect();
    let (eigs, eps) = zonal_blocks(t, &gm1, eps_rel);
    let mut f = vec![0.0; n];
    apply_log(&eigs[0], &gm1, eps, form, &mut f);
    f
}

/// Where the zonal eigen log stands with respect to its clipping (SHEXP eq. 32), for the
/// zonal occlusion `occ_zh`: `(c, m)` with `c` the number of eigenvalues of the `m = 0` block
/// (the only one the log reads) below `ε = max(eps_rel·λmax, EPS_FLOOR)`, and `m` the block
/// that holds `λmax` when `c > 0` (else 0). The log is a smooth function of the cap angle
/// wherever this state is constant; where it changes, the log has a kink (slope
/// discontinuity): an eigenvalue starts or stops being clipped, or, with one clipped, the
/// largest eigenvalue that ε follows moves to another block.
pub fn zonal_clip_state(t: &TripleProduct, occ_zh: &[f64], eps_rel: f64) -> (usize, usize) {
    let gm1: Vec<f64> = occ_zh.iter().map(|v| -v).collect();
    let (eigs, eps) = zonal_blocks(t, &gm1, eps_rel);
    let clipped = eigs[0].values.iter().filter(|&&mu| 1.0 + mu < eps).count();
    if clipped == 0 {
        return (0, 0);
    }
    let mut arg = 0;
    for (m, e) in eigs.iter().enumerate() {
        if e.max_value() > eigs[arg].max_value() {
            arg = m;
        }
    }
    (clipped, arg)
}

/// The per-`m` eigendecompositions of the zonal `M_{g−1}` (`gm1` = `g − 1`) and the clip ε.
fn zonal_blocks(t: &TripleProduct, gm1: &[f64], eps_rel: f64) -> (Vec<SymEigen>, f64) {
    let n = t.order();
    // blocks[m] is (n−m)×(n−m), rows/cols indexed by l − m.
    let mut blocks: Vec<Vec<f64>> = (0..n).map(|m| vec![0.0; (n - m) * (n - m)]).collect();
    for e in t.entries() {
        let (lk, mk) = lm_of(e.k as usize);
        if mk != 0 {
            continue;
        }
        let (li, mi) = lm_of(e.i as usize);
        let (lj, mj) = lm_of(e.j as usize);
        if mi != mj || mi < 0 {
            continue;
        }
        let m = mi as usize;
        let sz = n - m;
        blocks[m][(li - m) * sz + (lj - m)] += e.value * gm1[lk];
    }
    let eigs: Vec<SymEigen> = blocks.iter().enumerate().map(|(m, b)| SymEigen::new(b, n - m)).collect();
    let mu_max = eigs.iter().map(|e| e.max_value()).fold(f64::MIN, f64::max);
    let eps = (eps_rel * (1.0 + mu_max)).max(EPS_FLOOR);
    (eigs, eps)
}
