//! Indirect light from proxies (issue #14 §2, IBPA §5): the point-sampled (eq. 13), averaged
//! (eq. 14–15) and exact (eq. 16–17) operators against f64 quadrature of one diffuse sphere
//! lit by a non-constant environment (a constant one never exercises D₁/D₂).

use penumbra_asset::OwnedAsset;
use penumbra_math::sh::ShEval;
use penumbra_runtime::ShTables;
use penumbra_runtime::shadows::{IndirectOperator, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use penumbra_sh::tables_asset::to_asset;
use std::f64::consts::PI;

/// A directional, coloured order-3 environment (RGB SH coefficients).
fn light() -> Vec<[f64; 3]> {
    let mut l = vec![[0.0f64; 3]; 16];
    l[0] = [2.0, 1.5, 1.0];
    l[1] = [0.3, -0.2, 0.1]; // y
    l[2] = [0.9, 0.6, 0.2]; // z
    l[3] = [-0.5, 0.4, 0.3]; // x
    l[4] = [0.2, 0.1, -0.1];
    l[6] = [0.4, 0.3, 0.5];
    l[7] = [-0.3, 0.2, 0.1];
    l[8] = [0.25, -0.15, 0.05];
    l
}

/// `∫ (N·s)⁺ ρ/π L̃(n_q(s)) ds` over the directions from `p` that meet the sphere `(c, r)`,
/// `L̃` the order-3 irradiance of `light()`, by a dense midpoint rule over the sphere's cone.
fn quadrature(p: [f64; 3], n: [f64; 3], c: [f64; 3], r: f64, albedo: f64) -> [f64; 3] {
    let eval = ShEval::new(3);
    let a_hat = [PI, 2.0 * PI / 3.0, PI / 4.0];
    let l = light();
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
    let (nu, nv) = (600, 600);
    let mut y = vec![0.0; 9];
    let mut out = [0.0f64; 3];
    for i in 0..nu {
        let ct = cmin + (1.0 - cmin) * (i as f64 + 0.5) / nu as f64;
        let st = (1.0 - ct * ct).sqrt();
        for j in 0..nv {
            let ph = 2.0 * PI * (j as f64 + 0.5) / nv as f64;
            let s: [f64; 3] = std::array::from_fn(|q| st * ph.cos() * t[q] + st * ph.sin() * b[q] + ct * a[q]);
            let cn = s[0] * n[0] + s[1] * n[1] + s[2] * n[2];
            if cn <= 0.0 {
                continue;
            }
            // first hit along s and the sphere's normal there
            let bq = d * ct;
            let th = bq - (bq * bq - (d * d - r * r)).max(0.0).sqrt();
            let nq: [f64; 3] = std::array::from_fn(|q| (p[q] + th * s[q] - c[q]) / r);
            eval.eval_into(nq, &mut y);
            for ch in 0..3 {
                let e: f64 = (0..9).map(|m| a_hat[penumbra_math::sh::band_of(m)] * l[m][ch] * y[m]).sum();
                out[ch] += cn * albedo / PI * e;
            }
        }
    }
    let w = 2.0 * PI * (1.0 - cmin) / (nu * nv) as f64;
    out.map(|x| x * w)
}

#[test]
fn exact_operator_beats_averaged_beats_point_sampled() {
    let order = 4;
    let bytes = to_asset(&bake(&TablesParams::new(order), &NoProgress).unwrap(), None).unwrap().to_bytes().unwrap();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let l32: Vec<[f32; 3]> = light().iter().map(|c| c.map(|x| x as f32)).collect();
    let ev = ShadowEvaluator::new(&t, &l32, ShadowOptions { window: false, ..Default::default() });
    let mut err = [0.0f64; 3];
    let mut scale = 0.0f64;
    // receivers beside and below spheres of several sizes and directions
    let cases = [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.8, 0.2, 1.2], 0.7),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.5], 1.0),
        ([0.3, -0.2, 0.0], [0.0, 0.6, 0.8], [-1.0, 1.5, 1.0], 0.5),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [2.0, -1.0, 0.6], 0.5),
        // near contact (α = 0.91): the order-3 truncation of V·H dominates every operator
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.1, 0.0, 0.0], 1.0),
    ];
    for (case, (p, n, c, r)) in cases.into_iter().enumerate() {
        let truth = quadrature(p, n, c, r, 0.8);
        let s = [Sphere { center: c.map(|x| x as f32), radius: r as f32 }];
        let f = |op| ev.shade_with_indirect_by(p.map(|x| x as f32), n.map(|x| x as f32), &s, [0.8; 3], op).indirect;
        let got = [f(IndirectOperator::PointSampled), f(IndirectOperator::Averaged), f(IndirectOperator::Exact)];
        eprintln!("{c:?} r={r}: truth {truth:?}  point {:?}  D {:?}  M {:?}", got[0], got[1], got[2]);
        if case == 4 {
            for g in &got {
                for ch in 0..3 {
                    assert!((g[ch] as f64 - truth[ch]).abs() < 0.1 * truth[ch], "near contact: {g:?} vs {truth:?}");
                }
            }
            continue;
        }
        for (o, g) in got.iter().enumerate() {
            for ch in 0..3 {
                err[o] += (g[ch] as f64 - truth[ch]).powi(2);
            }
        }
        scale += truth.iter().map(|x| x * x).sum::<f64>();
    }
    let rel = err.map(|e| (e / scale).sqrt());
    eprintln!("relative RMS error: point {:.4}  averaged {:.4}  exact {:.4}", rel[0], rel[1], rel[2]);
    assert!(rel[2] < rel[1] && rel[1] < rel[0], "{rel:?}");
    assert!(rel[2] < 0.02, "exact operator {rel:?}");
}

