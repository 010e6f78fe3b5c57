//! BVH and inside tests on the real meshes (armadillo 86k triangles, the open Stanford
//! bunny against its closed decimation).

#![allow(clippy::print_stderr)] // tests may print a summary

mod common;

use std::time::Instant;

use penumbra_geometry::bvh::{MeshBvh, Ray, any_hit_brute_force, closest_hit_brute_force, closest_point_brute_force};
use penumbra_geometry::{TriMesh, WindingNumber, load_mesh};

/// Deterministic points in `[0, 1)³` (additive recurrence with irrational steps).
fn points(n: usize) -> impl Iterator<Item = [f64; 3]> {
    let g = [0.819_172_513_396_164_4, 0.671_043_606_703_789_2, 0.549_700_477_901_970_3];
    (1..=n).map(move |k| g.map(|a| (0.5 + a * k as f64).fract()))
}

/// Maps `u ∈ [0, 1)³` into the mesh's bounding box grown by `grow` of its extent per side.
fn boxer(m: &TriMesh, grow: f64) -> impl Fn([f64; 3]) -> [f64; 3] {
    let b = m.bounds().unwrap();
    let e = b.extent();
    move |u| [0, 1, 2].map(|k| b.min[k] - grow * e[k] + u[k] * (1.0 + 2.0 * grow) * e[k])
}

#[test]
fn armadillo_bvh_matches_brute_force() {
    let Some(data) = common::shared_data("armadillo_bvh_matches_brute_force") else {
        return;
    };
    let (scene, _) = load_mesh(data.join("meshes/armadillo_43k.obj")).unwrap();
    let m = &scene.mesh;
    let t = Instant::now();
    let bvh = MeshBvh::build(m).unwrap();
    let build = t.elapsed();
    let b02 = boxer(m, 0.2);
    let pts: Vec<[f64; 3]> = points(400).map(&b02).collect();
    let mut hits = 0;
    for k in 0..400 {
        // half the rays aim exactly at a mesh vertex: watertightness means they all hit
        let (o, target) =
            if k < 200 { (pts[k], pts[399 - k]) } else { (pts[k], m.positions[(k * 7919) % m.positions.len()]) };
        let r = Ray::new(o, [0, 1, 2].map(|c| target[c] - o[c]));
        let h = bvh.closest_hit(&r);
        assert_eq!(h, closest_hit_brute_force(m, &r), "ray {k}");
        assert_eq!(bvh.any_hit(&r), any_hit_brute_force(m, &r), "ray {k}");
        let seg = Ray::segment(o, target);
        assert_eq!(bvh.any_hit(&seg), any_hit_brute_force(m, &seg), "segment {k}");
        if k >= 200 {
            assert!(h.is_some(), "ray {k} aimed at a vertex missed");
        }
        hits += h.is_some() as usize;
    }
    assert!(hits >= 240, "only {hits} of 400 rays hit");
    for p in &pts[..100] {
        let a = bvh.closest_point(*p).unwrap();
        let b = closest_point_brute_force(m, *p).unwrap();
        assert!((a.distance - b.distance).abs() <= 1e-12 * (1.0 + b.distance));
    }
    // throughput, for information only (tests never assert on time)
    let b05 = boxer(m, 0.5);
    let rays: Vec<Ray> = points(100_000)
        .map(|u| {
            let o = b05(u);
            Ray::new(o, [-o[0], 0.3 - o[1], -o[2]])
        })
        .collect();
    let t = Instant::now();
    let n_hit = rays.iter().filter(|r| bvh.closest_hit(r).is_some()).count();
    let closest = t.elapsed();
    let t = Instant::now();
    let n_occ = rays.iter().filter(|r| bvh.any_hit(r)).count();
    let any = t.elapsed();
    assert_eq!(n_hit, n_occ);
    eprintln!(
        "armadillo: build {build:?}, depth {}; 100k closest-hit {closest:?}, any-hit {any:?} ({n_hit} hits)",
        bvh.depth()
    );
}

