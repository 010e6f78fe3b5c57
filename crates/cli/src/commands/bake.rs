//! `penumbra bake <config.toml>`: run every stage a config names, skip the up-to-date ones,
//! write `report.json`.

use super::bake_cache::Cache;
use crate::args::BakeArgs;
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::write_atomic_text;
use crate::progress::ProgressMode;
use anyhow::{Context, anyhow};
use penumbra_asset::AssetFile;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Stage names in execution order. Every configured entry of a stage is one work item;
/// `--shard K/N` runs the items whose index (in this order) is K mod N; `mrt_level` and `drt`
/// take the index of `mrt`, whose dictionary they read.
pub const STAGES: &[&str] = &["tables", "spheres", "fiv", "mrt", "mrt_level", "drt", "vo"];

/// Parses `K/N` (0 ≤ K < N).
pub fn parse_shard(s: &str) -> Result<(usize, usize), CliError> {
    let bad = || CliError::input(anyhow!("--shard {s:?}: expected K/N with 0 ≤ K < N, e.g. 0/4"));
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
    if n == 0 || k >= n {
        return Err(bad());
    }
    Ok((k, n))
}

/// The cache key recorded in an existing asset's metadata, if it is a valid asset.
fn existing_cache_key(path: &Path) -> Option<(String, Value)> {
    let file = AssetFile::open(path).ok()?;
    let meta: Value = serde_json::from_str(file.asset().meta_json()).ok()?;
    let key = meta.get("cache_key")?.as_str()?.to_string();
    Some((key, meta.get("metrics").cloned().unwrap_or(Value::Null)))
}

struct StageReport {
    value: Value,
}

/// What a bake wrote: bytes, wall seconds, metrics.
struct Baked {
    bytes: u64,
    seconds: f64,
    metrics: Value,
}

/// The report of a stage whose output is keyed by `key`: "up-to-date" when the asset at
/// `output` already carries that key, "from-cache" when the shared cache has a valid entry
/// for it (copied to `output`), otherwise runs `bake` ("baked") and stores the result in the
/// shared cache. `cache.force` skips both lookups.
fn cached_or_bake(
    name: &str,
    kind: &str,
    output: &Path,
    key: &str,
    cache: &Cache,
    bake: impl FnOnce() -> Result<Baked, CliError>,
) -> Result<StageReport, CliError> {
    let start = Instant::now();
    let report = |status: &str, bytes: u64, seconds: f64, metrics: Value| {
        json!({
            "name": name, "kind": kind, "status": status,
            "output": output.display().to_string(), "cache_key": key,
            "bytes": bytes, "seconds": seconds, "metrics": metrics,
        })
    };
    let size = |p: &Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    if !cache.force {
        if let Some((existing, mut metrics)) = existing_cache_key(output) {
            let record = target_record(output, key, &existing);
            if existing == key || record.is_some() {
                if let (Some(rec), Some(m)) = (record, metrics.as_object_mut()) {
                    m.insert("target".into(), rec);
                }
                let mut value = report("up-to-date", size(output), start.elapsed().as_secs_f64(), metrics);
                if let Some(c) = cache.share_if_missing(key, output) {
                    value["cache"] = c;
                }
                return Ok(StageReport { value });
            }
        }
    }
    let (hit, mut shared) = cache.restore(key, output);
    if hit {
        let metrics = existing_cache_key(output).map_or(Value::Null, |(_, m)| m);
        let mut value = report("from-cache", size(output), start.elapsed().as_secs_f64(), metrics);
        value["cache"] = shared.unwrap_or(Value::Null);
        return Ok(StageReport { value });
    }
    let o = bake()?;
    let mut value = report("baked", o.bytes, o.seconds, o.metrics);
    if let Some(c) = shared.as_mut() {
        cache.store(key, output, c);
        value["cache"] = shared.unwrap_or(Value::Null);
    }
    Ok(StageReport { value })
}

/// Where a target stage records its search beside its output: the asset carries the key of
/// the knobs the search chose (its bytes are the plain bake's), the record ties it to the
/// stage's key (the target, the ladder and every other setting).
fn target_record_path(output: &Path) -> std::path::PathBuf {
    let name = output.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    output.with_file_name(format!("{name}.target.json"))
}

/// The search record of a target stage when it was made for `key` and the asset at the
/// output is still the one it chose (`asset_key`).
fn target_record(output: &Path, key: &str, asset_key: &str) -> Option<Value> {
    let text = std::fs::read_to_string(target_record_path(output)).ok()?;
    let v: Value = serde_json::from_str(&text).ok()?;
    (v["stage_key"] == key && v["asset_key"] == asset_key).then(|| v["search"].clone())
}

