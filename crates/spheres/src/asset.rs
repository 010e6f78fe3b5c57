//! The `SPHR` asset (sections documented in `schemas/asset-format.md`, "SPHR"):
//!
//! | section | type | dims | content |
//! |---|---|---|---|
//! | `meta` | json | | kind version, method, parameters, metrics, report |
//! | `spheres` | f32 | [N, 4] | leaf spheres `x, y, z, radius` (input units and frame) |
//! | `hierarchy_levels` | u32 | [L, 2] | per internal level (root first): first node, node count in `hierarchy_nodes` |
//! | `hierarchy_nodes` | f32 | [M, 4] | internal node spheres, level by level from the root |
//! | `hierarchy_children` | u32 | [M, 2] | per node: first child, child count — in the next level's nodes, or in `spheres` for the last level |
//! | `skin_nodes` | u32 | [N, 4] | glTF node index of each influence (`0xFFFFFFFF` unused) |
//! | `skin_weights` | f32 | [N, 4] | influence weights (sum 1) |
//! | `albedo` | f32 | [N, 3] | per-sphere linear RGB albedo in [0, 1] (kind_version 2) |
//!
//! The hierarchy, skin and albedo sections are present only when baked. Kind version 2 adds
//! `albedo`; version 1 files (no albedo) read unchanged.

use penumbra_asset::{Asset, AssetBuilder, Kind};

use crate::error::SpheresError;
use crate::fit::{FitResult, StoredHierarchy};
use crate::skin::SphereSkin;

/// Version of the SPHR layout inside format v1.
pub const SPHR_KIND_VERSION: u32 = 2;

/// Every section name an SPHR asset (kind_version 1 or 2) may contain.
pub const SPHR_SECTIONS: &[&str] = &[
    "meta",
    "spheres",
    "hierarchy_levels",
    "hierarchy_nodes",
    "hierarchy_children",
    "skin_nodes",
    "skin_weights",
    "albedo",
];

fn err(e: impl core::fmt::Display) -> SpheresError {
    SpheresError::Asset(e.to_string())
}

/// Builds the asset; `meta` is the JSON object written as the `meta` section.
pub fn to_asset(r: &FitResult, meta: &serde_json::Value) -> Result<AssetBuilder, SpheresError> {
    let mut a = AssetBuilder::new(Kind::SPHR);
    a.add_json("meta", &serde_json::to_string(meta).map_err(err)?).map_err(err)?;
    let flat: Vec<f32> = r.spheres.iter().flatten().copied().collect();
    a.add_f32("spheres", &[r.spheres.len(), 4], &flat).map_err(err)?;
    if let Some(h) = &r.hierarchy {
        let mut levels = Vec::new();
        let mut nodes = Vec::new();
        let mut children = Vec::new();
        for (l, lv) in h.levels.iter().enumerate() {
            levels.extend_from_slice(&[(nodes.len() / 4) as u32, lv.len() as u32]);
            nodes.extend(lv.iter().flatten().copied());
            for &(first, count) in &h.children[l] {
                children.extend_from_slice(&[first, count]);
            }
        }
        let m = nodes.len() / 4;
        a.add_u32("hierarchy_levels", &[h.levels.len(), 2], &levels).map_err(err)?;
        a.add_f32("hierarchy_nodes", &[m, 4], &nodes).map_err(err)?;
        a.add_u32("hierarchy_children", &[m, 2], &children).map_err(err)?;
    }
    if let Some(s) = &r.skin {
        let nodes: Vec<u32> = s.iter().flat_map(|k| k.nodes).collect();
        let weights: Vec<f32> = s.iter().flat_map(|k| k.weights.map(|w| w as f32)).collect();
        a.add_u32("skin_nodes", &[s.len(), 4], &nodes).map_err(err)?;
        a.add_f32("skin_weights", &[s.len(), 4], &weights).map_err(err)?;
    }
    if let Some(al) = &r.albedo {
        let flat: Vec<f32> = al.iter().flatten().copied().collect();
        a.add_f32("albedo", &[al.len(), 3], &flat).map_err(err)?;
    }
    Ok(a)
}

