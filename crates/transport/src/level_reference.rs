//! Brute-force reference for levels: a path tracer on the level's block geometry (the
//! warped boxes, their walls and the openings between connected blocks), with the same
//! point lights as the MRT runtime's direct light (`penumbra verify mrt`).
//!
//! Rays need no BVH: every block is an axis-aligned box in the world (rotations are quarter
//! turns about +Y), so a ray is followed block by block: it leaves the current box through
//! one face (`shape::exit_face` in block-local coordinates); a wall is a hit, a connected
//! opening hands the ray to the neighbour (the faces coincide, validated), an unconnected
//! opening loses it. Exact and watertight.
//!
//! Irradiance from a point light of intensity `I` at `c`: `E(x) = I·max(n·ω, 0)/|c − x|²·V`,
//! `V` the visibility of the segment (followed the same way). One bounce:
//! `E₁(x) = ρ/N Σ E_d(y_i)` over `N` cosine-distributed rays (`y_i` the first wall hit);
//! multi-bounce: each ray continues as a path with cosine sampling at every hit,
//! `E(x) = ρ/N Σ_i Σ_k ρ^{k−1} E_d(y_{i,k})`, `k ≤ bounces`.

use crate::gather::DirectionSet;
use crate::level::{Level, Links};
use crate::shape::{FACE_FRAMES, Shape, Texels, exit_face};
use penumbra_math::rng::{hash4, unit_f64};
use rayon::prelude::*;

/// Hash stage of the level reference.
const STAGE: u64 = 0x4c56_4c52;

/// A point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLight {
    /// World position.
    pub position: [f64; 3],
    /// Intensity (irradiance `I/d²` at distance `d`, normal incidence).
    pub intensity: f64,
}

/// The level's geometry for ray queries.
#[derive(Debug, Clone)]
pub struct LevelGeometry<'a> {
    /// Level.
    pub level: &'a Level,
    /// Neighbours.
    pub links: &'a Links,
    /// Missing-face mask per dictionary shape.
    pub missing: &'a [u8],
}

/// A wall hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallHit {
    /// Block.
    pub block: usize,
    /// Its local face.
    pub face: usize,
    /// World point.
    pub point: [f64; 3],
}

fn add(p: [f64; 3], t: f64, d: [f64; 3]) -> [f64; 3] {
    [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]]
}

