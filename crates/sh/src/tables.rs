//! The SH tables bake behind `penumbra tables`: everything the soft-shadow runtime needs
//! for SH order n, plus the measurements that show how good it is.
//!
//! Grids (all inclusive of both ends, `K = theta_samples`):
//! - cap tables: `θ_k = (π/2)·k/(K−1)` (half-angle of the blocker cap);
//! - proxy tables (IBPA): `α_k = k/(K−1)` with `α = sin θ`;
//! - OL table: `‖f̂‖_k = max·k/(K−1)` with `max` = the norm of the 90° cap log;
//! - local lights: `θ_i = (π/2)(i+1)/T_θ` (light angular radius), `φ_j = π·j/(T_φ−1)`
//!   (angle between the light centre and the normal).
//!
//! "Starred" zonal coefficients are `z*_l = √(4π/(2l+1))·z_l` (SHEXP §6.1), ready for the
//! rotation rule `f_lm = z*_l · y_lm(axis)`.

use crate::eta::{Eta, eta_indirect, eta_shadow, eta_shadow_env};
use crate::exp::{exp_exact_zonal, norm};
use crate::gamma::TripleProduct;
use crate::indirect::{averaged_operator, exact_operator, paper_fit_rel_sq_error, refit};
use crate::local_light::{LobeFit, fit_lobe, local_light};
use crate::log::{EPS_REL, LogForm, log_eigen_zonal, log_eigen_zonal_occlusion_with, log_naive_zonal, naive_eps_zonal};
use crate::ohlsh::quadratic_to_ohlsh;
use crate::ol::{OlTable, cap_accurate_norm, cap_ol_sample};
use crate::proxy_knots::{ProxyKnot, proxy_log_knots};
use crate::zonal::{cap_indicator, cap_visibility, cosine_window};
use core::f64::consts::PI;
use penumbra_math::sh::{ShEval, zh_star_scale};
use rayon::prelude::*;

/// Allowed SH orders.
pub const ORDERS: core::ops::RangeInclusive<usize> = 2..=8;
/// Allowed θ sample counts.
pub const THETA_SAMPLES: core::ops::RangeInclusive<usize> = 16..=16384;
/// Default θ sample count (SHEXP §8 uses 256 samples in θ).
pub const DEFAULT_THETA_SAMPLES: usize = 256;
/// Default shading tolerance (IBPA §4.1: 1 in 256, 8-bit output).
pub const DEFAULT_SHADING_TOLERANCE: f64 = 1.0 / 256.0;
/// Local-light table resolution in θ (light radius).
pub const LOCAL_LIGHT_THETA: usize = 32;
/// Local-light table resolution in φ (light elevation from the normal).
pub const LOCAL_LIGHT_PHI: usize = 64;
/// Order of the indirect operators (IBPA §5 uses order 3).
pub const INDIRECT_ORDER: usize = 3;
/// Kind version of the SHTB asset written by this crate (2: `proxy_log_knots`; 1 still loads).
pub const SHTB_KIND_VERSION: u32 = 2;

/// Errors of the tables bake.
#[derive(Debug, thiserror::Error)]
pub enum TablesError {
    /// Order outside 2..=8.
    #[error("SH order {0} is out of range (allowed: 2..=8)")]
    Order(usize),
    /// θ sample count outside the allowed range.
    #[error("theta sample count {0} is out of range (allowed: 16..=16384)")]
    ThetaSamples(usize),
    /// Tolerance not in (0, 1).
    #[error("shading tolerance {0} is out of range (allowed: 0 < T < 1)")]
    Tolerance(f64),
    /// Environment lighting of the wrong size or non-finite.
    #[error("environment SH lighting must have {expected} finite coefficients, got {got}")]
    EnvLight {
        /// n².
        expected: usize,
        /// Given.
        got: usize,
    },
    /// The smooth clamp at `α = 1/η` does not fit on the α grid.
    #[error(
        "theta sample count {k} cannot represent the smooth clamp at alpha = 1/eta = {alpha_c:.4}: its 4 entries around round(alpha (K-1)) = {j} need j >= 2 (use --theta-samples >= {min_k})"
    )]
    ClampNotRepresentable {
        /// K.
        k: usize,
        /// 1/η.
        alpha_c: f64,
        /// round(α_c (K − 1)).
        j: i64,
        /// Smallest K that works.
        min_k: usize,
    },
    /// Building the asset failed.
    #[error("building the SHTB asset: {0}")]
    Asset(String),
}

