//! Command-line arguments (clap derive). `penumbra --help` is the reference; README.md
//! has a tour.

use crate::progress::ProgressMode;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// penumbra — offline bakes for real-time soft global illumination.
#[derive(Debug, Parser)]
#[command(name = "penumbra", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// Worker threads (default: all cores). Output bytes never depend on it.
    #[arg(long, global = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Progress display on stderr.
    #[arg(long, global = true, value_enum, default_value_t = ProgressMode::Auto)]
    pub progress: ProgressMode,
    /// Command.
    #[command(subcommand)]
    pub command: Command,
}

/// Commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Bake the SH log/exp and proxy tables for one SH order (SHEXP §4–7, IBPA §4–5).
    Tables(TablesArgs),
    /// Modular Radiance Transfer bakes: `mrt dict` (MRT thesis ch. 3–4, App. A–B).
    Mrt(crate::commands::mrt::MrtArgs),
    /// Show an asset's header, sections, checksums, metadata and values.
    Inspect(InspectArgs),
    /// Run every stage of a bake config (only the stages whose inputs changed).
    Bake(BakeArgs),
    /// Print the JSON Schema of the bake config.
    Schema,
}

fn parse_tolerance(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 1.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < T < 1)")) }
}

/// `penumbra tables`.
#[derive(Debug, Args)]
pub struct TablesArgs {
    /// SH order n (number of bands).
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=8))]
    pub order: u32,
    /// Samples of the 1D tables in θ and α.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=16384))]
    pub theta_samples: u32,
    /// Shading tolerance of the expansion-factor (η) analysis.
    #[arg(long, default_value = "0.00390625", value_parser = parse_tolerance)]
    pub shading_tolerance: f64,
    /// Environment map (lat-long .exr/.hdr) to specialise the shadow η to its lighting.
    #[arg(long)]
    pub env: Option<PathBuf>,
    /// Output asset (.shtb). Parent directories are created.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print one JSON object with the metrics on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `penumbra inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// Asset file.
    pub asset: PathBuf,
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Print section values (summary statistics for large sections).
    #[arg(long)]
    pub dump: bool,
    /// Print one section whole (`--json`: {"name","dtype","dims","values"}, row-major).
    #[arg(long, value_name = "NAME")]
    pub section: Option<String>,
}

/// `penumbra bake`.
#[derive(Debug, Args)]
pub struct BakeArgs {
    /// Bake config (TOML).
    pub config: PathBuf,
    /// Run only this stage (e.g. `tables`).
    #[arg(long, value_name = "STAGE")]
    pub only: Option<String>,
    /// Run the deterministic slice K of N (0-based K) of the independent work items.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Re-bake even when the output is up to date.
    #[arg(long)]
    pub force: bool,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}
