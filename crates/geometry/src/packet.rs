//! Any-hit queries for bundles of *parallel* rays (one direction, many origins) over a
//! binary BVH of our own, traversed as one stream ([`ParallelBvh::any_hits`]), and the same
//! tree collapsed to 4-wide nodes for single rays ([`ParallelBvh::any_hit`]).
//!
//! Written for the FIV bake (issue 15 §4), whose rays come texel by texel: every sample's
//! ray toward one environment texel has the texel's direction. The stream traversal tests
//! a node's two child boxes against the list of live rays that reached the node and passes
//! each child the rays that meet its box (branch-free list filtering, front-to-back by the
//! common direction), so each node is fetched once per bundle instead of once per ray.
//! **Measured slower than [`MeshBvh::any_hit_prepared`]'s obvhs CWBVH traversal on the
//! bake's rays** (docs/benchmarks.md, "FIV bake speed, second pass"): the traced rays are the
//! few near the silhouette, too sparse in line space for a bundle to share many nodes. The
//! bake therefore keeps the CWBVH; this module stays, tested and benchmarked
//! (`cargo bench --bench fiv -- fiv_rays`), for denser bundles (many samples per texel).
//!
//! # Same answer as [`MeshBvh::any_hit_prepared`]
//! Each ray is clipped to the padded mesh box in f64 by the same code, every candidate
//! triangle is decided by the same watertight f64 kernel with the same origin and range,
//! and any-hit is a boolean over all triangles, so only the culling differs — and it is
//! conservative by the argument of [`crate::bvh`] (the same normalised frame, the same
//! triangle boxes padded by 1/16 unit and rounded outwards, the same f32 start point and
//! unit direction; the slab test here accepts `[0, tmax]`, a superset of obvhs' range). A
//! triangle the exact test hits is therefore always reached, and the result is the one
//! `any_hit_prepared` gives, bit for bit (tested against it and against brute force).
//!
//! # Build
//! obvhs' PLOC build with reinsertion (its `medium_build` settings, the tree behind the
//! CWBVH), leaves collapsed by its SAH collapser to at most [`MAX_LEAF`] triangles, converted
//! to nodes that carry both children's boxes. Single-threaded and deterministic; results
//! never depend on the layout.

use glam::DVec3;

use crate::bvh::{MeshBvh, PreparedDir};
use crate::kernels::RayKernel;

/// Largest leaf.
const MAX_LEAF: usize = 4;
/// Leaf handles have this bit set: `LEAF | start << 3 | (count − 1)`.
const LEAF: u32 = 1 << 31;

/// An inner node: its two children's boxes (`[min xyz, max xyz]`, normalised frame), their
/// handles and the axis the build split on (child 0 holds the smaller centroids).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    bounds: [[f32; 6]; 2],
    child: [u32; 2],
    axis: u32,
}

/// A binary BVH for packets of parallel rays ([`MeshBvh::parallel_bvh`]).
#[derive(Debug, Clone)]
pub struct ParallelBvh {
    nodes: Vec<Node>,
    /// Triangles in leaf order.
    tris: Vec<[DVec3; 3]>,
    /// Handle of the root (a leaf for tiny meshes; `None` for an empty mesh).
    root: Option<u32>,
    /// Root box.
    root_bounds: [f32; 6],
    center: DVec3,
    scale: f64,
    padded_min: DVec3,
    padded_max: DVec3,
    depth: usize,
    /// The same tree collapsed to 4-wide nodes (root at 0) for single rays.
    wide: Vec<Node4>,
    /// Handle of the wide root (a leaf handle for tiny meshes).
    wide_root: u32,
}

/// A 4-wide node: its children's boxes as structure of arrays (`[min x, min y, min z, max
/// x, max y, max z][child]`; empty slots hold an inverted box that no ray meets) and their
/// handles (inner: index into `wide`; leaves as in the binary tree).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node4 {
    b: [[f32; 4]; 6],
    child: [u32; 4],
}

#[derive(Clone, Copy)]
struct Prim {
    lo: [f32; 3],
    hi: [f32; 3],
    id: u32,
}

fn union(a: [f32; 6], lo: [f32; 3], hi: [f32; 3]) -> [f32; 6] {
    [a[0].min(lo[0]), a[1].min(lo[1]), a[2].min(lo[2]), a[3].max(hi[0]), a[4].max(hi[1]), a[5].max(hi[2])]
}

const EMPTY: [f32; 6] =
    [f32::INFINITY, f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];

fn half_area(b: [f32; 6]) -> f32 {
    let (x, y, z) = (b[3] - b[0], b[4] - b[1], b[5] - b[2]);
    if x < 0.0 { 0.0 } else { x * y + y * z + z * x }
}

fn bounds_of(p: &[Prim]) -> [f32; 6] {
    p.iter().fold(EMPTY, |b, q| union(b, q.lo, q.hi))
}

