//! BVH and winding-number tests: property tests against brute force, watertightness,
//! determinism, exact vs fast winding numbers.

use glam::DVec3;
use proptest::prelude::*;

use crate::bvh::{MeshBvh, Ray, any_hit_brute_force, closest_hit_brute_force, closest_point_brute_force};
use crate::inside::WindingNumber;
use crate::mesh::TriMesh;
use crate::testutil::{grid, icosphere};

fn soup() -> impl Strategy<Value = TriMesh> {
    prop::collection::vec(prop::array::uniform3(prop::array::uniform3(-1.0f64..1.0)), 1..120).prop_map(|tris| {
        let mut m = TriMesh::default();
        for t in tris {
            let b = m.positions.len() as u32;
            m.positions.extend(t);
            m.indices.push([b, b + 1, b + 2]);
        }
        m
    })
}

fn ray() -> impl Strategy<Value = Ray> {
    (
        prop::array::uniform3(-2.0f64..2.0),
        prop::array::uniform3(-1.0f64..1.0),
        0.0f64..0.5,
        prop_oneof![Just(f64::INFINITY), 0.5f64..4.0],
        0u8..4,
    )
        .prop_filter_map("zero direction", |(o, mut d, tmin, tmax, axis)| {
            // a quarter of the rays have exactly-zero direction components
            if axis < 3 {
                d[axis as usize] = 0.0;
            }
            (DVec3::from(d).length() > 1e-3).then(|| Ray::new(o, d).with_range(tmin, tmax))
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn closest_hit_matches_brute_force(mesh in soup(), rays in prop::collection::vec(ray(), 32)) {
        let bvh = MeshBvh::build(&mesh).unwrap();
        for r in &rays {
            let a = bvh.closest_hit(r);
            let b = closest_hit_brute_force(&mesh, r);
            prop_assert_eq!(a, b, "ray {:?}", r);
        }
    }

    #[test]
    fn any_hit_matches_brute_force(mesh in soup(), rays in prop::collection::vec(ray(), 32)) {
        let bvh = MeshBvh::build(&mesh).unwrap();
        let mut stack = bvh.traversal_stack();
        for r in &rays {
            let expect = any_hit_brute_force(&mesh, r);
            prop_assert_eq!(bvh.any_hit(r), expect, "ray {:?}", r);
            // the prepared-direction path is the same query
            let prepared = crate::bvh::PreparedDir::new(r.direction)
                .is_some_and(|pd| bvh.any_hit_prepared(r.origin, &pd, r.tmin, r.tmax, &mut stack));
            prop_assert_eq!(prepared, expect, "prepared ray {:?}", r);
        }
    }

    #[test]
    fn closest_point_matches_brute_force(
        mesh in soup(),
        pts in prop::collection::vec(prop::array::uniform3(-3.0f64..3.0), 32),
    ) {
        let bvh = MeshBvh::build(&mesh).unwrap();
        for p in &pts {
            let a = bvh.closest_point(*p).unwrap();
            let b = closest_point_brute_force(&mesh, *p).unwrap();
            prop_assert!((a.distance - b.distance).abs() <= 1e-12 * (1.0 + b.distance));
            // the reported point lies on the reported triangle, at the reported distance
            let [x, y, z] = mesh.triangle(a.triangle as usize).map(DVec3::from);
            let q = crate::kernels::closest_point_on_triangle(DVec3::from(*p), x, y, z);
            prop_assert!((q - DVec3::from(a.point)).length() <= 1e-12);
            prop_assert!(((DVec3::from(a.point) - DVec3::from(*p)).length() - a.distance).abs() <= 1e-12);
        }
    }

    /// Grids have many exact ties (rays through shared vertices and edges); a ray through the
    /// grid plane must hit it (watertight), and the tie rule must match brute force.
    #[test]
    fn grid_ties_and_watertightness(i in 0u32..8, j in 0u32..8, fx in 0u8..3, fy in 0u8..3, dz in 0.1f64..2.0) {
        let m = grid(8);
        let bvh = MeshBvh::build(&m).unwrap();
        let x = i as f64 + fx as f64 * 0.5;
        let y = j as f64 + fy as f64 * 0.5;
        let r = Ray::new([x, y, dz], [0.0, 0.0, -1.0]);
        let a = bvh.closest_hit(&r);
        prop_assert!(a.is_some(), "ray through ({x}, {y}) leaked");
        prop_assert_eq!(a, closest_hit_brute_force(&m, &r));
        prop_assert!((a.unwrap().t - dz).abs() < 1e-14);
        // oblique ray aimed at the same point (inside the grid: rounding can move a target on
        // the grid's outer boundary off the mesh)
        let o = [x + 0.3 * dz, y - 0.2 * dz, dz];
        let r2 = Ray::new(o, [-0.3 * dz, 0.2 * dz, -dz]);
        if x > 0.0 && x < 8.0 && y > 0.0 && y < 8.0 {
            prop_assert!(bvh.any_hit(&r2));
        }
        prop_assert_eq!(bvh.closest_hit(&r2), closest_hit_brute_force(&m, &r2));
    }
}

/// Rays from inside a closed icosphere through every vertex and edge midpoint all hit.
#[test]
fn closed_mesh_does_not_leak() {
    let m = icosphere(3, 1.0, [0.1, -0.2, 0.3]);
    let bvh = MeshBvh::build(&m).unwrap();
    let c = DVec3::new(0.1, -0.2, 0.3);
    let mut targets: Vec<DVec3> = m.positions.iter().map(|p| DVec3::from(*p)).collect();
    for t in &m.indices {
        for k in 0..3 {
            let a = DVec3::from(m.positions[t[k] as usize]);
            let b = DVec3::from(m.positions[t[(k + 1) % 3] as usize]);
            targets.push(0.5 * (a + b));
        }
    }
    for origin in [c, c + DVec3::new(0.3, 0.1, -0.2)] {
        for t in &targets {
            let r = Ray::new(origin.to_array(), (*t - origin).to_array());
            let h = bvh.closest_hit(&r);
            assert!(h.is_some(), "ray from {origin} toward {t} leaked");
            assert!(bvh.any_hit(&r));
            assert_eq!(h, closest_hit_brute_force(&m, &r));
        }
    }
}

/// Same hits for a mesh scaled by 1e-4 and 1e4 (the BVH normalises internally).
#[test]
fn scale_invariance() {
    let m = icosphere(2, 1.0, [0.0; 3]);
    let rays: Vec<Ray> = (0..200)
        .map(|k| {
            let a = k as f64 * 0.618;
            let o = [2.0 * a.cos(), 1.3 * (a * 0.7).sin(), 2.0 * a.sin()];
            let d = [-o[0] + 0.3 * (a * 3.1).sin(), -o[1], -o[2] + 0.2];
            Ray::new(o, d)
        })
        .collect();
    let base = MeshBvh::build(&m).unwrap();
    for s in [1e-4, 1e4] {
        let mut ms = m.clone();
        ms.map_positions(|p| p.map(|x| x * s));
        let bvh = MeshBvh::build(&ms).unwrap();
        for r in &rays {
            let rs = Ray::new(r.origin.map(|x| x * s), r.direction);
            let a = base.closest_hit(r);
            let b = bvh.closest_hit(&rs);
            assert_eq!(a.map(|h| h.triangle), b.map(|h| h.triangle));
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a.t * s - b.t).abs() <= 1e-12 * b.t.abs());
            }
            assert_eq!(b, closest_hit_brute_force(&ms, &rs));
        }
    }
}

