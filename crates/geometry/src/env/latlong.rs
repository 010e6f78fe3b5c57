//! Lat-long (equirectangular) environment maps: the pixel ↔ direction mapping, exact texel
//! solid angles, bilinear lookup.

use std::f64::consts::PI;

use glam::DVec3;

use crate::error::EnvMapError;

/// A lat-long environment map: `width × height` linear RGB radiance texels (f32), row 0 at
/// the top. See the [module docs](crate::env) for the mapping.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvMap {
    width: usize,
    height: usize,
    data: Vec<[f32; 3]>,
}

impl EnvMap {
    /// A map from row-major texels (row 0 = top). Texels must be finite.
    pub fn new(width: usize, height: usize, data: Vec<[f32; 3]>) -> Result<Self, EnvMapError> {
        if width == 0 || height == 0 {
            return Err(EnvMapError::Empty { width, height });
        }
        let expected = width.saturating_mul(height);
        if data.len() != expected {
            return Err(EnvMapError::SizeMismatch { width, height, expected, got: data.len() });
        }
        if let Some(index) = data.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
            return Err(EnvMapError::NonFinite { index, value: data[index] });
        }
        Ok(Self { width, height, data })
    }

    /// A map of constant radiance.
    pub fn constant(width: usize, height: usize, rgb: [f32; 3]) -> Result<Self, EnvMapError> {
        Self::new(width, height, vec![rgb; width * height])
    }

    /// A map whose texel `(x, y)` is `f(direction of its centre)`.
    pub fn from_fn(width: usize, height: usize, f: impl Fn([f64; 3]) -> [f32; 3]) -> Result<Self, EnvMapError> {
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                data.push(f(texel_direction(width, height, x, y)));
            }
        }
        Self::new(width, height, data)
    }

    /// Width in texels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// All texels, row-major from the top row.
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.data
    }

    /// Texel `(x, y)`.
    pub fn texel(&self, x: usize, y: usize) -> [f32; 3] {
        self.data[y * self.width + x]
    }

    /// Unit direction through the centre of texel `(x, y)`.
    pub fn texel_direction(&self, x: usize, y: usize) -> [f64; 3] {
        texel_direction(self.width, self.height, x, y)
    }

    /// Exact solid angle of any texel of row `y`: `(2π/W)·(cos θ₀ − cos θ₁)` with
    /// `θ₀ = πy/H`, `θ₁ = π(y+1)/H` the polar angles (from +Y) of the row's edges.
    pub fn texel_solid_angle(&self, y: usize) -> f64 {
        texel_solid_angle(self.width, self.height, y)
    }

    /// Continuous texture coordinates `(u, v) ∈ [0, 1)²` of a direction (need not be unit):
    /// `u = (π − atan2(x, z)) / 2π`, `v = acos(y/|d|) / π`.
    pub fn direction_to_uv(dir: [f64; 3]) -> [f64; 2] {
        let d = DVec3::from(dir);
        let len = d.length();
        if len == 0.0 || !len.is_finite() {
            return [0.5, 0.5];
        }
        let theta = (d.y / len).clamp(-1.0, 1.0).acos();
        let lambda = d.x.atan2(d.z);
        let mut u = (PI - lambda) / (2.0 * PI);
        if u >= 1.0 {
            u -= 1.0;
        }
        [u, theta / PI]
    }

    /// Bilinear lookup of the radiance toward `dir` (need not be unit): wraps in longitude,
    /// clamps at the poles' texel centres.
    pub fn sample(&self, dir: [f64; 3]) -> [f32; 3] {
        let [u, v] = Self::direction_to_uv(dir);
        let px = u * self.width as f64 - 0.5;
        let py = (v * self.height as f64 - 0.5).clamp(0.0, (self.height - 1) as f64);
        let x0 = px.floor();
        let fx = px - x0;
        let y0 = py.floor();
        let fy = py - y0;
        let w = self.width as i64;
        let xa = (x0 as i64).rem_euclid(w) as usize;
        let xb = (x0 as i64 + 1).rem_euclid(w) as usize;
        let ya = y0 as usize;
        let yb = (ya + 1).min(self.height - 1);
        let t = |x: usize, y: usize| self.data[y * self.width + x];
        let mut out = [0.0f32; 3];
        for c in 0..3 {
            let top = t(xa, ya)[c] as f64 * (1.0 - fx) + t(xb, ya)[c] as f64 * fx;
            let bot = t(xa, yb)[c] as f64 * (1.0 - fx) + t(xb, yb)[c] as f64 * fx;
            out[c] = (top * (1.0 - fy) + bot * fy) as f32;
        }
        out
    }

    /// The texel containing `dir` (nearest lookup, no filtering).
    pub fn texel_at(&self, dir: [f64; 3]) -> [f32; 3] {
        let [u, v] = Self::direction_to_uv(dir);
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        self.data[y * self.width + x]
    }

    /// Every texel as `(unit direction of its centre, exact solid angle, rgb)`, row-major.
    pub fn iter(&self) -> impl Iterator<Item = ([f64; 3], f64, [f32; 3])> + '_ {
        (0..self.height).flat_map(move |y| {
            let sa = self.texel_solid_angle(y);
            (0..self.width).map(move |x| (self.texel_direction(x, y), sa, self.texel(x, y)))
        })
    }

    /// `∫ L dΩ` per channel (radiant power per unit area of the env), summed in f64.
    pub fn integral(&self) -> [f64; 3] {
        let mut acc = [0.0f64; 3];
        for y in 0..self.height {
            let sa = self.texel_solid_angle(y);
            let mut row = [0.0f64; 3];
            for t in &self.data[y * self.width..(y + 1) * self.width] {
                for c in 0..3 {
                    row[c] += t[c] as f64;
                }
            }
            for c in 0..3 {
                acc[c] += row[c] * sa;
            }
        }
        acc
    }
}

