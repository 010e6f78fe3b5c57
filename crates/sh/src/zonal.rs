//! Zonal harmonics (ZH) of the circularly symmetric functions the tables need, computed
//! exactly and stably at the extremes.
//!
//! A ZH vector `z[l]` holds the coefficients of `y_{l,0}` of a function symmetric about +z;
//! [`to_sh`] expands it to a full `n²` SH vector, [`penumbra_math::sh::zh_rotate`] rotates it.

use core::f64::consts::PI;
use penumbra_math::quadrature::gauss_legendre_cached;
use penumbra_math::sh::{eval_zonal, index};

/// Projects `f(z)` (a function of `z = cos θ` only) on `y_{l,0}` over `z ∈ [a, b]`:
/// `z_l = 2π ∫_a^b f(z) y_{l,0}(z) dz`, by `nodes`-point Gauss–Legendre.
/// Exact when `f` is a polynomial of degree `≤ 2·nodes − order`.
pub fn project_interval(order: usize, a: f64, b: f64, nodes: usize, f: impl Fn(f64) -> f64) -> Vec<f64> {
    let gl = gauss_legendre_cached(nodes);
    let mut out = vec![0.0; order];
    let mut y = vec![0.0; order];
    for (z, w) in gl.on_interval(a, b) {
        eval_zonal(order, z, &mut y);
        let fz = f(z);
        for l in 0..order {
            out[l] += 2.0 * PI * w * fz * y[l];
        }
    }
    out
}

/// ZH of the indicator of the cap `z ≥ cos θ` (solid angle `2π(1 − cos θ)`), i.e. the
/// *occlusion* of a blocker cap of half-angle `θ` around +z (IBPA's proxy visibility `V`).
///
/// The interval length `1 − cos θ = 2 sin²(θ/2)` is formed without cancellation, so the
/// result keeps full relative precision down to `θ ~ 1e-150`.
pub fn cap_indicator(order: usize, theta: f64) -> Vec<f64> {
    let theta = theta.clamp(0.0, PI);
    let len = 2.0 * (0.5 * theta).sin().powi(2); // 1 − cos θ
    let gl = gauss_legendre_cached(order / 2 + 1);
    let mut out = vec![0.0; order];
    let mut y = vec![0.0; order];
    for (u, w) in gl.on_interval(0.0, 1.0) {
        // z = 1 − len·u; dz = len·du
        eval_zonal(order, 1.0 - len * u, &mut y);
        for l in 0..order {
            out[l] += 2.0 * PI * len * w * y[l];
        }
    }
    out
}

/// ZH of the *visibility* of a blocker cap of half-angle `θ` around +z: 0 inside the cap,
/// 1 outside (SHEXP eq. 33). Up to 90° it is `1 − occlusion` with the occlusion from
/// [`cap_indicator`] (so `θ = 0` gives exactly `1` and the non-DC coefficients keep full
/// relative precision); beyond 90° it is integrated directly on `z ∈ [−1, cos θ]` (length
/// `2 cos²(θ/2)`), which stays accurate when the cap covers almost the whole sphere.
pub fn cap_visibility(order: usize, theta: f64) -> Vec<f64> {
    let theta = theta.clamp(0.0, PI);
    if theta <= 0.5 * PI {
        let mut g: Vec<f64> = cap_indicator(order, theta).into_iter().map(|o| -o).collect();
        g[0] += (4.0 * PI).sqrt();
        return g;
    }
    let len = 2.0 * (0.5 * theta).cos().powi(2); // 1 + cos θ
    let gl = gauss_legendre_cached(order / 2 + 1);
    let mut out = vec![0.0; order];
    let mut y = vec![0.0; order];
    for (u, w) in gl.on_interval(0.0, 1.0) {
        eval_zonal(order, -1.0 + len * u, &mut y);
        for l in 0..order {
            out[l] += 2.0 * PI * len * w * y[l];
        }
    }
    out
}