/// A sphere set read back from an asset.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereSet {
    /// Leaf spheres.
    pub spheres: Vec<[f32; 4]>,
    /// Hierarchy, if stored.
    pub hierarchy: Option<StoredHierarchy>,
    /// Skin influences, if stored.
    pub skin: Option<Vec<SphereSkin>>,
    /// Per-sphere linear RGB albedo, if stored (kind_version 2).
    pub albedo: Option<Vec<[f32; 3]>>,
}

fn rows4<T: Copy>(v: &[T]) -> Vec<[T; 4]> {
    v.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

/// Reads and validates the sphere sections of an `SPHR` asset.
pub fn read(a: &Asset) -> Result<SphereSet, SpheresError> {
    if a.kind() != Kind::SPHR {
        return Err(SpheresError::Asset(format!("expected an SPHR asset, found {}", a.kind())));
    }
    let sec = |name: &str| a.section(name);
    let s = sec("spheres").ok_or_else(|| err("missing section `spheres`"))?;
    if s.dims().len() != 2 || s.dims()[1] != 4 {
        return Err(err(format!("section `spheres` has dims {:?}, expected [N, 4]", s.dims())));
    }
    let spheres = rows4(&s.to_f32_vec().map_err(err)?);
    let hierarchy = match (sec("hierarchy_levels"), sec("hierarchy_nodes"), sec("hierarchy_children")) {
        (Some(l), Some(n), Some(c)) => {
            let levels: Vec<u32> = l.to_vec::<u32>().map_err(err)?;
            let nodes = rows4(&n.to_f32_vec().map_err(err)?);
            let ch: Vec<u32> = c.to_vec::<u32>().map_err(err)?;
            if ch.len() != 2 * nodes.len() || levels.len() % 2 != 0 {
                return Err(err("hierarchy sections disagree in size"));
            }
            let mut out = StoredHierarchy { levels: Vec::new(), children: Vec::new() };
            for pair in levels.chunks_exact(2) {
                let (first, count) = (pair[0] as usize, pair[1] as usize);
                let end = first
                    .checked_add(count)
                    .filter(|&e| e <= nodes.len())
                    .ok_or_else(|| err("hierarchy level out of range"))?;
                out.levels.push(nodes[first..end].to_vec());
                out.children.push((first..end).map(|i| (ch[2 * i], ch[2 * i + 1])).collect());
            }
            Some(out)
        }
        (None, None, None) => None,
        _ => return Err(err("incomplete hierarchy (need hierarchy_levels, hierarchy_nodes and hierarchy_children)")),
    };
    let skin = match (sec("skin_nodes"), sec("skin_weights")) {
        (Some(n), Some(w)) => {
            let nodes = rows4(&n.to_vec::<u32>().map_err(err)?);
            let weights = rows4(&w.to_f32_vec().map_err(err)?);
            if nodes.len() != spheres.len() || weights.len() != spheres.len() {
                return Err(err("skin sections do not match the sphere count"));
            }
            Some(
                nodes
                    .into_iter()
                    .zip(weights)
                    .map(|(n, w)| SphereSkin { nodes: n, weights: w.map(f64::from) })
                    .collect(),
            )
        }
        (None, None) => None,
        _ => return Err(err("incomplete skin (need skin_nodes and skin_weights)")),
    };
    let albedo = match sec("albedo") {
        None => None,
        Some(s) => {
            if s.dims() != [spheres.len(), 3] {
                return Err(err(format!("section `albedo` has dims {:?}, expected [{}, 3]", s.dims(), spheres.len())));
            }
            let v = s.to_f32_vec().map_err(err)?;
            if v.iter().any(|x| !(0.0..=1.0).contains(x)) {
                return Err(err("section `albedo` holds a value outside [0, 1]"));
            }
            Some(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
    };
    Ok(SphereSet { spheres, hierarchy, skin, albedo })
}