/// Lighting of an environment for the η analysis.
#[derive(Debug, Clone)]
pub struct EnvLighting {
    /// Luminance SH coefficients of order `order` (`order²` values).
    pub sh: Vec<f64>,
    /// File name (no directories) for the metadata.
    pub name: String,
    /// blake3 hex digest of the file's bytes.
    pub content_hash: String,
}

/// Parameters of the tables bake.
#[derive(Debug, Clone)]
pub struct TablesParams {
    /// SH order n (2..=8).
    pub order: usize,
    /// θ samples K of the 1D tables.
    pub theta_samples: usize,
    /// Shading tolerance of the η analyses.
    pub shading_tolerance: f64,
    /// Optional environment lighting.
    pub env: Option<EnvLighting>,
    /// Form of the eigen log once clipping engages (SHEXP eq. 30–32; default: as written).
    pub log_form: LogForm,
}

impl TablesParams {
    /// Defaults for order `order`.
    pub fn new(order: usize) -> Self {
        Self {
            order,
            theta_samples: DEFAULT_THETA_SAMPLES,
            shading_tolerance: DEFAULT_SHADING_TOLERANCE,
            env: None,
            log_form: LogForm::Paper,
        }
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), TablesError> {
        if !ORDERS.contains(&self.order) {
            return Err(TablesError::Order(self.order));
        }
        if !THETA_SAMPLES.contains(&self.theta_samples) {
            return Err(TablesError::ThetaSamples(self.theta_samples));
        }
        if !(self.shading_tolerance > 0.0 && self.shading_tolerance < 1.0) {
            return Err(TablesError::Tolerance(self.shading_tolerance));
        }
        if let Some(env) = &self.env {
            if env.sh.len() != self.order * self.order || env.sh.iter().any(|v| !v.is_finite()) {
                return Err(TablesError::EnvLight { expected: self.order * self.order, got: env.sh.len() });
            }
        }
        Ok(())
    }
}

/// One entry of `cap_log_samples` in the report.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CapLogSample {
    /// Cap half-angle in degrees.
    pub theta_deg: f64,
    /// Zonal coefficients `f_{l0}` of the log (orthonormal SH, eigen method).
    pub f: Vec<f64>,
    /// OL `a` (SHEXP eq. 24).
    pub a: f64,
    /// OL `b` (SHEXP eq. 24).
    pub b: f64,
}

/// Quality metrics of a tables bake (the `--json` keys).
#[derive(Debug, Clone, serde::Serialize)]
pub struct TablesMetrics {
    /// SH order.
    pub order: usize,
    /// Truly nonzero ordered entries of Γ (stored).
    pub gamma_nonzeros: usize,
    /// Ordered entries allowed by the selection rules (SHEXP §3's count).
    pub gamma_structural: usize,
    /// η used for the shadow tables' smooth clamp (delta-light, or `--env`).
    pub eta_shadow: f64,
    /// Where `eta_shadow` came from: "delta" or "env".
    pub eta_shadow_source: &'static str,
    /// Delta-light η as IBPA words it (always reported).
    pub eta_shadow_delta: f64,
    /// The same analysis with the cosine-windowed light.
    pub eta_shadow_windowed: f64,
    /// Indirect η (order 3).
    pub eta_indirect: f64,
    /// Critical half-angle of `eta_shadow` in degrees.
    pub eta_shadow_theta_deg: f64,
    /// Largest ‖f̂‖ where OL meets its 2 % threshold on the blocker family.
    pub ol_accurate_norm: f64,
    /// The same for single caps only (comparable to SHEXP Fig. 3).
    pub ol_cap_accurate_norm: f64,
    /// HYB's scaling target.
    pub hyb_target_norm: f64,
    /// Max over θ ≤ 50° of ‖exp*(log g) − g‖/‖g‖, eigen log.
    pub roundtrip_rel_error_eigen: f64,
    /// The same with the naive log.
    pub roundtrip_rel_error_naive: f64,
    /// Relative squared errors of IBPA §5's polynomial fits against our exact D.
    pub d_fit_rel_sq_error: DFitErrors,
    /// Largest relative error of the single-lobe ZH fit over the local-light table.
    pub local_light_fit_max_rel_error: f64,
    /// Mean relative error of the single-lobe ZH fit over the local-light table.
    pub local_light_fit_mean_rel_error: f64,
    /// Log samples at 22.5°, 45°, 67.5°, 90°.
    pub cap_log_samples: Vec<CapLogSample>,
    /// α of every kink of the proxy log stored in `proxy_log_knots` (where the log's
    /// eigenvalue clipping engages or releases inside a grid cell).
    pub proxy_log_knot_alphas: Vec<f64>,
}

