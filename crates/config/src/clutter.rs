//! The DRT clutter file (`penumbra drt --clutter clutter.toml`): objects placed inside a
//! level's blocks (MRT thesis ch. 5). Field docs become `schemas/clutter.schema.json`.
//!
//! This module checks syntax, types, unknown keys (with the key path) and the per-entry rules
//! that need no geometry (exactly one of `mesh` / `box`, at most one rotation form, ranges);
//! placement inside the level is checked by the bake.

use crate::error::ConfigError;
use crate::validate::Issue;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Clutter instances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "penumbra DRT clutter")]
pub struct ClutterFile {
    /// The instances, indexed from 0 in file order.
    #[serde(default, rename = "clutter")]
    pub clutter: Vec<ClutterEntry>,
}

/// One clutter instance: a box or a mesh, placed by `x ↦ translate + R(scale·x)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ClutterEntry {
    /// A name for reports (default `clutter<index>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// A mesh file (OBJ or glTF/GLB), relative to the clutter file; its triangles are taken
    /// in the file's world frame at rest pose, then placed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<String>,
    /// With `mesh`: only the triangles of the glTF nodes whose name matches (glob: `*` any
    /// run, `?` one character), and of their descendants: one pattern or a list.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<crate::types::NodeSelect>,
    /// With `mesh`: how its texels and charts are laid out: `"lightmap"` (the glTF
    /// `TEXCOORD_1` islands; an error when the mesh has none) or `"box-projection"`. Default:
    /// `"lightmap"` when every primitive has `TEXCOORD_1`, else `"box-projection"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charts: Option<ChartsName>,
    /// With lightmap charts: the atlas's texels per edge (2..=4096). Default: the texel
    /// density of the box projection (docs/drt.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lightmap_res: Option<usize>,
    /// A box instead of a mesh.
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub box_: Option<ClutterBox>,
    /// World translation (the level's units). A box stands on it: it is the centre of the
    /// box's footprint.
    pub translate: [f64; 3],
    /// A turn about +Y in degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotate_y_deg: Option<f64>,
    /// A rotation as a unit quaternion `[x, y, z, w]` (instead of `rotate_y_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotate: Option<[f64; 4]>,
    /// Uniform scale (default 1), > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Diffuse albedo, a scalar or `[r, g, b]`, each in `[0, 1)` (default 0.6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<Albedo>,
}

/// A box: `size` along x, y, z; it spans `[−x/2, x/2] × [0, y] × [−z/2, z/2]` before placement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ClutterBox {
    /// Size along x, y, z (> 0).
    pub size: [f64; 3],
    /// `"all"` (default) or `"no-bottom"` (five faces: a pillar standing on the floor).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faces: Option<BoxFacesName>,
}

/// Which faces a box has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum BoxFacesName {
    /// All six.
    All,
    /// No bottom (−y) face.
    NoBottom,
}

/// How a clutter mesh's charts are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ChartsName {
    /// The lightmap UVs (glTF `TEXCOORD_1`): one chart per UV island.
    Lightmap,
    /// The automatic box projection.
    BoxProjection,
}

/// A scalar or RGB albedo.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Albedo {
    /// The same in every channel.
    Scalar(f64),
    /// Per channel.
    Rgb([f64; 3]),
}

impl Albedo {
    /// RGB.
    pub fn rgb(self) -> [f64; 3] {
        match self {
            Self::Scalar(a) => [a; 3],
            Self::Rgb(c) => c,
        }
    }
}