/// Writes the search record of a target stage and returns its `search` object (the keys
/// `target`, `metric`, `chosen`, `measured`, `target_met`, `search_seconds`,
/// `candidates_tried`, `reason`).
fn write_target_record(output: &Path, key: &str, report: &Value) -> Result<Value, CliError> {
    let mut search = serde_json::Map::new();
    for k in [
        "target",
        "metric",
        "method",
        "chosen",
        "measured",
        "target_met",
        "search_seconds",
        "candidates_tried",
        "reason",
    ] {
        if let Some(v) = report.get(k) {
            search.insert(k.into(), v.clone());
        }
    }
    let search = Value::Object(search);
    let rec = json!({"stage_key": key, "asset_key": report["cache_key"], "search": search});
    write_atomic_text(
        &target_record_path(output),
        &(serde_json::to_string_pretty(&rec).map_err(CliError::internal)? + "\n"),
    )?;
    Ok(search)
}

/// The key of a target stage: the plain stage key of its template, the target and the ladder.
fn target_stage_key(stage: &str, template_key: &str, target: f64, ladder: Value) -> String {
    let v = json!({"stage": format!("{stage}-target"), "template": template_key, "target": target, "ladder": ladder});
    blake3::hash(v.to_string().as_bytes()).to_hex().to_string()
}

fn run_tables(
    cfg: &penumbra_config::LoadedConfig,
    out_dir: &Path,
    cache: &Cache,
    mode: ProgressMode,
) -> Result<StageReport, CliError> {
    let Some(t) = &cfg.config.tables else {
        return Err(CliError::internal(anyhow!("tables stage selected but not configured")));
    };
    let env = match &t.env {
        Some(e) => Some(existing_file(cfg, "tables.env", "environment map", e)?),
        None => None,
    };
    let p = super::tables::params(
        t.order,
        t.theta_samples.unwrap_or(256),
        t.shading_tolerance.unwrap_or(1.0 / 256.0),
        env.as_deref(),
    )?;
    let output = out_dir.join(t.output_name());
    let key = super::tables::cache_key(&p);
    cached_or_bake("tables", "SHTB", &output, &key, cache, || {
        let o = super::tables::bake_to(&p, &output, mode)?;
        Ok(Baked { bytes: o.bytes, seconds: o.seconds, metrics: o.metrics })
    })
}

fn run_spheres(
    cfg: &penumbra_config::LoadedConfig,
    index: usize,
    out_dir: &Path,
    cache: &Cache,
    mode: ProgressMode,
) -> Result<StageReport, CliError> {
    use penumbra_spheres::fit::{FitParams, Target};
    let sp = &cfg.config.spheres[index];
    let mesh = existing_file(cfg, &format!("spheres[{index}].mesh"), "mesh", &sp.mesh)?;
    let target = match (sp.count, sp.target_error, sp.target_union) {
        (Some(n), _, _) => Target::Count(n as usize),
        (None, Some(e), _) => Target::Error(e),
        (None, None, Some(u)) => Target::Union(u),
        (None, None, None) => {
            return Err(CliError::internal(anyhow!("spheres[{index}] has no target (validated config)")));
        }
    };
    let mut params = FitParams::new(target);
    params.max_count = sp.max_count.map_or(params.max_count, |m| m as usize);
    params.method = match sp.method.unwrap_or(penumbra_config::SphereMethod::Lloyd) {
        penumbra_config::SphereMethod::Lloyd => penumbra_spheres::Method::Lloyd,
        penumbra_config::SphereMethod::Octree => penumbra_spheres::Method::Octree,
    };
    params.grid = sp.grid.map_or(params.grid, |g| g as usize);
    params.iterations = sp.iterations.map_or(params.iterations, |i| i as usize);
    params.seed = sp.seed.unwrap_or(params.seed);
    params.metrics.seed = params.seed;
    params.hierarchy = sp.hierarchy.unwrap_or(false);
    params.skin = sp.skin.unwrap_or(false);
    params.polish = sp.polish.unwrap_or(false);
    params.skin_padding = sp.skin_padding.unwrap_or(false);
    params.albedo = sp.albedo.map(|a| a.rgb());
    let job = super::spheres::SpheresJob {
        mesh: mesh.clone(),
        mesh_name: sp.mesh_name.clone(),
        nodes: sp.node.as_ref().map(penumbra_config::NodeSelect::patterns).unwrap_or_default(),
        params,
        output: out_dir.join(sp.output_name()),
    };
    let key = super::spheres::cache_key(&job, &crate::fsutil::hash_input(&mesh)?);
    cached_or_bake(&format!("spheres[{index}]"), "SPHR", &job.output, &key, cache, || {
        let o = super::spheres::bake_to(&job, mode)?;
        Ok(Baked { bytes: o.bytes, seconds: o.seconds, metrics: o.metrics })
    })
}

