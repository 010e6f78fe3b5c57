//! The discretisation of the solid T that the fit clusters (SHEXP §6.2: "points on the surface
//! (triangle midpoints) and points in the interior (grid corners from a mesh voxelization)").
//!
//! Our surface elements are whole (sub-)triangles rather than their midpoints: an element is
//! bounded when its three corners are, and a ball containing the corners contains the whole
//! triangle, so the fitted spheres cover the continuous surface, not only sample points.
//! Triangles longer than the surface spacing are split by longest-edge bisection first, so
//! a coarse mesh (a 12-triangle box) is still sampled finely. Interior elements are the grid
//! nodes inside the mesh (`w ≥ ½`), from the signed-distance grid.

use std::collections::HashMap;

use penumbra_geometry::{SignedDistanceGrid, TriMesh};

use crate::frame::Frame;

/// Upper bound on the number of surface elements: beyond it the surface spacing grows.
pub const MAX_SURFACE_ELEMENTS: usize = 400_000;

/// Flood-fill cells are this many grid cells across.
const FLOOD_CELL: f64 = 2.0;

/// One clustering element: a triangle (three points) or an interior point (one point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Element {
    /// Point indices (`count` of them are used).
    pub points: [u32; 3],
    /// 3 for a surface triangle, 1 for an interior point.
    pub count: u8,
    /// Representative position (centroid / node), canonical frame.
    pub rep: [f64; 3],
}

impl Element {
    /// The used point indices.
    #[inline]
    pub fn point_ids(&self) -> &[u32] {
        &self.points[..self.count as usize]
    }
}

/// The sample points and elements of a mesh, with a cell index for flood fills.
#[derive(Debug, Clone)]
pub struct Samples {
    /// Points in the canonical frame.
    pub points: Vec<[f64; 3]>,
    /// The same points in input coordinates (surface points from the input triangles exactly).
    pub input_points: Vec<[f64; 3]>,
    /// Elements: surface triangles first, then interior points.
    pub elements: Vec<Element>,
    /// Number of surface elements (the first ones).
    pub surface_elements: usize,
    /// Number of points that lie on the surface (vertices and subdivision points; the rest
    /// are interior nodes).
    pub surface_points: usize,
    /// Surface spacing used for subdivision (canonical units).
    pub surface_spacing: f64,
    /// Grid node of every interior element (in element order after the surface elements).
    pub interior_nodes: Vec<u32>,
    /// Distance of every interior element to the surface (canonical units; empty until
    /// [`Samples::set_depths`]).
    pub interior_depth: Vec<f64>,
    /// Grid nodes along x, y, z (for neighbourhoods of interior nodes).
    pub grid_nodes: [usize; 3],
    /// Grid spacing (canonical units).
    pub grid_spacing: f64,
    /// For a finer set ([`Samples::build_finer`]): the element of [`Samples::build`]'s set
    /// that each surface element lies in (empty for `build`'s own set).
    pub coarse_parent: Vec<u32>,
    /// Flood-fill index: elements sorted by cell (`cell_elements[cell_start[c]..cell_start[c+1]]`).
    cell_start: Vec<u32>,
    cell_elements: Vec<u32>,
    elem_cell: Vec<u32>,
    cells: [usize; 3],
    /// Per flood-fill cell: the box `[lo, hi]` of its elements' points (fixed for the set, so
    /// computed once here instead of in every clustering pass).
    cell_boxes: Vec<[[f64; 3]; 2]>,
    /// Element representatives, contiguous (the clustering's nearest-element scans).
    reps: Vec<[f64; 3]>,
    /// The points of every element in `cell_elements` order (an interior element's one point
    /// three times): the clustering visits elements cell by cell, and loading them from here
    /// is sequential in memory instead of a jump into `elements` and `points` per element.
    cell_points: Vec<[[f64; 3]; 3]>,
}

impl Samples {
    /// Builds the elements of `canonical` (the mesh in the canonical frame; `input` is the same
    /// mesh in input coordinates) and of the grid's interior nodes.
    pub fn build(canonical: &TriMesh, input: &TriMesh, frame: &Frame, grid: &SignedDistanceGrid) -> Self {
        Self::build_finer(canonical, input, frame, grid, 1)
    }

