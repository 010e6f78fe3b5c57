//! Writes a [`DrtBake`] as a `DRTO` asset (sections in `schemas/asset-format.md`, "DRTO").
//!
//! Operators of varying shape are stored flat with record tables that give each one's offset
//! and dimensions (all u32), so a C reader needs no JSON.

use crate::TransportError;
use crate::clutter::ClutterScene;
use crate::drt::{DRTO_KIND_VERSION, DrtBake, ReflectRecord};
use penumbra_asset::{AssetBuilder, Kind};
use serde_json::json;

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
) -> Result<AssetBuilder, TransportError> {
    let mut a = AssetBuilder::new(Kind::DRTO);
    let meta = json!({
        "kind": "DRTO",
        "kind_version": DRTO_KIND_VERSION,
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
    a.add_json("meta", &serde_json::to_string(&meta).map_err(err)?).map_err(err)?;

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
    add_floats(&mut a, "du_b", &vals, b.params.half)?;

    write_reflect(&mut a, "du_c", &b.du_c.iter().collect::<Vec<_>>(), b.params.half)?;

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
    if b.params.half {
        a.add_f16("clutter.normals", &[m, 3], &nor).map_err(err)?;
    } else {
        a.add_f32("clutter.normals", &[m, 3], &nor).map_err(err)?;
    }
    a.add_u32("clutter.uv", &[m, 4], &uv).map_err(err)?;
    a.add_f32("clutter.t_d2c", &[m], &w).map_err(err)?;

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
    add_floats(&mut a, "c_b.a", &av, b.params.half)?;
    add_floats(&mut a, "c_b.w", &wv, b.params.half)?;
    write_reflect(&mut a, "c_c", &b.c_b.iter().map(|g| &g.c_c).collect::<Vec<_>>(), b.params.half)?;
    Ok(a)
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
