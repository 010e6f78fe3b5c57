//! Level operators (MRT thesis §3.5.3, §4.3.2, §4.6): the sparse block operator `T_b→r`
//! of a level by breadth-first propagation through its interfaces, and the light-map atlas
//! with its padding records. Written as an `MRTL` asset (`schemas/asset-format.md`).
//!
//! For every source block `x` and every opening of `x` connected to a neighbour, the
//! traversal starts with `A = R_b→rlf(x, face)` (the reduced lightfield leaving `x`), enters
//! the neighbour, and at every block it enters through face `g` adds `A` to the record of
//! `(block, g, x)`; it then continues through each other connected opening with
//! `A ← R_turn · A` (straight on, left or right, from the world travel directions) until it
//! has crossed `max_depth` interfaces. A record's operator is `T_rlf→r · ΣA` (k_r × k_b),
//! summed over every path from `x` to that interface ("if a path from the same source block
//! has already been computed, the matrices are summed", §3.5.3).

use crate::TransportError;
use crate::level::{Level, Links};
use crate::lightfield::Turn;
use crate::shape::{FACE_COUNT, FACE_NAMES, Shape, Texels, face_axis, face_point, face_uv};
use crate::svd::mul;
use faer::{Mat, MatRef};
use penumbra_asset::{Asset, AssetBuilder, Kind};
use rayon::prelude::*;
use serde::Serialize;
use serde_json::json;
use std::collections::BTreeMap;

/// Kind version of the `MRTL` sections.
pub const MRTL_KIND_VERSION: u32 = 1;

/// Kind version of an `MRTL` with re-baked warps (optional sections: a version-1 reader
/// skips them and applies the dictionary's operators to every block).
pub const MRTL_KIND_VERSION_WARPS: u32 = 2;

/// Default depth limit (interfaces crossed).
pub const DEFAULT_MAX_DEPTH: usize = 8;

/// What a level bake needs from a dictionary (read back from its `MRTD` asset).
#[derive(Debug, Clone)]
pub struct DictOps {
    /// Shape names, dictionary order.
    pub names: Vec<String>,
    /// Missing-face masks.
    pub missing: Vec<u8>,
    /// `k_b` per shape.
    pub k_b: Vec<usize>,
    /// Texels per face edge.
    pub face_res: usize,
    /// `R_b→rlf` per `(shape, face)`.
    pub r_b2rlf: BTreeMap<(usize, usize), Mat<f64>>,
    /// `R_↑, R_←, R_→`.
    pub r_turn: [Mat<f64>; 3],
    /// `T_rlf→r`.
    pub t_rlf2r: Mat<f64>,
    /// CRC-32C of the dictionary file (ties a level to its dictionary).
    pub crc32c: u32,
    /// The albedo the dictionary was baked with (`params.albedo`).
    pub albedo: f64,
    /// Per shape: `(L_imp, T_d→b)` when the dictionary has `<shape>.l_imp` (kind version 3 and
    /// later): what a warp re-bake ([`crate::warp`]) starts from.
    pub shape_ops: Vec<Option<(Mat<f64>, Mat<f64>)>>,
    /// The dictionary's `meta.params`.
    pub params: serde_json::Value,
}

fn aerr(m: impl core::fmt::Display) -> TransportError {
    TransportError::Input(m.to_string())
}

fn werr(m: impl core::fmt::Display) -> TransportError {
    TransportError::Asset(m.to_string())
}

fn read_mat(a: &Asset<'_>, name: &str) -> Result<Mat<f64>, TransportError> {
    let s = a.section(name).ok_or_else(|| aerr(format!("section {name} is missing")))?;
    let d = s.dims().to_vec();
    if d.len() != 2 {
        return Err(aerr(format!("section {name}: rank {} (expected 2)", d.len())));
    }
    let v = s.as_f32().map_err(|e| aerr(format!("section {name}: {e}")))?;
    Ok(Mat::from_fn(d[0], d[1], |i, j| f64::from(v[i * d[1] + j])))
}

