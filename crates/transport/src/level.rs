//! MRT levels (MRT thesis §3.5.2, §4.3): dictionary blocks placed in the world and the
//! connections between their missing side faces; validation; procedural test levels
//! (corridor, L-turn, random maze).
//!
//! # Block transform
//! A block-local point `p ∈ [0,1]³` lands at `translation + R_q(scale ⊙ (p − ½))`, with `R_q`
//! `q` quarter turns about +Y, each `(x, y, z) → (z, y, −x)` (a right-handed +90° turn).
//! Rotations about +Y keep every face axis-aligned and keep floor and ceiling in place, so the
//! dictionary's operators apply unchanged (their frames only depend on the travel direction,
//! `crate::lightfield`); the scale is the thesis's "warp": the operators of the unit block
//! are reused for a stretched one (§3.5.2, an approximation the verification measures).

use crate::shape::{FACE_COUNT, FACE_FRAMES, FACE_NAMES, face_axis, face_point};
use penumbra_math::rng::{hash4, unit_f64};

/// Errors of a level, each naming the block or connection.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LevelError {
    /// The level has no blocks.
    #[error("the level has no blocks")]
    Empty,
    /// A problem with one block.
    #[error("block {index}: {message}")]
    Block {
        /// Block index.
        index: usize,
        /// What is wrong.
        message: String,
    },
    /// A problem with one connection.
    #[error("connection {index} (blocks {a} and {b}): {message}")]
    Connection {
        /// Connection index.
        index: usize,
        /// First block.
        a: usize,
        /// Second block.
        b: usize,
        /// What is wrong.
        message: String,
    },
}

/// One placed block.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// Index of its shape in the dictionary.
    pub shape: usize,
    /// Quarter turns about +Y (0..=3).
    pub rotation: u32,
    /// World position of the centre.
    pub translation: [f64; 3],
    /// Size along local x, y, z.
    pub scale: [f64; 3],
}

impl Block {
    /// World position of block-local `p`.
    #[inline]
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        let l = [(p[0] - 0.5) * self.scale[0], (p[1] - 0.5) * self.scale[1], (p[2] - 0.5) * self.scale[2]];
        let r = rotate_y(l, self.rotation);
        [r[0] + self.translation[0], r[1] + self.translation[1], r[2] + self.translation[2]]
    }

    /// Block-local point of world `w` (the inverse of [`Block::to_world`]).
    #[inline]
    pub fn to_local(&self, w: [f64; 3]) -> [f64; 3] {
        let d = [w[0] - self.translation[0], w[1] - self.translation[1], w[2] - self.translation[2]];
        let l = rotate_y(d, (4 - self.rotation % 4) % 4);
        [l[0] / self.scale[0] + 0.5, l[1] / self.scale[1] + 0.5, l[2] / self.scale[2] + 0.5]
    }

    /// World direction of a block-local direction (not normalised when scaled).
    #[inline]
    pub fn dir_to_world(&self, d: [f64; 3]) -> [f64; 3] {
        rotate_y([d[0] * self.scale[0], d[1] * self.scale[1], d[2] * self.scale[2]], self.rotation)
    }

    /// Block-local direction of a world direction, such that `to_local(w + t·d)` moves by
    /// `t·dir_to_local(d)`.
    #[inline]
    pub fn dir_to_local(&self, d: [f64; 3]) -> [f64; 3] {
        let l = rotate_y(d, (4 - self.rotation % 4) % 4);
        [l[0] / self.scale[0], l[1] / self.scale[1], l[2] / self.scale[2]]
    }

    /// World unit normal (inward) of local face `f`.
    #[inline]
    pub fn normal(&self, f: usize) -> [f64; 3] {
        rotate_y(FACE_FRAMES[f].n, self.rotation)
    }

    /// The world face (`0..6`, same numbering as local faces) that local face `f` becomes.
    #[inline]
    pub fn world_face(&self, f: usize) -> usize {
        world_face(f, self.rotation)
    }

    /// The local face that lies on world face `w`.
    #[inline]
    pub fn local_face(&self, w: usize) -> usize {
        (0..FACE_COUNT).find(|&f| self.world_face(f) == w).unwrap_or(w)
    }
}

