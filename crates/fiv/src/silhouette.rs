//! Exact culling of rays that cannot hit the occluder: per environment texel, a bitmap of the
//! occluder's orthographic silhouette along the texel direction, dilated (conservative).
//!
//! A ray `p + s·ω` can only hit the mesh if the *line* through `p` along `ω` does, and that
//! line is fixed by the point where it crosses the plane through the ball centre `c`
//! perpendicular to `ω`: `(u, v) = ((p − c)·a, (p − c)·b)` with `(a, b, ω)` orthonormal.
//! So for every texel direction we mark, in a `RES × RES` bitmap over `[−R, R]²`, every
//! pixel whose square meets the projection of a bounding sphere of a cluster of triangles
//! (clusters: at most 16 triangles, by recursive median splits of their centroids; sphere: centre of
//! the cluster's vertex box, radius to its farthest vertex, padded by 1e-9·R). A triangle
//! lies in its cluster's sphere, so its projection lies in the sphere's projected disc: a ray
//! whose pixel is unmarked misses the mesh, and skipping it changes nothing. Rays in marked
//! pixels are traced exactly as before. For the bunny this removes most of the rays that
//! the bounding cone lets through but that miss (the cone only knows the ball).

use crate::bake::Occluder;
use crate::lighting::Lighting;
use rayon::prelude::*;

/// Pixels per side of each bitmap.
pub const RES: usize = 128;
const WORDS: usize = RES * RES / 64;
/// Triangles per cluster.
const CLUSTER: usize = 16;
/// Largest bitmap memory (bytes) before the culler is skipped (fine cube maps).
const MAX_BYTES: usize = 256 << 20;

/// Per-texel silhouette bitmaps (shared by opposite texels: a line along `ω` is a line along
/// `−ω`, so the bitmap of `−ω` serves `ω` too).
#[derive(Debug, Clone)]
pub struct Silhouettes {
    center: [f64; 3],
    radius: f64,
    /// Pixels per world unit.
    scale: f64,
    /// Bitmap index of every texel.
    map: Vec<u32>,
    /// `(a, b)` per bitmap.
    axes: Vec<[[f64; 3]; 2]>,
    bits: Vec<[u64; WORDS]>,
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// An orthonormal pair perpendicular to the unit vector `n` (Duff et al. 2017, branchless
/// revised Frisvad basis).
pub(crate) fn perpendicular_pair(n: [f64; 3]) -> [[f64; 3]; 2] {
    let sign = 1f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    [[1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]], [b, sign + n[1] * n[1] * a, -n[1]]]
}

/// Bounding spheres `(centre, radius)` of compact clusters of at most [`CLUSTER`] triangles:
/// recursive median splits of the triangle centroids along the longest axis of their box.
fn clusters(occ: &Occluder) -> Vec<([f64; 3], f64)> {
    let mesh = occ.mesh();
    let f = occ.frame();
    let cent: Vec<[f64; 3]> = (0..mesh.indices.len())
        .map(|t| {
            let tri = mesh.triangle(t);
            [0, 1, 2].map(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0)
        })
        .collect();
    let mut ids: Vec<u32> = (0..mesh.indices.len() as u32).collect();
    let mut out = Vec::new();
    let mut stack = vec![(0usize, ids.len())];
    while let Some((lo, hi)) = stack.pop() {
        let part = &mut ids[lo..hi];
        if part.len() <= CLUSTER {
            let mut bmin = [f64::INFINITY; 3];
            let mut bmax = [f64::NEG_INFINITY; 3];
            for &t in part.iter() {
                for v in mesh.triangle(t as usize) {
                    for k in 0..3 {
                        bmin[k] = bmin[k].min(v[k]);
                        bmax[k] = bmax[k].max(v[k]);
                    }
                }
            }
            let c = [0, 1, 2].map(|k| 0.5 * (bmin[k] + bmax[k]));
            let mut r2: f64 = 0.0;
            for &t in part.iter() {
                for v in mesh.triangle(t as usize) {
                    r2 = r2.max((v[0] - c[0]).powi(2) + (v[1] - c[1]).powi(2) + (v[2] - c[2]).powi(2));
                }
            }
            out.push((c, r2.sqrt() * (1.0 + 1e-9) + 1e-9 * f.radius));
            continue;
        }
        let mut bmin = [f64::INFINITY; 3];
        let mut bmax = [f64::NEG_INFINITY; 3];
        for &t in part.iter() {
            for k in 0..3 {
                bmin[k] = bmin[k].min(cent[t as usize][k]);
                bmax[k] = bmax[k].max(cent[t as usize][k]);
            }
        }
        let axis = (0..3).max_by(|&a, &b| (bmax[a] - bmin[a]).total_cmp(&(bmax[b] - bmin[b]))).unwrap_or(0);
        let mid = part.len() / 2;
        part.select_nth_unstable_by(mid, |&a, &b| {
            cent[a as usize][axis].total_cmp(&cent[b as usize][axis]).then(a.cmp(&b))
        });
        stack.push((lo + mid, hi));
        stack.push((lo, lo + mid));
    }
    out
}

