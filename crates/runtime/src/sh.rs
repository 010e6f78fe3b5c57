//! Real orthonormal SH in f32, same convention as the bake (`i = l(l+1)+m`,
//! Condon–Shortley phase: `y₁₋₁ ∝ −y, y₁₀ ∝ z, y₁₁ ∝ −x`; see `schemas/asset-format.md`).

/// Largest order the runtime evaluates.
pub const MAX_ORDER: usize = 8;

/// SH evaluator with precomputed normalisation constants (no allocation per call).
#[derive(Debug, Clone)]
pub struct ShBasis {
    order: usize,
    /// `k[l * MAX_ORDER + m]` = `K_l^m` (times √2 for m > 0).
    k: [f32; MAX_ORDER * MAX_ORDER],
    /// Associated-Legendre recurrence `P_l = a·z·P_{l−1} − b·P_{l−2}` for `l ≥ m + 2`:
    /// `a = (2l−1)/(l−m)`, `b = (l+m−1)/(l−m)` (precomputed: no division per evaluation).
    ra: [f32; MAX_ORDER * MAX_ORDER],
    rb: [f32; MAX_ORDER * MAX_ORDER],
}

impl ShBasis {
    /// Evaluator for `order` bands (clamped to 1..=8).
    pub fn new(order: usize) -> Self {
        let order = order.clamp(1, MAX_ORDER);
        let mut k = [0.0f32; MAX_ORDER * MAX_ORDER];
        for l in 0..order {
            for m in 0..=l {
                let mut ratio = 1.0f64;
                for f in (l - m + 1)..=(l + m) {
                    ratio /= f as f64;
                }
                let s = if m == 0 { 1.0 } else { core::f64::consts::SQRT_2 };
                k[l * MAX_ORDER + m] = (s * ((2 * l + 1) as f64 / (4.0 * core::f64::consts::PI) * ratio).sqrt()) as f32;
            }
        }
        let mut ra = [0.0f32; MAX_ORDER * MAX_ORDER];
        let mut rb = [0.0f32; MAX_ORDER * MAX_ORDER];
        for l in 0..order {
            for m in 0..l.saturating_sub(1) {
                ra[l * MAX_ORDER + m] = (2 * l - 1) as f32 / (l - m) as f32;
                rb[l * MAX_ORDER + m] = (l + m - 1) as f32 / (l - m) as f32;
            }
        }
        Self { order, k, ra, rb }
    }

    /// Number of bands.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Writes `y_i(dir)` for `i < order²` into `out`; `dir` must be unit length.
    #[inline]
    pub fn eval(&self, dir: [f32; 3], out: &mut [f32]) {
        self.visit(dir, |i, _, v| out[i] = v);
    }

    /// Adds `w[l] · y_lm(dir)` to `f[lm]` for every `lm < order²` (the rotation rule of a
    /// zonal function with starred coefficients `w`, accumulated in place).
    #[inline]
    pub fn add_zonal(&self, dir: [f32; 3], w: &[f32], f: &mut [f32]) {
        let w = &w[..self.order];
        self.visit(dir, |i, l, v| f[i] += w[l] * v);
    }

    /// [`ShBasis::add_zonal`] for a compile-time order `N` (`N2 = N²`): the loops unroll and
    /// the bounds checks vanish, which the per-receiver runtime needs (order = `self.order()`
    /// is the caller's responsibility).
    #[inline(always)]
    pub(crate) fn add_zonal_n<const N: usize, const N2: usize>(&self, dir: [f32; 3], w: &[f32; N], f: &mut [f32; N2]) {
        let [x, y, z] = dir;
        let (mut c, mut s) = (1.0f32, 0.0f32);
        let mut q_mm = 1.0f32;
        for m in 0..N {
            if m > 0 {
                let (c2, s2) = (c * x - s * y, c * y + s * x);
                c = c2;
                s = s2;
                q_mm *= -((2 * m - 1) as f32);
            }
            let mut q_prev = 0.0f32;
            let mut q = q_mm;
            for l in m..N {
                if l == m + 1 {
                    q_prev = q;
                    q = z * (2 * m + 1) as f32 * q_mm;
                } else if l > m + 1 {
                    let next = self.ra[l * MAX_ORDER + m] * z * q - self.rb[l * MAX_ORDER + m] * q_prev;
                    q_prev = q;
                    q = next;
                }
                let kq = w[l] * self.k[l * MAX_ORDER + m] * q;
                let base = l * (l + 1);
                if m == 0 {
                    f[base] += kq;
                } else {
                    f[base + m] += kq * c;
                    f[base - m] += kq * s;
                }
            }
        }
    }

