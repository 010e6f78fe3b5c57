//! The rays' sums of a DRT bake in fixed point, and incremental re-bakes from them (the
//! thesis's level-design loop, MRT thesis §5.4.4: move a pillar, see its effect).
//!
//! # Why fixed point
//! Moving one clutter instance changes only the rays that meet it, at its old or its new
//! place: about a tenth of a room's rays. An incremental re-bake keeps every texel's sums,
//! re-traces those rays in the old scene (subtracting what they gave) and in the new one
//! (adding), and assembles the operators again. For the result to be the bytes of a full
//! bake of the new scene, a texel's sums must not depend on the order of their additions
//! or on which rays were added and removed before: they are integers.
//! - A ray's bilinear weight `w` on a wall texel adds `round(w·2¹⁶)` to that texel's
//!   weight `W_t` (`W_SCALE`).
//! - `L_imp` of each shape is quantized once to `Lq = round(L_imp·s)`, `s` a power of two
//!   with `max |Lq| ≤ 2²²` ([`quantize`]).
//! - A texel's row per block is `Σ_t W_t·Lq_t` in `i64` (at most `rays·2¹⁶·2²²` ≤ 2⁵⁸ for
//!   the 2²⁰ rays the parameters allow), linear in `W`, so a re-traced ray's change is exact.
//! - Chart hits and back-face hits are counts.
//!
//! The operators are then `ΔU_b = −(ρ/N)·row/(2¹⁶·s)`, `C_b = (ρ/N)·row/(2¹⁶·s)`,
//! `ΔU_c = hits/(N·√m_j)` (`crate::drt`). The rounding of `w` changes a row by at most
//! `4·2⁻¹⁷` of one ray's weight per ray, and of `L_imp` by `2⁻²³` of its largest entry: far
//! below the f16 the asset stores (tested against the exact `(F_clutter − F)·L_imp`).
//!
//! # Which rays are re-traced
//! A ray's outcome (the first clutter it meets, the wall behind) can change only if it meets
//! a moved instance in the old or the new scene; the closest-hit search first tests each
//! instance's padded world box, so a ray that misses both padded boxes (for `t ≥ 0`, a
//! superset of every segment the search tests) gives the same outcome in both scenes and
//! is not re-traced. A moved instance's own texels are traced again in full.
//!
//! The vector operators (`--vector`) are `f64` sums, which cannot be re-traced ray by ray to
//! the same bits: the state keeps each item's output instead ([`DrtState::vector`]), and a
//! re-bake traces again the items a moved instance may touch ([`crate::drt_vector::VectorReuse`]).

use crate::TransportError;
use crate::clutter::ClutterScene;
use crate::drt::{DrtDict, RayHit, Scene, frame_dir, rotated_frame, rotation};
use crate::drt_vector::{ItemOut, VectorItems};
use crate::gather::DirectionSet;
use crate::level::Level;
use serde::{Deserialize, Serialize};

/// Fixed-point scale of a bilinear weight.
pub const W_SCALE: f64 = 65536.0;

/// Bits of a quantized `L_imp` entry's magnitude.
pub const L_BITS: i32 = 22;

/// `L_imp` quantized to `i32` with a power-of-two scale `s`: `Lq = round(L·s)`, the largest
/// `|Lq| ≤ 2^L_BITS`. Returns `(Lq, s)`.
pub fn quantize(l: &[f64]) -> (Vec<i32>, f64) {
    let m = l.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
    if m == 0.0 || !m.is_finite() {
        return (vec![0; l.len()], 1.0);
    }
    let e = m.log2().ceil() as i32;
    let s = 2f64.powi(L_BITS - e);
    (l.iter().map(|&x| (x * s).round() as i32).collect(), s)
}

/// One texel's sums (canonical: sorted keys, no zero entries).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Sums {
    /// `(block, Σ_t W_t·Lq_t per mode)`, ascending blocks.
    pub rows: Vec<(u32, Vec<i64>)>,
    /// `(chart, front hits)`, ascending charts.
    pub charts: Vec<(u32, i64)>,
    /// Rays meeting clutter from behind.
    pub back: i64,
}

impl Sums {
    /// No contribution at all.
    pub fn is_zero(&self) -> bool {
        self.rows.is_empty() && self.charts.is_empty() && self.back == 0
    }

