//! Ground truth for the screen-space estimators (MRT thesis §6.3): depth buffers ray-cast
//! from a mesh, the obscurance integral `V(P) = ∫ ρ O(x) dx` over the ball (ρ constant, §6.3)
//! by Monte Carlo with the winding-number inside test against the real mesh, and the same
//! integral against the depth buffer's height field (everything behind the buffer is
//! matter). Their difference is the error of the screen-space assumption; an estimator's
//! difference from the height-field truth is its sampling error.

use crate::estimator::{DepthBuffer, Method, Options, SetRef, estimate};
use crate::quality::unit_vector;
use crate::sets::STAGE_VO;
use penumbra_geometry::{MeshBvh, Ray, TriMesh, WindingNumber};
use penumbra_math::rng::ItemRng;
use rayon::prelude::*;
use serde::Serialize;

/// View direction of the orthographic camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// Looking along −Z (camera on +Z).
    Front,
    /// Looking along −X.
    Side,
    /// Looking along −Y (from above for +Y-up meshes).
    Top,
}

/// The camera frame of a depth buffer: view-plane axes and the ray origin plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Right, up, forward (unit, world).
    pub axes: [[f64; 3]; 3],
    /// World point of view coordinates (0, 0, 0).
    pub origin: [f64; 3],
}

impl Frame {
    /// World position of view coordinates `(x, y, z)`.
    pub fn world(&self, v: [f64; 3]) -> [f64; 3] {
        let a = &self.axes;
        [0, 1, 2].map(|k| self.origin[k] + v[0] * a[0][k] + v[1] * a[1][k] + v[2] * a[2][k])
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Ray-casts a `res × res` depth buffer of the mesh. Orthographic: a square with a 5 % margin
/// around its bounding box's projection, depth measured from a plane in front of the mesh.
/// Perspective: the camera two bounding-box diagonals from the box centre, the field of view
/// just covering the box's bounding sphere (5 % margin), depth = view-space Z.
pub fn ray_cast(
    mesh: &TriMesh,
    bvh: &MeshBvh,
    view: View,
    res: usize,
    perspective: bool,
) -> Option<(DepthBuffer, Frame)> {
    let b = mesh.bounds()?;
    let c = b.center();
    let axes = match view {
        View::Front => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
        View::Side => [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
        View::Top => [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]],
    };
    let diag = b.diagonal().max(1e-12);
    let ext = b.extent();
    let span = 1.05 * (0..2).map(|a| (0..3).map(|k| (ext[k] * axes[a][k]).abs()).sum::<f64>()).fold(0.0, f64::max);
    let dist = 2.0 * diag;
    let pixel = if perspective {
        2.0 * (0.5 * 1.05 * diag) / (dist - 0.5 * diag) / res as f64
    } else {
        span.max(1e-12) / res as f64
    };
    let origin = [0, 1, 2].map(|k| c[k] - if perspective { dist } else { diag } * axes[2][k]);
    let frame = Frame { axes, origin };
    let o2 = [-(res as f64 - 1.0) * 0.5 * pixel; 2];
    let rows: Vec<Vec<(f64, [f64; 3])>> = (0..res)
        .into_par_iter()
        .map(|j| {
            (0..res)
                .map(|i| {
                    let (x, y) = (o2[0] + i as f64 * pixel, o2[1] + j as f64 * pixel);
                    let (from, dir, zscale) = if perspective {
                        let d = [0, 1, 2].map(|k| axes[2][k] + x * axes[0][k] + y * axes[1][k]);
                        let l = dot(d, d).sqrt();
                        (frame.origin, d.map(|v| v / l), 1.0 / l)
                    } else {
                        (frame.world([x, y, 0.0]), axes[2], 1.0)
                    };
                    match bvh.closest_hit(&Ray::new(from, dir)) {
                        Some(h) => {
                            let cr = mesh.triangle_cross(h.triangle as usize);
                            let l = dot(cr, cr).sqrt().max(1e-300);
                            let mut n = [dot(cr, axes[0]) / l, dot(cr, axes[1]) / l, dot(cr, axes[2]) / l];
                            if n[2] > 0.0 {
                                n = n.map(|v| -v);
                            }
                            (h.t * zscale, n)
                        }
                        None => (f64::INFINITY, [0.0; 3]),
                    }
                })
                .collect()
        })
        .collect();
    let (depth, normal) = rows.into_iter().flatten().unzip();
    Some((DepthBuffer { width: res, height: res, pixel, origin: o2, depth, normal, perspective }, frame))
}

/// Knobs of a verification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerifyParams {
    /// Estimator options (radius in world units, normal clamp, thickness).
    pub options: Options,
    /// Pixels compared (a regular stride over the covered pixels).
    pub pixels: usize,
    /// Monte-Carlo points per pixel of the truths.
    pub mc_samples: usize,
    /// Seed of the Monte-Carlo points.
    pub seed: u64,
}

/// Accuracy of an estimator against both truths.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct VerifyReport {
    /// Pixels compared.
    pub pixels: usize,
    /// Mean over pixels of (estimate averaged over the reflections − volume truth).
    pub bias: f64,
    /// RMS over pixels of the standard deviation of the estimate across the S×S
    /// reflections (the per-pixel noise before any blur).
    pub noise: f64,
    /// RMS of (estimate with the pixel's own reflection − volume truth).
    pub rmse_vs_volume: f64,
    /// RMS of (estimate − height-field truth): the sampling error alone.
    pub rmse_vs_heightfield: f64,
    /// RMS of (height-field truth − volume truth): the screen-space assumption's error.
    pub heightfield_vs_volume_rmse: f64,
    /// RMS standard error of the Monte-Carlo volume truth (a floor under the RMSEs).
    pub truth_std_error: f64,
    /// Mean estimate, mean volume truth, mean height-field truth.
    pub mean_estimate: f64,
    /// Mean volume truth.
    pub mean_volume: f64,
    /// Mean height-field truth.
    pub mean_heightfield: f64,
    /// Wall time of the estimator per pixel (one reflection, this thread), nanoseconds.
    pub ns_per_pixel: f64,
}

