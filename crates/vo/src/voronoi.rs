//! Discrete Voronoi diagrams of the unit disk (weighted by `dμ = 2√(1 − r²) dA`) and of the
//! unit ball, as in MRT thesis §6.3.5 ("a discrete Voronoi diagram with 128³ cells for the
//! volume and 512² for the disk").
//!
//! The grid is the `res^D` cells of `[-1, 1]^D`; a cell belongs to the domain when its centre
//! does, and carries the measure of its centre (midpoint rule) — exactly the thesis's discrete
//! diagram. Each grid cell goes to its nearest generator (ties: the lowest index).
//!
//! Speed without changing the answer: a complete `2^D`-tree over the grid stores, per node,
//! the summed measure, first moment and cell count. A node inherits its parent's candidate
//! generators and keeps only those whose distance to the node's box is at most the smallest
//! farthest-distance of any candidate; a node left with one candidate is assigned whole from
//! its precomputed sums. Only grid cells near a Voronoi boundary are visited one by one.
//! The result is bit-for-bit the brute-force assignment up to summation order (tested).

/// Domain of a sample set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Domain {
    /// The unit disk under `dμ = 2√(1 − r²) dA` (line and area sampling, §6.3.1–6.3.2).
    Disk,
    /// The unit ball under the volume measure (point sampling).
    Ball,
}

impl Domain {
    /// Dimension (2 or 3).
    pub const fn dim(self) -> usize {
        match self {
            Domain::Disk => 2,
            Domain::Ball => 3,
        }
    }

    /// Name used in section names and JSON (`disk`, `ball`).
    pub const fn name(self) -> &'static str {
        match self {
            Domain::Disk => "disk",
            Domain::Ball => "ball",
        }
    }

    /// Unnormalised density at `p` (zero outside): `2√(1 − r²)` for the disk (the z-extent of
    /// the sphere above the point, thesis footnote 6), 1 inside the ball.
    #[inline]
    pub fn density(self, p: &[f64]) -> f64 {
        let r2: f64 = p.iter().map(|x| x * x).sum();
        if r2 >= 1.0 {
            return 0.0;
        }
        match self {
            Domain::Disk => 2.0 * (1.0 - r2).sqrt(),
            Domain::Ball => 1.0,
        }
    }
}

/// Per-generator statistics of one diagram.
#[derive(Debug, Clone, PartialEq)]
pub struct Cells {
    /// Measure of each cell, normalised so the domain has measure 1 (the sample weights).
    pub mass: Vec<f64>,
    /// Fraction of the domain's grid cells in each cell (area/volume fraction, unweighted).
    pub area: Vec<f64>,
    /// Measure-weighted centroid of each cell (`D` coordinates each; the generator itself for
    /// an empty cell).
    pub centroid: Vec<[f64; 3]>,
}

impl Cells {
    /// Coefficient of variation of the cell measures: `std(mass) / mean(mass)` (population std).
    pub fn cv(&self) -> f64 {
        cv(&self.mass)
    }
}

/// Coefficient of variation `std / mean` (population std; 0 for fewer than two values).
pub fn cv(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
    if mean > 0.0 { var.sqrt() / mean } else { 0.0 }
}

/// Leaf block edge (grid cells) below which the tree is not stored: leaves are scanned.
const LEAF: usize = 2;

/// A discrete Voronoi grid over a domain at a resolution, reusable for many diagrams.
#[derive(Debug, Clone)]
pub struct Grid {
    domain: Domain,
    res: usize,
    /// Tree levels: level `l` has `(2^l)^D` nodes (row-major, x fastest), down to blocks of
    /// `LEAF^D` grid cells.
    levels: Vec<Vec<Node>>,
    /// Total measure and cell count (for normalisation).
    total_mass: f64,
    total_count: f64,
}

#[derive(Debug, Clone, Copy, Default)]
struct Node {
    mass: f64,
    moment: [f64; 3],
    count: f64,
}

