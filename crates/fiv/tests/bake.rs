//! The FIV bake against independent answers: the brute-force reference (a ray to every
//! texel), the analytic FIV of a sphere's cap, exact inside flags, shard/merge bytes and
//! thread-count independence.

use penumbra_asset::Asset;
use penumbra_fiv::asset::AssetInputs;
use penumbra_fiv::reference::occluded_fiv;
use penumbra_fiv::*;
use penumbra_geometry::procedural::{torus, uv_sphere};
use penumbra_geometry::{CubeMap, TriMesh};
use penumbra_math::progress::NoProgress;
use std::f64::consts::PI;

/// A smooth, non-constant environment (so every texel weight differs).
fn env(size: usize) -> Lighting {
    let probe = CubeMap::constant(size, [0.0; 3]);
    let texels = probe
        .iter()
        .map(|(_, d, _, _)| [(1.0 + d[1]) as f32, (1.5 + 0.5 * d[0]) as f32, (0.2 + d[2] * d[2]) as f32])
        .collect();
    Lighting::new(CubeMap::from_texels(size, texels).unwrap())
}

fn params(a: usize, p: usize, k: usize, r_min: f64, r_max: f64) -> FivParams {
    FivParams {
        layout: ShellLayout { azimuth: a, polar: p, radial: k, r_min, r_max, up: UpAxis::Y },
        irradiance_size: 8,
    }
}

fn to_bytes(b: &FivBake, light: &Lighting, mesh: &TriMesh, storage: Storage) -> Vec<u8> {
    let inp = AssetInputs {
        inputs: serde_json::json!({"mesh": "test"}),
        cache_key: Some("k".into()),
        storage,
        env_cube: light.cube().texels(),
        mesh,
    };
    to_asset(b, &inp).unwrap().to_bytes().unwrap()
}

