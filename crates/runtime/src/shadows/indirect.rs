//! Indirect light from the proxies (IBPA §5, order 3): each proxy is a diffuse reflector lit
//! by the unshadowed environment; its radiance over the visible disk by one of the paper's
//! three operators ([`IndirectOperator`]); the sum over proxies ignores inter-proxy occlusion
//! and is normalised for overlap by IBPA eq. 12.

use super::{N2, SQRT_4PI, ShadowEvaluator, Sphere, band, dot, sub};

/// Shadowed direct and indirect irradiance at a receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shaded {
    /// Shadowed irradiance from the environment (RGB).
    pub direct: [f32; 3],
    /// Irradiance from light re-radiated by the proxies (RGB), IBPA §5.
    pub indirect: [f32; 3],
}

/// How a proxy's outgoing radiance is modelled (IBPA §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IndirectOperator {
    /// Point sampled (eq. 13): the irradiance at the proxy's point facing the receiver,
    /// `L̃(−d̂)`, pasted over its whole visible disk.
    PointSampled,
    /// Averaged (eq. 14–15): the disk's mean irradiance `κ = rot(D(θ), d̂)·L̃`, constant over
    /// the disk. The default.
    Averaged,
    /// Exact (eq. 16–17): the radiance distribution `R⁻¹ M(θ) R L̃` over the disk (the SHTB
    /// `indirect_m` table; falls back to nothing if the tables lack it).
    Exact,
}

/// Rotation of order-3 SH vectors into a proxy's frame by point evaluation: band `l` of
/// `f(Rᵀx)` is fixed by its values at `2l + 1` directions, `c' = A_l⁻¹ (f(Rᵀu_k))_k` with
/// `A_l[k][m] = y_lm(u_k)` inverted once.
#[derive(Debug, Clone)]
pub(crate) struct Rot3 {
    dirs: [[f32; 3]; 8],
    inv1: [[f32; 3]; 3],
    inv2: [[f32; 5]; 5],
}

fn invert<const K: usize>(a: [[f64; K]; K]) -> [[f32; K]; K] {
    // Gauss–Jordan with partial pivoting (the matrices are fixed and well conditioned)
    let mut m = a;
    let mut inv = [[0.0f64; K]; K];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for c in 0..K {
        let p = (c..K).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs())).unwrap_or(c);
        m.swap(c, p);
        inv.swap(c, p);
        let d = m[c][c];
        for k in 0..K {
            m[c][k] /= d;
            inv[c][k] /= d;
        }
        for r in 0..K {
            if r != c {
                let f = m[r][c];
                for k in 0..K {
                    m[r][k] -= f * m[c][k];
                    inv[r][k] -= f * inv[c][k];
                }
            }
        }
    }
    inv.map(|r| r.map(|v| v as f32))
}

impl Rot3 {
    pub(crate) fn new(basis3: &crate::sh::ShBasis) -> Self {
        let h = core::f32::consts::FRAC_1_SQRT_2;
        let dirs = [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [h, h, 0.0],
            [h, 0.0, h],
            [0.0, h, h],
        ];
        let mut y = [0.0f32; 9];
        let mut a1 = [[0.0f64; 3]; 3];
        let mut a2 = [[0.0f64; 5]; 5];
        for k in 0..3 {
            basis3.eval(dirs[k], &mut y);
            for m in 0..3 {
                a1[k][m] = f64::from(y[1 + m]);
            }
        }
        for k in 0..5 {
            basis3.eval(dirs[3 + k], &mut y);
            for m in 0..5 {
                a2[k][m] = f64::from(y[4 + m]);
            }
        }
        Self { dirs, inv1: invert(a1), inv2: invert(a2) }
    }