/// `q` quarter turns about +Y: `(x, y, z) → (z, y, −x)` per turn.
#[inline]
pub fn rotate_y(v: [f64; 3], q: u32) -> [f64; 3] {
    match q % 4 {
        0 => v,
        1 => [v[2], v[1], -v[0]],
        2 => [-v[0], v[1], -v[2]],
        _ => [-v[2], v[1], v[0]],
    }
}

/// The face a local face becomes after `q` quarter turns (by its inward normal).
pub fn world_face(f: usize, q: u32) -> usize {
    let n = rotate_y(FACE_FRAMES[f].n, q);
    let a = (0..3).max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs())).unwrap_or(0);
    // inward normal +axis ⇒ the face at the low end of that axis
    2 * a + usize::from(n[a] < 0.0)
}

/// A connection between local face `fa` of block `a` and local face `fb` of block `b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Connection {
    /// First block.
    pub a: usize,
    /// Its local face.
    pub fa: usize,
    /// Second block.
    pub b: usize,
    /// Its local face.
    pub fb: usize,
}

/// A level.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    /// Blocks.
    pub blocks: Vec<Block>,
    /// Connections.
    pub connections: Vec<Connection>,
}

/// Parses a face name (`-x`, `+x`, `-y`, `+y`, `-z`, `+z`).
pub fn parse_face(s: &str) -> Option<usize> {
    FACE_NAMES.iter().position(|&n| n == s)
}

/// The neighbour across every local face of every block: `links[b][f] = Some((b', f'))`.
pub type Links = Vec<[Option<(usize, usize)>; FACE_COUNT]>;

impl Level {
    /// Checks the level against the dictionary's shapes (`missing[s]` = missing-face mask of
    /// shape `s`, `names[s]` its name): transforms finite, rotations 0..=3, scales positive;
    /// connections between existing blocks, through side faces both shapes leave open,
    /// each face used once, and the two faces coincide in the world with opposite normals.
    /// Returns the neighbour table.
    pub fn validate(&self, names: &[String], missing: &[u8]) -> Result<Links, LevelError> {
        if self.blocks.is_empty() {
            return Err(LevelError::Empty);
        }
        for (i, b) in self.blocks.iter().enumerate() {
            let bad = |message: String| LevelError::Block { index: i, message };
            if b.shape >= missing.len() {
                return Err(bad(format!("shape index {} is not in the dictionary", b.shape)));
            }
            if b.rotation > 3 {
                return Err(bad(format!("rotation {} is out of range (allowed: 0..=3 quarter turns)", b.rotation)));
            }
            if !b.translation.iter().all(|x| x.is_finite()) {
                return Err(bad(format!("translation {:?} is not finite", b.translation)));
            }
            if !b.scale.iter().all(|x| x.is_finite() && *x > 0.0) {
                return Err(bad(format!("scale {:?} must be finite and positive", b.scale)));
            }
        }
        // blocks are boxes (quarter turns): two that share volume would put two sets of walls
        // in one place, which no operator models (connected blocks only touch at a face)
        let boxes: Vec<[[f64; 3]; 2]> = self
            .blocks
            .iter()
            .map(|b| {
                let (p, q) = (b.to_world([0.0; 3]), b.to_world([1.0; 3]));
                [core::array::from_fn(|k| p[k].min(q[k])), core::array::from_fn(|k| p[k].max(q[k]))]
            })
            .collect();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (&boxes[i], &boxes[j]);
                let tol =
                    1e-6 * (0..3).map(|k| (a[1][k] - a[0][k]).min(b[1][k] - b[0][k])).fold(f64::INFINITY, f64::min);
                let depth: [f64; 3] = core::array::from_fn(|k| a[1][k].min(b[1][k]) - a[0][k].max(b[0][k]));
                if depth.iter().all(|&d| d > tol) {
                    return Err(LevelError::Block {
                        index: i,
                        message: format!(
                            "overlaps block {j} (they share a box of {:?} world units; blocks may only touch, at \
                             connected openings or walls)",
                            depth.map(|d| (d * 1000.0).round() / 1000.0)
                        ),
                    });
                }
            }
        }
        let mut links: Links = vec![[None; FACE_COUNT]; self.blocks.len()];
        for (ci, c) in self.connections.iter().enumerate() {
            let bad = |message: String| LevelError::Connection { index: ci, a: c.a, b: c.b, message };
            for (blk, f) in [(c.a, c.fa), (c.b, c.fb)] {
                let Some(b) = self.blocks.get(blk) else {
                    return Err(bad(format!("block {blk} does not exist ({} blocks)", self.blocks.len())));
                };
                if f >= FACE_COUNT || face_axis(f).0 == 1 {
                    return Err(bad(format!("block {blk}: face {f} is not a side face (-x, +x, -z, +z)")));
                }
                if missing[b.shape] & (1 << f) == 0 {
                    return Err(bad(format!(
                        "block {blk}: face {} is a wall of shape {:?}, not an opening",
                        FACE_NAMES[f], names[b.shape]
                    )));
                }
                if links[blk][f].is_some() {
                    return Err(bad(format!("block {blk}: face {} is connected twice", FACE_NAMES[f])));
                }
            }
            if c.a == c.b {
                return Err(bad("a block cannot connect to itself".into()));
            }
            let (ba, bb) = (&self.blocks[c.a], &self.blocks[c.b]);
            let na = ba.normal(c.fa);
            let nb = bb.normal(c.fb);
            let opposite = (0..3).all(|k| (na[k] + nb[k]).abs() < 1e-9);
            let corners = |b: &Block, f: usize| -> Vec<[f64; 3]> {
                [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                    .iter()
                    .map(|&(u, v)| b.to_world(face_point(f, u, v)))
                    .collect()
            };
            let (pa, pb) = (corners(ba, c.fa), corners(bb, c.fb));
            let size = ba.scale.iter().chain(&bb.scale).fold(1.0f64, |m, x| m.max(*x));
            let tol = 1e-6 * size;
            let coincide = pa.iter().all(|p| pb.iter().any(|q| (0..3).all(|k| (p[k] - q[k]).abs() <= tol)));
            if !opposite || !coincide {
                return Err(bad(format!(
                    "face {} of block {} and face {} of block {} do not coincide in the world \
                     (corners {:?} vs {:?}); connected faces must be the same rectangle, facing each other",
                    FACE_NAMES[c.fa],
                    c.a,
                    FACE_NAMES[c.fb],
                    c.b,
                    round3(&pa),
                    round3(&pb)
                )));
            }
            links[c.a][c.fa] = Some((c.b, c.fb));
            links[c.b][c.fb] = Some((c.a, c.fa));
        }
        Ok(links)
    }
}