impl LevelGeometry<'_> {
    /// Follows a ray from `p` (inside or on the boundary of block `b`) along `d` (world) up
    /// to the parameter `t_max`: the first wall it hits, `Reached` when `t_max` comes first,
    /// `Lost` when it leaves the level through an unconnected opening.
    fn walk(&self, mut b: usize, mut p: [f64; 3], d: [f64; 3], t_max: f64) -> Walk {
        let mut travelled = 0.0;
        for _ in 0..4 * self.level.blocks.len() + 4 {
            let blk = &self.level.blocks[b];
            let pl = blk.to_local(p).map(|x| x.clamp(0.0, 1.0));
            let dl = blk.dir_to_local(d);
            let (f, t) = exit_face(pl, dl);
            if f == usize::MAX {
                return Walk::Lost;
            }
            if travelled + t >= t_max {
                return Walk::Reached;
            }
            let q = add(p, t, d);
            if self.missing[blk.shape] & (1 << f) == 0 {
                return Walk::Wall(WallHit { block: b, face: f, point: q });
            }
            match self.links[b][f] {
                Some((y, _)) => {
                    b = y;
                    p = q;
                    travelled += t;
                }
                None => return Walk::Lost,
            }
        }
        Walk::Lost
    }

    /// The first wall a ray hits, and in `segs` the blocks it crosses on the way, each with
    /// the ray parameters where it enters and leaves it (in order; cleared first).
    pub fn trace_segments(
        &self,
        mut b: usize,
        mut p: [f64; 3],
        d: [f64; 3],
        segs: &mut Vec<(usize, f64, f64)>,
    ) -> Option<WallHit> {
        segs.clear();
        let mut travelled = 0.0;
        let inv = d.map(|x| 1.0 / x);
        for _ in 0..4 * self.level.blocks.len() + 4 {
            let blk = &self.level.blocks[b];
            let (f, t) = world_exit(blk, p, d, inv);
            if f == usize::MAX {
                return None;
            }
            segs.push((b, travelled, travelled + t));
            let q = add(p, t, d);
            if self.missing[blk.shape] & (1 << f) == 0 {
                return Some(WallHit { block: b, face: f, point: q });
            }
            match self.links[b][f] {
                Some((y, _)) => {
                    b = y;
                    p = q;
                    travelled += t;
                }
                None => return None,
            }
        }
        None
    }

    /// The first wall a ray hits.
    pub fn trace(&self, b: usize, p: [f64; 3], d: [f64; 3]) -> Option<WallHit> {
        match self.walk(b, p, d, f64::INFINITY) {
            Walk::Wall(h) => Some(h),
            _ => None,
        }
    }

    /// Whether the segment from `x` (in block `b`) to `c` crosses no wall.
    pub fn segment_clear(&self, b: usize, x: [f64; 3], c: [f64; 3]) -> bool {
        let d = [c[0] - x[0], c[1] - x[1], c[2] - x[2]];
        matches!(self.walk(b, x, d, 1.0), Walk::Reached)
    }

    /// Direct irradiance at `x` on a wall of block `b` with world normal `n`.
    pub fn direct(&self, b: usize, x: [f64; 3], n: [f64; 3], lights: &[PointLight]) -> f64 {
        let mut e = 0.0;
        for l in lights {
            let v = [l.position[0] - x[0], l.position[1] - x[1], l.position[2] - x[2]];
            let d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            let cos = (n[0] * v[0] + n[1] * v[1] + n[2] * v[2]) / d2.sqrt();
            if cos <= 0.0 || d2 == 0.0 {
                continue;
            }
            if self.segment_clear(b, x, l.position) {
                e += l.intensity * cos / d2;
            }
        }
        e
    }

    /// The block containing a world point strictly inside it.
    pub fn block_of(&self, p: [f64; 3]) -> Option<usize> {
        self.level.blocks.iter().position(|blk| blk.to_local(p).iter().all(|&x| x > 0.0 && x < 1.0))
    }

    /// World frame `(u, v, n)` of local face `f` of block `b`.
    pub fn frame(&self, b: usize, f: usize) -> [[f64; 3]; 3] {
        let blk = &self.level.blocks[b];
        let fr = &FACE_FRAMES[f];
        let r = |v: [f64; 3]| crate::level::rotate_y(v, blk.rotation);
        [r(fr.u), r(fr.v), r(fr.n)]
    }
}

/// The local face through which a ray leaves block `blk` and its parameter, computed in
/// the world (every block is an axis-aligned box there): the same face and distance as
/// `exit_face` in block-local coordinates, without the per-block divisions (the walk of
/// the DRT bake's rays; `inv` is the direction's reciprocal).
#[inline]
fn world_exit(blk: &crate::level::Block, p: [f64; 3], d: [f64; 3], inv: [f64; 3]) -> (usize, f64) {
    static LOCAL: std::sync::OnceLock<[[usize; 6]; 4]> = std::sync::OnceLock::new();
    let local = LOCAL.get_or_init(|| {
        let mut t = [[0; 6]; 4];
        for (q, row) in t.iter_mut().enumerate() {
            for f in 0..6 {
                row[crate::level::world_face(f, q as u32)] = f;
            }
        }
        t
    });
    let ext = crate::level::rotate_y(blk.scale, blk.rotation);
    let mut best = (usize::MAX, f64::INFINITY);
    for a in 0..3 {
        let h = 0.5 * ext[a].abs();
        let (lo, hi) = (blk.translation[a] - h, blk.translation[a] + h);
        let pa = p[a].clamp(lo, hi);
        let (t, w) = if d[a] > 0.0 {
            ((hi - pa) * inv[a], 2 * a + 1)
        } else if d[a] < 0.0 {
            ((lo - pa) * inv[a], 2 * a)
        } else {
            continue;
        };
        let f = local[blk.rotation as usize % 4][w];
        if t < best.1 || (t == best.1 && f < best.0) {
            best = (f, t);
        }
    }
    best
}

enum Walk {
    Wall(WallHit),
    Reached,
    Lost,
}

