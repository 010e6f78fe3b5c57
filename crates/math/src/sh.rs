//! Real orthonormal spherical harmonics: the one convention used everywhere in penumbra.
//!
//! # Convention
//! - Real, orthonormal over the unit sphere: `∫ y_i(s) y_j(s) ds = δ_ij` (ds = solid angle).
//! - Single index `i = l(l+1) + m` for band `l ≥ 0`, `-l ≤ m ≤ l`.
//! - *Order* `n` means `n` bands (`l < n`) and `n²` coefficients.
//! - Condon–Shortley phase as in the graphics literature (Sloan's "Stupid SH tricks"):
//!   `y_{1,-1} = -√(3/4π)·y`, `y_{1,0} = √(3/4π)·z`, `y_{1,1} = -√(3/4π)·x`.
//! - For `m > 0`: `y_{l,m} = √2 K_l^m P_l^m(cos θ) cos(mφ)`, `y_{l,-m} = √2 K_l^m P_l^m(cos θ) sin(mφ)`,
//!   `y_{l,0} = K_l^0 P_l(cos θ)`, with `P_l^m` including the `(-1)^m` phase and
//!   `K_l^m = √((2l+1)/(4π) · (l-m)!/(l+m)!)`; `θ` is measured from +z, `φ` from +x toward +y.
//!
//! Directions are unit vectors `[x, y, z]` in the frame of the caller (the SH frame is
//! the world frame; nothing here assumes a particular "up").

use core::f64::consts::PI;

/// Largest band count supported by [`eval_into`]. Bakes use orders 2..=8; references
/// evaluate up to order 24 (e.g. for exact quadrature checks of products).
pub const MAX_ORDER: usize = 32;

/// Single index of `(l, m)`.
#[inline]
pub const fn index(l: usize, m: i64) -> usize {
    ((l * (l + 1)) as i64 + m) as usize
}

/// Band `l` of single index `i`.
#[inline]
pub fn band_of(i: usize) -> usize {
    // i = l² + l + m, l² ≤ i < (l+1)²
    let mut l = (i as f64).sqrt() as usize;
    while l * l > i {
        l -= 1;
    }
    while (l + 1) * (l + 1) <= i {
        l += 1;
    }
    l
}

/// `(l, m)` of single index `i`.
#[inline]
pub fn lm_of(i: usize) -> (usize, i64) {
    let l = band_of(i);
    (l, i as i64 - (l * (l + 1)) as i64)
}

/// Number of coefficients of order `n` (= `n²`).
#[inline]
pub const fn coeff_count(order: usize) -> usize {
    order * order
}

/// Normalisation `K_l^m` (m ≥ 0).
pub fn k_lm(l: usize, m: usize) -> f64 {
    // (l-m)!/(l+m)! as a product to stay in range for large l.
    let mut ratio = 1.0f64;
    for k in (l - m + 1)..=(l + m) {
        ratio /= k as f64;
    }
    ((2 * l + 1) as f64 / (4.0 * PI) * ratio).sqrt()
}

/// Precomputed normalisation constants for fast repeated evaluation.
#[derive(Debug, Clone)]
pub struct ShEval {
    order: usize,
    /// `k[l*order + m]` = K_l^m, times √2 for m > 0.
    k: Vec<f64>,
}

impl ShEval {
    /// Evaluator for order `order` (1..=MAX_ORDER).
    pub fn new(order: usize) -> Self {
        assert!((1..=MAX_ORDER).contains(&order), "SH order out of range");
        let mut k = vec![0.0; order * order];
        for l in 0..order {
            for m in 0..=l {
                let s = if m == 0 { 1.0 } else { core::f64::consts::SQRT_2 };
                k[l * order + m] = s * k_lm(l, m);
            }
        }
        Self { order, k }
    }

    /// Order this evaluator was built for.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Writes `y_i(dir)` for `i < order²` into `out` (`out.len() ≥ order²`).
    /// `dir` must be unit length.
    pub fn eval_into(&self, dir: [f64; 3], out: &mut [f64]) {
        let n = self.order;
        let [x, y, z] = dir;
        // Q_l^m(z) = P_l^m(z) / (1-z²)^{m/2}: polynomial in z; C_m + i S_m = (x + i y)^m
        // carries the sin^m θ factor, so no square roots or trig calls are needed.
        let (mut c, mut s) = (1.0f64, 0.0f64); // (x+iy)^0
        let mut q_mm = 1.0f64; // Q_m^m = (-1)^m (2m-1)!!
        for m in 0..n {
            if m > 0 {
                let (c2, s2) = (c * x - s * y, c * y + s * x);
                c = c2;
                s = s2;
                q_mm *= -((2 * m - 1) as f64);
            }
            // l = m
            let mut q_lm2 = 0.0;
            let mut q_lm1 = q_mm;
            self.store(out, m, m, q_mm, c, s);
            if m + 1 < n {
                let q = z * (2 * m + 1) as f64 * q_mm;
                self.store(out, m + 1, m, q, c, s);
                q_lm2 = q_lm1;
                q_lm1 = q;
            }
            for l in (m + 2)..n {
                let q = ((2 * l - 1) as f64 * z * q_lm1 - (l + m - 1) as f64 * q_lm2) / (l - m) as f64;
                self.store(out, l, m, q, c, s);
                q_lm2 = q_lm1;
                q_lm1 = q;
            }
        }
    }

    #[inline]
    fn store(&self, out: &mut [f64], l: usize, m: usize, q: f64, c: f64, s: f64) {
        let kq = self.k[l * self.order + m] * q;
        let base = l * (l + 1);
        if m == 0 {
            out[base] = kq;
        } else {
            out[base + m] = kq * c;
            out[base - m] = kq * s;
        }
    }

