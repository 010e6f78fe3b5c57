//! `penumbra verify fiv`: FIV shadows from the runtime against brute-force ray-traced
//! irradiance (FIV §5: NRMSE of the shadow on a ground plane).
//!
//! The reference is self-contained in the assets: every FIVT holds its environment cube
//! (`env_cube`) and its occluder mesh (`ref_vertices`, `ref_triangles`). Receivers:
//! - `--plane`: a ground plane (normal = the assets' up axis) touching the lowest point of
//!   the occluders, `128 × 128` receivers at the cell centres of the square `±3R` around the
//!   projection of the occluders' mean centre (R = the largest bounding radius);
//! - `--placement FILE`: occluder offsets and a plane or surface receiver set (docs/fiv.md).
//!
//! `--distance D` lowers the plane D·R below the occluders' lowest point (receivers from ~D R
//! to ~(3 + D)√2 R away) and `--reference-cube-size` supersamples the environment of the
//! reference.
//!
//! Metrics: `nrmse` = RMSE over receivers and RGB / (max − min of the reference);
//! `nrmse_visible` the same over the receivers no occluder covers when seen from straight
//! above (the paper's shadow figures). Receivers inside an occluder (a sunk plane) are left
//! out of both.

use crate::args::{PartialArg, VerifyFivArgs};
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use anyhow::{Context, anyhow};
use penumbra_asset::{AssetFile, write_file_atomic};
use penumbra_fiv::asset::{FivMeta, read_meta};
use penumbra_fiv::reference::{Placed, irradiance, nrmse};
use penumbra_fiv::{Lighting, UpAxis};
use penumbra_geometry::{CubeMap, MeshBvh, Ray, TriMesh, WindingNumber};
use penumbra_math::rng::ItemRng;
use penumbra_runtime::fiv::{FivShader, FivTable, Partial, PlacedOccluder, ShadeOptions};
use rayon::prelude::*;
use serde::Deserialize;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

/// The placement file.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    /// Occluders (default: one per `--fiv`, where it was baked).
    #[serde(default)]
    pub occluder: Vec<PlacedSpec>,
    /// Receivers (default: the `--plane` receivers).
    #[serde(default)]
    pub receivers: ReceiverSpec,
}

/// One placed occluder.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlacedSpec {
    /// Index into the `--fiv` list (default: the occluder's own index).
    pub fiv: Option<usize>,
    /// Translation of the mesh from where it was baked (world units).
    #[serde(default)]
    pub offset: [f64; 3],
}

/// Receiver set.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReceiverSpec {
    /// `"plane"` (default) or `"surface"` (points on occluder 0, self-shadowed).
    pub kind: Option<String>,
    /// Plane: fraction of the occluders' vertical extent below the plane (FIV Fig. 17: 0.2).
    pub sink: Option<f64>,
    /// Plane: height along the up axis (overrides `sink`).
    pub height: Option<f64>,
    /// Plane: half side of the receiver square (default 3R).
    pub half_size: Option<f64>,
    /// Plane: centre of the square, in (e1, e3) plane coordinates.
    pub center: Option<[f64; 2]>,
    /// Plane: receivers per side (default 128).
    pub resolution: Option<usize>,
    /// Surface: number of receivers (default 4096).
    pub count: Option<usize>,
    /// Surface: sampling seed (default 1).
    pub seed: Option<u64>,
}

/// A receiver set.
pub(crate) struct Receivers {
    /// Runtime positions.
    pub(crate) points: Vec<[f64; 3]>,
    /// Reference ray origins (surface receivers are lifted off the surface).
    pub(crate) origins: Vec<[f64; 3]>,
    /// Unit normals.
    pub(crate) normals: Vec<[f64; 3]>,
    /// Plane grid resolution (for the image), or None for surface receivers.
    pub(crate) grid: Option<usize>,
}

/// The runtime's irradiance at every receiver into `out` (f32, one thread): plane receivers
/// under all occluders, surface receivers self-shadowed by occluder 0 and shadowed by the rest.
pub(crate) fn runtime_irradiance(
    occs: &[PlacedOccluder<'_, '_>],
    recv: &Receivers,
    opts: ShadeOptions,
    out: &mut Vec<[f64; 3]>,
) {
    let mut shader = FivShader::new();
    out.clear();
    for r in 0..recv.points.len() {
        let p = recv.points[r].map(|v| v as f32);
        let n = recv.normals[r].map(|v| v as f32);
        let e = if recv.grid.is_some() {
            shader.irradiance(occs, p, n, opts)
        } else {
            shader.self_shadowed(&occs[0], &occs[1..], p, n, opts)
        };
        out.push(e.map(|v| v as f64));
    }
}