    /// `self += d`, keeping the canonical form.
    pub fn add(&mut self, d: &Sums) {
        let old = core::mem::take(&mut self.rows);
        let mut rows = Vec::with_capacity(old.len() + d.rows.len());
        let mut b = d.rows.iter().peekable();
        for (k, mut r) in old {
            while let Some(y) = b.next_if(|y| y.0 < k) {
                rows.push(y.clone());
            }
            if let Some((_, s)) = b.next_if(|y| y.0 == k) {
                for (p, q) in r.iter_mut().zip(s) {
                    *p += q;
                }
                if r.iter().all(|&v| v == 0) {
                    continue;
                }
            }
            rows.push((k, r));
        }
        rows.extend(b.cloned());
        self.rows = rows;
        let mut charts = Vec::with_capacity(self.charts.len() + d.charts.len());
        let (mut i, mut j) = (0, 0);
        while i < self.charts.len() || j < d.charts.len() {
            let x = self.charts.get(i).copied();
            let y = d.charts.get(j).copied();
            match (x, y) {
                (Some(x), Some(y)) if x.0 == y.0 => {
                    if x.1 + y.1 != 0 {
                        charts.push((x.0, x.1 + y.1));
                    }
                    i += 1;
                    j += 1;
                }
                (Some(x), Some(y)) if x.0 < y.0 => {
                    charts.push(x);
                    i += 1;
                }
                (Some(x), None) => {
                    charts.push(x);
                    i += 1;
                }
                (_, Some(y)) => {
                    charts.push(y);
                    j += 1;
                }
                (None, None) => break,
            }
        }
        self.charts = charts;
        self.back += d.back;
    }
}

/// A wall accumulator of one block: fixed-point weights per wall texel and the texels
/// touched since the last [`Acc::take`].
#[derive(Debug)]
struct Slot {
    block: usize,
    w: Vec<i64>,
    on: Vec<bool>,
    touched: Vec<usize>,
}

/// Modes up to which [`Acc::take`] sums a row in an `f64` array on the stack.
const F64_ROW: usize = 64;

/// `row += w · l` in `i64`.
#[inline]
fn row_i64(row: &mut [i64], w: i64, l: &[i32]) {
    if w != 0 {
        for (a, &l) in row.iter_mut().zip(l) {
            *a += w * i64::from(l);
        }
    }
}

/// One texel's accumulators, reused across texels (nothing is zeroed but what was touched).
#[derive(Debug)]
pub(crate) struct Acc {
    slots: Vec<Slot>,
    used: Vec<usize>,
    charts: Vec<i64>,
    chart_on: Vec<bool>,
    chart_touched: Vec<usize>,
    back: i64,
    /// The slot the last wall hit went to.
    last: usize,
}

impl Acc {
    pub(crate) fn new(charts: usize) -> Self {
        Self {
            slots: Vec::new(),
            used: Vec::new(),
            charts: vec![0; charts],
            chart_on: vec![false; charts],
            chart_touched: Vec::new(),
            back: 0,
            last: 0,
        }
    }

