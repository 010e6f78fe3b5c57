//! `penumbra drt`: Delta Radiance Transfer clutter operators for a level (MRT thesis ch. 5).
//! The scene setup (dictionary, level, clutter, lights) is shared with `penumbra verify drt`.

use crate::commands::mrt_level::{LevelSource, load_dict, resolve, to_file, validated};
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use crate::progress::{ProgressMode, Reporter};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::AssetFile;
use penumbra_config::clutter::{BoxFacesName, ChartsName, load_clutter};
use penumbra_transport::TransportError;
use penumbra_transport::clutter::{BoxFaces, ClutterScene, ClutterShape, ClutterSpec, quat_y};
use penumbra_transport::drt::{DrtDict, DrtParams, DrtShard, KcMode, bake_incremental, bake_shard, bake_with_state};
use penumbra_transport::drt_asset::{DrtInputs, to_asset};
use penumbra_transport::drt_examples::example;
use penumbra_transport::drt_state::{DrtState, StateInstance};
use penumbra_transport::drt_vector::{
    DrtVectorBake, VectorIncStats, VectorItems, VectorMetrics, VectorParams, VectorReuse, bake_vector_items,
};
use penumbra_transport::level::{Level, Links};
use penumbra_transport::level_ops::DictOps;
use penumbra_transport::level_reference::PointLight;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Where a DRT scene comes from (shared by `drt` and `verify drt`).
#[derive(Debug, Args)]
pub struct DrtSceneArgs {
    /// The dictionary (.mrtd, kind_version 3: it carries the implicit lights L_imp).
    #[arg(long, required = true)]
    pub dict: Option<PathBuf>,
    /// The level: a level file (TOML) or a baked level asset (.mrtl, baked with --dict).
    /// Omit with --maze/--corridor/--l-turn or --example.
    #[arg(long)]
    pub level: Option<PathBuf>,
    /// Procedural level (with --example maze-boxes: the maze's size and seed).
    #[command(flatten)]
    pub source: LevelSource,
    /// A built-in scene: pillars (Fig. 5.4), cornell (Fig. 5.3), maze-boxes (--maze N --seed S
    /// --boxes M).
    #[arg(long, value_name = "NAME")]
    pub example: Option<String>,
    /// Boxes of --example maze-boxes.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    pub boxes: u32,
    /// Clutter file (TOML, schemas/clutter.schema.json); adds to an --example's clutter.
    #[arg(long, value_name = "FILE")]
    pub clutter: Option<PathBuf>,
    /// Texels per box-face edge, and per mesh's largest extent (thesis: 16).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=64))]
    pub clutter_res: u32,
    /// Charts (basis functions) per box-face edge: 1 = one constant per face (the thesis's
    /// basis), S = S×S piecewise-constant charts per face (default 2: docs/drt.md measures it).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub clutter_basis_res: u32,
}

/// A resolved DRT scene.
#[derive(Debug)]
pub struct DrtScene {
    /// The dictionary's level operators view.
    pub ops: DictOps,
    /// The dictionary's DRT view.
    pub dict: DrtDict,
    /// Level.
    pub level: Level,
    /// Its links.
    pub links: Links,
    /// What the level is (for reports).
    pub what: String,
    /// The baked level asset, when given (bytes, its depth limit).
    pub level_asset: Option<(Vec<u8>, usize)>,
    /// Clutter.
    pub clutter: ClutterScene,
    /// Normalised clutter descriptions and their hashes.
    pub clutter_json: Vec<Value>,
    /// The example's lights, if an example.
    pub example_lights: Option<Vec<PointLight>>,
    /// The clutter as given (before the scene normalises it), the texels per box-face edge
    /// and charts per face edge: what rebuilds a previous placement exactly.
    pub raw_clutter: (Vec<ClutterSpec>, usize, usize),
}

fn box_json(s: &ClutterSpec) -> Value {
    json!({"translate": s.translate, "rotate": s.rotate, "scale": s.scale, "albedo": s.albedo})
}

