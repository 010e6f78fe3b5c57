//! Skinning of sphere sets (SHEXP §6.2, "Animation"): mean value coordinates of each sphere
//! centre with respect to the rest-pose mesh (Ju, Schaefer, Warren 2005, "Mean value
//! coordinates for closed triangular meshes"), multiplied by the vertices' bone weights and
//! reduced to the four largest bones per sphere.
//!
//! # Posing convention (what a runtime implements)
//! A sphere with influences `(nᵦ, Wᵦ)` (glTF node indices and weights summing to 1) is posed
//! by linear blend skinning of its rest-pose centre `P`:
//! `P' = Σᵦ Wᵦ · Gₙᵦ(t) · Gₙᵦ(rest)⁻¹ · P`, radius unchanged, where `G` is a node's global
//! transform. For a skin joint, `G(t)·G(rest)⁻¹ = S(t)·S(rest)⁻¹` with the usual skinning
//! matrix `S = G·IBM`, so the inverse bind matrices cancel; vertices of non-skinned meshes
//! count as bound to their node with weight 1, so rigidly animated parts work the same way.

use std::collections::BTreeMap;

use glam::{DMat4, DVec3};
use penumbra_geometry::{Scene, TriMesh};

use crate::sphere::Sphere;

/// Mean value coordinates of `x` with respect to a closed triangle mesh: one weight per
/// vertex, summing to 1, with `Σ wⱼ pⱼ = x` for closed meshes (linear precision). Points on
/// the surface get the barycentric coordinates of their triangle; points at a vertex get that
/// vertex. For open meshes the weights are still defined and sum to 1 (linear precision is
/// lost near the holes).
pub fn mean_value_coordinates(mesh: &TriMesh, x: [f64; 3]) -> Vec<f64> {
    const EPS: f64 = 1e-12;
    let n = mesh.positions.len();
    let x = DVec3::from(x);
    let mut w = vec![0.0; n];
    let scale = mesh.bounds().map_or(1.0, |b| b.diagonal().max(f64::MIN_POSITIVE));
    let mut d = vec![0.0; n];
    let mut u = vec![DVec3::ZERO; n];
    for j in 0..n {
        let v = DVec3::from(mesh.positions[j]) - x;
        d[j] = v.length();
        if d[j] < EPS * scale {
            w[j] = 1.0;
            return w;
        }
        u[j] = v / d[j];
    }
    let mut total = 0.0;
    for tri in &mesh.indices {
        let id = tri.map(|v| v as usize);
        let l = [(u[id[1]] - u[id[2]]).length(), (u[id[2]] - u[id[0]]).length(), (u[id[0]] - u[id[1]]).length()];
        let th = l.map(|li| 2.0 * (0.5 * li).min(1.0).asin());
        let h = 0.5 * (th[0] + th[1] + th[2]);
        if std::f64::consts::PI - h < 1e-10 {
            // x lies on the triangle: 2D barycentric coordinates
            let mut b = [0.0; 3];
            for i in 0..3 {
                b[i] = th[i].sin() * d[id[(i + 2) % 3]] * d[id[(i + 1) % 3]];
            }
            let s: f64 = b.iter().sum();
            w.iter_mut().for_each(|x| *x = 0.0);
            for i in 0..3 {
                w[id[i]] += b[i] / s;
            }
            return w;
        }
        let mut c = [0.0; 3];
        for i in 0..3 {
            c[i] = (2.0 * h.sin() * (h - th[i]).sin()) / (th[(i + 1) % 3].sin() * th[(i + 2) % 3].sin()) - 1.0;
        }
        let det = u[id[0]].dot(u[id[1]].cross(u[id[2]]));
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        let s = c.map(|ci| sign * (1.0 - ci * ci).max(0.0).sqrt());
        if s.iter().any(|si| si.abs() <= 1e-10) {
            // x is in the triangle's plane but outside it: no contribution
            continue;
        }
        for i in 0..3 {
            let (ip, im) = ((i + 1) % 3, (i + 2) % 3);
            let wi = (th[i] - c[ip] * th[im] - c[im] * th[ip]) / (d[id[i]] * th[ip].sin() * s[im]);
            w[id[i]] += wi;
            total += wi;
        }
    }
    if total.abs() > 0.0 && total.is_finite() {
        w.iter_mut().for_each(|x| *x /= total);
    }
    w
}

/// Up to four (node, weight) influences of one sphere; unused slots have weight 0 and node
/// `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereSkin {
    /// glTF node indices.
    pub nodes: [u32; 4],
    /// Weights, summing to 1.
    pub weights: [f64; 4],
}

/// Errors of skinning.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SkinError {
    /// The scene has no skinned vertices.
    #[error("the mesh has no skin (--skin needs a skinned glTF)")]
    NotSkinned,
    /// A vertex is attached to no node.
    #[error("vertex {0} is attached to no node, so it cannot be posed")]
    Unattached(usize),
    /// Posing failed.
    #[error("{0}")]
    Pose(#[from] penumbra_geometry::scene::PoseError),
}