fn local_to_world(fr: &[[f64; 3]; 3], l: [f64; 3]) -> [f64; 3] {
    core::array::from_fn(|k| l[0] * fr[0][k] + l[1] * fr[1][k] + l[2] * fr[2][k])
}

/// Texel samples of a level: per block its shape's texels (dictionary layout), world
/// positions and normals, concatenated in block order.
#[derive(Debug, Clone)]
pub struct LevelTexels {
    /// First texel of each block, and the total.
    pub offsets: Vec<usize>,
    /// `(block, local face, world position, world normal)` per texel.
    pub texels: Vec<(usize, usize, [f64; 3], [f64; 3])>,
}

/// The texels of every block (texel centres of its shape at `face_res`).
pub fn level_texels(level: &Level, missing: &[u8], face_res: usize) -> LevelTexels {
    let mut offsets = vec![0];
    let mut texels = Vec::new();
    for (b, blk) in level.blocks.iter().enumerate() {
        let tex = Texels::new(Shape::new("level", missing[blk.shape]), face_res);
        for t in 0..tex.len() {
            let (f, _, _) = tex.coords(t);
            texels.push((b, f, blk.to_world(tex.position(t)), blk.normal(f)));
        }
        offsets.push(texels.len());
    }
    LevelTexels { offsets, texels }
}

/// Reference solutions at the level's texels.
#[derive(Debug, Clone)]
pub struct LevelReference {
    /// Direct irradiance.
    pub direct: Vec<f64>,
    /// One-bounce indirect irradiance.
    pub one_bounce: Vec<f64>,
    /// Multi-bounce indirect irradiance (`bounces` bounces).
    pub multi_bounce: Vec<f64>,
    /// Half the difference of two independent half-sample estimates, one bounce.
    pub one_half_difference: Vec<f64>,
    /// The same, multi-bounce.
    pub multi_half_difference: Vec<f64>,
}

/// Direct light at the texels.
pub fn direct_at(g: &LevelGeometry<'_>, t: &LevelTexels, lights: &[PointLight]) -> Vec<f64> {
    t.texels.par_iter().map(|&(b, _, x, n)| g.direct(b, x, n, lights)).collect()
}

/// Path-traced indirect light at the texels: `rays` per texel (two halves of `rays/2`, each a
/// Hammersley cosine set rotated by a hashed angle for the first bounce; hashed cosine draws
/// after), albedo `albedo` on every wall, `bounces ≥ 1`.
pub fn reference(
    g: &LevelGeometry<'_>,
    t: &LevelTexels,
    lights: &[PointLight],
    albedo: f64,
    rays: usize,
    bounces: usize,
    seed: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> LevelReference {
    let half = (rays / 2).max(1);
    let dirs = DirectionSet::cosine(half);
    let direct = direct_at(g, t, lights);
    let per: Vec<[f64; 4]> = t
        .texels
        .par_iter()
        .enumerate()
        .map(|(i, &(b, f, x, _))| {
            let fr = g.frame(b, f);
            let mut est = [[0.0f64; 2]; 2]; // [half][one, multi]
            for (h, acc) in est.iter_mut().enumerate() {
                let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, STAGE, i as u64, h as u64));
                let (s, c) = phi.sin_cos();
                for (k, l) in dirs.dirs.iter().enumerate() {
                    let l = [l[0] * c - l[1] * s, l[0] * s + l[1] * c, l[2]];
                    let Some(mut hit) = g.trace(b, x, local_to_world(&fr, l)) else { continue };
                    let fr_h = g.frame(hit.block, hit.face);
                    let e1 = g.direct(hit.block, hit.point, fr_h[2], lights);
                    acc[0] += e1;
                    let mut sum = e1;
                    let mut w = 1.0;
                    for depth in 2..=bounces {
                        let item = ((i as u64) << 24) ^ ((h as u64) << 23) ^ k as u64;
                        let u1 = unit_f64(hash4(seed, STAGE + 1, item, 2 * depth as u64));
                        let u2 = unit_f64(hash4(seed, STAGE + 1, item, 2 * depth as u64 + 1));
                        let frh = g.frame(hit.block, hit.face);
                        let d = local_to_world(&frh, penumbra_math::warp::cosine_hemisphere(u1, u2));
                        let Some(next) = g.trace(hit.block, hit.point, d) else { break };
                        w *= albedo;
                        hit = next;
                        let frn = g.frame(hit.block, hit.face);
                        sum += w * g.direct(hit.block, hit.point, frn[2], lights);
                    }
                    acc[1] += sum;
                }
                let sc = albedo / half as f64;
                acc[0] *= sc;
                acc[1] *= sc;
            }
            if i % 64 == 63 {
                tick(64);
            }
            [
                0.5 * (est[0][0] + est[1][0]),
                0.5 * (est[0][1] + est[1][1]),
                0.5 * (est[0][0] - est[1][0]),
                0.5 * (est[0][1] - est[1][1]),
            ]
        })
        .collect();
    LevelReference {
        direct,
        one_bounce: per.iter().map(|v| v[0]).collect(),
        multi_bounce: per.iter().map(|v| v[1]).collect(),
        one_half_difference: per.iter().map(|v| v[2]).collect(),
        multi_half_difference: per.iter().map(|v| v[3]).collect(),
    }
}

