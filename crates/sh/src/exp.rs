//! SH exponential (SHEXP §4): product series PS-p, PS*-p, optimal linear OL, hybrid HYB,
//! and the exact exponential of the product matrix (eq. 28).
//!
//! All functions take an SH vector `f` of order `n` (length `n²`) and return `exp*(f)` of
//! the same order, where products are the truncated SH products of [`TripleProduct`].

use crate::gamma::TripleProduct;
use crate::ol::OlTable;
use penumbra_math::linalg::SymEigen;

/// `√(4π)`: the DC coefficient of the constant 1.
pub const SQRT_4PI: f64 = 3.544_907_701_811_032;

/// Which SH exponential to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExpMethod {
    /// Plain product series of degree p (SHEXP eq. 17).
    Ps(u32),
    /// DC isolation + scaling/squaring + even/odd factored series of degree p (SHEXP §4.3).
    PsStar(u32),
    /// Optimal linear approximation (SHEXP eq. 23).
    Ol,
    /// OL with scaling/squaring (SHEXP §4.3, "HYB").
    Hyb,
    /// `exp(M_f)·1` through the eigendecomposition of the product matrix (SHEXP eq. 28).
    Exact,
}

/// Euclidean norm.
pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `f̂`: `f` with its DC coefficient zeroed (SHEXP eq. 19).
pub fn without_dc(f: &[f64]) -> Vec<f64> {
    let mut h = f.to_vec();
    h[0] = 0.0;
    h
}

/// PS-p: `1 + f + f²*/2! + … + f^{p*}/p!` with powers amassed left to right (SHEXP eq. 17).
pub fn exp_ps(t: &TripleProduct, f: &[f64], p: u32) -> Vec<f64> {
    let n = t.len();
    let mut out = vec![0.0; n];
    out[0] = SQRT_4PI;
    let mut pow = f.to_vec();
    let mut fact = 1.0;
    let mut tmp = vec![0.0; n];
    for k in 1..=p {
        fact *= k as f64;
        if k > 1 {
            t.product(&pow, f, &mut tmp);
            core::mem::swap(&mut pow, &mut tmp);
        }
        for i in 0..n {
            out[i] += pow[i] / fact;
        }
    }
    out
}

/// Number of squarings SHEXP §4.1 uses for PS*: `max(0, ⌊log₂‖f‖⌋ + 3)`.
pub fn ps_star_squarings(norm_hat: f64) -> u32 {
    if norm_hat <= 0.0 || !norm_hat.is_finite() {
        return 0;
    }
    (norm_hat.log2().floor() as i64 + 3).max(0) as u32
}

/// PS*-p: DC isolation (eq. 20), scaling by `2^s` with `s = max(0, ⌊log₂‖f̂‖⌋+3)` (eq. 21),
/// the even/odd factored series of degree `p` (eq. 22), then `s` squarings.
pub fn exp_ps_star(t: &TripleProduct, f: &[f64], p: u32) -> Vec<f64> {
    let n = t.len();
    let mut h = without_dc(f);
    let s = ps_star_squarings(norm(&h));
    let scale = 0.5f64.powi(s as i32);
    h.iter_mut().for_each(|x| *x *= scale);
    // even = Σ h^{2k}/(2k)!, odd = Σ h^{2k}/(2k+1)!, result = even + h * odd.
    let mut even = vec![0.0; n];
    let mut odd = vec![0.0; n];
    even[0] = SQRT_4PI;
    odd[0] = SQRT_4PI;
    let h2 = t.product_vec(&h, &h);
    let mut pow = h2.clone(); // h^{2k}, k = 1
    let mut tmp = vec![0.0; n];
    let mut k = 1u32;
    while 2 * k <= p {
        if k > 1 {
            // h^4 = h²*h², h^6 = h⁴*h², … (SHEXP §4.1, factoring)
            t.product(&pow, &h2, &mut tmp);
            core::mem::swap(&mut pow, &mut tmp);
        }
        let fe = factorial(2 * k);
        for i in 0..n {
            even[i] += pow[i] / fe;
        }
        if 2 * k < p {
            let fo = factorial(2 * k + 1);
            for i in 0..n {
                odd[i] += pow[i] / fo;
            }
        }
        k += 1;
    }
    let mut g = t.product_vec(&h, &odd);
    // DC folded in before the squarings: (e^{f₀/(√4π 2^s)} g)^{2^s} = e^{f₀/√4π} g^{2^s},
    // and every intermediate stays within the range of the result (see `exp_hyb`).
    let dc = (f[0] / SQRT_4PI * scale).exp();
    for i in 0..n {
        g[i] = (g[i] + even[i]) * dc;
    }
    for _ in 0..s {
        t.product(&g, &g, &mut tmp);
        core::mem::swap(&mut g, &mut tmp);
    }
    g
}

fn factorial(k: u32) -> f64 {
    (1..=k).map(|i| i as f64).product()
}

