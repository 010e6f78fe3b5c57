//! `penumbra verify shadows`: the sphere-proxy soft-shadow runtime against ray-traced truth
//! (issue "Soft-shadow runtime"; SHEXP §4–7, Fig. 7).
//!
//! Errors are NRMSE = RMSE over receivers and RGB channels / (max − min of the reference over
//! receivers and channels), the convention of `penumbra verify fiv`:
//! - `nrmse_vs_mesh`: runtime vs the mesh ray-traced under the environment band-limited (and
//!   windowed) exactly as the runtime's lighting, so it measures visibility error;
//! - `nrmse_vs_mesh_full`: the same against the full-frequency environment map;
//! - `nrmse_vs_spheres`: runtime vs the spheres themselves ray-traced (after the same
//!   self-shadow rules) under the band-limited light: SH truncation, log/exponentiation,
//!   table interpolation and, with `--hierarchy`, the cut and its ratio vectors — everything
//!   but the spheres' fit to the mesh;
//! - `nrmse_log_vs_product`: runtime (log space) vs product-space accumulation (SHEXP eq. 6),
//!   relative to the product result's range. The product path reads the tables' θ-grid
//!   `cap_visibility`, the log path the α-grid `proxy_log_occlusion` (and `cap_log` near
//!   contact): same bake, different tables.
//! - `blockers_per_receiver`: blockers (leaves or cut nodes) handed to the runtime per
//!   receiver, before the self-shadow rules drop any.
//! - `ns_per_receiver`: the batched path, one thread; with `--accumulate-tables` the scalar
//!   one-receiver path (`irradiance_accumulated_by`).

use crate::args::{EnvRotateArg, UpArg};
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use anyhow::{Context, anyhow};
use clap::{Args, ValueEnum};
use penumbra_asset::AssetFile;
use penumbra_geometry::{EnvMap, MeshBvh, TriMesh};
use penumbra_math::sh::ShEval;
use penumbra_runtime::shadows::rules::replace_parts;
use penumbra_runtime::shadows::{CutBlocker, RuntimeExp, ShadowEvaluator, ShadowOptions, Sphere as RtSphere};
use penumbra_runtime::{NodeRef, PosedSpheres, ShTables, SphereSet, SphereTree};

mod indirect;
mod local_light;
pub mod pose;
use penumbra_spheres::reference;
use penumbra_spheres::sphere::Sphere;
use pose::Pose;
use rayon::prelude::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Receivers of a verification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReceiverKind {
    /// A ground plane under the object (touching its lowest point), seen from above.
    Plane,
    /// The mesh's own vertices (self-shadowing), with area-weighted vertex normals.
    Mesh,
    /// Far field: one plane of `--resolution`² receivers under the object at each distance of
    /// [`FAR_DIAGONALS`] object diagonals below its lowest point, each `±(2R + D/2)` wide
    /// (`R` half the diagonal); reported per distance as `nrmse_by_distance`.
    Far,
}

/// Distances of the `--receivers far` planes below the object, in object diagonals.
pub const FAR_DIAGONALS: [f64; 7] = [0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0];

/// Exponential of the runtime.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ExpArg {
    /// Optimal linear with scaling and squaring (SHEXP §4.3).
    Hyb,
    /// Optimal linear (SHEXP eq. 23).
    Ol,
    /// PS*-p: DC isolation, scaling/squaring, factored series of degree `--ps-degree`.
    Ps,
}

/// `penumbra verify shadows`.
#[derive(Debug, Args, Clone)]
pub struct VerifyShadowsArgs {
    /// Sphere set (SPHR asset).
    #[arg(long)]
    pub spheres: PathBuf,
    /// SH tables (SHTB asset); their order is the runtime's.
    #[arg(long)]
    pub tables: PathBuf,
    /// The mesh the spheres were fitted to (ray-traced truth).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Environment map (lat-long .exr or .hdr), or `builtin:area-lights`.
    #[arg(long)]
    pub env: PathBuf,
    /// Receivers.
    #[arg(long, value_enum, default_value_t = ReceiverKind::Plane)]
    pub receivers: ReceiverKind,
    /// SH exponential of the runtime.
    #[arg(long, value_enum, default_value_t = ExpArg::Hyb)]
    pub exp: ExpArg,
    /// Series degree p of `--exp ps`.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub ps_degree: u32,
    /// Use the sphere hierarchy: per receiver cluster a cut with ratio vectors (SHEXP §6.3).
    #[arg(long)]
    pub hierarchy: bool,
    /// Angular radius threshold θ_max of the cut, degrees (SHEXP: 20–30).
    #[arg(long, default_value_t = 25.0)]
    pub theta_max: f64,
    /// Receivers per cluster edge on the plane (clusters are tiles of N×N receivers); for mesh
    /// receivers, about N² receivers per cluster.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub cluster: u32,
    /// Plane receivers per side.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(2..=1024))]
    pub resolution: u32,
    /// Most mesh receivers (vertices are subsampled evenly beyond it).
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub max_receivers: u32,
    /// Reference rays per receiver: K×K stratified, cosine-weighted.
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(2..=1024))]
    pub rays: u32,
    /// Do not window lighting and visibility (SHEXP §7).
    #[arg(long)]
    pub no_window: bool,
    /// Up axis of the scene (the plane lies under the object along it).
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    pub up: UpArg,
    /// Rotate the environment by 180° about an axis (exact texel permutation); `z180` brings
    /// the upside-down grace_latlong.exr probe upright.
    #[arg(long, value_enum, default_value_t = EnvRotateArg::None)]
    pub env_rotate: EnvRotateArg,
    /// SH tables of a higher order to accumulate and exponentiate visibility at, truncating to
    /// `--tables`' order before shading (SHEXP Fig. 7e).
    #[arg(long, value_name = "SHTB")]
    pub accumulate_tables: Option<PathBuf>,
    /// Seed of the reference's stratified jitter.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write a PNG (plane receivers): runtime | mesh truth | difference, seen from above, each
    /// panel at least 512 px and titled, a colour bar for the difference and a caption.
    #[arg(long, value_name = "FILE")]
    pub image: Option<PathBuf>,
    /// Quality gate: exit 1 when `nrmse_vs_mesh` exceeds it (the report is still printed).
    #[arg(long, value_name = "NRMSE", value_parser = crate::commands::gate::parse_max)]
    pub max_nrmse: Option<f64>,
    /// Also shade with a local spherical light of unit radiance at `X,Y,Z` with radius `RADIUS`
    /// (scene units) through the tables' `L_H(θ, φ)` ZH fit (SHEXP §7), against the light
    /// ray traced at that finite distance: reports `nrmse_local_light`.
    #[arg(long, value_name = "X,Y,Z,RADIUS", allow_hyphen_values = true)]
    pub local_light: Option<String>,
    /// Pose the mesh and the spheres (SPHR skin influences, hierarchy refitted) by this glTF
    /// animation (name or index); reports `posed_coverage` and per-pose errors in `poses`.
    #[arg(long, value_name = "NAME")]
    pub animation: Option<String>,
    /// Time of the pose in seconds (with `--animation`; default: the animation's start).
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub time: Option<f64>,
    /// Evaluate N poses evenly spaced over the animation's key range, ends included.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=256))]
    pub frames: Option<u32>,
    /// Also verify indirect light from the proxies (IBPA §5) by the point-sampled, averaged
    /// `D(θ)` and exact `M(θ)` operators against a one-bounce path trace off the diffuse
    /// spheres: reports `nrmse_indirect` per operator and each one's cost.
    #[arg(long)]
    pub indirect: bool,
    /// Albedo of every proxy for `--indirect`, `R,G,B` (or one value) in [0, 1]. Default: the
    /// SPHR's per-sphere albedo (`albedo` section) when it has one, else 0.8.
    #[arg(long, value_name = "R,G,B")]
    pub albedo: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Everything the verification measured.
