//! The tables' physics: indirect operators (IBPA §5), expansion factors (IBPA §4.1),
//! local lights (SHEXP §7), OHLSH (MRT App. B), the smooth clamp.

use core::f64::consts::PI;
use penumbra_math::sh::{ShEval, index};
use penumbra_sh::eta::*;
use penumbra_sh::gamma::TripleProduct;
use penumbra_sh::indirect::*;
use penumbra_sh::local_light::*;
use penumbra_sh::reference;
use penumbra_sh::tables::*;

#[test]
fn averaged_operator_matches_ibpa_analytic_formula() {
    for k in 1..=200 {
        let a = k as f64 / 200.0;
        let d = averaged_operator(3, a);
        let an = averaged_operator_analytic(a);
        for l in 0..3 {
            assert!((d[l] - an[l]).abs() < 1e-12, "α={a} l={l}: {} vs {}", d[l], an[l]);
        }
    }
    // The formula as printed agrees where it does not cancel catastrophically.
    for a in [0.3f64, 0.7, 1.0] {
        let p = averaged_operator_analytic_printed(a);
        let d = averaged_operator(3, a);
        assert!((p[1] - d[1]).abs() < 1e-12 && (p[2] - d[2]).abs() < 1e-12);
    }
    // Head-on limit: the visible hemisphere averaged over its projected disk has
    // mean normal z = −2/3, so D₁(0) = y₁₀ coefficient · (−2/3) = −√3/(3√π).
    let d0 = averaged_operator(3, 1e-9);
    assert!((d0[1] + 3f64.sqrt() / (3.0 * PI.sqrt())).abs() < 1e-9);
}

#[test]
fn polynomial_fits_meet_ibpa_errors_within_sampling() {
    // IBPA: 0.00016 % (D₁) and 0.00064 % (D₂). Against our exact D, uniform in α:
    // 0.00018 % and 0.00049 %. Our own least-squares fit of the same form has the same
    // error as the paper's coefficients, so those coefficients are the optimum and the
    // small differences come from the unstated sampling of α (see docs/tables.md).
    let [e1, e2] = paper_fit_rel_sq_error(1000);
    assert!(e1 < 2.0 * 1.6e-6 && e1 > 0.5 * 1.6e-6, "D1 {e1}");
    assert!(e2 < 2.0 * 6.4e-6 && e2 > 0.5 * 6.4e-6, "D2 {e2}");
    let (c1, c2, [r1, r2]) = refit(1000);
    assert!(r1 <= e1 * (1.0 + 1e-9) && r2 <= e2 * (1.0 + 1e-9));
    // refit reproduces the paper's coefficients to ~3 digits
    assert!((c1[0] + 0.32494).abs() < 5e-4 && (c1[1] + 0.25073).abs() < 5e-4 && (c1[2] - 0.08432).abs() < 5e-4);
    assert!((c2[0] - 0.15950).abs() < 5e-4 && (c2[3] + 0.22230).abs() < 2e-3);
}

#[test]
fn exact_operator_consistent_with_averaged_and_brute_force() {
    let n = 3;
    for a in [0.05f64, 0.4, 0.9, 1.0] {
        let m = exact_operator(n, a);
        let d = averaged_operator(n, a);
        let w = solid_angle(a);
        // Row of the DC output: M_{0,(l,0)} = y00 · ω · D_l.
        for l in 0..n {
            let want = 0.5 / PI.sqrt() * w * d[l];
            assert!((m[index(l, 0)] - want).abs() < 1e-12, "α={a} l={l}");
        }
        // Brute force: midpoint rule over the cap in (s_z, φ), no substitution (the
        // rim's square-root singularity limits it to ~1e-5 relative).
        let e = ShEval::new(n);
        let ct = (1.0 - a * a).sqrt();
        let (nz, nphi) = (20000usize, 24usize);
        let dz = (1.0 - ct) / nz as f64;
        let mut bf = vec![0.0; 81];
        let (mut ys, mut yq) = (vec![0.0; 9], vec![0.0; 9]);
        for iz in 0..nz {
            let sz = ct + (iz as f64 + 0.5) * dz;
            let r = (1.0 - sz * sz).sqrt();
            let t = sz - (sz * sz - ct * ct).max(0.0).sqrt();
            for ip in 0..nphi {
                let phi = 2.0 * PI * (ip as f64 + 0.5) / nphi as f64;
                let s = [r * phi.cos(), r * phi.sin(), sz];
                let qn = [s[0] * t / a, s[1] * t / a, (s[2] * t - 1.0) / a];
                e.eval_into(s, &mut ys);
                e.eval_into(qn, &mut yq);
                let wt = dz * 2.0 * PI / nphi as f64;
                for j in 0..9 {
                    for k in 0..9 {
                        bf[j * 9 + k] += wt * ys[j] * yq[k];
                    }
                }
            }
        }
        let scale = m.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for (x, y) in m.iter().zip(&bf) {
            assert!((x - y).abs() < 1e-4 * scale, "α={a}: {x} vs {y}");
        }
    }
}

