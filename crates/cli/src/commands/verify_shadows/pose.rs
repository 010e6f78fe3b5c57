//! Animated poses for `penumbra verify shadows --animation NAME --time T | --frames N`
//! (SHEXP §6.2 "Animation", §6.3): which poses, the per-node matrices the runtime poses the
//! spheres with, and the posed coverage.

use crate::exit::CliError;
use anyhow::anyhow;
use penumbra_geometry::{Scene, TriMesh};
use penumbra_runtime::shadows::Sphere;

/// One pose: animation index (None: rest pose) and time in seconds.
pub type Pose = (Option<usize>, f64);

/// The poses a verification covers: the rest pose without `--animation`; with it, `--time T`
/// or `--frames N` evenly spaced over the animation's key range (ends included), or the
/// range's start.
pub fn poses(
    scene: &Scene,
    animation: Option<&str>,
    time: Option<f64>,
    frames: Option<u32>,
) -> Result<Vec<Pose>, CliError> {
    let Some(name) = animation else {
        if time.is_some() || frames.is_some() {
            return Err(CliError::input(anyhow!("--time and --frames need --animation")));
        }
        return Ok(vec![(None, 0.0)]);
    };
    if time.is_some() && frames.is_some() {
        return Err(CliError::input(anyhow!("--time and --frames exclude each other")));
    }
    let index = scene
        .animations
        .iter()
        .position(|a| a.name.as_deref() == Some(name))
        .or_else(|| name.parse::<usize>().ok().filter(|&i| i < scene.animations.len()))
        .ok_or_else(|| {
            let names: Vec<String> = scene
                .animations
                .iter()
                .enumerate()
                .map(|(i, a)| a.name.clone().unwrap_or_else(|| i.to_string()))
                .collect();
            CliError::input(anyhow!(
                "--animation {name}: no such animation (the mesh has: {})",
                if names.is_empty() { "none".to_string() } else { names.join(", ") }
            ))
        })?;
    let [t0, t1] = scene.animations[index].time_range();
    Ok(match (time, frames) {
        (Some(t), _) => {
            if !t.is_finite() {
                return Err(CliError::input(anyhow!("--time {t} is not finite")));
            }
            vec![(Some(index), t)]
        }
        (None, Some(n)) if n > 1 => {
            (0..n).map(|k| (Some(index), t0 + (t1 - t0) * f64::from(k) / f64::from(n - 1))).collect()
        }
        _ => vec![(Some(index), t0)],
    })
}

/// The runtime's posing input: per glTF node, `G(t)·G(rest)⁻¹` as a column-major f32 4×4.
pub fn node_matrices(scene: &Scene, pose: Pose) -> Result<Vec<[f32; 16]>, CliError> {
    let d = scene.pose_deltas(pose.0, pose.1).map_err(|e| CliError::input(anyhow!("{e}")))?;
    Ok(d.iter().map(|m| std::array::from_fn(|i| m[i / 4][i % 4] as f32)).collect())
}

/// Fraction of the mesh's surface area inside at least one of `spheres` (within
/// `tolerance`): each triangle is sampled at 7 points (centroid, the three points
/// `(2/3, 1/6, 1/6)` and the three edge midpoints), each carrying a seventh of its area.
pub fn surface_coverage(mesh: &TriMesh, spheres: &[Sphere], tolerance: f64) -> f64 {
    const BARY: [[f64; 3]; 7] = [
        [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
        [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
        [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
        [0.5, 0.5, 0.0],
        [0.0, 0.5, 0.5],
        [0.5, 0.0, 0.5],
    ];
    let (mut covered, mut total) = (0.0f64, 0.0f64);
    for t in 0..mesh.triangle_count() {
        let cr = mesh.triangle_cross(t);
        let area = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        let v = mesh.indices[t].map(|i| mesh.positions[i as usize]);
        for b in &BARY {
            let x: [f64; 3] = std::array::from_fn(|k| b[0] * v[0][k] + b[1] * v[1][k] + b[2] * v[2][k]);
            let inside = spheres.iter().any(|s| {
                let d2: f64 = (0..3).map(|k| (x[k] - f64::from(s.center[k])).powi(2)).sum();
                d2.sqrt() <= f64::from(s.radius) + tolerance
            });
            total += area / 7.0;
            if inside {
                covered += area / 7.0;
            }
        }
    }
    if total > 0.0 { covered / total } else { f64::NAN }
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_geometry::procedural::aabb_box;

    #[test]
    fn coverage_of_a_box_by_spheres() {
        let b = aabb_box([0.0; 3], [1.0; 3]);
        // a sphere around the whole box covers everything; one around a corner covers a part
        let all = [Sphere { center: [0.5; 3], radius: 0.9 }];
        assert_eq!(surface_coverage(&b, &all, 0.0), 1.0);
        let none = [Sphere { center: [5.0; 3], radius: 0.1 }];
        assert_eq!(surface_coverage(&b, &none, 0.0), 0.0);
        // the half-space x < 0.5 through a huge sphere centred far on −x: half the faces' area
        // (the x = 0 face, and half of the four side faces) = 3/6
        let half = [Sphere { center: [-1000.0, 0.5, 0.5], radius: 1000.5 }];
        let c = surface_coverage(&b, &half, 0.0);
        assert!((c - 0.5).abs() < 0.1, "{c}");
    }
}
