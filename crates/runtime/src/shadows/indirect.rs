//! Indirect light from the proxies (IBPA §5, averaged operator `D(θ)`, order 3): each proxy
//! is a diffuse reflector lit by the unshadowed environment; the sum over proxies is
//! normalised for overlap by IBPA eq. 12.

use super::{N2, SQRT_4PI, ShadowEvaluator, Sphere, band, dot, sub};

/// Shadowed direct and indirect irradiance at a receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shaded {
    /// Shadowed irradiance from the environment (RGB).
    pub direct: [f32; 3],
    /// Irradiance from light re-radiated by the proxies (RGB), IBPA §5.
    pub indirect: [f32; 3],
}

impl ShadowEvaluator<'_> {
    /// Shadowed direct irradiance plus indirect irradiance from the proxies (IBPA §5,
    /// averaged operator, order 3). Each proxy is a diffuse reflector of albedo `albedo`
    /// lit by the unshadowed environment: its radiance over the visible disk is
    /// `ρ/π · κ`, `κ = Σ_lm D*_l(α) y_lm(d̂) L̃_lm` with `L̃` the order-3 irradiance SH
    /// (IBPA eq. 15; IBPA folds ρ/π into `L̃`, we keep the physical factor). The sum over
    /// proxies ignores inter-proxy occlusion and is normalised for overlap by IBPA eq. 12:
    /// `ξ = (1 − O_p)₀ / (ω_p/√4π)`, the covered solid angle over the summed one.
    pub fn shade_with_indirect(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere], albedo: [f32; 3]) -> Shaded {
        let order = self.order;
        let n2 = order * order;
        let mut f = [0.0f32; N2];
        let mut g = [0.0f32; N2];
        self.accumulate_log(p, n, spheres, &mut f[..n2]);
        self.exponentiate(&f[..n2], &mut g[..n2]);
        let direct = self.shade(n, &g[..n2]);

        // Indirect, order 3 (9 coefficients).
        let mut sum = [[0.0f32; 9]; 3];
        let mut omega = 0.0f32;
        let mut y = [0.0f32; N2];
        let mut v = [0.0f32; 3];
        let mut d = [0.0f32; 3];
        let basis3 = &self.basis3;
        for &s0 in spheres {
            let Some(s) = self.effective(s0, p, n) else { continue };
            let w = sub(s.center, p);
            let dist = dot(w, w).sqrt();
            if dist.is_nan() || dist <= 0.0 {
                continue;
            }
            let alpha = (s.radius / dist).min(1.0);
            self.tables.proxy_visibility(alpha, &mut v);
            if v[0] == 0.0 {
                continue; // outside the indirect sphere of influence
            }
            self.tables.indirect_d(alpha, &mut d);
            let dir = [w[0] / dist, w[1] / dist, w[2] / dist];
            basis3.eval(dir, &mut y[..9]);
            // ω_i = 2π(1 − √(1 − α²)) = 2π α²/(1 + √(1 − α²)), cancellation-free
            omega += 2.0 * core::f32::consts::PI * alpha * alpha / (1.0 + (1.0 - alpha * alpha).max(0.0).sqrt());
            for c in 0..3 {
                let mut kappa = 0.0f32;
                for i in 0..9 {
                    kappa += d[band(i)] * y[i] * self.irradiance_sh[c][i];
                }
                let radiance = albedo[c] / core::f32::consts::PI * kappa;
                for i in 0..9 {
                    sum[c][i] += radiance * v[band(i)] * y[i];
                }
            }
        }
        let mut indirect = [0.0f32; 3];
        if omega > 0.0 {
            let covered = SQRT_4PI - g[0];
            let xi = (covered / (omega / SQRT_4PI)).max(0.0);
            let mut h = [0.0f32; 9];
            basis3.rotate_zonal(&self.cosine_star[..3], n, &mut h);
            for c in 0..3 {
                indirect[c] = xi * (0..9).map(|i| sum[c][i] * h[i]).sum::<f32>();
            }
        }
        Shaded { direct, indirect }
    }
}