impl Node {
    fn add(&mut self, o: &Node) {
        self.mass += o.mass;
        for k in 0..3 {
            self.moment[k] += o.moment[k];
        }
        self.count += o.count;
    }
}

impl Grid {
    /// A grid of `res^D` cells; `res` must be a power of two ≥ 4 (the thesis: 512 disk,
    /// 128 ball).
    pub fn new(domain: Domain, res: usize) -> Grid {
        assert!(res.is_power_of_two() && res >= LEAF, "grid resolution must be a power of two ≥ {LEAF}");
        assert!(res >= 2 * LEAF);
        let d = domain.dim();
        let blocks = res / LEAF;
        let depth = blocks.trailing_zeros() as usize;
        let nb = blocks.pow(d as u32);
        let mut leaf = vec![Node::default(); nb];
        let h = 2.0 / res as f64;
        for (bi, node) in leaf.iter_mut().enumerate() {
            let bc = unflatten(bi, blocks, d);
            for_each_cell(bc, d, |c| {
                let p = cell_centre(c, h);
                let m = domain.density(&p[..d]);
                if m > 0.0 {
                    node.mass += m;
                    for k in 0..d {
                        node.moment[k] += m * p[k];
                    }
                    node.count += 1.0;
                }
            });
        }
        let mut levels = vec![leaf];
        for l in (0..depth).rev() {
            let side = 1usize << l;
            let below = levels.last().unwrap_or_else(|| unreachable!());
            let mut up = vec![Node::default(); side.pow(d as u32)];
            for (i, n) in below.iter().enumerate() {
                let c = unflatten(i, side * 2, d);
                let pc = [c[0] / 2, c[1] / 2, c[2] / 2];
                up[flatten(pc, side, d)].add(n);
            }
            levels.push(up);
        }
        levels.reverse();
        let root = levels[0][0];
        Grid { domain, res, levels, total_mass: root.mass, total_count: root.count }
    }

    /// Domain.
    pub fn domain(&self) -> Domain {
        self.domain
    }

    /// Resolution per axis.
    pub fn res(&self) -> usize {
        self.res
    }

    /// The diagram of `points` (each `D` coordinates in the first entries).
    pub fn cells(&self, points: &[[f64; 3]]) -> Cells {
        let d = self.domain.dim();
        let n = points.len();
        let mut acc = vec![Node::default(); n];
        if n > 0 {
            let mut scratch: Vec<Vec<u16>> = vec![Vec::with_capacity(n); self.levels.len() + 1];
            scratch[0].extend(0..n as u16);
            self.visit(0, [0; 3], points, &mut scratch, &mut acc);
        }
        let mass = acc.iter().map(|a| a.mass / self.total_mass).collect();
        let area = acc.iter().map(|a| a.count / self.total_count).collect();
        let centroid = acc
            .iter()
            .zip(points)
            .map(|(a, p)| {
                if a.mass > 0.0 {
                    let mut c = [0.0; 3];
                    for k in 0..d {
                        c[k] = a.moment[k] / a.mass;
                    }
                    c
                } else {
                    *p
                }
            })
            .collect();
        Cells { mass, area, centroid }
    }