/// Node influences of every vertex of the scene (skin joints as nodes; rigid vertices bound
/// to their node with weight 1).
fn vertex_influences(scene: &Scene) -> Result<Vec<Vec<(u32, f64)>>, SkinError> {
    if !scene.is_skinned() {
        return Err(SkinError::NotSkinned);
    }
    scene
        .bindings
        .iter()
        .enumerate()
        .map(|(v, b)| match b.skin {
            Some(s) => {
                let joints = &scene.skins[s.skin as usize].joints;
                Ok((0..4)
                    .filter(|&k| s.weights[k] != 0.0)
                    .map(|k| (joints[s.joints[k] as usize] as u32, s.weights[k]))
                    .collect())
            }
            None => b.node.map(|n| vec![(n, 1.0)]).ok_or(SkinError::Unattached(v)),
        })
        .collect()
}

/// Per-sphere influences: mean value coordinates of each centre times the vertices' node
/// weights, top four, renormalised. Parallel over spheres.
pub fn sphere_skins(scene: &Scene, centers: &[[f64; 3]]) -> Result<Vec<SphereSkin>, SkinError> {
    use rayon::prelude::*;
    let infl = vertex_influences(scene)?;
    Ok(centers
        .par_iter()
        .map(|&c| {
            let mvc = mean_value_coordinates(&scene.mesh, c);
            let mut acc: BTreeMap<u32, f64> = BTreeMap::new();
            for (v, &l) in mvc.iter().enumerate() {
                if l != 0.0 {
                    for &(node, w) in &infl[v] {
                        *acc.entry(node).or_insert(0.0) += l * w;
                    }
                }
            }
            let mut list: Vec<(u32, f64)> = acc.into_iter().collect();
            list.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            list.truncate(4);
            let sum: f64 = list.iter().map(|x| x.1).sum();
            if sum.is_nan() || sum <= 1e-9 {
                // degenerate coordinates: use the nearest vertex's influences
                let nearest = (0..scene.mesh.positions.len())
                    .min_by(|&a, &b| {
                        crate::sphere::dist2(scene.mesh.positions[a], c)
                            .total_cmp(&crate::sphere::dist2(scene.mesh.positions[b], c))
                    })
                    .unwrap_or(0);
                list = infl.get(nearest).cloned().unwrap_or_default();
            }
            let sum: f64 = list.iter().map(|x| x.1).sum::<f64>().max(f64::MIN_POSITIVE);
            let mut out = SphereSkin { nodes: [u32::MAX; 4], weights: [0.0; 4] };
            for (k, (node, w)) in list.into_iter().enumerate().take(4) {
                out.nodes[k] = node;
                out.weights[k] = w / sum;
            }
            out
        })
        .collect())
}

/// Poses sphere centres by the convention of the module docs.
pub fn pose_spheres(
    scene: &Scene,
    spheres: &[Sphere],
    skins: &[SphereSkin],
    animation: Option<usize>,
    time: f64,
) -> Result<Vec<Sphere>, SkinError> {
    let rest = scene.global_transforms(None, 0.0)?;
    let now = scene.global_transforms(animation, time)?;
    let m: Vec<DMat4> = rest
        .iter()
        .zip(&now)
        .map(|(r, n)| DMat4::from_cols_array_2d(n) * DMat4::from_cols_array_2d(r).inverse())
        .collect();
    Ok(spheres
        .iter()
        .zip(skins)
        .map(|(s, k)| {
            let p = DVec3::from(s.center);
            let mut c = DVec3::ZERO;
            for i in 0..4 {
                if k.weights[i] != 0.0 {
                    if let Some(mat) = m.get(k.nodes[i] as usize) {
                        c += k.weights[i] * mat.transform_point3(p);
                    }
                }
            }
            Sphere::new(c.to_array(), s.radius)
        })
        .collect())
}

/// Poses sampled per animation by [`pose_padding`]: evenly over the key range, ends included
/// (denser than [`coverage`]'s 8, so the check there also sees times the padding never did).
pub const PADDING_POSES: usize = 32;

