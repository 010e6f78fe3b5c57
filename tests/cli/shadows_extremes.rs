#![allow(clippy::print_stderr)] // measured errors are printed for the record
//! The soft-shadow runtime at the extremes (issue #14 §1): hundreds of dense blockers, far
//! receivers, near-contact proxies, order-8 ratio vectors, NaN radii, receivers far from the
//! origin. Every expected value comes from an independent f64 computation.

use penumbra_asset::OwnedAsset;
use penumbra_math::sh::{ShEval, zh_rotate};
use penumbra_runtime::shadows::{RuntimeExp, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{ShTables, SphereTree};
use penumbra_sh::gamma::TripleProduct;
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use penumbra_sh::tables_asset::to_asset;
use penumbra_sh::zonal::{cap_visibility, clamped_cosine};
use std::f64::consts::PI;

#[allow(dead_code)]
fn tables_bytes(order: usize) -> Vec<u8> {
    let b = bake(&TablesParams::new(order), &NoProgress).unwrap();
    to_asset(&b, None).unwrap().to_bytes().unwrap()
}

fn white(order: usize) -> Vec<[f32; 3]> {
    let mut l = vec![[0.0f32; 3]; order * order];
    l[0] = [(4.0 * PI).sqrt() as f32; 3];
    l
}

/// Deterministic pseudo-random in [0, 1) (SplitMix64 of the index).
fn unit(i: u64) -> f64 {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// f64 product-space shading (SHEXP eq. 6) of a receiver at `p` with normal +z under unit
/// white light, no window: `H(+z) · (g₁ * g₂ * …)`.
fn product_space_f64(order: usize, p: [f64; 3], spheres: &[Sphere]) -> f64 {
    let gamma = TripleProduct::new(order);
    let e = ShEval::new(order);
    let mut prod = vec![0.0; order * order];
    prod[0] = (4.0 * PI).sqrt();
    for s in spheres {
        let d = [s.center[0] as f64 - p[0], s.center[1] as f64 - p[1], s.center[2] as f64 - p[2]];
        let dl = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let mut g = vec![0.0; order * order];
        zh_rotate(&e, &cap_visibility(order, (s.radius as f64 / dl).min(1.0).asin()), d.map(|x| x / dl), &mut g);
        prod = gamma.product_vec(&prod, &g);
    }
    let mut h = vec![0.0; order * order];
    zh_rotate(&e, &clamped_cosine(order), [0.0, 0.0, 1.0], &mut h);
    h.iter().zip(&prod).map(|(a, b)| a * b).sum()
}

/// 500 overlapping, near-contact blockers in a cone around (1, 0, 1)/√2 (SHEXP's scenes use
/// 244–500 spheres).
fn dense_blockers() -> Vec<Sphere> {
    (0..500u64)
        .map(|k| {
            let t = 0.42 + 0.3 * unit(4 * k);
            let (a, b) = (0.5 * (unit(4 * k + 1) - 0.5), 0.5 * (unit(4 * k + 2) - 0.5));
            let h = std::f64::consts::FRAC_1_SQRT_2;
            let d = [t * (h + a), t * b, t * (h - a)];
            Sphere { center: d.map(|x| x as f32), radius: (0.32 + 0.08 * unit(4 * k + 3)) as f32 }
        })
        .filter(|s| {
            let c = s.center;
            (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() > s.radius * 1.05
        })
        .take(500)
        .collect()
}

#[test]
fn five_hundred_dense_blockers_stay_finite_and_match_f64() {
    let order = 4;
    let baked = bake(&TablesParams::new(order), &NoProgress).unwrap();
    let bytes = to_asset(&baked, None).unwrap().to_bytes().unwrap();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let spheres = dense_blockers();
    assert!(spheres.len() >= 400, "{}", spheres.len());
    // Product space itself diverges here at order 4 (500 truncated products of ringing cap
    // visibilities), and so does the exact exponential exp(M_f)·1 of a log this large: both
    // are printed, not used. The reference is the same exponential in f64 (penumbra-sh) of
    // the same accumulated log, shaded in f64: the f32 runtime must not lose it.
    let product = product_space_f64(order, [0.0; 3], &spheres);
    let gamma = TripleProduct::new(order);
    let e4 = ShEval::new(order);
    let mut h = vec![0.0; order * order];
    zh_rotate(&e4, &clamped_cosine(order), [0.0, 0.0, 1.0], &mut h);
    for exp in [RuntimeExp::Hyb, RuntimeExp::PsStar(2)] {
        let opts = ShadowOptions { exp, window: false, self_shadow_rules: false };
        let ev = ShadowEvaluator::new(&t, &white(order), opts);
        let mut f = vec![0.0f32; 16];
        ev.accumulate_log([0.0; 3], [0.0, 0.0, 1.0], &spheres, &mut f);
        let e = ev.irradiance([0.0; 3], [0.0, 0.0, 1.0], &spheres)[0] as f64;
        let f64v: Vec<f64> = f.iter().map(|&x| x as f64).collect();
        let exact = penumbra_sh::exp::exp_exact(&gamma, &f64v);
        let exact: f64 = h.iter().zip(&exact).map(|(a, b)| a * b).sum();
        let g = match exp {
            RuntimeExp::Hyb => penumbra_sh::exp::exp_hyb(&gamma, &f64v, &baked.ol),
            RuntimeExp::PsStar(p) => penumbra_sh::exp::exp_ps_star(&gamma, &f64v, p),
            RuntimeExp::Ol => unreachable!(),
        };
        let truth: f64 = h.iter().zip(&g).map(|(a, b)| a * b).sum();
        let mut batch = [[0.0f32; 3]; 1];
        ev.irradiance_batch(&[[0.0; 3]], &[[0.0, 0.0, 1.0]], &spheres, &mut batch);
        eprintln!(
            "{exp:?}: f0 {} |f^| {}  E {e}  same exp in f64 {truth}  exact exp f64 {exact}  product space f64 {product} (π = unshadowed)",
            f[0],
            { f[1..].iter().map(|x| x * x).sum::<f32>().sqrt() }
        );
        assert!(e.is_finite() && (batch[0][0] as f64).is_finite(), "{exp:?}: {e}");
        // f₀/√4π < −87 here (exp underflows f32): before DC folding this was inf·0 = NaN
        assert!(f[0] / (4.0 * std::f32::consts::PI).sqrt() < -87.0, "not dense enough: f0 = {}", f[0]);
        assert!((e - truth).abs() <= 0.01 * truth.abs(), "{exp:?}: runtime {e} vs the same exponential in f64 {truth}");
        assert_eq!(batch[0][0] as f64, e, "batched path");
    }
}

fn tables(order: usize) -> (penumbra_sh::tables::TablesBake, Vec<u8>) {
    let baked = bake(&TablesParams::new(order), &NoProgress).unwrap();
    let bytes = to_asset(&baked, None).unwrap().to_bytes().unwrap();
    (baked, bytes)
}

#[test]
fn many_small_far_blockers_keep_their_shadow() {
    // 64 spheres of radius 0.05 in a ball of radius 0.5 (diagonal ≈ 1), 20 diagonals above the
    // receiver: each leaf subtends α = 0.0025, far below 1/η ≈ 0.036, while the object
    // darkens the receiver measurably. Dropping every leaf below the clamp lost it all.
    let order = 4;
    let (_, bytes) = tables(order);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let ev = ShadowEvaluator::new(&t, &white(order), ShadowOptions { window: false, ..Default::default() });
    for dist in [2.0f64, 5.0, 20.0] {
        let spheres: Vec<Sphere> = (0..64u64)
            .map(|k| {
                let c = [unit(3 * k) - 0.5, unit(3 * k + 1) - 0.5, unit(3 * k + 2) - 0.5].map(|x| 0.8 * x);
                Sphere { center: [c[0] as f32, c[1] as f32, (c[2] + dist) as f32], radius: 0.05 }
            })
            .collect();
        let e = ev.irradiance([0.0; 3], [0.0, 0.0, 1.0], &spheres)[0] as f64;
        let truth = product_space_f64(order, [0.0; 3], &spheres);
        let (shadow, want) = (PI - e, PI - truth);
        eprintln!("{dist} diagonals: runtime shadow {shadow:.3e}, f64 product-space shadow {want:.3e}");
        assert!(want > 0.0 && (shadow - want).abs() < 0.05 * want, "{dist}: {shadow} vs {want}");
    }
}

/// Worst relative error of the runtime's proxy log against the f64 eigen log of the cap, per
/// region (below the clamp's ramp top, the α table, near contact), with the α of each.
fn proxy_log_worst(order: usize, t: &ShTables, samples: &[f64]) -> ([f64; 3], [f64; 3]) {
    let gamma = TripleProduct::new(order);
    let mut worst = [0.0f64; 3];
    let mut at = [0.0f64; 3];
    let mut row = vec![0.0f32; order];
    for &alpha in samples {
        let th = alpha.asin();
        let want: Vec<f64> = penumbra_sh::log::log_eigen_zonal_occlusion(
            &gamma,
            &penumbra_sh::zonal::cap_indicator(order, th),
            penumbra_sh::log::EPS_REL,
        )
        .iter()
        .enumerate()
        .map(|(l, v)| v * penumbra_math::sh::zh_star_scale(l))
        .collect();
        t.proxy_log(alpha as f32, &mut row);
        let d = row.iter().zip(&want).map(|(a, b)| (*a as f64 - b).powi(2)).sum::<f64>().sqrt();
        let rel = d / want.iter().map(|x| x * x).sum::<f64>().sqrt();
        let region = if (alpha as f32) < t.alpha_top() {
            0
        } else if (alpha as f32) < penumbra_runtime::NEAR_CONTACT_ALPHA {
            1
        } else {
            2
        };
        if rel > worst[region] {
            worst[region] = rel;
            at[region] = alpha;
        }
    }
    (worst, at)
}

#[test]
fn proxy_log_is_accurate_from_far_field_to_contact() {
    // ≤ 0.5 % of the row's norm against the f64 eigen log of the cap, over the whole α range
    // and every order: below the smooth clamp (small-cap continuation), in the table (with
    // its cells split at the kinks the bake stores in `proxy_log_knots`), and near α = 1
    // (θ-grid). The same bake without its knots (the runtime as it read SHTB v1) misses it
    // at order 8, where the kink of the log's eigenvalue clipping sits inside a cell.
    let mut table = Vec::new();
    for order in 2..=8usize {
        let (mut baked, bytes) = tables(order);
        let owned = OwnedAsset::parse(&bytes).unwrap();
        let t = ShTables::from_asset(&owned.asset()).unwrap();
        assert_eq!(t.proxy_log_knot_count(), baked.proxy_log_knots.len());
        // 2000 even samples, 600 across the order-8 bend (α 0.40–0.43), and 200 within two
        // cells of every stored knot
        let mut samples: Vec<f64> = (1..=2000)
            .map(|k| (k as f64 / 2000.0).min(0.99999))
            .chain((0..600).map(|k| 0.40 + 0.03 * k as f64 / 600.0))
            .collect();
        for kn in &baked.proxy_log_knots {
            samples.extend((0..200).map(|k| kn.alpha + (k as f64 / 100.0 - 1.0) * 2.0 / 255.0));
        }
        samples.retain(|a| *a > 0.0 && *a < 1.0);
        let (worst, at) = proxy_log_worst(order, &t, &samples);
        let knots: Vec<String> = baked.proxy_log_knots.iter().map(|k| format!("{:.5}", k.alpha)).collect();
        eprintln!(
            "order {order}: worst rel error below clamp / table / near contact: {:?} at α = {at:.4?}; knots at α = [{}]",
            worst.map(|x| format!("{x:.2e}")),
            knots.join(", ")
        );
        table.push((order, worst, at));
        assert!(worst.iter().all(|&w| w <= 0.005), "order {order}: {worst:?} at α = {at:?}");
        if order == 8 {
            baked.proxy_log_knots.clear();
            let bytes = to_asset(&baked, None).unwrap().to_bytes().unwrap();
            let owned = OwnedAsset::parse(&bytes).unwrap();
            let t = ShTables::from_asset(&owned.asset()).unwrap();
            assert_eq!(t.proxy_log_knot_count(), 0);
            let (without, at) = proxy_log_worst(order, &t, &samples);
            eprintln!("order 8 without knots: {:?} at α = {at:.4?}", without.map(|x| format!("{x:.2e}")));
            assert!(without[1] > 0.005, "the kink is not where the test looks: {without:?}");
        }
    }
    let (order, worst, at) =
        table.iter().map(|(o, w, a)| (*o, w[1], a[1])).fold((0, 0.0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
    eprintln!("worst in the table over orders 2–8: {worst:.2e} (order {order}, α = {at:.4})");
}

#[test]
fn invalid_blockers_are_ignored_on_every_path() {
    let order = 4;
    let (_, bytes) = tables(order);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let good = Sphere { center: [0.3, 0.0, 1.5], radius: 0.5 };
    let bad = [
        Sphere { center: [0.0, 0.0, 1.0], radius: f32::NAN },
        Sphere { center: [f32::NAN, 0.0, 1.0], radius: 0.5 },
        Sphere { center: [0.0, 0.0, 1.0], radius: f32::INFINITY },
        Sphere { center: [0.0, 0.0, 1.0], radius: -1.0 },
    ];
    let p = [[0.0f32, 0.0, 0.0], [0.5, 0.0, 0.0]];
    let n = [[0.0f32, 0.0, 1.0]; 2];
    for rules in [true, false] {
        let ev =
            ShadowEvaluator::new(&t, &white(order), ShadowOptions { self_shadow_rules: rules, ..Default::default() });
        for b in bad {
            let with = [good, b];
            for k in 0..2 {
                let want = ev.irradiance(p[k], n[k], &[good]);
                assert!(want[0].is_finite());
                assert_eq!(ev.irradiance(p[k], n[k], &with), want, "rules {rules} {b:?}");
                assert_eq!(ev.irradiance_product(p[k], n[k], &with), ev.irradiance_product(p[k], n[k], &[good]));
            }
            let mut out = [[0.0f32; 3]; 2];
            ev.irradiance_batch(&p, &n, &with, &mut out);
            assert_eq!(out[0], ev.irradiance(p[0], n[0], &[good]), "batched, rules {rules} {b:?}");
        }
    }
}

#[test]
fn receivers_far_from_the_origin_keep_f32_precision() {
    // The runtime works on differences c − p: a scene translated to 10⁴ units from the origin
    // loses only the f32 rounding of its coordinates (ulp(10⁴) ≈ 1e-3 of a unit-size scene).
    let order = 4;
    let (_, bytes) = tables(order);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let ev = ShadowEvaluator::new(&t, &white(order), ShadowOptions::default());
    let spheres: Vec<Sphere> = (0..16u64)
        .map(|k| Sphere {
            center: [unit(3 * k) as f32 - 0.5, unit(3 * k + 1) as f32 - 0.5, 1.0 + unit(3 * k + 2) as f32],
            radius: 0.2,
        })
        .collect();
    for off in [1.0e3f32, 1.0e4] {
        let moved: Vec<Sphere> = spheres
            .iter()
            .map(|s| Sphere { center: [s.center[0] + off, s.center[1] - off, s.center[2] + off], radius: s.radius })
            .collect();
        for k in 0..10 {
            let p = [0.1 * k as f32 - 0.5, 0.0, 0.0];
            let a = ev.irradiance(p, [0.0, 0.0, 1.0], &spheres)[0];
            let b = ev.irradiance([p[0] + off, p[1] - off, p[2] + off], [0.0, 0.0, 1.0], &moved)[0];
            assert!((a - b).abs() < 0.01 * PI as f32, "offset {off}: {a} vs {b}");
        }
    }
}

#[test]
fn order_8_ratio_vectors_stay_bounded_at_theta_max_90() {
    use penumbra_asset::{AssetBuilder, Kind};
    use penumbra_runtime::SphereSet;
    use penumbra_runtime::shadows::{CutBlocker, RATIO_BOUND};
    // 8 leaves on a ring under one root that subtends ~50° from the receivers: with θ_max = 90°
    // the root enters the cut, and at order 8 bands of its ZH log cross zero (θ > ~29°).
    let order = 8;
    let (_, bytes) = tables(order);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let ev = ShadowEvaluator::new(&t, &white(order), ShadowOptions { window: false, ..Default::default() });
    let leaves: Vec<f32> = (0..8)
        .flat_map(|k| {
            let a = k as f32 * core::f32::consts::TAU / 8.0;
            [1.2 * a.cos(), 1.2 * a.sin(), 2.0, 0.3]
        })
        .collect();
    let mut b = AssetBuilder::new(Kind::SPHR);
    b.add_json("meta", "{}").unwrap();
    b.add_f32("spheres", &[8, 4], &leaves).unwrap();
    b.add_u32("hierarchy_levels", &[1, 2], &[0, 1]).unwrap();
    b.add_f32("hierarchy_nodes", &[1, 4], &[0.0, 0.0, 2.0, 1.5]).unwrap();
    b.add_u32("hierarchy_children", &[1, 2], &[0, 8]).unwrap();
    let sb = b.to_bytes().unwrap();
    let so = OwnedAsset::parse(&sb).unwrap();
    let set = SphereSet::from_asset(&so.asset()).unwrap();
    let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::<CutBlocker>::new());
    set.cut([0.0, 0.0, 0.0], 0.3, 1.0, &mut stack, &mut cut);
    assert_eq!(cut.len(), 1, "the root enters the cut");
    ev.cluster_blockers(&set, &cut, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], &mut blockers);
    let w = blockers[0].w;
    eprintln!("ratio vector {w:?}");
    let w0 = w[0];
    for l in 0..order {
        assert!(w[l].is_finite() && w[l] >= 0.0 && w[l] <= RATIO_BOUND * w0.max(1.0), "band {l}: {w:?}");
    }
    let mut leaf = Vec::new();
    set.leaves_into(&mut leaf);
    let mut worst = 0.0f32;
    for k in 0..7 {
        let p = [0.05 * k as f32 - 0.15, 0.02 * k as f32, 0.0];
        let a = ev.irradiance_blockers(p, [0.0, 0.0, 1.0], &blockers)[0];
        let b = ev.irradiance(p, [0.0, 0.0, 1.0], &leaf)[0];
        assert!(a.is_finite());
        worst = worst.max((a - b).abs() / PI as f32);
    }
    eprintln!("cut vs leaves, worst |ΔE|/π = {worst}");
    assert!(worst < 0.1, "{worst}");
}
