//! `penumbra fiv --target-nrmse X` (and a `[[fiv]]` stage's `target = X`): the cheapest
//! shell samples and environment cube size on a fixed ladder whose `verify fiv --plane` NRMSE
//! is at most X ([`crate::commands::target`] holds the walk's rules).
//!
//! The ladder is every pair of [`SAMPLE_RUNGS`] × [`CUBE_RUNGS`], ordered by the bake's
//! visibility cost, sample positions × environment directions (`A·P·K · 6·S²`, ties: the
//! smaller cube first). Each candidate is baked with `penumbra fiv`'s own bake (its bytes are
//! those of a plain `penumbra fiv --samples … --cube-size …`) and measured as `sweep fiv`
//! measures a point ([`PlaneBench`]: `verify fiv --plane`'s 128² receivers, runtime and
//! metric) against one reference computed before the walk: brute-force irradiance under the
//! environment resampled from the source at the ladder's largest cube size, 32. So a
//! candidate at a smaller cube carries the error of its coarser environment too, and
//! `verify fiv --fiv OUT` (whose reference is the asset's own cube) reports the same `nrmse`
//! for a chosen asset at cube size 32.

use crate::commands::fiv::{FivJob, Input, bake_prepared, cache_key, load_env, load_occluder};
use crate::commands::sweep_fiv::PlaneBench;
use crate::commands::target::{Candidates, Search, settings_text};
use crate::exit::CliError;
use crate::progress::ProgressMode;
use anyhow::anyhow;
use penumbra_fiv::{Lighting, Occluder, Shard};
use penumbra_geometry::CubeMap;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

/// Shell samples of the ladder (azimuth × polar × radial), from coarse to the paper's fine.
pub const SAMPLE_RUNGS: [[usize; 3]; 8] =
    [[8, 5, 4], [12, 7, 5], [16, 9, 6], [24, 13, 10], [32, 17, 15], [48, 25, 20], [64, 33, 30], [128, 65, 30]];
/// Environment cube face sizes of the ladder; the largest is the reference's.
pub const CUBE_RUNGS: [usize; 3] = [8, 16, 32];
/// Plane receivers per side (`verify fiv --plane`'s default).
pub const RECEIVERS_PER_SIDE: usize = 128;

/// One rung: samples, cube size and its cost (`A·P·K · 6·S²`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rung {
    /// Shell samples.
    pub samples: [usize; 3],
    /// Environment cube face size.
    pub cube_size: usize,
    /// Sample positions × environment directions.
    pub cost: u64,
}

/// The ladder in walking order, without rungs costing more than `max_cost`.
pub fn ladder(max_cost: Option<u64>) -> Vec<Rung> {
    let mut v: Vec<Rung> = SAMPLE_RUNGS
        .iter()
        .flat_map(|&s| {
            CUBE_RUNGS.iter().map(move |&c| Rung {
                samples: s,
                cube_size: c,
                cost: (s[0] * s[1] * s[2]) as u64 * 6 * (c * c) as u64,
            })
        })
        .filter(|r| max_cost.is_none_or(|m| r.cost <= m))
        .collect();
    v.sort_by_key(|r| (r.cost, r.cube_size));
    v
}

/// What a FIV target search produced.
#[derive(Debug)]
pub struct FivTargetOutcome {
    /// The chosen candidate's bake report with the search's keys (`target`, `chosen`,
    /// `measured`, `search_seconds`, `candidates_tried`, …) and `seconds`.
    pub report: Value,
    /// Whether the written asset meets the target.
    pub met: bool,
}