/// [`runtime_irradiance`] timed over repeated passes (at least 50 ms or 100 passes):
/// the irradiance and the nanoseconds per receiver.
pub(crate) fn timed_runtime(
    occs: &[PlacedOccluder<'_, '_>],
    recv: &Receivers,
    opts: ShadeOptions,
) -> (Vec<[f64; 3]>, f64) {
    let mut rt = Vec::with_capacity(recv.points.len());
    let t0 = Instant::now();
    let mut passes = 0u32;
    while passes == 0 || (t0.elapsed().as_secs_f64() < 0.05 && passes < 100) {
        runtime_irradiance(occs, recv, opts, &mut rt);
        passes += 1;
    }
    let ns = t0.elapsed().as_secs_f64() * 1e9 / (passes as f64 * recv.points.len().max(1) as f64);
    (rt, ns)
}

/// The brute-force reference irradiance at every receiver, parallel over receivers.
pub(crate) fn reference_irradiance(lighting: &Lighting, refs: &[Placed<'_>], recv: &Receivers) -> Vec<[f64; 3]> {
    (0..recv.points.len())
        .into_par_iter()
        .map(|r| irradiance(lighting, refs, recv.origins[r], recv.normals[r]))
        .collect()
}

/// Masks of plane receivers: inside an occluder (`inside(p)`; left out of every metric), and
/// covered by an occluder seen straight along the normal (left out of `nrmse_visible`).
/// Surface receivers are neither.
pub(crate) fn receiver_masks(
    recv: &Receivers,
    inside: impl Fn([f64; 3]) -> bool + Sync,
    refs: &[Placed<'_>],
) -> (Vec<bool>, Vec<bool>) {
    (0..recv.points.len())
        .into_par_iter()
        .map(|r| {
            if recv.grid.is_none() {
                return (false, false);
            }
            let p = recv.points[r];
            let up = recv.normals[r];
            let covered = refs.iter().any(|o| {
                let q = [0, 1, 2].map(|k| p[k] - o.offset[k]);
                o.bvh.any_hit(&Ray::new(q, up))
            });
            (inside(p), covered)
        })
        .unzip()
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn bad_asset(path: &Path, e: impl std::fmt::Display) -> CliError {
    CliError::input(anyhow!("{}: {e}", path.display()))
}

/// Reads the reference mesh embedded in a FIVT asset.
fn ref_mesh(file: &AssetFile, path: &Path) -> Result<TriMesh, CliError> {
    let a = file.asset();
    let v = a.section("ref_vertices").ok_or_else(|| bad_asset(path, "no ref_vertices section"))?;
    let t = a.section("ref_triangles").ok_or_else(|| bad_asset(path, "no ref_triangles section"))?;
    let pos = v.to_f64_vec().map_err(|e| bad_asset(path, e))?;
    let idx: Vec<u32> = t.to_vec().map_err(|e| bad_asset(path, e))?;
    if v.dims().len() != 2 || v.dims()[1] != 3 || t.dims().len() != 2 || t.dims()[1] != 3 {
        return Err(bad_asset(path, "ref_vertices/ref_triangles must be [N, 3]"));
    }
    let mesh = TriMesh {
        positions: pos.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        indices: idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    };
    mesh.validate().map_err(|e| bad_asset(path, format!("reference mesh: {e}")))?;
    Ok(mesh)
}

/// Reads the environment cube embedded in a FIVT asset.
fn ref_env(file: &AssetFile, path: &Path, size: usize) -> Result<CubeMap, CliError> {
    let s = file.asset().section("env_cube").ok_or_else(|| bad_asset(path, "no env_cube section"))?;
    if s.dims() != [6, size, size, 3] {
        return Err(bad_asset(path, format!("env_cube has dims {:?}, expected [6, {size}, {size}, 3]", s.dims())));
    }
    let v = s.to_f32_vec().map_err(|e| bad_asset(path, e))?;
    CubeMap::from_texels(size, v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        .ok_or_else(|| bad_asset(path, "env_cube has non-finite texels"))
}

/// The cube map with every texel split into `m × m` equal sub-texels of its radiance (the
/// face-plane grid is uniform, so the sub-texels tile the texel exactly and the radiance
/// integral is unchanged).
fn supersample(cube: &CubeMap, m: usize) -> CubeMap {
    if m == 1 {
        return cube.clone();
    }
    let (s, n) = (cube.size(), cube.size() * m);
    let src = cube.texels();
    let mut out = Vec::with_capacity(6 * n * n);
    for f in 0..6 {
        for j in 0..n {
            for i in 0..n {
                out.push(src[(f * s + j / m) * s + i / m]);
            }
        }
    }
    CubeMap::from_texels(n, out).unwrap_or_else(|| cube.clone())
}

pub(crate) fn plane_receivers(
    spec: &ReceiverSpec,
    distance: Option<f64>,
    up: UpAxis,
    meshes: &[(&TriMesh, [f64; 3], [f64; 3], f64)],
) -> Result<Receivers, CliError> {
    let [e1, e2, e3] = up.basis();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut cu, mut cv, mut rmax) = (0.0, 0.0, 0.0f64);
    for (mesh, offset, center, r) in meshes {
        for p in &mesh.positions {
            let h = dot([p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]], e2);
            lo = lo.min(h);
            hi = hi.max(h);
        }
        cu += dot(*center, e1) / meshes.len() as f64;
        cv += dot(*center, e3) / meshes.len() as f64;
        rmax = rmax.max(*r);
    }
    let sink = spec.sink.unwrap_or(0.0);
    if !(0.0..1.0).contains(&sink) {
        return Err(CliError::input(anyhow!(
            "placement: receivers.sink {sink} is out of range (allowed: 0 <= sink < 1)"
        )));
    }
    let d = distance.unwrap_or(0.0);
    let height = spec.height.unwrap_or(if distance.is_some() { lo - d * rmax } else { lo + sink * (hi - lo) });
    let half = spec.half_size.unwrap_or((3.0 + d) * rmax);
    if !(half > 0.0 && half.is_finite()) {
        return Err(CliError::input(anyhow!("placement: receivers.half_size {half} must be > 0")));
    }
    let [cu, cv] = spec.center.unwrap_or([cu, cv]);
    let n = spec.resolution.unwrap_or(128);
    if !(1..=2048).contains(&n) {
        return Err(CliError::input(anyhow!(
            "placement: receivers.resolution {n} is out of range (allowed: 1..=2048)"
        )));
    }
    let mut points = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let u = cu - half + (i as f64 + 0.5) * 2.0 * half / n as f64;
            let v = cv - half + (j as f64 + 0.5) * 2.0 * half / n as f64;
            points.push([0, 1, 2].map(|k| u * e1[k] + height * e2[k] + v * e3[k]));
        }
    }
    Ok(Receivers { origins: points.clone(), normals: vec![e2; points.len()], points, grid: Some(n) })
}

