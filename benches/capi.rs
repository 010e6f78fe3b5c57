//! Per-receiver cost through the C ABI (`penumbra-capi`) next to the direct Rust call, same
//! receivers, same evaluator (issue 13: within 10 %).
//!
//! Setup (not timed) as in `benches/shadows.rs`: order-4 tables baked in-process, 64 spheres
//! fitted to the demo character, a 64×64 ground grid. The ABI functions are called through
//! `black_box`ed function pointers, so they are not inlined into the benchmark: each call is an
//! indirect call into the `extern "C"` entry point, as from a C caller (argument checks and
//! `catch_unwind` included). FIV: the compat corpus' torus table, two placed occluders.
//! `cargo bench --bench capi` (part of `make bench`); figures in docs/benchmarks.md.
#![allow(unsafe_code)] // calling the C ABI is what is measured

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_asset::{AssetFile, OwnedAsset};
use penumbra_capi as capi;
use penumbra_geometry::Scene;
use penumbra_math::progress::NoProgress;
use penumbra_runtime::fiv::{FivShader, FivTable, PlacedOccluder, ShadeOptions};
use penumbra_runtime::shadows::{ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{ShTables, SphereSet};
use std::hint::black_box;
use std::ptr;
use std::time::Duration;

type Irradiance = unsafe extern "C" fn(
    *const capi::pn_shadow,
    *const f32,
    *const f32,
    *const capi::pn_sphere,
    usize,
    *mut f32,
) -> i32;
type Batch = unsafe extern "C" fn(
    *const capi::pn_shadow,
    *const f32,
    *const f32,
    usize,
    *const capi::pn_sphere,
    usize,
    *mut f32,
) -> i32;
type FivIrr = unsafe extern "C" fn(*mut capi::pn_fiv_scene, *const f32, *const f32, *mut f32) -> i32;

fn bench(c: &mut Criterion) {
    let order = 4;
    let tb = penumbra_sh::tables::bake(&penumbra_sh::tables::TablesParams::new(order), &NoProgress).unwrap();
    let tables_bytes = penumbra_sh::tables_asset::to_asset(&tb, None).unwrap().to_bytes().unwrap();
    let tables_owned = OwnedAsset::parse(&tables_bytes).unwrap();
    let tables_asset = tables_owned.asset();
    let tables = ShTables::from_asset(&tables_asset).unwrap();
    let scene = Scene { mesh: penumbra_geometry::procedural::character(36), ..Scene::default() };
    let mut p = penumbra_spheres::FitParams::new(penumbra_spheres::Target::Count(64));
    p.iterations = 30;
    let fit = penumbra_spheres::fit(&scene, &p, &NoProgress).unwrap();
    let meta = serde_json::json!({"kind": "SPHR"});
    let sphr = penumbra_spheres::asset::to_asset(&fit, &meta).unwrap().to_bytes().unwrap();
    let sphr_owned = OwnedAsset::parse(&sphr).unwrap();
    let sphr_asset = sphr_owned.asset();
    let set = SphereSet::from_asset(&sphr_asset).unwrap();
    let leaves: Vec<Sphere> = (0..set.len()).map(|i| set.leaf(i)).collect();
    let c_leaves: Vec<capi::pn_sphere> =
        leaves.iter().map(|s| capi::pn_sphere { center: s.center, radius: s.radius }).collect();
    let mut light = vec![[0.0f32; 3]; order * order];
    light[0] = [3.0, 3.2, 3.5];
    light[2] = [1.0, 1.1, 1.3];
    light[3] = [0.3, 0.2, 0.1];
    let ev = ShadowEvaluator::new(&tables, &light, ShadowOptions::default());
    let res = 64usize;
    let receivers: Vec<[f32; 3]> = (0..res * res)
        .map(|k| {
            let (x, z) = ((k % res) as f32 + 0.5, (k / res) as f32 + 0.5);
            [-1.2 + 2.4 * x / res as f32, 0.0, -1.2 + 2.4 * z / res as f32]
        })
        .collect();
    let n = [0.0f32, 1.0, 0.0];
    let normals = vec![n; receivers.len()];

    // the same evaluator through the C ABI
    let flat_light: Vec<f32> = light.iter().flatten().copied().collect();
    let (mut t, mut sh) = (ptr::null_mut(), ptr::null_mut());
    let tb = tables_owned.asset().bytes();
    // SAFETY: the buffers outlive the handles (freed at the end of this function).
    unsafe {
        assert_eq!(capi::pn_tables_open(tb.as_ptr(), tb.len(), &mut t, ptr::null_mut(), 0), capi::PN_OK);
        let st =
            capi::pn_shadow_new(t, flat_light.as_ptr(), flat_light.len(), ptr::null(), &mut sh, ptr::null_mut(), 0);
        assert_eq!(st, capi::PN_OK);
    }
    let irradiance: Irradiance = black_box(capi::pn_shadow_irradiance);
    let batch: Batch = black_box(capi::pn_shadow_irradiance_batch);

    let mut g = c.benchmark_group("capi_per_4096_receivers");
    g.sample_size(10).measurement_time(Duration::from_secs(5)).warm_up_time(Duration::from_secs(1));
    g.bench_function("shadow_rust_irradiance", |b| {
        b.iter(|| receivers.iter().map(|&p| ev.irradiance(p, n, black_box(&leaves))[0]).sum::<f32>())
    });
    g.bench_function("shadow_capi_irradiance", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            let mut out = [0.0f32; 3];
            for p in &receivers {
                // SAFETY: live handle, 3-float vectors, the sphere array and its length.
                unsafe {
                    irradiance(
                        sh,
                        p.as_ptr(),
                        n.as_ptr(),
                        black_box(c_leaves.as_ptr()),
                        c_leaves.len(),
                        out.as_mut_ptr(),
                    )
                };
                acc += out[0];
            }
            acc
        })
    });
    g.bench_function("shadow_rust_irradiance_batch", |b| {
        let mut out = vec![[0.0f32; 3]; receivers.len()];
        b.iter(|| {
            ev.irradiance_batch(&receivers, &normals, black_box(&leaves), &mut out);
            out[0][0]
        })
    });
    let pf: Vec<f32> = receivers.iter().flatten().copied().collect();
    let nf: Vec<f32> = normals.iter().flatten().copied().collect();
    g.bench_function("shadow_capi_irradiance_batch", |b| {
        let mut out = vec![0.0f32; pf.len()];
        b.iter(|| {
            // SAFETY: 3 × 4096 floats each, the sphere array, a disjoint output.
            unsafe {
                batch(
                    sh,
                    pf.as_ptr(),
                    nf.as_ptr(),
                    receivers.len(),
                    black_box(c_leaves.as_ptr()),
                    c_leaves.len(),
                    out.as_mut_ptr(),
                )
            };
            out[0]
        })
    });

    // FIV: two placed copies of the corpus torus over a plane
    let ff = AssetFile::open(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/assets/v1/fiv-torus-8x5x4.fivt")).unwrap();
    let fa = ff.asset();
    let table = FivTable::from_asset(&fa).unwrap();
    let (ctr, r) = (table.center(), table.radius());
    let moved = [ctr[0] + 1.2 * r, ctr[1], ctr[2]];
    let occ = [PlacedOccluder { table: &table, center: ctr }, PlacedOccluder { table: &table, center: moved }];
    let plane: Vec<[f32; 3]> = receivers.iter().map(|p| [p[0] * 2.0 * r, ctr[1] - r, p[2] * 2.0 * r]).collect();
    let (mut ft, mut fs) = (ptr::null_mut(), ptr::null_mut());
    // SAFETY: the file outlives the handles.
    unsafe {
        assert_eq!(
            capi::pn_fiv_table_open(ff.bytes().as_ptr(), ff.bytes().len(), &mut ft, ptr::null_mut(), 0),
            capi::PN_OK
        );
        let placed = [capi::pn_fiv_placed { table: ft, center: ctr }, capi::pn_fiv_placed { table: ft, center: moved }];
        let st =
            capi::pn_fiv_scene_new(placed.as_ptr(), 2, capi::PN_FIV_PARTIAL_NONE, true, &mut fs, ptr::null_mut(), 0);
        assert_eq!(st, capi::PN_OK);
    }
    let fiv_irr: FivIrr = black_box(capi::pn_fiv_scene_irradiance);
    g.bench_function("fiv_rust_two_occluders", |b| {
        let mut shader = FivShader::new();
        b.iter(|| {
            plane.iter().map(|&p| shader.irradiance(black_box(&occ), p, n, ShadeOptions::default())[0]).sum::<f32>()
        })
    });
    g.bench_function("fiv_capi_two_occluders", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            let mut out = [0.0f32; 3];
            for p in &plane {
                // SAFETY: live scene, 3-float vectors.
                unsafe { fiv_irr(black_box(fs), p.as_ptr(), n.as_ptr(), out.as_mut_ptr()) };
                acc += out[0];
            }
            acc
        })
    });
    g.finish();
    // SAFETY: each handle freed once, children first.
    unsafe {
        capi::pn_fiv_scene_free(fs);
        capi::pn_fiv_table_free(ft);
        capi::pn_shadow_free(sh);
        capi::pn_tables_free(t);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
