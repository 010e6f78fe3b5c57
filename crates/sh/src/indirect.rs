//! Indirect radiance operators of a spherical proxy (IBPA §5): the averaged operator
//! `D(θ)` (eq. 14), its analytic order-3 form and the paper's polynomial fits, and the
//! exact operator `M(θ)` (eq. 16).
//!
//! Canonical configuration (IBPA §5): receiver at the origin, proxy centre at +z,
//! radius `sin θ` (so the proxy subtends half-angle θ). A ray `s` with `s_z ≥ cos θ` hits
//! the proxy at `q(s) = s·(s_z − √(s_z² − cos²θ))` whose unit normal is
//! `q̂(s) = (q(s) − ẑ)/sin θ`.
//!
//! Integration: with `u = √(s_z² − cos²θ)` (so `s_z = √(u² + cos²θ)`) the square-root
//! singularity at the silhouette disappears and the integrands are smooth in `u ∈ [0,
//! sin θ]`; Gauss–Legendre in `u` then converges to machine precision with 48 nodes.

use core::f64::consts::PI;
use penumbra_math::quadrature::gauss_legendre_cached;
use penumbra_math::sh::{ShEval, eval_zonal};

const NODES: usize = 48;

/// Calls `f(s_z, u, q̂_z, weight)` over the cap for a canonical proxy with `α = sin θ`,
/// weights integrating `ds_z` (multiply by `2π` for the full solid angle of azimuth-free
/// integrands).
fn cap_nodes(alpha: f64, mut f: impl FnMut(f64, f64, f64, f64)) {
    let alpha = alpha.clamp(1e-9, 1.0);
    let c2 = (1.0 - alpha * alpha).max(0.0);
    let gl = gauss_legendre_cached(NODES);
    for (u, w) in gl.on_interval(0.0, alpha) {
        let sz = (u * u + c2).sqrt();
        // ds_z = u / s_z du ; q̂_z = (s_z (s_z − u) − 1)/α = (u² − α² − s_z u)/α
        let qz = (u * u - alpha * alpha - sz * u) / alpha;
        let jac = if sz > 0.0 { u / sz } else { 1.0 };
        f(sz, u, qz.clamp(-1.0, 1.0), w * jac);
    }
}

/// Solid angle `ω = 2π(1 − cos θ)` of a proxy with `α = sin θ`, cancellation-free.
pub fn solid_angle(alpha: f64) -> f64 {
    let alpha = alpha.clamp(0.0, 1.0);
    let one_minus_cos = alpha * alpha / (1.0 + (1.0 - alpha * alpha).sqrt());
    2.0 * PI * one_minus_cos
}

/// Averaged operator `D(θ)` of IBPA eq. 14: `D_l = (1/ω) ∫ v_θ(s) y_{l0}(q̂_θ(s)) ds`
/// (zonal; `order` coefficients). Small-α limit is well defined (α is clamped at 1e-9).
pub fn averaged_operator(order: usize, alpha: f64) -> Vec<f64> {
    let mut y = vec![0.0; order];
    let mut d = vec![0.0; order];
    let mut total = 0.0;
    cap_nodes(alpha, |_sz, _u, qz, w| {
        eval_zonal(order, qz, &mut y);
        total += w;
        for l in 0..order {
            d[l] += w * y[l];
        }
    });
    // (2π ∫ ... ds_z) / (2π ∫ ds_z): the quadrature of ω itself cancels its own error.
    d.iter().map(|v| v / total).collect()
}

/// IBPA §5's analytic order-3 `D(θ)`, with `d = csc θ`, `ď = √(d² − 1)`.
///
/// Evaluated in an algebraically identical form that avoids the catastrophic cancellation
/// of the printed one for small α (`2d³ − 2ďd²` loses ~3·log₁₀ d digits): with
/// `e = d − ď = 1/(d + ď)`, the D₁ numerator is `(d·e + 1)·e + 1` and the D₂ numerator
/// is `3d²e(d·e + 1) − ď + 4`.
pub fn averaged_operator_analytic(alpha: f64) -> [f64; 3] {
    let d = 1.0 / alpha;
    let dc = (d * d - 1.0).max(0.0).sqrt();
    let sp = PI.sqrt();
    let e = 1.0 / (d + dc);
    let n1 = (d * e + 1.0) * e + 1.0;
    let n2 = 3.0 * d * d * e * (d * e + 1.0) - dc + 4.0;
    let d1 = -(3.0f64.sqrt()) * n1 / (6.0 * sp * d * e);
    let d2 = 5.0f64.sqrt() * n2 / (20.0 * sp * d * d * e);
    [0.5 / sp, d1, d2]
}

