//! Known answers of the MRT dictionary bake (issue "mrt dict", goals): a rank-1 prior gives a
//! rank-1 `M`; a box with only a floor has `F = 0`; `F` conserves energy; `F` agrees with
//! analytic form factors and with the path-traced reference; Table 3.2 of the thesis.

use faer::Mat;
use penumbra_math::progress::NoProgress;
use penumbra_transport::balance::balance_transport;
use penumbra_transport::dict::{DictParams, bake, direct_matrix, raw_gather_check, rel_error};
use penumbra_transport::gather::{DirectionSet, Gather, texel_sh, transport_matrix};
use penumbra_transport::operators::{prior_from_samples, reduce};
use penumbra_transport::prior::{LightLayout, SphereLight, prior_lights, test_lights};
use penumbra_transport::reference::one_bounce;
use penumbra_transport::shape::{CLOSED, CUBE2D, DictionaryKind, Shape, Texels};
use penumbra_transport::svd::mul;

fn f_of(shape: Shape, res: usize, rays: usize, albedo: f64) -> (Texels, Mat<f64>) {
    let tex = Texels::new(shape, res);
    let f = transport_matrix(&tex, &DirectionSet::cosine(rays), albedo, Gather::Bilinear, 0, 0, &|_| {});
    (tex, f)
}

fn sphere_lights(shape: &Shape) -> Vec<SphereLight> {
    prior_lights(shape, LightLayout::Lattice).into_iter().map(|c| SphereLight { centre: c, radius: 0.05 }).collect()
}

#[test]
fn rank_one_prior_gives_one_nonzero_singular_value_of_m() {
    let (tex, f) = f_of(CLOSED, 6, 1024, 0.8);
    let n = tex.len();
    // every column a multiple of one light's pattern: rank 1 up to rounding
    let light = SphereLight { centre: [0.3, 0.6, 0.45], radius: 0.05 };
    let one = direct_matrix(&tex, &[light]);
    let l_d = Mat::from_fn(n, 40, |i, j| one[(i, 0)] * (1.0 + j as f64 * 0.37));
    let (prior, sigma_d) = prior_from_samples(l_d.as_ref(), 64).unwrap();
    assert!(sigma_d[1] < 1e-12 * sigma_d[0], "L_d is rank 1 up to rounding: {:?}", &sigma_d[..3]);
    assert_eq!(prior.k(), 1, "k_d is capped at the numerical rank");
    let r = reduce(f.as_ref(), &prior, 32).unwrap();
    let nonzero = r.sigma_m.iter().filter(|&&s| s > 1e-10 * r.sigma_m[0]).count();
    assert_eq!(nonzero, 1);
    assert!(r.sigma_m[0] > 0.0);
    // and the rank-1 operator is exact on its own light: U_b T l = F l
    let fl = mul(f.as_ref(), one.as_ref());
    let rec = mul(r.u_b.as_ref(), mul(r.t_d2b.as_ref(), one.as_ref()).as_ref());
    assert!(rel_error(rec.as_ref(), fl.as_ref()) < 1e-10);
}

#[test]
fn a_box_with_only_a_floor_has_no_transport() {
    let floor_only = Shape::new("floor_only", 0b11_1011);
    assert_eq!(floor_only.faces(), vec![2]);
    for gather in [Gather::Bilinear, Gather::Exact] {
        let tex = Texels::new(floor_only, 8);
        let f = transport_matrix(&tex, &DirectionSet::cosine(4096), 1.0, gather, 0, 0, &|_| {});
        assert!((0..tex.len()).all(|i| (0..tex.len()).all(|j| f[(i, j)] == 0.0)), "{gather:?}");
        // and so does the balanced operator (no wall to land on: every target is 0)
        let (_, f) = balanced_f(floor_only, 8, 4096, 1.0, gather);
        assert!((0..tex.len()).all(|i| (0..tex.len()).all(|j| f[(i, j)] == 0.0)), "{gather:?}");
    }
    // adding the ceiling makes it nonzero
    let (_, f) = f_of(Shape::new("floor_ceiling", 0b11_0011), 8, 4096, 1.0);
    assert!(f[(0, 64)] + f[(0, 64 + 9)] > 0.0);
}

