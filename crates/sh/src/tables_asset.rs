//! Writes a [`TablesBake`] as an `SHTB` asset (sections documented in
//! `schemas/asset-format.md`, "SHTB").

use crate::tables::{INDIRECT_ORDER, LOCAL_LIGHT_PHI, LOCAL_LIGHT_THETA, SHTB_KIND_VERSION, TablesBake, TablesError};
use penumbra_asset::{AssetBuilder, Kind};
use serde_json::json;

/// Names of every section an SHTB asset (v1 or v2) contains, for `require_known`.
pub const SHTB_SECTIONS: &[&str] = &[
    "meta",
    "gamma_index",
    "gamma_value",
    "cap_visibility",
    "cap_log",
    "cap_log_naive",
    "ol_ab",
    "ol_domain",
    "proxy_visibility",
    "proxy_log_occlusion",
    "proxy_log_knots",
    "eta",
    "indirect_d",
    "indirect_m",
    "cosine_window",
    "local_light",
    "local_light_zh",
    "ohlsh_map",
];

fn flat_f32(rows: &[Vec<f64>]) -> Vec<f32> {
    rows.iter().flat_map(|r| r.iter().map(|&v| v as f32)).collect()
}

fn err(e: impl core::fmt::Display) -> TablesError {
    TablesError::Asset(e.to_string())
}

/// The `meta` JSON of an SHTB asset: tool, kind version, convention, normalised
/// parameters, grids and quality metrics. No timestamps, durations or absolute paths.
pub fn meta_json(b: &TablesBake, cache_key: Option<&str>) -> serde_json::Value {
    let p = &b.params;
    let k = p.theta_samples;
    json!({
        "kind": "SHTB",
        "kind_version": SHTB_KIND_VERSION,
        "tool": concat!("penumbra ", env!("CARGO_PKG_VERSION")),
        "convention": {
            "sh": "real orthonormal; index i = l(l+1)+m; order n = n bands, n^2 coefficients",
            "phase": "Condon-Shortley as in graphics: y(1,-1) = -sqrt(3/4pi) y, y(1,0) = sqrt(3/4pi) z, y(1,1) = -sqrt(3/4pi) x",
            "zh_star": "starred zonal coefficients z*_l = sqrt(4pi/(2l+1)) z_l; rotate with f_lm = z*_l y_lm(axis)",
            "cap": "blocker cap of half-angle theta around +z: visibility 0 inside, 1 outside (SHEXP eq. 33)",
        },
        "params": {
            "order": p.order,
            "theta_samples": k,
            "shading_tolerance": p.shading_tolerance,
            "log_eps_rel": crate::log::EPS_REL,
            "log_eps_floor": crate::log::EPS_FLOOR,
            "log_form": p.log_form.name(),
            "naive_log_eps": "0.02 * max_s g~(s)",
            "indirect_order": INDIRECT_ORDER,
            "local_light": [LOCAL_LIGHT_THETA, LOCAL_LIGHT_PHI],
            "env": p.env.as_ref().map(|e| json!({"name": e.name, "blake3": e.content_hash})),
        },
        "grids": {
            "theta": format!("theta_k = (pi/2) k/{}, k = 0..{}", k - 1, k - 1),
            "alpha": format!("alpha_k = k/{}, alpha = sin(theta)", k - 1),
            "ol_norm": format!("|f^|_k = {} k/{}", b.ol.norms[b.ol.norms.len() - 1], k - 1),
            "local_light_theta": format!("theta_i = (pi/2)(i+1)/{LOCAL_LIGHT_THETA}"),
            "local_light_phi": format!("phi_j = pi j/{}", LOCAL_LIGHT_PHI - 1),
        },
        "cache_key": cache_key,
        "metrics": b.metrics,
    })
}

/// Builds the asset.
pub fn to_asset(b: &TablesBake, cache_key: Option<&str>) -> Result<AssetBuilder, TablesError> {
    let n = b.params.order;
    let k = b.params.theta_samples;
    let mut a = AssetBuilder::new(Kind::SHTB);
    let meta = serde_json::to_string(&meta_json(b, cache_key)).map_err(err)?;
    a.add_json("meta", &meta).map_err(err)?;

    let g = b.gamma.entries();
    let idx: Vec<u16> = g.iter().flat_map(|e| [e.i, e.j, e.k]).collect();
    let val: Vec<f32> = g.iter().map(|e| e.value as f32).collect();
    a.add_u16("gamma_index", &[g.len(), 3], &idx).map_err(err)?;
    a.add_f32("gamma_value", &[g.len()], &val).map_err(err)?;

    a.add_f32("cap_visibility", &[k, n], &flat_f32(&b.cap_visibility)).map_err(err)?;
    a.add_f32("cap_log", &[k, n], &flat_f32(&b.cap_log)).map_err(err)?;
    a.add_f32("cap_log_naive", &[k, n], &flat_f32(&b.cap_log_naive)).map_err(err)?;

    let ol: Vec<f32> =
        (0..b.ol.norms.len()).flat_map(|i| [b.ol.norms[i] as f32, b.ol.a[i] as f32, b.ol.b[i] as f32]).collect();
    a.add_f32("ol_ab", &[b.ol.norms.len(), 3], &ol).map_err(err)?;
    a.add_f32("ol_domain", &[2], &[b.ol.accurate_norm as f32, b.ol.hyb_target_norm as f32]).map_err(err)?;

    a.add_f32("proxy_visibility", &[k, n], &flat_f32(&b.proxy_visibility)).map_err(err)?;
    a.add_f32("proxy_log_occlusion", &[k, n], &flat_f32(&b.proxy_log_occlusion)).map_err(err)?;
    let knots: Vec<f32> = b
        .proxy_log_knots
        .iter()
        .flat_map(|kn| core::iter::once(kn.alpha).chain(kn.row.iter().copied()))
        .map(|v| v as f32)
        .collect();
    a.add_f32("proxy_log_knots", &[b.proxy_log_knots.len(), n + 1], &knots).map_err(err)?;
    let eta = [b.eta_shadow.eta, b.eta_shadow_delta.eta, b.eta_shadow_windowed.eta, b.eta_indirect.eta];
    a.add_f32("eta", &[4], &eta.map(|v| v as f32)).map_err(err)?;

    a.add_f32("indirect_d", &[k, INDIRECT_ORDER], &flat_f32(&b.indirect_d)).map_err(err)?;
    let m2 = INDIRECT_ORDER * INDIRECT_ORDER;
    a.add_f32("indirect_m", &[k, m2, m2], &flat_f32(&b.indirect_m)).map_err(err)?;
    a.add_f32("cosine_window", &[n], &b.window.iter().map(|&v| v as f32).collect::<Vec<_>>()).map_err(err)?;

    a.add_f32("local_light", &[LOCAL_LIGHT_THETA, LOCAL_LIGHT_PHI, n * n], &flat_f32(&b.local_light)).map_err(err)?;
    let zh: Vec<f32> = b
        .local_light_fit
        .iter()
        .flat_map(|f| core::iter::once(f.psi).chain(f.zh.iter().copied()).chain(core::iter::once(f.rel_error)))
        .map(|v| v as f32)
        .collect();
    a.add_f32("local_light_zh", &[LOCAL_LIGHT_THETA, LOCAL_LIGHT_PHI, n + 2], &zh).map_err(err)?;
    a.add_f32("ohlsh_map", &[4, 9], &b.ohlsh.map(|v| v as f32)).map_err(err)?;
    Ok(a)
}
