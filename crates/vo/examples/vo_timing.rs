//! Times the pieces of the sample-set bake (development measurement).
#![allow(clippy::print_stdout)]
use penumbra_vo::Domain;
use penumbra_vo::sets::{ElectroParams, electrostatic, halton};
use penumbra_vo::voronoi::Grid;
use std::time::Instant;

fn main() {
    let t = Instant::now();
    let g = Grid::new(Domain::Ball, 128);
    println!("grid ball 128: {:.3} s", t.elapsed().as_secs_f64());
    let p = halton(Domain::Ball, 64, false);
    let t = Instant::now();
    for _ in 0..10 {
        std::hint::black_box(g.cells(&p));
    }
    println!("cells ball 128 n64: {:.4} s", t.elapsed().as_secs_f64() / 10.0);
    let g32 = Grid::new(Domain::Ball, 32);
    let t = Instant::now();
    for _ in 0..100 {
        std::hint::black_box(g32.cells(&p));
    }
    println!("cells ball 32 n64: {:.5} s", t.elapsed().as_secs_f64() / 100.0);
    let g = Grid::new(Domain::Disk, 512);
    let p = halton(Domain::Disk, 64, false);
    let t = Instant::now();
    for _ in 0..10 {
        std::hint::black_box(g.cells(&p));
    }
    println!("cells disk 512 n64: {:.4} s", t.elapsed().as_secs_f64() / 10.0);
    for n in [8, 16, 32, 64] {
        let t = Instant::now();
        std::hint::black_box(electrostatic(&Grid::new(Domain::Ball, 16), &g32, n, false, 1, &ElectroParams::default()));
        println!("electrostatic ball n{n}: {:.3} s", t.elapsed().as_secs_f64());
    }
}
