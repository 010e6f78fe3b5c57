//! Reference arrangement for the issue-16 torus (minor/major 0.19, 24 × 12 segments): N equal
//! spheres centred on the centre line at equal angles, each the smallest centred sphere that
//! bounds its slab of the *smooth* torus (so it bounds the faceted mesh inside it too), and the
//! union outside ratio `V(∪S − T)/V(T)` of the faceted mesh by Monte Carlo with the exact
//! winding-number inside test. docs/spheres.md ("Thin features") quotes its output.
//!
//! ```sh
//! cargo run --release -p penumbra-spheres --example ring_reference -- 32 64 128
//! ```

#![allow(clippy::print_stdout)]

use penumbra_geometry::{WindingNumber, procedural};
use penumbra_math::rng::{hash4, unit_f64};

fn main() {
    let (big, r) = (1.0f64, 0.19f64);
    let mesh = procedural::torus([0.0; 3], big, r, 24, 12);
    let wn = WindingNumber::new(&mesh);
    let vt = mesh.signed_volume();
    let counts: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    for n in if counts.is_empty() { vec![32, 64, 128] } else { counts } {
        let th = std::f64::consts::PI / n as f64;
        // the farthest point of a slab |angle| ≤ θ of the smooth torus from (R, 0, 0): on its
        // boundary circles (checked densely)
        let mut rho2: f64 = 0.0;
        for k in 0..3600 {
            let phi = k as f64 * std::f64::consts::TAU / 3600.0;
            let rr = big + r * phi.cos();
            for t in [0.0, th] {
                let (x, y, z) = (rr * t.cos() - big, rr * t.sin(), r * phi.sin());
                rho2 = rho2.max(x * x + y * y + z * z);
            }
        }
        let rho = rho2.sqrt();
        // sphere centres in the mesh's frame: the ring lies in the xz plane (axis y)
        let centres: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let u = std::f64::consts::TAU * i as f64 / n as f64;
                [big * u.sin(), 0.0, big * u.cos()]
            })
            .collect();
        let ext = big + rho;
        let (lo, hi) = ([-ext, -rho, -ext], [ext, rho, ext]);
        let box_v: f64 = (0..3).map(|d| hi[d] - lo[d]).product();
        let m = 1u64 << 21;
        let mut out = 0u64;
        for s in 0..m {
            let p: [f64; 3] = std::array::from_fn(|d| lo[d] + (hi[d] - lo[d]) * unit_f64(hash4(16, s, d as u64, 0)));
            let ang = p[0].atan2(p[2]);
            let k = (ang / (2.0 * th)).round() as i64;
            let near = |j: i64| centres[j.rem_euclid(n as i64) as usize];
            let covered = (-1..=1).any(|d| {
                let c = near(k + d);
                (0..3).map(|q| (p[q] - c[q]).powi(2)).sum::<f64>() <= rho2
            });
            if covered && !wn.is_inside(p) {
                out += 1;
            }
        }
        let ratio = out as f64 / m as f64 * box_v / vt;
        println!("N {n}: sphere radius {rho:.4}, union outside ratio {ratio:.3} (2^21 points)");
    }
}
