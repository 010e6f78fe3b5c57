//! Brute-force reference for DRT (`penumbra verify drt`): the level path tracer of
//! [`crate::level_reference`] with the clutter's triangles in the scene. Clutter occludes
//! direct and indirect light and reflects diffusely with its own albedo; walls reflect with
//! the walls' albedo.
//!
//! Irradiance from point lights: `E(x) = Σ I·max(n·ω, 0)/|c − x|²·V`, `V` the visibility
//! through walls and clutter. One bounce: `E₁(x) = (1/N) Σ ρ(yᵢ) E_d(yᵢ)` over `N`
//! cosine-distributed rays, `yᵢ` the first surface hit (a wall, or the front side of clutter;
//! the back side of clutter is dark). Multi-bounce: each ray continues as a path with cosine
//! sampling about the normal of every surface it meets, `Σ_k Π_{i≤k} ρ(y_i) E_d(y_k)`.

use crate::clutter::ClutterScene;
use crate::drt::{RayHit, Scene};
use crate::gather::DirectionSet;
use crate::level_reference::PointLight;
use penumbra_math::rng::{hash4, unit_f64};
use rayon::prelude::*;

/// Hash stage of the DRT reference.
const STAGE: u64 = 0x4452_5452;

/// A receiver: block, world point on a surface, world unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Receiver {
    /// The block the point is in (or on the wall of).
    pub block: usize,
    /// World point.
    pub point: [f64; 3],
    /// World unit normal (the side light arrives from).
    pub normal: [f64; 3],
    /// The surface's geometric normal when `normal` is tilted (a normal-mapped surface): rays
    /// below that surface carry no light. `None`: every ray about `normal` counts.
    pub horizon: Option<[f64; 3]>,
}

/// Reference values at receivers.
#[derive(Debug, Clone)]
pub struct DrtReference {
    /// Direct irradiance.
    pub direct: Vec<f64>,
    /// One-bounce indirect irradiance.
    pub one_bounce: Vec<f64>,
    /// Multi-bounce indirect irradiance.
    pub multi_bounce: Vec<f64>,
    /// Half the difference of two half-sample one-bounce estimates.
    pub one_half_difference: Vec<f64>,
    /// The same, multi-bounce.
    pub multi_half_difference: Vec<f64>,
}

/// Surface albedos of the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Albedo {
    /// Walls.
    pub walls: f64,
    /// Which channel of the clutter albedos.
    pub channel: usize,
}

fn offset(p: [f64; 3], n: [f64; 3], e: f64) -> [f64; 3] {
    [p[0] + e * n[0], p[1] + e * n[1], p[2] + e * n[2]]
}

/// Direct irradiance at `x` (block `b`, normal `n`) with wall and clutter shadows.
pub fn direct(sc: &Scene<'_>, b: usize, x: [f64; 3], n: [f64; 3], lights: &[PointLight]) -> f64 {
    let mut e = 0.0;
    for l in lights {
        let v = [l.position[0] - x[0], l.position[1] - x[1], l.position[2] - x[2]];
        let d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if d2 == 0.0 {
            continue;
        }
        let cos = (n[0] * v[0] + n[1] * v[1] + n[2] * v[2]) / d2.sqrt();
        if cos <= 0.0 {
            continue;
        }
        if sc.geo.segment_clear(b, x, l.position) && !sc.clutter.blocks_segment(x, l.position) {
            e += l.intensity * cos / d2;
        }
    }
    e
}

/// The block a point on clutter lies in (probed just off the surface).
fn clutter_block(sc: &Scene<'_>, p: [f64; 3], n: [f64; 3]) -> Option<usize> {
    sc.geo.block_of(offset(p, n, 1e-7))
}

