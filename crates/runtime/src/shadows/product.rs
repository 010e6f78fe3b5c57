//! Product-space accumulation (SHEXP eq. 6, the method of Zhou et al. 2005 that log space
//! replaces): the verification reference for log-space accumulation.

use super::{N2, SQRT_4PI, ShadowEvaluator, Sphere, dot, sub};
use crate::sh::MAX_ORDER;

impl ShadowEvaluator<'_> {
    /// Shadowed irradiance by product-space accumulation: `g = g₁ * g₂ * … * g_m`, each
    /// blocker's cap visibility (the tables' θ-grid `cap_visibility`, unclamped) multiplied in
    /// with the order-n triple product and truncated after every product. Same self-shadow
    /// rules and shading as [`ShadowEvaluator::irradiance`]; O(spheres × Γ nonzeros).
    pub fn irradiance_product(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere]) -> [f32; 3] {
        let order = self.order;
        let n2 = order * order;
        let mut g = [0.0f32; N2];
        g[0] = SQRT_4PI;
        let mut gi = [0.0f32; N2];
        let mut tmp = [0.0f32; N2];
        let mut zh = [0.0f32; MAX_ORDER];
        for &s0 in spheres {
            let Some(s) = self.effective(s0, p, n) else { continue };
            let v = sub(s.center, p);
            let d = dot(v, v).sqrt();
            if d.is_nan() || d <= 0.0 || s.radius <= 0.0 {
                continue;
            }
            let theta = (s.radius / d).min(1.0).asin();
            self.tables.cap_visibility(theta, &mut zh[..order]);
            self.tables.basis().rotate_zonal(&zh[..order], [v[0] / d, v[1] / d, v[2] / d], &mut gi[..n2]);
            self.tables.product(&g[..n2], &gi[..n2], &mut tmp[..n2]);
            g[..n2].copy_from_slice(&tmp[..n2]);
        }
        self.shade(n, &g[..n2])
    }
}