/// Reads the clutter file's instances (meshes relative to the file).
fn clutter_from_file(path: &Path) -> Result<(Vec<ClutterSpec>, Vec<Value>), CliError> {
    let f = load_clutter(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut specs = Vec::new();
    let mut desc = Vec::new();
    for (i, c) in f.clutter.iter().enumerate() {
        // unnamed instances are named after their file and entry, so every later error names them
        let name = c.name.clone().unwrap_or_else(|| {
            let what = c.mesh.as_deref().unwrap_or("box");
            // file names only: the asset's meta never holds directories
            let file = path.file_name().map_or_else(String::new, |f| f.to_string_lossy().into_owned());
            format!("{file} clutter[{i}], {what}")
        });
        let rotate = match (c.rotate, c.rotate_y_deg) {
            (Some(q), _) => q,
            (None, Some(d)) => quat_y(d),
            (None, None) => [0.0, 0.0, 0.0, 1.0],
        };
        let (shape, what) = if let Some(b) = &c.box_ {
            let faces = match b.faces.unwrap_or(BoxFacesName::All) {
                BoxFacesName::All => BoxFaces::All,
                BoxFacesName::NoBottom => BoxFaces::NoBottom,
            };
            let fname = if faces == BoxFaces::All { "all" } else { "no-bottom" };
            (ClutterShape::Box { size: b.size, faces }, json!({"box": {"size": b.size, "faces": fname}}))
        } else {
            let rel = c.mesh.as_deref().unwrap_or_default();
            let mp = base.join(rel);
            let h = crate::fsutil::hash_input(&mp)
                .with_context(|| format!("{}: clutter[{i}]: cannot read mesh {}", path.display(), mp.display()))?;
            let (scene, _) = penumbra_geometry::load_mesh(&mp)
                .map_err(|e| CliError::input(anyhow!("{}: clutter[{i}]: {e}", path.display())))?;
            let scene = match &c.node {
                None => scene,
                Some(n) => super::spheres::select_nodes(&scene, &n.patterns()).map_err(|why| {
                    CliError::input(anyhow!("{}: clutter[{i}].node {:?}: {why}", path.display(), n.patterns()))
                })?,
            };
            let lightmap = match c.charts {
                Some(ChartsName::Lightmap) if scene.uv1.is_empty() => {
                    return Err(CliError::input(anyhow!(
                        "{}: clutter[{i}].charts = \"lightmap\": mesh {} has no TEXCOORD_1 on every primitive",
                        path.display(),
                        mp.display()
                    )));
                }
                Some(ChartsName::BoxProjection) => false,
                _ => !scene.uv1.is_empty(),
            };
            let charts = if lightmap { "lightmap" } else { "box-projection" };
            let desc = json!({"mesh": rel, "mesh_blake3": h, "node": c.node, "charts": charts});
            if lightmap {
                (ClutterShape::Lightmapped { mesh: scene.mesh, uv: scene.uv1, res: c.lightmap_res }, desc)
            } else {
                (ClutterShape::Mesh(scene.mesh), desc)
            }
        };
        let spec = ClutterSpec {
            name,
            shape,
            translate: c.translate,
            rotate,
            scale: c.scale.unwrap_or(1.0),
            albedo: c.albedo.map_or([0.6; 3], |a| a.rgb()),
        };
        let mut d = box_json(&spec);
        if let (Some(o), Some(w)) = (d.as_object_mut(), what.as_object()) {
            o.extend(w.clone());
            o.insert("name".into(), json!(spec.name));
        }
        desc.push(d);
        specs.push(spec);
    }
    Ok((specs, desc))
}

/// Resolves the scene of `a`.
pub fn load_scene(a: &DrtSceneArgs) -> Result<DrtScene, CliError> {
    let dpath = a.dict_path();
    let ops = load_dict(dpath)?;
    let f = AssetFile::open(dpath).with_context(|| format!("cannot open dictionary {}", dpath.display()))?;
    let dict = DrtDict::from_asset(&f.asset()).map_err(|e| CliError::input(anyhow!("{}: {e}", dpath.display())))?;
    let mut specs = Vec::new();
    let mut desc = Vec::new();
    let mut example_lights = None;
    let mut level_asset = None;
    let (level, links, what) = if let Some(name) = &a.example {
        if a.level.is_some() || a.source.corridor.is_some() || a.source.l_turn.is_some() {
            return Err(CliError::input(anyhow!(
                "--example brings its own level: give no --level/--corridor/--l-turn"
            )));
        }
        if name != "maze-boxes" && a.source.maze.is_some() {
            return Err(CliError::input(anyhow!("--maze goes with --example maze-boxes only")));
        }
        let ex = example(
            name,
            &ops.names,
            &ops.missing,
            a.source.maze.unwrap_or(41) as usize,
            a.source.seed,
            a.boxes as usize,
        )
        .map_err(|e| CliError::input(anyhow!("--example {name}: {e}")))?;
        let links = ex
            .level
            .validate(&ops.names, &ops.missing)
            .map_err(|e| CliError::internal(anyhow!("example {name}: {e}")))?;
        for s in &ex.clutter {
            let mut d = box_json(s);
            if let (Some(o), ClutterShape::Box { size, faces }) = (d.as_object_mut(), &s.shape) {
                let fname = if *faces == BoxFaces::All { "all" } else { "no-bottom" };
                o.insert("box".into(), json!({"size": size, "faces": fname}));
                o.insert("name".into(), json!(s.name));
            }
            desc.push(d);
        }
        specs.extend(ex.clutter);
        example_lights = Some(ex.lights);
        (ex.level, links, ex.name)
    } else if let Some(p) = a.level.as_ref().filter(|p| std::fs::read(p).is_ok_and(|b| b.starts_with(b"PENUMBRA"))) {
        let bytes = std::fs::read(p).with_context(|| format!("cannot read level {}", p.display()))?;
        let asset =
            penumbra_asset::OwnedAsset::parse(&bytes).map_err(|e| CliError::input(anyhow!("{}: {e}", p.display())))?;
        let at = asset.asset();
        if at.kind().as_str() != "MRTL" {
            return Err(CliError::input(anyhow!(
                "{}: a {} asset, not an MRT level (MRTL)",
                p.display(),
                at.kind().as_str()
            )));
        }
        let meta: Value = serde_json::from_str(at.meta_json()).map_err(CliError::internal)?;
        if meta["dictionary"]["crc32c"].as_str() != Some(format!("{:08x}", ops.crc32c).as_str()) {
            return Err(CliError::input(anyhow!(
                "{} was baked with another dictionary (CRC-32C {}), not {} ({:08x})",
                p.display(),
                meta["dictionary"]["crc32c"],
                a.dict_path().display(),
                ops.crc32c
            )));
        }
        let lf: penumbra_config::LevelFile = serde_json::from_value(meta["level"].clone())
            .map_err(|e| CliError::input(anyhow!("{}: meta.level: {e}", p.display())))?;
        let (level, links) = validated(&lf, p, &ops)?;
        let depth = meta["params"]["max_depth"].as_u64().unwrap_or(8) as usize;
        level_asset = Some((bytes, depth));
        (level, links, p.display().to_string())
    } else {
        resolve(a.level.as_deref(), &a.source, &ops)?
    };
    if let Some(p) = &a.clutter {
        let (s, d) = clutter_from_file(p)?;
        specs.extend(s);
        desc.extend(d);
    }
    let (res, basis) = (a.clutter_res as usize, a.clutter_basis_res as usize);
    let clutter = ClutterScene::with_basis(&specs, res, basis).map_err(|e| CliError::input(anyhow!("clutter: {e}")))?;
    // the atlas size a lightmapped mesh got (the engine addresses its texels by it)
    for (d, &n) in desc.iter_mut().zip(&clutter.lightmap_res) {
        if let (Some(o), true) = (d.as_object_mut(), n > 0) {
            o.insert("lightmap_res".into(), json!(n));
        }
    }
    Ok(DrtScene {
        ops,
        dict,
        level,
        links,
        what,
        level_asset,
        clutter,
        clutter_json: desc,
        example_lights,
        raw_clutter: (specs, res, basis),
    })
}

impl DrtScene {
    /// The inputs the asset records.
    pub fn inputs(&self) -> DrtInputs {
        let level = serde_json::to_value(to_file(&self.level, &self.ops.names)).unwrap_or(Value::Null);
        DrtInputs {
            dict_crc32c: self.ops.crc32c,
            level_crc32c: self.level_asset.as_ref().map(|(b, _)| penumbra_asset::crc32c(b)),
            level,
            clutter_hashes: self
                .clutter_json
                .iter()
                .map(|d| blake3::hash(d.to_string().as_bytes()).to_hex().to_string())
                .collect(),
            clutter: Value::Array(self.clutter_json.clone()),
        }
    }
}

/// Bake options shared by `drt` and `verify drt`.
#[derive(Debug, Args)]
pub struct DrtBakeArgs {
    /// Rays per scene texel (thesis: 1024).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=1_048_576))]
    pub rays: u32,
    /// Rays per clutter texel for C_b and C_c (default: --rays; docs/drt.md measures fewer).
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=1_048_576))]
    pub clutter_rays: Option<u32>,
    /// Receiving blocks: within D connection hops of a block with clutter (docs/drt.md measures D).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=16))]
    pub neighborhood: u32,
    /// Rank of the clutter gather C_b (thesis: 5 modes).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub kc: u32,
    /// Rank of the delta reflection ΔU_c (thesis: 32 modes).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub kdc: u32,
    /// Leave out C_c, the clutter-to-clutter gather (the thesis has none; docs/drt.md).
    #[arg(long)]
    pub no_clutter_to_clutter: bool,
    /// How C_b is reduced: svd (best rank-kc), first (the first kc modes of each block's b), full.
    #[arg(long, default_value = "svd", value_parser = ["svd", "first", "full"])]
    pub kc_mode: String,
    /// Do not inpaint scene texels inside clutter.
    #[arg(long)]
    pub no_inpaint: bool,
    /// Seed of the bake's rays.
    #[arg(long, default_value_t = 0)]
    pub ray_seed: u64,
    /// Store the operators and clutter normals as f32 instead of f16 (f16 halves the bytes and
    /// changes the verified error by < 1e-5 relative: docs/drt.md).
    #[arg(long)]
    pub f32: bool,
    /// Also bake the vector operators (ΔU_b⃗, ΔU_c⃗, C_b⃗ for normal maps) and the U_dyn volume
    /// probes (MRT thesis §5.4.3; docs/drt.md, "Vector and volume response").
    #[arg(long)]
    pub vector: bool,
    /// Uniform-hemisphere rays per texel of the vector operators (probes: 4× over the sphere).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=262_144))]
    pub vector_rays: u32,
    /// U_dyn probes per block edge with --vector (default: the dictionary's volume_res, so that
    /// U_dyn replaces its U_bvol probes one for one).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub volume_res: Option<u32>,
}

