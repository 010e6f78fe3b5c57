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
    /// Bake FIV occlusion textures for an occluder under an environment (FIV §4.2);
    /// `penumbra fiv merge` joins shards.
    Fiv(FivArgs),
    /// Bake Delta Radiance Transfer clutter operators for a level (MRT thesis ch. 5).
    Drt(crate::commands::drt::DrtArgs),
    /// Volumetric-obscurance sample sets: electrostatic 1/d⁴ sets for line/area sampling of
    /// the disk and point sampling of the ball, against Lloyd/Halton/Poisson (MRT thesis §6.3.5).
    Vo(crate::commands::vo::VoArgs),
    /// Measure an asset's accuracy against the brute-force reference.
    Verify(VerifyArgs),
    /// Run one bake over a grid of its knobs and plot error against cost.
    Sweep(SweepArgs),
    /// Print the JSON Schema of the bake config (or, with --level, of the MRT level file).
    Schema(SchemaArgs),
    /// Write the bake config a glTF level needs: roles from node extras or --role ROLE=GLOB
    /// (characters → sphere sets, occluders → FIV, clutter → DRT, blocks → MRT level).
    Plan(crate::commands::plan::PlanArgs),
    /// The runtime's WGSL shaders: `shaders export -o DIR` writes them with their SPIR-V, HLSL,
    /// GLSL and MSL translations (naga) and a README of bindings and layouts.
    Shaders(crate::commands::shaders::ShadersArgs),
}

/// `penumbra schema`.
#[derive(Debug, clap::Args)]
pub struct SchemaArgs {
    /// The schema of the MRT level file (`penumbra mrt level`) instead.
    #[arg(long, conflicts_with = "clutter")]
    pub level: bool,
    /// The schema of the DRT clutter file (`penumbra drt --clutter`) instead.
    #[arg(long)]
    pub clutter: bool,
}

