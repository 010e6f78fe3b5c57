//! The C ABI returns what the Rust runtime returns (the same functions behind it, so equal
//! bit for bit), and its error paths report what is wrong instead of crashing: NULL pointers,
//! misaligned or damaged bytes, the wrong asset kind, short buffers, out-of-range options.
#![allow(unsafe_code)] // calling the C ABI from Rust is what this test is for

mod common;

use penumbra_asset::AssetFile;
use penumbra_capi::*;
use penumbra_runtime::shadows::{ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{ShTables, SphereSet, SphereTree};
use std::ptr;

fn corpus(name: &str) -> AssetFile {
    AssetFile::open(common::root().join("tests/assets/v1").join(name)).unwrap()
}

fn message(buf: &[u8]) -> String {
    let end = buf.iter().position(|&b| b == 0).unwrap();
    String::from_utf8_lossy(&buf[..end]).into_owned()
}

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

#[test]
fn shadow_abi_equals_the_runtime() {
    let tf = corpus("tables-order3-k16.shtb");
    let sf = corpus("character-count6-hierarchy.sphr");
    let mut err = [0u8; 256];
    let (mut t, mut s, mut ev, mut cl) = (ptr::null_mut(), ptr::null_mut(), ptr::null_mut(), ptr::null_mut());
    let e = err.as_mut_ptr().cast();
    // SAFETY (whole test): every pointer passed points to live storage of the stated length.
    unsafe {
        assert_eq!(pn_tables_open(tf.bytes().as_ptr(), tf.bytes().len(), &mut t, e, err.len()), PN_OK);
        assert_eq!(pn_tables_order(t), 3);
        assert_eq!(pn_spheres_open(sf.bytes().as_ptr(), sf.bytes().len(), &mut s, e, err.len()), PN_OK);
        let light: Vec<f32> = LIGHT.iter().flatten().copied().collect();
        assert_eq!(pn_shadow_new(t, light.as_ptr(), light.len(), ptr::null(), &mut ev, e, err.len()), PN_OK);
        assert_eq!(pn_cluster_new(&mut cl), PN_OK);
    }
    let ta = tf.asset();
    let tables = ShTables::from_asset(&ta).unwrap();
    let sa = sf.asset();
    let set = SphereSet::from_asset(&sa).unwrap();
    let rust = ShadowEvaluator::new(&tables, &LIGHT, ShadowOptions::default());
    let leaves: Vec<Sphere> = (0..set.len()).map(|i| set.leaf(i)).collect();
    let c_leaves: Vec<pn_sphere> = leaves.iter().map(|l| pn_sphere { center: l.center, radius: l.radius }).collect();
    assert_eq!(unsafe { pn_spheres_count(s) }, leaves.len());

    // receivers on the ground under the character and one on its surface
    let mut pts: Vec<[f32; 3]> = (0..19).map(|k| [-0.6 + 0.07 * k as f32, 0.0, 0.1 * (k % 3) as f32]).collect();
    pts.push(leaves[0].center);
    let n = [0.0f32, 1.0, 0.0];
    let normals = vec![n; pts.len()];
    let mut shadowed = 0;
    for p in &pts {
        let want = rust.irradiance(*p, n, &leaves);
        let mut got = [0.0f32; 3];
        let st = unsafe {
            pn_shadow_irradiance(ev, p.as_ptr(), n.as_ptr(), c_leaves.as_ptr(), c_leaves.len(), got.as_mut_ptr())
        };
        assert_eq!((st, got), (PN_OK, want));
        // the three steps one by one give the same
        let (mut f, mut g, mut e3) = ([0.0f32; 9], [0.0f32; 9], [0.0f32; 3]);
        unsafe {
            let sph = c_leaves.as_ptr();
            assert_eq!(
                pn_shadow_accumulate_log(ev, p.as_ptr(), n.as_ptr(), sph, c_leaves.len(), f.as_mut_ptr(), 9),
                PN_OK
            );
            assert_eq!(pn_shadow_exponentiate(ev, f.as_ptr(), g.as_mut_ptr(), 9), PN_OK);
            assert_eq!(pn_shadow_shade(ev, n.as_ptr(), g.as_ptr(), 9, e3.as_mut_ptr()), PN_OK);
        }
        assert_eq!(e3, want);
        let mut u = [0.0f32; 3];
        unsafe { pn_shadow_unshadowed(ev, n.as_ptr(), u.as_mut_ptr()) };
        assert_eq!(u, rust.unshadowed(n));
        shadowed += usize::from(want[0] < 0.95 * u[0]);
        // direct + indirect
        let (mut d, mut i) = ([0.0f32; 3], [0.0f32; 3]);
        let albedo = [0.5f32, 0.4, 0.3];
        let st = unsafe {
            pn_shadow_shade_with_indirect(
                ev,
                p.as_ptr(),
                n.as_ptr(),
                c_leaves.as_ptr(),
                c_leaves.len(),
                albedo.as_ptr(),
                d.as_mut_ptr(),
                i.as_mut_ptr(),
            )
        };
        let r = rust.shade_with_indirect(*p, n, &leaves, albedo);
        assert_eq!((st, d, i), (PN_OK, r.direct, r.indirect));
    }
    assert!(shadowed >= 3, "only {shadowed} receivers in shadow: the test would not see a wrong shadow");

    // product space, accumulation by another evaluator (here the same one: equal to irradiance)
    let p0 = pts[0];
    let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
    unsafe {
        pn_shadow_irradiance_product(ev, p0.as_ptr(), n.as_ptr(), c_leaves.as_ptr(), c_leaves.len(), a.as_mut_ptr());
        pn_shadow_irradiance_accumulated_by(
            ev,
            ev,
            p0.as_ptr(),
            n.as_ptr(),
            c_leaves.as_ptr(),
            c_leaves.len(),
            b.as_mut_ptr(),
        );
    }
    assert_eq!(a, rust.irradiance_product(p0, n, &leaves));
    assert_eq!(b, rust.irradiance_accumulated_by(&rust, p0, n, &leaves));
    assert_ne!(a, b, "product space and log space differ");
    // table lookups, the SH product, η
    let mut z = [0.0f32; 3];
    for (which, x) in [
        (PN_TABLE_CAP_LOG, 0.7f32),
        (PN_TABLE_CAP_VISIBILITY, 0.7),
        (PN_TABLE_PROXY_LOG_OCCLUSION, 0.4),
        (PN_TABLE_PROXY_VISIBILITY, 0.4),
    ] {
        assert_eq!(unsafe { pn_tables_zonal(t, which, x, z.as_mut_ptr(), 3) }, PN_OK);
        let mut want = [0.0f32; 3];
        match which {
            PN_TABLE_CAP_LOG => tables.cap_log(x, &mut want),
            PN_TABLE_CAP_VISIBILITY => tables.cap_visibility(x, &mut want),
            PN_TABLE_PROXY_LOG_OCCLUSION => tables.proxy_log_occlusion(x, &mut want),
            _ => tables.proxy_visibility(x, &mut want),
        }
        assert_eq!(z, want);
        assert!(z.iter().any(|&v| v != 0.0));
    }
    assert_eq!(unsafe { pn_tables_zonal(t, 9, 0.5, z.as_mut_ptr(), 3) }, PN_ERR_RANGE);
    assert_eq!(unsafe { pn_tables_zonal(t, 0, 0.5, z.as_mut_ptr(), 2) }, PN_ERR_SIZE);
    let f: Vec<f32> = (0..9).map(|i| 0.1 * i as f32 - 0.3).collect();
    let g: Vec<f32> = (0..9).map(|i| 0.5 - 0.05 * i as f32).collect();
    let (mut fg, mut want) = ([0.0f32; 9], [0.0f32; 9]);
    assert_eq!(unsafe { pn_tables_product(t, f.as_ptr(), g.as_ptr(), fg.as_mut_ptr(), 9) }, PN_OK);
    tables.product(&f, &g, &mut want);
    assert_eq!(fg, want);
    let mut eta = [0.0f32; 2];
    assert_eq!(unsafe { pn_tables_eta(t, eta.as_mut_ptr()) }, PN_OK);
    assert_eq!(eta, [tables.eta_shadow(), tables.eta_indirect()]);

    // batches
    let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
    let (pf, nf) = (flat(&pts), flat(&normals));
    let mut out = vec![0.0f32; pf.len()];
    let st = unsafe {
        pn_shadow_irradiance_batch(
            ev,
            pf.as_ptr(),
            nf.as_ptr(),
            pts.len(),
            c_leaves.as_ptr(),
            c_leaves.len(),
            out.as_mut_ptr(),
        )
    };
    let mut want = vec![[0.0f32; 3]; pts.len()];
    rust.irradiance_batch(&pts, &normals, &leaves, &mut want);
    assert_eq!((st, out.clone()), (PN_OK, flat(&want)));

    // hierarchy cut of a cluster of receivers beside the character, far enough for internal
    // nodes to enter the cut
    let (p_r, r_r, sin_max) = ([0.0f32, 0.0, 1.2], 0.3f32, 0.7f32);
    let pts: Vec<[f32; 3]> = pts.iter().map(|p| [0.4 * p[0], p[1], 0.4 * p[2] + 1.2]).collect();
    let pf = flat(&pts);
    let st = unsafe { pn_cluster_cut(cl, ev, s, p_r.as_ptr(), r_r, sin_max, p_r.as_ptr(), n.as_ptr()) };
    assert_eq!(st, PN_OK);
    let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::new());
    set.cut(p_r, r_r, sin_max, &mut stack, &mut cut);
    rust.cluster_blockers(&set, &cut, p_r, n, &mut blockers);
    assert_eq!(unsafe { pn_cluster_size(cl) }, blockers.len());
    assert!(blockers.len() < leaves.len(), "the cut uses internal nodes");
    for p in &pts {
        let mut got = [0.0f32; 3];
        unsafe { pn_cluster_irradiance(cl, ev, p.as_ptr(), n.as_ptr(), got.as_mut_ptr()) };
        assert_eq!(got, rust.irradiance_blockers(*p, n, &blockers));
    }
    let st = unsafe { pn_cluster_irradiance_batch(cl, ev, pf.as_ptr(), nf.as_ptr(), pts.len(), out.as_mut_ptr()) };
    rust.irradiance_blockers_batch(&pts, &normals, &blockers, &mut want);
    assert!(want.iter().any(|w| w[0] < 0.99 * rust.unshadowed(n)[0]), "cluster receivers see the blockers");
    assert_eq!((st, out), (PN_OK, flat(&want)));

    // sphere set accessors
    let mut leaf = pn_sphere { center: [0.0; 3], radius: 0.0 };
    assert_eq!(unsafe { pn_spheres_leaf(s, 2, &mut leaf) }, PN_OK);
    assert_eq!((leaf.center, leaf.radius), (leaves[2].center, leaves[2].radius));
    assert_eq!(unsafe { pn_spheres_leaf(s, leaves.len(), &mut leaf) }, PN_ERR_RANGE);
    assert_eq!(unsafe { pn_spheres_depth(s) }, set.depth());
    let (mut nodes, mut w) = ([0u32; 4], [0.0f32; 4]);
    assert_eq!(unsafe { pn_spheres_skin(s, 0, nodes.as_mut_ptr(), w.as_mut_ptr()) }, PN_ERR_ABSENT);

    unsafe {
        pn_cluster_free(cl);
        pn_shadow_free(ev);
        pn_spheres_free(s);
        pn_tables_free(t);
    }
}

