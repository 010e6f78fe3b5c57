//! Voxelisation: a signed-distance grid over a triangle mesh, the exact inside oracle built
//! on it, and the conservative triangle/box overlap test both use.
//!
//! # The grid
//! Nodes sit at `origin + h·(i, j, k)`; cell `(i, j, k)` spans nodes `(i..=i+1, j..=j+1,
//! k..=k+1)`. [`GridSpec::fit`] chooses `h` so that the mesh's bounding box holds about
//! `resolution³` cells whatever its aspect ratio (a 100:1:1 needle gets as many cells as a
//! cube, not 64 × 1 × 1), and pads the box by whole cells so that every cell touching the
//! mesh has outside neighbours.
//!
//! # Signed distance
//! A *surface cell* is a cell that a triangle overlaps ([`triangle_box_overlap`], made
//! conservative by a relative margin). Nodes of surface cells carry the exact distance to the
//! nearest triangle, signed by the generalized winding number (negative inside, `w ≥ ½`).
//! Every other node is at least `h` from the surface (its eight cells are triangle-free), so
//! it stores `±h` — a lower bound, which is all that [`SignedDistanceGrid::soft_inside`] needs.
//! For a watertight mesh the sign of non-surface nodes is constant on each connected component
//! of such nodes (no edge between two of them crosses a triangle), so one winding number per
//! component suffices; open meshes evaluate it at every node, because the ½ level set of the
//! winding number spans holes without any triangle there.
//!
//! # Two inside tests
//! - [`SignedDistanceGrid::soft_inside`]: `clamp(½ − d̃/h, 0, 1)` with `d̃` the trilinear
//!   interpolation of the node values. A continuous ramp one cell wide centred on the surface;
//!   its integral over a region approximates the region's volume inside the mesh with an
//!   error of order `h²·curvature·area` (second-order accurate signed distance), so volume
//!   integrals against it are smooth in the region's parameters (what an optimiser needs).
//! - [`InsideOracle::is_inside`]: exact — the winding-number classification `w(q) ≥ ½` — but
//!   fast: a cell that is not a surface cell and whose eight nodes agree has a constant answer;
//!   only points in the remaining cells evaluate the winding number.

use glam::DVec3;
use rayon::prelude::*;

use crate::bvh::MeshBvh;
use crate::inside::WindingNumber;
use crate::mesh::{Aabb, TriMesh};

/// Grid geometry: origin, spacing and node counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// Position of node `(0, 0, 0)`.
    pub origin: [f64; 3],
    /// Node spacing (cell edge length).
    pub h: f64,
    /// Number of nodes along x, y, z (cells are one fewer).
    pub nodes: [usize; 3],
}

impl GridSpec {
    /// A grid over `bounds` with about `resolution³` cells inside the box, padded by `pad`
    /// cells on every side. `resolution ≥ 1`. Each extent is floored at
    /// `max extent / (2·resolution)` in the cell-count computation, so a flat box (even one of
    /// zero thickness) does not get a spacing so fine that the grid explodes, while a needle
    /// still gets several cells across.
    pub fn fit(bounds: &Aabb, resolution: usize, pad: usize) -> Self {
        let r = resolution.max(1) as f64;
        let e = bounds.extent();
        let emax = e[0].max(e[1]).max(e[2]);
        let emax = if emax > 0.0 && emax.is_finite() { emax } else { 1.0 };
        let floor = emax / (2.0 * r);
        let vol: f64 = e.iter().map(|&x| x.max(floor)).product();
        let h = vol.cbrt() / r;
        let c = bounds.center();
        let mut origin = [0.0; 3];
        let mut nodes = [0usize; 3];
        for k in 0..3 {
            let cells = ((e[k] / h).ceil() as usize).max(1) + 2 * pad;
            nodes[k] = cells + 1;
            origin[k] = c[k] - 0.5 * cells as f64 * h;
        }
        Self { origin, h, nodes }
    }