/// `penumbra tables --log-form`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LogFormArg {
    /// `Rᵀ q'(D̃) R (g − 1)`, `D̃ = max(D, ε)`, as SHEXP eq. 30–32 write it.
    Paper,
    /// `log(M̃_g)·1`: eq. 30 on the clipped matrix (the pre-#14 form).
    Matrix,
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
    /// Form of the eigen SH log once eigenvalue clipping engages (SHEXP eq. 30–32).
    #[arg(long, value_enum, default_value_t = LogFormArg::Paper)]
    pub log_form: LogFormArg,
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
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct BakeArgs {
    /// `merge`: join the output directories of sharded runs.
    #[command(subcommand)]
    pub command: Option<BakeCommand>,
    /// Bake config (TOML).
    #[arg(required = true)]
    pub config: Option<PathBuf>,
    /// Write the outputs and the report here instead of the config's `output_dir` (one
    /// directory per shard on a batch system; join them with `penumbra bake merge`).
    #[arg(long, value_name = "DIR")]
    pub output_dir: Option<PathBuf>,
    /// Run only this stage (e.g. `tables`).
    #[arg(long, value_name = "STAGE")]
    pub only: Option<String>,
    /// Run the deterministic slice K of N (0-based K) of the independent work items.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Re-bake even when the output is up to date (and ignore the shared cache's entries).
    #[arg(long)]
    pub force: bool,
    /// Shared content-addressed cache (e.g. a network directory): a stage whose cache key has
    /// a valid entry there is copied from it instead of baked ("from-cache"), and every baked
    /// or up-to-date output is stored there under its key.
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
    /// With --cache-dir: read entries, never write them (CI consumers of a cache that a
    /// trusted job fills).
    #[arg(long, requires = "cache_dir")]
    pub cache_read_only: bool,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `penumbra bake` subcommands.
#[derive(Debug, Subcommand)]
pub enum BakeCommand {
    /// Join the output directories of `penumbra bake CONFIG --shard K/N --output-dir DIR_K`
    /// (all N of them) into what one unsharded run writes: the same assets, byte for byte, and
    /// one `report.json`.
    Merge(BakeMergeArgs),
}

/// `penumbra bake merge`.
#[derive(Debug, Args)]
pub struct BakeMergeArgs {
    /// The shards' output directories, each holding one `report.shard-K-of-N.json`.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// The merged output directory.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print the merged report as JSON on stdout.
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

/// Initial centres of the Lloyd sphere fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SphereSeeding {
    /// Farthest-point sampling along the medial axis (ridges of the distance to the surface).
    Medial,
    /// k-means++ (D² sampling) over all surface and interior elements.
    #[value(name = "kmeans++")]
    KmeansPlusPlus,
}

fn parse_positive(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v.is_finite() { Ok(v) } else { Err(format!("{v} is out of range (allowed: a positive number)")) }
}

/// `penumbra spheres`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
#[command(group = clap::ArgGroup::new("sphere_target").required(true).multiple(false).args(["count", "target_error", "target_union"]))]
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
    /// Fit the smallest count whose union outside ratio V(∪Sᵢ − T)/V(T) is at most this.
    #[arg(long, value_parser = parse_positive)]
    pub target_union: Option<f64>,
    /// Largest count a --target-error/--target-union search tries; a target no count up to it
    /// meets exits 1 with the best set written.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub max_count: Option<u32>,
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
    /// Initial centres of the Lloyd fit: along the medial axis (ridges of the distance to the
    /// surface) or k-means++ over all elements.
    #[arg(long, value_enum, default_value_t = SphereSeeding::Medial)]
    pub seeding: SphereSeeding,
    /// Skip the union-aware refinement after the Lloyd fit (shrink spheres to what no other
    /// sphere bounds, drop and re-split the redundant ones).
    #[arg(long)]
    pub no_refine: bool,
    /// After the refinement, move spheres to lower the union's outside volume directly
    /// (single and pairwise moves, measured on exactly classified outside points; slower).
    #[arg(long)]
    pub polish: bool,
    /// Also build the sphere hierarchy (SHEXP §6.3, branching 4).
    #[arg(long)]
    pub hierarchy: bool,
    /// Also compute per-sphere bone weights (skinned glTF) and check them on the animations.
    #[arg(long)]
    pub skin: bool,
    /// With --skin: pad sphere radii so the set stays bounding in every animation pose
    /// (32 sampled times per animation; issue #14).
    #[arg(long, requires = "skin")]
    pub skin_padding: bool,
    /// Albedo of the proxies (IBPA §5), `R,G,B` or one value in [0, 1], for triangles without
    /// a glTF material (all of an OBJ). Per-sphere albedo is stored (SPHR `albedo`) when this
    /// is given or the glTF has materials (their baseColorFactor).
    #[arg(long, value_name = "R,G,B")]
    pub albedo: Option<String>,
    /// Fit only the glTF node(s) with this name (and their descendants).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Fit only the glTF nodes whose name matches PATTERN (glob: `*` any run of characters,
    /// `?` one character), and their descendants. Repeatable: a node matching any is taken.
    #[arg(long, value_name = "PATTERN")]
    pub node: Vec<String>,
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

/// `penumbra fiv`: bake (default) or `merge`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct FivArgs {
    /// `merge`: join shard assets.
    #[command(subcommand)]
    pub command: Option<FivCommand>,
    /// Bake options.
    #[command(flatten)]
    pub bake: FivBakeArgs,
}

/// Subcommands of `penumbra fiv`.
#[derive(Debug, Subcommand)]
pub enum FivCommand {
    /// Join the shards of one bake (`--shard K/N`, any order) into the bytes a single run writes.
    Merge(ShardMergeArgs),
    /// Export a table for the GPU: a KTX2 RGBA32F 3D texture (docs/fiv.md, "GPU export").
    Export(FivExportArgs),
}