#[test]
fn fast_path_matches_brute_force_everywhere() {
    // a torus tilted off the axes: holes, concavities, samples inside the ball and inside
    // the solid (r_min = 0.3)
    let mut mesh = torus([0.1, -0.2, 0.05], 1.0, 0.35, 40, 20);
    mesh.map_positions(|[x, y, z]| [x, 0.8 * y + 0.6 * z, -0.6 * y + 0.8 * z]);
    let occ = Occluder::new(mesh).unwrap();
    let light = env(12);
    let p = params(7, 5, 4, 0.3, 2.5);
    // culling forced on: silhouette skips and interior certificates must change nothing
    let b = bake_with(&occ, &light, &p, Shard::WHOLE, &NoProgress, Culling::Always).unwrap();
    assert!(b.stats.rays_certified > 0);
    let power = light.power().iter().sum::<f64>();
    let l = p.layout;
    let f = occ.frame();
    let mut checked = 0;
    for i in 0..l.azimuth {
        for j in 0..l.polar {
            for k in 0..l.radial {
                let s = l.index(i, j, k);
                let pos = l.position(&f, i, j, k);
                let inside = occ.is_inside(pos);
                assert_eq!(b.inside[s] == 1, inside && l.rho_over_r(k) <= 1.0, "sample {i},{j},{k}");
                if b.inside[s] == 1 {
                    assert!(b.fiv[s * 9..s * 9 + 9].iter().all(|&v| v == 0.0));
                    continue;
                }
                let r = occluded_fiv(&occ, &light, pos);
                for c in 0..3 {
                    for x in 0..3 {
                        let got = b.fiv[s * 9 + c * 3 + x] as f64;
                        assert!(
                            (got - r[c][x]).abs() <= 1e-6 * power,
                            "sample {i},{j},{k} [{c}][{x}]: {got} vs {}",
                            r[c][x]
                        );
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 100);
    // the culled traversal casts far fewer rays than one per texel and sample
    assert!(b.stats.rays_traced < (checked * light.texel_count()) as u64 / 3, "{:?}", b.stats);
    assert!(b.stats.rays_hit > 0);
}

#[test]
fn silhouette_culling_changes_no_bit() {
    let mesh = torus([0.0; 3], 1.0, 0.3, 48, 24);
    let occ = Occluder::new(mesh).unwrap();
    let light = env(16);
    let culled = FivTracer::new(&occ, &light, true);
    let plain = FivTracer::new(&occ, &light, false);
    assert!(culled.culls() && !plain.culls());
    let l = params(9, 7, 5, 1.0, 4.0).layout;
    let (mut rc, mut rp, mut certified) = (0, 0, 0);
    for i in 0..l.azimuth {
        for j in 0..l.polar {
            for k in 0..l.radial {
                let p = l.position(&occ.frame(), i, j, k);
                let (a, sa) = culled.fiv(p);
                let (b, sb) = plain.fiv(p);
                assert_eq!(a, b, "sample {i},{j},{k}");
                assert_eq!(sa.rays_hit, sb.rays_hit);
                assert_eq!(sb.rays_certified, 0);
                rc += sa.rays_traced;
                rp += sb.rays_traced;
                certified += sa.rays_certified;
            }
        }
    }
    assert!(rc < rp, "culling removed no ray ({rc} vs {rp})");
    assert!(certified > 0, "no hit certified");
}

#[test]
fn texel_major_blocks_give_each_sample_alone_bit_for_bit() {
    // the bake traces blocks of 256 rows texel-major; 40 × 9 = 360 rows make a full block and
    // a partial one. Every stored FIV must be the f32 of what the tracer computes for that
    // sample alone, and the counters their sum.
    let mut mesh = torus([0.05, 0.0, -0.1], 1.0, 0.35, 32, 16);
    mesh.map_positions(|[x, y, z]| [x, 0.6 * y - 0.8 * z, 0.8 * y + 0.6 * z]);
    let occ = Occluder::new(mesh).unwrap();
    let light = env(8);
    // r_min 0.74: the innermost shell runs through the tube (inside samples)
    let p = params(40, 9, 4, 0.74, 3.0);
    let b = bake_with(&occ, &light, &p, Shard::WHOLE, &NoProgress, Culling::Always).unwrap();
    let tracer = FivTracer::new(&occ, &light, true);
    let l = p.layout;
    let mut sum = BakeStats::default();
    for i in 0..l.azimuth {
        for j in 0..l.polar {
            for k in 0..l.radial {
                let s = l.index(i, j, k);
                if b.inside[s] == 1 {
                    continue;
                }
                let (f, st) = tracer.fiv(l.position(&occ.frame(), i, j, k));
                for c in 0..3 {
                    for x in 0..3 {
                        assert_eq!(b.fiv[s * 9 + c * 3 + x].to_bits(), (f[c][x] as f32).to_bits(), "{i},{j},{k}");
                    }
                }
                sum.rays_traced += st.rays_traced;
                sum.rays_hit += st.rays_hit;
                sum.rays_certified += st.rays_certified;
            }
        }
    }
    assert!(b.stats.inside_samples > 0 && sum.rays_certified > 0);
    assert_eq!(
        (b.stats.rays_traced, b.stats.rays_hit, b.stats.rays_certified),
        (sum.rays_traced, sum.rays_hit, sum.rays_certified)
    );
}

#[test]
fn half_ktx2_export_refuses_values_beyond_f16() {
    // a bright environment: occluded FIVs ~ 1e6 sr·radiance, beyond f16's 65504
    let occ = Occluder::new(uv_sphere([0.0; 3], 1.0, 8, 16)).unwrap();
    let light = Lighting::new(CubeMap::constant(8, [1e6, 1.0, 1.0]));
    let b = bake(&occ, &light, &params(8, 5, 3, 1.0, 3.0), Shard::WHOLE, &NoProgress).unwrap();
    let bytes = to_bytes(&b, &light, occ.mesh(), Storage::F32);
    let owned = penumbra_asset::OwnedAsset::parse(&bytes).unwrap();
    let asset = owned.asset();
    use penumbra_fiv::ktx2::{TexelFormat, to_ktx2_as};
    let full = to_ktx2_as(&asset, "t", TexelFormat::Rgba32F).unwrap();
    assert_eq!(u32::from_le_bytes(full[12..16].try_into().unwrap()), 109);
    let e = to_ktx2_as(&asset, "t", TexelFormat::Rgba16F).unwrap_err().to_string();
    assert!(e.contains("65504"), "{e}");
    // a dim one fits, and is half the level size
    let light = Lighting::new(CubeMap::constant(8, [1.0, 2.0, 0.5]));
    let b = bake(&occ, &light, &params(8, 5, 3, 1.0, 3.0), Shard::WHOLE, &NoProgress).unwrap();
    let bytes = to_bytes(&b, &light, occ.mesh(), Storage::F32);
    let owned = penumbra_asset::OwnedAsset::parse(&bytes).unwrap();
    let (f32_len, f16_len) = (
        to_ktx2_as(&owned.asset(), "t", TexelFormat::Rgba32F).unwrap().len(),
        to_ktx2_as(&owned.asset(), "t", TexelFormat::Rgba16F).unwrap(),
    );
    assert_eq!(u32::from_le_bytes(f16_len[12..16].try_into().unwrap()), 97);
    let level = 8 * 5 * 9 * 8;
    assert!(f16_len.len() >= level && f32_len >= 2 * level && f32_len - f16_len.len() >= level - 16);
}

#[test]
fn sphere_cap_fiv_matches_the_analytic_integral() {
    // a sphere of radius 1 seen from distance ρ hides the cap of half-angle α = asin(1/ρ);
    // under constant radiance L, FIV = L·∫_cap ω dΩ = L·π sin²α toward the centre
    let mesh = uv_sphere([0.0; 3], 1.0, 64, 128);
    let occ = Occluder::new(mesh).unwrap();
    assert!((occ.frame().radius - 1.0).abs() < 1e-9);
    let light = Lighting::new(CubeMap::constant(48, [2.0, 1.0, 0.5]));
    let tracer = FivTracer::new(&occ, &light, false);
    for (rho, dir) in [(2.0, [0.0, 1.0, 0.0]), (3.0, [0.6, 0.0, 0.8]), (1.5, [-0.48, 0.6, -0.64])] {
        let p = [rho * dir[0], rho * dir[1], rho * dir[2]];
        let (fiv, _) = tracer.fiv(p);
        let sin2 = 1.0 / (rho * rho);
        for (c, l) in [2.0, 1.0, 0.5].into_iter().enumerate() {
            for x in 0..3 {
                let exact = -l * PI * sin2 * dir[x];
                // discretisation: texels straddling the cap's rim
                assert!(
                    (fiv[c][x] - exact).abs() < 0.02 * l * PI * sin2,
                    "ρ={rho} [{c}][{x}] {} vs {exact}",
                    fiv[c][x]
                );
            }
        }
    }
}

/// An inside-out sphere (every triangle reversed: winding number −1 inside) is flagged the
/// same as the outward one.
#[test]
fn inside_flags_do_not_depend_on_the_winding() {
    let mut mesh = uv_sphere([0.5, 0.0, 0.0], 1.0, 32, 64);
    let light = env(4);
    let p = params(4, 3, 7, 0.0, 1.5);
    let outward = bake(&Occluder::new(mesh.clone()).unwrap(), &light, &p, Shard::WHOLE, &NoProgress).unwrap();
    for t in &mut mesh.indices {
        t.swap(1, 2);
    }
    let inverted = bake(&Occluder::new(mesh).unwrap(), &light, &p, Shard::WHOLE, &NoProgress).unwrap();
    assert_eq!(outward.stats.inside_samples, 4 * 3 * 4);
    assert_eq!(inverted.inside, outward.inside);
    assert_eq!(inverted.fiv, outward.fiv);
}

#[test]
fn inside_flags_of_a_sphere() {
    let mesh = uv_sphere([0.5, 0.0, 0.0], 1.0, 32, 64);
    let occ = Occluder::new(mesh).unwrap();
    let light = env(4);
    // shells at ρ/R = 0, 0.25, …, 1.5: the first four are inside (ρ ≤ 0.75 < the facets)
    let p = params(4, 3, 7, 0.0, 1.5);
    let b = bake(&occ, &light, &p, Shard::WHOLE, &NoProgress).unwrap();
    let l = p.layout;
    for i in 0..4 {
        for j in 0..3 {
            for k in 0..7 {
                let expect = k <= 3;
                assert_eq!(b.inside[l.index(i, j, k)] == 1, expect, "{i},{j},{k}");
            }
        }
    }
    assert_eq!(b.stats.inside_samples, 4 * 3 * 4);
}

#[test]
fn shards_merge_into_the_single_run_bytes() {
    let mesh = torus([0.0; 3], 1.0, 0.4, 24, 12);
    let occ = Occluder::new(mesh.clone()).unwrap();
    let light = env(6);
    let p = params(7, 5, 3, 1.0, 3.0);
    for storage in [Storage::F32, Storage::F16] {
        let whole = to_bytes(&bake(&occ, &light, &p, Shard::WHOLE, &NoProgress).unwrap(), &light, &mesh, storage);
        let shards: Vec<Vec<u8>> = (0..3)
            .map(|k| {
                let b = bake(&occ, &light, &p, Shard { index: k, count: 3 }, &NoProgress).unwrap();
                to_bytes(&b, &light, &mesh, storage)
            })
            .collect();
        // a shard is refused by readers that do not know shards (critical section)
        let a0 = Asset::parse(&shards[0]).unwrap();
        assert!(a0.require_known(&["fiv", "inside"]).is_err());
        // any order
        let parsed: Vec<Asset<'_>> = [2, 0, 1].iter().map(|&i| Asset::parse(&shards[i]).unwrap()).collect();
        let merged = merge(&parsed).unwrap().to_bytes().unwrap();
        assert!(merged == whole, "merged shards differ from the single run ({storage:?})");
        // missing or duplicated shards are refused
        let two: Vec<Asset<'_>> = [0, 1].iter().map(|&i| Asset::parse(&shards[i]).unwrap()).collect();
        assert!(merge(&two).unwrap_err().to_string().contains("exactly once"));
        let dup: Vec<Asset<'_>> = [0, 1, 1].iter().map(|&i| Asset::parse(&shards[i]).unwrap()).collect();
        assert!(merge(&dup).is_err());
        // a whole bake is not a shard
        assert!(merge(&[Asset::parse(&whole).unwrap()]).unwrap_err().to_string().contains("not a shard"));
    }
    // shards of different bakes are refused
    let other = params(7, 5, 3, 1.0, 4.0);
    let s0 = to_bytes(
        &bake(&occ, &light, &p, Shard { index: 0, count: 2 }, &NoProgress).unwrap(),
        &light,
        &mesh,
        Storage::F32,
    );
    let s1 = to_bytes(
        &bake(&occ, &light, &other, Shard { index: 1, count: 2 }, &NoProgress).unwrap(),
        &light,
        &mesh,
        Storage::F32,
    );
    let e = merge(&[Asset::parse(&s0).unwrap(), Asset::parse(&s1).unwrap()]).unwrap_err();
    assert!(e.to_string().contains("different bake"), "{e}");
}

#[test]
fn same_bytes_for_any_thread_count() {
    let mesh = torus([0.0; 3], 1.0, 0.4, 24, 12);
    let occ = Occluder::new(mesh.clone()).unwrap();
    let light = env(8);
    let p = params(8, 5, 4, 0.5, 3.0);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            to_bytes(&bake(&occ, &light, &p, Shard::WHOLE, &NoProgress).unwrap(), &light, &mesh, Storage::F32)
        })
    };
    assert!(run(1) == run(3));
}

#[test]
fn half_storage_rounds_each_value_and_rejects_overflow() {
    let mesh = torus([0.0; 3], 1.0, 0.4, 24, 12);
    let occ = Occluder::new(mesh.clone()).unwrap();
    let light = env(6);
    let p = params(4, 3, 2, 1.0, 2.0);
    let b = bake(&occ, &light, &p, Shard::WHOLE, &NoProgress).unwrap();
    let bytes = to_bytes(&b, &light, &mesh, Storage::F16);
    let a = Asset::parse(&bytes).unwrap();
    let s = a.section("fiv").unwrap();
    assert_eq!(s.dtype(), penumbra_asset::DType::F16);
    assert_eq!(s.dims(), &[4, 3, 2, 3, 3]);
    let v = s.to_f32_vec().unwrap();
    for (h, f) in v.iter().zip(&b.fiv) {
        assert!((h - f).abs() <= f.abs() * 1e-3 + 1e-7);
    }
    let bright = Lighting::new(CubeMap::constant(6, [1e6, 1.0, 1.0]));
    let b = bake(&occ, &bright, &p, Shard::WHOLE, &NoProgress).unwrap();
    let inp = AssetInputs {
        inputs: serde_json::json!(null),
        cache_key: None,
        storage: Storage::F16,
        env_cube: bright.cube().texels(),
        mesh: &mesh,
    };
    assert!(matches!(to_asset(&b, &inp), Err(FivError::HalfOverflow { .. })));
}

/// Several environments from one visibility pass: each table has exactly the bytes of a bake
/// under that environment alone, with the ray counters of one bake.
#[test]
fn many_environments_one_visibility_pass_give_the_single_bakes_bytes() {
    let occ = Occluder::new(torus([0.1, 0.0, 0.0], 1.0, 0.3, 24, 12)).unwrap();
    let a = env(8);
    let probe = CubeMap::constant(8, [0.0; 3]);
    let texels = probe.iter().map(|(_, d, _, _)| [(2.0 - d[0]) as f32, 0.3, (1.0 + d[2] * d[1]) as f32]).collect();
    let b = Lighting::new(CubeMap::from_texels(8, texels).unwrap());
    let p = params(8, 5, 4, 0.5, 3.0);
    for culling in [Culling::Never, Culling::Always] {
        let multi = bake_multi(&occ, &[&a, &b], &p, Shard::WHOLE, &NoProgress, culling).unwrap();
        let one_a = bake_with(&occ, &a, &p, Shard::WHOLE, &NoProgress, culling).unwrap();
        let one_b = bake_with(&occ, &b, &p, Shard::WHOLE, &NoProgress, culling).unwrap();
        assert_eq!(multi.len(), 2);
        for (m, o) in multi.iter().zip([&one_a, &one_b]) {
            assert_eq!(m.fiv, o.fiv);
            assert_eq!(m.inside, o.inside);
            assert_eq!(m.irradiance, o.irradiance);
            assert_eq!(m.env_fiv, o.env_fiv);
            assert_eq!(m.stats, o.stats);
        }
        assert_ne!(multi[0].fiv, multi[1].fiv);
    }
    // environments of different cube sizes cannot share directions
    assert!(bake_multi(&occ, &[&a, &env(4)], &p, Shard::WHOLE, &NoProgress, Culling::Auto).is_err());
}