    /// Cells along x, y, z.
    pub fn cells(&self) -> [usize; 3] {
        self.nodes.map(|n| n - 1)
    }

    /// Total number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes[0] * self.nodes[1] * self.nodes[2]
    }

    /// Total number of cells.
    pub fn cell_count(&self) -> usize {
        let c = self.cells();
        c[0] * c[1] * c[2]
    }

    /// Linear index of node `(i, j, k)` (x fastest).
    #[inline]
    pub fn node_index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.nodes[0] * (j + self.nodes[1] * k)
    }

    /// Linear index of cell `(i, j, k)` (x fastest).
    #[inline]
    pub fn cell_index(&self, i: usize, j: usize, k: usize) -> usize {
        let c = self.cells();
        i + c[0] * (j + c[1] * k)
    }

    /// Position of node `(i, j, k)`.
    #[inline]
    pub fn node_position(&self, i: usize, j: usize, k: usize) -> [f64; 3] {
        [self.origin[0] + self.h * i as f64, self.origin[1] + self.h * j as f64, self.origin[2] + self.h * k as f64]
    }

    /// `(i, j, k)` of a linear node index.
    #[inline]
    pub fn node_coords(&self, n: usize) -> [usize; 3] {
        let (nx, ny) = (self.nodes[0], self.nodes[1]);
        [n % nx, (n / nx) % ny, n / (nx * ny)]
    }

    /// The cell containing `p`, or `None` outside the grid (or for non-finite `p`).
    #[inline]
    pub fn cell_of(&self, p: [f64; 3]) -> Option<[usize; 3]> {
        let c = self.cells();
        let mut out = [0usize; 3];
        for k in 0..3 {
            let u = (p[k] - self.origin[k]) / self.h;
            if !(u >= 0.0 && u <= c[k] as f64) {
                return None;
            }
            out[k] = (u as usize).min(c[k] - 1);
        }
        Some(out)
    }

    /// Cell range `[lo, hi]` (inclusive) overlapping the box `[min, max]`, clamped to the grid.
    pub fn cell_range(&self, min: [f64; 3], max: [f64; 3]) -> Option<([usize; 3], [usize; 3])> {
        let c = self.cells();
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for k in 0..3 {
            let a = ((min[k] - self.origin[k]) / self.h).floor();
            let b = ((max[k] - self.origin[k]) / self.h).floor();
            if !(a.is_finite() && b.is_finite()) || b < 0.0 || a > (c[k] - 1) as f64 {
                return None;
            }
            lo[k] = a.max(0.0) as usize;
            hi[k] = (b.max(0.0) as usize).min(c[k] - 1);
        }
        Some((lo, hi))
    }
}