    /// `sign · (bilinear weights of the wall point (y, face, world q))`.
    fn wall(&mut self, sc: &Scene<'_>, y: usize, face: usize, q: [f64; 3], sign: i64) {
        let m = &sc.wall_uv[y][face];
        let u = m[0] * q[0] + m[1] * q[1] + m[2] * q[2] + m[3];
        let v = m[4] * q[0] + m[5] * q[1] + m[6] * q[2] + m[7];
        // most rays of a texel end in the same block: try the last slot first
        let s = match self.slots.get(self.last) {
            Some(s) if s.block == y => self.last,
            _ => match self.slots.iter().position(|s| s.block == y) {
                Some(s) => s,
                None => {
                    let n = sc.dict.shapes[sc.geo.level.blocks[y].shape].texels.len();
                    self.slots.push(Slot { block: y, w: vec![0; n], on: vec![false; n], touched: Vec::new() });
                    self.slots.len() - 1
                }
            },
        };
        self.last = s;
        let taps = sc.block_texels[y].bilinear(face, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        let slot = &mut self.slots[s];
        // the weights sum to one: some tap is nonzero, so the slot is in use
        if slot.touched.is_empty() {
            self.used.push(s);
        }
        for (t, bw) in taps {
            // bw ∈ [0, 1]: round half up without a libm call
            let q = (bw * W_SCALE + 0.5) as i64;
            if q == 0 {
                continue;
            }
            if !slot.on[t] {
                slot.on[t] = true;
                slot.touched.push(t);
            }
            slot.w[t] += sign * q;
        }
    }

    fn chart(&mut self, j: usize, sign: i64) {
        if !self.chart_on[j] {
            self.chart_on[j] = true;
            self.chart_touched.push(j);
        }
        self.charts[j] += sign;
    }

    /// The sums since the last call; the accumulators reset.
    pub(crate) fn take(&mut self, dict: &DrtDict, level: &Level) -> Sums {
        let mut rows = Vec::with_capacity(self.used.len());
        for &s in &self.used {
            let slot = &mut self.slots[s];
            let sh = &dict.shapes[level.blocks[slot.block].shape];
            let k = sh.k_b;
            // integer sums: no order to fix, so the touched texels are not sorted. When
            // Σ|W_t|·2^L_BITS < 2⁵³ every product and partial sum is an integer that f64
            // holds exactly, so the (vectorisable) f64 loop gives the i64 loop's result.
            let wsum: i64 = slot.touched.iter().map(|&t| slot.w[t].abs()).sum();
            let mut row = vec![0i64; k];
            if wsum < (1i64 << (53 - L_BITS)) && k <= F64_ROW {
                let mut rf = [0.0f64; F64_ROW];
                let rf = &mut rf[..k];
                for &t in &slot.touched {
                    let w = core::mem::take(&mut slot.w[t]) as f64;
                    slot.on[t] = false;
                    for (a, &l) in rf.iter_mut().zip(&sh.l_qf[t * k..(t + 1) * k]) {
                        *a += w * l;
                    }
                }
                for (a, &f) in row.iter_mut().zip(rf.iter()) {
                    *a = f as i64;
                }
            } else {
                for &t in &slot.touched {
                    let w = core::mem::take(&mut slot.w[t]);
                    slot.on[t] = false;
                    row_i64(&mut row, w, &sh.l_q[t * k..(t + 1) * k]);
                }
            }
            slot.touched.clear();
            if row.iter().any(|&v| v != 0) {
                rows.push((slot.block as u32, row));
            }
        }
        self.used.clear();
        rows.sort_unstable_by_key(|r| r.0);
        self.chart_touched.sort_unstable();
        let mut charts = Vec::with_capacity(self.chart_touched.len());
        for &j in &self.chart_touched {
            let c = core::mem::take(&mut self.charts[j]);
            self.chart_on[j] = false;
            if c != 0 {
                charts.push((j as u32, c));
            }
        }
        self.chart_touched.clear();
        Sums { rows, charts, back: core::mem::take(&mut self.back) }
    }
}

/// Casts the rays of scene texel `t` of block `x` (those `cull` keeps, or all) into each of
/// `scenes` (same level, other clutter), adding `sign` times each outcome to `acc`; returns
/// how many rays were kept.
pub(crate) fn scene_texel(
    scenes: &[(&Scene<'_>, i64)],
    dirs: &DirectionSet,
    seed: u64,
    (x, t): (usize, usize),
    cull: Option<&Cull>,
    acc: &mut Acc,
    segs: &mut Vec<(usize, f64, f64)>,
) -> u64 {
    let sc = scenes[0].0;
    let blk = &sc.geo.level.blocks[x];
    let sh = &sc.dict.shapes[blk.shape];
    let (f, _, _) = sh.texels.coords(t);
    let p = blk.to_world(sh.texels.position(t));
    let fr = sc.geo.frame(x, f);
    let rot = rotation(seed, x as u64, t as u64);
    let local = cull.map(|c| c.texel(p, &fr, rot)).unwrap_or_default();
    if cull.is_some() && local.is_empty() {
        return 0;
    }
    let g = rotated_frame(&fr, rot);
    let mut kept = 0;
    for dl in &dirs.dirs {
        if cull.is_some() && !Cull::near(&local, *dl) {
            continue;
        }
        let d = frame_dir(&g, *dl);
        if cull.is_some_and(|c| !meets_any(&c.boxes, p, d)) {
            continue;
        }
        kept += 1;
        let inv = d.map(|c| 1.0 / c);
        let wall = sc.walk.trace(x, p, d, inv, segs);
        for &(s, sign) in scenes {
            let RayHit::Clutter(wall, hit) = s.resolve_inv(wall, segs, p, d, inv, usize::MAX) else { continue };
            if let Some((y, g, q)) = wall {
                acc.wall(sc, y, g, q, sign);
            }
            match side(&hit, d) {
                Side::Chart(j) => acc.chart(j, sign),
                Side::Back => acc.back += sign,
                Side::Uncharted => {}
            }
        }
    }
    kept
}

/// Which side of the clutter a scene ray met.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    /// The front of chart `j` (`ΔU_c`).
    Chart(usize),
    /// A back face: the inside of an object (the inpainting test counts these).
    Back,
    /// The front of a triangle in no chart (a box-projected chart too small for a texel):
    /// it shadows, but it is neither a chart's light nor a sign of being inside.
    Uncharted,
}

/// The side of `hit` a ray along `d` met.
pub(crate) fn side(hit: &crate::clutter::ClutterHit, d: [f64; 3]) -> Side {
    if hit.front {
        Side::Chart(hit.chart)
    } else if hit.normal[0] * d[0] + hit.normal[1] * d[1] + hit.normal[2] * d[2] < 0.0 {
        Side::Uncharted
    } else {
        Side::Back
    }
}

/// The origin of clutter texel `i`'s rays and the block it lies in (`None`: its outside is
/// in no block, so it receives nothing).
pub(crate) fn clutter_origin(sc: &Scene<'_>, i: usize) -> ([f64; 3], Option<usize>) {
    let tx = &sc.clutter.texels[i];
    let n = tx.normal;
    // off the surface by a hair: the texel's own face is not hit again
    let eps = 1e-7;
    let o = [tx.position[0] + eps * n[0], tx.position[1] + eps * n[1], tx.position[2] + eps * n[2]];
    (o, sc.geo.block_of(o))
}

/// Casts the rays of clutter texel `i` (from block `b`; those `cull` keeps, or all) into
/// each of `scenes`, adding `sign` times each outcome to `acc`; returns how many rays were
/// kept.
pub(crate) fn clutter_texel(
    scenes: &[(&Scene<'_>, i64)],
    dirs: &DirectionSet,
    seed: u64,
    (i, b, o): (usize, usize, [f64; 3]),
    cull: Option<&Cull>,
    acc: &mut Acc,
    segs: &mut Vec<(usize, f64, f64)>,
) -> u64 {
    let sc = scenes[0].0;
    let tx = &sc.clutter.texels[i];
    let (t, bt) = penumbra_math::warp::orthonormal_basis(tx.normal);
    let fr = [t, bt, tx.normal];
    let rot = rotation(seed ^ 0x4342, u64::MAX - 1, i as u64);
    let own = sc.clutter.charts[tx.chart].instance;
    let skip = if sc.clutter.is_box(own) { own } else { usize::MAX };
    let local = cull.map(|c| c.texel(o, &fr, rot)).unwrap_or_default();
    if cull.is_some() && local.is_empty() {
        return 0;
    }
    let g = rotated_frame(&fr, rot);
    let mut kept = 0;
    for dl in &dirs.dirs {
        if cull.is_some() && !Cull::near(&local, *dl) {
            continue;
        }
        let d = frame_dir(&g, *dl);
        if cull.is_some_and(|c| !meets_any(&c.boxes, o, d)) {
            continue;
        }
        kept += 1;
        let inv = d.map(|c| 1.0 / c);
        let wall = sc.walk.trace(b, o, d, inv, segs);
        for &(s, sign) in scenes {
            match s.resolve_inv(wall, segs, o, d, inv, skip) {
                RayHit::Wall(y, g, q) => acc.wall(sc, y, g, q, sign),
                RayHit::Clutter(_, h) if h.front => acc.chart(h.chart, sign),
                _ => {}
            }
        }
    }
    kept
}

/// Per instance, what an incremental re-bake compares: everything that shapes its rays but
/// its placement (`shape_key`, from the caller), and its placement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateInstance {
    /// Hash of the instance's geometry and charting (not its placement or albedo: albedo
    /// scales the clutter's light at run time and changes no ray).
    pub shape_key: String,
    /// World translation.
    pub translate: [f64; 3],
    /// Rotation quaternion `[x, y, z, w]`.
    pub rotate: [f64; 4],
    /// Uniform scale.
    pub scale: f64,
}

/// The sums of a whole bake, what an incremental re-bake starts from.
#[derive(Debug, Clone, PartialEq)]
pub struct DrtState {
    /// The caller's hash of everything but the clutter placement (dictionary, level,
    /// parameters, tool version); a state with another key is not used.
    pub key: String,
    /// Per instance.
    pub instances: Vec<StateInstance>,
    /// Receiving blocks (ascending) and their texels' sums.
    pub blocks: Vec<(usize, Vec<Sums>)>,
    /// Per instance, per texel: the sums, `None` for a texel whose outside is in no block.
    pub clutter: Vec<Vec<Option<Sums>>>,
    /// CRC-32C of the asset bytes this bake wrote (set by the caller): the next incremental
    /// re-bake copies the unchanged records from that asset when it still finds it.
    pub asset_crc32c: Option<u32>,
    /// The vector operators' items (`--vector`, [`crate::drt_vector::bake_vector_items`]),
    /// `None` when the bake had none. They are `f64` outputs per item, not sums: an
    /// incremental re-bake re-traces every item a moved instance may touch and copies the
    /// others ([`crate::drt_vector::VectorReuse`]).
    pub vector: Option<VectorItems>,
}

const MAGIC: &[u8; 8] = b"PNBDRTS\x01";

#[derive(Serialize, Deserialize)]
struct Header {
    key: String,
    instances: Vec<StateInstance>,
    blocks: Vec<(usize, usize)>,
    clutter: Vec<usize>,
    #[serde(default)]
    asset_crc32c: Option<u32>,
    /// Item counts of the vector section (absent in states without one, and in states
    /// written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    vector: Option<VectorHeader>,
}

/// Per list of [`VectorItems`]: `(block or instance, items)`.
#[derive(Serialize, Deserialize)]
struct VectorHeader {
    scene: Vec<(usize, usize)>,
    clutter: Vec<(usize, usize)>,
    probes: Vec<(usize, usize)>,
}

fn counts(l: &[(usize, Vec<ItemOut>)]) -> Vec<(usize, usize)> {
    l.iter().map(|(k, v)| (*k, v.len())).collect()
}

fn put_f64s(out: &mut Vec<u8>, v: &[f64]) {
    out.extend((v.len() as u32).to_le_bytes());
    for x in v {
        out.extend(x.to_bits().to_le_bytes());
    }
}

fn put_item(out: &mut Vec<u8>, (blocks, charts, back): &ItemOut) {
    for list in [blocks, charts] {
        out.extend((list.len() as u32).to_le_bytes());
        for (k, v) in list {
            out.extend((*k as u32).to_le_bytes());
            put_f64s(out, v);
        }
    }
    out.extend((*back as u64).to_le_bytes());
}

fn put_sums(out: &mut Vec<u8>, s: &Sums) {
    out.extend((s.rows.len() as u32).to_le_bytes());
    for (b, r) in &s.rows {
        out.extend(b.to_le_bytes());
        out.extend((r.len() as u32).to_le_bytes());
        for v in r {
            out.extend(v.to_le_bytes());
        }
    }
    out.extend((s.charts.len() as u32).to_le_bytes());
    for (j, c) in &s.charts {
        out.extend(j.to_le_bytes());
        out.extend(c.to_le_bytes());
    }
    out.extend(s.back.to_le_bytes());
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], TransportError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len());
        let end = end.ok_or_else(|| TransportError::Input("DRT state: truncated".into()))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, TransportError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap_or_default()))
    }
    fn i64(&mut self) -> Result<i64, TransportError> {
        Ok(i64::from_le_bytes(self.take(8)?.try_into().unwrap_or_default()))
    }
    fn sums(&mut self) -> Result<Sums, TransportError> {
        let nr = self.u32()? as usize;
        let mut rows = Vec::with_capacity(nr.min(1 << 16));
        for _ in 0..nr {
            let b = self.u32()?;
            let k = self.u32()? as usize;
            let mut r = Vec::with_capacity(k.min(1 << 16));
            for _ in 0..k {
                r.push(self.i64()?);
            }
            rows.push((b, r));
        }
        let nc = self.u32()? as usize;
        let mut charts = Vec::with_capacity(nc.min(1 << 16));
        for _ in 0..nc {
            charts.push((self.u32()?, self.i64()?));
        }
        Ok(Sums { rows, charts, back: self.i64()? })
    }
    fn f64s(&mut self) -> Result<Vec<f64>, TransportError> {
        let n = self.u32()? as usize;
        let b = self.take(n.checked_mul(8).ok_or_else(|| TransportError::Input("DRT state: bad length".into()))?)?;
        Ok(b.chunks_exact(8).map(|c| f64::from_bits(u64::from_le_bytes(c.try_into().unwrap_or_default()))).collect())
    }
    fn item(&mut self) -> Result<ItemOut, TransportError> {
        let mut lists = [Vec::new(), Vec::new()];
        for list in &mut lists {
            let n = self.u32()? as usize;
            list.reserve(n.min(1 << 16));
            for _ in 0..n {
                let k = self.u32()? as usize;
                list.push((k, self.f64s()?));
            }
        }
        let back = self.i64()? as usize;
        let [blocks, charts] = lists;
        Ok((blocks, charts, back))
    }
    fn items(&mut self, h: &[(usize, usize)]) -> Result<Vec<(usize, Vec<ItemOut>)>, TransportError> {
        h.iter().map(|&(k, n)| Ok((k, (0..n).map(|_| self.item()).collect::<Result<Vec<_>, _>>()?))).collect()
    }
}

