//! The MRT level file (`penumbra mrt level LEVEL.toml`): a layout of dictionary blocks and
//! the connections between their missing faces (MRT thesis §3.5.2, §4.3). Field docs become
//! the JSON Schema committed as `schemas/mrt-level.schema.json`.
//!
//! This module checks syntax, types and unknown keys; the geometry (faces that claim to
//! connect must coincide, shapes must exist in the dictionary) is checked by the level bake,
//! which knows the dictionary (`penumbra_transport::level`).

use crate::error::ConfigError;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// An MRT level: blocks and connections.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "penumbra MRT level")]
pub struct LevelFile {
    /// The blocks, indexed from 0 in file order.
    #[serde(default, rename = "block")]
    pub blocks: Vec<LevelBlock>,
    /// Connections between missing side faces of two blocks.
    #[serde(default, rename = "connection", skip_serializing_if = "Vec::is_empty")]
    pub connections: Vec<LevelConnection>,
}

/// One block: a dictionary shape placed in the world. A block-local point `p` of the unit
/// cube `[0,1]³` lands at `translation + R(scale ⊙ (p − ½))`, `R` the rotation by
/// `rotation` quarter turns about +Y (`(x, y, z) → (z, y, −x)` per turn).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LevelBlock {
    /// Dictionary shape name (cube2d: `closed`, `dead_end`, `straight`, `corner`, `tee`,
    /// `cross`).
    pub shape: String,
    /// Quarter turns about +Y, 0..=3 (default 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rotation: u32,
    /// World position of the block's centre.
    pub translation: [f64; 3],
    /// Size along the block's local x, y, z (the "warp"; default `[1, 1, 1]`); positive.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<[f64; 3]>,
}

/// A connection: face `a_face` of block `a` meets face `b_face` of block `b`. Faces are
/// block-local side faces (`-x`, `+x`, `-z`, `+z`) that the shapes leave open.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LevelConnection {
    /// First block index.
    pub a: usize,
    /// Its face.
    pub a_face: String,
    /// Second block index.
    pub b: usize,
    /// Its face.
    pub b_face: String,
}

/// Point lights for `penumbra verify mrt --lights FILE`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LightsFile {
    /// The lights.
    #[serde(default, rename = "light")]
    pub lights: Vec<LevelLight>,
}

/// A point light inside the level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LevelLight {
    /// World position (inside a block).
    pub position: [f64; 3],
    /// Intensity: irradiance at unit distance, normal incidence (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intensity: Option<f64>,
}

/// Reads and parses a lights file.
pub fn load_lights(path: &Path) -> Result<LightsFile, ConfigError> {
    let source = std::fs::read_to_string(path).map_err(|e| ConfigError::io(path, e))?;
    let de = toml::de::Deserializer::parse(&source).map_err(|e| ConfigError::syntax(path, &source, &e))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        ConfigError::field(path, &source, key, &inner)
    })
}

fn is_zero(x: &u32) -> bool {
    *x == 0
}

impl LevelFile {
    /// The level as TOML text (for `--write-level`).
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_default();
        format!("# penumbra MRT level (schema: schemas/mrt-level.schema.json)\n{body}")
    }
}

/// Parses level text; `path` is only used in messages.
pub fn parse_level_str(source: &str, path: &Path) -> Result<LevelFile, ConfigError> {
    let de = toml::de::Deserializer::parse(source).map_err(|e| ConfigError::syntax(path, source, &e))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        ConfigError::field(path, source, key, &inner)
    })
}

/// Reads and parses a level file.
pub fn load_level(path: &Path) -> Result<LevelFile, ConfigError> {
    let source = std::fs::read_to_string(path).map_err(|e| ConfigError::io(path, e))?;
    parse_level_str(&source, path)
}

/// The JSON Schema of the level file, pretty-printed with a trailing newline.
pub fn level_schema_json() -> String {
    let schema = schemars::schema_for!(LevelFile);
    let mut s = serde_json::to_string_pretty(&schema).unwrap_or_else(|_| String::from("{}"));
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_rejects_unknown_keys() {
        let src = "[[block]]\nshape = \"straight\"\nrotation = 1\ntranslation = [0.5, 0.5, 0.5]\n\
                   [[block]]\nshape = \"dead_end\"\ntranslation = [1.5, 0.5, 0.5]\nscale = [1, 2, 1]\n\
                   [[connection]]\na = 0\na_face = \"+z\"\nb = 1\nb_face = \"-x\"\n";
        let l = parse_level_str(src, Path::new("l.toml")).unwrap();
        assert_eq!(l.blocks.len(), 2);
        assert_eq!(l.blocks[0].rotation, 1);
        assert_eq!(l.blocks[1].scale, Some([1.0, 2.0, 1.0]));
        assert_eq!(l.connections[0].b_face, "-x");
        let again = parse_level_str(&l.to_toml(), Path::new("l.toml")).unwrap();
        assert_eq!(again, l);
        let e =
            parse_level_str("[[block]]\nshape = \"x\"\ntranslation = [0,0,0]\nrotaton = 1\n", Path::new("bad.toml"))
                .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("bad.toml") && msg.contains("rotaton"), "{msg}");
    }
}
