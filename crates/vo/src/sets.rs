//! Sample-set generators (MRT thesis §6.3.5): the electrostatic 1/d⁴ sets and the three
//! baselines the thesis tried first (Lloyd relaxation, quasi-Monte Carlo, Poisson dart
//! throwing), all in the unit disk under `dμ = 2√(1 − r²) dA` or the unit ball.
//!
//! Every random draw is `hash4(seed, stage::VO, item, counter)` with `item` encoding
//! (domain, centre, N, start), so a set does not depend on which thread bakes it.

use crate::voronoi::{Domain, Grid};
use penumbra_math::rng::ItemRng;

/// Random stage of the sample-set bake (distinct from every other stage's).
pub const STAGE_VO: u64 = 18;

/// Item id of one (domain, centre, N, start) — unique per random stream.
pub fn item_id(domain: Domain, centre: bool, n: usize, start: usize) -> u64 {
    ((domain as u64) << 40) | ((centre as u64) << 39) | ((n as u64) << 20) | start as u64
}

/// Maps `u ∈ [0,1)^3` to a point of the domain distributed by its measure: the disk by
/// `r = √(1 − (1 − u)^{2/3})` (the inverse of `F(R) = 1 − (1 − R²)^{3/2}`, the μ-mass of the
/// disk of radius R), the ball by `r = u^{1/3}`.
pub fn warp(domain: Domain, u: [f64; 3]) -> [f64; 3] {
    use std::f64::consts::TAU;
    match domain {
        Domain::Disk => {
            let r = (1.0 - (1.0 - u[0]).powf(2.0 / 3.0)).max(0.0).sqrt();
            let t = TAU * u[1];
            [r * t.cos(), r * t.sin(), 0.0]
        }
        Domain::Ball => {
            let r = u[0].cbrt();
            let z = 1.0 - 2.0 * u[1];
            let s = (1.0 - z * z).max(0.0).sqrt();
            let t = TAU * u[2];
            [r * s * t.cos(), r * s * t.sin(), r * z]
        }
    }
}

fn norm2(p: &[f64; 3]) -> f64 {
    p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
}

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// Typical spacing of `n` points in the domain (edge of a cube/square of the mean cell size).
pub fn spacing(domain: Domain, n: usize) -> f64 {
    match domain {
        Domain::Disk => (std::f64::consts::PI / n as f64).sqrt(),
        Domain::Ball => (4.0 * std::f64::consts::PI / 3.0 / n as f64).cbrt(),
    }
}

/// Poisson-disk dart throwing under the domain's measure: candidates drawn from μ (via
/// [`warp`]), accepted when farther than `radius` from every accepted point; after 256
/// consecutive rejections the radius shrinks by 5 %. With `centre`, the first sample is the
/// origin.
pub fn poisson(domain: Domain, n: usize, centre: bool, rng: &mut ItemRng) -> Vec<[f64; 3]> {
    let mut pts: Vec<[f64; 3]> = Vec::with_capacity(n);
    if centre && n > 0 {
        pts.push([0.0; 3]);
    }
    let mut radius = 0.9 * spacing(domain, n);
    let mut fails = 0;
    while pts.len() < n {
        let p = warp(domain, [rng.next_f64(), rng.next_f64(), rng.next_f64()]);
        let r2 = radius * radius;
        if pts.iter().all(|q| dist2(&p, q) >= r2) {
            pts.push(p);
            fails = 0;
        } else {
            fails += 1;
            if fails >= 256 {
                radius *= 0.95;
                fails = 0;
            }
        }
    }
    pts
}

/// Radical inverse of `i` in base `b`.
pub fn radical_inverse(mut i: u64, b: u64) -> f64 {
    let inv = 1.0 / b as f64;
    let mut f = inv;
    let mut r = 0.0;
    while i > 0 {
        r += f * (i % b) as f64;
        i /= b;
        f *= inv;
    }
    r
}

