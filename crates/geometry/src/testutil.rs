//! Procedural meshes for the unit tests.

use glam::DVec3;

use crate::mesh::TriMesh;

/// Icosphere: a subdivided icosahedron projected to the sphere, outward-oriented, closed.
pub fn icosphere(subdivisions: u32, radius: f64, center: [f64; 3]) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| DVec3::from(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::BTreeMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                (v.len() - 1) as u32
            })
        };
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let ab = midpoint(a, b, &mut v);
            let bc = midpoint(b, c, &mut v);
            let ca = midpoint(c, a, &mut v);
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    let c = DVec3::from(center);
    TriMesh { positions: v.iter().map(|p| (c + radius * *p).to_array()).collect(), indices: f }
}

/// A regular grid of `n × n` quads (two triangles each) in the plane `z = 0` over `[0, n]²`.
pub fn grid(n: u32) -> TriMesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push([i as f64, j as f64, 0.0]);
        }
    }
    let mut indices = Vec::new();
    let id = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            indices.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            indices.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh { positions, indices }
}

#[test]
fn icosphere_is_closed() {
    let m = icosphere(2, 1.0, [0.0; 3]);
    assert_eq!(m.indices.len(), 320);
    assert!(m.is_watertight());
    let v = m.signed_volume();
    assert!(v > 0.0 && v < 4.0 / 3.0 * std::f64::consts::PI);
}
