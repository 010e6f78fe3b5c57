//! Writes a [`DrtBake`] as a `DRTO` asset (sections in `schemas/asset-format.md`, "DRTO").
//!
//! Operators of varying shape are stored flat with record tables that give each one's offset
//! and dimensions (all u32), so a C reader needs no JSON.

use crate::TransportError;
use crate::clutter::ClutterScene;
use crate::drt::{
    DRTO_KIND_VERSION, DeltaRecord, DrtBake, DrtMetrics, DrtParams, DrtShard, GatherOp, KcMode, Receiver, ReflectRecord,
};
use crate::drt_vector::{BlockProbes, Cols, DrtVectorBake, VecRecord, VectorMetrics, VectorParams};
use penumbra_asset::{Asset, AssetBuilder, DType, Kind};
use serde_json::{Value, json};

/// Every section of a kind-version-1 `DRTO`, in file order (for `require_known`).
pub const DRTO_SECTIONS: &[&str] = &[
    "meta",
    "receivers",
    "inpaint_mask",
    "du_b.records",
    "du_b",
    "du_c.records",
    "du_c.charts",
    "du_c.a",
    "du_c.w",
    "clutter.instances",
    "clutter.charts",
    "clutter.albedo",
    "clutter.positions",
    "clutter.normals",
    "clutter.uv",
    "clutter.t_d2c",
    "c_b.records",
    "c_b.srcs",
    "c_b.a",
    "c_b.w",
    "c_c.records",
    "c_c.charts",
    "c_c.a",
    "c_c.w",
];

/// The optional sections of the vector and volume response (kind version 2, §5.4.3).
pub const DRTO_VECTOR_SECTIONS: &[&str] = &[
    "vec.scene.records",
    "vec.scene.charts",
    "vec.scene.values",
    "vec.clutter.records",
    "vec.clutter.charts",
    "vec.clutter.values",
    "dyn.records",
    "dyn.charts",
    "dyn.values",
    "dyn.probes",
    "dyn.inside",
];

/// Kind version of a `DRTO` with the vector and volume sections (without them: 1).
pub const DRTO_VECTOR_KIND_VERSION: u32 = 2;

/// The clutter sections, which every shard writes whole (copied by [`merge`]).
const CLUTTER_SECTIONS: &[&str] = &[
    "clutter.instances",
    "clutter.charts",
    "clutter.albedo",
    "clutter.positions",
    "clutter.normals",
    "clutter.uv",
    "clutter.t_d2c",
];

fn err(e: impl core::fmt::Display) -> TransportError {
    TransportError::Asset(e.to_string())
}

fn f32s<'a>(v: impl IntoIterator<Item = &'a f64>) -> Vec<f32> {
    v.into_iter().map(|&x| x as f32).collect()
}

fn u32_of(x: usize) -> Result<u32, TransportError> {
    u32::try_from(x).map_err(|_| TransportError::Asset(format!("{x} does not fit in u32")))
}

/// What the asset records about its inputs (meta `inputs`).
#[derive(Debug, Clone)]
pub struct DrtInputs {
    /// CRC-32C of the dictionary file.
    pub dict_crc32c: u32,
    /// CRC-32C of the level asset, when the level came from one.
    pub level_crc32c: Option<u32>,
    /// The level in level-file form (JSON).
    pub level: serde_json::Value,
    /// BLAKE3 of each clutter instance's normalised description (JSON).
    pub clutter_hashes: Vec<String>,
    /// The clutter instances (normalised description, JSON).
    pub clutter: serde_json::Value,
}

