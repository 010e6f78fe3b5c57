//! The C ABI of the MRT runtime's geometry, vector and volume queries (issue #19 §2): on a
//! freshly baked dictionary (vector, volume, interfaces) and a level with `block_xform`, each
//! returns what the Rust runtime returns, bit for bit; the irradiance helpers their analytic
//! answers; error paths their codes.
#![allow(unsafe_code)] // calling the C ABI from Rust is what this test is for

use crate::mrt_level::small_dict;
use crate::{penumbra, run};
use penumbra_asset::AssetFile;
use penumbra_capi::*;
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_runtime::mrt_vec::TexelWorld;
use std::ptr;

const Y00: f32 = 0.282_094_8;
const C1: f32 = 0.488_602_5;

#[test]
fn mrt_texel_world_vector_and_probe_queries_through_the_c_abi_equal_the_runtime() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    // four turned blocks joined by interfaces (a U-turn)
    let lt = dir.path().join("l.toml");
    std::fs::write(&lt, crate::mrt_level::U_TURN).unwrap();
    let l = dir.path().join("l.mrtl");
    let (code, _, stderr) = run(penumbra().args(["mrt", "level"]).arg(&lt).arg("--dict").arg(&d).arg("-o").arg(&l));
    assert_eq!(code, 0, "{stderr}");
    let (df, lf) = (AssetFile::open(&d).unwrap(), AssetFile::open(&l).unwrap());
    let (da, la) = (df.asset(), lf.asset());
    let rd = MrtDictionary::from_asset(&da).unwrap();
    let rl = MrtLevel::from_asset(&la, &rd).unwrap();
    let mut rt = MrtRuntime::new(rd, rl);
    let mut m = ptr::null_mut();
    let mut err = [0 as core::ffi::c_char; 256];
    unsafe {
        let (db, lb) = (df.bytes(), lf.bytes());
        let e = err.as_mut_ptr();
        assert_eq!(pn_mrt_open(db.as_ptr(), db.len(), lb.as_ptr(), lb.len(), &mut m, e, err.len()), PN_OK);
        let want = PN_MRT_VECTOR | PN_MRT_VOLUME | PN_MRT_INTERFACE_VECTORS | PN_MRT_TEXEL_WORLD;
        assert_eq!(pn_mrt_features(m), want);
        assert_eq!(pn_mrt_features(ptr::null()), 0);
        let nt = pn_mrt_texel_count(m);
        let nb = pn_mrt_block_count(m);
        assert_eq!(nb, 4);

        // texel world: the runtime's frames, bit for bit
        let mut tw = vec![pn_texel_world::default(); nt];
        assert_eq!(pn_mrt_texel_world(m, tw.as_mut_ptr(), nt - 1), PN_ERR_SIZE);
        assert_eq!(pn_mrt_texel_world(m, ptr::null_mut(), nt), PN_ERR_NULL);
        assert_eq!(pn_mrt_texel_world(m, tw.as_mut_ptr(), nt), PN_OK);
        let mut w = vec![TexelWorld::default(); nt];
        rt.texel_world(&mut w).unwrap();
        for (a, b) in tw.iter().zip(&w) {
            assert_eq!([a.position, a.normal, a.u, a.v], [b.position, b.normal, b.u, b.v]);
        }

        // direct light of a point light in block 0, from the texel frames (what an engine does)
        let light = [0.3f32, 0.6, 0.45];
        let l_d: Vec<f32> = tw
            .iter()
            .map(|t| {
                let v: [f32; 3] = core::array::from_fn(|k| light[k] - t.position[k]);
                let r2 = v.iter().map(|x| x * x).sum::<f32>();
                let c = (0..3).map(|k| v[k] * t.normal[k]).sum::<f32>() / r2.sqrt();
                c.max(0.0) / r2
            })
            .collect();
        assert!(l_d.iter().filter(|&&x| x > 0.0).count() > nt / 4);
        let mut one = vec![0.0f32; nt];
        assert_eq!(pn_mrt_indirect(m, l_d.as_ptr(), one.as_mut_ptr(), nt, true), PN_OK);
        let mut one_rt = vec![0.0f32; nt];
        rt.indirect(&l_d, &mut one_rt, true);
        assert_eq!(one, one_rt);

        // vector coefficients, with and without the interfaces' U_r⃗ r
        for interfaces in [true, false] {
            let mut vc = vec![0.0f32; 4 * nt];
            assert_eq!(pn_mrt_vector_coefficients(m, vc.as_mut_ptr(), nt - 1, interfaces), PN_ERR_SIZE);
            assert_eq!(pn_mrt_vector_coefficients(m, vc.as_mut_ptr(), nt, interfaces), PN_OK);
            let mut vr = vec![[0.0f32; 4]; nt];
            rt.vector_coefficients_parts(&mut vr, interfaces);
            assert_eq!(vc, vr.concat());
            // at its own normal (0, 0, 1) a texel's OHLSH irradiance is finite and not all zero
            let e: Vec<f32> = vr.iter().map(|a| pn_ohlsh_irradiance(a.as_ptr(), [0.0f32, 0.0, 1.0].as_ptr())).collect();
            assert!(e.iter().all(|x| x.is_finite()) && e.iter().any(|&x| x > 0.0));
        }
        let (mut with, mut without) = (vec![0.0f32; 4 * nt], vec![0.0f32; 4 * nt]);
        pn_mrt_vector_coefficients(m, with.as_mut_ptr(), nt, true);
        pn_mrt_vector_coefficients(m, without.as_mut_ptr(), nt, false);
        assert_ne!(with, without, "the interfaces carry light out of block 0");

        // probes: the runtime's world SH, its irradiance, the error codes
        for x in 0..nb {
            let g = pn_mrt_probe_count(m, x);
            assert_eq!(g, 8, "volume_res 2");
            let mut sh = vec![0.0f32; 9 * g];
            assert_eq!(pn_mrt_probe_sh(m, x, sh.as_mut_ptr(), sh.len() - 1, true), PN_ERR_SIZE);
            assert_eq!(pn_mrt_probe_sh(m, x, sh.as_mut_ptr(), sh.len(), true), PN_OK);
            let mut r = Vec::new();
            assert_eq!(rt.probe_sh(x, &mut r), g);
            assert_eq!(sh, r);
            let (p, n) = ([0.3f32, 0.6, 0.5], [0.0f32, 0.6, 0.8]);
            let mut e = f32::NAN;
            assert_eq!(pn_mrt_probe_irradiance(m, x, sh.as_ptr(), sh.len(), p.as_ptr(), n.as_ptr(), &mut e), PN_OK);
            assert_eq!(e, rt.probe_irradiance(x, &r, p, n));
        }
        let mut sh = vec![0.0f32; 72];
        assert_eq!(pn_mrt_probe_count(m, nb), usize::MAX);
        assert_eq!(pn_mrt_probe_sh(m, nb, sh.as_mut_ptr(), 72, true), PN_ERR_RANGE);

        // locate: the light is in block 0; block 1's centre in block 1; far away in none
        let (mut b, mut loc) = (usize::MAX, [0.0f32; 3]);
        assert_eq!(pn_mrt_locate(m, light.as_ptr(), &mut b, loc.as_mut_ptr()), PN_OK);
        assert_eq!((b, loc), rt.locate(light).unwrap());
        assert_eq!(b, 0);
        assert_eq!(pn_mrt_locate(m, [1.5f32, 0.5, 0.5].as_ptr(), &mut b, loc.as_mut_ptr()), PN_OK);
        assert_eq!(b, 1);
        assert!(loc.iter().all(|&v| (v - 0.5).abs() < 1e-6), "{loc:?}");
        assert_eq!(pn_mrt_locate(m, [9.0f32, 9.0, 9.0].as_ptr(), &mut b, loc.as_mut_ptr()), PN_ERR_RANGE);
        pn_mrt_free(m);
    }
}