/// The config-relative path at `key`, resolved; exit 2 naming the config, the key and the
/// file when it does not exist.
fn existing_file(
    cfg: &penumbra_config::LoadedConfig,
    key: &str,
    what: &str,
    p: &str,
) -> Result<std::path::PathBuf, CliError> {
    let r = cfg.resolve(p);
    if r.is_file() {
        Ok(r)
    } else {
        Err(CliError::input(anyhow!("{}: `{key}`: {what} {} does not exist", cfg.path.display(), r.display())))
    }
}

fn run_fiv(
    cfg: &penumbra_config::LoadedConfig,
    index: usize,
    out_dir: &Path,
    cache: &Cache,
    mode: ProgressMode,
) -> Result<StageReport, CliError> {
    let Some(f) = cfg.config.fiv.get(index) else {
        return Err(CliError::internal(anyhow!("fiv stage {index} selected but not configured")));
    };
    let name = format!("fiv[{index}]");
    let mut specs = Vec::new();
    for (key, spec) in [("mesh", &f.mesh), ("env", &f.env)] {
        let resolved = super::fiv::resolve_spec(spec, |p| cfg.resolve(p));
        if !resolved.starts_with("builtin:") && !Path::new(&resolved).is_file() {
            return Err(CliError::input(anyhow!(
                "{}: `{name}.{key}`: file {resolved} does not exist",
                cfg.path.display()
            )));
        }
        specs.push(resolved);
    }
    let up = match f.up {
        Some(penumbra_config::UpAxis::Z) => penumbra_fiv::UpAxis::Z,
        _ => penumbra_fiv::UpAxis::Y,
    };
    use penumbra_geometry::env::Rotation;
    let rot = match f.env_rotate {
        Some(penumbra_config::EnvRotate::X180) => Rotation::X180,
        Some(penumbra_config::EnvRotate::Y180) => Rotation::Y180,
        Some(penumbra_config::EnvRotate::Z180) => Rotation::Z180,
        _ => Rotation::None,
    };
    let job = super::fiv::FivJob::new(
        &specs[0],
        &specs[1],
        rot,
        f.samples.unwrap_or([32, 17, 15]).map(|v| v as usize),
        f.r_min.unwrap_or(1.0),
        f.r_max.unwrap_or(8.0),
        up,
        f.cube_size.unwrap_or(32) as usize,
        f.irradiance_size.unwrap_or(32) as usize,
        f.half.unwrap_or(false),
    )?;
    let mut job = job;
    job.nodes = f.node.as_ref().map(penumbra_config::NodeSelect::patterns).unwrap_or_default();
    let output = out_dir.join(f.output_name());
    let key = super::fiv::cache_key(&job)?;
    if let Some(t) = f.target {
        let t = super::target::check_target(t, &format!("{name}.target"))?;
        let rungs: Vec<Value> =
            super::fiv_target::ladder(None).iter().map(|r| json!([r.samples, r.cube_size])).collect();
        let ladder = json!({"rungs": rungs, "receivers": super::fiv_target::RECEIVERS_PER_SIDE});
        let skey = target_stage_key("fiv", &key, t, ladder);
        return cached_or_bake(&name, "FIVT", &output, &skey, cache, || {
            let o = super::fiv_target::search(&job, t, None, &output, mode)?;
            let r = &o.report;
            let search = write_target_record(&output, &skey, r)?;
            Ok(Baked {
                bytes: r["bytes"].as_u64().unwrap_or(0),
                seconds: r["seconds"].as_f64().unwrap_or(0.0),
                metrics: json!({
                    "samples": r["samples"], "cube_size": r["cube_size"], "rays_traced": r["rays_traced"],
                    "rays_hit": r["rays_hit"], "inside_samples": r["inside_samples"], "fiv_bytes": r["fiv_bytes"],
                    "target": search,
                }),
            })
        });
    }
    cached_or_bake(&name, "FIVT", &output, &key, cache, || {
        let o = super::fiv::bake_to(&job, penumbra_fiv::Shard::WHOLE, &output, mode)?;
        let r = &o.report;
        Ok(Baked {
            bytes: r["bytes"].as_u64().unwrap_or(0),
            seconds: o.seconds,
            metrics: json!({
                "samples": r["samples"], "rays_traced": r["rays_traced"], "rays_hit": r["rays_hit"],
                "inside_samples": r["inside_samples"], "fiv_bytes": r["fiv_bytes"],
            }),
        })
    })
}

