//! `penumbra verify vo`: the line/area/point estimators of MRT thesis §6.3 on a depth buffer
//! ray-cast from a mesh, against the obscurance integral over the real mesh (winding number)
//! and over the depth buffer's height field.

use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::AssetFile;
use penumbra_geometry::{MeshBvh, WindingNumber, load_mesh};
use penumbra_math::progress::NoProgress;
use penumbra_vo::Domain;
use penumbra_vo::estimator::{Method, Options, SetRef, estimate};
use penumbra_vo::reference::{VerifyParams, View, ray_cast, verify};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Camera of `verify vo`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ViewArg {
    /// Looking along −Z.
    Front,
    /// Looking along −X.
    Side,
    /// Looking along −Y.
    Top,
}

/// `penumbra verify vo`.
#[derive(Debug, Args)]
pub struct VerifyVoArgs {
    /// Mesh (.obj, .gltf, .glb).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Estimator and sample count: `lines:N`, `area:N` or `points:N` (N in 1..=256).
    #[arg(long, default_value = "lines:9")]
    pub method: String,
    /// Sample sets (a VOSS asset from `penumbra vo`); default: bake the one set needed.
    #[arg(long)]
    pub sets: Option<PathBuf>,
    /// Use the set with the centre sample.
    #[arg(long)]
    pub centre: bool,
    /// Orthographic view direction.
    #[arg(long, value_enum, default_value_t = ViewArg::Front)]
    pub view: ViewArg,
    /// Perspective camera (two bounding-box diagonals away) instead of orthographic.
    #[arg(long)]
    pub perspective: bool,
    /// Depth-buffer resolution (square).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub res: u32,
    /// Sphere radius as a fraction of the mesh's bounding-box diagonal.
    #[arg(long, default_value_t = 0.05, value_parser = parse_fraction)]
    pub radius: f64,
    /// Restrict to the hemisphere above the surface (§6.3.4).
    #[arg(long)]
    pub normal: bool,
    /// Thickness model (§6.3.3): surfaces this thick, in units of the radius.
    #[arg(long, value_parser = parse_fraction_any)]
    pub thickness: Option<f64>,
    /// Pixels compared with the truths.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub pixels: u32,
    /// Monte-Carlo points per pixel of the truths.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub mc: u32,
    /// Seed of the truths' Monte Carlo (and of the baked set without --sets).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the estimate over the whole buffer as a grey PNG (at least 512 px, titled, with a
    /// colour bar and a caption).
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// Quality gate: exit 1 when `rmse_vs_volume` (the estimator against the obscurance
    /// integral over the real mesh) exceeds this.
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_rmse: Option<f64>,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_fraction(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v <= 1.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < r ≤ 1)")) }
}

fn parse_fraction_any(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v <= 100.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < t ≤ 100)")) }
}

/// Parses `lines:N`, `area:N`, `points:N`.
pub fn parse_method(s: &str) -> Result<(Method, usize), String> {
    let bad = || format!("--method {s:?}: expected lines:N, area:N or points:N with N in 1..=256");
    let (m, n) = s.split_once(':').ok_or_else(bad)?;
    let n: usize = n.parse().map_err(|_| bad())?;
    if !(1..=256).contains(&n) {
        return Err(bad());
    }
    let m = match m {
        "lines" => Method::Lines,
        "area" => Method::Area,
        "points" => Method::Points,
        _ => return Err(bad()),
    };
    Ok((m, n))
}

/// Runs `penumbra verify vo`.
pub fn run(a: &VerifyVoArgs) -> Result<ExitCode, CliError> {
    run_report(a).map(|(code, _)| code)
}