impl DrtState {
    /// The state file's bytes: magic, header JSON, the sums, a CRC-32C of all before it.
    pub fn to_bytes(&self) -> Vec<u8> {
        let h = Header {
            key: self.key.clone(),
            instances: self.instances.clone(),
            blocks: self.blocks.iter().map(|(b, s)| (*b, s.len())).collect(),
            clutter: self.clutter.iter().map(Vec::len).collect(),
            asset_crc32c: self.asset_crc32c,
            vector: self.vector.as_ref().map(|v| VectorHeader {
                scene: counts(&v.scene),
                clutter: counts(&v.clutter),
                probes: counts(&v.probes),
            }),
        };
        let hj = serde_json::to_vec(&h).unwrap_or_default();
        let mut out = Vec::with_capacity(1 << 20);
        out.extend(MAGIC);
        out.extend((hj.len() as u64).to_le_bytes());
        out.extend(&hj);
        for (_, s) in &self.blocks {
            for t in s {
                put_sums(&mut out, t);
            }
        }
        for inst in &self.clutter {
            for t in inst {
                match t {
                    Some(s) => {
                        out.push(1);
                        put_sums(&mut out, s);
                    }
                    None => out.push(0),
                }
            }
        }
        if let Some(v) = &self.vector {
            for (_, items) in v.scene.iter().chain(&v.clutter).chain(&v.probes) {
                for it in items {
                    put_item(&mut out, it);
                }
            }
        }
        let crc = penumbra_asset::crc32c(&out);
        out.extend(crc.to_le_bytes());
        out
    }