impl DrtBakeArgs {
    /// The bake parameters.
    pub fn params(&self, clutter_res: u32, clutter_basis_res: u32) -> DrtParams {
        DrtParams {
            rays: self.rays as usize,
            clutter_rays: self.clutter_rays.unwrap_or(self.rays) as usize,
            neighborhood: self.neighborhood as usize,
            k_c: self.kc as usize,
            k_dc: self.kdc as usize,
            clutter_to_clutter: !self.no_clutter_to_clutter,
            kc_mode: KcMode::parse(&self.kc_mode).unwrap_or(KcMode::Svd),
            inpaint: !self.no_inpaint,
            clutter_res: clutter_res as usize,
            clutter_basis_res: clutter_basis_res as usize,
            seed: self.ray_seed,
            half: !self.f32,
            vector_rays: self.vector.then_some(self.vector_rays as usize),
            volume_res: self.volume_res.filter(|_| self.vector).map(|g| g as usize),
        }
    }
}

/// `penumbra drt`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct DrtArgs {
    /// `merge`: join shard assets.
    #[command(subcommand)]
    pub command: Option<DrtCommand>,
    /// The scene.
    #[command(flatten)]
    pub scene: DrtSceneArgs,
    /// Bake options.
    #[command(flatten)]
    pub bake: DrtBakeArgs,
    /// Bake shard K of N (receiving blocks and clutter instances j with j mod N = K); join the
    /// shards with `penumbra drt merge`.
    #[arg(long, value_name = "K/N", conflicts_with = "state")]
    pub shard: Option<String>,
    /// Keep the rays' sums in FILE; when FILE holds a bake of the same dictionary, level,
    /// parameters and clutter shapes, re-trace only the rays that meet clutter that moved
    /// (the bytes of a full bake; docs/drt.md, "Incremental re-bakes").
    #[arg(long, value_name = "FILE")]
    pub state: Option<PathBuf>,
    /// Choose --rays (the clutter rays equal to them): the fewest on a fixed ladder (32..8192,
    /// doubling; docs/drt.md "Targets") whose `verify drt` one-bounce error rel_error_mrt_drt
    /// is at most X, each candidate measured against one path-traced reference; writes that
    /// asset (the bytes of the plain bake with `--rays R`). None meets X: the best is written
    /// and the exit code is 1.
    #[arg(long, value_name = "X", value_parser = crate::commands::target::parse_target,
          conflicts_with_all = ["rays", "clutter_rays", "shard", "state", "vector"])]
    pub target_error: Option<f64>,
    /// With --target-error: leave out ladder rungs with more rays per texel than N.
    #[arg(long, value_name = "N", requires = "target_error")]
    pub max_rays: Option<u32>,
    /// With --target-error: reference rays per receiver (`verify drt --reference-rays`; 512).
    #[arg(long = "reference-rays", value_name = "N", requires = "target_error",
          value_parser = clap::value_parser!(u32).range(4..=1_048_576))]
    pub reference_rays: Option<u32>,
    /// With --target-error: point lights of the comparison (`verify drt --lights`).
    #[arg(long, value_name = "FILE", requires = "target_error")]
    pub lights: Option<PathBuf>,
    /// Output asset (.drto).
    #[arg(short = 'o', long, required = true)]
    pub output: Option<PathBuf>,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