fn run_mrt(
    cfg: &penumbra_config::LoadedConfig,
    out_dir: &Path,
    cache: &Cache,
    mode: ProgressMode,
) -> Result<StageReport, CliError> {
    let Some(m) = &cfg.config.mrt else {
        return Err(CliError::internal(anyhow!("mrt stage selected but not configured")));
    };
    let mut o = super::mrt::DictOptions::from_stage(m);
    // only the shapes the level uses, when the level is the only reader of the dictionary
    let drt_example = cfg.config.drt.as_ref().is_some_and(|d| d.example.is_some());
    if let (Some(l), false, true) = (&cfg.config.mrt_level, drt_example, m.level_shapes_only.unwrap_or(true)) {
        let kind = o.dictionary.as_deref().and_then(penumbra_transport::shape::DictionaryKind::parse);
        let file = match &l.level {
            Some(p) => {
                Some(penumbra_config::level::load_level(&cfg.resolve(p)).map_err(|e| CliError::input(anyhow!("{e}")))?)
            }
            None => None,
        };
        let maze = l.maze.map(|n| (n as usize, l.seed.unwrap_or(0)));
        let names = super::mrt::level_shapes(
            kind.unwrap_or(penumbra_transport::shape::DictionaryKind::Cube2d),
            file.as_ref(),
            maze,
        )
        .map_err(|e| CliError::input(anyhow!("{}: [mrt_level]: {e}", cfg.path.display())))?;
        o.only = Some(names);
    }
    let p = super::mrt::params(&o)
        .map_err(|e| CliError { code: e.code, error: e.error.context(format!("{}: [mrt]", cfg.path.display())) })?;
    let output = out_dir.join(m.output_name());
    let key = super::mrt::cache_key(&p);
    cached_or_bake("mrt", "MRTD", &output, &key, cache, || {
        let o = super::mrt::bake_to(&p, &output, mode)?;
        Ok(Baked { bytes: o.bytes, seconds: o.seconds, metrics: o.metrics })
    })
}

fn run_mrt_level(cfg: &penumbra_config::LoadedConfig, out_dir: &Path, cache: &Cache) -> Result<StageReport, CliError> {
    use super::mrt_level::{LevelSource, bake, load_dict, resolve};
    let (Some(l), Some(m)) = (&cfg.config.mrt_level, &cfg.config.mrt) else {
        return Err(CliError::internal(anyhow!("mrt_level stage selected but not configured")));
    };
    let dict_path = out_dir.join(m.output_name());
    if !dict_path.exists() {
        return Err(CliError::input(anyhow!(
            "{}: [mrt_level] needs the dictionary {} (bake the [mrt] stage first)",
            cfg.path.display(),
            dict_path.display()
        )));
    }
    let d = load_dict(&dict_path)?;
    let level_path = l.level.as_deref().map(|p| cfg.resolve(p));
    let level_text = match &level_path {
        Some(p) => std::fs::read_to_string(p).with_context(|| format!("cannot read level {}", p.display()))?,
        None => String::new(),
    };
    let max_depth = l.max_depth.unwrap_or(penumbra_transport::level_ops::DEFAULT_MAX_DEPTH as u32) as usize;
    let key = blake3::hash(
        json!({"tool": env!("CARGO_PKG_VERSION"), "stage": "mrt_level", "level": level_text, "maze": l.maze,
               "seed": l.seed, "max_depth": max_depth, "dict": d.crc32c})
        .to_string()
        .as_bytes(),
    )
    .to_hex()
    .to_string();
    let output = out_dir.join(l.output_name());
    cached_or_bake("mrt_level", "MRTL", &output, &key, cache, || {
        let start = Instant::now();
        let src = LevelSource { maze: l.maze, seed: l.seed.unwrap_or(0), corridor: None, l_turn: None };
        let (level, links, _) = resolve(level_path.as_deref(), &src, &d)?;
        let (b, bytes) = bake(&level, &links, &d, max_depth, Some(key.clone()))?;
        penumbra_asset::write_file_atomic(&output, &bytes)
            .with_context(|| format!("cannot write {}", output.display()))?;
        let metrics = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
        Ok(Baked { bytes: bytes.len() as u64, seconds: start.elapsed().as_secs_f64(), metrics })
    })
}

