//! `penumbra verify drt`: MRT and MRT + DRT on a level with clutter against a path tracer
//! that sees the clutter (MRT thesis ch. 5).

use crate::commands::drt::{DrtBakeArgs, DrtScene, DrtSceneArgs, bake_scene, load_scene};
use crate::commands::mrt_level::bake as bake_level;
use crate::commands::print_json;
use crate::commands::verify_mrt::{default_lights, load_point_lights, median_ms};
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use crate::progress::{ProgressMode, Reporter};
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::{AssetFile, OwnedAsset};
use penumbra_math::progress::Progress;
use penumbra_runtime::drt::{DrtOperators, DrtRuntime, Paths};
use penumbra_runtime::drt_vec::DrtVector;
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_transport::drt::Scene;
use penumbra_transport::drt_reference::{Albedo, Receiver, direct, reference};
use penumbra_transport::gather::sh9;
use penumbra_transport::level::rotate_y;
use penumbra_transport::level_reference::{LevelGeometry, LevelTexels, PointLight, level_texels};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// `penumbra verify drt`.
#[derive(Debug, Args)]
pub struct VerifyDrtArgs {
    /// The scene (the same arguments the asset was baked with).
    #[command(flatten)]
    pub scene: DrtSceneArgs,
    /// A baked DRTO asset (checked against the scene); without it the operators are baked here.
    #[arg(long, value_name = "ASSET")]
    pub drt: Option<PathBuf>,
    /// Bake options (when no --drt is given).
    #[command(flatten)]
    pub bake: DrtBakeArgs,
    /// Point lights (TOML `[[light]] position = [x, y, z]`, `intensity`). Default: the
    /// example's, else one light at the centre of block 0 and of every 8th block after it.
    #[arg(long)]
    pub lights: Option<PathBuf>,
    /// Wall albedo of the comparison (the runtime scales the dictionary's baked albedo).
    #[arg(long, default_value_t = 0.5, value_parser = parse_albedo)]
    pub albedo: f64,
    /// Clutter albedo channel compared (0 = r, 1 = g, 2 = b).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=2))]
    pub channel: u32,
    /// Reference rays per receiver.
    #[arg(long = "reference-rays", default_value_t = 512, value_parser = clap::value_parser!(u32).range(4..=1_048_576))]
    pub reference_rays: u32,
    /// Bounces of the multi-bounce comparison.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub bounces: u32,
    /// Depth limit of the level operators (when the level is not a baked asset).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub max_depth: u32,
    /// Seed of the reference.
    #[arg(long = "ref-seed", default_value_t = 0)]
    pub ref_seed: u64,
    /// Top view of the floors' one-bounce indirect light: MRT | MRT + DRT | reference |
    /// difference (PNG; panels at least 512 px, titled, a colour bar and a caption).
    #[arg(long, value_name = "OUT.png")]
    pub image: Option<PathBuf>,
    /// Exit with code 1 when rel_error_mrt_drt exceeds this.
    #[arg(long, value_name = "X", value_parser = crate::commands::gate::parse_max)]
    pub max_rel_error: Option<f64>,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_albedo(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 1.0 { Ok(v) } else { Err(format!("{v} is out of range (allowed: 0 < A < 1)")) }
}

/// `‖a − b‖ / ‖b‖` over the entries `keep` selects.
pub(crate) fn rel(a: &[f64], b: &[f64], keep: &[bool]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, y), &k) in a.iter().zip(b).zip(keep) {
        if k {
            num += (x - y) * (x - y);
            den += y * y;
        }
    }
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

fn norm_ratio(a: &[f64], b: &[f64], keep: &[bool]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, y), &k) in a.iter().zip(b).zip(keep) {
        if k {
            num += x * x;
            den += y * y;
        }
    }
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

fn lights(a: &VerifyDrtArgs, sc: &DrtScene, geo: &LevelGeometry<'_>) -> Result<Vec<PointLight>, CliError> {
    scene_lights(a.lights.as_deref(), sc, geo)
}