#[test]
fn build_is_deterministic_and_batches_agree() {
    let m = icosphere(3, 1.0, [0.0; 3]);
    let a = MeshBvh::build(&m).unwrap();
    let b = MeshBvh::build(&m).unwrap();
    assert_eq!(a.cwbvh_fingerprint(), b.cwbvh_fingerprint());
    let rays: Vec<Ray> =
        (0..64).map(|k| Ray::new([0.0, 0.0, 0.0], [(k as f64).sin(), (k as f64 * 0.3).cos(), 0.5])).collect();
    let mut out = vec![None; rays.len()];
    a.closest_hits(&rays, &mut out);
    let mut occ = vec![false; rays.len()];
    a.any_hits(&rays, &mut occ);
    for (k, r) in rays.iter().enumerate() {
        assert_eq!(out[k], b.closest_hit(r));
        assert!(occ[k]);
    }
}

#[test]
fn empty_and_invalid_inputs() {
    let empty = MeshBvh::build(&TriMesh::default()).unwrap();
    let r = Ray::new([0.0; 3], [1.0, 0.0, 0.0]);
    assert!(empty.closest_hit(&r).is_none());
    assert!(!empty.any_hit(&r));
    assert!(empty.closest_point([0.0; 3]).is_none());
    let m = icosphere(1, 1.0, [0.0; 3]);
    let bvh = MeshBvh::build(&m).unwrap();
    assert!(bvh.closest_hit(&Ray::new([0.0; 3], [0.0; 3])).is_none());
    assert!(bvh.closest_hit(&Ray::new([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0])).is_none());
    let mut bad = m.clone();
    bad.positions[0][0] = f64::INFINITY;
    assert!(MeshBvh::build(&bad).is_err());
    fn assert_sync<T: Send + Sync>() {}
    assert_sync::<MeshBvh>();
    assert_sync::<WindingNumber>();
}

