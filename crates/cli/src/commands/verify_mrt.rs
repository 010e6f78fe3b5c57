//! `penumbra verify mrt`: the MRT runtime on a level against a path tracer on the same blocks.

use crate::commands::mrt_level::{LevelSource, bake, load_dict, resolve, validated};
use crate::commands::print_json;
use crate::commands::verify_mrt_vector::TILT_DEG as TILT;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use crate::progress::{ProgressMode, Reporter};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::{Asset, AssetFile};
use penumbra_math::progress::Progress;
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_transport::level::{Level, Links};
use penumbra_transport::level_ops::DictOps;
use penumbra_transport::level_reference::{
    LevelGeometry, PointLight, direct_at, level_texels, reference, reference_at,
};
use serde_json::json;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// `penumbra verify mrt`.
#[derive(Debug, Args)]
pub struct VerifyMrtArgs {
    /// The level: a level file (TOML) or a baked level asset (.mrtl, verified as it is, with
    /// the dictionary it was baked with). Omit with --maze/--corridor/--l-turn.
    #[arg(long)]
    pub level: Option<PathBuf>,
    /// The dictionary (.mrtd, with interfaces).
    #[arg(long)]
    pub dict: PathBuf,
    /// Procedural level.
    #[command(flatten)]
    pub source: LevelSource,
    /// Point lights (TOML `[[light]] position = [x, y, z]`, `intensity`). Default: one light of
    /// intensity 1 at the centre of block 0, and of every 8th block after it.
    #[arg(long)]
    pub lights: Option<PathBuf>,
    /// Wall albedo of the comparison (the runtime scales the dictionary's baked albedo).
    #[arg(long, default_value_t = 0.5, value_parser = parse_albedo)]
    pub albedo: f64,
    /// Reference rays per texel.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(4..=1_048_576))]
    pub rays: u32,
    /// Bounces of the multi-bounce comparison (runtime feedback iterations and path length).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub bounces: u32,
    /// Depth limit of the level operators.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub max_depth: u32,
    /// Seed of the reference.
    #[arg(long = "ref-seed", default_value_t = 0)]
    pub ref_seed: u64,
    /// Top view of the floor's one-bounce indirect light: MRT | reference | difference (PNG;
    /// panels at least 512 px, titled, a colour bar and a caption).
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// Exit with code 1 when rel_error_one_bounce exceeds this (a quality gate for CI).
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_rel_error: Option<f64>,
    /// Exit with code 1 when rel_error_vector (tilted normals on the walls) exceeds this.
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_rel_error_vector: Option<f64>,
    /// Exit with code 1 when rel_error_volume (probes at interior points) exceeds this.
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_rel_error_volume: Option<f64>,
    /// Also evaluate the level with its warped blocks re-baked (`mrt level
    /// --rebake-warps-above`): `rel_error_warped_unit_ops` against `rel_error_warped_rebaked`.
    #[command(flatten)]
    pub warps: crate::commands::mrt_level::WarpArgs,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_albedo(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 1.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < A < 1)")) }
}

