//! Config types. Field docs become the JSON Schema descriptions.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A penumbra bake: one config names every asset a scene needs; only those are baked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "penumbra bake configuration")]
pub struct BakeConfig {
    /// Directory for the baked assets and `report.json`, relative to this file.
    pub output_dir: String,
    /// SH log/exp and proxy tables (`penumbra tables`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tables: Option<TablesStage>,
    /// Bounding sphere sets, one per entry (`penumbra spheres`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub spheres: Vec<SpheresStage>,
    /// MRT dictionary (`penumbra mrt dict`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mrt: Option<MrtStage>,
    /// FIV occlusion textures, one `[[fiv]]` table per occluder (`penumbra fiv`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fiv: Vec<FivStage>,
    /// MRT level operators (`penumbra mrt level`) with the `[mrt]` stage's dictionary.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mrt_level: Option<MrtLevelStage>,
    /// DRT clutter operators (`penumbra drt`): the `[mrt]` dictionary with the `[mrt_level]`
    /// level and a clutter file, or a built-in example scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drt: Option<DrtStage>,
    /// Volumetric-obscurance sample sets (`penumbra vo`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vo: Option<VoStage>,
}

impl BakeConfig {
    /// Whether the config names at least one stage. Every stage added to the config is
    /// listed here.
    pub fn has_stage(&self) -> bool {
        self.tables.is_some()
            || !self.spheres.is_empty()
            || !self.fiv.is_empty()
            || self.mrt.is_some()
            || self.mrt_level.is_some()
            || self.drt.is_some()
            || self.vo.is_some()
    }
}

/// The `[tables]` stage: SH tables for one SH order (SHEXP §4–7, IBPA §4–5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TablesStage {
    /// SH order n (bands), 2..=8.
    pub order: u32,
    /// Samples of the 1D tables in θ / α, 16..=16384 (default 256).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta_samples: Option<u32>,
    /// Shading tolerance of the expansion-factor analysis, 0 < T < 1 (default 1/256).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading_tolerance: Option<f64>,
    /// Optional environment map (lat-long .exr or .hdr) to specialise η to its lighting.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env: Option<String>,
    /// Output file name inside `output_dir` (default `tables.shtb`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl TablesStage {
    /// Output file name.
    pub fn output_name(&self) -> &str {
        self.output.as_deref().unwrap_or("tables.shtb")
    }
}

/// Sphere-fitting method of a `[[spheres]]` entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum SphereMethod {
    /// Variational fit: flood-fill clustering, Powell, teleportation (SHEXP §6.2).
    Lloyd,
    /// Baseline: spheres around the occupied cells of an octree level (Hubbard 1995).
    Octree,
}

/// A `[[spheres]]` entry: a bounding sphere set for one mesh (SHEXP §6.2–6.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpheresStage {
    /// Mesh file (.obj, .gltf, .glb), relative to this config.
    pub mesh: String,
    /// Number of spheres, 1..=4096 (give exactly one of this, `target_error` and
    /// `target_union`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u32>,
    /// Fit the smallest count whose outside volume ratio E is at most this (> 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f64>,
    /// Fit the smallest count whose union outside ratio is at most this (> 0; what leaks
    /// light: `penumbra spheres --target-union`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_union: Option<f64>,
    /// With a target: the largest count the search tries, 1..=4096 (default 256; an
    /// unreachable target writes the best set and says so in the stage's metrics).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_count: Option<u32>,
    /// `lloyd` (default) or `octree`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<SphereMethod>,
    /// Grid resolution, 8..=256 (default 48).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<u32>,
    /// Maximum iterations, 1..=10000 (default 100).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u32>,
    /// Seed (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Build the sphere hierarchy (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hierarchy: Option<bool>,
    /// Compute skin weights for a skinned glTF (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skin: Option<bool>,
    /// Finish with the union polish (`penumbra spheres --polish`: a tighter union at about
    /// twice the CPU time, docs/spheres.md; default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polish: Option<bool>,
    /// With `skin = true`: pad the radii so the set stays bounding in every animation pose
    /// (`penumbra spheres --skin-padding`; default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skin_padding: Option<bool>,
    /// Proxy albedo (IBPA §5), one value or `[r, g, b]`, each in [0, 1], for triangles
    /// without a glTF material (all of an OBJ): `penumbra spheres --albedo`. Per-sphere
    /// albedo is stored (SPHR `albedo`) when this is given or the glTF has materials.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<crate::clutter::Albedo>,
    /// Fit only the glTF node(s) with this name (exact; see `node` for patterns).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_name: Option<String>,
    /// Fit only the glTF nodes whose name matches (glob: `*` any run, `?` one character),
    /// and their descendants: one pattern or a list (`penumbra spheres --node`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<NodeSelect>,
    /// Output file name inside `output_dir` (default: the mesh's file stem + `.sphr`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

