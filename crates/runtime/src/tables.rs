//! [`ShTables`]: a validated, zero-copy view of an `SHTB` asset.

use crate::error::RuntimeError;
use crate::proxy_knots::{Grid, IN_CELL, ProxyKnots};
pub use crate::sh::MAX_ORDER;
use crate::sh::ShBasis;
use penumbra_asset::{Asset, DType};

/// Scratch size for order-8 SH vectors.
const N2_MAX: usize = MAX_ORDER * MAX_ORDER;

/// From this `α` up, blockers read the θ-grid `cap_log` table (see [`ShTables::proxy_log`]).
pub const NEAR_CONTACT_ALPHA: f32 = 0.9;

/// From this order up, the proxy table between `α_top` and [`NEAR_CONTACT_ALPHA`] is read by
/// Catmull–Rom (cubic) interpolation instead of linear (see [`ShTables::proxy_log`]).
pub const CUBIC_MIN_ORDER: usize = 6;

/// The small-cap continuation of the proxy log below the smooth clamp's ramp.
#[derive(Debug, Clone)]
struct FarField {
    /// Top of the ramp: from here up the table is unclamped.
    alpha_top: f32,
    /// The first row at or above `α_top`, `⌈α_top (K − 1)⌉`: rows from it up are unramped.
    top_row: usize,
    /// `1/u_top`, `u_top = 1 − cos θ_top`.
    inv_u_top: f32,
    /// `ρ_l − 1`: table log over −occlusion at `α_top`, minus one.
    ratio_m1: [f32; MAX_ORDER],
    /// `o*_l(u)/(2πu)` as polynomial coefficients in `u` (ascending), exact.
    shape: [[f32; MAX_ORDER + 1]; MAX_ORDER],
}

impl FarField {
    /// The smooth clamp's ramp (asset spec, SHTB): `j = round(c/η)`, `c = min(K − 1, 255)`,
    /// ramp weights reach 1 at `α = (j + 2)/c`.
    fn new(plo: &[f32], order: usize, k: usize, eta: f32) -> Self {
        let cells = ((k - 1) as f64).min(255.0);
        let eta = if eta.is_finite() && eta > 1.0 { eta as f64 } else { 1.0 };
        let j = (cells / eta).round();
        let alpha_top = ((j + 2.0) / cells).clamp(1.0 / (k - 1) as f64, NEAR_CONTACT_ALPHA as f64);
        let u_top = alpha_top * alpha_top / (1.0 + (1.0 - alpha_top * alpha_top).sqrt());
        // P_l(1 − u) = Σ_k c_{l,k} u^k, c_{l,k} = (−1)^k (l+k)! / ((k!)² (l−k)! 2^k)
        let leg = |l: usize, kk: usize| -> f64 {
            if kk > l {
                return 0.0;
            }
            let f = |n: usize| (1..=n).map(|i| i as f64).product::<f64>();
            let sign = if kk % 2 == 0 { 1.0 } else { -1.0 };
            sign * f(l + kk) / (f(kk) * f(kk) * f(l - kk) * 2f64.powi(kk as i32))
        };
        let mut shape = [[0.0f32; MAX_ORDER + 1]; MAX_ORDER];
        let mut shape64 = [[0.0f64; MAX_ORDER + 1]; MAX_ORDER];
        for l in 0..order {
            // o*_l = 2π ∫_{1−u}^1 P_l = 2π (P_{l−1} − P_{l+1})(1 − u)/(2l + 1) (l ≥ 1), 2πu (l = 0)
            for kk in 1..=MAX_ORDER + 1 {
                let c = if l == 0 {
                    if kk == 1 { 1.0 } else { 0.0 }
                } else {
                    (leg(l - 1, kk) - leg(l + 1, kk)) / (2 * l + 1) as f64
                };
                shape64[l][kk - 1] = c;
                shape[l][kk - 1] = c as f32;
            }
        }
        let occ = |l: usize, u: f64| -> f64 {
            2.0 * core::f64::consts::PI * u * shape64[l].iter().rev().fold(0.0, |s, &c| s * u + c)
        };
        // table row at α_top (lerp, as the runtime reads it)
        let t = alpha_top * (k - 1) as f64;
        let i = (t as usize).min(k - 2);
        let w = t - i as f64;
        let mut ratio_m1 = [0.0f32; MAX_ORDER];
        for l in 0..order {
            let row = plo[i * order + l] as f64 * (1.0 - w) + plo[(i + 1) * order + l] as f64 * w;
            let o = occ(l, u_top);
            ratio_m1[l] = if o.abs() > 0.0 && row != 0.0 { (row / -o - 1.0) as f32 } else { 0.0 };
        }
        let top_row = (alpha_top * (k - 1) as f64 - 1e-9).ceil().max(0.0) as usize;
        Self { alpha_top: alpha_top as f32, top_row, inv_u_top: (1.0 / u_top) as f32, ratio_m1, shape }
    }
}