    /// Whether `b` starts like a DRT state file of any version (the magic without its version
    /// byte): a file that does not is not ours to overwrite.
    pub fn is_state_file(b: &[u8]) -> bool {
        b.len() >= 7 && b[..7] == MAGIC[..7]
    }

    /// Parses [`DrtState::to_bytes`]; `Err` names what is wrong.
    pub fn from_bytes(b: &[u8]) -> Result<Self, TransportError> {
        let bad = |m: &str| TransportError::Input(format!("DRT state: {m}"));
        if b.len() < MAGIC.len() + 8 + 4 || &b[..8] != MAGIC {
            return Err(bad("not a penumbra DRT state file (or another version)"));
        }
        let (body, crc) = b.split_at(b.len() - 4);
        if penumbra_asset::crc32c(body).to_le_bytes() != crc {
            return Err(bad("checksum mismatch (truncated or corrupt)"));
        }
        let mut r = Reader { b: body, at: 8 };
        let hl = r.i64()? as usize;
        let h: Header = serde_json::from_slice(r.take(hl)?).map_err(|e| bad(&format!("header: {e}")))?;
        let mut blocks = Vec::with_capacity(h.blocks.len());
        for &(x, n) in &h.blocks {
            let s = (0..n).map(|_| r.sums()).collect::<Result<Vec<_>, _>>()?;
            blocks.push((x, s));
        }
        let mut clutter = Vec::with_capacity(h.clutter.len());
        for &n in &h.clutter {
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                v.push(if r.take(1)?[0] == 1 { Some(r.sums()?) } else { None });
            }
            clutter.push(v);
        }
        let vector = match &h.vector {
            Some(vh) => Some(VectorItems {
                scene: r.items(&vh.scene)?,
                clutter: r.items(&vh.clutter)?,
                probes: r.items(&vh.probes)?,
            }),
            None => None,
        };
        if r.at != body.len() {
            return Err(bad("trailing bytes"));
        }
        Ok(Self { key: h.key, instances: h.instances, blocks, clutter, asset_crc32c: h.asset_crc32c, vector })
    }
}

