//! Per-proxy albedo (IBPA §5: each proxy re-radiates the light it receives as a diffuse
//! reflector of the albedo of the surface it stands for).
//!
//! The albedo of sphere `j` is the area-weighted mean of the albedo of the surface assigned to
//! it: every triangle of the rest-pose mesh is split into `k²` congruent sub-triangles (`k`
//! the smallest integer with `longest edge / k ≤ r_med / 2`, `r_med` the median sphere radius,
//! at most [`MAX_SPLIT`]), and each sub-triangle, of area `A/k²`, goes to the sphere that holds
//! its centroid most deeply, the smallest `|p − c|/r` (ties to the lower index). For a bounding
//! set that sphere contains the centroid. A sphere that receives no surface (one inside the
//! solid) takes the albedo of the triangle whose centroid it holds most deeply by the same
//! measure.
//!
//! A triangle's albedo is the RGB of its glTF material's `baseColorFactor` (linear; alpha and
//! textures are ignored), or `fallback` for a triangle without a material and for OBJ meshes.
//! Sums run in f64 in triangle order, so the result does not depend on the thread count.

use penumbra_geometry::Scene;
use rayon::prelude::*;

use crate::error::SpheresError;

/// Largest number of sub-triangles per triangle edge.
pub const MAX_SPLIT: usize = 32;

/// The per-triangle albedo of a scene: the material's `baseColorFactor` RGB, or `fallback`.
/// Errors if a factor is outside [0, 1] or not finite.
pub fn triangle_albedo(scene: &Scene, fallback: [f64; 3]) -> Result<Vec<[f64; 3]>, SpheresError> {
    let mut out = Vec::with_capacity(scene.mesh.indices.len());
    for (t, tri) in scene.mesh.indices.iter().enumerate() {
        let c = scene.base_color.get(tri[0] as usize).copied().flatten();
        let a = match c {
            None => fallback,
            Some(f) => {
                let rgb = [f[0], f[1], f[2]];
                if rgb.iter().any(|x| !(0.0..=1.0).contains(x)) {
                    return Err(SpheresError::OutOfRange {
                        name: "baseColorFactor",
                        value: format!("{rgb:?} (triangle {t})"),
                        allowed: "each component in [0, 1] (glTF 2.0 §5.22)".into(),
                    });
                }
                rgb
            }
        };
        out.push(a);
    }
    Ok(out)
}

/// Whether any triangle of the scene has a glTF material.
pub fn has_materials(scene: &Scene) -> bool {
    scene.base_color.iter().any(Option::is_some)
}

/// The sphere holding `p` most deeply: `(index, |p − c|²/r²)`.
fn deepest(spheres: &[[f32; 4]], p: [f64; 3]) -> (u32, f64) {
    let mut best = (0u32, f64::INFINITY);
    for (j, s) in spheres.iter().enumerate() {
        let d2: f64 = (0..3).map(|k| (p[k] - f64::from(s[k])).powi(2)).sum();
        let r = f64::from(s[3]);
        let q = if r > 0.0 { d2 / (r * r) } else { f64::INFINITY };
        if q < best.1 {
            best = (j as u32, q);
        }
    }
    best
}

/// Area-weighted albedo of each sphere (see the module docs). `tri_albedo` has one entry per
/// triangle of `scene.mesh`.
pub fn sphere_albedo(scene: &Scene, tri_albedo: &[[f64; 3]], spheres: &[[f32; 4]]) -> Vec<[f32; 3]> {
    let mesh = &scene.mesh;
    let n = spheres.len();
    if n == 0 {
        return Vec::new();
    }
    let mut radii: Vec<f64> = spheres.iter().map(|s| f64::from(s[3])).collect();
    radii.sort_by(f64::total_cmp);
    let step = (radii[n / 2] / 2.0).max(f64::MIN_POSITIVE);
    // per triangle: the (sphere, depth, area) of each sub-triangle, computed in parallel
    let per_tri: Vec<Vec<(u32, f64, f64)>> = (0..mesh.indices.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = mesh.triangle(t);
            let e = |p: [f64; 3], q: [f64; 3]| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
            let longest = e(a, b).max(e(b, c)).max(e(c, a));
            let k = ((longest / step).ceil() as usize).clamp(1, MAX_SPLIT);
            let area = mesh.triangle_area(t) / (k * k) as f64;
            let at = |i: f64, j: f64| -> [f64; 3] {
                let (u, v) = (i / k as f64, j / k as f64);
                std::array::from_fn(|q| a[q] + u * (b[q] - a[q]) + v * (c[q] - a[q]))
            };
            let mut out = Vec::with_capacity(k * k);
            // k² sub-triangles: (i, j) upright with centroid at (i + 1/3, j + 1/3), and for
            // i + j ≤ k − 2 the inverted one at (i + 2/3, j + 2/3) (grid units)
            for i in 0..k {
                for j in 0..k - i {
                    let p = at(i as f64 + 1.0 / 3.0, j as f64 + 1.0 / 3.0);
                    let (s, d) = deepest(spheres, p);
                    out.push((s, d, area));
                    if i + j + 2 <= k {
                        let p = at(i as f64 + 2.0 / 3.0, j as f64 + 2.0 / 3.0);
                        let (s, d) = deepest(spheres, p);
                        out.push((s, d, area));
                    }
                }
            }
            out
        })
        .collect();
    let mut sum = vec![[0.0f64; 3]; n];
    let mut weight = vec![0.0f64; n];
    for (t, subs) in per_tri.iter().enumerate() {
        for &(s, _, w) in subs {
            for q in 0..3 {
                sum[s as usize][q] += w * tri_albedo[t][q];
            }
            weight[s as usize] += w;
        }
    }
    // spheres without surface: the sub-triangle each holds most deeply
    let empty: Vec<usize> = (0..n).filter(|&j| weight[j] <= 0.0).collect();
    let mut nearest: Vec<(f64, [f64; 3])> = vec![(f64::INFINITY, [0.0; 3]); n];
    if !empty.is_empty() {
        for t in 0..mesh.indices.len() {
            let [a, b, c] = mesh.triangle(t);
            let p: [f64; 3] = std::array::from_fn(|q| (a[q] + b[q] + c[q]) / 3.0);
            for &j in &empty {
                let s = spheres[j];
                let d2: f64 = (0..3).map(|k| (p[k] - f64::from(s[k])).powi(2)).sum();
                let r = f64::from(s[3]).max(f64::MIN_POSITIVE);
                let q = d2 / (r * r);
                if q < nearest[j].0 {
                    nearest[j] = (q, tri_albedo[t]);
                }
            }
        }
    }
    (0..n)
        .map(|j| {
            let v = if weight[j] > 0.0 { sum[j].map(|x| x / weight[j]) } else { nearest[j].1 };
            v.map(|x| (x as f32).clamp(0.0, 1.0))
        })
        .collect()
}