#[test]
fn aabb_tree_depth_is_logarithmic() {
    let m = icosphere(4, 1.0, [0.0; 3]); // 5120 triangles
    let t = crate::aabb_tree::AabbTree::build(&m);
    assert!(t.depth() <= 12, "depth {}", t.depth());
}

/// Inside a closed icosphere w = 1, outside 0; the fast path agrees with the exact sum.
#[test]
fn winding_number_sphere_exact_and_fast() {
    let m = icosphere(3, 1.0, [0.0; 3]);
    let w = WindingNumber::new(&m);
    let mut max_err: f64 = 0.0;
    for k in 0..400 {
        let a = k as f64;
        let dir = DVec3::new((a * 1.3).sin(), (a * 0.7).cos(), (a * 2.1).sin()).normalize();
        let r = 0.02 + 2.5 * ((a * 0.37).sin() * 0.5 + 0.5);
        let p = (dir * r).to_array();
        let exact = w.exact(p);
        // the icosphere's inscribed radius exceeds 0.98
        if r < 0.98 {
            assert!((exact - 1.0).abs() < 1e-10, "inside {p:?}: {exact}");
        } else if r > 1.0 {
            assert!(exact.abs() < 1e-10, "outside {p:?}: {exact}");
        }
        if !(0.95..1.05).contains(&r) {
            let fast = w.winding_number(p);
            max_err = max_err.max((fast - exact).abs());
            assert_eq!(fast >= 0.5, exact >= 0.5);
        }
    }
    assert!(max_err < 5e-3, "max |fast − exact| = {max_err}");
    // higher β is more accurate
    let w4 = WindingNumber::with_beta(&m, 4.0);
    let max4 = (0..200)
        .map(|k| {
            let a = k as f64;
            let p = [1.2 * (a * 0.9).sin(), 1.3 * (a * 0.4).cos(), 0.7 * (a * 1.7).sin()];
            (w4.winding_number(p) - w4.exact(p)).abs()
        })
        .fold(0.0, f64::max);
    assert!(max4 < max_err / 4.0, "β=4: {max4}, β=2: {max_err}");
}

/// The far field is a second-order expansion: its error must fall like the neglected third
/// order term, i.e. the absolute error like d⁻⁵ (≈32× per doubling of the distance) for an
/// open cap (non-trivial far field) seen as a single node.
#[test]
fn far_field_expansion_is_second_order() {
    let m = icosphere(2, 1.0, [0.0; 3]);
    let cap = TriMesh {
        positions: m.positions.clone(),
        indices: m.indices.iter().filter(|t| t.iter().all(|&i| m.positions[i as usize][1] > -0.01)).copied().collect(),
    };
    let w = WindingNumber::with_beta(&cap, 2.0);
    for dir in [[0.0, 1.0, 0.0], [0.6, -0.8, 0.0], [0.0, -0.6, 0.8]] {
        let err = |d: f64| {
            let p = dir.map(|c| c * d);
            let (e, f) = (w.exact(p), w.winding_number(p));
            ((e - f).abs(), ((e - f) / e).abs())
        };
        let (a12, r12) = err(12.0);
        let (a24, _) = err(24.0);
        assert!(r12 < 1e-3, "relative error {r12} at distance 12");
        let ratio = a12 / a24;
        assert!((20.0..50.0).contains(&ratio), "error ratio {ratio} for {dir:?}");
    }
}

