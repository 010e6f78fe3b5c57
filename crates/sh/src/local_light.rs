//! Local spherical-light table `L_H(θ, φ)` and its single-lobe ZH fit (SHEXP §7).
//!
//! `L_H(θ, φ) = H(ẑ) * L(θ, φ)`: the SH product of the diffuse transfer `H` of a receiver
//! with normal +z (SHEXP eq. 9) and a circular light of angular radius θ and unit
//! radiance whose centre lies in the xz-plane at angle φ from +z. Shading a receiver
//! with total visibility `g` is then `L_H · g` after rotating the canonical frame.
//!
//! The single-lobe ZH model (Sloan et al. 2005) approximates each `L_H(θ, φ)` by a zonal
//! lobe `rot(z, d_ψ)` with axis `d_ψ = (sin ψ, 0, cos ψ)` in the xz-plane: for a fixed
//! axis the optimal zonal coefficients are `z_l = Σ_m f_lm y_lm(d) / √((2l+1)/4π)`
//! (least squares per band, using `Σ_m y_lm(d)² = (2l+1)/4π`); the axis ψ maximises the
//! captured energy `Σ_l (4π/(2l+1)) (Σ_m f_lm y_lm(d))²`, found by a 360-point scan plus
//! golden-section refinement.

use crate::gamma::TripleProduct;
use crate::zonal::{cap_indicator, irradiance_weight, to_sh};
use core::f64::consts::PI;
use penumbra_math::sh::{ShEval, zh_rotate};

/// One fitted lobe.
#[derive(Debug, Clone, PartialEq)]
pub struct LobeFit {
    /// Lobe axis angle ψ from +z toward +x (radians).
    pub psi: f64,
    /// Zonal coefficients of the lobe (`order` values).
    pub zh: Vec<f64>,
    /// Relative L2 error `‖f − rot(z, d_ψ)‖ / ‖f‖` (0 for a zero vector).
    pub rel_error: f64,
}

/// `L_H(θ, φ)` as a full SH vector of order `t.order()`.
pub fn local_light(t: &TripleProduct, eval: &ShEval, theta: f64, phi: f64) -> Vec<f64> {
    let n = t.order();
    let h = to_sh(&irradiance_weight(n));
    let cap = cap_indicator(n, theta);
    let mut l = vec![0.0; n * n];
    zh_rotate(eval, &cap, [phi.sin(), 0.0, phi.cos()], &mut l);
    t.product_vec(&h, &l)
}

fn band_projections(eval: &ShEval, f: &[f64], psi: f64, y: &mut [f64]) -> Vec<f64> {
    let n = eval.order();
    eval.eval_into([psi.sin(), 0.0, psi.cos()], y);
    (0..n).map(|l| (l * l..(l + 1) * (l + 1)).map(|i| f[i] * y[i]).sum()).collect()
}

fn captured(eval: &ShEval, f: &[f64], psi: f64, y: &mut [f64]) -> f64 {
    band_projections(eval, f, psi, y).iter().enumerate().map(|(l, p)| 4.0 * PI / (2 * l + 1) as f64 * p * p).sum()
}

/// Fits a single zonal lobe to `f` (order `eval.order()`), axis restricted to the xz-plane.
pub fn fit_lobe(eval: &ShEval, f: &[f64]) -> LobeFit {
    let n = eval.order();
    let mut y = vec![0.0; n * n];
    let total: f64 = f.iter().map(|v| v * v).sum();
    let scan = 360;
    let mut best = (f64::MIN, 0.0);
    for k in 0..scan {
        let psi = -PI + 2.0 * PI * k as f64 / scan as f64;
        let c = captured(eval, f, psi, &mut y);
        if c > best.0 + 1e-15 * total.max(1e-300) {
            best = (c, psi);
        }
    }
    // golden-section maximisation in the bracket around the best scan point
    let step = 2.0 * PI / scan as f64;
    let (mut a, mut b) = (best.1 - step, best.1 + step);
    let gr = 0.5 * (5.0f64.sqrt() - 1.0);
    let mut c = b - gr * (b - a);
    let mut d = a + gr * (b - a);
    let mut fc = captured(eval, f, c, &mut y);
    let mut fd = captured(eval, f, d, &mut y);
    for _ in 0..80 {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - gr * (b - a);
            fc = captured(eval, f, c, &mut y);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + gr * (b - a);
            fd = captured(eval, f, d, &mut y);
        }
    }
    let mut psi = 0.5 * (a + b);
    if captured(eval, f, psi, &mut y) < best.0 {
        psi = best.1;
    }
    // The lobe about −d with odd bands negated is the same function: take the axis on
    // which the linear band is non-negative (the side the light is on), so ψ = 0 for a
    // light on the normal.
    let p1 = band_projections(eval, f, psi, &mut y).get(1).copied().unwrap_or(0.0);
    if p1 < 0.0 {
        psi += PI;
    }
    // Canonical axis angle in (−π, π].
    if psi <= -PI {
        psi += 2.0 * PI;
    } else if psi > PI {
        psi -= 2.0 * PI;
    }
    let proj = band_projections(eval, f, psi, &mut y);
    let zh: Vec<f64> = proj.iter().enumerate().map(|(l, p)| p / ((2 * l + 1) as f64 / (4.0 * PI)).sqrt()).collect();
    let mut rec = vec![0.0; n * n];
    zh_rotate(eval, &zh, [psi.sin(), 0.0, psi.cos()], &mut rec);
    let err: f64 = rec.iter().zip(f).map(|(a, b)| (a - b) * (a - b)).sum();
    let rel_error = if total > 0.0 { (err / total).sqrt() } else { 0.0 };
    LobeFit { psi, zh, rel_error }
}
