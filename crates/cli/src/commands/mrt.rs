//! `penumbra mrt …`: Modular Radiance Transfer bakes. `mrt dict` bakes a dictionary (MRT
//! thesis ch. 3–4, App. A–B); `mrt level` (block layouts, §3.5.3) is in `mrt_level.rs`.

use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use crate::progress::{ProgressMode, Reporter};
use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};
use penumbra_transport::TransportError;
use penumbra_transport::asset::to_asset;
use penumbra_transport::dict::{DictParams, bake};
use penumbra_transport::gather::Gather;
use penumbra_transport::prior::LightLayout;
use penumbra_transport::shape::DictionaryKind;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `penumbra mrt`.
#[derive(Debug, Args)]
pub struct MrtArgs {
    /// MRT bake.
    #[command(subcommand)]
    pub command: MrtCommand,
}

/// MRT bakes.
#[derive(Debug, Subcommand)]
pub enum MrtCommand {
    /// Bake an MRT dictionary: light prior, one-bounce transport, U_b, T_d→b, vector
    /// irradiance, volume probes, enrichment (MRT thesis ch. 3–4, App. A–B).
    Dict(MrtDictArgs),
    /// Bake a level's operators: T_b→r by breadth-first propagation through the block
    /// layout's interfaces, and the padded light-map atlas (MRT thesis §3.5.3, §4.3, §4.6).
    Level(crate::commands::mrt_level::MrtLevelArgs),
}

/// Dictionaries (`--dictionary`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DictionaryArg {
    /// The 2D cube dictionary: six cubes with floor and ceiling and 0–4 side faces missing.
    Cube2d,
    /// The closed cube only (Table 3.2's setting).
    ClosedCube,
}

/// Gathers (`--gather`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GatherArg {
    /// Bilinear reads of the hit face's texels (the thesis's gather).
    Bilinear,
    /// Exact point-to-texel form factors (no rays).
    Exact,
}

/// Prior light layouts (`--light-layout`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LayoutArg {
    /// Six lights per axis at i/7, i = 1..6.
    Lattice,
    /// Six lights per axis at the cell centres (i+½)/6.
    Cells,
}

fn parse_unit_open(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v <= 1.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < A <= 1)")) }
}

fn parse_radius(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v <= 0.08 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < r <= 0.08)")) }
}

/// `penumbra mrt dict`.
#[derive(Debug, Args)]
pub struct MrtDictArgs {
    /// Which dictionary.
    #[arg(long, value_enum, default_value_t = DictionaryArg::Cube2d)]
    pub dictionary: DictionaryArg,
    /// Texels per face edge.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=24))]
    pub face_res: u32,
    /// Light-prior vectors k_d.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub kd: u32,
    /// Indirect modes k_b (at most k_d).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub kb: u32,
    /// Gather rays per texel for the one-bounce operator F.
    #[arg(long, default_value_t = 16384, value_parser = clap::value_parser!(u32).range(16..=1_048_576))]
    pub rays: u32,
    /// Diffuse albedo in F.
    #[arg(long, default_value = "1", value_parser = parse_unit_open)]
    pub albedo: f64,
    /// Enrichment iterations (App. A).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=8))]
    pub enrich: u32,
    /// Face-restricted prior vectors per face in the enrichment fallback (0 = face constants
    /// only, as in the thesis; at most k_d).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(0..=256))]
    pub fallback_modes: u32,
    /// How a gather reads the texels it hits.
    #[arg(long, value_enum, default_value_t = GatherArg::Bilinear)]
    pub gather: GatherArg,
    /// Keep the collocated F as gathered (no energy balance; column sums may exceed the
    /// albedo next to cube corners, docs/mrt.md "Energy").
    #[arg(long)]
    pub no_balance: bool,
    /// Record the plain runtime rule l_ind = U_b·b (the thesis's) instead of the same-face
    /// exclusion (a face's own direct light does not reach itself; docs/mrt.md). Use it
    /// with --enrich 0: the exclusion needs the enrichment's face-local prior vectors.
    #[arg(long)]
    pub keep_same_face: bool,
    /// Where the prior's sphere lights sit.
    #[arg(long, value_enum, default_value_t = LayoutArg::Lattice)]
    pub light_layout: LayoutArg,
    /// Sphere-light radius (cube edge = 1).
    #[arg(long, default_value = "0.05", value_parser = parse_radius)]
    pub light_radius: f64,
    /// Rays per texel of the vector-irradiance (U_b⃗) gather.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=65536))]
    pub vector_rays: u32,
    /// Volume probes per axis (U_bvol grid).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub volume_res: u32,
    /// Rays per volume probe.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(16..=65536))]
    pub probe_rays: u32,
    /// Lights per shape for the error measurements.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub test_lights: u32,
    /// Rays per texel of the path-traced reference.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(2..=65536))]
    pub reference_rays: u32,
    /// Seed of every hashed random draw.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Skip the interface operators (a dictionary that cannot light levels; faster).
    #[arg(long)]
    pub no_interfaces: bool,
    /// Bake only the shapes this level file (.toml) uses, and the closed cube (Table 3.2 and
    /// App. A are measured on it): the interfaces follow the shapes.
    #[arg(long, value_name = "LEVEL.toml")]
    pub for_level: Option<PathBuf>,
    /// Reduced lightfield modes k_rlf (thesis: 128).
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=512))]
    pub k_rlf: u32,
    /// Interface response modes k_r (thesis: 32; at most k_rlf).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=512))]
    pub k_r: u32,
    /// Lightfield spatial samples per interface edge (thesis: 12).
    #[arg(long, default_value_t = 12, value_parser = clap::value_parser!(u32).range(2..=32))]
    pub lf_spatial: u32,
    /// Lightfield directional samples per edge of the concentric square (thesis: 24).
    #[arg(long, default_value_t = 24, value_parser = clap::value_parser!(u32).range(2..=64))]
    pub lf_dir: u32,
    /// Directional supersamples per cell edge (thesis: 5).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub lf_super: u32,
    /// Enrichment iterations of the reduced lightfield basis (thesis: 3).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=8))]
    pub interface_enrich: u32,
    /// Cosine gather rays per texel for the interface response G.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=65536))]
    pub response_rays: u32,
    /// Skip the interfaces' vector and volume response U_r⃗, U_rvol (MRTD kind_version 3
    /// bytes, as before they existed).
    #[arg(long)]
    pub no_interface_vectors: bool,
    /// Output asset (.mrtd). Parent directories are created.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print one JSON object with the metrics on stdout.
    #[arg(long)]
    pub json: bool,
}

