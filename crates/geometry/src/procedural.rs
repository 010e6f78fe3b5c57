//! Procedural meshes for examples, the demo scene and tests: closed primitives (icosphere,
//! UV sphere, box, torus), an open grid, and closed surfaces of implicit solids by marching tetrahedra
//! (the demo character is a union of capsules and boxes). Everything is deterministic and
//! outward-oriented (`(b − a) × (c − a)` points out of the solid).

use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};

use glam::DVec3;

use crate::mesh::TriMesh;

/// Icosphere: a subdivided icosahedron projected to the sphere; closed, `20·4^s` triangles.
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
        let mut mid = BTreeMap::new();
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

/// A regular grid of `n × n` quads (two triangles each) in the plane `z = 0` over `[0, n]²`
/// (open, normal +z).
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

/// The axis-aligned box `[min, max]`: 8 vertices, 12 triangles, closed.
pub fn aabb_box(min: [f64; 3], max: [f64; 3]) -> TriMesh {
    let mut positions = Vec::with_capacity(8);
    for k in 0..8 {
        positions.push([
            if k & 1 == 0 { min[0] } else { max[0] },
            if k & 2 == 0 { min[1] } else { max[1] },
            if k & 4 == 0 { min[2] } else { max[2] },
        ]);
    }
    // each face as a quad (a, b, c, d), counter-clockwise seen from outside
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let indices = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    TriMesh { positions, indices }
}

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

/// The closed surface `{f = 0}` of the solid `{f < 0}` inside the box `[min, max]`, by marching
/// tetrahedra on a grid of `cells` cells along the longest side (Kuhn split of each cube into
/// six tetrahedra, which is consistent across neighbouring cubes, so the surface is watertight
/// wherever the solid stays inside the box). Vertices on shared grid edges are shared;
/// triangles are oriented toward increasing `f`. `f` should not vanish exactly at grid nodes
/// (a node value of exactly 0 counts as outside).
pub fn implicit_surface(f: impl Fn(DVec3) -> f64, min: [f64; 3], max: [f64; 3], cells: usize) -> TriMesh {
    let lo = DVec3::from(min);
    let ext = DVec3::from(max) - lo;
    let h = ext.max_element() / cells.max(1) as f64;
    let n = [(ext.x / h).ceil() as usize + 1, (ext.y / h).ceil() as usize + 1, (ext.z / h).ceil() as usize + 1];
    let node = |i: usize, j: usize, k: usize| i + n[0] * (j + n[1] * k);
    let pos = |i: usize, j: usize, k: usize| lo + h * DVec3::new(i as f64, j as f64, k as f64);
    let mut values = vec![0.0; n[0] * n[1] * n[2]];
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                values[node(i, j, k)] = f(pos(i, j, k));
            }
        }
    }
    let coords = |id: usize| (id % n[0], (id / n[0]) % n[1], id / (n[0] * n[1]));
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut edge_vertex: BTreeMap<(usize, usize), u32> = BTreeMap::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    let mut vertex_on = |a: usize, b: usize, positions: &mut Vec<[f64; 3]>| -> u32 {
        let key = (a.min(b), a.max(b));
        *edge_vertex.entry(key).or_insert_with(|| {
            let (fa, fb) = (values[key.0], values[key.1]);
            let (ia, ja, ka) = coords(key.0);
            let (ib, jb, kb) = coords(key.1);
            let t = fa / (fa - fb);
            let p = pos(ia, ja, ka).lerp(pos(ib, jb, kb), t);
            positions.push(p.to_array());
            (positions.len() - 1) as u32
        })
    };
    // Kuhn triangulation: a path from corner 0 to corner 7 along the axes in every order.
    const PERMS: [[usize; 3]; 6] = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    for k in 0..n[2] - 1 {
        for j in 0..n[1] - 1 {
            for i in 0..n[0] - 1 {
                for perm in PERMS {
                    let mut c = [i, j, k];
                    let mut tet = [node(c[0], c[1], c[2]); 4];
                    for (s, &axis) in perm.iter().enumerate() {
                        c[axis] += 1;
                        tet[s + 1] = node(c[0], c[1], c[2]);
                    }
                    let inside: Vec<usize> = tet.iter().copied().filter(|&v| values[v] < 0.0).collect();
                    let outside: Vec<usize> = tet.iter().copied().filter(|&v| values[v] >= 0.0).collect();
                    let centroid = |vs: &[usize]| {
                        vs.iter().fold(DVec3::ZERO, |acc, &v| {
                            let (a, b, c) = coords(v);
                            acc + pos(a, b, c)
                        }) / vs.len() as f64
                    };
                    let tris: Vec<[u32; 3]> = match inside.len() {
                        1 | 3 => {
                            let (lone, others) =
                                if inside.len() == 1 { (inside[0], &outside) } else { (outside[0], &inside) };
                            vec![[
                                vertex_on(lone, others[0], &mut positions),
                                vertex_on(lone, others[1], &mut positions),
                                vertex_on(lone, others[2], &mut positions),
                            ]]
                        }
                        2 => {
                            let (a, b) = (inside[0], inside[1]);
                            let (c, d) = (outside[0], outside[1]);
                            let (ac, ad, bd, bc) = (
                                vertex_on(a, c, &mut positions),
                                vertex_on(a, d, &mut positions),
                                vertex_on(b, d, &mut positions),
                                vertex_on(b, c, &mut positions),
                            );
                            vec![[ac, ad, bd], [ac, bd, bc]]
                        }
                        _ => Vec::new(),
                    };
                    if tris.is_empty() {
                        continue;
                    }
                    let outward = centroid(&outside) - centroid(&inside);
                    for t in tris {
                        let [p0, p1, p2] = t.map(|v| DVec3::from(positions[v as usize]));
                        let nrm = (p1 - p0).cross(p2 - p0);
                        indices.push(if nrm.dot(outward) >= 0.0 { t } else { [t[0], t[2], t[1]] });
                    }
                }
            }
        }
    }
    TriMesh { positions, indices }
}

