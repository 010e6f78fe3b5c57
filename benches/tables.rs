//! Tables bake for orders 2..=8 (issue: order 4 < 1 s, every order < 10 s on 2 cores).
//! Run with `make bench`; figures go to docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use std::time::Duration;

fn tables(c: &mut Criterion) {
    let mut g = c.benchmark_group("tables_bake");
    g.sample_size(10).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(1));
    for order in 2..=8usize {
        g.bench_function(format!("order_{order}"), |b| {
            b.iter(|| bake(&TablesParams::new(order), &NoProgress).map(|t| t.metrics.gamma_nonzeros))
        });
    }
    g.finish();
}

criterion_group!(benches, tables);
criterion_main!(benches);
