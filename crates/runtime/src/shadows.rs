//! Soft shadows and indirect light from sphere proxies at a receiver (SHEXP §4–7, IBPA §3–5).
//!
//! Per receiver `(p, N)`:
//! 1. accumulate the log visibility of every blocker sphere (SHEXP eq. 34): `α = r/d`,
//!    `f += O^log(α)·y(ŝ)` from the SHTB proxy table (IBPA §4.1: smoothly clamped to zero
//!    below `α = 1/η`), after the self-shadow replacement rules (SHEXP §6.2, [`replace`]);
//! 2. exponentiate (SHEXP §4: HYB by default, OL, or PS*-p);
//! 3. shade a diffuse receiver: `E = (H(N), L, g) = H(N)ᵀ M_L g` with the cosine-windowed
//!    environment `L` (SHEXP §7) — `H(N) = max(s·N, 0)` rotated to the normal;
//! 4. optionally add indirect light from the proxies (IBPA §5, averaged operator, order 3),
//!    normalised for overlap by IBPA eq. 12.
//!
//! Units: `E` is irradiance (W/m² per unit radiance of `L`); the shaded diffuse radiance
//! of an albedo-ρ receiver is `ρE/π`. f32 throughout; no allocation per receiver.

use crate::sh::MAX_ORDER;
use crate::tables::ShTables;

mod batch;
pub use batch::LANES;

const N2: usize = MAX_ORDER * MAX_ORDER;
const SQRT_4PI: f32 = 3.544_907_7;

/// SH exponential used at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RuntimeExp {
    /// Optimal linear with scaling/squaring (SHEXP §4.3). Default.
    Hyb,
    /// Optimal linear, no products (SHEXP eq. 23).
    Ol,
    /// DC isolation + scaling/squaring + factored product series of degree p (SHEXP §4.3).
    PsStar(u32),
}

/// A blocker sphere: centre and radius, in the receiver's world units.
///
/// `repr(C)` (16 bytes: x, y, z, r) so that the C ABI (`penumbra-capi`'s `pn_sphere`) passes
/// the caller's sphere arrays through without copying.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Sphere {
    /// Centre.
    pub center: [f32; 3],
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Whether the sphere can block: finite centre, finite radius > 0. Invalid blockers
    /// (NaN radius through the API, say) are ignored by every evaluation path.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.radius > 0.0 && self.radius.is_finite() && self.center.iter().all(|c| c.is_finite())
    }
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add_scaled(a: [f32; 3], b: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] + b[0] * s, a[1] + b[1] * s, a[2] + b[2] * s]
}

