//! `penumbra fiv`: the FIV occlusion bake (FIV §4.2), and `penumbra fiv merge` for shards.

use crate::args::{EnvRotateArg, FivArgs, FivBakeArgs, FivCommand, FivExportArgs, ShardMergeArgs, UpArg};
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::{ensure_parent, hash_input};
use crate::progress::{ProgressMode, Reporter};
use anyhow::{Context, anyhow};
use penumbra_asset::AssetFile;
use penumbra_fiv::asset::{AssetInputs, read_meta};
use penumbra_fiv::{FivParams, Lighting, Occluder, Shard, ShellLayout, Storage, UpAxis};
use penumbra_geometry::env::Rotation;
use penumbra_geometry::{CubeMap, EnvMap, TriMesh};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Procedural occluders accepted as `--mesh builtin:NAME`.
pub const BUILTIN_MESHES: &[&str] = &["builtin:torus", "builtin:sphere"];
/// Procedural environments accepted as `--env builtin:NAME`.
pub const BUILTIN_ENVS: &[&str] = &["builtin:area-lights"];

/// A loaded input with its description for `meta.inputs` and the cache key.
#[derive(Debug)]
pub struct Input<T> {
    /// The data.
    pub data: T,
    /// File name (no directories) or builtin name.
    pub name: String,
    /// blake3 of the file bytes, or of the builtin's name and the tool version.
    pub blake3: String,
    /// What the import did (`{}` for builtins), for `--json` and the text report.
    pub report: Value,
    /// The import's notes, one sentence each (shown as warnings).
    pub warnings: Vec<String>,
}

/// The import report of an occluder mesh as JSON, and its warnings.
fn mesh_report(
    scene: &penumbra_geometry::Scene,
    r: &penumbra_geometry::import::ImportReport,
    spec: &str,
) -> (Value, Vec<String>) {
    let mut warnings: Vec<String> = r.warnings.iter().map(|w| format!("{spec}: {w}")).collect();
    if r.dropped_triangles() > 0 {
        warnings.push(format!(
            "{spec}: {} of {} triangles dropped (repeated index {}, zero area {}, duplicate {})",
            r.dropped_triangles(),
            r.source_triangles,
            r.clean.dropped_repeated_index,
            r.clean.dropped_zero_area,
            r.clean.dropped_duplicate
        ));
    }
    if !scene.skins.is_empty() {
        warnings.push(format!("{spec}: {} skin(s) taken at the rest pose (the occluder is rigid)", scene.skins.len()));
    }
    let v = json!({
        "source_triangles": r.source_triangles,
        "dropped_triangles": r.dropped_triangles(),
        "dropped_repeated_index": r.clean.dropped_repeated_index,
        "dropped_zero_area": r.clean.dropped_zero_area,
        "dropped_duplicate": r.clean.dropped_duplicate,
        "skipped_elements": r.skipped_elements,
        "converted_strips_fans": r.converted_strips_fans,
        "skins_at_rest_pose": scene.skins.len(),
        "warnings": r.warnings,
    });
    (v, warnings)
}

/// The load report of an environment map as JSON, and its warnings.
fn env_report(r: &penumbra_geometry::env::EnvReport, spec: &str) -> (Value, Vec<String>) {
    let mut warnings: Vec<String> = r.warnings.iter().map(|w| format!("{spec}: {w}")).collect();
    if r.negative_texels_clamped > 0 {
        warnings.push(format!("{spec}: {} negative channel values clamped to 0", r.negative_texels_clamped));
    }
    let v = json!({
        "width": r.width,
        "height": r.height,
        "negative_texels_clamped": r.negative_texels_clamped,
        "not_2_to_1": r.width != 2 * r.height,
        "warnings": r.warnings,
    });
    (v, warnings)
}

fn builtin_hash(name: &str) -> String {
    // the definition is code: its name and the tool version identify it
    blake3::hash(format!("{name}@{}", env!("CARGO_PKG_VERSION")).as_bytes()).to_hex().to_string()
}

