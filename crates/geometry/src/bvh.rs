//! Ray queries (closest hit, any hit) over a triangle mesh with an obvhs CWBVH, and
//! closest-point queries with an f64 AABB tree.
//!
//! # How obvhs is used, and what is robust
//! obvhs 0.4 builds a compressed 8-wide BVH (PLOC + reinsertion, `BvhBuildParams::medium_build`,
//! no spatial splits) over f32 boxes, and traverses it with `CwBvhNode::intersect_ray` through
//! its public `traverse!` macro (the loop behind `CwBvh::ray_traverse` / `ray_traverse_miss`;
//! the occlusion variant stops at the first hit, which is what makes it 2–3× cheaper than a
//! closest hit). Three properties of obvhs matter, and are handled here:
//!
//! 1. **Its triangle test is not watertight.** `obvhs::triangle::Triangle::intersect` is an f32
//!    Möller–Trumbore test: a ray through a shared edge or vertex can miss both triangles, so
//!    rays leak through closed meshes (pinholes in visibility, wrong parity counts). It is not
//!    used: the primitive callback runs the watertight test of Woop, Benthin & Wald (2013) in
//!    f64 on the original f64 vertices, which never lets a ray pass between two triangles that
//!    share an edge (it may report a hit on both). Callers still must not count crossings to
//!    decide inside/outside (use [`crate::inside`]), and must offset secondary-ray origins
//!    (`tmin > 0`) themselves, as usual.
//! 2. **Its node test is a plain f32 slab test** with no error bound, a fixed minimum distance
//!    (`1e-4`, in node units) and clamped inverse directions. Here the BVH is built in a
//!    normalised frame (centred, scaled by a power of two so the mesh spans ~1024 units), each
//!    triangle box is padded by 1/16 unit (6·10⁻⁵ of the mesh size) and rounded outwards, every
//!    ray is first clipped in f64 to the (padded) mesh box so the traversal starts inside or on
//!    it, and near-zero direction components are replaced consistently (direction and inverse)
//!    by `+1e-30`. Together this makes the node culling conservative for every ray whose hit
//!    lies in the box: a triangle that the exact test hits is always reached.
//! 3. **Its traversal stack holds 32 entries and silently overwrites the top on overflow.**
//!    The depth of the built tree is measured; traversal uses a 64-entry stack on the call
//!    stack and falls back to a heap stack (one allocation per query) only for pathological
//!    trees deeper than that.
//!
//! # Determinism
//! Results never depend on the BVH layout (and so not on the thread count of a parallel
//! build, the `parallel` feature, or obvhs' internal ordering): the closest hit is the
//! smallest `t`, ties broken by the smallest triangle index; any-hit is a boolean over the
//! closed interval `[tmin, tmax]`; the closest point is the smallest distance, ties broken by
//! triangle index. The build itself is single-threaded (unless the `parallel` feature is on)
//! and deterministic.
//!
//! Queries take `&self`, allocate nothing (see 3.), and [`MeshBvh`] is `Send + Sync`, so
//! callers parallelise over rays with rayon.

use std::time::Duration;

use glam::{DVec3, UVec2, Vec3A, uvec2};
use obvhs::cwbvh::CwBvh;
use obvhs::faststack::FastStack;

use crate::aabb_tree::AabbTree;
use crate::kernels::RayKernel;
use crate::mesh::{Aabb, TriMesh};

/// A ray `origin + t·direction`, `t ∈ [tmin, tmax]` (closed). `direction` need not be unit
/// length; `t` is measured in multiples of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: [f64; 3],
    /// Direction (non-zero, finite).
    pub direction: [f64; 3],
    /// Smallest accepted `t`.
    pub tmin: f64,
    /// Largest accepted `t` (may be `f64::INFINITY`).
    pub tmax: f64,
}

impl Ray {
    /// An infinite ray from `origin` (`tmin = 0`).
    pub fn new(origin: [f64; 3], direction: [f64; 3]) -> Self {
        Self { origin, direction, tmin: 0.0, tmax: f64::INFINITY }
    }

    /// The segment from `from` (`t = 0`) to `to` (`t = 1`).
    pub fn segment(from: [f64; 3], to: [f64; 3]) -> Self {
        Self { origin: from, direction: (DVec3::from(to) - DVec3::from(from)).to_array(), tmin: 0.0, tmax: 1.0 }
    }

