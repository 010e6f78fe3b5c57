//! Union-aware refinement after the Lloyd fit (issue 16).
//!
//! SHEXP §6.2's objective E = Σ V(Sᵢ − T) counts an outside region once per sphere that
//! covers it, and its clustering gives every element to exactly one sphere, so a sphere keeps
//! bounding elements that a neighbour already bounds. What leaks light, and what the union
//! ratio measures, is V(∪Sᵢ − T). This pass keeps the clustering's guarantee (every element,
//! a whole sub-triangle or an interior point, lies inside one sphere, so the continuous surface
//! is bounded) but lets an element be *owned* by any sphere that contains it whole:
//!
//! 1. Spheres are visited in order of decreasing outside volume (index order on ties).
//! 2. A visited sphere hands each element it owns to another sphere that contains all its
//!    points (the one with the largest radius: it is the least likely to shrink later).
//! 3. It then shrinks to what it still owns: Powell on the centre with the radius bounding the
//!    owned points (the Lloyd update, SHEXP §6.2), started from its current centre, so the new
//!    radius never exceeds the old one. A sphere left with nothing is dropped.
//!
//! Every step keeps every element inside its owner, so the set stays bounding; radii only
//! shrink, so E and the union ratio only fall. The pass repeats while it shrinks anything
//! (at most `passes` times). Sequential in a fixed order, so deterministic for any thread
//! count (the Powell updates of one pass are independent only within a sphere).

use rayon::prelude::*;

use crate::lloyd::update_sphere;
use crate::samples::Samples;
use crate::sphere::{Sphere, dist2};
use crate::volume::VolumeModel;

/// `V(∪ spheres − T)` by the volume model: each sphere's outside volume not inside an earlier
/// one, summed (inclusion in index order, so every outside point counts once).
pub fn union_outside(model: &VolumeModel, spheres: &[Sphere]) -> f64 {
    // the terms in parallel, summed in index order (the same value for any thread count)
    let terms: Vec<f64> =
        (0..spheres.len()).into_par_iter().map(|i| model.exclusive_outside(&spheres[i], &spheres[..i])).collect();
    terms.iter().sum()
}

/// What the refinement did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RefineStats {
    /// Passes run.
    pub passes: usize,
    /// Spheres dropped because the others bounded all their elements.
    pub dropped: usize,
}

/// Refines `spheres` (canonical frame) with the owner of every element in `assign`; returns the
/// kept spheres, the owners re-indexed to them, and what was done.
pub fn refine(
    samples: &Samples,
    model: &VolumeModel,
    spheres: &[Sphere],
    assign: &[u32],
    passes: usize,
) -> (Vec<Sphere>, Vec<u32>, RefineStats) {
    let n = spheres.len();
    let mut sph: Vec<Sphere> = spheres.to_vec();
    let mut owner: Vec<u32> = assign.to_vec();
    let mut alive = vec![true; n];
    let mut stats = RefineStats::default();
    let contains_whole = |s: &Sphere, e: usize| -> bool {
        let r2 = s.radius * s.radius;
        samples.elements[e].point_ids().iter().all(|&p| dist2(samples.points[p as usize], s.center) <= r2)
    };
    for _ in 0..passes {
        stats.passes += 1;
        let outside: Vec<f64> = sph.par_iter().map(|s| model.outside_volume(s.center, s.radius)).collect();
        let mut order: Vec<usize> = (0..n).filter(|&i| alive[i]).collect();
        order.sort_by(|&a, &b| outside[b].total_cmp(&outside[a]).then(a.cmp(&b)));
        // the elements each sphere owns
        let mut owned: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (e, &o) in owner.iter().enumerate() {
            owned[o as usize].push(e as u32);
        }
        let mut changed = false;
        for &i in &order {
            let mine = std::mem::take(&mut owned[i]);
            let mut keep = Vec::with_capacity(mine.len());
            for &e in &mine {
                let e = e as usize;
                let rep = samples.elements[e].rep;
                let mut best: Option<usize> = None;
                for (j, sj) in sph.iter().enumerate() {
                    if j == i || !alive[j] || sj.radius <= 0.0 {
                        continue;
                    }
                    // quick reject by the representative point (inside the element's hull)
                    if dist2(rep, sj.center) > sj.radius * sj.radius {
                        continue;
                    }
                    if contains_whole(sj, e) && best.is_none_or(|b: usize| sj.radius > sph[b].radius) {
                        best = Some(j);
                    }
                }
                match best {
                    Some(j) => {
                        owner[e] = j as u32;
                        owned[j].push(e as u32);
                    }
                    None => keep.push(e as u32),
                }
            }
            if keep.is_empty() {
                alive[i] = false;
                stats.dropped += 1;
                changed = true;
                continue;
            }
            if keep.len() == mine.len() {
                owned[i] = keep;
                continue;
            }
            let mut ids: Vec<u32> =
                keep.iter().flat_map(|&e| samples.elements[e as usize].point_ids().to_vec()).collect();
            ids.sort_unstable();
            ids.dedup();
            let pts: Vec<[f64; 3]> = ids.iter().map(|&k| samples.points[k as usize]).collect();
            // the shrunk sphere about the same centre lies inside the old one, so the union can
            // only lose volume; Powell may find a centre with less outside volume still
            let c0 = sph[i].center;
            let a = Sphere::new(c0, crate::sphere::bounding_radius(c0, &pts));
            let (b, fb) = update_sphere(model, &pts, c0);
            let s = if fb < model.outside_volume(a.center, a.radius) && b.radius <= sph[i].radius { b } else { a };
            if s.radius < sph[i].radius || s.center != c0 {
                sph[i] = s;
                changed = true;
            }
            owned[i] = keep;
        }
        if !changed {
            break;
        }
    }
    // re-index the kept spheres
    let mut new_index = vec![u32::MAX; n];
    let mut out = Vec::with_capacity(n);
    for (i, s) in sph.iter().enumerate() {
        if alive[i] {
            new_index[i] = out.len() as u32;
            out.push(*s);
        }
    }
    let owner = owner.iter().map(|&o| new_index[o as usize]).collect();
    (out, owner, stats)
}

