//! The sphere-set bake on procedural meshes: bounding, known answers, invariances,
//! determinism, monotone E, and the quality ratio against the octree baseline.

use penumbra_geometry::procedural::{aabb_box, character, icosphere, torus};
use penumbra_geometry::{Scene, TriMesh};
use penumbra_math::progress::NoProgress;
use penumbra_math::rng::{hash4, unit_f64};
use penumbra_spheres::fit::{FitParams, FitResult, Method, Target};
use penumbra_spheres::sphere::{Sphere, from_f32};

fn scene(mesh: TriMesh) -> Scene {
    Scene { mesh, ..Scene::default() }
}

fn params(n: usize, method: Method) -> FitParams {
    let mut p = FitParams::new(Target::Count(n));
    p.method = method;
    p.grid = 32;
    p.iterations = 30;
    p.metrics.union_samples = 1 << 17;
    p.metrics.per_sphere_samples = 1024;
    p
}

fn run(mesh: &TriMesh, p: &FitParams) -> FitResult {
    penumbra_spheres::fit(&scene(mesh.clone()), p, &NoProgress).expect("fit")
}

/// Every vertex, and dense barycentric samples of every triangle, lie in a stored sphere
/// (evaluated in f64 from the f32 values).
fn assert_bounding(mesh: &TriMesh, r: &FitResult) {
    let spheres: Vec<Sphere> = r.spheres.iter().map(|&v| from_f32(v)).collect();
    let covered = |p: [f64; 3]| spheres.iter().any(|s| s.contains(p));
    for (i, p) in mesh.positions.iter().enumerate() {
        assert!(covered(*p), "vertex {i} {p:?} is outside every sphere");
    }
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t);
        for k in 0..6u64 {
            let (mut u, mut v) = (unit_f64(hash4(1, t as u64, k, 0)), unit_f64(hash4(1, t as u64, k, 1)));
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p: [f64; 3] = std::array::from_fn(|d| a[d] + u * (b[d] - a[d]) + v * (c[d] - a[d]));
            assert!(covered(p), "triangle {t}: surface point {p:?} is outside every sphere");
        }
    }
    assert_eq!(r.metrics.uncovered_sample_points, 0);
    assert!(r.metrics.max_uncovered_distance <= 1e-6 * mesh.bounds().unwrap().diagonal());
    assert!(r.spheres.iter().flatten().all(|x| x.is_finite()));
}

#[test]
fn lloyd_and_octree_fits_bound_the_surface() {
    for mesh in [torus([0.0; 3], 1.0, 0.3, 32, 16), character(28), aabb_box([0.0; 3], [2.0, 1.0, 0.5])] {
        for method in [Method::Lloyd, Method::Octree] {
            let r = run(&mesh, &params(12, method));
            assert_bounding(&mesh, &r);
            assert!(r.metrics.uncovered_ratio < 1e-3, "{method:?}: {}", r.metrics.uncovered_ratio);
            assert!(r.metrics.outside_volume_ratio.is_finite() && r.metrics.outside_volume_ratio > 0.0);
        }
    }
}

#[test]
fn one_sphere_is_the_minimal_enclosing_ball() {
    // icosphere vertices lie on the unit sphere: the minimal ball is the unit ball
    let mesh = icosphere(2, 1.0, [0.3, -0.2, 0.1]);
    let r = run(&mesh, &params(1, Method::Lloyd));
    let s = from_f32(r.spheres[0]);
    assert!((s.radius - 1.0).abs() < 1e-6, "{s:?}");
    assert!((0..3).all(|d| (s.center[d] - [0.3, -0.2, 0.1][d]).abs() < 1e-6), "{s:?}");
    // a box: half the diagonal, independent of Welzl's answer on the vertices
    let b = aabb_box([0.0; 3], [3.0, 2.0, 1.0]);
    let r = run(&b, &params(1, Method::Lloyd));
    let s = from_f32(r.spheres[0]);
    assert!((s.radius - 14f64.sqrt() / 2.0).abs() < 1e-6, "{s:?}");
    let w = penumbra_geometry::min_enclosing_ball(&b.positions).unwrap();
    assert!((w.radius - s.radius).abs() < 1e-6);
}