/// Halton points (bases 2, 3, 5; indices 1, 2, …) warped to the domain's measure; with
/// `centre`, the origin and N − 1 Halton points. Halton rather than Sobol: in two and three
/// dimensions it needs no direction-number table, and both are (0,m,s)-type low-discrepancy
/// sequences of the same order.
pub fn halton(domain: Domain, n: usize, centre: bool) -> Vec<[f64; 3]> {
    let mut pts = Vec::with_capacity(n);
    if centre && n > 0 {
        pts.push([0.0; 3]);
    }
    let mut i = 1u64;
    while pts.len() < n {
        pts.push(warp(domain, [radical_inverse(i, 2), radical_inverse(i, 3), radical_inverse(i, 5)]));
        i += 1;
    }
    pts
}

/// Lloyd relaxation under μ on a discrete diagram: every free sample moves to the weighted
/// centroid of its cell, `iterations` times (the centre sample, if any, stays put).
pub fn lloyd(grid: &Grid, mut pts: Vec<[f64; 3]>, centre: bool, iterations: usize) -> Vec<[f64; 3]> {
    let first = usize::from(centre);
    for _ in 0..iterations {
        let c = grid.cells(&pts);
        let n = pts.len();
        pts[first..n].copy_from_slice(&c.centroid[first..n]);
    }
    pts
}

/// Knobs of the electrostatic optimisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElectroParams {
    /// Poisson starting sets ("tens of starting point sets", §6.3.5).
    pub starts: usize,
    /// Boundary-charge adaptations (each computes one discrete diagram) per start.
    pub rounds: usize,
    /// Repulsion steps between adaptations.
    pub steps: usize,
}

impl ElectroParams {
    /// Starting sets at N samples: `starts` up to N = 16 (where the thesis saw the largest
    /// gains), then `starts · 16 / N` but at least 6 — the cost of a start grows as N².
    pub fn starts_for(&self, n: usize) -> usize {
        let s = self.starts.max(1);
        if n <= 16 { s } else { (s * 16 / n).max(6.min(s)) }
    }
}

impl Default for ElectroParams {
    fn default() -> Self {
        ElectroParams { starts: 24, rounds: 10, steps: 30 }
    }
}

/// Energy of a configuration and the force on every sample:
/// pairs repel with force `1/d⁴` (potential `1/(3d³)`), and the boundary charge `q` acts
/// through the potential `q/(3(1 − r²))`, the field of a uniformly charged unit sphere under
/// the same law (∮ (1 + r² − 2ru)^{-3/2}/3 du/2 = 1/(3(1 − r²))). The disk is the sphere's
/// orthographic projection (thesis footnote 6), so the same shell bounds it. Under 1/d² the
/// shell would exert no force inside (Gauss's law, §6.3.5).
fn energy_forces(pts: &[[f64; 3]], q: f64, dim: usize, forces: &mut [[f64; 3]]) -> f64 {
    let n = pts.len();
    let mut e = 0.0;
    for f in forces.iter_mut() {
        *f = [0.0; 3];
    }
    for i in 0..n {
        let pi = pts[i];
        let r2 = norm2(&pi);
        if r2 >= 1.0 {
            return f64::INFINITY;
        }
        let om = 1.0 - r2;
        e += q / (3.0 * om);
        let g = q * 2.0 / (3.0 * om * om);
        for k in 0..dim {
            forces[i][k] -= g * pi[k];
        }
        for j in (i + 1)..n {
            let mut dv = [0.0; 3];
            let mut d2 = 0.0;
            for k in 0..dim {
                dv[k] = pi[k] - pts[j][k];
                d2 += dv[k] * dv[k];
            }
            let d2 = d2.max(1e-18);
            let inv = 1.0 / d2.sqrt();
            let inv3 = inv * inv * inv;
            e += inv3 / 3.0;
            let f = inv3 * inv * inv; // |F| = 1/d⁴ along dv/d
            for k in 0..dim {
                forces[i][k] += f * dv[k];
                forces[j][k] -= f * dv[k];
            }
        }
    }
    e
}

