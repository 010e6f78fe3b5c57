//! `penumbra sweep shadows`: the speed/accuracy trade of sphere-proxy shadows over sphere count,
//! SH order and exponential. Bakes every sphere set and every table once, verifies every
//! combination against the ray-traced mesh, and writes `sweep.csv`, `sweep.json` and `sweep.svg`
//! (error against bake seconds and against runtime ns per receiver).

use crate::args::{EnvRotateArg, UpArg};
use crate::commands::print_json;
use crate::commands::spheres::{SpheresJob, bake_to as bake_spheres};
use crate::commands::sweep::{csv_text, parse_list, with_front, write_outputs};
use crate::commands::tables::{bake_to as bake_tables, params as table_params};
use crate::commands::verify_shadows::{ExpArg, ReceiverKind, VerifyShadowsArgs, evaluate};
use crate::exit::{CliError, ExitCode};
use crate::progress::ProgressMode;
use crate::svgplot::{Panel, Series};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_spheres::fit::{FitParams, Target};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// `penumbra sweep shadows`.
#[derive(Debug, Args, Clone)]
pub struct SweepShadowsArgs {
    /// Mesh to fit and to ray-trace.
    #[arg(long)]
    pub mesh: PathBuf,
    /// Environment map (lat-long .exr or .hdr), or `builtin:area-lights`.
    #[arg(long)]
    pub env: PathBuf,
    /// Rotate the environment by 180° about an axis (`z180` for grace_latlong.exr).
    #[arg(long, value_enum, default_value_t = EnvRotateArg::None)]
    pub env_rotate: EnvRotateArg,
    /// Sphere counts (comma-separated, 1..=4096).
    #[arg(long, default_value = "8,16,32,64,128")]
    pub counts: String,
    /// SH orders (comma-separated, 2..=8).
    #[arg(long, default_value = "3,4,5,6")]
    pub orders: String,
    /// Exponentials (comma-separated: hyb, ol, ps).
    #[arg(long, default_value = "hyb")]
    pub exp: String,
    /// Also bake hierarchies and verify with them.
    #[arg(long)]
    pub hierarchy: bool,
    /// Plane receivers per side.
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(2..=1024))]
    pub resolution: u32,
    /// Reference rays per receiver: K×K.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(2..=1024))]
    pub rays: u32,
    /// Up axis of the scene.
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    pub up: UpArg,
    /// Output directory (assets, sweep.csv, sweep.json, sweep.svg).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print the sweep as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `penumbra sweep shadows`.