/// Parses clutter text; `path` is only used in messages. Checks the per-entry rules.
pub fn parse_clutter_str(source: &str, path: &Path) -> Result<ClutterFile, ConfigError> {
    let de = toml::de::Deserializer::parse(source).map_err(|e| ConfigError::syntax(path, source, &e))?;
    let f: ClutterFile = serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        ConfigError::field(path, source, key, &inner)
    })?;
    for (i, c) in f.clutter.iter().enumerate() {
        let bad = |key: &str, m: String| {
            let issue = Issue { key: format!("clutter[{i}].{key}"), message: m };
            Err(ConfigError::invalid(path, source, &issue, 1))
        };
        match (&c.mesh, &c.box_) {
            (Some(_), Some(_)) | (None, None) => {
                return bad("mesh", "give exactly one of `mesh` and `box`".into());
            }
            _ => {}
        }
        if c.node.is_some() && c.mesh.is_none() {
            return bad("node", "`node` needs `mesh`".into());
        }
        if let Some(m) = crate::validate::node_select_issue(c.node.as_ref()) {
            return bad("node", m);
        }
        if c.charts.is_some() && c.mesh.is_none() {
            return bad("charts", "`charts` needs `mesh`".into());
        }
        if let Some(r) = c.lightmap_res {
            if c.charts == Some(ChartsName::BoxProjection) || c.mesh.is_none() {
                return bad("lightmap_res", "`lightmap_res` needs a mesh with lightmap charts".into());
            }
            if !(2..=4096).contains(&r) {
                return bad("lightmap_res", format!("{r} is out of range (allowed: 2..=4096)"));
            }
        }
        if c.rotate.is_some() && c.rotate_y_deg.is_some() {
            return bad("rotate", "give at most one of `rotate` and `rotate_y_deg`".into());
        }
        if let Some(s) = c.scale {
            if !(s.is_finite() && s > 0.0) {
                return bad("scale", format!("{s} is out of range (allowed: > 0)"));
            }
        }
        if let Some(a) = c.albedo {
            if !a.rgb().iter().all(|x| (0.0..1.0).contains(x)) {
                return bad("albedo", format!("{:?} is out of range (allowed: 0 <= a < 1)", a.rgb()));
            }
        }
        if let Some(b) = &c.box_ {
            if !b.size.iter().all(|x| x.is_finite() && *x > 0.0) {
                return bad("box.size", format!("{:?} must be positive", b.size));
            }
        }
        if !c.translate.iter().all(|x| x.is_finite()) {
            return bad("translate", format!("{:?} is not finite", c.translate));
        }
    }
    Ok(f)
}

/// Reads and parses a clutter file.
pub fn load_clutter(path: &Path) -> Result<ClutterFile, ConfigError> {
    let source = std::fs::read_to_string(path).map_err(|e| ConfigError::io(path, e))?;
    parse_clutter_str(&source, path)
}

/// The JSON Schema of the clutter file, pretty-printed with a trailing newline.
pub fn clutter_schema_json() -> String {
    let schema = schemars::schema_for!(ClutterFile);
    let mut s = serde_json::to_string_pretty(&schema).unwrap_or_else(|_| String::from("{}"));
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_boxes_and_meshes_and_names_bad_keys() {
        let src = "[[clutter]]\nbox = { size = [0.2, 0.8, 0.2], faces = \"no-bottom\" }\ntranslate = [0.3, 0, 0.3]\n\
                   rotate_y_deg = 30\nalbedo = 0.5\n\
                   [[clutter]]\nmesh = \"crate.glb\"\nnode = \"Crate\"\ntranslate = [1, 0, 1]\nalbedo = [0.5, 0.2, 0.1]\n";
        let f = parse_clutter_str(src, Path::new("c.toml")).unwrap();
        assert_eq!(f.clutter.len(), 2);
        assert_eq!(f.clutter[0].box_.as_ref().unwrap().faces, Some(BoxFacesName::NoBottom));
        assert_eq!(f.clutter[1].albedo.unwrap().rgb(), [0.5, 0.2, 0.1]);
        let e = parse_clutter_str(
            "[[clutter]]\nbox = { size = [1, 1, 1] }\ntranslate = [0, 0, 0]\nscal = 2\n",
            Path::new("bad.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("bad.toml") && e.contains("scal"), "{e}");
        let e = parse_clutter_str("[[clutter]]\ntranslate = [0, 0, 0]\n", Path::new("x.toml")).unwrap_err().to_string();
        assert!(e.contains("clutter[0].mesh") && e.contains("exactly one"), "{e}");
        let e = parse_clutter_str(
            "[[clutter]]\nbox = { size = [1, 1, 1] }\ntranslate = [0, 0, 0]\nalbedo = 1.5\n",
            Path::new("x.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("clutter[0].albedo"), "{e}");
    }
}
