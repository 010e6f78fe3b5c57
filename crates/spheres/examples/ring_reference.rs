//! Reference arrangement for the issue-16 torus (minor/major 0.19, 24 × 12 segments): N spheres
//! centred at equal angles on a circle of radius `rc` (scanned), each the smallest sphere about
//! its centre that bounds the part of the *faceted* mesh nearest to it (dense barycentric
//! samples of every triangle), and the union outside ratio `V(∪S − T)/V(T)` by Monte Carlo with
//! the exact winding-number inside test. docs/spheres.md ("Why the torus still stalls") quotes
//! its output. Each radius is the largest distance to the samples nearest to its centre, so it
//! converges to the bounding radius from below as `SUB` grows (0.108 at 64 spheres with 24
//! samples per edge, 0.118 with 96).
//!
//! An earlier version sized the spheres to bound the *smooth* torus and assumed the faceted mesh
//! lies inside it. It does not: on the inner side a flat facet's chord runs closer to the axis
//! than the smooth inner rim (0.81·cos 7.5° = 0.803 against 0.81), so those rings did not bound
//! the mesh and their ratios (0.300 / 0.120 / 0.076 at 32 / 64 / 128) were too low.
//!
//! ```sh
//! cargo run --release -p penumbra-spheres --example ring_reference -- 32 64 128
//! ```

#![allow(clippy::print_stdout)]

use std::f64::consts::TAU;

use penumbra_geometry::{WindingNumber, procedural};
use penumbra_math::rng::{hash4, unit_f64};

/// Barycentric subdivisions per triangle edge for the surface samples.
const SUB: usize = 96;

fn main() {
    let (big, r) = (1.0f64, 0.19f64);
    let mesh = procedural::torus([0.0; 3], big, r, 24, 12);
    let wn = WindingNumber::new(&mesh);
    let vt = mesh.signed_volume();
    // dense samples of the continuous faceted surface
    let mut surf: Vec<[f64; 3]> = Vec::new();
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t);
        for i in 0..=SUB {
            for j in 0..=SUB - i {
                let (u, v) = (i as f64 / SUB as f64, j as f64 / SUB as f64);
                surf.push(std::array::from_fn(|d| a[d] + u * (b[d] - a[d]) + v * (c[d] - a[d])));
            }
        }
    }
    let counts: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    for n in if counts.is_empty() { vec![32, 64, 128] } else { counts } {
        let mut best: Option<(f64, f64, f64, f64)> = None;
        for k in 0..=12 {
            let rc = 0.990 + 0.001 * k as f64;
            // sphere i sits at angle 2πi/n (on a vertex ring for i = 0); a surface point belongs
            // to the nearest centre, and each radius bounds its points
            let centres: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let u = TAU * i as f64 / n as f64;
                    [rc * u.sin(), 0.0, rc * u.cos()]
                })
                .collect();
            let near = |p: [f64; 3]| -> Vec<usize> {
                let k = (p[0].atan2(p[2]) / (TAU / n as f64)).round() as i64;
                (-1..=1).map(|d| (k + d).rem_euclid(n as i64) as usize).collect()
            };
            let d2 = |p: [f64; 3], c: [f64; 3]| (0..3).map(|q| (p[q] - c[q]).powi(2)).sum::<f64>();
            let mut rad2 = vec![0.0f64; n];
            for &p in &surf {
                let i = near(p).into_iter().min_by(|&x, &y| d2(p, centres[x]).total_cmp(&d2(p, centres[y]))).unwrap();
                rad2[i] = rad2[i].max(d2(p, centres[i]));
            }
            let rmax = rad2.iter().cloned().fold(0.0, f64::max).sqrt();
            let ext = big + rmax + 0.05;
            let (lo, hi) = ([-ext, -rmax - 0.05, -ext], [ext, rmax + 0.05, ext]);
            let box_v: f64 = (0..3).map(|d| hi[d] - lo[d]).product();
            let m = 1u64 << 20;
            let (mut out, mut uncovered) = (0u64, 0u64);
            for s in 0..m {
                let p: [f64; 3] =
                    std::array::from_fn(|d| lo[d] + (hi[d] - lo[d]) * unit_f64(hash4(16, s, d as u64, 0)));
                let covered = near(p).into_iter().any(|i| d2(p, centres[i]) <= rad2[i]);
                let inside = wn.is_inside(p);
                if covered && !inside {
                    out += 1;
                }
                if inside && !covered {
                    uncovered += 1;
                }
            }
            let ratio = out as f64 / m as f64 * box_v / vt;
            let unc = uncovered as f64 / m as f64 * box_v / vt;
            if best.is_none_or(|b| ratio < b.0) {
                best = Some((ratio, rc, rmax, unc));
            }
        }
        let (ratio, rc, rmax, unc) = best.unwrap();
        println!(
            "N {n}: best centre radius {rc:.3}, largest sphere radius {rmax:.4}, union outside ratio {ratio:.3}, uncovered ratio {unc:.1e} (2^20 points)"
        );
    }
}