    /// The same ray with `t ∈ [tmin, tmax]`.
    pub fn with_range(mut self, tmin: f64, tmax: f64) -> Self {
        self.tmin = tmin;
        self.tmax = tmax;
        self
    }

    /// Point at parameter `t`.
    pub fn at(&self, t: f64) -> [f64; 3] {
        (DVec3::from(self.origin) + t * DVec3::from(self.direction)).to_array()
    }
}

/// A ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f64,
    /// Index of the triangle in the mesh the BVH was built from.
    pub triangle: u32,
    /// Barycentrics `(b1, b2)`: the hit is `(1 − b1 − b2)·v0 + b1·v1 + b2·v2`.
    pub barycentric: [f64; 2],
}

/// Result of a closest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestPoint {
    /// The nearest point on the surface.
    pub point: [f64; 3],
    /// Its distance to the query point.
    pub distance: f64,
    /// The triangle it lies on (smallest index on ties).
    pub triangle: u32,
}

/// Half-width of the box padding in normalised BVH units (the mesh spans (512, 1024]).
const PAD: f64 = 1.0 / 16.0;
/// Direction components smaller than this are replaced by it in node tests.
const TINY_DIR: f32 = 1e-30;
/// Traversal stack size on the call stack.
const STACK_INLINE: usize = 64;

#[derive(Debug, Clone, Copy)]
struct PrimBox(obvhs::aabb::Aabb);

impl obvhs::Boundable for PrimBox {
    fn aabb(&self) -> obvhs::aabb::Aabb {
        self.0
    }
}

/// Triangle BVH with exact (f64, watertight) ray and closest-point queries.
#[derive(Debug, Clone)]
pub struct MeshBvh {
    cwbvh: CwBvh,
    /// Triangle corners in obvhs primitive order.
    tris: Vec<[DVec3; 3]>,
    /// Original triangle index per obvhs slot.
    ids: Vec<u32>,
    /// Normalisation: `q = (p − center) · scale`.
    center: DVec3,
    scale: f64,
    /// World bounds of the mesh padded by `PAD / scale`.
    padded_min: DVec3,
    padded_max: DVec3,
    bounds: Option<Aabb>,
    depth: usize,
    tree: AabbTree,
}

impl MeshBvh {
    /// Builds the BVH. The mesh must have finite positions and in-range indices
    /// ([`TriMesh::validate`] minus the non-empty requirement); an empty mesh gives a BVH that
    /// never hits.
    pub fn build(mesh: &TriMesh) -> Result<Self, crate::MeshValidationError> {
        if let Err(e) = mesh.validate() {
            if e != crate::MeshValidationError::NoTriangles {
                return Err(e);
            }
        }
        let tree = AabbTree::build(mesh);
        let bounds = Aabb::from_points(&mesh.positions);
        let n = mesh.indices.len();
        if n == 0 {
            return Ok(Self {
                cwbvh: CwBvh::default(),
                tris: Vec::new(),
                ids: Vec::new(),
                center: DVec3::ZERO,
                scale: 1.0,
                padded_min: DVec3::ZERO,
                padded_max: DVec3::ZERO,
                bounds,
                depth: 0,
                tree,
            });
        }
        // bounds of the referenced vertices only
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for t in 0..n {
            for v in mesh.triangle(t) {
                min = min.min(DVec3::from(v));
                max = max.max(DVec3::from(v));
            }
        }
        let center = 0.5 * (min + max);
        let extent = (max - min).max_element();
        // power of two: extent * scale in (512, 1024]
        let scale = if extent > 0.0 { 2f64.powi(10 - extent.log2().ceil() as i32) } else { 1.0 };
        let boxes: Vec<PrimBox> =
            (0..n).map(|t| PrimBox(prim_box(mesh.triangle(t).map(DVec3::from), center, scale))).collect();
        let cwbvh =
            obvhs::cwbvh::builder::build_cwbvh(&boxes, obvhs::BvhBuildParams::medium_build(), &mut Duration::default());
        let ids = cwbvh.primitive_indices.clone();
        let tris = ids.iter().map(|&i| mesh.triangle(i as usize).map(DVec3::from)).collect();
        let depth = cw_depth(&cwbvh);
        let pad_world = DVec3::splat(PAD / scale);
        Ok(Self {
            cwbvh,
            tris,
            ids,
            center,
            scale,
            padded_min: min - pad_world,
            padded_max: max + pad_world,
            bounds,
            depth,
            tree,
        })
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.tree.ids.len()
    }

