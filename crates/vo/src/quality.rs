//! Quality of a sample set: the CV of its cell measures and the noise of its estimator.
//!
//! Noise is measured on the one family whose obscurance is known in closed form: a random
//! half-space occupying `n·x > h` with a uniformly random offset `h ∈ [−1, 1]` occupies the
//! cap fraction `(1 − h)²(2 + h)/4` of the unit ball. Disk sets estimate it by line sampling
//! (§6.3.1: each line's free length `max(min(z_s, d) + z_s, 0)` is exact, the sum over lines
//! is weighted by the cells' μ); ball sets by point sampling. Normals are uniform on the
//! sphere (ball) or on the view-facing hemisphere `n_z > 0` (disk: a depth buffer stores
//! only such planes). Every trial applies a random reflection of the set (2D for lines, 3D
//! for points), as the runtime does per pixel (§6.3.5). `noise` is the RMS error over the
//! trials; trial `t` is the same for every set of a given (domain, centre, N), so methods
//! are compared on identical configurations.

use crate::sets::STAGE_VO;
use crate::voronoi::Domain;
use penumbra_math::rng::{ItemRng, hash4};

/// Fraction of the unit ball with `n·x > h` (a cap of height `1 − h`).
pub fn cap_fraction(h: f64) -> f64 {
    let h = h.clamp(-1.0, 1.0);
    (1.0 - h) * (1.0 - h) * (2.0 + h) / 4.0
}

/// A random unit vector on the sphere (or the `z > 0` hemisphere) from two uniforms.
pub fn unit_vector(u: f64, v: f64, hemisphere: bool) -> [f64; 3] {
    let z = if hemisphere { u } else { 1.0 - 2.0 * u };
    let s = (1.0 - z * z).max(0.0).sqrt();
    let t = std::f64::consts::TAU * v;
    [s * t.cos(), s * t.sin(), z]
}

/// Reflects `p` about the plane (line, in 2D) through the origin with unit normal `r`.
#[inline]
pub fn reflect(p: [f64; 3], r: [f64; 3]) -> [f64; 3] {
    let d = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
    [p[0] - 2.0 * d * r[0], p[1] - 2.0 * d * r[1], p[2] - 2.0 * d * r[2]]
}

/// Free length of the sphere's chord at `(x, y)` in front of depth `d` (§6.3.1):
/// `∫_{−z_s}^{z_s} [z ≤ d] dz = max(min(z_s, d) + z_s, 0)`.
#[inline]
pub fn line_free(z_s: f64, d: f64) -> f64 {
    (z_s.min(d) + z_s).max(0.0)
}

/// RMS error of the set's estimate of the free fraction over `trials` random half-spaces.
pub fn noise(domain: Domain, pts: &[[f64; 3]], weights: &[f64], trials: usize, seed: u64, item: u64) -> f64 {
    if pts.is_empty() || trials == 0 {
        return 0.0;
    }
    let mut se = 0.0;
    for t in 0..trials {
        let mut r = ItemRng::new(hash4(seed, STAGE_VO, item, 0x4e01), STAGE_VO, t as u64);
        let n = unit_vector(r.next_f64(), r.next_f64(), domain == Domain::Disk);
        let h = 2.0 * r.next_f64() - 1.0;
        let refl = match domain {
            Domain::Disk => {
                let a = std::f64::consts::TAU * r.next_f64();
                [a.cos(), a.sin(), 0.0]
            }
            Domain::Ball => unit_vector(r.next_f64(), r.next_f64(), false),
        };
        let exact = 1.0 - cap_fraction(h);
        let mut est = 0.0;
        for (p, &w) in pts.iter().zip(weights) {
            let p = reflect(*p, refl);
            let v = match domain {
                Domain::Disk => {
                    let z_s = (1.0 - p[0] * p[0] - p[1] * p[1]).max(0.0).sqrt();
                    if z_s <= 0.0 || n[2] <= 0.0 {
                        0.0
                    } else {
                        let d = (h - n[0] * p[0] - n[1] * p[1]) / n[2];
                        line_free(z_s, d) / (2.0 * z_s)
                    }
                }
                Domain::Ball => f64::from(u8::from(n[0] * p[0] + n[1] * p[1] + n[2] * p[2] <= h)),
            };
            est += w * v;
        }
        se += (est - exact) * (est - exact);
    }
    (se / trials as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cap_fraction_is_the_integral_of_the_disk_areas() {
        // ∫_h^1 π(1 − z²) dz / (4π/3)
        for h in [-1.0, -0.4, 0.0, 0.3, 0.9, 1.0] {
            let m = 20000;
            let s: f64 = (0..m)
                .map(|i| {
                    let z = h + (1.0 - h) * (i as f64 + 0.5) / m as f64;
                    (1.0 - z * z) * (1.0 - h) / m as f64
                })
                .sum::<f64>()
                * 3.0
                / 4.0;
            assert!((cap_fraction(h) - s).abs() < 1e-8, "{h}");
        }
    }

    #[test]
    fn a_dense_set_has_little_noise_and_one_point_has_the_variance() {
        // a fine μ-weighted grid of the disk integrates the half-space exactly up to the
        // midpoint rule: its noise is tiny
        let m = 64;
        let mut pts = Vec::new();
        let mut w = Vec::new();
        for i in 0..m {
            for j in 0..m {
                let p = [-1.0 + (i as f64 + 0.5) * 2.0 / m as f64, -1.0 + (j as f64 + 0.5) * 2.0 / m as f64, 0.0];
                let r2 = p[0] * p[0] + p[1] * p[1];
                if r2 < 1.0 {
                    pts.push(p);
                    w.push(2.0 * (1.0 - r2).sqrt());
                }
            }
        }
        let s: f64 = w.iter().sum();
        w.iter_mut().for_each(|x| *x /= s);
        assert!(noise(Domain::Disk, &pts, &w, 500, 1, 0) < 2e-3);
        // the centre alone answers the free fraction of its own line: for a plane with normal
        // n and offset h that is clamp((h/n_z + 1)/2, 0, 1); its error is far from zero
        let e = noise(Domain::Disk, &[[0.0; 3]], &[1.0], 2000, 1, 0);
        assert!(e > 0.05 && e < 0.3, "{e}");
        // ball: one point at the centre is free iff h ≥ 0: error² = E[(1 − cap(h) − [h≥0])²]
        let e = noise(Domain::Ball, &[[0.0; 3]], &[1.0], 20000, 1, 0);
        let m = 100000;
        let exact: f64 = (0..m)
            .map(|i| {
                let h = -1.0 + 2.0 * (i as f64 + 0.5) / m as f64;
                let v = 1.0 - cap_fraction(h) - if h >= 0.0 { 1.0 } else { 0.0 };
                v * v / m as f64
            })
            .sum::<f64>()
            .sqrt();
        assert!((e - exact).abs() < 0.01 * exact, "{e} {exact}");
    }
}