/// Marks every pixel of `bm` whose square meets the disc of centre `(u, v)` and radius `r`
/// (pixel units, origin at the bitmap corner): row by row, the pixels whose x-span meets
/// `[u − w, u + w]` with `w = √(r² − dy²)`, `dy` the distance from `v` to the row.
fn stamp(bm: &mut [u64; WORDS], u: f64, v: f64, r: f64) {
    let last = (RES - 1) as f64;
    let y0 = ((v - r).ceil() - 1.0).clamp(0.0, last) as usize;
    let y1 = (v + r).floor().clamp(0.0, last) as usize;
    for y in y0..=y1 {
        let dy = if v < y as f64 {
            y as f64 - v
        } else if v > (y + 1) as f64 {
            v - (y + 1) as f64
        } else {
            0.0
        };
        if dy > r {
            continue;
        }
        let w = (r * r - dy * dy).sqrt();
        let x0 = ((u - w).ceil() - 1.0).clamp(0.0, last) as usize;
        let x1 = (u + w).floor().clamp(0.0, last) as usize;
        // set bits x0..=x1 of row y (RES / 64 words per row)
        let row = y * RES;
        let (a, b) = (row + x0, row + x1);
        let (wa, wb) = (a / 64, b / 64);
        let lo = !0u64 << (a % 64);
        let hi = !0u64 >> (63 - b % 64);
        if wa == wb {
            bm[wa] |= lo & hi;
        } else {
            bm[wa] |= lo;
            for word in &mut bm[wa + 1..wb] {
                *word = !0;
            }
            bm[wb] |= hi;
        }
    }
}

impl Silhouettes {
    /// Builds the bitmaps (parallel over bitmaps), or `None` when they would take more than
    /// 256 MB (then only the cone culls).
    pub(crate) fn build(occ: &Occluder, lighting: &Lighting) -> Option<Self> {
        let texels = lighting.texel_count();
        if texels.saturating_mul(WORDS * 8) / 2 > MAX_BYTES {
            return None;
        }
        let n = lighting.cube().size();
        // opposite texels share a bitmap
        let mut map = vec![u32::MAX; texels];
        let mut owners: Vec<usize> = Vec::new();
        for t in 0..texels {
            let d = lighting.direction(t);
            let mirror = penumbra_geometry::CubeFace::from_direction([-d[0], -d[1], -d[2]]).map(|(f, s, tt)| {
                let i = ((s * n as f64) as usize).min(n - 1);
                let j = ((tt * n as f64) as usize).min(n - 1);
                (f.index() * n + j) * n + i
            });
            match mirror {
                Some(m)
                    if m < t && {
                        let e = lighting.direction(m);
                        (d[0] + e[0]).abs() + (d[1] + e[1]).abs() + (d[2] + e[2]).abs() < 1e-12
                    } =>
                {
                    map[t] = map[m];
                }
                _ => {
                    map[t] = owners.len() as u32;
                    owners.push(t);
                }
            }
        }
        let f = occ.frame();
        let spheres = clusters(occ);
        let scale = RES as f64 / (2.0 * f.radius);
        let axes: Vec<[[f64; 3]; 2]> = owners.iter().map(|&t| perpendicular_pair(lighting.direction(t))).collect();
        let rel: Vec<([f64; 3], f64)> = spheres
            .iter()
            .map(|(c, r)| ([c[0] - f.center[0], c[1] - f.center[1], c[2] - f.center[2]], *r * scale))
            .collect();
        let bits = axes
            .par_iter()
            .map(|[a, b]| {
                let mut bm = [0u64; WORDS];
                for (c, r) in &rel {
                    let u = (dot(*c, *a) + f.radius) * scale;
                    let v = (dot(*c, *b) + f.radius) * scale;
                    stamp(&mut bm, u, v, *r);
                }
                bm
            })
            .collect();
        Some(Self { center: f.center, radius: f.radius, scale, map, axes, bits })
    }

