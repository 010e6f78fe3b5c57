//! Soft shadows and indirect light from sphere proxies at a receiver (SHEXP §4–7, IBPA §3–5).
//!
//! Per receiver `(p, N)`:
//! 1. accumulate the log visibility of every blocker sphere (SHEXP eq. 34, [`accumulate`]):
//!    `α = r/d`, `f += O^log(α)·y(ŝ)` from the SHTB proxy table (IBPA §4.1), after the
//!    self-shadow replacement rules (SHEXP §6.2, [`rules`]);
//! 2. exponentiate (SHEXP §4: HYB by default, OL, or PS*-p; [`exp`]);
//! 3. shade a diffuse receiver ([`shade`]): `E = (H(N), L, g) = H(N)ᵀ M_L g` with the
//!    cosine-windowed environment `L` (SHEXP §7) — `H(N) = max(s·N, 0)` rotated to the
//!    normal — or a local spherical light through the `L_H(θ, φ)` table's ZH fit
//!    ([`local_light`], SHEXP §7 "Analytic Lights");
//! 4. optionally add indirect light from the proxies (IBPA §5, [`indirect`]).
//!
//! With a hierarchy, a receiver cluster's blockers are the nodes of its cut with ratio
//! vectors ([`ratio`], SHEXP §6.3); [`batch`] evaluates eight receivers at a time;
//! [`product`] is the product-space reference (SHEXP eq. 6).
//!
//! Units: `E` is irradiance (W/m² per unit radiance of `L`); the shaded diffuse radiance
//! of an albedo-ρ receiver is `ρE/π`. f32 throughout; no allocation per receiver.

use crate::sh::MAX_ORDER;
use crate::tables::ShTables;

pub mod accumulate;
pub mod batch;
pub mod exp;
pub mod indirect;
pub mod local_light;

pub mod product;
pub mod ratio;
pub mod rules;
pub mod shade;

pub use batch::LANES;
pub use indirect::{IndirectOperator, Shaded};
pub use local_light::LocalLight;

pub use ratio::{CutBlocker, RATIO_BAND_FLOOR, RATIO_BOUND, ratio_vector};
pub use rules::replace;

pub(crate) const N2: usize = MAX_ORDER * MAX_ORDER;
pub(crate) const SQRT_4PI: f32 = 3.544_907_7;

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

pub(crate) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// SH band `l` of coefficient index `i = l(l+1)+m`.
pub(crate) fn band(i: usize) -> usize {
    let mut l = 0;
    while (l + 1) * (l + 1) <= i {
        l += 1;
    }
    l
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
    rot3: indirect::Rot3,
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
            *c = shade::clamped_cosine_star(l);
        }
        let mut irradiance_sh = [[0.0f32; 9]; 3];
        for c in 0..3 {
            for i in 0..9.min(light.len()) {
                irradiance_sh[c][i] = light[i][c] * shade::clamped_cosine_star(band(i));
            }
        }
        let basis3 = crate::sh::ShBasis::new(3);
        let rot3 = indirect::Rot3::new(&basis3);
        Self { tables, options, order, light_matrix, cosine_star, window, irradiance_sh, basis3, rot3 }
    }

    /// The tables.
    pub fn tables(&self) -> &ShTables<'a> {
        self.tables
    }

    /// The options.
    pub fn options(&self) -> ShadowOptions {
        self.options
    }

    /// The SH order (the tables').
    pub fn order(&self) -> usize {
        self.order
    }

    /// The visibility `g` at `(p, n)` from `spheres` (steps 1–2): `order²` coefficients
    /// written to `g`.
    pub fn visibility(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere], g: &mut [f32]) {
        let mut f = [0.0f32; N2];
        let n2 = self.order * self.order;
        self.accumulate_log(p, n, spheres, &mut f[..n2]);
        self.exponentiate(&f[..n2], &mut g[..n2]);
    }

    /// Shadowed irradiance at `(p, n)` from `spheres` (steps 1–3).
    pub fn irradiance(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere]) -> [f32; 3] {
        let mut g = [0.0f32; N2];
        let n2 = self.order * self.order;
        self.visibility(p, n, spheres, &mut g[..n2]);
        self.shade(n, &g[..n2])
    }

    /// Shadowed irradiance at `(p, n)` from a cluster's blockers (SHEXP eq. 38).
    pub fn irradiance_blockers(&self, p: [f32; 3], n: [f32; 3], blockers: &[CutBlocker]) -> [f32; 3] {
        let mut f = [0.0f32; N2];
        let mut g = [0.0f32; N2];
        let n2 = self.order * self.order;
        self.accumulate_log_blockers(p, n, blockers, &mut f[..n2]);
        self.exponentiate(&f[..n2], &mut g[..n2]);
        self.shade(n, &g[..n2])
    }

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
        let mut g = [0.0f32; N2];
        accum.visibility(p, n, spheres, &mut g[..m2]);
        let n2 = self.order * self.order;
        g[m2.min(N2)..].iter_mut().for_each(|v| *v = 0.0);
        self.shade(n, &g[..n2])
    }
}
