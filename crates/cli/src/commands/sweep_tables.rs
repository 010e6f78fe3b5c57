//! `penumbra sweep tables`: the speed/accuracy trade of the SH tables over SH order and θ
//! sample count. Bakes every combination once with `penumbra tables`' own bake, reads each
//! asset back through the runtime's lookups ([`ShTables::cap_log`],
//! [`ShTables::cap_visibility`]) and compares them with the exact functions at fixed test
//! angles between the grid nodes, and writes `sweep.csv`, `sweep.json` and `sweep.svg`
//! (error against bake seconds and against bytes, the Pareto front marked).
//!
//! The reference of an order is computed once and shared by every θ sample count: the
//! starred ZH cap visibility g*(θ) and the starred eigen log-occlusion f*(θ) of the bake
//! (same functions, same ε, same log form), in f64, at `TEST_ANGLES` angles
//! `θ_j = (π/2)(j + ½)/TEST_ANGLES`. `(2j + 1)(K − 1) = 8192·k` has no solution unless
//! `2¹³` divides `K − 1`, so no test angle lies on a grid node of any allowed `K` but 8193:
//! what is measured is the interpolation between nodes plus the f32 storage.

use crate::commands::print_json;
use crate::commands::sweep::{OutputGuard, csv_text, parse_list, with_front, write_outputs};
use crate::commands::tables::{bake_to as bake_tables, params as table_params};
use crate::exit::{CliError, ExitCode};
use crate::progress::ProgressMode;
use crate::svgplot::{Panel, Series, pareto_front};
use anyhow::{Context, anyhow};
use clap::Args;
use core::f64::consts::FRAC_PI_2;
use penumbra_asset::AssetFile;
use penumbra_runtime::ShTables;
use penumbra_sh::gamma::TripleProduct;
use penumbra_sh::log::{EPS_REL, LogForm, log_eigen_zonal_occlusion_with};
use penumbra_sh::tables::{ORDERS, THETA_SAMPLES};
use penumbra_sh::zonal::{cap_indicator, cap_visibility};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// Test angles of the reference (see the module doc).
pub const TEST_ANGLES: usize = 4096;

/// `penumbra sweep tables`.
#[derive(Debug, Args, Clone)]
pub struct SweepTablesArgs {
    /// SH orders (comma-separated, 2..=8).
    #[arg(long, default_value = "3,4,5,6")]
    pub orders: String,
    /// θ sample counts of the 1D tables (comma-separated, 16..=16384).
    #[arg(long, default_value = "32,64,128,256,512")]
    pub theta_samples: String,
    /// Shading tolerance of the expansion-factor (η) analysis (as `penumbra tables`).
    #[arg(long, default_value_t = 1.0 / 256.0)]
    pub shading_tolerance: f64,
    /// Output directory (assets, sweep.csv, sweep.json, sweep.svg).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print the sweep as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn starred(zh: &[f64]) -> Vec<f64> {
    zh.iter().enumerate().map(|(l, v)| v * penumbra_math::sh::zh_star_scale(l)).collect()
}

/// The exact starred cap visibility and cap log of `order` at the test angles.
struct Reference {
    vis: Vec<Vec<f64>>,
    log: Vec<Vec<f64>>,
    seconds: f64,
}

fn reference(order: usize) -> Reference {
    use rayon::prelude::*;
    let t = Instant::now();
    let gamma = TripleProduct::new(order);
    let (vis, log): (Vec<_>, Vec<_>) = (0..TEST_ANGLES)
        .into_par_iter()
        .map(|j| {
            let th = FRAC_PI_2 * (j as f64 + 0.5) / TEST_ANGLES as f64;
            let g = cap_visibility(order, th);
            let f = log_eigen_zonal_occlusion_with(&gamma, &cap_indicator(order, th), EPS_REL, LogForm::Paper);
            (starred(&g), starred(&f))
        })
        .unzip();
    Reference { vis, log, seconds: t.elapsed().as_secs_f64() }
}