/// Runs `penumbra verify vo` and returns its report too (`penumbra bake` stage gates).
#[allow(clippy::print_stderr)]
pub(crate) fn run_report(a: &VerifyVoArgs) -> Result<(ExitCode, serde_json::Value), CliError> {
    let start = Instant::now();
    let (method, n) = parse_method(&a.method).map_err(|e| CliError::input(anyhow!(e)))?;
    let domain = if method == Method::Points { Domain::Ball } else { Domain::Disk };
    let (scene, _) = load_mesh(&a.mesh).map_err(|e| CliError::input(anyhow!("{e}")))?;
    let mesh = scene.mesh;
    if mesh.triangle_count() == 0 {
        return Err(CliError::input(anyhow!("{}: the mesh has no triangles", a.mesh.display())));
    }
    let (points, weights, log2area, reflections) = match &a.sets {
        Some(p) => {
            let f = AssetFile::open(p).with_context(|| format!("cannot open sample sets {}", p.display()))?;
            let asset = f.asset();
            if asset.kind().as_str() != "VOSS" {
                return Err(CliError::input(anyhow!("{}: kind {} is not VOSS", p.display(), asset.kind())));
            }
            let s = penumbra_vo::asset::read_set(&asset, domain, a.centre, n)
                .map_err(|e| CliError::input(anyhow!("{}: {e}", p.display())))?
                .ok_or_else(|| {
                    CliError::input(anyhow!(
                        "{}: no {} set (bake it with penumbra vo --counts …)",
                        p.display(),
                        penumbra_vo::bake::set_key(domain, a.centre, n)
                    ))
                })?;
            let r = penumbra_vo::asset::read_reflections(&asset, domain)
                .map_err(|e| CliError::input(anyhow!("{}: {e}", p.display())))?;
            (s.points, s.weights, s.log2area, r)
        }
        None => {
            let p = penumbra_vo::VoParams { counts: vec![n], seed: a.seed, noise_trials: 64, ..Default::default() };
            let b = penumbra_vo::bake(&p, &NoProgress).map_err(CliError::input)?;
            let s = b
                .sets
                .into_iter()
                .find(|s| s.domain == domain && s.centre == a.centre)
                .ok_or_else(|| CliError::internal(anyhow!("bake lacks the set")))?;
            let r = match domain {
                Domain::Disk => b.reflect2d.iter().map(|r| [r[0], r[1], 0.0]).collect(),
                Domain::Ball => b.reflect3d,
            };
            (s.points, s.weights, s.log2area, r)
        }
    };
    let bvh = MeshBvh::build(&mesh).map_err(|e| CliError::input(anyhow!("{}: {e}", a.mesh.display())))?;
    let view = match a.view {
        ViewArg::Front => View::Front,
        ViewArg::Side => View::Side,
        ViewArg::Top => View::Top,
    };
    let (db, frame) = ray_cast(&mesh, &bvh, view, a.res as usize, a.perspective)
        .ok_or_else(|| CliError::input(anyhow!("{}: empty mesh", a.mesh.display())))?;
    let wn = WindingNumber::new(&mesh);
    let diag = mesh.bounds().map_or(1.0, |b| b.diagonal());
    let options = Options { radius: a.radius * diag, normal_clamp: a.normal, thickness: a.thickness };
    let set = SetRef { points: &points, weights: &weights, log2area: &log2area };
    let params = VerifyParams { options, pixels: a.pixels as usize, mc_samples: a.mc as usize, seed: a.seed };
    let r = verify(&db, &frame, &wn, method, set, &reflections, &params);
    if let Some(img) = &a.image {
        use crate::figure::{ColorBar, Figure, Panel, gray};
        let s = (reflections.len() as f64).sqrt() as usize;
        // image rows top-down: +y up; pixels the estimate does not cover stay black
        let panel = Panel::from_fn(format!("{} estimate", a.method), db.width, db.height, |i, row| {
            let j = db.height - 1 - row;
            estimate(&db, i, j, method, set, reflections[(j % s) * s + i % s], &options).map_or([0, 0, 0], gray)
        });
        let fig = Figure {
            panels: vec![panel],
            colorbar: Some(ColorBar { label: "occlusion estimate (unitless)".into(), lo: 0.0, hi: 1.0, map: gray }),
            caption: vec![format!(
                "{}x{} pixels, radius {:.4} (world units), {} reflection vectors",
                db.width,
                db.height,
                options.radius,
                reflections.len()
            )],
        };
        ensure_parent(img)?;
        penumbra_asset::write_file_atomic(img, &crate::figure::render(&fig))
            .with_context(|| format!("cannot write {}", img.display()))?;
    }
    let mut v = serde_json::to_value(r).map_err(CliError::internal)?;
    if let Some(o) = v.as_object_mut() {
        o.insert("method".into(), json!(a.method));
        o.insert("centre".into(), json!(a.centre));
        o.insert("radius".into(), json!(options.radius));
        o.insert("normal".into(), json!(a.normal));
        o.insert("perspective".into(), json!(a.perspective));
        o.insert("mesh".into(), json!(a.mesh.display().to_string()));
        o.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
    }
    let failures = crate::commands::gate::apply(
        &mut v,
        &[crate::commands::gate::Gate { key: "max_rmse", metric: "rmse_vs_volume", max: a.max_rmse }],
    );
    if a.json {
        print_json(&v);
    } else {
        eprintln!(
            "{} {} on {} ({} pixels): bias {:+.4}  noise {:.4}  rmse vs volume {:.4}  vs height field {:.4}  (height field vs volume {:.4}; truth s.e. {:.4})  {:.0} ns/pixel",
            a.method,
            if a.centre { "(centre)" } else { "" },
            a.mesh.display(),
            r.pixels,
            r.bias,
            r.noise,
            r.rmse_vs_volume,
            r.rmse_vs_heightfield,
            r.heightfield_vs_volume_rmse,
            r.truth_std_error,
            r.ns_per_pixel
        );
    }
    Ok((crate::commands::gate::finish(&failures), v))
}
