//! DRT clutter (MRT thesis ch. 5): objects placed inside a level's blocks, their texels, the
//! constant-per-chart radiance basis (§5.3.2) and ray queries against them.
//!
//! # Placement
//! A clutter instance is a box or a triangle mesh in its own frame, placed in the world by
//! `x ↦ T + R(s·x)`: uniform scale `s`, rotation `R` (a unit quaternion `[x, y, z, w]`, or a
//! turn about +Y), translation `T` (world units, the level's frame). A box of size
//! `(sx, sy, sz)` spans `[−sx/2, sx/2] × [0, sy] × [−sz/2, sz/2]` in its frame: it stands on its
//! origin, so `translate` is the centre of its footprint. `faces = "no-bottom"` leaves out the
//! `−y` face (the thesis's five-faced pillars, which stand on the floor).
//!
//! # Texels and charts
//! Radiance on clutter is represented per texel (the direct light an engine computes, and the
//! indirect light `C_b b` DRT returns). Texels are grouped in **charts**; the clutter basis has
//! one function per chart, constant over it and orthonormal over the texels: `B[t, j] =
//! 1/√m_j` on the `m_j` texels of chart `j` (§5.3.2: "constant radiance over each clutter mesh
//! face"), so `T_d→c = Bᵀ` and `c_j = Σ_{t∈j} l_t/√m_j`.
//! - Boxes: one chart per face, `res × res` texels on it (§5.4.4: 16²), faces in the order
//!   −x, +x, −y, +y, −z, +z, each row-major (`j` then `i`) with outward normal `u × v`:
//!   −x: u = +z, v = +y; +x: u = −z, v = +y; −y: u = +x, v = +z; +y: u = +z, v = +x;
//!   −z: u = −x, v = +y; +z: u = +x, v = +y (the corner where `(i, j) = (0, 0)` starts is the
//!   one the two axes start from). Texel `(i, j)` is centred at `(i+½)/res, (j+½)/res`.
//! - Meshes: an automatic box-projection parameterisation (documented in docs/drt.md): every
//!   triangle joins the chart of the axis its normal is closest to (±x, ±y, ±z); a chart is
//!   rasterised in its axis plane on a square grid of spacing `h = (largest extent)/res`; each
//!   grid-cell centre covered by a triangle of the chart is a texel at the point of that
//!   triangle above it (several surfaces above one cell give one texel each, in depth order:
//!   the texel's `layer`).
//! - Meshes with glTF `TEXCOORD_1` (lightmap UVs, [`ClutterShape::Lightmapped`]): one chart
//!   per UV island, texels on the `N × N` atlas cells the islands cover (`layer` 0, `(i, j)`
//!   the cell, `N` = `lightmap_res` or [`lightmap_res`]); an island covering no cell centre
//!   gets one texel with `layer` 1. Overlapping islands are an error.
//!
//! # Rays
//! All instances' triangles, placed in the world, go into one BVH (`geometry`'s exact,
//! watertight f64 ray queries). A hit reports the chart of the triangle and whether the ray
//! met its front (outward) side; a back-side hit only happens from inside an object (or
//! through the open bottom of a five-faced box) and carries no light.

use crate::TransportError;
use penumbra_geometry::{MeshBvh, Ray, TriMesh};

/// Box faces of a clutter box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxFaces {
    /// All six faces.
    All,
    /// Five faces: no `−y` (bottom) face.
    NoBottom,
}

/// The geometry of one clutter instance, in its own frame.
#[derive(Debug, Clone)]
pub enum ClutterShape {
    /// A box standing on its origin (module docs).
    Box {
        /// Size along x, y, z.
        size: [f64; 3],
        /// Which faces.
        faces: BoxFaces,
    },
    /// A triangle mesh (outward winding), in its own frame.
    Mesh(TriMesh),
    /// A triangle mesh with lightmap UVs (glTF `TEXCOORD_1`, one per vertex, in `[0, 1]²`):
    /// its charts are the UV islands, its texels the atlas's `res × res` cells (module docs).
    Lightmapped {
        /// The mesh (outward winding), in its own frame.
        mesh: TriMesh,
        /// UV per vertex.
        uv: Vec<[f64; 2]>,
        /// Atlas texels per edge; `None` picks the box-projection's texel density.
        res: Option<usize>,
    },
}

/// One clutter instance as given by the user.
#[derive(Debug, Clone)]
pub struct ClutterSpec {
    /// A name for messages and reports.
    pub name: String,
    /// Geometry.
    pub shape: ClutterShape,
    /// World translation.
    pub translate: [f64; 3],
    /// Rotation, unit quaternion `[x, y, z, w]`.
    pub rotate: [f64; 4],
    /// Uniform scale (> 0).
    pub scale: f64,
    /// Diffuse albedo per channel, `[0, 1)`.
    pub albedo: [f64; 3],
}

/// A quaternion `[x, y, z, w]` for a turn of `deg` degrees about +Y.
pub fn quat_y(deg: f64) -> [f64; 4] {
    let h = 0.5 * deg.to_radians();
    [0.0, h.sin(), 0.0, h.cos()]
}

/// `q` applied to `v` (`q` unit).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [x, y, z, w] = q;
    // t = 2 (q.xyz × v); v' = v + w t + q.xyz × t
    let t = [2.0 * (y * v[2] - z * v[1]), 2.0 * (z * v[0] - x * v[2]), 2.0 * (x * v[1] - y * v[0])];
    [
        v[0] + w * t[0] + (y * t[2] - z * t[1]),
        v[1] + w * t[1] + (z * t[0] - x * t[2]),
        v[2] + w * t[2] + (x * t[1] - y * t[0]),
    ]
}

impl ClutterSpec {
    /// World point of a point of the instance's frame.
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        let r = rotate(self.rotate, [p[0] * self.scale, p[1] * self.scale, p[2] * self.scale]);
        [r[0] + self.translate[0], r[1] + self.translate[1], r[2] + self.translate[2]]
    }

    /// World direction of a direction of the instance's frame (rotation only).
    pub fn dir_to_world(&self, d: [f64; 3]) -> [f64; 3] {
        rotate(self.rotate, d)
    }

    fn validate(&self, index: usize) -> Result<[f64; 4], TransportError> {
        let bad = |m: String| Err(TransportError::Param(format!("clutter {index} ({}): {m}", self.name)));
        if !self.translate.iter().all(|x| x.is_finite()) {
            return bad(format!("translate {:?} is not finite", self.translate));
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return bad(format!("scale {} is out of range (allowed: > 0)", self.scale));
        }
        let n2: f64 = self.rotate.iter().map(|x| x * x).sum();
        if !(n2.is_finite() && (n2.sqrt() - 1.0).abs() < 1e-3) {
            return bad(format!("rotate {:?} is not a unit quaternion [x, y, z, w]", self.rotate));
        }
        if !self.albedo.iter().all(|a| (0.0..1.0).contains(a)) {
            return bad(format!("albedo {:?} is out of range (allowed: 0 <= a < 1 per channel)", self.albedo));
        }
        match &self.shape {
            ClutterShape::Box { size, .. } => {
                if !size.iter().all(|s| s.is_finite() && *s > 0.0) {
                    return bad(format!("box size {size:?} must be positive"));
                }
            }
            ClutterShape::Mesh(m) => {
                m.validate().map_err(|e| TransportError::Param(format!("clutter {index} ({}): {e}", self.name)))?;
            }
            ClutterShape::Lightmapped { mesh, uv, res } => {
                mesh.validate().map_err(|e| TransportError::Param(format!("clutter {index} ({}): {e}", self.name)))?;
                if uv.len() != mesh.positions.len() {
                    return bad(format!("{} TEXCOORD_1 values for {} vertices", uv.len(), mesh.positions.len()));
                }
                if let Some((v, w)) =
                    uv.iter().enumerate().find(|(_, w)| !w.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)))
                {
                    return bad(format!("TEXCOORD_1 of vertex {v} is {w:?}, outside [0, 1]² (lightmap UVs)"));
                }
                if let Some(r) = res
                    && !(2..=MAX_LIGHTMAP_RES).contains(r)
                {
                    return bad(format!("lightmap_res {r} is out of range (allowed: 2..={MAX_LIGHTMAP_RES})"));
                }
            }
        }
        let n = n2.sqrt();
        Ok(self.rotate.map(|x| x / n))
    }
}