#[test]
fn armadillo_winding_number_fast_vs_exact() {
    let Some(data) = common::shared_data("armadillo_winding_number_fast_vs_exact") else {
        return;
    };
    let (scene, _) = load_mesh(data.join("meshes/armadillo_43k.obj")).unwrap();
    let m = &scene.mesh;
    let t = Instant::now();
    let w = WindingNumber::new(m);
    let pre = t.elapsed();
    let bvh = MeshBvh::build(m).unwrap();
    let diag = m.bounds().unwrap().diagonal();
    let mut max_err: f64 = 0.0;
    let mut inside = 0;
    let mut checked = 0;
    let b01 = boxer(m, 0.1);
    for u in points(300) {
        let p = b01(u);
        let exact = w.exact(p);
        let fast = w.winding_number(p);
        // closed mesh: exactly 0 or 1 away from the surface
        let d = bvh.closest_point(p).unwrap().distance;
        if d > 1e-3 * diag {
            assert!(exact.abs() < 1e-9 || (exact - 1.0).abs() < 1e-9, "{p:?}: w = {exact}");
            assert_eq!(fast >= 0.5, exact >= 0.5, "{p:?}: fast {fast}, exact {exact}, d {d}");
            checked += 1;
        }
        inside += (exact >= 0.5) as usize;
        max_err = max_err.max((fast - exact).abs());
    }
    assert!(checked > 280);
    assert!(inside > 10, "{inside} points inside");
    assert!(max_err < 5e-3, "max |fast − exact| = {max_err}");
    let t = Instant::now();
    let mut s = 0.0;
    for u in points(20_000) {
        s += w.winding_number(b01(u));
    }
    eprintln!(
        "armadillo winding: precompute {pre:?}, 20k fast queries {:?} (mean w {:.3}), max |fast − exact| {max_err:.2e}",
        t.elapsed(),
        s / 20_000.0
    );
}

/// The original Stanford bunny has holes in its base (223 boundary edges). Its winding
/// number still classifies points like the closed decimated bunny does, away from the two
/// surfaces (which differ by the decimation).
#[test]
fn open_bunny_inside_matches_closed_bunny() {
    let Some(data) = common::shared_data("open_bunny_inside_matches_closed_bunny") else {
        return;
    };
    let (open, _) = load_mesh(data.join("meshes/stanford-bunny.obj")).unwrap();
    let (closed, _) = load_mesh(data.join("meshes/bunny_closed_3k.obj")).unwrap();
    assert!(!open.mesh.is_watertight() && closed.mesh.is_watertight());
    let wo = WindingNumber::new(&open.mesh);
    let wc = WindingNumber::new(&closed.mesh);
    let (bo, bc) = (MeshBvh::build(&open.mesh).unwrap(), MeshBvh::build(&closed.mesh).unwrap());
    let diag = closed.mesh.bounds().unwrap().diagonal();
    let (mut agree, mut total, mut inside) = (0, 0, 0);
    let mut min_inside_w: f64 = 1.0;
    let n = 24;
    let b005 = boxer(&closed.mesh, 0.05);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let u = [i, j, k].map(|c| (c as f64 + 0.5) / n as f64);
                let p = b005(u);
                let margin = 0.01 * diag;
                if bo.closest_point(p).unwrap().distance < margin || bc.closest_point(p).unwrap().distance < margin {
                    continue;
                }
                let c = wc.winding_number(p) >= 0.5;
                let w = wo.winding_number(p);
                total += 1;
                agree += (c == (w >= 0.5)) as usize;
                if c {
                    inside += 1;
                    min_inside_w = min_inside_w.min(w);
                }
            }
        }
    }
    let rate = agree as f64 / total as f64;
    eprintln!("bunny: {agree}/{total} agree ({inside} inside), min open-bunny w inside {min_inside_w:.3}");
    assert!(inside > 500);
    assert!(rate > 0.995, "agreement {rate}");
    assert!(min_inside_w > 0.5, "an interior point of the open bunny has w = {min_inside_w}");
}