/// What a dictionary bake produced.
#[derive(Debug)]
pub struct DictOutcome {
    /// Metrics as JSON (the `--json` keys without bytes/seconds/output).
    pub metrics: serde_json::Value,
    /// Bytes written.
    pub bytes: u64,
    /// Wall time.
    pub seconds: f64,
    /// Wall time of the interface bake.
    pub interface_seconds: f64,
}

/// Parameter values as given on the command line or in a config (`None` = default).
#[derive(Debug, Clone, Default)]
pub struct DictOptions {
    /// `cube2d` / `closed-cube`.
    pub dictionary: Option<String>,
    /// Texels per face edge.
    pub face_res: Option<u32>,
    /// k_d.
    pub kd: Option<u32>,
    /// k_b.
    pub kb: Option<u32>,
    /// Rays of F.
    pub rays: Option<u32>,
    /// Albedo.
    pub albedo: Option<f64>,
    /// Enrichment iterations.
    pub enrich: Option<u32>,
    /// Fallback modes.
    pub fallback_modes: Option<u32>,
    /// `bilinear` / `exact`.
    pub gather: Option<String>,
    /// Energy balance of F.
    pub balance: Option<bool>,
    /// Same-face exclusion rule.
    pub exclude_same_face: Option<bool>,
    /// `lattice` / `cells`.
    pub light_layout: Option<String>,
    /// Light radius.
    pub light_radius: Option<f64>,
    /// Vector-irradiance rays.
    pub vector_rays: Option<u32>,
    /// Probes per axis.
    pub volume_res: Option<u32>,
    /// Rays per probe.
    pub probe_rays: Option<u32>,
    /// Test lights.
    pub test_lights: Option<u32>,
    /// Reference rays.
    pub reference_rays: Option<u32>,
    /// Seed.
    pub seed: Option<u64>,
    /// Interfaces on/off.
    pub interfaces: Option<bool>,
    /// k_rlf.
    pub k_rlf: Option<u32>,
    /// k_r.
    pub k_r: Option<u32>,
    /// Lightfield spatial resolution.
    pub lf_spatial: Option<u32>,
    /// Lightfield directional resolution.
    pub lf_dir: Option<u32>,
    /// Directional supersampling.
    pub lf_super: Option<u32>,
    /// Interface enrichment iterations.
    pub interface_enrich: Option<u32>,
    /// Response gather rays.
    pub response_rays: Option<u32>,
    /// Interface vector and volume response on/off.
    pub interface_vectors: Option<bool>,
    /// Only these shapes (and the closed cube); `None`: all.
    pub only: Option<Vec<String>>,
}