/// `(NRMSE, max error)` of rows against reference rows, both divided by the largest
/// reference norm: `sqrt(mean_j ‖a_j − r_j‖²) / max_j ‖r_j‖`, `max_j ‖a_j − r_j‖ / max_j ‖r_j‖`.
fn table_error(approx: &[Vec<f64>], reference: &[Vec<f64>]) -> (f64, f64) {
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let scale = reference.iter().map(|r| norm(r)).fold(0.0f64, f64::max).max(f64::MIN_POSITIVE);
    let (mut se, mut max) = (0.0f64, 0.0f64);
    for (a, r) in approx.iter().zip(reference) {
        let d: Vec<f64> = a.iter().zip(r).map(|(x, y)| x - y).collect();
        let e = norm(&d);
        se += e * e;
        max = max.max(e);
    }
    ((se / reference.len().max(1) as f64).sqrt() / scale, max / scale)
}

/// Runs `penumbra sweep tables`.
#[allow(clippy::print_stderr)]
pub fn run(a: &SweepTablesArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let orders: Vec<usize> = parse_list(&a.orders, "orders")?;
    let ks: Vec<usize> = parse_list(&a.theta_samples, "theta-samples")?;
    if let Some(&o) = orders.iter().find(|&&o| !ORDERS.contains(&o)) {
        return Err(CliError::input(anyhow!(
            "--orders: {o} is out of range (allowed: {}..={})",
            ORDERS.start(),
            ORDERS.end()
        )));
    }
    if let Some(&k) = ks.iter().find(|&&k| !THETA_SAMPLES.contains(&k)) {
        return Err(CliError::input(anyhow!(
            "--theta-samples: {k} is out of range (allowed: {}..={})",
            THETA_SAMPLES.start(),
            THETA_SAMPLES.end()
        )));
    }
    if !(a.shading_tolerance > 0.0 && a.shading_tolerance < 1.0) {
        return Err(CliError::input(anyhow!(
            "--shading-tolerance: {} is out of range (allowed: 0 < T < 1)",
            a.shading_tolerance
        )));
    }
    // every parameter set is validated before anything is written
    for &o in &orders {
        for &k in &ks {
            table_params(o as u32, k as u32, a.shading_tolerance, None)?;
        }
    }
    let mut guard = OutputGuard::create(&a.output)?;
    let mut rows: Vec<Value> = Vec::new();
    let mut reference_seconds = 0.0;
    for &o in &orders {
        let r = reference(o);
        reference_seconds += r.seconds;
        for &k in &ks {
            let p = table_params(o as u32, k as u32, a.shading_tolerance, None)?;
            let path = guard.file(&format!("tables-o{o}-k{k}.shtb"));
            let out = bake_tables(&p, &path, mode)?;
            let file = AssetFile::open(&path).with_context(|| format!("cannot read back {}", path.display()))?;
            let asset = file.asset();
            let t = ShTables::from_asset(&asset).map_err(|e| CliError::internal(anyhow!("{}: {e}", path.display())))?;
            let mut row = vec![0.0f32; o];
            let mut lookup = |f: &dyn Fn(&ShTables<'_>, f32, &mut [f32])| -> Vec<Vec<f64>> {
                (0..TEST_ANGLES)
                    .map(|j| {
                        let th = FRAC_PI_2 * (j as f64 + 0.5) / TEST_ANGLES as f64;
                        f(&t, th as f32, &mut row);
                        row.iter().map(|&v| v as f64).collect()
                    })
                    .collect()
            };
            let log = lookup(&|t, th, out| t.cap_log(th, out));
            let vis = lookup(&|t, th, out| t.cap_visibility(th, out));
            let (log_nrmse, log_max) = table_error(&log, &r.log);
            let (vis_nrmse, vis_max) = table_error(&vis, &r.vis);
            // runtime cost of one interpolated lookup (one core, repeated passes)
            let t0 = Instant::now();
            let mut passes = 0u32;
            let mut sink = 0.0f32;
            while passes == 0 || (t0.elapsed().as_secs_f64() < 0.02 && passes < 1000) {
                for j in 0..TEST_ANGLES {
                    t.cap_log(FRAC_PI_2 as f32 * (j as f32 + 0.5) / TEST_ANGLES as f32, &mut row);
                    sink += row[0];
                }
                passes += 1;
            }
            std::hint::black_box(sink);
            let ns_per_lookup = t0.elapsed().as_secs_f64() * 1e9 / (passes as f64 * TEST_ANGLES as f64);
            let m = &out.metrics;
            eprintln!(
                "order {o}, {k} θ samples: {:.2} s, {} bytes, cap log NRMSE {log_nrmse:.3e} (max {log_max:.3e}), cap visibility NRMSE {vis_nrmse:.3e}",
                out.seconds, out.bytes
            );
            rows.push(json!({
                "order": o,
                "theta_samples": k,
                "bake_seconds": out.seconds,
                "bytes": out.bytes,
                "cap_log_nrmse": log_nrmse,
                "cap_log_max_error": log_max,
                "cap_visibility_nrmse": vis_nrmse,
                "cap_visibility_max_error": vis_max,
                "ns_per_lookup": ns_per_lookup,
                "roundtrip_rel_error_eigen": m["roundtrip_rel_error_eigen"],
                "eta_shadow": m["eta_shadow"],
            }));
        }
    }
    // Pareto flags: cap log error against bake seconds and against bytes
    let flags = |x: &str| -> Vec<bool> {
        pareto_front(
            &rows
                .iter()
                .map(|r| (r[x].as_f64().unwrap_or(f64::NAN), r["cap_log_nrmse"].as_f64().unwrap_or(f64::NAN)))
                .collect::<Vec<_>>(),
        )
    };
    let (by_seconds, by_bytes) = (flags("bake_seconds"), flags("bytes"));
    for ((r, s), b) in rows.iter_mut().zip(by_seconds).zip(by_bytes) {
        r["pareto_seconds"] = json!(s);
        r["pareto_bytes"] = json!(b);
    }
    let cols = [
        "order",
        "theta_samples",
        "bake_seconds",
        "bytes",
        "cap_log_nrmse",
        "cap_log_max_error",
        "cap_visibility_nrmse",
        "cap_visibility_max_error",
        "ns_per_lookup",
        "roundtrip_rel_error_eigen",
        "eta_shadow",
        "pareto_seconds",
        "pareto_bytes",
    ];
    let csv = csv_text(&cols, &rows);
    let series_of = |x: &str| -> Vec<Series> {
        orders
            .iter()
            .map(|&o| Series {
                name: format!("order {o}"),
                points: rows
                    .iter()
                    .filter(|r| r["order"] == o)
                    .map(|r| {
                        (
                            r[x].as_f64().unwrap_or(f64::NAN),
                            r["cap_log_nrmse"].as_f64().unwrap_or(f64::NAN),
                            r["theta_samples"].to_string(),
                        )
                    })
                    .collect(),
            })
            .collect()
    };
    let panels = [
        with_front(Panel {
            title: "SH tables: cap log error vs bake time".into(),
            x_label: "bake seconds (labels: θ samples)".into(),
            y_label: "cap log NRMSE vs exact f*(θ)".into(),
            series: series_of("bake_seconds"),
            front: Vec::new(),
        }),
        with_front(Panel {
            title: "cap log error vs asset size".into(),
            x_label: "bytes (labels: θ samples)".into(),
            y_label: "cap log NRMSE vs exact f*(θ)".into(),
            series: series_of("bytes"),
            front: Vec::new(),
        }),
    ];
    let summary = json!({
        "orders": orders,
        "theta_samples": ks,
        "shading_tolerance": a.shading_tolerance,
        "test_angles": TEST_ANGLES,
        "reference_seconds": reference_seconds,
        "rows": rows,
        "seconds": start.elapsed().as_secs_f64(),
        "output": a.output.display().to_string(),
    });
    write_outputs(&a.output, &csv, &panels, &summary)?;
    guard.keep();
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