/// Form factor from a point to a parallel rectangle `[x0,x1]×[z0,z1]` at height `h`,
/// by the classic corner formula (independent of the Lambert polygon code).
fn ff_parallel_rect(px: f64, pz: f64, h: f64, x0: f64, x1: f64, z0: f64, z1: f64) -> f64 {
    let corner = |a: f64, b: f64| {
        // signed: rectangle [0,a]×[0,b] with a corner above the point
        let (x, y) = (a / h, b / h);
        let g = x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
            + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan();
        g / (2.0 * core::f64::consts::PI)
    };
    let f = |a: f64, b: f64| corner(a.abs(), b.abs()) * a.signum() * b.signum();
    f(x1 - px, z1 - pz) - f(x0 - px, z1 - pz) - f(x1 - px, z0 - pz) + f(x0 - px, z0 - pz)
}

#[test]
fn f_matches_analytic_form_factors_on_face_constant_light() {
    // floor and ceiling only: F·(1 on the ceiling) at a floor texel = ρ·FF(point → ceiling);
    // bilinear reads of a constant are exact, so only the ray sampling errs.
    let shape = Shape::new("floor_ceiling", 0b11_0011);
    let albedo = 0.7;
    let (tex, f) = f_of(shape, 8, 16384, albedo);
    let ceiling = tex.face_range(3);
    let mut worst: f64 = 0.0;
    for x in tex.face_range(2) {
        let p = tex.position(x);
        let got: f64 = ceiling.clone().map(|t| f[(x, t)]).sum();
        let want = albedo * ff_parallel_rect(p[0], p[2], 1.0, 0.0, 1.0, 0.0, 1.0);
        worst = worst.max((got - want).abs());
    }
    // binomial MC error of one texel at 16K rays is ≤ 0.004; the Hammersley set does far better
    assert!(worst < 1e-3, "worst |F·1 − ρ·FF| = {worst}");
    // sanity of the closed form: a point under the centre of a unit square at height 1
    // (0.2394565 by direct numerical integration of cos²θ/(πr²) over the square)
    assert!((ff_parallel_rect(0.5, 0.5, 1.0, 0.0, 1.0, 0.0, 1.0) - 0.239_456_5).abs() < 1e-6);
}

/// `F` as the bake uses it: gathered, then energy-balanced (`penumbra_transport::balance`).
fn balanced_f(shape: Shape, res: usize, rays: usize, albedo: f64, gather: Gather) -> (Texels, Mat<f64>) {
    let tex = Texels::new(shape, res);
    let mut f = transport_matrix(&tex, &DirectionSet::cosine(rays), albedo, gather, 0, 0, &|_| {});
    balance_transport(&tex, &mut f, albedo);
    (tex, f)
}

