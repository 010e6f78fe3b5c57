//! Diffuse shading under the environment (SHEXP §7): `E = (H(N), L, g) = H(N)ᵀ M_L g` with
//! the light's product matrix `M_L` (built once per environment) and the clamped cosine
//! `H(N)` rotated to the normal by the zonal rule; lighting and visibility windowed by the
//! tables' cosine window (`α_l = cos(π l / 2h)`, `h = 2n`) when enabled.

use super::batch::LANES;
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

    /// [`ShadowEvaluator::shade`] on every lane of a receiver batch (compile-time order `N`,
    /// `N2 = N²`, the evaluator's): the same operations in the same order per lane, so each
    /// lane equals the scalar result bit for bit. A row the scalar path skips for a lane
    /// (`H_i = 0` there) is computed for the batch when some other lane needs it, and the
    /// lane keeps its sum unchanged (a select, not an added zero: `0·∞` would be NaN).
    #[inline(always)]
    pub(crate) fn shade_lanes<const N: usize, const N2: usize>(
        &self,
        n: &[[f32; LANES]; 3],
        g: &[[f32; LANES]; N2],
    ) -> [[f32; LANES]; 3] {
        let zh: &[f32; N] = self.cosine_star[..N].try_into().expect("order N");
        let mut h = [[0.0f32; LANES]; N2];
        self.tables.basis().rotate_zonal_lanes::<N, N2, LANES>(zh, n, &mut h);
        let mut gw = [[0.0f32; LANES]; N2];
        for i in 0..N2 {
            let w = self.window[band(i)];
            for lane in 0..LANES {
                gw[i][lane] = g[i][lane] * w;
            }
        }
        let mut out = [[0.0f32; LANES]; 3];
        for (c, m) in self.light_matrix.iter().enumerate() {
            let mut s = [0.0f32; LANES];
            for i in 0..N2 {
                let used = h[i].map(|v| v != 0.0);
                if !used.iter().any(|&u| u) {
                    continue;
                }
                let row: &[f32; N2] = m[i * N2..(i + 1) * N2].try_into().expect("n² × n² light matrix");
                let mut acc = [0.0f32; LANES];
                for k in 0..N2 {
                    for lane in 0..LANES {
                        acc[lane] += row[k] * gw[k][lane];
                    }
                }
                for lane in 0..LANES {
                    s[lane] = if used[lane] { s[lane] + h[i][lane] * acc[lane] } else { s[lane] };
                }
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