/// Self-shadow replacement rules (SHEXP §6.2) for a blocker `s` seen from a receiver at
/// `p` with unit outward normal `n` (tangent plane `T_p`). Returns the sphere to
/// accumulate, or `None` if it is eliminated. Let `h = (c − p)·N` (height of the centre
/// above `T_p`), `q₁` the projection of `c` onto `T_p` and `d_c = √(r² − h²)` the radius
/// of the sphere's cross-section with `T_p`.
///
/// - `p` inside `S`: eliminated when `h ≤ 0`, else replaced by the sphere of radius `h`
///   about `c` (tangent to `T_p` at `q₁`).
/// - `p` outside `S`: eliminated when entirely behind `T_p` (`h ≤ −r`), unchanged when
///   entirely in front (`h ≥ r`); otherwise replaced by `S'`, the sphere tangent to `T_p`
///   at `q₁` whose diameter is `q₀q₁`, `q₀ = c + rN`, i.e. radius `(h + r)/2`.
///
/// Continuity. Both replacements are spheres tangent to `T_p` at `q₁`; only their radius
/// `ρ` differs (`max(h, 0)` inside, `(h + r)/2` outside), so the rule as stated jumps when
/// `p` leaves `S`. SHEXP fixes this by "gradually scaling up the radius of S' as a function
/// of p's distance to S along the tangent plane" with `α = max(1, (‖p − q₁‖ − d)/d)`,
/// `d = d_c`. As printed, `α ≥ 1` everywhere and equals 1 on the boundary, which cannot
/// make `ρ` continuous there (the text extraction may have lost a `min`). We implement the
/// stated intent: with `t = clamp((‖p − q₁‖ − d_c)/d_c, 0, 1)` — the same quantity, zero
/// on the boundary of `S` and 1 once `p` is `d_c` beyond it — the radius grows linearly
/// from the inside-rule radius to that of `S'`: `ρ = (1 − t)·max(h, 0) + t·(h + r)/2`.
/// The result is continuous in `p` (tested).
pub fn replace(s: Sphere, p: [f32; 3], n: [f32; 3]) -> Option<Sphere> {
    let r = s.radius;
    let cp = sub(s.center, p);
    let h = dot(cp, n);
    let d2 = dot(cp, cp);
    let q1 = add_scaled(s.center, n, -h);
    let tangent = |rho: f32| (rho > 0.0).then(|| Sphere { center: add_scaled(q1, n, rho), radius: rho });
    if d2 < r * r {
        return if h <= 0.0 { None } else { tangent(h) };
    }
    if h <= -r {
        return None;
    }
    if h >= r {
        return Some(s);
    }
    let dc = (r * r - h * h).max(0.0).sqrt();
    let in_plane = {
        let v = sub(p, q1);
        dot(v, v).sqrt()
    };
    let t = if dc > 0.0 { ((in_plane - dc) / dc).clamp(0.0, 1.0) } else { 1.0 };
    tangent((1.0 - t) * h.max(0.0) + t * 0.5 * (h + r))
}

/// Options of the shadow evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowOptions {
    /// SH exponential.
    pub exp: RuntimeExp,
    /// Apply the self-shadow replacement rules (off: accumulate spheres as they are).
    pub self_shadow_rules: bool,
    /// Window lighting and visibility with the table's cosine window (SHEXP §7).
    pub window: bool,
}

impl Default for ShadowOptions {
    fn default() -> Self {
        Self { exp: RuntimeExp::Hyb, self_shadow_rules: true, window: true }
    }
}

/// Evaluates shadowed irradiance at receivers for one lighting environment.
#[derive(Debug, Clone)]
pub struct ShadowEvaluator<'a> {
    tables: &'a ShTables<'a>,
    options: ShadowOptions,
    order: usize,
    /// Per colour channel, the product matrix of the (windowed) light, row-major n²×n².
    light_matrix: [Vec<f32>; 3],
    /// Starred ZH of `H = max(z,0)/π`·π = clamped cosine (so `E` is irradiance).
    cosine_star: [f32; MAX_ORDER],
    window: [f32; MAX_ORDER],
    /// Order-3 irradiance SH of the (unwindowed) light per channel: `L̃ = Â_l L_lm`.
    irradiance_sh: [[f32; 9]; 3],
    basis3: crate::sh::ShBasis,
}

impl<'a> ShadowEvaluator<'a> {
    /// `light` holds RGB SH coefficients of the environment radiance at the tables' order
    /// (`order²` entries, each `[r, g, b]`).
    pub fn new(tables: &'a ShTables<'a>, light: &[[f32; 3]], options: ShadowOptions) -> Self {
        let order = tables.order();
        let n2 = order * order;
        let mut window = [1.0f32; MAX_ORDER];
        if options.window {
            window[..order].copy_from_slice(tables.cosine_window());
        }
        let mut light_matrix = [vec![0.0f32; n2 * n2], vec![0.0f32; n2 * n2], vec![0.0f32; n2 * n2]];
        for (c, m) in light_matrix.iter_mut().enumerate() {
            let mut l = [0.0f32; N2];
            for i in 0..n2.min(light.len()) {
                l[i] = light[i][c] * window[band(i)];
            }
            tables.product_matrix(&l[..n2], m);
        }
        // Clamped cosine ZH (starred): π, 2π/3, π/4, 0, −π/24, 0, π/64, …
        let mut cosine_star = [0.0f32; MAX_ORDER];
        for (l, c) in cosine_star.iter_mut().enumerate().take(order.max(3)) {
            *c = clamped_cosine_star(l);
        }
        let mut irradiance_sh = [[0.0f32; 9]; 3];
        for c in 0..3 {
            for i in 0..9.min(light.len()) {
                irradiance_sh[c][i] = light[i][c] * clamped_cosine_star(band(i));
            }
        }
        Self {
            tables,
            options,
            order,
            light_matrix,
            cosine_star,
            window,
            irradiance_sh,
            basis3: crate::sh::ShBasis::new(3),
        }
    }