    /// Bounding box of the mesh's vertices.
    pub fn bounds(&self) -> Option<Aabb> {
        self.bounds
    }

    /// A copy of the obvhs tree, to compare builds in tests.
    #[cfg(test)]
    pub(crate) fn cwbvh_fingerprint(&self) -> CwBvh {
        self.cwbvh.clone()
    }

    /// Depth of the CWBVH (number of node levels).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Clips the ray to the padded mesh box in f64: the node-traversal start `t0` and end.
    #[inline]
    fn clip(&self, o: DVec3, pd: &PreparedDir, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        pd.clip(o, self.padded_min, self.padded_max, tmin, tmax)
    }

    /// The normalisation and padded box, for [`crate::packet::ParallelBvh`].
    pub(crate) fn frame_parts(&self) -> (DVec3, f64, DVec3, DVec3) {
        (self.center, self.scale, self.padded_min, self.padded_max)
    }

    /// Triangle corners in obvhs slot order.
    pub(crate) fn triangles_slot_order(&self) -> &[[DVec3; 3]] {
        &self.tris
    }

    /// The padded, outward-rounded f32 box of slot `i` in the normalised frame, exactly as
    /// the CWBVH was built over.
    pub(crate) fn slot_box(&self, i: usize) -> ([f32; 3], [f32; 3]) {
        let c = self.tris[i];
        let b = prim_box(c, self.center, self.scale);
        (b.min.to_array(), b.max.to_array())
    }

    /// A binary BVH over the same triangles for bundles of parallel rays, whose answers are
    /// [`MeshBvh::any_hit_prepared`]'s ([`crate::packet`]; measured slower on the FIV bake's
    /// rays, see there).
    pub fn parallel_bvh(&self) -> crate::packet::ParallelBvh {
        crate::packet::ParallelBvh::build(self)
    }

    /// Runs the CWBVH traversal for the ray clipped to `[t0, t1]`, calling `prim(slot)` for
    /// every candidate primitive; `prim` may shrink the ray (a closer hit) or stop.
    #[inline]
    fn traverse<F>(&self, o: DVec3, pd: &PreparedDir, t0: f64, t1: f64, prim: F)
    where
        F: FnMut(usize) -> Step,
    {
        if self.depth < STACK_INLINE {
            let mut buf = [UVec2::ZERO; STACK_INLINE];
            self.traverse_with(&mut buf, o, pd, t0, t1, prim);
        } else {
            let mut buf = vec![UVec2::ZERO; self.depth + 2];
            self.traverse_with(&mut buf, o, pd, t0, t1, prim);
        }
    }

