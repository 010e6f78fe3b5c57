//! Vector and volume response of DRT (MRT thesis §5.4.3): the vector-valued operators
//! `ΔU_b⃗`, `ΔU_c⃗`, `C_b⃗` (and `C_c⃗`, this project's clutter-to-clutter path) for
//! normal-mapped surfaces, and `U_dyn`, which maps `[b; c]` to order-3 SH radiance probes
//! that see the clutter (its shadows and its bounced light), for dynamic objects.
//!
//! # What is computed
//! "Projecting basis-space radiance into spherical harmonics (SH) and mapping the SH
//! coefficients into MRT's hemispherical basis" (§5.4.3): from each texel, `V` uniform
//! hemisphere rays (the SH projection `∫_H L y_j dω` needs the uniform measure: with the
//! scalar bake's cosine rays it would divide by `cos θ`, an estimator of infinite variance at
//! the horizon), the same paths as the scalar operators (`crate::drt`):
//! - `ΔU_b⃗^{X←Y}` (scene texel of `X`): a ray that meets clutter before its wall `y` in block
//!   `Y` adds `−(ρ/π)·(2π/V)·y_j(ω)·L_imp_Y(y)`; `ΔU_c⃗^X`: a ray that meets the front of chart
//!   `j` first adds `(1/π)·(2π/V)·y_j(ω)/√m_j` (per unit `c_j`, which the runtime scales by the
//!   chart's albedo, as for `ΔU_c`). The 9 SH coefficients, in the texel frame of the
//!   dictionary's `U_b⃗` (x = face u, y = face v, z = inward normal), go through App. B's
//!   quadratic-SH → OHLSH map to 4 coefficients, so `Ū_b⃗ = U_b⃗ + ΔU_b⃗` texel by texel.
//! - `C_b⃗` / `C_c⃗` (clutter texel): a ray that reaches a wall with no clutter before it adds
//!   the `L_imp` term above, a ray that meets the front of a chart the chart term; the SH is
//!   taken in the texel's frame `(t, b, n)` (`orthonormal_basis(n)`), mapped to OHLSH, and the
//!   linear band is then written in **world** axes: `[a₀, w]` with
//!   `E(m) = π y₀₀ a₀ + (2π/3)·√(3/4π)·(w · m)` for a world unit normal `m` (clutter texels
//!   have no frame an engine could rebuild, a world vector needs none).
//! - `U_dyn^{X}`: probes at the centres of a `g³` grid of cells of each receiving block `X`
//!   (`g` = the dictionary's `volume_res`, the cells of its `U_bvol`, mapped to the world by
//!   the block's transform), `4V` uniform-sphere rays each (the same angular density as the
//!   texels'), SH in **world** axes: a wall hit with no clutter before it adds
//!   `(ρ/π)(4π/4V)·y_j(ω)·L_imp_Y(y)` to the columns of `b_Y`, a front chart hit
//!   `(1/π)(4π/4V)·y_j(ω)/√m_j` to `c_j`. Unlike MRT's `U_bvol`, the rays cross openings, so
//!   light from the neighbouring blocks' `b` is in the probes too. A probe more than half of
//!   whose rays meet the back of clutter is inside it (`inside`) and takes the mean of its
//!   valid neighbours, ring by ring ([`fill_inside`], §5.4.2's inpainting on the probe grid).
//!
//! Rays are hashed per `(seed, item, texel)` on streams of their own, so the bytes do not
//! depend on the thread count. The vector operators are stored unreduced.

use crate::TransportError;
use crate::clutter::ClutterScene;
use crate::drt::{DrtDict, RayHit, Scene, frame_dir, rotate_z};
use crate::gather::{DirectionSet, sh9};
use crate::level::{Level, Links};
use crate::level_reference::LevelGeometry;
use crate::shape::face_uv;
use penumbra_math::ohlsh::quadratic_to_ohlsh;
use penumbra_math::progress::Progress;
use penumbra_math::rng::{hash4, unit_f64};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// Hash stage of the vector rays (distinct from the scalar bake's).
const STAGE: u64 = 0x4452_5456;

/// Parameters of the vector and volume bake.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VectorParams {
    /// Uniform-hemisphere rays per texel (probes get four times as many over the sphere).
    pub rays: usize,
    /// Probes per block edge (`g`; the dictionary's `volume_res`).
    pub volume_res: usize,
}

impl VectorParams {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), TransportError> {
        if !(16..=1 << 18).contains(&self.rays) {
            return Err(TransportError::Param(format!(
                "vector_rays {} is out of range (allowed: 16..=262144)",
                self.rays
            )));
        }
        if !(1..=16).contains(&self.volume_res) {
            return Err(TransportError::Param(format!(
                "volume_res {} is out of range (allowed: 1..=16)",
                self.volume_res
            )));
        }
        Ok(())
    }
}

/// Columns of a vector record: a block's `b` or a list of charts' `c`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Cols {
    /// The `k_b` modes of this source block.
    Block(usize),
    /// These global charts, ascending.
    Charts(Vec<usize>),
}