impl DrtSceneArgs {
    /// The dictionary path (clap requires it outside `drt merge`).
    pub fn dict_path(&self) -> &Path {
        self.dict.as_deref().unwrap_or(Path::new(""))
    }
}

/// `penumbra drt` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum DrtCommand {
    /// Join the shards of one bake (`--shard K/N`, any order) into the bytes a single run writes.
    Merge(crate::args::ShardMergeArgs),
}

/// The content hash of everything that changes a DRT bake's bytes: tool version, dictionary
/// and level-asset CRCs, the level, each clutter instance's description (meshes by BLAKE3)
/// and the parameters.
pub fn cache_key(sc: &DrtScene, params: &DrtParams) -> String {
    let inputs = sc.inputs();
    blake3::hash(
        json!({"tool": env!("CARGO_PKG_VERSION"), "trace": penumbra_transport::drt::TRACE_VERSION, "stage": "drt", "dict": sc.ops.crc32c, "level_asset": inputs.level_crc32c,
               "level": inputs.level, "clutter": inputs.clutter_hashes, "params": params.to_json()})
        .to_string()
        .as_bytes(),
    )
    .to_hex()
    .to_string()
}

/// The key a DRT state file must carry to be used: [`cache_key`] without the clutter.
pub fn state_key(sc: &DrtScene, params: &DrtParams) -> String {
    let inputs = sc.inputs();
    let (_, res, basis) = &sc.raw_clutter;
    blake3::hash(
        json!({"tool": env!("CARGO_PKG_VERSION"), "trace": penumbra_transport::drt::TRACE_VERSION, "stage": "drt-state", "dict": sc.ops.crc32c,
               "level_asset": inputs.level_crc32c, "level": inputs.level, "params": params.to_json(),
               "clutter_res": res, "clutter_basis_res": basis})
        .to_string()
        .as_bytes(),
    )
    .to_hex()
    .to_string()
}

