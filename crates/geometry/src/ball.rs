//! The minimum enclosing ball of a point set (Welzl 1991), deterministic.
//!
//! Iterative Welzl with the points visited in a fixed pseudo-random order (a hash of the
//! index, so the result depends only on the input): expected linear time, recursion depth
//! bounded by the four support points. The support balls through 2, 3 and 4 points are solved
//! in f64 relative to the first support point; a point counts as inside when it is within
//! `(1 + 1e-12)·r + 1e-300`, which keeps the loop from cycling on rounding.
//!
//! The result is exact up to rounding: every input point lies in the returned ball (the
//! radius is finally enlarged to the farthest point, so containment holds exactly in f64),
//! and the radius is the minimum (tested against brute force over all support subsets).

use glam::DVec3;

/// A ball `|x − center| ≤ radius`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Centre.
    pub center: [f64; 3],
    /// Radius (0 for a single point).
    pub radius: f64,
}

impl Ball {
    /// Whether `p` is inside or on the ball: `|p − center| ≤ radius`, with the distance
    /// computed as [`min_enclosing_ball`] computes it (so its input points are all inside).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (DVec3::from(p) - DVec3::from(self.center)).length() <= self.radius
    }
}

#[derive(Clone, Copy)]
struct B {
    c: DVec3,
    r2: f64,
}

impl B {
    #[inline]
    fn contains(&self, p: DVec3) -> bool {
        let d2 = (p - self.c).length_squared();
        // relative slack on the squared radius, ~2e-12 relative on the radius
        d2 <= self.r2 * (1.0 + 4e-12) + 1e-300
    }
}

fn ball2(a: DVec3, b: DVec3) -> B {
    let c = 0.5 * (a + b);
    B { c, r2: (a - c).length_squared().max((b - c).length_squared()) }
}

/// Smallest ball with `a, b, c` on its boundary (centre in their plane); falls back to the
/// smallest ball of the farthest pair when the points are collinear.
fn ball3(a: DVec3, b: DVec3, c: DVec3) -> B {
    let u = b - a;
    let v = c - a;
    let n = u.cross(v);
    let n2 = n.length_squared();
    let scale = u.length_squared() * v.length_squared();
    if n2 <= 1e-24 * scale || n2 == 0.0 {
        return farthest_pair_ball(&[a, b, c]);
    }
    // circumcentre relative to a: (|u|² (v×n) + |v|² (n×u)) / (2|n|²)
    let o = (u.length_squared() * v.cross(n) + v.length_squared() * n.cross(u)) / (2.0 * n2);
    let c0 = a + o;
    B { c: c0, r2: [a, b, c].iter().map(|p| (*p - c0).length_squared()).fold(0.0, f64::max) }
}

/// Ball through four points (circumsphere); falls back to the smallest enclosing ball of the
/// four when they are (nearly) coplanar.
fn ball4(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> B {
    let u = b - a;
    let v = c - a;
    let w = d - a;
    let det = u.dot(v.cross(w));
    let scale = u.length() * v.length() * w.length();
    if det.abs() <= 1e-12 * scale || det == 0.0 {
        return brute_small(&[a, b, c, d]);
    }
    let o = (u.length_squared() * v.cross(w) + v.length_squared() * w.cross(u) + w.length_squared() * u.cross(v))
        / (2.0 * det);
    let c0 = a + o;
    B { c: c0, r2: [a, b, c, d].iter().map(|p| (*p - c0).length_squared()).fold(0.0, f64::max) }
}

fn farthest_pair_ball(pts: &[DVec3]) -> B {
    let mut best = B { c: pts[0], r2: 0.0 };
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            let b = ball2(pts[i], pts[j]);
            if b.r2 > best.r2 {
                best = b;
            }
        }
    }
    best
}

/// Smallest enclosing ball of at most four points by trying every support subset.
fn brute_small(pts: &[DVec3]) -> B {
    let n = pts.len();
    let mut best: Option<B> = None;
    let mut consider = |b: B| {
        if pts.iter().all(|p| b.contains(*p)) && best.is_none_or(|x| b.r2 < x.r2) {
            best = Some(b);
        }
    };
    for i in 0..n {
        consider(B { c: pts[i], r2: 0.0 });
        for j in i + 1..n {
            consider(ball2(pts[i], pts[j]));
            for k in j + 1..n {
                consider(ball3(pts[i], pts[j], pts[k]));
            }
        }
    }
    best.unwrap_or_else(|| farthest_pair_ball(pts))
}

/// Deterministic visiting order: indices sorted by a hash of the index.
fn order(n: usize) -> Vec<usize> {
    let mut idx: Vec<(u64, usize)> = (0..n).map(|i| (penumbra_math::rng::mix64(i as u64 ^ 0x5EED_BA11), i)).collect();
    idx.sort_unstable();
    idx.into_iter().map(|(_, i)| i).collect()
}

