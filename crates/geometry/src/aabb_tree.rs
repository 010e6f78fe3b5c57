//! A binary f64 AABB tree over triangles, used for closest-point queries and as the
//! hierarchy of the fast winding number. Median splits along the longest axis of the
//! centroid bounds with ties broken by triangle index, so the tree is a pure function of the
//! input and its depth is at most `⌈log2(n / LEAF)⌉ + 1`.

use glam::DVec3;

use crate::kernels::closest_point_on_triangle;
use crate::mesh::TriMesh;

/// Maximum triangles per leaf.
pub(crate) const LEAF: usize = 4;
/// Traversal stack size; enough for any tree with fewer than 2^60 triangles.
pub(crate) const STACK: usize = 128;

#[derive(Debug, Clone, Copy)]
pub(crate) struct TreeNode {
    pub min: DVec3,
    pub max: DVec3,
    /// First slot in `AabbTree::tris` (leaves).
    pub start: u32,
    /// Number of triangles (0 for inner nodes).
    pub count: u32,
    /// Right child (inner nodes; the left child is the next node).
    pub right: u32,
}

impl TreeNode {
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    pub fn dist2(&self, p: DVec3) -> f64 {
        let d = (self.min - p).max(p - self.max).max(DVec3::ZERO);
        d.length_squared()
    }
}

/// The tree plus the triangles in leaf order.
#[derive(Debug, Clone)]
pub(crate) struct AabbTree {
    pub nodes: Vec<TreeNode>,
    /// Triangle corners in leaf order.
    pub tris: Vec<[DVec3; 3]>,
    /// Original triangle index of each slot.
    pub ids: Vec<u32>,
}

impl AabbTree {
    /// Builds the tree; `mesh` must be valid (indices in range). An empty mesh gives an empty
    /// tree.
    pub fn build(mesh: &TriMesh) -> Self {
        let n = mesh.indices.len();
        let corners: Vec<[DVec3; 3]> = (0..n).map(|t| mesh.triangle(t).map(DVec3::from)).collect();
        let centroids: Vec<DVec3> = corners.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes: Vec<TreeNode> = Vec::with_capacity(2 * n / LEAF + 1);
        // (start, end, parent whose `right` this node is)
        let mut work: Vec<(usize, usize, Option<usize>)> = Vec::new();
        if n > 0 {
            work.push((0, n, None));
        }
        while let Some((s, e, right_of)) = work.pop() {
            let idx = nodes.len();
            if let Some(p) = right_of {
                nodes[p].right = idx as u32;
            }
            let mut min = DVec3::splat(f64::INFINITY);
            let mut max = DVec3::splat(f64::NEG_INFINITY);
            let mut cmin = min;
            let mut cmax = max;
            for &t in &order[s..e] {
                for v in corners[t as usize] {
                    min = min.min(v);
                    max = max.max(v);
                }
                cmin = cmin.min(centroids[t as usize]);
                cmax = cmax.max(centroids[t as usize]);
            }
            if e - s <= LEAF {
                nodes.push(TreeNode { min, max, start: s as u32, count: (e - s) as u32, right: 0 });
                continue;
            }
            nodes.push(TreeNode { min, max, start: 0, count: 0, right: 0 });
            let ext = cmax - cmin;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = s + (e - s) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&a, &b| {
                centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]).then(a.cmp(&b))
            });
            work.push((mid, e, Some(idx)));
            work.push((s, mid, None));
        }
        let tris = order.iter().map(|&t| corners[t as usize]).collect();
        Self { nodes, tris, ids: order }
    }

    /// Closest point on the mesh to `p` among points within `sqrt(max_d2)`:
    /// `(squared distance, triangle id, point)`. Ties go to the smaller triangle index.
    pub fn closest_point(&self, p: DVec3, max_d2: f64) -> Option<(f64, u32, DVec3)> {
        if self.nodes.is_empty() || !p.is_finite() {
            return None;
        }
        let mut best: Option<(f64, u32, DVec3)> = None;
        let mut best_d2 = max_d2;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        if self.nodes[0].dist2(p) <= best_d2 {
            stack[0] = 0;
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if node.dist2(p) > best_d2 {
                continue;
            }
            if node.is_leaf() {
                for slot in node.start as usize..(node.start + node.count) as usize {
                    let [a, b, c] = self.tris[slot];
                    let q = closest_point_on_triangle(p, a, b, c);
                    let d2 = (q - p).length_squared();
                    let id = self.ids[slot];
                    let better = match best {
                        None => d2 <= best_d2,
                        Some((bd, bid, _)) => d2 < bd || (d2 == bd && id < bid),
                    };
                    if better {
                        best = Some((d2, id, q));
                        best_d2 = d2;
                    }
                }
            } else {
                let l = stack[sp] + 1;
                let r = node.right;
                let dl = self.nodes[l as usize].dist2(p);
                let dr = self.nodes[r as usize].dist2(p);
                // push the farther child first so the nearer one is visited first
                let (first, second, d_first, d_second) = if dl <= dr { (r, l, dr, dl) } else { (l, r, dl, dr) };
                if d_first <= best_d2 {
                    stack[sp] = first;
                    sp += 1;
                }
                if d_second <= best_d2 {
                    stack[sp] = second;
                    sp += 1;
                }
            }
        }
        best
    }

    /// Calls `f(slot)` for every triangle slot of a leaf whose box, grown by `pad` on every
    /// side, meets the ray `o + t·d`, `t ≥ 0` (`d` non-zero and finite). Conservative for
    /// every triangle with a point within `pad` of the ray, up to the slab test's rounding,
    /// which `pad` must dominate.
    pub fn ray_slots(&self, o: DVec3, d: DVec3, pad: f64, mut f: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = DVec3::ONE / d;
        let meets = |n: &TreeNode| {
            let (lo, hi) = (n.min - DVec3::splat(pad), n.max + DVec3::splat(pad));
            let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
            for k in 0..3 {
                if d[k] == 0.0 {
                    if o[k] < lo[k] || o[k] > hi[k] {
                        return false;
                    }
                    continue;
                }
                let a = (lo[k] - o[k]) * inv[k];
                let b = (hi[k] - o[k]) * inv[k];
                let (a, b) = if a <= b { (a, b) } else { (b, a) };
                t0 = t0.max(a);
                t1 = t1.min(b);
            }
            t0 <= t1
        };
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        if meets(&self.nodes[0]) {
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp];
            let node = &self.nodes[ni as usize];
            if node.is_leaf() {
                for slot in node.start as usize..(node.start + node.count) as usize {
                    f(slot);
                }
                continue;
            }
            for child in [ni + 1, node.right] {
                if meets(&self.nodes[child as usize]) {
                    stack[sp] = child;
                    sp += 1;
                }
            }
        }
    }

    /// Depth of the tree (1 for a single leaf, 0 when empty).
    #[cfg(test)]
    pub fn depth(&self) -> usize {
        let mut max = 0;
        let mut stack = vec![(0usize, 1usize)];
        if self.nodes.is_empty() {
            return 0;
        }
        while let Some((i, d)) = stack.pop() {
            max = max.max(d);
            if !self.nodes[i].is_leaf() {
                stack.push((i + 1, d + 1));
                stack.push((self.nodes[i].right as usize, d + 1));
            }
        }
        max
    }
}