/// The SH tables of one order (SHEXP §4–6), read from an `SHTB` asset.
///
/// Grids (see the asset spec): cap tables on `θ_k = (π/2)k/(K−1)`, proxy tables on
/// `α_k = k/(K−1)`, OL coefficients on a uniform `‖f̂‖` grid stored with the values.
#[derive(Debug, Clone)]
pub struct ShTables<'a> {
    order: usize,
    k: usize,
    gamma_index: &'a [u16],
    gamma_value: &'a [f32],
    /// Γ for squaring `g * g`: entries with `j ≤ k`, off-diagonal ones doubled (built once at
    /// load; halves the work of HYB's and PS*'s squarings).
    gamma_square: Vec<(u8, u8, u8, f32)>,
    /// Where the blocker log leaves the tables (see [`ShTables::proxy_log`]).
    far: FarField,
    /// Kinks of `proxy_log_occlusion` (SHTB v2 `proxy_log_knots`; none in v1 assets).
    knots: ProxyKnots,
    cap_log: &'a [f32],
    cap_visibility: &'a [f32],
    proxy_log_occlusion: &'a [f32],
    proxy_visibility: &'a [f32],
    indirect_d: &'a [f32],
    ol_ab: &'a [f32],
    ol_accurate_norm: f32,
    hyb_target_norm: f32,
    eta: [f32; 4],
    window: &'a [f32],
    /// `local_light_zh` `[32, 64, n + 2]` (optional: older assets lack it).
    local_light_zh: Option<&'a [f32]>,
    /// `indirect_m` `[K, 9, 9]` (optional).
    indirect_m: Option<&'a [f32]>,
    basis: ShBasis,
}

/// θ samples of the local-light table: `θ_i = (π/2)(i+1)/32` (SHEXP §7).
pub const LOCAL_LIGHT_THETA: usize = 32;
/// φ samples of the local-light table: `φ_j = π j/63`.
pub const LOCAL_LIGHT_PHI: usize = 64;

fn f32s<'a>(asset: &Asset<'a>, name: &'static str, dims: &[usize]) -> Result<&'a [f32], RuntimeError> {
    let s = asset.section(name).ok_or(RuntimeError::MissingSection(name))?;
    if s.dtype() != DType::F32 || s.dims() != dims {
        return Err(RuntimeError::BadSection {
            name,
            reason: format!("expected f32 {dims:?}, found {} {:?}", s.dtype().name(), s.dims()),
        });
    }
    s.as_f32().map_err(|e| RuntimeError::BadSection { name, reason: e.to_string() })
}

