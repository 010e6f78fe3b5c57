//! Exact energy balance of the one-bounce operator `F` (docs/mrt.md, "Energy").
//!
//! # Why
//! With equal-area texels, `‖F l‖₁ = Σ_j c_j l_j` where `c_j` is column `j`'s sum, so
//! `‖F l‖₁ ≤ ρ‖l‖₁` for every `l ≥ 0` holds exactly when every `c_j ≤ ρ`. Physically `c_j`
//! is the power that texel `j`'s reflected light deposits on the walls (per unit texel area
//! and irradiance), which is `ρ·g_j` with `g_j` the fraction of texel `j`'s cosine-weighted
//! emission that lands on a wall (area-averaged over the texel; 1 in a closed shape). A
//! collocated gather (rows evaluated at texel centres) gets the rows right — a point's
//! gather of uniform light is exactly `ρ·(its wall fraction)` — but not the columns: next to
//! a cube corner the receiving texel centres over-sample the kernel and `c_j` reaches
//! `1.032ρ` (the same with exact form factors: quadrature error, not noise).
//!
//! # What
//! The exact (Galerkin, equal-area) operator is symmetric by reciprocity, so its row sums
//! and its column sums are both `ρ·g`. We restore both marginals with the smallest
//! multiplicative change: `F ← D_r F D_c` with positive diagonal `D_r`, `D_c` found by
//! Sinkhorn–Knopp matrix scaling (alternating row and column normalisation; it minimises
//! the Kullback–Leibler divergence to `F` among matrices with those marginals). The last
//! step scales the columns, so every column sum is `ρ·g_j ≤ ρ` to rounding whatever the
//! convergence. In the closed cube `g = 1`: rows stay `ρ` (uniform light still reflects
//! exactly `ρ`) and columns become `ρ`. The corrections are a few percent next to corners
//! and edges and negligible elsewhere (docs/mrt.md measures the effect on every error).
//!
//! `g_j` is not sampled: it is `1 − Σ_openings FF(x → opening)` (Lambert's point-to-polygon
//! form factor, exact for the convex cube: every direction leaves through exactly one face)
//! averaged over texel `j` by a tensor Gauss–Legendre rule.

use crate::reference::point_polygon_form_factor;
use crate::shape::{FACE_FRAMES, Texels, face_point};
use faer::Mat;
use penumbra_math::quadrature::GaussLegendre;
use rayon::prelude::*;
use serde::Serialize;

/// Gauss–Legendre points per texel edge for the wall fractions (the integrand is smooth on
/// a texel; 8² points give ~1e-9 relative next to an opening's edge, where it is least so).
pub const WALL_FRACTION_ORDER: usize = 8;

/// Sinkhorn iterations at most (convergence is geometric, ~15 iterations reach 1e-12 here).
pub const MAX_ITERATIONS: usize = 500;

/// Stop when every row sum is within this relative distance of its target (after a column
/// step, which makes the columns exact).
pub const TOLERANCE: f64 = 1e-12;

/// What balancing changed.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct BalanceStats {
    /// Largest column sum divided by `ρ` before balancing.
    pub max_column_sum_before: f64,
    /// Largest `|c_j/(ρ g_j) − 1|` before balancing.
    pub max_column_dev_before: f64,
    /// Largest `|r_i/(ρ g_i) − 1|` before balancing (rows of a collocated gather are point
    /// values, the targets area averages: they differ next to openings only).
    pub max_row_dev_before: f64,
    /// Largest relative row-sum deviation from its target after balancing.
    pub max_row_dev_after: f64,
    /// Largest and smallest row scale `D_r`, and column scale `D_c`.
    pub row_scale_range: [f64; 2],
    /// Column scales' range.
    pub column_scale_range: [f64; 2],
    /// Sinkhorn iterations (row + column step each).
    pub iterations: usize,
}

/// `g_j`: the fraction of texel `j`'s cosine-weighted emission that lands on a wall of its
/// shape, area-averaged over the texel (module docs).
pub fn wall_fractions(tex: &Texels) -> Vec<f64> {
    wall_fractions_scaled(tex, [1.0; 3])
}

