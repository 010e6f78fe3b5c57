//! DRT clutter operators (issue "penumbra drt"; MRT thesis §5.4.4). Goals: the `pillars`
//! scene (one closed room, four five-faced pillars) at 16² texels per face and 1024 rays
//! ≤ 0.5 s on 2 cores (thesis ≈ 5 s on 12 cores); the DRT runtime's cost next to MRT's.
//! Run with `make bench`; figures go to docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_math::progress::NoProgress;
use penumbra_runtime::drt::{DrtOperators, DrtRuntime, Paths};
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_transport::asset::to_asset;
use penumbra_transport::clutter::ClutterScene;
use penumbra_transport::dict::{DictParams, bake};
use penumbra_transport::drt::{DrtDict, DrtParams};
use penumbra_transport::drt_examples::example;
use penumbra_transport::level_ops::{DictOps, bake_level};
use penumbra_transport::shape::DictionaryKind;
use std::time::Duration;

fn drt(c: &mut Criterion) {
    // the thesis dictionary without interfaces (a one-block room needs none), baked once
    let mut p = DictParams::new(DictionaryKind::Cube2d);
    p.interfaces = false;
    let dict = bake(&p, &NoProgress).expect("dictionary");
    let bytes = to_asset(&dict, None).expect("asset").to_bytes().expect("bytes");
    let owned = penumbra_asset::OwnedAsset::parse(&bytes).expect("parse");
    let da = owned.asset();
    let dd = DrtDict::from_asset(&da).expect("drt dict");
    let names: Vec<String> = dd.shapes.iter().map(|s| s.name.clone()).collect();
    let ex = example("pillars", &names, &dd.missing, 0, 0, 0).expect("pillars");
    let links = ex.level.validate(&names, &dd.missing).expect("valid");
    let params = DrtParams::default();
    let scene = ClutterScene::with_basis(&ex.clutter, params.clutter_res, params.clutter_basis_res).expect("clutter");
    let mut g = c.benchmark_group("drt");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("pillars_16x16_1024rays", |b| {
        b.iter(|| {
            penumbra_transport::drt::bake(&ex.level, &links, &dd, &scene, &params, &NoProgress).map(|x| x.du_b.len())
        })
    });
    // moving one pillar (0.75 → 0.62 along x) from the state of a bake: the rays that meet it
    // at either place and its own texels' rays (issue goal: ≤ 0.1 s)
    let inst: Vec<penumbra_transport::drt_state::StateInstance> = ex
        .clutter
        .iter()
        .map(|s| penumbra_transport::drt_state::StateInstance {
            shape_key: "box".into(),
            translate: s.translate,
            rotate: s.rotate,
            scale: s.scale,
        })
        .collect();
    let (_, state) = penumbra_transport::drt::bake_with_state(
        &ex.level,
        &links,
        &dd,
        &scene,
        &params,
        "bench".into(),
        inst,
        &NoProgress,
    )
    .expect("state");
    let mut moved = ex.clutter.clone();
    moved[1].translate[0] = 0.62;
    let new = ClutterScene::with_basis(&moved, params.clutter_res, params.clutter_basis_res).expect("clutter");
    g.bench_function("pillars_move_one_incremental", |b| {
        b.iter_batched(
            || state.clone(),
            |mut st| {
                penumbra_transport::drt::bake_incremental(
                    &ex.level,
                    &links,
                    &dd,
                    &scene,
                    &new,
                    &[1],
                    &mut st,
                    &params,
                    None,
                    &NoProgress,
                )
                .map(|x| x.1.rays_cast)
            },
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();

    // runtime: the baked operators through the asset bytes (needs a dictionary with interfaces
    // for the MRT runtime: bake a small one for the runtime only)
    let mut pi = DictParams::new(DictionaryKind::Cube2d);
    pi.interface.grid.spatial = 4;
    pi.interface.grid.dir = 6;
    pi.interface.grid.sub = 1;
    pi.interface.k_rlf = 24;
    pi.interface.k_r = 8;
    let dict_i = bake(&pi, &NoProgress).expect("dictionary with interfaces");
    let bytes_i = to_asset(&dict_i, None).expect("asset").to_bytes().expect("bytes");
    let owned_i = penumbra_asset::OwnedAsset::parse(&bytes_i).expect("parse");
    let dai = owned_i.asset();
    let ddi = DrtDict::from_asset(&dai).expect("drt dict");
    let ops = DictOps::from_asset(&dai).expect("dict ops");
    let lb = bake_level(&ex.level, &links, &ops, 8).expect("level");
    let lbytes = penumbra_transport::level_ops::to_asset(&ex.level, &links, &ops, &lb, serde_json::json!({}), None)
        .expect("asset")
        .to_bytes()
        .expect("bytes");
    let lo = penumbra_asset::OwnedAsset::parse(&lbytes).expect("parse");
    let b = penumbra_transport::drt::bake(&ex.level, &links, &ddi, &scene, &params, &NoProgress).expect("drt");
    let inputs = penumbra_transport::drt_asset::DrtInputs {
        dict_crc32c: 0,
        level_crc32c: None,
        level: serde_json::json!({}),
        clutter_hashes: vec![],
        clutter: serde_json::json!([]),
    };
    let obytes = penumbra_transport::drt_asset::to_asset(&b, &scene, &inputs, None, None)
        .expect("asset")
        .to_bytes()
        .expect("bytes");
    let oo = penumbra_asset::OwnedAsset::parse(&obytes).expect("parse");
    let (la, oa) = (lo.asset(), oo.asset());
    let rd = MrtDictionary::from_asset(&dai).expect("runtime dict");
    let rl = MrtLevel::from_asset(&la, &rd).expect("runtime level");
    let rops = DrtOperators::from_asset(&oa, &rd, &rl).expect("drt ops");
    let mut mrt = MrtRuntime::new(rd, rl);
    let mut drt = DrtRuntime::new(rops, &mrt);
    let n = mrt.texel_count();
    let m = drt.operators().clutter_texel_count();
    let (l_d, l_dc) = (vec![1.0f32; n], vec![1.0f32; m]);
    let (mut s, mut cl) = (vec![0.0f32; n], vec![0.0f32; m]);
    let mut g = c.benchmark_group("drt_runtime");
    g.sample_size(50).measurement_time(Duration::from_secs(5));
    g.bench_function("pillars_mrt_only", |bch| bch.iter(|| mrt.indirect(&l_d, &mut s, true)));
    g.bench_function("pillars_mrt_plus_drt", |bch| {
        bch.iter(|| drt.one_bounce(&mut mrt, &l_d, &l_dc, 0, 1.0, Paths::ALL, &mut s, &mut cl))
    });
    g.finish();
}

criterion_group!(benches, drt);
criterion_main!(benches);