#[derive(Debug, Clone)]
pub struct ShadowReport {
    /// The `--json` object.
    pub json: Value,
    /// Per receiver RGB: runtime, mesh truth (band-limited).
    pub runtime: Vec<[f64; 3]>,
    /// Mesh truth.
    pub mesh_truth: Vec<[f64; 3]>,
}

/// NRMSE of `a` against `reference` (see the module docs).
pub fn nrmse(a: &[[f64; 3]], reference: &[[f64; 3]]) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut se = 0.0;
    for (x, r) in a.iter().zip(reference) {
        for c in 0..3 {
            lo = lo.min(r[c]);
            hi = hi.max(r[c]);
            se += (x[c] - r[c]).powi(2);
        }
    }
    let rmse = (se / (3 * a.len().max(1)) as f64).sqrt();
    if hi > lo { rmse / (hi - lo) } else { f64::NAN }
}

pub use crate::env_light::env_rgb_sh;

fn open_asset(path: &Path) -> Result<AssetFile, CliError> {
    AssetFile::open(path).map_err(|e| CliError::input(anyhow!("{e}")))
}

/// The receivers: `(position, unit normal)`, plus the plane layout when on a plane.
/// A receiver: position and unit normal.
type Receiver = ([f64; 3], [f64; 3]);
/// An estimate and its standard error (RGB).
type Estimate = ([f64; 3], [f64; 3]);

fn receivers(mesh: &TriMesh, a: &VerifyShadowsArgs) -> Result<Vec<Receiver>, CliError> {
    let b = mesh.bounds().ok_or_else(|| CliError::input(anyhow!("{}: the mesh is empty", a.mesh.display())))?;
    let up = match a.up {
        UpArg::Y => 1,
        UpArg::Z => 2,
    };
    match a.receivers {
        ReceiverKind::Plane => {
            let c = b.center();
            let r = 0.5 * b.diagonal();
            let res = a.resolution as usize;
            let (u, v) = ((up + 1) % 3, (up + 2) % 3);
            let mut out = Vec::with_capacity(res * res);
            let mut n = [0.0; 3];
            n[up] = 1.0;
            for j in 0..res {
                for i in 0..res {
                    let mut p = [0.0; 3];
                    p[up] = b.min[up];
                    // row 0 of the image is the far side: i along u, j along v
                    p[u] = c[u] - 2.0 * r + 4.0 * r * (i as f64 + 0.5) / res as f64;
                    p[v] = c[v] - 2.0 * r + 4.0 * r * (j as f64 + 0.5) / res as f64;
                    out.push((p, n));
                }
            }
            Ok(out)
        }
        ReceiverKind::Far => {
            let c = b.center();
            let diag = b.diagonal();
            let r = 0.5 * diag;
            let res = a.resolution as usize;
            let (u, v) = ((up + 1) % 3, (up + 2) % 3);
            let mut n = [0.0; 3];
            n[up] = 1.0;
            let mut out = Vec::with_capacity(FAR_DIAGONALS.len() * res * res);
            for &dd in &FAR_DIAGONALS {
                let half = 2.0 * r + 0.5 * dd * diag;
                for j in 0..res {
                    for i in 0..res {
                        let mut p = [0.0; 3];
                        p[up] = b.min[up] - dd * diag;
                        p[u] = c[u] - half + 2.0 * half * (i as f64 + 0.5) / res as f64;
                        p[v] = c[v] - half + 2.0 * half * (j as f64 + 0.5) / res as f64;
                        out.push((p, n));
                    }
                }
            }
            Ok(out)
        }
        ReceiverKind::Mesh => {
            let nv = mesh.positions.len();
            let mut normals = vec![[0.0f64; 3]; nv];
            for t in 0..mesh.triangle_count() {
                let cr = mesh.triangle_cross(t);
                for &vi in &mesh.indices[t] {
                    for k in 0..3 {
                        normals[vi as usize][k] += cr[k];
                    }
                }
            }
            let used: Vec<usize> = (0..nv).filter(|&i| normals[i].iter().map(|x| x * x).sum::<f64>() > 0.0).collect();
            let stride = used.len().div_ceil(a.max_receivers as usize).max(1);
            Ok(used
                .iter()
                .step_by(stride)
                .map(|&i| {
                    let l = normals[i].iter().map(|x| x * x).sum::<f64>().sqrt();
                    (mesh.positions[i], normals[i].map(|x| x / l))
                })
                .collect())
        }
    }
}

