//! The triangle-mesh model shared by every bake: f64 positions, `u32` triangle indices,
//! measures (bounds, area, signed volume), topology checks and cleaning.

use glam::DVec3;

use crate::error::MeshValidationError;

/// An axis-aligned box in f64.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f64; 3],
    /// Maximum corner.
    pub max: [f64; 3],
}

impl Aabb {
    /// The box spanned by `points`, or `None` for an empty slice.
    pub fn from_points(points: &[[f64; 3]]) -> Option<Self> {
        let first = points.first()?;
        let mut b = Aabb { min: *first, max: *first };
        for p in &points[1..] {
            b.grow(*p);
        }
        Some(b)
    }

    /// Extends the box to contain `p`.
    pub fn grow(&mut self, p: [f64; 3]) {
        for k in 0..3 {
            self.min[k] = self.min[k].min(p[k]);
            self.max[k] = self.max[k].max(p[k]);
        }
    }

    /// `max - min`.
    pub fn extent(&self) -> [f64; 3] {
        [self.max[0] - self.min[0], self.max[1] - self.min[1], self.max[2] - self.min[2]]
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        DVec3::from(self.extent()).length()
    }

    /// Centre of the box.
    pub fn center(&self) -> [f64; 3] {
        [0.5 * (self.min[0] + self.max[0]), 0.5 * (self.min[1] + self.max[1]), 0.5 * (self.min[2] + self.max[2])]
    }

    /// Whether `p` lies inside or on the boundary.
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|k| p[k] >= self.min[k] && p[k] <= self.max[k])
    }
}

/// A triangle mesh: positions in the input's units and frame, counter-clockwise triangles
/// (glTF and OBJ convention: the outward normal is `(b − a) × (c − a)`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as vertex indices.
    pub indices: Vec<[u32; 3]>,
}

/// What [`TriMesh::clean`] removed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CleanReport {
    /// Triangles with a repeated vertex index (`a == b`, ...).
    pub dropped_repeated_index: usize,
    /// Triangles whose area is zero relative to the mesh scale (see [`ZERO_AREA_REL`]).
    pub dropped_zero_area: usize,
    /// Exact duplicates (same three vertices in the same cyclic order) of an earlier triangle.
    pub dropped_duplicate: usize,
    /// Pairs of triangles with the same vertices in opposite orientation (kept: a two-sided sheet).
    pub opposite_duplicates: usize,
}

impl CleanReport {
    /// Total number of triangles dropped.
    pub fn dropped(&self) -> usize {
        self.dropped_repeated_index + self.dropped_zero_area + self.dropped_duplicate
    }
}

/// A triangle counts as zero-area when `|(b − a) × (c − a)| ≤ ZERO_AREA_REL · d²`, with `d` the
/// diagonal of the mesh's bounding box. `1e-14` is about 50 ulps of the cross product of
/// coordinates of size `d`: collinear vertices land below it, any triangle a bake can resolve
/// lands far above it, and the test is invariant under scaling of the mesh.
pub const ZERO_AREA_REL: f64 = 1e-14;

/// Edge statistics of a mesh, with vertices at bitwise-identical positions treated as one
/// vertex (so UV or normal seams are not holes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EdgeStats {
    /// Distinct undirected edges.
    pub edges: usize,
    /// Edges used by exactly one triangle.
    pub boundary: usize,
    /// Edges used by more than two triangles.
    pub non_manifold: usize,
    /// Edges used by two triangles in the same direction (inconsistent orientation).
    pub inconsistent: usize,
}

impl TriMesh {
    /// Builds a mesh and validates it (see [`TriMesh::validate`]).
    pub fn new(positions: Vec<[f64; 3]>, indices: Vec<[u32; 3]>) -> Result<Self, MeshValidationError> {
        let m = Self { positions, indices };
        m.validate()?;
        Ok(m)
    }