#[test]
fn scaled_meshes_give_the_same_fit_up_to_scale() {
    let base = character(24);
    let p = params(10, Method::Lloyd);
    let r1 = run(&base, &p);
    for scale in [1e-4, 1e4] {
        let mut m = base.clone();
        m.map_positions(|q| q.map(|x| x * scale));
        let r = run(&m, &p);
        assert_eq!(r.spheres.len(), r1.spheres.len());
        for (a, b) in r.spheres.iter().zip(&r1.spheres) {
            for k in 0..4 {
                let (x, y) = (a[k] as f64 / scale, b[k] as f64);
                assert!((x - y).abs() <= 1e-5 * (1.0 + y.abs()), "scale {scale}: {a:?} vs {b:?}");
            }
        }
        assert!((r.metrics.outside_volume_ratio - r1.metrics.outside_volume_ratio).abs() < 1e-3);
    }
}

#[test]
fn needle_and_flat_meshes_fit_without_nan() {
    let needle = aabb_box([0.0; 3], [100.0, 1.0, 1.0]);
    let mut p = params(8, Method::Lloyd);
    p.grid = 16;
    let r = run(&needle, &p);
    assert_bounding(&needle, &r);
    assert!(r.metrics.outside_volume_ratio.is_finite());
    // spheres along a needle are small: far below the needle's half length
    assert!(r.spheres.iter().all(|s| s[3] < 20.0), "{:?}", r.spheres);
    // a flat, open square has no volume: its ratios are NaN (null in JSON), but the fit bounds it
    let flat = penumbra_geometry::procedural::grid(6);
    let r = run(&flat, &p);
    assert_bounding(&flat, &r);
    assert!(r.metrics.outside_volume_ratio.is_nan() && r.metrics.union_outside_ratio.is_nan());
}

#[test]
fn same_result_for_any_thread_count() {
    let mesh = character(24);
    let mut p = params(9, Method::Lloyd);
    p.hierarchy = true;
    let go = |threads: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| run(&mesh, &p))
    };
    let (a, b, c) = (go(1), go(2), go(2));
    assert_eq!(a.spheres, b.spheres);
    assert_eq!(b.spheres, c.spheres);
    assert_eq!(a.hierarchy, b.hierarchy);
    assert_eq!(a.metrics, b.metrics);
}

#[test]
fn outside_volume_never_increases_over_iterations() {
    let mesh = character(28);
    let r = run(&mesh, &params(16, Method::Lloyd));
    let log = &r.report.log;
    assert!(log.len() >= 3, "{log:?}");
    for w in log.windows(2) {
        assert!(w[1].e <= w[0].e, "E rose: {w:?}");
    }
    assert!(log.last().unwrap().e < 0.9 * log[0].e, "the fit improved on its start: {log:?}");
    for l in log {
        assert!(l.accepted == (l.e == l.candidate_e) || !l.accepted);
    }
}

#[test]
fn lloyd_union_ratio_beats_the_octree_at_equal_count() {
    let mesh = character(32);
    let oct = run(&mesh, &params(24, Method::Octree));
    let n = oct.spheres.len();
    let lloyd = run(&mesh, &params(n, Method::Lloyd));
    assert_eq!(lloyd.spheres.len(), n);
    assert!(
        lloyd.metrics.union_outside_ratio * 2.0 < oct.metrics.union_outside_ratio,
        "{n} spheres: lloyd {} vs octree {}",
        lloyd.metrics.union_outside_ratio,
        oct.metrics.union_outside_ratio
    );
}

