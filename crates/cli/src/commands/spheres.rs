//! `penumbra spheres`: bounding sphere sets (SHEXP §6.2–6.3), and `penumbra spheres export`.

use crate::args::{SphereMethod, SpheresAction, SpheresArgs, SpheresExportArgs, SpheresFitArgs};
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::{ensure_parent, write_atomic_text};
use crate::progress::{ProgressMode, Reporter};
use anyhow::{Context, anyhow};
use penumbra_asset::AssetFile;
use penumbra_geometry::{ImportReport, Scene, load_mesh};
use penumbra_spheres::asset::{SPHR_KIND_VERSION, read, to_asset};
use penumbra_spheres::fit::{FitParams, FitResult, Method, Target};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One sphere bake: what to fit and where to write it.
#[derive(Debug, Clone)]
pub struct SpheresJob {
    /// Input mesh.
    pub mesh: PathBuf,
    /// glTF node name filter.
    pub mesh_name: Option<String>,
    /// glTF node name patterns (`--node`, globs); with `mesh_name`, a node matching either
    /// is selected.
    pub nodes: Vec<String>,
    /// Fit parameters.
    pub params: FitParams,
    /// Output asset.
    pub output: PathBuf,
}

/// What a sphere bake produced.
#[derive(Debug)]
pub struct SpheresOutcome {
    /// The `--json` object without `bytes`, `seconds`, `output`.
    pub metrics: Value,
    /// Bytes written.
    pub bytes: u64,
    /// Wall time.
    pub seconds: f64,
    /// The Lloyd iteration log (for `--verbose`).
    pub log: Vec<penumbra_spheres::lloyd::IterationLog>,
}

/// Maps the CLI method.
pub fn method(m: SphereMethod) -> Method {
    match m {
        SphereMethod::Lloyd => Method::Lloyd,
        SphereMethod::Octree => Method::Octree,
    }
}

fn method_name(m: Method) -> &'static str {
    match m {
        Method::Lloyd => "lloyd",
        Method::Octree => "octree",
    }
}

/// Normalised parameters as JSON (cache key and `meta`).
fn params_json(job: &SpheresJob) -> Value {
    let p = &job.params;
    let (count, target_error, target_union) = match p.target {
        Target::Count(n) => (Some(n), None, None),
        Target::Error(e) => (None, Some(e), None),
        Target::Union(u) => (None, None, Some(u)),
    };
    let mut v = json!({
        "method": method_name(p.method),
        "count": count,
        "target_error": target_error,
        "grid": p.grid,
        "iterations": p.iterations,
        "seed": p.seed,
        "seeding": p.seeding,
        "refine": p.refine,
        "hierarchy": p.hierarchy,
        "skin": p.skin,
        "mesh_name": job.mesh_name,
        "per_sphere_samples": p.metrics.per_sphere_samples,
        "union_samples": p.metrics.union_samples,
    });
    if !job.nodes.is_empty() {
        // only when given, so the bytes of bakes without it stay as they were
        if let Some(o) = v.as_object_mut() {
            o.insert("node".into(), json!(job.nodes));
        }
    }
    // keys added later appear only when used, so that older cache keys stay valid
    if let Some(o) = v.as_object_mut() {
        if target_union.is_some() {
            o.insert("target_union".into(), json!(target_union));
        }
        if p.polish {
            o.insert("polish".into(), json!(true));
        }
        // the evenly spaced candidate (issue 16) changes the default Lloyd fit's bytes, so a
        // key made before it must not match
        if p.cvt && p.refine && p.method == Method::Lloyd {
            o.insert("cvt".into(), json!(true));
        }
        if p.fine_refine && p.refine && p.method == Method::Lloyd {
            o.insert("fine_refine".into(), json!(true));
        }
        // the candidate is refined only when it starts within this factor of the SHEXP set's
        // union (issue 16, fourth pass): where it would have lost the bytes are the same, but a
        // key must not promise that where it would have won
        if p.cvt && p.refine && p.method == Method::Lloyd {
            o.insert("cvt_skip_ratio".into(), json!(penumbra_spheres::fit::CVT_SKIP_RATIO));
        }
        if p.skin_padding {
            o.insert("skin_padding".into(), json!(true));
        }
        if count.is_none() {
            o.insert("max_count".into(), json!(p.max_count));
        }
        if let Some(al) = p.albedo {
            o.insert("albedo".into(), json!(al));
        }
    }
    v
}