/// Centre direction of texel `(x, y)` of a `w × h` lat-long map (see the module docs).
pub fn texel_direction(w: usize, h: usize, x: usize, y: usize) -> [f64; 3] {
    let theta = PI * (y as f64 + 0.5) / h as f64;
    let lambda = PI - 2.0 * PI * (x as f64 + 0.5) / w as f64;
    let (st, ct) = theta.sin_cos();
    let (sl, cl) = lambda.sin_cos();
    [sl * st, ct, cl * st]
}

/// Exact solid angle of a texel in row `y` of a `w × h` lat-long map.
pub fn texel_solid_angle(w: usize, h: usize, y: usize) -> f64 {
    let t0 = PI * y as f64 / h as f64;
    let t1 = PI * (y + 1) as f64 / h as f64;
    // cos t0 − cos t1 = 2 sin((t0+t1)/2) sin((t1−t0)/2), accurate for thin rows
    2.0 * PI / w as f64 * 2.0 * (0.5 * (t0 + t1)).sin() * (0.5 * (t1 - t0)).sin()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_land_where_openexr_says() {
        let (w, h) = (8, 4);
        let m = EnvMap::constant(w, h, [1.0; 3]).unwrap();
        // u = 1/2 → +Z, u = 1/4 → +X, u = 3/4 → −X, u = 0 → −Z; v = 0 → +Y
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-15 && (a[1] - b[1]).abs() < 1e-15;
        assert!(close(EnvMap::direction_to_uv([0.0, 0.0, 1.0]), [0.5, 0.5]));
        assert!(close(EnvMap::direction_to_uv([1.0, 0.0, 0.0]), [0.25, 0.5]));
        assert!(close(EnvMap::direction_to_uv([-1.0, 0.0, 0.0]), [0.75, 0.5]));
        assert!(close(EnvMap::direction_to_uv([0.0, 0.0, -1.0]), [0.0, 0.5]));
        assert!(close(EnvMap::direction_to_uv([0.0, 1.0, 0.0]), [0.5, 0.0]));
        assert!(close(EnvMap::direction_to_uv([0.0, -1.0, 0.0]), [0.5, 1.0]));
        // texel_direction and direction_to_uv are inverse at texel centres
        for y in 0..h {
            for x in 0..w {
                let [u, v] = EnvMap::direction_to_uv(m.texel_direction(x, y));
                assert!((u * w as f64 - 0.5 - x as f64).abs() < 1e-12);
                assert!((v * h as f64 - 0.5 - y as f64).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        for (w, h) in [(2, 1), (8, 4), (1024, 512), (37, 19)] {
            let s: f64 = (0..h).map(|y| texel_solid_angle(w, h, y) * w as f64).sum();
            assert!((s - 4.0 * PI).abs() <= 1e-12 * 4.0 * PI, "{w}x{h}: {s}");
        }
        // a constant map integrates to 4π·L
        let m = EnvMap::constant(64, 32, [2.0, 1.0, 0.5]).unwrap();
        let i = m.integral();
        assert!((i[0] - 8.0 * PI).abs() < 1e-12);
        assert!((i[2] - 2.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn bilinear_reproduces_texels_and_wraps() {
        let m = EnvMap::from_fn(16, 8, |d| [d[0] as f32, d[1] as f32, d[2] as f32]).unwrap();
        for (x, y) in [(0, 3), (15, 4), (7, 0), (3, 7)] {
            let d = m.texel_direction(x, y);
            let s = m.sample(d);
            let t = m.texel(x, y);
            for c in 0..3 {
                assert!((s[c] - t[c]).abs() < 1e-6);
            }
        }
        // across the seam (u = 0 / 1): halfway between the last and first column
        let d = [0.0, 0.0, -1.0];
        let s = m.sample(d);
        let (a, b) = (m.texel(0, 3), m.texel(15, 3));
        let (a4, b4) = (m.texel(0, 4), m.texel(15, 4));
        for c in 0..3 {
            let e = 0.25 * (a[c] + b[c] + a4[c] + b4[c]);
            assert!((s[c] - e).abs() < 1e-6);
        }
        assert!(EnvMap::new(2, 2, vec![[0.0; 3]; 3]).is_err());
        assert!(EnvMap::new(2, 1, vec![[0.0; 3], [f32::NAN, 0.0, 0.0]]).is_err());
    }
}
