//! Sphere-set bake (issue "penumbra spheres"): the quality/time table of docs/benchmarks.md
//! and the timing goals (64 spheres: bunny < 10 s, 86k-triangle armadillo < 60 s, 2 cores).
//!
//! `cargo bench --bench spheres` (part of `make bench`) fits `bunny_closed_3k`, `armadillo_43k`,
//! `spot` and `rocker-arm` at 16, 32, 64 and 128 spheres with the octree baseline and with
//! Lloyd at the requested count and at the octree's actual count (octree levels cannot hit a
//! count exactly), and prints a markdown table. `SPHERES_BENCH_MESHES=bunny_closed_3k` and
//! `SPHERES_BENCH_COUNTS=64` restrict it. Needs `../shared/data` (skips otherwise).

#![allow(clippy::print_stdout, clippy::print_stderr)]

use std::time::Instant;

use penumbra_geometry::load_mesh;
use penumbra_math::progress::NoProgress;
use penumbra_spheres::fit::{FitParams, FitResult, Method, Target};

fn fit(scene: &penumbra_geometry::Scene, n: usize, method: Method) -> (FitResult, f64) {
    let mut p = FitParams::new(Target::Count(n));
    p.method = method;
    let t = Instant::now();
    let r = penumbra_spheres::fit(scene, &p, &NoProgress).expect("fit");
    (r, t.elapsed().as_secs_f64())
}

fn main() {
    let data = penumbra_testkit::shared_data_dir();
    if !data.is_dir() {
        eprintln!("skipping the spheres benchmark: {} not found", data.display());
        return;
    }
    let list = |var: &str, default: &str| -> Vec<String> {
        std::env::var(var).unwrap_or_else(|_| default.to_string()).split(',').map(str::to_string).collect()
    };
    let meshes = list("SPHERES_BENCH_MESHES", "bunny_closed_3k,armadillo_43k,spot,rocker-arm");
    let counts: Vec<usize> =
        list("SPHERES_BENCH_COUNTS", "16,32,64,128").iter().filter_map(|c| c.parse().ok()).collect();
    println!("threads: {}", rayon::current_num_threads());
    println!();
    println!(
        "| mesh | N | octree: count, E, union, s | Lloyd at N: E, union, s, iterations (teleports kept/tried) | Lloyd at octree count: E, union | union ratio octree / Lloyd |"
    );
    println!("|---|---|---|---|---|---|");
    for m in &meshes {
        let path = data.join("meshes").join(format!("{m}.obj"));
        let (scene, _) = load_mesh(&path).expect("mesh");
        for &n in &counts {
            let (o, to) = fit(&scene, n, Method::Octree);
            let (l, tl) = fit(&scene, n, Method::Lloyd);
            let no = o.spheres.len();
            let (le, _) = if no == n { (l.clone(), tl) } else { fit(&scene, no, Method::Lloyd) };
            let rep = &l.report;
            println!(
                "| {m} | {n} | {no}, {:.3}, {:.3}, {:.2} | {:.3}, {:.3}, {:.2}, {} ({}/{}) | {:.3}, {:.3} | {:.1}× |",
                o.metrics.outside_volume_ratio,
                o.metrics.union_outside_ratio,
                to,
                l.metrics.outside_volume_ratio,
                l.metrics.union_outside_ratio,
                tl,
                rep.iterations,
                rep.teleports_accepted,
                rep.teleports_accepted + rep.teleports_rejected,
                le.metrics.outside_volume_ratio,
                le.metrics.union_outside_ratio,
                o.metrics.union_outside_ratio / le.metrics.union_outside_ratio,
            );
        }
    }
}