    /// [`Samples::build`] with surface elements `divisor` times finer (at most the same cap on
    /// their number). The bisection is the same longest-edge bisection continued further, so
    /// every element of the finer set lies inside one element of the coarser one; the interior
    /// elements are the same, in the same order, after the surface ones.
    pub fn build_finer(
        canonical: &TriMesh,
        input: &TriMesh,
        frame: &Frame,
        grid: &SignedDistanceGrid,
        divisor: usize,
    ) -> Self {
        let spec = *grid.spec();
        let area = canonical.area();
        let cap = (area / MAX_SURFACE_ELEMENTS as f64 * 2.0).sqrt();
        let spacing = (spec.h / divisor.max(1) as f64).max(cap);
        // the spacing of `build`, to name the coarse element every finer one lies in
        let coarse2 = spec.h.max(cap).powi(2);
        let mut coarse_parent: Vec<u32> = Vec::new();
        let mut coarse_count = 0u32;
        let nv = canonical.positions.len();
        // only vertices that some triangle uses
        let mut used = vec![false; nv];
        for t in &canonical.indices {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let mut points: Vec<[f64; 3]> = Vec::with_capacity(nv);
        let mut input_points: Vec<[f64; 3]> = Vec::with_capacity(nv);
        let mut remap = vec![u32::MAX; nv];
        for v in 0..nv {
            if used[v] {
                remap[v] = points.len() as u32;
                points.push(canonical.positions[v]);
                input_points.push(input.positions[v]);
            }
        }
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut elements = Vec::with_capacity(canonical.indices.len());
        // (triangle, the coarse element it lies in once known)
        let mut stack: Vec<([u32; 3], u32)> = Vec::new();
        let s2 = spacing * spacing;
        for t in &canonical.indices {
            stack.push((t.map(|v| remap[v as usize]), u32::MAX));
            while let Some((tri, mut parent)) = stack.pop() {
                let p = tri.map(|i| points[i as usize]);
                let e2 = [
                    crate::sphere::dist2(p[0], p[1]),
                    crate::sphere::dist2(p[1], p[2]),
                    crate::sphere::dist2(p[2], p[0]),
                ];
                let k = if e2[0] >= e2[1] && e2[0] >= e2[2] {
                    0
                } else if e2[1] >= e2[2] {
                    1
                } else {
                    2
                };
                // depth-first, so coarse elements are met in the order `build` emits them
                if parent == u32::MAX && e2[k] <= coarse2 {
                    parent = coarse_count;
                    coarse_count += 1;
                }
                if e2[k] <= s2 {
                    let rep = std::array::from_fn(|d| (p[0][d] + p[1][d] + p[2][d]) / 3.0);
                    elements.push(Element { points: tri, count: 3, rep });
                    coarse_parent.push(parent);
                    continue;
                }
                // bisect edge (tri[k], tri[k+1]); children keep the orientation
                let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
                let key = (a.min(b), a.max(b));
                let m = *midpoints.entry(key).or_insert_with(|| {
                    let (pa, pb) = (points[a as usize], points[b as usize]);
                    let (qa, qb) = (input_points[a as usize], input_points[b as usize]);
                    points.push(std::array::from_fn(|d| 0.5 * (pa[d] + pb[d])));
                    input_points.push(std::array::from_fn(|d| 0.5 * (qa[d] + qb[d])));
                    (points.len() - 1) as u32
                });
                stack.push(([a, m, c], parent));
                stack.push(([m, b, c], parent));
            }
        }
        let surface_elements = elements.len();
        let surface_points = points.len();
        let mut interior_nodes = Vec::new();
        for n in 0..spec.node_count() {
            if grid.node_inside(n) {
                interior_nodes.push(n as u32);
                let [i, j, k] = spec.node_coords(n);
                let q = spec.node_position(i, j, k);
                let id = points.len() as u32;
                points.push(q);
                input_points.push(frame.to_input(q));
                elements.push(Element { points: [id, id, id], count: 1, rep: q });
            }
        }
        // cell index (counting sort; elements outside the grid go to the nearest cell). Its
        // cells are 2×2×2 grid cells: the clustering's per-cell work (bounds for every
        // cluster) is then shared by ~20 elements instead of ~2.
        let size = FLOOD_CELL * spec.h;
        let cells = spec.cells().map(|c| c.div_ceil(FLOOD_CELL as usize));
        let ncell = cells[0] * cells[1] * cells[2];
        let cell_of = |p: [f64; 3]| -> usize {
            let c: [usize; 3] = std::array::from_fn(|d| {
                let u = ((p[d] - spec.origin[d]) / size).floor();
                (u.max(0.0) as usize).min(cells[d] - 1)
            });
            c[0] + cells[0] * (c[1] + cells[1] * c[2])
        };
        let elem_cell: Vec<u32> = elements.iter().map(|e| cell_of(e.rep) as u32).collect();
        let mut cell_start = vec![0u32; ncell + 1];
        for &c in &elem_cell {
            cell_start[c as usize + 1] += 1;
        }
        for c in 0..ncell {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start.clone();
        let mut cell_elements = vec![0u32; elements.len()];
        for (e, &c) in elem_cell.iter().enumerate() {
            cell_elements[fill[c as usize] as usize] = e as u32;
            fill[c as usize] += 1;
        }
        let cell_boxes = (0..ncell)
            .map(|c| {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for &e in &cell_elements[cell_start[c] as usize..cell_start[c + 1] as usize] {
                    for &p in elements[e as usize].point_ids() {
                        let q = points[p as usize];
                        for d in 0..3 {
                            lo[d] = lo[d].min(q[d]);
                            hi[d] = hi[d].max(q[d]);
                        }
                    }
                }
                [lo, hi]
            })
            .collect();
        let reps = elements.iter().map(|e| e.rep).collect();
        let cell_points = cell_elements
            .iter()
            .map(|&e| {
                let el = &elements[e as usize];
                let ids = el.point_ids();
                std::array::from_fn(|k| points[ids[k.min(ids.len() - 1)] as usize])
            })
            .collect();
        Self {
            points,
            input_points,
            elements,
            surface_elements,
            surface_points,
            surface_spacing: spacing,
            coarse_parent: if divisor > 1 { coarse_parent } else { Vec::new() },
            interior_nodes,
            interior_depth: Vec::new(),
            grid_nodes: spec.nodes,
            grid_spacing: spec.h,
            cell_start,
            cell_elements,
            elem_cell,
            cells,
            cell_boxes,
            reps,
            cell_points,
        }
    }

    /// Sets the distance of every interior element to the surface (`bvh` of the canonical mesh).
    pub fn set_depths(&mut self, bvh: &penumbra_geometry::MeshBvh) {
        use rayon::prelude::*;
        let first = self.surface_elements;
        self.interior_depth =
            self.elements[first..].par_iter().map(|e| bvh.closest_point(e.rep).map_or(0.0, |c| c.distance)).collect();
    }

    /// Number of cells of the flood-fill index.
    pub fn cell_count(&self) -> usize {
        self.cells[0] * self.cells[1] * self.cells[2]
    }

    /// Elements in cell `c`.
    #[inline]
    pub fn cell(&self, c: usize) -> &[u32] {
        &self.cell_elements[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// The box `[lo, hi]` of the points of the elements in cell `c` (empty cell: `lo` = +∞,
    /// `hi` = −∞).
    #[inline]
    pub fn cell_box(&self, c: usize) -> [[f64; 3]; 2] {
        self.cell_boxes[c]
    }

    /// The points of the elements in cell `c`, in the order of [`Samples::cell`]; each
    /// element's points padded to three by repeating its last (so a maximum over the three
    /// equals the maximum over the element's own points).
    #[inline]
    pub fn cell_points(&self, c: usize) -> &[[[f64; 3]; 3]] {
        &self.cell_points[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// The representative point of every element, in element order.
    #[inline]
    pub fn reps(&self) -> &[[f64; 3]] {
        &self.reps
    }

    /// The cell holding element `e`.
    #[inline]
    pub fn element_cell(&self, e: usize) -> usize {
        self.elem_cell[e] as usize
    }

    /// Calls `f` on every cell sharing a face, edge or corner with cell `c`.
    #[inline]
    pub fn for_neighbors(&self, c: usize, mut f: impl FnMut(usize)) {
        let [nx, ny, nz] = self.cells;
        let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
        for dk in -1i64..=1 {
            let kk = k as i64 + dk;
            if kk < 0 || kk >= nz as i64 {
                continue;
            }
            for dj in -1i64..=1 {
                let jj = j as i64 + dj;
                if jj < 0 || jj >= ny as i64 {
                    continue;
                }
                for di in -1i64..=1 {
                    let ii = i as i64 + di;
                    if ii < 0 || ii >= nx as i64 || (di == 0 && dj == 0 && dk == 0) {
                        continue;
                    }
                    f(ii as usize + nx * (jj as usize + ny * kk as usize));
                }
            }
        }
    }
}