/// What a ray meets: `(block, point, normal, albedo)` of a lit surface, or `None`.
fn surface(sc: &Scene<'_>, clutter: &ClutterScene, alb: Albedo, h: RayHit) -> Option<(usize, [f64; 3], [f64; 3], f64)> {
    match h {
        RayHit::Lost => None,
        RayHit::Wall(y, g, q) => Some((y, q, sc.geo.frame(y, g)[2], alb.walls)),
        RayHit::Clutter(_, c) => {
            if !c.front {
                return None;
            }
            let b = clutter_block(sc, c.point, c.normal)?;
            Some((b, c.point, c.normal, clutter.charts[c.chart].albedo[alb.channel]))
        }
    }
}

/// Path-traced reference at `receivers`: `rays` per receiver in two halves (Hammersley cosine
/// sets rotated by a hashed angle), hashed cosine draws after the first bounce.
pub fn reference(
    sc: &Scene<'_>,
    receivers: &[Receiver],
    lights: &[PointLight],
    alb: Albedo,
    rays: usize,
    bounces: usize,
    seed: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> DrtReference {
    let half = (rays / 2).max(1);
    let dirs = DirectionSet::cosine(half);
    let per: Vec<[f64; 5]> = receivers
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let ed = direct(sc, r.block, r.point, r.normal, lights);
            let (t, bt) = penumbra_math::warp::orthonormal_basis(r.normal);
            let o = offset(r.point, r.horizon.unwrap_or(r.normal), 1e-7);
            let mut est = [[0.0f64; 2]; 2];
            for (h, acc) in est.iter_mut().enumerate() {
                let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, STAGE, i as u64, h as u64));
                let (s, c) = phi.sin_cos();
                for (k, l) in dirs.dirs.iter().enumerate() {
                    let l = [l[0] * c - l[1] * s, l[0] * s + l[1] * c, l[2]];
                    let d: [f64; 3] = core::array::from_fn(|m| l[0] * t[m] + l[1] * bt[m] + l[2] * r.normal[m]);
                    if r.horizon.is_some_and(|h| h[0] * d[0] + h[1] * d[1] + h[2] * d[2] <= 0.0) {
                        continue;
                    }
                    let Some((mut b, mut p, mut n, mut rho)) = surface(sc, sc.clutter, alb, sc.cast(r.block, o, d))
                    else {
                        continue;
                    };
                    let e1 = rho * direct(sc, b, p, n, lights);
                    acc[0] += e1;
                    let mut sum = e1;
                    let mut w = rho;
                    for depth in 2..=bounces {
                        let item = ((i as u64) << 24) ^ ((h as u64) << 23) ^ k as u64;
                        let u1 = unit_f64(hash4(seed, STAGE + 1, item, 2 * depth as u64));
                        let u2 = unit_f64(hash4(seed, STAGE + 1, item, 2 * depth as u64 + 1));
                        let ll = penumbra_math::warp::cosine_hemisphere(u1, u2);
                        let (t2, b2) = penumbra_math::warp::orthonormal_basis(n);
                        let d2: [f64; 3] = core::array::from_fn(|m| ll[0] * t2[m] + ll[1] * b2[m] + ll[2] * n[m]);
                        let Some(next) = surface(sc, sc.clutter, alb, sc.cast(b, offset(p, n, 1e-7), d2)) else {
                            break;
                        };
                        (b, p, n, rho) = next;
                        w *= rho;
                        sum += w * direct(sc, b, p, n, lights);
                    }
                    acc[1] += sum;
                }
                acc[0] /= half as f64;
                acc[1] /= half as f64;
            }
            if i % 64 == 63 {
                tick(64);
            }
            [
                ed,
                0.5 * (est[0][0] + est[1][0]),
                0.5 * (est[0][1] + est[1][1]),
                0.5 * (est[0][0] - est[1][0]),
                0.5 * (est[0][1] - est[1][1]),
            ]
        })
        .collect();
    DrtReference {
        direct: per.iter().map(|v| v[0]).collect(),
        one_bounce: per.iter().map(|v| v[1]).collect(),
        multi_bounce: per.iter().map(|v| v[2]).collect(),
        one_half_difference: per.iter().map(|v| v[3]).collect(),
        multi_half_difference: per.iter().map(|v| v[4]).collect(),
    }
}