    /// Convenience: allocate and evaluate.
    pub fn eval(&self, dir: [f64; 3]) -> Vec<f64> {
        let mut out = vec![0.0; self.order * self.order];
        self.eval_into(dir, &mut out);
        out
    }
}

/// Evaluates the zonal basis functions `y_{l,0}` at `z = cos θ` for `l < order`.
pub fn eval_zonal(order: usize, z: f64, out: &mut [f64]) {
    let mut p_prev = 0.0;
    let mut p = 1.0;
    for l in 0..order {
        if l == 1 {
            p_prev = p;
            p = z;
        } else if l > 1 {
            let next = ((2 * l - 1) as f64 * z * p - (l - 1) as f64 * p_prev) / l as f64;
            p_prev = p;
            p = next;
        }
        out[l] = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * p;
    }
}

/// Legendre polynomials `P_0..P_{count-1}` at `x`.
pub fn legendre(count: usize, x: f64, out: &mut [f64]) {
    for l in 0..count {
        out[l] = match l {
            0 => 1.0,
            1 => x,
            _ => ((2 * l - 1) as f64 * x * out[l - 1] - (l - 1) as f64 * out[l - 2]) / l as f64,
        };
    }
}

/// Rotation rule for zonal functions (IBPA eq. 8; SHEXP §6.1): the SH vector of a
/// function that is circularly symmetric about `axis` with zonal coefficients `zh[l]`
/// (coefficients of `y_{l,0}` when the axis is +z) is
/// `out[l,m] = √(4π/(2l+1)) · zh[l] · y_{l,m}(axis)`.
pub fn zh_rotate(eval: &ShEval, zh: &[f64], axis: [f64; 3], out: &mut [f64]) {
    let n = zh.len();
    debug_assert!(n <= eval.order());
    eval.eval_into(axis, out);
    for l in 0..n {
        let scale = (4.0 * PI / (2 * l + 1) as f64).sqrt() * zh[l];
        for i in l * l..(l + 1) * (l + 1) {
            out[i] *= scale;
        }
    }
}

/// The scale `√(4π/(2l+1))` that turns zonal coefficients into the `g*_l` form of SHEXP §6.1.
#[inline]
pub fn zh_star_scale(l: usize) -> f64 {
    (4.0 * PI / (2 * l + 1) as f64).sqrt()
}

/// Unit vector from spherical angles: `θ` from +z, `φ` from +x toward +y.
#[inline]
pub fn dir_from_angles(theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [st * cp, st * sp, ct]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::SphereQuadrature;

    #[test]
    fn convention_band1_signs() {
        let e = ShEval::new(2);
        let c = (3.0 / (4.0 * PI)).sqrt();
        let y = e.eval([0.0, 0.0, 1.0]);
        assert!((y[2] - c).abs() < 1e-15);
        let y = e.eval([1.0, 0.0, 0.0]);
        assert!((y[3] + c).abs() < 1e-15, "y11 = -c x");
        let y = e.eval([0.0, 1.0, 0.0]);
        assert!((y[1] + c).abs() < 1e-15, "y1-1 = -c y");
        assert!((y[0] - 0.5 / PI.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn band2_closed_forms() {
        // Sloan's closed forms with the same phase convention.
        let e = ShEval::new(3);
        let d = {
            let v = [0.3f64, -0.5, 0.7];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let [x, y, z] = d;
        let out = e.eval(d);
        let c1 = 0.5 * (15.0 / PI).sqrt();
        let c2 = 0.25 * (5.0 / PI).sqrt();
        let c3 = 0.25 * (15.0 / PI).sqrt();
        let expect = [c1 * x * y, -c1 * y * z, c2 * (3.0 * z * z - 1.0), -c1 * x * z, c3 * (x * x - y * y)];
        for (k, e) in expect.iter().enumerate() {
            assert!((out[4 + k] - e).abs() < 1e-14, "index {} {} vs {}", 4 + k, out[4 + k], e);
        }
    }

    #[test]
    fn orthonormal_to_order_12() {
        let n = 12;
        let q = SphereQuadrature::exact_for_degree(2 * n);
        let e = ShEval::new(n);
        let nc = n * n;
        let mut gram = vec![0.0; nc * nc];
        let mut y = vec![0.0; nc];
        for (d, w) in q.iter() {
            e.eval_into(d, &mut y);
            for i in 0..nc {
                for j in 0..nc {
                    gram[i * nc + j] += w * y[i] * y[j];
                }
            }
        }
        for i in 0..nc {
            for j in 0..nc {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((gram[i * nc + j] - want).abs() < 1e-12, "({i},{j})");
            }
        }
    }

    #[test]
    fn zonal_matches_full() {
        let e = ShEval::new(9);
        let mut zo = [0.0; 9];
        for &z in &[-1.0, -0.3, 0.0, 0.77, 1.0] {
            let s = (1.0f64 - z * z).sqrt();
            let full = e.eval([s, 0.0, z]);
            eval_zonal(9, z, &mut zo);
            for l in 0..9 {
                assert!((full[index(l, 0)] - zo[l]).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn index_roundtrip() {
        for i in 0..400 {
            let (l, m) = lm_of(i);
            assert_eq!(index(l, m), i);
            assert!(m.unsigned_abs() as usize <= l);
        }
    }

    #[test]
    fn addition_theorem() {
        // Σ_m y_lm(d)² = (2l+1)/(4π) for every direction.
        let e = ShEval::new(8);
        let y = e.eval(dir_from_angles(1.1, -2.3));
        for l in 0..8 {
            let s: f64 = (l * l..(l + 1) * (l + 1)).map(|i| y[i] * y[i]).sum();
            assert!((s - (2 * l + 1) as f64 / (4.0 * PI)).abs() < 1e-13);
        }
    }
}