/// Signed distance to the capsule (segment `a`–`b`, radius `r`).
pub fn capsule_sdf(p: DVec3, a: DVec3, b: DVec3, r: f64) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    (p - (a + t * ab)).length() - r
}

/// Signed distance to the box `center ± half` with its edges rounded by `round`.
pub fn rounded_box_sdf(p: DVec3, center: DVec3, half: DVec3, round: f64) -> f64 {
    let q = (p - center).abs() - (half - DVec3::splat(round));
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - round
}

/// Thin-feature test shape: a tube of radius 0.08 bent into a U (a half circle of radius 0.6
/// joining two straight legs of length 0.8), the kind of pipe or handle sphere fits struggle
/// with. Closed, by marching tetrahedra at `cells` along the longest side (2 units).
pub fn bent_tube(cells: usize) -> TriMesh {
    let r = 0.08;
    let mut pts = vec![DVec3::new(-0.6, -0.8, 0.0)];
    for k in 0..=24 {
        let a = PI * k as f64 / 24.0;
        pts.push(DVec3::new(-0.6 * a.cos(), 0.6 * a.sin(), 0.0));
    }
    pts.push(DVec3::new(0.6, -0.8, 0.0));
    let sdf = move |p: DVec3| pts.windows(2).map(|w| capsule_sdf(p, w[0], w[1], r)).fold(f64::INFINITY, f64::min);
    let pad = 0.0613;
    implicit_surface(sdf, [-0.68 - pad, -0.88 - pad, -r - pad], [0.68 + pad, 0.68 + pad, r + pad], cells)
}

/// Thin-feature test shape: a plate 1.6 × 1.0 and 0.06 thick with rounded edges (aspect
/// ratio ≈ 27). Closed, by marching tetrahedra at `cells` along the longest side.
pub fn thin_plate(cells: usize) -> TriMesh {
    let half = DVec3::new(0.8, 0.03, 0.5);
    let sdf = move |p: DVec3| rounded_box_sdf(p, DVec3::ZERO, half, 0.025);
    let pad = 0.0571;
    implicit_surface(sdf, [-0.8 - pad, -0.03 - pad, -0.5 - pad], [0.8 + pad, 0.03 + pad, 0.5 + pad], cells)
}

