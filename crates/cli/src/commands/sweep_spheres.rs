//! `penumbra sweep spheres`: the speed/quality trade of sphere-set fits over sphere count, grid
//! resolution and method (Lloyd, octree). Bakes every combination once with `penumbra
//! spheres`' own bake, and writes `sweep.csv`, `sweep.json` and `sweep.svg` (union outside ratio
//! and E against bake seconds, one line per method and grid, the Pareto front marked).

use crate::args::SphereMethod;
use crate::commands::print_json;
use crate::commands::spheres::{SpheresJob, bake_to as bake_spheres, method};
use crate::commands::sweep::{csv_text, parse_list, with_front, write_outputs};
use crate::exit::{CliError, ExitCode};
use crate::progress::ProgressMode;
use crate::svgplot::{Panel, Series};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_spheres::fit::{FitParams, GRID_RANGE, MAX_COUNT, Target};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// `penumbra sweep spheres`.
#[derive(Debug, Args, Clone)]
pub struct SweepSpheresArgs {
    /// Mesh to fit (.obj, .gltf, .glb).
    pub mesh: PathBuf,
    /// Sphere counts (comma-separated, 1..=4096).
    #[arg(long, default_value = "16,32,64,128")]
    pub counts: String,
    /// Grid resolutions (comma-separated, 8..=256).
    #[arg(long, default_value = "48")]
    pub grids: String,
    /// Methods (comma-separated: lloyd, octree).
    #[arg(long, default_value = "lloyd,octree")]
    pub methods: String,
    /// Seed of the fits and the measurements.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory (assets, sweep.csv, sweep.json, sweep.svg).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print the sweep as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn method_name(m: SphereMethod) -> &'static str {
    match m {
        SphereMethod::Lloyd => "lloyd",
        SphereMethod::Octree => "octree",
    }
}

/// Runs `penumbra sweep spheres`.
#[allow(clippy::print_stderr)]
pub fn run(a: &SweepSpheresArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let counts: Vec<usize> = parse_list(&a.counts, "counts")?;
    let grids: Vec<usize> = parse_list(&a.grids, "grids")?;
    let methods: Vec<SphereMethod> = a
        .methods
        .split(',')
        .map(|m| match m.trim() {
            "lloyd" => Ok(SphereMethod::Lloyd),
            "octree" => Ok(SphereMethod::Octree),
            other => Err(CliError::input(anyhow!("--methods: {other:?} is not one of lloyd, octree"))),
        })
        .collect::<Result<_, _>>()?;
    if let Some(&n) = counts.iter().find(|&&n| !(1..=MAX_COUNT).contains(&n)) {
        return Err(CliError::input(anyhow!("--counts: {n} is out of range (allowed: 1..={MAX_COUNT})")));
    }
    if let Some(&g) = grids.iter().find(|&&g| !GRID_RANGE.contains(&g)) {
        return Err(CliError::input(anyhow!(
            "--grids: {g} is out of range (allowed: {}..={})",
            GRID_RANGE.start(),
            GRID_RANGE.end()
        )));
    }
    if !a.mesh.is_file() {
        return Err(CliError::input(anyhow!("{}: mesh not found", a.mesh.display())));
    }
    std::fs::create_dir_all(&a.output).with_context(|| format!("cannot create {}", a.output.display()))?;
    let mut rows: Vec<Value> = Vec::new();
    for &m in &methods {
        for &g in &grids {
            for &n in &counts {
                let mut params = FitParams::new(Target::Count(n));
                params.method = method(m);
                params.grid = g;
                params.seed = a.seed;
                params.metrics.seed = a.seed;
                let job = SpheresJob {
                    mesh: a.mesh.clone(),
                    mesh_name: None,
                    nodes: Vec::new(),
                    params,
                    output: a.output.join(format!("{}-g{g}-{n}.sphr", method_name(m))),
                };
                let out = bake_spheres(&job, mode)?;
                let v = &out.metrics;
                let row = json!({
                    "method": method_name(m),
                    "grid": g,
                    "requested_count": n,
                    "count": v["count"],
                    "bake_seconds": out.seconds,
                    "fit_seconds": v["fit_seconds"],
                    "outside_volume_ratio": v["outside_volume_ratio"],
                    "outside_volume_ratio_stderr": v["outside_volume_ratio_stderr"],
                    "union_outside_ratio": v["union_outside_ratio"],
                    "union_outside_ratio_stderr": v["union_outside_ratio_stderr"],
                    "uncovered_sample_points": v["uncovered_sample_points"],
                    "iterations": v["iterations"],
                });
                eprintln!(
                    "{} grid {g}, {n} spheres ({}): {:.2} s, union {:.3}, E {:.3}",
                    method_name(m),
                    v["count"],
                    out.seconds,
                    v["union_outside_ratio"].as_f64().unwrap_or(f64::NAN),
                    v["outside_volume_ratio"].as_f64().unwrap_or(f64::NAN),
                );
                rows.push(row);
            }
        }
    }
    let cols = [
        "method",
        "grid",
        "requested_count",
        "count",
        "bake_seconds",
        "fit_seconds",
        "outside_volume_ratio",
        "outside_volume_ratio_stderr",
        "union_outside_ratio",
        "union_outside_ratio_stderr",
        "uncovered_sample_points",
        "iterations",
    ];
    let csv = csv_text(&cols, &rows);
    let series_of = |y: &str| -> Vec<Series> {
        let mut out = Vec::new();
        for &m in &methods {
            for &g in &grids {
                let points = rows
                    .iter()
                    .filter(|r| r["method"] == method_name(m) && r["grid"] == g)
                    .map(|r| {
                        (
                            r["bake_seconds"].as_f64().unwrap_or(f64::NAN),
                            r[y].as_f64().unwrap_or(f64::NAN),
                            r["count"].to_string(),
                        )
                    })
                    .collect();
                let name =
                    if grids.len() > 1 { format!("{}, grid {g}", method_name(m)) } else { method_name(m).to_string() };
                out.push(Series { name, points });
            }
        }
        out
    };
    let title = a.mesh.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let panels = [
        with_front(Panel {
            title: format!("{title}: union outside ratio vs bake time"),
            x_label: "bake seconds (labels: sphere count)".into(),
            y_label: "V(∪S − T) / V(T)".into(),
            series: series_of("union_outside_ratio"),
            front: Vec::new(),
        }),
        with_front(Panel {
            title: "E vs bake time".into(),
            x_label: "bake seconds (labels: sphere count)".into(),
            y_label: "E = Σ V(Sᵢ − T) / V(T)".into(),
            series: series_of("outside_volume_ratio"),
            front: Vec::new(),
        }),
    ];
    let union_front = crate::svgplot::pareto_front(
        &rows
            .iter()
            .map(|r| {
                (r["bake_seconds"].as_f64().unwrap_or(f64::NAN), r["union_outside_ratio"].as_f64().unwrap_or(f64::NAN))
            })
            .collect::<Vec<_>>(),
    );
    for (r, on) in rows.iter_mut().zip(union_front) {
        r["pareto_union"] = json!(on);
    }
    let summary = json!({
        "mesh": a.mesh.display().to_string(),
        "counts": counts,
        "grids": grids,
        "methods": methods.iter().map(|&m| method_name(m)).collect::<Vec<_>>(),
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