/// ZH of the clamped cosine `max(z, 0)` (its convolution factors `√(4π/(2l+1))·z_l` are
/// `π, 2π/3, π/4, 0, −π/24, …`).
pub fn clamped_cosine(order: usize) -> Vec<f64> {
    project_interval(order, 0.0, 1.0, order / 2 + 2, |z| z)
}

/// ZH of the diffuse transfer `H = max(z, 0)/π` of SHEXP eq. 9 (normal along +z).
pub fn irradiance_weight(order: usize) -> Vec<f64> {
    clamped_cosine(order).into_iter().map(|c| c / PI).collect()
}

/// Expands a ZH vector (axis +z) to a full SH vector of `n²` coefficients.
pub fn to_sh(zh: &[f64]) -> Vec<f64> {
    let n = zh.len();
    let mut out = vec![0.0; n * n];
    for l in 0..n {
        out[index(l, 0)] = zh[l];
    }
    out
}

/// Extracts the `m = 0` coefficients of a full SH vector.
pub fn from_sh(sh: &[f64], order: usize) -> Vec<f64> {
    (0..order).map(|l| sh[index(l, 0)]).collect()
}

/// The constant function 1 as an SH vector: `(√4π, 0, …)`.
pub fn one(order: usize) -> Vec<f64> {
    let mut v = vec![0.0; order * order];
    v[0] = (4.0 * PI).sqrt();
    v
}

/// Cosine window of SHEXP §7: band `l` is scaled by `cos(π/2 · l/h)`; `h = 2n` by default.
pub fn cosine_window(order: usize, h: f64) -> Vec<f64> {
    (0..order).map(|l| (0.5 * PI * l as f64 / h).cos()).collect()
}

/// Applies a per-band window to a full SH vector.
pub fn apply_window(sh: &mut [f64], window: &[f64]) {
    for (l, w) in window.iter().enumerate() {
        for c in &mut sh[l * l..(l + 1) * (l + 1)] {
            *c *= w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_math::sh::zh_star_scale;

    #[test]
    fn clamped_cosine_known_answer() {
        let c = clamped_cosine(6);
        let conv: Vec<f64> = c.iter().enumerate().map(|(l, v)| zh_star_scale(l) * v).collect();
        let want = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0, -PI / 24.0, 0.0];
        for l in 0..6 {
            assert!((conv[l] - want[l]).abs() < 1e-14, "l={l}: {} vs {}", conv[l], want[l]);
        }
    }

    #[test]
    fn cap_closed_forms() {
        // ∫_c^1 P_l = (P_{l-1}(c) − P_{l+1}(c))/(2l+1) for l ≥ 1.
        for &theta in &[0.1f64, 0.7, core::f64::consts::FRAC_PI_2, 2.5, 3.1] {
            let n = 8;
            let o = cap_indicator(n, theta);
            let g = cap_visibility(n, theta);
            let c = theta.cos();
            let mut p = [0.0; 10];
            penumbra_math::sh::legendre(10, c, &mut p);
            for l in 0..n {
                let k = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
                let integral = if l == 0 { 1.0 - c } else { (p[l - 1] - p[l + 1]) / (2 * l + 1) as f64 };
                assert!((o[l] - 2.0 * PI * k * integral).abs() < 1e-13);
                let full = if l == 0 { (4.0 * PI).sqrt() } else { 0.0 };
                assert!((o[l] + g[l] - full).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn tiny_cap_keeps_relative_precision() {
        // Solid angle of a cap ~ πθ²; o_0 = solid angle · y_00.
        for &theta in &[1e-6f64, 1e-9, 1e-12] {
            let o = cap_indicator(4, theta);
            let want = PI * theta * theta * 0.5 / PI.sqrt();
            assert!(((o[0] - want) / want).abs() < 1e-9, "θ={theta}");
            // Small caps look like a delta: o_l ≈ ω · y_l0(+z).
            let yl = ((2 * 3 + 1) as f64 / (4.0 * PI)).sqrt();
            assert!(((o[3] / (PI * theta * theta)) - yl).abs() / yl < 1e-6);
        }
    }
}