#[test]
fn sinkhorn_balance_bounds_every_column_by_construction() {
    // The energy statement ‖F l‖₁ ≤ ρ‖l‖₁ for every l ≥ 0 — for every shape, every
    // single-texel input (column), sphere lights and random inputs — on the *balanced* F.
    // The balance's last step scales the columns to ρ·g_j ≤ ρ, so this checks the balance
    // (that it ran and converged), not the gather: the raw gather is checked physically by
    // `raw_gather_rows_are_albedo_times_point_to_wall_form_factors` and
    // `raw_gather_face_to_face_form_factors_match_the_unit_cube`.
    let albedo = 0.6;
    for gather in [Gather::Bilinear, Gather::Exact] {
        for shape in CUBE2D {
            let (tex, f) = balanced_f(shape, 8, 4096, albedo, gather);
            let n = tex.len();
            let l1 = |v: &[f64]| v.iter().map(|x| x.abs()).sum::<f64>();
            let apply = |l: &[f64]| -> Vec<f64> { (0..n).map(|i| (0..n).map(|j| f[(i, j)] * l[j]).sum()).collect() };
            let tol = 1.0 + 1e-12;
            // every single-texel input l = e_j: ‖F e_j‖₁ is column j's sum
            for j in 0..n {
                let mut e = vec![0.0; n];
                e[j] = 1.0;
                let out = apply(&e);
                assert!(out.iter().all(|&x| x >= 0.0));
                assert!(l1(&out) <= albedo * tol, "{} {gather:?}: texel {j}: {}", shape.name, l1(&out) / albedo);
            }
            // sphere lights and random non-negative inputs
            let lights = direct_matrix(&tex, &sphere_lights(&shape));
            let mut rng = penumbra_math::rng::ItemRng::new(3, 9, 0);
            let mut inputs: Vec<Vec<f64>> =
                (0..lights.ncols()).map(|j| (0..n).map(|i| lights[(i, j)]).collect()).collect();
            inputs.extend((0..16).map(|_| (0..n).map(|_| rng.next_f64()).collect::<Vec<f64>>()));
            for l in &inputs {
                assert!(l1(&apply(l)) <= albedo * l1(l) * tol, "{} {gather:?}", shape.name);
            }
            let rows: Vec<f64> = (0..n).map(|i| (0..n).map(|j| f[(i, j)]).sum()).collect();
            let cols: Vec<f64> = (0..n).map(|j| (0..n).map(|i| f[(i, j)]).sum()).collect();
            if shape == CLOSED {
                // the equality case: every ray lands, so uniform light reflects exactly ρ
                // (rows) and all of every texel's light lands on a wall (columns)
                for (r, c) in rows.iter().zip(&cols) {
                    assert!((r / albedo - 1.0).abs() < 1e-11 && (c / albedo - 1.0).abs() < 1e-12, "{r} {c}");
                }
            } else {
                // openings lose light: strictly below ρ
                assert!(cols.iter().all(|&c| c < albedo), "{}", shape.name);
            }
        }
    }
}

/// The raw gather checked physically (the balance enforces the energy bound above by
/// construction, so it cannot tell a wrong gather from a right one): before any balance, row
/// `i` of `F` is `ρ` times the fraction of texel `i`'s cosine hemisphere that lands on a wall,
/// which Lambert's point-to-polygon form factors give exactly, face by face.
#[test]
fn raw_gather_rows_are_albedo_times_point_to_wall_form_factors() {
    use penumbra_transport::reference::point_polygon_form_factor;
    use penumbra_transport::shape::{FACE_COUNT, face_point};
    let albedo = 0.6;
    for shape in CUBE2D {
        let (tex, f) = f_of(shape, 8, 4096, albedo);
        let n = tex.len();
        let mut worst = 0.0f64;
        for i in 0..n {
            let (g, _, _) = tex.coords(i);
            let x = tex.position(i);
            let nn = tex.normal(i);
            let ff: f64 = (0..FACE_COUNT)
                .filter(|&h| h != g && shape.missing & (1 << h) == 0)
                .map(|h| {
                    let poly: Vec<[f64; 3]> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                        .iter()
                        .map(|&(u, v)| face_point(h, u, v))
                        .collect();
                    point_polygon_form_factor(x, nn, &poly)
                })
                .sum();
            let row: f64 = (0..n).map(|j| f[(i, j)]).sum();
            worst = worst.max((row - albedo * ff).abs() / albedo);
        }
        // 4096 stratified cosine rays per texel: the landing fraction to well below 1 %
        // (measured worst: closed 2e-15, dead_end 0.0024, straight 0.0034, corner 0.0024,
        // tee 0.0030, cross 0.0025; a gather without the cosine is off by ~10 %)
        assert!(worst < 4e-3, "{}: worst |row/ρ − Σ FF| = {worst}", shape.name);
    }
}