/// Per instance, its shape's hash (its description without placement, albedo and name) and
/// its placement as given.
fn state_instances(sc: &DrtScene) -> Vec<StateInstance> {
    sc.clutter_json
        .iter()
        .zip(&sc.raw_clutter.0)
        .map(|(d, s)| {
            let mut d = d.clone();
            if let Some(o) = d.as_object_mut() {
                for k in ["translate", "rotate", "scale", "albedo", "name"] {
                    o.remove(k);
                }
            }
            StateInstance {
                shape_key: blake3::hash(d.to_string().as_bytes()).to_hex().to_string(),
                translate: s.translate,
                rotate: s.rotate,
                scale: s.scale,
            }
        })
        .collect()
}

/// Bakes with a state file (`--state`, and the bake config's `[drt]` stage): incrementally
/// when the file holds a comparable bake, else in full; the file then holds this bake's sums.
/// Returns the bake, the asset bytes, the new state's bytes and the `incremental` report.
#[allow(clippy::type_complexity)]
pub fn bake_scene_stateful(
    sc: &DrtScene,
    params: &DrtParams,
    state_path: &Path,
    output: &Path,
    mode: ProgressMode,
) -> Result<(penumbra_transport::drt::DrtBake, Vec<u8>, Vec<u8>, Value, Option<VectorMetrics>), CliError> {
    let key = state_key(sc, params);
    let insts = state_instances(sc);
    let prev = match std::fs::read(state_path) {
        // a stale or corrupt state is rebuilt; a file that is no state at all (a typo'd path
        // to an asset, say) is refused rather than overwritten
        Ok(b) if !b.is_empty() && !DrtState::is_state_file(&b) => {
            return Err(CliError::input(anyhow!(
                "{}: not a DRT state file; refusing to overwrite it (remove it or give another --state path)",
                state_path.display()
            )));
        }
        Ok(b) => DrtState::from_bytes(&b).map_err(|e| format!("{}: {e}", state_path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err("no state file yet".into()),
        Err(e) => Err(format!("cannot read {}: {e}", state_path.display())),
    };
    let prev = prev.and_then(|st| {
        if st.key != key {
            Err("the dictionary, level or parameters changed".into())
        } else if st.instances.len() != insts.len() {
            Err(format!("{} clutter instances before, {} now", st.instances.len(), insts.len()))
        } else if let Some(i) = (0..insts.len()).find(|&i| st.instances[i].shape_key != insts[i].shape_key) {
            Err(format!("clutter {i} ({}) changed shape", sc.clutter.specs[i].name))
        } else {
            Ok(st)
        }
    });
    let rep = Reporter::new("drt", mode);
    let mut report = json!({"state": state_path.display().to_string(), "used": false});
    // the previous bake's vector items, its clutter and what moved since (an incremental
    // vector re-bake's inputs), once the scalar re-bake has used the state
    let mut vec_prev: Result<(VectorItems, ClutterScene, Vec<usize>), String> =
        Err("the scalar operators were baked in full".into());
    let (b, mut state) = match prev {
        Ok(mut st) => {
            let prev_vec = st.vector.take();
            let moved: Vec<usize> = (0..insts.len())
                .filter(|&i| {
                    let (a, b) = (&st.instances[i], &insts[i]);
                    (a.translate, a.rotate, a.scale) != (b.translate, b.rotate, b.scale)
                })
                .collect();
            let (raw, res, basis) = &sc.raw_clutter;
            let mut old_specs = raw.clone();
            for &i in &moved {
                let s = &st.instances[i];
                (old_specs[i].translate, old_specs[i].rotate, old_specs[i].scale) = (s.translate, s.rotate, s.scale);
            }
            let old = ClutterScene::with_basis(&old_specs, *res, *basis)
                .map_err(|e| CliError::input(anyhow!("{}: the previous clutter: {e}", state_path.display())))?;
            let (prev_bake, prev_why) = match previous_bake(sc, &st, output) {
                Ok(b) => (Some(b), None),
                Err(why) => (None, Some(why)),
            };
            let inc = bake_incremental(
                &sc.level,
                &sc.links,
                &sc.dict,
                &old,
                &sc.clutter,
                &moved,
                &mut st,
                params,
                prev_bake.as_ref(),
                &rep,
            );
            match inc {
                Ok((b, stats)) => {
                    st.instances = insts;
                    vec_prev = prev_vec.map(|v| (v, old, moved.clone())).ok_or_else(|| {
                        "the state holds no vector operators (baked without --vector, or before states kept them)"
                            .to_string()
                    });
                    let names: Vec<&str> = moved.iter().map(|&i| sc.clutter.specs[i].name.as_str()).collect();
                    report = json!({"state": state_path.display().to_string(), "used": true, "moved": names,
                                    "rays_cast": stats.rays_cast, "rays_full": stats.rays_full,
                                    "texels_changed": stats.texels_changed,
                                    "blocks_traced_in_full": stats.blocks_traced_in_full,
                                    "records_assembled": stats.records_assembled,
                                    "records_reused": stats.records_reused});
                    if let Some(why) = prev_why {
                        report["records_reason"] = json!(why);
                    }
                    (b, st)
                }
                Err(TransportError::Param(why)) => {
                    report["reason"] = json!(why);
                    full_with_state(sc, params, key, insts, &rep)?
                }
                Err(e) => return Err(CliError::input(anyhow!("{e}"))),
            }
        }
        Err(why) => {
            report["reason"] = json!(why);
            full_with_state(sc, params, key, insts, &rep)?
        }
    };
    rep.finish();
    let reuse = vec_prev.as_ref().ok().map(|(items, old, moved)| VectorReuse { prev: items, old, moved });
    let v = vector_items_of(sc, params, &b, reuse, mode)?;
    let v = match v {
        Some((v, items, stats)) => {
            report["vector"] = match (&vec_prev, report["used"].as_bool() == Some(true)) {
                (Ok(_), _) => json!({"used": true, "items_traced": stats.items_traced,
                                     "items_reused": stats.items_reused, "rays_cast": stats.rays_cast}),
                (Err(why), true) => json!({"used": false, "reason": why}),
                (Err(_), false) => json!({"used": false, "reason": "the scalar operators were baked in full"}),
            };
            state.vector = Some(items);
            Some(v)
        }
        None => None,
    };
    let inputs = sc.inputs();
    let asset =
        to_asset(&b, &sc.clutter, &inputs, Some(&cache_key(sc, params)), v.as_ref()).map_err(CliError::internal)?;
    let bytes = asset.to_bytes().map_err(CliError::internal)?;
    state.asset_crc32c = Some(penumbra_asset::crc32c(&bytes));
    let sb = state.to_bytes();
    report["state_bytes"] = json!(sb.len());
    Ok((b, bytes, sb, report, v.map(|v| v.metrics)))
}

/// The bake a state came from, read back from the asset it wrote (`output`, when that file
/// is still the one the state names), so an incremental re-bake can copy the records whose
/// sums did not change; `Err` says why it cannot (every record is then assembled again).
fn previous_bake(sc: &DrtScene, st: &DrtState, output: &Path) -> Result<penumbra_transport::drt::DrtBake, String> {
    let want = st.asset_crc32c.ok_or("the state names no asset")?;
    let bytes =
        std::fs::read(output).map_err(|e| format!("cannot read the previous asset {}: {e}", output.display()))?;
    if penumbra_asset::crc32c(&bytes) != want {
        return Err(format!("{} is not the asset the state was baked with", output.display()));
    }
    // the whole-file checksum matched the bytes the state's bake wrote: no section check
    let asset =
        penumbra_asset::OwnedAsset::parse_unverified(&bytes).map_err(|e| format!("{}: {e}", output.display()))?;
    let k_b =
        |y: usize| sc.dict.shapes.get(sc.level.blocks.get(y).map_or(usize::MAX, |b| b.shape)).map_or(0, |s| s.k_b);
    penumbra_transport::drt_asset::read_bake(&asset.asset(), &k_b).map_err(|e| format!("{}: {e}", output.display()))
}

/// The vector and volume operators (§5.4.3) of a bake's receiving blocks and instances (a
/// shard's own in a sharded bake), when `params.vector_rays` asks for them.
fn vector_of(
    sc: &DrtScene,
    params: &DrtParams,
    b: &penumbra_transport::drt::DrtBake,
    mode: ProgressMode,
) -> Result<Option<DrtVectorBake>, CliError> {
    Ok(vector_items_of(sc, params, b, None, mode)?.map(|v| v.0))
}

/// [`vector_of`] with the items a state keeps, from a previous bake's where `reuse` gives them.
fn vector_items_of(
    sc: &DrtScene,
    params: &DrtParams,
    b: &penumbra_transport::drt::DrtBake,
    reuse: Option<VectorReuse<'_>>,
    mode: ProgressMode,
) -> Result<Option<(DrtVectorBake, VectorItems, VectorIncStats)>, CliError> {
    let Some(rays) = params.vector_rays else { return Ok(None) };
    let rep = Reporter::new("drt vector", mode);
    // a shard's receiving blocks and instances: `drt merge` joins the shards' records
    let recv: Vec<usize> = b.receivers.iter().map(|r| r.block).collect();
    let insts: Vec<usize> = (0..sc.clutter.len()).filter(|&i| b.shard.owns(i)).collect();
    let vp = VectorParams { rays, volume_res: params.volume_res.unwrap_or(sc.dict.volume_res) };
    let v = bake_vector_items(&sc.level, &sc.links, &sc.dict, &sc.clutter, &recv, &insts, params.seed, vp, reuse, &rep)
        .map_err(|e| CliError::input(anyhow!("{e}")))?;
    rep.finish();
    Ok(Some(v))
}

fn full_with_state(
    sc: &DrtScene,
    params: &DrtParams,
    key: String,
    insts: Vec<StateInstance>,
    rep: &Reporter,
) -> Result<(penumbra_transport::drt::DrtBake, DrtState), CliError> {
    bake_with_state(&sc.level, &sc.links, &sc.dict, &sc.clutter, params, key, insts, rep)
        .map_err(|e| CliError::input(anyhow!("{e}")))
}

/// Bakes the scene's operators; returns the bake and the asset bytes.
pub fn bake_scene(
    sc: &DrtScene,
    params: &DrtParams,
    mode: ProgressMode,
) -> Result<(penumbra_transport::drt::DrtBake, Vec<u8>, Option<VectorMetrics>), CliError> {
    bake_scene_shard(sc, params, DrtShard::WHOLE, mode)
}

/// [`bake_scene`] for one shard (its receiving blocks and instances, vector operators too).
pub fn bake_scene_shard(
    sc: &DrtScene,
    params: &DrtParams,
    shard: DrtShard,
    mode: ProgressMode,
) -> Result<(penumbra_transport::drt::DrtBake, Vec<u8>, Option<VectorMetrics>), CliError> {
    let rep = Reporter::new("drt", mode);
    let b = bake_shard(&sc.level, &sc.links, &sc.dict, &sc.clutter, params, shard, &rep)
        .map_err(|e| CliError::input(anyhow!("{e}")))?;
    rep.finish();
    let v = vector_of(sc, params, &b, mode)?;
    let inputs = sc.inputs();
    let key = cache_key(sc, params);
    let asset = to_asset(&b, &sc.clutter, &inputs, Some(&key), v.as_ref()).map_err(CliError::internal)?;
    let bytes = asset.to_bytes().map_err(CliError::internal)?;
    Ok((b, bytes, v.map(|v| v.metrics)))
}

/// Runs `penumbra drt`.
#[allow(clippy::print_stderr)]
pub fn run(a: &DrtArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    if let Some(DrtCommand::Merge(m)) = &a.command {
        return run_merge(m);
    }
    let start = Instant::now();
    let shard = match &a.shard {
        Some(s) => {
            let (index, count) = super::bake::parse_shard(s)?;
            DrtShard { index, count }
        }
        None => DrtShard::WHOLE,
    };
    let sc = load_scene(&a.scene)?;
    let params = a.bake.params(a.scene.clutter_res, a.scene.clutter_basis_res);
    let output = a.output.as_deref().unwrap_or(Path::new("out.drto"));
    if let Some(target) = a.target_error {
        return run_target(a, &sc, &params, target, output, mode);
    }
    let t0 = Instant::now();
    let (b, bytes, state, vector) = match &a.state {
        Some(p) => {
            let (b, bytes, sb, rep, v) = bake_scene_stateful(&sc, &params, p, output, mode)?;
            (b, bytes, Some((p, sb, rep)), v)
        }
        None => {
            let (b, bytes, v) = bake_scene_shard(&sc, &params, shard, mode)?;
            (b, bytes, None, v)
        }
    };
    let bake_seconds = t0.elapsed().as_secs_f64();
    ensure_parent(output)?;
    penumbra_asset::write_file_atomic(output, &bytes).with_context(|| format!("cannot write {}", output.display()))?;
    if let Some((p, sb, _)) = &state {
        ensure_parent(p)?;
        penumbra_asset::write_file_atomic(p, sb).with_context(|| format!("cannot write {}", p.display()))?;
    }
    let mut v = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
    if let Some(o) = v.as_object_mut() {
        o.insert("level".into(), json!(sc.what));
        o.insert("level_blocks".into(), json!(sc.level.blocks.len()));
        o.insert("kc_mode".into(), json!(params.kc_mode.name()));
        o.insert("bytes".into(), json!(bytes.len()));
        o.insert("bake_seconds".into(), json!(bake_seconds));
        o.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
        o.insert("output".into(), json!(output.display().to_string()));
        if shard.count > 1 {
            o.insert("shard".into(), json!({"index": shard.index, "count": shard.count}));
        }
        if let Some((_, _, rep)) = &state {
            o.insert("incremental".into(), rep.clone());
        }
        if let Some(vm) = &vector {
            o.insert("vector".into(), serde_json::to_value(vm).map_err(CliError::internal)?);
        }
    }
    if a.json {
        print_json(&v);
    } else {
        let m = &b.metrics;
        eprintln!(
            "{}: {} receiving blocks, {} clutter instances ({} texels, {} charts), {} rays per texel\n  inpainted {} texels ({} failures), {} ΔU_b records, C_b rank {}\n  wrote {} ({} bytes) in {:.2} s",
            sc.what,
            m.blocks,
            m.clutter_instances,
            m.clutter_texels,
            m.clutter_charts,
            m.rays,
            m.inpainted_texels,
            m.inpaint_failures,
            m.delta_occlusion_records,
            m.k_c,
            output.display(),
            bytes.len(),
            start.elapsed().as_secs_f64()
        );
        if let Some(vm) = &vector {
            eprintln!(
                "  vector operators and U_dyn: {} rays per texel, {} probes ({} inside clutter), {} values",
                vm.vector_rays, vm.probes, vm.probes_inside_clutter, vm.values
            );
        }
        if let Some((p, _, r)) = &state {
            if r["used"] == json!(true) {
                eprintln!(
                    "  incremental from {}: moved {}, cast {} of a full bake's {} rays",
                    p.display(),
                    r["moved"],
                    r["rays_cast"],
                    r["rays_full"]
                );
            } else {
                eprintln!("  baked in full ({}); {} now holds this bake's sums", r["reason"], p.display());
            }
        }
    }
    Ok(ExitCode::Ok)
}

/// `penumbra drt --target-error X` ([`crate::commands::drt_target`]).
#[allow(clippy::print_stderr)]
fn run_target(
    a: &DrtArgs,
    sc: &DrtScene,
    params: &DrtParams,
    target: f64,
    output: &Path,
    mode: ProgressMode,
) -> Result<ExitCode, CliError> {
    let o = super::drt_target::DrtTargetOptions {
        dict_path: a.scene.dict_path(),
        lights: a.lights.as_deref(),
        reference_rays: a.reference_rays.unwrap_or(512) as usize,
        max_rays: a.max_rays.map(|r| r as usize),
        max_depth: 8,
    };
    let out = super::drt_target::search(sc, params, target, &o, output, mode)?;
    let v = &out.report;
    if a.json {
        print_json(v);
    } else {
        eprintln!(
            "{} {}: rel_error_mrt_drt {:.5} against the target {target} (MRT alone {:.5}), {} candidates in {:.2} s; wrote {} ({} bytes)",
            if out.met { "chose" } else { "target not met, wrote the best:" },
            super::target::settings_text(&v["chosen"]),
            v["measured"].as_f64().unwrap_or(f64::NAN),
            v["rel_error_mrt"].as_f64().unwrap_or(f64::NAN),
            v["candidates_tried"].as_array().map_or(0, Vec::len),
            v["search_seconds"].as_f64().unwrap_or(f64::NAN),
            output.display(),
            v["bytes"],
        );
    }
    if out.met {
        Ok(ExitCode::Ok)
    } else {
        eprintln!("quality gate failed: {}", v["reason"].as_str().unwrap_or_default());
        Ok(ExitCode::QualityGate)
    }
}

/// Runs `penumbra drt merge`.
#[allow(clippy::print_stderr)]
fn run_merge(a: &crate::args::ShardMergeArgs) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let files: Vec<AssetFile> = a
        .shards
        .iter()
        .map(|p| AssetFile::open(p).with_context(|| format!("cannot read shard {}", p.display())))
        .collect::<Result<_, _>>()?;
    let assets: Vec<_> = files.iter().map(AssetFile::asset).collect();
    let merged = penumbra_transport::drt_asset::merge(&assets).map_err(|e| {
        let names: Vec<String> = a.shards.iter().map(|p| p.display().to_string()).collect();
        CliError::input(anyhow!("{e} (inputs: {})", names.join(", ")))
    })?;
    let bytes = merged.to_bytes().map_err(CliError::internal)?;
    ensure_parent(&a.output)?;
    penumbra_asset::write_file_atomic(&a.output, &bytes)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    if a.json {
        print_json(&json!({
            "shards": a.shards.len(),
            "bytes": bytes.len(),
            "seconds": start.elapsed().as_secs_f64(),
            "output": a.output.display().to_string(),
        }));
    } else {
        eprintln!("merged {} shards into {} ({} bytes)", a.shards.len(), a.output.display(), bytes.len());
    }
    Ok(ExitCode::Ok)
}
