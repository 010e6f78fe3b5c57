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
    /// FIV occlusion textures, one `[[fiv]]` table per occluder (`penumbra fiv`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fiv: Vec<FivStage>,
}

impl BakeConfig {
    /// Whether the config names at least one stage. Every stage added to the config is
    /// listed here.
    pub fn has_stage(&self) -> bool {
        self.tables.is_some() || !self.fiv.is_empty()
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

/// Polar axis of the FIV sample shells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// +Y up (glTF, most OBJ files).
    Y,
    /// +Z up.
    Z,
}

/// A 180° rotation of the environment about an axis (an exact texel permutation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum EnvRotate {
    /// As stored.
    None,
    /// (x, y, z) → (x, −y, −z).
    X180,
    /// (x, y, z) → (−x, y, −z).
    Y180,
    /// (x, y, z) → (−x, −y, z); brings grace_latlong.exr upright.
    Z180,
}

/// One `[[fiv]]` stage: FIV occlusion textures for one occluder under one environment
/// (FIV §4.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FivStage {
    /// Occluder mesh (.obj, .gltf, .glb; relative to this file) or a procedural occluder:
    /// `builtin:torus`, `builtin:sphere`.
    pub mesh: String,
    /// Environment map (lat-long .exr or .hdr; relative to this file) or
    /// `builtin:area-lights`.
    pub env: String,
    /// Rotation of the environment (default `none`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_rotate: Option<EnvRotate>,
    /// Samples `[azimuth, polar, radial]`: azimuth 2..=4096, polar 2..=2049, radial 2..=1024
    /// (default `[32, 17, 15]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<[u32; 3]>,
    /// Innermost shell radius in units of the bounding radius, 0 <= r_min < r_max
    /// (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_min: Option<f64>,
    /// Outermost shell radius in units of the bounding radius, r_min < r_max <= 1000
    /// (default 8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_max: Option<f64>,
    /// Polar axis of the shells (default `y`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<UpAxis>,
    /// Environment cube face size, 1..=512 (default 32: the paper's 6×32×32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cube_size: Option<u32>,
    /// Irradiance cube face size, 1..=256 (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiance_size: Option<u32>,
    /// Store the FIVs as f16 (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half: Option<bool>,
    /// Output file name inside `output_dir` (default: the mesh's file stem or builtin name,
    /// with `.fivt`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl FivStage {
    /// Output file name.
    pub fn output_name(&self) -> String {
        if let Some(o) = &self.output {
            return o.clone();
        }
        let base = self.mesh.strip_prefix("builtin:").unwrap_or(&self.mesh);
        let stem = std::path::Path::new(base).file_stem().map(|s| s.to_string_lossy().into_owned());
        format!("{}.fivt", stem.filter(|s| !s.is_empty()).unwrap_or_else(|| "occluder".into()))
    }
}