/// Cache key of a job: tool version, parameters and the mesh bytes.
pub fn cache_key(job: &SpheresJob, mesh_hash: &str) -> String {
    // kind_version 2 stores the glTF materials' albedo: a key made before it must not match;
    // albedo_model 2 reads base-colour textures (a key from before must not match either)
    let v = json!({"tool": env!("CARGO_PKG_VERSION"), "stage": "spheres", "params": params_json(job), "mesh": mesh_hash, "kind_version": SPHR_KIND_VERSION, "albedo_model": 2});
    blake3::hash(v.to_string().as_bytes()).to_hex().to_string()
}

/// Loads the mesh (and, with `--mesh-name` or `--node`, the selected nodes' part of it).
pub fn load_scene(path: &Path, mesh_name: Option<&str>, nodes: &[String]) -> Result<(Scene, ImportReport), CliError> {
    let (scene, report) = load_mesh(path).map_err(CliError::input)?;
    let mut patterns: Vec<String> = nodes.to_vec();
    if let Some(n) = mesh_name {
        patterns.push(n.to_string());
    }
    if patterns.is_empty() {
        return Ok((scene, report));
    }
    let what = match (mesh_name, nodes.is_empty()) {
        (Some(n), true) => format!("--mesh-name {n:?}"),
        _ => format!("--node {}", patterns.iter().map(|p| format!("{p:?}")).collect::<Vec<_>>().join(" ")),
    };
    let sub =
        select_nodes(&scene, &patterns).map_err(|why| CliError::input(anyhow!("{}: {what}: {why}", path.display())))?;
    Ok((sub, report))
}

/// The part of `scene` under the nodes matching `patterns`, or the message saying why there is
/// none (listing the file's node names).
pub fn select_nodes(scene: &Scene, patterns: &[String]) -> Result<Scene, String> {
    scene.subset_by_nodes(patterns).ok_or_else(|| {
        let names = scene.node_names();
        format!(
            "no triangles belong to a matching node or its descendants{}",
            if names.is_empty() {
                " (the file has no named nodes)".to_string()
            } else {
                format!(" (nodes: {})", names.join(", "))
            }
        )
    })
}

fn strip_seconds(v: &mut Value) {
    if let Some(o) = v.as_object_mut() {
        o.retain(|k, _| !k.ends_with("seconds"));
    }
}