/// The lights of a comparison: the file's, else the example's, else the level's defaults.
pub(crate) fn scene_lights(
    file: Option<&std::path::Path>,
    sc: &DrtScene,
    geo: &LevelGeometry<'_>,
) -> Result<Vec<PointLight>, CliError> {
    match (file, &sc.example_lights) {
        (Some(p), _) => load_point_lights(p, geo),
        (None, Some(l)) => Ok(l.clone()),
        (None, None) => Ok(default_lights(&sc.level)),
    }
}

/// The receivers of a DRT comparison: every scene texel, then every clutter texel (its block
/// found a hair off the surface); `clutter_ok[i]`: clutter texel `i` lies in a block.
pub(crate) fn receivers(tex: &LevelTexels, sc: &DrtScene, geo: &LevelGeometry<'_>) -> (Vec<Receiver>, Vec<bool>) {
    let mut recv: Vec<Receiver> =
        tex.texels.iter().map(|&(b, _, p, nn)| Receiver { block: b, point: p, normal: nn, horizon: None }).collect();
    let mut clutter_ok = Vec::new();
    for t in &sc.clutter.texels {
        let o: [f64; 3] = core::array::from_fn(|k| t.position[k] + 1e-7 * t.normal[k]);
        let b = geo.block_of(o);
        clutter_ok.push(b.is_some());
        recv.push(Receiver { block: b.unwrap_or(0), point: t.position, normal: t.normal, horizon: None });
    }
    (recv, clutter_ok)
}

/// Direct light at the `n` scene texels and at the clutter texels after them (0 for a clutter
/// texel outside every block).
pub(crate) fn direct_light(
    scene: &Scene<'_>,
    recv: &[Receiver],
    n: usize,
    clutter_ok: &[bool],
    lights: &[PointLight],
) -> (Vec<f32>, Vec<f32>) {
    let at = |r: &Receiver| direct(scene, r.block, r.point, r.normal, lights) as f32;
    let l_d = recv[..n].iter().map(at).collect();
    let l_dc =
        recv[n..n + clutter_ok.len()].iter().zip(clutter_ok).map(|(r, &ok)| if ok { at(r) } else { 0.0 }).collect();
    (l_d, l_dc)
}

/// The scene texels a comparison keeps: those not inside clutter (the operators' inpainting
/// mask), in level texel order.
pub(crate) fn visible_texels(ops: &DrtOperators<'_>, tex: &LevelTexels) -> Vec<bool> {
    let mut keep = vec![true; tex.texels.len()];
    for rc in ops.receivers.chunks_exact(3) {
        let (b, off, cnt) = (rc[0] as usize, rc[1] as usize, rc[2] as usize);
        for t in 0..cnt {
            if ops.inpaint_mask[off + t] != 0 {
                keep[tex.offsets[b] + t] = false;
            }
        }
    }
    keep
}