/// Builds the asset.
pub fn to_asset(
    b: &DrtBake,
    clutter: &ClutterScene,
    inputs: &DrtInputs,
    cache_key: Option<&str>,
    vector: Option<&DrtVectorBake>,
) -> Result<AssetBuilder, TransportError> {
    let mut a = AssetBuilder::new(Kind::DRTO);
    let mut meta = json!({
        "kind": "DRTO",
        "kind_version": if vector.is_some() { DRTO_VECTOR_KIND_VERSION } else { DRTO_KIND_VERSION },
        "tool": concat!("penumbra ", env!("CARGO_PKG_VERSION")),
        "convention": {
            "scene": "scene texels are the level's block texels in MRTL block order, each block in its MRTD shape's texel layout; l_d and the output are irradiance",
            "runtime": "scene indirect = s (MRT + sum over du_b records (dst, src) of du_b . b_src) + du_c.a (du_c.w c[charts]); c_j = albedo_j[channel] * sum_{t in chart j} t_d2c[t] * l_dc[t]; clutter indirect l_c = s c_b.a (c_b.w b_stack) + c_c.a (c_c.w c[charts]) per instance, b_stack = the b of c_b.srcs stacked; s = walls' albedo / the dictionary's params.albedo (du_b and c_b carry the baked albedo like U_b; du_c and c_c carry none: c has the clutter's)",
            "clutter_frame": "world (the level's frame), outward normals; clutter.uv = (chart, layer, i, j): box faces are res x res charts (i along u, j along v), meshes box-projected charts (docs/drt.md)",
            "inpaint_mask": "per receiving-block texel: 0 outside clutter, 1 inside and inpainted, 2 inside and not inpainted",
        },
        "params": b.params.to_json(),
        "inputs": {
            "dictionary_crc32c": format!("{:08x}", inputs.dict_crc32c),
            "level_crc32c": inputs.level_crc32c.map(|c| format!("{c:08x}")),
            "level": inputs.level,
            "clutter_blake3": inputs.clutter_hashes,
            "clutter": inputs.clutter,
        },
        "cache_key": cache_key,
        "metrics": b.metrics,
    });
    if let Some(v) = vector {
        meta["vector"] = json!({
            "metrics": v.metrics,
            "convention": {
                "vec.scene": "per receiving block texel 4 OHLSH coefficients (MRT thesis App. B) in the texel frame of the MRTD's u_bvec (x = face u, y = face v, z = inward normal): rows = texels x 4, texel-major; delta U_b (columns: b of src, times s) and delta U_c (columns: c of the listed charts)",
                "vec.clutter": "per clutter texel [a0, w_x, w_y, w_z]: E(m) = pi y00 a0 + (2 pi / 3) sqrt(3 / 4 pi) (w . m) for a world unit normal m; C_b (columns: b of src, times s) and C_c (columns: c)",
                "dyn": "U_dyn: per probe of each receiving block (g^3 probes, x fastest, in receivers order; dyn.probes world positions) 9 world-frame SH radiance coefficients: rows = probes x 9; columns b of src (times s) and c of the listed charts",
            },
        });
    }
    a.add_json("meta", &serde_json::to_string(&meta).map_err(err)?).map_err(err)?;
    body(&mut a, b, &mut |a| clutter_sections(a, clutter, b.params.half))?;
    if let Some(v) = vector {
        vector_sections(&mut a, v, b.params.half)?;
    }
    Ok(a)
}

/// The vector and volume sections of a bake (`DRTO_VECTOR_SECTIONS`).
fn vector_sections(a: &mut AssetBuilder, v: &DrtVectorBake, half: bool) -> Result<(), TransportError> {
    write_vec_group(a, "vec.scene", &v.scene, half)?;
    write_vec_group(a, "vec.clutter", &v.clutter, half)?;
    write_vec_group(a, "dyn", &v.dyn_probes, half)?;
    let pts: Vec<f32> = v.probes.iter().flat_map(|p| p.points.iter().flatten()).map(|&x| x as f32).collect();
    // 0 outside clutter, 1 inside and filled from its neighbours, 2 inside and not filled
    let inside: Vec<u8> = v
        .probes
        .iter()
        .flat_map(|p| {
            p.inside.iter().zip(&p.filled).map(|(&i, &f)| {
                if !i {
                    0
                } else if f {
                    1
                } else {
                    2
                }
            })
        })
        .collect();
    a.add_f32("dyn.probes", &[inside.len(), 3], &pts).map_err(err)?;
    a.add_u8("dyn.inside", &[inside.len()], &inside).map_err(err)?;
    Ok(())
}

/// A list of unreduced operators: `<p>.records` u32 [R, 6] = (dst, src or 0xFFFFFFFF for
/// chart columns, rows, cols, values offset, charts offset), `<p>.charts` u32 (the chart
/// columns of the chart records, in record order), `<p>.values` (rows × cols each, row-major).
fn write_vec_group(a: &mut AssetBuilder, p: &str, recs: &[VecRecord], half: bool) -> Result<(), TransportError> {
    let mut rec = Vec::new();
    let mut charts = Vec::new();
    let mut vals = Vec::new();
    for r in recs {
        let (src, off) = match &r.cols {
            Cols::Block(y) => (u32_of(*y)?, 0),
            Cols::Charts(c) => {
                let off = u32_of(charts.len())?;
                for &j in c {
                    charts.push(u32_of(j)?);
                }
                (u32::MAX, off)
            }
        };
        rec.extend([u32_of(r.dst)?, src, u32_of(r.rows)?, u32_of(r.ncols())?, u32_of(vals.len())?, off]);
        vals.extend(f32s(&r.op));
    }
    a.add_u32(&format!("{p}.records"), &[recs.len(), 6], &rec).map_err(err)?;
    a.add_u32(&format!("{p}.charts"), &[charts.len()], &charts).map_err(err)?;
    add_floats(a, &format!("{p}.values"), &vals, half)?;
    Ok(())
}