fn run_drt(
    cfg: &penumbra_config::LoadedConfig,
    out_dir: &Path,
    cache: &Cache,
    mode: ProgressMode,
) -> Result<StageReport, CliError> {
    use super::drt::{DrtSceneArgs, bake_scene_stateful, cache_key, load_scene};
    use super::mrt_level::LevelSource;
    let (Some(d), Some(m)) = (&cfg.config.drt, &cfg.config.mrt) else {
        return Err(CliError::internal(anyhow!("drt stage selected but not configured")));
    };
    let dict = out_dir.join(m.output_name());
    let level = cfg.config.mrt_level.as_ref().map(|l| out_dir.join(l.output_name()));
    for p in std::iter::once(&dict).chain(level.iter().filter(|_| d.example.is_none())) {
        if !p.exists() {
            return Err(CliError::input(anyhow!(
                "{}: [drt] needs {} (bake the [mrt] and [mrt_level] stages first)",
                cfg.path.display(),
                p.display()
            )));
        }
    }
    let args = DrtSceneArgs {
        dict: Some(dict),
        level: if d.example.is_some() { None } else { level },
        source: LevelSource { maze: None, seed: 0, corridor: None, l_turn: None },
        example: d.example.clone(),
        boxes: 100,
        clutter: d.clutter.as_deref().map(|c| cfg.resolve(c)),
        clutter_res: d.clutter_res.unwrap_or(16),
        clutter_basis_res: d.clutter_basis_res.unwrap_or(2),
    };
    let sc = load_scene(&args)?;
    let defaults = penumbra_transport::drt::DrtParams::default();
    let params = penumbra_transport::drt::DrtParams {
        rays: d.rays.map_or(defaults.rays, |v| v as usize),
        clutter_rays: d.clutter_rays.or(d.rays).map_or(defaults.clutter_rays, |v| v as usize),
        neighborhood: d.neighborhood.map_or(defaults.neighborhood, |v| v as usize),
        k_c: d.kc.map_or(defaults.k_c, |v| v as usize),
        k_dc: d.kdc.map_or(defaults.k_dc, |v| v as usize),
        inpaint: d.inpaint.unwrap_or(true),
        vector_rays: d.vector_rays.map(|v| v as usize),
        volume_res: d.volume_res.map(|v| v as usize),
        clutter_res: args.clutter_res as usize,
        clutter_basis_res: args.clutter_basis_res as usize,
        ..defaults
    };
    let key = cache_key(&sc, &params);
    let output = out_dir.join(d.output_name());
    if let Some(t) = d.target {
        let t = super::target::check_target(t, "drt.target")?;
        let ladder = json!({"rays": super::drt_target::RAYS_RUNGS, "reference_rays": 512});
        let skey = target_stage_key("drt", &key, t, ladder);
        let dict_path = args.dict_path().to_path_buf();
        return cached_or_bake("drt", "DRTO", &output, &skey, cache, || {
            let o = super::drt_target::DrtTargetOptions {
                dict_path: &dict_path,
                lights: None,
                reference_rays: 512,
                max_rays: None,
                max_depth: 8,
            };
            let out = super::drt_target::search(&sc, &params, t, &o, &output, mode)?;
            let r = &out.report;
            let mut rr = r.clone();
            rr["cache_key"] = json!(cache_key(
                &sc,
                &penumbra_transport::drt::DrtParams {
                    rays: r["chosen"]["rays"].as_u64().unwrap_or(0) as usize,
                    clutter_rays: r["chosen"]["clutter_rays"].as_u64().unwrap_or(0) as usize,
                    ..params.clone()
                }
            ));
            let search = write_target_record(&output, &skey, &rr)?;
            let mut metrics = r.clone();
            for k in [
                "target",
                "metric",
                "method",
                "chosen",
                "measured",
                "target_met",
                "search_seconds",
                "candidates_tried",
                "reason",
            ] {
                if let Some(m) = metrics.as_object_mut() {
                    m.remove(k);
                }
            }
            metrics["target"] = search;
            Ok(Baked {
                bytes: r["bytes"].as_u64().unwrap_or(0),
                seconds: r["seconds"].as_f64().unwrap_or(0.0),
                metrics,
            })
        });
    }
    // the rays' sums beside the asset: moving clutter re-bakes only the rays it touches
    let state = out_dir.join(format!("{}.state", d.output_name()));
    cached_or_bake("drt", "DRTO", &output, &key, cache, || {
        let start = Instant::now();
        let (b, bytes, sb, inc, _) = bake_scene_stateful(&sc, &params, &state, &output, mode)?;
        penumbra_asset::write_file_atomic(&output, &bytes)
            .with_context(|| format!("cannot write {}", output.display()))?;
        penumbra_asset::write_file_atomic(&state, &sb).with_context(|| format!("cannot write {}", state.display()))?;
        let mut metrics = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
        metrics["incremental"] = inc;
        Ok(Baked { bytes: bytes.len() as u64, seconds: start.elapsed().as_secs_f64(), metrics })
    })
}