impl DictOps {
    /// Reads a dictionary asset (`MRTD` kind version 1 or 2); errors when it has no
    /// interfaces (version 1, or baked with `interfaces = false`).
    pub fn from_asset(a: &Asset<'_>) -> Result<Self, TransportError> {
        if a.kind() != Kind::MRTD {
            return Err(aerr(format!("not an MRT dictionary (kind {}, expected MRTD)", a.kind().as_str())));
        }
        let meta: serde_json::Value = serde_json::from_str(a.meta_json()).map_err(aerr)?;
        let kv = meta["kind_version"].as_u64().unwrap_or(0);
        if !(1..=4).contains(&kv) {
            return Err(aerr(format!("MRTD kind_version {kv} is not supported (this penumbra reads 1 to 4)")));
        }
        let face_res =
            meta["params"]["face_res"].as_u64().ok_or_else(|| aerr("meta.params.face_res missing"))? as usize;
        let mut names = Vec::new();
        let mut missing = Vec::new();
        let mut k_b = Vec::new();
        for s in meta["shapes"].as_array().ok_or_else(|| aerr("meta.shapes missing"))? {
            names.push(s["name"].as_str().ok_or_else(|| aerr("meta.shapes[].name missing"))?.to_string());
            let mut m = 0u8;
            for f in s["missing_faces"].as_array().into_iter().flatten() {
                let f =
                    f.as_str().and_then(crate::level::parse_face).ok_or_else(|| aerr("bad missing face in meta"))?;
                m |= 1 << f;
            }
            missing.push(m);
            k_b.push(s["k_b"].as_u64().unwrap_or(0) as usize);
        }
        let list = meta["interfaces"].as_array().cloned().unwrap_or_default();
        if list.is_empty() {
            return Err(aerr(if kv < 2 {
                "the dictionary has no interface operators (MRTD kind_version 1): re-bake it with this penumbra"
            } else {
                "the dictionary has no interface operators (baked without interfaces or without open shapes)"
            }));
        }
        let mut r_b2rlf = BTreeMap::new();
        for i in &list {
            let sn = i["shape"].as_str().unwrap_or("");
            let s =
                names.iter().position(|n| n == sn).ok_or_else(|| aerr(format!("interface of unknown shape {sn}")))?;
            let f = i["face"].as_str().and_then(crate::level::parse_face).ok_or_else(|| aerr("bad interface face"))?;
            let [rn, _] = crate::asset::interface_section_names(sn, f);
            r_b2rlf.insert((s, f), read_mat(a, &rn)?);
        }
        let r_turn = [read_mat(a, "iface.r_straight")?, read_mat(a, "iface.r_left")?, read_mat(a, "iface.r_right")?];
        let t_rlf2r = read_mat(a, "iface.t_rlf2r")?;
        let crc32c = penumbra_asset::crc32c(a.bytes());
        let albedo = meta["params"]["albedo"].as_f64().unwrap_or(1.0);
        let shape_ops = names
            .iter()
            .map(|n| {
                let l = format!("{n}.l_imp");
                if a.section(&l).is_none() {
                    return Ok(None);
                }
                Ok(Some((read_mat(a, &l)?, read_mat(a, &format!("{n}.t_d2b"))?)))
            })
            .collect::<Result<Vec<_>, TransportError>>()?;
        let params = meta["params"].clone();
        Ok(Self { names, missing, k_b, face_res, r_b2rlf, r_turn, t_rlf2r, crc32c, albedo, shape_ops, params })
    }

    /// Largest `k_b`.
    pub fn k_b_max(&self) -> usize {
        self.k_b.iter().copied().max().unwrap_or(0)
    }

    /// `k_r`.
    pub fn k_r(&self) -> usize {
        self.t_rlf2r.nrows()
    }
}

/// One stored block of `T_b→r`: light of source block `src` entering block `dst` through its
/// local face `face`, as response coefficients `r = op · b_src`.
#[derive(Debug, Clone)]
pub struct Record {
    /// Receiving block.
    pub dst: usize,
    /// Its local face the light enters through.
    pub face: usize,
    /// Source block.
    pub src: usize,
    /// `k_r × k_b(src)`.
    pub op: Mat<f64>,
}

/// A light-map tile: one present face of one block, `(R+2)²` pixels with a 1-pixel border.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tile {
    /// Block.
    pub block: usize,
    /// Local face.
    pub face: usize,
    /// Top-left pixel of the padded tile.
    pub x0: usize,
    /// Top-left pixel of the padded tile.
    pub y0: usize,
}