#[test]
fn eta_analysis_matches_brute_force_quadrature() {
    for n in [2usize, 4, 6, 8] {
        let t = TripleProduct::new(n);
        for windowed in [false, true] {
            let light = delta_light(n, windowed);
            for th in [0.01f64, 0.05, 0.3, 1.0] {
                let a = shadow_difference(&t, &light, th);
                let b = reference::shadow_difference_quadrature(n, &light, th);
                assert!((a - b).abs() < 1e-12 * (1.0 + b.abs()), "order {n}: {a} vs {b}");
            }
            // The critical angle sits on the tolerance.
            let e = eta_shadow(&t, 1.0 / 256.0, windowed);
            let d = reference::shadow_difference_quadrature(n, &light, e.theta);
            assert!((d.abs() - 1.0 / 256.0).abs() < 1e-9, "order {n}: ΔS(θ*) = {d}");
            assert!((e.eta - 1.0 / e.theta.sin()).abs() < 1e-12);
        }
    }
    // Unit unshadowed shading by construction.
    let l = delta_light(4, false);
    let h = penumbra_sh::zonal::irradiance_weight(4);
    let u: f64 = l.iter().zip(&h).map(|(a, b)| a * b).sum();
    assert!((u - 1.0).abs() < 1e-14);
}

#[test]
fn eta_order4_is_clearly_larger_than_ibpa_15() {
    let t = TripleProduct::new(4);
    let e = eta_shadow(&t, 1.0 / 256.0, false);
    assert!(e.eta > 25.0 && e.eta < 32.0, "η = {}", e.eta);
    let w = eta_shadow(&t, 1.0 / 256.0, true);
    assert!(w.eta > 20.0 && w.eta <= e.eta, "windowed η = {}", w.eta);
    // η grows with order (peakier lights).
    let e3 = eta_shadow(&TripleProduct::new(3), 1.0 / 256.0, false);
    assert!(e3.eta < e.eta);
    // A looser tolerance needs a smaller sphere of influence.
    assert!(eta_shadow(&t, 1.0 / 64.0, false).eta < e.eta);
}

#[test]
fn eta_env_with_delta_light_reproduces_delta_analysis() {
    // An "environment" that is the order-n delta toward +z: the worst case over normals and
    // blocker directions is the normal and blocker aligned with the light, i.e. the delta
    // analysis — up to the direction sampling of the Fibonacci sets.
    let n = 4;
    let t = TripleProduct::new(n);
    let zh = delta_light(n, false);
    let light = penumbra_sh::zonal::to_sh(&zh);
    let env = eta_shadow_env(&t, &light, 1.0 / 256.0, 400);
    let delta = eta_shadow(&t, 1.0 / 256.0, false);
    assert!((env.eta - delta.eta).abs() / delta.eta < 0.03, "{} vs {}", env.eta, delta.eta);
}

#[test]
fn eta_indirect_is_finite_and_conservative() {
    let e = eta_indirect(1.0 / 256.0);
    assert!(e.eta > 3.0 && e.eta < 20.0, "{}", e.eta);
    assert!((indirect_difference(e.theta) - 1.0 / 256.0).abs() < 1e-9);
    // Below the critical angle the indirect shading is under the tolerance.
    assert!(indirect_difference(0.5 * e.theta) < 1.0 / 256.0);
}