/// Receiver clusters: index lists (plane: tiles; mesh: uniform grid buckets).
fn clusters(recv: &[Receiver], a: &VerifyShadowsArgs) -> Vec<Vec<usize>> {
    let cs = a.cluster as usize;
    match a.receivers {
        ReceiverKind::Plane | ReceiverKind::Far => {
            let res = a.resolution as usize;
            let tiles = res.div_ceil(cs);
            let planes = recv.len() / (res * res);
            let mut out = vec![Vec::new(); planes * tiles * tiles];
            for k in 0..planes {
                for j in 0..res {
                    for i in 0..res {
                        out[k * tiles * tiles + (j / cs) * tiles + i / cs].push(k * res * res + j * res + i);
                    }
                }
            }
            out
        }
        ReceiverKind::Mesh => {
            let target = (recv.len() / (cs * cs)).max(1);
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for (p, _) in recv {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            let vol: f64 = (0..3).map(|k| (hi[k] - lo[k]).max(1e-12)).product();
            let h = (vol / target as f64).cbrt();
            let dims: [usize; 3] = std::array::from_fn(|k| (((hi[k] - lo[k]) / h).ceil() as usize).max(1));
            let mut map = std::collections::BTreeMap::<usize, Vec<usize>>::new();
            for (i, (p, _)) in recv.iter().enumerate() {
                let c: [usize; 3] = std::array::from_fn(|k| (((p[k] - lo[k]) / h) as usize).min(dims[k] - 1));
                map.entry(c[0] + dims[0] * (c[1] + dims[1] * c[2])).or_default().push(i);
            }
            map.into_values().collect()
        }
    }
}

fn to32(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// Runs the verification (no output files).
#[allow(clippy::too_many_lines)]
pub fn evaluate(a: &VerifyShadowsArgs) -> Result<ShadowReport, CliError> {
    let tables_file = open_asset(&a.tables)?;
    let tables_asset = tables_file.asset();
    let tables =
        ShTables::from_asset(&tables_asset).map_err(|e| CliError::input(anyhow!("{}: {e}", a.tables.display())))?;
    let sphere_file = open_asset(&a.spheres)?;
    let sphere_asset = sphere_file.asset();
    let set =
        SphereSet::from_asset(&sphere_asset).map_err(|e| CliError::input(anyhow!("{}: {e}", a.spheres.display())))?;
    if set.is_empty() {
        return Err(CliError::input(anyhow!("{}: the sphere set is empty", a.spheres.display())));
    }
    if a.hierarchy && set.depth() == 0 {
        return Err(CliError::input(anyhow!(
            "{}: --hierarchy: the asset has no hierarchy (bake it with `penumbra spheres --hierarchy`)",
            a.spheres.display()
        )));
    }
    if !(a.theta_max > 0.0 && a.theta_max < 90.0) {
        return Err(CliError::input(anyhow!(
            "--theta-max {} is out of range (allowed: 0 < θ < 90 degrees)",
            a.theta_max
        )));
    }
    if let Some(m) = a.max_nrmse {
        if !(m > 0.0 && m.is_finite()) {
            return Err(CliError::input(anyhow!("--max-nrmse {m} is out of range (allowed: a finite value > 0)")));
        }
    }
    let (scene, _) = penumbra_geometry::load_mesh(&a.mesh).map_err(CliError::input)?;
    let env = match a.env.to_str().and_then(|s| s.strip_prefix("builtin:")) {
        Some("area-lights") => penumbra_geometry::env::procedural::area_lights(512, 256),
        Some(other) => {
            return Err(CliError::input(anyhow!(
                "--env builtin:{other}: unknown procedural environment (known: builtin:area-lights)"
            )));
        }
        None => {
            penumbra_geometry::load_env_map(&a.env)
                .with_context(|| format!("cannot load environment map {}", a.env.display()))?
                .0
        }
    };
    use penumbra_geometry::env::Rotation;
    let rotation = match a.env_rotate {
        EnvRotateArg::None => Rotation::None,
        EnvRotateArg::X180 => Rotation::X180,
        EnvRotateArg::Y180 => Rotation::Y180,
        EnvRotateArg::Z180 => Rotation::Z180,
    };
    let env = if rotation == Rotation::None {
        env
    } else {
        env.rotated(rotation).ok_or_else(|| CliError::input(anyhow!("{}: cannot rotate this map", a.env.display())))?
    };
    let order = tables.order();
    let exp = match a.exp {
        ExpArg::Hyb => RuntimeExp::Hyb,
        ExpArg::Ol => RuntimeExp::Ol,
        ExpArg::Ps => RuntimeExp::PsStar(a.ps_degree),
    };
    let window = !a.no_window;
    let light = env_rgb_sh(&env, order);
    let light32: Vec<[f32; 3]> = light.iter().map(|&c| to32(c)).collect();
    let options = ShadowOptions { exp, window, ..Default::default() };
    let ev = ShadowEvaluator::new(&tables, &light32, options);
    // the band-limited light the runtime shades with (windowed like the runtime's)
    let win: Vec<f64> =
        if window { tables.cosine_window().iter().map(|&w| w as f64).collect() } else { vec![1.0; order] };
    let light_bl: Vec<[f64; 3]> = light
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let w = win[penumbra_math::sh::band_of(i)];
            c.map(|x| x * w)
        })
        .collect();
    let acc_file = a.accumulate_tables.as_deref().map(open_asset).transpose()?;
    let acc_asset = acc_file.as_ref().map(|f| f.asset());
    let acc_tables = acc_asset.as_ref().map(ShTables::from_asset).transpose().map_err(|e| {
        CliError::input(anyhow!(
            "{}: {e}",
            a.accumulate_tables.as_ref().map(|p| p.display().to_string()).unwrap_or_default()
        ))
    })?;
    if let Some(t) = &acc_tables {
        if t.order() < order {
            return Err(CliError::input(anyhow!(
                "--accumulate-tables: order {} is below --tables' order {order} (it must be higher)",
                t.order()
            )));
        }
        if a.hierarchy {
            return Err(CliError::input(anyhow!("--accumulate-tables cannot be combined with --hierarchy")));
        }
    }
    let acc_light: Vec<[f32; 3]> =
        acc_tables.as_ref().map(|t| env_rgb_sh(&env, t.order()).iter().map(|&c| to32(c)).collect()).unwrap_or_default();
    let acc_ev = acc_tables.as_ref().map(|t| ShadowEvaluator::new(t, &acc_light, options));
    let poses = pose::poses(&scene, a.animation.as_deref(), a.time, a.frames)?;
    if poses.len() > 1 && (a.receivers == ReceiverKind::Far || a.image.is_some()) {
        return Err(CliError::input(anyhow!("--frames N > 1 cannot be combined with --receivers far or --image")));
    }
    if a.animation.is_some() && !set.is_skinned() {
        return Err(CliError::input(anyhow!(
            "{}: --animation: the sphere set has no skin influences (bake it with `penumbra spheres --skin`)",
            a.spheres.display()
        )));
    }
    let local = a.local_light.as_deref().map(local_light::parse).transpose()?;
    if local.is_some() && tables.local_light_zh().is_none() {
        return Err(CliError::input(anyhow!(
            "{}: --local-light: the tables have no local_light_zh section",
            a.tables.display()
        )));
    }
    // per-sphere albedo of the proxies: --albedo for all, else the SPHR's, else 0.8
    let albedo: Option<(Vec<[f64; 3]>, &str)> = if !a.indirect {
        None
    } else if let Some(s) = a.albedo.as_deref() {
        Some((vec![crate::commands::spheres::parse_albedo(s)?; set.len()], "flag"))
    } else if set.has_albedo() {
        Some(((0..set.len()).map(|i| set.albedo(i).unwrap_or([0.0; 3]).map(f64::from)).collect(), "sphr"))
    } else {
        Some((vec![[0.8; 3]; set.len()], "default"))
    };
    let env_sh3 = if a.indirect { env_rgb_sh(&env, 3) } else { Vec::new() };
    let indirect_in = albedo.as_ref().map(|al| (al.0.as_slice(), env_sh3.as_slice()));
    let env_ctx = EnvCtx { env: &env, light_bl: &light_bl, eval: ShEval::new(order) };
    let mut frames: Vec<FrameOut> = Vec::with_capacity(poses.len());
    for &p in &poses {
        let mut tree = PosedSpheres::rest(set);
        let mesh = match p.0 {
            None => scene.mesh.clone(),
            Some(_) => {
                tree.pose(&pose::node_matrices(&scene, p)?)
                    .map_err(|e| CliError::input(anyhow!("{}: {e}", a.spheres.display())))?;
                scene.posed_mesh(p.0, p.1).map_err(|e| CliError::input(anyhow!("{}: {e}", a.mesh.display())))?
            }
        };
        frames.push(evaluate_frame(a, &ev, acc_ev.as_ref(), &tree, &mesh, &env_ctx, local, indirect_in)?);
        if let Some(f) = frames.last_mut() {
            f.pose = p;
            if p.0.is_some() {
                let tol = 1e-6 * mesh.bounds().map_or(1.0, |b| b.diagonal());
                f.coverage = Some(pose::surface_coverage(&mesh, tree.leaves(), tol));
            }
        }
    }
    let cat = |sel: &dyn Fn(&FrameOut) -> &Vec<[f64; 3]>| -> Vec<[f64; 3]> {
        frames.iter().flat_map(|f| sel(f).iter().copied()).collect()
    };
    let runtime = cat(&|f| &f.runtime);
    let product = cat(&|f| &f.product);
    let mesh_truth = cat(&|f| &f.mesh_truth);
    let mesh_full = cat(&|f| &f.mesh_full);
    let sphere_truth = cat(&|f| &f.sphere_truth);
    let n_recv = runtime.len();
    // RMS of the references' standard errors over their range (an upper bound of their noise)
    let noise = |sel: &dyn Fn(&FrameOut) -> &Vec<[f64; 3]>, reference: &[[f64; 3]]| -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for r in reference {
            for c in 0..3 {
                lo = lo.min(r[c]);
                hi = hi.max(r[c]);
            }
        }
        let ms = frames.iter().flat_map(|f| sel(f).iter()).map(|se| se.iter().map(|x| x * x).sum::<f64>()).sum::<f64>()
            / (3 * n_recv) as f64;
        if hi > lo { ms.sqrt() / (hi - lo) } else { f64::NAN }
    };
    let unshadowed_mean = frames
        .iter()
        .flat_map(|f| f.recv.iter())
        .map(|(_, n)| ev.unshadowed(to32(*n)).iter().map(|&x| x as f64).sum::<f64>() / 3.0)
        .sum::<f64>()
        / n_recv as f64;
    let max_abs =
        runtime.iter().zip(&mesh_truth).flat_map(|(x, r)| (0..3).map(move |c| (x[c] - r[c]).abs())).fold(0.0, f64::max);
    let nrmse_by_distance: Option<Vec<Value>> = (a.receivers == ReceiverKind::Far).then(|| {
        let per = a.resolution as usize * a.resolution as usize;
        FAR_DIAGONALS
            .iter()
            .enumerate()
            .map(|(k, &dd)| {
                let r = k * per..(k + 1) * per;
                json!({
                    "diagonals": dd,
                    "nrmse_vs_spheres": nrmse(&runtime[r.clone()], &sphere_truth[r.clone()]),
                    "nrmse_vs_mesh": nrmse(&runtime[r.clone()], &mesh_truth[r.clone()]),
                    "nrmse_spheres_vs_mesh": nrmse(&sphere_truth[r.clone()], &mesh_truth[r.clone()]),
                    "shadow_depth": {
                        "mesh": shadow_depth(&mesh_truth[r.clone()]),
                        "runtime": shadow_depth(&runtime[r]),
                    },
                })
            })
            .collect()
    });
    let mean = |sel: &dyn Fn(&FrameOut) -> f64| {
        frames.iter().map(|f| sel(f) * f.recv.len() as f64).sum::<f64>() / n_recv as f64
    };
    let ns = mean(&|f| f.ns_per_receiver);
    let scalar_timing = acc_ev.is_some();
    let animated = a.animation.is_some();
    let anim_name = |p: Pose| p.0.map(|i| scene.animations[i].name.clone().unwrap_or_else(|| i.to_string()));
    let pose_json: Option<Vec<Value>> = animated.then(|| {
        frames
            .iter()
            .map(|f| {
                json!({
                    "animation": anim_name(f.pose),
                    "time": f.pose.1,
                    "posed_coverage": f.coverage,
                    "nrmse_vs_mesh": nrmse(&f.runtime, &f.mesh_truth),
                    "nrmse_vs_spheres": nrmse(&f.runtime, &f.sphere_truth),
                    "nrmse_spheres_vs_mesh": nrmse(&f.sphere_truth, &f.mesh_truth),
                    "nrmse_local_light": f.local.as_ref().map(|l| nrmse(&l.runtime, &l.mesh)),
                })
            })
            .collect()
    });
    let local_json = local.map(|l| {
        let lc = |sel: &dyn Fn(&LocalOut) -> &Vec<[f64; 3]>| -> Vec<[f64; 3]> {
            frames.iter().filter_map(|f| f.local.as_ref()).flat_map(|o| sel(o).iter().copied()).collect()
        };
        let (rt, mesh, sph, rt_un, un) = (
            lc(&|o| &o.runtime),
            lc(&|o| &o.mesh),
            lc(&|o| &o.spheres),
            lc(&|o| &o.runtime_unshadowed),
            lc(&|o| &o.unshadowed),
        );
        json!({
            "nrmse_local_light": nrmse(&rt, &mesh),
            "nrmse_local_light_vs_spheres": nrmse(&rt, &sph),
            "nrmse_local_light_unshadowed": nrmse(&rt_un, &un),
            "nrmse_local_light_spheres_vs_mesh": nrmse(&sph, &mesh),
            "local_light": {"center": [l.0[0], l.0[1], l.0[2]], "radius": l.0[3], "radiance": 1.0},
        })
    });
    let mut json = json!({
        "nrmse_by_distance": nrmse_by_distance,
        "nrmse_vs_mesh": nrmse(&runtime, &mesh_truth),
        "nrmse_vs_mesh_full": nrmse(&runtime, &mesh_full),
        "nrmse_vs_spheres": nrmse(&runtime, &sphere_truth),
        "nrmse_log_vs_product": nrmse(&runtime, &product),
        "nrmse_product_vs_spheres": nrmse(&product, &sphere_truth),
        "nrmse_spheres_vs_mesh": nrmse(&sphere_truth, &mesh_truth),
        "reference_noise_nrmse": {
            "mesh": noise(&|f| &f.mesh_se, &mesh_truth),
            "mesh_full": noise(&|f| &f.mesh_full_se, &mesh_full),
            "spheres": noise(&|f| &f.sphere_se, &sphere_truth),
        },
        "max_abs_error_vs_mesh": max_abs,
        "unshadowed_irradiance_mean": unshadowed_mean,
        "receivers": n_recv,
        "receiver_kind": match a.receivers { ReceiverKind::Plane => "plane", ReceiverKind::Mesh => "mesh", ReceiverKind::Far => "far" },
        "reference_rays_per_receiver": a.rays as usize * a.rays as usize,
        "ns_per_receiver": (!scalar_timing).then_some(ns),
        "ns_per_receiver_scalar": scalar_timing.then_some(ns),
        "timed_path": if scalar_timing { "scalar (irradiance_accumulated_by)" } else if a.hierarchy { "batched, cut + ratio vectors included" } else { "batched" },
        "blockers_per_receiver": mean(&|f| f.accumulated_per_receiver),
        "candidate_blockers_per_receiver": mean(&|f| f.candidates_per_receiver),
        "hierarchy": a.hierarchy,
        "theta_max_deg": a.hierarchy.then_some(a.theta_max),
        "clusters": a.hierarchy.then(|| frames.iter().map(|f| f.clusters).sum::<usize>()),
        "exp_method": match a.exp { ExpArg::Hyb => "hyb".to_string(), ExpArg::Ol => "ol".to_string(), ExpArg::Ps => format!("ps*-{}", a.ps_degree) },
        "window": window,
        "order": order,
        "accumulation_order": acc_tables.as_ref().map_or(order, |t| t.order()),
        "env_rotate": format!("{:?}", a.env_rotate).to_lowercase(),
        "sphere_count": set.len(),
        "animation": poses.first().and_then(|&p| anim_name(p)),
        "poses": pose_json,
        "posed_coverage": animated.then(|| frames.iter().filter_map(|f| f.coverage).fold(f64::INFINITY, f64::min)),
        "posed_coverage_mean": animated.then(|| frames.iter().filter_map(|f| f.coverage).sum::<f64>() / frames.len() as f64),
        "nrmse_definition": "RMSE over receivers and RGB / (max - min of the reference over receivers and RGB)",
    });
    if let (Some(o), Some(Value::Object(l))) = (json.as_object_mut(), local_json) {
        o.extend(l);
    }
    if let (Some(o), Some((al, source))) = (json.as_object_mut(), albedo.as_ref()) {
        let outs: Vec<&indirect::IndirectOut> = frames.iter().filter_map(|f| f.indirect.as_ref()).collect();
        if let Value::Object(l) = indirect::report(&outs, al, source) {
            o.extend(l);
        }
    }
    Ok(ShadowReport { json, runtime, mesh_truth })
}

