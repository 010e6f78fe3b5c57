//! Diffuse shading under the environment (SHEXP §7): `E = (H(N), L, g) = H(N)ᵀ M_L g` with
//! the light's product matrix `M_L` (built once per environment) and the clamped cosine
//! `H(N)` rotated to the normal by the zonal rule; lighting and visibility windowed by the
//! tables' cosine window (`α_l = cos(π l / 2h)`, `h = 2n`) when enabled.

use super::{N2, SQRT_4PI, ShadowEvaluator, band};

impl ShadowEvaluator<'_> {
    /// Irradiance `E = (H(N), L, g)` for a total visibility `g` (windowed first if
    /// enabled), RGB.
    pub fn shade(&self, n: [f32; 3], g: &[f32]) -> [f32; 3] {
        let order = self.order;
        let n2 = order * order;
        let mut h = [0.0f32; N2];
        self.tables.basis().rotate_zonal(&self.cosine_star[..order], n, &mut h[..n2]);
        let mut gw = [0.0f32; N2];
        for i in 0..n2 {
            gw[i] = g[i] * self.window[band(i)];
        }
        let mut out = [0.0f32; 3];
        for (c, m) in self.light_matrix.iter().enumerate() {
            let mut s = 0.0f32;
            for i in 0..n2 {
                if h[i] == 0.0 {
                    continue;
                }
                let row = &m[i * n2..(i + 1) * n2];
                let mut acc = 0.0f32;
                for k in 0..n2 {
                    acc += row[k] * gw[k];
                }
                s += h[i] * acc;
            }
            out[c] = s;
        }
        out
    }

    /// Unshadowed irradiance at normal `n` (visibility `1`).
    pub fn unshadowed(&self, n: [f32; 3]) -> [f32; 3] {
        let mut one = [0.0f32; N2];
        one[0] = SQRT_4PI;
        self.shade(n, &one)
    }

    /// The cosine window per band (all ones when windowing is off).
    pub(crate) fn window(&self) -> &[f32] {
        &self.window[..self.order]
    }
}

/// `√(4π/(2l+1))` times the clamped-cosine ZH coefficient: π, 2π/3, π/4, 0, −π/24, …
pub(crate) fn clamped_cosine_star(l: usize) -> f32 {
    use core::f64::consts::PI;
    let v = match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // Â_l = 2π (−1)^{l/2 − 1} / ((l + 2)(l − 1)) · l! / (2^l ((l/2)!)²)
            let mut fact_ratio = 1.0f64; // l! / (2^l ((l/2)!)^2)
            for k in 1..=l {
                fact_ratio *= k as f64;
            }
            let mut half = 1.0f64;
            for k in 1..=l / 2 {
                half *= k as f64;
            }
            fact_ratio /= 2f64.powi(l as i32) * half * half;
            let sign = if (l / 2) % 2 == 1 { 1.0 } else { -1.0 };
            2.0 * PI * sign / ((l + 2) as f64 * (l - 1) as f64) * fact_ratio
        }
    };
    v as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamped_cosine_known_values() {
        use core::f32::consts::PI;
        let want = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0, -PI / 24.0, 0.0, PI / 64.0];
        for (l, w) in want.iter().enumerate() {
            assert!((clamped_cosine_star(l) - w).abs() < 1e-6, "l={l}: {}", clamped_cosine_star(l));
        }
    }
}