/// Everything after `meta`; `clutter` writes the clutter sections in their place.
fn body(
    a: &mut AssetBuilder,
    b: &DrtBake,
    clutter: &mut dyn FnMut(&mut AssetBuilder) -> Result<(), TransportError>,
) -> Result<(), TransportError> {
    let mut recv = Vec::new();
    let mut mask = Vec::new();
    for r in &b.receivers {
        recv.extend([u32_of(r.block)?, u32_of(mask.len())?, u32_of(r.texels)?]);
        mask.extend_from_slice(&r.mask);
    }
    a.add_u32("receivers", &[b.receivers.len(), 3], &recv).map_err(err)?;
    a.add_u8("inpaint_mask", &[mask.len()], &mask).map_err(err)?;

    let mut rec = Vec::new();
    let mut vals = Vec::new();
    for r in &b.du_b {
        rec.extend([u32_of(r.dst)?, u32_of(r.src)?, u32_of(vals.len())?, u32_of(r.rows)?, u32_of(r.cols)?]);
        vals.extend(f32s(&r.op));
    }
    a.add_u32("du_b.records", &[b.du_b.len(), 5], &rec).map_err(err)?;
    add_floats(a, "du_b", &vals, b.params.half)?;

    write_reflect(a, "du_c", &b.du_c.iter().collect::<Vec<_>>(), b.params.half)?;
    clutter(a)?;
    write_gathers(a, b)?;
    if b.shard.count > 1 {
        // a shard is not a usable operator set: readers that do not know shards must refuse it
        let sh = json!({
            "index": b.shard.index,
            "count": b.shard.count,
            "c_b_src_offsets": b.c_b.iter().map(|g| g.src_offsets.clone()).collect::<Vec<_>>(),
        });
        a.add_json("shard", &sh.to_string()).map_err(err)?;
        a.set_critical("shard", true).map_err(err)?;
    }
    Ok(())
}

/// The clutter sections of a scene.
fn clutter_sections(a: &mut AssetBuilder, clutter: &ClutterScene, half: bool) -> Result<(), TransportError> {
    let ni = clutter.len();
    let mut inst = Vec::new();
    for (i, &[first, count]) in clutter.instance_texels.iter().enumerate() {
        let c0 = clutter.charts.iter().position(|c| c.instance == i).unwrap_or(0);
        let nc = clutter.charts.iter().filter(|c| c.instance == i).count();
        inst.extend([u32_of(first)?, u32_of(count)?, u32_of(c0)?, u32_of(nc)?]);
    }
    a.add_u32("clutter.instances", &[ni, 4], &inst).map_err(err)?;
    let mut ch = Vec::new();
    let mut alb = Vec::new();
    for c in &clutter.charts {
        ch.extend([u32_of(c.instance)?, u32_of(c.first)?, u32_of(c.count)?]);
        alb.extend(c.albedo.iter().map(|&x| x as f32));
    }
    let nc = clutter.charts.len();
    a.add_u32("clutter.charts", &[nc, 3], &ch).map_err(err)?;
    a.add_f32("clutter.albedo", &[nc, 3], &alb).map_err(err)?;
    let m = clutter.texels.len();
    let pos: Vec<f32> = clutter.texels.iter().flat_map(|t| t.position).map(|x| x as f32).collect();
    let nor: Vec<f32> = clutter.texels.iter().flat_map(|t| t.normal).map(|x| x as f32).collect();
    let mut uv = Vec::with_capacity(4 * m);
    for t in &clutter.texels {
        uv.extend([u32_of(t.chart)?, t.uv[0], t.uv[1], t.uv[2]]);
    }
    let w: Vec<f32> =
        clutter.texels.iter().map(|t| (1.0 / (clutter.charts[t.chart].count as f64).sqrt()) as f32).collect();
    a.add_f32("clutter.positions", &[m, 3], &pos).map_err(err)?;
    if half {
        a.add_f16("clutter.normals", &[m, 3], &nor).map_err(err)?;
    } else {
        a.add_f32("clutter.normals", &[m, 3], &nor).map_err(err)?;
    }
    a.add_u32("clutter.uv", &[m, 4], &uv).map_err(err)?;
    a.add_f32("clutter.t_d2c", &[m], &w).map_err(err)?;
    Ok(())
}

/// `c_b.*` and `c_c.*`.
fn write_gathers(a: &mut AssetBuilder, b: &DrtBake) -> Result<(), TransportError> {
    let mut rec = Vec::new();
    let mut srcs = Vec::new();
    let mut av = Vec::new();
    let mut wv = Vec::new();
    for g in &b.c_b {
        let kk = *g.src_offsets.last().unwrap_or(&0);
        rec.extend([
            u32_of(g.instance)?,
            u32_of(g.rank)?,
            u32_of(kk)?,
            u32_of(av.len())?,
            u32_of(wv.len())?,
            u32_of(srcs.len())?,
            u32_of(g.srcs.len())?,
        ]);
        for &s in &g.srcs {
            srcs.push(u32_of(s)?);
        }
        av.extend(f32s(&g.a));
        wv.extend(f32s(&g.w));
    }
    a.add_u32("c_b.records", &[b.c_b.len(), 7], &rec).map_err(err)?;
    a.add_u32("c_b.srcs", &[srcs.len()], &srcs).map_err(err)?;
    add_floats(a, "c_b.a", &av, b.params.half)?;
    add_floats(a, "c_b.w", &wv, b.params.half)?;
    write_reflect(a, "c_c", &b.c_b.iter().map(|g| &g.c_c).collect::<Vec<_>>(), b.params.half)?;
    Ok(())
}

