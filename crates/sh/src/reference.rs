//! Brute-force references for the tables: direct quadrature of the functions the fast
//! paths work with, used by tests and `penumbra verify`.

use core::f64::consts::PI;
use penumbra_math::quadrature::{SphereQuadrature, gauss_legendre_cached};
use penumbra_math::sh::{ShEval, eval_zonal};

/// Projects an arbitrary spherical function onto SH of `order` with a product rule of
/// `nz × 2nz` points.
pub fn project(order: usize, nz: usize, f: impl Fn([f64; 3]) -> f64) -> Vec<f64> {
    let q = SphereQuadrature::new(nz, 2 * nz);
    let e = ShEval::new(order);
    let mut y = vec![0.0; order * order];
    let mut out = vec![0.0; order * order];
    for (d, w) in q.iter() {
        e.eval_into(d, &mut y);
        let v = f(d);
        for i in 0..out.len() {
            out[i] += w * v * y[i];
        }
    }
    out
}

/// Reconstruction `f̃(s) = Σ f_i y_i(s)`.
pub fn reconstruct(eval: &ShEval, f: &[f64], dir: [f64; 3], scratch: &mut [f64]) -> f64 {
    eval.eval_into(dir, scratch);
    f.iter().zip(scratch.iter()).map(|(a, b)| a * b).sum()
}

/// `∫ ã(z) b̃(z) c̃(z) dΩ` of three zonal reconstructions by 1D Gauss–Legendre with
/// `nodes` points (exact once `nodes ≥ 3(n−1)/2 + 1`).
pub fn zonal_triple_quadrature(a: &[f64], b: &[f64], c: &[f64], nodes: usize) -> f64 {
    let n = a.len();
    let gl = gauss_legendre_cached(nodes);
    let mut y = vec![0.0; n];
    let mut s = 0.0;
    for (z, w) in gl.on_interval(-1.0, 1.0) {
        eval_zonal(n, z, &mut y);
        let dot = |v: &[f64]| v.iter().zip(&y).map(|(p, q)| p * q).sum::<f64>();
        s += 2.0 * PI * w * dot(a) * dot(b) * dot(c);
    }
    s
}

/// The η shadow analysis (IBPA §4.1 as worded) by brute-force quadrature: the shading
/// difference `∫ H̃(s) L̃(s) õ_θ(s) ds` of the reconstructed order-n projections, with
/// `L̃` the reconstruction of the normalised delta light and `õ` of the cap occlusion.
pub fn shadow_difference_quadrature(order: usize, light_zh: &[f64], theta: f64) -> f64 {
    let h = crate::zonal::irradiance_weight(order);
    let o = crate::zonal::cap_indicator(order, theta);
    zonal_triple_quadrature(&h, light_zh, &o, 256)
}

/// Shadowed shading of a receiver (normal +z) under a light `l` (full SH) and a binary
/// visibility function, by dense quadrature — no SH truncation of the visibility.
pub fn shade_exact(order: usize, l: &[f64], visible: impl Fn([f64; 3]) -> bool, nz: usize) -> f64 {
    let q = SphereQuadrature::new(nz, 2 * nz);
    let e = ShEval::new(order);
    let mut y = vec![0.0; order * order];
    let mut s = 0.0;
    for (d, w) in q.iter() {
        if d[2] <= 0.0 || !visible(d) {
            continue;
        }
        s += w * d[2] / PI * reconstruct(&e, l, d, &mut y);
    }
    s
}
