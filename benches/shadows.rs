//! Sphere-proxy shadow runtime cost per receiver (issue "Soft-shadow runtime": ≤ 2 µs for 64
//! spheres at order 4 on one core without the hierarchy; the cost with it stated).
//!
//! Setup (not timed): order-4 tables baked in-process; 64 spheres with a hierarchy fitted to the
//! procedural demo character; a 64×64 ground-plane grid of receivers under it, lit by a
//! synthetic order-4 environment. `cargo bench --bench shadows` (part of `make bench`).

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_asset::OwnedAsset;
use penumbra_geometry::Scene;
use penumbra_math::progress::NoProgress;
use penumbra_runtime::shadows::{CutBlocker, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{NodeRef, ShTables, SphereSet, SphereTree};
use std::hint::black_box;
use std::time::Duration;

fn shadows(c: &mut Criterion) {
    let order = 4;
    let tb = penumbra_sh::tables::bake(&penumbra_sh::tables::TablesParams::new(order), &NoProgress).unwrap();
    let tables_bytes = penumbra_sh::tables_asset::to_asset(&tb, None).unwrap().to_bytes().unwrap();
    let tables_owned = OwnedAsset::parse(&tables_bytes).unwrap();
    let tables_asset = tables_owned.asset();
    let tables = ShTables::from_asset(&tables_asset).unwrap();
    let scene = Scene { mesh: penumbra_geometry::procedural::character(36), ..Scene::default() };
    let mut p = penumbra_spheres::FitParams::new(penumbra_spheres::Target::Count(64));
    p.hierarchy = true;
    p.iterations = 30;
    let fit = penumbra_spheres::fit(&scene, &p, &NoProgress).unwrap();
    let meta = serde_json::json!({"kind": "SPHR"});
    let sphr = penumbra_spheres::asset::to_asset(&fit, &meta).unwrap().to_bytes().unwrap();
    let sphr_owned = OwnedAsset::parse(&sphr).unwrap();
    let sphr_asset = sphr_owned.asset();
    let set = SphereSet::from_asset(&sphr_asset).unwrap();
    let leaves: Vec<Sphere> = (0..set.len()).map(|i| set.leaf(i)).collect();
    // a sky-like light: bright above, some colour gradient
    let mut light = vec![[0.0f32; 3]; order * order];
    light[0] = [3.0, 3.2, 3.5];
    light[2] = [1.0, 1.1, 1.3];
    light[3] = [0.3, 0.2, 0.1];
    let ev = ShadowEvaluator::new(&tables, &light, ShadowOptions::default());
    let res = 64usize;
    let receivers: Vec<[f32; 3]> = (0..res * res)
        .map(|k| {
            [
                -1.2 + 2.4 * ((k % res) as f32 + 0.5) / res as f32,
                0.0,
                -1.2 + 2.4 * ((k / res) as f32 + 0.5) / res as f32,
            ]
        })
        .collect();
    let n = [0.0f32, 1.0, 0.0];
    let mut g = c.benchmark_group("shadow_runtime_per_4096_receivers");
    g.sample_size(10).measurement_time(Duration::from_secs(6)).warm_up_time(Duration::from_secs(1));
    g.bench_function("64_spheres_order4_hyb_no_hierarchy", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for &p in &receivers {
                acc += ev.irradiance(p, n, black_box(&leaves))[0];
            }
            acc
        })
    });
    let n2 = order * order;
    g.bench_function("parts_accumulate_only", |b| {
        let mut f = vec![0.0f32; n2];
        b.iter(|| {
            let mut acc = 0.0f32;
            for &p in &receivers {
                ev.accumulate_log(p, n, black_box(&leaves), &mut f);
                acc += f[0];
            }
            acc
        })
    });
    let mut fs = vec![vec![0.0f32; n2]; receivers.len()];
    for (k, &p) in receivers.iter().enumerate() {
        ev.accumulate_log(p, n, &leaves, &mut fs[k]);
    }
    g.bench_function("parts_exp_only", |b| {
        let mut gg = vec![0.0f32; n2];
        b.iter(|| {
            let mut acc = 0.0f32;
            for f in &fs {
                ev.exponentiate(black_box(f), &mut gg);
                acc += gg[0];
            }
            acc
        })
    });
    g.bench_function("parts_shade_only", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for f in &fs {
                acc += ev.shade(n, black_box(f))[0];
            }
            acc
        })
    });
    // hierarchy: 8×8-receiver tiles, θ_max = 25°; cut and ratio vectors counted in the time
    let sin_max = 25f32.to_radians().sin();
    g.bench_function("64_spheres_order4_hyb_hierarchy_tiles8", |b| {
        let mut stack: Vec<NodeRef> = Vec::new();
        let mut cut: Vec<NodeRef> = Vec::new();
        let mut blockers: Vec<CutBlocker> = Vec::new();
        b.iter(|| {
            let mut acc = 0.0f32;
            for ty in 0..res / 8 {
                for tx in 0..res / 8 {
                    let center = receivers[(ty * 8 + 4) * res + tx * 8 + 4];
                    let r_r = 2.4 / res as f32 * 8.0 * std::f32::consts::FRAC_1_SQRT_2;
                    set.cut(center, r_r, sin_max, &mut stack, &mut cut);
                    ev.cluster_blockers(&set, &cut, center, n, &mut blockers);
                    for y in 0..8 {
                        for x in 0..8 {
                            acc += ev.irradiance_blockers(receivers[(ty * 8 + y) * res + tx * 8 + x], n, &blockers)[0];
                        }
                    }
                }
            }
            acc
        })
    });
    // Batched (8 receivers per call-step, structure of arrays; same results bit for bit).
    let normals = vec![n; receivers.len()];
    g.bench_function("64_spheres_order4_hyb_no_hierarchy_batched", |b| {
        let mut out = vec![[0.0f32; 3]; receivers.len()];
        b.iter(|| {
            ev.irradiance_batch(&receivers, &normals, black_box(&leaves), &mut out);
            out[0][0]
        })
    });
    g.bench_function("64_spheres_order4_hyb_hierarchy_tiles8_batched", |b| {
        let mut stack: Vec<NodeRef> = Vec::new();
        let mut cut: Vec<NodeRef> = Vec::new();
        let mut blockers: Vec<CutBlocker> = Vec::new();
        let mut tile_p = vec![[0.0f32; 3]; 64];
        let tile_n = vec![n; 64];
        let mut out = vec![[0.0f32; 3]; 64];
        b.iter(|| {
            let mut acc = 0.0f32;
            for ty in 0..res / 8 {
                for tx in 0..res / 8 {
                    let center = receivers[(ty * 8 + 4) * res + tx * 8 + 4];
                    let r_r = 2.4 / res as f32 * 8.0 * std::f32::consts::FRAC_1_SQRT_2;
                    set.cut(center, r_r, sin_max, &mut stack, &mut cut);
                    ev.cluster_blockers(&set, &cut, center, n, &mut blockers);
                    for y in 0..8 {
                        for x in 0..8 {
                            tile_p[y * 8 + x] = receivers[(ty * 8 + y) * res + tx * 8 + x];
                        }
                    }
                    ev.irradiance_blockers_batch(&tile_p, &tile_n, &blockers, &mut out);
                    acc += out[0][0];
                }
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, shadows);
criterion_main!(benches);