/// The minimum enclosing ball of `points` (`None` when empty or any point is non-finite).
pub fn min_enclosing_ball(points: &[[f64; 3]]) -> Option<Ball> {
    if points.is_empty() || points.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
        return None;
    }
    let pts: Vec<DVec3> = order(points.len()).into_iter().map(|i| DVec3::from(points[i])).collect();
    let mut b = B { c: pts[0], r2: 0.0 };
    for i in 1..pts.len() {
        if b.contains(pts[i]) {
            continue;
        }
        let pi = pts[i];
        b = B { c: pi, r2: 0.0 };
        for j in 0..i {
            if b.contains(pts[j]) {
                continue;
            }
            let pj = pts[j];
            b = ball2(pi, pj);
            for k in 0..j {
                if b.contains(pts[k]) {
                    continue;
                }
                let pk = pts[k];
                b = ball3(pi, pj, pk);
                for l in 0..k {
                    if !b.contains(pts[l]) {
                        b = ball4(pi, pj, pk, pts[l]);
                    }
                }
            }
        }
    }
    // exact containment in f64: the radius is the distance to the farthest point
    let r = pts.iter().map(|p| (*p - b.c).length()).fold(0.0, f64::max);
    Some(Ball { center: b.c.to_array(), radius: r })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute(points: &[[f64; 3]]) -> f64 {
        // every ball through ≤ 4 support points; the smallest containing all
        let p: Vec<DVec3> = points.iter().map(|&q| DVec3::from(q)).collect();
        let n = p.len();
        let mut best = f64::INFINITY;
        let mut try_ball = |b: B| {
            if b.r2.is_finite() && p.iter().all(|q| (*q - b.c).length_squared() <= b.r2 * (1.0 + 1e-9) + 1e-18) {
                best = best.min(b.r2.sqrt());
            }
        };
        for i in 0..n {
            try_ball(B { c: p[i], r2: 0.0 });
            for j in i + 1..n {
                try_ball(ball2(p[i], p[j]));
                for k in j + 1..n {
                    try_ball(ball3(p[i], p[j], p[k]));
                    for l in k + 1..n {
                        try_ball(ball4(p[i], p[j], p[k], p[l]));
                    }
                }
            }
        }
        best
    }

    #[test]
    fn known_answers() {
        // a regular tetrahedron's circumsphere
        let t = [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
        let b = min_enclosing_ball(&t).unwrap();
        assert!((b.radius - 3f64.sqrt()).abs() < 1e-12);
        assert!(b.center.iter().all(|c| c.abs() < 1e-12));
        // an obtuse triangle: the ball of its longest edge
        let b = min_enclosing_ball(&[[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [2.0, 0.5, 0.0]]).unwrap();
        assert!((b.radius - 2.0).abs() < 1e-12 && (b.center[0] - 2.0).abs() < 1e-12);
        // cube corners plus interior points
        let mut pts = vec![];
        for i in 0..8 {
            pts.push([(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]);
        }
        pts.push([0.5, 0.5, 0.5]);
        let b = min_enclosing_ball(&pts).unwrap();
        assert!((b.radius - 0.75f64.sqrt()).abs() < 1e-12);
        assert_eq!(min_enclosing_ball(&[[1.0, 2.0, 3.0]]).unwrap().radius, 0.0);
        assert!(min_enclosing_ball(&[]).is_none());
        assert!(min_enclosing_ball(&[[f64::NAN, 0.0, 0.0]]).is_none());
    }

    #[test]
    fn coplanar_and_cospherical_sets() {
        // points on a circle (coplanar, cospherical): radius of the circle
        let pts: Vec<[f64; 3]> = (0..50)
            .map(|i| {
                let a = i as f64 * 0.37;
                [3.0 + 2.0 * a.cos(), -1.0, 2.0 * a.sin()]
            })
            .collect();
        let b = min_enclosing_ball(&pts).unwrap();
        assert!((b.radius - 2.0).abs() < 1e-9, "{}", b.radius);
        // a fine grid on a sphere: everything on the boundary
        let mut pts = vec![];
        for i in 0..20 {
            for j in 0..20 {
                let (t, p) = (std::f64::consts::PI * (i as f64 + 0.5) / 20.0, 0.3 * j as f64);
                pts.push([5.0 * t.sin() * p.cos(), 5.0 * t.cos(), 5.0 * t.sin() * p.sin()]);
            }
        }
        let b = min_enclosing_ball(&pts).unwrap();
        assert!(b.radius <= 5.0 + 1e-9 && b.radius > 4.9, "{}", b.radius);
        assert!(pts.iter().all(|p| b.contains(*p)));
    }

    proptest! {
        #[test]
        fn matches_brute_force(pts in prop::collection::vec(prop::array::uniform3(-10.0f64..10.0), 1..9)) {
            let b = min_enclosing_ball(&pts).unwrap();
            prop_assert!(pts.iter().all(|p| b.contains(*p)));
            let r = brute(&pts);
            prop_assert!((b.radius - r).abs() <= 1e-9 * (1.0 + r), "welzl {} brute {}", b.radius, r);
        }

        #[test]
        fn contains_everything(pts in prop::collection::vec(prop::array::uniform3(-1e3f64..1e3), 1..300)) {
            let b = min_enclosing_ball(&pts).unwrap();
            prop_assert!(pts.iter().all(|p| b.contains(*p)));
        }
    }
}