fn round3(v: &[[f64; 3]]) -> Vec<[f64; 3]> {
    v.iter().map(|p| p.map(|x| (x * 1000.0).round() / 1000.0)).collect()
}

/// Hash stage of the maze generator.
const MAZE_STAGE: u64 = 0x4d41_5a45;

/// World side faces in the maze's fixed direction order: +x, −x, +z, −z as grid steps.
const STEPS: [(i64, i64, usize); 4] = [(1, 0, 1), (-1, 0, 0), (0, 1, 5), (0, -1, 4)];

/// Finds `(shape, rotation)` whose rotated openings are exactly the world side faces in
/// `open` (bit mask over world faces); floor and ceiling must be present.
pub fn fit_shape(missing: &[u8], open: u8) -> Option<(usize, u32)> {
    for (s, &m) in missing.iter().enumerate() {
        if m & 0b1100 != 0 {
            continue;
        }
        for q in 0..4 {
            let mut w = 0u8;
            for f in 0..FACE_COUNT {
                if m & (1 << f) != 0 {
                    w |= 1 << world_face(f, q);
                }
            }
            if w == open {
                return Some((s, q));
            }
        }
    }
    None
}

/// A random connected 2D maze of `n` unit blocks on a grid (a random spanning tree grown
/// from one cell: each new block is attached to a random free side of a random existing
/// block, draws hashed from `(seed, block)`). Cell `(i, k)` is centred at
/// `(i + ½, ½, k + ½)`. Each block gets the dictionary shape and rotation whose openings are
/// exactly its connections. Errors when the dictionary lacks a needed shape.
pub fn maze(n: usize, seed: u64, missing: &[u8]) -> Result<Level, LevelError> {
    if n == 0 {
        return Err(LevelError::Empty);
    }
    let mut cells: Vec<(i64, i64)> = vec![(0, 0)];
    let mut edges: Vec<(usize, usize, usize)> = Vec::new(); // (block, world face, new block)
    let find = |cells: &[(i64, i64)], c: (i64, i64)| cells.iter().position(|&x| x == c);
    for i in 1..n {
        let mut cand: Vec<(usize, usize, (i64, i64))> = Vec::new();
        for (b, &(x, z)) in cells.iter().enumerate() {
            for &(dx, dz, f) in &STEPS {
                let c = (x + dx, z + dz);
                if find(&cells, c).is_none() {
                    cand.push((b, f, c));
                }
            }
        }
        let pick = (unit_f64(hash4(seed, MAZE_STAGE, i as u64, 0)) * cand.len() as f64) as usize;
        let (b, f, c) = cand[pick.min(cand.len() - 1)];
        cells.push(c);
        edges.push((b, f, i));
    }
    grid_level(&cells, &edges, missing)
}