/// One operator: `rows × cols`, row-major; `rows` = items × 4 (OHLSH) or items × 9 (SH).
#[derive(Debug, Clone, PartialEq)]
pub struct VecRecord {
    /// Receiving block (`ΔU⃗`, `U_dyn`) or clutter instance (`C⃗`).
    pub dst: usize,
    /// What the columns multiply.
    pub cols: Cols,
    /// Rows.
    pub rows: usize,
    /// Values, `rows × ncols`.
    pub op: Vec<f64>,
}

impl VecRecord {
    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.op.len().checked_div(self.rows).unwrap_or(0)
    }
}

/// Probes of one receiving block.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockProbes {
    /// Block.
    pub block: usize,
    /// World positions, `g³`, x fastest then y then z (block-local cell centres).
    pub points: Vec<[f64; 3]>,
    /// Inside clutter (more than half the rays meet a back face).
    pub inside: Vec<bool>,
    /// Inside probes filled from their neighbours ([`fill_inside`]).
    pub filled: Vec<bool>,
}

/// Fills the probes inside clutter (§5.4.2's inpainting, on the probe grid): ring by ring,
/// an inside probe with valid 26-neighbours (outside, or filled in an earlier ring) takes
/// their mean, so that trilinear reads next to clutter do not blend in the dark inside of an
/// object. Returns which probes were filled (an inside probe no valid probe reaches stays as
/// traced).
fn fill_inside(items: &mut [ItemOut], inside: &[bool], g: usize) -> Vec<bool> {
    let mut valid: Vec<bool> = inside.iter().map(|&i| !i).collect();
    let mut filled = vec![false; items.len()];
    loop {
        let mut ring = Vec::new();
        for p in 0..items.len() {
            if valid[p] {
                continue;
            }
            let (x, y, z) = ((p % g) as i64, ((p / g) % g) as i64, (p / (g * g)) as i64);
            let mut nbrs = Vec::new();
            for dz in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        let (a, b, c) = (x + dx, y + dy, z + dz);
                        let r = 0..g as i64;
                        if (dx, dy, dz) == (0, 0, 0) || !r.contains(&a) || !r.contains(&b) || !r.contains(&c) {
                            continue;
                        }
                        let q = (a + g as i64 * (b + g as i64 * c)) as usize;
                        if valid[q] {
                            nbrs.push(q);
                        }
                    }
                }
            }
            if !nbrs.is_empty() {
                ring.push((p, mean(items, &nbrs)));
            }
        }
        if ring.is_empty() {
            return filled;
        }
        for (p, v) in ring {
            items[p] = v;
            valid[p] = true;
            filled[p] = true;
        }
    }
}

/// The mean of some items' outputs (keys merged).
fn mean(items: &[ItemOut], which: &[usize]) -> ItemOut {
    let w = 1.0 / which.len() as f64;
    let mut blocks: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    let mut charts: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for &q in which {
        for (y, v) in &items[q].0 {
            let e = blocks.entry(*y).or_insert_with(|| vec![0.0; v.len()]);
            e.iter_mut().zip(v).for_each(|(a, b)| *a += w * b);
        }
        for (j, v) in &items[q].1 {
            let e = charts.entry(*j).or_insert_with(|| vec![0.0; v.len()]);
            e.iter_mut().zip(v).for_each(|(a, b)| *a += w * b);
        }
    }
    (blocks.into_iter().collect(), charts.into_iter().collect(), 0)
}

/// Measurements of the vector bake (`--json` `vector`).
#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
pub struct VectorMetrics {
    /// Rays per texel (uniform hemisphere).
    pub vector_rays: usize,
    /// Rays per probe (uniform sphere).
    pub probe_rays: usize,
    /// Probes per block edge.
    pub volume_res: usize,
    /// Probes in all (receiving blocks × `g³`).
    pub probes: usize,
    /// Probes inside clutter.
    pub probes_inside_clutter: usize,
    /// Of those, filled from their neighbours (the others stay as traced).
    pub probes_inpainted: usize,
    /// Rays traced.
    pub rays_traced: u64,
    /// Values stored.
    pub values: usize,
}

/// The vector and volume operators of a level with clutter.
#[derive(Debug, Clone)]
pub struct DrtVectorBake {
    /// Parameters.
    pub params: VectorParams,
    /// `ΔU_b⃗` (`Cols::Block`) and `ΔU_c⃗` (`Cols::Charts`) per receiving block, texels × 4 rows
    /// (texel frame OHLSH).
    pub scene: Vec<VecRecord>,
    /// `C_b⃗` and `C_c⃗` per instance, clutter texels × 4 rows (world OHLSH).
    pub clutter: Vec<VecRecord>,
    /// `U_dyn` per receiving block, probes × 9 rows (world SH).
    pub dyn_probes: Vec<VecRecord>,
    /// Probe positions per receiving block (ascending).
    pub probes: Vec<BlockProbes>,
    /// Measurements.
    pub metrics: VectorMetrics,
}

/// Accumulators of one item: per source block 9 × k_b (SH-major), per chart 9.
#[derive(Default)]
struct ShAcc {
    blocks: BTreeMap<usize, Vec<f64>>,
    charts: BTreeMap<usize, [f64; 9]>,
    back: usize,
}