impl DictOptions {
    /// The options of a bake config's `[mrt]` stage.
    pub fn from_stage(m: &penumbra_config::MrtStage) -> Self {
        Self {
            dictionary: m.dictionary.clone(),
            face_res: m.face_res,
            kd: m.kd,
            kb: m.kb,
            rays: m.rays,
            albedo: m.albedo,
            enrich: m.enrich,
            fallback_modes: m.fallback_modes,
            gather: m.gather.clone(),
            balance: m.balance,
            exclude_same_face: m.exclude_same_face,
            light_layout: m.light_layout.clone(),
            light_radius: m.light_radius,
            vector_rays: m.vector_rays,
            volume_res: m.volume_res,
            probe_rays: m.probe_rays,
            test_lights: m.test_lights,
            reference_rays: m.reference_rays,
            seed: m.seed,
            interfaces: m.interfaces,
            k_rlf: m.k_rlf,
            k_r: m.k_r,
            lf_spatial: m.lf_spatial,
            lf_dir: m.lf_dir,
            lf_super: m.lf_super,
            interface_enrich: m.interface_enrich,
            response_rays: m.response_rays,
            interface_vectors: m.interface_vectors,
            only: None,
        }
    }
}

/// The dictionary shapes a level uses, by name, in first-use order: a level file's blocks, or
/// the blocks of a generated maze (resolved against the whole `dictionary`, as `mrt level`
/// resolves it).
pub fn level_shapes(
    dictionary: DictionaryKind,
    file: Option<&penumbra_config::level::LevelFile>,
    maze: Option<(usize, u64)>,
) -> Result<Vec<String>, String> {
    let mut names: Vec<String> = match (file, maze) {
        (Some(f), _) => f.blocks.iter().map(|b| b.shape.clone()).collect(),
        (None, Some((n, seed))) => {
            let shapes = dictionary.shapes();
            let missing: Vec<u8> = shapes.iter().map(|s| s.missing).collect();
            let level = penumbra_transport::level::maze(n, seed, &missing).map_err(|e| format!("maze {n}: {e}"))?;
            level.blocks.iter().map(|b| shapes[b.shape].name.to_string()).collect()
        }
        (None, None) => return Err("no level".into()),
    };
    let mut seen = std::collections::BTreeSet::new();
    names.retain(|n| seen.insert(n.clone()));
    Ok(names)
}

/// Builds and validates the parameters (defaults filled in).
pub fn params(o: &DictOptions) -> Result<DictParams, CliError> {
    let bad = |what: &str, v: &str, allowed: &str| {
        CliError::input(anyhow::anyhow!("{what} {v:?} is not valid (allowed: {allowed})"))
    };
    let dictionary = match o.dictionary.as_deref() {
        None => DictionaryKind::Cube2d,
        Some(s) => DictionaryKind::parse(s).ok_or_else(|| bad("dictionary", s, "cube2d, closed-cube"))?,
    };
    let mut p = DictParams::new(dictionary);
    let set = |dst: &mut usize, v: Option<u32>| {
        if let Some(v) = v {
            *dst = v as usize;
        }
    };
    set(&mut p.face_res, o.face_res);
    set(&mut p.k_d, o.kd);
    set(&mut p.k_b, o.kb);
    set(&mut p.rays, o.rays);
    set(&mut p.enrich, o.enrich);
    set(&mut p.fallback_modes, o.fallback_modes);
    set(&mut p.vector_rays, o.vector_rays);
    set(&mut p.volume_res, o.volume_res);
    set(&mut p.probe_rays, o.probe_rays);
    set(&mut p.test_lights, o.test_lights);
    set(&mut p.reference_rays, o.reference_rays);
    if let Some(a) = o.albedo {
        p.albedo = a;
    }
    if let Some(r) = o.light_radius {
        p.light_radius = r;
    }
    if let Some(s) = o.seed {
        p.seed = s;
    }
    if let Some(b) = o.balance {
        p.balance = b;
    }
    if let Some(x) = o.exclude_same_face {
        p.exclude_same_face = x;
    }
    if let Some(x) = o.interfaces {
        p.interfaces = x;
    }
    if let Some(x) = o.interface_vectors {
        p.interface_vectors = x;
    }
    p.only = o.only.clone();
    set(&mut p.interface.k_rlf, o.k_rlf);
    set(&mut p.interface.k_r, o.k_r);
    set(&mut p.interface.grid.spatial, o.lf_spatial);
    set(&mut p.interface.grid.dir, o.lf_dir);
    set(&mut p.interface.grid.sub, o.lf_super);
    set(&mut p.interface.enrich, o.interface_enrich);
    set(&mut p.interface.response_rays, o.response_rays);
    if let Some(g) = o.gather.as_deref() {
        p.gather = Gather::parse(g).ok_or_else(|| bad("gather", g, "bilinear, exact"))?;
    }
    if let Some(l) = o.light_layout.as_deref() {
        p.layout = LightLayout::parse(l).ok_or_else(|| bad("light layout", l, "lattice, cells"))?;
    }
    p.validate().map_err(CliError::input)?;
    Ok(p)
}