/// The padded light-map atlas (§3.5.2, §4.6).
#[derive(Debug, Clone)]
pub struct Atlas {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Tiles, in block order then face order.
    pub tiles: Vec<Tile>,
    /// Border pixel records: `(atlas pixel y·W + x, source block, source texel)`.
    pub pad: Vec<[u32; 3]>,
}

/// Level-bake measurements (`--json`).
#[derive(Debug, Clone, Serialize)]
pub struct LevelMetrics {
    /// Blocks.
    pub blocks: usize,
    /// Distinct (receiving block, source block) pairs with a stored operator.
    pub block_pairs: usize,
    /// Stored `k_r × k_b` records (per receiving interface and source block).
    pub records: usize,
    /// Propagation steps taken (paths × interfaces).
    pub path_segments: usize,
    /// Padding records.
    pub pad_records: usize,
    /// Depth limit used.
    pub max_depth: usize,
}

/// A baked level.
#[derive(Debug, Clone)]
pub struct LevelBake {
    /// Records sorted by `(dst, face, src)`.
    pub records: Vec<Record>,
    /// Atlas.
    pub atlas: Atlas,
    /// Measurements.
    pub metrics: LevelMetrics,
}

/// Builds `T_b→r` and the atlas of a validated level.
pub fn bake_level(level: &Level, links: &Links, d: &DictOps, max_depth: usize) -> Result<LevelBake, TransportError> {
    for (i, b) in level.blocks.iter().enumerate() {
        for f in 0..FACE_COUNT {
            if links[i][f].is_some() && !d.r_b2rlf.contains_key(&(b.shape, f)) {
                return Err(TransportError::Param(format!(
                    "block {i}: the dictionary has no interface for shape {} face {}",
                    d.names[b.shape], FACE_NAMES[f]
                )));
            }
        }
    }
    let per_source: Vec<(Vec<Record>, usize)> =
        (0..level.blocks.len()).into_par_iter().map(|x| propagate_from(level, links, d, x, max_depth)).collect();
    let mut records = Vec::new();
    let mut segments = 0;
    for (r, s) in per_source {
        records.extend(r);
        segments += s;
    }
    records.sort_by_key(|r| (r.dst, r.face, r.src));
    let mut pairs: Vec<(usize, usize)> = records.iter().map(|r| (r.dst, r.src)).collect();
    pairs.dedup();
    pairs.sort_unstable();
    pairs.dedup();
    let atlas = build_atlas(level, links, d);
    let metrics = LevelMetrics {
        blocks: level.blocks.len(),
        block_pairs: pairs.len(),
        records: records.len(),
        path_segments: segments,
        pad_records: atlas.pad.len(),
        max_depth,
    };
    Ok(LevelBake { records, atlas, metrics })
}

/// Breadth-first propagation of source block `x`'s light (records of `x`, path segments).
fn propagate_from(level: &Level, links: &Links, d: &DictOps, x: usize, max_depth: usize) -> (Vec<Record>, usize) {
    let mut acc: BTreeMap<(usize, usize), Mat<f64>> = BTreeMap::new();
    let mut queue: std::collections::VecDeque<(usize, usize, Mat<f64>, usize)> = Default::default();
    let sx = level.blocks[x].shape;
    if max_depth > 0 {
        for f in 0..FACE_COUNT {
            if let Some((y, g)) = links[x][f] {
                queue.push_back((y, g, d.r_b2rlf[&(sx, f)].clone(), 1));
            }
        }
    }
    let mut segments = 0;
    while let Some((y, g, a, depth)) = queue.pop_front() {
        segments += 1;
        match acc.get_mut(&(y, g)) {
            Some(m) => *m += &a,
            None => {
                acc.insert((y, g), a.clone());
            }
        }
        if depth >= max_depth {
            continue;
        }
        let by = &level.blocks[y];
        let t_in = by.normal(g);
        for h in 0..FACE_COUNT {
            if h == g || face_axis(h).0 == 1 {
                continue;
            }
            let Some((z, hz)) = links[y][h] else { continue };
            let n = by.normal(h);
            let t_out = [-n[0], -n[1], -n[2]];
            let Some(turn) = Turn::between(t_in, t_out) else { continue };
            let r = &d.r_turn[turn as usize];
            queue.push_back((z, hz, mul(r.as_ref(), a.as_ref()), depth + 1));
        }
    }
    let records = acc
        .into_iter()
        .map(|((dst, face), a)| Record { dst, face, src: x, op: mul(d.t_rlf2r.as_ref(), a.as_ref()) })
        .collect();
    (records, segments)
}