/// MRT's volume-probe irradiance (U_bvol, §3.5.5) at clutter texels, from each block's `b`.
fn probe_irradiance(
    dict_asset: &penumbra_asset::Asset<'_>,
    sc: &DrtScene,
    b: &[f32],
    kb_stride: usize,
    recv: &[Receiver],
) -> Result<Vec<f64>, CliError> {
    const AHAT: [f64; 9] = [
        core::f64::consts::PI,
        2.0 * core::f64::consts::PI / 3.0,
        2.0 * core::f64::consts::PI / 3.0,
        2.0 * core::f64::consts::PI / 3.0,
        core::f64::consts::FRAC_PI_4,
        core::f64::consts::FRAC_PI_4,
        core::f64::consts::FRAC_PI_4,
        core::f64::consts::FRAC_PI_4,
        core::f64::consts::FRAC_PI_4,
    ];
    let mut out = Vec::with_capacity(recv.len());
    for r in recv {
        let blk = &sc.level.blocks[r.block];
        let name = &sc.ops.names[blk.shape];
        let sec = dict_asset
            .section(&format!("{name}.u_bvol"))
            .ok_or_else(|| CliError::input(anyhow!("the dictionary has no {name}.u_bvol")))?;
        let d = sec.dims().to_vec();
        let vol = sec.as_f32().map_err(CliError::internal)?;
        let (gp, kb) = (d[0], d[1]);
        let g = (gp as f64).cbrt().round() as usize;
        let q = blk.to_local(r.point);
        // normal into the block frame: (R S)ᵀ n
        let nl = rotate_y(r.normal, (4 - blk.rotation % 4) % 4);
        let nl = [nl[0] * blk.scale[0], nl[1] * blk.scale[1], nl[2] * blk.scale[2]];
        let ln = (nl[0] * nl[0] + nl[1] * nl[1] + nl[2] * nl[2]).sqrt().max(f64::MIN_POSITIVE);
        let y = sh9(nl.map(|x| x / ln));
        let bs = &b[r.block * kb_stride..r.block * kb_stride + kb];
        let mut e = 0.0;
        let axis = |x: f64| {
            let s = (x * g as f64 - 0.5).clamp(0.0, (g - 1) as f64);
            let i0 = (s as usize).min(g.saturating_sub(2));
            let i1 = (i0 + 1).min(g - 1);
            (i0, i1, s - i0 as f64)
        };
        let (x0, x1, fx) = axis(q[0]);
        let (y0, y1, fy) = axis(q[1]);
        let (z0, z1, fz) = axis(q[2]);
        for (zi, wz) in [(z0, 1.0 - fz), (z1, fz)] {
            for (yi, wy) in [(y0, 1.0 - fy), (y1, fy)] {
                for (xi, wx) in [(x0, 1.0 - fx), (x1, fx)] {
                    let w = wx * wy * wz;
                    if w == 0.0 {
                        continue;
                    }
                    let p = (zi * g + yi) * g + xi;
                    for (m, &bm) in bs.iter().enumerate() {
                        let c = &vol[(p * kb + m) * 9..(p * kb + m) * 9 + 9];
                        let s: f64 = (0..9).map(|j| AHAT[j] * f64::from(c[j]) * y[j]).sum();
                        e += w * s * f64::from(bm);
                    }
                }
            }
        }
        out.push(e);
    }
    Ok(out)
}

/// Runs `penumbra verify drt`.
pub fn run(a: &VerifyDrtArgs, mode: ProgressMode) -> Result<ExitCode, CliError> {
    run_report(a, mode).map(|(code, _)| code)
}