/// The `--json` object of a result (without bytes/seconds/output).
fn result_json(r: &FitResult, import: &ImportReport, scene: &Scene) -> Value {
    let m = &r.metrics;
    let rep = &r.report;
    let accepted: Vec<f64> = rep.log.iter().map(|l| l.e).collect();
    let mut v = json!({
        "count": rep.count,
        "method": method_name(rep.method),
        "outside_volume_ratio": m.outside_volume_ratio,
        "outside_volume_ratio_stderr": m.outside_volume_ratio_stderr,
        "union_outside_ratio": m.union_outside_ratio,
        "union_outside_ratio_stderr": m.union_outside_ratio_stderr,
        "uncovered_ratio": m.uncovered_ratio,
        "uncovered_ratio_stderr": m.uncovered_ratio_stderr,
        "union_samples": m.union_samples,
        "per_sphere_samples": m.per_sphere_samples,
        "max_uncovered_distance": m.max_uncovered_distance,
        "max_uncovered_distance_rel": m.max_uncovered_distance_rel,
        "uncovered_sample_points": m.uncovered_sample_points,
        "volume": m.volume,
        "volume_exact": m.volume_exact,
        "model_outside_volume_ratio": rep.model_outside_volume_ratio,
        "iterations": rep.iterations,
        "teleports_accepted": rep.teleports_accepted,
        "teleports_rejected": rep.teleports_rejected,
        "e_history": accepted,
        "search": rep.search.iter().map(|(n, e)| {
            let metric = rep.target.as_ref().map_or("outside_volume_ratio", |t| t.metric);
            json!({"requested_count": n, metric: e})
        }).collect::<Vec<_>>(),
        "target_met": rep.target.as_ref().map(|t| t.met),
        "target_reason": rep.target.as_ref().and_then(|t| t.reason.clone()),
        "target_max_count": rep.target.as_ref().map(|t| t.max_count),
        // internal levels: the rows of the SPHR `hierarchy_levels` section (leaves not counted)
        "hierarchy_levels": r.hierarchy.as_ref().map(|h| h.levels.len()),
        "hierarchy_nodes": r.hierarchy.as_ref().map(|h| h.levels.iter().map(Vec::len).collect::<Vec<_>>()),
        "skin_coverage_min": r.skin_coverage.as_ref().map(|c| c.min),
        "skin_coverage": r.skin_coverage,
        "octree_level": rep.octree_level,
        "octree_level_counts": rep.octree_level_counts,
        "grid_nodes": rep.grid_nodes,
        "grid_spacing": rep.grid_spacing,
        "surface_elements": rep.surface_elements,
        "interior_points": rep.interior_points,
        "watertight": rep.watertight,
        "flipped_orientation": rep.flipped_orientation,
        "dropped_triangles": import.dropped_triangles(),
        "setup_seconds": rep.setup_seconds,
        "fit_seconds": rep.fit_seconds,
        "finish_seconds": rep.finish_seconds,
    });
    if let Some(o) = v.as_object_mut() {
        // a fixed --count is a request; a target search settles on a count itself
        o.insert("requested_count".into(), json!(rep.target.is_none().then_some(rep.requested_count)));
        o.insert("settled_count".into(), json!(rep.target.as_ref().map(|_| rep.requested_count)));
        o.insert("hierarchy_levels_with_leaves".into(), json!(r.hierarchy.as_ref().map(|h| h.levels.len() + 1)));
        if let Some(al) = &r.albedo {
            let mean: [f64; 3] =
                std::array::from_fn(|c| al.iter().map(|a| f64::from(a[c])).sum::<f64>() / al.len().max(1) as f64);
            o.insert("albedo_mean".into(), json!(mean));
            o.insert("albedo_from_materials".into(), json!(penumbra_spheres::albedo::has_materials(scene)));
            o.insert("albedo_texture_images".into(), json!(penumbra_spheres::albedo::texture_images(scene)));
        }
        if let Some(pad) = &r.skin_padding {
            let max = pad.iter().copied().fold(0.0, f64::max);
            o.insert("skin_padding_max".into(), json!(max));
            o.insert("skin_padding_mean".into(), json!(pad.iter().sum::<f64>() / pad.len().max(1) as f64));
            o.insert("skin_padded_spheres".into(), json!(pad.iter().filter(|&&d| d > 0.0).count()));
        }
    }
    v
}

/// Runs one job: load, fit, write atomically.
pub fn bake_to(job: &SpheresJob, mode: ProgressMode) -> Result<SpheresOutcome, CliError> {
    let start = Instant::now();
    let mesh_hash = crate::fsutil::hash_input(&job.mesh)?;
    let (scene, import) = load_scene(&job.mesh, job.mesh_name.as_deref(), &job.nodes)?;
    let reporter = Reporter::new("spheres", mode);
    let r = penumbra_spheres::fit(&scene, &job.params, &reporter)
        .map_err(|e| CliError::input(anyhow!("{}: {e}", job.mesh.display())))?;
    reporter.finish();
    let metrics = result_json(&r, &import, &scene);
    let mut meta_metrics = metrics.clone();
    strip_seconds(&mut meta_metrics);
    if let Some(o) = meta_metrics.as_object_mut() {
        o.remove("e_history");
    }
    let mut log = serde_json::to_value(&r.report.log).unwrap_or(Value::Null);
    strip_seconds(&mut log);
    let meta = json!({
        "kind": "SPHR",
        "kind_version": SPHR_KIND_VERSION,
        "tool": concat!("penumbra ", env!("CARGO_PKG_VERSION")),
        "convention": {
            "spheres": "[x, y, z, radius] f32, in the input's units and frame (glTF: metres, +Y up)",
            "bounding": "every mesh vertex, every surface subdivision point and every interior grid point lies inside at least one sphere, evaluated in f64 from the stored f32 values",
            "hierarchy": "levels from the root; hierarchy_children (first, count) index the next level, or `spheres` for the last level",
            "skin": "P' = sum_b w_b * G_b(t) * G_b(rest)^-1 * P (G: global transform of glTF node skin_nodes[b]); radius unchanged",
            "albedo": "per sphere, linear RGB in [0, 1]: area-weighted mean of the glTF baseColorFactor (or --albedo) times the sRGB-decoded baseColorTexture, if any, over the surface whose sub-triangle centroids the sphere holds most deeply (smallest |p - c| / r)",
        },
        "params": params_json(job),
        "input": {
            "file": job.mesh.file_name().map(|n| n.to_string_lossy().into_owned()),
            "blake3": mesh_hash,
            "triangles": scene.mesh.indices.len(),
            "vertices": scene.mesh.positions.len(),
        },
        "cache_key": cache_key(job, &mesh_hash),
        "metrics": meta_metrics,
        "iteration_log": log,
    });
    let asset = to_asset(&r, &meta).map_err(CliError::internal)?;
    ensure_parent(&job.output)?;
    let bytes = asset.write_atomic(&job.output).with_context(|| format!("cannot write {}", job.output.display()))?;
    Ok(SpheresOutcome { metrics, bytes, seconds: start.elapsed().as_secs_f64(), log: r.report.log })
}

