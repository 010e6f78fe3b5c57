//! The lighting environment as the bake sees it: a cube map of radiance whose texels are
//! directional lights `L_t` in direction `ω_t` (texel centre) with weight `L_t·dΩ_t` (exact
//! solid angle), the diffuse irradiance cube map (FIV §4.2, "DifMap") and the environment's
//! FIV (FIV eq. 9).
//!
//! For the visibility pass the texels are grouped into square tiles with a bounding cone of
//! their centre directions, so a sample can skip every tile outside the cone that bounds
//! its occluder.

use penumbra_geometry::{CubeFace, CubeMap, PreparedDir};
use rayon::prelude::*;

/// Texels per tile side.
const TILE: usize = 4;

/// One tile of texels with the cone bounding their centre directions.
#[derive(Debug, Clone)]
pub(crate) struct Tile {
    /// Unit axis.
    pub axis: [f64; 3],
    /// cos and sin of the half-angle β.
    pub cos_b: f64,
    pub sin_b: f64,
    /// Range into [`Lighting::tile_texels`].
    pub start: u32,
    pub end: u32,
}

/// A cube-map environment prepared for the bake.
#[derive(Debug, Clone)]
pub struct Lighting {
    cube: CubeMap,
    /// Unit direction of every texel centre, storage order.
    dirs: Vec<[f64; 3]>,
    /// `L·dΩ` per texel and channel.
    weights: Vec<[f64; 3]>,
    /// Texel directions prepared for ray casting.
    prepared: Vec<PreparedDir>,
    pub(crate) tiles: Vec<Tile>,
    /// Texel indices grouped by tile.
    pub(crate) tile_texels: Vec<u32>,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Lighting {
    /// Prepares `cube` (radiance, linear RGB).
    pub fn new(cube: CubeMap) -> Self {
        let n = cube.size();
        let mut dirs = Vec::with_capacity(6 * n * n);
        let mut weights = Vec::with_capacity(6 * n * n);
        for (_, d, sa, rgb) in cube.iter() {
            dirs.push(d);
            weights.push([rgb[0] as f64 * sa, rgb[1] as f64 * sa, rgb[2] as f64 * sa]);
        }
        let mut tiles = Vec::new();
        let mut tile_texels = Vec::with_capacity(dirs.len());
        for f in CubeFace::ALL {
            for tj in (0..n).step_by(TILE) {
                for ti in (0..n).step_by(TILE) {
                    let start = tile_texels.len() as u32;
                    let mut sum = [0.0f64; 3];
                    for j in tj..(tj + TILE).min(n) {
                        for i in ti..(ti + TILE).min(n) {
                            let t = (f.index() * n + j) * n + i;
                            tile_texels.push(t as u32);
                            for c in 0..3 {
                                sum[c] += dirs[t][c];
                            }
                        }
                    }
                    let len = dot(sum, sum).sqrt();
                    let axis = sum.map(|v| v / len);
                    let members = &tile_texels[start as usize..];
                    // half-angle to the farthest member, padded for rounding
                    let cos_b = members.iter().map(|&t| dot(axis, dirs[t as usize])).fold(1.0f64, f64::min);
                    let cos_b = (cos_b - 1e-12).clamp(-1.0, 1.0);
                    let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
                    tiles.push(Tile { axis, cos_b, sin_b, start, end: tile_texels.len() as u32 });
                }
            }
        }
        // texel-centre directions are unit and finite
        let prepared = dirs.iter().map(|&d| PreparedDir::new(d).unwrap_or_else(|| unreachable!())).collect();
        Self { cube, dirs, weights, prepared, tiles, tile_texels }
    }

    /// Texel `t`'s direction prepared for [`penumbra_geometry::MeshBvh::any_hit_prepared`].
    pub fn prepared(&self, t: usize) -> &PreparedDir {
        &self.prepared[t]
    }

    /// The radiance cube map.
    pub fn cube(&self) -> &CubeMap {
        &self.cube
    }

    /// Number of texels (directional lights).
    pub fn texel_count(&self) -> usize {
        self.dirs.len()
    }

    /// Unit direction of texel `t`'s centre.
    pub fn direction(&self, t: usize) -> [f64; 3] {
        self.dirs[t]
    }

    /// `L·dΩ` of texel `t`.
    pub fn weight(&self, t: usize) -> [f64; 3] {
        self.weights[t]
    }

    /// `∫ L dΩ` per channel.
    pub fn power(&self) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for w in &self.weights {
            for c in 0..3 {
                acc[c] += w[c];
            }
        }
        acc
    }