/// Fit errors of D₁ and D₂.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DFitErrors {
    /// IBPA's D₁ fit vs exact.
    #[serde(rename = "D1")]
    pub d1: f64,
    /// IBPA's D₂ fit vs exact.
    #[serde(rename = "D2")]
    pub d2: f64,
    /// Our least-squares refit of the same form (D₁ quadratic, D₂ cubic).
    pub refit_d1: f64,
    /// Same for D₂.
    pub refit_d2: f64,
    /// Paper's stated values for comparison.
    pub paper_d1: f64,
    /// Paper's stated value for D₂.
    pub paper_d2: f64,
}

/// Everything the bake computed.
#[derive(Debug, Clone)]
pub struct TablesBake {
    /// Parameters used.
    pub params: TablesParams,
    /// Γ of this order.
    pub gamma: TripleProduct,
    /// Starred cap visibility ZH `[K][n]` on the θ grid.
    pub cap_visibility: Vec<Vec<f64>>,
    /// Starred cap log ZH, eigen method `[K][n]`.
    pub cap_log: Vec<Vec<f64>>,
    /// Starred cap log ZH, naive method `[K][n]`.
    pub cap_log_naive: Vec<Vec<f64>>,
    /// OL table.
    pub ol: OlTable,
    /// Starred proxy visibility `V(α)` with smooth clamp at `1/η_indirect` `[K][n]`.
    pub proxy_visibility: Vec<Vec<f64>>,
    /// Starred proxy log-occlusion `O^log(α)` with smooth clamp at `1/η_shadow` `[K][n]`.
    pub proxy_log_occlusion: Vec<Vec<f64>>,
    /// Kinks of `proxy_log_occlusion` inside unramped grid cells, with their exact rows
    /// (see [`crate::proxy_knots`]).
    pub proxy_log_knots: Vec<ProxyKnot>,
    /// η values.
    pub eta_shadow: Eta,
    /// Delta-light η.
    pub eta_shadow_delta: Eta,
    /// Windowed delta-light η.
    pub eta_shadow_windowed: Eta,
    /// Indirect η.
    pub eta_indirect: Eta,
    /// Starred averaged operator `D(α)` `[K][3]`.
    pub indirect_d: Vec<Vec<f64>>,
    /// Exact operator `M(α)` `[K][9·9]`.
    pub indirect_m: Vec<Vec<f64>>,
    /// Cosine window (h = 2n).
    pub window: Vec<f64>,
    /// `L_H(θ_i, φ_j)` `[Tθ·Tφ][n²]`.
    pub local_light: Vec<Vec<f64>>,
    /// Single-lobe ZH fits `[Tθ·Tφ]`.
    pub local_light_fit: Vec<LobeFit>,
    /// Quadratic → OHLSH map.
    pub ohlsh: [f64; 36],
    /// Metrics.
    pub metrics: TablesMetrics,
}

/// Smooth-clamp weights over an `α` grid of `k` samples for a cutoff at `alpha_c`
/// (IBPA §4.1: "the 4 table entries around 1/η … weighted smoothly to 0; vectors for even
/// smaller half angles are forced to 0"). With `j = round(α_c (K−1))`, entries
/// `j−2, j−1, j, j+1` get `s(1/5), s(2/5), s(3/5), s(4/5)` with `s(t) = 3t² − 2t³`
/// (0.104, 0.352, 0.648, 0.896), entries below get 0 and entries above 1.
///
/// Finer grids (K > 256) would shrink that ramp to a step: there the ramp keeps the width it
/// has at K = 256 (5/255 in α), `t = (α·255 − (j − 3))/5` with `j = round(α_c·255)`, so its
/// entries follow the same smoothstep on a finer grid. For K ≤ 256 the weights are IBPA's
/// four entries exactly. [`clamp_fits`] says whether the grid can hold the ramp at all.
pub fn smooth_clamp_weights(k: usize, alpha_c: f64) -> Vec<f64> {
    let cells = clamp_cells(k);
    let j = (alpha_c * cells).round() as i64;
    (0..k)
        .map(|i| {
            let x = i as f64 / (k - 1) as f64 * cells;
            let t = (x - (j - 3) as f64) / 5.0;
            if t <= 0.0 {
                0.0
            } else if t >= 1.0 {
                1.0
            } else {
                t * t * (3.0 - 2.0 * t)
            }
        })
        .collect()
}