/// One chart: a run of texels of one instance with one basis function.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chart {
    /// Instance.
    pub instance: usize,
    /// First texel (global clutter texel index).
    pub first: usize,
    /// Texels.
    pub count: usize,
    /// Albedo of the chart's surface per channel.
    pub albedo: [f64; 3],
}

/// One clutter texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClutterTexel {
    /// World position (on the surface).
    pub position: [f64; 3],
    /// World outward unit normal.
    pub normal: [f64; 3],
    /// Global chart index.
    pub chart: usize,
    /// Atlas coordinates within the chart: `layer`, `i`, `j` (module docs).
    pub uv: [u32; 3],
}

/// A ray hit on clutter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClutterHit {
    /// Distance along the (unit) ray.
    pub t: f64,
    /// Chart of the hit triangle.
    pub chart: usize,
    /// The ray met the outward side.
    pub front: bool,
    /// The hit point.
    pub point: [f64; 3],
    /// Outward normal of the hit triangle (unit).
    pub normal: [f64; 3],
}

/// Every clutter instance of a scene, placed, with texels, charts and a BVH.
#[derive(Debug, Clone)]
pub struct ClutterScene {
    /// The instances as given (rotations normalised).
    pub specs: Vec<ClutterSpec>,
    /// Texels of all instances, instance by instance, chart by chart.
    pub texels: Vec<ClutterTexel>,
    /// Charts, instance by instance.
    pub charts: Vec<Chart>,
    /// `[first texel, count]` per instance.
    pub instance_texels: Vec<[usize; 2]>,
    /// World bounds `[min, max]` per instance.
    pub bounds: Vec<[[f64; 3]; 2]>,
    /// All triangles in the world (for the BVH and the reference).
    pub mesh: TriMesh,
    tri_chart: Vec<u32>,
    tri_normal: Vec<[f64; 3]>,
    bvh: Option<MeshBvh>,
    /// Per instance: its own BVH and the global index of its first triangle.
    inst_bvh: Vec<(MeshBvh, usize)>,
    /// Per instance: the lightmap atlas edge of a lightmapped mesh (`TEXCOORD_1`), else 0.
    pub lightmap_res: Vec<usize>,
    /// Per instance: the analytic form of a box (ray queries without the BVH).
    inst_box: Vec<Option<BoxGeom>>,
    /// `bounds`, padded ([`pad_box`]).
    padded: Vec<[[f64; 3]; 2]>,
}

/// A placed clutter box in the form ray queries need: the ray goes into the box's frame and
/// meets the slabs there (the same surface as its triangles, without a BVH descent).
#[derive(Debug, Clone, Copy)]
struct BoxGeom {
    /// Inverse rotation (conjugate quaternion).
    inv_rot: [f64; 4],
    /// The world → box-frame linear map, `inv_scale · R(inv_rot)` as rows (the ray loops
    /// apply it to every ray that reaches the box's padded bounds).
    to_box: [[f64; 3]; 3],
    translate: [f64; 3],
    inv_scale: f64,
    size: [f64; 3],
    /// Per cube face: its rank among the present faces, `usize::MAX` when absent.
    slot: [usize; 6],
    /// Global chart of the first face's first chart.
    chart0: usize,
    /// Charts per face edge.
    sub: usize,
    /// World outward normal per face.
    normal: [[f64; 3]; 6],
}

impl BoxGeom {
    fn new(spec: &ClutterSpec, size: [f64; 3], faces: BoxFaces, sub: usize, chart0: usize) -> Self {
        let q = spec.rotate;
        let mut slot = [usize::MAX; 6];
        let mut normal = [[0.0; 3]; 6];
        let mut r = 0;
        for (f, n) in normal.iter_mut().enumerate() {
            let (_, u, v) = box_face(size, f);
            *n = normalize(spec.dir_to_world(normalize(cross(u, v))));
            if !(f == 2 && faces == BoxFaces::NoBottom) {
                slot[f] = r;
                r += 1;
            }
        }
        let inv_rot = [-q[0], -q[1], -q[2], q[3]];
        let inv_scale = 1.0 / spec.scale;
        let cols: [[f64; 3]; 3] =
            core::array::from_fn(|j| rotate(inv_rot, core::array::from_fn(|k| f64::from(u8::from(k == j)))));
        let to_box = core::array::from_fn(|i| core::array::from_fn(|j| cols[j][i] * inv_scale));
        Self { inv_rot, to_box, translate: spec.translate, inv_scale, size, slot, chart0, sub, normal }
    }

