//! FIV bake and runtime (issue 5: 128×65×30 with a 6×32×32 environment on the 69k-triangle
//! stanford-bunny in ≤ 10 s on 2 cores; paper: 99 min; issue 15 §4: ≤ 2.5 s, same bytes).
//! Run with `make bench`; figures go to docs/benchmarks.md. Uses `../shared/data` (stanford-bunny.obj, grace_latlong.exr) when
//! present, else the procedural torus under the procedural area lights.
#![allow(clippy::print_stderr)]

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_fiv::asset::AssetInputs;
use penumbra_fiv::{Culling, FivParams, Lighting, Occluder, Shard, ShellLayout, Storage, UpAxis, bake_with};
use penumbra_geometry::env::Rotation;
use penumbra_geometry::packet::StreamScratch;
use penumbra_geometry::{CubeMap, EnvMap, TriMesh};
use penumbra_math::progress::NoProgress;
use penumbra_runtime::fiv::{FivShader, FivTable, PlacedOccluder, ShadeOptions};
use std::time::Duration;

fn inputs() -> (String, TriMesh, EnvMap) {
    let data = penumbra_testkit::shared_data_dir();
    let mesh = penumbra_geometry::load_mesh(data.join("meshes/stanford-bunny.obj"));
    let env = penumbra_geometry::load_env_map(data.join("env/grace_latlong.exr"));
    match (mesh, env) {
        (Ok((scene, _)), Ok((env, _))) => {
            ("stanford-bunny/grace".into(), scene.mesh, env.rotated(Rotation::Z180).unwrap_or(env))
        }
        _ => {
            eprintln!("shared data absent: benchmarking the procedural torus under area lights");
            (
                "torus/area-lights".into(),
                penumbra_geometry::procedural::torus([0.0; 3], 1.0, 0.35, 256, 128),
                penumbra_geometry::env::procedural::area_lights(512, 256),
            )
        }
    }
}

/// Everything `penumbra fiv` does after reading its two input files.
fn full_bake(mesh: &TriMesh, env: &EnvMap, samples: [usize; 3], culling: Culling) -> usize {
    let occ = Occluder::new(mesh.clone()).expect("valid mesh");
    let light = Lighting::new(CubeMap::from_latlong(env, 32));
    let layout = ShellLayout {
        azimuth: samples[0],
        polar: samples[1],
        radial: samples[2],
        r_min: 1.0,
        r_max: 8.0,
        up: UpAxis::Y,
    };
    let params = FivParams { layout, irradiance_size: 32 };
    let b = bake_with(&occ, &light, &params, Shard::WHOLE, &NoProgress, culling).expect("bake");
    let inp = AssetInputs {
        inputs: serde_json::json!(null),
        cache_key: None,
        storage: Storage::F32,
        env_cube: light.cube().texels(),
        mesh,
    };
    penumbra_fiv::to_asset(&b, &inp).expect("asset").to_bytes().expect("bytes").len()
}

fn bake(c: &mut Criterion) {
    let (name, mesh, env) = inputs();
    let mut g = c.benchmark_group(format!("fiv_bake/{name}"));
    g.sample_size(10).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(1));
    for s in [[32, 17, 15], [64, 33, 30], [128, 65, 30]] {
        g.bench_function(format!("{}x{}x{}", s[0], s[1], s[2]), |b| {
            b.iter(|| full_bake(&mesh, &env, s, Culling::Auto))
        });
    }
    // the bounding cone alone, for the speed-up of the silhouette culling and certificates
    g.bench_function("128x65x30_cone_only", |b| b.iter(|| full_bake(&mesh, &env, [128, 65, 30], Culling::Never)));
    g.finish();
}

fn runtime(c: &mut Criterion) {
    let mesh = penumbra_geometry::procedural::torus([0.0; 3], 1.0, 0.35, 64, 32);
    let occ = Occluder::new(mesh.clone()).expect("valid mesh");
    let light = Lighting::new(CubeMap::from_latlong(&penumbra_geometry::env::procedural::area_lights(256, 128), 32));
    let layout = ShellLayout { azimuth: 64, polar: 33, radial: 30, r_min: 1.0, r_max: 8.0, up: UpAxis::Y };
    let b =
        bake_with(&occ, &light, &FivParams { layout, irradiance_size: 32 }, Shard::WHOLE, &NoProgress, Culling::Auto)
            .expect("bake");
    let inp = AssetInputs {
        inputs: serde_json::json!(null),
        cache_key: None,
        storage: Storage::F32,
        env_cube: light.cube().texels(),
        mesh: &mesh,
    };
    let bytes = penumbra_fiv::to_asset(&b, &inp).expect("asset").to_bytes().expect("bytes");
    let owned = penumbra_asset::OwnedAsset::parse(&bytes).expect("parse");
    let asset = owned.asset();
    let table = FivTable::from_asset(&asset).expect("table");
    let receivers: Vec<[f32; 3]> =
        (0..4096).map(|i| [(i % 64) as f32 * 0.1 - 3.2, -0.35, (i / 64) as f32 * 0.1 - 3.2]).collect();
    let mut g = c.benchmark_group("fiv_runtime");
    g.sample_size(20);
    for n in [1usize, 2, 4] {
        let occs: Vec<PlacedOccluder<'_, '_>> =
            (0..n).map(|k| PlacedOccluder::translated(&table, [1.2 * k as f32, 0.0, 0.7 * k as f32])).collect();
        g.bench_function(format!("4096_receivers_{n}_occluders"), |bch| {
            let mut sh = FivShader::new();
            bch.iter(|| {
                let mut acc = 0.0f32;
                for p in &receivers {
                    acc += sh.irradiance(&occs, *p, [0.0, 1.0, 0.0], ShadeOptions::default())[1];
                }
                acc
            })
        });
    }
    g.finish();
}