#[test]
fn collocation_alone_overshoots_next_to_corners() {
    // Why the balance exists: the collocated gather's column sums in the closed cube average
    // exactly ρ but reach ~1.03ρ diagonally next to a corner (docs/mrt.md, "Energy"), so the
    // energy statement fails for single-texel inputs there without it.
    let (tex, f) = f_of(CLOSED, 8, 4096, 1.0);
    let n = tex.len();
    let cols: Vec<f64> = (0..n).map(|j| (0..n).map(|i| f[(i, j)]).sum()).collect();
    let max = cols.iter().copied().fold(0.0, f64::max);
    let mean = cols.iter().sum::<f64>() / n as f64;
    assert!((mean - 1.0).abs() < 1e-12);
    assert!(max > 1.02 && max < 1.04, "{max}");
    let (f0, _, _) = tex.coords(cols.iter().position(|&c| c == max).unwrap());
    let (_, i, j) = tex.coords(cols.iter().position(|&c| c == max).unwrap());
    assert!((i == 1 || i == 6) && (j == 1 || j == 6), "face {f0} texel ({i}, {j})");
}

#[test]
fn gather_agrees_with_the_path_traced_reference() {
    for (id, shape) in CUBE2D.iter().enumerate() {
        let (tex, f) = f_of(*shape, 8, 4096, 0.9);
        let lights = test_lights(shape, LightLayout::Lattice, 4, 0.05, 11, id as u64);
        let e = direct_matrix(&tex, &lights);
        let fe = mul(f.as_ref(), e.as_ref());
        let r = one_bounce(&tex, &lights, 0.9, 4096, 5, id as u64, &|_| {});
        let err = rel_error(fe.as_ref(), r.indirect.as_ref());
        // bilinear reconstruction of the direct light between texel centres is the only
        // systematic difference; at 8² texels per face it stays within a few percent
        assert!(err < 0.03, "{}: {err}", shape.name);
    }
}

#[test]
fn uniform_walls_give_exact_vector_irradiance_and_probes() {
    let tex = Texels::new(CLOSED, 4);
    let ones = Mat::from_fn(tex.len(), 1, |_, _| 1.0);
    let albedo = 0.5;
    let sh = texel_sh(&tex, &ones, albedo, &DirectionSet::uniform_hemisphere(1024), 0, 0, &|_| {});
    let c0 = 0.282_094_791_773_878_14;
    let c1 = 0.488_602_511_902_919_9;
    let pi = core::f64::consts::PI;
    for x in 0..tex.len() {
        let b = &sh[x * 9..x * 9 + 9];
        // constant radiance ρ/π over the hemisphere: b₀ = (ρ/π)·2π·c₀ exactly (every ray hits)
        assert!((b[0] - albedo / pi * 2.0 * pi * c0).abs() < 1e-12);
        // b₁₀ = (ρ/π)·c₁·∫_H z = (ρ/π)·c₁·π (the Hammersley z's average exactly 1/2)
        assert!((b[2] - albedo * c1).abs() < 1e-9, "{}", b[2]);
        let a = penumbra_math::ohlsh::quadratic_to_ohlsh();
        let a0: f64 = (0..9).map(|j| a[j] * b[j]).sum();
        let a10: f64 = (0..9).map(|j| a[18 + j] * b[j]).sum();
        let e = pi * c0 * a0 + 2.0 * pi / 3.0 * c1 * a10;
        assert!((e - albedo).abs() < 2e-3, "irradiance {e}");
    }
    let probes = [[0.5, 0.5, 0.5], [0.2, 0.7, 0.9]];
    let v =
        penumbra_transport::gather::probe_sh(&tex, &probes, &ones, albedo, &DirectionSet::uniform_sphere(2048), 0, 0);
    for p in 0..2 {
        assert!((v[p * 9] - albedo / pi * 4.0 * pi * c0).abs() < 1e-12);
        for j in 1..9 {
            assert!(v[p * 9 + j].abs() < 2e-3, "probe {p} coefficient {j}: {}", v[p * 9 + j]);
        }
    }
}