/// A list of factored reflection operators: `<p>.records` u32 [R, 7] = (dst, rows, rank,
/// cols, a offset, w offset, charts offset), `<p>.charts` u32, `<p>.a` f32 (rows × rank each),
/// `<p>.w` f32 (rank × cols each).
fn write_reflect(a: &mut AssetBuilder, p: &str, recs: &[&ReflectRecord], half: bool) -> Result<(), TransportError> {
    let mut rec = Vec::new();
    let mut charts = Vec::new();
    let mut av = Vec::new();
    let mut wv = Vec::new();
    for r in recs {
        rec.extend([
            u32_of(r.dst)?,
            u32_of(r.rows)?,
            u32_of(r.rank)?,
            u32_of(r.charts.len())?,
            u32_of(av.len())?,
            u32_of(wv.len())?,
            u32_of(charts.len())?,
        ]);
        for &c in &r.charts {
            charts.push(u32_of(c)?);
        }
        av.extend(f32s(&r.a));
        wv.extend(f32s(&r.w));
    }
    a.add_u32(&format!("{p}.records"), &[recs.len(), 7], &rec).map_err(err)?;
    a.add_u32(&format!("{p}.charts"), &[charts.len()], &charts).map_err(err)?;
    add_floats(a, &format!("{p}.a"), &av, half)?;
    add_floats(a, &format!("{p}.w"), &wv, half)?;
    Ok(())
}

/// A flat operator section, f32 or (with `half`) f16.
fn add_floats(a: &mut AssetBuilder, name: &str, v: &[f32], half: bool) -> Result<(), TransportError> {
    if half {
        a.add_f16(name, &[v.len()], v).map_err(err)?;
    } else {
        a.add_f32(name, &[v.len()], v).map_err(err)?;
    }
    Ok(())
}

/// The records of a shard asset read back: the values as stored (f16 or f32, exactly), the
/// per-record truncation errors from its metrics, and what its meta says.
struct ShardPart {
    shard: DrtShard,
    meta: Value,
    bake: DrtBake,
    c_c: bool,
}

fn u32s(a: &Asset<'_>, name: &str, cols: usize) -> Result<Vec<usize>, TransportError> {
    let s = a.section(name).ok_or_else(|| TransportError::Asset(format!("section {name:?} is missing")))?;
    let v = s.as_u32().map_err(|e| TransportError::Asset(format!("section {name:?}: {e}")))?;
    if cols > 0 && v.len() % cols != 0 {
        return Err(TransportError::Asset(format!("section {name:?}: {} values, not rows of {cols}", v.len())));
    }
    Ok(v.iter().map(|&x| x as usize).collect())
}

fn floats(a: &Asset<'_>, name: &str) -> Result<Vec<f64>, TransportError> {
    let s = a.section(name).ok_or_else(|| TransportError::Asset(format!("section {name:?} is missing")))?;
    s.to_f64_vec().map_err(|e| TransportError::Asset(format!("section {name:?}: {e}")))
}

fn slice(v: &[f64], off: usize, len: usize, what: &str) -> Result<Vec<f64>, TransportError> {
    v.get(off..off + len)
        .map(<[f64]>::to_vec)
        .ok_or_else(|| TransportError::Asset(format!("{what}: range {off}..{} past the data", off + len)))
}

fn read_reflect(a: &Asset<'_>, p: &str, errs: &[f64]) -> Result<Vec<ReflectRecord>, TransportError> {
    let rec = u32s(a, &format!("{p}.records"), 7)?;
    let charts = u32s(a, &format!("{p}.charts"), 0)?;
    let av = floats(a, &format!("{p}.a"))?;
    let wv = floats(a, &format!("{p}.w"))?;
    rec.chunks(7)
        .enumerate()
        .map(|(i, r)| {
            let [dst, rows, rank, cols, ao, wo, co] = [r[0], r[1], r[2], r[3], r[4], r[5], r[6]];
            let ch = charts
                .get(co..co + cols)
                .ok_or_else(|| TransportError::Asset(format!("{p}.charts: record {i} past the data")))?
                .to_vec();
            let mut out = ReflectRecord::new(dst, ch, rows);
            out.op = Vec::new();
            out.a = slice(&av, ao, rows * rank, &format!("{p}.a"))?;
            out.w = slice(&wv, wo, rank * cols, &format!("{p}.w"))?;
            out.rank = rank;
            out.truncation_rel_error = errs.get(i).copied().unwrap_or(0.0);
            Ok(out)
        })
        .collect()
}