/// Walks the ladder for `template` (every setting but its samples and cube size) and writes
/// the chosen candidate to `output`: the first meeting `target`, else the best measured.
#[allow(clippy::print_stderr)]
pub fn search(
    template: &FivJob,
    target: f64,
    max_cost: Option<u64>,
    output: &Path,
    mode: ProgressMode,
) -> Result<FivTargetOutcome, CliError> {
    let start = Instant::now();
    let rungs = ladder(max_cost);
    if rungs.is_empty() {
        return Err(CliError::input(anyhow!(
            "--max-cost {}: below the ladder's cheapest rung ({} = 8x5x4 samples × 6·8² directions)",
            max_cost.unwrap_or(0),
            ladder(None)[0].cost
        )));
    }
    let mut search = Search::new(target, "nrmse");
    let mesh: Input<_> = load_occluder(&template.mesh, &template.nodes)?;
    let occ = Occluder::new(mesh.data.clone())
        .map_err(|e| CliError::input(anyhow!("occluder mesh {}: {e}", template.mesh)))?;
    let ref_size = CUBE_RUNGS[CUBE_RUNGS.len() - 1];
    let mut envs: Vec<(usize, Input<CubeMap>, Lighting)> = Vec::new();
    let env_of = |c: usize| -> Result<(usize, Input<CubeMap>, Lighting), CliError> {
        let e = load_env(&template.env, template.env_rotate, c)?;
        let l = Lighting::new(e.data.clone());
        Ok((c, e, l))
    };
    envs.push(env_of(ref_size)?);
    let t_ref = Instant::now();
    let up = template.params.layout.up;
    let bench = PlaneBench::new(&mesh.data, &occ, &envs[0].2, RECEIVERS_PER_SIDE, None, up)?;
    let reference_seconds = t_ref.elapsed().as_secs_f64();
    if mode != ProgressMode::None {
        eprintln!(
            "target nrmse {target}: reference at cube size {ref_size}, {} receivers, {reference_seconds:.2} s",
            bench.recv.points.len()
        );
    }
    let mut files = Candidates::new(output)?;
    let mut bakes: Vec<(Value, f64, f64)> = Vec::new();
    for (i, r) in rungs.iter().enumerate() {
        let t0 = Instant::now();
        let l = template.params.layout;
        let mut job = FivJob::new(
            &template.mesh,
            &template.env,
            template.env_rotate,
            r.samples,
            l.r_min,
            l.r_max,
            up,
            r.cube_size,
            template.params.irradiance_size,
            template.storage == penumbra_fiv::Storage::F16,
        )?;
        job.nodes = template.nodes.clone();
        if envs.iter().all(|e| e.0 != r.cube_size) {
            envs.push(env_of(r.cube_size)?);
        }
        let (_, env, lighting) =
            envs.iter().find(|e| e.0 == r.cube_size).ok_or_else(|| CliError::internal(anyhow!("no env")))?;
        let path = files.path(i);
        let key = cache_key(&job)?;
        let out = bake_prepared(
            std::slice::from_ref(&job),
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
        let m = bench.measure(&path, false)?;
        let settings = json!({
            "samples": format!("{}x{}x{}", r.samples[0], r.samples[1], r.samples[2]),
            "cube_size": r.cube_size,
        });
        let seconds = t0.elapsed().as_secs_f64();
        let met = search.record(settings.clone(), m.nrmse, seconds);
        bakes.push((out.report, out.seconds, m.nrmse_visible));
        if mode != ProgressMode::None {
            eprintln!(
                "[{}/{}] {} (cost {:.3e}): nrmse {:.5}{} ({:.2} s)",
                i + 1,
                rungs.len(),
                settings_text(&settings),
                r.cost as f64,
                m.nrmse,
                if met { " meets the target" } else { "" },
                seconds
            );
        }
        // only the best so far can still be written
        if let Some((b, _)) = search.chosen() {
            for j in (0..=i).filter(|&j| j != b) {
                files.discard(j);
            }
        }
        if met {
            break;
        }
    }
    let (ci, met) = search.chosen().ok_or_else(|| CliError::internal(anyhow!("no candidate")))?;
    files.finish(ci)?;
    let (mut report, bake_seconds, nrmse_visible) = bakes.swap_remove(ci);
    report["output"] = json!(output.display().to_string());
    report["bake_seconds"] = json!(bake_seconds);
    report["nrmse_visible"] = json!(nrmse_visible);
    report["reference_cube_size"] = json!(ref_size);
    report["reference_seconds"] = json!(reference_seconds);
    report["receivers"] = json!(bench.recv.points.len());
    report["max_cost"] = json!(max_cost);
    if let (Some(o), Some(s)) =
        (report.as_object_mut(), search.report("ladder: samples x cube size by A·P·K·6·S²").as_object())
    {
        o.extend(s.clone());
    }
    report["seconds"] = json!(start.elapsed().as_secs_f64());
    Ok(FivTargetOutcome { report, met })
}