    /// Whether the line through `p` along texel `t`'s direction may hit the mesh (`false`:
    /// it certainly misses).
    #[inline]
    pub(crate) fn may_hit(&self, t: usize, p: [f64; 3]) -> bool {
        let m = self.map[t] as usize;
        let q = [p[0] - self.center[0], p[1] - self.center[1], p[2] - self.center[2]];
        let [a, b] = self.axes[m];
        let u = (dot(q, a) + self.radius) * self.scale;
        let v = (dot(q, b) + self.radius) * self.scale;
        const EDGE: f64 = 1e-6;
        if !(u >= -EDGE && v >= -EDGE && u <= RES as f64 + EDGE && v <= RES as f64 + EDGE) {
            // outside the square around the projected ball: the line misses the ball
            return false;
        }
        // (clamped like the stamps, so a line touching the ball's edge finds its pixel)
        let x = (u.max(0.0) as usize).min(RES - 1);
        let y = (v.max(0.0) as usize).min(RES - 1);
        let i = y * RES + x;
        self.bits[m][i / 64] >> (i % 64) & 1 == 1
    }
}

/// Debug statistics: (cluster count, mean cluster radius / R, bitmaps, mean marked fraction).
#[doc(hidden)]
pub fn debug_stats(occ: &Occluder, lighting: &Lighting) -> (usize, f64, usize, f64) {
    let c = clusters(occ);
    let r = c.iter().map(|x| x.1).sum::<f64>() / c.len() as f64 / occ.frame().radius;
    let s = Silhouettes::build(occ, lighting).unwrap_or_else(|| unreachable!());
    let marked: u64 = s.bits.iter().map(|b| b.iter().map(|w| w.count_ones() as u64).sum::<u64>()).sum();
    (c.len(), r, s.bits.len(), marked as f64 / (s.bits.len() * RES * RES) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_cover_exactly_the_touched_pixels() {
        for (u, v, r) in [(10.3, 20.7, 2.2), (0.2, 127.9, 1.0), (64.0, 64.0, 0.0), (63.9, 5.5, 40.0)] {
            let mut bm = [0u64; WORDS];
            stamp(&mut bm, u, v, r);
            for y in 0..RES {
                for x in 0..RES {
                    let dx = (x as f64 - u).max(u - (x + 1) as f64).max(0.0);
                    let dy = (y as f64 - v).max(v - (y + 1) as f64).max(0.0);
                    let touched = dx * dx + dy * dy <= r * r;
                    let i = y * RES + x;
                    assert_eq!(bm[i / 64] >> (i % 64) & 1 == 1, touched, "({u},{v},{r}) pixel ({x},{y})");
                }
            }
        }
    }

    #[test]
    fn perpendicular_pairs_are_orthonormal() {
        for n in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.6, 0.0, 0.8], [0.0, -1.0, 0.0], [0.48, -0.6, -0.64]] {
            let [a, b] = perpendicular_pair(n);
            for (x, y, e) in [(a, a, 1.0), (b, b, 1.0), (a, b, 0.0), (a, n, 0.0), (b, n, 0.0)] {
                assert!((dot(x, y) - e).abs() < 1e-15, "{n:?}");
            }
        }
    }
}