/// Runs `penumbra verify drt` and returns its report too (`penumbra bake` stage gates).
#[allow(clippy::print_stderr)]
pub(crate) fn run_report(a: &VerifyDrtArgs, mode: ProgressMode) -> Result<(ExitCode, Value), CliError> {
    let start = Instant::now();
    let sc = load_scene(&a.scene)?;
    // the operators: a baked asset (checked against the scene) or baked here
    let (drt_bytes, params) = match &a.drt {
        Some(p) => {
            let bytes = std::fs::read(p).with_context(|| format!("cannot read {}", p.display()))?;
            let asset = OwnedAsset::parse(&bytes).map_err(|e| CliError::input(anyhow!("{}: {e}", p.display())))?;
            let at = asset.asset();
            if at.kind().as_str() != "DRTO" {
                return Err(CliError::input(anyhow!(
                    "{}: a {} asset, not DRT operators (DRTO)",
                    p.display(),
                    at.kind().as_str()
                )));
            }
            let meta: Value = serde_json::from_str(at.meta_json()).map_err(CliError::internal)?;
            let inputs = sc.inputs();
            let same = meta["inputs"]["dictionary_crc32c"].as_str()
                == Some(format!("{:08x}", inputs.dict_crc32c).as_str())
                && meta["inputs"]["level"] == inputs.level
                && meta["inputs"]["clutter_blake3"] == json!(inputs.clutter_hashes);
            if !same {
                return Err(CliError::input(anyhow!(
                    "{} was baked for another dictionary, level or clutter than the one given (compare its meta.inputs)",
                    p.display()
                )));
            }
            let params = penumbra_transport::drt_asset::params_of(&meta["params"]);
            (bytes, params)
        }
        None => {
            let params = a.bake.params(a.scene.clutter_res, a.scene.clutter_basis_res);
            (bake_scene(&sc, &params, mode)?.1, params)
        }
    };
    let level_bytes = match &sc.level_asset {
        Some((b, _)) => b.clone(),
        None => bake_level(&sc.level, &sc.links, &sc.ops, a.max_depth as usize, None)?.1,
    };
    let dict_file = AssetFile::open(a.scene.dict_path())
        .with_context(|| format!("cannot open {}", a.scene.dict_path().display()))?;
    let dict_asset = dict_file.asset();
    let rd = MrtDictionary::from_asset(&dict_asset)
        .map_err(|e| CliError::input(anyhow!("{}: {e}", a.scene.dict_path().display())))?;
    let level_asset = OwnedAsset::parse(&level_bytes).map_err(CliError::internal)?;
    let la = level_asset.asset();
    let rl = MrtLevel::from_asset(&la, &rd).map_err(|e| CliError::input(anyhow!("level: {e}")))?;
    let drt_asset = OwnedAsset::parse(&drt_bytes).map_err(CliError::internal)?;
    let da = drt_asset.asset();
    let ops = DrtOperators::from_asset(&da, &rd, &rl).map_err(|e| CliError::input(anyhow!("DRT operators: {e}")))?;
    let mut mrt = MrtRuntime::new(rd, rl);
    let mut drt = DrtRuntime::new(ops, &mrt);

    let geo = LevelGeometry { level: &sc.level, links: &sc.links, missing: &sc.ops.missing };
    let scene = Scene::new(geo.clone(), &sc.clutter, &sc.dict);
    let lights = lights(a, &sc, &geo)?;
    let tex = level_texels(&sc.level, &sc.ops.missing, sc.ops.face_res);
    let n = tex.texels.len();
    if n != mrt.texel_count() {
        return Err(CliError::internal(anyhow!("texel count {n} vs runtime {}", mrt.texel_count())));
    }
    // receivers: every scene texel, then every clutter texel (its block probed off the surface)
    let (mut recv, clutter_ok) = receivers(&tex, &sc, &geo);
    let m = sc.clutter.texels.len();
    let (l_d, l_dc) = direct_light(&scene, &recv, n, &clutter_ok, &lights);
    let scale = (a.albedo / sc.ops.albedo) as f32;
    let ch = a.channel as usize;
    // runtime: MRT alone, MRT + DRT (with and without inpainting), occlusion only, multi-bounce
    let mut mrt_one = vec![0.0f32; n];
    mrt.indirect(&l_d, &mut mrt_one, true);
    let mrt_one: Vec<f64> = mrt_one.iter().map(|&x| f64::from(x) * f64::from(scale)).collect();
    let b_one: Vec<f32> = mrt.coefficients().to_vec();
    let kb = mrt.level().k_b;
    let mut mrt_multi = vec![0.0f32; n];
    mrt.multi_bounce(&l_d, &mut mrt_multi, a.bounces as usize, scale);
    let (mut s_drt, mut c_drt) = (vec![0.0f32; n], vec![0.0f32; m]);
    drt.one_bounce(&mut mrt, &l_d, &l_dc, ch, scale, Paths::ALL, &mut s_drt, &mut c_drt);
    let (mut s_occ, mut c_occ) = (vec![0.0f32; n], vec![0.0f32; m]);
    drt.one_bounce(
        &mut mrt,
        &l_d,
        &l_dc,
        ch,
        scale,
        Paths { occlusion: true, reflection: false },
        &mut s_occ,
        &mut c_occ,
    );
    let (mut s_multi, mut c_multi) = (vec![0.0f32; n], vec![0.0f32; m]);
    drt.multi_bounce(&mut mrt, &l_d, &l_dc, ch, scale, a.bounces as usize, &mut s_multi, &mut c_multi);
    let ms_runtime =
        median_ms(21, || drt.one_bounce(&mut mrt, &l_d, &l_dc, ch, scale, Paths::ALL, &mut s_drt, &mut c_drt));
    let mut scratch = vec![0.0f32; n];
    let ms_mrt = median_ms(21, || mrt.indirect(&l_d, &mut scratch, true));
    let to64 = |v: &[f32]| -> Vec<f64> { v.iter().map(|&x| f64::from(x)).collect() };
    let (s_drt, c_drt, s_occ, s_multi) = (to64(&s_drt), to64(&c_drt), to64(&s_occ), to64(&s_multi));
    let mrt_multi: Vec<f64> = mrt_multi.iter().map(|&x| f64::from(x)).collect();
    let probes = probe_irradiance(&dict_asset, &sc, &b_one, kb, &recv[n..])?
        .into_iter()
        .map(|e| e * f64::from(scale))
        .collect::<Vec<_>>();

    // inpainting shows where a bilinear read of the light map mixes inside and outside texels
    // (Fig. 5.3): texel corners next to inside texels, themselves outside clutter, read with
    // and without inpainting (the latter from a bake with --no-inpaint)
    let boundary = boundary_points(&scene, &sc, &tex, drt.operators());
    let (mut b_with, mut b_without) = (Vec::new(), Vec::new());
    if !boundary.is_empty() {
        let mut p2 = params.clone();
        p2.inpaint = false;
        // the scalar operators are all this comparison reads
        (p2.vector_rays, p2.volume_res) = (None, None);
        let bytes2 = bake_scene(&sc, &p2, ProgressMode::None)?.1;
        let asset2 = OwnedAsset::parse(&bytes2).map_err(CliError::internal)?;
        let rd2 = MrtDictionary::from_asset(&dict_asset).map_err(|e| CliError::input(anyhow!("{e}")))?;
        let rl2 = MrtLevel::from_asset(&la, &rd2).map_err(|e| CliError::input(anyhow!("level: {e}")))?;
        let ops2 = DrtOperators::from_asset(&asset2.asset(), &rd2, &rl2)
            .map_err(|e| CliError::input(anyhow!("DRT operators: {e}")))?;
        let mut mrt2 = MrtRuntime::new(rd2, rl2);
        let mut drt2 = DrtRuntime::new(ops2, &mrt2);
        let (mut s2, mut c2) = (vec![0.0f32; n], vec![0.0f32; m]);
        drt2.one_bounce(&mut mrt2, &l_d, &l_dc, ch, scale, Paths::ALL, &mut s2, &mut c2);
        for (_, w) in &boundary {
            b_with.push(w.iter().map(|&(t, x)| x * s_drt[t]).sum::<f64>());
            b_without.push(w.iter().map(|&(t, x)| x * f64::from(s2[t])).sum::<f64>());
        }
    }
    recv.extend(boundary.iter().map(|(r, _)| *r));

    // scene texels inside clutter are not seen: left out (and counted)
    let keep = visible_texels(drt.operators(), &tex);
    let ops = drt.operators();
    // §5.4.3: the vector and volume response, when the asset carries it (`drt --vector`)
    let mut dv = DrtVector::from_asset(&da, &mrt, ops.instances, ops.receivers, ops.chart_count() as u32)
        .map_err(|e| CliError::input(anyhow!("DRT vector operators: {e}")))?;
    let mrt_probe = |r: &[Receiver]| -> Result<Vec<f64>, CliError> {
        Ok(probe_irradiance(&dict_asset, &sc, &b_one, kb, r)?.into_iter().map(|e| e * f64::from(scale)).collect())
    };
    let vchecks = match dv.as_mut() {
        Some(dv) => Some(crate::commands::verify_drt_vector::build(
            dv,
            drt.operators(),
            &mrt,
            drt.coefficients(),
            scale,
            &geo,
            &tex,
            &keep,
            &sc.clutter,
            &mrt_probe,
        )?),
        None => None,
    };
    let v_off = recv.len();
    if let Some(vc) = &vchecks {
        recv.extend(vc.receivers.iter().copied());
    }

    // the reference
    let rep = Reporter::new("verify drt", mode);
    let done = AtomicU64::new(0);
    let total = recv.len() as u64;
    let t_ref = Instant::now();
    let alb = Albedo { walls: a.albedo, channel: ch };
    let r = reference(&scene, &recv, &lights, alb, a.reference_rays as usize, a.bounces as usize, a.ref_seed, &|k| {
        let v = done.fetch_add(k, Ordering::Relaxed) + k;
        rep.update("reference", v.min(total), total);
    });
    rep.finish();
    let reference_seconds = t_ref.elapsed().as_secs_f64();

    let inside = keep.iter().filter(|&&k| !k).count();
    let vector = vchecks.as_ref().map(|vc| {
        vc.report(&r.one_bounce[v_off..], &r.one_half_difference[v_off..], &|x, y| rel(x, y, &vec![true; x.len()]))
    });
    let (r1, rm) = (&r.one_bounce[..n], &r.multi_bounce[..n]);
    let (rc1, rcm) = (&r.one_bounce[n..n + m], &r.multi_bounce[n..n + m]);
    let rb1 = &r.one_bounce[n + m..n + m + boundary.len()];
    let all_b = vec![true; boundary.len()];
    let per_block: Vec<Value> = (0..sc.level.blocks.len())
        .map(|b| {
            let rg = tex.offsets[b]..tex.offsets[b + 1];
            let k = &keep[rg.clone()];
            json!({
                "block": b,
                "shape": sc.ops.names[sc.level.blocks[b].shape],
                "rel_error_mrt": rel(&mrt_one[rg.clone()], &r1[rg.clone()], k),
                "rel_error_mrt_drt": rel(&s_drt[rg.clone()], &r1[rg.clone()], k),
                "reference_noise": norm_ratio(&r.one_half_difference[rg.clone()], &r1[rg], k),
            })
        })
        .collect();
    let cm = &clutter_ok;
    let mut v = json!({
        "scene": sc.what,
        "blocks": sc.level.blocks.len(),
        "texels": n,
        "texels_inside_clutter": inside,
        "clutter_instances": sc.clutter.len(),
        "clutter_texels": m,
        "lights": lights.len(),
        "albedo": a.albedo,
        "channel": ch,
        "bounces": a.bounces,
        "reference_rays": a.reference_rays,
        "drt_params": params.to_json(),
        "rel_error_mrt": rel(&mrt_one, r1, &keep),
        "rel_error_mrt_drt": rel(&s_drt, r1, &keep),
        "rel_error_mrt_drt_occlusion_only": rel(&s_occ, r1, &keep),
        "rel_error_mrt_multi_bounce": rel(&mrt_multi, rm, &keep),
        "rel_error_mrt_drt_multi_bounce": rel(&s_multi, rm, &keep),
        "rel_error_clutter_cb": rel(&c_drt, rc1, cm),
        "rel_error_clutter_probes": rel(&probes, rc1, cm),
        "rel_error_clutter_cb_multi_bounce": rel(&to64(&c_multi), rcm, cm),
        "reference_noise": norm_ratio(&r.one_half_difference[..n], r1, &keep),
        "reference_noise_multi_bounce": norm_ratio(&r.multi_half_difference[..n], rm, &keep),
        "reference_noise_clutter": norm_ratio(&r.one_half_difference[n..n + m], rc1, cm),
        "boundary_points": boundary.len(),
        "rel_error_boundary_inpainted": if boundary.is_empty() { Value::Null } else { json!(rel(&b_with, rb1, &all_b)) },
        "rel_error_boundary_without_inpainting": if boundary.is_empty() { Value::Null } else { json!(rel(&b_without, rb1, &all_b)) },
        "vector": vector,
        "ms_runtime": ms_runtime,
        "ms_runtime_mrt": ms_mrt,
        "per_block": per_block,
        "reference_seconds": reference_seconds,
        "seconds": start.elapsed().as_secs_f64(),
    });
    let failures = crate::commands::gate::apply(
        &mut v,
        &[crate::commands::gate::Gate { key: "max_rel_error", metric: "rel_error_mrt_drt", max: a.max_rel_error }],
    );
    if let Some(p) = &a.image {
        let caption = vec![format!(
            "relative error: MRT alone {:.4}, MRT + DRT {:.4}; blocks: {}, reference rays per texel: {}",
            v["rel_error_mrt"].as_f64().unwrap_or(f64::NAN),
            v["rel_error_mrt_drt"].as_f64().unwrap_or(f64::NAN),
            v["blocks"],
            a.reference_rays
        )];
        let fig = crate::commands::floor_view::floor_figure(
            &tex,
            &[("MRT alone", &mrt_one), ("MRT + DRT", &s_drt), ("reference (path traced)", r1)],
            Some(&keep),
            (1, 2),
            0.2,
            caption,
        );
        let png = crate::figure::render(&fig);
        ensure_parent(p)?;
        penumbra_asset::write_file_atomic(p, &png).with_context(|| format!("cannot write {}", p.display()))?;
    }
    let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    if a.json {
        print_json(&v);
    } else {
        eprintln!(
            "{}: {} blocks, {n} texels ({inside} inside clutter), {} clutter instances ({m} texels), {} lights\n  one bounce: MRT {:.4}, MRT + DRT {:.4} (occlusion only {:.4}; reference noise {:.4})\n  {} bounces: MRT {:.4}, MRT + DRT {:.4}\n  clutter: C_b {:.4}, MRT probes {:.4}\n  runtime {:.3} ms MRT + DRT ({:.3} ms MRT alone, one thread)",
            sc.what,
            sc.level.blocks.len(),
            sc.clutter.len(),
            lights.len(),
            f("rel_error_mrt"),
            f("rel_error_mrt_drt"),
            f("rel_error_mrt_drt_occlusion_only"),
            f("reference_noise"),
            a.bounces,
            f("rel_error_mrt_multi_bounce"),
            f("rel_error_mrt_drt_multi_bounce"),
            f("rel_error_clutter_cb"),
            f("rel_error_clutter_probes"),
            ms_runtime,
            ms_mrt
        );
        if let Some(x) = v.get("vector").filter(|x| !x.is_null()) {
            let g = |k: &str| x[k].as_f64().unwrap_or(f64::NAN);
            eprintln!(
                "  vector (normals tilted {}°): walls MRT {:.4}, MRT + DRT {:.4}; clutter MRT probes {:.4}, C_b⃗ {:.4}; volume MRT probes {:.4}, U_dyn {:.4}",
                g("tilt_deg"),
                g("rel_error_vector_mrt"),
                g("rel_error_vector_mrt_drt"),
                g("rel_error_clutter_vector_probes"),
                g("rel_error_clutter_vector_cb"),
                g("rel_error_volume_mrt_probes"),
                g("rel_error_volume_dyn")
            );
        }
    }
    Ok((crate::commands::gate::finish(&failures), v))
}

