//! `penumbra verify gpu`: the WGSL twins of the runtime evaluators (`crates/gpu/shaders`) on a
//! compute device against the CPU runtime, on the same inputs (issue #20).

use crate::commands::gate::{self, Gate};
use crate::commands::mrt_level::LevelSource;
use crate::commands::print_json;
use crate::commands::verify_mrt::{OpenedLevel, default_lights, load_point_lights, median_ms, open_level};
use crate::exit::{CliError, ExitCode};
use anyhow::{Context, anyhow};
use clap::{Args, Subcommand};
use penumbra_asset::{Asset, AssetFile};
use penumbra_gpu::{Diff, FLOOR_FRACTION, Gpu, GpuError, compare, mrt::GpuMrt};
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_transport::level_reference::{LevelGeometry, PointLight, direct_at, level_texels};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// `penumbra verify gpu`.
#[derive(Debug, Args)]
pub struct VerifyGpuArgs {
    /// Which evaluator.
    #[command(subcommand)]
    pub command: VerifyGpuCommand,
}

/// Evaluators with a WGSL twin.
#[derive(Debug, Subcommand)]
pub enum VerifyGpuCommand {
    /// The MRT runtime (`shaders/mrt.wgsl`): one bounce with and without interfaces,
    /// multi-bounce and the padded atlas, on the inputs of `verify mrt`.
    Mrt(VerifyGpuMrtArgs),
}

/// `penumbra verify gpu mrt`.
#[derive(Debug, Args)]
pub struct VerifyGpuMrtArgs {
    /// The level: a level file (TOML) or a baked level asset (.mrtl, with the dictionary it
    /// was baked with). Omit with --maze/--corridor/--l-turn.
    #[arg(long)]
    pub level: Option<PathBuf>,
    /// The dictionary (.mrtd, with interfaces).
    #[arg(long)]
    pub dict: PathBuf,
    /// Procedural level.
    #[command(flatten)]
    pub source: LevelSource,
    /// Point lights (TOML `[[light]]`), as `verify mrt`. Default: intensity 1 at the centre
    /// of block 0 and of every 8th block after it.
    #[arg(long)]
    pub lights: Option<PathBuf>,
    /// Wall albedo of the multi-bounce (the runtime scales the dictionary's baked albedo).
    #[arg(long, default_value_t = 0.5, value_parser = parse_albedo)]
    pub albedo: f64,
    /// Bounces of the multi-bounce comparison.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub bounces: u32,
    /// Depth limit of the level operators (when the level is baked here).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub max_depth: u32,
    /// Exit with code 1 when max_rel_diff exceeds this (the report's `max_diff` key holds the
    /// bound).
    #[arg(long, value_name = "X", value_parser = gate::parse_max)]
    pub max_diff: Option<f64>,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_albedo(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 1.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < A < 1)")) }
}

/// Runs `penumbra verify gpu …`.
pub fn run(a: &VerifyGpuArgs) -> Result<ExitCode, CliError> {
    match &a.command {
        VerifyGpuCommand::Mrt(m) => run_mrt(m),
    }
}

/// The device, or exit 2 saying how to get one.
pub(crate) fn device() -> Result<Gpu, CliError> {
    Gpu::new().map_err(|e| match e {
        GpuError::NoAdapter(_) => CliError::input(anyhow!("{e}")),
        e => CliError::internal(anyhow!("{e}")),
    })
}

fn gpu_err(e: GpuError) -> CliError {
    CliError::internal(anyhow!("{e}"))
}

fn diff_json(d: &Diff) -> Value {
    json!({"max_rel_diff": d.max_rel, "at": d.at, "floor": d.floor})
}