/// The records of a vector group `p` (`write_vec_group`) read back, values as stored.
fn read_vec_group(a: &Asset<'_>, p: &str) -> Result<Vec<VecRecord>, TransportError> {
    let rec = u32s(a, &format!("{p}.records"), 6)?;
    let charts = u32s(a, &format!("{p}.charts"), 0)?;
    let vals = floats(a, &format!("{p}.values"))?;
    rec.chunks_exact(6)
        .map(|r| {
            let (dst, src, rows, ncols, off, coff) = (r[0], r[1], r[2], r[3], r[4], r[5]);
            let cols = if src == u32::MAX as usize {
                let c = charts
                    .get(coff..coff + ncols)
                    .ok_or_else(|| TransportError::Asset(format!("{p}.records: chart columns out of range")))?;
                Cols::Charts(c.to_vec())
            } else {
                Cols::Block(src)
            };
            let op = slice(&vals, off, rows * ncols, &format!("{p}.values"))?;
            Ok(VecRecord { dst, cols, rows, op })
        })
        .collect()
}

/// A shard's vector and volume operators read back (`None` without them): `receivers` are
/// its receiving blocks in order, each with `g³` probes.
fn read_vector(a: &Asset<'_>, meta: &Value, receivers: &[usize]) -> Result<Option<DrtVectorBake>, TransportError> {
    let Some(vm) = meta.get("vector") else { return Ok(None) };
    let metrics: VectorMetrics = serde_json::from_value(vm["metrics"].clone())
        .map_err(|e| TransportError::Asset(format!("meta.vector.metrics: {e}")))?;
    let g3 = metrics.volume_res.pow(3);
    let pts = floats(a, "dyn.probes")?;
    let inside = a
        .section("dyn.inside")
        .ok_or_else(|| TransportError::Asset("section \"dyn.inside\" is missing".into()))?
        .as_u8()
        .map_err(|e| TransportError::Asset(format!("section \"dyn.inside\": {e}")))?;
    if inside.len() != receivers.len() * g3 || pts.len() != 3 * inside.len() {
        return Err(TransportError::Asset(format!(
            "dyn.probes: {} probes for {} receiving blocks of {g3}",
            inside.len(),
            receivers.len()
        )));
    }
    let probes = receivers
        .iter()
        .enumerate()
        .map(|(k, &block)| {
            let r = k * g3..(k + 1) * g3;
            BlockProbes {
                block,
                points: r.clone().map(|i| [pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]]).collect(),
                inside: inside[r.clone()].iter().map(|&c| c != 0).collect(),
                filled: inside[r].iter().map(|&c| c == 1).collect(),
            }
        })
        .collect();
    let params = VectorParams { rays: metrics.vector_rays, volume_res: metrics.volume_res };
    Ok(Some(DrtVectorBake {
        params,
        scene: read_vec_group(a, "vec.scene")?,
        clutter: read_vec_group(a, "vec.clutter")?,
        dyn_probes: read_vec_group(a, "dyn")?,
        probes,
        metrics,
    }))
}

fn f64_list(v: &Value) -> Vec<f64> {
    v.as_array().map(|a| a.iter().filter_map(Value::as_f64).collect()).unwrap_or_default()
}

fn read_part(a: &Asset<'_>, i: usize) -> Result<ShardPart, TransportError> {
    read_records(a, None, &|m| TransportError::Merge(format!("input {}: {m}", i + 1)))
}

/// The records of a whole bake's asset read back (the values as stored, exactly), as an
/// incremental re-bake copies the unchanged ones (`crate::drt::bake_incremental`): `k_b(src)`
/// gives the modes of a source block, from which the `C_b` column offsets follow.
pub fn read_bake(a: &Asset<'_>, k_b: &dyn Fn(usize) -> usize) -> Result<DrtBake, TransportError> {
    Ok(read_records(a, Some(k_b), &|m| TransportError::Asset(format!("previous DRT asset: {m}")))?.bake)
}