    /// The environment's FIV, `Σ_t L_t ω_t dΩ_t` (FIV eq. 9), as `[rgb][xyz]`.
    pub fn env_fiv(&self) -> [[f64; 3]; 3] {
        let mut out = [[0.0; 3]; 3];
        for (d, w) in self.dirs.iter().zip(&self.weights) {
            for c in 0..3 {
                for x in 0..3 {
                    out[c][x] += w[c] * d[x];
                }
            }
        }
        out
    }

    /// Irradiance for a unit normal `n`: `Σ_t max(0, n·ω_t)·L_t dΩ_t` over every texel
    /// (FIV eq. 5 on the whole environment; exact convolution, all frequencies kept).
    pub fn irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for (d, w) in self.dirs.iter().zip(&self.weights) {
            let c = dot(n, *d);
            if c > 0.0 {
                for k in 0..3 {
                    acc[k] += c * w[k];
                }
            }
        }
        acc
    }

    /// The diffuse irradiance cube map ("DifMap", FIV §4.2, Fig. 3): for every texel centre
    /// of a `size`-sized cube (OpenGL faces, see [`CubeFace::direction`]), the irradiance
    /// [`Lighting::irradiance`] of a surface with that normal. `[6·size², rgb]`, parallel
    /// over texels (each texel is summed in texel order: same bits for any thread count).
    pub fn irradiance_cube(&self, size: usize) -> Vec<[f64; 3]> {
        let probe = CubeMap::constant(size, [0.0; 3]);
        let normals: Vec<[f64; 3]> = probe.iter().map(|t| t.1).collect();
        normals.par_iter().map(|&n| self.irradiance(n)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn constant_environment_known_answers() {
        // L = 1: irradiance π for every normal, FIV 0, power 4π
        let l = Lighting::new(CubeMap::constant(16, [1.0, 2.0, 0.5]));
        let p = l.power();
        assert!((p[0] - 4.0 * PI).abs() < 1e-12 && (p[1] - 8.0 * PI).abs() < 1e-12);
        let f = l.env_fiv();
        assert!(f.iter().flatten().all(|v| v.abs() < 1e-12), "{f:?}");
        // the discrete cosine sum converges to π (error O(texel²))
        for n in [[0.0, 1.0, 0.0], [0.6, 0.0, 0.8], [1.0 / 3f64.sqrt(); 3]] {
            let e = l.irradiance(n);
            assert!((e[0] - PI).abs() < 2e-3 * PI, "{e:?}");
            assert!((e[1] - 2.0 * PI).abs() < 4e-3 * PI);
        }
        // every texel is in exactly one tile, and each tile's cone holds its texels
        let mut seen = vec![0u32; l.texel_count()];
        for t in &l.tiles {
            for &x in &l.tile_texels[t.start as usize..t.end as usize] {
                seen[x as usize] += 1;
                assert!(dot(t.axis, l.direction(x as usize)) >= t.cos_b);
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
    }

    #[test]
    fn upper_hemisphere_light_fiv() {
        // L = 1 for y > 0: FIV = (0, π, 0) (∫ ω dΩ over a hemisphere), irradiance π at +Y,
        // 0 at −Y, and (1 + cos γ)/2·π... at normal n: π(1 + n_y)/2
        let n = 32;
        let texels: Vec<[f32; 3]> =
            CubeMap::constant(n, [0.0; 3]).iter().map(|t| if t.1[1] > 0.0 { [1.0; 3] } else { [0.0; 3] }).collect();
        let l = Lighting::new(CubeMap::from_texels(n, texels).unwrap());
        let f = l.env_fiv();
        assert!((f[0][1] - PI).abs() < 0.01 * PI, "{f:?}");
        assert!(f[0][0].abs() < 1e-9 && f[0][2].abs() < 1e-9);
        assert!((l.irradiance([0.0, 1.0, 0.0])[0] - PI).abs() < 0.01 * PI);
        assert!(l.irradiance([0.0, -1.0, 0.0])[0].abs() < 1e-12);
        let e = l.irradiance([1.0, 0.0, 0.0])[0];
        assert!((e - PI / 2.0).abs() < 0.01 * PI, "{e}");
    }
}