fn run_vo(
    cfg: &penumbra_config::LoadedConfig,
    out_dir: &Path,
    cache: &Cache,
    mode: ProgressMode,
) -> Result<StageReport, CliError> {
    let Some(v) = &cfg.config.vo else {
        return Err(CliError::internal(anyhow!("vo stage selected but not configured")));
    };
    let d = penumbra_vo::VoParams::default();
    let p = penumbra_vo::VoParams {
        counts: v.counts.as_ref().map_or(d.counts.clone(), |c| c.iter().map(|&n| n as usize).collect()),
        seed: v.seed.unwrap_or(d.seed),
        starts: v.starts.map_or(d.starts, |s| s as usize),
        noise_trials: v.noise_trials.map_or(d.noise_trials, |s| s as usize),
        ..d
    };
    let output = out_dir.join(v.output_name());
    let key = super::vo::cache_key(&p);
    cached_or_bake("vo", "VOSS", &output, &key, cache, || {
        let o = super::vo::bake_to(&p, &output, mode, Some(key.clone()))?;
        let seconds = o.report["seconds"].as_f64().unwrap_or(0.0);
        Ok(Baked { bytes: o.bytes, seconds, metrics: o.report })
    })
}

/// Parses a verify command's arguments from `argv` (its defaults for everything not given),
/// as the command line would.
fn verify_args<A: clap::Args + clap::FromArgMatches>(argv: &[std::ffi::OsString]) -> Result<A, CliError> {
    let cmd = A::augment_args(clap::Command::new("verify").no_binary_name(true));
    let m = cmd.try_get_matches_from(argv).map_err(|e| CliError::internal(anyhow!("stage gate arguments: {e}")))?;
    A::from_arg_matches(&m).map_err(|e| CliError::internal(anyhow!("stage gate arguments: {e}")))
}