fn rel(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

fn norm_ratio(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().map(|x| x * x).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

/// Point lights of a lights file (TOML `[[light]]`), each checked to lie inside a block of the
/// level and to have a positive intensity (shared by `verify mrt` and `verify drt`).
pub fn load_point_lights(p: &std::path::Path, geo: &LevelGeometry<'_>) -> Result<Vec<PointLight>, CliError> {
    let f = penumbra_config::level::load_lights(p)?;
    if f.lights.is_empty() {
        return Err(CliError::input(anyhow!("{}: no [[light]]", p.display())));
    }
    let mut v = Vec::new();
    for (i, l) in f.lights.iter().enumerate() {
        let intensity = l.intensity.unwrap_or(1.0);
        if !(intensity.is_finite() && intensity > 0.0) || geo.block_of(l.position).is_none() {
            return Err(CliError::input(anyhow!(
                "{}: light {i} at {:?} must have a positive intensity and lie inside a block",
                p.display(),
                l.position
            )));
        }
        v.push(PointLight { position: l.position, intensity });
    }
    Ok(v)
}

/// Lights nearer to a wall of their block than `1/7` of the block (the lattice prior's
/// nearest lights, MRT thesis §3.5.1: `i/7, i = 1..6`), in block-local units: outside what the
/// prior was sampled for. `{light, block, distance}` each.
pub fn lights_outside_prior(geo: &LevelGeometry<'_>, lights: &[PointLight]) -> Vec<serde_json::Value> {
    let mut out = Vec::new();
    for (i, l) in lights.iter().enumerate() {
        let Some(b) = geo.block_of(l.position) else { continue };
        let blk = &geo.level.blocks[b];
        let p = blk.to_local(l.position);
        let d = (0..6)
            .filter(|&f| geo.missing[blk.shape] & (1 << f) == 0)
            .map(|f| if f % 2 == 0 { p[f / 2] } else { 1.0 - p[f / 2] })
            .fold(f64::INFINITY, f64::min);
        if d < 1.0 / 7.0 - 1e-9 {
            out.push(json!({"light": i, "block": b, "distance": d}));
        }
    }
    out
}

/// The default lights: intensity 1 at the centre of block 0 and of every 8th block after it.
pub fn default_lights(level: &Level) -> Vec<PointLight> {
    (0..level.blocks.len())
        .step_by(8)
        .map(|b| PointLight { position: level.blocks[b].to_world([0.5, 0.5, 0.5]), intensity: 1.0 })
        .collect()
}

/// Median wall time of `f` over `reps` runs, in ms.
pub fn median_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// A level to evaluate with its dictionary: the level and its links, what it is called, and
/// its level-asset bytes (a baked `.mrtl` as it is, checked against the dictionary; otherwise
/// baked here with `max_depth`). Shared by `verify mrt` and `verify gpu mrt`.
pub(crate) struct OpenedLevel {
    pub d: DictOps,
    pub level: Level,
    pub links: Links,
    pub what: String,
    pub bytes: Vec<u8>,
    pub max_depth: usize,
    /// The level was a baked `.mrtl` (its operators as they are).
    pub from_mrtl: bool,
}

/// Opens `--level` (a level file or a baked `.mrtl`) or the procedural `source` against the
/// dictionary at `dict`.
pub(crate) fn open_level(
    dict: &std::path::Path,
    level: Option<&std::path::Path>,
    source: &LevelSource,
    max_depth: usize,
) -> Result<OpenedLevel, CliError> {
    let d = load_dict(dict)?;
    // a baked MRTL asset: its own level and operators (checked against the dictionary)
    let mut baked: Option<(Vec<u8>, usize)> = None;
    let mut from_asset: Option<(Level, Links, String)> = None;
    if let Some(p) = level {
        let bytes = std::fs::read(p).with_context(|| format!("cannot read level {}", p.display()))?;
        if bytes.starts_with(b"PENUMBRA") {
            let asset = penumbra_asset::OwnedAsset::parse(&bytes)
                .map_err(|e| CliError::input(anyhow!("{}: {e}", p.display())))?;
            let at = asset.asset();
            if at.kind().as_str() != "MRTL" {
                return Err(CliError::input(anyhow!(
                    "{}: a {} asset, not an MRT level (MRTL)",
                    p.display(),
                    at.kind().as_str()
                )));
            }
            let meta: serde_json::Value = serde_json::from_str(at.meta_json()).map_err(CliError::internal)?;
            if meta["dictionary"]["crc32c"].as_str() != Some(format!("{:08x}", d.crc32c).as_str()) {
                return Err(CliError::input(anyhow!(
                    "{} was baked with another dictionary (CRC-32C {}), not {} ({:08x})",
                    p.display(),
                    meta["dictionary"]["crc32c"],
                    dict.display(),
                    d.crc32c
                )));
            }
            if source.maze.is_some() || source.corridor.is_some() || source.l_turn.is_some() {
                return Err(CliError::input(anyhow!("give either --level or --maze/--corridor/--l-turn, not both")));
            }
            let lf: penumbra_config::LevelFile = serde_json::from_value(meta["level"].clone())
                .map_err(|e| CliError::input(anyhow!("{}: meta.level: {e}", p.display())))?;
            let (level, links) = validated(&lf, p, &d)?;
            let depth = meta["params"]["max_depth"].as_u64().unwrap_or(8) as usize;
            from_asset = Some((level, links, p.display().to_string()));
            baked = Some((bytes, depth));
        }
    }
    let (level, links, what) = match from_asset {
        Some(x) => x,
        None => resolve(level, source, &d)?,
    };
    let from_mrtl = baked.is_some();
    let (max_depth, bytes) = match baked {
        Some((bytes, depth)) => (depth, bytes),
        None => (max_depth, bake(&level, &links, &d, max_depth, None)?.1),
    };
    Ok(OpenedLevel { d, level, links, what, bytes, max_depth, from_mrtl })
}

/// Runs `penumbra verify mrt`.
pub fn run(a: &VerifyMrtArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    run_report(a, mode).map(|(code, _)| code)
}

/// Runs `penumbra verify mrt` and returns its report too (`penumbra bake` stage gates).
#[allow(clippy::print_stderr)]
pub(crate) fn run_report(a: &VerifyMrtArgs, mode: ProgressMode) -> Result<(ExitCode, serde_json::Value), CliError> {
    let start = Instant::now();
    let OpenedLevel { d, level, links, what, bytes, max_depth, from_mrtl } =
        open_level(&a.dict, a.level.as_deref(), &a.source, a.max_depth as usize)?;
    let geo = LevelGeometry { level: &level, links: &links, missing: &d.missing };
    let lights: Vec<PointLight> = match &a.lights {
        Some(p) => load_point_lights(p, &geo)?,
        None => default_lights(&level),
    };
    let outside_prior = lights_outside_prior(&geo, &lights);
    // the level operators, through the asset bytes the runtime reads
    let level_asset = penumbra_asset::OwnedAsset::parse(&bytes).map_err(CliError::internal)?;
    let dict_file = AssetFile::open(&a.dict).with_context(|| format!("cannot open {}", a.dict.display()))?;
    let dict_asset: Asset<'_> = dict_file.asset();
    let rd =
        MrtDictionary::from_asset(&dict_asset).map_err(|e| CliError::input(anyhow!("{}: {e}", a.dict.display())))?;
    let la = level_asset.asset();
    let rl = MrtLevel::from_asset(&la, &rd).map_err(|e| CliError::input(anyhow!("level: {e}")))?;
    let block_pairs = {
        let mut p: Vec<(u32, u32)> = rl.records.iter().map(|r| (r.dst, r.src)).collect();
        p.dedup();
        p.sort_unstable();
        p.dedup();
        p.len()
    };
    let mut rt = MrtRuntime::new(rd, rl);
    let tex = level_texels(&level, &d.missing, d.face_res);
    if tex.texels.len() != rt.texel_count() {
        return Err(CliError::internal(anyhow!("texel count {} vs runtime {}", tex.texels.len(), rt.texel_count())));
    }
    let direct = direct_at(&geo, &tex, &lights);
    let l_d: Vec<f32> = direct.iter().map(|&x| x as f32).collect();
    let n = l_d.len();
    let scale = (a.albedo / d.albedo) as f32;
    let mut one = vec![0.0f32; n];
    let mut none = vec![0.0f32; n];
    let mut multi = vec![0.0f32; n];
    rt.indirect(&l_d, &mut one, true);
    rt.indirect(&l_d, &mut none, false);
    rt.multi_bounce(&l_d, &mut multi, a.bounces as usize, scale);
    let ms_runtime = median_ms(21, || rt.indirect(&l_d, &mut one, true));
    let ms_multi = median_ms(5, || rt.multi_bounce(&l_d, &mut multi, a.bounces as usize, scale));
    let to64 = |v: &[f32], s: f64| -> Vec<f64> { v.iter().map(|&x| f64::from(x) * s).collect() };
    let one = to64(&one, f64::from(scale));
    let none = to64(&none, f64::from(scale));
    let multi = to64(&multi, 1.0);
    // the vector and volume response of the one-bounce state (b and r of `indirect` with
    // interfaces), and what evaluating it costs
    let mut tmp = vec![0.0f32; n];
    rt.indirect(&l_d, &mut tmp, true);
    let vchecks = crate::commands::verify_mrt_vector::build(&rt, &one, scale, &geo, &tex);
    let ms_vector = vchecks.as_ref().map(|_| {
        let mut vbuf = vec![[0.0f32; 4]; n];
        let mut sh = Vec::new();
        median_ms(5, || {
            rt.vector_coefficients(&mut vbuf);
            for x in 0..level.blocks.len() {
                rt.probe_sh(x, &mut sh);
            }
        })
    });
    // the same level with its warped blocks re-baked (one and multi-bounce)
    let rebaked = match (from_mrtl, a.warps.rebake_warps_above) {
        (false, Some(_)) => {
            let w = a.warps.rebake(&level, &d)?.ok_or_else(|| CliError::internal(anyhow!("no warps")))?;
            let (_, wbytes) =
                crate::commands::mrt_level::bake_with_warps(&level, &links, &d, a.max_depth as usize, None, Some(&w))?;
            let wa = penumbra_asset::OwnedAsset::parse(&wbytes).map_err(CliError::internal)?;
            let rd2 = MrtDictionary::from_asset(&dict_asset).map_err(|e| CliError::input(anyhow!("{e}")))?;
            let wl = wa.asset();
            let rl2 = MrtLevel::from_asset(&wl, &rd2).map_err(|e| CliError::input(anyhow!("level: {e}")))?;
            let mut rt2 = MrtRuntime::new(rd2, rl2);
            let (mut o1, mut om) = (vec![0.0f32; n], vec![0.0f32; n]);
            rt2.indirect(&l_d, &mut o1, true);
            rt2.multi_bounce(&l_d, &mut om, a.bounces as usize, scale);
            Some((to64(&o1, f64::from(scale)), to64(&om, 1.0), crate::commands::mrt_level::warp_report(&w)))
        }
        (true, Some(_)) => {
            return Err(CliError::input(anyhow!(
                "--rebake-warps-above needs a level file or a procedural level, not a baked .mrtl (bake it with mrt level --rebake-warps-above)"
            )));
        }
        _ => None,
    };
    // the reference
    let rep = Reporter::new("verify mrt", mode);
    let done = AtomicU64::new(0);
    let total = n as u64;
    let t_ref = Instant::now();
    let r = reference(&geo, &tex, &lights, a.albedo, a.rays as usize, a.bounces as usize, a.ref_seed, &|k| {
        let v = done.fetch_add(k, Ordering::Relaxed) + k;
        rep.update("reference", v.min(total), total);
    });
    let vref = vchecks.as_ref().map(|vc| {
        let total = vc.receivers.len() as u64;
        let done = AtomicU64::new(0);
        reference_at(&geo, &vc.receivers, &lights, a.albedo, a.rays as usize, a.ref_seed, &|k| {
            let v = done.fetch_add(k, Ordering::Relaxed) + k;
            rep.update("reference (vector, volume)", v.min(total), total);
        })
    });
    rep.finish();
    let reference_seconds = t_ref.elapsed().as_secs_f64();
    let (vector, vector_blocks) = match (&vchecks, &vref) {
        (Some(vc), Some((vone, vhalf))) => {
            let (top, per) = vc.report(vone, vhalf, level.blocks.len());
            (top, per)
        }
        _ => (serde_json::Value::Null, Vec::new()),
    };
    let mut per_block: Vec<serde_json::Value> = (0..level.blocks.len())
        .map(|b| {
            let rg = tex.offsets[b]..tex.offsets[b + 1];
            json!({
                "block": b,
                "shape": d.names[level.blocks[b].shape],
                "one_bounce": rel(&one[rg.clone()], &r.one_bounce[rg.clone()]),
                "one_bounce_no_interfaces": rel(&none[rg.clone()], &r.one_bounce[rg.clone()]),
                "multi_bounce": rel(&multi[rg.clone()], &r.multi_bounce[rg.clone()]),
                "reference_noise_one_bounce": norm_ratio(&r.one_half_difference[rg.clone()], &r.one_bounce[rg]),
            })
        })
        .collect();
    if let Some((o1, om, _)) = &rebaked {
        for (b, pb) in per_block.iter_mut().enumerate() {
            let rg = tex.offsets[b]..tex.offsets[b + 1];
            pb["stretch"] = json!(penumbra_transport::warp::stretch(level.blocks[b].scale));
            pb["one_bounce_rebaked"] = json!(rel(&o1[rg.clone()], &r.one_bounce[rg.clone()]));
            pb["multi_bounce_rebaked"] = json!(rel(&om[rg.clone()], &r.multi_bounce[rg]));
        }
    }
    for (pb, vb) in per_block.iter_mut().zip(&vector_blocks) {
        if let (Some(o), Some(w)) = (pb.as_object_mut(), vb.as_object()) {
            o.extend(w.iter().map(|(k, x)| (k.clone(), x.clone())));
        }
    }
    let mut v = json!({
        "level": what,
        "blocks": level.blocks.len(),
        "texels": n,
        "lights": lights.len(),
        "albedo": a.albedo,
        "bounces": a.bounces,
        "rays": a.rays,
        "max_depth": max_depth,
        "block_pairs": block_pairs,
        "rel_error_one_bounce": rel(&one, &r.one_bounce),
        "rel_error_one_bounce_no_interfaces": rel(&none, &r.one_bounce),
        "rel_error_multi_bounce": rel(&multi, &r.multi_bounce),
        "reference_noise_one_bounce": norm_ratio(&r.one_half_difference, &r.one_bounce),
        "reference_noise_multi_bounce": norm_ratio(&r.multi_half_difference, &r.multi_bounce),
        "indirect_to_direct": norm_ratio(&r.one_bounce, &direct),
        "lights_outside_prior": outside_prior,
        "ms_runtime": ms_runtime,
        "ms_runtime_multi_bounce": ms_multi,
        "ms_runtime_vector": ms_vector,
        "per_block": per_block,
        "reference_seconds": reference_seconds,
        "seconds": start.elapsed().as_secs_f64(),
    });
    if let Some((o1, om, report)) = &rebaked {
        let max_stretch = level.blocks.iter().map(|b| penumbra_transport::warp::stretch(b.scale)).fold(1.0, f64::max);
        v["max_stretch"] = json!(max_stretch);
        v["rel_error_warped_unit_ops"] = v["rel_error_one_bounce"].clone();
        v["rel_error_warped_rebaked"] = json!(rel(o1, &r.one_bounce));
        v["rel_error_warped_unit_ops_multi_bounce"] = v["rel_error_multi_bounce"].clone();
        v["rel_error_warped_rebaked_multi_bounce"] = json!(rel(om, &r.multi_bounce));
        v["warps"] = report.clone();
    }
    // the vector and volume keys at the top level (null without U_b⃗/U_bvol)
    if let (Some(o), Some(w)) = (v.as_object_mut(), vector.as_object()) {
        o.extend(w.iter().map(|(k, x)| (k.clone(), x.clone())));
    } else if let Some(o) = v.as_object_mut() {
        for k in ["rel_error_vector", "rel_error_volume"] {
            o.insert(k.into(), serde_json::Value::Null);
        }
    }
    let failures = crate::commands::gate::apply(
        &mut v,
        &[
            crate::commands::gate::Gate { key: "max_rel_error", metric: "rel_error_one_bounce", max: a.max_rel_error },
            crate::commands::gate::Gate {
                key: "max_rel_error_vector",
                metric: "rel_error_vector",
                max: a.max_rel_error_vector,
            },
            crate::commands::gate::Gate {
                key: "max_rel_error_volume",
                metric: "rel_error_volume",
                max: a.max_rel_error_volume,
            },
        ],
    );
    if let Some(p) = &a.image {
        let caption = vec![format!(
            "one-bounce relative error {:.4}; blocks: {}, reference rays per texel: {}",
            v["rel_error_one_bounce"].as_f64().unwrap_or(f64::NAN),
            level.blocks.len(),
            a.rays
        )];
        let fig = crate::commands::floor_view::floor_figure(
            &tex,
            &[("MRT (one bounce)", &one), ("reference (path traced)", &r.one_bounce)],
            None,
            (0, 1),
            0.2,
            caption,
        );
        let png = crate::figure::render(&fig);
        ensure_parent(p)?;
        penumbra_asset::write_file_atomic(p, &png).with_context(|| format!("cannot write {}", p.display()))?;
    }
    if a.json {
        print_json(&v);
    } else {
        eprintln!(
            "{what}: {} blocks, {n} texels, {} lights, albedo {}\n  one bounce: rel. error {:.4} (without interfaces {:.4}; reference noise {:.4})\n  {} bounces: rel. error {:.4} (reference noise {:.4})\n  runtime {:.3} ms one bounce, {:.3} ms {} bounces (one thread)",
            level.blocks.len(),
            lights.len(),
            a.albedo,
            v["rel_error_one_bounce"].as_f64().unwrap_or(f64::NAN),
            v["rel_error_one_bounce_no_interfaces"].as_f64().unwrap_or(f64::NAN),
            v["reference_noise_one_bounce"].as_f64().unwrap_or(f64::NAN),
            a.bounces,
            v["rel_error_multi_bounce"].as_f64().unwrap_or(f64::NAN),
            v["reference_noise_multi_bounce"].as_f64().unwrap_or(f64::NAN),
            ms_runtime,
            ms_multi,
            a.bounces
        );
        if rebaked.is_some() {
            eprintln!(
                "  warped blocks re-baked ({} distinct, {:.3} s each): one bounce {:.4} (unit operators {:.4}), {} bounces {:.4} (unit operators {:.4})",
                v["warps"]["distinct"],
                v["warps"]["seconds_per_warp"].as_f64().unwrap_or(f64::NAN),
                v["rel_error_warped_rebaked"].as_f64().unwrap_or(f64::NAN),
                v["rel_error_warped_unit_ops"].as_f64().unwrap_or(f64::NAN),
                a.bounces,
                v["rel_error_warped_rebaked_multi_bounce"].as_f64().unwrap_or(f64::NAN),
                v["rel_error_warped_unit_ops_multi_bounce"].as_f64().unwrap_or(f64::NAN),
            );
        }
        if !vector.is_null() {
            let g = |k: &str| vector[k].as_f64().unwrap_or(f64::NAN);
            eprintln!(
                "  vector (normals tilted {}°, one bounce): rel. error {:.4} (b only {:.4}, untilted scalar {:.4}; reference noise {:.4})\n  volume probes (6 axis normals): rel. error {:.4} (b only {:.4}; reference noise {:.4}){}",
                TILT,
                g("rel_error_vector"),
                g("rel_error_vector_b_only"),
                g("rel_error_vector_scalar"),
                g("reference_noise_vector"),
                g("rel_error_volume"),
                g("rel_error_volume_b_only"),
                g("reference_noise_volume"),
                if vector["interface_vectors"].as_bool() == Some(true) {
                    ""
                } else {
                    "\n  (the dictionary has no interface vector response U_r⃗/U_rvol: both are b only; re-bake it)"
                }
            );
        }
    }
    for l in &outside_prior {
        eprintln!(
            "warning: light {} is {:.3} block from a wall of block {}, nearer than the dictionary's light prior reaches \
             (1/7 block): expect a larger error next to it (docs/mrt.md)",
            l["light"],
            l["distance"].as_f64().unwrap_or(f64::NAN),
            l["block"]
        );
    }
    Ok((crate::commands::gate::finish(&failures), v))
}
