//! `penumbra sweep fiv`: the speed/accuracy trade of FIV over shell samples, environment cube
//! size and shell radii. Bakes every combination once with `penumbra fiv`'s own bake and
//! measures it as `penumbra verify fiv --plane` does (same receivers, runtime evaluation,
//! reference and metrics, [`crate::commands::verify_fiv`]), then writes `sweep.csv`,
//! `sweep.json` and `sweep.svg` (error against bake seconds, runtime ns per receiver and
//! bytes, the Pareto front marked).
//!
//! What does not change between points is done once: the occluder is loaded and its BVH
//! built once, each environment cube size is resampled once, and the receivers, their masks
//! and the brute-force reference irradiance are computed once for the whole sweep. The
//! reference is the environment resampled at `--reference-cube-size` (default: the largest
//! swept cube size) from the source map, so points at smaller cube sizes carry the error of
//! their coarser environment too.

use crate::args::{EnvRotateArg, UpArg};
use crate::commands::fiv::{FivJob, Input, bake_prepared, cache_key, load_env, load_occluder, parse_samples};
use crate::commands::print_json;
use crate::commands::sweep::{OutputGuard, csv_text, parse_list, with_front, write_outputs};
use crate::commands::verify_fiv::{
    ReceiverSpec, Receivers, metrics, plane_receivers, receiver_masks, reference_irradiance, runtime_irradiance,
    timed_runtime,
};
use crate::exit::{CliError, ExitCode};
use crate::progress::ProgressMode;
use crate::svgplot::{Panel, Series, pareto_front};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::AssetFile;
use penumbra_fiv::asset::read_meta;
use penumbra_fiv::reference::Placed;
use penumbra_fiv::{Lighting, Occluder, Shard, UpAxis};
use penumbra_geometry::env::Rotation;
use penumbra_geometry::{CubeMap, TriMesh, WindingNumber};
use penumbra_runtime::fiv::{FivTable, Partial, PlacedOccluder, ShadeOptions};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// `penumbra sweep fiv`.
#[derive(Debug, Args, Clone)]
pub struct SweepFivArgs {
    /// Occluder mesh (.obj, .gltf, .glb) or `builtin:torus`, `builtin:sphere`.
    #[arg(long)]
    pub mesh: String,
    /// Environment map (lat-long .exr or .hdr) or `builtin:area-lights`.
    #[arg(long)]
    pub env: String,
    /// Rotate the environment by 180° about an axis (`z180` for grace_latlong.exr).
    #[arg(long, value_enum, default_value_t = EnvRotateArg::None)]
    pub env_rotate: EnvRotateArg,
    /// Shell samples, comma-separated AxPxK (azimuth × polar × radial), as `penumbra fiv --samples`.
    #[arg(long, default_value = "16x9x6,32x17x15", value_name = "AxPxK,...")]
    pub samples: String,
    /// Environment cube face sizes (comma-separated, 1..=512).
    #[arg(long, default_value = "16,32")]
    pub cube_size: String,
    /// Innermost shell radii in units of R (comma-separated, 0 <= r_min < r_max).
    #[arg(long, default_value = "1")]
    pub r_min: String,
    /// Outermost shell radii in units of R (comma-separated, r_min < r_max <= 1000).
    #[arg(long, default_value = "8")]
    pub r_max: String,
    /// Polar axis of the shells (and the receiver plane's normal): y or z.
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    pub up: UpArg,
    /// Face size of the diffuse irradiance cube map (every point).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub irradiance_size: u32,
    /// Store the FIVs as f16 (every point).
    #[arg(long)]
    pub half: bool,
    /// Plane receivers per side (the `verify fiv --plane` square of ±3R).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=2048))]
    pub resolution: u32,
    /// Lower the receiver plane D·R below the occluder (as `verify fiv --distance`).
    #[arg(long, value_name = "D")]
    pub distance: Option<f64>,
    /// Cube face size of the reference's environment (default: the largest --cube-size).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=512))]
    pub reference_cube_size: Option<u32>,
    /// Output directory (assets, sweep.csv, sweep.json, sweep.svg).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Print the sweep as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// Runs `penumbra sweep fiv`.
#[allow(clippy::print_stderr)]
pub fn run(a: &SweepFivArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    // every argument and input is checked before anything is written
    let samples: Vec<[usize; 3]> = a.samples.split(',').map(|s| parse_samples(s.trim())).collect::<Result<_, _>>()?;
    let cubes: Vec<usize> = parse_list(&a.cube_size, "cube-size")?;
    let r_mins: Vec<f64> = parse_list(&a.r_min, "r-min")?;
    let r_maxs: Vec<f64> = parse_list(&a.r_max, "r-max")?;
    if let Some(&c) = cubes.iter().find(|&&c| !penumbra_fiv::bake::CUBE_SIZE.contains(&c)) {
        return Err(CliError::input(anyhow!("--cube-size: {c} is out of range (allowed: 1..=512)")));
    }
    if let Some(d) = a.distance.filter(|d| !(d.is_finite() && (0.0..=1000.0).contains(d))) {
        return Err(CliError::input(anyhow!("--distance {d} is out of range (allowed: 0 <= D <= 1000)")));
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
    let mut points: Vec<FivJob> = Vec::new();
    for &s in &samples {
        for &r0 in &r_mins {
            for &r1 in &r_maxs {
                for &c in &cubes {
                    let job = FivJob::new(&a.mesh, &a.env, rot, s, r0, r1, up, c, a.irradiance_size as usize, a.half)
                        .map_err(|e| {
                        CliError::input(anyhow!(
                            "point --samples {}x{}x{} --r-min {r0} --r-max {r1} --cube-size {c}: {}",
                            s[0],
                            s[1],
                            s[2],
                            e.error
                        ))
                    })?;
                    points.push(job);
                }
            }
        }
    }
    let ref_size = a.reference_cube_size.map(|v| v as usize).unwrap_or(cubes.iter().copied().max().unwrap_or(32));
    let t_setup = Instant::now();
    let mesh: Input<_> = load_occluder(&a.mesh, &[])?;
    let occ =
        Occluder::new(mesh.data.clone()).map_err(|e| CliError::input(anyhow!("occluder mesh {}: {e}", a.mesh)))?;
    let mut envs: Vec<(usize, Input<CubeMap>, Lighting)> = Vec::new();
    for &c in cubes.iter().chain(std::iter::once(&ref_size)) {
        if envs.iter().all(|e| e.0 != c) {
            let env = load_env(&a.env, rot, c)?;
            let lighting = Lighting::new(env.data.clone());
            envs.push((c, env, lighting));
        }
    }
    for w in mesh.warnings.iter().chain(&envs[0].1.warnings) {
        eprintln!("warning: {w}");
    }
    let ref_light = &envs.iter().find(|e| e.0 == ref_size).ok_or_else(|| CliError::internal(anyhow!("no ref env")))?.2;
    let setup_seconds = t_setup.elapsed().as_secs_f64();
    let mut guard = OutputGuard::create(&a.output)?;

    // the one reference of the sweep
    let t_ref = Instant::now();
    let bench = PlaneBench::new(&mesh.data, &occ, ref_light, a.resolution as usize, a.distance, up)?;
    let reference_seconds = t_ref.elapsed().as_secs_f64();
    eprintln!(
        "reference: {} receivers, cube size {ref_size}, {reference_seconds:.2} s (setup {setup_seconds:.2} s)",
        bench.recv.points.len()
    );

    let mut rows: Vec<Value> = Vec::new();
    for job in &points {
        let l = job.params.layout;
        let name =
            format!("fiv-{}x{}x{}-r{}-{}-c{}.fivt", l.azimuth, l.polar, l.radial, l.r_min, l.r_max, job.cube_size);
        let path = guard.file(&name);
        let (_, env, lighting) =
            envs.iter().find(|e| e.0 == job.cube_size).ok_or_else(|| CliError::internal(anyhow!("no env")))?;
        let key = cache_key(job)?;
        let out = bake_prepared(
            std::slice::from_ref(job),
            Shard::WHOLE,
            std::slice::from_ref(&path),
            mode,
            std::slice::from_ref(&key),
            &mesh,
            &occ,
            &[env],
            &[lighting],
        )?
        .remove(0);
        // measured as `verify fiv --plane` measures it, against the shared reference
        let m = bench.measure(&path, true)?;
        let (e_all, e_vis, max_abs, n_all, ns) =
            (m.nrmse, m.nrmse_visible, m.max_abs_error, m.receivers, m.ns_per_receiver);
        let (e_beyond, n_beyond) = (m.nrmse_beyond_r_max, m.receivers_beyond_r_max);
        let v = &out.report;
        eprintln!(
            "{}x{}x{} r {}..{} cube {}: {:.2} s, {} bytes, NRMSE {e_all:.4} (visible {e_vis:.4}), {ns:.0} ns/receiver",
            l.azimuth, l.polar, l.radial, l.r_min, l.r_max, job.cube_size, out.seconds, v["bytes"]
        );
        rows.push(json!({
            "samples": format!("{}x{}x{}", l.azimuth, l.polar, l.radial),
            "sample_count": l.azimuth * l.polar * l.radial,
            "r_min": l.r_min,
            "r_max": l.r_max,
            "cube_size": job.cube_size,
            "bake_seconds": out.seconds,
            "bytes": v["bytes"],
            "fiv_bytes": v["fiv_bytes"],
            "rays_traced": v["rays_traced"],
            "ns_per_receiver": ns,
            "nrmse": e_all,
            "nrmse_visible": e_vis,
            "max_abs_error": max_abs,
            "receivers": n_all,
            "receivers_beyond_r_max": n_beyond,
            "nrmse_beyond_r_max": if n_beyond > 0 { json!(e_beyond) } else { Value::Null },
            "asset": name,
        }));
    }
    // Pareto flags: NRMSE against each cost
    for (x, key) in
        [("bake_seconds", "pareto_seconds"), ("ns_per_receiver", "pareto_runtime"), ("bytes", "pareto_bytes")]
    {
        let on = pareto_front(&rows.iter().map(|r| (f(&r[x]), f(&r["nrmse"]))).collect::<Vec<_>>());
        for (r, o) in rows.iter_mut().zip(on) {
            r[key] = json!(o);
        }
    }
    let cols = [
        "samples",
        "sample_count",
        "r_min",
        "r_max",
        "cube_size",
        "bake_seconds",
        "bytes",
        "fiv_bytes",
        "rays_traced",
        "ns_per_receiver",
        "nrmse",
        "nrmse_visible",
        "max_abs_error",
        "receivers",
        "receivers_beyond_r_max",
        "nrmse_beyond_r_max",
        "pareto_seconds",
        "pareto_runtime",
        "pareto_bytes",
        "asset",
    ];
    let csv = csv_text(&cols, &rows);
    // one line per (cube size, r_min, r_max), through the sample counts
    let mut groups: Vec<(usize, f64, f64)> = Vec::new();
    for j in &points {
        let g = (j.cube_size, j.params.layout.r_min, j.params.layout.r_max);
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    let series_of = |x: &str| -> Vec<Series> {
        groups
            .iter()
            .map(|&(c, r0, r1)| {
                let mut name = format!("cube {c}");
                if r_mins.len() > 1 || r_maxs.len() > 1 {
                    name.push_str(&format!(", r {r0}..{r1}"));
                }
                let pts = rows
                    .iter()
                    .filter(|r| r["cube_size"] == c && f(&r["r_min"]) == r0 && f(&r["r_max"]) == r1)
                    .map(|r| (f(&r[x]), f(&r["nrmse"]), r["samples"].as_str().unwrap_or_default().to_string()))
                    .collect();
                Series { name, points: pts }
            })
            .collect()
    };
    let title = format!("{} under {}", mesh.name, envs[0].1.name);
    let panel = |title: String, x: &str, x_label: &str| {
        with_front(Panel {
            title,
            x_label: x_label.into(),
            y_label: "NRMSE vs ray-traced irradiance".into(),
            series: series_of(x),
            front: Vec::new(),
        })
    };
    let panels = [
        panel(format!("{title}: error vs bake time"), "bake_seconds", "bake seconds (labels: AxPxK)"),
        panel("error vs runtime cost".into(), "ns_per_receiver", "runtime ns per receiver (one core)"),
        panel("error vs asset size".into(), "bytes", "bytes"),
    ];
    let max_point = rows.iter().map(|r| f(&r["bake_seconds"])).fold(0.0f64, f64::max);
    let seconds = start.elapsed().as_secs_f64();
    let summary = json!({
        "mesh": a.mesh,
        "env": a.env,
        "env_rotate": rot.name(),
        "receivers": bench.recv.points.len(),
        "receivers_inside": bench.inside.iter().filter(|&&x| x).count(),
        "reference_cube_size": ref_size,
        "reference_seconds": reference_seconds,
        "setup_seconds": setup_seconds,
        "points": rows.len(),
        "max_point_bake_seconds": max_point,
        "cost_over_max_point": seconds / max_point,
        "rows": rows,
        "seconds": seconds,
        "output": a.output.display().to_string(),
    });
    write_outputs(&a.output, &csv, &panels, &summary)?;
    guard.keep();
    if a.json {
        print_json(&summary);
    } else {
        eprintln!(
            "wrote {}/sweep.csv, sweep.json, sweep.svg in {seconds:.1} s ({:.2}× the most expensive point's bake, {max_point:.2} s)",
            a.output.display(),
            seconds / max_point
        );
    }
    Ok(ExitCode::Ok)
}

/// Plane receivers under one occluder with their brute-force reference irradiance and masks,
/// computed once: what `sweep fiv` and `fiv --target-nrmse` measure every candidate asset
/// against, as `verify fiv --plane` measures it (same receivers, runtime, masks and metrics).
pub(crate) struct PlaneBench {
    /// The receivers (`verify fiv --plane`'s square of ±(3 + D)R).
    pub(crate) recv: Receivers,
    /// The reference irradiance per receiver.
    pub(crate) rf: Vec<[f64; 3]>,
    /// Receivers inside the occluder (left out of every metric).
    pub(crate) inside: Vec<bool>,
    /// Receivers covered from straight above (left out of `nrmse_visible`).
    pub(crate) covered: Vec<bool>,
}

/// What [`PlaneBench::measure`] reports of one asset.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PlaneMetrics {
    /// `verify fiv`'s `nrmse` (every receiver outside the occluder).
    pub(crate) nrmse: f64,
    /// `verify fiv`'s `nrmse_visible`.
    pub(crate) nrmse_visible: f64,
    /// `verify fiv`'s `max_abs_error`.
    pub(crate) max_abs_error: f64,
    /// Receivers in `nrmse`.
    pub(crate) receivers: usize,
    /// Runtime nanoseconds per receiver (one core; NaN when not timed).
    pub(crate) ns_per_receiver: f64,
    /// NRMSE over the receivers beyond the outermost shell.
    pub(crate) nrmse_beyond_r_max: f64,
    /// Receivers beyond the outermost shell.
    pub(crate) receivers_beyond_r_max: usize,
}

impl PlaneBench {
    /// `resolution`² plane receivers (optionally `distance`·R lower) under `mesh` and the
    /// reference irradiance under `light` (the environment of the reference).
    pub(crate) fn new(
        mesh: &TriMesh,
        occ: &Occluder,
        light: &Lighting,
        resolution: usize,
        distance: Option<f64>,
        up: UpAxis,
    ) -> Result<Self, CliError> {
        let frame = occ.frame();
        let recv = plane_receivers(
            &ReceiverSpec { resolution: Some(resolution), ..ReceiverSpec::default() },
            distance,
            up,
            &[(mesh, [0.0; 3], frame.center, frame.radius)],
        )?;
        let ball = penumbra_geometry::min_enclosing_ball(&mesh.positions).map(|b| (b.center, b.radius));
        let refs = [Placed { bvh: occ.bvh(), offset: [0.0; 3], ball }];
        let rf = reference_irradiance(light, &refs, &recv);
        let winding = WindingNumber::new(mesh);
        let (inside, covered) = receiver_masks(&recv, |p| winding.is_inside(p), &refs);
        Ok(Self { recv, rf, inside, covered })
    }

    /// Reads the asset at `path` and measures its runtime shadow against the reference
    /// (`timed`: repeated passes for `ns_per_receiver`, else one pass).
    pub(crate) fn measure(&self, path: &std::path::Path, timed: bool) -> Result<PlaneMetrics, CliError> {
        let file = AssetFile::open(path).with_context(|| format!("cannot read back {}", path.display()))?;
        let asset = file.asset();
        let meta = read_meta(&asset).map_err(|e| CliError::internal(anyhow!("{}: {e}", path.display())))?;
        let table = FivTable::from_asset(&asset).map_err(|e| CliError::internal(anyhow!("{}: {e}", path.display())))?;
        let occs = [PlacedOccluder { table: &table, center: meta.frame.center.map(|v| v as f32) }];
        let opts = ShadeOptions { partial: Partial::None, overlap: true };
        let (rt, ns) = if timed {
            timed_runtime(&occs, &self.recv, opts)
        } else {
            let mut rt = Vec::with_capacity(self.recv.points.len());
            runtime_irradiance(&occs, &self.recv, opts, &mut rt);
            (rt, f64::NAN)
        };
        let (inside, covered, rf) = (&self.inside, &self.covered, &self.rf);
        let (e_all, max_abs, n_all) = metrics(&rt, rf, |r| !inside[r]);
        let (e_vis, _, _) = metrics(&rt, rf, |r| !inside[r] && !covered[r]);
        let dist = |p: &[f64; 3]| {
            let c = meta.frame.center;
            ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() / meta.frame.radius
        };
        let beyond: Vec<bool> = self.recv.points.iter().map(|p| dist(p) > meta.params.r_max).collect();
        let (e_beyond, _, n_beyond) = metrics(&rt, rf, |r| !inside[r] && beyond[r]);
        Ok(PlaneMetrics {
            nrmse: e_all,
            nrmse_visible: e_vis,
            max_abs_error: max_abs,
            receivers: n_all,
            ns_per_receiver: ns,
            nrmse_beyond_r_max: e_beyond,
            receivers_beyond_r_max: n_beyond,
        })
    }
}
