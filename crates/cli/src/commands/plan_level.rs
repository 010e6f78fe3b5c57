//! `penumbra plan`'s MRT level: glTF nodes with role `block` → blocks of a level file.
//!
//! A block is the world box of its node's triangles (rest pose). Its shape and quarter turn
//! come from the node's extras (`{"penumbra": {"role": "block", "shape": "straight",
//! "rotation": 1}}`) or from the geometry: a side of the box is an opening when less than half
//! of it is covered by triangles lying in its plane, and the cube2d shape whose rotated
//! openings are exactly those is taken. Two openings on the same rectangle, facing each
//! other, are connected; the level is validated as `penumbra mrt level` would.

use crate::exit::CliError;
use anyhow::anyhow;
use penumbra_config::level::{LevelBlock, LevelConnection, LevelFile};
use penumbra_geometry::scene::Scene;
use penumbra_transport::level::{Block, Connection, Level, fit_shape, parse_face};
use penumbra_transport::shape::{CUBE2D, FACE_NAMES};
use serde_json::Value;
use std::path::Path;

/// The world box of some triangles and which of its side faces (bits over faces `-x, +x, -z,
/// +z` = 0, 1, 4, 5) their geometry leaves open.
#[derive(Debug, Clone, Copy)]
pub struct Geometry {
    /// Box corner with the smallest coordinates.
    pub lo: [f64; 3],
    /// Box corner with the largest coordinates.
    pub hi: [f64; 3],
    /// Open side faces.
    pub open: u8,
}

/// A planned block: the node, its level-file entry and its world box.
#[derive(Debug, Clone)]
pub struct PlannedBlock {
    /// Node name.
    pub name: String,
    /// The level-file entry.
    pub block: LevelBlock,
    /// World box.
    pub geometry: Geometry,
}

impl PlannedBlock {
    /// Whether `g`'s box lies inside this block's box.
    pub fn contains(&self, g: &Geometry) -> bool {
        let (l, h) = (self.geometry.lo, self.geometry.hi);
        (0..3).all(|k| {
            let tol = 1e-6 * (h[k] - l[k]);
            g.lo[k] >= l[k] - tol && g.hi[k] <= h[k] + tol
        })
    }
}

fn missing_masks() -> Vec<u8> {
    CUBE2D.iter().map(|s| s.missing).collect()
}

