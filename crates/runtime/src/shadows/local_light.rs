//! Local spherical lights (SHEXP §7, "Analytic Lights"): shading with the baked table
//! `L_H(θ, φ) = H(ẑ) * L(θ, φ)` through its single-lobe ZH fit.
//!
//! At a receiver `(p, N)` a spherical light of centre `C`, radius `R` and radiance `L_e`
//! subtends `θ = asin(R/‖C − p‖)` about `d̂ = (C − p)/‖C − p‖`, at `φ = acos(N·d̂)` from the
//! normal. The table's canonical frame has the normal on `z` and the light in the xz-plane;
//! its fitted lobe has axis `(sin ψ, 0, cos ψ)` and plain zonal coefficients `z_l`
//! (`local_light_zh`, schemas/asset-format.md). At run time:
//! 1. look the lobe up at `(θ, φ)`: bilinear in the grid `θ_i = (π/2)(i+1)/32`,
//!    `φ_j = π j/63`, blending the unit axes (renormalised) and the `z_l` per unit solid
//!    angle, `z_l(θ_i)/(1 − cos θ_i)`, scaled back by `1 − cos θ` (the lobe grows with the
//!    light's solid angle: at θ = 8.6° on the normal, order 4, the lookup is 0.005 % from the
//!    bake's f64 `L_H` against 0.6 % when blending `z_l` directly);
//!    below the first θ sample (`π/64`) the lobe keeps its shape and scales with the solid
//!    angle (a small light is a delta times its solid angle); `θ` is clamped to `π/2`
//!    (receiver inside the light);
//! 2. rotate it to the light: the axis becomes `sin ψ·x̂ + cos ψ·N` with `x̂` the unit
//!    component of `d̂` orthogonal to `N`, and the zonal rotation rule (SHEXP §6.1) gives
//!    `t_lm = √(4π/(2l+1)) z_l y_lm(axis)`;
//! 3. dot with the visibility: `E = π L_e Σ_lm t_lm g_lm` (`H = max(z, 0)/π`, so the π makes
//!    `E` irradiance), `g` windowed as in [`ShadowEvaluator::shade`] when windowing is on.
//!
//! The fit is exact for a light on the normal and keeps band 0 (the unshadowed shading);
//! off the normal it is the paper's approximation (docs/tables.md).

use super::{N2, ShadowEvaluator, Sphere, band, dot, sub};
use crate::sh::MAX_ORDER;
use crate::tables::{LOCAL_LIGHT_PHI, LOCAL_LIGHT_THETA};
use core::f32::consts::PI;

/// A spherical light source at a finite distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalLight {
    /// Centre and radius of the emitting sphere.
    pub sphere: Sphere,
    /// Emitted radiance, RGB.
    pub radiance: [f32; 3],
}