    /// The first surface the ray `o + t·d`, `t ∈ [tmin, tmax]`, meets: `(t, face)`. A ray
    /// that enters through the missing bottom meets the inside of the face it leaves by.
    fn hit(&self, o: [f64; 3], d: [f64; 3], tmin: f64, tmax: f64) -> Option<(f64, usize)> {
        let m = &self.to_box;
        let v = sub(o, self.translate);
        let ol: [f64; 3] = core::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2]);
        let dl: [f64; 3] = core::array::from_fn(|i| m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2]);
        let lo = [-0.5 * self.size[0], 0.0, -0.5 * self.size[2]];
        let hi = [0.5 * self.size[0], self.size[1], 0.5 * self.size[2]];
        let (mut tn, mut tf) = (f64::NEG_INFINITY, f64::INFINITY);
        let (mut fin, mut fout) = (usize::MAX, usize::MAX);
        for k in 0..3 {
            if dl[k] == 0.0 {
                if ol[k] < lo[k] || ol[k] > hi[k] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / dl[k];
            let (a, b) = ((lo[k] - ol[k]) * inv, (hi[k] - ol[k]) * inv);
            // entering through the low side when moving up the axis
            let (near, far, fnear, ffar) = if inv > 0.0 { (a, b, 2 * k, 2 * k + 1) } else { (b, a, 2 * k + 1, 2 * k) };
            if near > tn {
                tn = near;
                fin = fnear;
            }
            if far < tf {
                tf = far;
                fout = ffar;
            }
        }
        if tn > tf || tf < tmin || fout == usize::MAX {
            return None;
        }
        if tn >= tmin && fin != usize::MAX && self.slot[fin] != usize::MAX {
            return (tn <= tmax).then_some((tn, fin));
        }
        // inside the box, or entering through the missing face: the face it leaves by
        (self.slot[fout] != usize::MAX && tf <= tmax).then_some((tf, fout))
    }

    /// Global chart of the point `p` (world) on face `f`.
    fn chart(&self, p: [f64; 3], f: usize) -> usize {
        let pl = rotate(self.inv_rot, sub(p, self.translate)).map(|x| x * self.inv_scale);
        let (o, u, v) = box_face(self.size, f);
        let w = sub(pl, o);
        let n = self.sub as f64;
        let cell = |e: [f64; 3]| ((dot(w, e) / dot(e, e) * n).floor().max(0.0) as usize).min(self.sub - 1);
        self.chart0 + self.slot[f] * self.sub * self.sub + cell(v) * self.sub + cell(u)
    }
}