/// The α grid unit of the smooth clamp's ramp: `K − 1` cells up to K = 256, then 255.
fn clamp_cells(k: usize) -> f64 {
    ((k - 1) as f64).min(255.0)
}

/// Checks that the smooth clamp at `alpha_c` lies on the grid: `j = round(α_c·cells) ≥ 2`,
/// so that its four ramp entries `j − 2 … j + 1` exist (at K = 16 and η ≈ 28, `j = 1`:
/// 1/η is not representable and the ramp would start below α = 0).
pub fn clamp_fits(k: usize, alpha_c: f64) -> Result<(), TablesError> {
    let j = (alpha_c * clamp_cells(k)).round() as i64;
    if j >= 2 {
        return Ok(());
    }
    let min_k = (1.5 / alpha_c).ceil() as usize + 1;
    Err(TablesError::ClampNotRepresentable { k, alpha_c, j, min_k })
}

fn starred(zh: &[f64]) -> Vec<f64> {
    zh.iter().enumerate().map(|(l, v)| v * zh_star_scale(l)).collect()
}

pub use penumbra_math::progress::{NoProgress, Progress};

/// Runs the tables bake.
pub fn bake(params: &TablesParams, progress: &dyn Progress) -> Result<TablesBake, TablesError> {
    params.validate()?;
    let n = params.order;
    let k = params.theta_samples;
    let tol = params.shading_tolerance;
    let total_stages = 8u64;
    progress.update("triple product", 0, total_stages);
    let gamma = TripleProduct::new(n);

    progress.update("cap logs", 1, total_stages);
    let thetas: Vec<f64> = (0..k).map(|i| 0.5 * PI * i as f64 / (k - 1) as f64).collect();
    let caps: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = thetas
        .par_iter()
        .map(|&th| {
            let g = cap_visibility(n, th);
            let f = log_eigen_zonal_occlusion_with(&gamma, &cap_indicator(n, th), EPS_REL, params.log_form);
            let fnv = log_naive_zonal(n, &g, naive_eps_zonal(n, &g));
            (g, f, fnv)
        })
        .collect();

    // Round trips over θ ≤ 50° (exp* = exact exponential of the product series, eq. 28).
    let roundtrip = |f: &[f64], g: &[f64]| {
        let e = exp_exact_zonal(&gamma, f);
        let d: f64 = e.iter().zip(g).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        d / norm(g)
    };
    let (mut rt_eigen, mut rt_naive) = (0.0f64, 0.0f64);
    for (th, (g, f, fnv)) in thetas.iter().zip(&caps) {
        if *th <= 50f64.to_radians() + 1e-12 {
            rt_eigen = rt_eigen.max(roundtrip(f, g));
            rt_naive = rt_naive.max(roundtrip(fnv, g));
        }
    }

    progress.update("OL coefficients", 2, total_stages);
    let ol = OlTable::build(&gamma, k, k);
    let ol_cap = cap_accurate_norm(&gamma, &ol, 180);

    progress.update("expansion factors", 3, total_stages);
    let eta_delta = eta_shadow(&gamma, tol, false);
    let eta_win = eta_shadow(&gamma, tol, true);
    let eta_ind = eta_indirect(tol);
    let (eta_sh, source) = match &params.env {
        Some(env) => (eta_shadow_env(&gamma, &env.sh, tol, 384), "env"),
        None => (eta_delta, "delta"),
    };

    progress.update("proxy tables", 4, total_stages);
    clamp_fits(k, 1.0 / eta_sh.eta)?;
    clamp_fits(k, 1.0 / eta_ind.eta)?;
    let alphas: Vec<f64> = (0..k).map(|i| i as f64 / (k - 1) as f64).collect();
    let w_sh = smooth_clamp_weights(k, 1.0 / eta_sh.eta);
    let w_ind = smooth_clamp_weights(k, 1.0 / eta_ind.eta);
    let proxy: Vec<(Vec<f64>, Vec<f64>)> = alphas
        .par_iter()
        .map(|&a| {
            let th = a.clamp(0.0, 1.0).asin();
            let v = starred(&cap_indicator(n, th));
            let lo = starred(&log_eigen_zonal_occlusion_with(&gamma, &cap_indicator(n, th), EPS_REL, params.log_form));
            (v, lo)
        })
        .collect();
    let proxy_visibility: Vec<Vec<f64>> =
        proxy.iter().zip(&w_ind).map(|((v, _), w)| v.iter().map(|x| x * w).collect()).collect();
    let proxy_log_occlusion: Vec<Vec<f64>> =
        proxy.iter().zip(&w_sh).map(|((_, lo), w)| lo.iter().map(|x| x * w).collect()).collect();
    let proxy_log_knots = proxy_log_knots(&gamma, k, &w_sh, EPS_REL, params.log_form);

    progress.update("indirect operators", 5, total_stages);
    let indirect: Vec<(Vec<f64>, Vec<f64>)> = alphas
        .par_iter()
        .map(|&a| (starred(&averaged_operator(INDIRECT_ORDER, a)), exact_operator(INDIRECT_ORDER, a)))
        .collect();
    let (indirect_d, indirect_m): (Vec<_>, Vec<_>) = indirect.into_iter().unzip();
    let fit_err = paper_fit_rel_sq_error(1000);
    let (_, _, refit_err) = refit(1000);

    progress.update("local lights", 6, total_stages);
    let eval = ShEval::new(n);
    let ll: Vec<(Vec<f64>, LobeFit)> = (0..LOCAL_LIGHT_THETA * LOCAL_LIGHT_PHI)
        .into_par_iter()
        .map(|idx| {
            let (i, j) = (idx / LOCAL_LIGHT_PHI, idx % LOCAL_LIGHT_PHI);
            let th = 0.5 * PI * (i + 1) as f64 / LOCAL_LIGHT_THETA as f64;
            let ph = PI * j as f64 / (LOCAL_LIGHT_PHI - 1) as f64;
            let lh = local_light(&gamma, &eval, th, ph);
            let fit = fit_lobe(&eval, &lh);
            (lh, fit)
        })
        .collect();
    let (local_light, local_light_fit): (Vec<_>, Vec<_>) = ll.into_iter().unzip();
    let ll_max_err = local_light_fit.iter().map(|f| f.rel_error).fold(0.0, f64::max);
    let ll_mean_err = local_light_fit.iter().map(|f| f.rel_error).sum::<f64>() / local_light_fit.len() as f64;

    progress.update("samples", 7, total_stages);
    let cap_log_samples = [22.5f64, 45.0, 67.5, 90.0]
        .iter()
        .map(|&deg| {
            let s = cap_ol_sample(&gamma, deg.to_radians());
            let f = log_eigen_zonal(&gamma, &cap_visibility(n, deg.to_radians()), EPS_REL);
            CapLogSample { theta_deg: deg, f, a: s.a, b: s.b }
        })
        .collect();

    let metrics = TablesMetrics {
        order: n,
        gamma_nonzeros: gamma.nonzeros(),
        gamma_structural: gamma.structural_count(),
        eta_shadow: eta_sh.eta,
        eta_shadow_source: source,
        eta_shadow_delta: eta_delta.eta,
        eta_shadow_windowed: eta_win.eta,
        eta_indirect: eta_ind.eta,
        eta_shadow_theta_deg: eta_sh.theta.to_degrees(),
        ol_accurate_norm: ol.accurate_norm,
        ol_cap_accurate_norm: ol_cap,
        hyb_target_norm: ol.hyb_target_norm,
        roundtrip_rel_error_eigen: rt_eigen,
        roundtrip_rel_error_naive: rt_naive,
        d_fit_rel_sq_error: DFitErrors {
            d1: fit_err[0],
            d2: fit_err[1],
            refit_d1: refit_err[0],
            refit_d2: refit_err[1],
            paper_d1: 0.00016e-2,
            paper_d2: 0.00064e-2,
        },
        local_light_fit_max_rel_error: ll_max_err,
        local_light_fit_mean_rel_error: ll_mean_err,
        cap_log_samples,
        proxy_log_knot_alphas: proxy_log_knots.iter().map(|kn| kn.alpha).collect(),
    };
    progress.update("done", total_stages, total_stages);
    Ok(TablesBake {
        params: params.clone(),
        cap_visibility: caps.iter().map(|c| starred(&c.0)).collect(),
        cap_log: caps.iter().map(|c| starred(&c.1)).collect(),
        cap_log_naive: caps.iter().map(|c| starred(&c.2)).collect(),
        gamma,
        ol,
        proxy_visibility,
        proxy_log_occlusion,
        proxy_log_knots,
        eta_shadow: eta_sh,
        eta_shadow_delta: eta_delta,
        eta_shadow_windowed: eta_win,
        eta_indirect: eta_ind,
        indirect_d,
        indirect_m,
        window: cosine_window(n, 2.0 * n as f64),
        local_light,
        local_light_fit,
        ohlsh: quadratic_to_ohlsh(),
        metrics,
    })
}