impl ShadowEvaluator<'_> {
    /// The light's rotated transfer vector `t` at `(p, n)` (`order²` entries, see the module
    /// docs), or `None` if the tables have no local-light table or the light is invalid.
    pub fn local_light_transfer(&self, p: [f32; 3], n: [f32; 3], light: &LocalLight, t: &mut [f32]) -> Option<()> {
        let table = self.tables.local_light_zh()?;
        if !light.sphere.is_valid() {
            return None;
        }
        let order = self.order;
        let v = sub(light.sphere.center, p);
        let d = dot(v, v).sqrt();
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let dir = [v[0] / d, v[1] / d, v[2] / d];
        let theta = if light.sphere.radius >= d { 0.5 * PI } else { (light.sphere.radius / d).asin() };
        let cos_phi = dot(n, dir).clamp(-1.0, 1.0);
        let phi = cos_phi.acos();
        // table coordinates; the z_l are interpolated per unit solid angle of the light,
        // `z_l(θ_i)/(1 − cos θ_i)`, and scaled back by `1 − cos θ` (the lobe's size goes with the
        // light's solid angle: linear interpolation of `z_l` itself misses that quadratic)
        let theta0 = 0.5 * PI / LOCAL_LIGHT_THETA as f32;
        let u = (theta / theta0 - 1.0).clamp(0.0, (LOCAL_LIGHT_THETA - 1) as f32);
        let one_minus_cos = |t: f32| {
            let s = (0.5 * t).sin();
            2.0 * s * s
        };
        let vv = (phi / PI * (LOCAL_LIGHT_PHI - 1) as f32).clamp(0.0, (LOCAL_LIGHT_PHI - 1) as f32);
        let (i0, j0) = ((u as usize).min(LOCAL_LIGHT_THETA - 2), (vv as usize).min(LOCAL_LIGHT_PHI - 2));
        let (wu, wv) = (u - i0 as f32, vv - j0 as f32);
        let row = order + 2;
        let mut axis = [0.0f32; 2]; // (x, z) in the canonical frame
        let mut zh = [0.0f32; MAX_ORDER];
        for (di, dj, w) in
            [(0, 0, (1.0 - wu) * (1.0 - wv)), (1, 0, wu * (1.0 - wv)), (0, 1, (1.0 - wu) * wv), (1, 1, wu * wv)]
        {
            let e = &table[((i0 + di) * LOCAL_LIGHT_PHI + j0 + dj) * row..][..row];
            axis[0] += w * e[0].sin();
            axis[1] += w * e[0].cos();
            let per_solid_angle = w / one_minus_cos(theta0 * (i0 + di + 1) as f32);
            for l in 0..order {
                zh[l] += per_solid_angle * e[1 + l];
            }
        }
        let scale = one_minus_cos(theta);
        let len = (axis[0] * axis[0] + axis[1] * axis[1]).sqrt();
        let (sx, cz) = if len > 0.0 { (axis[0] / len, axis[1] / len) } else { (0.0, 1.0) };
        // x̂: the light's direction orthogonal to the normal (any orthogonal unit vector when
        // the light is on the normal's line, where the lobe's axis is ±N anyway)
        let mut x = [dir[0] - cos_phi * n[0], dir[1] - cos_phi * n[1], dir[2] - cos_phi * n[2]];
        let xl = dot(x, x).sqrt();
        if xl > 1e-6 {
            x = [x[0] / xl, x[1] / xl, x[2] / xl];
        } else {
            let a = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
            let k = dot(a, n);
            let o = [a[0] - k * n[0], a[1] - k * n[1], a[2] - k * n[2]];
            let ol = dot(o, o).sqrt();
            x = [o[0] / ol, o[1] / ol, o[2] / ol];
        }
        let ax = [sx * x[0] + cz * n[0], sx * x[1] + cz * n[1], sx * x[2] + cz * n[2]];
        let mut star = [0.0f32; MAX_ORDER];
        for l in 0..order {
            star[l] = scale * zh[l] * (4.0 * PI / (2 * l + 1) as f32).sqrt();
        }
        self.tables.basis().rotate_zonal(&star[..order], ax, &mut t[..order * order]);
        Some(())
    }

    /// Irradiance at `(p, n)` from `light` for the total visibility `g` (from
    /// [`ShadowEvaluator::visibility`]), RGB; `None` without a local-light table or for an
    /// invalid light.
    pub fn shade_local_light(&self, p: [f32; 3], n: [f32; 3], light: &LocalLight, g: &[f32]) -> Option<[f32; 3]> {
        let n2 = self.order * self.order;
        let mut t = [0.0f32; N2];
        self.local_light_transfer(p, n, light, &mut t[..n2])?;
        let w = self.window();
        let mut s = 0.0f32;
        for i in 0..n2 {
            s += t[i] * g[i] * w[band(i)];
        }
        Some(light.radiance.map(|r| PI * r * s))
    }

    /// Shadowed irradiance at `(p, n)` from `light`, blocked by `spheres`.
    pub fn irradiance_local_light(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        spheres: &[Sphere],
        light: &LocalLight,
    ) -> Option<[f32; 3]> {
        let n2 = self.order * self.order;
        let mut g = [0.0f32; N2];
        self.visibility(p, n, spheres, &mut g[..n2]);
        self.shade_local_light(p, n, light, &g[..n2])
    }
}