/// [`refine`], then spends the spheres it dropped again: the sphere with the largest outside
/// volume is split in two along the farthest pair of its owned points (each half bounded by the
/// Lloyd update from its centroid) when the two halves add less outside volume to the union of
/// the other spheres than the whole did, and the set is refined again; up to `target` spheres.
/// If no split of the `SPLIT_TRIES` worst spheres helps, the set keeps fewer spheres than
/// requested.
pub fn refine_to_count(
    samples: &Samples,
    model: &VolumeModel,
    spheres: &[Sphere],
    assign: &[u32],
    target: usize,
) -> (Vec<Sphere>, Vec<u32>, RefineStats) {
    const PASSES: usize = 4;
    const SPLIT_TRIES: usize = 8;
    const MAX_SPLIT_ROUNDS: usize = 16;
    let (mut sph, mut owner, mut stats) = refine(samples, model, spheres, assign, PASSES);
    // each round refines the whole set again (elements × spheres): a fixed cap keeps the
    // pass well below the Lloyd fit's cost
    let mut rounds = 0;
    while sph.len() < target && rounds < MAX_SPLIT_ROUNDS {
        rounds += 1;
        let n = sph.len();
        let outside: Vec<f64> = sph.par_iter().map(|s| model.outside_volume(s.center, s.radius)).collect();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| outside[b].total_cmp(&outside[a]).then(a.cmp(&b)));
        let mut split = None;
        for &w in order.iter().take(SPLIT_TRIES) {
            let elems: Vec<usize> = (0..owner.len()).filter(|&e| owner[e] as usize == w).collect();
            // judged by the union: the outside volume the halves add to the other spheres
            // against what the whole adds (E would count the halves' overlap twice and reject
            // every split of a tube, whose halves both span its cross-section)
            let others: Vec<Sphere> = (0..n).filter(|&k| k != w).map(|k| sph[k]).collect();
            if let Some((a, b, ea, eb, _)) = split_elements(samples, model, &elems, &others) {
                let before = model.exclusive_outside(&sph[w], &others);
                let after_a = model.exclusive_outside(&a.0, &others);
                let mut with_a = others.clone();
                with_a.push(a.0);
                let after_b = model.exclusive_outside(&b.0, &with_a);
                if after_a + after_b < before {
                    split = Some((w, a.0, b.0, ea, eb));
                    break;
                }
            }
        }
        let Some((w, a, b, ea, eb)) = split else { break };
        sph[w] = a;
        sph.push(b);
        for e in ea {
            owner[e] = w as u32;
        }
        for e in eb {
            owner[e] = n as u32;
        }
        let (s2, o2, st) = refine(samples, model, &sph, &owner, 1);
        (sph, owner) = (s2, o2);
        stats.passes += st.passes;
        stats.dropped += st.dropped;
    }
    (sph, owner, stats)
}