/// Tiles in rows of `⌈√T⌉`, each `(R+2)²`; border pixels copy the texel that continues the
/// face across each edge: the adjacent wall of the same block at a crease (folded), the same
/// face of the connected neighbour across an opening, the face's own edge texel at an
/// unconnected opening; corners copy the face's own corner texel.
pub fn build_atlas(level: &Level, links: &Links, d: &DictOps) -> Atlas {
    let r = d.face_res;
    let p = r + 2;
    let mut tiles = Vec::new();
    for (b, blk) in level.blocks.iter().enumerate() {
        for f in 0..FACE_COUNT {
            if d.missing[blk.shape] & (1 << f) == 0 {
                tiles.push(Tile { block: b, face: f, x0: 0, y0: 0 });
            }
        }
    }
    let cols = (tiles.len() as f64).sqrt().ceil().max(1.0) as usize;
    let rows = tiles.len().div_ceil(cols).max(1);
    for (i, t) in tiles.iter_mut().enumerate() {
        t.x0 = (i % cols) * p;
        t.y0 = (i / cols) * p;
    }
    let width = cols * p;
    let texels: Vec<Texels> = d.missing.iter().map(|&m| Texels::new(Shape::new("level", m), r)).collect();
    let mut pad = Vec::new();
    let ri = r as i64;
    for t in &tiles {
        let blk = &level.blocks[t.block];
        let tex = &texels[blk.shape];
        for j in -1..=ri {
            for i in -1..=ri {
                let inside_i = (0..ri).contains(&i);
                let inside_j = (0..ri).contains(&j);
                if inside_i && inside_j {
                    continue;
                }
                let dst = ((t.y0 as i64 + j + 1) as usize) * width + (t.x0 as i64 + i + 1) as usize;
                let own = |i: i64, j: i64| tex.index(t.face, i.clamp(0, ri - 1) as usize, j.clamp(0, ri - 1) as usize);
                let (sb, st) = if !inside_i && !inside_j {
                    (t.block, own(i, j))
                } else {
                    edge_source(level, links, &texels, t.block, t.face, i, j, r).unwrap_or((t.block, own(i, j)))
                };
                pad.push([dst as u32, sb as u32, st as u32]);
            }
        }
    }
    Atlas { width, height: rows * p, tiles, pad }
}

/// The texel that continues face `f` of block `b` beyond its edge at border pixel `(i, j)`.
#[allow(clippy::too_many_arguments)]
fn edge_source(
    level: &Level,
    links: &Links,
    texels: &[Texels],
    b: usize,
    f: usize,
    i: i64,
    j: i64,
    r: usize,
) -> Option<(usize, usize)> {
    let rf = r as f64;
    let p = face_point(f, (i as f64 + 0.5) / rf, (j as f64 + 0.5) / rf);
    // the cube side the point has left through
    let a = (0..3).find(|&a| p[a] < 0.0 || p[a] > 1.0)?;
    let e = 2 * a + usize::from(p[a] > 1.0);
    let blk = &level.blocks[b];
    let tex = &texels[blk.shape];
    let texel_at = |tex: &Texels, g: usize, q: [f64; 3]| {
        let (u, v) = face_uv(g, q);
        let c = |x: f64| ((x * rf).floor() as i64).clamp(0, r as i64 - 1) as usize;
        tex.index(g, c(u), c(v))
    };
    if tex.shape.has(e) {
        // crease: fold onto face e, half a texel in from the edge
        let mut q = p;
        q[a] = q[a].clamp(0.0, 1.0);
        let n = crate::shape::FACE_FRAMES[f].n;
        for k in 0..3 {
            q[k] += 0.5 / rf * n[k];
        }
        return Some((b, texel_at(tex, e, q)));
    }
    let (y, _) = links[b][e]?;
    let by = &level.blocks[y];
    let fy = by.local_face(blk.world_face(f));
    let ty = &texels[by.shape];
    if !ty.shape.has(fy) {
        return None;
    }
    let q = by.to_local(blk.to_world(p));
    Some((y, texel_at(ty, fy, q)))
}

