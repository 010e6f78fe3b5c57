//! Exact per-triangle kernels in f64: watertight ray/triangle intersection, closest point on
//! a triangle, and the signed solid angle of a triangle.

use glam::DVec3;

/// Per-ray precomputation of the watertight test (Woop, Benthin, Wald 2013, "Watertight
/// Ray/Triangle Intersection", JCGT 2(1)).
#[derive(Debug, Clone, Copy)]
pub(crate) struct RayKernel {
    origin: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl RayKernel {
    /// `None` for a zero or non-finite direction.
    #[inline]
    pub(crate) fn new(origin: DVec3, dir: DVec3) -> Option<Self> {
        if !origin.is_finite() {
            return None;
        }
        Self::for_direction(dir).map(|k| k.with_origin(origin))
    }

    /// The same kernel for another origin (the direction-dependent part is kept).
    #[inline]
    pub(crate) fn with_origin(mut self, origin: DVec3) -> Self {
        self.origin = origin;
        self
    }

    /// The direction-dependent part (origin zero); `None` for a zero or non-finite direction.
    #[inline]
    pub(crate) fn for_direction(dir: DVec3) -> Option<Self> {
        let origin = DVec3::ZERO;
        if !dir.is_finite() {
            return None;
        }
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        if dir[kz] == 0.0 {
            return None;
        }
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Some(Self { origin, kx, ky, kz, sx: dir[kx] / dir[kz], sy: dir[ky] / dir[kz], sz: 1.0 / dir[kz] })
    }

    /// Intersection with triangle `(v0, v1, v2)` at `t ∈ [tmin, tmax]`: `(t, b1, b2)` with the
    /// hit point `(1 − b1 − b2)·v0 + b1·v1 + b2·v2`. Both faces are hit. Watertight: a ray
    /// through a shared edge or vertex of a closed mesh hits at least one adjacent triangle,
    /// because each edge function depends only on the edge's two (identically transformed)
    /// vertices and changes sign exactly under reversal of the edge.
    #[inline]
    pub(crate) fn intersect(&self, v0: DVec3, v1: DVec3, v2: DVec3, tmin: f64, tmax: f64) -> Option<(f64, f64, f64)> {
        let a = v0 - self.origin;
        let b = v1 - self.origin;
        let c = v2 - self.origin;
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t = (u * az + v * bz + w * cz) / det;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        Some((t, v / det, w / det))
    }
}

impl RayKernel {
    /// The signed crossing of the ray (`t > 0`) with triangle `(v0, v1, v2)` as decided in
    /// f64 with error bounds: `Some(0)` none, `Some(±1)` a crossing (the sign of the edge
    /// functions, i.e. of the triangle's orientation seen along the ray), `None` when the
    /// ray passes so close to an edge, a vertex or the origin that rounding could change the
    /// answer. Every edge function `u = cx·by − cy·bx` of the sheared coordinates is within
    /// a few ulps of `|cx·by| + |cy·bx|` of the exact value (each sheared coordinate carries
    /// at most three roundings); a sign is trusted only above 10⁻¹² of that magnitude. A
    /// triangle with two equal corners (zero area, zero solid angle) never crosses.
    pub(crate) fn crossing(&self, v0: DVec3, v1: DVec3, v2: DVec3) -> Option<i32> {
        if v0 == v1 || v1 == v2 || v0 == v2 {
            return Some(0);
        }
        let a = v0 - self.origin;
        let b = v1 - self.origin;
        let c = v2 - self.origin;
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let (sx, sy) = (self.sx, self.sy);
        let (ax, ay, bx, by, cx, cy) = (
            a[kx] - sx * a[kz],
            a[ky] - sy * a[kz],
            b[kx] - sx * b[kz],
            b[ky] - sy * b[kz],
            c[kx] - sx * c[kz],
            c[ky] - sy * c[kz],
        );
        // magnitudes of the sheared coordinates (bounds on their rounding, up to ulps)
        let m = |p: DVec3, s: f64, k: usize| p[k].abs() + (s * p[kz]).abs();
        let (max, may, mbx, mby, mcx, mcy) =
            (m(a, sx, kx), m(a, sy, ky), m(b, sx, kx), m(b, sy, ky), m(c, sx, kx), m(c, sy, ky));
        const REL: f64 = 1e-12;
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let eu = REL * (mcx * mby + mcy * mbx);
        let ev = REL * (max * mcy + may * mcx);
        let ew = REL * (mbx * may + mby * max);
        if u.abs() <= eu || v.abs() <= ev || w.abs() <= ew {
            return None;
        }
        if !((u > 0.0 && v > 0.0 && w > 0.0) || (u < 0.0 && v < 0.0 && w < 0.0)) {
            return Some(0);
        }
        let (az, bz, cz) = (self.sz * a[kz], self.sz * b[kz], self.sz * c[kz]);
        // t·det; its bound allows for u, v, w each off by their own bound
        let td = u * az + v * bz + w * cz;
        let et = 1e-9 * ((u.abs() + eu) * az.abs() + (v.abs() + ev) * bz.abs() + (w.abs() + ew) * cz.abs());
        if td.abs() <= et {
            return None;
        }
        let det_positive = u > 0.0;
        if (td > 0.0) != det_positive {
            return Some(0); // behind the origin
        }
        Some(if det_positive { 1 } else { -1 })
    }
}

/// Closest point to `p` on triangle `(a, b, c)` (Ericson, Real-Time Collision Detection §5.1.5).
#[inline]
pub(crate) fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return a + v * ab;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return a + w * ac;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + w * (c - b);
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // degenerate triangle: closest point on its three edges
        let e = |s: DVec3, t: DVec3| {
            let d = t - s;
            let l = d.length_squared();
            let u = if l > 0.0 { ((p - s).dot(d) / l).clamp(0.0, 1.0) } else { 0.0 };
            s + u * d
        };
        let cands = [e(a, b), e(b, c), e(c, a)];
        return cands
            .into_iter()
            .min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared()))
            .unwrap_or(a);
    }
    let inv = 1.0 / denom;
    let v = vb * inv;
    let w = vc * inv;
    a + ab * v + ac * w
}

