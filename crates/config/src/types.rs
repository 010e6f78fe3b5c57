//! Config types. Field docs become the JSON Schema descriptions.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A penumbra bake: one config names every asset a scene needs; only those are baked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "penumbra bake configuration")]
pub struct BakeConfig {
    /// Directory for the baked assets and `report.json`, relative to this file.
    pub output_dir: String,
    /// SH log/exp and proxy tables (`penumbra tables`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tables: Option<TablesStage>,
}

impl BakeConfig {
    /// Whether the config names at least one stage. Every stage added to the config is
    /// listed here.
    pub fn has_stage(&self) -> bool {
        self.tables.is_some()
    }
}

/// The `[tables]` stage: SH tables for one SH order (SHEXP §4–7, IBPA §4–5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TablesStage {
    /// SH order n (bands), 2..=8.
    pub order: u32,
    /// Samples of the 1D tables in θ / α, 16..=16384 (default 256).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta_samples: Option<u32>,
    /// Shading tolerance of the expansion-factor analysis, 0 < T < 1 (default 1/256).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading_tolerance: Option<f64>,
    /// Optional environment map (lat-long .exr or .hdr) to specialise η to its lighting.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env: Option<String>,
    /// Output file name inside `output_dir` (default `tables.shtb`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl TablesStage {
    /// Output file name.
    pub fn output_name(&self) -> &str {
        self.output.as_deref().unwrap_or("tables.shtb")
    }
}