/// Per-sphere albedo and the order-3 environment SH of `--indirect`.
type IndirectIn<'a> = (&'a [[f64; 3]], &'a [[f64; 3]]);

/// The environment light of a verification.
struct EnvCtx<'e> {
    env: &'e EnvMap,
    /// Band-limited, windowed RGB SH (the runtime's light).
    light_bl: &'e [[f64; 3]],
    eval: ShEval,
}

/// Local-light results of one pose (RGB per receiver).
struct LocalOut {
    runtime: Vec<[f64; 3]>,
    mesh: Vec<[f64; 3]>,
    spheres: Vec<[f64; 3]>,
    runtime_unshadowed: Vec<[f64; 3]>,
    unshadowed: Vec<[f64; 3]>,
}

/// What one pose measured.
struct FrameOut {
    pose: Pose,
    recv: Vec<Receiver>,
    runtime: Vec<[f64; 3]>,
    product: Vec<[f64; 3]>,
    mesh_truth: Vec<[f64; 3]>,
    mesh_se: Vec<[f64; 3]>,
    mesh_full: Vec<[f64; 3]>,
    mesh_full_se: Vec<[f64; 3]>,
    sphere_truth: Vec<[f64; 3]>,
    sphere_se: Vec<[f64; 3]>,
    ns_per_receiver: f64,
    candidates_per_receiver: f64,
    accumulated_per_receiver: f64,
    clusters: usize,
    coverage: Option<f64>,
    local: Option<LocalOut>,
    indirect: Option<indirect::IndirectOut>,
}