#[allow(clippy::print_stderr)]
pub fn run(a: &SweepShadowsArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let counts: Vec<usize> = parse_list(&a.counts, "counts")?;
    let orders: Vec<u32> = parse_list(&a.orders, "orders")?;
    let exps: Vec<ExpArg> = a
        .exp
        .split(',')
        .map(|e| match e.trim() {
            "hyb" => Ok(ExpArg::Hyb),
            "ol" => Ok(ExpArg::Ol),
            "ps" => Ok(ExpArg::Ps),
            other => Err(CliError::input(anyhow!("--exp: {other:?} is not one of hyb, ol, ps"))),
        })
        .collect::<Result<_, _>>()?;
    if let Some(&n) = counts.iter().find(|&&n| !(1..=4096).contains(&n)) {
        return Err(CliError::input(anyhow!("--counts: {n} is out of range (allowed: 1..=4096)")));
    }
    if let Some(&o) = orders.iter().find(|&&o| !(2..=8).contains(&o)) {
        return Err(CliError::input(anyhow!("--orders: {o} is out of range (allowed: 2..=8)")));
    }
    if !a.mesh.is_file() {
        return Err(CliError::input(anyhow!("{}: mesh not found", a.mesh.display())));
    }
    if !a.env.is_file() && !a.env.to_str().is_some_and(|s| s.starts_with("builtin:")) {
        return Err(CliError::input(anyhow!("{}: environment map not found", a.env.display())));
    }
    std::fs::create_dir_all(&a.output).with_context(|| format!("cannot create {}", a.output.display()))?;
    // bake every table and every sphere set once
    let mut table_seconds = Vec::new();
    for &o in &orders {
        let p = table_params(o, 256, 1.0 / 256.0, None)?;
        let out = bake_tables(&p, &a.output.join(format!("tables-o{o}.shtb")), mode)?;
        eprintln!("tables order {o}: {:.2} s", out.seconds);
        table_seconds.push(out.seconds);
    }
    let mut sphere_runs = Vec::new();
    for &n in &counts {
        let mut params = FitParams::new(Target::Count(n));
        params.hierarchy = a.hierarchy;
        let job = SpheresJob {
            mesh: a.mesh.clone(),
            mesh_name: None,
            nodes: Vec::new(),
            params,
            output: a.output.join(format!("spheres-{n}.sphr")),
        };
        let out = bake_spheres(&job, mode)?;
        eprintln!(
            "{n} spheres: {:.2} s, E {:.3}",
            out.seconds,
            out.metrics["outside_volume_ratio"].as_f64().unwrap_or(f64::NAN)
        );
        sphere_runs.push(out);
    }
    let mut rows: Vec<Value> = Vec::new();
    for (ci, &n) in counts.iter().enumerate() {
        for (oi, &o) in orders.iter().enumerate() {
            for &e in &exps {
                let v = VerifyShadowsArgs {
                    spheres: a.output.join(format!("spheres-{n}.sphr")),
                    tables: a.output.join(format!("tables-o{o}.shtb")),
                    mesh: a.mesh.clone(),
                    env: a.env.clone(),
                    receivers: ReceiverKind::Plane,
                    exp: e,
                    ps_degree: 2,
                    hierarchy: a.hierarchy,
                    theta_max: 25.0,
                    cluster: 8,
                    resolution: a.resolution,
                    max_receivers: 4096,
                    rays: a.rays,
                    no_window: false,
                    up: a.up,
                    env_rotate: a.env_rotate,
                    accumulate_tables: None,
                    seed: 1,
                    image: None,
                    max_nrmse: None,
                    local_light: None,
                    animation: None,
                    time: None,
                    frames: None,
                    indirect: false,
                    albedo: None,
                    json: false,
                };
                let r = evaluate(&v)?;
                let j = &r.json;
                let sph = &sphere_runs[ci];
                let row = json!({
                    "count": n,
                    "order": o,
                    "exp_method": j["exp_method"],
                    "spheres_bake_seconds": sph.seconds,
                    "tables_bake_seconds": table_seconds[oi],
                    "bake_seconds": sph.seconds + table_seconds[oi],
                    "ns_per_receiver": j["ns_per_receiver"],
                    "nrmse_vs_mesh": j["nrmse_vs_mesh"],
                    "nrmse_vs_mesh_full": j["nrmse_vs_mesh_full"],
                    "nrmse_vs_spheres": j["nrmse_vs_spheres"],
                    "nrmse_log_vs_product": j["nrmse_log_vs_product"],
                    "outside_volume_ratio": sph.metrics["outside_volume_ratio"],
                    "union_outside_ratio": sph.metrics["union_outside_ratio"],
                });
                eprintln!(
                    "{n:>4} spheres, order {o}, {}: NRMSE vs mesh {:.4}, {:.0} ns/receiver",
                    j["exp_method"].as_str().unwrap_or(""),
                    j["nrmse_vs_mesh"].as_f64().unwrap_or(f64::NAN),
                    j["ns_per_receiver"].as_f64().unwrap_or(f64::NAN)
                );
                rows.push(row);
            }
        }
    }
    // outputs
    let cols = [
        "count",
        "order",
        "exp_method",
        "spheres_bake_seconds",
        "tables_bake_seconds",
        "bake_seconds",
        "ns_per_receiver",
        "nrmse_vs_mesh",
        "nrmse_vs_mesh_full",
        "nrmse_vs_spheres",
        "nrmse_log_vs_product",
        "outside_volume_ratio",
        "union_outside_ratio",
    ];
    let csv = csv_text(&cols, &rows);
    let series_of = |x: &str| -> Vec<Series> {
        let mut out = Vec::new();
        for &o in &orders {
            for &e in &exps {
                let name = format!(
                    "order {o}{}",
                    if exps.len() > 1 { format!(", {e:?}").to_lowercase() } else { String::new() }
                );
                let points = rows
                    .iter()
                    .filter(|r| r["order"] == o && r["exp_method"] == rows_exp(e))
                    .map(|r| {
                        (
                            r[x].as_f64().unwrap_or(f64::NAN),
                            r["nrmse_vs_mesh"].as_f64().unwrap_or(f64::NAN),
                            r["count"].to_string(),
                        )
                    })
                    .collect();
                out.push(Series { name, points });
            }
        }
        out
    };
    let title = format!(
        "{} under {}",
        a.mesh.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
        a.env.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default()
    );
    let panels = [
        with_front(Panel {
            title: format!("{title}: error vs bake time"),
            x_label: "bake seconds (spheres + tables)".into(),
            y_label: "NRMSE vs ray-traced mesh".into(),
            series: series_of("bake_seconds"),
            front: Vec::new(),
        }),
        with_front(Panel {
            title: "error vs runtime cost (labels: sphere count)".into(),
            x_label: "runtime ns per receiver (one core)".into(),
            y_label: "NRMSE vs ray-traced mesh".into(),
            series: series_of("ns_per_receiver"),
            front: Vec::new(),
        }),
    ];
    let summary = json!({
        "mesh": a.mesh.display().to_string(),
        "env": a.env.display().to_string(),
        "env_rotate": format!("{:?}", a.env_rotate).to_lowercase(),
        "receivers": a.resolution * a.resolution,
        "reference_rays_per_receiver": a.rays * a.rays,
        "hierarchy": a.hierarchy,
        "rows": rows,
        "seconds": start.elapsed().as_secs_f64(),
        "output": a.output.display().to_string(),
    });
    write_outputs(&a.output, &csv, &panels, &summary)?;
    if a.json {
        print_json(&summary);
    } else {
        eprintln!(
            "wrote {}/sweep.csv, sweep.json, sweep.svg in {:.1} s",
            a.output.display(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(ExitCode::Ok)
}

fn rows_exp(e: ExpArg) -> &'static str {
    match e {
        ExpArg::Hyb => "hyb",
        ExpArg::Ol => "ol",
        ExpArg::Ps => "ps*-2",
    }
}