    #[inline]
    fn traverse_with<F>(&self, buf: &mut [UVec2], o: DVec3, pd: &PreparedDir, t0: f64, t1: f64, mut prim: F)
    where
        F: FnMut(usize) -> Step,
    {
        let len = pd.len;
        let (origin, tmax) = pd.node_start(o, t0, t1, self.center, self.scale);
        let mut ray = obvhs::ray::Ray { origin, direction: pd.dir32, inv_direction: pd.inv32, tmin: 0.0, tmax };
        // node-space cut-off for a world-space hit parameter t
        let cut = |t: f64| ((t - t0) * len * self.scale) as f32 * (1.0 + 1e-6) + 1e-3;
        let mut state = TraversalState {
            stack: SliceStack { data: buf, len: 0 },
            current_group: if self.cwbvh.nodes.is_empty() { UVec2::ZERO } else { uvec2(0, 0x8000_0000) },
            primitive_group: UVec2::ZERO,
            oct_inv4: pd.oct,
            primitive_id: 0,
            hitmask: 0,
        };
        let mut node;
        'traversal: {
            obvhs::traverse!(self.cwbvh, node, state, node.intersect_ray(&ray, state.oct_inv4), {
                match prim(state.primitive_id as usize) {
                    Step::Continue => {}
                    Step::Shrink(t) => ray.tmax = ray.tmax.min(cut(t)),
                    Step::Stop => break 'traversal,
                }
            });
        }
    }

    /// The closest hit in `[ray.tmin, ray.tmax]`; ties go to the smallest triangle index.
    /// `None` for a miss or an invalid ray (zero or non-finite direction, non-finite origin).
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let o = DVec3::from(ray.origin);
        let pd = PreparedDir::new(ray.direction)?;
        if !o.is_finite() {
            return None;
        }
        let kernel = pd.kernel.with_origin(o);
        let (t0, t1) = self.clip(o, &pd, ray.tmin, ray.tmax)?;
        let mut best: Option<Hit> = None;
        let mut best_t = ray.tmax;
        self.traverse(o, &pd, t0, t1, |slot| {
            let [a, b, c] = self.tris[slot];
            if let Some((t, b1, b2)) = kernel.intersect(a, b, c, ray.tmin, best_t) {
                let id = self.ids[slot];
                let better = match best {
                    None => true,
                    Some(h) => t < h.t || id < h.triangle,
                };
                if better {
                    best = Some(Hit { t, triangle: id, barycentric: [b1, b2] });
                    best_t = t;
                    return Step::Shrink(t);
                }
            }
            Step::Continue
        });
        best
    }

    /// Whether anything is hit in `[ray.tmin, ray.tmax]` (occlusion). Stops at the first hit.
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let Some(pd) = PreparedDir::new(ray.direction) else {
            return false;
        };
        let o = DVec3::from(ray.origin);
        if !o.is_finite() {
            return false;
        }
        let kernel = pd.kernel.with_origin(o);
        let Some((t0, t1)) = self.clip(o, &pd, ray.tmin, ray.tmax) else {
            return false;
        };
        let mut hit = false;
        self.traverse(o, &pd, t0, t1, |slot| {
            let [a, b, c] = self.tris[slot];
            if kernel.intersect(a, b, c, ray.tmin, ray.tmax).is_some() {
                hit = true;
                Step::Stop
            } else {
                Step::Continue
            }
        });
        hit
    }

    /// [`MeshBvh::closest_hit`] for each ray; `out.len()` must equal `rays.len()`.
    pub fn closest_hits(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "closest_hits: rays and out differ in length");
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.closest_hit(r);
        }
    }

    /// [`MeshBvh::any_hit`] for each ray; `out.len()` must equal `rays.len()`.
    pub fn any_hits(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "any_hits: rays and out differ in length");
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.any_hit(r);
        }
    }

    /// A traversal stack for [`MeshBvh::any_hit_prepared`] (one per thread, reused).
    pub fn traversal_stack(&self) -> TraversalStack {
        TraversalStack(vec![UVec2::ZERO; (self.depth + 2).max(STACK_INLINE)])
    }

    /// [`MeshBvh::any_hit`] of the ray `origin + t·d`, `t ∈ [tmin, tmax]`, for a direction
    /// prepared once ([`PreparedDir`]) and a caller-held stack: the same arithmetic, so the
    /// same answer bit for bit, without the per-ray divisions, normalisation and stack
    /// initialisation (for casting many rays along a few directions).
    pub fn any_hit_prepared(
        &self,
        origin: [f64; 3],
        pd: &PreparedDir,
        tmin: f64,
        tmax: f64,
        stack: &mut TraversalStack,
    ) -> bool {
        let o = DVec3::from(origin);
        if !o.is_finite() {
            return false;
        }
        let kernel = pd.kernel.with_origin(o);
        let Some((t0, t1)) = self.clip(o, pd, tmin, tmax) else {
            return false;
        };
        if stack.0.len() < self.depth + 2 {
            stack.0.resize(self.depth + 2, UVec2::ZERO);
        }
        let mut hit = false;
        self.traverse_with(&mut stack.0, o, pd, t0, t1, |slot| {
            let [a, b, c] = self.tris[slot];
            if kernel.intersect(a, b, c, tmin, tmax).is_some() {
                hit = true;
                Step::Stop
            } else {
                Step::Continue
            }
        });
        hit
    }

    /// The point of the surface nearest to `p` (`None` for an empty mesh or non-finite `p`).
    pub fn closest_point(&self, p: [f64; 3]) -> Option<ClosestPoint> {
        self.closest_point_within(p, f64::INFINITY)
    }

    /// Like [`MeshBvh::closest_point`], but only considers points within `max_distance`
    /// (faster when a bound is known).
    pub fn closest_point_within(&self, p: [f64; 3], max_distance: f64) -> Option<ClosestPoint> {
        let max_d2 = if max_distance.is_finite() { max_distance * max_distance } else { f64::INFINITY };
        self.tree.closest_point(DVec3::from(p), max_d2).map(|(d2, id, q)| ClosestPoint {
            point: q.to_array(),
            distance: d2.sqrt(),
            triangle: id,
        })
    }
}