#[test]
fn per_sphere_albedo_scales_each_proxy_and_matches_quadrature() {
    // Two proxies with different albedos, disjoint caps: the runtime's indirect light is linear
    // in each proxy's albedo (the overlap factor ξ does not depend on it), equals the uniform
    // path when the albedos agree, and matches the sum of the two spheres' f64 quadratures
    // with their own albedos (exact operator, 3 %: its own error plus ξ ≈ 1).
    let order = 4;
    let bytes = to_asset(&bake(&TablesParams::new(order), &NoProgress).unwrap(), None).unwrap().to_bytes().unwrap();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let t = ShTables::from_asset(&owned.asset()).unwrap();
    let l32: Vec<[f32; 3]> = light().iter().map(|c| c.map(|x| x as f32)).collect();
    let ev = ShadowEvaluator::new(&t, &l32, ShadowOptions { window: false, ..Default::default() });
    let (p, n) = ([0.0f32, 0.0, 0.0], [0.0f32, 0.0, 1.0]);
    let (ca, ra, cb, rb) = ([1.2, 0.0, 1.5], 0.5, [-1.0, 0.4, 1.8], 0.6);
    let s = [
        Sphere { center: ca.map(|x: f64| x as f32), radius: ra as f32 },
        Sphere { center: cb.map(|x: f64| x as f32), radius: rb as f32 },
    ];
    let (rho_a, rho_b) = (0.9f32, 0.2f32);
    for op in [IndirectOperator::PointSampled, IndirectOperator::Averaged, IndirectOperator::Exact] {
        let f = |al: &[[f32; 3]]| ev.shade_with_indirect_per_sphere(p, n, &s, al, op).indirect;
        let both = f(&[[rho_a; 3], [rho_b; 3]]);
        let only_a = f(&[[1.0; 3], [0.0; 3]]);
        let only_b = f(&[[0.0; 3], [1.0; 3]]);
        let uniform = ev.shade_with_indirect_by(p, n, &s, [rho_a; 3], op).indirect;
        let same = f(&[[rho_a; 3], [rho_a; 3]]);
        for c in 0..3 {
            let lin = rho_a * only_a[c] + rho_b * only_b[c];
            assert!((both[c] - lin).abs() <= 1e-5 * lin.abs().max(1e-3), "{op:?}: {both:?} vs {lin}");
            assert!((same[c] - uniform[c]).abs() <= 1e-6 * uniform[c].abs(), "{op:?}: {same:?} vs {uniform:?}");
            // the two albedos give different weights: not the uniform answer
            assert!((both[c] - uniform[c]).abs() > 0.05 * uniform[c].abs(), "{op:?}");
        }
        // a missing entry reflects nothing
        let short = f(&[[rho_a; 3]]);
        for c in 0..3 {
            assert!((short[c] - rho_a * only_a[c]).abs() <= 1e-5 * short[c].abs().max(1e-3));
        }
        if op == IndirectOperator::Exact {
            let pa = [0.0f64; 3];
            let truth: [f64; 3] = {
                let a = quadrature(pa, [0.0, 0.0, 1.0], ca, ra, f64::from(rho_a));
                let b = quadrature(pa, [0.0, 0.0, 1.0], cb, rb, f64::from(rho_b));
                std::array::from_fn(|c| a[c] + b[c])
            };
            for c in 0..3 {
                let got = f64::from(both[c]);
                assert!((got - truth[c]).abs() < 0.03 * truth[c], "exact, c={c}: {got} vs quadrature {}", truth[c]);
            }
        }
    }
}