/// A straight corridor of `n ≥ 2` blocks along +Z: dead end, `n − 2` straights, dead end.
pub fn corridor(n: usize, missing: &[u8]) -> Result<Level, LevelError> {
    line(&vec![(0i64, 1i64); n.max(2) - 1], missing)
}

/// An L-turn: `a` blocks along +Z, then `b` blocks along +X (a corner where they meet).
pub fn l_turn(a: usize, b: usize, missing: &[u8]) -> Result<Level, LevelError> {
    let mut steps = vec![(0i64, 1i64); a.max(1)];
    steps.extend(vec![(1i64, 0i64); b.max(1)]);
    line(&steps, missing)
}

/// Blocks along a path of unit grid steps from cell (0, 0).
fn line(steps: &[(i64, i64)], missing: &[u8]) -> Result<Level, LevelError> {
    let mut cells = vec![(0i64, 0i64)];
    for &(dx, dz) in steps {
        let &(x, z) = cells.last().unwrap_or(&(0, 0));
        cells.push((x + dx, z + dz));
    }
    let face_of = |dx: i64, dz: i64| STEPS.iter().find(|s| s.0 == dx && s.1 == dz).map_or(5, |s| s.2);
    let edges: Vec<(usize, usize, usize)> =
        steps.iter().enumerate().map(|(i, &(dx, dz))| (i, face_of(dx, dz), i + 1)).collect();
    grid_level(&cells, &edges, missing)
}