    /// Checks that there is at least one triangle, that every position is finite, and that
    /// every index is in range. Degenerate triangles are allowed (see [`TriMesh::clean`]).
    pub fn validate(&self) -> Result<(), MeshValidationError> {
        if self.positions.len() > u32::MAX as usize {
            return Err(MeshValidationError::TooManyVertices(self.positions.len()));
        }
        if self.indices.is_empty() {
            return Err(MeshValidationError::NoTriangles);
        }
        if let Some((vertex, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())) {
            return Err(MeshValidationError::NonFinitePosition { vertex, position: *p });
        }
        let n = self.positions.len();
        for (t, tri) in self.indices.iter().enumerate() {
            for &i in tri {
                if i as usize >= n {
                    return Err(MeshValidationError::IndexOutOfRange { triangle: t, index: i, vertex_count: n });
                }
            }
        }
        Ok(())
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn triangle(&self, t: usize) -> [[f64; 3]; 3] {
        let [a, b, c] = self.indices[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Bounding box of all vertices (referenced or not); `None` without vertices.
    pub fn bounds(&self) -> Option<Aabb> {
        Aabb::from_points(&self.positions)
    }

    /// `(b − a) × (c − a)` of triangle `t`: twice the area times the unit normal.
    #[inline]
    pub fn triangle_cross(&self, t: usize) -> [f64; 3] {
        let [a, b, c] = self.triangle(t).map(DVec3::from);
        (b - a).cross(c - a).to_array()
    }

    /// Area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f64 {
        0.5 * DVec3::from(self.triangle_cross(t)).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.indices.len()).map(|t| self.triangle_area(t)).sum()
    }

    /// Signed volume `Σ a·(b×c)/6` (positive for a closed, outward-oriented mesh). Computed
    /// relative to the bounding-box centre, which makes it exact to rounding for meshes far
    /// from the origin. Meaningful for closed meshes only.
    pub fn signed_volume(&self) -> f64 {
        let Some(b) = self.bounds() else { return 0.0 };
        let c = DVec3::from(b.center());
        self.indices
            .iter()
            .map(|&[i, j, k]| {
                let a = DVec3::from(self.positions[i as usize]) - c;
                let b = DVec3::from(self.positions[j as usize]) - c;
                let d = DVec3::from(self.positions[k as usize]) - c;
                a.dot(b.cross(d))
            })
            .sum::<f64>()
            / 6.0
    }

    /// For each vertex, the smallest vertex index with a bitwise-identical position.
    pub fn position_classes(&self) -> Vec<u32> {
        let mut order: Vec<u32> = (0..self.positions.len() as u32).collect();
        let key = |i: u32| self.positions[i as usize].map(|c| (c + 0.0).to_bits());
        order.sort_unstable_by_key(|&i| (key(i), i));
        let mut class = vec![0u32; self.positions.len()];
        let mut start = 0;
        while start < order.len() {
            let k = key(order[start]);
            let mut end = start + 1;
            while end < order.len() && key(order[end]) == k {
                end += 1;
            }
            for &v in &order[start..end] {
                class[v as usize] = order[start];
            }
            start = end;
        }
        class
    }

    /// Edge statistics (see [`EdgeStats`]); deterministic (sort based).
    pub fn edge_stats(&self) -> EdgeStats {
        let class = self.position_classes();
        // (lo, hi, forward?) per directed edge
        let mut edges: Vec<(u32, u32, bool)> = Vec::with_capacity(self.indices.len() * 3);
        for tri in &self.indices {
            let t = tri.map(|i| class[i as usize]);
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a == b {
                    continue;
                }
                edges.push((a.min(b), a.max(b), a < b));
            }
        }
        edges.sort_unstable();
        let mut stats = EdgeStats::default();
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
                j += 1;
            }
            stats.edges += 1;
            match j - i {
                1 => stats.boundary += 1,
                2 => {
                    if edges[i].2 == edges[i + 1].2 {
                        stats.inconsistent += 1;
                    }
                }
                _ => stats.non_manifold += 1,
            }
            i = j;
        }
        stats
    }

    /// Whether every edge is shared by exactly two triangles with opposite orientation
    /// (vertices at identical positions are one vertex, so seams are not holes).
    pub fn is_watertight(&self) -> bool {
        let s = self.edge_stats();
        !self.indices.is_empty() && s.boundary == 0 && s.non_manifold == 0 && s.inconsistent == 0
    }

    /// Removes triangles with a repeated index, zero area (see [`ZERO_AREA_REL`]) or an exact
    /// duplicate earlier in the list. Vertices are kept as they are; the order of the
    /// surviving triangles is preserved.
    pub fn clean(&self) -> (TriMesh, CleanReport) {
        let mut report = CleanReport::default();
        let d = self.bounds().map_or(0.0, |b| b.diagonal());
        let tol = ZERO_AREA_REL * d * d;
        let class = self.position_classes();
        // canonical rotation of each triangle (by position class) to find duplicates
        let canon = |t: [u32; 3]| {
            let c = t.map(|i| class[i as usize]);
            let r = (0..3).min_by_key(|&k| c[k]).unwrap_or(0);
            [c[r], c[(r + 1) % 3], c[(r + 2) % 3]]
        };
        let mut keep = vec![true; self.indices.len()];
        for (t, tri) in self.indices.iter().enumerate() {
            let c = tri.map(|i| class[i as usize]);
            if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
                report.dropped_repeated_index += 1;
                keep[t] = false;
            } else if DVec3::from(self.triangle_cross(t)).length() <= tol {
                report.dropped_zero_area += 1;
                keep[t] = false;
            }
        }
        let mut keys: Vec<([u32; 3], u32)> =
            (0..self.indices.len()).filter(|&t| keep[t]).map(|t| (canon(self.indices[t]), t as u32)).collect();
        keys.sort_unstable();
        for w in keys.windows(2) {
            if w[0].0 == w[1].0 {
                keep[w[1].1 as usize] = false;
                report.dropped_duplicate += 1;
            }
        }
        // opposite-orientation pairs among the survivors
        let mut flipped: Vec<[u32; 3]> =
            (0..self.indices.len()).filter(|&t| keep[t]).map(|t| canon(self.indices[t])).collect();
        flipped.sort_unstable();
        for t in (0..self.indices.len()).filter(|&t| keep[t]) {
            let [a, b, c] = self.indices[t];
            let rev = canon([a, c, b]);
            if flipped.binary_search(&rev).is_ok() {
                report.opposite_duplicates += 1;
            }
        }
        report.opposite_duplicates /= 2;
        let indices = self.indices.iter().zip(&keep).filter(|(_, k)| **k).map(|(t, _)| *t).collect();
        (TriMesh { positions: self.positions.clone(), indices }, report)
    }

    /// Applies `f` to every position.
    pub fn map_positions(&mut self, f: impl Fn([f64; 3]) -> [f64; 3]) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Axis-aligned unit cube `[0,1]³`, outward-oriented, 12 triangles.
    pub fn unit_cube() -> TriMesh {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        let indices = vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [2, 3, 7],
            [2, 7, 6],
            [1, 2, 6],
            [1, 6, 5],
            [0, 4, 7],
            [0, 7, 3],
        ];
        TriMesh { positions, indices }
    }

    #[test]
    fn cube_measures() {
        let m = unit_cube();
        m.validate().unwrap();
        assert!((m.area() - 6.0).abs() < 1e-12);
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
        assert!(m.is_watertight());
        let b = m.bounds().unwrap();
        assert_eq!(b.min, [0.0; 3]);
        assert_eq!(b.max, [1.0; 3]);
        // flipping one triangle breaks orientation consistency
        let mut f = m.clone();
        f.indices[0] = [0, 1, 2];
        assert!(!f.is_watertight());
        assert_eq!(f.edge_stats().inconsistent, 3);
        // removing one triangle opens three boundary edges
        let mut o = m.clone();
        o.indices.pop();
        assert!(!o.is_watertight());
        assert_eq!(o.edge_stats().boundary, 3);
    }

    #[test]
    fn seams_are_not_holes() {
        // duplicate vertex 6 at the same position and use it in two triangles
        let mut m = unit_cube();
        m.positions.push([1.0, 1.0, 1.0]);
        m.indices[2] = [4, 5, 8];
        m.indices[3] = [4, 8, 7];
        assert!(m.is_watertight());
    }

    #[test]
    fn validation_errors() {
        let mut m = unit_cube();
        m.positions[3][1] = f64::NAN;
        assert!(matches!(m.validate(), Err(MeshValidationError::NonFinitePosition { vertex: 3, .. })));
        let mut m = unit_cube();
        m.indices[5][2] = 8;
        assert_eq!(m.validate(), Err(MeshValidationError::IndexOutOfRange { triangle: 5, index: 8, vertex_count: 8 }));
        let m = TriMesh { positions: vec![[0.0; 3]], indices: vec![] };
        assert_eq!(m.validate(), Err(MeshValidationError::NoTriangles));
    }

    #[test]
    fn clean_drops_degenerates_and_duplicates() {
        let mut m = unit_cube();
        m.positions.push([0.5, 0.0, 0.0]); // 8: on edge 0-1
        m.indices.push([0, 0, 1]); // repeated index
        m.indices.push([0, 8, 1]); // collinear: zero area
        m.indices.push([2, 0, 3]); // rotation of [0,3,2]: duplicate
        m.indices.push([0, 2, 3]); // opposite of [0,3,2]
        let (c, r) = m.clean();
        assert_eq!(r.dropped_repeated_index, 1);
        assert_eq!(r.dropped_zero_area, 1);
        assert_eq!(r.dropped_duplicate, 1);
        assert_eq!(r.opposite_duplicates, 1);
        assert_eq!(c.indices.len(), 13);
        assert_eq!(&c.indices[..12], &unit_cube().indices[..]);
        // scale invariance of the zero-area test
        for s in [1e-6, 1e6] {
            let mut t = m.clone();
            t.map_positions(|p| p.map(|x| x * s));
            assert_eq!(t.clean().1, r);
        }
    }
}