impl ShAcc {
    fn wall(&mut self, sc: &Scene<'_>, y: usize, face: usize, q: [f64; 3], scale: f64, sh: &[f64; 9], val: &mut [f64]) {
        let blk = &sc.geo.level.blocks[y];
        let shape = &sc.dict.shapes[blk.shape];
        let k = shape.k_b;
        let (u, v) = face_uv(face, blk.to_local(q));
        val[..k].iter_mut().for_each(|x| *x = 0.0);
        for (t, w) in shape.texels.bilinear(face, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)) {
            if w == 0.0 {
                continue;
            }
            for (a, &l) in val[..k].iter_mut().zip(&shape.l_imp[t * k..(t + 1) * k]) {
                *a += w * l;
            }
        }
        let acc = self.blocks.entry(y).or_insert_with(|| vec![0.0; 9 * k]);
        for (j, &yj) in sh.iter().enumerate() {
            let s = scale * yj;
            for (a, &x) in acc[j * k..(j + 1) * k].iter_mut().zip(&val[..k]) {
                *a += s * x;
            }
        }
    }

    fn chart(&mut self, clutter: &ClutterScene, j: usize, scale: f64, sh: &[f64; 9]) {
        let b = scale / (clutter.charts[j].count as f64).sqrt();
        let acc = self.charts.entry(j).or_insert([0.0; 9]);
        for (a, &yj) in acc.iter_mut().zip(sh) {
            *a += b * yj;
        }
    }
}

/// What one item's rays gave: per source block `out × k_b` values and per chart `out`
/// values, `out` = 4 (OHLSH) or 9 (SH).
pub type ItemOut = (Vec<(usize, Vec<f64>)>, Vec<(usize, Vec<f64>)>, usize);

/// SH → the item's output: OHLSH in the texel frame (`Frame::Texel`), OHLSH with a world
/// linear band (`Frame::World(t, b, n)`), or the SH itself (`Frame::Sh`).
#[derive(Clone, Copy)]
enum Frame {
    Texel,
    World([[f64; 3]; 3]),
    Sh,
}

fn finish(acc: ShAcc, frame: Frame, a: &[f64; 36]) -> ItemOut {
    let map = |s: &dyn Fn(usize) -> f64| -> Vec<f64> {
        match frame {
            Frame::Sh => (0..9).map(s).collect(),
            Frame::Texel | Frame::World(_) => {
                let o: [f64; 4] = core::array::from_fn(|i| (0..9).map(|j| a[i * 9 + j] * s(j)).sum());
                match frame {
                    Frame::World([t, b, n]) => {
                        // linear band v_local = (−a₃, −a₁, a₂) in (t, b, n) → world
                        let w: [f64; 3] = core::array::from_fn(|m| -o[3] * t[m] - o[1] * b[m] + o[2] * n[m]);
                        vec![o[0], w[0], w[1], w[2]]
                    }
                    _ => o.to_vec(),
                }
            }
        }
    };
    let blocks = acc
        .blocks
        .into_iter()
        .map(|(y, v)| {
            let k = v.len() / 9;
            // out-major rows: row i of the item holds k values
            let per_mode: Vec<Vec<f64>> = (0..k).map(|m| map(&|j| v[j * k + m])).collect();
            let out = per_mode[0].len();
            let mut r = vec![0.0; out * k];
            for (m, col) in per_mode.iter().enumerate() {
                for (i, &x) in col.iter().enumerate() {
                    r[i * k + m] = x;
                }
            }
            (y, r)
        })
        .collect();
    let charts = acc.charts.into_iter().map(|(j, v)| (j, map(&|i| v[i]))).collect();
    (blocks, charts, acc.back)
}

/// Stacks the items' outputs into records: one per source block, one for the charts.
fn records(dst: usize, items: &[ItemOut], out: usize, k_of: &dyn Fn(usize) -> usize) -> Vec<VecRecord> {
    let rows = items.len() * out;
    let mut blocks: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    let mut charts: Vec<usize> = items.iter().flat_map(|o| o.1.iter().map(|c| c.0)).collect();
    charts.sort_unstable();
    charts.dedup();
    for (t, (bl, _, _)) in items.iter().enumerate() {
        for (y, v) in bl {
            let k = k_of(*y);
            let op = blocks.entry(*y).or_insert_with(|| vec![0.0; rows * k]);
            op[t * out * k..(t + 1) * out * k].copy_from_slice(v);
        }
    }
    let mut recs: Vec<VecRecord> =
        blocks.into_iter().map(|(y, op)| VecRecord { dst, cols: Cols::Block(y), rows, op }).collect();
    if !charts.is_empty() {
        let nc = charts.len();
        let mut op = vec![0.0; rows * nc];
        for (t, (_, ch, _)) in items.iter().enumerate() {
            for (j, v) in ch {
                let c = charts.binary_search(j).expect("chart listed");
                for (i, &x) in v.iter().enumerate() {
                    op[(t * out + i) * nc + c] = x;
                }
            }
        }
        recs.push(VecRecord { dst, cols: Cols::Charts(charts), rows, op });
    }
    recs
}

fn rot(seed: u64, item: u64, texel: u64) -> (f64, f64) {
    let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, STAGE, item, texel));
    let (s, c) = phi.sin_cos();
    (c, s)
}