/// Whether the ray `o + t·d`, `t ≥ 0`, meets any of `boxes` (padded world bounds).
/// Branch-free: the same interval test as the queries' slab test (so never stricter), and a
/// NaN (an origin on a box plane with a zero direction component) counts as a hit.
pub(crate) fn meets_any(boxes: &[[[f64; 3]; 2]], o: [f64; 3], d: [f64; 3]) -> bool {
    let inv = d.map(|x| 1.0 / x);
    boxes.iter().any(|[bl, bh]| {
        let (mut lo, mut hi, mut nan) = (0.0f64, f64::INFINITY, false);
        for k in 0..3 {
            let a = (bl[k] - o[k]) * inv[k];
            let b = (bh[k] - o[k]) * inv[k];
            nan |= a.is_nan() | b.is_nan();
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            lo = if a > lo { a } else { lo };
            hi = if b < hi { b } else { hi };
        }
        nan || lo <= hi
    })
}

/// The rays an incremental re-bake traces again: those that meet a moved instance's padded
/// box (old or new place) for `t ≥ 0`. A texel's rays are first tested against each box's
/// bounding sphere in the texel's own frame (three multiply-adds per ray, no division), then
/// the survivors against the boxes ([`meets_any`]).
#[derive(Debug, Clone)]
pub(crate) struct Cull {
    boxes: Vec<[[f64; 3]; 2]>,
    /// Centre and squared radius of each box's sphere, the radius enlarged by 10⁻⁶ of itself
    /// (and 10⁻⁹) so that rounding never makes the sphere test stricter than the box test.
    spheres: Vec<([f64; 3], f64)>,
    /// Every direction lies in its frame's upper half space (`z ≥ 0`): a sphere wholly
    /// below a texel's tangent plane is then out of reach of all its rays.
    upper: bool,
}