/// glTF node selection: one name pattern or a list of them (glob: `*` any run of characters,
/// `?` one character; a node is selected when its name or an ancestor's matches any).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum NodeSelect {
    /// One pattern.
    One(String),
    /// Several patterns (a node matching any is selected).
    Many(Vec<String>),
}

impl NodeSelect {
    /// The patterns, in order.
    pub fn patterns(&self) -> Vec<String> {
        match self {
            NodeSelect::One(p) => vec![p.clone()],
            NodeSelect::Many(v) => v.clone(),
        }
    }
}

/// Polar axis of the FIV sample shells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// +Y up (glTF, most OBJ files).
    Y,
    /// +Z up.
    Z,
}

/// A 180° rotation of the environment about an axis (an exact texel permutation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum EnvRotate {
    /// As stored.
    None,
    /// (x, y, z) → (x, −y, −z).
    X180,
    /// (x, y, z) → (−x, y, −z).
    Y180,
    /// (x, y, z) → (−x, −y, z); brings grace_latlong.exr upright.
    Z180,
}

/// One `[[fiv]]` stage: FIV occlusion textures for one occluder under one environment
/// (FIV §4.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FivStage {
    /// Occluder mesh (.obj, .gltf, .glb; relative to this file) or a procedural occluder:
    /// `builtin:torus`, `builtin:sphere`.
    pub mesh: String,
    /// With a glTF `mesh`: only the nodes whose name matches (glob: `*` any run, `?` one
    /// character), and their descendants: one pattern or a list (`penumbra fiv --node`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<NodeSelect>,
    /// Environment map (lat-long .exr or .hdr; relative to this file) or
    /// `builtin:area-lights`.
    pub env: String,
    /// Rotation of the environment (default `none`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_rotate: Option<EnvRotate>,
    /// Samples `[azimuth, polar, radial]`: azimuth 2..=4096, polar 2..=2049, radial 2..=1024
    /// (default `[32, 17, 15]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<[u32; 3]>,
    /// Innermost shell radius in units of the bounding radius, 0 <= r_min < r_max
    /// (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_min: Option<f64>,
    /// Outermost shell radius in units of the bounding radius, r_min < r_max <= 1000
    /// (default 8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_max: Option<f64>,
    /// Polar axis of the shells (default `y`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<UpAxis>,
    /// Environment cube face size, 1..=512 (default 32: the paper's 6×32×32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cube_size: Option<u32>,
    /// Irradiance cube face size, 1..=256 (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiance_size: Option<u32>,
    /// Store the FIVs as f16 (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half: Option<bool>,
    /// Instead of `samples` and `cube_size`: the `verify fiv --plane` NRMSE to reach; the bake
    /// walks `penumbra fiv --target-nrmse`'s ladder to the cheapest rung meeting it (exit 1,
    /// the best asset written, when none does). A finite value > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<f64>,
    /// Quality gate checked after the bake: `verify fiv --plane` with its defaults, exit 1
    /// above a bound (e.g. `gate = { max_nrmse = 0.05 }`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gate: Option<crate::gate::FivGate>,
    /// Output file name inside `output_dir` (default: the mesh's file stem or builtin name,
    /// with `.fivt`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

