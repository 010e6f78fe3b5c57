//! Quadratic SH → optimal hemispherical linear SH (OHLSH), MRT thesis App. B.
//!
//! Minimising `∫_H [L₂(ω) − L₁(ω)]² dω` over the upper hemisphere `H = {z ≥ 0}` (the
//! texel's normal is +z) gives `H₁ a = H₂ b` with `[H₁]_ik = ∫_H y_i y_k` (4×4) and
//! `[H₂]_kj = ∫_H y_k y_j` (4×9), so `a = H₁⁻¹ H₂ b`. We build both Gram matrices by
//! exact hemispherical quadrature (the integrands are polynomials of degree ≤ 3 in z on
//! `[0, 1]` times trigonometric polynomials in φ) and solve; the tests compare with the
//! thesis's closed form (B.3) `a = {b₁ − c₁b₇, b₂ + c₂b₆, b₃ + c₃b₇, b₄ + c₂b₈}`,
//! `c₁ = 3√5/4, c₂ = 3√5/8, c₃ = √15/2` (1-based indices in our SH order).

use crate::linalg::solve;
use crate::quadrature::GaussLegendre;
use crate::sh::ShEval;
use core::f64::consts::PI;

/// The 4×9 row-major matrix `A = H₁⁻¹ H₂` mapping quadratic SH to OHLSH.
pub fn quadratic_to_ohlsh() -> [f64; 36] {
    let eval = ShEval::new(3);
    let gl = GaussLegendre::new(8);
    let nphi = 16;
    let mut gram = [0.0f64; 81];
    let mut y = [0.0; 9];
    for (z, wz) in gl.on_interval(0.0, 1.0) {
        let r = (1.0 - z * z).sqrt();
        for k in 0..nphi {
            let phi = 2.0 * PI * (k as f64 + 0.5) / nphi as f64;
            eval.eval_into([r * phi.cos(), r * phi.sin(), z], &mut y);
            let w = wz * 2.0 * PI / nphi as f64;
            for i in 0..9 {
                for j in 0..9 {
                    gram[i * 9 + j] += w * y[i] * y[j];
                }
            }
        }
    }
    let mut h1 = [0.0; 16];
    for i in 0..4 {
        for k in 0..4 {
            h1[i * 4 + k] = gram[i * 9 + k];
        }
    }
    let mut a = [0.0; 36];
    for j in 0..9 {
        let rhs: Vec<f64> = (0..4).map(|k| gram[k * 9 + j]).collect();
        // H₁ is a Gram matrix of independent functions: positive definite, never singular.
        let col = solve(&h1, &rhs, 4).unwrap_or_else(|| vec![0.0; 4]);
        for i in 0..4 {
            a[i * 9 + j] = col[i];
        }
    }
    a
}

/// The thesis's closed form (B.3) as a 4×9 matrix.
pub fn closed_form() -> [f64; 36] {
    let c1 = 3.0 * 5.0f64.sqrt() / 4.0;
    let c2 = 3.0 * 5.0f64.sqrt() / 8.0;
    let c3 = 15.0f64.sqrt() / 2.0;
    let mut a = [0.0; 36];
    // 0-based: a0 = b0 − c1 b6, a1 = b1 + c2 b5, a2 = b2 + c3 b6, a3 = b3 + c2 b7
    a[0] = 1.0;
    a[6] = -c1;
    a[9 + 1] = 1.0;
    a[9 + 5] = c2;
    a[18 + 2] = 1.0;
    a[18 + 6] = c3;
    a[27 + 3] = 1.0;
    a[27 + 7] = c2;
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ohlsh_matches_closed_form() {
        let a = quadratic_to_ohlsh();
        let c = closed_form();
        for (x, y) in a.iter().zip(&c) {
            assert!((x - y).abs() < 1e-12, "{x} vs {y}");
        }
    }
}