/// One electrostatic run from a starting set: adaptive-step descent of the repulsion energy,
/// with the boundary charge adapted after every `steps` steps so that samples move toward the
/// weighted centroids of their discrete Voronoi cells on `grid` (MRT thesis §6.3.5).
pub fn electrostatic_run(grid: &Grid, mut pts: Vec<[f64; 3]>, centre: bool, p: &ElectroParams) -> Vec<[f64; 3]> {
    let domain = grid.domain();
    let dim = domain.dim();
    let n = pts.len();
    let first = usize::from(centre);
    if n == first {
        return pts;
    }
    let s = spacing(domain, n);
    // boundary charge: initial guess of the order of the pair forces at the typical spacing
    let mut q = n as f64 * s.powi(-3) * 0.05;
    let mut forces = vec![[0.0; 3]; n];
    let mut trial = pts.clone();
    let mut trial_f = vec![[0.0; 3]; n];
    let mut h = 0.1 * s;
    for _round in 0..p.rounds {
        let mut e = energy_forces(&pts, q, dim, &mut forces);
        for _ in 0..p.steps {
            let fmax = forces[first..].iter().map(|f| norm2(f).sqrt()).fold(0.0f64, f64::max);
            if fmax <= 0.0 || !fmax.is_finite() {
                break;
            }
            // adaptive step: a step is applied only when it lowers the energy; the step grows
            // after a success and halves after a failure (§6.3.5)
            let mut accepted = false;
            for _ in 0..12 {
                for i in 0..n {
                    trial[i] = pts[i];
                    if i >= first {
                        for k in 0..dim {
                            trial[i][k] += h * forces[i][k] / fmax;
                        }
                    }
                }
                let et = energy_forces(&trial, q, dim, &mut trial_f);
                if et < e {
                    std::mem::swap(&mut pts, &mut trial);
                    std::mem::swap(&mut forces, &mut trial_f);
                    e = et;
                    h *= 1.25;
                    accepted = true;
                    break;
                }
                h *= 0.5;
            }
            if !accepted {
                break;
            }
        }
        // adapt the boundary charge: centroids farther out than their samples mean the
        // boundary pushes too hard (and vice versa)
        let cells = grid.cells(&pts);
        let mut disc = 0.0;
        for i in first..n {
            disc += cells.centroid[i][..dim].iter().map(|x| x * x).sum::<f64>().sqrt() - norm2(&pts[i]).sqrt();
        }
        disc /= (n - first) as f64 * s;
        q *= (-4.0 * disc).exp().clamp(0.5, 2.0);
        h = h.max(0.02 * s);
    }
    pts
}

/// Half-space trials of the selection among starts (independent of the reported noise's).
pub const SELECTION_TRIALS: usize = 512;