impl<'a> ShTables<'a> {
    /// Validates the asset's kind, section types and shapes, and Γ's indices.
    pub fn from_asset(asset: &Asset<'a>) -> Result<Self, RuntimeError> {
        if asset.kind().as_str() != "SHTB" {
            return Err(RuntimeError::WrongKind { expected: "SHTB", found: asset.kind().as_str().to_string() });
        }
        let window = asset.section("cosine_window").ok_or(RuntimeError::MissingSection("cosine_window"))?;
        let order = window.dims().first().copied().unwrap_or(0);
        if !(2..=MAX_ORDER).contains(&order) {
            return Err(RuntimeError::BadSection {
                name: "cosine_window",
                reason: format!("order {order} not in 2..=8"),
            });
        }
        let cap = asset.section("cap_log").ok_or(RuntimeError::MissingSection("cap_log"))?;
        let k = cap.dims().first().copied().unwrap_or(0);
        if k < 2 {
            return Err(RuntimeError::BadSection { name: "cap_log", reason: "fewer than 2 samples".into() });
        }
        let gi = asset.section("gamma_index").ok_or(RuntimeError::MissingSection("gamma_index"))?;
        let nnz = gi.dims().first().copied().unwrap_or(0);
        if gi.dtype() != DType::U16 || gi.dims() != [nnz, 3] {
            return Err(RuntimeError::BadSection { name: "gamma_index", reason: "expected u16 [nnz, 3]".into() });
        }
        let gamma_index =
            gi.as_u16().map_err(|e| RuntimeError::BadSection { name: "gamma_index", reason: e.to_string() })?;
        let n2 = (order * order) as u16;
        if gamma_index.iter().any(|&i| i >= n2) {
            return Err(RuntimeError::BadSection { name: "gamma_index", reason: "index out of range".into() });
        }
        let ol_ab_s = asset.section("ol_ab").ok_or(RuntimeError::MissingSection("ol_ab"))?;
        let m = ol_ab_s.dims().first().copied().unwrap_or(0);
        if m < 2 {
            return Err(RuntimeError::BadSection { name: "ol_ab", reason: "fewer than 2 samples".into() });
        }
        let dom = f32s(asset, "ol_domain", &[2])?;
        let eta = f32s(asset, "eta", &[4])?;
        let gamma_value = f32s(asset, "gamma_value", &[nnz])?;
        let gamma_square = gamma_index
            .chunks_exact(3)
            .zip(gamma_value)
            .filter(|(ix, _)| ix[1] <= ix[2])
            .map(|(ix, &v)| (ix[0] as u8, ix[1] as u8, ix[2] as u8, if ix[1] < ix[2] { 2.0 * v } else { v }))
            .collect();
        let plo = f32s(asset, "proxy_log_occlusion", &[k, order])?;
        let far = FarField::new(plo, order, k, eta[0]);
        let knots = match asset.section("proxy_log_knots") {
            None => ProxyKnots::default(),
            Some(s) => {
                let p = s.dims().first().copied().unwrap_or(0);
                ProxyKnots::new(f32s(asset, "proxy_log_knots", &[p, order + 1])?, order, k)?
            }
        };
        Ok(Self {
            gamma_square,
            far,
            knots,
            order,
            k,
            gamma_index,
            gamma_value,
            cap_log: f32s(asset, "cap_log", &[k, order])?,
            cap_visibility: f32s(asset, "cap_visibility", &[k, order])?,
            proxy_log_occlusion: f32s(asset, "proxy_log_occlusion", &[k, order])?,
            proxy_visibility: f32s(asset, "proxy_visibility", &[k, order])?,
            indirect_d: f32s(asset, "indirect_d", &[k, 3])?,
            ol_ab: f32s(asset, "ol_ab", &[m, 3])?,
            ol_accurate_norm: dom[0],
            hyb_target_norm: dom[1],
            eta: [eta[0], eta[1], eta[2], eta[3]],
            window: f32s(asset, "cosine_window", &[order])?,
            local_light_zh: match asset.section("local_light_zh") {
                None => None,
                Some(_) => {
                    let t = f32s(asset, "local_light_zh", &[LOCAL_LIGHT_THETA, LOCAL_LIGHT_PHI, order + 2])?;
                    if t.iter().any(|v| !v.is_finite()) {
                        return Err(RuntimeError::BadSection {
                            name: "local_light_zh",
                            reason: "non-finite value".into(),
                        });
                    }
                    Some(t)
                }
            },
            indirect_m: match asset.section("indirect_m") {
                None => None,
                Some(_) => Some(f32s(asset, "indirect_m", &[k, 9, 9])?),
            },
            basis: ShBasis::new(order),
        })
    }

    /// SH order (bands).
    pub fn order(&self) -> usize {
        self.order
    }

    /// Expansion factor used for the shadow tables' smooth clamp.
    pub fn eta_shadow(&self) -> f32 {
        self.eta[0]
    }

    /// Expansion factor for indirect accumulation.
    pub fn eta_indirect(&self) -> f32 {
        self.eta[3]
    }

    /// Cosine window `cos(π/2 · l/h)`, `h = 2n` (SHEXP §7), per band.
    pub fn cosine_window(&self) -> &[f32] {
        self.window
    }