#[test]
fn table_3_2_and_enrichment_at_thesis_settings() {
    let mut p = DictParams::new(DictionaryKind::ClosedCube);
    p.test_lights = 4;
    p.reference_rays = 64;
    p.vector_rays = 64;
    p.probe_rays = 64;
    let b = bake(&p, &NoProgress).unwrap();
    let t = &b.metrics.table_3_2;
    assert_eq!(t.n, 1536);
    let thesis = [[164usize, 240, 313], [22, 41, 62], [1, 5, 8]];
    for (got, want) in [t.f, t.l_d, t.m].iter().zip(thesis) {
        for (g, w) in got.iter().zip(want) {
            // within ±30 %, and for M (single digits) within one
            let ok = (*g as f64 - w as f64).abs() <= (0.3 * w as f64).max(1.0);
            assert!(ok, "Table 3.2: got {got:?}, thesis {want:?}");
        }
    }
    // App. A's five red faces and a white one: with enrichment and the same-face exclusion
    // no non-red light reaches the white face (the reference has none: a plane cannot light
    // itself), and the white face's remaining error is the red channel's, i.e. the
    // dictionary's ordinary reconstruction error for those lights (docs/mrt.md).
    let e = &b.metrics.enrichment;
    assert!(e.non_red_on_white_before > 0.15, "{e:?}");
    assert!(e.non_red_on_white_after < 1e-12, "{e:?}");
    assert!((e.rel_error_after - e.red_on_white_after).abs() < 1e-12, "{e:?}");
    let general = b.metrics.reconstruction_rel_error["closed"];
    assert!(e.rel_error_after < 1.5 * general && e.rel_error_after < 0.08, "{e:?} vs {general}");
    // the thesis's plain runtime rule leaves a leak even with enrichment
    assert!(e.enriched_without_exclusion.non_red > 0.02, "{e:?}");
    // the case that can fail under the exclusion: floor and ceiling white, the walls red. The
    // green each white face sends to the other is real (F·green ≠ 0 there) and must be
    // predicted; measured (thesis settings): 0.731 without enrichment, 0.178 enriched, 0.070
    // enriched with the exclusion. Each step must help, and the result must be near the
    // dictionary's ordinary error, not zero by construction.
    let t = &e.two_white;
    assert!(t.green_rel_error_before > 0.5, "{t:?}");
    assert!(t.green_rel_error_enriched < 0.5 * t.green_rel_error_before, "{t:?}");
    assert!(t.green_rel_error_enriched_excluded < 0.6 * t.green_rel_error_enriched, "{t:?}");
    assert!(t.green_rel_error_enriched_excluded > 1e-3 && t.green_rel_error_enriched_excluded < 0.1, "{t:?}");
    assert_eq!(b.metrics.enrichment_rel_error_enriched_only, e.enriched_without_exclusion.rgb);
    // the exclusion alone (unenriched operators): on App. A's case it removes the non-red
    // light on the white face by construction (zero against a zero reference), so only the
    // two-white case shows what it does without enrichment's face-local prior vectors
    assert_eq!(b.metrics.enrichment_rel_error_excluded_only, e.excluded_without_enrichment.rgb);
    assert!(e.excluded_without_enrichment.non_red < 1e-12, "{e:?}");
    // measured (4 test lights): two white, green 0.683 neither, 0.193 enrichment only, 0.176
    // exclusion only, 0.069 both: each alone helps, both together beat either
    assert!(t.green_rel_error_excluded < 0.5 * t.green_rel_error_before, "{t:?}");
    assert!(t.green_rel_error_enriched_excluded < 0.6 * t.green_rel_error_excluded, "{t:?}");
    assert!(t.rgb_rel_error_excluded < t.rgb_rel_error[0] && t.rgb_rel_error[2] < t.rgb_rel_error_excluded, "{t:?}");
}