    /// The three channels of `l` expressed in the frame with rows `frame` (`R x = frame·x`).
    fn rotate(&self, basis3: &crate::sh::ShBasis, frame: &[[f32; 3]; 3], l: &[[f32; 9]; 3]) -> [[f32; 9]; 3] {
        let mut out = [[0.0f32; 9]; 3];
        let mut vals = [[0.0f32; 8]; 3];
        let mut y = [0.0f32; 9];
        for (k, u) in self.dirs.iter().enumerate() {
            // Rᵀu
            let x: [f32; 3] = core::array::from_fn(|q| u[0] * frame[0][q] + u[1] * frame[1][q] + u[2] * frame[2][q]);
            basis3.eval(x, &mut y);
            let range = if k < 3 { 1..4 } else { 4..9 };
            for c in 0..3 {
                vals[c][k] = range.clone().map(|i| l[c][i] * y[i]).sum();
            }
        }
        for c in 0..3 {
            out[c][0] = l[c][0];
            for m in 0..3 {
                out[c][1 + m] = (0..3).map(|k| self.inv1[m][k] * vals[c][k]).sum();
            }
            for m in 0..5 {
                out[c][4 + m] = (0..5).map(|k| self.inv2[m][k] * vals[c][3 + k]).sum();
            }
        }
        out
    }
}

