//! Quality gates of bake stages (`gate = { … }`): after baking, `penumbra bake` runs the
//! stage's verify command with its defaults and exits 1 when a bound is exceeded (the asset is
//! kept; the report names the stage, the gate and the measured value). The keys are the verify
//! flags' (`verify fiv --max-nrmse` ↔ `max_nrmse`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// `gate` of a `[[fiv]]` stage: `penumbra verify fiv --plane` on the baked table (give at
/// least one bound).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FivGate {
    /// Bound on `nrmse` (all plane receivers), > 0: `verify fiv --max-nrmse`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_nrmse: Option<f64>,
    /// Bound on `nrmse_visible` (receivers visible from above), > 0:
    /// `verify fiv --max-nrmse-visible`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_nrmse_visible: Option<f64>,
}

/// `gate` of the `[mrt_level]` stage (`verify mrt`: `rel_error_one_bounce`) or of the `[drt]`
/// stage (`verify drt`: `rel_error_mrt_drt`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RelErrorGate {
    /// Bound on the relative error of indirect light against the path tracer, > 0:
    /// `--max-rel-error`.
    pub max_rel_error: f64,
}

/// `gate` of the `[vo]` stage: `penumbra verify vo --sets <the baked sets>` on a mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VoGate {
    /// Bound on `rmse_vs_volume`, > 0: `verify vo --max-rmse`.
    pub max_rmse: f64,
    /// The mesh whose depth buffer is verified (.obj, .gltf, .glb), relative to this config.
    pub mesh: String,
    /// Estimator and count, `lines:N`, `area:N` or `points:N` (default `lines:9`; N must be
    /// one of the stage's `counts`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
}

/// A gate bound: finite and > 0.
pub(crate) fn bad_bound(x: f64) -> bool {
    !(x > 0.0 && x.is_finite())
}
