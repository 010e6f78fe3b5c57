//! The C ABI of posing, local lights and the indirect operators (issue #14 §2): called through
//! `penumbra-capi`, each returns what the Rust runtime returns (bit for bit) and, where there
//! is one, the analytic answer; error paths return their codes.
#![allow(unsafe_code)] // calling the C ABI from Rust is what this test is for

use penumbra_asset::{AssetBuilder, Kind, OwnedAsset};
use penumbra_capi::*;
use penumbra_runtime::shadows::{IndirectOperator, LocalLight, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{PosedSpheres, ShTables, SphereSet, SphereTree};
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use std::ptr;

const LIGHT: [[f32; 3]; 9] = [
    [3.0, 3.2, 3.5],
    [0.1, 0.0, 0.0],
    [1.0, 1.1, 1.3],
    [0.3, 0.2, 0.1],
    [0.05, 0.02, 0.0],
    [0.0, 0.01, 0.03],
    [-0.2, -0.1, 0.0],
    [0.0, 0.0, 0.04],
    [0.02, 0.02, 0.02],
];

/// Three skinned leaves under one root, with per-sphere albedo (SPHR kind_version 2).
fn skinned_set() -> OwnedAsset {
    let mut a = AssetBuilder::new(Kind::SPHR);
    a.add_json("meta", r#"{"kind":"SPHR","kind_version":2}"#).unwrap();
    let leaves = [0.0f32, 1.0, 0.0, 0.3, 0.5, 1.5, 0.2, 0.25, -0.4, 1.2, 0.1, 0.2];
    a.add_f32("spheres", &[3, 4], &leaves).unwrap();
    a.add_u32("hierarchy_levels", &[1, 2], &[0, 1]).unwrap();
    a.add_f32("hierarchy_nodes", &[1, 4], &[0.0, 1.2, 0.0, 1.0]).unwrap();
    a.add_u32("hierarchy_children", &[1, 2], &[0, 3]).unwrap();
    let u = u32::MAX;
    a.add_u32("skin_nodes", &[3, 4], &[0, u, u, u, 0, 1, u, u, 1, u, u, u]).unwrap();
    a.add_f32("skin_weights", &[3, 4], &[1.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]).unwrap();
    a.add_f32("albedo", &[3, 3], &[0.9, 0.1, 0.1, 0.2, 0.8, 0.3, 0.5, 0.5, 0.5]).unwrap();
    OwnedAsset::parse(&a.to_bytes().unwrap()).unwrap()
}

/// Column-major 4×4: translation `t`, or a rotation by 90° about z.
fn translate(t: [f32; 3]) -> [f32; 16] {
    [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, t[0], t[1], t[2], 1.0]
}
fn rot_z90() -> [f32; 16] {
    [0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
}

#[test]
fn posing_local_lights_and_indirect_through_the_abi() {
    let tbytes = penumbra_sh::tables_asset::to_asset(&bake(&TablesParams::new(3), &NoProgress).unwrap(), None)
        .unwrap()
        .to_bytes()
        .unwrap();
    let towned = OwnedAsset::parse(&tbytes).unwrap();
    let sowned = skinned_set();
    let (tb, sb) = (towned.bytes(), sowned.bytes());
    let mut err = [0u8; 256];
    let e = err.as_mut_ptr().cast();
    let (mut t, mut s, mut ev, mut ps, mut cl) =
        (ptr::null_mut(), ptr::null_mut(), ptr::null_mut(), ptr::null_mut(), ptr::null_mut());
    let light: Vec<f32> = LIGHT.iter().flatten().copied().collect();
    // SAFETY (whole test): every pointer passed points to live storage of the stated length.
    unsafe {
        assert_eq!(pn_tables_open(tb.as_ptr(), tb.len(), &mut t, e, err.len()), PN_OK);
        assert_eq!(pn_spheres_open(sb.as_ptr(), sb.len(), &mut s, e, err.len()), PN_OK);
        assert_eq!(pn_shadow_new(t, light.as_ptr(), light.len(), ptr::null(), &mut ev, e, err.len()), PN_OK);
        assert_eq!(pn_posed_spheres_new(s, &mut ps), PN_OK);
        assert_eq!(pn_cluster_new(&mut cl), PN_OK);
    }
    let ta = towned.asset();
    let tables = ShTables::from_asset(&ta).unwrap();
    let sa = sowned.asset();
    let set = SphereSet::from_asset(&sa).unwrap();
    let rust = ShadowEvaluator::new(&tables, &LIGHT, ShadowOptions::default());

    // --- posing: node 0 translated by (1, 0, 0), node 1 turned 90° about z
    let mats: Vec<[f32; 16]> = vec![translate([1.0, 0.0, 0.0]), rot_z90()];
    let flat: Vec<f32> = mats.iter().flatten().copied().collect();
    assert_eq!(unsafe { pn_posed_spheres_pose(ps, flat.as_ptr(), 2) }, PN_OK);
    let mut got = [pn_sphere { center: [0.0; 3], radius: 0.0 }; 3];
    assert_eq!(unsafe { pn_posed_spheres_leaves(ps, got.as_mut_ptr(), 3) }, PN_OK);
    // analytic: leaf 0 (0,1,0) → (1,1,0); leaf 1 (0.5,1.5,0.2): ½(1.5,1.5,0.2) + ½(−1.5,0.5,0.2)
    // = (0, 1, 0.2); leaf 2 (−0.4,1.2,0.1) → (−1.2,−0.4,0.1); radii kept
    let want = [[1.0, 1.0, 0.0], [0.0, 1.0, 0.2], [-1.2, -0.4, 0.1]];
    for (i, g) in got.iter().enumerate() {
        for k in 0..3 {
            assert!((g.center[k] - want[i][k]).abs() < 1e-6, "leaf {i}: {:?} vs {:?}", g.center, want[i]);
        }
        assert_eq!(g.radius, set.leaf(i).radius);
    }
    let mut rp = PosedSpheres::rest(set);
    rp.pose(&mats).unwrap();
    for (g, r) in got.iter().zip(rp.leaves()) {
        assert_eq!(g.center, r.center);
    }
    // the cut on the posed tree: the refitted root bounds every posed leaf, and the cluster's
    // irradiance equals the Rust runtime's on the same posed tree
    let root = rp.sphere(penumbra_runtime::NodeRef::Node(0));
    for l in rp.leaves() {
        let d = (0..3).map(|k| (l.center[k] - root.center[k]).powi(2)).sum::<f32>().sqrt();
        assert!(d + l.radius <= root.radius * (1.0 + 1e-6), "root does not bound {l:?}");
    }
    let (p_r, p_star, n_star) = ([0.0f32, -3.0, 0.0], [0.0f32, -3.0, 0.0], [0.0f32, 1.0, 0.0]);
    let sin_max = 25f32.to_radians().sin();
    let mut out = [0.0f32; 3];
    unsafe {
        assert_eq!(
            pn_cluster_cut_posed(cl, ev, ps, p_r.as_ptr(), 0.5, sin_max, p_star.as_ptr(), n_star.as_ptr()),
            PN_OK
        );
        assert_eq!(pn_cluster_irradiance(cl, ev, p_star.as_ptr(), n_star.as_ptr(), out.as_mut_ptr()), PN_OK);
    }
    let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::new());
    rp.cut(p_r, 0.5, sin_max, &mut stack, &mut cut);
    rust.cluster_blockers(&rp, &cut, p_star, n_star, &mut blockers);
    assert_eq!(out, rust.irradiance_blockers(p_star, n_star, &blockers));
    assert!(out[0] < rust.unshadowed(n_star)[0], "the posed set shadows the receiver");
    // errors: too few matrices, a NaN matrix (the pose stays), a wrong leaf count, no skin
    assert_eq!(unsafe { pn_posed_spheres_pose(ps, flat.as_ptr(), 1) }, PN_ERR_RANGE);
    let mut nan = flat.clone();
    nan[5] = f32::NAN;
    assert_eq!(unsafe { pn_posed_spheres_pose(ps, nan.as_ptr(), 2) }, PN_ERR_RANGE);
    let mut again = got;
    assert_eq!(unsafe { pn_posed_spheres_leaves(ps, again.as_mut_ptr(), 3) }, PN_OK);
    assert_eq!(again.map(|x| x.center), got.map(|x| x.center));
    assert_eq!(unsafe { pn_posed_spheres_leaves(ps, again.as_mut_ptr(), 2) }, PN_ERR_SIZE);
    assert_eq!(unsafe { pn_posed_spheres_set_leaves(ps, again.as_ptr(), 2) }, PN_ERR_SIZE);
    assert_eq!(unsafe { pn_posed_spheres_pose(ps, ptr::null(), 2) }, PN_ERR_NULL);
    let plain = penumbra_asset::AssetFile::open(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets/v1/character-count6-hierarchy.sphr"),
    )
    .unwrap();
    let (mut s1, mut ps1) = (ptr::null_mut(), ptr::null_mut());
    unsafe {
        assert_eq!(pn_spheres_open(plain.bytes().as_ptr(), plain.bytes().len(), &mut s1, e, err.len()), PN_OK);
        assert_eq!(pn_posed_spheres_new(s1, &mut ps1), PN_OK);
        assert_eq!(pn_posed_spheres_pose(ps1, flat.as_ptr(), 2), PN_ERR_ABSENT);
        let mut a = [0.0f32; 3];
        assert_eq!(pn_spheres_albedo(s1, 0, a.as_mut_ptr()), PN_ERR_ABSENT, "a v1 set has no albedo");
    }

    // --- local light on the normal, nothing in the way: the order-3 SH value of
    // E = L_e ∫_cap cos, Σ_l (max(z,0))_l (cap)_l = (π/2)(1−c) + (π/2)(1−c²) + (5π/16)(c − c³)
    // with c = cos θ (the table keeps band 0 of H*L; the full integral is π L_e sin²θ)
    let (p, n) = ([0.0f32, 0.0, 0.0], [0.0f32, 1.0, 0.0]);
    let ll = pn_local_light { sphere: pn_sphere { center: [0.0, 4.0, 0.0], radius: 1.0 }, radiance: [1.0, 2.0, 0.5] };
    let rl = LocalLight { sphere: Sphere { center: [0.0, 4.0, 0.0], radius: 1.0 }, radiance: [1.0, 2.0, 0.5] };
    let mut out = [0.0f32; 3];
    assert_eq!(
        unsafe { pn_shadow_irradiance_local_light(ev, p.as_ptr(), n.as_ptr(), ptr::null(), 0, &ll, out.as_mut_ptr()) },
        PN_OK
    );
    let pi = std::f64::consts::PI;
    let cz = (1.0f64 - 1.0 / 16.0).sqrt();
    let sh3 = pi / 2.0 * (1.0 - cz) + pi / 2.0 * (1.0 - cz * cz) + 5.0 * pi / 16.0 * (cz - cz.powi(3));
    for c in 0..3 {
        let want = f64::from(rl.radiance[c]) * sh3;
        assert!((f64::from(out[c]) - want).abs() < 0.005 * want, "c={c}: {} vs {want}", out[c]);
    }
    assert_eq!(out, rust.irradiance_local_light(p, n, &[], &rl).unwrap());
    // blocked by the posed spheres: the ABI equals the runtime, and the light is dimmer
    let blockers: Vec<pn_sphere> = vec![pn_sphere { center: [0.2, 2.0, 0.0], radius: 0.5 }];
    let rb = [Sphere { center: [0.2, 2.0, 0.0], radius: 0.5 }];
    let mut shadowed = [0.0f32; 3];
    assert_eq!(
        unsafe {
            pn_shadow_irradiance_local_light(
                ev,
                p.as_ptr(),
                n.as_ptr(),
                blockers.as_ptr(),
                1,
                &ll,
                shadowed.as_mut_ptr(),
            )
        },
        PN_OK
    );
    assert_eq!(shadowed, rust.irradiance_local_light(p, n, &rb, &rl).unwrap());
    assert!(shadowed[0] < 0.95 * out[0], "{shadowed:?} vs {out:?}");
    let mut g = [0.0f32; 9];
    rust.visibility(p, n, &rb, &mut g);
    let mut via_g = [0.0f32; 3];
    assert_eq!(
        unsafe { pn_shadow_shade_local_light(ev, p.as_ptr(), n.as_ptr(), &ll, g.as_ptr(), 9, via_g.as_mut_ptr()) },
        PN_OK
    );
    assert_eq!(via_g, shadowed);
    assert_eq!(
        unsafe { pn_shadow_shade_local_light(ev, p.as_ptr(), n.as_ptr(), &ll, g.as_ptr(), 4, via_g.as_mut_ptr()) },
        PN_ERR_SIZE
    );
    let bad = pn_local_light { sphere: pn_sphere { center: [0.0, 4.0, 0.0], radius: f32::NAN }, radiance: [1.0; 3] };
    assert_eq!(
        unsafe { pn_shadow_irradiance_local_light(ev, p.as_ptr(), n.as_ptr(), ptr::null(), 0, &bad, out.as_mut_ptr()) },
        PN_ERR_ABSENT
    );

    // --- indirect by every operator, uniform and per-sphere albedo (the SPHR's rows)
    let mut albedo = [[0.0f32; 3]; 3];
    for (i, a) in albedo.iter_mut().enumerate() {
        assert_eq!(unsafe { pn_spheres_albedo(s, i, a.as_mut_ptr()) }, PN_OK);
        assert_eq!(Some(*a), set.albedo(i));
    }
    assert_eq!(albedo[0], [0.9, 0.1, 0.1]);
    let recv = ([0.3f32, -0.5, 0.2], [0.0f32, 1.0, 0.0]);
    let leaves = rp.leaves().to_vec();
    let c_leaves: Vec<pn_sphere> = leaves.iter().map(|l| pn_sphere { center: l.center, radius: l.radius }).collect();
    let flat_al: Vec<f32> = albedo.iter().flatten().copied().collect();
    for (code, op) in [
        (PN_INDIRECT_POINT, IndirectOperator::PointSampled),
        (PN_INDIRECT_AVERAGED, IndirectOperator::Averaged),
        (PN_INDIRECT_EXACT, IndirectOperator::Exact),
    ] {
        let (mut d, mut i) = ([0.0f32; 3], [0.0f32; 3]);
        let call = |al: &[f32], k: usize, d: &mut [f32; 3], i: &mut [f32; 3]| unsafe {
            pn_shadow_shade_with_indirect_by(
                ev,
                recv.0.as_ptr(),
                recv.1.as_ptr(),
                c_leaves.as_ptr(),
                3,
                al.as_ptr(),
                k,
                code,
                d.as_mut_ptr(),
                i.as_mut_ptr(),
            )
        };
        assert_eq!(call(&flat_al, 3, &mut d, &mut i), PN_OK);
        let r = rust.shade_with_indirect_per_sphere(recv.0, recv.1, &leaves, &albedo, op);
        assert_eq!((d, i), (r.direct, r.indirect), "{op:?}");
        assert!(i.iter().all(|&x| x > 0.0), "{op:?}: the proxies reflect light: {i:?}");
        assert_eq!(call(&[0.5, 0.5, 0.5], 1, &mut d, &mut i), PN_OK);
        assert_eq!(i, rust.shade_with_indirect_by(recv.0, recv.1, &leaves, [0.5; 3], op).indirect);
        assert_eq!(call(&flat_al, 2, &mut d, &mut i), PN_ERR_SIZE);
    }
    let (mut d, mut i) = ([0.0f32; 3], [0.0f32; 3]);
    let code = unsafe {
        pn_shadow_shade_with_indirect_by(
            ev,
            recv.0.as_ptr(),
            recv.1.as_ptr(),
            c_leaves.as_ptr(),
            3,
            flat_al.as_ptr(),
            3,
            7,
            d.as_mut_ptr(),
            i.as_mut_ptr(),
        )
    };
    assert_eq!(code, PN_ERR_RANGE);
    assert_eq!(unsafe { pn_spheres_albedo(s, 3, d.as_mut_ptr()) }, PN_ERR_RANGE);
    unsafe {
        pn_cluster_free(cl);
        pn_posed_spheres_free(ps);
        pn_posed_spheres_free(ps1);
        pn_shadow_free(ev);
        pn_spheres_free(s);
        pn_spheres_free(s1);
        pn_tables_free(t);
    }
}