impl ShadowEvaluator<'_> {
    /// Shadowed direct irradiance plus indirect irradiance from the proxies with the averaged
    /// operator ([`ShadowEvaluator::shade_with_indirect_by`]).
    pub fn shade_with_indirect(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere], albedo: [f32; 3]) -> Shaded {
        self.shade_with_indirect_by(p, n, spheres, albedo, IndirectOperator::Averaged)
    }

    /// Shadowed direct irradiance plus indirect irradiance from the proxies (IBPA §5, order
    /// 3). Each proxy is a diffuse reflector of albedo `albedo` lit by the unshadowed
    /// environment, `L̃` the order-3 irradiance SH (IBPA folds ρ/π into `L̃`, we keep the
    /// physical factor `ρ/π`). Per proxy, with `V_i` its (smoothly clamped) visibility and
    /// `H(N)` the clamped cosine:
    /// - point sampled: `ρ/π · L̃(−d̂) · (V_i·H)`;
    /// - averaged: `ρ/π · κ (V_i·H)`, `κ = Σ_lm D*_l(α) y_lm(d̂) L̃_lm`;
    /// - exact: `ρ/π · w · (M(α) R L̃)·(R H)` with `R` the rotation taking `d̂` to `z` and
    ///   `w = V_0(α)/ω` the clamp's weight (the operator covers the disk itself).
    ///
    /// The sum is normalised by IBPA eq. 12: `ξ = (1 − O_p)₀ / (ω_p/√4π)`, the covered solid
    /// angle over the summed one.
    pub fn shade_with_indirect_by(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        spheres: &[Sphere],
        albedo: [f32; 3],
        op: IndirectOperator,
    ) -> Shaded {
        self.indirect_impl(p, n, spheres, |_| albedo, op)
    }

    /// [`ShadowEvaluator::shade_with_indirect_by`] with an albedo per proxy: `albedo[i]`
    /// (linear RGB) for `spheres[i]`, as stored in an SPHR `albedo` section
    /// ([`crate::SphereSet::albedo_into`]). A sphere without an entry (`i ≥ albedo.len()`)
    /// reflects nothing; it still shadows.
    pub fn shade_with_indirect_per_sphere(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        spheres: &[Sphere],
        albedo: &[[f32; 3]],
        op: IndirectOperator,
    ) -> Shaded {
        self.indirect_impl(p, n, spheres, |i| albedo.get(i).copied().unwrap_or([0.0; 3]), op)
    }

    fn indirect_impl(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        spheres: &[Sphere],
        albedo_of: impl Fn(usize) -> [f32; 3],
        op: IndirectOperator,
    ) -> Shaded {
        let order = self.order;
        let n2 = order * order;
        let mut f = [0.0f32; N2];
        let mut g = [0.0f32; N2];
        self.accumulate_log(p, n, spheres, &mut f[..n2]);
        self.exponentiate(&f[..n2], &mut g[..n2]);
        let direct = self.shade(n, &g[..n2]);

        // Indirect, order 3 (9 coefficients).
        let mut total = [0.0f32; 3];
        let mut omega = 0.0f32;
        let mut y = [0.0f32; 9];
        let mut h = [0.0f32; 9];
        let mut hr = [0.0f32; 9];
        let mut v = [0.0f32; 3];
        let mut d = [0.0f32; 3];
        let mut m = [0.0f32; 81];
        let basis3 = &self.basis3;
        basis3.rotate_zonal(&self.cosine_star[..3], n, &mut h);
        for (si, &s0) in spheres.iter().enumerate() {
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
            let dir = [w[0] / dist, w[1] / dist, w[2] / dist];
            // ω_i = 2π(1 − √(1 − α²)) = 2π α²/(1 + √(1 − α²)), cancellation-free
            let omega_i = 2.0 * core::f32::consts::PI * alpha * alpha / (1.0 + (1.0 - alpha * alpha).max(0.0).sqrt());
            omega += omega_i;
            basis3.eval(dir, &mut y);
            // V_i·H with V_i = rot(v*, d̂)
            let vh: f32 = (0..9).map(|i| v[band(i)] * y[i] * h[i]).sum();
            let albedo = albedo_of(si);
            match op {
                IndirectOperator::Averaged | IndirectOperator::PointSampled => {
                    if op == IndirectOperator::Averaged {
                        self.tables.indirect_d(alpha, &mut d);
                    }
                    for c in 0..3 {
                        let kappa: f32 = match op {
                            // L̃(−d̂): odd bands flip sign
                            IndirectOperator::PointSampled => {
                                (0..9).map(|i| if band(i) == 1 { -y[i] } else { y[i] } * self.irradiance_sh[c][i]).sum()
                            }
                            _ => (0..9).map(|i| d[band(i)] * y[i] * self.irradiance_sh[c][i]).sum(),
                        };
                        total[c] += albedo[c] / core::f32::consts::PI * kappa * vh;
                    }
                }
                IndirectOperator::Exact => {
                    if !self.tables.indirect_m(alpha, &mut m) {
                        continue;
                    }
                    // R: rows (t, b, d̂), right-handed (t × b = d̂)
                    let a = if dir[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
                    let k = dot(a, dir);
                    let t0 = [a[0] - k * dir[0], a[1] - k * dir[1], a[2] - k * dir[2]];
                    let tl = dot(t0, t0).sqrt();
                    let t = [t0[0] / tl, t0[1] / tl, t0[2] / tl];
                    let b =
                        [dir[1] * t[2] - dir[2] * t[1], dir[2] * t[0] - dir[0] * t[2], dir[0] * t[1] - dir[1] * t[0]];
                    let frame = [t, b, dir];
                    let lr = self.rot3.rotate(basis3, &frame, &self.irradiance_sh);
                    let nr = [dot(t, n), dot(b, n), dot(dir, n)];
                    basis3.rotate_zonal(&self.cosine_star[..3], nr, &mut hr);
                    let weight = v[0] / omega_i;
                    for c in 0..3 {
                        let mut s = 0.0f32;
                        for j in 0..9 {
                            if hr[j] == 0.0 {
                                continue;
                            }
                            let row = &m[9 * j..9 * j + 9];
                            s += hr[j] * (0..9).map(|q| row[q] * lr[c][q]).sum::<f32>();
                        }
                        total[c] += albedo[c] / core::f32::consts::PI * weight * s;
                    }
                }
            }
        }
        let mut indirect = [0.0f32; 3];
        if omega > 0.0 {
            let covered = SQRT_4PI - g[0];
            let xi = (covered / (omega / SQRT_4PI)).max(0.0);
            for c in 0..3 {
                indirect[c] = xi * total[c];
            }
        }
        Shaded { direct, indirect }
    }
}
