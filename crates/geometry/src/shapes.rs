//! Procedural closed meshes (outward, counter-clockwise): for demos, tests and benchmarks
//! that must not depend on data files.

use std::f64::consts::{PI, TAU};

use crate::mesh::TriMesh;

/// A UV sphere of `radius` around `center` with `stacks ≥ 2` latitude bands and
/// `slices ≥ 3` longitude segments (poles are single vertices; closed and watertight).
pub fn uv_sphere(center: [f64; 3], radius: f64, stacks: usize, slices: usize) -> TriMesh {
    let stacks = stacks.max(2);
    let slices = slices.max(3);
    let mut positions = vec![[center[0], center[1] + radius, center[2]]];
    for i in 1..stacks {
        let t = PI * i as f64 / stacks as f64;
        for j in 0..slices {
            let p = TAU * j as f64 / slices as f64;
            positions.push([
                center[0] + radius * t.sin() * p.sin(),
                center[1] + radius * t.cos(),
                center[2] + radius * t.sin() * p.cos(),
            ]);
        }
    }
    positions.push([center[0], center[1] - radius, center[2]]);
    let bottom = (positions.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * slices + j % slices) as u32;
    let mut indices = Vec::new();
    for j in 0..slices {
        indices.push([0, ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            indices.push([a, c, d]);
            indices.push([a, d, b]);
        }
    }
    for j in 0..slices {
        indices.push([ring(stacks - 1, j), bottom, ring(stacks - 1, j + 1)]);
    }
    TriMesh { positions, indices }
}

/// A torus around the +Y axis through `center`: tube centre-line radius `major`, tube radius
/// `minor < major`, `n` segments around the axis and `m` around the tube (closed, genus 1).
pub fn torus(center: [f64; 3], major: f64, minor: f64, n: usize, m: usize) -> TriMesh {
    let n = n.max(3);
    let m = m.max(3);
    let mut positions = Vec::with_capacity(n * m);
    for i in 0..n {
        let u = TAU * i as f64 / n as f64;
        for j in 0..m {
            let v = TAU * j as f64 / m as f64;
            let r = major + minor * v.cos();
            positions.push([center[0] + r * u.sin(), center[1] + minor * v.sin(), center[2] + r * u.cos()]);
        }
    }
    let id = |i: usize, j: usize| ((i % n) * m + j % m) as u32;
    let mut indices = Vec::with_capacity(2 * n * m);
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            indices.push([a, b, d]);
            indices.push([a, d, c]);
        }
    }
    TriMesh { positions, indices }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_is_closed_outward_and_close_to_analytic() {
        let m = uv_sphere([1.0, 2.0, 3.0], 2.0, 48, 96);
        m.validate().unwrap();
        assert!(m.is_watertight());
        let v = m.signed_volume();
        let exact = 4.0 / 3.0 * PI * 8.0;
        assert!(v > 0.0 && (v - exact).abs() < 0.01 * exact, "{v} vs {exact}");
        let a = m.area();
        assert!((a - 4.0 * PI * 4.0).abs() < 0.01 * 16.0 * PI);
    }

    #[test]
    fn torus_is_closed_outward_and_close_to_analytic() {
        let m = torus([0.0; 3], 2.0, 0.5, 96, 48);
        m.validate().unwrap();
        assert!(m.is_watertight());
        let v = m.signed_volume();
        let exact = 2.0 * PI * PI * 2.0 * 0.25;
        assert!(v > 0.0 && (v - exact).abs() < 0.01 * exact, "{v} vs {exact}");
        let e = m.edge_stats();
        // genus 1: V − E + F = 0
        assert_eq!(m.positions.len() as i64 - e.edges as i64 + m.indices.len() as i64, 0);
    }
}
