//! The octree baseline (Hubbard 1995, as compared in SHEXP Fig. 4): the spheres circumscribing
//! the occupied cells of one octree level — cells a triangle overlaps, and cells wholly inside
//! the solid. The level is the one whose cell count is closest to the requested count (in
//! ratio). Every point of T lies in an occupied cell, so the set is bounding.

use rayon::prelude::*;

use penumbra_geometry::{InsideOracle, TriMesh, triangle_box_overlap};

use crate::sphere::Sphere;

/// Levels are not refined past this many cells or this depth.
const MAX_CELLS: usize = 4_000_000;
const MAX_LEVEL: u32 = 12;

#[derive(Debug, Clone)]
struct Cell {
    center: [f64; 3],
    half: f64,
    /// Overlapping triangles; empty for a cell wholly inside.
    tris: Vec<u32>,
}

/// Result of the octree baseline.
#[derive(Debug, Clone)]
pub struct OctreeOutcome {
    /// One sphere per occupied cell of the chosen level.
    pub spheres: Vec<Sphere>,
    /// The chosen level (0 = the bounding cube).
    pub level: u32,
    /// Occupied cell count of every level built, from level 0.
    pub level_counts: Vec<usize>,
}

/// Builds levels until the count passes `8·target` and picks the closest one.
pub fn fit(mesh: &TriMesh, oracle: &InsideOracle, target: usize) -> OctreeOutcome {
    let target = target.max(1);
    let Some(b) = mesh.bounds() else {
        return OctreeOutcome { spheres: Vec::new(), level: 0, level_counts: Vec::new() };
    };
    let e = b.extent();
    let half = 0.5 * e[0].max(e[1]).max(e[2]) * (1.0 + 1e-9);
    let root = Cell { center: b.center(), half, tris: (0..mesh.triangle_count() as u32).collect() };
    let mut levels: Vec<Vec<Cell>> = vec![vec![root]];
    loop {
        let last = levels.last().map_or(0, |l| l.len());
        if last >= 8 * target || levels.len() as u32 > MAX_LEVEL || last * 8 > MAX_CELLS {
            break;
        }
        let prev = levels.last().cloned().unwrap_or_default();
        let next: Vec<Cell> = prev.par_iter().flat_map_iter(|c| children(mesh, oracle, c)).collect();
        levels.push(next);
    }
    let level_counts: Vec<usize> = levels.iter().map(Vec::len).collect();
    let score = |n: usize| ((n.max(1) as f64) / target as f64).ln().abs();
    let level =
        (0..levels.len()).min_by(|&a, &b| score(level_counts[a]).total_cmp(&score(level_counts[b]))).unwrap_or(0);
    let spheres = levels[level].iter().map(|c| Sphere::new(c.center, c.half * 3f64.sqrt())).collect();
    OctreeOutcome { spheres, level: level as u32, level_counts }
}

fn children(mesh: &TriMesh, oracle: &InsideOracle, c: &Cell) -> Vec<Cell> {
    let h = 0.5 * c.half;
    let mut out = Vec::with_capacity(8);
    for k in 0..8 {
        let center: [f64; 3] = std::array::from_fn(|d| c.center[d] + if k >> d & 1 == 1 { h } else { -h });
        if c.tris.is_empty() {
            out.push(Cell { center, half: h, tris: Vec::new() });
            continue;
        }
        let hh = [h * (1.0 + 1e-9); 3];
        let tris: Vec<u32> =
            c.tris.iter().copied().filter(|&t| triangle_box_overlap(center, hh, &mesh.triangle(t as usize))).collect();
        if !tris.is_empty() || oracle.is_inside(center) {
            out.push(Cell { center, half: h, tris });
        }
    }
    out
}
