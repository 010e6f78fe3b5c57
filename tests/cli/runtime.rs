//! The f32 runtime reading an SHTB asset agrees with the f64 bake it came from.

use penumbra_asset::OwnedAsset;
use penumbra_math::sh::{ShEval, dir_from_angles, zh_rotate};
use penumbra_runtime::ShTables;
use penumbra_sh::exp::exp_hyb;
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use penumbra_sh::tables_asset::to_asset;

#[test]
fn runtime_lookups_and_hyb_match_the_bake() {
    for order in [3usize, 4, 6] {
        let b = bake(&TablesParams::new(order), &NoProgress).unwrap();
        let bytes = to_asset(&b, None).unwrap().to_bytes().unwrap();
        let owned = OwnedAsset::parse(&bytes).unwrap();
        let t = ShTables::from_asset(&owned.asset()).unwrap();
        assert_eq!(t.order(), order);
        // table nodes
        let k = b.params.theta_samples;
        let mut row = vec![0.0f32; order];
        for i in [0usize, 1, k / 3, k - 1] {
            let th = std::f64::consts::FRAC_PI_2 * i as f64 / (k - 1) as f64;
            t.cap_log(th as f32, &mut row);
            for l in 0..order {
                assert!((row[l] as f64 - b.cap_log[i][l]).abs() < 1e-4 * (1.0 + b.cap_log[i][l].abs()));
            }
        }
        // HYB of an accumulated log of several spheres, f32 runtime vs f64 bake
        let e = ShEval::new(order);
        let mut acc = vec![0.0; order * order];
        let mut tmp = vec![0.0; order * order];
        for (j, deg) in [10.0f64, 25.0, 40.0, 15.0].iter().enumerate() {
            let i = ((deg.to_radians() / std::f64::consts::FRAC_PI_2) * (k - 1) as f64).round() as usize;
            let zh: Vec<f64> = (0..order).map(|l| b.cap_log[i][l] / penumbra_math::sh::zh_star_scale(l)).collect();
            zh_rotate(&e, &zh, dir_from_angles(0.2 + 0.3 * j as f64, 1.1 * j as f64), &mut tmp);
            acc.iter_mut().zip(&tmp).for_each(|(a, b)| *a += b);
        }
        let want = exp_hyb(&b.gamma, &acc, &b.ol);
        let f32s: Vec<f32> = acc.iter().map(|&v| v as f32).collect();
        let mut got = vec![0.0f32; order * order];
        t.exp_hyb(&f32s, &mut got);
        let num: f64 = got.iter().zip(&want).map(|(a, b)| (*a as f64 - b).powi(2)).sum::<f64>().sqrt();
        let den: f64 = want.iter().map(|b| b * b).sum::<f64>().sqrt();
        assert!(num / den < 1e-4, "order {order}: f32 HYB rel diff {}", num / den);
        // f32 SH basis matches f64
        let d = dir_from_angles(0.7, -2.0);
        let mut y32 = vec![0.0f32; order * order];
        t.basis().eval([d[0] as f32, d[1] as f32, d[2] as f32], &mut y32);
        for (a, b) in y32.iter().zip(e.eval(d)) {
            assert!((*a as f64 - b).abs() < 1e-5);
        }
    }
}