/// The `[mrt]` stage: an MRT dictionary (MRT thesis ch. 3–4, App. A–B). Defaults are the
/// thesis settings (16² texels per face, k_d 64, k_b 32, 16K rays).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MrtStage {
    /// `cube2d` (six shapes, default) or `closed-cube`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dictionary: Option<String>,
    /// Texels per face edge, 2..=24 (default 16).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub face_res: Option<u32>,
    /// Light-prior vectors k_d, 1..=256 (default 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kd: Option<u32>,
    /// Indirect modes k_b, 1..=kd (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kb: Option<u32>,
    /// Gather rays per texel for F, 16..=1048576 (default 16384).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rays: Option<u32>,
    /// Diffuse albedo in F, 0 < A <= 1 (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<f64>,
    /// Enrichment iterations (App. A), 0..=8 (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub enrich: Option<u32>,
    /// Face-restricted prior vectors per face in the enrichment fallback, 0..=kd (default 16;
    /// 0 = face constants only, as in the thesis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fallback_modes: Option<u32>,
    /// How gathers read the texels they hit: `bilinear` (default) or `exact` form factors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gather: Option<String>,
    /// Balance F's row and column sums to the exact wall fractions so that energy is
    /// conserved exactly (default true; docs/mrt.md, "Energy").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub balance: Option<bool>,
    /// Runtime rule recorded in the dictionary: a face's indirect light leaves out the
    /// reduced operator's transfer from that face to itself (default true; docs/mrt.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exclude_same_face: Option<bool>,
    /// Prior light positions: `lattice` (i/7, default) or `cells` ((i+1/2)/6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_layout: Option<String>,
    /// Sphere-light radius (cube edge 1), 0 < r <= 0.08 (default 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_radius: Option<f64>,
    /// Rays per texel of the vector-irradiance gather, 16..=65536 (default 1024).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vector_rays: Option<u32>,
    /// Volume probes per axis, 1..=16 (default 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume_res: Option<u32>,
    /// Rays per volume probe, 16..=65536 (default 4096).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe_rays: Option<u32>,
    /// Lights per shape for the error measurements, 1..=64 (default 8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_lights: Option<u32>,
    /// Rays per texel of the path-traced reference, 2..=65536 (default 1024).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_rays: Option<u32>,
    /// Seed of every hashed random draw (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Bake the interface operators (default true; needed by `[mrt_level]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interfaces: Option<bool>,
    /// Reduced lightfield modes, 1..=512 (default 128).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_rlf: Option<u32>,
    /// Interface response modes, 1..=k_rlf (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_r: Option<u32>,
    /// Lightfield spatial samples per interface edge, 2..=32 (default 12).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_spatial: Option<u32>,
    /// Lightfield directional samples per square edge, 2..=64 (default 24).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_dir: Option<u32>,
    /// Directional supersamples per cell edge, 1..=8 (default 5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_super: Option<u32>,
    /// Enrichment iterations of the lightfield basis, 0..=8 (default 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interface_enrich: Option<u32>,
    /// Cosine gather rays per texel of the interface response, 16..=65536 (default 1024).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub response_rays: Option<u32>,
    /// Bake the interfaces' vector and volume response `U_r⃗`, `U_rvol` (default true; MRTD
    /// kind_version 4; false keeps the kind-version-3 bytes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interface_vectors: Option<bool>,
    /// Bake only the shapes the `[mrt_level]` level uses, plus the closed cube (default true
    /// when the config has `[mrt_level]` and `[drt]` uses no built-in example scene; false
    /// bakes the whole dictionary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level_shapes_only: Option<bool>,
    /// Output file name inside `output_dir` (default `dictionary.mrtd`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl SpheresStage {
    /// Output file name.
    pub fn output_name(&self) -> String {
        match &self.output {
            Some(o) => o.clone(),
            None => {
                let stem = std::path::Path::new(&self.mesh).file_stem().map(|s| s.to_string_lossy().into_owned());
                format!("{}.sphr", stem.unwrap_or_else(|| "spheres".into()))
            }
        }
    }
}

impl MrtStage {
    /// Output file name.
    pub fn output_name(&self) -> &str {
        self.output.as_deref().unwrap_or("dictionary.mrtd")
    }
}

impl FivStage {
    /// Output file name.
    pub fn output_name(&self) -> String {
        if let Some(o) = &self.output {
            return o.clone();
        }
        let base = self.mesh.strip_prefix("builtin:").unwrap_or(&self.mesh);
        let stem = std::path::Path::new(base).file_stem().map(|s| s.to_string_lossy().into_owned());
        format!("{}.fivt", stem.filter(|s| !s.is_empty()).unwrap_or_else(|| "occluder".into()))
    }
}