/// Loads an occluder mesh from a file or a `builtin:` name; with `nodes` (glob patterns),
/// only the glTF nodes matching one and their descendants.
pub fn load_occluder(spec: &str, nodes: &[String]) -> Result<Input<TriMesh>, CliError> {
    if !nodes.is_empty() && spec.starts_with("builtin:") {
        return Err(CliError::input(anyhow!("--node selects glTF nodes: --mesh {spec:?} is a procedural occluder")));
    }
    if let Some(shape) = spec.strip_prefix("builtin:") {
        let mesh = match shape {
            // a torus lying in the XZ plane: a ring shadow with a bright centre
            "torus" => penumbra_geometry::procedural::torus([0.0; 3], 1.0, 0.35, 64, 32),
            "sphere" => penumbra_geometry::procedural::uv_sphere([0.0; 3], 1.0, 32, 64),
            _ => {
                return Err(CliError::input(anyhow!(
                    "--mesh {spec:?}: unknown procedural occluder (known: {})",
                    BUILTIN_MESHES.join(", ")
                )));
            }
        };
        return Ok(Input {
            data: mesh,
            name: spec.to_string(),
            blake3: builtin_hash(spec),
            report: json!({}),
            warnings: Vec::new(),
        });
    }
    let path = Path::new(spec);
    let (scene, report) =
        penumbra_geometry::load_mesh(path).with_context(|| format!("cannot load occluder mesh {}", path.display()))?;
    let scene = if nodes.is_empty() {
        scene
    } else {
        super::spheres::select_nodes(&scene, nodes).map_err(|why| {
            let pats: Vec<String> = nodes.iter().map(|p| format!("{p:?}")).collect();
            CliError::input(anyhow!("{}: --node {}: {why}", path.display(), pats.join(" ")))
        })?
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (report, warnings) = mesh_report(&scene, &report, &name);
    Ok(Input { data: scene.mesh, name, blake3: hash_input(path)?, report, warnings })
}

fn rotate(env: EnvMap, r: Rotation, spec: &str) -> Result<EnvMap, CliError> {
    env.rotated(r).ok_or_else(|| {
        CliError::input(anyhow!("--env-rotate {}: {spec} has an odd width, so it is not a texel permutation", r.name()))
    })
}

/// The lat-long map turned by `step/steps` of a full turn about +Y (from +Z toward +X, the
/// shell azimuth θ of `--up y`): `L'(ω) = L(R⁻¹ω)` is the column shift
/// `L'[x] = L[(x + step·W/steps) mod W]` (OpenEXR LatLong: `λ = π − 2π(x + ½)/W`), exact.
fn yawed(env: EnvMap, step: usize, steps: usize, spec: &str) -> Result<EnvMap, CliError> {
    if step == 0 {
        return Ok(env);
    }
    let (w, h) = (env.width(), env.height());
    if w % steps != 0 {
        return Err(CliError::input(anyhow!(
            "--yaw-steps {steps}: {spec} is {w} texels wide, not a multiple of {steps}, so its turns are not texel shifts"
        )));
    }
    let shift = step * w / steps;
    let src = env.texels();
    let data = (0..h).flat_map(|y| (0..w).map(move |x| src[y * w + (x + shift) % w])).collect();
    EnvMap::new(w, h, data).map_err(|e| CliError::input(anyhow!("{spec}: {e}")))
}

/// Loads an environment (lat-long file or `builtin:`), rotates it and resamples it to a
/// cube map.
pub fn load_env(spec: &str, rotation: Rotation, cube_size: usize) -> Result<Input<CubeMap>, CliError> {
    load_env_yawed(spec, rotation, (0, 1), cube_size)
}

/// [`load_env`], then turned by `yaw.0/yaw.1` of a full turn about +Y ([`yawed`]).
pub fn load_env_yawed(
    spec: &str,
    rotation: Rotation,
    yaw: (usize, usize),
    cube_size: usize,
) -> Result<Input<CubeMap>, CliError> {
    if let Some(name) = spec.strip_prefix("builtin:") {
        let env = match name {
            "area-lights" => penumbra_geometry::env::procedural::area_lights(512, 256),
            _ => {
                return Err(CliError::input(anyhow!(
                    "--env {spec:?}: unknown procedural environment (known: {})",
                    BUILTIN_ENVS.join(", ")
                )));
            }
        };
        let cube = CubeMap::from_latlong(&yawed(rotate(env, rotation, spec)?, yaw.0, yaw.1, spec)?, cube_size);
        return Ok(Input {
            data: cube,
            name: spec.to_string(),
            blake3: builtin_hash(spec),
            report: json!({}),
            warnings: Vec::new(),
        });
    }
    let path = Path::new(spec);
    let (env, report) = penumbra_geometry::load_env_map(path)
        .with_context(|| format!("cannot load environment map {}", path.display()))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (report, warnings) = env_report(&report, &name);
    let cube = CubeMap::from_latlong(&yawed(rotate(env, rotation, spec)?, yaw.0, yaw.1, spec)?, cube_size);
    Ok(Input { data: cube, name, blake3: hash_input(path)?, report, warnings })
}

/// Parses `AxPxK`.
pub fn parse_samples(s: &str) -> Result<[usize; 3], CliError> {
    let bad = || CliError::input(anyhow!("--samples {s:?}: expected AxPxK, e.g. 128x65x30"));
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut out = [0usize; 3];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p.trim().parse().map_err(|_| bad())?;
    }
    Ok(out)
}