/// IBPA §5's analytic order-3 `D(θ)` exactly as printed (for comparison in tests).
pub fn averaged_operator_analytic_printed(alpha: f64) -> [f64; 3] {
    let d = 1.0 / alpha;
    let dc = (d * d - 1.0).max(0.0).sqrt();
    let sp = PI.sqrt();
    let d1 = -(3.0f64.sqrt()) * (2.0 * d * d * d - 2.0 * dc * d * d - dc + 1.0) / (6.0 * sp * d * (d - dc));
    let d2 = 5.0f64.sqrt() * (6.0 * d.powi(5) - 6.0 * dc * d.powi(4) - 3.0 * dc * d * d - dc + 4.0)
        / (20.0 * sp * d * d * (d - dc));
    [0.5 / sp, d1, d2]
}

/// IBPA §5's polynomial fits of `D₁`, `D₂` in `α = sin θ`.
pub fn averaged_operator_paper_fit(alpha: f64) -> [f64; 3] {
    let a = alpha;
    [0.28209, 0.08432 * a * a - 0.25073 * a - 0.32494, -0.22230 * a * a * a + 0.22502 * a * a + 0.47398 * a + 0.15950]
}

/// Exact operator `M(θ)` of IBPA eq. 16 for SH order `order`:
/// `M_jk = ∫ v_θ(s) y_j(s) y_k(q̂_θ(s)) ds`, row-major `n² × n²`.
/// The azimuthal integral uses the trapezoidal rule with `4·order` points, exact for the
/// trigonometric degree `2(order − 1)` of the integrand.
pub fn exact_operator(order: usize, alpha: f64) -> Vec<f64> {
    let nc = order * order;
    let eval = ShEval::new(order);
    let mut m = vec![0.0; nc * nc];
    let nphi = 4 * order;
    let dphi = 2.0 * PI / nphi as f64;
    let alpha_c = alpha.clamp(1e-9, 1.0);
    let mut ys = vec![0.0; nc];
    let mut yq = vec![0.0; nc];
    cap_nodes(alpha_c, |sz, u, qz, w| {
        let rs = (1.0 - sz * sz).max(0.0).sqrt();
        // q̂_xy = s_xy · t / α with the hit distance t = s_z − u.
        let rq = rs * (sz - u) / alpha_c;
        for k in 0..nphi {
            let phi = (k as f64 + 0.5) * dphi;
            let (sp, cp) = phi.sin_cos();
            eval.eval_into([rs * cp, rs * sp, sz], &mut ys);
            let qn = [rq * cp, rq * sp, qz];
            let len = (qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2]).sqrt();
            eval.eval_into([qn[0] / len, qn[1] / len, qn[2] / len], &mut yq);
            let ww = w * dphi;
            for j in 0..nc {
                let a = ww * ys[j];
                for kk in 0..nc {
                    m[j * nc + kk] += a * yq[kk];
                }
            }
        }
    });
    m
}

/// Relative squared error `Σ(fit − exact)² / Σ exact²` of the paper's fits against our
/// exact `D₁`, `D₂`, over `samples` α values uniform in `(0, 1]`.
pub fn paper_fit_rel_sq_error(samples: usize) -> [f64; 2] {
    let mut num = [0.0; 2];
    let mut den = [0.0; 2];
    for k in 1..=samples {
        let a = k as f64 / samples as f64;
        let d = averaged_operator(3, a);
        let f = averaged_operator_paper_fit(a);
        for c in 0..2 {
            num[c] += (f[c + 1] - d[c + 1]).powi(2);
            den[c] += d[c + 1].powi(2);
        }
    }
    [num[0] / den[0], num[1] / den[1]]
}

/// Our own least-squares fits of the same form (quadratic `D₁`, cubic `D₂` in α) and their
/// relative squared errors: `([c0,c1,c2], [c0,c1,c2,c3], [err1, err2])`, coefficients in
/// ascending powers.
pub fn refit(samples: usize) -> (Vec<f64>, Vec<f64>, [f64; 2]) {
    let alphas: Vec<f64> = (1..=samples).map(|k| k as f64 / samples as f64).collect();
    let ds: Vec<Vec<f64>> = alphas.iter().map(|&a| averaged_operator(3, a)).collect();
    let fit = |deg: usize, comp: usize| {
        let mut a = Vec::new();
        let mut y = Vec::new();
        for (al, d) in alphas.iter().zip(&ds) {
            for p in 0..=deg {
                a.push(al.powi(p as i32));
            }
            y.push(d[comp]);
        }
        let c = penumbra_math::linalg::least_squares(&a, &y, alphas.len(), deg + 1).unwrap_or_default();
        let (mut num, mut den) = (0.0, 0.0);
        for (al, d) in alphas.iter().zip(&ds) {
            let v: f64 = c.iter().enumerate().map(|(p, cp)| cp * al.powi(p as i32)).sum();
            num += (v - d[comp]).powi(2);
            den += d[comp].powi(2);
        }
        (c, num / den)
    };
    let (c1, e1) = fit(2, 1);
    let (c2, e2) = fit(3, 2);
    (c1, c2, [e1, e2])
}