#[test]
fn errors_are_reported_not_crashed() {
    let tf = corpus("tables-order3-k16.shtb");
    let bytes = tf.bytes();
    let mut err = [0u8; 128];
    let e = err.as_mut_ptr().cast();
    let mut t = ptr::null_mut();
    unsafe {
        // NULL data and NULL out
        assert_eq!(pn_tables_open(ptr::null(), 10, &mut t, e, err.len()), PN_ERR_NULL);
        assert_eq!(pn_tables_open(bytes.as_ptr(), bytes.len(), ptr::null_mut(), e, err.len()), PN_ERR_NULL);
        // damaged bytes: the loader's message, truncated to the buffer
        let mut copy = penumbra_asset::AlignedBuf::from_slice(bytes);
        let last = copy.len() - 1;
        copy.as_mut_slice()[last] ^= 0x40;
        assert_eq!(pn_tables_open(copy.as_slice().as_ptr(), copy.len(), &mut t, e, err.len()), PN_ERR_ASSET);
        assert!(message(&err).contains("checksum"), "{}", message(&err));
        // a tiny message buffer is still NUL-terminated
        let mut tiny = [0xAAu8; 5];
        assert_eq!(
            pn_tables_open(copy.as_slice().as_ptr(), copy.len(), &mut t, tiny.as_mut_ptr().cast(), 5),
            PN_ERR_ASSET
        );
        assert_eq!(tiny[4], 0);
        // misaligned
        let mut shifted = vec![0u8; bytes.len() + 8];
        let off = (8 - shifted.as_ptr() as usize % 8) % 8 + 1;
        shifted[off..off + bytes.len()].copy_from_slice(bytes);
        assert_eq!(pn_tables_open(shifted[off..].as_ptr(), bytes.len(), &mut t, e, err.len()), PN_ERR_ALIGNMENT);
        // wrong kind
        let sf = corpus("character-count6-hierarchy.sphr");
        assert_eq!(pn_tables_open(sf.bytes().as_ptr(), sf.bytes().len(), &mut t, e, err.len()), PN_ERR_RUNTIME);
        assert!(message(&err).contains("SHTB"), "{}", message(&err));
        assert!(t.is_null());

        // a good one, then bad evaluator arguments
        assert_eq!(pn_tables_open(bytes.as_ptr(), bytes.len(), &mut t, e, err.len()), PN_OK);
        assert_eq!(message(&err), "");
        let mut light = [0.0f32; 27];
        light[..3].copy_from_slice(&[1.0, 0.8, 0.6]); // a constant environment
        let mut ev = ptr::null_mut();
        assert_eq!(pn_shadow_new(t, light.as_ptr(), 26, ptr::null(), &mut ev, e, err.len()), PN_ERR_SIZE);
        let opts = pn_shadow_options { exp: 7, ps_degree: 0, self_shadow_rules: true, window: true };
        assert_eq!(pn_shadow_new(t, light.as_ptr(), 27, &opts, &mut ev, e, err.len()), PN_ERR_RANGE);
        let opts = pn_shadow_options { exp: PN_EXP_PS_STAR, ps_degree: 4, self_shadow_rules: false, window: false };
        assert_eq!(pn_shadow_new(t, light.as_ptr(), 27, &opts, &mut ev, e, err.len()), PN_OK);
        let (p, n) = ([0.0f32, 0.0, 0.0], [0.0f32, 1.0, 0.0]);
        let mut f = [0.0f32; 9];
        assert_eq!(
            pn_shadow_accumulate_log(ev, p.as_ptr(), n.as_ptr(), ptr::null(), 0, f.as_mut_ptr(), 8),
            PN_ERR_SIZE
        );
        assert_eq!(pn_shadow_irradiance(ev, p.as_ptr(), ptr::null(), ptr::null(), 0, f.as_mut_ptr()), PN_ERR_NULL);
        assert_eq!(
            pn_shadow_irradiance(ptr::null(), p.as_ptr(), n.as_ptr(), ptr::null(), 0, f.as_mut_ptr()),
            PN_ERR_NULL
        );
        // no spheres: the unshadowed irradiance
        let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
        assert_eq!(pn_shadow_irradiance(ev, p.as_ptr(), n.as_ptr(), ptr::null(), 0, a.as_mut_ptr()), PN_OK);
        pn_shadow_unshadowed(ev, n.as_ptr(), b.as_mut_ptr());
        assert_eq!(a, b);
        assert!(a[0] > 0.0);
        pn_shadow_free(ev);
        pn_tables_free(t);
        pn_tables_free(ptr::null_mut());

        // MRT: a level with another dictionary is refused; sizes are checked
        let d = corpus("mrt-cube2d-r4.mrtd");
        let l = corpus("mrt-corridor3.mrtl");
        let mut m = ptr::null_mut();
        let st =
            pn_mrt_open(d.bytes().as_ptr(), d.bytes().len(), l.bytes().as_ptr(), l.bytes().len(), &mut m, e, err.len());
        assert_ne!(st, PN_OK, "corridor3 was baked with the interfaces dictionary");
        assert!(!message(&err).is_empty());
        let d = corpus("mrt-cube2d-r4-interfaces.mrtd");
        let st =
            pn_mrt_open(d.bytes().as_ptr(), d.bytes().len(), l.bytes().as_ptr(), l.bytes().len(), &mut m, e, err.len());
        assert_eq!(st, PN_OK, "{}", message(&err));
        let nt = pn_mrt_texel_count(m);
        assert_eq!(pn_mrt_block_offset(m, pn_mrt_block_count(m)), nt);
        let (l_d, mut out) = (vec![1.0f32; nt], vec![0.0f32; nt]);
        assert_eq!(pn_mrt_indirect(m, l_d.as_ptr(), out.as_mut_ptr(), nt - 1, true), PN_ERR_SIZE);
        assert_eq!(pn_mrt_indirect(m, l_d.as_ptr(), out.as_mut_ptr(), nt, true), PN_OK);
        // b of every block, as the runtime's: b = T_d→b l_d of block 0 computed here
        let mut stride = 0usize;
        assert_eq!(pn_mrt_coefficients(m, ptr::null_mut(), 0, &mut stride), PN_OK);
        let nb = pn_mrt_block_count(m);
        let mut bv = vec![0.0f32; nb * stride];
        assert_eq!(pn_mrt_coefficients(m, bv.as_mut_ptr(), bv.len() - 1, ptr::null_mut()), PN_ERR_SIZE);
        assert_eq!(pn_mrt_coefficients(m, bv.as_mut_ptr(), bv.len(), ptr::null_mut()), PN_OK);
        let mut sh0 = pn_mrt_shape { n: 0, k_b: 0, u_b: ptr::null(), t_d2b: ptr::null() };
        assert_eq!(pn_mrt_shape_info(m, pn_mrt_block_shape(m, 0), &mut sh0), PN_OK);
        let t_d2b = core::slice::from_raw_parts(sh0.t_d2b, sh0.k_b * sh0.n);
        for i in 0..sh0.k_b {
            let want: f32 = (0..sh0.n).map(|t| t_d2b[i * sh0.n + t] * l_d[t]).sum();
            assert!((bv[i] - want).abs() <= 1e-4 * want.abs().max(1e-3), "b[{i}] {} vs {want}", bv[i]);
        }
        let mut shape = pn_mrt_shape { n: 0, k_b: 0, u_b: ptr::null(), t_d2b: ptr::null() };
        assert_eq!(pn_mrt_shape_info(m, pn_mrt_block_shape(m, 0), &mut shape), PN_OK);
        assert_eq!(pn_mrt_block_offset(m, 1), shape.n);
        assert_eq!(pn_mrt_shape_info(m, 99, &mut shape), PN_ERR_RANGE);
        pn_mrt_free(m);
    }
    assert_eq!(pn_abi_version(), PN_ABI_VERSION);
}

