//! Reference rings for the issue-16 torus question "can 64 spheres reach a union outside ratio
//! of 0.10?" (docs/spheres.md, "Fourth pass"). N spheres on the torus's centre line, each the
//! smallest sphere about its centre bounding the dense surface samples nearest to it (48 per
//! triangle edge, so radii converge from below, like `ring_reference`), union by Monte Carlo
//! (2^19 points, exact winding-number inside test):
//!
//! - `circle`: equal angles on a circle, radius scanned 0.985–1.015 and phase over 8 steps;
//! - `poly`: equal arc length on the 24-gon through the faceted tube's ring centres (the axes
//!   of its straight segments), same scans;
//! - `joint 2,2,1`: one sphere on every joint of the 24-gon and the given numbers of equally
//!   spaced spheres inside successive segments (the pattern repeats; 24 + 40 = 64).
//!
//! `SEGS=192` meshes the torus with 192 segments around instead of 24 (a nearly smooth ring);
//! `NR`/`NP` override the numbers of radius and phase steps.
//!
//! ```sh
//! cargo run --release -p penumbra-spheres --example poly_reference -- 64 poly
//! SEGS=192 NR=11 NP=1 cargo run --release -p penumbra-spheres --example poly_reference -- 64 circle
//! ```

#![allow(clippy::print_stdout)]
use penumbra_geometry::{WindingNumber, procedural};
use penumbra_math::rng::{hash4, unit_f64};
use std::f64::consts::TAU;
const SUB: usize = 48;
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args[0].parse().unwrap();
    let poly: bool = args[1] == "poly";
    let joint: bool = args[1] == "joint";
    let segs: usize = std::env::var("SEGS").ok().and_then(|s| s.parse().ok()).unwrap_or(24);
    let mesh = procedural::torus([0.0; 3], 1.0, 0.19, segs, 12);
    let wn = WindingNumber::new(&mesh);
    let vt = mesh.signed_volume();
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
    let d2 = |p: [f64; 3], c: [f64; 3]| (0..3).map(|q| (p[q] - c[q]).powi(2)).sum::<f64>();
    let mut best: Option<(f64, f64, f64)> = None;
    let (nr, np) = if joint { (1, 1) } else { (11, 8) };
    let nr = std::env::var("NR").ok().and_then(|s| s.parse().ok()).unwrap_or(nr);
    let np = std::env::var("NP").ok().and_then(|s| s.parse().ok()).unwrap_or(np);
    for kr in 0..nr {
        for kp in 0..np {
            let rc = if joint { 1.0 } else { 0.985 + 0.003 * kr as f64 };
            let phase = kp as f64 / 8.0;
            let mut fr: Vec<f64> = Vec::new();
            if joint {
                let pat: Vec<usize> = args[2].split(',').map(|x| x.parse().unwrap()).collect();
                let mut k = 0usize;
                for seg in 0..24 {
                    let m = pat[seg % pat.len()];
                    for q in 0..=m {
                        fr.push(seg as f64 + q as f64 / (m + 1) as f64);
                    }
                    k += m + 1;
                }
                assert_eq!(k, n);
            }
            let centres: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let u = if joint { TAU * fr[i] / 24.0 } else { TAU * (i as f64 + phase) / n as f64 };
                    if poly || joint {
                        // point on the 24-gon of radius rc at the same arc fraction (segments equal length)
                        let seg = TAU / 24.0;
                        let k = (u / seg).floor();
                        let f = u / seg - k;
                        let (a0, a1) = (k * seg, (k + 1.0) * seg);
                        let p0 = [rc * a0.sin(), 0.0, rc * a0.cos()];
                        let p1 = [rc * a1.sin(), 0.0, rc * a1.cos()];
                        std::array::from_fn(|d| p0[d] + f * (p1[d] - p0[d]))
                    } else {
                        [rc * u.sin(), 0.0, rc * u.cos()]
                    }
                })
                .collect();
            let ang = |p: [f64; 3]| p[0].atan2(p[2]).rem_euclid(TAU);
            let near = |p: [f64; 3]| -> Vec<usize> {
                let a = ang(p);
                let mut v: Vec<usize> = (0..n).collect();
                v.sort_by(|&x, &y| {
                    let dx = (ang(centres[x]) - a + TAU / 2.0).rem_euclid(TAU) - TAU / 2.0;
                    let dy = (ang(centres[y]) - a + TAU / 2.0).rem_euclid(TAU) - TAU / 2.0;
                    dx.abs().total_cmp(&dy.abs())
                });
                v.truncate(5);
                v
            };
            let mut rad2 = vec![0.0f64; n];
            for &p in &surf {
                let i = near(p).into_iter().min_by(|&x, &y| d2(p, centres[x]).total_cmp(&d2(p, centres[y]))).unwrap();
                rad2[i] = rad2[i].max(d2(p, centres[i]));
            }
            let rmax = rad2.iter().cloned().fold(0.0, f64::max).sqrt();
            let ext = 1.0 + rmax + 0.05;
            let (lo, hi) = ([-ext, -rmax - 0.05, -ext], [ext, rmax + 0.05, ext]);
            let box_v: f64 = (0..3).map(|d| hi[d] - lo[d]).product();
            let m = 1u64 << 19;
            let mut out = 0u64;
            for s in 0..m {
                let p: [f64; 3] =
                    std::array::from_fn(|d| lo[d] + (hi[d] - lo[d]) * unit_f64(hash4(16, s, d as u64, 0)));
                let covered = near(p).into_iter().any(|i| d2(p, centres[i]) <= rad2[i]);
                if covered && !wn.is_inside(p) {
                    out += 1;
                }
            }
            let ratio = out as f64 / m as f64 * box_v / vt;
            if best.is_none_or(|b| ratio < b.0) {
                best = Some((ratio, rc, phase));
            }
        }
    }
    let (ratio, rc, phase) = best.unwrap();
    println!(
        "N {n} {} ({segs} segments): union outside ratio {ratio:.3} (centre radius {rc:.3}, phase {phase})",
        args[1]
    );
}