/// A ray direction with everything the traversal derives from it computed once: the
/// watertight kernel's shear, the f64 inverse for clipping, the normalised f32 direction
/// with its inverse and octant for the node tests. Used by every ray query, so
/// [`MeshBvh::any_hit_prepared`] and [`MeshBvh::any_hit`] agree bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct PreparedDir {
    d: DVec3,
    inv: DVec3,
    len: f64,
    dir32: Vec3A,
    inv32: Vec3A,
    oct: u32,
    kernel: RayKernel,
}

impl PreparedDir {
    /// `None` for a zero or non-finite direction (need not be unit length).
    pub fn new(direction: [f64; 3]) -> Option<Self> {
        let d = DVec3::from(direction);
        let kernel = RayKernel::for_direction(d)?;
        let len = d.length();
        let dn = d / len;
        let fix = |x: f64| {
            let f = x as f32;
            if f.abs() < TINY_DIR { TINY_DIR } else { f }
        };
        let dir32 = Vec3A::new(fix(dn.x), fix(dn.y), fix(dn.z));
        let inv = DVec3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
        Some(Self { d, inv, len, dir32, inv32: Vec3A::ONE / dir32, oct: octant_inv4(dir32), kernel })
    }
}

impl PreparedDir {
    /// The f32 inverse of the normalised direction used by the node tests.
    pub(crate) fn inv32(&self) -> Vec3A {
        self.inv32
    }

    /// The watertight kernel's direction part.
    pub(crate) fn kernel(&self) -> RayKernel {
        self.kernel
    }

    /// Clips the ray `o + t·d`, `t ∈ [tmin, tmax]`, to the box `[lo, hi]` in f64: the
    /// node-traversal start `t0` and end.
    #[inline]
    pub(crate) fn clip(&self, o: DVec3, lo: DVec3, hi: DVec3, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        let d = self.d;
        let mut t0 = tmin;
        let mut t1 = tmax;
        for k in 0..3 {
            if d[k] == 0.0 {
                if o[k] < lo[k] || o[k] > hi[k] {
                    return None;
                }
                continue;
            }
            let inv = self.inv[k];
            let (a, b) = {
                let a = (lo[k] - o[k]) * inv;
                let b = (hi[k] - o[k]) * inv;
                if a <= b { (a, b) } else { (b, a) }
            };
            t0 = t0.max(a);
            t1 = t1.min(b);
        }
        if t0 <= t1 && t0.is_finite() && t1.is_finite() { Some((t0, t1)) } else { None }
    }

    /// The node-space (normalised frame, unit f32 direction) start point of the clipped ray
    /// `[t0, t1]` and the node-space range end that the node tests accept (padded).
    #[inline]
    pub(crate) fn node_start(&self, o: DVec3, t0: f64, t1: f64, center: DVec3, scale: f64) -> (Vec3A, f32) {
        let start = (o + t0 * self.d - center) * scale;
        let span = ((t1 - t0) * self.len * scale) as f32;
        (Vec3A::new(start.x as f32, start.y as f32, start.z as f32), span.next_up() * (1.0 + 1e-6) + PAD as f32)
    }
}

/// The padded (by [`PAD`]) f32 box of a triangle in the normalised frame, rounded outwards.
fn prim_box(c: [DVec3; 3], center: DVec3, scale: f64) -> obvhs::aabb::Aabb {
    let to_f32_down = |x: f64| {
        let f = x as f32;
        if (f as f64) > x { f.next_down() } else { f }
    };
    let to_f32_up = |x: f64| {
        let f = x as f32;
        if (f as f64) < x { f.next_up() } else { f }
    };
    let lo = (c[0].min(c[1]).min(c[2]) - center) * scale - DVec3::splat(PAD);
    let hi = (c[0].max(c[1]).max(c[2]) - center) * scale + DVec3::splat(PAD);
    obvhs::aabb::Aabb::new(
        Vec3A::new(to_f32_down(lo.x), to_f32_down(lo.y), to_f32_down(lo.z)),
        Vec3A::new(to_f32_up(hi.x), to_f32_up(hi.y), to_f32_up(hi.z)),
    )
}