/// The `[mrt_level]` stage: the level operators of a block layout (MRT thesis §3.5.3, §4.3,
/// §4.6) with the dictionary of the `[mrt]` stage. Give `level` or `maze`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MrtLevelStage {
    /// Level file (TOML, schemas/mrt-level.schema.json), relative to this config.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<String>,
    /// A random connected 2D maze of this many blocks instead of a level file, 1..=4096.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maze: Option<u32>,
    /// Seed of the maze (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Depth limit of the propagation (interfaces crossed), 0..=64 (default 8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_depth: Option<u32>,
    /// Quality gate checked after the bake: `verify mrt` on the baked level with its defaults,
    /// exit 1 when `rel_error_one_bounce` is above `max_rel_error`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gate: Option<crate::gate::RelErrorGate>,
    /// Output file name inside `output_dir` (default `level.mrtl`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

/// The `[drt]` stage: Delta Radiance Transfer clutter operators (MRT thesis ch. 5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DrtStage {
    /// Clutter file (TOML, schemas/clutter.schema.json), relative to this config; the level is
    /// the `[mrt_level]` stage's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clutter: Option<String>,
    /// A built-in scene instead (`pillars`, `cornell`, `maze-boxes`); it brings its own level.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub example: Option<String>,
    /// Rays per texel, 16..=1048576 (default 1024).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rays: Option<u32>,
    /// Rays per clutter texel, 16..=1048576 (default: `rays`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clutter_rays: Option<u32>,
    /// Receiving blocks within this many hops of clutter, 0..=16 (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neighborhood: Option<u32>,
    /// Rank of C_b and C_c, 1..=256 (default 5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kc: Option<u32>,
    /// Rank of ΔU_c, 1..=4096 (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kdc: Option<u32>,
    /// Texels per box-face edge, 2..=64 (default 16).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clutter_res: Option<u32>,
    /// Charts per box-face edge, dividing clutter_res (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clutter_basis_res: Option<u32>,
    /// Inpaint scene texels inside clutter (default true).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inpaint: Option<bool>,
    /// Also bake the vector operators and the U_dyn volume probes (MRT thesis §5.4.3) with
    /// this many uniform rays per texel, 16..=262144 (`penumbra drt --vector --vector-rays`;
    /// absent: scalar operators only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vector_rays: Option<u32>,
    /// U_dyn probes per block edge, 1..=16 (default: the dictionary's volume_res); needs
    /// `vector_rays`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume_res: Option<u32>,
    /// Instead of `rays` and `clutter_rays`: the `verify drt` one-bounce error
    /// `rel_error_mrt_drt` to reach; the bake walks `penumbra drt --target-error`'s ladder to
    /// the cheapest rung meeting it (exit 1, the best asset written, when none does). A finite
    /// value > 0; not with `vector_rays` or a state file's incremental re-bake.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<f64>,
    /// Quality gate checked after the bake: `verify drt` on the baked operators with its
    /// defaults, exit 1 when `rel_error_mrt_drt` is above `max_rel_error`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gate: Option<crate::gate::RelErrorGate>,
    /// Output file name inside `output_dir` (default `clutter.drto`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl DrtStage {
    /// The output file name.
    pub fn output_name(&self) -> &str {
        self.output.as_deref().unwrap_or("clutter.drto")
    }
}

impl MrtLevelStage {
    /// The output file name.
    pub fn output_name(&self) -> &str {
        self.output.as_deref().unwrap_or("level.mrtl")
    }
}

/// The `[vo]` stage: volumetric-obscurance sample sets for line/area sampling of the disk and
/// point sampling of the ball, with and without the centre sample (MRT thesis §6.3.5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VoStage {
    /// Sample counts N, strictly increasing, each 1..=256 (default 1, 2, …, 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub counts: Option<Vec<u32>>,
    /// Seed of every random draw (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Poisson starting sets per electrostatic set, 1..=1000 (default 24).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub starts: Option<u32>,
    /// Random half-spaces per noise measurement, 1..=1000000 (default 4096).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_trials: Option<u32>,
    /// Quality gate checked after the bake: `verify vo --sets <the baked sets>` on `mesh` with
    /// its defaults, exit 1 when `rmse_vs_volume` is above `max_rmse`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gate: Option<crate::gate::VoGate>,
    /// Output file name inside `output_dir` (default `sets.voss`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl VoStage {
    /// The output file name.
    pub fn output_name(&self) -> &str {
        self.output.as_deref().unwrap_or("sets.voss")
    }
}