/// Texel corners of receiving blocks where a bilinear read mixes texels inside clutter with
/// texels outside (at least one of each among the four), that are themselves outside
/// clutter (at most half of 64 cosine rays meet clutter from behind, the bake's test): the
/// receiver and the four `(global texel, ¼)` weights of the read.
fn boundary_points(
    scene: &Scene<'_>,
    sc: &DrtScene,
    tex: &penumbra_transport::level_reference::LevelTexels,
    ops: &DrtOperators<'_>,
) -> Vec<(Receiver, [(usize, f64); 4])> {
    use penumbra_transport::drt::RayHit;
    use penumbra_transport::shape::face_point;
    let dirs = penumbra_transport::gather::DirectionSet::cosine(64);
    let mut out = Vec::new();
    for rc in ops.receivers.chunks_exact(3) {
        let (b, off, cnt) = (rc[0] as usize, rc[1] as usize, rc[2] as usize);
        let mask = &ops.inpaint_mask[off..off + cnt];
        if mask.iter().all(|&v| v == 0) {
            continue;
        }
        let blk = &sc.level.blocks[b];
        let t = &sc.dict.shapes[blk.shape].texels;
        let r = t.res;
        for f in penumbra_transport::drt::present_faces(sc.ops.missing[blk.shape]) {
            for j in 1..r {
                for i in 1..r {
                    let q = [t.index(f, i - 1, j - 1), t.index(f, i, j - 1), t.index(f, i - 1, j), t.index(f, i, j)];
                    let ins = q.iter().filter(|&&x| mask[x] != 0).count();
                    if ins == 0 || ins == 4 {
                        continue;
                    }
                    let p = blk.to_world(face_point(f, i as f64 / r as f64, j as f64 / r as f64));
                    let nn = blk.normal(f);
                    let o = [p[0] + 1e-7 * nn[0], p[1] + 1e-7 * nn[1], p[2] + 1e-7 * nn[2]];
                    let (tu, tv) = penumbra_math::warp::orthonormal_basis(nn);
                    let back = dirs
                        .dirs
                        .iter()
                        .filter(|l| {
                            let d: [f64; 3] = core::array::from_fn(|k| l[0] * tu[k] + l[1] * tv[k] + l[2] * nn[k]);
                            matches!(scene.cast(b, o, d), RayHit::Clutter(_, h) if !h.front)
                        })
                        .count();
                    if 2 * back > dirs.len() {
                        continue;
                    }
                    out.push((
                        Receiver { block: b, point: p, normal: nn, horizon: None },
                        q.map(|x| (tex.offsets[b] + x, 0.25)),
                    ));
                }
            }
        }
    }
    out
}