/// Signed solid angle of triangle `(a, b, c)` seen from `q` (Van Oosterom & Strackee 1983):
/// `Ω = 2·atan2(A·(B×C), |A||B||C| + (A·B)|C| + (B·C)|A| + (C·A)|B|)` with `A = a − q`, ...
/// Positive when `q` is on the back side (the side opposite to `(b − a) × (c − a)`), so a
/// closed outward-oriented mesh sums to `4π` at interior points.
#[inline]
pub(crate) fn solid_angle(q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let a = a - q;
    let b = b - q;
    let c = c - q;
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let div = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(div)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn watertight_on_shared_edge_and_vertex() {
        // two triangles sharing the diagonal of the unit square in z = 0
        let (p0, p1, p2, p3) = (
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        );
        for k in 0..=64 {
            let s = k as f64 / 64.0;
            let o = DVec3::new(s, s, 1.0);
            let r = RayKernel::new(o, DVec3::new(0.0, 0.0, -1.0)).unwrap();
            let h1 = r.intersect(p0, p1, p2, 0.0, f64::INFINITY);
            let h2 = r.intersect(p0, p2, p3, 0.0, f64::INFINITY);
            assert!(h1.is_some() || h2.is_some(), "ray at {s} leaked");
        }
        // barycentrics reproduce the hit point
        let r = RayKernel::new(DVec3::new(0.7, 0.2, 2.0), DVec3::new(0.0, 0.0, -2.0)).unwrap();
        let (t, b1, b2) = r.intersect(p0, p1, p2, 0.0, 10.0).unwrap();
        assert!((t - 1.0).abs() < 1e-15);
        let hit = (1.0 - b1 - b2) * p0 + b1 * p1 + b2 * p2;
        assert!((hit - DVec3::new(0.7, 0.2, 0.0)).length() < 1e-15);
        // interval is respected; back face is hit too
        assert!(r.intersect(p0, p1, p2, 0.0, 0.99).is_none());
        assert!(r.intersect(p0, p2, p1, 0.0, 10.0).is_some());
        assert!(RayKernel::new(DVec3::ZERO, DVec3::ZERO).is_none());
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let cp = |p: DVec3| closest_point_on_triangle(p, a, b, c);
        assert!((cp(DVec3::new(0.2, 0.2, 5.0)) - DVec3::new(0.2, 0.2, 0.0)).length() < 1e-15);
        assert_eq!(cp(DVec3::new(-1.0, -1.0, 0.0)), a);
        assert_eq!(cp(DVec3::new(2.0, -1.0, 0.0)), b);
        assert_eq!(cp(DVec3::new(0.5, -1.0, 1.0)), DVec3::new(0.5, 0.0, 0.0));
        let e = cp(DVec3::new(1.0, 1.0, 0.0));
        assert!((e - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-15);
        // degenerate (collinear) triangle
        let d = closest_point_on_triangle(DVec3::new(0.5, 1.0, 0.0), a, b, 2.0 * b);
        assert!((d - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-15);
    }

    #[test]
    fn solid_angle_octant() {
        // the triangle (X, Y, Z) seen from the origin covers 1/8 of the sphere; its normal
        // points away from the origin, so the origin is on the back side: +π/2
        let w = solid_angle(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z);
        assert!((w - std::f64::consts::FRAC_PI_2).abs() < 1e-14);
        let w2 = solid_angle(DVec3::ZERO, DVec3::X, DVec3::Z, DVec3::Y);
        assert!((w2 + std::f64::consts::FRAC_PI_2).abs() < 1e-14);
    }
}
