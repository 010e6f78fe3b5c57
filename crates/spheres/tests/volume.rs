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
