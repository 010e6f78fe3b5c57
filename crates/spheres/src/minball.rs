//! The exact minimal enclosing ball of a point set (Welzl 1991), in expected linear time on
//! a seeded random permutation. With one sphere, minimising SHEXP's outside volume
//! `V(S − T) = V(S) − V(T)` is minimising the radius, so `--count 1` returns this ball.

use penumbra_math::rng::ItemRng;

use crate::sphere::{Sphere, dist2};

/// Relative slack of the containment test inside the recursion (rounding only).
const EPS: f64 = 1e-12;

/// The smallest ball containing every point (`radius 0` at the origin for no points). The
/// result is made exactly bounding in f64: its radius is the largest distance from the
/// computed centre.
pub fn min_ball(points: &[[f64; 3]], seed: u64) -> Sphere {
    if points.is_empty() {
        return Sphere::new([0.0; 3], 0.0);
    }
    let mut pts = points.to_vec();
    let mut rng = ItemRng::new(seed, penumbra_math::rng::stage::SPHERES, 0x6d62);
    for i in (1..pts.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        pts.swap(i, j);
    }
    let mut support = Vec::with_capacity(4);
    let b = welzl(&pts, pts.len(), &mut support);
    let radius = crate::sphere::bounding_radius(b.center, points);
    Sphere::new(b.center, radius)
}

fn welzl(pts: &[[f64; 3]], n: usize, support: &mut Vec<[f64; 3]>) -> Sphere {
    let mut ball = ball_from_support(support);
    if support.len() == 4 {
        return ball;
    }
    for i in 0..n {
        let p = pts[i];
        if ball.radius < 0.0 || dist2(p, ball.center) > ball.radius * ball.radius * (1.0 + EPS) + 1e-300 {
            support.push(p);
            ball = welzl(pts, i, support);
            support.pop();
        }
    }
    ball
}

/// The smallest ball with all of `s` (≤ 4 points) on its boundary; for degenerate
/// configurations, the smallest ball through a subset that contains them all.
fn ball_from_support(s: &[[f64; 3]]) -> Sphere {
    match s.len() {
        0 => Sphere::new([0.0; 3], -1.0),
        1 => Sphere::new(s[0], 0.0),
        _ => circumball(s).unwrap_or_else(|| {
            // drop one older point at a time; keep the newest (the one that forced the call)
            let last = s.len() - 1;
            let mut best: Option<Sphere> = None;
            for skip in 0..last {
                let sub: Vec<[f64; 3]> = (0..s.len()).filter(|&k| k != skip).map(|k| s[k]).collect();
                let b = ball_from_support(&sub);
                let covers = s.iter().all(|p| dist2(*p, b.center) <= b.radius * b.radius * (1.0 + 1e-9) + 1e-300);
                if covers && best.is_none_or(|x| b.radius < x.radius) {
                    best = Some(b);
                }
            }
            best.unwrap_or_else(|| {
                let c = s[0];
                Sphere::new(c, s.iter().map(|p| dist2(*p, c)).fold(0.0, f64::max).sqrt())
            })
        }),
    }
}

/// The ball whose boundary passes through all points of `s` (2–4) with its centre in their
/// affine hull; `None` when they are (nearly) affinely dependent.
fn circumball(s: &[[f64; 3]]) -> Option<Sphere> {
    let p0 = s[0];
    let k = s.len() - 1;
    let v: Vec<[f64; 3]> = s[1..].iter().map(|p| [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]]).collect();
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // Gram system: Σ_j (v_i·v_j) λ_j = |v_i|²/2
    let mut g = [[0.0f64; 4]; 3];
    for i in 0..k {
        for j in 0..k {
            g[i][j] = dot(&v[i], &v[j]);
        }
        g[i][3] = 0.5 * dot(&v[i], &v[i]);
    }
    let scale = (0..k).map(|i| g[i][i]).fold(0.0, f64::max);
    // Gaussian elimination with partial pivoting
    for col in 0..k {
        let piv = (col..k).max_by(|&a, &b| g[a][col].abs().total_cmp(&g[b][col].abs()))?;
        if g[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        g.swap(col, piv);
        for r in 0..k {
            if r != col {
                let f = g[r][col] / g[col][col];
                for c in col..4 {
                    g[r][c] -= f * g[col][c];
                }
            }
        }
    }
    let mut c = p0;
    for i in 0..k {
        let l = g[i][3] / g[i][i];
        for d in 0..3 {
            c[d] += l * v[i][d];
        }
    }
    let r = s.iter().map(|p| dist2(*p, c)).fold(0.0, f64::max).sqrt();
    r.is_finite().then(|| Sphere::new(c, r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_math::rng::{hash4, unit_f64};

    fn brute_radius(points: &[[f64; 3]]) -> f64 {
        // the minimal ball is determined by ≤ 4 points: try all subsets of size ≤ 4 that
        // contain every point, keep the smallest
        let n = points.len();
        let mut best = f64::INFINITY;
        let mut consider = |s: &[[f64; 3]]| {
            if let Some(b) = if s.len() == 1 { Some(Sphere::new(s[0], 0.0)) } else { circumball(s) } {
                if points.iter().all(|p| dist2(*p, b.center) <= b.radius * b.radius * (1.0 + 1e-9)) {
                    best = best.min(b.radius);
                }
            }
        };
        for a in 0..n {
            consider(&[points[a]]);
            for b in a + 1..n {
                consider(&[points[a], points[b]]);
                for c in b + 1..n {
                    consider(&[points[a], points[b], points[c]]);
                    for d in c + 1..n {
                        consider(&[points[a], points[b], points[c], points[d]]);
                    }
                }
            }
        }
        best
    }

    #[test]
    fn matches_brute_force_on_random_sets() {
        for case in 0..30u64 {
            let n = 3 + (case as usize % 12);
            let pts: Vec<[f64; 3]> = (0..n)
                .map(|i| std::array::from_fn(|k| unit_f64(hash4(5, case, i as u64, k as u64)) * 2.0 - 1.0))
                .collect();
            let b = min_ball(&pts, case);
            let r = brute_radius(&pts);
            assert!((b.radius - r).abs() <= 1e-9 * r.max(1.0), "case {case}: {} vs {r}", b.radius);
            assert!(pts.iter().all(|p| b.contains(*p)));
        }
    }

    #[test]
    fn degenerate_sets() {
        // collinear, coplanar grid, duplicated points
        let line: Vec<[f64; 3]> = (0..50).map(|i| [i as f64, 2.0 * i as f64, 0.0]).collect();
        let b = min_ball(&line, 1);
        assert!((b.radius - 0.5 * (49f64.powi(2) * 5.0).sqrt()).abs() < 1e-9);
        let mut grid = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                grid.push([i as f64, j as f64, 3.0]);
                grid.push([i as f64, j as f64, 3.0]);
            }
        }
        let b = min_ball(&grid, 2);
        assert!((b.radius - 9.0 * 2f64.sqrt() / 2.0).abs() < 1e-9, "{b:?}");
        assert!(grid.iter().all(|p| b.contains(*p)));
        assert_eq!(min_ball(&[[1.0, 2.0, 3.0]], 0), Sphere::new([1.0, 2.0, 3.0], 0.0));
    }
}