/// The probe points of block `b` (block-local cell centres of a `g³` grid, in the world).
pub fn probe_points(level: &Level, b: usize, g: usize) -> Vec<[f64; 3]> {
    let blk = &level.blocks[b];
    (0..g * g * g)
        .map(|k| {
            let c = |i: usize| (i as f64 + 0.5) / g as f64;
            blk.to_world([c(k % g), c((k / g) % g), c(k / (g * g))])
        })
        .collect()
}

/// Each item's output as traced, before the records are stacked and inside probes are
/// filled: what an incremental re-bake keeps ([`crate::drt_state::DrtState::vector`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VectorItems {
    /// Per receiving block (ascending), per scene texel.
    pub scene: Vec<(usize, Vec<ItemOut>)>,
    /// Per clutter instance, per clutter texel.
    pub clutter: Vec<(usize, Vec<ItemOut>)>,
    /// Per receiving block (ascending), per probe, as traced (before [`fill_inside`]).
    pub probes: Vec<(usize, Vec<ItemOut>)>,
}

/// What an incremental vector re-bake starts from: the items of a bake of the scene `old`,
/// in which the instances `moved` stood elsewhere.
#[derive(Debug, Clone, Copy)]
pub struct VectorReuse<'a> {
    /// The previous bake's items.
    pub prev: &'a VectorItems,
    /// The previous scene.
    pub old: &'a ClutterScene,
    /// The instances placed elsewhere since.
    pub moved: &'a [usize],
}

/// What an incremental vector re-bake did (`--json` `incremental.vector`).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct VectorIncStats {
    /// Items (scene texels, clutter texels, probes) traced again.
    pub items_traced: usize,
    /// Items copied from the previous bake: none of their rays can meet a moved instance.
    pub items_reused: usize,
    /// Rays cast (the traced items' rays; the reuse test casts none).
    pub rays_cast: u64,
}

/// Bakes the vector and volume operators for the receiving blocks `recv` (those of the
/// scalar bake) and the clutter instances `insts` (every instance in a whole bake; a
/// shard's own in a sharded one, `crate::drt::DrtShard`).
#[allow(clippy::too_many_arguments)]
pub fn bake_vector(
    level: &Level,
    links: &Links,
    dict: &DrtDict,
    clutter: &ClutterScene,
    recv: &[usize],
    insts: &[usize],
    seed: u64,
    params: VectorParams,
    progress: &dyn Progress,
) -> Result<DrtVectorBake, TransportError> {
    bake_vector_items(level, links, dict, clutter, recv, insts, seed, params, None, progress).map(|r| r.0)
}

/// Whether an item's outcome may differ between the scenes: whether any of its rays (from
/// `o` along `dirs`) meets one of `boxes`, the moved instances' padded bounds at either
/// place (`crate::drt_state`: a ray that misses both meets the same walls and clutter in
/// both scenes). `normal`: the item's rays are in the hemisphere about it, so a box whose
/// bounding sphere lies wholly behind the tangent plane is skipped without a ray.
fn touched(
    boxes: &[[[f64; 3]; 2]],
    o: [f64; 3],
    normal: Option<[f64; 3]>,
    dirs: impl Iterator<Item = [f64; 3]>,
) -> bool {
    let near: Vec<[[f64; 3]; 2]> = boxes
        .iter()
        .filter(|[lo, hi]| {
            let Some(n) = normal else { return true };
            let c: [f64; 3] = core::array::from_fn(|k| 0.5 * (lo[k] + hi[k]) - o[k]);
            let r = (0..3).map(|k| 0.25 * (hi[k] - lo[k]) * (hi[k] - lo[k])).sum::<f64>().sqrt();
            // margin for the rounding of the rays' directions (d·n may be −1e-17)
            c[0] * n[0] + c[1] * n[1] + c[2] * n[2] >= -r * (1.0 + 1e-9) - 1e-9
        })
        .copied()
        .collect();
    if near.is_empty() {
        return false;
    }
    let mut dirs = dirs;
    dirs.any(|d| crate::drt_state::meets_any(&near, o, d))
}