    fn visit(&self, level: usize, c: [usize; 3], pts: &[[f64; 3]], scratch: &mut [Vec<u16>], acc: &mut [Node]) {
        let d = self.domain.dim();
        let side = 1usize << level;
        let node = &self.levels[level][flatten(c, side, d)];
        if node.count == 0.0 {
            return;
        }
        let s = 2.0 / side as f64;
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for k in 0..d {
            lo[k] = -1.0 + c[k] as f64 * s;
            hi[k] = lo[k] + s;
        }
        // prune the parent's candidates (MRT thesis §6.3.5 diagram, accelerated)
        let (parent, rest) = scratch.split_at_mut(level + 1);
        let cand_in = &parent[level];
        let mut thresh = f64::INFINITY;
        for &i in cand_in {
            let p = &pts[i as usize];
            let mut dmax = 0.0;
            for k in 0..d {
                let a = (p[k] - lo[k]).abs().max((p[k] - hi[k]).abs());
                dmax += a * a;
            }
            thresh = thresh.min(dmax);
        }
        let out = &mut rest[0];
        out.clear();
        for &i in cand_in {
            let p = &pts[i as usize];
            let mut dmin = 0.0;
            for k in 0..d {
                let a = (lo[k] - p[k]).max(0.0).max(p[k] - hi[k]);
                dmin += a * a;
            }
            if dmin <= thresh {
                out.push(i);
            }
        }
        if out.len() == 1 {
            acc[out[0] as usize].add(node);
            return;
        }
        if level + 1 < self.levels.len() {
            for child in 0..(1usize << d) {
                let mut cc = [0; 3];
                for k in 0..d {
                    cc[k] = c[k] * 2 + ((child >> k) & 1);
                }
                self.visit(level + 1, cc, pts, scratch, acc);
            }
            return;
        }
        // a leaf block: scan its grid cells
        let cand = &rest[0];
        let h = 2.0 / self.res as f64;
        for_each_cell(c, d, |g| {
            let p = cell_centre(g, h);
            let m = self.domain.density(&p[..d]);
            if m <= 0.0 {
                return;
            }
            let mut best = u16::MAX;
            let mut bd = f64::INFINITY;
            for &i in cand {
                let q = &pts[i as usize];
                let mut dd = 0.0;
                for k in 0..d {
                    dd += (p[k] - q[k]) * (p[k] - q[k]);
                }
                if dd < bd || (dd == bd && i < best) {
                    bd = dd;
                    best = i;
                }
            }
            let a = &mut acc[best as usize];
            a.mass += m;
            for k in 0..d {
                a.moment[k] += m * p[k];
            }
            a.count += 1.0;
        });
    }

    /// Brute-force diagram (every grid cell against every generator): the test oracle.
    pub fn cells_brute_force(&self, points: &[[f64; 3]]) -> Cells {
        let d = self.domain.dim();
        let n = points.len();
        let mut acc = vec![Node::default(); n];
        let h = 2.0 / self.res as f64;
        let total = self.res.pow(d as u32);
        for idx in 0..total {
            let g = unflatten(idx, self.res, d);
            let p = cell_centre(g, h);
            let m = self.domain.density(&p[..d]);
            if m <= 0.0 || n == 0 {
                continue;
            }
            let mut best = 0;
            let mut bd = f64::INFINITY;
            for (i, q) in points.iter().enumerate() {
                let dd: f64 = (0..d).map(|k| (p[k] - q[k]).powi(2)).sum();
                if dd < bd {
                    bd = dd;
                    best = i;
                }
            }
            let a = &mut acc[best];
            a.mass += m;
            for k in 0..d {
                a.moment[k] += m * p[k];
            }
            a.count += 1.0;
        }
        Cells {
            mass: acc.iter().map(|a| a.mass / self.total_mass).collect(),
            area: acc.iter().map(|a| a.count / self.total_count).collect(),
            centroid: acc
                .iter()
                .zip(points)
                .map(
                    |(a, p)| {
                        if a.mass > 0.0 {
                            [a.moment[0] / a.mass, a.moment[1] / a.mass, a.moment[2] / a.mass]
                        } else {
                            *p
                        }
                    },
                )
                .collect(),
        }
    }
}

#[inline]
fn cell_centre(g: [usize; 3], h: f64) -> [f64; 3] {
    [-1.0 + (g[0] as f64 + 0.5) * h, -1.0 + (g[1] as f64 + 0.5) * h, -1.0 + (g[2] as f64 + 0.5) * h]
}