/// The box and open faces of the triangles of the nodes in `members` (`None`: no triangle).
pub fn geometry(scene: &Scene, node_of_tri: &[Option<usize>], members: &[usize]) -> Option<Geometry> {
    let p = |v: u32| scene.mesh.positions[v as usize].map(f64::from);
    let tris: Vec<[[f64; 3]; 3]> = scene
        .mesh
        .indices
        .iter()
        .zip(node_of_tri)
        .filter(|(_, n)| n.is_some_and(|n| members.contains(&n)))
        .map(|(t, _)| t.map(p))
        .collect();
    if tris.is_empty() {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for q in tris.iter().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    let size: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
    let tol = 1e-4 * size.iter().fold(0.0f64, |m, &x| m.max(x));
    // area of the triangles lying in each side plane of the box
    let mut covered = [0.0f64; 6];
    for q in &tris {
        let e1: [f64; 3] = std::array::from_fn(|k| q[1][k] - q[0][k]);
        let e2: [f64; 3] = std::array::from_fn(|k| q[2][k] - q[0][k]);
        let c = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let area = 0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        for f in [0usize, 1, 4, 5] {
            let axis = f / 2;
            let plane = if f % 2 == 1 { hi[axis] } else { lo[axis] };
            if q.iter().all(|v| (v[axis] - plane).abs() <= tol) {
                covered[f] += area;
            }
        }
    }
    let mut open = 0u8;
    for f in [0usize, 1, 4, 5] {
        let face_area = size[1] * size[if f / 2 == 0 { 2 } else { 0 }];
        if covered[f] < 0.5 * face_area {
            open |= 1 << f;
        }
    }
    Some(Geometry { lo, hi, open })
}

/// `x` at f32 precision, printed short (glTF positions are f32).
fn tidy(x: f64) -> f64 {
    format!("{}", x as f32).parse().unwrap_or(x)
}

/// The block of node `name`: shape and rotation from `extras` (`extras.penumbra`) or from the
/// openings of `g`. Exit 2 naming the scene and node when neither gives a cube2d shape.
pub fn block(scene: &Path, name: &str, extras: Option<&Value>, g: Geometry) -> Result<PlannedBlock, CliError> {
    let bad = |m: String| CliError::input(anyhow!("{}: block {name:?}: {m}", scene.display()));
    let shape_names = || CUBE2D.iter().map(|c| c.name).collect::<Vec<_>>().join(", ");
    let (shape, rotation) = match extras.and_then(|x| x.get("shape")) {
        Some(s) => {
            let Some(si) = s.as_str().and_then(|s| CUBE2D.iter().position(|c| c.name == s)) else {
                return Err(bad(format!("extras shape {s} is not a cube2d shape ({})", shape_names())));
            };
            let q = match extras.and_then(|x| x.get("rotation")) {
                None => 0,
                Some(r) => match r.as_u64() {
                    Some(q) if q <= 3 => q as u32,
                    _ => {
                        return Err(bad(format!("extras rotation {r} is out of range (allowed: 0..=3 quarter turns)")));
                    }
                },
            };
            (si, q)
        }
        None => fit_shape(&missing_masks(), g.open).ok_or_else(|| {
            let open: Vec<&str> = (0..6).filter(|f| g.open & (1 << f) != 0).map(|f| FACE_NAMES[f]).collect();
            bad(format!(
                "no cube2d shape has the openings {open:?} its geometry leaves (give extras {{\"penumbra\": \
                 {{\"role\": \"block\", \"shape\": …, \"rotation\": …}}}}; shapes: {})",
                shape_names()
            ))
        })?,
    };
    let size: [f64; 3] = std::array::from_fn(|k| tidy(g.hi[k] - g.lo[k]));
    let scale = if rotation % 2 == 1 { [size[2], size[1], size[0]] } else { size };
    let block = LevelBlock {
        shape: CUBE2D[shape].name.into(),
        rotation,
        translation: std::array::from_fn(|k| tidy(0.5 * (g.lo[k] + g.hi[k]))),
        scale: (scale != [1.0; 3]).then_some(scale),
    };
    Ok(PlannedBlock { name: name.into(), block, geometry: g })
}

fn transport_block(b: &LevelBlock) -> Block {
    Block {
        shape: CUBE2D.iter().position(|c| c.name == b.shape).unwrap_or(0),
        rotation: b.rotation,
        translation: b.translation,
        scale: b.scale.unwrap_or([1.0; 3]),
    }
}

/// The level of the planned blocks: openings on the same rectangle facing each other are
/// connected, and the result is validated (exit 2 naming the scene when the blocks overlap).
/// Also returns notes on openings nothing meets.
pub fn level(scene: &Path, blocks: &[PlannedBlock]) -> Result<(LevelFile, Vec<String>), CliError> {
    let missing = missing_masks();
    let tb: Vec<Block> = blocks.iter().map(|b| transport_block(&b.block)).collect();
    let open_world = |b: &Block| -> Vec<(usize, usize)> {
        (0..6).filter(|&f| missing[b.shape] & (1 << f) != 0).map(|f| (b.world_face(f), f)).collect()
    };
    let mut connections = Vec::new();
    for i in 0..blocks.len() {
        for j in i + 1..blocks.len() {
            let (gi, gj) = (&blocks[i].geometry, &blocks[j].geometry);
            let size = (0..3).map(|k| (gi.hi[k] - gi.lo[k]).max(gj.hi[k] - gj.lo[k])).fold(0.0f64, f64::max);
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-4 * size;
            for (wi, fi) in open_world(&tb[i]) {
                for (wj, fj) in open_world(&tb[j]) {
                    let axis = wi / 2;
                    if wj / 2 != axis || wi % 2 == wj % 2 {
                        continue;
                    }
                    let (pi, pj) = if wi % 2 == 1 { (gi.hi[axis], gj.lo[axis]) } else { (gi.lo[axis], gj.hi[axis]) };
                    let same_rect =
                        (0..3).filter(|&k| k != axis).all(|k| close(gi.lo[k], gj.lo[k]) && close(gi.hi[k], gj.hi[k]));
                    if close(pi, pj) && same_rect {
                        connections.push(LevelConnection {
                            a: i,
                            a_face: FACE_NAMES[fi].into(),
                            b: j,
                            b_face: FACE_NAMES[fj].into(),
                        });
                    }
                }
            }
        }
    }
    let lv = Level {
        blocks: tb,
        connections: connections
            .iter()
            .map(|c| Connection {
                a: c.a,
                fa: parse_face(&c.a_face).unwrap_or(0),
                b: c.b,
                fb: parse_face(&c.b_face).unwrap_or(0),
            })
            .collect(),
    };
    let names: Vec<String> = CUBE2D.iter().map(|c| c.name.to_string()).collect();
    lv.validate(&names, &missing)
        .map_err(|e| CliError::input(anyhow!("{}: the blocks do not form an MRT level: {e}", scene.display())))?;
    let mut notes = Vec::new();
    for (b, pb) in blocks.iter().enumerate() {
        let openings = missing[lv.blocks[b].shape].count_ones();
        let used = connections.iter().filter(|c| c.a == b || c.b == b).count() as u32;
        if openings > used {
            notes.push(format!(
                "block {:?} ({}) has {} opening(s) no other block meets: light leaves the level there",
                pb.name,
                pb.block.shape,
                openings - used
            ));
        }
    }
    Ok((LevelFile { blocks: blocks.iter().map(|b| b.block.clone()).collect(), connections }, notes))
}
