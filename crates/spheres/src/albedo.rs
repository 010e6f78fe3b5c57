//! Per-proxy albedo (IBPA §5: each proxy re-radiates the light it receives as a diffuse
//! reflector of the albedo of the surface it stands for).
//!
//! The albedo of sphere `j` is the area-weighted mean of the albedo of the surface assigned to
//! it: every triangle of the rest-pose mesh is split into `k²` congruent sub-triangles (`k`
//! the smallest integer with `longest edge / k ≤ r_med / 2`, `r_med` the median sphere radius,
//! at most [`MAX_SPLIT`]), and each sub-triangle, of area `A/k²`, goes to the sphere that holds
//! its centroid most deeply, the smallest `|p − c|/r` (ties to the lower index). For a bounding
//! set that sphere contains the centroid. A sphere that receives no surface (one inside the
//! solid) takes the albedo of the triangle whose centroid it holds most deeply by the same
//! measure.
//!
//! The albedo at a point of a triangle is the RGB of its glTF material's `baseColorFactor`
//! (linear; alpha is ignored) times, when the material has a `baseColorTexture`, the texture's
//! linear RGB there (sRGB-decoded, glTF 2.0 §3.9.2) — `fallback` for a triangle without a
//! material and for OBJ meshes. A sub-triangle takes the texture's mean over its own
//! footprint: the texture is read at the sub-triangle's centroid UV from the mip level whose
//! texels are as wide as the sub-triangle (`side = √(2·A_uv·w·h)` level-0 texels, `A_uv` its
//! area in UV space; trilinear), so the sphere's albedo is an area average of the texture, not
//! of a few point samples. Sums run in f64 in triangle order, so the result does not depend on
//! the thread count.

use penumbra_geometry::Scene;
use penumbra_geometry::texture::{MipChain, Wrap};
use rayon::prelude::*;

use crate::error::SpheresError;

/// Largest number of sub-triangles per triangle edge.
pub const MAX_SPLIT: usize = 32;

/// The per-triangle albedo of a scene: the material's `baseColorFactor` RGB, or `fallback`.
/// Errors if a factor is outside [0, 1] or not finite.
pub fn triangle_albedo(scene: &Scene, fallback: [f64; 3]) -> Result<Vec<[f64; 3]>, SpheresError> {
    let mut out = Vec::with_capacity(scene.mesh.indices.len());
    for (t, tri) in scene.mesh.indices.iter().enumerate() {
        let c = scene.base_color.get(tri[0] as usize).copied().flatten();
        let a = match c {
            None => fallback,
            Some(f) => {
                let rgb = [f[0], f[1], f[2]];
                if rgb.iter().any(|x| !(0.0..=1.0).contains(x)) {
                    return Err(SpheresError::OutOfRange {
                        name: "baseColorFactor",
                        value: format!("{rgb:?} (triangle {t})"),
                        allowed: "each component in [0, 1] (glTF 2.0 §5.22)".into(),
                    });
                }
                rgb
            }
        };
        out.push(a);
    }
    Ok(out)
}

/// The albedo over a scene's surface: per-triangle factor and, for textured triangles, the
/// decoded texture and the corners' UVs.
#[derive(Debug)]
pub struct SurfaceAlbedo {
    factor: Vec<[f64; 3]>,
    textured: Vec<Option<TexturedTriangle>>,
    chains: Vec<MipChain>,
}

#[derive(Debug, Clone, Copy)]
struct TexturedTriangle {
    chain: u32,
    wrap: (Wrap, Wrap),
    uv: [[f64; 2]; 3],
}

impl SurfaceAlbedo {
    /// Reads the factors ([`triangle_albedo`]) and decodes every image a triangle's
    /// base-colour texture uses (each once). Errors name the image that cannot be decoded.
    pub fn new(scene: &Scene, fallback: [f64; 3]) -> Result<Self, SpheresError> {
        let factor = triangle_albedo(scene, fallback)?;
        let mut chain_of: Vec<Option<u32>> = vec![None; scene.images.len()];
        let mut chains = Vec::new();
        let mut textured = Vec::with_capacity(scene.mesh.indices.len());
        for tri in &scene.mesh.indices {
            let corners = tri.map(|v| scene.base_color_texture.get(v as usize).copied().flatten());
            let t = match corners {
                [Some((tex, a)), Some((_, b)), Some((_, c))] => {
                    let image = tex.image as usize;
                    let chain = match chain_of.get(image).copied() {
                        Some(Some(c)) => c,
                        Some(None) => {
                            chains.push(MipChain::decode(&scene.images[image])?);
                            let c = (chains.len() - 1) as u32;
                            chain_of[image] = Some(c);
                            c
                        }
                        None => {
                            return Err(SpheresError::OutOfRange {
                                name: "baseColorTexture",
                                value: format!("image {image}"),
                                allowed: format!("an image index below {} (glTF images array)", scene.images.len()),
                            });
                        }
                    };
                    Some(TexturedTriangle { chain, wrap: (tex.wrap_s, tex.wrap_t), uv: [a, b, c] })
                }
                _ => None,
            };
            textured.push(t);
        }
        Ok(Self { factor, textured, chains })
    }

    /// Whether any triangle reads a texture.
    pub fn is_textured(&self) -> bool {
        !self.chains.is_empty()
    }

