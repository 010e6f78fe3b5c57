//! FIV bake and runtime (issue 5: 128×65×30 with a 6×32×32 environment on the 69k-triangle
//! stanford-bunny in ≤ 10 s on 2 cores; paper: 99 min; issue 15 §4: ≤ 2.5 s, same bytes).
//! Run with `make bench`; figures go to docs/benchmarks.md. Uses `../shared/data` (stanford-bunny.obj, grace_latlong.exr) when
//! present, else the procedural torus under the procedural area lights.
#![allow(clippy::print_stderr)]

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_fiv::asset::AssetInputs;
use penumbra_fiv::{Culling, FivParams, Lighting, Occluder, Shard, ShellLayout, Storage, UpAxis, bake_with};
use penumbra_geometry::env::Rotation;
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

criterion_group!(benches, bake, runtime);
criterion_main!(benches);