/// One-bounce reference at arbitrary receivers of the level (`penumbra verify mrt`'s vector
/// and volume checks): a point on a wall or inside a block, a unit normal, and for a tilted
/// (normal-mapped) normal the wall's own normal as the horizon (rays below it carry nothing).
/// `rays` cosine rays about the normal in two halves, as [`reference`]; returns the estimates
/// and half the difference of the two halves.
pub fn reference_at(
    g: &LevelGeometry<'_>,
    receivers: &[crate::drt_reference::Receiver],
    lights: &[PointLight],
    albedo: f64,
    rays: usize,
    seed: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> (Vec<f64>, Vec<f64>) {
    let half = (rays / 2).max(1);
    let dirs = DirectionSet::cosine(half);
    let per: Vec<[f64; 2]> = receivers
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let (t, bt) = penumbra_math::warp::orthonormal_basis(r.normal);
            let mut est = [0.0f64; 2];
            for (h, acc) in est.iter_mut().enumerate() {
                let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, STAGE + 2, i as u64, h as u64));
                let (s, c) = phi.sin_cos();
                for l in &dirs.dirs {
                    let l = [l[0] * c - l[1] * s, l[0] * s + l[1] * c, l[2]];
                    let d: [f64; 3] = core::array::from_fn(|m| l[0] * t[m] + l[1] * bt[m] + l[2] * r.normal[m]);
                    if r.horizon.is_some_and(|hz| hz[0] * d[0] + hz[1] * d[1] + hz[2] * d[2] <= 0.0) {
                        continue;
                    }
                    let Some(hit) = g.trace(r.block, r.point, d) else { continue };
                    let fr = g.frame(hit.block, hit.face);
                    *acc += g.direct(hit.block, hit.point, fr[2], lights);
                }
                *acc *= albedo / half as f64;
            }
            if i % 64 == 63 {
                tick(64);
            }
            [0.5 * (est[0] + est[1]), 0.5 * (est[0] - est[1])]
        })
        .collect();
    (per.iter().map(|v| v[0]).collect(), per.iter().map(|v| v[1]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::level::corridor;
    use crate::reference::point_polygon_form_factor;
    use crate::shape::{CUBE2D, face_point};

    #[test]
    fn world_exit_is_the_local_exit_face() {
        // rotated, non-uniformly scaled blocks; origins inside and on the boundary
        for q in 0..4u32 {
            let blk =
                crate::level::Block { shape: 0, rotation: q, translation: [1.5, -0.25, 3.0], scale: [2.0, 0.5, 1.25] };
            for i in 0..2000u64 {
                let u = |k: u64| unit_f64(hash4(7, q as u64, i, k));
                let l = [u(0), u(1), u(2)];
                let l = if i % 5 == 0 { [0.0, l[1], l[2]] } else { l };
                let z = 2.0 * u(3) - 1.0;
                let ph = 2.0 * core::f64::consts::PI * u(4);
                let r = (1.0 - z * z).sqrt();
                let d = [r * ph.cos(), z, r * ph.sin()];
                let p = blk.to_world(l);
                let (f0, t0) = exit_face(blk.to_local(p).map(|x| x.clamp(0.0, 1.0)), blk.dir_to_local(d));
                let (f1, t1) = world_exit(&blk, p, d, d.map(|x| 1.0 / x));
                assert_eq!(f0, f1, "rotation {q}, ray {i}");
                assert!((t0 - t1).abs() <= 1e-12 * (1.0 + t0), "rotation {q}, ray {i}: {t0} vs {t1}");
            }
        }
    }

    fn missing() -> Vec<u8> {
        CUBE2D.iter().map(|s| s.missing).collect()
    }

    #[test]
    fn rays_cross_connected_openings_and_stop_at_walls() {
        let m = missing();
        let names: Vec<String> = CUBE2D.iter().map(|s| s.name.to_string()).collect();
        let l = corridor(3, &m).unwrap();
        let links = l.validate(&names, &m).unwrap();
        let g = LevelGeometry { level: &l, links: &links, missing: &m };
        // straight down the corridor from the middle of block 0 hits the far end wall
        let h = g.trace(0, [0.5, 0.5, 0.5], [0.0, 0.0, 1.0]).unwrap();
        assert_eq!(h.block, 2);
        assert!((h.point[2] - 3.0).abs() < 1e-12);
        // sideways: the wall of the same block
        let h = g.trace(1, [0.5, 0.5, 1.5], [1.0, 0.0, 0.0]).unwrap();
        assert_eq!((h.block, h.point[0]), (1, 1.0));
        assert!(g.segment_clear(0, [0.5, 0.0, 0.2], [0.5, 0.5, 2.5]));
        assert!(!g.segment_clear(0, [0.5, 0.0, 0.2], [1.5, 0.5, 2.5]));
        assert_eq!(g.block_of([0.5, 0.5, 2.5]), Some(2));
    }

    #[test]
    fn one_bounce_matches_a_form_factor_quadrature_and_bounces_add_up() {
        // E₁(x) = ρ ∫ E_d(y) cos/π dω at the centre of a closed cube's floor, independently
        // by quadrature: 64² cells per wall, exact point-to-cell form factors times the
        // direct light at the cell centre.
        let m = missing();
        let l = Level {
            blocks: vec![crate::level::Block { shape: 0, rotation: 0, translation: [0.5; 3], scale: [1.0; 3] }],
            connections: vec![],
        };
        let links: Links = vec![[None; 6]];
        let g = LevelGeometry { level: &l, links: &links, missing: &m };
        let lights = [PointLight { position: [0.3, 0.6, 0.55], intensity: 1.0 }];
        let x = [0.5, 0.0, 0.5];
        let n = [0.0, 1.0, 0.0];
        let cells = 64;
        let mut want = 0.0;
        for f in [0usize, 1, 3, 4, 5] {
            for j in 0..cells {
                for i in 0..cells {
                    let (u0, v0) = (i as f64 / cells as f64, j as f64 / cells as f64);
                    let d = 1.0 / cells as f64;
                    let poly = [
                        face_point(f, u0, v0),
                        face_point(f, u0 + d, v0),
                        face_point(f, u0 + d, v0 + d),
                        face_point(f, u0, v0 + d),
                    ];
                    let c = face_point(f, u0 + 0.5 * d, v0 + 0.5 * d);
                    want += point_polygon_form_factor(x, n, &poly) * g.direct(0, c, FACE_FRAMES[f].n, &lights);
                }
            }
        }
        let tex = LevelTexels { offsets: vec![0, 1], texels: vec![(0, 2, x, n)] };
        let r = reference(&g, &tex, &lights, 0.8, 1 << 16, 1, 3, &|_| {});
        let got = r.one_bounce[0];
        assert!((got - 0.8 * want).abs() < 0.01 * 0.8 * want, "{got} vs {}", 0.8 * want);
        assert_eq!(r.multi_bounce, r.one_bounce); // one bounce: the same estimator
        // a closed box loses nothing: 12 bounces approach the geometric series
        // Σ_{k<12} ρ^k = 4.66 (exactly that for light spread uniformly over the walls)
        let r2 = reference(&g, &tex, &lights, 0.8, 1 << 14, 12, 3, &|_| {});
        let ratio = r2.multi_bounce[0] / r2.one_bounce[0];
        assert!((4.0..5.0).contains(&ratio), "{ratio}");
    }
}