/// Whether triangle `t` overlaps the axis-aligned box `center ± half` (separating-axis test of
/// Akenine-Möller 2001: the three box axes, the triangle normal and the nine edge cross
/// products). Touching counts as overlapping.
pub fn triangle_box_overlap(center: [f64; 3], half: [f64; 3], t: &[[f64; 3]; 3]) -> bool {
    let c = DVec3::from(center);
    let h = DVec3::from(half);
    let v = [DVec3::from(t[0]) - c, DVec3::from(t[1]) - c, DVec3::from(t[2]) - c];
    // box axes
    for k in 0..3 {
        let lo = v[0][k].min(v[1][k]).min(v[2][k]);
        let hi = v[0][k].max(v[1][k]).max(v[2][k]);
        if lo > h[k] || hi < -h[k] {
            return false;
        }
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // triangle normal
    let n = e[0].cross(e[1]);
    let r = h.x * n.x.abs() + h.y * n.y.abs() + h.z * n.z.abs();
    if n.dot(v[0]).abs() > r {
        return false;
    }
    // edge × box axis
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    for ed in &e {
        for ax in &axes {
            let a = ed.cross(*ax);
            if a == DVec3::ZERO {
                continue;
            }
            let p = [a.dot(v[0]), a.dot(v[1]), a.dot(v[2])];
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            let r = h.x * a.x.abs() + h.y * a.y.abs() + h.z * a.z.abs();
            if lo > r || hi < -r {
                return false;
            }
        }
    }
    true
}

/// Relative enlargement of cells in the surface-cell test, so that rounding never misses a
/// triangle lying exactly on a cell face.
const CELL_MARGIN: f64 = 1e-9;

/// Per-cell classification used by the oracle.
const CELL_OUTSIDE: u8 = 0;
const CELL_INSIDE: u8 = 1;
const CELL_EXACT: u8 = 2;

/// Signed distances on a grid over a mesh; see the module docs.
#[derive(Debug, Clone)]
pub struct SignedDistanceGrid {
    spec: GridSpec,
    /// Signed distance per node (negative inside).
    values: Vec<f64>,
    /// Per cell: `CELL_OUTSIDE`, `CELL_INSIDE` (constant answer) or `CELL_EXACT`.
    cell_state: Vec<u8>,
    /// Per node: `½ − value/h`, the unclamped soft indicator (f32: it is a ramp parameter).
    ramp: Vec<f32>,
    /// Per cell: 0 when the ramp is ≤ 0 at all corners (soft indicator 0 in the whole cell),
    /// 1 when it is ≥ 1 at all corners, 2 otherwise.
    ramp_kind: Vec<u8>,
    inv_h: f64,
    surface_cells: usize,
    winding_evaluations: usize,
}

impl SignedDistanceGrid {
    /// Builds the grid. `bvh` and `winding` must belong to `mesh`; `watertight` selects the
    /// component fill for the signs of non-surface nodes (see the module docs). Parallel over
    /// nodes; the result does not depend on the thread count.
    pub fn build(mesh: &TriMesh, bvh: &MeshBvh, winding: &WindingNumber, spec: GridSpec, watertight: bool) -> Self {
        let cells = spec.cells();
        let h = spec.h;
        // 1. surface cells
        let mut surface = vec![false; spec.cell_count()];
        let half = [0.5 * h * (1.0 + CELL_MARGIN); 3];
        for t in 0..mesh.triangle_count() {
            let tri = mesh.triangle(t);
            let mut lo = tri[0];
            let mut hi = tri[0];
            for p in &tri[1..] {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            let m = h * CELL_MARGIN;
            let Some((a, b)) = spec.cell_range(lo.map(|x| x - m), hi.map(|x| x + m)) else { continue };
            for k in a[2]..=b[2] {
                for j in a[1]..=b[1] {
                    for i in a[0]..=b[0] {
                        let ci = spec.cell_index(i, j, k);
                        if surface[ci] {
                            continue;
                        }
                        let p = spec.node_position(i, j, k);
                        let center = [p[0] + 0.5 * h, p[1] + 0.5 * h, p[2] + 0.5 * h];
                        if triangle_box_overlap(center, half, &tri) {
                            surface[ci] = true;
                        }
                    }
                }
            }
        }
        // 2. band nodes: corners of surface cells
        let mut band = vec![false; spec.node_count()];
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    if surface[spec.cell_index(i, j, k)] {
                        for dk in 0..2 {
                            for dj in 0..2 {
                                for di in 0..2 {
                                    band[spec.node_index(i + di, j + dj, k + dk)] = true;
                                }
                            }
                        }
                    }
                }
            }
        }
        let band_nodes: Vec<usize> = (0..band.len()).filter(|&n| band[n]).collect();
        let band_values: Vec<f64> = band_nodes
            .par_iter()
            .map(|&n| {
                let [i, j, k] = spec.node_coords(n);
                let p = spec.node_position(i, j, k);
                let d = bvh.closest_point(p).map_or(f64::INFINITY, |c| c.distance);
                if winding.is_inside(p) { -d } else { d }
            })
            .collect();
        let mut values = vec![f64::NAN; spec.node_count()];
        for (&n, &v) in band_nodes.iter().zip(&band_values) {
            values[n] = v;
        }
        let mut winding_evaluations = band_nodes.len();
        // 3. the other nodes: ±h
        if watertight {
            let mut stack = Vec::new();
            for start in 0..values.len() {
                if !values[start].is_nan() {
                    continue;
                }
                let [i, j, k] = spec.node_coords(start);
                let inside = winding.is_inside(spec.node_position(i, j, k));
                winding_evaluations += 1;
                let v = if inside { -h } else { h };
                values[start] = v;
                stack.push(start);
                while let Some(n) = stack.pop() {
                    let [i, j, k] = spec.node_coords(n);
                    let mut visit = |ii: usize, jj: usize, kk: usize| {
                        let m = spec.node_index(ii, jj, kk);
                        if values[m].is_nan() {
                            values[m] = v;
                            stack.push(m);
                        }
                    };
                    if i > 0 {
                        visit(i - 1, j, k);
                    }
                    if i + 1 < spec.nodes[0] {
                        visit(i + 1, j, k);
                    }
                    if j > 0 {
                        visit(i, j - 1, k);
                    }
                    if j + 1 < spec.nodes[1] {
                        visit(i, j + 1, k);
                    }
                    if k > 0 {
                        visit(i, j, k - 1);
                    }
                    if k + 1 < spec.nodes[2] {
                        visit(i, j, k + 1);
                    }
                }
            }
        } else {
            let rest: Vec<usize> = (0..values.len()).filter(|&n| values[n].is_nan()).collect();
            let signs: Vec<f64> = rest
                .par_iter()
                .map(|&n| {
                    let [i, j, k] = spec.node_coords(n);
                    if winding.is_inside(spec.node_position(i, j, k)) { -h } else { h }
                })
                .collect();
            winding_evaluations += rest.len();
            for (&n, &v) in rest.iter().zip(&signs) {
                values[n] = v;
            }
        }
        // 4. cell states
        let mut cell_state = vec![CELL_EXACT; spec.cell_count()];
        let mut surface_cells = 0;
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    let ci = spec.cell_index(i, j, k);
                    if surface[ci] {
                        surface_cells += 1;
                        continue;
                    }
                    let mut neg = 0;
                    for dk in 0..2 {
                        for dj in 0..2 {
                            for di in 0..2 {
                                if values[spec.node_index(i + di, j + dj, k + dk)] < 0.0 {
                                    neg += 1;
                                }
                            }
                        }
                    }
                    cell_state[ci] = match neg {
                        0 => CELL_OUTSIDE,
                        8 => CELL_INSIDE,
                        _ => CELL_EXACT,
                    };
                }
            }
        }
        let ramp: Vec<f32> = values.iter().map(|&v| (0.5 - v / h) as f32).collect();
        let mut ramp_kind = vec![2u8; spec.cell_count()];
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                    for dk in 0..2 {
                        for dj in 0..2 {
                            for di in 0..2 {
                                let u = ramp[spec.node_index(i + di, j + dj, k + dk)];
                                lo = lo.min(u);
                                hi = hi.max(u);
                            }
                        }
                    }
                    ramp_kind[spec.cell_index(i, j, k)] = if hi <= 0.0 {
                        0
                    } else if lo >= 1.0 {
                        1
                    } else {
                        2
                    };
                }
            }
        }
        Self { spec, values, cell_state, ramp, ramp_kind, inv_h: 1.0 / h, surface_cells, winding_evaluations }
    }

    /// The grid geometry.
    pub fn spec(&self) -> &GridSpec {
        &self.spec
    }

    /// Signed distance stored at node `n` (negative inside; `±h` away from the surface).
    pub fn node_value(&self, n: usize) -> f64 {
        self.values[n]
    }

    /// Whether node `n` is inside the mesh (`w ≥ ½`).
    pub fn node_inside(&self, n: usize) -> bool {
        self.values[n] < 0.0
    }

    /// Number of cells a triangle overlaps.
    pub fn surface_cells(&self) -> usize {
        self.surface_cells
    }

    /// Winding-number evaluations spent building the grid.
    pub fn winding_evaluations(&self) -> usize {
        self.winding_evaluations
    }

    /// Trilinearly interpolated signed distance at `p` (`+h` outside the grid).
    #[inline]
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        let s = &self.spec;
        let c = s.cells();
        let mut base = [0usize; 3];
        let mut f = [0.0f64; 3];
        for k in 0..3 {
            let u = (p[k] - s.origin[k]) / s.h;
            if !(u >= 0.0 && u <= c[k] as f64) {
                return s.h;
            }
            let i = (u as usize).min(c[k] - 1);
            base[k] = i;
            f[k] = u - i as f64;
        }
        let n0 = s.node_index(base[0], base[1], base[2]);
        let sx = 1;
        let sy = s.nodes[0];
        let sz = s.nodes[0] * s.nodes[1];
        let v = &self.values;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let x00 = lerp(v[n0], v[n0 + sx], f[0]);
        let x10 = lerp(v[n0 + sy], v[n0 + sy + sx], f[0]);
        let x01 = lerp(v[n0 + sz], v[n0 + sz + sx], f[0]);
        let x11 = lerp(v[n0 + sz + sy], v[n0 + sz + sy + sx], f[0]);
        lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2])
    }

    /// Soft inside indicator `clamp(½ − d̃(p)/h, 0, 1)`; see the module docs. (Interpolates
    /// the per-node ramp `½ − v/h`, which is the same thing because the map is affine; cells
    /// where the ramp is saturated at every corner answer without interpolating.)
    #[inline(always)]
    pub fn soft_inside(&self, p: [f64; 3]) -> f64 {
        let s = &self.spec;
        let c = s.cells();
        let u =
            [(p[0] - s.origin[0]) * self.inv_h, (p[1] - s.origin[1]) * self.inv_h, (p[2] - s.origin[2]) * self.inv_h];
        if !(u[0] >= 0.0
            && u[1] >= 0.0
            && u[2] >= 0.0
            && u[0] < c[0] as f64
            && u[1] < c[1] as f64
            && u[2] < c[2] as f64)
        {
            return 0.0;
        }
        // 0 ≤ u < cells (checked above, and the cell counts fit in u32): truncating through u32
        // is the same index as through usize, with one conversion instruction instead of the
        // sign fix-up a float → usize conversion needs (this is the volume model's inner loop)
        let (i, j, k) = (u[0] as u32 as usize, u[1] as u32 as usize, u[2] as u32 as usize);
        match self.ramp_kind[i + c[0] * (j + c[1] * k)] {
            0 => 0.0,
            1 => 1.0,
            _ => {
                let (fx, fy, fz) = ((u[0] - i as f64) as f32, (u[1] - j as f64) as f32, (u[2] - k as f64) as f32);
                let sy = s.nodes[0];
                let sz = s.nodes[0] * s.nodes[1];
                let n0 = i + sy * (j + s.nodes[1] * k);
                let v = &self.ramp[n0..n0 + sz + sy + 2];
                let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
                let x00 = lerp(v[0], v[1], fx);
                let x10 = lerp(v[sy], v[sy + 1], fx);
                let x01 = lerp(v[sz], v[sz + 1], fx);
                let x11 = lerp(v[sz + sy], v[sz + sy + 1], fx);
                f64::from(lerp(lerp(x00, x10, fy), lerp(x01, x11, fy), fz).clamp(0.0, 1.0))
            }
        }
    }

    /// The constant answer of the cell containing `p`, or `None` when the winding number is
    /// needed (surface cells, cells whose nodes disagree). Outside the grid: `Some(false)`.
    #[inline]
    pub fn cell_answer(&self, p: [f64; 3]) -> Option<bool> {
        match self.spec.cell_of(p) {
            None => Some(false),
            Some([i, j, k]) => match self.cell_state[self.spec.cell_index(i, j, k)] {
                CELL_OUTSIDE => Some(false),
                CELL_INSIDE => Some(true),
                _ => None,
            },
        }
    }

    /// `∫ soft_inside` over the grid by the trapezoidal rule on the nodes: the volume the soft
    /// indicator assigns to the mesh.
    pub fn soft_volume(&self) -> f64 {
        let h = self.spec.h;
        self.values.iter().map(|&d| (0.5 - d / h).clamp(0.0, 1.0)).sum::<f64>() * h * h * h
    }
}

