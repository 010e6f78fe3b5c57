//! Brute-force ground truth (DESIGN §1): a one-bounce path tracer on the analytic shape that
//! evaluates the direct light exactly where each ray lands (no texels, no prior, no bases),
//! and the exact point-to-polygon form factor.

use crate::gather::{DirectionSet, to_world};
use crate::prior::{DirectLight, SphereLight, slab_visibility};
use crate::shape::{FACE_FRAMES, Texels, exit_face};
use faer::Mat;
use penumbra_math::rng::{hash4, stage, unit_f64};
use rayon::prelude::*;

/// Form factor from a differential area at `x` with unit normal `n` to the convex polygon
/// `poly` (fully visible, on the front side of `x`'s plane): Lambert's formula
/// `(1/2π) Σ_i γ_i n·(R_i × R_{i+1})/|R_i × R_{i+1}|`, `γ_i` the angle between `R_i = v_i − x`
/// and `R_{i+1}`. Either winding works (the absolute value is taken).
pub fn point_polygon_form_factor(x: [f64; 3], n: [f64; 3], poly: &[[f64; 3]]) -> f64 {
    let k = poly.len();
    let r: Vec<[f64; 3]> = poly
        .iter()
        .map(|v| {
            let d = [v[0] - x[0], v[1] - x[1], v[2] - x[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            [d[0] / l, d[1] / l, d[2] / l]
        })
        .collect();
    let mut sum = 0.0;
    for i in 0..k {
        let (a, b) = (r[i], r[(i + 1) % k]);
        let c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
        let cl = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        if cl < 1e-300 {
            continue;
        }
        let gamma = cl.atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
        sum += gamma * (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) / cl;
    }
    (sum / (2.0 * core::f64::consts::PI)).abs()
}

/// Form factor between two directly opposed, parallel `a × b` rectangles a distance `c`
/// apart (Howell's catalogue, configuration C-11; exact): 0.19982 for opposite faces of a
/// cube.
pub fn ff_parallel_rectangles(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    let t = 0.5 * ((1.0 + x2) * (1.0 + y2) / (1.0 + x2 + y2)).ln()
        + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
        + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
        - x * x.atan()
        - y * y.atan();
    2.0 / (core::f64::consts::PI * x * y) * t
}

/// Form factor from a `w × l` rectangle to an `h × l` rectangle that shares its edge of length
/// `l` at a right angle (Howell's catalogue, configuration C-14; exact): 0.20004 between
/// adjacent faces of a cube.
pub fn ff_perpendicular_rectangles(w: f64, h: f64, l: f64) -> f64 {
    let (hh, ww) = (h / l, w / l);
    let (h2, w2) = (hh * hh, ww * ww);
    let s = (h2 + w2).sqrt();
    let ln = ((1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2)).ln()
        + w2 * (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).ln()
        + h2 * (h2 * (1.0 + h2 + w2) / ((1.0 + h2) * (h2 + w2))).ln();
    (ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan() - s * (1.0 / s).atan() + 0.25 * ln) / (core::f64::consts::PI * ww)
}

/// A path-traced one-bounce solution for a set of lights.
#[derive(Debug, Clone)]
pub struct OneBounce {
    /// Indirect irradiance at every texel centre, one column per light (n × lights).
    pub indirect: Mat<f64>,
    /// Half the difference of two independent half-sample estimates (same shape): an
    /// estimate of the reference's own Monte-Carlo error.
    pub half_difference: Mat<f64>,
}

/// One-bounce indirect irradiance at every texel centre of `tex` from `lights`, by
/// cosine-weighted path tracing with `rays` rays per texel in two independent halves (each a
/// Hammersley set of `rays/2` cosine directions, rotated about the normal by an angle from
/// the hash of `(seed, REFERENCE, shape, texel, half)`; a different point set and different
/// rotations from `F`'s), the direct light evaluated exactly (with wall shadowing) at each
/// hit point: no texels, no bilinear reads.
pub fn one_bounce(
    tex: &Texels,
    lights: &[SphereLight],
    albedo: f64,
    rays: usize,
    seed: u64,
    shape_id: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> OneBounce {
    let n = tex.len();
    let nl = lights.len();
    let half = (rays / 2).max(1);
    let dirs = DirectionSet::cosine(half);
    let dl = DirectLight::new();
    let slab: Vec<Option<f64>> = lights.iter().map(|l| slab_visibility(&tex.shape, l)).collect();
    let per: Vec<[Vec<f64>; 2]> = (0..n)
        .into_par_iter()
        .map(|x| {
            let (f, _, _) = tex.coords(x);
            let p = tex.position(x);
            let mut est = [vec![0.0; nl], vec![0.0; nl]];
            for (h, acc) in est.iter_mut().enumerate() {
                let item = (shape_id << 32) | x as u64;
                let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, stage::REFERENCE, item, h as u64));
                let rot = (phi.cos(), phi.sin());
                for l in &dirs.dirs {
                    let (_, d) = to_world(f, *l, rot);
                    let (g, t) = exit_face(p, d);
                    if g == usize::MAX || !tex.shape.has(g) {
                        continue;
                    }
                    let y = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
                    let ny = FACE_FRAMES[g].n;
                    for ((a, light), s) in acc.iter_mut().zip(lights).zip(&slab) {
                        *a += dl.irradiance_with(&tex.shape, light, *s, y, ny);
                    }
                }
                let s = albedo / half as f64;
                acc.iter_mut().for_each(|a| *a *= s);
            }
            if x % 64 == 63 {
                tick(64);
            }
            est
        })
        .collect();
    let indirect = Mat::from_fn(n, nl, |i, j| 0.5 * (per[i][0][j] + per[i][1][j]));
    let half_difference = Mat::from_fn(n, nl, |i, j| 0.5 * (per[i][0][j] - per[i][1][j]));
    OneBounce { indirect, half_difference }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn form_factor_of_a_coaxial_square_matches_the_closed_form() {
        // differential area to a parallel a×b rectangle at distance c with a corner on the
        // normal (the classic closed form); a centred square is four of them.
        let corner = |a: f64, b: f64, c: f64| {
            let (x, y) = (a / c, b / c);
            (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
                + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
                / (2.0 * core::f64::consts::PI)
        };
        let a = 0.3;
        let poly = [[-a, -a, 1.0], [a, -a, 1.0], [a, a, 1.0], [-a, a, 1.0]];
        let ff = point_polygon_form_factor([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], &poly);
        assert!((ff - 4.0 * corner(a, a, 1.0)).abs() < 1e-14, "{ff}");
        // an infinite plane has form factor 1; a huge square approaches it
        let b = 1e6;
        let big = [[-b, -b, 1.0], [b, -b, 1.0], [b, b, 1.0], [-b, b, 1.0]];
        assert!((point_polygon_form_factor([0.0; 3], [0.0, 0.0, 1.0], &big) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn closed_cube_faces_sum_to_one_from_any_wall_point() {
        use crate::shape::face_point;
        let x = [0.3, 0.0, 0.7];
        let n = [0.0, 1.0, 0.0];
        let mut sum = 0.0;
        for f in 0..6 {
            if f == 2 {
                continue;
            }
            let poly =
                [face_point(f, 0.0, 0.0), face_point(f, 1.0, 0.0), face_point(f, 1.0, 1.0), face_point(f, 0.0, 1.0)];
            sum += point_polygon_form_factor(x, n, &poly);
        }
        assert!((sum - 1.0).abs() < 1e-12, "{sum}");
    }

    #[test]
    fn rectangle_form_factors_match_the_cube_and_numerical_integration() {
        use penumbra_math::quadrature::GaussLegendre;
        let (opp, adj) = (ff_parallel_rectangles(1.0, 1.0, 1.0), ff_perpendicular_rectangles(1.0, 1.0, 1.0));
        // the textbook values for a unit cube, and a closed cube's sum rule
        assert!((opp - 0.19982).abs() < 5e-6 && (adj - 0.20004).abs() < 5e-6, "{opp} {adj}");
        assert!((opp + 4.0 * adj - 1.0).abs() < 1e-12, "{}", opp + 4.0 * adj);
        // area average of Lambert's point-to-polygon form factor over the source (an
        // independent route), for other proportions too; the adjacent case's integrand has a
        // log-singular slope at the shared edge, hence the looser tolerance
        let gl = GaussLegendre::new(48);
        let area_avg = |w: f64, l: f64, n: [f64; 3], at: &dyn Fn(f64, f64) -> [f64; 3], poly: &[[f64; 3]]| {
            gl.integrate(0.0, w, |u| gl.integrate(0.0, l, |v| point_polygon_form_factor(at(u, v), n, poly))) / (w * l)
        };
        let (a, b, c) = (2.0, 1.0, 0.5);
        let top = [[0.0, c, 0.0], [a, c, 0.0], [a, c, b], [0.0, c, b]];
        let got = area_avg(a, b, [0.0, 1.0, 0.0], &|u, v| [u, 0.0, v], &top);
        assert!((got - ff_parallel_rectangles(a, b, c)).abs() < 1e-9, "{got}");
        // source w × l in the floor (x ∈ [0, w], z ∈ [0, l]), target h × l in the wall x = 0
        let (w, h, l) = (0.7, 1.3, 1.1);
        let wall = [[0.0, 0.0, 0.0], [0.0, h, 0.0], [0.0, h, l], [0.0, 0.0, l]];
        let got = area_avg(w, l, [0.0, 1.0, 0.0], &|u, v| [u, 0.0, v], &wall);
        assert!((got - ff_perpendicular_rectangles(w, h, l)).abs() < 1e-4, "{got}");
        // reciprocity: A₁F₁₂ = A₂F₂₁
        assert!((w * ff_perpendicular_rectangles(w, h, l) - h * ff_perpendicular_rectangles(h, w, l)).abs() < 1e-14);
    }
}
