//! Fits sphere sets to the thin-feature test shapes and the shared meshes and prints one
//! markdown row per (mesh, count, method): the table of docs/spheres.md ("Thin features").
//!
//! ```sh
//! cargo run --release -p penumbra-spheres --example fit_table -- [--grid 48] [--counts 16,32,64,128] \
//!     [--octree] [--no-refine] [--no-cvt] [--no-fine] [--medial] [--polish] [--iterations 100] torus bent-tube thin-plate capsule-chain open-tube bunny_closed_3k rocker-arm ...
//! ```
//!
//! Names without a path are procedural shapes (`torus`: minor/major 0.19, 576 triangles) or
//! meshes of `../shared/data/meshes` (skipped with a message when absent). Times are the fit
//! alone, in process, on whatever cores are free: note the load next to them.

#![allow(clippy::print_stdout, clippy::print_stderr)]

use std::time::Instant;

use penumbra_geometry::{Scene, TriMesh, load_mesh, procedural};
use penumbra_math::progress::NoProgress;
use penumbra_spheres::fit::{FitParams, Method, Target};

fn shape(name: &str) -> Option<TriMesh> {
    Some(match name {
        "torus" => procedural::torus([0.0; 3], 1.0, 0.19, 24, 12),
        "bent-tube" => procedural::bent_tube(64),
        "thin-plate" => procedural::thin_plate(64),
        "capsule-chain" => procedural::capsule_chain(64),
        "open-tube" => procedural::open_tube(24, 12),
        "four-hole-plate" => procedural::four_hole_plate(72),
        _ => return None,
    })
}

/// CPU seconds (user + system) this process has used so far (Linux `/proc/self/stat`; 0 elsewhere).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // fields after the parenthesised command name; utime and stime are fields 14 and 15
    let rest = stat.rsplit_once(')').map_or("", |x| x.1);
    let f: Vec<f64> = rest.split_whitespace().filter_map(|x| x.parse().ok()).collect();
    // rest starts at field 3 (state, not numeric, skipped by the parse): utime is f[10]
    if f.len() > 12 { (f[10] + f[11]) / 100.0 } else { 0.0 }
}

fn main() {
    let mut grid = 48usize;
    let mut counts = vec![16usize, 32, 64, 128];
    let mut methods = vec![Method::Lloyd];
    let mut refine = true;
    let mut polish = false;
    let mut cvt = true;
    let mut fine = true;
    let mut iterations = 100usize;
    let mut seeding = penumbra_spheres::lloyd::Seeding::KMeansPlusPlus;
    let mut names = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--grid" => grid = args.next().and_then(|g| g.parse().ok()).expect("--grid N"),
            "--counts" => {
                counts = args.next().expect("--counts").split(',').map(|c| c.parse().expect("count")).collect()
            }
            "--octree" => methods.push(Method::Octree),
            "--no-refine" => refine = false,
            "--polish" => polish = true,
            "--no-cvt" => cvt = false,
            "--no-fine" => fine = false,
            "--iterations" => iterations = args.next().and_then(|g| g.parse().ok()).expect("--iterations N"),
            "--medial" => seeding = penumbra_spheres::lloyd::Seeding::Medial,
            _ => names.push(a),
        }
    }
    let data = penumbra_testkit::shared_data_dir().join("meshes");
    println!(
        "threads: {}, grid {grid}, refine {refine}, cvt {cvt}, fine {fine}, seeding {seeding:?}, iterations {iterations}",
        rayon::current_num_threads()
    );
    println!("| mesh | triangles | method | N | count | E | union | uncovered pts | s | cpu s | iterations |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in &names {
        let scene = match shape(name) {
            Some(mesh) => Scene { mesh, ..Scene::default() },
            None => {
                let path = if name.contains('/') { name.into() } else { data.join(format!("{name}.obj")) };
                match load_mesh(&path) {
                    Ok((s, _)) => s,
                    Err(e) => {
                        eprintln!("skipping {name}: {e}");
                        continue;
                    }
                }
            }
        };
        for &method in &methods {
            for &n in &counts {
                let mut p = FitParams::new(Target::Count(n));
                p.method = method;
                p.grid = grid;
                p.refine = refine;
                p.polish = polish;
                p.cvt = cvt;
                p.fine_refine = fine;
                p.iterations = iterations;
                p.seeding = seeding;
                let t = Instant::now();
                let cpu0 = cpu_seconds();
                let r = penumbra_spheres::fit(&scene, &p, &NoProgress).expect("fit");
                let s = t.elapsed().as_secs_f64() - r.report.finish_seconds;
                let cpu = cpu_seconds() - cpu0;
                println!(
                    "| {name} | {} | {method:?} | {n} | {} | {:.3} | {:.3} | {} | {s:.2} | {cpu:.2} | {} |",
                    scene.mesh.indices.len(),
                    r.spheres.len(),
                    r.metrics.outside_volume_ratio,
                    r.metrics.union_outside_ratio,
                    r.metrics.uncovered_sample_points,
                    r.report.iterations,
                );
            }
        }
    }
}