/// Exact inside test (`w ≥ ½`) accelerated by a [`SignedDistanceGrid`]; see the module docs.
#[derive(Debug, Clone, Copy)]
pub struct InsideOracle<'a> {
    /// The grid.
    pub grid: &'a SignedDistanceGrid,
    /// The mesh's winding number.
    pub winding: &'a WindingNumber,
}

impl InsideOracle<'_> {
    /// Whether `p` is inside the mesh by the winding-number definition.
    #[inline]
    pub fn is_inside(&self, p: [f64; 3]) -> bool {
        match self.grid.cell_answer(p) {
            Some(a) => a,
            None => self.winding.is_inside(p),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{aabb_box, grid, icosphere, torus};
    use penumbra_math::rng::{hash4, unit_f64};

    fn uniform(stage: u64, i: u64) -> f64 {
        unit_f64(hash4(7, stage, i, 0))
    }

    fn build(mesh: &TriMesh, res: usize) -> (SignedDistanceGrid, WindingNumber) {
        let bvh = MeshBvh::build(mesh).unwrap();
        let wn = WindingNumber::new(mesh);
        let spec = GridSpec::fit(&mesh.bounds().unwrap(), res, 2);
        let g = SignedDistanceGrid::build(mesh, &bvh, &wn, spec, mesh.is_watertight());
        (g, wn)
    }

    #[test]
    fn fit_handles_flat_and_needle_boxes() {
        let b = Aabb { min: [0.0; 3], max: [100.0, 1.0, 1.0] };
        let s = GridSpec::fit(&b, 32, 1);
        let c = s.cells();
        // a few times 32³ cells at most inside the box, several across the thin sides
        let inner = (c[0] - 2) * (c[1] - 2) * (c[2] - 2);
        assert!(inner as f64 > 0.3 * 32f64.powi(3) && (inner as f64) < 1.3 * 32f64.powi(3), "{c:?} {inner}");
        assert!(c[1] >= 4 + 2, "{c:?}");
        let flat = Aabb { min: [0.0; 3], max: [1.0, 1.0, 0.0] };
        let s = GridSpec::fit(&flat, 32, 1);
        assert!(s.h > 0.0 && s.h.is_finite() && s.cells()[2] >= 3);
        assert!(s.cell_count() < 4 * 32usize.pow(3), "{:?}", s.cells());
    }

    #[test]
    fn triangle_box_overlap_agrees_with_dense_sampling() {
        // If a sampled point of the triangle lies in the box, the test must say "overlap";
        // if the test says "no overlap", no sampled point may lie in the box.
        let mut overlaps = 0;
        for case in 0..400u64 {
            let r = |k: u64| uniform(1, case * 16 + k) * 4.0 - 2.0;
            let t = [[r(0), r(1), r(2)], [r(3), r(4), r(5)], [r(6), r(7), r(8)]];
            let half = [0.3 + uniform(1, case * 16 + 9), 0.2, 0.5];
            let o = triangle_box_overlap([0.0; 3], half, &t);
            overlaps += o as usize;
            let n = 60;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let p: Vec<f64> =
                        (0..3).map(|k| t[0][k] + u * (t[1][k] - t[0][k]) + v * (t[2][k] - t[0][k])).collect();
                    let inside = (0..3).all(|k| p[k].abs() <= half[k]);
                    assert!(!inside || o, "case {case}: sampled point {p:?} in box but no overlap reported");
                }
            }
        }
        assert!(overlaps > 50 && overlaps < 350, "{overlaps}");
        // a triangle far from the box but whose bounding box overlaps it: separated by an edge axis
        let t = [[2.2, -1.0, 0.0], [2.2, 2.2, 0.0], [-1.0, 2.2, 0.0]];
        assert!(!triangle_box_overlap([0.0; 3], [0.5; 3], &t));
    }

    #[test]
    fn soft_volume_and_oracle_on_closed_meshes() {
        for (mesh, exact) in [
            (icosphere(4, 1.0, [0.1, 0.2, 0.3]), None),
            (aabb_box([0.0; 3], [2.0, 1.0, 0.5]), Some(1.0)),
            (torus([0.0; 3], 1.0, 0.3, 64, 32), None),
        ] {
            let exact = exact.unwrap_or_else(|| mesh.signed_volume());
            let (g, wn) = build(&mesh, 48);
            let v = g.soft_volume();
            assert!((v - exact).abs() < 0.01 * exact, "soft volume {v} vs {exact}");
            let oracle = InsideOracle { grid: &g, winding: &wn };
            let b = mesh.bounds().unwrap();
            let mut exact_calls = 0;
            for i in 0..4000u64 {
                let p: [f64; 3] = std::array::from_fn(|k| {
                    b.min[k] - 0.2 + (b.max[k] - b.min[k] + 0.4) * uniform(2, 3 * i + k as u64)
                });
                let truth = wn.exact(p) >= 0.5;
                assert_eq!(oracle.is_inside(p), truth, "{p:?}");
                exact_calls += g.cell_answer(p).is_none() as usize;
            }
            // the grid answers most points itself
            assert!(exact_calls < 1500, "{exact_calls}");
        }
    }

    #[test]
    fn open_mesh_signs_follow_the_winding_number() {
        // a unit cube with its top face removed: the ½ level set closes the hole, so points
        // just below the missing face are inside
        let cube = aabb_box([0.0; 3], [1.0; 3]);
        let open = TriMesh {
            positions: cube.positions.clone(),
            indices: cube.indices.iter().copied().filter(|t| !t.iter().all(|&v| v & 4 != 0)).collect(),
        };
        assert_eq!(open.indices.len(), 10);
        assert!(!open.is_watertight());
        let (g, wn) = build(&open, 24);
        let oracle = InsideOracle { grid: &g, winding: &wn };
        assert!(oracle.is_inside([0.5, 0.5, 0.9]));
        assert!(oracle.is_inside([0.5, 0.5, 0.1]));
        assert!(!oracle.is_inside([0.5, 0.5, 1.2]));
        let v = g.soft_volume();
        assert!((v - 1.0).abs() < 0.05, "{v}");
        // an open flat grid has no inside at all
        let (g, _) = build(&grid(4), 16);
        assert!(g.soft_volume() < 1e-12);
    }

    #[test]
    fn distances_are_exact_near_the_surface() {
        let m = icosphere(5, 1.0, [0.0; 3]);
        let (g, _) = build(&m, 32);
        let s = *g.spec();
        let mut checked = 0;
        for n in 0..s.node_count() {
            let [i, j, k] = s.node_coords(n);
            let p = DVec3::from(s.node_position(i, j, k));
            let d = g.node_value(n);
            if d.abs() < s.h {
                // polygonal sphere: distance to the true sphere within the chord sagitta
                assert!((d - (p.length() - 1.0)).abs() < 2e-3, "{d} at {p}");
                checked += 1;
            }
        }
        assert!(checked > 1000);
    }
}