/// The bake's ray queries alone (issue 15 §4, second pass): the bounding-cone rays of a
/// 32×17×15 layout around the occluder toward every texel of the 6×32×32 cube, bundled by
/// texel (one direction, many origins), cast three ways with the same booleans (asserted):
/// one by one through the CWBVH (`MeshBvh::any_hit_prepared`, what the bake does), as one
/// stream per texel through `ParallelBvh::any_hits`, and one by one through its 4-wide tree.
fn rays(c: &mut Criterion) {
    let (name, mesh, env) = inputs();
    let occ = Occluder::new(mesh).expect("valid mesh");
    let light = Lighting::new(CubeMap::from_latlong(&env, 32));
    let layout = ShellLayout { azimuth: 32, polar: 17, radial: 15, r_min: 1.0, r_max: 8.0, up: UpAxis::Y };
    let f = occ.frame();
    let samples: Vec<[f64; 3]> = (0..32)
        .flat_map(|i| (0..17).flat_map(move |j| (0..15).map(move |k| (i, j, k))))
        .map(|(i, j, k)| layout.position(&f, i, j, k))
        .collect();
    // per texel: the samples whose bounding cone admits it (the rays the bake considers)
    let bundles: Vec<(usize, Vec<[f64; 3]>)> = (0..light.texel_count())
        .map(|t| {
            let d = light.direction(t);
            let o: Vec<[f64; 3]> = samples
                .iter()
                .copied()
                .filter(|p| {
                    let to_c = [f.center[0] - p[0], f.center[1] - p[1], f.center[2] - p[2]];
                    let rho = (to_c[0] * to_c[0] + to_c[1] * to_c[1] + to_c[2] * to_c[2]).sqrt();
                    let cos = (to_c[0] * d[0] + to_c[1] * d[1] + to_c[2] * d[2]) / rho;
                    rho <= f.radius || cos >= (1.0 - (f.radius / rho).powi(2)).max(0.0).sqrt()
                })
                .collect();
            (t, o)
        })
        .collect();
    let n_rays: usize = bundles.iter().map(|b| b.1.len()).sum();
    let bvh = occ.bvh();
    let par = bvh.parallel_bvh();
    let cw = || {
        let mut stack = bvh.traversal_stack();
        let mut hits = 0usize;
        for (t, o) in &bundles {
            for p in o {
                hits += bvh.any_hit_prepared(*p, light.prepared(*t), 0.0, f64::INFINITY, &mut stack) as usize;
            }
        }
        hits
    };
    let stream = || {
        let mut scratch = StreamScratch::default();
        let mut out = Vec::new();
        let mut hits = 0usize;
        for (t, o) in &bundles {
            out.clear();
            out.resize(o.len(), false);
            par.any_hits(o, light.prepared(*t), 0.0, f64::INFINITY, &mut out, &mut scratch);
            hits += out.iter().filter(|h| **h).count();
        }
        hits
    };
    let wide = || {
        let mut hits = 0usize;
        for (t, o) in &bundles {
            for p in o {
                hits += par.any_hit(*p, light.prepared(*t), 0.0, f64::INFINITY) as usize;
            }
        }
        hits
    };
    let want = cw();
    assert_eq!(stream(), want, "stream traversal disagrees with the CWBVH");
    assert_eq!(wide(), want, "4-wide traversal disagrees with the CWBVH");
    eprintln!("fiv_rays/{name}: {n_rays} cone rays in {} bundles, {want} hits", bundles.len());
    let mut g = c.benchmark_group(format!("fiv_rays/{name}"));
    g.sample_size(10).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(1));
    g.bench_function("cwbvh_one_by_one", |b| b.iter(cw));
    g.bench_function("parallel_stream", |b| b.iter(stream));
    g.bench_function("parallel_4wide_one_by_one", |b| b.iter(wide));
    g.finish();
}

criterion_group!(benches, bake, runtime, rays);
criterion_main!(benches);
