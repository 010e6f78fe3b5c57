//! The sample layout of a FIV bake: the occluder frame (minimum enclosing ball) and the
//! concentric shells of sample positions (FIV §4.2, Fig. 4).
//!
//! With `A × P × K` samples (azimuth × polar × radial):
//! - `θ_i = 2πi/A` (i = 0..A), `φ_j = πj/(P−1)` (j = 0..P, both poles included),
//!   `ρ_k = R·(r_min + (r_max − r_min)·k/(K−1))` (k = 0..K);
//! - sample `(i, j, k)` sits at `c + ρ_k·(sin φ_j sin θ_i·e₁ + cos φ_j·e₂ + sin φ_j cos θ_i·e₃)`.
//!
//! `(e₁, e₂, e₃)` is the shell basis: for `--up y` (default) `(+X, +Y, +Z)`, so the position
//! is `c + ρ(sin φ sin θ, cos φ, sin φ cos θ)`: the polar axis is +Y and θ turns from +Z
//! toward +X. For `--up z` it is `(+Y, +Z, +X)`: polar axis +Z, θ from +X toward +Y
//! (the same right-handed frame, cyclically relabelled). At the poles (`j = 0`, `j = P−1`)
//! `sin φ` is taken as exactly 0, so every θ gives the same position and the same FIV.

use serde::{Deserialize, Serialize};

/// The polar axis of the shells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// +Y up (glTF, most OBJ files).
    #[default]
    Y,
    /// +Z up.
    Z,
}

impl UpAxis {
    /// The shell basis `(e₁, e₂, e₃)`, `e₂` the polar axis.
    pub fn basis(self) -> [[f64; 3]; 3] {
        match self {
            UpAxis::Y => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            UpAxis::Z => [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
        }
    }

    /// Index of the up axis (1 for Y, 2 for Z).
    pub fn index(self) -> usize {
        match self {
            UpAxis::Y => 1,
            UpAxis::Z => 2,
        }
    }

    /// `"y"` or `"z"`.
    pub fn name(self) -> &'static str {
        match self {
            UpAxis::Y => "y",
            UpAxis::Z => "z",
        }
    }
}

/// Allowed azimuth counts A.
pub const AZIMUTH: core::ops::RangeInclusive<usize> = 2..=4096;
/// Allowed polar counts P (both poles included).
pub const POLAR: core::ops::RangeInclusive<usize> = 2..=2049;
/// Allowed radial counts K.
pub const RADIAL: core::ops::RangeInclusive<usize> = 2..=1024;
/// Largest total sample count A·P·K (2²⁴: 604 MB of f32 FIVs).
pub const MAX_SAMPLES: usize = 1 << 24;
/// Largest allowed `r_max` (in units of R).
pub const MAX_R: f64 = 1000.0;

/// Shell counts and radii; radii in units of the occluder's bounding radius R.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ShellLayout {
    /// Azimuth samples A.
    pub azimuth: usize,
    /// Polar samples P (both poles included).
    pub polar: usize,
    /// Radial samples K.
    pub radial: usize,
    /// Innermost shell radius / R (≥ 0).
    pub r_min: f64,
    /// Outermost shell radius / R (> r_min).
    pub r_max: f64,
    /// Polar axis.
    pub up: UpAxis,
}

impl Default for ShellLayout {
    fn default() -> Self {
        Self { azimuth: 32, polar: 17, radial: 15, r_min: 1.0, r_max: 8.0, up: UpAxis::Y }
    }
}

/// The occluder frame: minimum enclosing ball of the vertices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// Centre c of the ball.
    pub center: [f64; 3],
    /// Radius R of the ball.
    pub radius: f64,
}

impl ShellLayout {
    /// Total number of samples A·P·K.
    pub fn samples(&self) -> usize {
        self.azimuth * self.polar * self.radial
    }

    /// Checks the counts and radii; the message names the allowed range.
    pub fn validate(&self) -> Result<(), String> {
        let check = |name: &str, v: usize, r: &core::ops::RangeInclusive<usize>| {
            if r.contains(&v) {
                Ok(())
            } else {
                Err(format!("{name} count {v} is out of range (allowed: {}..={})", r.start(), r.end()))
            }
        };
        check("azimuth", self.azimuth, &AZIMUTH)?;
        check("polar", self.polar, &POLAR)?;
        check("radial", self.radial, &RADIAL)?;
        let n = self.azimuth.saturating_mul(self.polar).saturating_mul(self.radial);
        if n > MAX_SAMPLES {
            return Err(format!("{n} samples are too many (allowed: at most {MAX_SAMPLES})"));
        }
        if !(self.r_min.is_finite() && self.r_min >= 0.0 && self.r_min < MAX_R) {
            return Err(format!("r_min {} is out of range (allowed: 0 <= r_min < {MAX_R})", self.r_min));
        }
        if !(self.r_max.is_finite() && self.r_max > self.r_min && self.r_max <= MAX_R) {
            return Err(format!("r_max {} is out of range (allowed: r_min < r_max <= {MAX_R})", self.r_max));
        }
        Ok(())
    }

    /// `θ_i = 2πi/A`.
    pub fn theta(&self, i: usize) -> f64 {
        std::f64::consts::TAU * i as f64 / self.azimuth as f64
    }

    /// `φ_j = πj/(P−1)`.
    pub fn phi(&self, j: usize) -> f64 {
        std::f64::consts::PI * j as f64 / (self.polar - 1) as f64
    }