/// The count a target search returns meets the target and the count one below it was probed
/// and missed (the search bisects to the boundary, not to the first probe that missed).
fn assert_minimal(r: &FitResult, target: f64) {
    let n = r.report.requested_count;
    assert!(r.spheres.len() <= n, "{} spheres for a request of {n}", r.spheres.len());
    let search = &r.report.search;
    let at = |k: usize| search.iter().find(|x| x.0 == k).map(|x| x.1);
    let mine = at(n).unwrap_or_else(|| panic!("count {n} not in the search {search:?}"));
    assert!(mine <= target, "{n} spheres: {mine} > {target}; {search:?}");
    if n > 1 {
        let below = at(n - 1).unwrap_or_else(|| panic!("count {} was never probed: {search:?}", n - 1));
        assert!(below > target, "{} spheres already meet {target}: {search:?}", n - 1);
    }
    let t = r.report.target.as_ref().expect("a target outcome");
    assert!(t.met && t.reason.is_none(), "{t:?}");
}

#[test]
fn target_error_bisects_to_the_smallest_count_meeting_it() {
    let mesh = torus([0.0; 3], 1.0, 0.3, 24, 12);
    let mut p = params(1, Method::Lloyd);
    p.grid = 20;
    p.iterations = 12;
    p.target = Target::Error(0.6);
    let r = run(&mesh, &p);
    assert_minimal(&r, 0.6);
    assert_eq!(
        r.metrics.outside_volume_ratio,
        r.report.search.iter().find(|x| x.0 == r.report.requested_count).unwrap().1
    );
    // the search went through the doubling and the bisection: more probes than doublings
    let doublings = r.report.search.iter().filter(|x| x.0.is_power_of_two()).count();
    assert!(r.report.search.len() > doublings || r.report.requested_count <= 2, "{:?}", r.report.search);
    assert_bounding(&mesh, &r);
}

#[test]
fn target_union_searches_on_the_union_ratio() {
    let mesh = torus([0.0; 3], 1.0, 0.3, 24, 12);
    let mut p = params(1, Method::Lloyd);
    p.grid = 20;
    p.iterations = 12;
    p.target = Target::Union(0.5);
    let r = run(&mesh, &p);
    assert_minimal(&r, 0.5);
    assert_eq!(
        r.metrics.union_outside_ratio,
        r.report.search.iter().find(|x| x.0 == r.report.requested_count).unwrap().1
    );
    assert_eq!(r.report.target.as_ref().unwrap().metric, "union_outside_ratio");
}

#[test]
fn unreachable_target_keeps_the_best_set_and_says_why() {
    let mesh = torus([0.0; 3], 1.0, 0.3, 24, 12);
    let mut p = params(1, Method::Lloyd);
    p.grid = 20;
    p.iterations = 12;
    p.max_count = 5;
    p.target = Target::Error(1e-3);
    let r = run(&mesh, &p);
    let t = r.report.target.as_ref().unwrap();
    assert!(!t.met && t.max_count == 5, "{t:?}");
    assert!(t.reason.as_deref().is_some_and(|s| s.contains("--max-count 5")), "{t:?}");
    // doubling 1, 2, 4, then the cap 5; the best of them is kept
    let counts: Vec<usize> = r.report.search.iter().map(|x| x.0).collect();
    assert_eq!(counts, [1, 2, 4, 5]);
    let best = r.report.search.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert_eq!(r.report.requested_count, best.0);
    assert!(r.spheres.len() <= best.0);
    assert_bounding(&mesh, &r);
    // a flat sheet has no volume: no ratio to search on, a clear error instead of a search
    let flat = penumbra_geometry::procedural::grid(6);
    let e = penumbra_spheres::fit(&scene(flat), &p, &NoProgress).unwrap_err();
    assert!(matches!(e, penumbra_spheres::SpheresError::NoVolume { .. }), "{e}");
    assert!(e.to_string().contains("no volume"), "{e}");
}

