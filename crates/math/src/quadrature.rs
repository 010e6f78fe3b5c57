//! Deterministic quadrature rules: Gauss–Legendre on an interval and product rules on the sphere.

use core::f64::consts::PI;

/// Gauss–Legendre nodes and weights on `[-1, 1]`.
///
/// Exact for polynomials of degree `≤ 2n − 1`. Nodes by Newton iteration on `P_n`
/// from Tricomi's initial guesses; accurate to a few ulps for `n` up to several thousand.
#[derive(Debug, Clone)]
pub struct GaussLegendre {
    /// Nodes in ascending order.
    pub nodes: Vec<f64>,
    /// Weights, summing to 2.
    pub weights: Vec<f64>,
}

impl GaussLegendre {
    /// `n`-point rule (`n ≥ 1`).
    pub fn new(n: usize) -> Self {
        assert!(n >= 1);
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        let nf = n as f64;
        for i in 0..n.div_ceil(2) {
            // Tricomi's approximation of the i-th root (descending).
            let theta = PI * (4.0 * i as f64 + 3.0) / (4.0 * nf + 2.0);
            let mut x = (1.0 - (nf - 1.0) / (8.0 * nf * nf * nf)) * theta.cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (p, d) = legendre_and_derivative(n, x);
                dp = d;
                let dx = p / d;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, d) = legendre_and_derivative(n, x);
            if d != 0.0 {
                dp = d;
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            nodes[i] = -x;
            nodes[n - 1 - i] = x;
            weights[i] = w;
            weights[n - 1 - i] = w;
        }
        if n % 2 == 1 {
            nodes[n / 2] = 0.0;
        }
        Self { nodes, weights }
    }

    /// Nodes and weights mapped to `[a, b]`.
    pub fn on_interval(&self, a: f64, b: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let h = 0.5 * (b - a);
        let c = 0.5 * (b + a);
        self.nodes.iter().zip(&self.weights).map(move |(&x, &w)| (c + h * x, h * w))
    }

    /// Integrates `f` over `[a, b]`.
    pub fn integrate(&self, a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
        self.on_interval(a, b).map(|(x, w)| w * f(x)).sum()
    }
}

/// Process-wide cache of Gauss–Legendre rules (construction is O(n²); bakes reuse a few
/// sizes thousands of times).
pub fn gauss_legendre_cached(n: usize) -> std::sync::Arc<GaussLegendre> {
    use std::collections::BTreeMap;
    use std::sync::{Arc, Mutex, OnceLock};
    static CACHE: OnceLock<Mutex<BTreeMap<usize, Arc<GaussLegendre>>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(BTreeMap::new()));
    if let Some(r) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&n) {
        return r.clone();
    }
    let rule = Arc::new(GaussLegendre::new(n));
    cache.lock().unwrap_or_else(|e| e.into_inner()).entry(n).or_insert(rule).clone()
}

fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let mut p0 = 1.0;
    let mut p1 = x;
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

/// Product quadrature on the unit sphere: Gauss–Legendre in `z = cos θ` times the
/// uniform (trapezoidal) rule in `φ`.
///
/// With `nz` Gauss nodes and `nphi` azimuth samples it integrates every spherical
/// polynomial of degree `≤ min(2·nz − 1, nphi − 1)` exactly (up to rounding); in
/// particular products of SH functions whose band indices sum to at most that degree.
#[derive(Debug, Clone)]
pub struct SphereQuadrature {
    gl: GaussLegendre,
    nphi: usize,
    /// Optional rotation of the φ origin (in units of the φ step) so that no sample
    /// falls on a chosen meridian.
    phi_offset: f64,
}

impl SphereQuadrature {
    /// Rule with `nz` latitude nodes and `nphi` longitude samples.
    pub fn new(nz: usize, nphi: usize) -> Self {
        Self { gl: GaussLegendre::new(nz), nphi, phi_offset: 0.5 }
    }

    /// Smallest product rule exact for spherical polynomials of total degree `degree`.
    pub fn exact_for_degree(degree: usize) -> Self {
        Self::new(degree / 2 + 1, degree + 1)
    }

    /// Number of sample directions.
    pub fn len(&self) -> usize {
        self.gl.nodes.len() * self.nphi
    }

    /// Whether the rule is empty (never, for a constructed rule).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `(direction, weight)` pairs; weights sum to 4π.
    pub fn iter(&self) -> impl Iterator<Item = ([f64; 3], f64)> + '_ {
        let dphi = 2.0 * PI / self.nphi as f64;
        self.gl.nodes.iter().zip(&self.gl.weights).flat_map(move |(&z, &wz)| {
            let s = (1.0 - z * z).max(0.0).sqrt();
            (0..self.nphi).map(move |k| {
                let phi = (k as f64 + self.phi_offset) * dphi;
                let (sp, cp) = phi.sin_cos();
                ([s * cp, s * sp, z], wz * dphi)
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_exactness() {
        for n in [1usize, 2, 5, 16, 64] {
            let g = GaussLegendre::new(n);
            let sw: f64 = g.weights.iter().sum();
            assert!((sw - 2.0).abs() < 1e-13, "n={n}");
            for deg in 0..(2 * n) {
                let got: f64 = g.integrate(-1.0, 1.0, |x| x.powi(deg as i32));
                let want = if deg % 2 == 1 { 0.0 } else { 2.0 / (deg as f64 + 1.0) };
                assert!((got - want).abs() < 1e-13, "n={n} deg={deg}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn gauss_legendre_large_n() {
        let g = GaussLegendre::new(1000);
        let got = g.integrate(0.0, PI, f64::sin);
        assert!((got - 2.0).abs() < 1e-13);
        for w in g.nodes.windows(2) {
            assert!(w[0] < w[1]);
        }
    }

    #[test]
    fn sphere_weights_sum_to_4pi() {
        let q = SphereQuadrature::exact_for_degree(10);
        let s: f64 = q.iter().map(|(_, w)| w).sum();
        assert!((s - 4.0 * PI).abs() < 1e-12);
        // ∫ z² = 4π/3, ∫ x²y² = 4π/15
        let z2: f64 = q.iter().map(|(d, w)| w * d[2] * d[2]).sum();
        assert!((z2 - 4.0 * PI / 3.0).abs() < 1e-12);
        let x2y2: f64 = q.iter().map(|(d, w)| w * d[0] * d[0] * d[1] * d[1]).sum();
        assert!((x2y2 - 4.0 * PI / 15.0).abs() < 1e-12);
    }
}