/// [`slab`] on a box padded in advance ([`pad_box`]) with the direction's reciprocals
/// `inv = 1/d` (±∞ for a zero component: the NaN of `0·∞` fails both comparisons below only
/// when the origin lies exactly on a face plane, which the padding keeps away from).
#[inline]
pub(crate) fn slab_inv(&[lo, hi]: &[[f64; 3]; 2], o: [f64; 3], inv: [f64; 3], mut t0: f64, mut t1: f64) -> bool {
    for k in 0..3 {
        let (a, b) = ((lo[k] - o[k]) * inv[k], (hi[k] - o[k]) * inv[k]);
        let (a, b) = if a > b { (b, a) } else { (a, b) };
        // a NaN (origin on a padded plane with a zero component) keeps the interval open
        t0 = if a > t0 { a } else { t0 };
        t1 = if b < t1 { b } else { t1 };
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// The box `[lo, hi]` padded by a hair ([`slab`]'s padding).
fn pad_box(&[lo, hi]: &[[f64; 3]; 2]) -> [[f64; 3]; 2] {
    let pad = |k: usize| 1e-9 * (1.0 + lo[k].abs().max(hi[k].abs()));
    [core::array::from_fn(|k| lo[k] - pad(k)), core::array::from_fn(|k| hi[k] + pad(k))]
}

/// Whether the ray `o + t·d`, `t ∈ [t0, t1]`, meets the box `[lo, hi]` (padded by a hair so
/// that a hit on a face is never missed by rounding).
#[inline]
fn slab(&[lo, hi]: &[[f64; 3]; 2], o: [f64; 3], d: [f64; 3], mut t0: f64, mut t1: f64) -> bool {
    for k in 0..3 {
        let pad = 1e-9 * (1.0 + lo[k].abs().max(hi[k].abs()));
        let (l, h) = (lo[k] - pad, hi[k] + pad);
        if d[k] == 0.0 {
            if o[k] < l || o[k] > h {
                return false;
            }
            continue;
        }
        let inv = 1.0 / d[k];
        let (mut a, mut b) = ((l - o[k]) * inv, (h - o[k]) * inv);
        if a > b {
            core::mem::swap(&mut a, &mut b);
        }
        t0 = t0.max(a);
        t1 = t1.min(b);
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// One face of a clutter box: outward normal's face index (cube order), origin corner, u and v
/// edge vectors (their lengths are the face's size).
fn box_face(size: [f64; 3], f: usize) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let [sx, sy, sz] = size;
    let (hx, hz) = (0.5 * sx, 0.5 * sz);
    match f {
        0 => ([-hx, 0.0, -hz], [0.0, 0.0, sz], [0.0, sy, 0.0]),
        1 => ([hx, 0.0, hz], [0.0, 0.0, -sz], [0.0, sy, 0.0]),
        2 => ([-hx, 0.0, -hz], [sx, 0.0, 0.0], [0.0, 0.0, sz]),
        3 => ([-hx, sy, -hz], [0.0, 0.0, sz], [sx, 0.0, 0.0]),
        4 => ([hx, 0.0, -hz], [-sx, 0.0, 0.0], [0.0, sy, 0.0]),
        _ => ([-hx, 0.0, hz], [sx, 0.0, 0.0], [0.0, sy, 0.0]),
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    if l > 0.0 { a.map(|x| x / l) } else { a }
}

/// Per-instance geometry before merging: triangles (world), their local chart, texels.
struct Built {
    tris: Vec<[[f64; 3]; 3]>,
    tri_chart: Vec<usize>,
    charts: Vec<Vec<ClutterTexel>>,
}

fn build_box(spec: &ClutterSpec, size: [f64; 3], faces: BoxFaces, res: usize, sub: usize) -> Built {
    let mut b = Built { tris: Vec::new(), tri_chart: Vec::new(), charts: Vec::new() };
    let k = res / sub;
    for f in 0..6 {
        if f == 2 && faces == BoxFaces::NoBottom {
            continue;
        }
        let (o, u, v) = box_face(size, f);
        let c =
            |a: f64, bb: f64| [o[0] + a * u[0] + bb * v[0], o[1] + a * u[1] + bb * v[1], o[2] + a * u[2] + bb * v[2]];
        let w = |p: [f64; 3]| spec.to_world(p);
        let n = normalize(spec.dir_to_world(normalize(cross(u, v))));
        // `sub × sub` charts per face (1: the thesis's face constants), each a square of
        // `k × k` texels with its own two triangles
        for sj in 0..sub {
            for si in 0..sub {
                let chart = b.charts.len();
                let (a0, a1) = (si as f64 / sub as f64, (si + 1) as f64 / sub as f64);
                let (b0, b1) = (sj as f64 / sub as f64, (sj + 1) as f64 / sub as f64);
                let (p00, p10, p11, p01) = (w(c(a0, b0)), w(c(a1, b0)), w(c(a1, b1)), w(c(a0, b1)));
                b.tris.push([p00, p10, p11]);
                b.tris.push([p00, p11, p01]);
                b.tri_chart.extend([chart, chart]);
                let mut texels = Vec::with_capacity(k * k);
                for j in sj * k..(sj + 1) * k {
                    for i in si * k..(si + 1) * k {
                        let p = c((i as f64 + 0.5) / res as f64, (j as f64 + 0.5) / res as f64);
                        texels.push(ClutterTexel { position: w(p), normal: n, chart: 0, uv: [0, i as u32, j as u32] });
                    }
                }
                b.charts.push(texels);
            }
        }
    }
    b
}

/// Largest lightmap atlas edge (texels).
pub const MAX_LIGHTMAP_RES: usize = 4096;

/// The atlas edge a lightmapped mesh gets without `lightmap_res`: the box projection's
/// texel spacing `h = (largest extent)/res` in the world, through the mean ratio of world to
/// UV area: `N = ⌈√(A_world/A_uv)/h⌉`, clamped to `2..=MAX_LIGHTMAP_RES`.
pub fn lightmap_res(spec: &ClutterSpec, mesh: &TriMesh, uv: &[[f64; 2]], res: usize) -> usize {
    let (mut aw, mut au) = (0.0, 0.0);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (t, ix) in mesh.indices.iter().enumerate() {
        let w = mesh.triangle(t).map(|p| spec.to_world(p));
        for p in &w {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let n = cross(sub(w[1], w[0]), sub(w[2], w[0]));
        aw += 0.5 * dot(n, n).sqrt();
        let [a, b, c] = ix.map(|v| uv[v as usize]);
        au += 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs();
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
    if !(au > 0.0 && extent > 0.0) {
        return 2;
    }
    let h = extent / res as f64;
    let n = ((aw / au).sqrt() / h).ceil();
    (n as usize).clamp(2, MAX_LIGHTMAP_RES)
}

/// A covered atlas cell: (cell, island, triangle, strictly inside, point, normal).
type UvHit = (usize, usize, usize, bool, [f64; 3], [f64; 3]);

/// Lightmap texels of a mesh (module docs): charts are the UV islands (triangles joined
/// through shared vertices; exporters split vertices at UV seams), texel `(i, j)` is the
/// atlas cell centred at `((i+½)/N, (j+½)/N)`, placed at the point of the triangle that
/// covers it (barycentric in UV, closed edges; a centre two triangles of one island share
/// is kept once). Two islands over one centre are an error: lightmap UVs must not overlap.
/// An island too small to cover a cell centre gets one texel at the centroid of its largest
/// triangle, with `layer` 1 and the cell of that centroid's UV (it has no atlas cell of its
/// own; an engine lights the island with that one value).
fn build_lightmapped(
    spec: &ClutterSpec,
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    n: usize,
    index: usize,
) -> Result<Built, TransportError> {
    // islands: union-find over vertices
    let mut parent: Vec<usize> = (0..mesh.positions.len()).collect();
    fn root(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for t in &mesh.indices {
        let r0 = root(&mut parent, t[0] as usize);
        for &v in &t[1..] {
            let r = root(&mut parent, v as usize);
            if r != r0 {
                let (a, b) = (r.min(r0), r.max(r0));
                parent[b] = a;
            }
        }
    }
    let world: Vec<[[f64; 3]; 3]> =
        (0..mesh.triangle_count()).map(|t| mesh.triangle(t).map(|p| spec.to_world(p))).collect();
    // island of each triangle, numbered in order of first appearance
    let mut island_of_root = std::collections::BTreeMap::new();
    let mut island = Vec::with_capacity(world.len());
    for t in &mesh.indices {
        let r = root(&mut parent, t[0] as usize);
        let next = island_of_root.len();
        island.push(*island_of_root.entry(r).or_insert(next));
    }
    let nf = n as f64;
    let mut hits: Vec<UvHit> = Vec::new();
    for (t, ix) in mesh.indices.iter().enumerate() {
        let tri = world[t];
        let nn = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        if dot(nn, nn) == 0.0 {
            continue;
        }
        let nrm = normalize(nn);
        let q = ix.map(|v| uv[v as usize]);
        let (mut a0, mut a1, mut b0, mut b1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for v in &q {
            a0 = a0.min(v[0]);
            a1 = a1.max(v[0]);
            b0 = b0.min(v[1]);
            b1 = b1.max(v[1]);
        }
        let i0 = ((a0 * nf - 0.5).floor().max(0.0)) as usize;
        let i1 = ((a1 * nf - 0.5).ceil().max(0.0) as usize).min(n - 1);
        let j0 = ((b0 * nf - 0.5).floor().max(0.0)) as usize;
        let j1 = ((b1 * nf - 0.5).ceil().max(0.0) as usize).min(n - 1);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let (x, y) = ((i as f64 + 0.5) / nf, (j as f64 + 0.5) / nf);
                let e = |v0: [f64; 2], v1: [f64; 2]| (v1[0] - v0[0]) * (y - v0[1]) - (v1[1] - v0[1]) * (x - v0[0]);
                let (w0, w1, w2) = (e(q[1], q[2]), e(q[2], q[0]), e(q[0], q[1]));
                let area = w0 + w1 + w2;
                if area == 0.0 {
                    continue;
                }
                let (l0, l1, l2) = (w0 / area, w1 / area, w2 / area);
                if l0 < 0.0 || l1 < 0.0 || l2 < 0.0 {
                    continue;
                }
                let pos: [f64; 3] = core::array::from_fn(|k| l0 * tri[0][k] + l1 * tri[1][k] + l2 * tri[2][k]);
                let strict = l0 > 1e-9 && l1 > 1e-9 && l2 > 1e-9;
                hits.push((j * n + i, island[t], t, strict, pos, nrm));
            }
        }
    }
    hits.sort_by(|a, b| a.0.cmp(&b.0).then(a.2.cmp(&b.2)));
    let mut charts: Vec<Vec<ClutterTexel>> = vec![Vec::new(); island_of_root.len()];
    let mut k = 0;
    while k < hits.len() {
        let cell = hits[k].0;
        let first = hits[k];
        let mut e = k;
        while e < hits.len() && hits[e].0 == cell {
            let h = hits[e];
            if h.1 != first.1 && (h.3 || first.3) {
                let (i, j) = (cell % n, cell / n);
                return Err(TransportError::Param(format!(
                    "clutter {index} ({}): TEXCOORD_1 overlaps: lightmap texel ({i}, {j}) of {n}² lies in triangles                      {} and {} of two UV islands (lightmap UVs must not overlap)",
                    spec.name, first.2, h.2
                )));
            }
            e += 1;
        }
        charts[first.1].push(ClutterTexel {
            position: first.4,
            normal: first.5,
            chart: 0,
            uv: [0, (cell % n) as u32, (cell / n) as u32],
        });
        k = e;
    }
    // islands without a cell centre: one texel at their largest triangle's centroid
    let mut largest: Vec<Option<(f64, usize)>> = vec![None; charts.len()];
    for (t, tri) in world.iter().enumerate() {
        let nn = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        let a = dot(nn, nn);
        if a > 0.0 && largest[island[t]].is_none_or(|(b, _)| a > b) {
            largest[island[t]] = Some((a, t));
        }
    }
    for (c, l) in charts.iter_mut().zip(&largest) {
        if let (true, Some((_, t))) = (c.is_empty(), l) {
            let tri = world[*t];
            let q = mesh.indices[*t].map(|v| uv[v as usize]);
            let cell =
                |k: usize| (((q[0][k] + q[1][k] + q[2][k]) / 3.0 * nf).floor().max(0.0) as u32).min(n as u32 - 1);
            c.push(ClutterTexel {
                position: core::array::from_fn(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0),
                normal: normalize(cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))),
                chart: 0,
                uv: [1, cell(0), cell(1)],
            });
        }
    }
    let mut b = Built { tris: Vec::new(), tri_chart: Vec::new(), charts };
    for (t, tri) in world.into_iter().enumerate() {
        let nn = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        if dot(nn, nn) > 0.0 {
            b.tris.push(tri);
            b.tri_chart.push(island[t]);
        }
    }
    Ok(b)
}

/// A covered cell of a chart's grid: (cell, unused, depth along the axis, point, normal).
type CellHit = (usize, usize, f64, [f64; 3], [f64; 3]);

/// Box-projection texels of a mesh (module docs).
fn build_mesh(spec: &ClutterSpec, mesh: &TriMesh, res: usize) -> Built {
    let world: Vec<[[f64; 3]; 3]> =
        (0..mesh.triangle_count()).map(|t| mesh.triangle(t).map(|p| spec.to_world(p))).collect();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for t in &world {
        for p in t {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
    let h = extent / res as f64;
    let mut axis_of = Vec::with_capacity(world.len());
    for t in &world {
        let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        let a = (0..3).max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs())).unwrap_or(0);
        // zero-area triangles have no chart (they carry no light and are skipped by the BVH)
        let f = if dot(n, n) > 0.0 { Some(2 * a + usize::from(n[a] > 0.0)) } else { None };
        axis_of.push(f);
    }
    let mut b = Built { tris: Vec::new(), tri_chart: Vec::new(), charts: Vec::new() };
    let mut chart_of_face = [usize::MAX; 6];
    for f in 0..6 {
        let (a, _) = (f / 2, f % 2);
        let (p, q) = ((a + 1) % 3, (a + 2) % 3);
        let members: Vec<usize> = (0..world.len()).filter(|&t| axis_of[t] == Some(f)).collect();
        if members.is_empty() {
            continue;
        }
        let (np, nq) = (((hi[p] - lo[p]) / h).ceil().max(1.0) as usize, ((hi[q] - lo[q]) / h).ceil().max(1.0) as usize);
        // (cell, depth, position, normal) of every covered cell centre
        let mut hits: Vec<CellHit> = Vec::new();
        for &t in &members {
            let tri = world[t];
            let n = normalize(cross(sub(tri[1], tri[0]), sub(tri[2], tri[0])));
            let (mut a0, mut a1, mut b0, mut b1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for v in &tri {
                a0 = a0.min(v[p]);
                a1 = a1.max(v[p]);
                b0 = b0.min(v[q]);
                b1 = b1.max(v[q]);
            }
            let i0 = (((a0 - lo[p]) / h - 0.5).floor().max(0.0)) as usize;
            let i1 = ((((a1 - lo[p]) / h - 0.5).ceil()) as usize).min(np - 1);
            let j0 = (((b0 - lo[q]) / h - 0.5).floor().max(0.0)) as usize;
            let j1 = ((((b1 - lo[q]) / h - 0.5).ceil()) as usize).min(nq - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let (x, y) = (lo[p] + (i as f64 + 0.5) * h, lo[q] + (j as f64 + 0.5) * h);
                    // 2D barycentrics in the (p, q) plane; closed edges: a centre on an edge two
                    // triangles share is found twice and merged below (same depth)
                    let e = |v0: [f64; 3], v1: [f64; 3]| (v1[p] - v0[p]) * (y - v0[q]) - (v1[q] - v0[q]) * (x - v0[p]);
                    let (w0, w1, w2) = (e(tri[1], tri[2]), e(tri[2], tri[0]), e(tri[0], tri[1]));
                    let area = w0 + w1 + w2;
                    if area == 0.0 {
                        continue;
                    }
                    let inside = |w: f64| if area > 0.0 { w >= 0.0 } else { w <= 0.0 };
                    if !(inside(w0) && inside(w1) && inside(w2)) {
                        continue;
                    }
                    let (l0, l1, l2) = (w0 / area, w1 / area, w2 / area);
                    let pos: [f64; 3] = core::array::from_fn(|k| l0 * tri[0][k] + l1 * tri[1][k] + l2 * tri[2][k]);
                    hits.push((j * np + i, 0, pos[a], pos, n));
                }
            }
        }
        hits.sort_by(|x, y| x.0.cmp(&y.0).then(x.2.total_cmp(&y.2)));
        let chart = b.charts.len();
        chart_of_face[f] = chart;
        let mut texels: Vec<ClutterTexel> = Vec::new();
        let mut k = 0;
        while k < hits.len() {
            let cell = hits[k].0;
            let mut layer = 0u32;
            let mut last_depth = f64::NEG_INFINITY;
            while k < hits.len() && hits[k].0 == cell {
                // one texel per surface: hits closer than h/2 in depth are the same surface
                // (a centre on an edge shared by two triangles)
                if hits[k].2 - last_depth > 0.5 * h {
                    let (_, _, d, pos, n) = hits[k];
                    texels.push(ClutterTexel {
                        position: pos,
                        normal: n,
                        chart: 0,
                        uv: [layer, (cell % np) as u32, (cell / np) as u32],
                    });
                    layer += 1;
                    last_depth = d;
                }
                k += 1;
            }
        }
        b.charts.push(texels);
    }
    for (t, tri) in world.into_iter().enumerate() {
        if let Some(f) = axis_of[t] {
            b.tris.push(tri);
            b.tri_chart.push(chart_of_face[f]);
        }
    }
    b
}

impl ClutterScene {
    /// Places every instance; `res` texels per box-face edge / per mesh's largest extent.
    pub fn new(specs: &[ClutterSpec], res: usize) -> Result<Self, TransportError> {
        Self::with_basis(specs, res, 1)
    }

    /// [`ClutterScene::new`] with `sub × sub` charts per box face (`sub` divides `res`; 1 is
    /// the thesis's one constant per face).
    pub fn with_basis(specs: &[ClutterSpec], res: usize, per_face: usize) -> Result<Self, TransportError> {
        if !(2..=64).contains(&res) {
            return Err(TransportError::Param(format!("clutter_res {res} is out of range (allowed: 2..=64)")));
        }
        if per_face == 0 || res % per_face != 0 {
            return Err(TransportError::Param(format!(
                "clutter_basis_res {per_face} must divide clutter_res {res} (charts per box-face edge)"
            )));
        }
        let mut out_specs = Vec::with_capacity(specs.len());
        let mut texels = Vec::new();
        let mut charts = Vec::new();
        let mut instance_texels = Vec::new();
        let mut bounds = Vec::new();
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        let mut tri_chart = Vec::new();
        let mut tri_normal = Vec::new();
        let mut inst_bvh = Vec::new();
        let mut inst_box = Vec::new();
        let mut lightmap = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            let mut s = s.clone();
            s.rotate = s.validate(i)?;
            let built = match &s.shape {
                ClutterShape::Box { size, faces } => build_box(&s, *size, *faces, res, per_face),
                ClutterShape::Mesh(m) => build_mesh(&s, m, res),
                ClutterShape::Lightmapped { mesh, uv, res: r } => {
                    let n = r.unwrap_or_else(|| lightmap_res(&s, mesh, uv, res));
                    lightmap.push(n);
                    build_lightmapped(&s, mesh, uv, n, i)?
                }
            };
            if !matches!(s.shape, ClutterShape::Lightmapped { .. }) {
                lightmap.push(0);
            }
            let first = texels.len();
            let chart0 = charts.len();
            inst_box.push(match &s.shape {
                ClutterShape::Box { size, faces } => Some(BoxGeom::new(&s, *size, *faces, per_face, chart0)),
                ClutterShape::Mesh(_) | ClutterShape::Lightmapped { .. } => None,
            });
            for ct in &built.charts {
                if ct.is_empty() {
                    continue;
                }
                let c = charts.len();
                charts.push(Chart { instance: i, first: texels.len(), count: ct.len(), albedo: s.albedo });
                texels.extend(ct.iter().map(|t| ClutterTexel { chart: c, ..*t }));
            }
            // local chart index → global (empty charts were skipped)
            let mut map = Vec::with_capacity(built.charts.len());
            let mut c = chart0;
            for ct in &built.charts {
                map.push(if ct.is_empty() { usize::MAX } else { c });
                if !ct.is_empty() {
                    c += 1;
                }
            }
            if texels.len() == first {
                return Err(TransportError::Param(format!(
                    "clutter {i} ({}): no texels (empty or degenerate mesh)",
                    s.name
                )));
            }
            instance_texels.push([first, texels.len() - first]);
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            let tri0 = indices.len();
            let own = TriMesh {
                positions: built.tris.iter().flatten().copied().collect(),
                indices: (0..built.tris.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
            };
            let ob =
                MeshBvh::build(&own).map_err(|e| TransportError::Param(format!("clutter {i} ({}): {e}", s.name)))?;
            inst_bvh.push((ob, tri0));
            for (tri, &lc) in built.tris.iter().zip(&built.tri_chart) {
                let base = positions.len() as u32;
                for p in tri {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                    positions.push(*p);
                }
                indices.push([base, base + 1, base + 2]);
                let g = map[lc];
                tri_chart.push(if g == usize::MAX { u32::MAX } else { g as u32 });
                tri_normal.push(normalize(cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))));
            }
            bounds.push([lo, hi]);
            out_specs.push(s);
        }
        let mesh = TriMesh { positions, indices };
        let padded = bounds.iter().map(pad_box).collect();
        let bvh = if mesh.indices.is_empty() {
            None
        } else {
            Some(MeshBvh::build(&mesh).map_err(|e| TransportError::Param(format!("clutter geometry: {e}")))?)
        };
        Ok(Self {
            specs: out_specs,
            texels,
            charts,
            instance_texels,
            bounds,
            mesh,
            tri_chart,
            tri_normal,
            bvh,
            inst_bvh,
            padded,
            inst_box,
            lightmap_res: lightmap,
        })
    }

    /// No clutter at all.
    pub fn empty() -> Self {
        let mesh = TriMesh { positions: Vec::new(), indices: Vec::new() };
        Self {
            specs: Vec::new(),
            texels: Vec::new(),
            charts: Vec::new(),
            instance_texels: Vec::new(),
            bounds: Vec::new(),
            mesh,
            tri_chart: Vec::new(),
            tri_normal: Vec::new(),
            bvh: None,
            inst_bvh: Vec::new(),
            inst_box: Vec::new(),
            padded: Vec::new(),
            lightmap_res: Vec::new(),
        }
    }

    /// Number of instances.
    pub fn len(&self) -> usize {
        self.specs.len()
    }

    /// Whether there is no clutter.
    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }

    /// The closest clutter hit along the unit ray `o + t·d`, `t ∈ (tmin, tmax)`.
    pub fn closest(&self, o: [f64; 3], d: [f64; 3], tmin: f64, tmax: f64) -> Option<ClutterHit> {
        // few instances: their boxes first (most rays miss every object; a slab test is far
        // cheaper than a BVH descent)
        if self.bounds.len() <= 32 && !self.bounds.iter().any(|b| slab(b, o, d, tmin, tmax)) {
            return None;
        }
        let h = self.bvh.as_ref()?.closest_hit(&Ray::new(o, d).with_range(tmin, tmax))?;
        let tri = h.triangle as usize;
        let n = self.tri_normal[tri];
        let c = self.tri_chart[tri];
        let point = [o[0] + h.t * d[0], o[1] + h.t * d[1], o[2] + h.t * d[2]];
        Some(ClutterHit {
            t: h.t,
            chart: if c == u32::MAX { usize::MAX } else { c as usize },
            front: dot(n, d) < 0.0 && c != u32::MAX,
            point,
            normal: n,
        })
    }

    /// The closest hit among the instances `insts` along the unit ray `o + t·d`,
    /// `t ∈ [tmin, tmax]` (each instance's box first, then its own BVH).
    pub fn closest_among(&self, insts: &[usize], o: [f64; 3], d: [f64; 3], tmin: f64, tmax: f64) -> Option<ClutterHit> {
        self.closest_among_except(insts, usize::MAX, o, d, tmin, tmax)
    }

    /// [`ClutterScene::closest_among`] without instance `skip` (a ray leaving a box's own
    /// surface outwards cannot meet that box again: it is convex, open bottom or not).
    pub fn closest_among_except(
        &self,
        insts: &[usize],
        skip: usize,
        o: [f64; 3],
        d: [f64; 3],
        tmin: f64,
        tmax: f64,
    ) -> Option<ClutterHit> {
        self.closest_among_except_inv(insts, skip, o, d, d.map(|x| 1.0 / x), tmin, tmax)
    }

    /// [`ClutterScene::closest_among_except`] with the direction's reciprocals `inv = 1/d`
    /// computed by the caller (once per ray, not once per block it crosses).
    #[allow(clippy::too_many_arguments)]
    pub fn closest_among_except_inv(
        &self,
        insts: &[usize],
        skip: usize,
        o: [f64; 3],
        d: [f64; 3],
        inv: [f64; 3],
        tmin: f64,
        tmax: f64,
    ) -> Option<ClutterHit> {
        self.closest_among_except_iter(insts.iter().copied(), skip, o, d, inv, tmin, tmax)
    }

    /// [`ClutterScene::closest_among_except_inv`] over instances in any order-preserving
    /// iterator (the DRT ray loops' pre-filtered candidates).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn closest_among_except_iter(
        &self,
        insts: impl Iterator<Item = usize>,
        skip: usize,
        o: [f64; 3],
        d: [f64; 3],
        inv: [f64; 3],
        tmin: f64,
        tmax: f64,
    ) -> Option<ClutterHit> {
        // (t, global triangle or usize::MAX for a box, instance, box face)
        let mut best: Option<(f64, usize, usize, usize)> = None;
        for i in insts {
            if i == skip {
                continue;
            }
            let hi = best.map_or(tmax, |b| b.0);
            if !slab_inv(&self.padded[i], o, inv, tmin, hi) {
                continue;
            }
            if let Some(bx) = &self.inst_box[i] {
                if let Some((t, f)) = bx.hit(o, d, tmin, hi)
                    && best.is_none_or(|b| t < b.0)
                {
                    best = Some((t, usize::MAX, i, f));
                }
                continue;
            }
            let (bvh, tri0) = &self.inst_bvh[i];
            if let Some(h) = bvh.closest_hit(&Ray::new(o, d).with_range(tmin, hi)) {
                let g = tri0 + h.triangle as usize;
                if best.is_none_or(|b| h.t < b.0 || (h.t == b.0 && g < b.1)) {
                    best = Some((h.t, g, i, 0));
                }
            }
        }
        let (t, tri, i, f) = best?;
        let point = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
        if tri == usize::MAX {
            let bx = self.inst_box[i].as_ref()?;
            let n = bx.normal[f];
            return Some(ClutterHit { t, chart: bx.chart(point, f), front: dot(n, d) < 0.0, point, normal: n });
        }
        let n = self.tri_normal[tri];
        let c = self.tri_chart[tri];
        Some(ClutterHit {
            t,
            chart: if c == u32::MAX { usize::MAX } else { c as usize },
            front: dot(n, d) < 0.0 && c != u32::MAX,
            point,
            normal: n,
        })
    }

    /// [`ClutterScene::closest_among`] through the instances' triangle BVHs only (the
    /// reference the analytic box queries are tested against).
    pub fn closest_among_triangles(
        &self,
        insts: &[usize],
        o: [f64; 3],
        d: [f64; 3],
        tmin: f64,
        tmax: f64,
    ) -> Option<ClutterHit> {
        let mut best: Option<(f64, usize)> = None;
        for &i in insts {
            let hi = best.map_or(tmax, |b| b.0);
            let (bvh, tri0) = &self.inst_bvh[i];
            if let Some(h) = bvh.closest_hit(&Ray::new(o, d).with_range(tmin, hi)) {
                let g = tri0 + h.triangle as usize;
                if best.is_none_or(|b| h.t < b.0 || (h.t == b.0 && g < b.1)) {
                    best = Some((h.t, g));
                }
            }
        }
        let (t, tri) = best?;
        let n = self.tri_normal[tri];
        let c = self.tri_chart[tri];
        Some(ClutterHit {
            t,
            chart: if c == u32::MAX { usize::MAX } else { c as usize },
            front: dot(n, d) < 0.0 && c != u32::MAX,
            point: [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]],
            normal: n,
        })
    }

    /// Instance `i`'s world bounds, padded as the ray queries test them: a ray that misses
    /// them meets nothing of the instance.
    pub fn padded_bounds(&self, i: usize) -> [[f64; 3]; 2] {
        self.padded[i]
    }

    /// Whether instance `i` is a box (met analytically; convex).
    pub fn is_box(&self, i: usize) -> bool {
        self.inst_box[i].is_some()
    }

    /// Whether the segment from `a` to `b` crosses clutter (strictly between the ends).
    pub fn blocks_segment(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let Some(bvh) = &self.bvh else { return false };
        let eps = 1e-9;
        bvh.any_hit(&Ray::segment(a, b).with_range(eps, 1.0 - eps))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pillar(t: [f64; 3], deg: f64) -> ClutterSpec {
        ClutterSpec {
            name: "pillar".into(),
            shape: ClutterShape::Box { size: [0.2, 0.8, 0.1], faces: BoxFaces::NoBottom },
            translate: t,
            rotate: quat_y(deg),
            scale: 1.0,
            albedo: [0.5; 3],
        }
    }

    #[test]
    fn box_texels_lie_on_the_box_with_outward_normals() {
        let s = ClutterScene::new(&[pillar([0.3, 0.0, 0.6], 30.0)], 4).unwrap();
        assert_eq!(s.charts.len(), 5);
        assert_eq!(s.texels.len(), 5 * 16);
        let c = s.specs[0].to_world([0.0, 0.4, 0.0]);
        for t in &s.texels {
            // outward: from the box centre to the texel along the normal
            assert!(dot(sub(t.position, c), t.normal) > 0.0, "{t:?}");
            // a ray from just outside along −n hits this chart's front face
            let o = [
                t.position[0] + 1e-3 * t.normal[0],
                t.position[1] + 1e-3 * t.normal[1],
                t.position[2] + 1e-3 * t.normal[2],
            ];
            let h = s.closest(o, t.normal.map(|x| -x), 0.0, 1.0).unwrap();
            assert!(h.front && h.chart == t.chart && (h.t - 1e-3).abs() < 1e-9, "{h:?}");
        }
        // the open bottom: from below the footprint a ray up meets the inside of the top
        let h = s.closest([0.3, -0.1, 0.6], [0.0, 1.0, 0.0], 0.0, 10.0).unwrap();
        assert!(!h.front && (h.t - 0.9).abs() < 1e-9);
    }

    #[test]
    fn mesh_charts_cover_a_cube_like_a_box() {
        // the unit cube as a mesh at res 4: six charts of 4×4 texels, like a box
        let spec = ClutterSpec {
            name: "cube".into(),
            shape: ClutterShape::Mesh(penumbra_geometry::procedural::aabb_box([0.0; 3], [1.0; 3])),
            translate: [0.0; 3],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 0.5,
            albedo: [0.3; 3],
        };
        let s = ClutterScene::new(&[spec], 4).unwrap();
        assert_eq!(s.charts.len(), 6);
        assert!(s.charts.iter().all(|c| c.count == 16), "{:?}", s.charts);
        for t in &s.texels {
            let on_face = t.position.iter().any(|&x| x.abs() < 1e-12 || (x - 0.5).abs() < 1e-12);
            assert!(on_face, "{t:?}");
        }
    }

    /// The unit cube with split vertices per face and each face's UVs an inset rectangle of a
    /// 3 × 2 grid (`g` the gap), faces listed as (origin, edge u, edge v) with `u × v` outward.
    type Frames = Vec<([f64; 3], [f64; 3], [f64; 3])>;

    fn lightmapped_cube(g: f64) -> (TriMesh, Vec<[f64; 2]>, Frames) {
        let faces = [
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),  // −x
            ([1.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]), // +x
            ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),  // −y
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),  // +y
            ([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), // −z
            ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),  // +z
        ];
        let (mut positions, mut indices, mut uv) = (Vec::new(), Vec::new(), Vec::new());
        for (f, (o, eu, ev)) in faces.iter().enumerate() {
            let (c, r) = ((f % 3) as f64, (f / 3) as f64);
            let b = positions.len() as u32;
            for (a, bb) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                positions.push(core::array::from_fn(|k| o[k] + a * eu[k] + bb * ev[k]));
                uv.push([(c + g + a * (1.0 - 2.0 * g)) / 3.0, (r + g + bb * (1.0 - 2.0 * g)) / 2.0]);
            }
            indices.push([b, b + 1, b + 2]);
            indices.push([b, b + 2, b + 3]);
        }
        (TriMesh { positions, indices }, uv, faces.to_vec())
    }

    #[test]
    fn lightmap_uvs_give_one_chart_per_island_on_the_cells_it_covers() {
        let (mesh, uv, faces) = lightmapped_cube(0.05);
        let n = 30;
        let spec = ClutterSpec {
            name: "cube".into(),
            shape: ClutterShape::Lightmapped { mesh, uv, res: Some(n) },
            translate: [0.0; 3],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 1.0,
            albedo: [0.3; 3],
        };
        let s = ClutterScene::new(&[spec], 4).unwrap();
        assert_eq!(s.lightmap_res, vec![n]);
        assert_eq!(s.charts.len(), 6);
        for (f, (o, eu, ev)) in faces.iter().enumerate() {
            let (c, r) = ((f % 3) as f64, (f / 3) as f64);
            // independent count: cell centres inside the face's UV rectangle
            let (u0, u1) = ((c + 0.05) / 3.0, (c + 0.95) / 3.0);
            let (v0, v1) = ((r + 0.05) / 2.0, (r + 0.95) / 2.0);
            let mut want = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    let (x, y) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                    if (u0..=u1).contains(&x) && (v0..=v1).contains(&y) {
                        want.push((i as u32, j as u32, x, y));
                    }
                }
            }
            let ch = &s.charts[f];
            assert_eq!(ch.count, want.len(), "face {f}");
            let nrm = cross(*eu, *ev);
            for (t, &(i, j, x, y)) in s.texels[ch.first..ch.first + ch.count].iter().zip(&want) {
                assert_eq!(t.uv, [0, i, j]);
                // the UV → face map is affine: the texel lies where its cell centre maps
                let (a, b) = ((3.0 * x - c - 0.05) / 0.9, (2.0 * y - r - 0.05) / 0.9);
                let p: [f64; 3] = core::array::from_fn(|k| o[k] + a * eu[k] + b * ev[k]);
                assert!((0..3).all(|k| (p[k] - t.position[k]).abs() < 1e-12), "{p:?} {t:?}");
                assert!((0..3).all(|k| (nrm[k] - t.normal[k]).abs() < 1e-12), "{t:?}");
            }
        }
        // density-matched default: world area 6, UV area 6·(0.9/3)(0.9/2), extent 1, res 4
        let (mesh, uv, _) = lightmapped_cube(0.05);
        let spec = ClutterSpec {
            name: "cube".into(),
            shape: ClutterShape::Lightmapped { mesh, uv, res: None },
            translate: [0.0; 3],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 2.0,
            albedo: [0.3; 3],
        };
        let want = ((1.0f64 / (0.3 * 0.45)).sqrt() * 4.0).ceil() as usize;
        assert_eq!(ClutterScene::new(&[spec], 4).unwrap().lightmap_res, vec![want]);
    }

    #[test]
    fn overlapping_lightmap_islands_and_tiny_islands() {
        // two faces on the same UV rectangle: an error naming the texel
        let (mesh, mut uv, _) = lightmapped_cube(0.05);
        for v in 0..4 {
            uv[4 + v] = uv[v];
        }
        let spec = |mesh, uv, res| ClutterSpec {
            name: "cube".into(),
            shape: ClutterShape::Lightmapped { mesh, uv, res },
            translate: [0.0; 3],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 1.0,
            albedo: [0.3; 3],
        };
        let e = ClutterScene::new(&[spec(mesh, uv, Some(16))], 4).unwrap_err().to_string();
        assert!(e.contains("overlap") && e.contains("clutter 0"), "{e}");
        // at 2 × 2 texels most islands cover no cell centre: one texel each, layer 1
        let (mesh, uv, _) = lightmapped_cube(0.05);
        let s = ClutterScene::new(&[spec(mesh, uv, Some(2))], 4).unwrap();
        assert_eq!(s.charts.len(), 6);
        assert!(s.charts.iter().all(|c| c.count >= 1));
        assert!(s.texels.iter().any(|t| t.uv[0] == 1));
        // UVs outside the unit square
        let (mesh, mut uv, _) = lightmapped_cube(0.05);
        uv[3] = [1.5, 0.0];
        let e = ClutterScene::new(&[spec(mesh, uv, None)], 4).unwrap_err().to_string();
        assert!(e.contains("TEXCOORD_1 of vertex 3"), "{e}");
    }

    #[test]
    fn bad_instances_are_named() {
        let mut p = pillar([0.0; 3], 0.0);
        p.scale = -1.0;
        let e = ClutterScene::new(&[p], 4).unwrap_err().to_string();
        assert!(e.contains("clutter 0") && e.contains("scale"), "{e}");
        let mut p = pillar([0.0; 3], 0.0);
        p.rotate = [0.0, 0.0, 0.0, 2.0];
        assert!(ClutterScene::new(&[p], 4).unwrap_err().to_string().contains("quaternion"));
    }

    /// The analytic box queries meet the same surface as the boxes' triangles: same distance,
    /// chart and side, for rays from outside, from inside and up through the open bottom.
    #[test]
    fn analytic_box_hits_equal_the_triangle_hits() {
        use penumbra_math::rng::{hash4, unit_f64};
        let mut specs = vec![pillar([0.3, 0.0, 0.6], 30.0), pillar([0.7, 0.1, 0.3], -71.0)];
        specs[1].shape = ClutterShape::Box { size: [0.15, 0.3, 0.25], faces: BoxFaces::All };
        specs[1].scale = 1.7;
        specs[1].rotate = [0.2, 0.3, -0.1, (1.0f64 - 0.04 - 0.09 - 0.01).sqrt()];
        let s = ClutterScene::with_basis(&specs, 8, 2).unwrap();
        let all = [0, 1];
        let (mut hits, mut backs) = (0, 0);
        for r in 0..20_000u64 {
            let u = |j: u64| unit_f64(hash4(11, 5, r, j));
            // origins in and around both boxes, some below the open bottom
            let o = [u(0) * 1.2 - 0.1, u(1) * 0.9 - 0.1, u(2) * 1.2 - 0.1];
            let z = 2.0 * u(3) - 1.0;
            let ph = 2.0 * core::f64::consts::PI * u(4);
            let rr = (1.0 - z * z).sqrt();
            let d = [rr * ph.cos(), z, rr * ph.sin()];
            let a = s.closest_among(&all, o, d, 1e-9, 10.0);
            let b = s.closest_among_triangles(&all, o, d, 1e-9, 10.0);
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    backs += usize::from(!b.front);
                    assert!((a.t - b.t).abs() < 1e-9, "ray {r}: t {} vs {}", a.t, b.t);
                    assert_eq!(a.front, b.front, "ray {r}");
                    if b.front {
                        assert_eq!(a.chart, b.chart, "ray {r} at {:?}", b.point);
                    }
                    assert!(dot(a.normal, b.normal) > 1.0 - 1e-9, "ray {r}");
                }
                (a, b) => panic!("ray {r} from {o:?} dir {d:?}: analytic {a:?}, triangles {b:?}"),
            }
        }
        assert!(hits > 2000 && backs > 100, "hits {hits}, back hits {backs}");
    }
}