/// The two truths at pixel `(i, j)`: the free fraction of the ball (hemisphere with the
/// normal clamp) by `m` uniform points, against the mesh (winding number < ½) and against the
/// height field (`z ≤ depth(x, y)`).
pub fn truths(
    db: &DepthBuffer,
    frame: &Frame,
    wn: &WindingNumber,
    i: usize,
    j: usize,
    o: &Options,
    m: usize,
    seed: u64,
) -> Option<(f64, f64)> {
    let k = j * db.width + i;
    let z0 = db.depth[k];
    if !z0.is_finite() {
        return None;
    }
    let n = db.normal[k];
    let [x0, y0] = db.position(i, j);
    let mut rng = ItemRng::new(seed, STAGE_VO, 0x7_0000_0000 + k as u64);
    let (mut fv, mut fh) = (0usize, 0usize);
    for _ in 0..m {
        let d = unit_vector(rng.next_f64(), rng.next_f64(), false);
        let r = rng.next_f64().cbrt();
        let mut q = d.map(|v| v * r);
        if o.normal_clamp && dot(q, n) < 0.0 {
            let s = 2.0 * dot(q, n);
            q = [q[0] - s * n[0], q[1] - s * n[1], q[2] - s * n[2]];
        }
        let v = [x0 + o.radius * q[0], y0 + o.radius * q[1], z0 + o.radius * q[2]];
        fv += usize::from(!wn.is_inside(frame.world(v)));
        fh += usize::from(v[2] <= db.depth_at(v[0], v[1], v[2]));
    }
    Some((fv as f64 / m as f64, fh as f64 / m as f64))
}