#[test]
fn local_light_lobe_fit() {
    let n = 4;
    let t = TripleProduct::new(n);
    let e = ShEval::new(n);
    // Light on the normal: L_H is zonal about +z, one lobe is exact.
    let lh = local_light(&t, &e, 0.4, 0.0);
    let fit = fit_lobe(&e, &lh);
    // (golden-section search resolves the flat maximum to √ε ≈ 1e-8 in ψ)
    assert!(fit.rel_error < 1e-6 && fit.psi.abs() < 1e-6, "{fit:?}");
    // Off the normal: the band-0 coefficient (unshadowed shading) is always reproduced,
    // and the fit is never worse than putting the lobe on the light's own axis.
    for phi in [0.3f64, 1.0, 2.0] {
        let lh = local_light(&t, &e, 0.3, phi);
        let fit = fit_lobe(&e, &lh);
        let mut rec = vec![0.0; n * n];
        penumbra_math::sh::zh_rotate(&e, &fit.zh, [fit.psi.sin(), 0.0, fit.psi.cos()], &mut rec);
        assert!((rec[0] - lh[0]).abs() < 1e-12);
        // the fit is at least as good as the lobe on the light's own axis (same least-squares
        // lobe, fixed axis): a bound that fails if the axis search is broken
        let axis = [phi.sin(), 0.0, phi.cos()];
        let mut y = vec![0.0; n * n];
        e.eval_into(axis, &mut y);
        let zh: Vec<f64> = (0..n)
            .map(|l| {
                let p: f64 = (l * l..(l + 1) * (l + 1)).map(|i| lh[i] * y[i]).sum();
                p / ((2 * l + 1) as f64 / (4.0 * core::f64::consts::PI)).sqrt()
            })
            .collect();
        let mut rec_axis = vec![0.0; n * n];
        penumbra_math::sh::zh_rotate(&e, &zh, axis, &mut rec_axis);
        let on_axis = (rec_axis.iter().zip(&lh).map(|(a, b)| (a - b) * (a - b)).sum::<f64>()
            / lh.iter().map(|v| v * v).sum::<f64>())
        .sqrt();
        assert!(on_axis > 0.01, "off the normal one lobe is not exact: {on_axis}");
        assert!(fit.rel_error <= on_axis + 1e-9, "φ={phi}: fit {} vs on-axis {on_axis}", fit.rel_error);
    }
    // Unshadowed shading from a small light straight above ≈ ω · H̃(+z), where H̃ is the
    // order-4 reconstruction of max(z,0)/π: Σ_l (2l+1)/4π · Â_l / π = 1.0625/π
    // (Â = π, 2π/3, π/4, 0), i.e. the truncated cosine lobe overshoots by 6.25 %.
    let th = 0.05f64;
    let lh = local_light(&t, &e, th, 0.0);
    let unshadowed = lh[0] * (4.0 * PI).sqrt();
    let want = 2.0 * PI * (1.0 - th.cos()) * 1.0625 / PI;
    assert!((unshadowed - want).abs() / want < 2e-3, "{unshadowed} vs {want}");
}

#[test]
fn smooth_clamp_weights_shape() {
    let w = smooth_clamp_weights(256, 1.0 / 15.0);
    let j = (255.0f64 / 15.0).round() as usize; // 17
    assert_eq!(w[j - 3], 0.0);
    assert!(w[..j - 2].iter().all(|&x| x == 0.0));
    assert!((w[j - 2] - 0.104).abs() < 1e-12 && (w[j + 1] - 0.896).abs() < 1e-12);
    assert!(w[j + 2..].iter().all(|&x| x == 1.0));
    for p in w.windows(2) {
        assert!(p[1] >= p[0]);
    }
}

#[test]
fn smooth_clamp_stays_smooth_at_the_largest_theta_samples() {
    // issue #14: at K = 16384 a ramp of a fixed number of grid cells (5) would be a step in α.
    // The ramp keeps its K = 256 width in α (5/255), i.e. ≈ 5·16383/255 ≈ 321 entries.
    let k = 16384;
    let w = smooth_clamp_weights(k, 1.0 / 15.0);
    let inner = w.iter().filter(|&&x| x > 0.0 && x < 1.0).count();
    assert!((300..=330).contains(&inner), "{inner} ramp entries");
    let first = w.iter().position(|&x| x > 0.0).unwrap();
    let last = w.iter().position(|&x| x == 1.0).unwrap();
    let width = (last - first) as f64 / (k - 1) as f64;
    assert!((width - 5.0 / 255.0).abs() < 2.0 / (k - 1) as f64, "ramp width {width} in α");
    for p in w.windows(2) {
        assert!(p[1] >= p[0] && p[1] - p[0] < 0.01, "a jump of {} in the ramp", p[1] - p[0]);
    }
}

#[test]
fn tables_bake_small() {
    let mut p = TablesParams::new(3);
    p.theta_samples = 64;
    let b = bake(&p, &NoProgress).unwrap();
    let m = &b.metrics;
    assert_eq!(m.gamma_nonzeros, 83);
    assert_eq!(b.cap_log.len(), 64);
    assert!(m.roundtrip_rel_error_eigen < m.roundtrip_rel_error_naive);
    // proxy log-occlusion is forced to zero well below α = 1/η and untouched above.
    let cut = (63.0 / m.eta_shadow).round() as usize;
    assert!(b.proxy_log_occlusion[..cut - 2].iter().all(|v| v.iter().all(|&x| x == 0.0)));
    let top = &b.proxy_log_occlusion[63];
    assert!(top[0] < 0.0);
    assert_eq!(m.cap_log_samples.len(), 4);
    // cap_log_samples are orthonormal ZH of the eigen log: 90° starred table entry agrees.
    let f90 = &m.cap_log_samples[3].f;
    for l in 0..3 {
        let star = f90[l] * penumbra_math::sh::zh_star_scale(l);
        assert!((star - b.cap_log[63][l]).abs() < 1e-12);
    }
    assert!(TablesParams { order: 9, ..p.clone() }.validate().is_err());
    assert!(TablesParams { theta_samples: 8, ..p.clone() }.validate().is_err());
}