/// Normalised parameters of a dictionary bake, hashed for the cache key.
pub fn cache_key(p: &DictParams) -> String {
    let v = json!({"tool": env!("CARGO_PKG_VERSION"), "stage": "mrt", "params": p.to_json()});
    blake3::hash(v.to_string().as_bytes()).to_hex().to_string()
}

fn classify(e: TransportError) -> CliError {
    match e {
        TransportError::Param(_) => CliError::input(e),
        other => CliError::internal(other),
    }
}

/// Bakes and writes the asset atomically.
pub fn bake_to(p: &DictParams, output: &Path, mode: ProgressMode) -> Result<DictOutcome, CliError> {
    let start = Instant::now();
    let reporter = Reporter::new("mrt dict", mode);
    let b = bake(p, &reporter).map_err(classify)?;
    reporter.finish();
    let asset = to_asset(&b, Some(&cache_key(p))).map_err(CliError::internal)?;
    ensure_parent(output)?;
    let bytes = asset.write_atomic(output).with_context(|| format!("cannot write {}", output.display()))?;
    let mut metrics = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
    let baked: Vec<&str> = p.shapes().iter().map(|(_, s)| s.name).collect();
    metrics["shapes_baked"] = json!(baked);
    Ok(DictOutcome { metrics, bytes, seconds: start.elapsed().as_secs_f64(), interface_seconds: b.interface_seconds })
}

/// Runs `penumbra mrt …`.
pub fn run(a: &MrtArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    match &a.command {
        MrtCommand::Dict(d) => run_dict(d, mode),
        MrtCommand::Level(l) => crate::commands::mrt_level::run(l),
    }
}