/// With obvhs' parallel build, query results do not depend on the thread count (they never
/// depend on the tree layout; the trees themselves are compared for information).
#[cfg(feature = "parallel")]
#[test]
fn parallel_build_thread_count_independent() {
    let m = icosphere(4, 1.0, [0.0; 3]);
    let build = |threads: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| MeshBvh::build(&m).unwrap())
    };
    let (a, b) = (build(1), build(2));
    for k in 0..500 {
        let t = k as f64 * 0.37;
        let r = Ray::new([2.0 * t.cos(), 0.3 * t.sin(), 2.0 * t.sin()], [-t.cos(), 0.1, -t.sin()]);
        assert_eq!(a.closest_hit(&r), b.closest_hit(&r));
        assert_eq!(a.any_hit(&r), b.any_hit(&r));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The parallel-ray BVH (stream and 4-wide single rays) gives the CWBVH's and brute
    /// force's any-hit booleans for bundles of rays sharing one direction.
    #[test]
    fn parallel_bvh_matches_cwbvh_and_brute_force(
        mesh in soup(),
        dir in prop::array::uniform3(-1.0f64..1.0),
        zero in 0u8..4,
        origins in prop::collection::vec(prop::array::uniform3(-2.0f64..2.0), 1..200),
        tmin in 0.0f64..0.5,
        tmax in prop_oneof![Just(f64::INFINITY), 0.5f64..4.0],
    ) {
        let mut d = dir;
        if zero < 3 {
            d[zero as usize] = 0.0;
        }
        prop_assume!(DVec3::from(d).length() > 1e-3);
        let bvh = MeshBvh::build(&mesh).unwrap();
        let par = bvh.parallel_bvh();
        let pd = crate::bvh::PreparedDir::new(d).unwrap();
        let mut stack = bvh.traversal_stack();
        let mut out = vec![false; origins.len()];
        par.any_hits(&origins, &pd, tmin, tmax, &mut out, &mut crate::packet::StreamScratch::default());
        for (o, &h) in origins.iter().zip(&out) {
            let want = bvh.any_hit_prepared(*o, &pd, tmin, tmax, &mut stack);
            prop_assert_eq!(want, any_hit_brute_force(&mesh, &Ray::new(*o, d).with_range(tmin, tmax)));
            prop_assert_eq!(h, want);
            prop_assert_eq!(par.any_hit(*o, &pd, tmin, tmax), want);
        }
    }
}

#[test]
fn parallel_bvh_on_closed_meshes_and_shared_edges() {
    // a closed sphere (rays from outside through it hit, from inside always hit) and the
    // grid's shared edges and vertices (watertight: never a leak between two triangles)
    for mesh in [icosphere(4, 1.0, [0.1, -0.2, 0.3]), grid(8)] {
        let bvh = MeshBvh::build(&mesh).unwrap();
        let par = bvh.parallel_bvh();
        assert!(par.node_count() > 0);
        let mut scratch = crate::packet::StreamScratch::default();
        let mut stack = bvh.traversal_stack();
        let mut n_hit = 0;
        for d in [[0.0, 0.0, -1.0], [0.3, -0.2, -1.0], [1.0, 0.0, 0.0], [-0.7, 0.7, 0.1]] {
            let pd = crate::bvh::PreparedDir::new(d).unwrap();
            // a lattice of origins on grid vertices and edge midpoints, shifted back along d
            let origins: Vec<[f64; 3]> = (0..33 * 33)
                .map(|i| {
                    let (x, y) = ((i % 33) as f64 / 32.0, (i / 33) as f64 / 32.0);
                    [2.0 * x - 1.0 - 3.0 * d[0], 2.0 * y - 1.0 - 3.0 * d[1], 0.0 - 3.0 * d[2]]
                })
                .collect();
            let mut out = vec![false; origins.len()];
            par.any_hits(&origins, &pd, 0.0, f64::INFINITY, &mut out, &mut scratch);
            for (o, &h) in origins.iter().zip(&out) {
                let want = bvh.any_hit_prepared(*o, &pd, 0.0, f64::INFINITY, &mut stack);
                assert_eq!(h, want, "origin {o:?} dir {d:?}");
                assert_eq!(par.any_hit(*o, &pd, 0.0, f64::INFINITY), want);
                n_hit += h as usize;
            }
        }
        // the test is not vacuous: many lattice rays hit
        assert!(n_hit > 500, "{n_hit}");
    }
    // an empty mesh never hits
    let empty = MeshBvh::build(&TriMesh::default()).unwrap().parallel_bvh();
    let pd = crate::bvh::PreparedDir::new([0.0, 0.0, 1.0]).unwrap();
    let mut out = [true];
    empty.any_hits(&[[0.0; 3]], &pd, 0.0, f64::INFINITY, &mut out, &mut crate::packet::StreamScratch::default());
    assert!(!out[0] && !empty.any_hit([0.0; 3], &pd, 0.0, f64::INFINITY));
}