    /// The tables.
    pub fn tables(&self) -> &ShTables<'a> {
        self.tables
    }

    /// Accumulates the log visibility of `spheres` at `(p, n)` into `f` (`order²`
    /// entries, zeroed first).
    pub fn accumulate_log(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere], f: &mut [f32]) {
        let get = |i: usize| (spheres[i], None);
        match self.order {
            2 => self.accumulate_n::<2, 4>(p, n, spheres.len(), get, f),
            3 => self.accumulate_n::<3, 9>(p, n, spheres.len(), get, f),
            4 => self.accumulate_n::<4, 16>(p, n, spheres.len(), get, f),
            5 => self.accumulate_n::<5, 25>(p, n, spheres.len(), get, f),
            6 => self.accumulate_n::<6, 36>(p, n, spheres.len(), get, f),
            7 => self.accumulate_n::<7, 49>(p, n, spheres.len(), get, f),
            _ => self.accumulate_n::<8, 64>(p, n, spheres.len(), get, f),
        }
    }

    /// The accumulation loop for a compile-time order `N` (`N2 = N²`): `get(i)` is blocker `i`
    /// with its optional per-band ratio vector (SHEXP eq. 38).
    #[inline(always)]
    fn accumulate_n<'w, const N: usize, const N2: usize>(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>),
        f: &mut [f32],
    ) {
        let mut acc = [0.0f32; N2];
        let basis = self.tables.basis();
        for i in 0..count {
            let (s0, w) = get(i);
            let Some(s) = self.effective(s0, p, n) else { continue };
            let v = sub(s.center, p);
            let d2 = dot(v, v);
            if d2.is_nan() || d2 <= 0.0 || s.radius.is_nan() || s.radius <= 0.0 {
                continue;
            }
            let d = d2.sqrt();
            let alpha = (s.radius / d).min(1.0);
            // no sphere-of-influence skip: far blockers add their small-cap log
            // (`ShTables::proxy_log`), so many small ones keep their summed shadow
            let mut zh = self.tables.proxy_log_n::<N>(alpha);
            if let Some(w) = w {
                for l in 0..N {
                    zh[l] *= w[l];
                }
            }
            let inv = 1.0 / d;
            basis.add_zonal_n::<N, N2>([v[0] * inv, v[1] * inv, v[2] * inv], &zh, &mut acc);
        }
        f[..N2].copy_from_slice(&acc);
    }

    /// Adds one (already replaced) sphere's log visibility at `p` to `f`.
    pub(crate) fn add_sphere_log(&self, p: [f32; 3], s: Sphere, f: &mut [f32]) {
        let order = self.order;
        let v = sub(s.center, p);
        let d = dot(v, v).sqrt();
        if d.is_nan() || d <= 0.0 || s.radius.is_nan() || s.radius <= 0.0 {
            return;
        }
        // p outside after the replacement rules; if still inside (rules off), treat the
        // blocker as covering the whole hemisphere seen from the surface: α = 1.
        let alpha = (s.radius / d).min(1.0);
        let mut zh = [0.0f32; MAX_ORDER];
        self.tables.proxy_log(alpha, &mut zh[..order]);
        let inv = 1.0 / d;
        let dir = [v[0] * inv, v[1] * inv, v[2] * inv];
        self.tables.basis().add_zonal(dir, &zh[..order], f);
    }

    /// `g = exp*(f)` with the configured method.
    pub fn exponentiate(&self, f: &[f32], g: &mut [f32]) {
        match self.options.exp {
            RuntimeExp::Hyb => self.tables.exp_hyb(f, g),
            RuntimeExp::Ol => self.tables.exp_ol(f, g),
            RuntimeExp::PsStar(p) => self.tables.exp_ps_star(f, p, g),
        }
    }

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

    /// Shadowed irradiance at `(p, n)` from `spheres` (steps 1–3).
    pub fn irradiance(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere]) -> [f32; 3] {
        let mut f = [0.0f32; N2];
        let mut g = [0.0f32; N2];
        let n2 = self.order * self.order;
        self.accumulate_log(p, n, spheres, &mut f[..n2]);
        self.exponentiate(&f[..n2], &mut g[..n2]);
        self.shade(n, &g[..n2])
    }
}

