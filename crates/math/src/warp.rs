//! Sampling warps from the unit square to directions.

use core::f64::consts::PI;

/// Uniform direction on the unit sphere (pdf `1/4π`).
#[inline]
pub fn uniform_sphere(u: f64, v: f64) -> [f64; 3] {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * v;
    [r * phi.cos(), r * phi.sin(), z]
}

/// Cosine-weighted direction on the +z hemisphere (pdf `cos θ / π`), Malley's method
/// via the concentric disk map (low distortion, so stratification survives).
#[inline]
pub fn cosine_hemisphere(u: f64, v: f64) -> [f64; 3] {
    let [x, y] = concentric_disk(u, v);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    [x, y, z]
}

/// Shirley–Chiu concentric map from `[0,1)²` to the unit disk.
#[inline]
pub fn concentric_disk(u: f64, v: f64) -> [f64; 2] {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, phi) = if a.abs() > b.abs() { (a, PI / 4.0 * (b / a)) } else { (b, PI / 2.0 - PI / 4.0 * (a / b)) };
    [r * phi.cos(), r * phi.sin()]
}

/// Uniform direction in the cone of half-angle `theta_max` around +z (pdf `1/(2π(1−cos θmax))`).
#[inline]
pub fn uniform_cone(u: f64, v: f64, cos_theta_max: f64) -> [f64; 3] {
    let z = 1.0 - u * (1.0 - cos_theta_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * v;
    [r * phi.cos(), r * phi.sin(), z]
}

/// An orthonormal frame `(t, b)` completing the unit vector `n` (Duff et al. 2017).
#[inline]
pub fn orthonormal_basis(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1.0f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    ([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]], [b, sign + n[1] * n[1] * a, -n[1]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_are_unit_and_in_domain() {
        for i in 0..64 {
            for j in 0..64 {
                let (u, v) = ((i as f64 + 0.5) / 64.0, (j as f64 + 0.5) / 64.0);
                for d in [uniform_sphere(u, v), cosine_hemisphere(u, v), uniform_cone(u, v, 0.5)] {
                    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    assert!((n - 1.0).abs() < 1e-12);
                }
                assert!(cosine_hemisphere(u, v)[2] >= 0.0);
                assert!(uniform_cone(u, v, 0.5)[2] >= 0.5 - 1e-12);
            }
        }
    }

    #[test]
    fn cosine_mean_is_two_thirds() {
        // E[cos θ] under the cosine pdf = 2/3.
        let n = 256;
        let mut s = 0.0;
        for i in 0..n {
            for j in 0..n {
                s += cosine_hemisphere((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64)[2];
            }
        }
        // sqrt(1-r²) has an infinite slope at the rim, so the midpoint grid converges
        // only like n^-1.5; a uniform-hemisphere warp would give 1/2, not 2/3.
        assert!((s / (n * n) as f64 - 2.0 / 3.0).abs() < 1e-3);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.6, 0.0, 0.8], [0.36, -0.48, 0.8]] {
            let (t, b) = orthonormal_basis(n);
            let dot = |a: [f64; 3], c: [f64; 3]| a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
            assert!(dot(t, n).abs() < 1e-12 && dot(b, n).abs() < 1e-12 && dot(t, b).abs() < 1e-12);
            assert!((dot(t, t) - 1.0).abs() < 1e-12 && (dot(b, b) - 1.0).abs() < 1e-12);
        }
    }
}