#[allow(clippy::print_stderr)]
fn run_mrt(a: &VerifyGpuMrtArgs) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let OpenedLevel { d, level, links, what, bytes, .. } =
        open_level(&a.dict, a.level.as_deref(), &a.source, a.max_depth as usize)?;
    let gpu = device()?;
    let geo = LevelGeometry { level: &level, links: &links, missing: &d.missing };
    let lights: Vec<PointLight> = match &a.lights {
        Some(p) => load_point_lights(p, &geo)?,
        None => default_lights(&level),
    };
    let level_asset = penumbra_asset::OwnedAsset::parse(&bytes).map_err(CliError::internal)?;
    let dict_file = AssetFile::open(&a.dict).with_context(|| format!("cannot open {}", a.dict.display()))?;
    let dict_asset: Asset<'_> = dict_file.asset();
    let rd =
        MrtDictionary::from_asset(&dict_asset).map_err(|e| CliError::input(anyhow!("{}: {e}", a.dict.display())))?;
    let la = level_asset.asset();
    let rl = MrtLevel::from_asset(&la, &rd).map_err(|e| CliError::input(anyhow!("level: {e}")))?;
    let mut rt = MrtRuntime::new(rd, rl);
    let tex = level_texels(&level, &d.missing, d.face_res);
    let l_d: Vec<f32> = direct_at(&geo, &tex, &lights).iter().map(|&x| x as f32).collect();
    let n = rt.texel_count();
    if l_d.len() != n {
        return Err(CliError::internal(anyhow!("texel count {} vs runtime {n}", l_d.len())));
    }
    let scale = (a.albedo / d.albedo) as f32;
    let bounces = a.bounces as usize;

    // CPU runtime
    let (mut one, mut none, mut multi) = (vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
    rt.indirect(&l_d, &mut none, false);
    rt.multi_bounce(&l_d, &mut multi, bounces, scale);
    rt.indirect(&l_d, &mut one, true);
    let (w, h) = rt.level().atlas;
    let mut atlas = vec![0.0f32; w * h];
    rt.pad_atlas(&one, &mut atlas);
    let cpu_ms = median_ms(21, || rt.indirect(&l_d, &mut one, true));

    // its WGSL twin
    let mut g = GpuMrt::new(&gpu, &rt).map_err(|e| match e {
        GpuError::Unsupported(_) => CliError::input(anyhow!("{e}")),
        e => gpu_err(e),
    })?;
    let g_none = g.indirect(&l_d, false).map_err(gpu_err)?;
    let g_multi = g.multi_bounce(&l_d, bounces, scale).map_err(gpu_err)?;
    let g_one = g.indirect(&l_d, true).map_err(gpu_err)?;
    let g_atlas = g.pad_atlas(&g_one).map_err(gpu_err)?;
    let gpu_ms = g.time_indirect(11).map_err(gpu_err)?;

    let checks = [
        ("one_bounce", compare(&g_one, &one)),
        ("no_interfaces", compare(&g_none, &none)),
        ("multi_bounce", compare(&g_multi, &multi)),
        ("atlas", compare(&g_atlas, &atlas)),
    ];
    let max_rel = checks.iter().map(|c| c.1.max_rel).fold(0.0f64, f64::max);
    let mut v = json!({
        "evaluator": "mrt",
        "shader": "mrt.wgsl",
        "level": what,
        "blocks": level.blocks.len(),
        "texels": n,
        "records": rt.level().records.len(),
        "bounces": bounces,
        "adapter": gpu.adapter(),
        "backend": gpu.backend(),
        "device_type": gpu.device_type(),
        "max_rel_diff": max_rel,
        "rel_diff_definition": format!(
            "max over outputs of |gpu - cpu| / max(|cpu|, floor), floor = {FLOOR_FRACTION} x the largest |cpu| of that output"
        ),
        "floor_fraction": FLOOR_FRACTION,
        "checks": checks.iter().map(|(k, d)| (k.to_string(), diff_json(d))).collect::<serde_json::Map<_, _>>(),
        "gpu_ms": gpu_ms,
        "cpu_ms": cpu_ms,
        "timing_note": "one indirect() with interfaces, median; gpu_ms includes submission and wait; on a software device (device_type Cpu) it is correctness-only",
        "seconds": start.elapsed().as_secs_f64(),
    });
    let failures = gate::apply(&mut v, &[Gate { key: "max_diff", metric: "max_rel_diff", max: a.max_diff }]);
    if a.json {
        print_json(&v);
    } else {
        eprintln!(
            "verify gpu mrt: {what}, {} blocks, {n} texels on {} ({})",
            level.blocks.len(),
            gpu.adapter(),
            gpu.backend()
        );
        for (k, d) in &checks {
            eprintln!("  {k:<14} max rel diff {:.3e} (texel {}, floor {:.3e})", d.max_rel, d.at, d.floor);
        }
        eprintln!("  gpu {gpu_ms:.3} ms, cpu {cpu_ms:.3} ms per one-bounce evaluation");
    }
    Ok(gate::finish(&failures))
}
