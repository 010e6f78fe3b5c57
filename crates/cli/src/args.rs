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
    /// Fit bounding sphere sets to a mesh (SHEXP §6.2–6.3), or export one for viewing.
    Spheres(SpheresArgs),
    /// Modular Radiance Transfer bakes: `mrt dict` (MRT thesis ch. 3–4, App. A–B).
    Mrt(crate::commands::mrt::MrtArgs),
    /// Show an asset's header, sections, checksums, metadata and values.
    Inspect(InspectArgs),
    /// Run every stage of a bake config (only the stages whose inputs changed).
    Bake(BakeArgs),
    /// Accuracy of baked assets against brute-force references (`verify mrt`).
    Verify(crate::commands::verify::VerifyArgs),
    /// Print the JSON Schema of the bake config (or, with --level, of the MRT level file).
    Schema(SchemaArgs),
}

/// `penumbra schema`.
#[derive(Debug, clap::Args)]
pub struct SchemaArgs {
    /// The schema of the MRT level file (`penumbra mrt level`) instead.
    #[arg(long)]
    pub level: bool,
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

/// Sphere-fitting method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SphereMethod {
    /// Variational fit: flood-fill clustering, Powell, teleportation (SHEXP §6.2).
    Lloyd,
    /// Baseline: spheres around the occupied cells of an octree level (Hubbard 1995).
    Octree,
}

fn parse_positive(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v.is_finite() { Ok(v) } else { Err(format!("{v} is out of range (allowed: a positive number)")) }
}

/// `penumbra spheres`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
#[command(group = clap::ArgGroup::new("sphere_target").required(true).multiple(false).args(["count", "target_error"]))]
pub struct SpheresArgs {
    /// `export`: write a fitted set as an OBJ for viewing.
    #[command(subcommand)]
    pub action: Option<SpheresAction>,
    /// The fit.
    #[command(flatten)]
    pub fit: SpheresFitArgs,
}

/// `penumbra spheres <mesh> ...`.
#[derive(Debug, Args)]
pub struct SpheresFitArgs {
    /// Mesh to bound (.obj, .gltf, .glb).
    #[arg(required = true)]
    pub mesh: Option<PathBuf>,
    /// Number of spheres (octree: about this many).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub count: Option<u32>,
    /// Fit the smallest count whose outside volume ratio E = Σ V(Sᵢ − T)/V(T) is at most this.
    #[arg(long, value_parser = parse_positive)]
    pub target_error: Option<f64>,
    /// Fitting method.
    #[arg(long, value_enum, default_value_t = SphereMethod::Lloyd)]
    pub method: SphereMethod,
    /// Grid resolution: about R³ cells in the mesh's bounding box (interior points, volume model).
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(8..=256))]
    pub grid: u32,
    /// Maximum clustering + update iterations (teleport trials included).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub iterations: u32,
    /// Seed of the initial centres and of the measurements.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Also build the sphere hierarchy (SHEXP §6.3, branching 4).
    #[arg(long)]
    pub hierarchy: bool,
    /// Also compute per-sphere bone weights (skinned glTF) and check them on the animations.
    #[arg(long)]
    pub skin: bool,
    /// Fit only the glTF node(s) with this name.
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Output asset (.sphr). Parent directories are created.
    #[arg(short = 'o', long, required = true)]
    pub output: Option<PathBuf>,
    /// Print one JSON object with the metrics on stdout.
    #[arg(long)]
    pub json: bool,
    /// Log every iteration (E, accepted or not) on stderr.
    #[arg(long)]
    pub verbose: bool,
}

/// Subcommands of `penumbra spheres`.
#[derive(Debug, Subcommand)]
pub enum SpheresAction {
    /// Write the spheres of an SPHR asset as a triangle mesh (OBJ), one icosphere each.
    Export(SpheresExportArgs),
}

/// `penumbra spheres export`.
#[derive(Debug, Args)]
pub struct SpheresExportArgs {
    /// The SPHR asset.
    pub asset: PathBuf,
    /// Output OBJ file.
    #[arg(long, value_name = "FILE")]
    pub obj: PathBuf,
    /// Export hierarchy level L (0 = root) instead of the leaves.
    #[arg(long, value_name = "L")]
    pub level: Option<u32>,
    /// Icosphere subdivisions per sphere (0 = 20 triangles, 2 = 320).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=5))]
    pub subdivisions: u32,
}
