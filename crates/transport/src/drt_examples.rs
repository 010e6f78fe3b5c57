//! Built-in DRT scenes (`penumbra drt --example NAME`, `penumbra verify drt --example NAME`):
//! a level of dictionary blocks, its clutter and default point lights.
//!
//! - `pillars` (thesis Fig. 5.4): one closed unit room with four five-faced pillars
//!   (0.12 × 0.75 × 0.12, albedo 0.6) standing on the floor at (0.25 | 0.75, 0, 0.25 | 0.75);
//!   one light at (0.38, 0.62, 0.55).
//! - `cornell` (Fig. 5.3): the Cornell box room, a `dead_end` block (open at +Z, the camera
//!   side) uniformly scaled to 5.55 world units, with its tall (0.3 × 0.6 × 0.3, turned
//!   +17°) and short (0.3 × 0.3 × 0.3, turned −17°) boxes; one light under the ceiling's centre
//!   at 0.8 of the height.
//! - `maze-boxes`: a random maze of `N` blocks with `M` five-faced boxes (footprint 0.12–0.28,
//!   height 0.12–0.4, any turn about +Y) on the floors of random blocks, never overlapping each
//!   other or the walls, from a hash of the seed; one light at the centre of every 8th block
//!   (as `verify mrt`).

use crate::TransportError;
use crate::clutter::{BoxFaces, ClutterShape, ClutterSpec, quat_y};
use crate::level::{Block, Level, maze};
use crate::level_reference::PointLight;
use penumbra_math::rng::{hash4, unit_f64};

/// A built-in scene.
#[derive(Debug, Clone)]
pub struct Example {
    /// Name.
    pub name: String,
    /// Level.
    pub level: Level,
    /// Clutter.
    pub clutter: Vec<ClutterSpec>,
    /// Default lights.
    pub lights: Vec<PointLight>,
}

/// Names of the built-in scenes.
pub const EXAMPLES: [&str; 3] = ["pillars", "cornell", "maze-boxes"];

fn boxed(name: String, size: [f64; 3], t: [f64; 3], deg: f64, albedo: f64) -> ClutterSpec {
    ClutterSpec {
        name,
        shape: ClutterShape::Box { size, faces: BoxFaces::NoBottom },
        translate: t,
        rotate: quat_y(deg),
        scale: 1.0,
        albedo: [albedo; 3],
    }
}

fn shape_index(names: &[String], want: &str) -> Result<usize, TransportError> {
    names.iter().position(|n| n == want).ok_or_else(|| {
        TransportError::Input(format!("the dictionary has no {want:?} shape (a cube2d dictionary has it)"))
    })
}

/// The scene `name`; `maze`, `seed`, `boxes` are used by `maze-boxes` only. `names` and
/// `missing` are the dictionary's shape names and missing-face masks.
pub fn example(
    name: &str,
    names: &[String],
    missing: &[u8],
    maze_blocks: usize,
    seed: u64,
    boxes: usize,
) -> Result<Example, TransportError> {
    match name {
        "pillars" => {
            let s = shape_index(names, "closed")?;
            let level = Level {
                blocks: vec![Block { shape: s, rotation: 0, translation: [0.5; 3], scale: [1.0; 3] }],
                connections: vec![],
            };
            let mut clutter = Vec::new();
            for (i, &(x, z)) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)].iter().enumerate() {
                clutter.push(boxed(format!("pillar{i}"), [0.12, 0.75, 0.12], [x, 0.0, z], 0.0, 0.6));
            }
            let lights = vec![PointLight { position: [0.38, 0.62, 0.55], intensity: 1.0 }];
            Ok(Example { name: name.into(), level, clutter, lights })
        }
        "cornell" => {
            let s = shape_index(names, "dead_end")?;
            let k = 5.55;
            let level = Level {
                blocks: vec![Block { shape: s, rotation: 0, translation: [0.5 * k; 3], scale: [k; 3] }],
                connections: vec![],
            };
            let clutter = vec![
                boxed("tall box".into(), [0.3 * k, 0.6 * k, 0.3 * k], [0.34 * k, 0.0, 0.36 * k], 17.0, 0.6),
                boxed("short box".into(), [0.3 * k, 0.3 * k, 0.3 * k], [0.67 * k, 0.0, 0.62 * k], -17.0, 0.6),
            ];
            let lights = vec![PointLight { position: [0.5 * k, 0.8 * k, 0.5 * k], intensity: k * k }];
            Ok(Example { name: name.into(), level, clutter, lights })
        }
        "maze-boxes" => {
            let level = maze(maze_blocks, seed, missing).map_err(|e| TransportError::Param(format!("maze: {e}")))?;
            let nb = level.blocks.len();
            let mut clutter: Vec<ClutterSpec> = Vec::new();
            // (block, x, z, radius) of placed footprints
            let mut placed: Vec<(usize, f64, f64, f64)> = Vec::new();
            let stage = 0x4d42_4f58;
            let mut attempt = 0u64;
            while clutter.len() < boxes && attempt < 64 * boxes as u64 + 64 {
                let a = attempt;
                let u = |j: u64| unit_f64(hash4(seed, stage, a, j));
                attempt += 1;
                let b = ((u(0) * nb as f64) as usize).min(nb - 1);
                let (sx, sz, sy) = (0.12 + 0.16 * u(1), 0.12 + 0.16 * u(2), 0.12 + 0.28 * u(3));
                let r = 0.5 * (sx * sx + sz * sz).sqrt();
                // local footprint centre: the whole rotated footprint stays 0.02 off the walls
                let lo = r + 0.02;
                let (x, z) = (lo + (1.0 - 2.0 * lo) * u(4), lo + (1.0 - 2.0 * lo) * u(5));
                if placed.iter().any(|&(pb, px, pz, pr)| pb == b && (px - x).hypot(pz - z) < pr + r + 0.02) {
                    continue;
                }
                let blk = &level.blocks[b];
                let w = blk.to_world([x, 0.0, z]);
                let deg = 360.0 * u(6);
                placed.push((b, x, z, r));
                clutter.push(boxed(format!("box{}", clutter.len()), [sx, sy, sz], w, deg, 0.6));
            }
            if clutter.len() < boxes {
                return Err(TransportError::Param(format!(
                    "could place only {} of {boxes} boxes in a {nb}-block maze",
                    clutter.len()
                )));
            }
            let lights = (0..nb)
                .step_by(8)
                .map(|b| PointLight { position: level.blocks[b].to_world([0.5; 3]), intensity: 1.0 })
                .collect();
            Ok(Example { name: format!("maze-boxes {maze_blocks} seed {seed} boxes {boxes}"), level, clutter, lights })
        }
        other => Err(TransportError::Param(format!("unknown example {other:?} (known: {})", EXAMPLES.join(", ")))),
    }
}
