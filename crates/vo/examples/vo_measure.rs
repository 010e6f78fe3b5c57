//! Bakes the default sample sets and prints the comparison table (development measurement).
#![allow(clippy::print_stdout)]
use penumbra_math::progress::NoProgress;
use penumbra_vo::{VoParams, bake};

fn main() {
    let mut p = VoParams::default();
    if let Some(a) = std::env::args().nth(1) {
        let m: usize = a.parse().unwrap_or(64);
        p.counts = (1..=m).collect();
    }
    let t = std::time::Instant::now();
    let b = bake(&p, &NoProgress).unwrap_or_else(|e| panic!("{e}"));
    println!("seconds {:.2}", t.elapsed().as_secs_f64());
    println!("dom c n | cv: es lloyd halton poisson | noise: es lloyd halton poisson");
    for c in &b.comparison {
        println!(
            "{} {} {:2} | {:.4} {:.4} {:.4} {:.4} | {:.5} {:.5} {:.5} {:.5}",
            c.domain,
            u8::from(c.centre),
            c.n,
            c.electrostatic.cell_cv,
            c.lloyd.cell_cv,
            c.halton.cell_cv,
            c.poisson.cell_cv,
            c.electrostatic.noise,
            c.lloyd.noise,
            c.halton.noise,
            c.poisson.noise
        );
    }
}
