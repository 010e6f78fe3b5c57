//! Brute-force references: what the bake and the runtime approximate, computed by casting a
//! ray toward every environment texel against the actual meshes.
//!
//! - [`occluded_fiv`]: the FIV of the occluded environment at a point (no cone culling);
//! - [`irradiance`]: the irradiance at a receiver `(p, n)` among placed occluders,
//!   `E = Σ_t max(0, n·ω_t)·V(p, ω_t)·L_t dΩ_t` (FIV eq. 3 on the cube texels), the
//!   "standard rendering formula with an overall integration of the unoccluded part of the
//!   environment map" of FIV §5;
//! - [`nrmse`]: the paper's error measure.

use crate::bake::Occluder;
use crate::lighting::Lighting;
use penumbra_geometry::{MeshBvh, Ray};

/// An occluder mesh translated by `offset` (world units).
#[derive(Debug, Clone, Copy)]
pub struct Placed<'a> {
    /// The mesh's BVH (in the mesh's own coordinates).
    pub bvh: &'a MeshBvh,
    /// Translation applied to the mesh.
    pub offset: [f64; 3],
    /// A ball `(centre, radius)` holding the mesh (its own coordinates), if known: rays
    /// missing it are not traced (the answer is the same, only faster).
    pub ball: Option<([f64; 3], f64)>,
}

impl Placed<'_> {
    /// Whether the ray from `p` along the unit direction `d` (`s ≥ tmin`) hits the placed
    /// mesh.
    pub fn hits(&self, p: [f64; 3], d: [f64; 3], tmin: f64) -> bool {
        let o = [p[0] - self.offset[0], p[1] - self.offset[1], p[2] - self.offset[2]];
        if let Some((c, r)) = self.ball {
            let v = [c[0] - o[0], c[1] - o[1], c[2] - o[2]];
            let t = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
            let vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            let r2 = (r * (1.0 + 1e-9)).powi(2);
            // the ball is behind the origin, or the line passes outside it
            if (t < 0.0 && vv > r2) || vv - t * t > r2 {
                return false;
            }
        }
        self.bvh.any_hit(&Ray::new(o, d).with_range(tmin, f64::INFINITY))
    }
}

/// FIV of the environment part hidden by `occ` as seen from `p`: a ray toward every texel.
pub fn occluded_fiv(occ: &Occluder, lighting: &Lighting, p: [f64; 3]) -> [[f64; 3]; 3] {
    let mut acc = [[0.0f64; 3]; 3];
    for t in 0..lighting.texel_count() {
        let d = lighting.direction(t);
        if occ.bvh().any_hit(&Ray::new(p, d)) {
            let w = lighting.weight(t);
            for c in 0..3 {
                for x in 0..3 {
                    acc[c][x] += w[c] * d[x];
                }
            }
        }
    }
    acc
}

/// Irradiance at `p` with unit normal `n` among `occluders`: a ray toward every texel of the
/// upper hemisphere against every placed mesh. Rays start at `p` (`s ≥ 0`); a receiver on a
/// mesh surface must be offset along its normal by the caller.
pub fn irradiance(lighting: &Lighting, occluders: &[Placed<'_>], p: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    let mut acc = [0.0f64; 3];
    for t in 0..lighting.texel_count() {
        let d = lighting.direction(t);
        let c = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        if c <= 0.0 || occluders.iter().any(|o| o.hits(p, d, 0.0)) {
            continue;
        }
        let w = lighting.weight(t);
        for k in 0..3 {
            acc[k] += c * w[k];
        }
    }
    acc
}

/// Error of `approx` against `reference` (flattened receivers × channels):
/// `(NRMSE, max |error|)` with NRMSE = RMSE / (max − min of the reference) (FIV §5).
/// Returns NaN NRMSE for an empty or constant reference.
pub fn nrmse(approx: &[f64], reference: &[f64]) -> (f64, f64) {
    assert_eq!(approx.len(), reference.len(), "nrmse: lengths differ");
    if reference.is_empty() {
        return (f64::NAN, 0.0);
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut se, mut max) = (0.0f64, 0.0f64);
    for (a, r) in approx.iter().zip(reference) {
        lo = lo.min(*r);
        hi = hi.max(*r);
        let e = a - r;
        se += e * e;
        max = max.max(e.abs());
    }
    let rmse = (se / reference.len() as f64).sqrt();
    (if hi > lo { rmse / (hi - lo) } else { f64::NAN }, max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nrmse_known_answers() {
        let r = [0.0, 1.0, 2.0, 4.0];
        let a = [0.5, 1.0, 2.0, 3.5];
        let (n, m) = nrmse(&a, &r);
        // RMSE = sqrt((0.25 + 0.25)/4) = 0.3536, range 4
        assert!((n - (0.5f64 / 4.0).sqrt() / 4.0).abs() < 1e-15);
        assert_eq!(m, 0.5);
        assert!(nrmse(&[1.0, 1.0], &[2.0, 2.0]).0.is_nan());
    }
}