/// Splits elements into two groups by a plane through their centroid, trying the farthest-pair
/// direction and the three principal axes of the element positions (a short slab of a tube is
/// split along the tube by its smallest axis, which the farthest pair, across the tube, misses).
/// The candidate whose two minimal enclosing balls add the least outside volume to `others`
/// wins; each half is then bounded by the Lloyd update from its ball's centre.
#[allow(clippy::type_complexity)]
fn split_elements(
    samples: &Samples,
    model: &VolumeModel,
    elems: &[usize],
    others: &[Sphere],
) -> Option<((Sphere, f64), (Sphere, f64), Vec<usize>, Vec<usize>, f64)> {
    if elems.len() < 2 {
        return None;
    }
    let reps: Vec<[f64; 3]> = elems.iter().map(|&e| samples.elements[e].rep).collect();
    let m = reps.len() as f64;
    let centroid: [f64; 3] = std::array::from_fn(|d| reps.iter().map(|p| p[d]).sum::<f64>() / m);
    let farthest =
        |from: [f64; 3]| *reps.iter().max_by(|a, b| dist2(**a, from).total_cmp(&dist2(**b, from))).unwrap_or(&from);
    let a = farthest(centroid);
    let b = farthest(a);
    let mut dirs = vec![std::array::from_fn(|d| b[d] - a[d])];
    let cov: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| reps.iter().map(|p| (p[i] - centroid[i]) * (p[j] - centroid[j])).sum::<f64>() / m)
    });
    dirs.extend(eigenvectors(cov));
    let points_of = |es: &[usize]| -> Vec<[f64; 3]> {
        let mut ids: Vec<u32> = es.iter().flat_map(|&e| samples.elements[e].point_ids().to_vec()).collect();
        ids.sort_unstable();
        ids.dedup();
        ids.iter().map(|&k| samples.points[k as usize]).collect()
    };
    let mut best: Option<(f64, Vec<usize>, Vec<usize>, [f64; 3], [f64; 3])> = None;
    for dir in dirs {
        let side = |p: [f64; 3]| (0..3).map(|d| (p[d] - centroid[d]) * dir[d]).sum::<f64>() <= 0.0;
        let (mut ea, mut eb) = (Vec::new(), Vec::new());
        for (k, &e) in elems.iter().enumerate() {
            if side(reps[k]) { ea.push(e) } else { eb.push(e) }
        }
        if ea.is_empty() || eb.is_empty() {
            continue;
        }
        let (pa, pb) = (points_of(&ea), points_of(&eb));
        let (Some(ba), Some(bb)) =
            (penumbra_geometry::min_enclosing_ball(&pa), penumbra_geometry::min_enclosing_ball(&pb))
        else {
            continue;
        };
        let sa = Sphere::new(ba.center, crate::sphere::bounding_radius(ba.center, &pa));
        let sb = Sphere::new(bb.center, crate::sphere::bounding_radius(bb.center, &pb));
        let mut with_a = others.to_vec();
        let cost_a = model.exclusive_outside(&sa, &with_a);
        with_a.push(sa);
        let cost = cost_a + model.exclusive_outside(&sb, &with_a);
        if best.as_ref().is_none_or(|x| cost < x.0) {
            best = Some((cost, ea, eb, sa.center, sb.center));
        }
    }
    let (cost, ea, eb, ca, cb) = best?;
    let fa = update_sphere(model, &points_of(&ea), ca);
    let fb = update_sphere(model, &points_of(&eb), cb);
    Some((fa, fb, ea, eb, cost))
}

/// Eigenvectors of a symmetric 3×3 matrix (cyclic Jacobi rotations; the order is irrelevant
/// here, every axis is tried).
fn eigenvectors(mut a: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off <= 1e-30 * (a[0][0].abs() + a[1][1].abs() + a[2][2].abs()) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // columns of v are the eigenvectors
    std::array::from_fn(|j| [v[0][j], v[1][j], v[2][j]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_finds_the_axes_of_a_rotated_diagonal_matrix() {
        // A = R diag(3, 2, 1) Rᵀ with R a rotation about z by 30°: eigenvectors are R's columns
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let r = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        let d = [3.0, 2.0, 1.0];
        let a: [[f64; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| r[i][k] * d[k] * r[j][k]).sum()));
        let v = eigenvectors(a);
        let cols: [[f64; 3]; 3] = std::array::from_fn(|k| [r[0][k], r[1][k], r[2][k]]);
        for (k, col) in cols.iter().enumerate() {
            let best = v.iter().map(|e| (0..3).map(|i| e[i] * col[i]).sum::<f64>().abs()).fold(0.0, f64::max);
            assert!((best - 1.0).abs() < 1e-12, "axis {k}: {v:?}");
        }
    }
}
