//! Volumetric-obscurance sample sets and estimators (issue 18: all sets N ≤ 64, both domains,
//! ± centre ≤ 10 s on 2 cores). Run with `make bench`.

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra_math::progress::NoProgress;
use penumbra_vo::estimator::{DepthBuffer, Method, Options, SetRef, estimate};
use penumbra_vo::voronoi::Grid;
use penumbra_vo::{Domain, VoParams, bake};
use std::time::Duration;

fn sets(c: &mut Criterion) {
    let mut g = c.benchmark_group("vo_bake");
    g.sample_size(10).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(1));
    g.bench_function("counts_1_16", |b| {
        b.iter(|| {
            bake(&VoParams { counts: (1..=16).collect(), ..VoParams::default() }, &NoProgress).map(|x| x.sets.len())
        })
    });
    let ball = Grid::new(Domain::Ball, 128);
    let disk = Grid::new(Domain::Disk, 512);
    let pb = penumbra_vo::sets::halton(Domain::Ball, 64, false);
    let pd = penumbra_vo::sets::halton(Domain::Disk, 64, false);
    g.bench_function("voronoi_ball_128_n64", |b| b.iter(|| ball.cells(&pb).mass[0]));
    g.bench_function("voronoi_disk_512_n64", |b| b.iter(|| disk.cells(&pd).mass[0]));
    g.finish();
}

fn estimators(c: &mut Criterion) {
    let p = VoParams { counts: vec![5, 12], starts: 4, noise_trials: 16, ..VoParams::default() };
    let b = bake(&p, &NoProgress).unwrap_or_else(|e| panic!("{e}"));
    let db = DepthBuffer::from_fn(256, 256, 1.0 / 64.0, [-2.0, -2.0], |x, y| {
        Some(((3.0 * x).sin() * 0.3 + y * y * 0.2, [0.0, 0.0, -1.0]))
    });
    let o = Options { radius: 0.25, normal_clamp: false, thickness: None };
    let mut g = c.benchmark_group("vo_estimate_per_pixel");
    for (name, method, ball, n) in [
        ("lines_5", Method::Lines, false, 5),
        ("area_5", Method::Area, false, 5),
        ("points_12", Method::Points, true, 12),
    ] {
        let s = b
            .sets
            .iter()
            .find(|s| (s.domain == Domain::Ball) == ball && !s.centre && s.points.len() == n)
            .unwrap_or_else(|| panic!("set"));
        let set = SetRef { points: &s.points, weights: &s.weights, log2area: &s.log2area };
        g.bench_function(name, |bb| bb.iter(|| estimate(&db, 128, 128, method, set, [0.6, 0.8, 0.0], &o)));
    }
    g.finish();
}

criterion_group!(benches, sets, estimators);
criterion_main!(benches);