/// `penumbra fiv export`.
#[derive(Debug, Args)]
pub struct FivExportArgs {
    /// The FIVT asset.
    pub asset: PathBuf,
    /// Output KTX2 file (written atomically; parent directories are created).
    #[arg(long, value_name = "OUT.ktx2")]
    pub ktx2: PathBuf,
    /// RGBA16F texels (`VK_FORMAT_R16G16B16A16_SFLOAT`, half the memory) instead of RGBA32F;
    /// a value beyond f16's range is an error.
    #[arg(long)]
    pub half: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `penumbra fiv` bake options.
#[derive(Debug, Args)]
pub struct FivBakeArgs {
    /// Occluder mesh (.obj, .gltf, .glb) or a procedural one: `builtin:torus`, `builtin:sphere`.
    #[arg(long, required = true)]
    pub mesh: Option<String>,
    /// Only the glTF nodes whose name matches PATTERN (glob: `*` any run, `?` one character)
    /// and their descendants occlude. Repeatable: a node matching any is taken.
    #[arg(long, value_name = "PATTERN")]
    pub node: Vec<String>,
    /// Environment map (lat-long .exr or .hdr, OpenEXR orientation) or `builtin:area-lights`.
    /// Repeat (with one `-o` per `--env`, in order) to bake a table per environment from one
    /// visibility pass; each output has the bytes of its single-environment bake.
    #[arg(long, required = true)]
    pub env: Vec<String>,
    /// Rotate the environment by 180° about an axis before baking (exact texel permutation);
    /// `z180` brings the upside-down grace_latlong.exr probe upright.
    #[arg(long, value_enum, default_value_t = EnvRotateArg::None)]
    pub env_rotate: EnvRotateArg,
    /// Samples AxPxK: azimuth × polar (both poles) × radial shells.
    #[arg(long, default_value = "32x17x15", value_name = "AxPxK")]
    pub samples: String,
    /// Innermost shell radius in units of the bounding radius R (0 <= r_min < r_max).
    #[arg(long, default_value_t = 1.0)]
    pub r_min: f64,
    /// Outermost shell radius in units of R (r_min < r_max <= 1000).
    #[arg(long, default_value_t = 8.0)]
    pub r_max: f64,
    /// Polar axis of the shells: y (glTF, most OBJ) or z.
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    pub up: UpArg,
    /// Face size of the environment cube map (6·S² directional lights).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=512))]
    pub cube_size: u32,
    /// Face size of the diffuse irradiance cube map.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub irradiance_size: u32,
    /// Bake every environment turned by m/N of a full turn about +Y (m = 0..N, `--up y`; the
    /// map's width must be a multiple of N), one `-o` per environment and step (environment
    /// major), all from one visibility pass; the runtime blends the two nearest turns
    /// (`penumbra_runtime::fiv::yaw_blend`).
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=360))]
    pub yaw_steps: u32,
    /// Store the FIVs as f16 (18 bytes per sample instead of 36).
    #[arg(long)]
    pub half: bool,
    /// Bake only the azimuth slab K of N (0-based); `penumbra fiv merge` joins the slabs.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Choose --samples and --cube-size: the cheapest rung of a fixed ladder (ordered by
    /// A·P·K·6·S², docs/fiv.md "Targets") whose `verify fiv --plane` NRMSE is at most X, each
    /// candidate measured against one reference; writes that asset (the bytes of the plain
    /// bake with those knobs). None meets X: the best is written and the exit code is 1.
    #[arg(long, value_name = "X", value_parser = crate::commands::target::parse_target,
          conflicts_with_all = ["samples", "cube_size", "shard", "yaw_steps"])]
    pub target_nrmse: Option<f64>,
    /// With --target-nrmse: leave out ladder rungs whose cost A·P·K·6·S² (sample positions ×
    /// environment directions) is above N.
    #[arg(long, value_name = "N", requires = "target_nrmse")]
    pub max_cost: Option<u64>,
    /// Output asset (.fivt), one per `--env`. Parent directories are created.
    #[arg(short = 'o', long, required = true)]
    pub output: Vec<PathBuf>,
    /// Print one JSON object with the results on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Environment rotation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EnvRotateArg {
    /// As stored.
    None,
    /// (x, y, z) → (x, −y, −z).
    X180,
    /// (x, y, z) → (−x, y, −z).
    Y180,
    /// (x, y, z) → (−x, −y, z).
    Z180,
}

/// Polar axis choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum UpArg {
    /// +Y up.
    Y,
    /// +Z up.
    Z,
}

/// `penumbra fiv merge`.
#[derive(Debug, Args)]
pub struct ShardMergeArgs {
    /// Shard assets (every K of one bake's K/N, any order).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output asset.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `penumbra verify`.
#[derive(Debug, Args)]
pub struct VerifyArgs {
    /// What to verify.
    #[command(subcommand)]
    pub command: VerifyCommand,
}

/// Subcommands of `penumbra verify`.
#[derive(Debug, Subcommand)]
pub enum VerifyCommand {
    /// Sphere-proxy soft shadows (runtime) against ray-traced truth (SHEXP §4–7, Fig. 7).
    Shadows(crate::commands::verify_shadows::VerifyShadowsArgs),
    /// FIV shadows (runtime) against brute-force ray-traced irradiance (FIV §5).
    Fiv(VerifyFivArgs),
    /// MRT runtime (dictionary + level operators) against a path tracer on the same blocks:
    /// relative error of indirect light, one bounce and multi-bounce (MRT thesis §3.6).
    Mrt(crate::commands::verify_mrt::VerifyMrtArgs),
    /// MRT and MRT + DRT on a level with clutter against a path tracer that sees the clutter
    /// (MRT thesis ch. 5): indirect shadows and interreflections, scene and clutter.
    Drt(crate::commands::verify_drt::VerifyDrtArgs),
    /// Volumetric-obscurance estimators (lines, area, points; MRT thesis §6.3) on a ray-cast
    /// depth buffer against the obscurance integral over the mesh and over the height field.
    Vo(crate::commands::verify_vo::VerifyVoArgs),
    /// The WGSL twins of the runtime evaluators on a compute device (lavapipe will do) against
    /// the CPU runtime on the same inputs: max_rel_diff, adapter, gpu_ms, cpu_ms.
    Gpu(crate::commands::verify_gpu::VerifyGpuArgs),
}

/// Partial-occluder handling at run time (FIV §4.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PartialArg {
    /// Use the FIV as it is (default; wins in docs/fiv.md).
    None,
    /// Scale by (d + R)/2R.
    Scale,
}

