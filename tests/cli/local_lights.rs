//! Local spherical lights (issue #14 §2, SHEXP §7 "Analytic Lights"): the runtime shades with
//! the SHTB `L_H(θ, φ)` table's single-lobe ZH fit, rotated to the light, dotted with the
//! visibility. Checked against independent f64 quadrature of the spherical light.

use penumbra_asset::OwnedAsset;
use penumbra_runtime::ShTables;
use penumbra_runtime::shadows::{LocalLight, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use penumbra_sh::tables_asset::to_asset;
use std::f64::consts::PI;

fn tables_bytes(order: usize) -> Vec<u8> {
    to_asset(&bake(&TablesParams::new(order), &NoProgress).unwrap(), None).unwrap().to_bytes().unwrap()
}

/// `∫_{cone} V (N·ω)⁺ dω` for a light sphere `(c, r)` seen from `p`, blocked by `blockers`,
/// by a dense midpoint rule in `(cos θ, φ)` about the light's axis.
fn cone_truth(p: [f64; 3], n: [f64; 3], c: [f64; 3], r: f64, blockers: &[([f64; 3], f64)]) -> f64 {
    let v = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
    let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let a = v.map(|x| x / d);
    let helper = if a[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let k = helper[0] * a[0] + helper[1] * a[1] + helper[2] * a[2];
    let t0 = [helper[0] - k * a[0], helper[1] - k * a[1], helper[2] - k * a[2]];
    let tl = (t0[0] * t0[0] + t0[1] * t0[1] + t0[2] * t0[2]).sqrt();
    let t = t0.map(|x| x / tl);
    let b = [a[1] * t[2] - a[2] * t[1], a[2] * t[0] - a[0] * t[2], a[0] * t[1] - a[1] * t[0]];
    let cmin = (1.0 - (r / d).powi(2)).sqrt();
    let (nu, nv) = (400, 400);
    let mut s = 0.0;
    for i in 0..nu {
        let ct = cmin + (1.0 - cmin) * (i as f64 + 0.5) / nu as f64;
        let st = (1.0 - ct * ct).sqrt();
        for j in 0..nv {
            let ph = 2.0 * PI * (j as f64 + 0.5) / nv as f64;
            let w: [f64; 3] = std::array::from_fn(|q| st * ph.cos() * t[q] + st * ph.sin() * b[q] + ct * a[q]);
            let cn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
            if cn <= 0.0 {
                continue;
            }
            let hit = blockers.iter().any(|&(bc, br)| {
                let oc = [p[0] - bc[0], p[1] - bc[1], p[2] - bc[2]];
                let bb = oc[0] * w[0] + oc[1] * w[1] + oc[2] * w[2];
                let cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - br * br;
                bb < 0.0 && bb * bb - cc >= 0.0
            });
            if !hit {
                s += cn;
            }
        }
    }
    s * 2.0 * PI * (1.0 - cmin) / (nu * nv) as f64
}

fn light(c: [f32; 3], r: f32) -> LocalLight {
    LocalLight { sphere: Sphere { center: c, radius: r }, radiance: [1.0, 2.0, 0.5] }
}

#[test]
fn light_on_the_normal_matches_the_closed_form_and_scales_with_radiance() {
    let order = 4;
    let bytes = tables_bytes(order);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let ev = ShadowEvaluator::new(&t, &[[0.0; 3]; 16], ShadowOptions { window: false, ..Default::default() });
    let n = [0.0f32, 0.0, 1.0];
    // unoccluded light on the normal: the runtime gives π·(L_H)₀₀·√4π of the bake's own f64
    // L_H = H * L (truncated product; the fit is exact on the normal) up to the table's
    // interpolation, and that is π sin²θ up to the order-4 truncation; at a grid point,
    // between grid points and below the first one (θ < π/64, the solid-angle scaling)
    let gamma = penumbra_sh::gamma::TripleProduct::new(order);
    let eval = penumbra_math::sh::ShEval::new(order);
    for (r, d) in [(1.0f32, 2.0f32), (0.3, 2.0), (0.02, 2.0), (0.5, 20.0)] {
        let e = ev.irradiance_local_light([0.0; 3], n, &[], &light([0.0, 0.0, d], r)).unwrap();
        let theta = (r as f64 / d as f64).asin();
        let lh = penumbra_sh::local_light::local_light(&gamma, &eval, theta, 0.0);
        let sh_exact = PI * lh[0] * (4.0 * PI).sqrt();
        let exact = PI * (r as f64 / d as f64).powi(2);
        eprintln!("θ = {:.2}°: runtime {} SH {sh_exact} closed form {exact}", theta.to_degrees(), e[0]);
        assert!((e[0] as f64 - sh_exact).abs() < 1e-3 * sh_exact, "r={r} d={d}: {} vs SH {sh_exact}", e[0]);
        // order-4 H overshoots at the pole (1.06): the truncation, not the runtime
        assert!((e[0] as f64 - exact).abs() < 0.08 * exact, "r={r} d={d}: {} vs {exact}", e[0]);
        assert!((e[1] / e[0] - 2.0).abs() < 1e-6 && (e[2] / e[0] - 0.5).abs() < 1e-6);
    }
    // the same configuration in another frame gives the same answer (rotation to the light)
    let s = 0.5f32.sqrt();
    let a = ev.irradiance_local_light([0.0; 3], n, &[], &light([1.2, 0.0, 1.2], 0.4)).unwrap()[0];
    let b = ev
        .irradiance_local_light([3.0, 1.0, 0.0], [s, s, 0.0], &[], &light([3.0 + 1.2 * s, 1.0 + 1.2 * s, -1.2], 0.4))
        .unwrap()[0];
    assert!((a - b).abs() < 1e-4 * a.abs().max(1e-3), "{a} vs {b}");
    // a light entirely below the horizon gives (almost) nothing; one at 45° matches quadrature
    let below = ev.irradiance_local_light([0.0; 3], n, &[], &light([0.0, 1.5, -1.5], 0.3)).unwrap()[0];
    let above = ev.irradiance_local_light([0.0; 3], n, &[], &light([0.0, 1.5, 1.5], 0.3)).unwrap()[0];
    assert!(below.abs() < 0.05 * above, "{below} vs {above}");
    let truth = cone_truth([0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.5, 1.5], 0.3, &[]);
    assert!((above as f64 - truth).abs() < 0.05 * truth, "{above} vs {truth}"); // fit + order 4: 3.5 %
}

#[test]
fn blocker_between_receiver_and_light_shadows_it_on_the_right_side() {
    // an off-normal light (φ = 50°) with a blocker on the line to it: the runtime's shadow
    // matches quadrature; the same blocker mirrored to the other side of the normal blocks
    // nothing of the light, and the runtime sees (almost) no shadow there — a frame built
    // with the wrong side would swap the two
    let order = 6;
    let bytes = tables_bytes(order);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let ev = ShadowEvaluator::new(&t, &[[0.0; 3]; 36], ShadowOptions { window: false, ..Default::default() });
    let p = [0.0f64; 3];
    let n = [0.0, 0.0, 1.0];
    let phi = 50f64.to_radians();
    let dir = [phi.sin(), 0.0, phi.cos()];
    let c = dir.map(|x| 4.0 * x);
    let r = 1.0;
    let on_line = (dir.map(|x| 1.6 * x), 0.45);
    let mirrored = ([-on_line.0[0], 0.0, on_line.0[2]], 0.45);
    let l = light(c.map(|x| x as f32), r as f32);
    let f32s = |s: ([f64; 3], f64)| Sphere { center: s.0.map(|x| x as f32), radius: s.1 as f32 };
    let e_free = ev.irradiance_local_light([0.0; 3], [0.0, 0.0, 1.0], &[], &l).unwrap()[0] as f64;
    let e_block = ev.irradiance_local_light([0.0; 3], [0.0, 0.0, 1.0], &[f32s(on_line)], &l).unwrap()[0] as f64;
    let e_mirror = ev.irradiance_local_light([0.0; 3], [0.0, 0.0, 1.0], &[f32s(mirrored)], &l).unwrap()[0] as f64;
    let t_free = cone_truth(p, n, c, r, &[]);
    let t_block = cone_truth(p, n, c, r, &[on_line]);
    let t_mirror = cone_truth(p, n, c, r, &[mirrored]);
    eprintln!("free {e_free} / {t_free}, blocked {e_block} / {t_block}, mirrored {e_mirror} / {t_mirror}");
    assert_eq!(t_mirror, t_free, "the mirrored blocker is outside the light's cone");
    assert!(t_block < 0.5 * t_free, "the blocker hides a good part of the light");
    // unshadowed: single-lobe fit + order-6 truncation; a blocker outside the light's cone
    // changes (almost) nothing; the one hiding it darkens the light by half or more (order 6
    // cannot represent the full eclipse: the shadow is band-limited)
    assert!((e_free - t_free).abs() < 0.05 * t_free, "free {e_free} vs {t_free}");
    assert!((e_mirror - t_mirror).abs() < 0.05 * t_free, "mirrored {e_mirror} vs {t_mirror}");
    assert!(e_block < 0.6 * e_free, "blocked {e_block} vs free {e_free}");
    assert!(e_mirror - e_block > 0.4 * t_free, "the shadow falls on the light's side");
}

#[test]
fn tables_without_the_local_light_section_say_so() {
    // an SHTB written before the table existed: the runtime returns None, never garbage
    let bytes = tables_bytes(3);
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let a = owned.asset();
    let mut b = penumbra_asset::AssetBuilder::new(a.kind());
    for i in 0..a.sections().len() {
        let s = a.section_at(i).unwrap();
        if s.name() == "local_light_zh" {
            continue;
        }
        b.add_raw(s.name(), s.dtype(), s.dims(), s.bytes()).unwrap();
    }
    let stripped = b.to_bytes().unwrap();
    let so = OwnedAsset::parse(&stripped).unwrap();
    let t = ShTables::from_asset(&so.asset()).unwrap();
    assert!(t.local_light_zh().is_none());
    let ev = ShadowEvaluator::new(&t, &[[0.0; 3]; 9], ShadowOptions::default());
    assert!(ev.irradiance_local_light([0.0; 3], [0.0, 0.0, 1.0], &[], &light([0.0, 0.0, 2.0], 0.5)).is_none());
}