#[test]
fn fiv_abi_equals_the_runtime() {
    let ff = corpus("fiv-torus-8x5x4.fivt");
    let fa = ff.asset();
    let table = penumbra_runtime::fiv::FivTable::from_asset(&fa).unwrap();
    let mut err = [0u8; 128];
    let e = err.as_mut_ptr().cast();
    let (mut t, mut sc) = (ptr::null_mut(), ptr::null_mut());
    unsafe {
        assert_eq!(pn_fiv_table_open(ff.bytes().as_ptr(), ff.bytes().len(), &mut t, e, err.len()), PN_OK);
        let (mut c, mut r) = ([0.0f32; 3], 0.0f32);
        assert_eq!(pn_fiv_table_ball(t, c.as_mut_ptr(), &mut r), PN_OK);
        assert_eq!((c, r), (table.center(), table.radius()));
        // yaw blend: 2.25 of 8 steps → tables 2 and 3, weight 0.25; bad input refused
        let (mut m0, mut m1, mut f) = (9usize, 9usize, -1.0f32);
        let yaw = 2.25 * core::f32::consts::TAU / 8.0;
        assert_eq!(pn_fiv_yaw_blend(8, yaw, &mut m0, &mut m1, &mut f), PN_OK);
        assert_eq!((m0, m1), (2, 3));
        assert!((f - 0.25).abs() < 1e-5);
        assert_eq!(pn_fiv_yaw_blend(0, yaw, &mut m0, &mut m1, &mut f), PN_ERR_RANGE);
        assert_eq!(pn_fiv_yaw_blend(8, f32::NAN, &mut m0, &mut m1, &mut f), PN_ERR_RANGE);
        assert_eq!(pn_fiv_yaw_blend(8, yaw, ptr::null_mut(), &mut m1, &mut f), PN_ERR_NULL);
        let placed = [
            pn_fiv_placed { table: t, center: c },
            pn_fiv_placed { table: t, center: [c[0] + r, c[1], c[2] + 0.5 * r] },
        ];
        assert_eq!(pn_fiv_scene_new(placed.as_ptr(), 2, 5, true, &mut sc, e, err.len()), PN_ERR_RANGE);
        assert_eq!(pn_fiv_scene_new(placed.as_ptr(), 0, 0, true, &mut sc, e, err.len()), PN_ERR_SIZE);
        assert_eq!(pn_fiv_scene_new(placed.as_ptr(), 2, PN_FIV_PARTIAL_SCALE, true, &mut sc, e, err.len()), PN_OK);
        use penumbra_runtime::fiv::{FivShader, Partial, PlacedOccluder, ShadeOptions};
        let occ = [
            PlacedOccluder { table: &table, center: placed[0].center },
            PlacedOccluder { table: &table, center: placed[1].center },
        ];
        let opts = ShadeOptions { partial: Partial::Scale, overlap: true };
        let mut shader = FivShader::new();
        let n = [0.0f32, 1.0, 0.0];
        let mut differs = 0;
        for k in 0..12 {
            let p = [c[0] - 2.0 * r + 0.4 * r * k as f32, c[1] - 1.1 * r, c[2]];
            let (mut a, mut o) = ([0.0f32; 3], [0.0f32; 3]);
            assert_eq!(pn_fiv_scene_irradiance(sc, p.as_ptr(), n.as_ptr(), a.as_mut_ptr()), PN_OK);
            assert_eq!(a, shader.irradiance(&occ, p, n, opts));
            assert_eq!(pn_fiv_scene_occluded(sc, p.as_ptr(), n.as_ptr(), o.as_mut_ptr()), PN_OK);
            assert_eq!(o, shader.occluded_irradiance(&occ, p, n, opts));
            differs += usize::from(o[0] > 0.0);
            // self-shadowing on occluder 1, shadowed by occluder 0
            let q = [placed[1].center[0], placed[1].center[1] + 0.9 * r, placed[1].center[2] + 0.1 * k as f32];
            assert_eq!(pn_fiv_scene_self_shadowed(sc, 1, q.as_ptr(), n.as_ptr(), a.as_mut_ptr()), PN_OK);
            assert_eq!(a, shader.self_shadowed(&occ[1], &occ[..1], q, n, opts));
        }
        assert!(differs >= 3, "receivers must see occlusion for the test to mean anything");
        assert_eq!(pn_fiv_scene_self_shadowed(sc, 2, c.as_ptr(), n.as_ptr(), err.as_mut_ptr().cast()), PN_ERR_RANGE);
        // moving an occluder is what the runtime sees after the move
        let to = [c[0] + 3.0 * r, c[1], c[2]];
        assert_eq!(pn_fiv_scene_move(sc, 1, to.as_ptr()), PN_OK);
        let occ = [occ[0], PlacedOccluder { table: &table, center: to }];
        let p = [c[0] + 3.0 * r, c[1] - 1.1 * r, c[2]];
        let mut a = [0.0f32; 3];
        pn_fiv_scene_irradiance(sc, p.as_ptr(), n.as_ptr(), a.as_mut_ptr());
        assert_eq!(a, shader.irradiance(&occ, p, n, opts));
        pn_fiv_scene_free(sc);
        pn_fiv_table_free(t);
    }
}

