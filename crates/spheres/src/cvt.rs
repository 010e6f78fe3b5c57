//! Evenly spaced starting sets: a centroidal Voronoi tessellation (CVT) of the medial ridge (issue 16).
//!
//! SHEXP §6.2's Lloyd fit minimises E = Σ V(Sᵢ − T). On a tube that objective leaves the slabs
//! of the tube uneven (on the torus at 64 spheres, angular gaps of 3.0°–9.4° where a
//! regular ring has 5.6°), and since a slab's outside volume grows like the cube of its length
//! the union pays for the long ones. No local move undoes that: evening out the gaps needs every
//! sphere along the ring to shift together. Classic Lloyd relaxation (k-means with centroid
//! updates, Lloyd 1982; Du, Faber, Gunzburger 1999) does exactly that shift: its fixed points
//! are centroidal Voronoi tessellations, whose cells have near-equal size.
//!
//! So this module builds a second candidate set, next to the SHEXP fit:
//!
//! 1. **CVT** of the medial ridge nodes ([`crate::lloyd`]'s approximate medial axis: the
//!    centre line of a tube, the mid-surface of a plate), from the medial seeds,
//!    up to `CVT_ITERATIONS` centroid updates. The ridge, not the whole volume: centroidal cells
//!    are compact, so a tessellation of a thick tube's volume puts two or three cells side by
//!    side across it instead of one slab per sphere (measured: torus at 64 spheres, union
//!    outside volume 4× the SHEXP fit's by the model, against 0.7× from the ridge). Without
//!    enough ridge nodes, the interior nodes; without those (a flat sheet), the surface.
//! 2. **Clusters**: every element (a whole sub-triangle or an interior node) joins the centre
//!    whose ball around it is smallest (the largest distance from the centre to its points).
//! 3. **Spheres**: each cluster's sphere is the Lloyd update (Powell on the centre, the radius
//!    bounding the cluster, SHEXP §6.2) from the cluster's CVT centre.
//!
//! The caller refines it like the SHEXP fit ([`crate::refine`]) and keeps whichever of the two
//! has the smaller union outside volume. Measured in docs/spheres.md ("Evenly spaced starts").
//!
//! Deterministic: every parallel map writes its own slot, and every sum runs in element order.

use rayon::prelude::*;

use crate::lloyd::update_sphere;
use crate::samples::Samples;
use crate::sphere::{Sphere, dist2};
use crate::volume::VolumeModel;

/// Centroid updates of the CVT.
pub const CVT_ITERATIONS: usize = 30;

/// A CVT-based set of `centers.len()` spheres bounding every element (canonical frame), from
/// the given initial centres; returns the spheres and the cluster of every element.
pub fn fit_from(samples: &Samples, model: &VolumeModel, centers: &[[f64; 3]]) -> (Vec<Sphere>, Vec<u32>) {
    let n = centers.len();
    let first = samples.surface_elements;
    let ne = samples.elements.len();
    // the points the tessellation is centroidal for: the medial ridge (a tessellation of the
    // whole volume would put two or three cells side by side across a thick tube, because
    // centroidal cells are compact), else the interior nodes, else the surface
    let sites: Vec<[f64; 3]> = if let Some(r) = crate::lloyd::ridge_nodes(samples).filter(|r| r.len() >= n) {
        r.iter().map(|&k| samples.elements[first + k].rep).collect()
    } else if ne - first >= n {
        samples.elements[first..].iter().map(|e| e.rep).collect()
    } else {
        samples.elements[..first].iter().map(|e| e.rep).collect()
    };
    let mut c = centers.to_vec();
    for _ in 0..CVT_ITERATIONS {
        let owner: Vec<u32> = sites.par_iter().map(|&p| nearest(&c, p) as u32).collect();
        let mut sum = vec![[0.0f64; 3]; n];
        let mut cnt = vec![0usize; n];
        for (p, &o) in sites.iter().zip(&owner) {
            let o = o as usize;
            (0..3).for_each(|d| sum[o][d] += p[d]);
            cnt[o] += 1;
        }
        let mut moved = 0.0f64;
        for i in 0..n {
            if cnt[i] > 0 {
                let g = sum[i].map(|x| x / cnt[i] as f64);
                moved = moved.max(dist2(g, c[i]));
                c[i] = g;
            }
        }
        if moved.sqrt() < 1e-3 * samples.grid_spacing {
            break;
        }
    }
    // clusters: the centre whose ball around the element is smallest
    let assign: Vec<u32> = (0..ne)
        .into_par_iter()
        .map(|e| {
            let ids = samples.elements[e].point_ids();
            let reach = |ci: [f64; 3]| ids.iter().map(|&p| dist2(samples.points[p as usize], ci)).fold(0.0, f64::max);
            let mut best = (f64::INFINITY, 0usize);
            for (i, &ci) in c.iter().enumerate() {
                let d = reach(ci);
                if d < best.0 {
                    best = (d, i);
                }
            }
            best.1 as u32
        })
        .collect();
    let mut ids: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (e, &o) in assign.iter().enumerate() {
        ids[o as usize].extend_from_slice(samples.elements[e].point_ids());
    }
    let keep: Vec<usize> = (0..n).filter(|&i| !ids[i].is_empty()).collect();
    let spheres: Vec<Sphere> = ids
        .into_par_iter()
        .enumerate()
        .map(|(i, mut v)| {
            v.sort_unstable();
            v.dedup();
            let pts: Vec<[f64; 3]> = v.iter().map(|&k| samples.points[k as usize]).collect();
            update_sphere(model, &pts, c[i]).0
        })
        .collect();
    // a centre no element chose has an empty cluster: drop it (the refinement spends it again)
    if keep.len() == n {
        return (spheres, assign);
    }
    let mut index = vec![u32::MAX; n];
    for (k, &i) in keep.iter().enumerate() {
        index[i] = k as u32;
    }
    (keep.iter().map(|&i| spheres[i]).collect(), assign.iter().map(|&o| index[o as usize]).collect())
}

/// Index of the centre nearest to `p` (lowest index on ties).
fn nearest(c: &[[f64; 3]], p: [f64; 3]) -> usize {
    let mut best = (f64::INFINITY, 0usize);
    for (i, &ci) in c.iter().enumerate() {
        let d = dist2(ci, p);
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_prefers_the_lowest_index_on_ties() {
        let c = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.5, 0.0]];
        assert_eq!(nearest(&c, [0.0, 0.0, 0.0]), 2);
        assert_eq!(nearest(&c[..2], [0.0, 0.0, 0.0]), 0);
        assert_eq!(nearest(&c, [0.9, 0.0, 0.0]), 0);
    }
}