impl Cull {
    /// The culling of rays that may meet `boxes`; `upper` as the field says (the caller
    /// checks its direction sets).
    pub(crate) fn new(boxes: Vec<[[f64; 3]; 2]>, upper: bool) -> Self {
        let spheres = boxes
            .iter()
            .map(|[lo, hi]| {
                let c = core::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
                let r = (0..3).map(|k| (0.5 * (hi[k] - lo[k])).powi(2)).sum::<f64>().sqrt();
                let r = r * (1.0 + 1e-6) + 1e-9;
                (c, r * r)
            })
            .collect();
        Self { boxes, spheres, upper }
    }

    /// Per sphere, for the texel at `o` with frame `fr` and rotation `rot`: the centre's
    /// offset in the frame the shared directions are given in, its squared length and `r²`;
    /// with `upper`, only the spheres not wholly below the tangent plane (none left: the
    /// texel casts no ray).
    fn texel(&self, o: [f64; 3], fr: &[[f64; 3]; 3], (c, s): (f64, f64)) -> Vec<([f64; 3], f64, f64)> {
        // the distance test needs unit directions, which an orthonormal frame keeps; any
        // other frame keeps every ray (the box test alone decides)
        let ortho = (0..3).all(|i| {
            (0..3).all(|j| {
                let d = fr[i][0] * fr[j][0] + fr[i][1] * fr[j][1] + fr[i][2] * fr[j][2];
                (d - f64::from(u8::from(i == j))).abs() < 1e-9
            })
        });
        self.spheres
            .iter()
            .map(|&(ctr, r2)| {
                let v = [ctr[0] - o[0], ctr[1] - o[1], ctr[2] - o[2]];
                let w: [f64; 3] = core::array::from_fn(|k| fr[k][0] * v[0] + fr[k][1] * v[1] + fr[k][2] * v[2]);
                // d = frame(rotate_z(dl)), so d·v = dl·rotate_z⁻¹(w)
                let wl = [c * w[0] + s * w[1], -s * w[0] + c * w[1], w[2]];
                (wl, v[0] * v[0] + v[1] * v[1] + v[2] * v[2], if ortho { r2 } else { f64::INFINITY })
            })
            // a ray with local z ≥ 0 stays in z ≥ 0; the sphere reaches up to wl_z + r
            .filter(|&(wl, _, r2)| !self.upper || wl[2] + r2.sqrt() >= 0.0)
            .collect()
    }

    /// Whether the unit ray along `dl` (shared frame) comes within a sphere's radius for
    /// `t ≥ 0`.
    #[inline]
    fn near(local: &[([f64; 3], f64, f64)], dl: [f64; 3]) -> bool {
        local.iter().any(|&(w, vv, r2)| {
            let t = w[0] * dl[0] + w[1] * dl[1] + w[2] * dl[2];
            vv <= r2 || (t >= 0.0 && vv - t * t <= r2)
        })
    }
}

