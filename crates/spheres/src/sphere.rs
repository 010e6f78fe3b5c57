//! The sphere type and the small exact geometry on spheres the fit needs.

use serde::{Deserialize, Serialize};

/// A sphere: centre and radius, in the units and frame of the mesh it was fitted to.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sphere {
    /// Centre.
    pub center: [f64; 3],
    /// Radius (≥ 0).
    pub radius: f64,
}

impl Sphere {
    /// A sphere.
    pub const fn new(center: [f64; 3], radius: f64) -> Self {
        Self { center, radius }
    }

    /// Volume `4/3·π·r³`.
    pub fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3)
    }

    /// Signed distance from `p` to the sphere's surface (negative inside).
    #[inline]
    pub fn signed_distance(&self, p: [f64; 3]) -> f64 {
        dist(self.center, p) - self.radius
    }

    /// Whether `p` lies inside or on the sphere.
    #[inline]
    pub fn contains(&self, p: [f64; 3]) -> bool {
        dist2(self.center, p) <= self.radius * self.radius
    }

    /// Whether the sphere contains all of `other`.
    pub fn contains_sphere(&self, other: &Sphere) -> bool {
        dist(self.center, other.center) + other.radius <= self.radius
    }
}

/// Squared Euclidean distance.
#[inline]
pub fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Euclidean distance.
#[inline]
pub fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    dist2(a, b).sqrt()
}

/// The smallest radius about `center` that contains every point: `max |p − center|`, rounded
/// up so that [`Sphere::contains`] (`|p − c|² ≤ r²` in f64) holds for every point.
#[inline]
pub fn bounding_radius(center: [f64; 3], points: &[[f64; 3]]) -> f64 {
    let m = points.iter().fold(0.0f64, |m, p| m.max(dist2(center, *p)));
    let mut r = m.sqrt();
    while r * r < m {
        r = r.next_up();
    }
    r
}

/// Rounds a sphere to f32 so that, evaluated in f64 from the f32 values, it still contains
/// every point of `points` and every sphere of `children` (the f32 centre is the nearest
/// f32; the radius is the smallest f32 not below the exact requirement).
pub fn round_to_f32(s: &Sphere, points: &[[f64; 3]], children: &[Sphere]) -> [f32; 4] {
    let c32 = s.center.map(|x| x as f32);
    let c = c32.map(f64::from);
    let mut need = s.radius.max(0.0);
    for p in points {
        need = need.max(dist(c, *p));
    }
    for ch in children {
        need = need.max(dist(c, ch.center) + ch.radius);
    }
    // smallest f32 ≥ need whose f64 value passes the same comparisons
    let mut r = need as f32;
    while f64::from(r) < need {
        r = r.next_up();
    }
    [c32[0], c32[1], c32[2], r]
}

/// A sphere from f32 storage.
pub fn from_f32(v: [f32; 4]) -> Sphere {
    Sphere::new([v[0] as f64, v[1] as f64, v[2] as f64], v[3] as f64)
}