/// Thin-feature test shape: a zig-zag chain of five capsules of radii 0.05–0.1 (a limb or a
/// railing). Closed, by marching tetrahedra at `cells` along the longest side.
pub fn capsule_chain(cells: usize) -> TriMesh {
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let joints = [
        v(-1.0, 0.0, 0.0),
        v(-0.55, 0.3, 0.1),
        v(-0.1, -0.1, 0.0),
        v(0.35, 0.25, -0.1),
        v(0.7, -0.2, 0.05),
        v(1.0, 0.1, 0.2),
    ];
    let radii = [0.1, 0.07, 0.05, 0.08, 0.06];
    let sdf = move |p: DVec3| {
        (0..5).map(|i| capsule_sdf(p, joints[i], joints[i + 1], radii[i])).fold(f64::INFINITY, f64::min)
    };
    let pad = 0.0537;
    implicit_surface(sdf, [-1.1 - pad, -0.3 - pad, -0.2 - pad], [1.1 + pad, 0.4 + pad, 0.3 + pad], cells)
}

/// Genus-4 test shape (a stand-in for a sculpture with four holes): a rounded plate
/// 2.0 × 0.2 × 0.7 pierced by four round holes of radius 0.16 along its thin axis, leaving bars
/// 0.16 wide between the holes and 0.19 beside them. Closed, by marching tetrahedra at `cells`
/// along the longest side.
pub fn four_hole_plate(cells: usize) -> TriMesh {
    let half = DVec3::new(1.0, 0.1, 0.35);
    let sdf = move |p: DVec3| {
        let plate = rounded_box_sdf(p, DVec3::ZERO, half, 0.04);
        let hole = [-0.72, -0.24, 0.24, 0.72]
            .iter()
            .map(|&x| ((p.x - x).powi(2) + p.z * p.z).sqrt() - 0.16)
            .fold(f64::INFINITY, f64::min);
        plate.max(-hole)
    };
    let pad = 0.0583;
    implicit_surface(sdf, [-1.0 - pad, -0.1 - pad, -0.35 - pad], [1.0 + pad, 0.1 + pad, 0.35 + pad], cells)
}

/// An open mesh: the side of a cylinder (radius 0.15, length 1.5 along +Y, centred at the
/// origin) without its caps, `n` segments around and `m` along. Its inside by the generalized
/// winding number is the solid cylinder (the open ends are spanned like soap films).
pub fn open_tube(n: usize, m: usize) -> TriMesh {
    let (n, m) = (n.max(3), m.max(1));
    let mut positions = Vec::with_capacity(n * (m + 1));
    for j in 0..=m {
        let y = -0.75 + 1.5 * j as f64 / m as f64;
        for i in 0..n {
            let u = TAU * i as f64 / n as f64;
            positions.push([0.15 * u.sin(), y, 0.15 * u.cos()]);
        }
    }
    let id = |i: usize, j: usize| (j * n + i % n) as u32;
    let mut indices = Vec::with_capacity(2 * n * m);
    for j in 0..m {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            indices.push([a, b, d]);
            indices.push([a, d, c]);
        }
    }
    TriMesh { positions, indices }
}

/// Marching-tetrahedra resolution of the committed demo character.
pub const DEMO_CHARACTER_CELLS: usize = 36;

/// The demo character: a union of a rounded-box torso and pelvis, a spherical head, and
/// capsule arms and legs, about 1.8 units tall, standing on `y = 0` and facing +z (glTF
/// frame: +y up). `cells` is the marching-tetrahedra resolution along the height.
pub fn character(cells: usize) -> TriMesh {
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let sdf = move |p: DVec3| {
        let parts = [
            rounded_box_sdf(p, v(0.0, 1.2, 0.0), v(0.22, 0.28, 0.13), 0.06), // torso
            rounded_box_sdf(p, v(0.0, 0.9, 0.0), v(0.2, 0.1, 0.12), 0.05),   // pelvis
            (p - v(0.0, 1.62, 0.02)).length() - 0.14,                        // head
            capsule_sdf(p, v(0.0, 1.45, 0.0), v(0.0, 1.52, 0.0), 0.06),      // neck
            capsule_sdf(p, v(-0.3, 1.42, 0.0), v(-0.62, 1.12, 0.05), 0.06),  // left arm
            capsule_sdf(p, v(0.3, 1.42, 0.0), v(0.55, 1.0, 0.12), 0.06),     // right arm
            capsule_sdf(p, v(-0.11, 0.85, 0.0), v(-0.14, 0.1, 0.02), 0.08),  // left leg
            capsule_sdf(p, v(0.11, 0.85, 0.0), v(0.16, 0.1, -0.02), 0.08),   // right leg
            rounded_box_sdf(p, v(-0.14, 0.05, 0.07), v(0.07, 0.05, 0.13), 0.03), // left foot
            rounded_box_sdf(p, v(0.16, 0.05, 0.05), v(0.07, 0.05, 0.13), 0.03), // right foot
        ];
        parts.into_iter().fold(f64::INFINITY, f64::min)
    };
    // offsets by irrational fractions keep grid nodes off the zero set
    let pad = 0.0517;
    implicit_surface(sdf, [-0.75 - pad, -pad * 0.7, -0.3 - pad], [0.75 + pad, 1.85, 0.35 + pad], cells)
}

