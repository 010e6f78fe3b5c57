//! `penumbra sweep mrt`: the speed/quality trade of the MRT dictionary over texels per face,
//! prior vectors, modes, gather rays and the interfaces' ranks. One dictionary bake per grid
//! point with `penumbra mrt dict`'s own bake, its level operators, and the runtime's one-bounce
//! and multi-bounce light on one level, measured as `verify mrt` measures them against the
//! level path tracer. The path-traced reference depends on the level and the texel layout
//! only, so it is traced once per `--face-res` value, not per point. Writes `sweep.csv`,
//! `sweep.json` and `sweep.svg` (error against bake seconds and against bytes, fronts marked).

use crate::commands::mrt::{DictOptions, bake_to, params};
use crate::commands::mrt_level::{LevelSource, bake as bake_level, load_dict, resolve};
use crate::commands::print_json;
use crate::commands::sweep::{OutputGuard, cost_ratio, csv_text, finish, flag_front, parse_list, with_front};
use crate::commands::verify_mrt::{default_lights, load_point_lights};
use crate::exit::{CliError, ExitCode};
use crate::progress::ProgressMode;
use crate::svgplot::{Panel, Series};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::{AssetFile, OwnedAsset};
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_transport::level_reference::{
    LevelGeometry, LevelReference, PointLight, direct_at, level_texels, reference,
};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// `penumbra sweep mrt`.
#[derive(Debug, Args)]
pub struct SweepMrtArgs {
    /// Level file (TOML); or --maze/--corridor/--l-turn.
    pub level: Option<PathBuf>,
    /// Procedural level.
    #[command(flatten)]
    pub source: LevelSource,
    /// Texels per face edge (comma-separated, 2..=24).
    #[arg(long, default_value = "8,16")]
    pub face_res: String,
    /// Light-prior vectors k_d (comma-separated).
    #[arg(long, default_value = "64")]
    pub kd: String,
    /// Indirect modes k_b (comma-separated, each at most its k_d).
    #[arg(long, default_value = "16,32")]
    pub kb: String,
    /// Gather rays per texel of F (comma-separated).
    #[arg(long, default_value = "4096")]
    pub rays: String,
    /// Reduced lightfield modes k_rlf (comma-separated).
    #[arg(long, default_value = "128")]
    pub k_rlf: String,
    /// Interface response modes k_r (comma-separated, each at most its k_rlf).
    #[arg(long, default_value = "32")]
    pub k_r: String,
    /// Point lights (TOML), as `verify mrt --lights`.
    #[arg(long)]
    pub lights: Option<PathBuf>,
    /// Wall albedo of the comparison.
    #[arg(long, default_value_t = 0.5)]
    pub albedo: f64,
    /// Reference rays per texel.
    #[arg(long = "reference-rays", default_value_t = 512, value_parser = clap::value_parser!(u32).range(4..=1_048_576))]
    pub reference_rays: u32,
    /// Bounces of the multi-bounce comparison.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub bounces: u32,
    /// Depth limit of the level operators.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub max_depth: u32,
    /// Seed of the reference.
    #[arg(long = "ref-seed", default_value_t = 0)]
    pub ref_seed: u64,
    /// Output directory (dictionaries, sweep.csv, sweep.json, sweep.svg).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print the sweep as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn rel(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

/// Runs `penumbra sweep mrt`.
#[allow(clippy::print_stderr)]
pub fn run(a: &SweepMrtArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let lists = [
        ("face-res", parse_list::<u32>(&a.face_res, "face-res")?),
        ("kd", parse_list::<u32>(&a.kd, "kd")?),
        ("kb", parse_list::<u32>(&a.kb, "kb")?),
        ("rays", parse_list::<u32>(&a.rays, "rays")?),
        ("k-rlf", parse_list::<u32>(&a.k_rlf, "k-rlf")?),
        ("k-r", parse_list::<u32>(&a.k_r, "k-r")?),
    ];
    if !(a.albedo > 0.0 && a.albedo <= 1.0) {
        return Err(CliError::input(anyhow!("--albedo {} is out of range (allowed: 0 < A <= 1)", a.albedo)));
    }
    // every point's parameters, checked before anything is baked or written
    let mut points = Vec::new();
    for &fr in &lists[0].1 {
        for &kd in &lists[1].1 {
            for &kb in &lists[2].1 {
                for &rays in &lists[3].1 {
                    for &k_rlf in &lists[4].1 {
                        for &k_r in &lists[5].1 {
                            let o = DictOptions {
                                face_res: Some(fr),
                                kd: Some(kd),
                                kb: Some(kb),
                                rays: Some(rays),
                                k_rlf: Some(k_rlf),
                                k_r: Some(k_r),
                                ..DictOptions::default()
                            };
                            let p = params(&o).map_err(|e| CliError {
                                code: e.code,
                                error: e.error.context(format!(
                                    "sweep point face-res {fr}, kd {kd}, kb {kb}, rays {rays}, k-rlf {k_rlf}, k-r {k_r}"
                                )),
                            })?;
                            points.push(((fr, kd, kb, rays, k_rlf, k_r), p));
                        }
                    }
                }
            }
        }
    }
    if let Some(p) = &a.level {
        if !p.is_file() {
            return Err(CliError::input(anyhow!("{}: level file not found", p.display())));
        }
    }
    let mut guard = OutputGuard::create(&a.output)?;
    // one reference per texel layout: (face_res, reference, seconds)
    let mut refs: Vec<(u32, LevelReference, f64)> = Vec::new();
    let mut rows: Vec<Value> = Vec::new();
    let mut what = String::new();
    for (i, ((fr, kd, kb, rays, k_rlf, k_r), p)) in points.iter().enumerate() {
        let name = format!("mrt-f{fr}-kd{kd}-kb{kb}-r{rays}-rlf{k_rlf}-kr{k_r}.mrtd");
        let path = guard.file(&name);
        let out = bake_to(p, &path, mode)?;
        let d = load_dict(&path)?;
        let (level, links, w) = resolve(a.level.as_deref(), &a.source, &d)?;
        what = w;
        let t0 = Instant::now();
        let (_, level_bytes) = bake_level(&level, &links, &d, a.max_depth as usize, None)?;
        let level_seconds = t0.elapsed().as_secs_f64();
        let geo = LevelGeometry { level: &level, links: &links, missing: &d.missing };
        let lights: Vec<PointLight> = match &a.lights {
            Some(l) => load_point_lights(l, &geo)?,
            None => default_lights(&level),
        };
        let tex = level_texels(&level, &d.missing, d.face_res);
        if !refs.iter().any(|(f, _, _)| f == fr) {
            let t = Instant::now();
            let r = reference(
                &geo,
                &tex,
                &lights,
                a.albedo,
                a.reference_rays as usize,
                a.bounces as usize,
                a.ref_seed,
                &|_| {},
            );
            refs.push((*fr, r, t.elapsed().as_secs_f64()));
        }
        let r = &refs.iter().find(|(f, _, _)| f == fr).ok_or_else(|| CliError::internal(anyhow!("no reference")))?.1;
        let df = AssetFile::open(&path).with_context(|| format!("cannot open {}", path.display()))?;
        let da = df.asset();
        let rd = MrtDictionary::from_asset(&da).map_err(|e| CliError::input(anyhow!("{e}")))?;
        let la = OwnedAsset::parse(&level_bytes).map_err(CliError::internal)?;
        let lat = la.asset();
        let rl = MrtLevel::from_asset(&lat, &rd).map_err(|e| CliError::input(anyhow!("level: {e}")))?;
        let mut rt = MrtRuntime::new(rd, rl);
        let l_d: Vec<f32> = direct_at(&geo, &tex, &lights).iter().map(|&x| x as f32).collect();
        let n = l_d.len();
        let scale = (a.albedo / d.albedo) as f32;
        let (mut one, mut multi) = (vec![0.0f32; n], vec![0.0f32; n]);
        rt.indirect(&l_d, &mut one, true);
        rt.multi_bounce(&l_d, &mut multi, a.bounces as usize, scale);
        let ms_runtime = crate::commands::verify_mrt::median_ms(11, || rt.indirect(&l_d, &mut one, true));
        let one: Vec<f64> = one.iter().map(|&x| f64::from(x) * f64::from(scale)).collect();
        let multi: Vec<f64> = multi.iter().map(|&x| f64::from(x)).collect();
        rows.push(json!({
            "face_res": fr, "kd": kd, "kb": kb, "rays": rays, "k_rlf": k_rlf, "k_r": k_r,
            "bake_seconds": out.seconds,
            "level_seconds": level_seconds,
            "bytes": out.bytes,
            "level_bytes": level_bytes.len(),
            "ms_runtime": ms_runtime,
            "rel_error_one_bounce": rel(&one, &r.one_bounce),
            "rel_error_multi_bounce": rel(&multi, &r.multi_bounce),
            "output": name,
        }));
        if !a.json {
            eprintln!(
                "[{}/{}] face-res {fr} kd {kd} kb {kb} rays {rays} k-rlf {k_rlf} k-r {k_r}: one bounce {:.4}, multi {:.4}, {:.2} s, {} bytes",
                i + 1,
                points.len(),
                rows[i]["rel_error_one_bounce"].as_f64().unwrap_or(f64::NAN),
                rows[i]["rel_error_multi_bounce"].as_f64().unwrap_or(f64::NAN),
                out.seconds,
                out.bytes
            );
        }
    }
    flag_front(&mut rows, "pareto_seconds", "bake_seconds", "rel_error_one_bounce");
    flag_front(&mut rows, "pareto_bytes", "bytes", "rel_error_one_bounce");
    let cols = [
        "face_res",
        "kd",
        "kb",
        "rays",
        "k_rlf",
        "k_r",
        "bake_seconds",
        "level_seconds",
        "bytes",
        "level_bytes",
        "ms_runtime",
        "rel_error_one_bounce",
        "rel_error_multi_bounce",
        "pareto_seconds",
        "pareto_bytes",
        "output",
    ];
    let csv = csv_text(&cols, &rows);
    let series = |x: &str, y: &str| -> Vec<Series> {
        lists[0]
            .1
            .iter()
            .map(|&fr| Series {
                name: format!("face-res {fr}"),
                points: rows
                    .iter()
                    .filter(|r| r["face_res"] == fr)
                    .map(|r| {
                        (
                            r[x].as_f64().unwrap_or(f64::NAN),
                            r[y].as_f64().unwrap_or(f64::NAN),
                            format!("kb {}", r["kb"]),
                        )
                    })
                    .collect(),
            })
            .collect()
    };
    let panels = [
        with_front(Panel {
            title: format!("{what}: one-bounce error vs dictionary bake time"),
            x_label: "bake seconds (labels: k_b)".into(),
            y_label: "rel_error_one_bounce".into(),
            series: series("bake_seconds", "rel_error_one_bounce"),
            front: Vec::new(),
        }),
        with_front(Panel {
            title: "one-bounce error vs dictionary bytes".into(),
            x_label: "dictionary bytes".into(),
            y_label: "rel_error_one_bounce".into(),
            series: series("bytes", "rel_error_one_bounce"),
            front: Vec::new(),
        }),
        with_front(Panel {
            title: "multi-bounce error vs bake time".into(),
            x_label: "bake seconds".into(),
            y_label: "rel_error_multi_bounce".into(),
            series: series("bake_seconds", "rel_error_multi_bounce"),
            front: Vec::new(),
        }),
    ];
    let seconds = start.elapsed().as_secs_f64();
    let summary = json!({
        "level": what,
        "points": rows.len(),
        "reference_rays": a.reference_rays,
        "references": refs.iter().map(|(f, _, s)| json!({"face_res": f, "seconds": s})).collect::<Vec<_>>(),
        "rows": rows,
        "seconds": seconds,
        "cost_vs_most_expensive_point": cost_ratio(&rows, seconds),
        "output": a.output.display().to_string(),
    });
    finish(guard, &a.output, &csv, &panels, &summary)?;
    if a.json {
        print_json(&summary);
    } else {
        eprintln!(
            "{} points in {:.2} s ({:.2}× the most expensive point; {} reference(s), one per face-res): {}",
            rows.len(),
            seconds,
            summary["cost_vs_most_expensive_point"].as_f64().unwrap_or(f64::NAN),
            refs.len(),
            a.output.join("sweep.svg").display()
        );
    }
    Ok(ExitCode::Ok)
}