/// [`wall_fractions`] of the shape stretched to the box `scale` (a warped block,
/// [`crate::warp`]): positions and openings scaled per axis (× 1.0 is exact: the unit
/// shape's values are bit for bit [`wall_fractions`]'s).
pub fn wall_fractions_scaled(tex: &Texels, scale: [f64; 3]) -> Vec<f64> {
    let sc = |p: [f64; 3]| [p[0] * scale[0], p[1] * scale[1], p[2] * scale[2]];
    // 1 − (what leaves through the openings): exactly 1 in a closed shape, and 1–4 polygons
    // per point instead of 3–5 walls
    let openings: Vec<(usize, [[f64; 3]; 4])> = tex
        .shape
        .missing_faces()
        .into_iter()
        .map(|g| {
            (
                g,
                [
                    sc(face_point(g, 0.0, 0.0)),
                    sc(face_point(g, 1.0, 0.0)),
                    sc(face_point(g, 1.0, 1.0)),
                    sc(face_point(g, 0.0, 1.0)),
                ],
            )
        })
        .collect();
    if openings.is_empty() {
        return vec![1.0; tex.len()];
    }
    let gl = GaussLegendre::new(WALL_FRACTION_ORDER);
    let r = tex.res as f64;
    (0..tex.len())
        .into_par_iter()
        .map(|t| {
            let (f, i, j) = tex.coords(t);
            let n = FACE_FRAMES[f].n;
            let mut acc = 0.0;
            for (u, wu) in gl.on_interval(i as f64 / r, (i + 1) as f64 / r) {
                for (v, wv) in gl.on_interval(j as f64 / r, (j + 1) as f64 / r) {
                    let p = sc(face_point(f, u, v));
                    let ff: f64 = openings.iter().map(|(_, poly)| point_polygon_form_factor(p, n, poly)).sum();
                    acc += wu * wv * ff;
                }
            }
            // the weights sum to the texel's area 1/r²; clamp the rounding of "all escapes"
            (1.0 - acc * r * r).clamp(0.0, 1.0)
        })
        .collect()
}

/// Balances `f` in place so that its row and column sums equal `target` (module docs);
/// `target[j] = ρ·g_j`. Rows and columns whose target or sum is zero are left as they are
/// (a zero target with a nonzero sum is zeroed: no light can go there).
///
/// The scalings are kept as vectors (`f` itself is scaled once at the end), so an iteration
/// is two passes over the column-major matrix: `r = F d_c` and `c = Fᵀ d_r`.
pub fn balance(f: &mut Mat<f64>, target: &[f64], albedo: f64) -> BalanceStats {
    let n = f.nrows();
    assert_eq!(f.ncols(), n);
    assert_eq!(target.len(), n);
    let rel = |s: f64, t: f64| if t > 0.0 { (s / t - 1.0).abs() } else { s.abs() };
    let scale_of = |s: f64, t: f64| {
        if s > 0.0 && t > 0.0 {
            t / s
        } else if t > 0.0 {
            1.0
        } else {
            0.0
        }
    };
    // r_i = Σ_j F_ij d_j (column-major: accumulate column by column, in index order)
    let row_sums = |f: &Mat<f64>, d: &[f64]| {
        let mut r = vec![0.0; n];
        for (j, &dj) in d.iter().enumerate() {
            for (ri, x) in r.iter_mut().zip(f.col(j).iter()) {
                *ri += x * dj;
            }
        }
        r
    };
    // c_j = d_jᶜ Σ_i d_i F_ij
    let col_sums = |f: &Mat<f64>, d: &[f64]| -> Vec<f64> {
        (0..n).map(|j| f.col(j).iter().zip(d).map(|(x, di)| x * di).sum()).collect()
    };
    let ones = vec![1.0f64; n];
    let r0 = row_sums(f, &ones);
    let c0 = col_sums(f, &ones);
    let max_column_sum_before = c0.iter().copied().fold(0.0, f64::max) / albedo;
    let max_column_dev_before = c0.iter().zip(target).map(|(&s, &t)| rel(s, t)).fold(0.0, f64::max);
    let max_row_dev_before = r0.iter().zip(target).map(|(&s, &t)| rel(s, t)).fold(0.0, f64::max);
    let mut dr = vec![1.0f64; n];
    let mut dc = vec![1.0f64; n];
    let mut iterations = 0;
    let mut row_dev = max_row_dev_before;
    let mut r = r0;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        // rows: r_i currently = Σ_j F_ij dc_j (before the row scale)
        for ((d, &s), &t) in dr.iter_mut().zip(&r).zip(target) {
            *d = scale_of(s, t);
        }
        // columns of D_r F D_c: dc_j · Σ_i dr_i F_ij
        let c = col_sums(f, &dr);
        for ((d, &s), &t) in dc.iter_mut().zip(&c).zip(target) {
            *d = scale_of(s, t);
        }
        r = row_sums(f, &dc);
        row_dev = r.iter().zip(&dr).zip(target).map(|((&s, &d), &t)| rel(s * d, t)).fold(0.0, f64::max);
        if row_dev < TOLERANCE {
            break;
        }
    }
    for (j, &dcj) in dc.iter().enumerate() {
        for (x, &di) in f.col_mut(j).iter_mut().zip(&dr) {
            *x *= di * dcj;
        }
    }
    let range = |d: &[f64], t: &[f64]| {
        let it = d.iter().zip(t).filter(|(_, t)| **t > 0.0).map(|(d, _)| *d);
        [it.clone().fold(f64::INFINITY, f64::min), it.fold(0.0, f64::max)]
    };
    BalanceStats {
        max_column_sum_before,
        max_column_dev_before,
        max_row_dev_before,
        max_row_dev_after: row_dev,
        row_scale_range: range(&dr, target),
        column_scale_range: range(&dc, target),
        iterations,
    }
}