/// What an incremental re-bake did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct IncrementalStats {
    /// Instances whose placement changed.
    pub moved: Vec<usize>,
    /// Rays cast (old and new scene together).
    pub rays_cast: u64,
    /// Rays a full bake casts.
    pub rays_full: u64,
    /// Scene and clutter texels whose sums changed.
    pub texels_changed: usize,
    /// Receiving blocks traced in full (new to the neighbourhood).
    pub blocks_traced_in_full: usize,
    /// Records (receiving blocks and instances) assembled and factored again.
    pub records_assembled: usize,
    /// Records copied from the previous bake (their sums did not change).
    pub records_reused: usize,
}

/// Checks that `old` and `new` differ only in the placement of `moved` (same instances,
/// texels and charts per instance), as an incremental re-bake needs.
pub fn compatible(old: &ClutterScene, new: &ClutterScene) -> Result<(), String> {
    if old.len() != new.len() {
        return Err(format!("{} clutter instances before, {} now", old.len(), new.len()));
    }
    if old.charts.len() != new.charts.len() {
        return Err(format!("{} clutter charts before, {} now", old.charts.len(), new.charts.len()));
    }
    for i in 0..old.len() {
        if old.instance_texels[i] != new.instance_texels[i] {
            return Err(format!("clutter {i} ({}) has another texel count", new.specs[i].name));
        }
    }
    for (a, b) in old.charts.iter().zip(&new.charts) {
        if (a.instance, a.first, a.count) != (b.instance, b.first, b.count) {
            return Err(format!("clutter {} ({}) has other charts", b.instance, new.specs[b.instance].name));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clutter::ClutterHit;

    #[test]
    fn the_sphere_test_never_drops_a_ray_the_box_test_keeps() {
        use penumbra_math::rng::{hash4, unit_f64};
        let boxes = vec![[[0.2, 0.0, 0.3], [0.32, 0.75, 0.42]], [[0.55, 0.0, 0.1], [0.6, 0.2, 0.9]]];
        // cosine directions: all in the upper half space, so whole spheres below a texel's
        // tangent plane are dropped too
        let cull = Cull::new(boxes.clone(), true);
        let dirs = DirectionSet::cosine(256);
        let (mut kept, mut near_only, mut dropped) = (0, 0, 0);
        for k in 0..400u64 {
            let u = |j: u64| unit_f64(hash4(5, k, j, 0));
            // origins inside, beside and on the boxes' planes
            let o = if k % 7 == 0 { [0.2, u(1), 0.35] } else { [u(1), 0.8 * u(2), u(3)] };
            let a = [u(4) - 0.5, u(5) - 0.5, u(6) - 0.5];
            let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            let nz = a.map(|x| x / l);
            let (t, b) = penumbra_math::warp::orthonormal_basis(nz);
            let fr = [t, b, nz];
            let rot = rotation(9, k, 1);
            let local = cull.texel(o, &fr, rot);
            dropped += 2 - local.len();
            for dl in &dirs.dirs {
                let d = frame_dir(&rotated_frame(&fr, rot), *dl);
                let exact = meets_any(&boxes, o, d);
                let near = Cull::near(&local, *dl);
                assert!(near || !exact, "ray {k} {dl:?}: the box test keeps it, the sphere test drops it");
                kept += usize::from(exact);
                near_only += usize::from(near && !exact);
            }
        }
        // the test is not vacuous: both kinds occur, and whole spheres are dropped
        assert!(kept > 1000 && near_only > 1000 && dropped > 50, "{kept} {near_only} {dropped}");
    }

    #[test]
    fn an_uncharted_front_face_is_not_a_back_face() {
        let h =
            |chart: usize, front: bool| ClutterHit { t: 1.0, chart, front, point: [0.0; 3], normal: [0.0, -1.0, 0.0] };
        let up = [0.0, 1.0, 0.0];
        let down = [0.0, -1.0, 0.0];
        assert_eq!(side(&h(3, true), up), Side::Chart(3));
        // a ray going up meets a downward face from the front: with no chart it is uncharted
        assert_eq!(side(&h(usize::MAX, false), up), Side::Uncharted);
        // going down it meets the same face from behind
        assert_eq!(side(&h(usize::MAX, false), down), Side::Back);
        assert_eq!(side(&h(3, false), down), Side::Back);
    }
}
