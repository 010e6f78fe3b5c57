//! `penumbra vo`: volumetric-obscurance sample sets (MRT thesis §6.3.5) and their comparison
//! with the Lloyd, Halton and Poisson baselines.

use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use crate::progress::{ProgressMode, Reporter};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_vo::bake::{MAX_COUNT, versus};
use penumbra_vo::{VoParams, bake};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `penumbra vo`.
#[derive(Debug, Args)]
pub struct VoArgs {
    /// Sample counts: a range `A..B` (inclusive), a list `4,9,12` or one count (1..=256).
    #[arg(long, default_value = "1..64")]
    pub counts: String,
    /// Seed of every random draw.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Poisson starting sets per electrostatic set (N ≤ 16; fewer above, at least 6).
    #[arg(long, default_value_t = 24, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub starts: u32,
    /// Random half-spaces of each noise measurement.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub noise_trials: u32,
    /// Output asset (.voss). Parent directories are created.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Parses `A..B`, `A,B,C` or `A` into strictly increasing counts in 1..=256.
pub fn parse_counts(s: &str) -> Result<Vec<usize>, String> {
    let bad = |m: String| Err(format!("--counts {s:?}: {m}"));
    let num = |t: &str| t.trim().parse::<usize>().map_err(|_| format!("--counts {s:?}: {t:?} is not a count"));
    let v: Vec<usize> = if let Some((a, b)) = s.split_once("..") {
        let (a, b) = (num(a)?, num(b.trim_start_matches('='))?);
        if a > b {
            return bad(format!("the range {a}..{b} is empty"));
        }
        (a..=b).collect()
    } else {
        s.split(',').map(num).collect::<Result<_, _>>()?
    };
    if v.iter().any(|&n| n == 0 || n > MAX_COUNT) {
        return bad(format!("counts must be in 1..={MAX_COUNT}"));
    }
    if v.windows(2).any(|w| w[0] >= w[1]) {
        return bad("counts must be strictly increasing".into());
    }
    Ok(v)
}

/// What a sample-set bake produced.
#[derive(Debug)]
pub struct VoOutcome {
    /// The `--json` object (without `output`).
    pub report: serde_json::Value,
    /// Bytes written.
    pub bytes: u64,
}

/// The cache key of a bake (tool version and normalised parameters).
pub fn cache_key(p: &VoParams) -> String {
    let v = json!({"tool": env!("CARGO_PKG_VERSION"), "stage": "vo", "params": p});
    blake3::hash(v.to_string().as_bytes()).to_hex().to_string()
}

/// Bakes the sets of `p` and writes the asset atomically.
pub fn bake_to(p: &VoParams, output: &Path, mode: ProgressMode, key: Option<String>) -> Result<VoOutcome, CliError> {
    let start = Instant::now();
    p.validate().map_err(CliError::input)?;
    let reporter = Reporter::new("vo", mode);
    let b = bake(p, &reporter).map_err(CliError::input)?;
    reporter.finish();
    let params = serde_json::to_value(p).map_err(CliError::internal)?;
    let key = key.unwrap_or_else(|| cache_key(p));
    let asset = penumbra_vo::asset::to_asset(&b, params, Some(&key)).map_err(CliError::internal)?;
    ensure_parent(output)?;
    let bytes = asset.write_atomic(output).with_context(|| format!("cannot write {}", output.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    let vs: serde_json::Map<String, serde_json::Value> = versus(&b.comparison, 16)
        .into_iter()
        .map(|(k, v)| (k.to_string(), serde_json::to_value(v).unwrap_or_default()))
        .collect();
    let report = json!({
        "sets": b.sets.len(),
        "domains": ["disk", "ball"],
        "counts": p.counts,
        "bytes": bytes,
        "seconds": seconds,
        "electrostatic_vs_n_le_16": vs,
        "comparison": b.comparison,
    });
    Ok(VoOutcome { report, bytes })
}

/// Builds the parameters of the command line.
pub fn params(a: &VoArgs) -> Result<VoParams, CliError> {
    let counts = parse_counts(&a.counts).map_err(|e| CliError::input(anyhow!(e)))?;
    Ok(VoParams {
        counts,
        seed: a.seed,
        starts: a.starts as usize,
        noise_trials: a.noise_trials as usize,
        ..VoParams::default()
    })
}

/// Runs `penumbra vo`.
#[allow(clippy::print_stderr)]
pub fn run(a: &VoArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let p = params(a)?;
    let out = bake_to(&p, &a.output, mode, None)?;
    let mut v = out.report;
    if a.json {
        if let Some(o) = v.as_object_mut() {
            o.insert("output".into(), json!(a.output.display().to_string()));
        }
        print_json(&v);
    } else {
        eprintln!(
            "wrote {} ({} bytes) in {:.2} s: {} sets (disk/ball × centre/no centre × N = {:?})",
            a.output.display(),
            out.bytes,
            v["seconds"].as_f64().unwrap_or(f64::NAN),
            v["sets"],
            p.counts
        );
        for (k, s) in v["electrostatic_vs_n_le_16"].as_object().into_iter().flatten() {
            eprintln!(
                "  vs {k:8} (2 ≤ N ≤ 16, {} rows): median ratio cell_cv {:.3}, noise {:.3}; ≥20 % better: cv {} rows, noise {} rows",
                s["rows"],
                s["cell_cv_ratio_median"].as_f64().unwrap_or(f64::NAN),
                s["noise_ratio_median"].as_f64().unwrap_or(f64::NAN),
                s["cell_cv_wins_20pct"],
                s["noise_wins_20pct"]
            );
        }
    }
    Ok(ExitCode::Ok)
}

#[cfg(test)]
mod tests {
    use super::parse_counts;

    #[test]
    fn counts() {
        assert_eq!(parse_counts("1..4").unwrap(), vec![1, 2, 3, 4]);
        assert_eq!(parse_counts("1..=3").unwrap(), vec![1, 2, 3]);
        assert_eq!(parse_counts("5,9,12").unwrap(), vec![5, 9, 12]);
        assert_eq!(parse_counts("7").unwrap(), vec![7]);
        assert!(parse_counts("0..4").unwrap_err().contains("1..=256"));
        assert!(parse_counts("9,5").unwrap_err().contains("increasing"));
        assert!(parse_counts("4..2").unwrap_err().contains("empty"));
        assert!(parse_counts("x").is_err());
        assert!(parse_counts("1..300").is_err());
    }
}