/// Everything a FIV bake needs besides its inputs.
#[derive(Debug, Clone)]
pub struct FivJob {
    /// Mesh spec (path or builtin).
    pub mesh: String,
    /// Environment spec (path or builtin).
    pub env: String,
    /// Rotation applied to the environment.
    pub env_rotate: Rotation,
    /// Bake parameters.
    pub params: FivParams,
    /// Environment cube face size.
    pub cube_size: usize,
    /// `fiv` storage.
    pub storage: Storage,
    /// The environment turned by `yaw.0/yaw.1` of a full turn about +Y (`(0, 1)`: as is).
    pub yaw: (usize, usize),
    /// glTF node patterns selecting the occluder (`--node`; empty: the whole file).
    pub nodes: Vec<String>,
}

impl FivJob {
    /// Builds and validates a job.
    pub fn new(
        mesh: &str,
        env: &str,
        env_rotate: Rotation,
        samples: [usize; 3],
        r_min: f64,
        r_max: f64,
        up: UpAxis,
        cube_size: usize,
        irradiance_size: usize,
        half: bool,
    ) -> Result<Self, CliError> {
        let layout = ShellLayout { azimuth: samples[0], polar: samples[1], radial: samples[2], r_min, r_max, up };
        let params = FivParams { layout, irradiance_size };
        params.validate().map_err(CliError::input)?;
        if !penumbra_fiv::bake::CUBE_SIZE.contains(&cube_size) {
            return Err(CliError::input(anyhow!("cube size {cube_size} is out of range (allowed: 1..=512)")));
        }
        Ok(Self {
            mesh: mesh.to_string(),
            env: env.to_string(),
            env_rotate,
            params,
            cube_size,
            storage: if half { Storage::F16 } else { Storage::F32 },
            yaw: (0, 1),
            nodes: Vec::new(),
        })
    }
}

/// Content hash of a mesh or environment spec: [`hash_input`] of the file, or the builtin's.
pub fn spec_hash(spec: &str) -> Result<String, CliError> {
    if spec.starts_with("builtin:") { Ok(builtin_hash(spec)) } else { Ok(hash_input(Path::new(spec))?) }
}