impl ShadowEvaluator<'_> {
    /// Shadowed irradiance by *product-space* accumulation (SHEXP eq. 6, the method of Zhou
    /// et al. 2005 that log space replaces): `g = g₁ * g₂ * … * g_m`, each blocker's cap
    /// visibility (unclamped, no sphere of influence) multiplied in with the order-n triple
    /// product and truncated after every product. Same self-shadow rules and shading as
    /// [`ShadowEvaluator::irradiance`]; O(spheres × Γ nonzeros), for verification.
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

/// A blocker of a receiver cluster (SHEXP §6.3): a node of the cluster's cut with its
/// ratio vector `w` (eq. 37, one weight per band; 1 for leaves).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutBlocker {
    /// The node's bounding sphere.
    pub sphere: Sphere,
    /// Per-band scaling of the sphere's log visibility (eq. 37).
    pub w: [f32; MAX_ORDER],
}

impl ShadowEvaluator<'_> {
    /// The blockers of a receiver cluster from its cut (see
    /// [`SphereSet::cut`](crate::sphere_set::SphereSet::cut)), with ratio vectors computed at
    /// the cluster's central point `(p_star, n_star)`: `w_l = Σ_m f_b f_d / Σ_m f_b²` with `f_b`
    /// the log visibility of the node's bounding sphere and `f_d` the summed log visibility of
    /// the leaves below it (SHEXP eq. 37; the self-shadow rules applied as at run time). `out`
    /// is cleared first.
    pub fn cluster_blockers(
        &self,
        set: &crate::sphere_set::SphereSet<'_>,
        cut: &[crate::sphere_set::NodeRef],
        p_star: [f32; 3],
        n_star: [f32; 3],
        out: &mut Vec<CutBlocker>,
    ) {
        use crate::sphere_set::NodeRef;
        out.clear();
        let order = self.order;
        let n2 = order * order;
        for &node in cut {
            let sphere = set.sphere(node);
            let mut w = [1.0f32; MAX_ORDER];
            if let NodeRef::Node(_) = node {
                let mut fb = [0.0f32; N2];
                let mut fd = [0.0f32; N2];
                if let Some(s) = self.effective(sphere, p_star, n_star) {
                    self.add_sphere_log(p_star, s, &mut fb[..n2]);
                }
                set.for_leaves_below(node, &mut |leaf| {
                    if let Some(s) = self.effective(set.leaf(leaf as usize), p_star, n_star) {
                        self.add_sphere_log(p_star, s, &mut fd[..n2]);
                    }
                });
                w = ratio_vector(&fb[..n2], &fd[..n2], order);
            }
            out.push(CutBlocker { sphere, w });
        }
    }

    /// The sphere a receiver at `(p, n)` accumulates for blocker `s` (self-shadow rules when
    /// enabled).
    ///
    /// A blocker whose radius is not a positive finite number or whose centre is not finite
    /// (NaN through the API) is ignored, in every path (scalar, batched, product, indirect).
    #[inline]
    fn effective(&self, s: Sphere, p: [f32; 3], n: [f32; 3]) -> Option<Sphere> {
        if !s.is_valid() {
            return None;
        }
        if self.options.self_shadow_rules { replace(s, p, n) } else { Some(s) }
    }

    /// Accumulates a receiver's log visibility from its cluster's blockers (SHEXP eq. 38:
    /// each sphere's zonal log visibility scaled per band by its ratio vector).
    pub fn accumulate_log_blockers(&self, p: [f32; 3], n: [f32; 3], blockers: &[CutBlocker], f: &mut [f32]) {
        let get = |i: usize| (blockers[i].sphere, Some(&blockers[i].w));
        let c = blockers.len();
        match self.order {
            2 => self.accumulate_n::<2, 4>(p, n, c, get, f),
            3 => self.accumulate_n::<3, 9>(p, n, c, get, f),
            4 => self.accumulate_n::<4, 16>(p, n, c, get, f),
            5 => self.accumulate_n::<5, 25>(p, n, c, get, f),
            6 => self.accumulate_n::<6, 36>(p, n, c, get, f),
            7 => self.accumulate_n::<7, 49>(p, n, c, get, f),
            _ => self.accumulate_n::<8, 64>(p, n, c, get, f),
        }
    }

    /// Shadowed irradiance at `(p, n)` from a cluster's blockers.
    pub fn irradiance_blockers(&self, p: [f32; 3], n: [f32; 3], blockers: &[CutBlocker]) -> [f32; 3] {
        let mut f = [0.0f32; N2];
        let mut g = [0.0f32; N2];
        let n2 = self.order * self.order;
        self.accumulate_log_blockers(p, n, blockers, &mut f[..n2]);
        self.exponentiate(&f[..n2], &mut g[..n2]);
        self.shade(n, &g[..n2])
    }
}