    /// The single-lobe ZH fit of the local-light table `L_H(θ_i, φ_j)` (SHEXP §7), row-major
    /// `[32][64][n + 2]`: `(ψ, z_0 … z_{n−1}, fit error)`, or `None` if the asset has none.
    pub fn local_light_zh(&self) -> Option<&'a [f32]> {
        self.local_light_zh
    }

    /// The exact indirect operator `M(α)` (IBPA eq. 16, order 3, canonical frame, row-major
    /// 9×9: output radiance coefficient × input irradiance coefficient), linearly interpolated
    /// in `α = sin θ`; `false` if the asset has no `indirect_m`.
    pub fn indirect_m(&self, alpha: f32, out: &mut [f32; 81]) -> bool {
        let Some(m) = self.indirect_m else { return false };
        Self::lerp_row(m, 81, self.k, alpha, out);
        true
    }

    /// The SH basis of this order.
    pub fn basis(&self) -> &ShBasis {
        &self.basis
    }

    #[inline]
    fn lerp_row(table: &[f32], order: usize, k: usize, x: f32, out: &mut [f32]) {
        let t = (x.clamp(0.0, 1.0)) * (k - 1) as f32;
        let i = (t as usize).min(k - 2);
        let w = t - i as f32;
        for l in 0..order {
            out[l] = table[i * order + l] * (1.0 - w) + table[(i + 1) * order + l] * w;
        }
    }

    /// Starred ZH log-visibility of a cap of half-angle `theta` (radians, clamped to
    /// `[0, π/2]`), linearly interpolated (SHEXP §6.1, eigen method).
    pub fn cap_log(&self, theta: f32, out: &mut [f32]) {
        Self::lerp_row(self.cap_log, self.order, self.k, theta / core::f32::consts::FRAC_PI_2, out);
    }

    /// Starred ZH visibility of a cap of half-angle `theta` (radians, clamped to `[0, π/2]`),
    /// linearly interpolated — the blocker visibility of product-space accumulation
    /// (SHEXP eq. 6).
    pub fn cap_visibility(&self, theta: f32, out: &mut [f32]) {
        Self::lerp_row(self.cap_visibility, self.order, self.k, theta / core::f32::consts::FRAC_PI_2, out);
    }

    /// Starred ZH log-occlusion of a proxy with `α = sin θ`, smoothly clamped to zero
    /// below `1/η` (IBPA §4.1).
    #[inline]
    pub fn proxy_log_occlusion(&self, alpha: f32, out: &mut [f32]) {
        Self::lerp_row(self.proxy_log_occlusion, self.order, self.k, alpha, out);
    }

    /// Starred ZH of the proxy visibility `V(α)` for the first `out.len()` bands (≤ order),
    /// smoothly clamped to zero below `α = 1/η_indirect` (IBPA §4.1, §5).
    pub fn proxy_visibility(&self, alpha: f32, out: &mut [f32]) {
        let mut row = [0.0f32; MAX_ORDER];
        Self::lerp_row(self.proxy_visibility, self.order, self.k, alpha, &mut row[..self.order]);
        let m = out.len().min(self.order);
        out[..m].copy_from_slice(&row[..m]);
    }

    /// Starred ZH of the averaged indirect operator `D(α)` (IBPA eq. 14, order 3).
    pub fn indirect_d(&self, alpha: f32, out: &mut [f32; 3]) {
        Self::lerp_row(self.indirect_d, 3, self.k, alpha, out);
    }

    /// OL coefficients `(a, b)` at `‖f̂‖` (clamped to the table).
    pub fn ol_ab(&self, norm_hat: f32) -> (f32, f32) {
        let m = self.ol_ab.len() / 3;
        let max = self.ol_ab[(m - 1) * 3];
        if norm_hat.is_nan() || norm_hat <= 0.0 {
            return (self.ol_ab[1], self.ol_ab[2]);
        }
        if norm_hat >= max {
            return (self.ol_ab[(m - 1) * 3 + 1], self.ol_ab[(m - 1) * 3 + 2]);
        }
        let t = norm_hat / max * (m - 1) as f32;
        let i = (t as usize).min(m - 2);
        let w = t - i as f32;
        let at = |j: usize, c: usize| self.ol_ab[j * 3 + c];
        (at(i, 1) * (1.0 - w) + at(i + 1, 1) * w, at(i, 2) * (1.0 - w) + at(i + 1, 2) * w)
    }

    /// SH product `out = f * g` (truncated to this order; SHEXP eq. 3).
    pub fn product(&self, f: &[f32], g: &[f32], out: &mut [f32]) {
        let n2 = self.order * self.order;
        out[..n2].iter_mut().for_each(|o| *o = 0.0);
        for (idx, &v) in self.gamma_index.chunks_exact(3).zip(self.gamma_value) {
            out[idx[0] as usize] += v * f[idx[1] as usize] * g[idx[2] as usize];
        }
    }

    /// SH square `out = g * g` (truncated to this order), with the symmetric half of Γ.
    #[inline]
    pub fn square(&self, g: &[f32], out: &mut [f32]) {
        let n2 = self.order * self.order;
        out[..n2].iter_mut().for_each(|o| *o = 0.0);
        let g = &g[..n2];
        for &(i, j, k, v) in &self.gamma_square {
            out[i as usize] += v * g[j as usize] * g[k as usize];
        }
    }

    /// The log visibility a blocker with `α = sin θ` adds (starred ZH, compile-time order
    /// `N`): what [`ShTables::proxy_log`] returns.
    ///
    /// - `α ≥` [`NEAR_CONTACT_ALPHA`]: the unclamped `cap_log` row at `θ = asin α` (uniform θ
    ///   grid). Near α = 1, θ(α) has an infinite slope and a uniform-α lerp of
    ///   `proxy_log_occlusion` is off by 4 % in the last cell at K = 256; in θ it is smooth.
    /// - between the top of the smooth-clamp ramp `α_top` and that: `proxy_log_occlusion`
    ///   (IBPA §4.1's table, unclamped there), linearly interpolated in α — or, from order
    ///   [`CUBIC_MIN_ORDER`] up, by Catmull–Rom over rows `i−1 … i+2` when row `i−1` is
    ///   unramped and `i+2 < K` (in the first unramped cell, `i` = the first row at or above
    ///   `α_top`, the quadratic through rows `i … i+2`): at order 8 the rows bend sharply just below the α where
    ///   the log's eigenvalue clipping engages (α ≈ 0.415 at K = 256), where linear
    ///   interpolation is 0.78 % off and Catmull–Rom 0.48 % (docs/tables.md). Order ≤ 5 stays
    ///   linear (the cubic reads twice the rows). Where the clipping itself engages, the row
    ///   has a kink inside a cell; an SHTB v2 stores the exact row there (`proxy_log_knots`)
    ///   and a cell holding a knot is split at it, each side read by Lagrange interpolation
    ///   over the nodes on its own side (the cell's node, the knot and the next node
    ///   outwards); from order [`CUBIC_MIN_ORDER`] up the cells next to it, whose cubic
    ///   stencils would reach across the kink, take the knot as their outer node instead
    ///   (see `proxy_knots.rs`).
    /// - below `α_top`: the small-cap log, continuous with the table at `α_top`:
    ///   `−o*_l(α)·(1 + (ρ_l − 1)·u/u_top)`, `o*_l` the cap's exact starred occlusion as a
    ///   polynomial in `u = 1 − cos θ` (no cancellation in f32), `ρ_l` the table's ratio of
    ///   log to −occlusion at `α_top` (→ 1 as α → 0: `log(1 − o) = −o + O(o²)`).
    ///
    /// So the smooth clamp of IBPA §4.1 never drops a leaf: many small blockers keep their
    /// summed shadow at any distance (issue #14: the whole object at 20 diagonals).
    #[inline(always)]
    pub(crate) fn proxy_log_n<const N: usize>(&self, alpha: f32) -> [f32; N] {
        let alpha = alpha.clamp(0.0, 1.0);
        if alpha >= NEAR_CONTACT_ALPHA {
            let k = self.k;
            let t = alpha.asin() * core::f32::consts::FRAC_2_PI * (k - 1) as f32;
            let i = (t as usize).min(k - 2);
            let w = t - i as f32;
            // a kink of the log inside this θ cell (stored at its α): split the cell there
            if self.knots.theta_flags(i) & IN_CELL != 0 {
                return self.knots.interpolate::<N>(Grid::Theta, self.cap_log, i, w, 0, 2);
            }
            let rows = &self.cap_log[i * N..(i + 2) * N];
            return core::array::from_fn(|l| rows[l] * (1.0 - w) + rows[N + l] * w);
        }
        if alpha >= self.far.alpha_top {
            let k = self.k;
            let t = alpha * (k - 1) as f32;
            let i = (t as usize).min(k - 2);
            let w = t - i as f32;
            // a kink of the log (SHTB v2 `proxy_log_knots`) in this cell, or, for the cubic
            // orders whose stencil reaches into the next cells, next to it: one-sided nodes
            let flags = self.knots.flags(i);
            if flags != 0 && (N >= CUBIC_MIN_ORDER || flags & IN_CELL != 0) {
                return self.knots.interpolate::<N>(Grid::Alpha, self.proxy_log_occlusion, i, w, self.far.top_row, 2);
            }
            // order ≥ 6: Catmull–Rom over rows i−1 … i+2 when all four are unramped (row i−1
            // at or above α_top's row) and inside the table; in the first unramped cell the
            // quadratic through rows i … i+2; linear otherwise
            if N >= CUBIC_MIN_ORDER && i == self.far.top_row && i + 2 < k {
                let h = 0.5 * w * (w - 1.0);
                let c = [1.0 - w + h, w - 2.0 * h, h];
                let rows = &self.proxy_log_occlusion[i * N..(i + 3) * N];
                return core::array::from_fn(|l| c[0] * rows[l] + c[1] * rows[N + l] + c[2] * rows[2 * N + l]);
            }
            if N >= CUBIC_MIN_ORDER && i > self.far.top_row && i + 2 < k {
                let (w2, w3) = (w * w, w * w * w);
                let c = [
                    0.5 * (-w3 + 2.0 * w2 - w),
                    0.5 * (3.0 * w3 - 5.0 * w2 + 2.0),
                    0.5 * (-3.0 * w3 + 4.0 * w2 + w),
                    0.5 * (w3 - w2),
                ];
                let rows = &self.proxy_log_occlusion[(i - 1) * N..(i + 3) * N];
                return core::array::from_fn(|l| {
                    c[0] * rows[l] + c[1] * rows[N + l] + c[2] * rows[2 * N + l] + c[3] * rows[3 * N + l]
                });
            }
            let rows = &self.proxy_log_occlusion[i * N..(i + 2) * N];
            return core::array::from_fn(|l| rows[l] * (1.0 - w) + rows[N + l] * w);
        }
        let a2 = alpha * alpha;
        let u = a2 / (1.0 + (1.0 - a2).sqrt());
        let x = u * self.far.inv_u_top;
        core::array::from_fn(|l| {
            // `shape[l]` has nonzero coefficients at indices ≤ l < N only: Horner steps over the
            // zero ones above add exact zeros (u ≥ 0 is finite here), so they are skipped
            let c = &self.far.shape[l][..N.min(MAX_ORDER)];
            let mut s = 0.0f32;
            for &ck in c.iter().rev() {
                s = s * u + ck;
            }
            -core::f32::consts::TAU * u * s * (1.0 + self.far.ratio_m1[l] * x)
        })
    }

    /// [`ShTables::proxy_log_n`] for the tables' order into `out` (`order` entries): the
    /// starred ZH log visibility a blocker of `α = sin θ` adds at run time.
    pub fn proxy_log(&self, alpha: f32, out: &mut [f32]) {
        macro_rules! go {
            ($n:literal) => {{
                let v = self.proxy_log_n::<$n>(alpha);
                out[..$n].copy_from_slice(&v);
            }};
        }
        match self.order {
            2 => go!(2),
            3 => go!(3),
            4 => go!(4),
            5 => go!(5),
            6 => go!(6),
            7 => go!(7),
            _ => go!(8),
        }
    }

    /// Number of kinks of the proxy log stored with the table (SHTB v2 `proxy_log_knots`;
    /// 0 for v1 assets), which [`ShTables::proxy_log`] splits its cells at.
    pub fn proxy_log_knot_count(&self) -> usize {
        self.knots.len()
    }

    /// The top of the smooth-clamp ramp in α: below it [`ShTables::proxy_log`] uses the
    /// small-cap log instead of the (ramped) table.
    pub fn alpha_top(&self) -> f32 {
        self.far.alpha_top
    }

    /// Product matrix `(M_f)_ij = Σ_k Γ_ijk f_k` (SHEXP eq. 5), row-major `n² × n²` into `out`.
    pub fn product_matrix(&self, f: &[f32], out: &mut [f32]) {
        let n2 = self.order * self.order;
        out[..n2 * n2].iter_mut().for_each(|o| *o = 0.0);
        for (idx, &v) in self.gamma_index.chunks_exact(3).zip(self.gamma_value) {
            out[idx[0] as usize * n2 + idx[1] as usize] += v * f[idx[2] as usize];
        }
    }

    /// OL SH exponential (SHEXP eq. 23), no products.
    pub fn exp_ol(&self, f: &[f32], out: &mut [f32]) {
        let n2 = self.order * self.order;
        let sqrt_4pi = (4.0 * core::f32::consts::PI).sqrt();
        let norm_hat = f[1..n2].iter().map(|x| x * x).sum::<f32>().sqrt();
        let (a, b) = self.ol_ab(norm_hat);
        let dc = (f[0] / sqrt_4pi).exp();
        out[0] = dc * a * sqrt_4pi;
        for i in 1..n2 {
            out[i] = dc * b * f[i];
        }
    }

    /// PS*-p SH exponential (SHEXP §4.3): DC isolation, `s = max(0, ⌊log₂‖f̂‖⌋ + 3)`
    /// squarings, even/odd factored product series of degree `p` (eq. 22).
    pub fn exp_ps_star(&self, f: &[f32], p: u32, out: &mut [f32]) {
        let n2 = self.order * self.order;
        let sqrt_4pi = (4.0 * core::f32::consts::PI).sqrt();
        let norm_hat = f[1..n2].iter().map(|x| x * x).sum::<f32>().sqrt();
        let s = if norm_hat > 0.0 && norm_hat.is_finite() { (norm_hat.log2().floor() as i32 + 3).max(0) } else { 0 };
        let scale = 0.5f32.powi(s);
        let mut h = [0.0f32; N2_MAX];
        for i in 1..n2 {
            h[i] = f[i] * scale;
        }
        let (mut even, mut odd) = ([0.0f32; N2_MAX], [0.0f32; N2_MAX]);
        even[0] = sqrt_4pi;
        odd[0] = sqrt_4pi;
        let mut h2 = [0.0f32; N2_MAX];
        self.square(&h[..n2], &mut h2[..n2]);
        let mut pow = h2;
        let mut tmp = [0.0f32; N2_MAX];
        let mut k = 1u32;
        let mut fact = 1.0f32;
        while 2 * k <= p {
            if k > 1 {
                self.product(&pow[..n2], &h2[..n2], &mut tmp[..n2]);
                pow = tmp;
            }
            fact *= (2 * k - 1) as f32 * (2 * k) as f32; // (2k)!
            for i in 0..n2 {
                even[i] += pow[i] / fact;
            }
            if 2 * k < p {
                let fo = fact * (2 * k + 1) as f32;
                for i in 0..n2 {
                    odd[i] += pow[i] / fo;
                }
            }
            k += 1;
        }
        let mut g = [0.0f32; N2_MAX];
        self.product(&h[..n2], &odd[..n2], &mut g[..n2]);
        // DC folded in before the squarings (see `exp_hyb`)
        let dc = (f[0] / sqrt_4pi * scale).exp();
        for i in 0..n2 {
            g[i] = (g[i] + even[i]) * dc;
        }
        for _ in 0..s {
            self.square(&g[..n2], &mut tmp[..n2]);
            g = tmp;
        }
        out[..n2].copy_from_slice(&g[..n2]);
    }

    /// HYB's number of squarings `s` for an input of AC norm `norm_hat`: none inside OL's
    /// accurate domain, else enough halvings to bring it down to `hyb_target_norm`.
    #[inline]
    pub(crate) fn hyb_squarings(&self, norm_hat: f32) -> i32 {
        if norm_hat.is_finite() && norm_hat > self.ol_accurate_norm && self.hyb_target_norm > 0.0 {
            (norm_hat / self.hyb_target_norm).log2().ceil().max(0.0) as i32
        } else {
            0
        }
    }

    /// [`ShTables::square`] on `L` receivers at once, structure of arrays (`g[i][lane]`):
    /// the same terms in the same order per lane, so each lane equals the scalar result.
    ///
    /// The output row being summed is held in a local accumulator while consecutive terms
    /// share it (the bake lists the tensor's terms sorted by output index), instead of a load and
    /// a store of `out[i]` per term — the same additions in the same order.
    #[inline(always)]
    pub(crate) fn square_lanes<const N2: usize, const L: usize>(&self, g: &[[f32; L]; N2], out: &mut [[f32; L]; N2]) {
        *out = [[0.0; L]; N2];
        let Some(&(first, ..)) = self.gamma_square.first() else { return };
        let mut cur = first as usize;
        let mut acc = out[cur];
        for &(i, j, k, v) in &self.gamma_square {
            let i = i as usize;
            if i != cur {
                out[cur] = acc;
                cur = i;
                acc = out[cur];
            }
            let (gj, gk) = (g[j as usize], g[k as usize]);
            for lane in 0..L {
                acc[lane] += v * gj[lane] * gk[lane];
            }
        }
        out[cur] = acc;
    }

    /// [`ShTables::exp_hyb`] on `L` receivers at once (`f[i][lane]`, `order² = N2`). Lanes
    /// that need fewer squarings than the batch's maximum keep their value; every lane
    /// equals the scalar result exactly (same operations in the same order; tested).
    #[inline(always)]
    pub(crate) fn exp_hyb_lanes<const N2: usize, const L: usize>(&self, f: &[[f32; L]; N2], out: &mut [[f32; L]; N2]) {
        let sqrt_4pi = (4.0 * core::f32::consts::PI).sqrt();
        let mut steps = [0i32; L];
        let mut g = [[0.0f32; L]; N2];
        for lane in 0..L {
            let norm_hat = (1..N2).map(|i| f[i][lane] * f[i][lane]).sum::<f32>().sqrt();
            let s = self.hyb_squarings(norm_hat);
            let scale = 0.5f32.powi(s);
            let (a, b) = self.ol_ab(norm_hat * scale);
            let dc = (f[0][lane] / sqrt_4pi * scale).exp();
            steps[lane] = s;
            g[0][lane] = dc * a * sqrt_4pi;
            for i in 1..N2 {
                g[i][lane] = dc * b * scale * f[i][lane];
            }
        }
        let max_steps = steps.iter().copied().max().unwrap_or(0);
        let mut sq = [[0.0f32; L]; N2];
        for step in 0..max_steps {
            self.square_lanes(&g, &mut sq);
            for lane in 0..L {
                if step < steps[lane] {
                    for i in 0..N2 {
                        g[i][lane] = sq[i][lane];
                    }
                }
            }
        }
        *out = g;
    }

    /// HYB SH exponential (SHEXP §4.3): DC isolation, scale `f̂` by `2^-s` so it lies in
    /// OL's domain (no scaling inside `ol_accurate_norm`, else down to
    /// `hyb_target_norm`), OL (eq. 23), `s` squarings. `f` and `out` have `order²` entries.
    pub fn exp_hyb(&self, f: &[f32], out: &mut [f32]) {
        let n2 = self.order * self.order;
        let sqrt_4pi = (4.0 * core::f32::consts::PI).sqrt();
        let norm_hat = f[1..n2].iter().map(|x| x * x).sum::<f32>().sqrt();
        let s = self.hyb_squarings(norm_hat);
        let scale = 0.5f32.powi(s);
        let (a, b) = self.ol_ab(norm_hat * scale);
        let mut g = [0.0f32; N2_MAX];
        let mut tmp = [0.0f32; N2_MAX];
        // The DC factor is folded in before the squarings, scaled like the rest:
        // exp(f) = (e^{f₀/(√4π 2^s)} OL(f̂/2^s))^{2^s}. Applied after them (SHEXP eq. 20's
        // separation), the AC part grows like e^{‖f̂‖} while the DC factor shrinks like
        // e^{f₀/√4π}; with hundreds of dense blockers both leave f32's range (inf·0 = NaN).
        let dc = (f[0] / sqrt_4pi * scale).exp();
        g[0] = dc * a * sqrt_4pi;
        for i in 1..n2 {
            g[i] = dc * b * scale * f[i];
        }
        for _ in 0..s {
            self.square(&g[..n2], &mut tmp[..n2]);
            g[..n2].copy_from_slice(&tmp[..n2]);
        }
        out[..n2].copy_from_slice(&g[..n2]);
    }
}