/// `penumbra verify fiv`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("receivers").required(true).args(["plane", "placement"])))]
pub struct VerifyFivArgs {
    /// FIVT assets (one per occluder; repeat for several).
    #[arg(long = "fiv", required = true, value_name = "ASSET")]
    pub fivs: Vec<PathBuf>,
    /// Receivers on a ground plane touching the occluders' lowest point: 128×128 cell
    /// centres of the square ±3R around the centre's projection.
    #[arg(long)]
    pub plane: bool,
    /// A placement file (TOML): occluder offsets and receivers; see docs/fiv.md.
    #[arg(long, value_name = "FILE")]
    pub placement: Option<PathBuf>,
    /// Partial-occluder handling.
    #[arg(long, value_enum, default_value_t = PartialArg::None)]
    pub partial: PartialArg,
    /// Disable the multi-occluder overlap correction (eq. 13–14).
    #[arg(long)]
    pub no_overlap: bool,
    /// Write a PNG: runtime | reference | difference, each panel at least 512 px and titled,
    /// a colour bar for the difference in irradiance units, and the key figures in a caption.
    #[arg(long, value_name = "OUT.png")]
    pub image: Option<PathBuf>,
    /// Exit with code 1 when nrmse (all receivers) exceeds this.
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_nrmse: Option<f64>,
    /// Exit with code 1 when nrmse_visible exceeds this.
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_nrmse_visible: Option<f64>,
    /// Plane receivers: put the plane D·R below the occluders' lowest point (the occluders
    /// raised D radii; 0 to 1000) and widen the square to ±(3 + D)R.
    #[arg(long, value_name = "D")]
    pub distance: Option<f64>,
    /// Cast the reference against the stored environment cube supersampled to this face size
    /// (a multiple of the bake's cube size; each texel split into equal sub-texels), so the
    /// error of treating each texel as one direction is measured too.
    #[arg(long, value_name = "N")]
    pub reference_cube_size: Option<usize>,
    /// Cast the reference under this environment (the map the asset was baked from, checked
    /// by its content hash, with the bake's rotation) resampled to --reference-cube-size
    /// (default: the bake's cube size) instead of the stored cube: what `fiv --target-nrmse`
    /// and `sweep fiv` measure against, so a coarse cube's resampling error is seen too.
    #[arg(long, value_name = "ENV")]
    pub reference_env: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `penumbra sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// What to sweep.
    #[command(subcommand)]
    pub command: SweepCommand,
}

/// Subcommands of `penumbra sweep`.
#[derive(Debug, Subcommand)]
pub enum SweepCommand {
    /// Sphere-proxy shadows over sphere count × SH order × exponential.
    Shadows(crate::commands::sweep_shadows::SweepShadowsArgs),
    /// Sphere-set fits over sphere count × grid × method (union ratio and E against bake time).
    Spheres(crate::commands::sweep_spheres::SweepSpheresArgs),
    /// SH tables over SH order and θ samples: cap-table error against the exact functions,
    /// bake seconds and bytes.
    Tables(crate::commands::sweep_tables::SweepTablesArgs),
    /// FIV over shell samples, cube size and shell radii: shadow error against one shared
    /// ray-traced reference, bake seconds, runtime cost and bytes.
    Fiv(crate::commands::sweep_fiv::SweepFivArgs),
    /// DRT clutter operators over scene rays, clutter rays, neighbourhood and rank of C_b:
    /// one-bounce error against one shared path-traced reference, bake seconds and bytes.
    Drt(crate::commands::sweep_drt::SweepDrtArgs),
    /// MRT dictionaries over face resolution, k_d, k_b, gather rays, k_rlf and k_r: one- and
    /// multi-bounce error on a level against one path-traced reference per face resolution.
    Mrt(crate::commands::sweep_mrt::SweepMrtArgs),
}