/// Compares an estimator with both truths on a strided subset of the covered pixels.
/// `reflections` is the S×S texture (row-major); pixel `(i, j)` uses texel
/// `(i mod S, j mod S)`.
pub fn verify(
    db: &DepthBuffer,
    frame: &Frame,
    wn: &WindingNumber,
    method: Method,
    set: SetRef<'_>,
    reflections: &[[f64; 3]],
    p: &VerifyParams,
) -> VerifyReport {
    let s = (reflections.len() as f64).sqrt() as usize;
    let covered: Vec<(usize, usize)> = (0..db.height)
        .flat_map(|j| (0..db.width).map(move |i| (i, j)))
        .filter(|&(i, j)| db.depth[j * db.width + i].is_finite())
        .collect();
    let stride = covered.len().div_ceil(p.pixels.max(1)).max(1);
    let chosen: Vec<(usize, usize)> = covered.iter().copied().step_by(stride).collect();
    let o = p.options;
    let t0 = std::time::Instant::now();
    let mut own = 0.0;
    for &(i, j) in &chosen {
        own += estimate(db, i, j, method, set, reflections[(j % s) * s + i % s], &o).unwrap_or(0.0);
    }
    let ns = t0.elapsed().as_secs_f64() * 1e9 / chosen.len().max(1) as f64;
    std::hint::black_box(own);
    let rows: Vec<[f64; 6]> = chosen
        .par_iter()
        .map(|&(i, j)| {
            let est: Vec<f64> =
                reflections.iter().map(|&r| estimate(db, i, j, method, set, r, &o).unwrap_or(0.0)).collect();
            let mean = est.iter().sum::<f64>() / est.len() as f64;
            let var = est.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / est.len() as f64;
            let e = est[(j % s) * s + i % s];
            let (tv, th) = truths(db, frame, wn, i, j, &o, p.mc_samples, p.seed).unwrap_or((0.0, 0.0));
            [mean, var, e, tv, th, tv * (1.0 - tv) / p.mc_samples as f64]
        })
        .collect();
    let n = rows.len().max(1) as f64;
    let sum = |f: &dyn Fn(&[f64; 6]) -> f64| rows.iter().map(f).sum::<f64>() / n;
    VerifyReport {
        pixels: rows.len(),
        bias: sum(&|r| r[0] - r[3]),
        noise: sum(&|r| r[1]).sqrt(),
        rmse_vs_volume: sum(&|r| (r[2] - r[3]).powi(2)).sqrt(),
        rmse_vs_heightfield: sum(&|r| (r[2] - r[4]).powi(2)).sqrt(),
        heightfield_vs_volume_rmse: sum(&|r| (r[4] - r[3]).powi(2)).sqrt(),
        truth_std_error: sum(&|r| r[5]).sqrt(),
        mean_estimate: sum(&|r| r[2]),
        mean_volume: sum(&|r| r[3]),
        mean_heightfield: sum(&|r| r[4]),
        ns_per_pixel: ns,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An axis-aligned box mesh `[lo, hi]` with outward triangles.
    fn cube(lo: [f64; 3], hi: [f64; 3]) -> TriMesh {
        let mut v = Vec::new();
        for k in 0..8 {
            v.push([0, 1, 2].map(|a| if (k >> a) & 1 == 1 { hi[a] } else { lo[a] }));
        }
        let f: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let idx = f.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        TriMesh::new(v, idx).unwrap()
    }

    #[test]
    fn box_face_truths_are_a_half_and_the_cast_depths_are_exact() {
        let m = cube([-1.0; 3], [1.0; 3]);
        let bvh = MeshBvh::build(&m).unwrap();
        let (db, frame) = ray_cast(&m, &bvh, View::Front, 64, false).unwrap();
        let wn = WindingNumber::new(&m);
        // every covered pixel sees the +Z face at the same depth
        let d: Vec<f64> = db.depth.iter().copied().filter(|d| d.is_finite()).collect();
        assert!(d.len() > 3000);
        let d0 = d[0];
        assert!(d.iter().all(|x| (x - d0).abs() < 1e-9));
        let c = db.width / 2;
        assert!((frame.world([db.position(c, c)[0], db.position(c, c)[1], d0])[2] - 1.0).abs() < 1e-9);
        // at the face centre a small ball is half matter, in both truths; with the normal the
        // hemisphere is free
        let o = Options { radius: 0.2, normal_clamp: false, thickness: None };
        let (tv, th) = truths(&db, &frame, &wn, c, c, &o, 4000, 1).unwrap();
        assert!((tv - 0.5).abs() < 0.03 && (th - 0.5).abs() < 0.03, "{tv} {th}");
        let on = Options { normal_clamp: true, ..o };
        let (tv, th) = truths(&db, &frame, &wn, c, c, &on, 1000, 1).unwrap();
        assert!(tv > 0.999 && th > 0.999, "{tv} {th}");
        // perspective: the +Z face is the plane Z = const in view space; its points sit on
        // their pixels' rays, and the same truths and line estimate hold at the centre
        let (dp, fp) = ray_cast(&m, &bvh, View::Front, 64, true).unwrap();
        let c = 32;
        let z = dp.depth[c * 64 + c];
        let [x, y] = dp.position(c, c);
        let w = fp.world([x, y, z]);
        assert!((w[2] - 1.0).abs() < 1e-9, "{w:?}");
        let covered = dp.depth.iter().filter(|d| d.is_finite()).count();
        assert!(covered > 100 && covered < 64 * 64);
        let (tv, th) = truths(&dp, &fp, &wn, c, c, &o, 4000, 1).unwrap();
        assert!((tv - 0.5).abs() < 0.03 && (th - 0.5).abs() < 0.03, "{tv} {th}");
        let pts = crate::sets::halton(crate::Domain::Disk, 16, false);
        let g = crate::voronoi::Grid::new(crate::Domain::Disk, 128);
        let cells = g.cells(&pts);
        let l: Vec<f64> = cells.area.iter().map(|a| a.log2()).collect();
        let set = SetRef { points: &pts, weights: &cells.mass, log2area: &l };
        let e = estimate(&dp, c, c, Method::Lines, set, [1.0, 0.0, 0.0], &o).unwrap();
        assert!((e - 0.5).abs() < 1e-9, "{e}");
    }

    #[test]
    fn step_edge_volume_and_heightfield_differ_behind_a_thin_slab() {
        // a thin slab (thickness 0.1) seen face-on: the height field fills everything behind
        // it, the mesh does not; at the slab's face centre with radius 0.5 the volume truth is
        // 1 − (cap(0) − cap(0.2)), the height-field truth ½
        let m = cube([-2.0, -2.0, -0.1], [2.0, 2.0, 0.0]);
        let bvh = MeshBvh::build(&m).unwrap();
        let (db, frame) = ray_cast(&m, &bvh, View::Front, 64, false).unwrap();
        let wn = WindingNumber::new(&m);
        let o = Options { radius: 0.5, normal_clamp: false, thickness: None };
        let c = db.width / 2;
        let (tv, th) = truths(&db, &frame, &wn, c, c, &o, 8000, 2).unwrap();
        let want = 1.0 - (crate::quality::cap_fraction(0.0) - crate::quality::cap_fraction(0.2));
        assert!((tv - want).abs() < 0.02, "{tv} vs {want}");
        assert!((th - 0.5).abs() < 0.02, "{th}");
    }
}
