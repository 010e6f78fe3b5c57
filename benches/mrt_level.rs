//! MRT interfaces, level operators and runtime (issue "mrt level"; MRT thesis §3.4, §3.5.3,
//! §3.6.3, Table 3.3). Goals: the interfaces of the cube2d dictionary at the thesis resolution
//! (12² × 24² lightfield samples, 5² supersampling, k_rlf 128, k_r 32, 3 enrichment
//! iterations) ≤ 20 s on 2 cores (thesis: 260 s on 12 cores); the 41-block maze's level
//! operators < 1 s; the runtime for the 41-block maze ≤ 6.2 ms on one core (Table 3.3, x86).
//! Run with `make bench`; figures go to docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_math::progress::NoProgress;
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_transport::asset::to_asset;
use penumbra_transport::dict::{DictParams, bake};
use penumbra_transport::interface::{ShapeInput, bake_interfaces};
use penumbra_transport::level::maze;
use penumbra_transport::level_ops::{DictOps, bake_level};
use penumbra_transport::level_reference::{LevelGeometry, PointLight, direct_at, level_texels};
use penumbra_transport::shape::DictionaryKind;
use std::time::Duration;

fn mrt_level(c: &mut Criterion) {
    // the thesis dictionary with interfaces, baked once
    let p = DictParams::new(DictionaryKind::Cube2d);
    let dict = bake(&p, &NoProgress).expect("dictionary");
    let mut g = c.benchmark_group("mrt_interfaces");
    g.sample_size(10).measurement_time(Duration::from_secs(60)).warm_up_time(Duration::from_secs(1));
    let inputs: Vec<ShapeInput<'_>> =
        dict.shapes.iter().map(|s| ShapeInput { texels: &s.texels, reduced: &s.reduced }).collect();
    let sigma_m: Vec<Vec<f64>> = dict.shapes.iter().map(|s| s.reduced.sigma_m.clone()).collect();
    g.bench_function("cube2d_thesis", |b| {
        b.iter(|| {
            bake_interfaces(&inputs, &sigma_m, p.albedo, p.face_res, &p.interface, p.seed, &NoProgress)
                .map(|i| i.sigma_rlf.len())
        })
    });
    g.finish();

    let bytes = to_asset(&dict, None).expect("asset").to_bytes().expect("bytes");
    let dict_asset = penumbra_asset::OwnedAsset::parse(&bytes).expect("parse");
    let d = DictOps::from_asset(&dict_asset.asset()).expect("dict ops");
    let level = maze(41, 1, &d.missing).expect("maze");
    let links = level.validate(&d.names, &d.missing).expect("valid");
    let mut g = c.benchmark_group("mrt_level");
    g.sample_size(20).measurement_time(Duration::from_secs(10));
    g.bench_function("maze41_depth8", |b| b.iter(|| bake_level(&level, &links, &d, 8).map(|x| x.records.len())));
    g.finish();

    let lb = bake_level(&level, &links, &d, 8).expect("level");
    let lbytes = penumbra_transport::level_ops::to_asset(&level, &links, &d, &lb, serde_json::json!({}), None)
        .expect("asset")
        .to_bytes()
        .expect("bytes");
    let la = penumbra_asset::OwnedAsset::parse(&lbytes).expect("parse");
    let da = dict_asset.asset();
    let rd = MrtDictionary::from_asset(&da).expect("runtime dict");
    let laa = la.asset();
    let rl = MrtLevel::from_asset(&laa, &rd).expect("runtime level");
    let mut rt = MrtRuntime::new(rd, rl);
    let geo = LevelGeometry { level: &level, links: &links, missing: &d.missing };
    let tex = level_texels(&level, &d.missing, d.face_res);
    let lights: Vec<PointLight> = (0..41)
        .step_by(8)
        .map(|b| PointLight { position: level.blocks[b].to_world([0.5; 3]), intensity: 1.0 })
        .collect();
    let l_d: Vec<f32> = direct_at(&geo, &tex, &lights).iter().map(|&x| x as f32).collect();
    let mut out = vec![0.0f32; l_d.len()];
    let mut g = c.benchmark_group("mrt_runtime");
    g.sample_size(50).measurement_time(Duration::from_secs(5));
    // the runtime is single-threaded: one core
    g.bench_function("maze41_one_bounce", |b| b.iter(|| rt.indirect(&l_d, &mut out, true)));
    g.bench_function("maze41_8_bounces", |b| b.iter(|| rt.multi_bounce(&l_d, &mut out, 8, 0.5)));
    g.finish();
}

criterion_group!(benches, mrt_level);
criterion_main!(benches);