/// Normalised parameters and input hashes, hashed for the cache key (reads the input files
/// to hash them, but does not parse them).
pub fn cache_key(job: &FivJob) -> Result<String, CliError> {
    let l = job.params.layout;
    let v = json!({
        "tool": env!("CARGO_PKG_VERSION"),
        "stage": "fiv",
        "samples": [l.azimuth, l.polar, l.radial],
        "r_min": l.r_min,
        "r_max": l.r_max,
        "up": l.up.name(),
        "cube_size": job.cube_size,
        "irradiance_size": job.params.irradiance_size,
        "storage": job.storage,
        "mesh": spec_hash(&job.mesh)?,
        "env": spec_hash(&job.env)?,
        "env_rotate": job.env_rotate.name(),
    });
    let mut v = v;
    if job.yaw.0 != 0 {
        // absent for unturned environments, so their keys stay what they were
        v["yaw"] = json!([job.yaw.0, job.yaw.1]);
    }
    if !job.nodes.is_empty() {
        v["node"] = json!(job.nodes);
    }
    Ok(blake3::hash(v.to_string().as_bytes()).to_hex().to_string())
}

/// What a FIV bake produced.
#[derive(Debug)]
pub struct FivOutcome {
    /// The `--json` object (without `seconds`).
    pub report: Value,
    /// Wall time.
    pub seconds: f64,
}

/// Bakes (one shard of) a job and writes the asset atomically.
pub fn bake_to(job: &FivJob, shard: Shard, output: &Path, mode: ProgressMode) -> Result<FivOutcome, CliError> {
    let mut v = bake_many(std::slice::from_ref(job), shard, &[output.to_path_buf()], mode)?;
    Ok(v.remove(0))
}

/// Bakes jobs that differ only in their environment from one visibility pass
/// ([`penumbra_fiv::bake_multi`]) and writes `outputs[e]` for `jobs[e]`, each the bytes its
/// job alone writes. `seconds` is the whole run's wall time in every outcome.
pub fn bake_many(
    jobs: &[FivJob],
    shard: Shard,
    outputs: &[PathBuf],
    mode: ProgressMode,
) -> Result<Vec<FivOutcome>, CliError> {
    let start = Instant::now();
    let Some(first) = jobs.first() else {
        return Err(CliError::input(anyhow!("no environment to bake")));
    };
    if outputs.len() != jobs.len() {
        return Err(CliError::input(anyhow!(
            "{} environments but {} outputs: give one -o per --env (in the same order)",
            jobs.len(),
            outputs.len()
        )));
    }
    for (i, o) in outputs.iter().enumerate() {
        if outputs[..i].contains(o) {
            return Err(CliError::input(anyhow!("-o {} is given twice", o.display())));
        }
    }
    let keys: Vec<String> = jobs.iter().map(cache_key).collect::<Result<_, _>>()?;
    let mesh = load_occluder(&first.mesh, &first.nodes)?;
    let envs: Vec<Input<CubeMap>> =
        jobs.iter().map(|j| load_env_yawed(&j.env, j.env_rotate, j.yaw, j.cube_size)).collect::<Result<_, _>>()?;
    let occ =
        Occluder::new(mesh.data.clone()).map_err(|e| CliError::input(anyhow!("occluder mesh {}: {e}", first.mesh)))?;
    let lightings: Vec<Lighting> = envs.iter().map(|e| Lighting::new(e.data.clone())).collect();
    let env_refs: Vec<&Input<CubeMap>> = envs.iter().collect();
    let light_refs: Vec<&Lighting> = lightings.iter().collect();
    let mut out = bake_prepared(jobs, shard, outputs, mode, &keys, &mesh, &occ, &env_refs, &light_refs)?;
    let seconds = start.elapsed().as_secs_f64();
    for o in &mut out {
        o.seconds = seconds;
    }
    Ok(out)
}