/// The electrostatic set: `starts` Poisson starting sets, each optimised by
/// [`electrostatic_run`] with its boundary charge adapted on the coarse `adapt` diagram; of
/// those, the set whose estimator (weights from the `grid` diagram) has the lowest error on
/// [`SELECTION_TRIALS`] random half-spaces — drawn from a stream independent of the one
/// [`crate::quality::noise`] reports on — is kept ("keep the best", §6.3.5; ties: the earlier
/// start).
pub fn electrostatic(adapt: &Grid, grid: &Grid, n: usize, centre: bool, seed: u64, p: &ElectroParams) -> Vec<[f64; 3]> {
    let domain = grid.domain();
    let mut best: Option<(Vec<[f64; 3]>, f64)> = None;
    let selection_seed = penumbra_math::rng::hash4(seed, STAGE_VO, 0x5e1ec7, 0);
    for start in 0..p.starts_for(n) {
        let mut rng = ItemRng::new(seed, STAGE_VO, item_id(domain, centre, n, start));
        let init = poisson(domain, n, centre, &mut rng);
        let pts = electrostatic_run(adapt, init, centre, p);
        let w = grid.cells(&pts).mass;
        let err =
            crate::quality::noise(domain, &pts, &w, SELECTION_TRIALS, selection_seed, item_id(domain, centre, n, 0));
        if best.as_ref().is_none_or(|b| err < b.1) {
            best = Some((pts, err));
        }
    }
    best.map(|b| b.0).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_follow_the_measure() {
        // μ-mass of the disk of radius 1/2: 1 − (3/4)^{3/2}; ball: 1/8
        let m = 20000;
        for (domain, frac) in [(Domain::Disk, 1.0 - 0.75f64.powf(1.5)), (Domain::Ball, 0.125)] {
            let inside = (0..m)
                .filter(|&i| {
                    let u = [radical_inverse(i, 2), radical_inverse(i, 3), radical_inverse(i, 5)];
                    norm2(&warp(domain, u)) < 0.25
                })
                .count();
            assert!((inside as f64 / m as f64 - frac).abs() < 2e-3, "{domain:?}");
        }
    }

    #[test]
    fn poisson_respects_its_shrinking_radius_and_centre() {
        let mut r = ItemRng::new(1, STAGE_VO, 0);
        let p = poisson(Domain::Ball, 20, true, &mut r);
        assert_eq!(p.len(), 20);
        assert_eq!(p[0], [0.0; 3]);
        assert!(p.iter().all(|q| norm2(q) < 1.0));
        let dmin =
            (0..20).flat_map(|i| (0..i).map(move |j| (i, j))).map(|(i, j)| dist2(&p[i], &p[j])).fold(9.0, f64::min);
        assert!(dmin.sqrt() > 0.3 * spacing(Domain::Ball, 20));
    }

    #[test]
    fn forces_are_the_energy_gradient() {
        let pts = vec![[0.1, 0.2, 0.0], [-0.3, 0.1, 0.2], [0.4, -0.4, -0.1]];
        let mut f = vec![[0.0; 3]; 3];
        let e = energy_forces(&pts, 0.7, 3, &mut f);
        let h = 1e-6;
        for i in 0..3 {
            for k in 0..3 {
                let mut p2 = pts.clone();
                p2[i][k] += h;
                let mut g = vec![[0.0; 3]; 3];
                let e2 = energy_forces(&p2, 0.7, 3, &mut g);
                let num = -(e2 - e) / h;
                assert!((num - f[i][k]).abs() < 1e-4 * (1.0 + num.abs()), "{num} {}", f[i][k]);
            }
        }
        // the shell potential 1/(3(1 − r²)) equals the average of 1/(3d³) over the unit sphere
        let p = [0.3, -0.2, 0.5];
        let mut acc = 0.0;
        let m = 400;
        for a in 0..m {
            for b in 0..2 * m {
                let z = -1.0 + 2.0 * (a as f64 + 0.5) / m as f64;
                let t = std::f64::consts::PI * (b as f64 + 0.5) / m as f64;
                let s = (1.0 - z * z).sqrt();
                let d = dist2(&p, &[s * t.cos(), s * t.sin(), z]).sqrt();
                acc += 1.0 / (3.0 * d * d * d);
            }
        }
        acc /= (2 * m * m) as f64;
        assert!((acc - 1.0 / (3.0 * (1.0 - norm2(&p)))).abs() < 1e-3 * acc, "{acc}");
    }

    #[test]
    fn electrostatic_beats_its_start_and_keeps_the_centre() {
        let g = Grid::new(Domain::Ball, 32);
        let mut r = ItemRng::new(3, STAGE_VO, 1);
        let init = poisson(Domain::Ball, 12, true, &mut r);
        let cv0 = g.cells(&init).cv();
        let p = electrostatic_run(&g, init, true, &ElectroParams::default());
        let cv = g.cells(&p).cv();
        assert_eq!(p[0], [0.0; 3]);
        assert!(cv < 0.7 * cv0, "{cv} vs start {cv0}");
        assert!(p.iter().all(|q| norm2(q) < 1.0));
    }
}