/// [`bake_vector`], also returning the items an incremental re-bake starts from. With
/// `reuse`, an item none of whose rays can meet a moved instance (old or new place, same
/// test as the scalar re-bake's) is copied from the previous bake, every other item (and
/// every texel of a moved instance, and every item of a block or instance the previous bake
/// did not have) is traced again: each item is a function of its own rays, so the result
/// is the full bake's, bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn bake_vector_items(
    level: &Level,
    links: &Links,
    dict: &DrtDict,
    clutter: &ClutterScene,
    recv: &[usize],
    insts: &[usize],
    seed: u64,
    params: VectorParams,
    reuse: Option<VectorReuse<'_>>,
    progress: &dyn Progress,
) -> Result<(DrtVectorBake, VectorItems, VectorIncStats), TransportError> {
    params.validate()?;
    let sc = Scene::new(LevelGeometry { level, links, missing: &dict.missing }, clutter, dict);
    let rho = dict.albedo;
    let hemi = DirectionSet::uniform_hemisphere(params.rays);
    let sphere = DirectionSet::uniform_sphere(4 * params.rays);
    let a = quadratic_to_ohlsh();
    let pi = core::f64::consts::PI;
    let (hw, sw) = (2.0 * pi / params.rays as f64 / pi, 4.0 * pi / sphere.len() as f64 / pi);
    let k_of = |y: usize| dict.shapes[level.blocks[y].shape].k_b;
    let kmax = dict.shapes.iter().map(|s| s.k_b).max().unwrap_or(0);
    let g = params.volume_res;
    let scene_items: usize = recv.iter().map(|&x| dict.shapes[level.blocks[x].shape].texels.len()).sum();
    let clutter_items: usize = insts.iter().map(|&i| clutter.instance_texels[i][1]).sum();
    let total = (scene_items + clutter_items + recv.len() * g * g * g) as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    let tick = |k: u64| {
        let v = done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k;
        progress.update("drt vector rays", v.min(total), total);
    };
    // the moved instances' padded bounds at both places
    let boxes: Vec<[[f64; 3]; 2]> = reuse
        .map(|r| r.moved.iter().flat_map(|&i| [r.old.padded_bounds(i), clutter.padded_bounds(i)]).collect())
        .unwrap_or_default();
    let prev_of = |list: Option<&Vec<(usize, Vec<ItemOut>)>>, key: usize, n: usize| -> Option<Vec<ItemOut>> {
        let (_, v) = list?.iter().find(|(k, _)| *k == key)?;
        (v.len() == n).then(|| v.clone())
    };
    let traced = std::sync::atomic::AtomicUsize::new(0);
    let mut items_out = VectorItems::default();

    // ΔU_b⃗, ΔU_c⃗: scene texels, texel frame
    let mut scene = Vec::new();
    for &x in recv {
        let blk = &level.blocks[x];
        let tex = &dict.shapes[blk.shape].texels;
        let prev = prev_of(reuse.map(|r| &r.prev.scene), x, tex.len());
        let items: Vec<ItemOut> = (0..tex.len())
            .into_par_iter()
            .map_init(
                || (Vec::with_capacity(8), vec![0.0; kmax]),
                |(segs, val), t| {
                    let (f, _, _) = tex.coords(t);
                    let p = blk.to_world(tex.position(t));
                    let fr = sc.geo.frame(x, f);
                    let r = rot(seed, x as u64, t as u64);
                    let dir = |dl: &[f64; 3]| {
                        let l = rotate_z(*dl, r);
                        (l, frame_dir(&fr, l))
                    };
                    if t % 64 == 63 {
                        tick(64);
                    }
                    if let Some(prev) = &prev {
                        if !touched(&boxes, p, Some(fr[2]), hemi.dirs.iter().map(|dl| dir(dl).1)) {
                            return prev[t].clone();
                        }
                    }
                    traced.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let mut acc = ShAcc::default();
                    for dl in &hemi.dirs {
                        let (l, d) = dir(dl);
                        let RayHit::Clutter(wall, hit) = sc.cast_with(x, p, d, segs) else { continue };
                        let y = sh9(l);
                        if let Some((yb, g, q)) = wall {
                            acc.wall(&sc, yb, g, q, -rho * hw, &y, val);
                        }
                        if hit.front {
                            acc.chart(clutter, hit.chart, hw, &y);
                        }
                    }
                    finish(acc, Frame::Texel, &a)
                },
            )
            .collect();
        scene.extend(records(x, &items, 4, &k_of));
        items_out.scene.push((x, items));
    }
    let scene_traced = traced.swap(0, std::sync::atomic::Ordering::Relaxed);

    // C_b⃗, C_c⃗: clutter texels, world OHLSH
    let mut cl = Vec::new();
    for &i in insts {
        let [first, count] = clutter.instance_texels[i];
        let skip = if clutter.is_box(i) { i } else { usize::MAX };
        let is_moved = reuse.is_some_and(|r| r.moved.contains(&i));
        let prev = prev_of(reuse.map(|r| &r.prev.clutter), i, count).filter(|_| !is_moved);
        let items: Vec<ItemOut> = (first..first + count)
            .into_par_iter()
            .map_init(
                || (Vec::with_capacity(8), vec![0.0; kmax]),
                |(segs, val), ti| {
                    let tx = &clutter.texels[ti];
                    let (t, bt) = penumbra_math::warp::orthonormal_basis(tx.normal);
                    let fr = [t, bt, tx.normal];
                    let (o, b) = crate::drt_state::clutter_origin(&sc, ti);
                    let r = rot(seed ^ 0x4342, u64::MAX - 1, ti as u64);
                    let dir = |dl: &[f64; 3]| {
                        let l = rotate_z(*dl, r);
                        (l, frame_dir(&fr, l))
                    };
                    if ti % 64 == 63 {
                        tick(64);
                    }
                    if let Some(prev) = &prev {
                        if !touched(&boxes, o, Some(tx.normal), hemi.dirs.iter().map(|dl| dir(dl).1)) {
                            return prev[ti - first].clone();
                        }
                    }
                    traced.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let mut acc = ShAcc::default();
                    if let Some(b) = b {
                        for dl in &hemi.dirs {
                            let (l, d) = dir(dl);
                            let y = sh9(l);
                            match sc.cast_except(b, o, d, segs, skip) {
                                RayHit::Wall(yb, g, q) => acc.wall(&sc, yb, g, q, rho * hw, &y, val),
                                RayHit::Clutter(_, h) if h.front => acc.chart(clutter, h.chart, hw, &y),
                                _ => {}
                            }
                        }
                    }
                    finish(acc, Frame::World(fr), &a)
                },
            )
            .collect();
        cl.extend(records(i, &items, 4, &k_of));
        items_out.clutter.push((i, items));
    }
    let clutter_traced = traced.swap(0, std::sync::atomic::Ordering::Relaxed);

    // U_dyn: probes, world SH
    let mut dyn_probes = Vec::new();
    let mut probes = Vec::new();
    for &x in recv {
        let points = probe_points(level, x, g);
        let prev = prev_of(reuse.map(|r| &r.prev.probes), x, points.len());
        let items: Vec<ItemOut> = points
            .par_iter()
            .enumerate()
            .map_init(
                || (Vec::with_capacity(8), vec![0.0; kmax]),
                |(segs, val), (pi_, &p)| {
                    // rotate the sphere set about +Y (world up) per probe
                    let (c, s) = rot(seed ^ 0x5644, x as u64, pi_ as u64);
                    let dir = |dl: &[f64; 3]| [dl[0] * c + dl[2] * s, dl[1], -dl[0] * s + dl[2] * c];
                    if let Some(prev) = &prev {
                        if !touched(&boxes, p, None, sphere.dirs.iter().map(dir)) {
                            return prev[pi_].clone();
                        }
                    }
                    traced.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let mut acc = ShAcc::default();
                    for dl in &sphere.dirs {
                        let d = dir(dl);
                        let y = sh9(d);
                        match sc.cast_with(x, p, d, segs) {
                            RayHit::Wall(yb, g, q) => acc.wall(&sc, yb, g, q, rho * sw, &y, val),
                            RayHit::Clutter(_, h) if h.front => acc.chart(clutter, h.chart, sw, &y),
                            RayHit::Clutter(..) => acc.back += 1,
                            RayHit::Lost => {}
                        }
                    }
                    finish(acc, Frame::Sh, &a)
                },
            )
            .collect();
        tick(points.len() as u64);
        items_out.probes.push((x, items.clone()));
        let mut items = items;
        let inside: Vec<bool> = items.iter().map(|o| 2 * o.2 > sphere.len()).collect();
        let filled = fill_inside(&mut items, &inside, g);
        dyn_probes.extend(records(x, &items, 9, &k_of));
        probes.push(BlockProbes { block: x, points, inside, filled });
    }
    let probes_traced = traced.load(std::sync::atomic::Ordering::Relaxed);
    let n_probes: usize = probes.iter().map(|p| p.points.len()).sum();
    let metrics = VectorMetrics {
        vector_rays: params.rays,
        probe_rays: sphere.len(),
        volume_res: g,
        probes: n_probes,
        probes_inside_clutter: probes.iter().flat_map(|p| &p.inside).filter(|&&b| b).count(),
        probes_inpainted: probes.iter().flat_map(|p| &p.filled).filter(|&&b| b).count(),
        rays_traced: ((scene_items + clutter_items) * params.rays + n_probes * sphere.len()) as u64,
        values: scene.iter().chain(&cl).chain(&dyn_probes).map(|r| r.op.len()).sum(),
    };
    let items_traced = scene_traced + clutter_traced + probes_traced;
    let stats = VectorIncStats {
        items_traced,
        items_reused: scene_items + clutter_items + n_probes - items_traced,
        rays_cast: ((scene_traced + clutter_traced) * params.rays + probes_traced * sphere.len()) as u64,
    };
    Ok((DrtVectorBake { params, scene, clutter: cl, dyn_probes, probes, metrics }, items_out, stats))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clutter::{BoxFaces, ClutterShape, ClutterSpec, quat_y};
    use crate::drt::{DrtParams, DrtShape, KcMode, bake};
    use crate::level::Block;
    use crate::shape::{CLOSED, Texels};
    use penumbra_math::progress::NoProgress;

    const R: usize = 6;
    const KB: usize = 3;
    const Y00: f64 = 0.282_094_791_773_878_14;
    const C1: f64 = 0.488_602_511_902_919_9;

    /// A closed-cube dictionary: `L_imp` column 0 all ones (a uniformly lit room), the other
    /// columns hashed.
    fn dict(albedo: f64) -> DrtDict {
        let texels = Texels::new(CLOSED, R);
        let n = texels.len();
        let l_imp =
            (0..n * KB).map(|i| if i % KB == 0 { 1.0 } else { unit_f64(hash4(5, 6, i as u64, 0)) - 0.4 }).collect();
        DrtDict {
            shapes: vec![DrtShape::new("closed".into(), texels, KB, l_imp, vec![0.0; n * KB])],
            missing: vec![0],
            face_res: R,
            albedo,
            crc32c: 0,
            volume_res: 3,
        }
    }

    fn scene() -> (Level, Links, ClutterScene) {
        let level = Level {
            blocks: vec![Block { shape: 0, rotation: 0, translation: [0.5; 3], scale: [1.0; 3] }],
            connections: vec![],
        };
        let spec = ClutterSpec {
            name: "p".into(),
            shape: ClutterShape::Box { size: [0.25, 0.55, 0.2], faces: BoxFaces::NoBottom },
            translate: [0.42, 0.0, 0.55],
            rotate: quat_y(20.0),
            scale: 1.0,
            albedo: [0.5; 3],
        };
        (level, vec![[None; 6]], ClutterScene::new(&[spec], 4).unwrap())
    }

    /// Three pillars in a closed room, the second at `x1`.
    fn pillars(x1: f64) -> ClutterScene {
        let specs: Vec<ClutterSpec> = [(0.25, 0.25), (x1, 0.3), (0.3, 0.75)]
            .iter()
            .enumerate()
            .map(|(i, &(x, z))| ClutterSpec {
                name: format!("p{i}"),
                shape: ClutterShape::Box { size: [0.12, 0.6, 0.12], faces: BoxFaces::NoBottom },
                translate: [x, 0.0, z],
                rotate: quat_y(10.0 * i as f64),
                scale: 1.0,
                albedo: [0.5; 3],
            })
            .collect();
        ClutterScene::new(&specs, 4).unwrap()
    }

    #[test]
    fn an_incremental_vector_re_bake_equals_the_full_bake_and_reuses_the_untouched_items() {
        let d = dict(0.6);
        let (level, links, _) = scene();
        let (old, new) = (pillars(0.7), pillars(0.62));
        let vp = VectorParams { rays: 64, volume_res: 3 };
        let all: Vec<usize> = (0..3).collect();
        let run =
            |c: &ClutterScene, reuse| bake_vector_items(&level, &links, &d, c, &[0], &all, 9, vp, reuse, &NoProgress);
        let (_, items_old, st) = run(&old, None).unwrap();
        assert_eq!((st.items_reused, st.rays_cast), (0, (6 * R * R + 3 * 80) as u64 * 64 + 27 * 256));
        // the items survive a state file round trip bit for bit
        let state = crate::drt_state::DrtState {
            key: "k".into(),
            instances: vec![],
            blocks: vec![],
            clutter: vec![],
            asset_crc32c: None,
            vector: Some(items_old.clone()),
        };
        let back = crate::drt_state::DrtState::from_bytes(&state.to_bytes()).unwrap();
        assert_eq!(back.vector.as_ref(), Some(&items_old));
        let reuse = VectorReuse { prev: back.vector.as_ref().unwrap(), old: &old, moved: &[1] };
        let (inc, items_inc, st) = run(&new, Some(reuse)).unwrap();
        let (full, items_full, _) = run(&new, None).unwrap();
        assert_eq!(items_inc, items_full);
        assert_eq!(
            (inc.scene, inc.clutter, inc.dyn_probes, inc.probes),
            (full.scene, full.clutter, full.dyn_probes, full.probes)
        );
        // the moved pillar's 80 texels are traced again; some texels of the others are not
        assert!(st.items_traced >= 80 && st.items_reused > 0, "{st:?}");
        assert_eq!(st.items_traced + st.items_reused, 6 * R * R + 3 * 80 + 27);
        // a reuse that ignored the move would differ: the test can fail
        let wrong = VectorReuse { prev: &items_old, old: &old, moved: &[] };
        let (_, items_wrong, _) = run(&new, Some(wrong)).unwrap();
        assert_ne!(items_wrong, items_full);
    }

    /// `Σ_records op·x` for item row `row` of `dst`: `x` gives each column's value.
    fn eval(recs: &[VecRecord], dst: usize, row: usize, x: &dyn Fn(&Cols, usize) -> f64) -> f64 {
        recs.iter()
            .filter(|r| r.dst == dst)
            .map(|r| {
                let nc = r.ncols();
                (0..nc).map(|c| r.op[row * nc + c] * x(&r.cols, c)).sum::<f64>()
            })
            .sum()
    }

    #[test]
    fn world_ohlsh_carries_the_local_linear_band_into_world_axes() {
        // radiance y₁₀ (∝ the local z, the normal) and −y₁₁ (∝ the local x = t): the world
        // linear band must point along n and along t
        let n = [0.6, 0.0, 0.8];
        let (t, b) = penumbra_math::warp::orthonormal_basis(n);
        let a = quadratic_to_ohlsh();
        for (j, want) in [(2usize, n), (3, t.map(|x| -x))] {
            let mut acc = ShAcc::default();
            let mut sh = [0.0; 9];
            sh[j] = 1.0;
            acc.charts.insert(0, sh);
            let (_, ch, _) = finish(acc, Frame::World([t, b, n]), &a);
            let o = &ch[0].1;
            let w = [o[1], o[2], o[3]];
            let len = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            assert!(len > 0.5, "{o:?}");
            for k in 0..3 {
                assert!((w[k] / len - want[k]).abs() < 1e-9, "band {j}: {w:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn dyn_probes_see_a_uniform_scene_as_uniform_radiance() {
        // walls lit uniformly (b = e₀: L_imp = 1, radiance ρ/π) and every chart at the same
        // radiance (c_j = ρ·√m_j): each probe outside the box sees ρ/π in every direction,
        // so its SH is 4ρ·y₀₀ in the DC band and its irradiance ρ for every normal. A wrong
        // scale on either part, or a missing chart part, breaks it.
        let rho = 0.7;
        let d = dict(rho);
        let (level, links, cl) = scene();
        let vp = VectorParams { rays: 256, volume_res: 3 };
        let v = bake_vector(&level, &links, &d, &cl, &[0], &[0], 1, vp, &NoProgress).unwrap();
        assert_eq!(v.probes[0].points.len(), 27);
        let col = |c: &Cols, k: usize| match c {
            Cols::Block(_) => f64::from(u8::from(k == 0)),
            Cols::Charts(ch) => rho * (cl.charts[ch[k]].count as f64).sqrt(),
        };
        let mut saw_box = false;
        let [lo, hi] = cl.bounds[0];
        for (p, &inside) in v.probes[0].inside.iter().enumerate() {
            let q = v.probes[0].points[p];
            let in_bounds = (0..3).all(|a| q[a] > lo[a] && q[a] < hi[a]);
            // the box's centre column of probes is inside it; the others are not
            assert_eq!(inside, in_bounds, "probe {p} at {q:?}");
            if inside {
                continue;
            }
            let sh: Vec<f64> = (0..9).map(|j| eval(&v.dyn_probes, 0, p * 9 + j, &col)).collect();
            assert!((sh[0] - 4.0 * rho * Y00).abs() < 1e-9, "probe {p}: DC {}", sh[0]);
            for (j, &s) in sh.iter().enumerate().skip(1) {
                assert!(s.abs() < 0.03 * sh[0], "probe {p} band {j}: {s}");
            }
            // the walls alone do not give the DC band wherever the box is in view
            let walls =
                eval(&v.dyn_probes, 0, p * 9, &|c, k| if matches!(c, Cols::Block(_)) { col(c, k) } else { 0.0 });
            saw_box |= walls < 0.99 * sh[0];
        }
        assert!(saw_box);
    }

    #[test]
    fn the_vector_operators_at_the_normal_are_the_scalar_ones() {
        // OHLSH irradiance at the texel's own normal, `π y₀₀ a₀ + (2π/3) C1 a₂` (scene) or with
        // the world band along n (clutter), estimates what the scalar ΔU_b and C_b rows hold
        // (other rays: uniform instead of cosine, so within the Monte-Carlo error)
        let d = dict(0.6);
        let (level, links, cl) = scene();
        let rays = 4096;
        let params = DrtParams {
            rays,
            clutter_rays: rays,
            neighborhood: 0,
            k_c: 64,
            k_dc: 4096,
            clutter_to_clutter: false,
            kc_mode: KcMode::Full,
            inpaint: false,
            clutter_res: 4,
            clutter_basis_res: 1,
            seed: 3,
            half: false,
            vector_rays: None,
            volume_res: None,
        };
        let s = bake(&level, &links, &d, &cl, &params, &NoProgress).unwrap();
        let v = bake_vector(&level, &links, &d, &cl, &[0], &[0], 9, VectorParams { rays, volume_res: 2 }, &NoProgress)
            .unwrap();
        let pi = core::f64::consts::PI;
        let n = d.shapes[0].texels.len();
        let du = s.du_b.iter().find(|r| r.dst == 0 && r.src == 0).unwrap();
        let (mut num, mut den) = (0.0, 0.0);
        for t in 0..n {
            for m in 0..KB {
                let x = |c: &Cols, k: usize| f64::from(u8::from(matches!(c, Cols::Block(0)) && k == m));
                let e =
                    pi * Y00 * eval(&v.scene, 0, t * 4, &x) + 2.0 * pi / 3.0 * C1 * eval(&v.scene, 0, t * 4 + 2, &x);
                let want = du.op[t * KB + m];
                num += (e - want) * (e - want);
                den += want * want;
            }
        }
        assert!(den > 0.0);
        let err = (num / den).sqrt();
        assert!(err < 0.06, "ΔU_b⃗ at the normal vs ΔU_b: {err}");
        // clutter: the unreduced C_b (kc_mode full, rank ≥ its columns) against C_b⃗ at n
        let g = &s.c_b[0];
        let k = *g.src_offsets.last().unwrap();
        let (mut num, mut den) = (0.0, 0.0);
        for (i, tx) in cl.texels.iter().enumerate() {
            for m in 0..KB {
                let x = |c: &Cols, kk: usize| f64::from(u8::from(matches!(c, Cols::Block(0)) && kk == m));
                let a: [f64; 4] = core::array::from_fn(|r| eval(&v.clutter, 0, i * 4 + r, &x));
                let wn = a[1] * tx.normal[0] + a[2] * tx.normal[1] + a[3] * tx.normal[2];
                let e = pi * Y00 * a[0] + 2.0 * pi / 3.0 * C1 * wn;
                let want = g.full[i * k + m];
                num += (e - want) * (e - want);
                den += want * want;
            }
        }
        let err = (num / den).sqrt();
        assert!(err < 0.03, "C_b⃗ at the normal vs C_b: {err}");
    }
}
