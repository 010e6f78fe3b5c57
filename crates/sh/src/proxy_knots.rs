//! The kinks of the proxy log table (issue #14 §1): where the eigenvalue clipping of the SH
//! log (SHEXP §5, eq. 32, ε = 0.02·λmax) engages or releases between two nodes of the uniform
//! α grid, the row `O^log(α)` has a slope discontinuity that no polynomial through the
//! cell's nodes can follow (0.55 % at order 8, α ≈ 0.415, K = 256). The bake finds every such
//! α by bisection (f64) and stores the exact row there as an extra node (SHTB kind_version 2,
//! section `proxy_log_knots`); the runtime splits the cell at it.

use crate::gamma::TripleProduct;
use crate::log::{LogForm, log_eigen_zonal_occlusion_with, zonal_clip_state};
use crate::zonal::cap_indicator;
use penumbra_math::sh::zh_star_scale;
use rayon::prelude::*;

/// One kink of the proxy log: its α and the exact starred log row there.
#[derive(Debug, Clone, PartialEq)]
pub struct ProxyKnot {
    /// `α = sin θ` of the kink, strictly inside its grid cell.
    pub alpha: f64,
    /// Starred ZH log of the cap at `θ = asin α` (the table's row, unclamped), `n` values.
    pub row: Vec<f64>,
}

/// Bisection steps: the cell (≥ 1/16383 wide) shrinks below 1e-16 in α.
const BISECTION_STEPS: usize = 48;

/// Knots closer than this fraction of a cell to a grid node are not stored: the node itself
/// is then (nearly) at the kink, and the knot's f32 α could round onto it.
pub const MIN_FRAC: f64 = 1e-3;

fn state(t: &TripleProduct, alpha: f64, eps_rel: f64) -> (usize, usize) {
    zonal_clip_state(t, &cap_indicator(t.order(), alpha.clamp(0.0, 1.0).asin()), eps_rel)
}

/// The kinks of the proxy log on the α grid `α_i = i/(K − 1)` (`k` = K), one per cell at
/// most: for every cell `[α_i, α_{i+1}]` whose two nodes both have smooth-clamp weight 1
/// (`weights`, the ramp is read elsewhere at run time), if the clipping state
/// ([`zonal_clip_state`]) differs between the nodes, the α where it first changes, found by
/// bisection on "state equals the left node's" to 2⁻⁴⁸ of the cell, with the exact
/// row there, α rounded to f32 as stored. Knots within [`MIN_FRAC`] of a cell of a node are
/// dropped (the node already is the kink). Sorted by α; deterministic.
pub fn proxy_log_knots(t: &TripleProduct, k: usize, weights: &[f64], eps_rel: f64, form: LogForm) -> Vec<ProxyKnot> {
    let n = t.order();
    let h = 1.0 / (k - 1) as f64;
    let states: Vec<(usize, usize)> = (0..k).into_par_iter().map(|i| state(t, i as f64 * h, eps_rel)).collect();
    let cells: Vec<usize> =
        (0..k - 1).filter(|&i| weights[i] == 1.0 && weights[i + 1] == 1.0 && states[i] != states[i + 1]).collect();
    cells
        .par_iter()
        .filter_map(|&i| {
            let left = states[i];
            let (mut lo, mut hi) = (i as f64 * h, (i + 1) as f64 * h);
            for _ in 0..BISECTION_STEPS {
                let mid = 0.5 * (lo + hi);
                if state(t, mid, eps_rel) == left {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // stored as f32: the row is the log at the rounded α, which must stay inside the
            // cell as the runtime sees it (α·(K−1) in f64)
            let alpha = (0.5 * (lo + hi)) as f32 as f64;
            let frac = alpha * (k - 1) as f64 - i as f64;
            if !(MIN_FRAC..=1.0 - MIN_FRAC).contains(&frac) {
                return None;
            }
            let log = log_eigen_zonal_occlusion_with(t, &cap_indicator(n, alpha.asin()), eps_rel, form);
            let row = log.iter().enumerate().map(|(l, v)| v * zh_star_scale(l)).collect();
            Some(ProxyKnot { alpha, row })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::EPS_REL;

    /// The largest one-sided slope mismatch of the row at `a`: `|(f(a+δ) − f(a)) − (f(a) − f(a−δ))|/δ`.
    fn slope_jump(t: &TripleProduct, a: f64, d: f64) -> f64 {
        let row = |x: f64| -> Vec<f64> {
            log_eigen_zonal_occlusion_with(t, &cap_indicator(t.order(), x.asin()), EPS_REL, LogForm::Paper)
        };
        let (l, c, r) = (row(a - d), row(a), row(a + d));
        (0..t.order()).map(|i| ((r[i] - c[i]) - (c[i] - l[i])).abs() / d).fold(0.0, f64::max)
    }

    #[test]
    fn knots_are_kinks_of_the_log_and_exact_rows() {
        // order 8, K = 256: the clipping engages near α = 0.415 (docs/tables.md); each knot
        // is a true slope discontinuity (second difference ∝ 1/δ at the knot, ∝ δ off it) and
        // its row is the f64 log there
        let t = TripleProduct::new(8);
        let k = 256;
        let knots = proxy_log_knots(&t, k, &vec![1.0; k], EPS_REL, LogForm::Paper);
        assert!(
            knots.iter().any(|kn| (kn.alpha - 0.415).abs() < 0.002),
            "{:?}",
            knots.iter().map(|k| k.alpha).collect::<Vec<_>>()
        );
        for kn in &knots {
            let cell = (kn.alpha * 255.0).floor();
            assert!(kn.alpha * 255.0 - cell > 0.0 && kn.alpha * 255.0 - cell < 1.0);
            let want = log_eigen_zonal_occlusion_with(&t, &cap_indicator(8, kn.alpha.asin()), EPS_REL, LogForm::Paper);
            for (l, v) in want.iter().enumerate() {
                assert!((kn.row[l] - v * zh_star_scale(l)).abs() <= 1e-12);
            }
        }
        let kn = knots.iter().find(|kn| (kn.alpha - 0.415).abs() < 0.002).unwrap();
        let at = slope_jump(&t, kn.alpha, 1e-5);
        let off = slope_jump(&t, kn.alpha - 2e-3, 1e-5);
        assert!(at > 100.0 * off, "slope jump at the knot {at:e}, 2e-3 below it {off:e}");
    }

    #[test]
    fn ramped_cells_get_no_knots_and_the_result_is_deterministic() {
        let t = TripleProduct::new(8);
        let k = 256;
        let all = proxy_log_knots(&t, k, &vec![1.0; k], EPS_REL, LogForm::Paper);
        let none = proxy_log_knots(&t, k, &vec![0.5; k], EPS_REL, LogForm::Paper);
        assert!(none.is_empty());
        assert_eq!(all, proxy_log_knots(&t, k, &vec![1.0; k], EPS_REL, LogForm::Paper));
        assert!(all.windows(2).all(|w| w[0].alpha < w[1].alpha));
    }
}