#[test]
fn metrics_agree_with_an_analytic_case() {
    // one sphere around a unit cube (bounding radius √3/2): E = (V_ball − 1)/1 exactly, and the
    // union ratio is the same (one sphere); the measurement must find it within its stderr
    let cube = aabb_box([0.0; 3], [1.0; 3]);
    let mut p = params(1, Method::Lloyd);
    p.metrics.per_sphere_samples = 1 << 15;
    p.metrics.union_samples = 1 << 19;
    let r = run(&cube, &p);
    let exact = 4.0 / 3.0 * std::f64::consts::PI * (3f64.sqrt() / 2.0).powi(3) - 1.0;
    let m = &r.metrics;
    assert!(
        (m.outside_volume_ratio - exact).abs() < 4.0 * m.outside_volume_ratio_stderr + 1e-4,
        "{} vs {exact}",
        m.outside_volume_ratio
    );
    assert!(
        (m.union_outside_ratio - exact).abs() < 4.0 * m.union_outside_ratio_stderr + 1e-4,
        "{} vs {exact}",
        m.union_outside_ratio
    );
    assert!(m.volume_exact && (m.volume - 1.0).abs() < 1e-9);
}

#[test]
fn thin_shapes_are_bounded_and_medial_refined_fits_beat_the_paper_defaults() {
    use penumbra_geometry::procedural::{bent_tube, capsule_chain, open_tube, thin_plate};
    use penumbra_spheres::lloyd::Seeding;
    for (name, mesh) in [
        ("bent tube", bent_tube(40)),
        ("capsule chain", capsule_chain(40)),
        ("thin plate", thin_plate(40)),
        ("open tube", open_tube(16, 6)),
    ] {
        let r = run(&mesh, &params(16, Method::Lloyd));
        assert_bounding(&mesh, &r);
        assert!(r.spheres.len() <= 16 && r.spheres.len() >= 8, "{name}: {}", r.spheres.len());
    }
    // the torus (minor/major 0.19, 576 triangles) at 32 spheres: medial seeding and the
    // union-aware refinement against k-means++ seeding without it (SHEXP's own procedure)
    let torus = torus([0.0; 3], 1.0, 0.19, 24, 12);
    let new = run(&torus, &params(32, Method::Lloyd));
    let mut p = params(32, Method::Lloyd);
    p.seeding = Seeding::KMeansPlusPlus;
    p.refine = false;
    let old = run(&torus, &p);
    let mut p = params(32, Method::Lloyd);
    p.seeding = Seeding::KMeansPlusPlus;
    let refined = run(&torus, &p);
    assert_bounding(&torus, &new);
    assert_bounding(&torus, &refined);
    let (u_new, u_old, u_ref) =
        (new.metrics.union_outside_ratio, old.metrics.union_outside_ratio, refined.metrics.union_outside_ratio);
    // the refinement only shrinks spheres: never a larger union than the fit it starts from
    assert!(u_ref <= u_old + 3.0 * old.metrics.union_outside_ratio_stderr, "{u_ref} vs {u_old}");
    assert!(u_new < 0.85 * u_old, "medial + refine {u_new} vs k-means++ {u_old} (+ refine {u_ref})");
}

#[test]
fn union_polish_lowers_the_union_and_keeps_the_set_bounding() {
    // the polish moves spheres only when the union's outside volume (by its lattice of exactly
    // classified outside points) drops, and never lets an element leave every sphere; on the
    // issue's torus at 64 spheres (grid 48) it lowered the union of the SHEXP fit from 0.172
    // to 0.158 (the evenly spaced candidate and the fine refinement are off here: after them
    // the polish gains < 1 %)
    let mesh = torus([0.0; 3], 1.0, 0.19, 24, 12);
    let mut p = params(64, Method::Lloyd);
    p.grid = 48;
    p.iterations = 100;
    p.cvt = false;
    p.fine_refine = false;
    let plain = run(&mesh, &p);
    p.polish = true;
    let polished = run(&mesh, &p);
    assert_bounding(&mesh, &polished);
    let (a, b) = (polished.metrics.union_outside_ratio, plain.metrics.union_outside_ratio);
    assert!(a < 0.95 * b, "polished {a} vs {b}");
    assert!(polished.spheres.len() == 64, "{}", polished.spheres.len());
    // deterministic for any thread count (the polish itself is sequential)
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| run(&mesh, &p));
    assert_eq!(one.spheres, polished.spheres);
}