/// The bake and the writes of [`bake_many`] from inputs already loaded (`keys[e]`,
/// `envs[e]`, `lightings[e]` for `jobs[e]`; `occ` built from `mesh`), so a sweep loads them
/// once. `seconds` is this call's wall time (visibility pass and writes) in every outcome.
pub fn bake_prepared(
    jobs: &[FivJob],
    shard: Shard,
    outputs: &[PathBuf],
    mode: ProgressMode,
    keys: &[String],
    mesh: &Input<TriMesh>,
    occ: &Occluder,
    envs: &[&Input<CubeMap>],
    lightings: &[&Lighting],
) -> Result<Vec<FivOutcome>, CliError> {
    let start = Instant::now();
    let Some(first) = jobs.first() else {
        return Err(CliError::input(anyhow!("no environment to bake")));
    };
    let refs = lightings;
    let reporter = Reporter::new("fiv", mode);
    let bakes = penumbra_fiv::bake_multi(occ, refs, &first.params, shard, &reporter, penumbra_fiv::Culling::Auto)
        .map_err(CliError::input)?;
    reporter.finish();
    let mut out = Vec::with_capacity(jobs.len());
    for ((((job, env), lighting), b), (key, output)) in
        jobs.iter().zip(envs).zip(lightings).zip(&bakes).zip(keys.iter().zip(outputs))
    {
        let mut inputs = json!({
            "mesh": {"name": mesh.name, "blake3": mesh.blake3, "vertices": mesh.data.positions.len(), "triangles": mesh.data.indices.len()},
            "env": {"name": env.name, "blake3": env.blake3, "rotate": job.env_rotate.name()},
        });
        if job.yaw.0 != 0 {
            inputs["env"]["yaw_turns"] = json!([job.yaw.0, job.yaw.1]);
        }
        if !job.nodes.is_empty() {
            inputs["mesh"]["node"] = json!(job.nodes);
        }
        let ai = AssetInputs {
            inputs,
            cache_key: Some(key.clone()),
            storage: job.storage,
            env_cube: lighting.cube().texels(),
            mesh: &mesh.data,
        };
        let asset = penumbra_fiv::to_asset(b, &ai).map_err(CliError::input)?;
        ensure_parent(output)?;
        let bytes = asset.write_atomic(output).with_context(|| format!("cannot write {}", output.display()))?;
        let meta = penumbra_fiv::asset::meta_of(b, &ai);
        let l = job.params.layout;
        let f = occ.frame();
        let report = json!({
            "samples": [l.azimuth, l.polar, l.radial],
            "bytes": bytes,
            "fiv_bytes": meta.metrics.fiv_bytes,
            "rays_traced": b.stats.rays_traced,
            "rays_hit": b.stats.rays_hit,
            "rays_certified": b.stats.rays_certified,
            "inside_samples": b.stats.inside_samples,
            "center": f.center,
            "radius": f.radius,
            "cube_size": job.cube_size,
            "storage": job.storage,
            "shard": meta.shard,
            "cache_key": key,
            "output": output.display().to_string(),
            "env": env.name,
            "mesh_import": mesh.report,
            "env_import": env.report,
            "warnings": mesh.warnings.iter().chain(&env.warnings).collect::<Vec<_>>(),
        });
        out.push(FivOutcome { report, seconds: 0.0 });
    }
    let seconds = start.elapsed().as_secs_f64();
    for o in &mut out {
        o.seconds = seconds;
    }
    Ok(out)
}