/// The level of unit blocks at grid `cells` (cell `(i, k)` centred at `(i + ½, ½, k + ½)`)
/// joined by `edges` `(block, world face, other block)`: each block gets the dictionary shape
/// and rotation whose openings are exactly its edges.
fn grid_level(cells: &[(i64, i64)], edges: &[(usize, usize, usize)], missing: &[u8]) -> Result<Level, LevelError> {
    let mut open = vec![0u8; cells.len()];
    for &(b, f, c) in edges {
        open[b] |= 1 << f;
        open[c] |= 1 << (f ^ 1);
    }
    let mut blocks = Vec::with_capacity(cells.len());
    for (i, &(x, z)) in cells.iter().enumerate() {
        let (shape, rotation) = fit_shape(missing, open[i]).ok_or_else(|| LevelError::Block {
            index: i,
            message: format!("the dictionary has no shape with openings {:06b} (world faces)", open[i]),
        })?;
        blocks.push(Block { shape, rotation, translation: [x as f64 + 0.5, 0.5, z as f64 + 0.5], scale: [1.0; 3] });
    }
    let connections = edges
        .iter()
        .map(|&(a, f, b)| Connection { a, fa: blocks[a].local_face(f), b, fb: blocks[b].local_face(f ^ 1) })
        .collect();
    Ok(Level { blocks, connections })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::CUBE2D;

    fn dict() -> (Vec<String>, Vec<u8>) {
        (CUBE2D.iter().map(|s| s.name.to_string()).collect(), CUBE2D.iter().map(|s| s.missing).collect())
    }

    #[test]
    fn transforms_invert_and_faces_rotate_with_normals() {
        let b = Block { shape: 0, rotation: 3, translation: [2.0, 0.5, -1.0], scale: [1.0, 2.0, 0.5] };
        let p = [0.2, 0.9, 0.4];
        let q = b.to_local(b.to_world(p));
        assert!((0..3).all(|k| (p[k] - q[k]).abs() < 1e-14));
        for q in 0..4 {
            for f in 0..FACE_COUNT {
                let w = world_face(f, q);
                assert_eq!(rotate_y(FACE_FRAMES[f].n, q), FACE_FRAMES[w].n);
            }
        }
        // one turn takes local +z (face 5) to world +x (face 1)
        assert_eq!(world_face(5, 1), 1);
    }

    #[test]
    fn mazes_are_connected_trees_that_validate() {
        let (names, missing) = dict();
        for (n, seed) in [(1, 0), (5, 1), (41, 7), (41, 8)] {
            let l = maze(n, seed, &missing).unwrap();
            assert_eq!(l.blocks.len(), n);
            assert_eq!(l.connections.len(), n - 1);
            let links = l.validate(&names, &missing).unwrap();
            // every opening of every block is connected (a closed maze)
            for (b, blk) in l.blocks.iter().enumerate() {
                for f in 0..FACE_COUNT {
                    assert_eq!(missing[blk.shape] & (1 << f) != 0, links[b][f].is_some(), "block {b} face {f}");
                }
            }
            // connected: a walk from block 0 reaches all
            let mut seen = vec![false; n];
            let mut stack = vec![0];
            while let Some(b) = stack.pop() {
                if std::mem::replace(&mut seen[b], true) {
                    continue;
                }
                stack.extend(links[b].iter().flatten().map(|x| x.0));
            }
            assert!(seen.iter().all(|&s| s));
        }
        assert_ne!(maze(41, 7, &missing).unwrap(), maze(41, 8, &missing).unwrap());
    }

    #[test]
    fn corridor_and_l_turn_use_the_expected_shapes() {
        let (names, missing) = dict();
        let c = corridor(5, &missing).unwrap();
        let shapes: Vec<&str> = c.blocks.iter().map(|b| names[b.shape].as_str()).collect();
        assert_eq!(shapes, ["dead_end", "straight", "straight", "straight", "dead_end"]);
        c.validate(&names, &missing).unwrap();
        let l = l_turn(2, 2, &missing).unwrap();
        let shapes: Vec<&str> = l.blocks.iter().map(|b| names[b.shape].as_str()).collect();
        assert_eq!(shapes, ["dead_end", "straight", "corner", "straight", "dead_end"]);
        l.validate(&names, &missing).unwrap();
    }

    #[test]
    fn bad_levels_name_the_block_or_connection() {
        let (names, missing) = dict();
        let mut c = corridor(3, &missing).unwrap();
        c.blocks[2].translation[0] += 0.5;
        let e = c.validate(&names, &missing).unwrap_err().to_string();
        assert!(e.contains("connection 1") && e.contains("do not coincide"), "{e}");
        let mut c = corridor(3, &missing).unwrap();
        c.connections[0].fa = 0;
        let e = c.validate(&names, &missing).unwrap_err().to_string();
        assert!(e.contains("is a wall of shape \"dead_end\""), "{e}");
        let mut c = corridor(3, &missing).unwrap();
        c.blocks[1].scale[1] = 0.0;
        assert!(c.validate(&names, &missing).unwrap_err().to_string().starts_with("block 1:"));
        let mut c = corridor(3, &missing).unwrap();
        c.blocks[0].rotation = 4;
        assert!(c.validate(&names, &missing).unwrap_err().to_string().contains("0..=3"));
        let mut c = corridor(3, &missing).unwrap();
        c.connections.push(c.connections[0]);
        assert!(c.validate(&names, &missing).unwrap_err().to_string().contains("connected twice"));
        // a block that shares volume with another (here a fourth, unconnected, half inside
        // block 1) is refused; touching at a face (every corridor) is fine
        let mut c = corridor(3, &missing).unwrap();
        let mut extra = c.blocks[1].clone();
        extra.translation[2] += 0.5;
        c.blocks.push(extra);
        let e = c.validate(&names, &missing).unwrap_err().to_string();
        assert!(e.starts_with("block 1:") && e.contains("overlaps block 3"), "{e}");
        let mut c = corridor(3, &missing).unwrap();
        let mut extra = c.blocks[1].clone();
        extra.translation[0] += 1.0;
        c.blocks.push(extra);
        c.validate(&names, &missing).unwrap();
    }
}