fn os(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<std::ffi::OsString> {
    args.iter().map(|a| a.as_ref().to_os_string()).collect()
}

/// The gate of stage `name` (item `index`) when it declares one: runs the stage's verify on
/// its output with the verify's defaults and the gate's bounds. `{verify, passed, failures,
/// measured, report}`; `failures` are `{gate, metric, value, max}`.
fn run_gate(
    cfg: &penumbra_config::LoadedConfig,
    name: &str,
    index: usize,
    out_dir: &Path,
    mode: ProgressMode,
) -> Result<Option<Value>, CliError> {
    use super::gate::{Gate, apply};
    let c = &cfg.config;
    let (verify, gates, report) = match name {
        "fiv" => {
            let Some(g) = c.fiv.get(index).and_then(|f| f.gate.as_ref()) else { return Ok(None) };
            let out = out_dir.join(c.fiv[index].output_name());
            let a: crate::args::VerifyFivArgs = verify_args(&os(&[&"--fiv", &out, &"--plane"]))?;
            let (_, v) = super::verify_fiv::run_report(&a)?;
            let gates = vec![
                Gate { key: "max_nrmse", metric: "nrmse", max: g.max_nrmse },
                Gate { key: "max_nrmse_visible", metric: "nrmse_visible", max: g.max_nrmse_visible },
            ];
            ("verify fiv --plane", gates, v)
        }
        "mrt_level" => {
            let (Some(l), Some(m)) = (&c.mrt_level, &c.mrt) else { return Ok(None) };
            let Some(g) = &l.gate else { return Ok(None) };
            let (level, dict) = (out_dir.join(l.output_name()), out_dir.join(m.output_name()));
            let a: super::verify_mrt::VerifyMrtArgs = verify_args(&os(&[&"--level", &level, &"--dict", &dict]))?;
            let (_, v) = super::verify_mrt::run_report(&a, mode)?;
            (
                "verify mrt",
                vec![Gate { key: "max_rel_error", metric: "rel_error_one_bounce", max: Some(g.max_rel_error) }],
                v,
            )
        }
        "drt" => {
            let (Some(d), Some(m)) = (&c.drt, &c.mrt) else { return Ok(None) };
            let Some(g) = &d.gate else { return Ok(None) };
            let dict = out_dir.join(m.output_name());
            let drt = out_dir.join(d.output_name());
            let mut argv = os(&[&"--dict", &dict, &"--drt", &drt]);
            match (&d.example, &c.mrt_level) {
                (Some(e), _) => argv.extend(os(&[&"--example", e])),
                (None, Some(l)) => argv.extend(os(&[&"--level", &out_dir.join(l.output_name())])),
                (None, None) => {}
            }
            if let Some(cl) = &d.clutter {
                argv.extend(os(&[&"--clutter", &cfg.resolve(cl)]));
            }
            let (r, b) = (d.clutter_res.unwrap_or(16).to_string(), d.clutter_basis_res.unwrap_or(2).to_string());
            argv.extend(os(&[&"--clutter-res", &r, &"--clutter-basis-res", &b]));
            let a: super::verify_drt::VerifyDrtArgs = verify_args(&argv)?;
            let (_, v) = super::verify_drt::run_report(&a, mode)?;
            (
                "verify drt",
                vec![Gate { key: "max_rel_error", metric: "rel_error_mrt_drt", max: Some(g.max_rel_error) }],
                v,
            )
        }
        "vo" => {
            let Some(vo) = &c.vo else { return Ok(None) };
            let Some(g) = &vo.gate else { return Ok(None) };
            let mesh = existing_file(cfg, "vo.gate.mesh", "mesh", &g.mesh)?;
            let sets = out_dir.join(vo.output_name());
            let method = g.method.clone().unwrap_or_else(|| "lines:9".into());
            let a: super::verify_vo::VerifyVoArgs =
                verify_args(&os(&[&"--mesh", &mesh, &"--sets", &sets, &"--method", &method]))?;
            let (_, v) = super::verify_vo::run_report(&a)?;
            ("verify vo", vec![Gate { key: "max_rmse", metric: "rmse_vs_volume", max: Some(g.max_rmse) }], v)
        }
        _ => return Ok(None),
    };
    let mut report = report;
    let failures = apply(&mut report, &gates);
    let measured: serde_json::Map<String, Value> =
        gates.iter().filter(|g| g.max.is_some()).map(|g| (g.metric.to_string(), report[g.metric].clone())).collect();
    Ok(Some(json!({
        "verify": verify,
        "passed": failures.is_empty(),
        "bounds": gates.iter().filter_map(|g| g.max.map(|m| (g.key.to_string(), json!(m)))).collect::<serde_json::Map<_, _>>(),
        "measured": measured,
        "failures": failures.iter().map(super::gate::Failure::to_json).collect::<Vec<_>>(),
        "report": report,
    })))
}

/// Runs `penumbra bake`.
#[allow(clippy::print_stderr)]
pub fn run(a: &BakeArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    if let Some(crate::args::BakeCommand::Merge(m)) = &a.command {
        return super::bake_merge::run(m);
    }
    let start = Instant::now();
    let config = a.config.as_deref().ok_or_else(|| CliError::input(anyhow!("give a bake config")))?;
    let cfg = penumbra_config::load(config).map_err(CliError::input)?;
    // work items: (stage, entry index)
    let mut items: Vec<(&str, usize)> = Vec::new();
    if cfg.config.tables.is_some() {
        items.push(("tables", 0));
    }
    items.extend((0..cfg.config.spheres.len()).map(|i| ("spheres", i)));
    items.extend((0..cfg.config.fiv.len()).map(|i| ("fiv", i)));
    if cfg.config.mrt.is_some() {
        items.push(("mrt", 0));
    }
    if cfg.config.mrt_level.is_some() {
        items.push(("mrt_level", 0));
    }
    if cfg.config.drt.is_some() {
        items.push(("drt", 0));
    }
    if cfg.config.vo.is_some() {
        items.push(("vo", 0));
    }
    let configured: Vec<&str> = STAGES.iter().copied().filter(|s| items.iter().any(|(n, _)| n == s)).collect();
    if let Some(only) = &a.only {
        if !STAGES.contains(&only.as_str()) {
            return Err(CliError::input(anyhow!("--only {only:?}: unknown stage (stages: {})", STAGES.join(", "))));
        }
        if !configured.contains(&only.as_str()) {
            return Err(CliError::input(anyhow!("--only {only:?}: {} has no [{only}] stage", config.display())));
        }
    }
    let shard = a.shard.as_deref().map(parse_shard).transpose()?;
    let out_dir: PathBuf = a.output_dir.clone().unwrap_or_else(|| cfg.output_dir());
    // a stage that reads another's output runs in the same shard: `mrt_level` and `drt` go
    // with `mrt` (their dictionary)
    let head = items.iter().position(|(n, _)| *n == "mrt");
    let slot = |item: usize| match (items[item].0, head) {
        ("mrt_level" | "drt", Some(h)) => h,
        _ => item,
    };
    std::fs::create_dir_all(&out_dir)
        .with_context(|| format!("cannot create output directory {}", out_dir.display()))?;

    let cache = Cache { dir: a.cache_dir.clone(), read_only: a.cache_read_only, force: a.force };
    let mut stages = Vec::new();
    let mut failed_gates: Vec<Value> = Vec::new();
    for (item, &(name, index)) in items.iter().enumerate() {
        let label = if name == "spheres" || name == "fiv" { format!("{name}[{index}]") } else { name.to_string() };
        let skip = |status: &str| json!({"name": label, "status": status});
        if a.only.as_deref().is_some_and(|o| o != name) {
            stages.push(skip("skipped-by-only"));
            continue;
        }
        if let Some((k, n)) = shard {
            if slot(item) % n != k {
                stages.push(skip("skipped-by-shard"));
                continue;
            }
        }
        let mut r = match name {
            "tables" => run_tables(&cfg, &out_dir, &cache, mode)?,
            "spheres" => run_spheres(&cfg, index, &out_dir, &cache, mode)?,
            "fiv" => run_fiv(&cfg, index, &out_dir, &cache, mode)?,
            "mrt" => run_mrt(&cfg, &out_dir, &cache, mode)?,
            "mrt_level" => run_mrt_level(&cfg, &out_dir, &cache)?,
            "drt" => run_drt(&cfg, &out_dir, &cache, mode)?,
            "vo" => run_vo(&cfg, &out_dir, &cache, mode)?,
            other => return Err(CliError::internal(anyhow!("stage {other} has no runner"))),
        };
        if !a.json {
            eprintln!(
                "{:<11} {:<10} {} ({:.2} s)",
                label,
                r.value["status"].as_str().unwrap_or(""),
                r.value["output"].as_str().unwrap_or(""),
                r.value["seconds"].as_f64().unwrap_or(0.0)
            );
        }
        // a target no rung met: the best asset is kept, and the bake fails like a gate
        let tg = &r.value["metrics"]["target"];
        if tg["target_met"] == false {
            failed_gates.push(json!({"stage": label, "gate": "target", "metric": tg["metric"],
                                     "value": tg["measured"], "max": tg["target"]}));
            if !a.json {
                eprintln!("{:<11} target not met: {}", label, tg["reason"].as_str().unwrap_or(""));
            }
        }
        if let Some(g) = run_gate(&cfg, name, index, &out_dir, mode)? {
            for f in g["failures"].as_array().into_iter().flatten() {
                failed_gates.push(json!({"stage": label, "gate": f["gate"], "metric": f["metric"],
                                         "value": f["value"], "max": f["max"]}));
            }
            if !a.json {
                let what = if g["passed"] == true { "passed" } else { "FAILED" };
                let m: Vec<String> = g["measured"]
                    .as_object()
                    .into_iter()
                    .flatten()
                    .map(|(k, v)| format!("{k} {}", v.as_f64().map_or("null".into(), |x| format!("{x:.6}"))))
                    .collect();
                eprintln!("{:<11} gate {what} ({}: {})", label, g["verify"].as_str().unwrap_or(""), m.join(", "));
            }
            r.value["gate"] = g;
        }
        stages.push(r.value);
    }
    let report = json!({
        "config": config.display().to_string(),
        "output_dir": out_dir.display().to_string(),
        "shard": a.shard,
        "stages": stages,
        "gates_passed": failed_gates.is_empty(),
        "failed_gates": failed_gates,
        "seconds": start.elapsed().as_secs_f64(),
    });
    let report_path = match shard {
        Some((k, n)) => out_dir.join(format!("report.shard-{k}-of-{n}.json")),
        None => out_dir.join("report.json"),
    };
    write_atomic_text(&report_path, &(serde_json::to_string_pretty(&report).map_err(CliError::internal)? + "\n"))?;
    if a.json {
        print_json(&report);
    } else {
        eprintln!("report: {}", report_path.display());
    }
    for f in &failed_gates {
        eprintln!(
            "quality gate failed: {}: {} {} > {} {} (asset kept)",
            f["stage"].as_str().unwrap_or(""),
            f["metric"].as_str().unwrap_or(""),
            f["value"],
            f["gate"].as_str().unwrap_or(""),
            f["max"]
        );
    }
    Ok(if failed_gates.is_empty() { ExitCode::Ok } else { ExitCode::QualityGate })
}
