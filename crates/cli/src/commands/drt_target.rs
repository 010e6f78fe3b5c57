//! `penumbra drt --target-error X` (and the `[drt]` stage's `target = X`): the fewest rays
//! per texel on a fixed ladder whose `verify drt` one-bounce error `rel_error_mrt_drt` is at
//! most X ([`crate::commands::target`] holds the walk's rules).
//!
//! The ladder is [`RAYS_RUNGS`], rays per scene texel with the clutter rays equal to them:
//! the trace is nearly all of a DRT bake's cost and grows linearly with them. The rank `k_c`
//! is not on it: it shapes the clutter gather `C_b` only, which `rel_error_mrt_drt` does not
//! see (measured: the same value to the last bit for k_c 1..8 on the pillars), so a search on
//! that metric would always settle on k_c = 1 and spoil `rel_error_clutter_cb`; the chosen
//! asset's `rel_error_clutter_cb` is reported beside it. The neighbourhood decides which
//! blocks receive clutter effects at all and stays the caller's. Each rung is baked with the
//! engine `sweep drt` uses ([`Tracer`]; the bytes of a plain `penumbra drt --rays R`) and
//! measured as `verify drt` measures an asset ([`DrtBench`]: the same receivers, lights,
//! runtime and path-traced reference, traced once before the walk with `verify drt`'s
//! defaults), so `verify drt --drt OUT` with the same `--reference-rays` reports the chosen
//! `measured`.

use crate::commands::drt::DrtScene;
use crate::commands::sweep_drt::{DrtBench, Tracer};
use crate::commands::target::{Search, settings_text};
use crate::exit::CliError;
use crate::fsutil::ensure_parent;
use crate::progress::ProgressMode;
use anyhow::{Context, anyhow};
use penumbra_transport::drt::DrtParams;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

/// Rays per scene texel (and per clutter texel) of the ladder.
pub const RAYS_RUNGS: [usize; 9] = [32, 64, 128, 256, 512, 1024, 2048, 4096, 8192];

/// The reference and budget of a DRT target search.
#[derive(Debug, Clone)]
pub struct DrtTargetOptions<'a> {
    /// The dictionary file (the runtime reads it).
    pub dict_path: &'a Path,
    /// Point lights of the comparison (`verify drt --lights`).
    pub lights: Option<&'a Path>,
    /// Reference rays per receiver (`verify drt --reference-rays`, 512).
    pub reference_rays: usize,
    /// Leave out rungs with more rays per texel.
    pub max_rays: Option<usize>,
    /// Depth limit of the level operators when the level is not a baked asset.
    pub max_depth: usize,
}

/// The ladder in walking order, without rungs above `max_rays`.
pub fn ladder(max_rays: Option<usize>) -> Vec<usize> {
    RAYS_RUNGS.iter().copied().filter(|&r| max_rays.is_none_or(|m| r <= m)).collect()
}

/// What a DRT target search produced.
#[derive(Debug)]
pub struct DrtTargetOutcome {
    /// `penumbra drt`'s report of the chosen bake with the search's keys.
    pub report: Value,
    /// Whether the written asset meets the target.
    pub met: bool,
}

/// Walks the ladder for `base` (every parameter but rays and clutter rays) and writes
/// the chosen candidate to `output`: the first meeting `target`, else the best measured.
#[allow(clippy::print_stderr)]
pub fn search(
    sc: &DrtScene,
    base: &DrtParams,
    target: f64,
    o: &DrtTargetOptions<'_>,
    output: &Path,
    mode: ProgressMode,
) -> Result<DrtTargetOutcome, CliError> {
    let start = Instant::now();
    let rungs = ladder(o.max_rays);
    if rungs.is_empty() {
        return Err(CliError::input(anyhow!(
            "--max-rays {}: below the ladder's fewest rays ({})",
            o.max_rays.unwrap_or(0),
            RAYS_RUNGS[0]
        )));
    }
    if base.vector_rays.is_some() {
        return Err(CliError::input(anyhow!(
            "--target-error chooses the scalar operators' knobs: bake --vector with the chosen --rays"
        )));
    }
    let mut search = Search::new(target, "rel_error_mrt_drt");
    let bench = DrtBench::new(sc, o.dict_path, o.lights, 0.5, o.reference_rays, 0, o.max_depth, mode)?;
    if mode != ProgressMode::None {
        eprintln!(
            "target rel_error_mrt_drt {target}: reference ({} rays per receiver) {:.2} s",
            o.reference_rays, bench.reference_seconds
        );
    }
    // the best candidate so far: index, asset bytes, bake metrics, its other errors, bake seconds
    type Kept = (usize, Vec<u8>, Value, [f64; 2], f64);
    let mut best: Option<Kept> = None;
    for (i, &rays) in rungs.iter().enumerate() {
        let t0 = Instant::now();
        let p = DrtParams { rays, clutter_rays: rays, ..base.clone() };
        p.validate().map_err(|e| CliError::input(anyhow!("{e}")))?;
        let (b, bytes, _, bake_seconds) = Tracer::default().bake(sc, &p)?;
        let m = bench.measure(&bytes, false)?;
        let settings = json!({"rays": rays, "clutter_rays": rays});
        let seconds = t0.elapsed().as_secs_f64();
        let met = search.record(settings.clone(), m.rel_error_mrt_drt, seconds);
        if mode != ProgressMode::None {
            eprintln!(
                "[{}/{}] {}: rel_error_mrt_drt {:.5}{} ({:.2} s)",
                i + 1,
                rungs.len(),
                settings_text(&settings),
                m.rel_error_mrt_drt,
                if met { " meets the target" } else { "" },
                seconds
            );
        }
        if search.chosen().is_some_and(|(c, _)| c == i) {
            let metrics = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
            best = Some((i, bytes, metrics, [m.rel_error_mrt, m.rel_error_clutter_cb], bake_seconds));
        }
        if met {
            break;
        }
    }
    let (ci, met) = search.chosen().ok_or_else(|| CliError::internal(anyhow!("no candidate")))?;
    let Some((bi, bytes, mut report, [e_mrt, e_cb], bake_seconds)) = best else {
        return Err(CliError::internal(anyhow!("no candidate kept")));
    };
    if bi != ci {
        return Err(CliError::internal(anyhow!("kept candidate {bi}, chose {ci}")));
    }
    ensure_parent(output)?;
    penumbra_asset::write_file_atomic(output, &bytes).with_context(|| format!("cannot write {}", output.display()))?;
    if let Some(r) = report.as_object_mut() {
        r.insert("level".into(), json!(sc.what));
        r.insert("level_blocks".into(), json!(sc.level.blocks.len()));
        r.insert("kc_mode".into(), json!(base.kc_mode.name()));
        r.insert("bytes".into(), json!(bytes.len()));
        r.insert("bake_seconds".into(), json!(bake_seconds));
        r.insert("output".into(), json!(output.display().to_string()));
        r.insert("rel_error_mrt".into(), json!(e_mrt));
        r.insert("rel_error_clutter_cb".into(), json!(e_cb));
        r.insert("reference_rays".into(), json!(o.reference_rays));
        r.insert("reference_seconds".into(), json!(bench.reference_seconds));
        r.insert("max_rays".into(), json!(o.max_rays));
        if let Some(s) = search.report("ladder: rays per texel (clutter rays equal), ascending").as_object() {
            r.extend(s.clone());
        }
        r.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
    }
    Ok(DrtTargetOutcome { report, met })
}