fn f32s(v: impl IntoIterator<Item = f64>) -> Vec<f32> {
    v.into_iter().map(|x| x as f32).collect()
}

/// Section names of an `MRTL` asset.
pub const MRTL_SECTIONS: &[&str] =
    &["meta", "blocks", "block_xform", "links", "records", "t_b2r", "atlas_size", "atlas_tiles", "atlas_pad"];

/// Builds the `MRTL` asset. `level_json` describes the level (blocks and connections as in
/// the level file), stored in `meta`.
pub fn to_asset(
    level: &Level,
    links: &Links,
    d: &DictOps,
    b: &LevelBake,
    level_json: serde_json::Value,
    cache_key: Option<&str>,
) -> Result<AssetBuilder, TransportError> {
    to_asset_with_warps(level, links, d, b, level_json, cache_key, None)
}

/// [`to_asset`] with re-baked warps ([`crate::warp::LevelWarps`]): with at least one warp the
/// asset is kind version [`MRTL_KIND_VERSION_WARPS`] with the optional sections `warp_shapes`,
/// `block_warp` and `warp.<i>.u_b`, `warp.<i>.t_d2b`, `warp.<i>.to_dict_b`, and `meta.warps`;
/// without one (`None`, or no block beyond the threshold) the bytes of [`to_asset`].
pub fn to_asset_with_warps(
    level: &Level,
    links: &Links,
    d: &DictOps,
    b: &LevelBake,
    level_json: serde_json::Value,
    cache_key: Option<&str>,
    warps: Option<&crate::warp::LevelWarps>,
) -> Result<AssetBuilder, TransportError> {
    let warps = warps.filter(|w| !w.entries.is_empty());
    let kb = d.k_b_max();
    let kr = d.k_r();
    let mut meta = json!({
        "kind": "MRTL",
        "kind_version": if warps.is_some() { MRTL_KIND_VERSION_WARPS } else { MRTL_KIND_VERSION },
        "tool": concat!("penumbra ", env!("CARGO_PKG_VERSION")),
        "convention": {
            "transform": "block-local p in [0,1]^3 -> translation + R_q(scale * (p - 1/2)); R_q: q quarter turns about +Y, (x,y,z) -> (z,y,-x) per turn",
            "runtime": "b_x = t_d2b(shape_x) . l_d(x); for every record (dst, face, src): r = t_b2r[record] . b_src (first k_b(src) columns); indirect at texel t of dst += u_r[u_r_idx(shape_dst, face)[t]] . r (MRT thesis 3.6.3 steps 2-5)",
            "atlas": "tile (R+2)^2 per present face of each block (block order, face order), texel (i,j) of the face at pixel (x0+1+i, y0+1+j); atlas_pad: border pixel <- texel (block, texel index in its shape's layout)",
        },
        "params": { "max_depth": b.metrics.max_depth },
        "dictionary": {
            "crc32c": format!("{:08x}", d.crc32c),
            "shapes": d.names,
            "face_res": d.face_res,
            "k_b": kb,
            "k_r": kr,
        },
        "level": level_json,
        "cache_key": cache_key,
        "metrics": b.metrics,
    });
    if let Some(w) = warps {
        meta["warps"] = w.meta();
    }
    let mut a = AssetBuilder::new(Kind::MRTL);
    a.add_json("meta", &serde_json::to_string(&meta).map_err(werr)?).map_err(werr)?;
    let nb = level.blocks.len();
    let blocks: Vec<u32> = level.blocks.iter().flat_map(|x| [x.shape as u32, x.rotation]).collect();
    a.add_u32("blocks", &[nb, 2], &blocks).map_err(werr)?;
    let xf = f32s(level.blocks.iter().flat_map(|x| x.translation.into_iter().chain(x.scale)));
    a.add_f32("block_xform", &[nb, 6], &xf).map_err(werr)?;
    let li: Vec<i32> =
        links.iter().flat_map(|l| l.iter().flat_map(|x| x.map_or([-1, -1], |(b, f)| [b as i32, f as i32]))).collect();
    a.add_i32("links", &[nb, FACE_COUNT, 2], &li).map_err(werr)?;
    let np = b.records.len();
    let rec: Vec<u32> = b.records.iter().flat_map(|r| [r.dst as u32, r.face as u32, r.src as u32]).collect();
    a.add_u32("records", &[np, 3], &rec).map_err(werr)?;
    let mut ops = Vec::with_capacity(np * kr * kb);
    for r in &b.records {
        let m: MatRef<'_, f64> = r.op.as_ref();
        for i in 0..kr {
            for j in 0..kb {
                ops.push(if j < m.ncols() { m[(i, j)] as f32 } else { 0.0 });
            }
        }
    }
    a.add_f32("t_b2r", &[np, kr, kb], &ops).map_err(werr)?;
    a.add_u32("atlas_size", &[2], &[b.atlas.width as u32, b.atlas.height as u32]).map_err(werr)?;
    let tiles: Vec<u32> =
        b.atlas.tiles.iter().flat_map(|t| [t.block as u32, t.face as u32, t.x0 as u32, t.y0 as u32]).collect();
    a.add_u32("atlas_tiles", &[b.atlas.tiles.len(), 4], &tiles).map_err(werr)?;
    let pad: Vec<u32> = b.atlas.pad.iter().flatten().copied().collect();
    a.add_u32("atlas_pad", &[b.atlas.pad.len(), 3], &pad).map_err(werr)?;
    if let Some(w) = warps {
        let ws: Vec<u32> = w.entries.iter().map(|e| e.shape as u32).collect();
        a.add_u32("warp_shapes", &[ws.len()], &ws).map_err(werr)?;
        let bw: Vec<u32> = w.block_warp.iter().map(|x| x.map_or(u32::MAX, |i| i as u32)).collect();
        a.add_u32("block_warp", &[bw.len()], &bw).map_err(werr)?;
        let m = |m: &Mat<f64>| f32s((0..m.nrows()).flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)])));
        for (i, e) in w.entries.iter().enumerate() {
            let r = &e.ops.reduced;
            a.add_f32(&format!("warp.{i}.u_b"), &[r.u_b.nrows(), r.u_b.ncols()], &m(&r.u_b)).map_err(werr)?;
            a.add_f32(&format!("warp.{i}.t_d2b"), &[r.t_d2b.nrows(), r.t_d2b.ncols()], &m(&r.t_d2b)).map_err(werr)?;
            let x = &e.ops.to_dict_b;
            a.add_f32(&format!("warp.{i}.to_dict_b"), &[x.nrows(), x.ncols()], &m(x)).map_err(werr)?;
        }
    }
    Ok(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::level::{Block, Connection, corridor, l_turn};
    use crate::shape::CUBE2D;

    /// A synthetic dictionary: random operators of small sizes (the propagation logic does
    /// not depend on their values).
    fn dict(kb: usize, krlf: usize, kr: usize, res: usize) -> DictOps {
        let rnd = |r: usize, c: usize, s: u64| {
            Mat::from_fn(r, c, |i, j| {
                penumbra_math::rng::unit_f64(penumbra_math::rng::hash4(s, 1, i as u64, j as u64)) - 0.5
            })
        };
        let mut r_b2rlf = BTreeMap::new();
        for (s, sh) in CUBE2D.iter().enumerate() {
            for f in crate::interface::side_openings(sh) {
                r_b2rlf.insert((s, f), rnd(krlf, kb, (s * 8 + f) as u64));
            }
        }
        DictOps {
            names: CUBE2D.iter().map(|s| s.name.to_string()).collect(),
            missing: CUBE2D.iter().map(|s| s.missing).collect(),
            k_b: vec![kb; 6],
            face_res: res,
            r_b2rlf,
            r_turn: [rnd(krlf, krlf, 100), rnd(krlf, krlf, 101), rnd(krlf, krlf, 102)],
            t_rlf2r: rnd(kr, krlf, 103),
            crc32c: 0,
            albedo: 1.0,
            shape_ops: vec![None; 6],
            params: serde_json::Value::Null,
        }
    }

    /// The reduced lightfield `A` with `op = T·A` (T has full column rank here: kr ≥ krlf).
    fn pinv_apply(d: &DictOps, op: &Mat<f64>) -> Mat<f64> {
        use faer::linalg::solvers::Solve;
        let t = d.t_rlf2r.as_ref();
        let tt = crate::svd::mul_tn(t, t);
        let rhs = crate::svd::mul_tn(t, op.as_ref());
        tt.as_ref().partial_piv_lu().solve(rhs.as_ref())
    }

    fn close(a: &Mat<f64>, b: &Mat<f64>) -> bool {
        (a - b).norm_l2() <= 1e-12 * (1.0 + b.norm_l2())
    }

    #[test]
    fn corridor_chains_straight_operators_up_to_the_depth_limit() {
        let d = dict(3, 5, 2, 2);
        let l = corridor(4, &d.missing).unwrap();
        let links = l.validate(&d.names, &d.missing).unwrap();
        let b = bake_level(&l, &links, &d, 2).unwrap();
        // from block 0 (dead end, opening +z): block 1 then block 2, never block 3 (depth 2)
        let from0: Vec<&Record> = b.records.iter().filter(|r| r.src == 0).collect();
        assert_eq!(from0.iter().map(|r| r.dst).collect::<Vec<_>>(), vec![1, 2]);
        let start = &d.r_b2rlf[&(1, 5)];
        assert!(close(&from0[0].op, &mul(d.t_rlf2r.as_ref(), start.as_ref())));
        let two = mul(d.t_rlf2r.as_ref(), mul(d.r_turn[0].as_ref(), start.as_ref()).as_ref());
        assert!(close(&from0[1].op, &two));
        // depth 0: no inter-block light at all
        assert!(bake_level(&l, &links, &d, 0).unwrap().records.is_empty());
        // depth 3 reaches the far end
        let b3 = bake_level(&l, &links, &d, 3).unwrap();
        assert!(b3.records.iter().any(|r| r.src == 0 && r.dst == 3));
        assert_eq!(b3.metrics.blocks, 4);
        assert_eq!(b3.metrics.block_pairs, 12);
    }

    #[test]
    fn l_turn_uses_the_turn_operator_by_travel_direction() {
        let d = dict(3, 4, 2, 2);
        // along +z then +x: travelling +z and leaving +x is a left turn (+90° about +Y)
        let l = l_turn(1, 1, &d.missing).unwrap();
        let links = l.validate(&d.names, &d.missing).unwrap();
        let b = bake_level(&l, &links, &d, 2).unwrap();
        let r = b.records.iter().find(|r| r.src == 0 && r.dst == 2).unwrap();
        let start = &d.r_b2rlf[&(1, 5)];
        let want = mul(d.t_rlf2r.as_ref(), mul(d.r_turn[Turn::Left as usize].as_ref(), start.as_ref()).as_ref());
        assert!(close(&r.op, &want));
        // and back the other way it is a right turn
        let r = b.records.iter().find(|r| r.src == 2 && r.dst == 0).unwrap();
        let sh2 = l.blocks[2].shape;
        let f2 = (0..6).find(|&f| links[2][f].is_some()).unwrap();
        let start = &d.r_b2rlf[&(sh2, f2)];
        let want = mul(d.t_rlf2r.as_ref(), mul(d.r_turn[Turn::Right as usize].as_ref(), start.as_ref()).as_ref());
        assert!(close(&r.op, &want));
    }

    #[test]
    fn paths_around_a_loop_are_summed() {
        // a 2×2 ring of corners: block 0's light comes back to it from both sides
        let d = dict(2, 3, 3, 2);
        let s = d.names.iter().position(|n| n == "corner").unwrap();
        let centres = [[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [1.5, 0.5, 1.5], [0.5, 0.5, 1.5]];
        // world openings: 0: +x,+z  1: −x,+z  2: −x,−z  3: +x,−z; corner opens local +x,+z
        let rot = [0u32, 3, 2, 1];
        let blocks: Vec<Block> =
            (0..4).map(|i| Block { shape: s, rotation: rot[i], translation: centres[i], scale: [1.0; 3] }).collect();
        let conn = |a: usize, wa: usize, b: usize, wb: usize| Connection {
            a,
            fa: blocks[a].local_face(wa),
            b,
            fb: blocks[b].local_face(wb),
        };
        let connections = vec![conn(0, 1, 1, 0), conn(1, 5, 2, 4), conn(2, 0, 3, 1), conn(3, 4, 0, 5)];
        let l = Level { blocks: blocks.clone(), connections };
        let links = l.validate(&d.names, &d.missing).unwrap();
        let b = bake_level(&l, &links, &d, 4).unwrap();
        // two paths of 4 interfaces bring block 0's light back into block 0, through its two
        // openings; each is one record with a single path (the ring's corners all turn)
        let back: Vec<&Record> = b.records.iter().filter(|r| r.src == 0 && r.dst == 0).collect();
        assert_eq!(back.len(), 2);
        // block 2 (opposite corner) is reached by two paths of 2 interfaces, one per face
        let opp: Vec<&Record> = b.records.iter().filter(|r| r.src == 0 && r.dst == 2).collect();
        assert_eq!(opp.len(), 2);
        // with depth 6 a record gets a second path (the 6-interface one): the sum differs
        let b6 = bake_level(&l, &links, &d, 6).unwrap();
        let r4 = b.records.iter().find(|r| r.src == 0 && r.dst == 2).unwrap();
        let r6 = b6.records.iter().find(|r| r.src == 0 && r.dst == 2 && r.face == r4.face).unwrap();
        assert!(!close(&r4.op, &r6.op));
        // the added path entered block 2 through the same face after going once more around
        // the ring: 4 more turns of the same kind, so diff = T·R⁴·R⁽²⁾·R_b→rlf with R⁽²⁾ the
        // 2-interface path's turn; verify via the 2-interface record's accumulated lightfield
        let turn = d.r_turn.iter().find(|t| {
            let mut m = mul(t.as_ref(), t.as_ref());
            m = mul(m.as_ref(), m.as_ref());
            let want = &r4.op + &mul(mul(d.t_rlf2r.as_ref(), m.as_ref()).as_ref(), pinv_apply(&d, &r4.op).as_ref());
            close(&want, &r6.op)
        });
        assert!(turn.is_some(), "the 6-interface path is the 2-interface one plus 4 equal turns");
    }

    #[test]
    fn padding_copies_the_texel_that_continues_the_surface() {
        let d = dict(2, 2, 2, 4);
        let l = l_turn(2, 2, &d.missing).unwrap();
        let links = l.validate(&d.names, &d.missing).unwrap();
        let a = build_atlas(&l, &links, &d);
        let r = d.face_res;
        let texels: Vec<Texels> = d.missing.iter().map(|&m| Texels::new(Shape::new("t", m), r)).collect();
        let mut tile_of = BTreeMap::new();
        for t in &a.tiles {
            tile_of.insert((t.x0, t.y0), *t);
        }
        let mut across = 0;
        for &[dst, sb, st] in &a.pad {
            let (x, y) = (dst as usize % a.width, dst as usize / a.width);
            let p = r + 2;
            let t = tile_of[&(x / p * p, y / p * p)];
            let (i, j) = ((x % p) as i64 - 1, (y % p) as i64 - 1);
            let corner = !(0..r as i64).contains(&i) && !(0..r as i64).contains(&j);
            if corner {
                continue;
            }
            let blk = &l.blocks[t.block];
            let want = blk.to_world(face_point(t.face, (i as f64 + 0.5) / r as f64, (j as f64 + 0.5) / r as f64));
            let sbk = &l.blocks[sb as usize];
            let got = sbk.to_world(texels[sbk.shape].position(st as usize));
            let dist = (0..3).map(|k| (want[k] - got[k]).powi(2)).sum::<f64>().sqrt();
            // same plane across an opening: the same point; a crease: folded, ≤ a texel away;
            // an edge texel at an unconnected opening would be a texel away too
            assert!(dist <= 1.0 / r as f64 + 1e-12, "tile {t:?} ({i},{j}): {dist}");
            if sb as usize != t.block {
                across += 1;
                assert!(dist < 1e-12, "across an opening the surface continues exactly: {dist}");
            }
        }
        assert!(across > 0);
    }
}