impl ShadowEvaluator<'_> {
    /// Shadowed irradiance with visibility accumulated and exponentiated at the (higher) order
    /// of `accum` and truncated to this evaluator's order before shading (SHEXP Fig. 7e:
    /// "accumulate using n = 6 blocker vectors, exponentiate, and then truncate to n = 4").
    /// `accum` must have an order ≥ this one (otherwise its vector is zero-padded).
    pub fn irradiance_accumulated_by(
        &self,
        accum: &ShadowEvaluator<'_>,
        p: [f32; 3],
        n: [f32; 3],
        spheres: &[Sphere],
    ) -> [f32; 3] {
        let m2 = accum.order * accum.order;
        let mut f = [0.0f32; N2];
        let mut g = [0.0f32; N2];
        accum.accumulate_log(p, n, spheres, &mut f[..m2]);
        accum.exponentiate(&f[..m2], &mut g[..m2]);
        let n2 = self.order * self.order;
        g[m2.min(N2)..].iter_mut().for_each(|v| *v = 0.0);
        self.shade(n, &g[..n2])
    }
}

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

/// Largest ratio a band may take, relative to the DC ratio `w₀` (see [`ratio_vector`]).
pub const RATIO_BOUND: f32 = 4.0;
/// A band whose energy in `f_b` is below this fraction of the DC's is ill-conditioned.
pub const RATIO_BAND_FLOOR: f32 = 1e-3;