fn run_bake(a: &FivBakeArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let Some(mesh) = &a.mesh else {
        return Err(CliError::input(anyhow!("--mesh, --env and -o are required")));
    };
    if a.env.is_empty() || a.output.is_empty() {
        return Err(CliError::input(anyhow!("--mesh, --env and -o are required")));
    }
    let up = match a.up {
        UpArg::Y => UpAxis::Y,
        UpArg::Z => UpAxis::Z,
    };
    let rot = match a.env_rotate {
        EnvRotateArg::None => Rotation::None,
        EnvRotateArg::X180 => Rotation::X180,
        EnvRotateArg::Y180 => Rotation::Y180,
        EnvRotateArg::Z180 => Rotation::Z180,
    };
    if let Some(target) = a.target_nrmse {
        return run_target(a, mesh, rot, up, target, mode);
    }
    let steps = a.yaw_steps as usize;
    if steps > 1 && up != UpAxis::Y {
        return Err(CliError::input(anyhow!("--yaw-steps turns the environment about +Y: it needs --up y")));
    }
    let specs: Vec<(&String, usize)> = a.env.iter().flat_map(|e| (0..steps).map(move |m| (e, m))).collect();
    let jobs: Vec<FivJob> = specs
        .iter()
        .map(|&(env, m)| {
            FivJob::new(
                mesh,
                env,
                rot,
                parse_samples(&a.samples)?,
                a.r_min,
                a.r_max,
                up,
                a.cube_size as usize,
                a.irradiance_size as usize,
                a.half,
            )
            .map(|mut j| {
                j.yaw = (m, steps);
                j.nodes = a.node.clone();
                j
            })
        })
        .collect::<Result<_, _>>()?;
    let shard = match &a.shard {
        Some(s) => {
            let (k, n) = super::bake::parse_shard(s)?;
            let sh = Shard { index: k, count: n };
            sh.validate(jobs[0].params.layout.azimuth).map_err(|e| CliError::input(anyhow!("--shard: {e}")))?;
            sh
        }
        None => Shard::WHOLE,
    };
    let outs = bake_many(&jobs, shard, &a.output, mode)?;
    let mut reports: Vec<Value> = outs
        .into_iter()
        .map(|o| {
            let mut v = o.report;
            v["seconds"] = json!(o.seconds);
            v
        })
        .collect();
    if a.json {
        if reports.len() == 1 {
            print_json(&reports.remove(0));
        } else {
            print_json(&json!({ "tables": reports, "seconds": reports[0]["seconds"] }));
        }
    } else {
        #[allow(clippy::print_stderr)]
        for v in &reports {
            eprintln!(
                "wrote {} ({} bytes, FIV data {} bytes) in {:.2} s\n  samples {}  rays {} ({} hit)  inside samples {}  R = {:.6}",
                v["output"].as_str().unwrap_or_default(),
                v["bytes"],
                v["fiv_bytes"],
                v["seconds"].as_f64().unwrap_or(f64::NAN),
                a.samples,
                v["rays_traced"],
                v["rays_hit"],
                v["inside_samples"],
                v["radius"].as_f64().unwrap_or(f64::NAN),
            );
            for w in v["warnings"].as_array().into_iter().flatten() {
                eprintln!("warning: {}", w.as_str().unwrap_or_default());
            }
        }
    }
    Ok(ExitCode::Ok)
}

/// `penumbra fiv --target-nrmse X` ([`crate::commands::fiv_target`]).
#[allow(clippy::print_stderr)]
fn run_target(
    a: &FivBakeArgs,
    mesh: &str,
    rot: Rotation,
    up: UpAxis,
    target: f64,
    mode: ProgressMode,
) -> Result<ExitCode, CliError> {
    if a.env.len() != 1 || a.output.len() != 1 {
        return Err(CliError::input(anyhow!("--target-nrmse bakes one table: give one --env and one -o")));
    }
    // samples and cube size are the search's; the placeholders are replaced on every rung
    let mut template =
        FivJob::new(mesh, &a.env[0], rot, [32, 17, 15], a.r_min, a.r_max, up, 32, a.irradiance_size as usize, a.half)?;
    template.nodes = a.node.clone();
    let out = super::fiv_target::search(&template, target, a.max_cost, &a.output[0], mode)?;
    let v = &out.report;
    if a.json {
        print_json(v);
    } else {
        eprintln!(
            "{} {} ({}): nrmse {:.5} against the target {target}, {} candidates in {:.2} s; wrote {} ({} bytes)",
            if out.met { "chose" } else { "target not met, wrote the best:" },
            super::target::settings_text(&v["chosen"]),
            v["samples"],
            v["measured"].as_f64().unwrap_or(f64::NAN),
            v["candidates_tried"].as_array().map_or(0, Vec::len),
            v["search_seconds"].as_f64().unwrap_or(f64::NAN),
            v["output"].as_str().unwrap_or_default(),
            v["bytes"],
        );
        for w in v["warnings"].as_array().into_iter().flatten() {
            eprintln!("warning: {}", w.as_str().unwrap_or_default());
        }
    }
    if out.met {
        Ok(ExitCode::Ok)
    } else {
        eprintln!("quality gate failed: {}", v["reason"].as_str().unwrap_or_default());
        Ok(ExitCode::QualityGate)
    }
}