    /// The albedo of triangle `t` averaged over a piece of it centred at barycentric `(u, v)`
    /// (weights of corners 1 and 2) whose area is `fraction` of the triangle's.
    pub fn at(&self, t: usize, u: f64, v: f64, fraction: f64) -> [f64; 3] {
        let f = self.factor[t];
        let Some(tt) = self.textured[t] else { return f };
        let [a, b, c] = tt.uv;
        let uv = [a[0] + u * (b[0] - a[0]) + v * (c[0] - a[0]), a[1] + u * (b[1] - a[1]) + v * (c[1] - a[1])];
        let chain = &self.chains[tt.chain as usize];
        let (w, h) = chain.size();
        let area_uv = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs() * fraction;
        let side = (2.0 * area_uv * f64::from(w) * f64::from(h)).sqrt();
        let tex = chain.sample(uv, tt.wrap, side);
        std::array::from_fn(|k| f[k] * tex[k])
    }
}

/// How many distinct images the scene's base-colour textures use.
pub fn texture_images(scene: &Scene) -> usize {
    let mut ids: Vec<u32> = scene.base_color_texture.iter().flatten().map(|(t, _)| t.image).collect();
    ids.sort_unstable();
    ids.dedup();
    ids.len()
}

/// Whether any triangle of the scene has a glTF material.
pub fn has_materials(scene: &Scene) -> bool {
    scene.base_color.iter().any(Option::is_some)
}

/// The sphere holding `p` most deeply: `(index, |p − c|²/r²)`.
fn deepest(spheres: &[[f32; 4]], p: [f64; 3]) -> (u32, f64) {
    let mut best = (0u32, f64::INFINITY);
    for (j, s) in spheres.iter().enumerate() {
        let d2: f64 = (0..3).map(|k| (p[k] - f64::from(s[k])).powi(2)).sum();
        let r = f64::from(s[3]);
        let q = if r > 0.0 { d2 / (r * r) } else { f64::INFINITY };
        if q < best.1 {
            best = (j as u32, q);
        }
    }
    best
}

/// Area-weighted albedo of each sphere (see the module docs), `surface` built from `scene`.
pub fn sphere_albedo(scene: &Scene, surface: &SurfaceAlbedo, spheres: &[[f32; 4]]) -> Vec<[f32; 3]> {
    let mesh = &scene.mesh;
    let n = spheres.len();
    if n == 0 {
        return Vec::new();
    }
    let mut radii: Vec<f64> = spheres.iter().map(|s| f64::from(s[3])).collect();
    radii.sort_by(f64::total_cmp);
    let step = (radii[n / 2] / 2.0).max(f64::MIN_POSITIVE);
    // per triangle: the (sphere, area, albedo) of each sub-triangle, computed in parallel
    let per_tri: Vec<Vec<(u32, f64, [f64; 3])>> = (0..mesh.indices.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = mesh.triangle(t);
            let e = |p: [f64; 3], q: [f64; 3]| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
            let longest = e(a, b).max(e(b, c)).max(e(c, a));
            let k = ((longest / step).ceil() as usize).clamp(1, MAX_SPLIT);
            let area = mesh.triangle_area(t) / (k * k) as f64;
            let at = |i: f64, j: f64| -> [f64; 3] {
                let (u, v) = (i / k as f64, j / k as f64);
                std::array::from_fn(|q| a[q] + u * (b[q] - a[q]) + v * (c[q] - a[q]))
            };
            let fraction = 1.0 / (k * k) as f64;
            let mut out = Vec::with_capacity(k * k);
            let mut sub = |gi: f64, gj: f64| {
                let (s, _) = deepest(spheres, at(gi, gj));
                out.push((s, area, surface.at(t, gi / k as f64, gj / k as f64, fraction)));
            };
            // k² sub-triangles: (i, j) upright with centroid at (i + 1/3, j + 1/3), and for
            // i + j ≤ k − 2 the inverted one at (i + 2/3, j + 2/3) (grid units)
            for i in 0..k {
                for j in 0..k - i {
                    sub(i as f64 + 1.0 / 3.0, j as f64 + 1.0 / 3.0);
                    if i + j + 2 <= k {
                        sub(i as f64 + 2.0 / 3.0, j as f64 + 2.0 / 3.0);
                    }
                }
            }
            out
        })
        .collect();
    let mut sum = vec![[0.0f64; 3]; n];
    let mut weight = vec![0.0f64; n];
    for subs in &per_tri {
        for &(s, w, rgb) in subs {
            for q in 0..3 {
                sum[s as usize][q] += w * rgb[q];
            }
            weight[s as usize] += w;
        }
    }
    // spheres without surface: the sub-triangle each holds most deeply
    let empty: Vec<usize> = (0..n).filter(|&j| weight[j] <= 0.0).collect();
    let mut nearest: Vec<(f64, [f64; 3])> = vec![(f64::INFINITY, [0.0; 3]); n];
    if !empty.is_empty() {
        for t in 0..mesh.indices.len() {
            let [a, b, c] = mesh.triangle(t);
            let p: [f64; 3] = std::array::from_fn(|q| (a[q] + b[q] + c[q]) / 3.0);
            for &j in &empty {
                let s = spheres[j];
                let d2: f64 = (0..3).map(|k| (p[k] - f64::from(s[k])).powi(2)).sum();
                let r = f64::from(s[3]).max(f64::MIN_POSITIVE);
                let q = d2 / (r * r);
                if q < nearest[j].0 {
                    nearest[j] = (q, surface.at(t, 1.0 / 3.0, 1.0 / 3.0, 1.0));
                }
            }
        }
    }
    (0..n)
        .map(|j| {
            let v = if weight[j] > 0.0 { sum[j].map(|x| x / weight[j]) } else { nearest[j].1 };
            v.map(|x| (x as f32).clamp(0.0, 1.0))
        })
        .collect()
}