/// Builds a job from the command line.
pub fn job_from_args(a: &SpheresFitArgs) -> Result<SpheresJob, CliError> {
    let mesh = a.mesh.clone().ok_or_else(|| CliError::input(anyhow!("a mesh is required")))?;
    let output = a.output.clone().ok_or_else(|| CliError::input(anyhow!("-o OUTPUT is required")))?;
    let target = match (a.count, a.target_error, a.target_union) {
        (Some(n), None, None) => Target::Count(n as usize),
        (None, Some(e), None) => Target::Error(e),
        (None, None, Some(u)) => Target::Union(u),
        _ => {
            return Err(CliError::input(anyhow!(
                "give exactly one of --count N, --target-error E or --target-union U"
            )));
        }
    };
    let mut params = FitParams::new(target);
    if let Some(m) = a.max_count {
        if matches!(target, Target::Count(_)) {
            return Err(CliError::input(anyhow!(
                "--max-count caps a --target-error/--target-union search; with --count it has no effect"
            )));
        }
        params.max_count = m as usize;
    }
    params.method = method(a.method);
    params.grid = a.grid as usize;
    params.iterations = a.iterations as usize;
    params.seed = a.seed;
    params.seeding = match a.seeding {
        crate::args::SphereSeeding::Medial => penumbra_spheres::lloyd::Seeding::Medial,
        crate::args::SphereSeeding::KmeansPlusPlus => penumbra_spheres::lloyd::Seeding::KMeansPlusPlus,
    };
    params.refine = !a.no_refine;
    params.polish = a.polish;
    params.hierarchy = a.hierarchy;
    params.skin = a.skin;
    params.skin_padding = a.skin_padding;
    params.albedo = a.albedo.as_deref().map(parse_albedo).transpose()?;
    params.metrics.seed = a.seed;
    params.validate().map_err(CliError::input)?;
    Ok(SpheresJob { mesh, mesh_name: a.mesh_name.clone(), nodes: a.node.clone(), params, output })
}

/// Parses `--albedo R,G,B` or `--albedo A` (each in [0, 1]).
pub fn parse_albedo(s: &str) -> Result<[f64; 3], CliError> {
    let v: Vec<f64> = s.split(',').map(|x| x.trim().parse::<f64>()).collect::<Result<_, _>>().unwrap_or_default();
    let ok = |v: &[f64]| v.iter().all(|x| (0.0..=1.0).contains(x));
    match v.as_slice() {
        [a] if ok(&v) => Ok([*a; 3]),
        [r, g, b] if ok(&v) => Ok([*r, *g, *b]),
        _ => Err(CliError::input(anyhow!("--albedo {s}: expected R,G,B or one value, each in [0, 1]"))),
    }
}