    /// `ρ_k / R = r_min + (r_max − r_min)·k/(K−1)`.
    pub fn rho_over_r(&self, k: usize) -> f64 {
        self.r_min + (self.r_max - self.r_min) * k as f64 / (self.radial - 1) as f64
    }

    /// Unit direction of azimuth `i`, polar `j` in world coordinates (exact on the poles).
    pub fn direction(&self, i: usize, j: usize) -> [f64; 3] {
        let (st, ct) = self.theta(i).sin_cos();
        let (sp, cp) = if j == 0 {
            (0.0, 1.0)
        } else if j + 1 == self.polar {
            (0.0, -1.0)
        } else {
            self.phi(j).sin_cos()
        };
        let local = [sp * st, cp, sp * ct];
        let b = self.up.basis();
        let mut out = [0.0; 3];
        for (e, l) in b.iter().zip(local) {
            for c in 0..3 {
                out[c] += e[c] * l;
            }
        }
        out
    }

    /// World position of sample `(i, j, k)` in `frame`.
    pub fn position(&self, frame: &Frame, i: usize, j: usize, k: usize) -> [f64; 3] {
        let d = self.direction(i, j);
        let rho = frame.radius * self.rho_over_r(k);
        [frame.center[0] + rho * d[0], frame.center[1] + rho * d[1], frame.center[2] + rho * d[2]]
    }

    /// Flat sample index `(i·P + j)·K + k` (row-major over `[A, P, K]`).
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.polar + j) * self.radial + k
    }
}

/// A slab of azimuth indices `[start, end)`: the part of the samples one shard bakes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Shard number K (0-based).
    pub index: usize,
    /// Number of shards N.
    pub count: usize,
}

impl Shard {
    /// The whole bake.
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// Azimuth range `[⌊K·A/N⌋, ⌊(K+1)·A/N⌋)` of this shard.
    pub fn azimuth_range(&self, azimuth: usize) -> core::ops::Range<usize> {
        (self.index * azimuth / self.count)..((self.index + 1) * azimuth / self.count)
    }

    /// Checks `0 ≤ K < N ≤ A`.
    pub fn validate(&self, azimuth: usize) -> Result<(), String> {
        if self.count == 0 || self.index >= self.count {
            return Err(format!("shard {}/{} is invalid (expected K/N with 0 <= K < N)", self.index, self.count));
        }
        if self.count > azimuth {
            return Err(format!(
                "{} shards for {azimuth} azimuth samples: every shard needs at least one azimuth slab (allowed: N <= {azimuth})",
                self.count
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_follow_the_documented_formula() {
        let l = ShellLayout { azimuth: 8, polar: 5, radial: 3, r_min: 1.0, r_max: 3.0, up: UpAxis::Y };
        let f = Frame { center: [1.0, 2.0, 3.0], radius: 2.0 };
        // θ = 0, φ = π/2, ρ = R·1: toward +Z
        let p = l.position(&f, 0, 2, 0);
        assert!((p[0] - 1.0).abs() < 1e-15 && (p[1] - 2.0).abs() < 1e-15 && (p[2] - 5.0).abs() < 1e-15);
        // θ = π/2 (i = 2): toward +X; ρ = R·2 (k = 1)
        let p = l.position(&f, 2, 2, 1);
        assert!((p[0] - 5.0).abs() < 1e-14 && (p[1] - 2.0).abs() < 1e-14 && (p[2] - 3.0).abs() < 1e-14);
        // poles are exact and shared by all θ
        assert_eq!(l.position(&f, 3, 0, 2), [1.0, 8.0, 3.0]);
        assert_eq!(l.position(&f, 5, 4, 2), [1.0, -4.0, 3.0]);
        // z-up: the pole is +Z, θ = 0 is +X, θ = π/2 is +Y
        let z = ShellLayout { up: UpAxis::Z, ..l };
        assert_eq!(z.direction(0, 0), [0.0, 0.0, 1.0]);
        let d = z.direction(0, 2);
        assert!((d[0] - 1.0).abs() < 1e-15 && d[1].abs() < 1e-15 && d[2].abs() < 1e-15);
        let d = z.direction(2, 2);
        assert!(d[0].abs() < 1e-15 && (d[1] - 1.0).abs() < 1e-15 && d[2].abs() < 1e-15);
    }

    #[test]
    fn shards_partition_the_azimuths() {
        for a in [2usize, 7, 128] {
            for n in 1..=a.min(9) {
                let mut next = 0;
                for k in 0..n {
                    let r = Shard { index: k, count: n }.azimuth_range(a);
                    assert_eq!(r.start, next);
                    assert!(!r.is_empty());
                    next = r.end;
                }
                assert_eq!(next, a);
            }
        }
        assert!(Shard { index: 3, count: 3 }.validate(8).is_err());
        assert!(Shard { index: 0, count: 9 }.validate(8).is_err());
    }

    #[test]
    fn validation_names_the_ranges() {
        let mut l = ShellLayout::default();
        assert!(l.validate().is_ok());
        l.polar = 1;
        assert!(l.validate().unwrap_err().contains("2..=2049"));
        l = ShellLayout { r_min: 2.0, r_max: 1.0, ..ShellLayout::default() };
        assert!(l.validate().unwrap_err().contains("r_min < r_max"));
    }
}
