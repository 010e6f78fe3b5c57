//! `penumbra tables`: the SH tables bake.

use crate::args::TablesArgs;
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::{ensure_parent, hash_file};
use crate::progress::{ProgressMode, Reporter};
use anyhow::Context;
use penumbra_sh::tables::{EnvLighting, TablesParams, bake};
use penumbra_sh::tables_asset::to_asset;
use serde_json::json;
use std::path::Path;
use std::time::Instant;

/// What a tables bake produced.
#[derive(Debug)]
pub struct TablesOutcome {
    /// Metrics as JSON (the `--json` keys without bytes/seconds/output).
    pub metrics: serde_json::Value,
    /// Bytes written.
    pub bytes: u64,
    /// Wall time.
    pub seconds: f64,
}

/// Normalised parameters of a tables bake (defaults filled in), as hashed for the cache key.
pub fn cache_key(params: &TablesParams) -> String {
    let v = json!({
        "tool": env!("CARGO_PKG_VERSION"),
        "stage": "tables",
        "kind_version": penumbra_sh::tables::SHTB_KIND_VERSION,
        "order": params.order,
        "theta_samples": params.theta_samples,
        "shading_tolerance": params.shading_tolerance,
        "env": params.env.as_ref().map(|e| &e.content_hash),
        "log_form": params.log_form.name(),
    });
    blake3::hash(v.to_string().as_bytes()).to_hex().to_string()
}

/// Builds the parameters, loading the environment lighting when given.
pub fn params(order: u32, theta_samples: u32, tolerance: f64, env: Option<&Path>) -> Result<TablesParams, CliError> {
    let mut p = TablesParams::new(order as usize);
    p.theta_samples = theta_samples as usize;
    p.shading_tolerance = tolerance;
    if let Some(path) = env {
        let sh = crate::env_light::env_luminance_sh(path, p.order)?;
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        p.env = Some(EnvLighting { sh, name, content_hash: hash_file(path)? });
    }
    p.validate().map_err(CliError::input)?;
    Ok(p)
}

/// Bakes and writes the asset atomically.
pub fn bake_to(params: &TablesParams, output: &Path, mode: ProgressMode) -> Result<TablesOutcome, CliError> {
    let start = Instant::now();
    let reporter = Reporter::new("tables", mode);
    let b = bake(params, &reporter).map_err(CliError::input)?;
    reporter.finish();
    let asset = to_asset(&b, Some(&cache_key(params))).map_err(CliError::internal)?;
    ensure_parent(output)?;
    let bytes = asset.write_atomic(output).with_context(|| format!("cannot write {}", output.display()))?;
    let metrics = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
    Ok(TablesOutcome { metrics, bytes, seconds: start.elapsed().as_secs_f64() })
}

/// Runs `penumbra tables`.
#[allow(clippy::print_stderr)]
pub fn run(a: &TablesArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let mut p = params(a.order, a.theta_samples, a.shading_tolerance, a.env.as_deref())?;
    p.log_form = match a.log_form {
        crate::args::LogFormArg::Paper => penumbra_sh::log::LogForm::Paper,
        crate::args::LogFormArg::Matrix => penumbra_sh::log::LogForm::Matrix,
    };
    let out = bake_to(&p, &a.output, mode)?;
    let mut v = out.metrics.clone();
    if let Some(obj) = v.as_object_mut() {
        obj.insert("bytes".into(), json!(out.bytes));
        obj.insert("seconds".into(), json!(out.seconds));
        obj.insert("output".into(), json!(a.output.display().to_string()));
    }
    if a.json {
        print_json(&v);
    } else {
        let m = &out.metrics;
        eprintln!(
            "wrote {} ({} bytes) in {:.2} s\n  order {}  Γ nonzeros {}  η shadow {:.2} (windowed {:.2})  η indirect {:.2}\n  OL accurate ‖f̂‖ ≤ {:.3}  round trip eigen {:.2e} / naive {:.2e}",
            a.output.display(),
            out.bytes,
            out.seconds,
            m["order"],
            m["gamma_nonzeros"],
            m["eta_shadow"].as_f64().unwrap_or(f64::NAN),
            m["eta_shadow_windowed"].as_f64().unwrap_or(f64::NAN),
            m["eta_indirect"].as_f64().unwrap_or(f64::NAN),
            m["ol_accurate_norm"].as_f64().unwrap_or(f64::NAN),
            m["roundtrip_rel_error_eigen"].as_f64().unwrap_or(f64::NAN),
            m["roundtrip_rel_error_naive"].as_f64().unwrap_or(f64::NAN),
        );
    }
    Ok(ExitCode::Ok)
}