/// Runs `penumbra spheres`.
#[allow(clippy::print_stderr)]
pub fn run(a: &SpheresArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    if let Some(SpheresAction::Export(e)) = &a.action {
        return export(e);
    }
    let f = &a.fit;
    let job = job_from_args(f)?;
    let out = bake_to(&job, mode)?;
    if f.verbose {
        for l in &out.log {
            eprintln!(
                "iteration {:>3} {:<8} E {:.5} (candidate {:.5}) {}",
                l.iteration,
                format!("{:?}", l.kind).to_lowercase(),
                l.e,
                l.candidate_e,
                if l.accepted { "accepted" } else { "rejected" }
            );
        }
    }
    let mut v = out.metrics.clone();
    if let Some(o) = v.as_object_mut() {
        o.insert("bytes".into(), json!(out.bytes));
        o.insert("seconds".into(), json!(out.seconds));
        o.insert("output".into(), json!(job.output.display().to_string()));
    }
    let missed = out.metrics["target_met"] == json!(false);
    if f.json {
        print_json(&v);
    } else {
        let m = &out.metrics;
        let num = |k: &str| m[k].as_f64().unwrap_or(f64::NAN);
        eprintln!(
            "wrote {} ({} bytes) in {:.2} s\n  {} spheres ({})  E {:.4} ± {:.4}  union outside {:.4}  uncovered {:.2e}  max uncovered distance {:.3e}\n  iterations {}  teleports {} accepted / {} rejected{}{}",
            job.output.display(),
            out.bytes,
            out.seconds,
            m["count"],
            m["method"].as_str().unwrap_or(""),
            num("outside_volume_ratio"),
            num("outside_volume_ratio_stderr"),
            num("union_outside_ratio"),
            num("uncovered_ratio"),
            num("max_uncovered_distance"),
            m["iterations"],
            m["teleports_accepted"],
            m["teleports_rejected"],
            m["hierarchy_levels"]
                .as_u64()
                .map(|l| format!("  hierarchy: {l} internal levels above the leaves"))
                .unwrap_or_default(),
            m["skin_coverage_min"].as_f64().map(|c| format!("  posed coverage ≥ {c:.4}")).unwrap_or_default(),
        );
    }
    if missed {
        // DESIGN §2: a bake that ran but missed its requested quality exits 1; the best set
        // is written
        eprintln!(
            "error: {}: target not met: {}",
            job.mesh.display(),
            out.metrics["target_reason"].as_str().unwrap_or("unknown reason")
        );
        return Ok(ExitCode::QualityGate);
    }
    Ok(ExitCode::Ok)
}

/// `penumbra spheres export`: one icosphere per sphere, as OBJ (one `o` group per sphere).
#[allow(clippy::print_stderr)]
fn export(e: &SpheresExportArgs) -> Result<ExitCode, CliError> {
    let file = AssetFile::open(&e.asset).map_err(|err| CliError::input(anyhow!("{err}")))?;
    let set = read(&file.asset()).map_err(|err| CliError::input(anyhow!("{}: {err}", e.asset.display())))?;
    let spheres: Vec<[f32; 4]> = match e.level {
        None => set.spheres.clone(),
        Some(l) => {
            let h = set.hierarchy.as_ref().ok_or_else(|| {
                CliError::input(anyhow!(
                    "{}: --level {l}: the asset has no hierarchy (bake with --hierarchy)",
                    e.asset.display()
                ))
            })?;
            let depth = h.levels.len();
            match (l as usize).cmp(&depth) {
                std::cmp::Ordering::Less => h.levels[l as usize].clone(),
                std::cmp::Ordering::Equal => set.spheres.clone(),
                std::cmp::Ordering::Greater => {
                    return Err(CliError::input(anyhow!(
                        "--level {l} is out of range (allowed: 0..={depth}; {depth} = the leaves)"
                    )));
                }
            }
        }
    };
    let unit = penumbra_geometry::procedural::icosphere(e.subdivisions, 1.0, [0.0; 3]);
    let mut text = format!("# penumbra spheres export: {} spheres from {}\n", spheres.len(), e.asset.display());
    let nv = unit.positions.len();
    for (i, s) in spheres.iter().enumerate() {
        text.push_str(&format!("o sphere_{i}\n"));
        for p in &unit.positions {
            text.push_str(&format!(
                "v {} {} {}\n",
                s[0] as f64 + s[3] as f64 * p[0],
                s[1] as f64 + s[3] as f64 * p[1],
                s[2] as f64 + s[3] as f64 * p[2]
            ));
        }
        for t in &unit.indices {
            let b = i * nv + 1;
            text.push_str(&format!("f {} {} {}\n", b + t[0] as usize, b + t[1] as usize, b + t[2] as usize));
        }
    }
    ensure_parent(&e.obj)?;
    write_atomic_text(&e.obj, &text)?;
    eprintln!("wrote {} ({} spheres)", e.obj.display(), spheres.len());
    Ok(ExitCode::Ok)
}
