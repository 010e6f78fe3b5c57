//! The fit's outside-volume model against an independent Monte-Carlo integration of the
//! winding-number inside test (hierarchical evaluation; exact away from a thin surface layer).

#![allow(clippy::print_stderr)] // the measured accuracy is printed for docs/spheres.md

use penumbra_geometry::procedural::{character, torus};
use penumbra_geometry::{GridSpec, MeshBvh, SignedDistanceGrid, TriMesh, WindingNumber};
use penumbra_math::rng::{hash4, unit_f64};
use penumbra_spheres::frame::Frame;
use penumbra_spheres::sphere::Sphere;
use penumbra_spheres::volume::VolumeModel;

fn check(mesh: &TriMesh, grid_res: usize, tolerance: f64) {
    let frame = Frame::of(mesh).unwrap();
    let m = frame.canonical_mesh(mesh);
    let bvh = MeshBvh::build(&m).unwrap();
    let wn = WindingNumber::new(&m);
    let spec = GridSpec::fit(&m.bounds().unwrap(), grid_res, 2);
    let grid = SignedDistanceGrid::build(&m, &bvh, &wn, spec, true);
    let model = VolumeModel::new(&grid, 3);
    let h = spec.h;
    let mut worst: f64 = 0.0;
    let mut raw: f64 = 0.0;
    for case in 0..25u64 {
        // a sphere centred near a random vertex, 2 to 20 cells in radius
        let v = m.positions[(hash4(2, case, 0, 0) % m.positions.len() as u64) as usize];
        let u = |k: u64| unit_f64(hash4(2, case, 1, k));
        let c = [v[0] + (u(0) - 0.5) * 4.0 * h, v[1] + (u(1) - 0.5) * 4.0 * h, v[2] + (u(2) - 0.5) * 4.0 * h];
        let r = h * (2.0 + 18.0 * u(3));
        let s = Sphere::new(c, r);
        // Monte Carlo with the exact inside test
        let n = 8_000;
        let mut inside = 0;
        for k in 0..n {
            let w = |j: u64| unit_f64(hash4(5, case, k, j));
            let z = 1.0 - 2.0 * w(0);
            let rr = (1.0 - z * z).sqrt();
            let phi = std::f64::consts::TAU * w(1);
            let t = w(2).cbrt() * r;
            let p = [c[0] + t * rr * phi.cos(), c[1] + t * rr * phi.sin(), c[2] + t * z];
            inside += wn.is_inside(p) as usize;
        }
        let p = inside as f64 / n as f64;
        let mc_out = s.volume() * (1.0 - p);
        let sigma = s.volume() * (p * (1.0 - p) / n as f64).sqrt();
        let err = (model.outside_volume(c, r) - mc_out).abs();
        assert!(
            err <= tolerance * s.volume() + 4.0 * sigma,
            "case {case}: r = {:.1} h, error {:.4} of the ball",
            r / h,
            err / s.volume()
        );
        worst = worst.max((err - 4.0 * sigma).max(0.0) / s.volume());
        raw = raw.max(err / s.volume());
        // the clustering profile (coarser: 96 directions per shell) agrees with the quadrature
        let prof = model.profile(c, 1.1 * r);
        let d = (prof.at(r) - model.outside_volume(c, r)).abs();
        assert!(d <= 2.0 * tolerance * s.volume() + 1e-12, "profile case {case}: {:.4}", d / s.volume());
    }
    eprintln!("largest |model − MC|: {raw:.4} of the sphere volume ({worst:.4} beyond 4σ of the MC)");
    assert!(worst < tolerance);
}

#[test]
fn objective_matches_exact_monte_carlo() {
    // within 1 % of the sphere volume (beyond the Monte-Carlo noise) for spheres 2–20 grid
    // cells in radius
    check(&character(40), 48, 0.01);
    check(&torus([0.0; 3], 1.0, 0.35, 48, 24), 48, 0.01);
}

#[test]
fn finer_samples_nest_in_the_coarse_elements() {
    // every surface element of `build_finer` lies inside the coarse element it names (its
    // corners have barycentric coordinates in [0, 1] there, in the coarse triangle's plane),
    // every coarse element is covered, and the finer areas add up to the coarse ones
    use penumbra_spheres::samples::Samples;
    let mesh = torus([0.0; 3], 1.0, 0.19, 24, 12);
    let frame = Frame::of(&mesh).unwrap();
    let m = frame.canonical_mesh(&mesh);
    let bvh = MeshBvh::build(&m).unwrap();
    let wn = WindingNumber::new(&m);
    let grid = SignedDistanceGrid::build(&m, &bvh, &wn, GridSpec::fit(&m.bounds().unwrap(), 24, 2), true);
    let coarse = Samples::build(&m, &mesh, &frame, &grid);
    let fine = Samples::build_finer(&m, &mesh, &frame, &grid, 2);
    assert!(coarse.coarse_parent.is_empty());
    assert!(
        fine.surface_elements > 3 * coarse.surface_elements,
        "{} vs {}",
        fine.surface_elements,
        coarse.surface_elements
    );
    assert_eq!(fine.coarse_parent.len(), fine.surface_elements);
    assert_eq!(fine.elements.len() - fine.surface_elements, coarse.elements.len() - coarse.surface_elements);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let area = |p: [[f64; 3]; 3]| {
        let c = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        0.5 * dot(c, c).sqrt()
    };
    let tri = |s: &Samples, e: usize| s.elements[e].points.map(|k| s.points[k as usize]);
    let mut fine_area = vec![0.0f64; coarse.surface_elements];
    for e in 0..fine.surface_elements {
        let parent = fine.coarse_parent[e] as usize;
        let [a, b, c] = tri(&coarse, parent);
        let n = cross(sub(b, a), sub(c, a));
        let nn = dot(n, n);
        for q in tri(&fine, e) {
            // barycentric coordinates of q in (a, b, c) and its distance to their plane
            let w = sub(q, a);
            let u = dot(cross(w, sub(c, a)), n) / nn;
            let v = dot(cross(sub(b, a), w), n) / nn;
            let off = dot(w, n) / nn.sqrt();
            assert!(u >= -1e-9 && v >= -1e-9 && u + v <= 1.0 + 1e-9 && off.abs() < 1e-12, "element {e}: {u} {v} {off}");
        }
        fine_area[parent] += area(tri(&fine, e));
    }
    for (k, fa) in fine_area.iter().enumerate() {
        let ca = area(tri(&coarse, k));
        assert!((fa - ca).abs() <= 1e-9 * ca.max(1e-12), "coarse element {k}: {fa} vs {ca}");
    }
}