/// [`read_part`] (`whole` = `None`: a shard) or [`read_bake`] (`whole` = `k_b`: a whole bake).
fn read_records(
    a: &Asset<'_>,
    whole: Option<&dyn Fn(usize) -> usize>,
    bad: &dyn Fn(String) -> TransportError,
) -> Result<ShardPart, TransportError> {
    if a.kind() != Kind::DRTO {
        return Err(bad(format!("not a DRTO asset (kind {})", a.kind().as_str())));
    }
    let meta: Value = serde_json::from_str(a.meta_json()).map_err(|e| bad(e.to_string()))?;
    let (shard, sh) = match (a.section("shard"), whole) {
        (None, None) => return Err(bad("a whole bake, not a shard (no shard section)".into())),
        (Some(_), Some(_)) => return Err(bad("a shard, not a whole bake".into())),
        (None, Some(_)) => (DrtShard::WHOLE, Value::Null),
        (Some(sh), None) => {
            let sh: Value =
                serde_json::from_str(sh.as_json().map_err(|e| bad(e.to_string()))?).map_err(|e| bad(e.to_string()))?;
            let shard = DrtShard {
                index: sh["index"].as_u64().ok_or_else(|| bad("shard.index missing".into()))? as usize,
                count: sh["count"].as_u64().ok_or_else(|| bad("shard.count missing".into()))? as usize,
            };
            (shard, sh)
        }
    };
    let m = &meta["metrics"];
    let recv = u32s(a, "receivers", 3)?;
    let mask = a
        .section("inpaint_mask")
        .ok_or_else(|| bad("section inpaint_mask is missing".into()))?
        .as_u8()
        .map_err(|e| bad(e.to_string()))?;
    let receivers = recv
        .chunks(3)
        .map(|r| {
            let m = mask.get(r[1]..r[1] + r[2]).ok_or_else(|| bad("inpaint_mask too short".into()))?;
            Ok(Receiver { block: r[0], texels: r[2], mask: m.to_vec() })
        })
        .collect::<Result<Vec<_>, TransportError>>()?;
    let rec = u32s(a, "du_b.records", 5)?;
    let vals = floats(a, "du_b")?;
    let du_b = rec
        .chunks(5)
        .map(|r| {
            Ok(DeltaRecord {
                dst: r[0],
                src: r[1],
                rows: r[3],
                cols: r[4],
                op: slice(&vals, r[2], r[3] * r[4], "du_b")?,
            })
        })
        .collect::<Result<Vec<_>, TransportError>>()?;
    let du_c = read_reflect(a, "du_c", &f64_list(&m["du_c_truncation_rel_error"]))?;
    let c_c_errs = f64_list(&m["c_c_truncation_rel_error"]);
    let c_c_on = meta["params"]["clutter_to_clutter"].as_bool().unwrap_or(true);
    let c_c = read_reflect(a, "c_c", &c_c_errs)?;
    let rec = u32s(a, "c_b.records", 7)?;
    let srcs = u32s(a, "c_b.srcs", 0)?;
    let av = floats(a, "c_b.a")?;
    let wv = floats(a, "c_b.w")?;
    let offs = sh["c_b_src_offsets"].as_array().cloned().unwrap_or_default();
    let cb_errs = f64_list(&m["c_b_truncation_rel_error"]);
    let mut c_b = Vec::new();
    for (j, r) in rec.chunks(7).enumerate() {
        let [inst, rank, kk, ao, wo, so, ns] = [r[0], r[1], r[2], r[3], r[4], r[5], r[6]];
        let src_offsets: Vec<usize> = match whole {
            // a whole bake's offsets are the running sums of its sources' modes
            Some(k_b) => {
                let s = srcs.get(so..so + ns).ok_or_else(|| bad(format!("c_b record {j}: sources past c_b.srcs")))?;
                core::iter::once(0)
                    .chain(s.iter().scan(0, |acc, &y| {
                        *acc += k_b(y);
                        Some(*acc)
                    }))
                    .collect()
            }
            None => offs
                .get(j)
                .and_then(Value::as_array)
                .map(|o| o.iter().filter_map(Value::as_u64).map(|x| x as usize).collect())
                .ok_or_else(|| bad(format!("shard.c_b_src_offsets has no entry {j}")))?,
        };
        if src_offsets.last().copied() != Some(kk) {
            return Err(bad(format!("c_b record {j}: source offsets do not end at {kk}")));
        }
        c_b.push((inst, rank, kk, ao, wo, srcs.get(so..so + ns).map(<[usize]>::to_vec), src_offsets));
    }
    // rows per instance come from the clutter table (every shard has it whole)
    let inst_tab = u32s(a, "clutter.instances", 4)?;
    let mut gathers = Vec::new();
    for (j, (inst, rank, kk, ao, wo, srcs, src_offsets)) in c_b.into_iter().enumerate() {
        let m_rows = *inst_tab.get(4 * inst + 1).ok_or_else(|| bad(format!("c_b record {j}: no instance {inst}")))?;
        let srcs = srcs.ok_or_else(|| bad(format!("c_b record {j}: sources past c_b.srcs")))?;
        let c_c = if c_c_on {
            c_c.get(j).cloned().ok_or_else(|| bad(format!("no c_c record for c_b record {j}")))?
        } else {
            ReflectRecord::new(inst, Vec::new(), m_rows)
        };
        gathers.push(GatherOp {
            instance: inst,
            srcs,
            src_offsets,
            a: slice(&av, ao, m_rows * rank, "c_b.a")?,
            w: slice(&wv, wo, rank * kk, "c_b.w")?,
            rank,
            truncation_rel_error: cb_errs.get(j).copied().unwrap_or(0.0),
            full: Vec::new(),
            c_c,
        });
    }
    let params = params_of(&meta["params"]);
    let metrics: DrtMetrics = serde_json::from_value(m.clone()).map_err(|e| bad(format!("meta.metrics: {e}")))?;
    Ok(ShardPart {
        shard,
        meta,
        bake: DrtBake { params, shard, receivers, du_b, du_c, c_b: gathers, metrics },
        c_c: c_c_on,
    })
}