impl ParallelBvh {
    pub(crate) fn build(bvh: &MeshBvh) -> Self {
        let (center, scale, padded_min, padded_max) = bvh.frame_parts();
        let src = bvh.triangles_slot_order();
        let prims: Vec<Prim> = src
            .iter()
            .enumerate()
            .map(|(i, _)| {
                let (lo, hi) = bvh.slot_box(i);
                Prim { lo, hi, id: i as u32 }
            })
            .collect();
        let mut out = Self {
            nodes: Vec::new(),
            tris: Vec::with_capacity(src.len()),
            root: None,
            root_bounds: EMPTY,
            center,
            scale,
            padded_min,
            padded_max,
            depth: 0,
            wide: Vec::new(),
            wide_root: 0,
        };
        if prims.is_empty() {
            return out;
        }
        out.root_bounds = bounds_of(&prims);
        let (root, depth) = out.adopt_ploc(&prims, src);
        out.root = Some(root);
        out.depth = depth;
        out.wide_root = if root & LEAF != 0 { root } else { out.collapse(root) };
        out
    }

    /// Collapses the binary subtree at inner node `n` into 4-wide nodes; returns the index.
    fn collapse(&mut self, n: u32) -> u32 {
        // up to four (box, handle) pairs: open the inner child of largest surface area
        let node = self.nodes[n as usize];
        let mut kids: Vec<([f32; 6], u32)> = vec![(node.bounds[0], node.child[0]), (node.bounds[1], node.child[1])];
        while kids.len() < 4 {
            let Some(i) = (0..kids.len())
                .filter(|&i| kids[i].1 & LEAF == 0)
                .max_by(|&a, &b| half_area(kids[a].0).total_cmp(&half_area(kids[b].0)).then(b.cmp(&a)))
            else {
                break;
            };
            let c = self.nodes[kids[i].1 as usize];
            kids[i] = (c.bounds[0], c.child[0]);
            kids.insert(i + 1, (c.bounds[1], c.child[1]));
        }
        let idx = self.wide.len();
        self.wide.push(Node4 {
            b: [
                [f32::INFINITY; 4],
                [f32::INFINITY; 4],
                [f32::INFINITY; 4],
                [f32::NEG_INFINITY; 4],
                [f32::NEG_INFINITY; 4],
                [f32::NEG_INFINITY; 4],
            ],
            child: [LEAF; 4],
        });
        for (slot, (b, h)) in kids.into_iter().enumerate() {
            let h = if h & LEAF != 0 { h } else { self.collapse(h) };
            let w = &mut self.wide[idx];
            for k in 0..6 {
                w.b[k][slot] = b[k];
            }
            w.child[slot] = h;
        }
        idx as u32
    }