fn run_merge(a: &ShardMergeArgs) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let files: Vec<AssetFile> = a
        .shards
        .iter()
        .map(|p| AssetFile::open(p).with_context(|| format!("cannot read shard {}", p.display())))
        .collect::<Result<_, _>>()?;
    for (f, p) in files.iter().zip(&a.shards) {
        read_meta(&f.asset()).map_err(|e| CliError::input(anyhow!("{}: {e}", p.display())))?;
    }
    let assets: Vec<_> = files.iter().map(|f| f.asset()).collect();
    let merged = penumbra_fiv::merge(&assets).map_err(CliError::input)?;
    ensure_parent(&a.output)?;
    let bytes = merged.write_atomic(&a.output).with_context(|| format!("cannot write {}", a.output.display()))?;
    let out = AssetFile::open(&a.output).with_context(|| format!("cannot read back {}", a.output.display()))?;
    let meta = read_meta(&out.asset()).map_err(CliError::internal)?;
    let v = json!({
        "output": a.output.display().to_string(),
        "bytes": bytes,
        "shards": a.shards.len(),
        "samples": meta.params.samples,
        "rays_traced": meta.metrics.rays_traced,
        "inside_samples": meta.metrics.inside_samples,
        "seconds": start.elapsed().as_secs_f64(),
    });
    if a.json {
        print_json(&v);
    } else {
        #[allow(clippy::print_stderr)]
        {
            eprintln!("merged {} shards into {} ({bytes} bytes)", a.shards.len(), a.output.display());
        }
    }
    Ok(ExitCode::Ok)
}

fn run_export(a: &FivExportArgs) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let file = AssetFile::open(&a.asset).with_context(|| format!("cannot read FIV asset {}", a.asset.display()))?;
    let asset = file.asset();
    let format =
        if a.half { penumbra_fiv::ktx2::TexelFormat::Rgba16F } else { penumbra_fiv::ktx2::TexelFormat::Rgba32F };
    let bytes = penumbra_fiv::ktx2::to_ktx2_as(&asset, concat!("penumbra ", env!("CARGO_PKG_VERSION")), format)
        .map_err(|e| CliError::input(anyhow!("{}: {e}", a.asset.display())))?;
    ensure_parent(&a.ktx2)?;
    penumbra_asset::write_file_atomic(&a.ktx2, &bytes).with_context(|| format!("cannot write {}", a.ktx2.display()))?;
    let dims = asset.section("fiv").map(|s| s.dims().to_vec()).unwrap_or_default();
    let v = json!({
        "output": a.ktx2.display().to_string(),
        "bytes": bytes.len(),
        "format": format.name(),
        "extent": [dims[0], dims[1], 3 * dims[2]],
        "seconds": start.elapsed().as_secs_f64(),
    });
    if a.json {
        print_json(&v);
    } else {
        #[allow(clippy::print_stderr)]
        {
            eprintln!(
                "wrote {} ({} bytes): {} 3D texture {}×{}×{} (3 slabs of {} shells)",
                a.ktx2.display(),
                bytes.len(),
                if a.half { "RGBA16F" } else { "RGBA32F" },
                dims[0],
                dims[1],
                3 * dims[2],
                dims[2]
            );
        }
    }
    Ok(ExitCode::Ok)
}

/// Runs `penumbra fiv` / `penumbra fiv merge` / `penumbra fiv export`.
pub fn run(a: &FivArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    match &a.command {
        Some(FivCommand::Merge(m)) => run_merge(m),
        Some(FivCommand::Export(e)) => run_export(e),
        None => run_bake(&a.bake, mode),
    }
}

/// Resolves a config path spec: builtins stay as they are, files are resolved.
pub fn resolve_spec(spec: &str, resolve: impl Fn(&str) -> PathBuf) -> String {
    if spec.starts_with("builtin:") { spec.to_string() } else { resolve(spec).display().to_string() }
}