#[test]
fn polished_fits_are_scale_invariant() {
    let base = character(24);
    let mut p = params(10, Method::Lloyd);
    p.polish = true;
    let r1 = run(&base, &p);
    assert_bounding(&base, &r1);
    for scale in [1e-4, 1e4] {
        let mut m = base.clone();
        m.map_positions(|q| q.map(|x| x * scale));
        let r = run(&m, &p);
        assert_eq!(r.spheres.len(), r1.spheres.len());
        for (a, b) in r.spheres.iter().zip(&r1.spheres) {
            for k in 0..4 {
                let (x, y) = (a[k] as f64 / scale, b[k] as f64);
                assert!((x - y).abs() <= 1e-5 * (1.0 + y.abs()), "scale {scale}: {a:?} vs {b:?}");
            }
        }
    }
}

/// Angular gaps (degrees) between consecutive sphere centres around the y axis, sorted by angle.
fn ring_gaps(r: &FitResult) -> Vec<f64> {
    let mut a: Vec<f64> = r.spheres.iter().map(|s| f64::from(s[0]).atan2(f64::from(s[2])).to_degrees()).collect();
    a.sort_by(f64::total_cmp);
    let mut g: Vec<f64> = a.windows(2).map(|w| w[1] - w[0]).collect();
    g.push(a[0] + 360.0 - a[a.len() - 1]);
    g
}

#[test]
fn evenly_spaced_candidate_evens_out_a_ring_and_lowers_its_union() {
    // the issue-16 torus (minor/major 0.19, 24 × 12 segments): SHEXP's E leaves the slabs of
    // the ring uneven; the CVT of the medial ridge spaces them evenly, and the union, which pays
    // for the long slabs, is lower
    let mesh = torus([0.0; 3], 1.0, 0.19, 24, 12);
    let mut p = params(64, Method::Lloyd);
    p.metrics.union_samples = 1 << 19;
    p.fine_refine = false;
    p.cvt = false;
    let shexp = run(&mesh, &p);
    p.cvt = true;
    let even = run(&mesh, &p);
    assert_bounding(&mesh, &even);
    assert_eq!(even.spheres.len(), 64);
    let (gs, ge) = (ring_gaps(&shexp), ring_gaps(&even));
    // coefficient of variation of the gaps (a regular ring has 0)
    let cv = |g: &[f64]| {
        let m = g.iter().sum::<f64>() / g.len() as f64;
        (g.iter().map(|x| (x - m).powi(2)).sum::<f64>() / g.len() as f64).sqrt() / m
    };
    let (us, ue) = (shexp.metrics.union_outside_ratio, even.metrics.union_outside_ratio);
    assert!(cv(&ge) < 0.75 * cv(&gs), "gaps not more even: cv {} vs {}: {ge:.2?}", cv(&ge), cv(&gs));
    assert!(ue < 0.9 * us, "union {ue} not below 0.9 × {us}");
}

#[test]
fn fine_refinement_lowers_the_union_and_keeps_the_set_bounding() {
    // elements must lie inside one sphere whole; halving them for the final refinement lets
    // neighbouring spheres meet closer to the middle (torus at 64: 0.119 -> 0.112 at grid 48)
    let mesh = torus([0.0; 3], 1.0, 0.19, 24, 12);
    let mut p = params(64, Method::Lloyd);
    p.grid = 48;
    p.iterations = 100;
    p.metrics.union_samples = 1 << 19;
    p.fine_refine = false;
    let coarse = run(&mesh, &p);
    p.fine_refine = true;
    let fine = run(&mesh, &p);
    assert_bounding(&mesh, &fine);
    let (uc, uf) = (coarse.metrics.union_outside_ratio, fine.metrics.union_outside_ratio);
    assert!(uf < 0.97 * uc, "fine {uf} vs coarse {uc}");
    // deterministic for any thread count
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| run(&mesh, &p));
    assert_eq!(one.spheres, fine.spheres);
}