/// The runtime, product space and the references for one pose of the mesh and the spheres.
fn evaluate_frame(
    a: &VerifyShadowsArgs,
    ev: &ShadowEvaluator<'_>,
    acc_ev: Option<&ShadowEvaluator<'_>>,
    tree: &PosedSpheres<'_>,
    mesh: &TriMesh,
    env: &EnvCtx<'_>,
    local: Option<local_light::Light>,
    indirect_in: Option<IndirectIn<'_>>,
) -> Result<FrameOut, CliError> {
    let order = ev.order();
    let recv = receivers(mesh, a)?;
    let n_recv = recv.len();
    let leaves: Vec<RtSphere> = tree.leaves().to_vec();
    let clusters = clusters(&recv, a);
    let p32: Vec<[f32; 3]> = recv.iter().map(|(p, _)| to32(*p)).collect();
    let n32: Vec<[f32; 3]> = recv.iter().map(|(_, n)| to32(*n)).collect();
    let sin_max = (a.theta_max.to_radians().sin()) as f32;
    // a cluster's cut and its ratio vectors at its central receiver (SHEXP §6.3)
    let cluster_cut =
        |cl: &[usize], stack: &mut Vec<NodeRef>, cut: &mut Vec<NodeRef>, blockers: &mut Vec<CutBlocker>| {
            let mut g = [0.0f64; 3];
            for &i in cl {
                for k in 0..3 {
                    g[k] += recv[i].0[k] / cl.len() as f64;
                }
            }
            let star = *cl
                .iter()
                .min_by(|&&x, &&y| {
                    penumbra_spheres::sphere::dist2(recv[x].0, g)
                        .total_cmp(&penumbra_spheres::sphere::dist2(recv[y].0, g))
                })
                .unwrap_or(&cl[0]);
            let r_r = cl.iter().map(|&i| penumbra_spheres::sphere::dist(recv[i].0, g)).fold(0.0, f64::max);
            tree.cut(to32(g), r_r as f32, sin_max, stack, cut);
            ev.cluster_blockers(tree, cut, to32(recv[star].0), to32(recv[star].1), blockers);
        };

    // runtime, timed on one thread
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(CliError::internal)?;
    let (runtime, ns_per_receiver) = pool.install(|| {
        let start = Instant::now();
        let mut out = vec![[0.0f64; 3]; n_recv];
        if a.hierarchy {
            let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::new());
            let (mut cp, mut cn, mut co) = (Vec::new(), Vec::new(), Vec::new());
            for cl in &clusters {
                cluster_cut(cl, &mut stack, &mut cut, &mut blockers);
                // the cluster's receivers share the blockers: one batched call
                cp.clear();
                cn.clear();
                cp.extend(cl.iter().map(|&i| p32[i]));
                cn.extend(cl.iter().map(|&i| n32[i]));
                co.resize(cl.len(), [0.0f32; 3]);
                ev.irradiance_blockers_batch(&cp, &cn, &blockers, &mut co);
                for (k, &i) in cl.iter().enumerate() {
                    out[i] = co[k].map(f64::from);
                }
            }
        } else {
            match acc_ev {
                Some(acc) => {
                    for (i, (p, n)) in recv.iter().enumerate() {
                        out[i] = ev.irradiance_accumulated_by(acc, to32(*p), to32(*n), &leaves).map(f64::from);
                    }
                }
                None => {
                    let mut o32 = vec![[0.0f32; 3]; n_recv];
                    ev.irradiance_batch(&p32, &n32, &leaves, &mut o32);
                    for (o, v) in out.iter_mut().zip(&o32) {
                        *o = v.map(f64::from);
                    }
                }
            }
        }
        (out, start.elapsed().as_nanos() as f64 / n_recv as f64)
    });
    // blockers per receiver, untimed: handed to the runtime, and really accumulated (after
    // the self-shadow rules drop those behind or containing the receiver)
    let (mut candidates, mut accumulated) = (0usize, 0usize);
    if a.hierarchy {
        let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::new());
        for cl in &clusters {
            cluster_cut(cl, &mut stack, &mut cut, &mut blockers);
            candidates += blockers.len() * cl.len();
            accumulated += cl
                .iter()
                .map(|&i| ev.accumulated_count(p32[i], n32[i], blockers.iter().map(|b| b.sphere)))
                .sum::<usize>();
        }
    } else {
        candidates = leaves.len() * n_recv;
        accumulated = (0..n_recv).map(|i| ev.accumulated_count(p32[i], n32[i], leaves.iter().copied())).sum();
    }
    // product-space accumulation (all leaves)
    let product: Vec<[f64; 3]> =
        recv.par_iter().map(|(p, n)| ev.irradiance_product(to32(*p), to32(*n), &leaves).map(f64::from)).collect();

    // references
    let bvh = MeshBvh::build(mesh).map_err(|e| CliError::input(anyhow!("{}: {e}", a.mesh.display())))?;
    let scale = mesh.bounds().map_or(1.0, |b| b.diagonal());
    let lift = 1e-6 * scale;
    let k = a.rays as usize;
    let spheres64: Vec<Sphere> = leaves.iter().map(|s| Sphere::new(s.center.map(f64::from), s.radius as f64)).collect();
    let blocked_mesh = reference::mesh_blocked(&bvh, lift);
    type Trio = (Estimate, Estimate, Estimate);
    let truths: Vec<Trio> = recv
        .par_iter()
        .enumerate()
        .map(|(i, (p, n))| {
            let o: [f64; 3] = std::array::from_fn(|c| p[c] + lift * n[c]);
            let y = std::cell::RefCell::new(vec![0.0; order * order]);
            let bl = |d: [f64; 3]| reference::sh_radiance(&env.eval, env.light_bl, d, &mut y.borrow_mut());
            let full = |d: [f64; 3]| env.env.sample(d).map(f64::from);
            let mesh_bl = reference::irradiance(o, *n, k, a.seed, i as u64, &bl, &blocked_mesh);
            let mesh_full = reference::irradiance(o, *n, k, a.seed, i as u64, &full, &blocked_mesh);
            let eff = effective_spheres(&spheres64, *p, *n);
            let sph =
                reference::irradiance(o, *n, k, a.seed, i as u64, &bl, &|oo, d| reference::spheres_hit(&eff, oo, d));
            (mesh_bl, mesh_full, sph)
        })
        .collect();
    let local =
        local.map(|l| local_light::evaluate(ev, l, &recv, &leaves, &spheres64, &bvh, lift, k, a.seed)).transpose()?;
    let indirect_out = indirect_in
        .map(|(al, sh3)| indirect::evaluate(ev, al, sh3, &recv, &leaves, &spheres64, k, a.seed))
        .transpose()?;
    Ok(FrameOut {
        pose: (None, 0.0),
        runtime,
        product,
        mesh_truth: truths.iter().map(|t| t.0.0).collect(),
        mesh_se: truths.iter().map(|t| t.0.1).collect(),
        mesh_full: truths.iter().map(|t| t.1.0).collect(),
        mesh_full_se: truths.iter().map(|t| t.1.1).collect(),
        sphere_truth: truths.iter().map(|t| t.2.0).collect(),
        sphere_se: truths.iter().map(|t| t.2.1).collect(),
        ns_per_receiver,
        candidates_per_receiver: candidates as f64 / n_recv as f64,
        accumulated_per_receiver: accumulated as f64 / n_recv as f64,
        clusters: clusters.len(),
        coverage: None,
        local,
        indirect: indirect_out,
        recv,
    })
}