#[test]
fn drt_abi_equals_the_runtime() {
    let d = corpus("mrt-cube2d-r4-v3.mrtd");
    let l = corpus("mrt-room1-v3.mrtl");
    let o = corpus("drt-room1-pillar-r4.drto");
    let mut err = vec![0u8; 256];
    let e = err.as_mut_ptr().cast();
    let mut h = ptr::null_mut();
    // SAFETY: the pointers are the corpus files' bytes, alive for the whole test.
    unsafe {
        let st = pn_drt_open(
            d.bytes().as_ptr(),
            d.bytes().len(),
            l.bytes().as_ptr(),
            l.bytes().len(),
            o.bytes().as_ptr(),
            o.bytes().len(),
            &mut h,
            e,
            err.len(),
        );
        assert_eq!(st, PN_OK, "{}", message(&err));
        let (n, m) = (pn_drt_texel_count(h), pn_drt_clutter_texel_count(h));
        assert!(n > 0 && m > 0);
        let l_d: Vec<f32> = (0..n).map(|i| 0.5 + (i % 7) as f32 * 0.1).collect();
        let l_dc: Vec<f32> = (0..m).map(|i| 0.2 + (i % 5) as f32 * 0.2).collect();
        let (mut s, mut c) = (vec![0.0f32; n], vec![0.0f32; m]);
        assert_eq!(
            pn_drt_multi_bounce(h, l_d.as_ptr(), s.as_mut_ptr(), n, l_dc.as_ptr(), c.as_mut_ptr(), m, 1, 0.7, 3),
            PN_OK
        );
        // the Rust runtime on the same bytes
        let (da, la, oa) = (d.asset(), l.asset(), o.asset());
        let dict = penumbra_runtime::mrt::MrtDictionary::from_asset(&da).unwrap();
        let level = penumbra_runtime::mrt::MrtLevel::from_asset(&la, &dict).unwrap();
        let ops = penumbra_runtime::drt::DrtOperators::from_asset(&oa, &dict, &level).unwrap();
        let mut mrt = penumbra_runtime::mrt::MrtRuntime::new(dict, level);
        let mut drt = penumbra_runtime::drt::DrtRuntime::new(ops, &mrt);
        let (mut s2, mut c2) = (vec![0.0f32; n], vec![0.0f32; m]);
        drt.multi_bounce(&mut mrt, &l_d, &l_dc, 1, 0.7, 3, &mut s2, &mut c2);
        assert_eq!(s, s2);
        assert_eq!(c, c2);
        assert!(c.iter().any(|&v| v > 0.0));
        // errors: sizes, channel, a DRTO opened against another level
        assert_eq!(
            pn_drt_one_bounce(h, l_d.as_ptr(), s.as_mut_ptr(), n - 1, l_dc.as_ptr(), c.as_mut_ptr(), m, 0, 1.0),
            PN_ERR_SIZE
        );
        assert_eq!(
            pn_drt_one_bounce(h, l_d.as_ptr(), s.as_mut_ptr(), n, l_dc.as_ptr(), c.as_mut_ptr(), m, 3, 1.0),
            PN_ERR_RANGE
        );
        pn_drt_free(h);
        let other = corpus("mrt-corridor3.mrtl");
        let d2 = corpus("mrt-cube2d-r4-interfaces.mrtd");
        let st = pn_drt_open(
            d2.bytes().as_ptr(),
            d2.bytes().len(),
            other.bytes().as_ptr(),
            other.bytes().len(),
            o.bytes().as_ptr(),
            o.bytes().len(),
            &mut h,
            e,
            err.len(),
        );
        assert_eq!(st, PN_ERR_RUNTIME, "{}", message(&err));
        assert!(message(&err).contains("du_b") || message(&err).contains("record"), "{}", message(&err));
    }
}