/// Calls `f` for every grid cell of leaf block `b`.
#[inline]
fn for_each_cell(b: [usize; 3], d: usize, mut f: impl FnMut([usize; 3])) {
    let zn = if d == 3 { LEAF } else { 1 };
    for z in 0..zn {
        for y in 0..LEAF {
            for x in 0..LEAF {
                f([b[0] * LEAF + x, b[1] * LEAF + y, if d == 3 { b[2] * LEAF + z } else { 0 }]);
            }
        }
    }
}

#[inline]
fn flatten(c: [usize; 3], side: usize, d: usize) -> usize {
    if d == 3 { (c[2] * side + c[1]) * side + c[0] } else { c[1] * side + c[0] }
}

#[inline]
fn unflatten(i: usize, side: usize, d: usize) -> [usize; 3] {
    if d == 3 { [i % side, (i / side) % side, i / (side * side)] } else { [i % side, i / side, 0] }
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_math::rng::ItemRng;

    fn random_points(domain: Domain, n: usize, seed: u64) -> Vec<[f64; 3]> {
        let mut r = ItemRng::new(seed, 99, 0);
        let d = domain.dim();
        let mut v = Vec::new();
        while v.len() < n {
            let mut p = [0.0; 3];
            for k in 0..d {
                p[k] = 2.0 * r.next_f64() - 1.0;
            }
            if p.iter().map(|x| x * x).sum::<f64>() < 1.0 {
                v.push(p);
            }
        }
        v
    }

    #[test]
    fn tree_matches_brute_force() {
        for (domain, res) in [(Domain::Disk, 64), (Domain::Ball, 16)] {
            let g = Grid::new(domain, res);
            for n in [1, 2, 7, 33] {
                let pts = random_points(domain, n, n as u64);
                let a = g.cells(&pts);
                let b = g.cells_brute_force(&pts);
                for i in 0..n {
                    assert!((a.mass[i] - b.mass[i]).abs() < 1e-12, "{domain:?} n={n} i={i}");
                    assert!((a.area[i] - b.area[i]).abs() < 1e-12);
                    for k in 0..3 {
                        assert!((a.centroid[i][k] - b.centroid[i][k]).abs() < 1e-10);
                    }
                }
                assert!((a.mass.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn symmetric_sets_have_equal_cells_and_known_measure() {
        // two points mirrored about the origin split any symmetric domain in halves
        let g = Grid::new(Domain::Disk, 256);
        let c = g.cells(&[[0.3, 0.123_456_7, 0.0], [-0.3, -0.123_456_7, 0.0]]);
        assert!((c.mass[0] - 0.5).abs() < 1e-12);
        // the discrete total measure approaches the exact (4π/3) as the midpoint rule converges
        let h = 2.0 / 256.0;
        assert!((g.total_mass * h * h - 4.0 * std::f64::consts::PI / 3.0).abs() < 2e-3);
        // a centre point and a far point: the centre's cell measure under 2√(1−r²) is larger
        // than its area fraction (the density peaks at the centre)
        let c = g.cells(&[[0.0, 0.0, 0.0], [0.9, 0.0, 0.0]]);
        assert!(c.mass[0] > c.area[0]);
        // centroid of the half disk x>0 under μ: 2∫∫ x√(1−r²) / (2π/3) = 3/8·... = (3π/16)·(2/π)…
        let c = g.cells(&[[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]]);
        // exact: ∫_half x·2√(1−r²) dA = 2∫_{-π/2}^{π/2}cosθ dθ ∫ r²√(1−r²) dr = 4·π/16 = π/4;
        // half measure 2π/3 → centroid 3/8
        assert!((c.centroid[0][0] - 0.375).abs() < 2e-3, "{}", c.centroid[0][0]);
        let g = Grid::new(Domain::Ball, 64);
        let c = g.cells(&[[0.0, 0.0, 0.5], [0.0, 0.0, -0.5]]);
        // half ball centroid 3/8
        assert!((c.centroid[0][2] - 0.375).abs() < 3e-3, "{}", c.centroid[0][2]);
        assert!((c.mass[0] - 0.5).abs() < 1e-12);
    }
}