/// Scratch stack for [`MeshBvh::any_hit_prepared`].
#[derive(Debug, Clone)]
pub struct TraversalStack(Vec<UVec2>);

/// What the primitive callback asks the traversal to do.
enum Step {
    Continue,
    /// A closer hit at world parameter `t`: cull nodes beyond it.
    Shrink(f64),
    Stop,
}

/// Same encoding as obvhs' private `ray_get_octant_inv4`.
#[inline]
fn octant_inv4(dir: Vec3A) -> u32 {
    (if dir.x < 0.0 { 0 } else { 0x0404_0404 })
        | (if dir.y < 0.0 { 0 } else { 0x0202_0202 })
        | (if dir.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// The traversal state the `obvhs::traverse!` macro expects (fields by name).
struct TraversalState<'a> {
    stack: SliceStack<'a>,
    current_group: UVec2,
    primitive_group: UVec2,
    oct_inv4: u32,
    primitive_id: u32,
    hitmask: u32,
}

/// A stack over caller-provided storage, sized from the measured tree depth (never overflows).
struct SliceStack<'a> {
    data: &'a mut [UVec2],
    len: usize,
}

impl FastStack<UVec2> for SliceStack<'_> {
    #[inline(always)]
    fn push(&mut self, v: UVec2) {
        self.data[self.len] = v;
        self.len += 1;
    }
    #[inline(always)]
    fn pop_fast(&mut self) -> UVec2 {
        self.len -= 1;
        self.data[self.len]
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<UVec2> {
        if self.len == 0 { None } else { Some(self.pop_fast()) }
    }
    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.len == 0
    }
    #[inline(always)]
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// Number of node levels of a CWBVH (children of node `i` in slot `s`, for inner children,
/// are at `child_base_idx + popcount(imask & ((1 << s) − 1))`).
fn cw_depth(bvh: &CwBvh) -> usize {
    if bvh.nodes.is_empty() {
        return 0;
    }
    let mut max = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        max = max.max(d);
        let node = &bvh.nodes[i];
        for slot in 0..8u32 {
            if node.imask & (1 << slot) != 0 {
                let rel = (node.imask as u32 & ((1u32 << slot) - 1)).count_ones();
                stack.push(((node.child_base_idx + rel) as usize, d + 1));
            }
        }
    }
    max
}

/// Reference closest hit over all triangles (same kernel and tie rule as [`MeshBvh`]).
pub fn closest_hit_brute_force(mesh: &TriMesh, ray: &Ray) -> Option<Hit> {
    let kernel = RayKernel::new(DVec3::from(ray.origin), DVec3::from(ray.direction))?;
    let mut best: Option<Hit> = None;
    let mut best_t = ray.tmax;
    for t in 0..mesh.indices.len() {
        let [a, b, c] = mesh.triangle(t).map(DVec3::from);
        if let Some((th, b1, b2)) = kernel.intersect(a, b, c, ray.tmin, best_t) {
            if best.is_none_or(|h| th < h.t) {
                best = Some(Hit { t: th, triangle: t as u32, barycentric: [b1, b2] });
                best_t = th;
            }
        }
    }
    best
}

/// Reference any-hit over all triangles.
pub fn any_hit_brute_force(mesh: &TriMesh, ray: &Ray) -> bool {
    let Some(kernel) = RayKernel::new(DVec3::from(ray.origin), DVec3::from(ray.direction)) else {
        return false;
    };
    (0..mesh.indices.len()).any(|t| {
        let [a, b, c] = mesh.triangle(t).map(DVec3::from);
        kernel.intersect(a, b, c, ray.tmin, ray.tmax).is_some()
    })
}

/// Reference closest point over all triangles.
pub fn closest_point_brute_force(mesh: &TriMesh, p: [f64; 3]) -> Option<ClosestPoint> {
    let q = DVec3::from(p);
    let mut best: Option<ClosestPoint> = None;
    for t in 0..mesh.indices.len() {
        let [a, b, c] = mesh.triangle(t).map(DVec3::from);
        let x = crate::kernels::closest_point_on_triangle(q, a, b, c);
        let d = (x - q).length();
        if best.is_none_or(|bp| d < bp.distance) {
            best = Some(ClosestPoint { point: x.to_array(), distance: d, triangle: t as u32 });
        }
    }
    best
}
