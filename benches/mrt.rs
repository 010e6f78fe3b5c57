//! MRT dictionary bake (issue "mrt dict": the whole cube2d dictionary at the thesis settings —
//! 16² texels per face, k_d 64, k_b 32, 16K rays — in ≤ 10 s on 2 cores; thesis: 119 s on 12
//! cores for dictionary + enrichment). Run with `make bench`; figures go to docs/benchmarks.md.
//! The bake includes every measurement the command reports (Table 3.2, the path-traced
//! reference, the five-red-faces case).

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_math::progress::NoProgress;
use penumbra_transport::dict::{DictParams, bake};
use penumbra_transport::gather::{DirectionSet, Gather, transport_matrix};
use penumbra_transport::shape::{CLOSED, DictionaryKind, Texels};
use std::time::Duration;

fn mrt(c: &mut Criterion) {
    let mut g = c.benchmark_group("mrt_dict");
    // ≈ 10 runs of a few seconds each
    g.sample_size(10).measurement_time(Duration::from_secs(60)).warm_up_time(Duration::from_secs(1));
    for (name, kind) in [("cube2d_thesis", DictionaryKind::Cube2d), ("closed_cube_thesis", DictionaryKind::ClosedCube)]
    {
        // without interfaces: the issue-6 figure (interfaces: benches/mrt_level.rs)
        let mut p = DictParams::new(kind);
        p.interfaces = false;
        g.bench_function(name, |b| b.iter(|| bake(&p, &NoProgress).map(|d| d.metrics.table_3_2.f)));
    }
    g.finish();
    let mut g = c.benchmark_group("mrt_transport");
    g.sample_size(10).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(1));
    let tex = Texels::new(CLOSED, 16);
    let dirs = DirectionSet::cosine(16384);
    g.bench_function("F_closed_16x16_16k_rays", |b| {
        b.iter(|| transport_matrix(&tex, &dirs, 1.0, Gather::Bilinear, 0, 0, &|_| {}).nrows())
    });
    g.finish();
}

criterion_group!(benches, mrt);
criterion_main!(benches);