    /// [`ShBasis::add_zonal_n`] on `L` directions at once, structure of arrays
    /// (`dir[axis][lane]`, `w[l][lane]`, `f[lm][lane]`): the same operations in the same
    /// order per lane, so each lane equals the scalar result (the compiler vectorises across
    /// lanes).
    #[inline(always)]
    pub(crate) fn add_zonal_lanes<const N: usize, const N2: usize, const L: usize>(
        &self,
        dir: &[[f32; L]; 3],
        w: &[[f32; L]; N],
        f: &mut [[f32; L]; N2],
    ) {
        let [x, y, z] = dir;
        let mut c = [1.0f32; L];
        let mut s = [0.0f32; L];
        let mut q_mm = 1.0f32;
        for m in 0..N {
            if m > 0 {
                for lane in 0..L {
                    let (c2, s2) = (c[lane] * x[lane] - s[lane] * y[lane], c[lane] * y[lane] + s[lane] * x[lane]);
                    c[lane] = c2;
                    s[lane] = s2;
                }
                q_mm *= -((2 * m - 1) as f32);
            }
            let mut q_prev = [0.0f32; L];
            let mut q = [q_mm; L];
            for l in m..N {
                if l == m + 1 {
                    q_prev = q;
                    for lane in 0..L {
                        q[lane] = z[lane] * (2 * m + 1) as f32 * q_mm;
                    }
                } else if l > m + 1 {
                    let (ra, rb) = (self.ra[l * MAX_ORDER + m], self.rb[l * MAX_ORDER + m]);
                    for lane in 0..L {
                        let next = ra * z[lane] * q[lane] - rb * q_prev[lane];
                        q_prev[lane] = q[lane];
                        q[lane] = next;
                    }
                }
                let k = self.k[l * MAX_ORDER + m];
                let base = l * (l + 1);
                for lane in 0..L {
                    let kq = w[l][lane] * k * q[lane];
                    if m == 0 {
                        f[base][lane] += kq;
                    } else {
                        f[base + m][lane] += kq * c[lane];
                        f[base - m][lane] += kq * s[lane];
                    }
                }
            }
        }
    }

    /// [`ShBasis::rotate_zonal`] for a compile-time order `N` (`N2 = N²`) on `L` axes at once,
    /// structure of arrays (`axis[a][lane]`, `out[lm][lane]`): `y_lm(axis)` by the same
    /// recurrences as [`ShBasis::eval`], then times `zh_star[l]`, so each lane equals the
    /// scalar result bit for bit.
    #[inline(always)]
    pub(crate) fn rotate_zonal_lanes<const N: usize, const N2: usize, const L: usize>(
        &self,
        zh_star: &[f32; N],
        axis: &[[f32; L]; 3],
        out: &mut [[f32; L]; N2],
    ) {
        let [x, y, z] = axis;
        let mut c = [1.0f32; L];
        let mut s = [0.0f32; L];
        let mut q_mm = 1.0f32;
        for m in 0..N {
            if m > 0 {
                for lane in 0..L {
                    let (c2, s2) = (c[lane] * x[lane] - s[lane] * y[lane], c[lane] * y[lane] + s[lane] * x[lane]);
                    c[lane] = c2;
                    s[lane] = s2;
                }
                q_mm *= -((2 * m - 1) as f32);
            }
            let mut q_prev = [0.0f32; L];
            let mut q = [q_mm; L];
            for l in m..N {
                if l == m + 1 {
                    q_prev = q;
                    for lane in 0..L {
                        q[lane] = z[lane] * (2 * m + 1) as f32 * q_mm;
                    }
                } else if l > m + 1 {
                    let (ra, rb) = (self.ra[l * MAX_ORDER + m], self.rb[l * MAX_ORDER + m]);
                    for lane in 0..L {
                        let next = ra * z[lane] * q[lane] - rb * q_prev[lane];
                        q_prev[lane] = q[lane];
                        q[lane] = next;
                    }
                }
                let (k, zl) = (self.k[l * MAX_ORDER + m], zh_star[l]);
                let base = l * (l + 1);
                for lane in 0..L {
                    let kq = k * q[lane];
                    if m == 0 {
                        out[base][lane] = kq * zl;
                    } else {
                        out[base + m][lane] = kq * c[lane] * zl;
                        out[base - m][lane] = kq * s[lane] * zl;
                    }
                }
            }
        }
    }

    /// Calls `sink(index, band, y)` for every basis function at `dir`.
    #[inline(always)]
    fn visit(&self, dir: [f32; 3], mut sink: impl FnMut(usize, usize, f32)) {
        let order = self.order;
        let [x, y, z] = dir;
        let (mut c, mut s) = (1.0f32, 0.0f32);
        let mut q_mm = 1.0f32;
        for m in 0..order {
            if m > 0 {
                let (c2, s2) = (c * x - s * y, c * y + s * x);
                c = c2;
                s = s2;
                q_mm *= -((2 * m - 1) as f32);
            }
            let mut q_prev = 0.0f32;
            let mut q = q_mm;
            for l in m..order {
                if l == m + 1 {
                    q_prev = q;
                    q = z * (2 * m + 1) as f32 * q_mm;
                } else if l > m + 1 {
                    let next = self.ra[l * MAX_ORDER + m] * z * q - self.rb[l * MAX_ORDER + m] * q_prev;
                    q_prev = q;
                    q = next;
                }
                let kq = self.k[l * MAX_ORDER + m] * q;
                let base = l * (l + 1);
                if m == 0 {
                    sink(base, l, kq);
                } else {
                    sink(base + m, l, kq * c);
                    sink(base - m, l, kq * s);
                }
            }
        }
    }

    /// Rotation rule for zonal functions: `out[l,m] = zh_star[l] · y_lm(axis)` with starred
    /// zonal coefficients `z*_l = √(4π/(2l+1)) z_l` as stored in SHTB tables.
    pub fn rotate_zonal(&self, zh_star: &[f32], axis: [f32; 3], out: &mut [f32]) {
        self.eval(axis, out);
        for (l, z) in zh_star.iter().enumerate().take(self.order) {
            for o in &mut out[l * l..(l + 1) * (l + 1)] {
                *o *= z;
            }
        }
    }
}