/// The committed demo mesh `bake-configs/assets/character.obj`: [`character`] at
/// [`DEMO_CHARACTER_CELLS`], positions rounded to 10⁻⁶ (the file stays small; the mesh stays
/// closed because vertices are shared), as OBJ text.
pub fn demo_character_obj() -> String {
    let mut m = character(DEMO_CHARACTER_CELLS);
    m.map_positions(|p| p.map(|x| (x * 1e6).round() / 1e6));
    crate::export::obj_text(
        &m,
        "penumbra demo character: capsules and rounded boxes, marching tetrahedra\n\
         generated by `cargo run -p penumbra-geometry --example demo_character`; do not edit",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_closed_with_known_volume() {
        let s = icosphere(2, 1.0, [0.0; 3]);
        assert_eq!(s.indices.len(), 320);
        assert!(s.is_watertight());
        let b = aabb_box([0.0, 0.0, 0.0], [2.0, 3.0, 4.0]);
        assert!(b.is_watertight());
        assert!((b.signed_volume() - 24.0).abs() < 1e-12);
    }

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

    #[test]
    fn implicit_sphere_is_closed_and_accurate() {
        let m = implicit_surface(|p| p.length() - 1.0, [-1.3; 3], [1.3; 3], 40);
        assert!(m.is_watertight());
        let v = m.signed_volume();
        let exact = 4.0 / 3.0 * std::f64::consts::PI;
        assert!((v - exact).abs() < 0.02 * exact, "{v} vs {exact}");
    }

    #[test]
    fn character_is_closed() {
        let m = character(48);
        assert!(m.is_watertight());
        let b = m.bounds().unwrap();
        assert!(b.min[1] > -0.01 && b.max[1] > 1.7 && b.max[1] < 1.8, "{b:?}");
        assert!(m.signed_volume() > 0.0);
    }
    #[test]
    fn thin_feature_shapes_are_closed_or_open_as_documented() {
        for (name, m) in
            [("bent tube", bent_tube(64)), ("thin plate", thin_plate(64)), ("capsule chain", capsule_chain(64))]
        {
            assert!(m.is_watertight(), "{name}");
            assert!(m.signed_volume() > 0.0, "{name}");
        }
        // the bent tube's volume is close to π r² × its centre-line length (2 legs + half circle)
        let v = bent_tube(96).signed_volume();
        let exact = PI * 0.08f64.powi(2) * (2.0 * 0.8 + PI * 0.6) + 4.0 / 3.0 * PI * 0.08f64.powi(3);
        assert!((v - exact).abs() < 0.05 * exact, "{v} vs {exact}");
        let o = open_tube(24, 6);
        assert!(!o.is_watertight());
        assert_eq!(o.indices.len(), 2 * 24 * 6);
        // outward: the signed volume of the side alone is positive (caps would add the rest)
        assert!(o.signed_volume() > 0.0);
    }

    #[test]
    fn four_hole_plate_has_genus_four() {
        let m = four_hole_plate(72);
        assert!(m.is_watertight());
        // Euler characteristic V − E + F = 2 − 2g of a closed triangle mesh (E = 3F/2)
        let (v, f) = (m.positions.len() as i64, m.indices.len() as i64);
        assert_eq!(v - 3 * f / 2 + f, -6, "V = {v}, F = {f}");
        // the plate minus four cylinders (the rounded edges take a little more)
        let exact = 2.0 * 0.2 * 0.7 - 4.0 * PI * 0.16f64.powi(2) * 0.2;
        let vol = m.signed_volume();
        assert!(vol < exact && vol > 0.95 * exact, "{vol} vs {exact}");
    }
}