/// OL (SHEXP eq. 23): `exp(f₀/√4π) · (a(‖f̂‖)·1 + b(‖f̂‖)·f̂)`. No SH products.
pub fn exp_ol(f: &[f64], ol: &OlTable) -> Vec<f64> {
    let h = without_dc(f);
    let (a, b) = ol.lookup(norm(&h));
    let dc = (f[0] / SQRT_4PI).exp();
    let mut g: Vec<f64> = h.iter().map(|x| dc * b * x).collect();
    g[0] = dc * a * SQRT_4PI;
    g
}

/// Squarings HYB uses: none inside OL's accurate domain, otherwise enough that
/// `‖f̂‖/2^s ≤ hyb_target_norm` (see [`OlTable`]).
pub fn hyb_squarings(norm_hat: f64, accurate_norm: f64, hyb_target_norm: f64) -> u32 {
    // NaN-safe: anything not clearly beyond the domain gets no squarings.
    if !norm_hat.is_finite()
        || norm_hat.is_nan()
        || norm_hat <= accurate_norm
        || hyb_target_norm.is_nan()
        || hyb_target_norm <= 0.0
    {
        return 0;
    }
    (norm_hat / hyb_target_norm).log2().ceil().max(0.0) as u32
}

/// HYB (SHEXP §4.3): divide `f` by `2^s`, apply OL, square `s` times.
///
/// The DC part is scaled with the rest, i.e. folded in *before* the squarings:
/// `exp(f) = (exp(f₀/(√4π 2^s))·OL(f̂/2^s))^{2^s}`. Applying `exp(f₀/√4π)` after the
/// squarings instead (as SHEXP eq. 20 separates it) lets the AC part grow like
/// `exp(‖f̂‖)` while the DC factor shrinks like `exp(f₀/√4π)`: with hundreds of dense
/// blockers both leave f32's range and the product is `inf·0 = NaN`.
pub fn exp_hyb(t: &TripleProduct, f: &[f64], ol: &OlTable) -> Vec<f64> {
    let n = t.len();
    let mut h = f.to_vec();
    let s = hyb_squarings(norm(&without_dc(f)), ol.accurate_norm, ol.hyb_target_norm);
    let scale = 0.5f64.powi(s as i32);
    h.iter_mut().for_each(|x| *x *= scale);
    let mut g = exp_ol(&h, ol);
    let mut tmp = vec![0.0; n];
    for _ in 0..s {
        t.product(&g, &g, &mut tmp);
        core::mem::swap(&mut g, &mut tmp);
    }
    g
}

/// Exact exponential of the product series (SHEXP eq. 28–29):
/// `g = 1 + Rᵀ q(D) R f` with `M_f = Rᵀ D R` and `q(x) = (eˣ − 1)/x`, i.e. `exp(M_f)·1`.
/// This is the limit of PS-p as `p → ∞`, free of series truncation; a preprocess-only
/// reference (one n²×n² symmetric eigendecomposition).
pub fn exp_exact(t: &TripleProduct, f: &[f64]) -> Vec<f64> {
    let n = t.len();
    let m = t.product_matrix(f);
    let eig = SymEigen::new(&m, n);
    let mut g = vec![0.0; n];
    eig.apply_fn(f, q_fn, &mut g);
    g[0] += SQRT_4PI;
    g
}

/// [`exp_exact`] for a *zonal* `f` (ZH coefficients, axis +z), returning ZH coefficients.
/// `M_f` of a zonal function is block-diagonal in `m` and `1` lies in the `m = 0` block,
/// so `exp(M_f)·1` needs only the `n × n` block `(M_f)_{(l,0),(l',0)}`.
pub fn exp_exact_zonal(t: &TripleProduct, f_zh: &[f64]) -> Vec<f64> {
    let n = t.order();
    let mut block = vec![0.0; n * n];
    for e in t.entries() {
        let (li, mi) = penumbra_math::sh::lm_of(e.i as usize);
        let (lj, mj) = penumbra_math::sh::lm_of(e.j as usize);
        let (lk, mk) = penumbra_math::sh::lm_of(e.k as usize);
        if mi == 0 && mj == 0 && mk == 0 {
            block[li * n + lj] += e.value * f_zh[lk];
        }
    }
    let eig = SymEigen::new(&block, n);
    let mut g = vec![0.0; n];
    eig.apply_fn(f_zh, q_fn, &mut g);
    g[0] += SQRT_4PI;
    g
}

/// `q(x) = (eˣ − 1)/x` with `q(0) = 1` (SHEXP eq. 29).
pub fn q_fn(x: f64) -> f64 {
    if x.abs() < 1e-8 { 1.0 + 0.5 * x } else { x.exp_m1() / x }
}

/// Applies `method`.
pub fn exp_with(t: &TripleProduct, f: &[f64], method: ExpMethod, ol: &OlTable) -> Vec<f64> {
    match method {
        ExpMethod::Ps(p) => exp_ps(t, f, p),
        ExpMethod::PsStar(p) => exp_ps_star(t, f, p),
        ExpMethod::Ol => exp_ol(f, ol),
        ExpMethod::Hyb => exp_hyb(t, f, ol),
        ExpMethod::Exact => exp_exact(t, f),
    }
}