#[test]
fn exact_gather_rows_sum_to_point_to_face_form_factors() {
    // The exact point-to-texel form factors sum, per receiver, to the point-to-face form
    // factors: a closed cube's rows sum to 1.
    let tex = Texels::new(CLOSED, 4);
    let f = transport_matrix(&tex, &DirectionSet::cosine(16), 1.0, Gather::Exact, 0, 0, &|_| {});
    for i in 0..tex.len() {
        let s: f64 = (0..tex.len()).map(|j| f[(i, j)]).sum();
        assert!((s - 1.0).abs() < 1e-12, "{s}");
    }
}

#[test]
fn prior_layout_reproduces_the_thesis_light_statistics() {
    // L_d alone (no rays): 22/41/62 in the thesis at 6×16² samples
    let tex = Texels::new(CLOSED, 16);
    let l_d = direct_matrix(&tex, &sphere_lights(&CLOSED));
    let (_, s) = prior_from_samples(l_d.as_ref(), 64).unwrap();
    let counts: Vec<usize> = [0.8, 0.9, 0.95].iter().map(|&p| penumbra_transport::svd::energy_count(&s, p)).collect();
    assert_eq!(counts, vec![22, 41, 64]);
}

/// The raw gather against the exact face-to-face form factors of the unit cube (Howell C-11
/// and C-14: opposite 0.19982, adjacent 0.20004), the `raw_gather` figures `mrt dict --json`
/// reports per shape: `(1/n_g) Σ_{i∈g} Σ_{j∈h} F_ij / ρ` before the balance, texel centres as
/// a midpoint rule over the receiving face.
#[test]
fn raw_gather_face_to_face_form_factors_match_the_unit_cube() {
    let albedo = 0.6;
    for gather in [Gather::Bilinear, Gather::Exact] {
        for shape in CUBE2D {
            let tex = Texels::new(shape, 8);
            let f = transport_matrix(&tex, &DirectionSet::cosine(4096), albedo, gather, 0, 0, &|_| {});
            let r = raw_gather_check(&tex, f.as_ref(), albedo);
            assert!(
                (r.face_ff_opposite_exact - 0.19982).abs() < 5e-6 && (r.face_ff_adjacent_exact - 0.20004).abs() < 5e-6
            );
            // every cube2d shape has floor and ceiling (opposite); the cross has no wall
            assert!(r.face_ff_opposite.is_some(), "{r:?}");
            assert_eq!(r.face_ff_adjacent.is_none(), shape.name == "cross", "{r:?}");
            if gather == Gather::Exact {
                // exact point-to-texel form factors sum to the point-to-face ones
                assert!(r.point_face_max_abs_error < 1e-12 && r.row_max_abs_error < 1e-12, "{r:?}");
            }
            assert!(r.face_ff_max_abs_error < TOL_FACE, "{} {gather:?}: {r:?}", shape.name);
            assert!(r.row_max_abs_error < TOL_ROW, "{} {gather:?}: {r:?}", shape.name);
        }
    }
    // a gather that forgot the cosine (uniform hemisphere directions, weight ρ/N) still has
    // exact row sums in the closed cube (every ray lands) but the wrong face-to-face split
    let tex = Texels::new(CLOSED, 8);
    let f = transport_matrix(&tex, &DirectionSet::uniform_hemisphere(4096), albedo, Gather::Bilinear, 0, 0, &|_| {});
    let r = raw_gather_check(&tex, f.as_ref(), albedo);
    assert!(r.row_max_abs_error < 1e-12, "{r:?}");
    assert!(r.face_ff_max_abs_error > 10.0 * TOL_FACE, "{r:?}");
}

/// Face to face at 8² texels: the 8 × 8 midpoint rule over the receiving face errs by
/// 4.7·10⁻⁴ with exact point values (`Gather::Exact`); the bilinear gather's 4096 rays add to
/// 7.5·10⁻⁴ (measured, every shape).
const TOL_FACE: f64 = 1.5e-3;
/// Per texel, bilinear gather, 4096 rays: measured ≤ 3.4·10⁻³ (straight), as in
/// `raw_gather_rows_are_albedo_times_point_to_wall_form_factors`.
const TOL_ROW: f64 = 4e-3;