#[test]
fn sh_and_ohlsh_irradiance_helpers_give_the_analytic_answers() {
    unsafe {
        // radiance 1 everywhere: c₀₀ = 4π·y₀₀, irradiance π at any normal
        let mut c = [0.0f32; 9];
        c[0] = 4.0 * core::f32::consts::PI * Y00;
        for n in [[0.0f32, 1.0, 0.0], [0.6, 0.0, -0.8]] {
            assert!((pn_sh9_irradiance(c.as_ptr(), n.as_ptr()) - core::f32::consts::PI).abs() < 1e-5);
        }
        // radiance y₁₀ = C1·z: irradiance (2π/3)·C1·n_z (the clamped-cosine band-1 factor)
        let mut c = [0.0f32; 9];
        c[2] = 1.0;
        let e = pn_sh9_irradiance(c.as_ptr(), [0.0f32, 0.6, 0.8].as_ptr());
        assert!((e - 2.0 * core::f32::consts::PI / 3.0 * C1 * 0.8).abs() < 1e-6, "{e}");
        // OHLSH: a₀ alone is π·y₀₀·a₀; the linear band follows (−m_x, −m_y, m_z) for (a₃, a₁, a₂)
        let a = [1.0f32 / Y00, 0.0, 0.0, 0.0];
        assert!((pn_ohlsh_irradiance(a.as_ptr(), [0.0f32, 0.0, 1.0].as_ptr()) - core::f32::consts::PI).abs() < 1e-5);
        let a = [0.0f32, 1.0, 2.0, 3.0];
        let mm = [0.36f32, 0.48, 0.8];
        let want = 2.0 * core::f32::consts::PI / 3.0 * C1 * (-mm[1] + 2.0 * mm[2] - 3.0 * mm[0]);
        assert!((pn_ohlsh_irradiance(a.as_ptr(), mm.as_ptr()) - want).abs() < 1e-6);
        assert!(pn_ohlsh_irradiance(ptr::null(), mm.as_ptr()).is_nan());
        assert!(pn_sh9_irradiance(c.as_ptr(), ptr::null()).is_nan());
    }
}