/// The ratio vector of a node (SHEXP eq. 37): per band `w_l = Σ_m f_b f_d / Σ_m f_b²`,
/// the least-squares scale of the node's log `f_b` onto its leaves' summed log `f_d`.
///
/// Bounded (issue #14): eq. 37 divides by the band energy of `f_b`, which nears zero for
/// large caps at high order (a band of the cap's ZH crosses zero; order 8, θ ≳ 29°), and the
/// ratio then explodes at every other receiver of the cluster. The DC ratio `w₀` is always
/// well conditioned (`f_b0 < 0`), so
/// - a band with `Σ_m f_b² < 10⁻³·f_b0²` takes `w₀`;
/// - every band is clamped to `[0, 4·max(w₀, 1)]` (a node's leaves never block more than
///   the node's bounding sphere does, per band, by more than that: overlap counts twice).
pub fn ratio_vector(fb: &[f32], fd: &[f32], order: usize) -> [f32; MAX_ORDER] {
    let mut w = [1.0f32; MAX_ORDER];
    let den0 = fb[0] * fb[0];
    if den0.is_nan() || den0 <= 0.0 {
        return w;
    }
    let w0 = (fb[0] * fd[0] / den0).max(0.0);
    let hi = RATIO_BOUND * w0.max(1.0);
    for l in 0..order {
        let (mut num, mut den) = (0.0f32, 0.0f32);
        for i in l * l..(l + 1) * (l + 1) {
            num += fb[i] * fd[i];
            den += fb[i] * fb[i];
        }
        let r = if den > RATIO_BAND_FLOOR * den0 { num / den } else { w0 };
        w[l] = if r.is_finite() { r.clamp(0.0, hi) } else { w0 };
    }
    w
}

fn band(i: usize) -> usize {
    let mut l = 0;
    while (l + 1) * (l + 1) <= i {
        l += 1;
    }
    l
}

/// `√(4π/(2l+1))` times the clamped-cosine ZH coefficient: π, 2π/3, π/4, 0, −π/24, …
fn clamped_cosine_star(l: usize) -> f32 {
    use core::f64::consts::PI;
    let v = match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // 2π (−1)^{l/2+1} (l−2)!! / ((l+2)(l−1) l!!) ·… closed form of the even bands:
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

    #[test]
    fn replacement_rules_cases() {
        let n = [0.0, 0.0, 1.0];
        let p = [0.0, 0.0, 0.0];
        // entirely in front: unchanged
        let s = Sphere { center: [0.0, 0.0, 3.0], radius: 1.0 };
        assert_eq!(replace(s, p, n), Some(s));
        // entirely behind: removed
        assert_eq!(replace(Sphere { center: [2.0, 0.0, -1.5], radius: 1.0 }, p, n), None);
        // contains p, centre behind: removed
        assert_eq!(replace(Sphere { center: [0.1, 0.0, -0.2], radius: 1.0 }, p, n), None);
        // contains p, centre in front: radius = height, tangent to the plane
        let r = replace(Sphere { center: [0.1, 0.0, 0.3], radius: 1.0 }, p, n).unwrap();
        assert!((r.radius - 0.3).abs() < 1e-6 && (r.center[2] - 0.3).abs() < 1e-6);
        // straddling, far along the plane: S' with diameter q0 q1 (radius (h+r)/2)
        let r = replace(Sphere { center: [10.0, 0.0, 0.5], radius: 1.0 }, p, n).unwrap();
        assert!((r.radius - 0.75).abs() < 1e-6 && (r.center[2] - 0.75).abs() < 1e-6 && r.center[0] == 10.0);
    }

    #[test]
    fn replacement_is_continuous_leaving_the_sphere() {
        // Receiver moves along the plane out of a sphere straddling it, for centres above
        // and below the plane: the replacement radius never jumps.
        let n = [0.0, 0.0, 1.0];
        for h in [-0.6f32, -0.1, 0.0, 0.2, 0.7] {
            let s = Sphere { center: [0.0, 0.0, h], radius: 1.0 };
            let mut prev: Option<f32> = None;
            for k in 0..=4000 {
                let x = 3.0 * k as f32 / 4000.0;
                let rho = replace(s, [x, 0.0, 0.0], n).map_or(0.0, |r| r.radius);
                if let Some(pr) = prev {
                    assert!((rho - pr).abs() < 2e-3, "h={h} x={x}: {pr} -> {rho}");
                }
                prev = Some(rho);
            }
        }
    }
}