/// The bake parameters recorded in a DRTO's `meta.params`.
pub fn params_of(p: &Value) -> DrtParams {
    let d = DrtParams::default();
    let u = |k: &str, v: usize| p[k].as_u64().map_or(v, |x| x as usize);
    DrtParams {
        rays: u("rays", d.rays),
        clutter_rays: u("clutter_rays", u("rays", d.rays)),
        neighborhood: u("neighborhood", d.neighborhood),
        k_c: u("k_c", d.k_c),
        k_dc: u("k_dc", d.k_dc),
        clutter_to_clutter: p["clutter_to_clutter"].as_bool().unwrap_or(true),
        kc_mode: p["kc_mode"].as_str().and_then(KcMode::parse).unwrap_or(KcMode::Svd),
        inpaint: p["inpaint"].as_bool().unwrap_or(true),
        clutter_res: u("clutter_res", d.clutter_res),
        clutter_basis_res: u("clutter_basis_res", 1),
        seed: p["seed"].as_u64().unwrap_or(0),
        half: p["half"].as_bool().unwrap_or(true),
        vector_rays: p["vector_rays"].as_u64().map(|x| x as usize),
        volume_res: p["volume_res"].as_u64().map(|x| x as usize),
    }
}

/// Merges the shard assets of one bake (`--shard K/N`, any order) into the asset a single run
/// writes, byte for byte: the records are joined in a single run's order (receiving blocks
/// ascending, `ΔU_b` by (dst, src), instances ascending), the stored values are copied
/// exactly (f16 and f32 re-encode to the same bits), the clutter sections are every shard's
/// (checked equal) and the metrics are recomputed from the joined records and the shards'
/// counters. Refuses shards of different bakes and missing or repeated shards.
pub fn merge(shards: &[Asset<'_>]) -> Result<AssetBuilder, TransportError> {
    let merr = |m: String| TransportError::Merge(m);
    if shards.is_empty() {
        return Err(merr("no shards given".into()));
    }
    let parts: Vec<ShardPart> = shards.iter().enumerate().map(|(i, a)| read_part(a, i)).collect::<Result<_, _>>()?;
    let n = parts[0].shard.count;
    let mut order: Vec<usize> = (0..parts.len()).collect();
    order.sort_by_key(|&i| parts[i].shard.index);
    if parts.len() != n
        || order.iter().enumerate().any(|(k, &i)| parts[i].shard.index != k || parts[i].shard.count != n)
    {
        let have: Vec<String> = parts.iter().map(|p| format!("{}/{}", p.shard.index, p.shard.count)).collect();
        return Err(merr(format!("need shards 0..{n} of {n} exactly once, got {}", have.join(", "))));
    }
    let strip = |m: &Value| {
        let mut m = m.clone();
        if let Some(o) = m.as_object_mut() {
            o.remove("metrics");
        }
        if let Some(o) = m.get_mut("vector").and_then(Value::as_object_mut) {
            o.remove("metrics");
        }
        m
    };
    let base = &parts[order[0]];
    for &i in &order[1..] {
        if strip(&parts[i].meta) != strip(&base.meta) {
            return Err(merr(format!(
                "shard {}/{n} comes from a different bake (parameters, inputs or tool differ from shard 0/{n})",
                parts[i].shard.index
            )));
        }
        for name in CLUTTER_SECTIONS {
            let (x, y) = (shards[i].section(name), shards[order[0]].section(name));
            if x.map(|s| s.bytes()) != y.map(|s| s.bytes()) {
                return Err(merr(format!(
                    "shard {}/{n}: section {name:?} differs from shard 0/{n}",
                    parts[i].shard.index
                )));
            }
        }
    }
    let mut receivers: Vec<Receiver> = Vec::new();
    let mut du_b: Vec<DeltaRecord> = Vec::new();
    let mut du_c: Vec<ReflectRecord> = Vec::new();
    let mut c_b: Vec<GatherOp> = Vec::new();
    let (mut traced, mut outside) = (0u64, 0usize);
    for p in &parts {
        receivers.extend(p.bake.receivers.iter().cloned());
        du_b.extend(p.bake.du_b.iter().cloned());
        du_c.extend(p.bake.du_c.iter().cloned());
        c_b.extend(p.bake.c_b.iter().cloned());
        traced += p.bake.metrics.rays_traced;
        outside += p.bake.metrics.clutter_texels_outside;
    }
    receivers.sort_by_key(|r| r.block);
    du_b.sort_by_key(|r| (r.dst, r.src));
    du_c.sort_by_key(|r| r.dst);
    c_b.sort_by_key(|g| g.instance);
    let m0 = &base.bake.metrics;
    let inpainted = receivers.iter().map(|r| r.mask.iter().filter(|&&v| v == 1).count()).sum();
    let failures = receivers.iter().map(|r| r.mask.iter().filter(|&&v| v == 2).count()).sum();
    let metrics = DrtMetrics {
        blocks: receivers.len(),
        clutter_instances: m0.clutter_instances,
        clutter_texels: m0.clutter_texels,
        clutter_charts: m0.clutter_charts,
        rays: m0.rays,
        rays_traced: traced,
        inpainted_texels: inpainted,
        inpaint_failures: failures,
        clutter_texels_outside: outside,
        neighborhood: m0.neighborhood,
        delta_occlusion_records: du_b.len(),
        k_c: c_b.iter().map(|g| g.rank).max().unwrap_or(0),
        c_b_truncation_rel_error: c_b.iter().map(|g| g.truncation_rel_error).collect(),
        k_dc: du_c.iter().map(|r| r.rank).max().unwrap_or(0),
        du_c_truncation_rel_error: du_c.iter().map(|r| r.truncation_rel_error).collect(),
        c_c_truncation_rel_error: if base.c_c {
            c_b.iter().map(|g| g.c_c.truncation_rel_error).collect()
        } else {
            Vec::new()
        },
    };
    let mut meta = base.meta.clone();
    meta["metrics"] = serde_json::to_value(&metrics).map_err(err)?;
    let vector = merge_vector(shards, &parts, &order)?;
    if let Some(v) = &vector {
        meta["vector"]["metrics"] = serde_json::to_value(&v.metrics).map_err(err)?;
    }
    let b = DrtBake { params: base.bake.params.clone(), shard: DrtShard::WHOLE, receivers, du_b, du_c, c_b, metrics };
    let mut a = AssetBuilder::new(Kind::DRTO);
    a.add_json("meta", &serde_json::to_string(&meta).map_err(err)?).map_err(err)?;
    let src = &shards[order[0]];
    body(&mut a, &b, &mut |a| {
        for name in CLUTTER_SECTIONS {
            let s = src.section(name).ok_or_else(|| TransportError::Asset(format!("section {name:?} is missing")))?;
            let dt: DType = s.dtype();
            a.add_raw(name, dt, s.dims(), s.bytes()).map_err(err)?;
        }
        Ok(())
    })?;
    if let Some(v) = &vector {
        vector_sections(&mut a, v, b.params.half)?;
    }
    Ok(a)
}

/// The shards' vector and volume operators joined in a single run's order (each receiving
/// block's and instance's records are one shard's, so a stable sort by destination keeps
/// their order within), with the metrics summed; `None` when the bake has none.
fn merge_vector(
    shards: &[Asset<'_>],
    parts: &[ShardPart],
    order: &[usize],
) -> Result<Option<DrtVectorBake>, TransportError> {
    let mut all = Vec::new();
    for &i in order {
        let recv: Vec<usize> = parts[i].bake.receivers.iter().map(|r| r.block).collect();
        let v = read_vector(&shards[i], &parts[i].meta, &recv).map_err(|e| {
            TransportError::Merge(format!("shard {}/{}: {e}", parts[i].shard.index, parts[i].shard.count))
        })?;
        match v {
            Some(v) => all.push(v),
            None => return Ok(None),
        }
    }
    let mut it = all.into_iter();
    let Some(mut v) = it.next() else { return Ok(None) };
    for w in it {
        v.scene.extend(w.scene);
        v.clutter.extend(w.clutter);
        v.dyn_probes.extend(w.dyn_probes);
        v.probes.extend(w.probes);
        v.metrics.rays_traced += w.metrics.rays_traced;
    }
    v.scene.sort_by_key(|r| r.dst);
    v.clutter.sort_by_key(|r| r.dst);
    v.dyn_probes.sort_by_key(|r| r.dst);
    v.probes.sort_by_key(|p| p.block);
    let m = &mut v.metrics;
    m.probes = v.probes.iter().map(|p| p.points.len()).sum();
    m.probes_inside_clutter = v.probes.iter().flat_map(|p| &p.inside).filter(|&&b| b).count();
    m.probes_inpainted = v.probes.iter().flat_map(|p| &p.filled).filter(|&&b| b).count();
    m.values = v.scene.iter().chain(&v.clutter).chain(&v.dyn_probes).map(|r| r.op.len()).sum();
    Ok(Some(v))
}