#[allow(clippy::print_stderr)]
fn run_dict(a: &MrtDictArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let o = DictOptions {
        dictionary: Some(match a.dictionary {
            DictionaryArg::Cube2d => "cube2d".into(),
            DictionaryArg::ClosedCube => "closed-cube".into(),
        }),
        face_res: Some(a.face_res),
        kd: Some(a.kd),
        kb: Some(a.kb),
        rays: Some(a.rays),
        albedo: Some(a.albedo),
        enrich: Some(a.enrich),
        fallback_modes: Some(a.fallback_modes),
        gather: Some(
            match a.gather {
                GatherArg::Bilinear => "bilinear",
                GatherArg::Exact => "exact",
            }
            .into(),
        ),
        balance: Some(!a.no_balance),
        exclude_same_face: Some(!a.keep_same_face),
        light_layout: Some(
            match a.light_layout {
                LayoutArg::Lattice => "lattice",
                LayoutArg::Cells => "cells",
            }
            .into(),
        ),
        light_radius: Some(a.light_radius),
        vector_rays: Some(a.vector_rays),
        volume_res: Some(a.volume_res),
        probe_rays: Some(a.probe_rays),
        test_lights: Some(a.test_lights),
        reference_rays: Some(a.reference_rays),
        seed: Some(a.seed),
        interfaces: Some(!a.no_interfaces),
        k_rlf: Some(a.k_rlf),
        k_r: Some(a.k_r),
        lf_spatial: Some(a.lf_spatial),
        lf_dir: Some(a.lf_dir),
        lf_super: Some(a.lf_super),
        interface_enrich: Some(a.interface_enrich),
        response_rays: Some(a.response_rays),
        interface_vectors: Some(!a.no_interface_vectors),
        only: match &a.for_level {
            Some(path) => {
                let f =
                    penumbra_config::level::load_level(path).map_err(|e| CliError::input(anyhow::anyhow!("{e}")))?;
                let kind = match a.dictionary {
                    DictionaryArg::Cube2d => DictionaryKind::Cube2d,
                    DictionaryArg::ClosedCube => DictionaryKind::ClosedCube,
                };
                let names = level_shapes(kind, Some(&f), None).map_err(|e| CliError::input(anyhow::anyhow!(e)))?;
                Some(names)
            }
            None => None,
        },
    };
    let p = params(&o).map_err(|e| match &a.for_level {
        Some(path) => CliError { code: e.code, error: e.error.context(format!("--for-level {}", path.display())) },
        None => e,
    })?;
    let out = bake_to(&p, &a.output, mode)?;
    let mut v = out.metrics.clone();
    if let Some(obj) = v.as_object_mut() {
        obj.insert("bytes".into(), json!(out.bytes));
        obj.insert("seconds".into(), json!(out.seconds));
        obj.insert("interface_seconds".into(), json!(out.interface_seconds));
        obj.insert("output".into(), json!(a.output.display().to_string()));
    }
    if a.json {
        print_json(&v);
    } else {
        let m = &out.metrics;
        let t = &m["table_3_2"];
        eprintln!(
            "wrote {} ({} bytes) in {:.2} s\n  Table 3.2 (closed cube, n = {}): F {}  L_d {}  M {}   (thesis: F 164/240/313, L_d 22/41/62, M 1/5/8)\n  App. A (five red faces), white-face error: {:.3} neither, {:.3} enrichment only, {:.3} same-face exclusion only, {:.3} both\n  floor and ceiling white, green error: {:.3} neither, {:.3} enrichment only, {:.3} exclusion only, {:.3} both",
            a.output.display(),
            out.bytes,
            out.seconds,
            t["n"],
            t["F"],
            t["L_d"],
            t["M"],
            m["enrichment_rel_error_before"].as_f64().unwrap_or(f64::NAN),
            m["enrichment_rel_error_enriched_only"].as_f64().unwrap_or(f64::NAN),
            m["enrichment_rel_error_excluded_only"].as_f64().unwrap_or(f64::NAN),
            m["enrichment_rel_error_after"].as_f64().unwrap_or(f64::NAN),
            m["enrichment"]["two_white"]["green_rel_error_before"].as_f64().unwrap_or(f64::NAN),
            m["enrichment"]["two_white"]["green_rel_error_enriched"].as_f64().unwrap_or(f64::NAN),
            m["enrichment"]["two_white"]["green_rel_error_excluded"].as_f64().unwrap_or(f64::NAN),
            m["enrichment"]["two_white"]["green_rel_error_enriched_excluded"].as_f64().unwrap_or(f64::NAN),
        );
        if let Some(im) = m["interface_metrics"].as_object() {
            eprintln!(
                "  interfaces: {} openings, k_rlf {}, k_r {} in {:.2} s; lightfield outside H_rlf {:.3}, propagated outside {:.3}/{:.3}/{:.3}, response outside U_r {:.3}",
                m["interfaces"].as_array().map_or(0, Vec::len),
                m["k_rlf"],
                m["k_r"],
                out.interface_seconds,
                im["lightfield_rel_error"].as_f64().unwrap_or(f64::NAN),
                im["propagation_rel_error"][0].as_f64().unwrap_or(f64::NAN),
                im["propagation_rel_error"][1].as_f64().unwrap_or(f64::NAN),
                im["propagation_rel_error"][2].as_f64().unwrap_or(f64::NAN),
                im["response_rel_error"].as_f64().unwrap_or(f64::NAN),
            );
            if let Some(e) = im.get("vector_response_rel_error").and_then(serde_json::Value::as_f64) {
                eprintln!(
                    "  interface vector/volume response (U_r⃗, U_rvol): outside the k_r coefficients {:.3} / {:.3}; irradiance at the normal vs U_r {:.3}",
                    e,
                    im["volume_response_rel_error"].as_f64().unwrap_or(f64::NAN),
                    im["vector_response_consistency"].as_f64().unwrap_or(f64::NAN),
                );
            }
        }
        if let Some(shapes) = m["shapes"].as_object() {
            for (name, s) in shapes {
                eprintln!(
                    "  {name:<9} n {:>5}  prior lights {:>4}  reconstruction {:.4}  vs reference {:.4} (reference noise {:.4})",
                    s["texels"],
                    s["prior_lights"],
                    s["reconstruction_rel_error"].as_f64().unwrap_or(f64::NAN),
                    s["reference_rel_error"].as_f64().unwrap_or(f64::NAN),
                    s["reference_noise_rel"].as_f64().unwrap_or(f64::NAN),
                );
            }
        }
    }
    Ok(ExitCode::Ok)
}