fn surface_receivers(
    spec: &ReceiverSpec,
    mesh: &TriMesh,
    offset: [f64; 3],
    radius: f64,
) -> Result<Receivers, CliError> {
    let count = spec.count.unwrap_or(4096);
    if !(1..=1_000_000).contains(&count) {
        return Err(CliError::input(anyhow!(
            "placement: receivers.count {count} is out of range (allowed: 1..=1000000)"
        )));
    }
    let mut cdf = Vec::with_capacity(mesh.indices.len());
    let mut acc = 0.0;
    for t in 0..mesh.indices.len() {
        acc += mesh.triangle_area(t);
        cdf.push(acc);
    }
    let mut rng = ItemRng::new(spec.seed.unwrap_or(1), penumbra_math::rng::stage::REFERENCE, 0x5F1F);
    let (mut points, mut origins, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    while points.len() < count {
        let x = rng.next_f64() * acc;
        let t = cdf.partition_point(|&c| c <= x).min(cdf.len() - 1);
        let [a, b, c] = mesh.triangle(t);
        let n = mesh.triangle_cross(t);
        let len = dot(n, n).sqrt();
        if len == 0.0 {
            continue;
        }
        let n = n.map(|v| v / len);
        let (s1, s2) = (rng.next_f64().sqrt(), rng.next_f64());
        let (wa, wb, wc) = (1.0 - s1, s1 * (1.0 - s2), s1 * s2);
        let p = [0, 1, 2].map(|k| wa * a[k] + wb * b[k] + wc * c[k] + offset[k]);
        points.push(p);
        origins.push([0, 1, 2].map(|k| p[k] + 1e-5 * radius * n[k]));
        normals.push(n);
    }
    Ok(Receivers { points, origins, normals, grid: None })
}

fn tone(v: f64) -> u8 {
    (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8
}

/// runtime | reference | |runtime − reference| (grey, full white at ⅛ of the reference's
/// range, with its colour bar), the receiver grid's rows as they come, `caption` below.
fn write_image(
    path: &Path,
    n: usize,
    rt: &[[f64; 3]],
    rf: &[[f64; 3]],
    range: (f64, f64),
    caption: Vec<String>,
) -> Result<(), CliError> {
    use crate::figure::{ColorBar, Figure, Panel, gray};
    let scale = if range.1 > 0.0 { 1.0 / range.1 } else { 1.0 };
    let span = (range.1 - range.0).max(f64::MIN_POSITIVE) / 8.0;
    let fig = Figure {
        panels: vec![
            Panel::from_fn("runtime (FIV lookup)", n, n, |i, j| rt[j * n + i].map(|v| tone(v * scale))),
            Panel::from_fn("reference (ray traced)", n, n, |i, j| rf[j * n + i].map(|v| tone(v * scale))),
            Panel::from_fn("|runtime - reference|", n, n, |i, j| {
                let r = j * n + i;
                core::array::from_fn(|c| gray((rt[r][c] - rf[r][c]).abs() / span)[0])
            }),
        ],
        colorbar: Some(ColorBar {
            label: "|runtime - reference| per channel, irradiance (white: 1/8 of the reference's range)".into(),
            lo: 0.0,
            hi: span,
            map: gray,
        }),
        caption,
    };
    ensure_parent(path)?;
    write_file_atomic(path, &crate::figure::render(&fig))
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// NRMSE and max error of `rt` against `rf` over the receivers `keep` selects.
pub(crate) fn metrics(rt: &[[f64; 3]], rf: &[[f64; 3]], keep: impl Fn(usize) -> bool) -> (f64, f64, usize) {
    let mut a = Vec::new();
    let mut b = Vec::new();
    for r in 0..rt.len() {
        if keep(r) {
            a.extend_from_slice(&rt[r]);
            b.extend_from_slice(&rf[r]);
        }
    }
    let (e, m) = nrmse(&a, &b);
    (e, m, a.len() / 3)
}

/// Runs `penumbra verify fiv`.
pub fn run(a: &VerifyFivArgs) -> Result<ExitCode, CliError> {
    run_report(a).map(|(code, _)| code)
}

/// Runs `penumbra verify fiv` and returns its report too (`penumbra bake` stage gates).
#[allow(clippy::print_stderr)]
pub(crate) fn run_report(a: &VerifyFivArgs) -> Result<(ExitCode, Value), CliError> {
    let start = Instant::now();
    let files: Vec<AssetFile> = a
        .fivs
        .iter()
        .map(|p| AssetFile::open(p).with_context(|| format!("cannot read FIV asset {}", p.display())))
        .collect::<Result<_, _>>()?;
    let metas: Vec<FivMeta> = files
        .iter()
        .zip(&a.fivs)
        .map(|(f, p)| read_meta(&f.asset()).map_err(|e| bad_asset(p, e)))
        .collect::<Result<_, _>>()?;
    let assets: Vec<_> = files.iter().map(|f| f.asset()).collect();
    let tables: Vec<FivTable<'_>> = assets
        .iter()
        .zip(&a.fivs)
        .map(|(asset, p)| FivTable::from_asset(asset).map_err(|e| bad_asset(p, e)))
        .collect::<Result<_, _>>()?;
    for (m, p) in metas.iter().zip(&a.fivs).skip(1) {
        if m.inputs["env"] != metas[0].inputs["env"] || m.params.cube_size != metas[0].params.cube_size {
            return Err(CliError::input(anyhow!(
                "{} and {} were baked under different environments (or cube sizes); shadows of several occluders need one environment",
                a.fivs[0].display(),
                p.display()
            )));
        }
        if m.params.up != metas[0].params.up {
            return Err(CliError::input(anyhow!("{} and {} use different up axes", a.fivs[0].display(), p.display())));
        }
    }
    let placement: Placement = match &a.placement {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("cannot read placement {}", p.display()))?;
            toml::from_str(&text).map_err(|e| CliError::input(anyhow!("{}: {}", p.display(), e.message())))?
        }
        None => Placement::default(),
    };
    if let Some(d) = a.distance {
        if !(d.is_finite() && (0.0..=1000.0).contains(&d)) {
            return Err(CliError::input(anyhow!("--distance {d} is out of range (allowed: 0 <= D <= 1000)")));
        }
        if placement.receivers.kind.as_deref().is_some_and(|k| k != "plane") {
            return Err(CliError::input(anyhow!("--distance needs plane receivers (receivers.kind = \"plane\")")));
        }
    }
    let cube_size = metas[0].params.cube_size;
    let env_cube = ref_env(&files[0], &a.fivs[0], cube_size)?;
    let ref_size = a.reference_cube_size.unwrap_or(cube_size);
    let ref_cube = if let Some(spec) = &a.reference_env {
        if !(1..=512).contains(&ref_size) {
            return Err(CliError::input(anyhow!(
                "--reference-cube-size {ref_size} is out of range (allowed: 1..=512)"
            )));
        }
        let env = &metas[0].inputs["env"];
        let hash = crate::commands::fiv::spec_hash(spec)?;
        if env["blake3"].as_str() != Some(hash.as_str()) {
            return Err(CliError::input(anyhow!(
                "--reference-env {spec}: not the environment {} was baked under ({})",
                a.fivs[0].display(),
                env["name"]
            )));
        }
        if env.get("yaw_turns").is_some() {
            return Err(CliError::input(anyhow!(
                "--reference-env: {} was baked under a turned environment (--yaw-steps); verify it against its stored cube",
                a.fivs[0].display()
            )));
        }
        let rot = env["rotate"].as_str().and_then(penumbra_geometry::env::Rotation::parse).unwrap_or_default();
        crate::commands::fiv::load_env(spec, rot, ref_size)?.data
    } else {
        if ref_size % cube_size != 0 || !(1..=512).contains(&ref_size) {
            return Err(CliError::input(anyhow!(
                "--reference-cube-size {ref_size} must be a multiple of the bake's cube size {cube_size} (allowed: up to 512)"
            )));
        }
        supersample(&env_cube, ref_size / cube_size)
    };
    let lighting = Lighting::new(ref_cube);
    let meshes: Vec<TriMesh> = files.iter().zip(&a.fivs).map(|(f, p)| ref_mesh(f, p)).collect::<Result<_, _>>()?;
    let specs: Vec<PlacedSpec> = if placement.occluder.is_empty() {
        (0..files.len()).map(|i| PlacedSpec { fiv: Some(i), offset: [0.0; 3] }).collect()
    } else {
        placement.occluder.clone()
    };
    let mut placed: Vec<(usize, [f64; 3])> = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        let f = s.fiv.unwrap_or(i);
        if f >= files.len() {
            return Err(CliError::input(anyhow!(
                "placement: occluder {i} uses --fiv {f}, but only {} assets were given",
                files.len()
            )));
        }
        if !s.offset.iter().all(|v| v.is_finite()) {
            return Err(CliError::input(anyhow!("placement: occluder {i} has a non-finite offset")));
        }
        placed.push((f, s.offset));
    }
    let bvhs: Vec<MeshBvh> =
        meshes.iter().map(|m| MeshBvh::build(m).map_err(CliError::internal)).collect::<Result<_, _>>()?;
    let windings: Vec<WindingNumber> = meshes.iter().map(WindingNumber::new).collect();
    let balls: Vec<_> = meshes.iter().map(|m| penumbra_geometry::min_enclosing_ball(&m.positions)).collect();
    let refs: Vec<Placed<'_>> = placed
        .iter()
        .map(|&(f, off)| Placed { bvh: &bvhs[f], offset: off, ball: balls[f].map(|b| (b.center, b.radius)) })
        .collect();
    let centers: Vec<[f64; 3]> =
        placed.iter().map(|&(f, off)| [0, 1, 2].map(|k| metas[f].frame.center[k] + off[k])).collect();

    let kind = placement.receivers.kind.as_deref().unwrap_or("plane");
    let recv = match kind {
        "plane" => {
            let list: Vec<_> = placed
                .iter()
                .zip(&centers)
                .map(|(&(f, off), c)| (&meshes[f], off, *c, metas[f].frame.radius))
                .collect();
            plane_receivers(&placement.receivers, a.distance, metas[0].params.up, &list)?
        }
        "surface" => {
            let (f, off) = placed[0];
            surface_receivers(&placement.receivers, &meshes[f], off, metas[f].frame.radius)?
        }
        other => {
            return Err(CliError::input(anyhow!(
                "placement: receivers.kind {other:?} is unknown (allowed: \"plane\", \"surface\")"
            )));
        }
    };
    if a.image.is_some() && recv.grid.is_none() {
        return Err(CliError::input(anyhow!("--image needs plane receivers (receivers.kind = \"plane\")")));
    }
    let count = recv.points.len();

    // runtime, f32, one thread, timed over repeated passes
    let occs: Vec<PlacedOccluder<'_, '_>> = placed
        .iter()
        .zip(&centers)
        .map(|(&(f, _), c)| PlacedOccluder { table: &tables[f], center: c.map(|v| v as f32) })
        .collect();
    let eval = |opts: ShadeOptions, out: &mut Vec<[f64; 3]>| runtime_irradiance(&occs, &recv, opts, out);
    let partial = match a.partial {
        PartialArg::None => Partial::None,
        PartialArg::Scale => Partial::Scale,
    };
    let opts = ShadeOptions { partial, overlap: !a.no_overlap };
    let (rt, ns_per_receiver) = timed_runtime(&occs, &recv, opts);

    // reference, parallel over receivers
    let t1 = Instant::now();
    let rf = reference_irradiance(&lighting, &refs, &recv);
    let reference_seconds = t1.elapsed().as_secs_f64();

    // masks: inside an occluder (left out), covered from straight above (not "visible")
    let (inside, covered) = receiver_masks(
        &recv,
        |p| placed.iter().any(|&(f, off)| windings[f].is_inside([0, 1, 2].map(|k| p[k] - off[k]))),
        &refs,
    );
    let (e_all, max_abs, n_all) = metrics(&rt, &rf, |r| !inside[r]);
    let (e_vis, _, n_vis) = metrics(&rt, &rf, |r| !inside[r] && !covered[r]);
    // receivers nearer to some occluder's centre than its innermost shell (the lookup clamps
    // ρ there)
    let in_ball: Vec<bool> = recv
        .points
        .iter()
        .map(|p| {
            placed.iter().zip(&centers).any(|(&(f, _), c)| {
                let d = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
                d < metas[f].frame.radius * metas[f].params.r_min
            })
        })
        .collect();
    let (e_vis_out, _, n_vis_out) = metrics(&rt, &rf, |r| !inside[r] && !covered[r] && !in_ball[r]);
    // the inward extrapolation (receivers in the gap get the innermost shell's FIV), measured
    let (e_gap, _, n_gap) = metrics(&rt, &rf, |r| !inside[r] && in_ball[r]);
    // receivers farther from every occluder than its outermost shell (the far-field fall-off)
    let beyond: Vec<bool> = recv
        .points
        .iter()
        .map(|p| {
            placed.iter().zip(&centers).all(|(&(f, _), c)| {
                let d = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
                d > metas[f].frame.radius * metas[f].params.r_max
            })
        })
        .collect();
    let (e_beyond, _, n_beyond) = metrics(&rt, &rf, |r| !inside[r] && beyond[r]);
    let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
    for p in &recv.points {
        for (&(f, _), c) in placed.iter().zip(&centers) {
            let d = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
            dmin = dmin.min(d / metas[f].frame.radius);
            dmax = dmax.max(d / metas[f].frame.radius);
        }
    }
    let mut warnings: Vec<String> = Vec::new();
    if recv.grid.is_none() && !tables[placed[0].0].has_inner_samples() {
        warnings.push(format!(
            "self-shadowing asked of {}, which has no shells inside its bounding ball (r_min = {} >= 1): every surface receiver gets the innermost shell's FIV; bake with --r-min < 1",
            a.fivs[placed[0].0].display(),
            metas[placed[0].0].params.r_min
        ));
    }

    // the other settings, for comparison
    let mut variants = serde_json::Map::new();
    let mut tmp = Vec::with_capacity(count);
    for (pname, p) in [("none", Partial::None), ("scale", Partial::Scale)] {
        for overlap in [true, false] {
            if !overlap && occs.len() < 2 {
                continue;
            }
            eval(ShadeOptions { partial: p, overlap }, &mut tmp);
            let (ea, _, _) = metrics(&tmp, &rf, |r| !inside[r]);
            let (ev, _, _) = metrics(&tmp, &rf, |r| !inside[r] && !covered[r]);
            let key = if occs.len() < 2 {
                pname.to_string()
            } else {
                format!("{pname}{}", if overlap { "" } else { "_no_overlap" })
            };
            variants.insert(key, json!({"nrmse": ea, "nrmse_visible": ev}));
        }
    }

    // the unshadowed baseline: irradiance cube alone (no occluder at all)
    let base: Vec<[f64; 3]> =
        recv.normals.iter().map(|n| tables[0].total_irradiance(n.map(|v| v as f32)).map(|v| v as f64)).collect();
    let (e_base, _, _) = metrics(&base, &rf, |r| !inside[r]);
    let (e_base_vis, _, _) = metrics(&base, &rf, |r| !inside[r] && !covered[r]);

    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for r in (0..count).filter(|&r| !inside[r]) {
        for c in 0..3 {
            lo = lo.min(rf[r][c]);
            hi = hi.max(rf[r][c]);
        }
    }
    if let (Some(img), Some(n)) = (&a.image, recv.grid) {
        let caption = vec![
            format!(
                "NRMSE {e_all:.4} (visible receivers {e_vis:.4}), {n_all} receivers ({n}x{n} grid), {} occluder(s), cube size {cube_size}",
                occs.len()
            ),
            format!("tone: gamma 2.2 of irradiance / the reference's peak {hi:.4}"),
        ];
        write_image(img, n, &rt, &rf, (lo, hi), caption)?;
    }
    let mut v: Value = json!({
        "nrmse": e_all,
        "nrmse_visible": e_vis,
        "max_abs_error": max_abs,
        "receivers": n_all,
        "receivers_visible": n_vis,
        "receivers_inside": inside.iter().filter(|&&x| x).count(),
        "receivers_in_shells_gap": n_vis - n_vis_out,
        "nrmse_visible_outside_gap": e_vis_out,
        "receivers_in_gap": n_gap,
        "nrmse_in_gap": if n_gap > 0 { json!(e_gap) } else { Value::Null },
        "receivers_beyond_r_max": n_beyond,
        "nrmse_beyond_r_max": if n_beyond > 0 { json!(e_beyond) } else { Value::Null },
        "receiver_distance_range": [dmin, dmax],
        "distance": a.distance,
        "reference_cube_size": ref_size,
        "reference_env": a.reference_env,
        "cube_size": cube_size,
        "warnings": warnings,
        "receiver_kind": kind,
        "ns_per_receiver": ns_per_receiver,
        "partial": match partial { Partial::None => "none", Partial::Scale => "scale" },
        "overlap_correction": opts.overlap,
        "occluders": occs.len(),
        "reference_range": [lo, hi],
        "nrmse_unshadowed": e_base,
        "nrmse_visible_unshadowed": e_base_vis,
        "variants": variants,
        "reference_seconds": reference_seconds,
        "seconds": start.elapsed().as_secs_f64(),
        "image": a.image.as_ref().map(|p| p.display().to_string()),
    });
    let failures = crate::commands::gate::apply(
        &mut v,
        &[
            crate::commands::gate::Gate { key: "max_nrmse", metric: "nrmse", max: a.max_nrmse },
            crate::commands::gate::Gate { key: "max_nrmse_visible", metric: "nrmse_visible", max: a.max_nrmse_visible },
        ],
    );
    if a.json {
        print_json(&v);
    } else {
        eprintln!(
            "nrmse {:.4} over {} receivers, nrmse_visible {:.4} over the {} visible from above; max |error| {:.4e}; runtime {:.0} ns/receiver",
            e_all, n_all, e_vis, n_vis, max_abs, ns_per_receiver
        );
        eprintln!(
            "  receivers at {:.2}..{:.2} R from the occluder centres; {} inside an innermost shell (nrmse {:.4}), {} beyond r_max (nrmse {:.4}); reference cube {}",
            dmin, dmax, n_gap, e_gap, n_beyond, e_beyond, ref_size
        );
        for w in &warnings {
            eprintln!("warning: {w}");
        }
    }
    Ok((crate::commands::gate::finish(&failures), v))
}