    /// [`MeshBvh::any_hit_prepared`]'s boolean for one ray, through the 4-wide tree.
    pub fn any_hit(&self, origin: [f64; 3], pd: &PreparedDir, tmin: f64, tmax: f64) -> bool {
        if self.root.is_none() {
            return false;
        }
        let o = DVec3::from(origin);
        if !o.is_finite() {
            return false;
        }
        let Some((t0, t1)) = pd.clip(o, self.padded_min, self.padded_max, tmin, tmax) else {
            return false;
        };
        let (start, span) = pd.node_start(o, t0, t1, self.center, self.scale);
        let k = pd.kernel().with_origin(o);
        let inv = pd.inv32();
        let inv = [inv.x, inv.y, inv.z];
        let st = [start.x, start.y, start.z];
        // near/far rows of the box arrays per axis
        let rows: [(usize, usize); 3] = core::array::from_fn(|a| if inv[a] < 0.0 { (a + 3, a) } else { (a, a + 3) });
        let mut stack = [0u32; 128];
        let mut sp = 0usize;
        let mut cur = self.wide_root;
        loop {
            if cur & LEAF != 0 {
                let first = ((cur & !LEAF) >> 3) as usize;
                let count = (cur & 7) as usize + 1;
                if self.tris[first..first + count].iter().any(|[a, b, c]| k.intersect(*a, *b, *c, tmin, tmax).is_some())
                {
                    return true;
                }
            } else {
                let n = &self.wide[cur as usize];
                let mut tn = [0f32; 4];
                let mut tf = [span; 4];
                for (a, &(rn, rf)) in rows.iter().enumerate() {
                    for l in 0..4 {
                        tn[l] = tn[l].max((n.b[rn][l] - st[a]) * inv[a]);
                        tf[l] = tf[l].min((n.b[rf][l] - st[a]) * inv[a]);
                    }
                }
                // push the hit children far to near (nearest popped first)
                let mut hit: [(f32, u32); 4] = [(0.0, 0); 4];
                let mut nh = 0;
                for l in 0..4 {
                    if tn[l] <= tf[l] {
                        hit[nh] = (tn[l], n.child[l]);
                        nh += 1;
                    }
                }
                let hs = &mut hit[..nh];
                hs.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
                if sp + nh > stack.len() {
                    // deeper than any sane tree: finish this ray by the stream path
                    let mut out = [false];
                    self.any_hits(&[origin], pd, tmin, tmax, &mut out, &mut StreamScratch::default());
                    return out[0];
                }
                for &(_, h) in hs.iter() {
                    stack[sp] = h;
                    sp += 1;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }

    /// The tree obvhs builds for the CWBVH (PLOC, reinsertion, leaves collapsed by SAH to at
    /// most [`MAX_LEAF`] triangles), in this layout; returns the root handle and the depth.
    fn adopt_ploc(&mut self, prims: &[Prim], src: &[[DVec3; 3]]) -> (u32, usize) {
        #[derive(Clone, Copy)]
        struct B(obvhs::aabb::Aabb);
        impl obvhs::Boundable for B {
            fn aabb(&self) -> obvhs::aabb::Aabb {
                self.0
            }
        }
        let boxes: Vec<B> = prims
            .iter()
            .map(|p| B(obvhs::aabb::Aabb::new(glam::Vec3A::from_array(p.lo), glam::Vec3A::from_array(p.hi))))
            .collect();
        let cfg = obvhs::BvhBuildParams::medium_build();
        let mut b2 = obvhs::ploc::PlocBuilder::with_capacity(boxes.len()).build(
            cfg.ploc_search_distance,
            &boxes,
            (0..boxes.len() as u32).collect(),
            cfg.sort_precision,
            cfg.search_depth_threshold,
        );
        obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut b2, cfg.reinsertion_batch_ratio, None);
        obvhs::bvh2::leaf_collapser::collapse(&mut b2, MAX_LEAF as u32, cfg.collapse_traversal_cost);
        let ab = |i: usize| {
            let a = b2.nodes[i].aabb;
            [a.min.x, a.min.y, a.min.z, a.max.x, a.max.y, a.max.z]
        };
        // handles: post-order conversion with an explicit stack
        fn conv(
            me: &mut ParallelBvh,
            b2: &obvhs::bvh2::Bvh2,
            i: usize,
            src: &[[DVec3; 3]],
            prims: &[Prim],
            ab: &dyn Fn(usize) -> [f32; 6],
            depth: usize,
        ) -> (u32, usize) {
            let n = &b2.nodes[i];
            if n.prim_count > 0 {
                let start = me.tris.len() as u32;
                let count = n.prim_count as usize;
                for k in 0..count {
                    let pi = b2.primitive_indices[n.first_index as usize + k] as usize;
                    me.tris.push(src[prims[pi].id as usize]);
                }
                return (LEAF | start << 3 | (count as u32 - 1), depth);
            }
            let (c0, c1) = (n.first_index as usize, n.first_index as usize + 1);
            let idx = me.nodes.len();
            let axis = {
                let (a, b) = (ab(c0), ab(c1));
                let d = [0, 1, 2].map(|k| (b[k] + b[k + 3]) - (a[k] + a[k + 3]));
                (0..3).max_by(|&x, &y| d[x].abs().total_cmp(&d[y].abs())).unwrap_or(0)
            };
            // child 0 is the one with the smaller centre along `axis`
            let (a, b) = (ab(c0), ab(c1));
            let swap = (b[axis] + b[axis + 3]) < (a[axis] + a[axis + 3]);
            let (c0, c1) = if swap { (c1, c0) } else { (c0, c1) };
            me.nodes.push(Node { bounds: [ab(c0), ab(c1)], child: [0; 2], axis: axis as u32 });
            let (h0, d0) = conv(me, b2, c0, src, prims, ab, depth + 1);
            let (h1, d1) = conv(me, b2, c1, src, prims, ab, depth + 1);
            me.nodes[idx].child = [h0, h1];
            (idx as u32, d0.max(d1))
        }
        conv(self, &b2, 0, src, prims, &ab, 1)
    }

    /// Number of inner nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// For every origin `o` of `origins`, `out[i]` = [`MeshBvh::any_hit_prepared`]`(o, pd,
    /// tmin, tmax)` (the same boolean; see the module docs), all rays traced together as one
    /// stream; `scratch` is reused between calls (no allocation once it has grown).
    pub fn any_hits(
        &self,
        origins: &[[f64; 3]],
        pd: &PreparedDir,
        tmin: f64,
        tmax: f64,
        out: &mut [bool],
        scratch: &mut StreamScratch,
    ) {
        assert_eq!(origins.len(), out.len(), "any_hits: origins and out differ in length");
        out.fill(false);
        let Some(root) = self.root else {
            return;
        };
        let StreamScratch { rays, kernels, slot, list, stack } = scratch;
        rays.clear();
        kernels.clear();
        slot.clear();
        let k0 = pd.kernel();
        for (i, o) in origins.iter().enumerate() {
            let o = DVec3::from(*o);
            if !o.is_finite() {
                continue;
            }
            let Some((t0, t1)) = pd.clip(o, self.padded_min, self.padded_max, tmin, tmax) else {
                continue;
            };
            let (start, span) = pd.node_start(o, t0, t1, self.center, self.scale);
            rays.push([start.x, start.y, start.z, span]);
            kernels.push(k0.with_origin(o));
            slot.push(i as u32);
        }
        let inv = pd.inv32();
        let slab = Slab { inv: [inv.x, inv.y, inv.z], neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0] };
        list.clear();
        for (r, ray) in rays.iter().enumerate() {
            if slab.hits(&self.root_bounds, ray) {
                list.push(r as u32);
            }
        }
        let mut alive = rays.len();
        stack.clear();
        stack.push((root, 0, list.len() as u32));
        // depth first; a node's ray list lies in `list[start..start + len]`, its children's
        // are appended after it, and everything after a popped entry's list is dead
        while let Some((node, start, len)) = stack.pop() {
            let (start, len) = (start as usize, len as usize);
            list.truncate(start + len);
            if node & LEAF != 0 {
                let first = ((node & !LEAF) >> 3) as usize;
                let count = (node & 7) as usize + 1;
                let tris = &self.tris[first..first + count];
                for idx in start..start + len {
                    let r = list[idx] as usize;
                    if rays[r][3] < 0.0 {
                        continue;
                    }
                    let k = &kernels[r];
                    if tris.iter().any(|[a, b, c]| k.intersect(*a, *b, *c, tmin, tmax).is_some()) {
                        out[slot[r] as usize] = true;
                        // a ray that has hit fails every later box test (range end < 0 ≤ start)
                        rays[r][3] = f32::NEG_INFINITY;
                        alive -= 1;
                    }
                }
                if alive == 0 {
                    return;
                }
                continue;
            }
            let n = &self.nodes[node as usize];
            let near = slab.neg[n.axis as usize] as usize;
            let (bn, bf) = (&n.bounds[near], &n.bounds[1 - near]);
            // far list first (it waits on the stack), then the near one; branch-free
            // (every candidate is written, the cursor advances only on a hit)
            let f0 = list.len();
            list.resize(f0 + 2 * len, 0);
            let (src, dst) = list.split_at_mut(f0);
            let src = &src[start..start + len];
            let mut nf = 0usize;
            let mut nn = len;
            for &r in src {
                let ray = &rays[r as usize];
                dst[nf] = r;
                nf += slab.hits(bf, ray) as usize;
                dst[nn] = r;
                nn += slab.hits(bn, ray) as usize;
            }
            let n0 = f0 + nf;
            // move the near list down to follow the far one
            dst.copy_within(len..nn, nf);
            let n1 = n0 + (nn - len);
            list.truncate(n1);
            if n0 > f0 {
                stack.push((n.child[1 - near], f0 as u32, (n0 - f0) as u32));
            }
            if n1 > n0 {
                stack.push((n.child[near], n0 as u32, (n1 - n0) as u32));
            }
        }
    }
}

/// Reusable buffers of [`ParallelBvh::any_hits`].
#[derive(Debug, Clone, Default)]
pub struct StreamScratch {
    /// Node-space start point and range end of each clipped ray.
    rays: Vec<[f32; 4]>,
    kernels: Vec<RayKernel>,
    /// The ray's index in `origins`.
    slot: Vec<u32>,
    list: Vec<u32>,
    stack: Vec<(u32, u32, u32)>,
}

/// The slab test of the stream's common direction.
struct Slab {
    inv: [f32; 3],
    /// Direction component negative (the near plane of a slab is then its max).
    neg: [bool; 3],
}

impl Slab {
    /// Whether the ray (start point, range end) meets box `b` at a node-space parameter in
    /// `[0, tmax]`.
    #[inline(always)]
    fn hits(&self, b: &[f32; 6], ray: &[f32; 4]) -> bool {
        let pick = |k: usize| if self.neg[k] { (b[k + 3], b[k]) } else { (b[k], b[k + 3]) };
        let (nx, fx) = pick(0);
        let (ny, fy) = pick(1);
        let (nz, fz) = pick(2);
        let [ix, iy, iz] = self.inv;
        let tn = ((nx - ray[0]) * ix).max((ny - ray[1]) * iy).max((nz - ray[2]) * iz).max(0.0);
        let tf = ((fx - ray[0]) * ix).min((fy - ray[1]) * iy).min((fz - ray[2]) * iz).min(ray[3]);
        tn <= tf
    }
}