/// Balances the one-bounce operator of `tex` for albedo `albedo`: targets `ρ·g`.
pub fn balance_transport(tex: &Texels, f: &mut Mat<f64>, albedo: f64) -> BalanceStats {
    let target: Vec<f64> = wall_fractions(tex).into_iter().map(|g| albedo * g).collect();
    balance(f, &target, albedo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::{CLOSED, CUBE2D, Shape};

    #[test]
    fn wall_fractions_are_one_in_the_closed_cube_and_match_the_opening_form_factor() {
        let tex = Texels::new(CLOSED, 4);
        for g in wall_fractions(&tex) {
            assert!((g - 1.0).abs() < 1e-13, "{g}");
        }
        // floor and ceiling only: a floor texel's wall fraction is its area-averaged form
        // factor to the ceiling; the centre texel of a 1-texel floor sees 0.1998 (the classic
        // unit-square-to-unit-square form factor at distance 1)
        let fc = Shape::new("floor_ceiling", 0b11_0011);
        let tex = Texels::new(fc, 1);
        let g = wall_fractions(&tex);
        assert!((g[0] - 0.199_824_4).abs() < 1e-6, "{}", g[0]);
        // every shape with an opening loses some of every texel's emission
        for s in &CUBE2D[1..] {
            let tex = Texels::new(*s, 4);
            assert!(wall_fractions(&tex).iter().all(|&g| g > 0.0 && g < 1.0), "{}", s.name);
        }
    }

    #[test]
    fn balancing_restores_both_marginals() {
        let n = 5;
        let mut f = Mat::from_fn(n, n, |i, j| if i == j { 0.0 } else { 0.1 + 0.05 * ((i * 7 + j * 3) % 5) as f64 });
        let t = vec![0.9, 0.8, 0.95, 0.7, 0.85];
        let s = balance(&mut f, &t, 1.0);
        for i in 0..n {
            let r: f64 = (0..n).map(|j| f[(i, j)]).sum();
            let c: f64 = (0..n).map(|j| f[(j, i)]).sum();
            assert!((r - t[i]).abs() < 1e-11 && (c - t[i]).abs() < 1e-13, "{r} {c} {}", t[i]);
            assert_eq!(f[(i, i)], 0.0, "the zero pattern is kept");
        }
        assert!(s.iterations < MAX_ITERATIONS);
    }
}