/// Per-sphere radius padding that keeps the set bounding in every sampled pose (issue #14:
/// SHEXP §6.2 keeps the rest radius, "which remains a bound assuming typical articulated
/// motion"; for skinned meshes whose surface stretches or slides over the bones it does not).
/// For every animation at [`PADDING_POSES`] times, every posed vertex that no posed sphere
/// contains (within `tolerance`) grows the sphere whose surface is nearest to it, just enough
/// to contain it. Returns one padding per sphere (0 for most), in input units; the posed
/// convention of the module docs with radius `r + pad`.
pub fn pose_padding(
    scene: &Scene,
    spheres: &[Sphere],
    skins: &[SphereSkin],
    tolerance: f64,
) -> Result<Vec<f64>, SkinError> {
    use rayon::prelude::*;
    let mut poses: Vec<(usize, f64)> = Vec::new();
    for (a, anim) in scene.animations.iter().enumerate() {
        let [t0, t1] = anim.time_range();
        for k in 0..PADDING_POSES {
            poses.push((a, t0 + (t1 - t0) * k as f64 / (PADDING_POSES - 1) as f64));
        }
    }
    let per_pose: Vec<Result<Vec<f64>, SkinError>> = poses
        .par_iter()
        .map(|&(a, t)| {
            let verts = scene.pose(Some(a), t)?;
            let posed = pose_spheres(scene, spheres, skins, Some(a), t)?;
            let mut pad = vec![0.0f64; spheres.len()];
            for v in &verts {
                let mut best = (f64::INFINITY, usize::MAX);
                for (j, s) in posed.iter().enumerate() {
                    let gap = crate::sphere::dist(s.center, *v) - s.radius;
                    if gap < best.0 {
                        best = (gap, j);
                    }
                }
                if best.0 > tolerance && best.1 < pad.len() {
                    pad[best.1] = pad[best.1].max(best.0);
                }
            }
            Ok(pad)
        })
        .collect();
    let mut pad = vec![0.0f64; spheres.len()];
    for p in per_pose {
        for (a, b) in pad.iter_mut().zip(p?) {
            *a = a.max(b);
        }
    }
    Ok(pad)
}

/// The posed-coverage check: for every animation at 8 evenly spaced times of its key range,
/// the fraction of posed vertices inside at least one posed sphere (within `tolerance`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SkinCoverage {
    /// The smallest fraction over all poses (1 when there are no animations: the rest pose).
    pub min: f64,
    /// Where it occurred: animation index (None: rest pose) and time.
    pub worst_animation: Option<usize>,
    /// Time of the worst pose, seconds.
    pub worst_time: f64,
    /// Poses checked.
    pub poses: usize,
}

/// Runs the coverage check (parallel over poses).
pub fn coverage(
    scene: &Scene,
    spheres: &[Sphere],
    skins: &[SphereSkin],
    tolerance: f64,
) -> Result<SkinCoverage, SkinError> {
    use rayon::prelude::*;
    let mut poses: Vec<(Option<usize>, f64)> = Vec::new();
    for (a, anim) in scene.animations.iter().enumerate() {
        let [t0, t1] = anim.time_range();
        for k in 0..8 {
            poses.push((Some(a), t0 + (t1 - t0) * k as f64 / 7.0));
        }
    }
    if poses.is_empty() {
        poses.push((None, 0.0));
    }
    let fractions: Vec<Result<f64, SkinError>> = poses
        .par_iter()
        .map(|&(a, t)| {
            let verts = scene.pose(a, t)?;
            let posed = pose_spheres(scene, spheres, skins, a, t)?;
            let covered = verts
                .iter()
                .filter(|v| posed.iter().any(|s| crate::sphere::dist(s.center, **v) <= s.radius + tolerance))
                .count();
            Ok(covered as f64 / verts.len().max(1) as f64)
        })
        .collect();
    let mut best = SkinCoverage { min: f64::INFINITY, worst_animation: None, worst_time: 0.0, poses: poses.len() };
    for (f, &(a, t)) in fractions.into_iter().zip(&poses) {
        let f = f?;
        if f < best.min {
            best.min = f;
            best.worst_animation = a;
            best.worst_time = t;
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_geometry::procedural::{aabb_box, icosphere, torus};

    fn check_linear_precision(mesh: &TriMesh, x: [f64; 3]) {
        let w = mean_value_coordinates(mesh, x);
        let sum: f64 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12, "partition of unity: {sum}");
        let mut p = [0.0; 3];
        for (j, &wj) in w.iter().enumerate() {
            for d in 0..3 {
                p[d] += wj * mesh.positions[j][d];
            }
        }
        for d in 0..3 {
            assert!((p[d] - x[d]).abs() < 1e-9, "linear precision at {x:?}: {p:?}");
        }
    }

    #[test]
    fn mean_value_coordinates_reproduce_linear_functions() {
        let s = icosphere(2, 1.0, [0.0; 3]);
        for x in [[0.0, 0.0, 0.0], [0.3, -0.2, 0.5], [0.0, 0.0, 0.95]] {
            check_linear_precision(&s, x);
        }
        // non-convex: a torus, points inside the tube and in the hole (outside the mesh)
        let t = torus([0.0; 3], 1.0, 0.3, 24, 12);
        check_linear_precision(&t, [1.0, 0.0, 0.1]);
        check_linear_precision(&t, [0.0, 0.0, 0.0]);
        // on a face and at a vertex
        let b = aabb_box([0.0; 3], [1.0; 3]);
        let w = mean_value_coordinates(&b, [1.0, 0.3, 0.4]);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        check_linear_precision(&b, [1.0, 0.3, 0.4]);
        let w = mean_value_coordinates(&b, [1.0, 1.0, 1.0]);
        assert_eq!(w[7], 1.0);
    }
}