/// The spheres a receiver at `(p, n)` sees after the runtime's own self-shadow rule
/// (`penumbra_runtime::shadows::rules`), evaluated in f64: what the sphere truths trace.
pub fn effective_spheres(spheres: &[Sphere], p: [f64; 3], n: [f64; 3]) -> Vec<Sphere> {
    spheres
        .iter()
        .filter_map(|s| {
            let (c, r, keep) = replace_parts(s.center, s.radius, p, n);
            keep.then(|| Sphere::new(c, r))
        })
        .collect()
}

/// `(max − min)/max` of the mean of RGB over receivers: how deep the shadow on a plane is.
fn shadow_depth(v: &[[f64; 3]]) -> f64 {
    let m: Vec<f64> = v.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
    let hi = m.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = m.iter().copied().fold(f64::INFINITY, f64::min);
    if hi > 0.0 { (hi - lo) / hi } else { f64::NAN }
}

/// Runtime | mesh truth | difference (false colour, ±10 % of the truth's luminance range,
/// with its colour bar) for plane receivers, top view (far side up), with `caption` below.
pub fn write_image(
    path: &Path,
    res: usize,
    runtime: &[[f64; 3]],
    truth: &[[f64; 3]],
    caption: Vec<String>,
) -> Result<(), CliError> {
    use crate::figure::{ColorBar, Figure, Panel, diverging};
    let lum = |c: &[f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let max = truth.iter().map(lum).fold(f64::MIN_POSITIVE, f64::max);
    let min = truth.iter().map(lum).fold(f64::INFINITY, f64::min);
    let range = (max - min).max(f64::MIN_POSITIVE);
    let tone = |v: f64| {
        let g = ((v / max).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8;
        [g, g, g]
    };
    // receiver k = j·res + i; image row 0 is the far side (j = res − 1)
    let at = |i: usize, row: usize| (res - 1 - row) * res + i;
    let span = 0.1 * range;
    let fig = Figure {
        panels: vec![
            Panel::from_fn("runtime (sphere proxies)", res, res, |i, r| tone(lum(&runtime[at(i, r)]))),
            Panel::from_fn("reference (mesh ray traced)", res, res, |i, r| tone(lum(&truth[at(i, r)]))),
            Panel::from_fn("difference", res, res, |i, r| {
                let k = at(i, r);
                diverging(0.5 + 0.5 * (lum(&runtime[k]) - lum(&truth[k])) / span)
            }),
        ],
        colorbar: Some(ColorBar {
            label: "runtime - reference, luminance of irradiance (clamped at 10% of the reference's range)".into(),
            lo: -span,
            hi: span,
            map: diverging,
        }),
        caption,
    };
    ensure_parent(path)?;
    penumbra_asset::write_file_atomic(path, &crate::figure::render(&fig))
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// Runs `penumbra verify shadows`.
pub fn run(a: &VerifyShadowsArgs) -> Result<ExitCode, CliError> {
    run_report(a).map(|(code, _)| code)
}

/// Runs `penumbra verify shadows` and returns its report too (`penumbra bake` stage gates).
#[allow(clippy::print_stderr)]
pub(crate) fn run_report(a: &VerifyShadowsArgs) -> Result<(ExitCode, Value), CliError> {
    let start = Instant::now();
    let r = evaluate(a)?;
    if let Some(img) = &a.image {
        if a.receivers != ReceiverKind::Plane {
            return Err(CliError::input(anyhow!("--image needs --receivers plane")));
        }
        let j = &r.json;
        let caption = vec![
            format!(
                "NRMSE vs mesh {:.4}, {} receivers ({}x{} plane), {} spheres, order {}, {}{}",
                j["nrmse_vs_mesh"].as_f64().unwrap_or(f64::NAN),
                j["receivers"],
                a.resolution,
                a.resolution,
                j["sphere_count"],
                j["order"],
                j["exp_method"].as_str().unwrap_or(""),
                if a.hierarchy { ", hierarchy" } else { "" }
            ),
            format!("top view, far side up; tone: gamma 2.2 of luminance / the reference's peak {:.4}", {
                let lum = |c: &[f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
                r.mesh_truth.iter().map(lum).fold(0.0f64, f64::max)
            }),
        ];
        write_image(img, a.resolution as usize, &r.runtime, &r.mesh_truth, caption)?;
    }
    let mut v = r.json;
    if let Some(o) = v.as_object_mut() {
        o.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
        o.insert("image".into(), json!(a.image.as_ref().map(|p| p.display().to_string())));
    }
    let failures = crate::commands::gate::apply(
        &mut v,
        &[crate::commands::gate::Gate { key: "max_nrmse", metric: "nrmse_vs_mesh", max: a.max_nrmse }],
    );
    if a.json {
        print_json(&v);
    } else {
        let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
        eprintln!(
            "{} receivers, {} spheres, order {}, {}{}\n  NRMSE vs mesh {:.4} (full-frequency env {:.4})  vs spheres {:.4}  log vs product {:.4}\n  runtime {:.0} ns per receiver ({:.1} blockers)",
            v["receivers"],
            v["sphere_count"],
            v["order"],
            v["exp_method"].as_str().unwrap_or(""),
            if a.hierarchy { " with hierarchy" } else { "" },
            f("nrmse_vs_mesh"),
            f("nrmse_vs_mesh_full"),
            f("nrmse_vs_spheres"),
            f("nrmse_log_vs_product"),
            v["ns_per_receiver"].as_f64().or_else(|| v["ns_per_receiver_scalar"].as_f64()).unwrap_or(f64::NAN),
            f("blockers_per_receiver"),
        );
        if let Some(x) = v["nrmse_local_light"].as_f64() {
            eprintln!("  local light: NRMSE vs mesh {x:.4}  vs spheres {:.4}", f("nrmse_local_light_vs_spheres"));
        }
        if let Some(x) = v["posed_coverage"].as_f64() {
            eprintln!("  posed coverage ≥ {x:.4} over {} poses", v["poses"].as_array().map_or(0, Vec::len));
        }
        if v["nrmse_indirect"].is_object() {
            let g = |k: &str| v["nrmse_indirect"][k].as_f64().unwrap_or(f64::NAN);
            eprintln!("  indirect NRMSE: point {:.4}  averaged {:.4}  exact {:.4}", g("point"), g("d"), g("m"));
        }
    }
    Ok((crate::commands::gate::finish(&failures), v))
}
