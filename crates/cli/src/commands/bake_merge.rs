//! `penumbra bake merge DIR_0 … DIR_{N-1} -o DIR`: joins the output directories of the N runs
//! `penumbra bake CONFIG --shard K/N --output-dir DIR_K` into what one unsharded run writes.
//!
//! Each shard directory holds its assets and one `report.shard-K-of-N.json`. Every work item
//! ran in exactly one shard (the others report it `skipped-by-shard`), so the union of the
//! shards' files is the single run's set of files: they are copied as they are (a file that two
//! shards both hold must be the same bytes), and `report.json` is the single run's report with
//! each stage taken from the shard that ran it, its `output` moved to the merged directory,
//! the gates joined in stage order and `seconds` the slowest shard's (the batch's wall time
//! when the shards ran side by side); `merged_from` lists the shard directories.

use crate::args::BakeMergeArgs;
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::write_atomic_text;
use anyhow::{Context, anyhow};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One shard's directory and report.
struct Shard {
    dir: PathBuf,
    k: usize,
    n: usize,
    report: Value,
}

fn read_shard(dir: &Path) -> Result<Shard, CliError> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("cannot read shard directory {}", dir.display()))?;
    let mut found = Vec::new();
    for e in entries {
        let name = e.with_context(|| format!("cannot read {}", dir.display()))?.file_name();
        let name = name.to_string_lossy().to_string();
        let kn = name.strip_prefix("report.shard-").and_then(|r| r.strip_suffix(".json")).and_then(|r| {
            let (k, n) = r.split_once("-of-")?;
            Some((k.parse::<usize>().ok()?, n.parse::<usize>().ok()?))
        });
        if let Some((k, n)) = kn {
            found.push((name, k, n));
        }
    }
    let [(name, k, n)] = <[_; 1]>::try_from(found).map_err(|f| {
        CliError::input(anyhow!(
            "{}: expected one report.shard-K-of-N.json, found {} (a directory per shard: `penumbra bake CONFIG --shard K/N --output-dir DIR_K`)",
            dir.display(),
            f.len()
        ))
    })?;
    let path = dir.join(&name);
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let report: Value = serde_json::from_str(&text)
        .map_err(|e| CliError::input(anyhow!("{}: not a bake report ({e})", path.display())))?;
    if !report["stages"].is_array() {
        return Err(CliError::input(anyhow!("{}: not a bake report (no stages)", path.display())));
    }
    Ok(Shard { dir: dir.to_path_buf(), k, n, report })
}

/// Runs `penumbra bake merge`.
#[allow(clippy::print_stderr)]
pub fn run(a: &BakeMergeArgs) -> Result<ExitCode, CliError> {
    let shards: Vec<Shard> = a.dirs.iter().map(|d| read_shard(d)).collect::<Result<_, _>>()?;
    let n = shards[0].n;
    let mut seen = vec![false; n];
    for s in &shards {
        if s.n != n {
            return Err(CliError::input(anyhow!(
                "{}: a shard of {} runs, {} of {n}",
                s.dir.display(),
                s.n,
                shards[0].dir.display()
            )));
        }
        if s.report["config"] != shards[0].report["config"] {
            return Err(CliError::input(anyhow!(
                "{}: baked {}, {} baked {}",
                s.dir.display(),
                s.report["config"],
                shards[0].dir.display(),
                shards[0].report["config"]
            )));
        }
        if std::mem::replace(&mut seen[s.k], true) {
            return Err(CliError::input(anyhow!("shard {}/{n} given twice ({})", s.k, s.dir.display())));
        }
    }
    if let Some(k) = seen.iter().position(|&x| !x) {
        return Err(CliError::input(anyhow!("shard {k}/{n} is missing: give all {n} shard directories")));
    }
    let stages_of = |s: &Shard| s.report["stages"].as_array().cloned().unwrap_or_default();
    let names = |s: &Shard| stages_of(s).iter().map(|v| v["name"].clone()).collect::<Vec<_>>();
    if let Some(s) = shards.iter().find(|s| names(s) != names(&shards[0])) {
        return Err(CliError::input(anyhow!(
            "{}: other stages than {} (the same config with other options?)",
            s.dir.display(),
            shards[0].dir.display()
        )));
    }
    // files: the union, the same bytes where two shards hold one
    let mut files: BTreeMap<String, PathBuf> = BTreeMap::new();
    for s in &shards {
        let entries = std::fs::read_dir(&s.dir).with_context(|| format!("cannot read {}", s.dir.display()))?;
        for e in entries {
            let e = e.with_context(|| format!("cannot read {}", s.dir.display()))?;
            let name = e.file_name().to_string_lossy().to_string();
            if name.starts_with("report.") || !e.file_type().is_ok_and(|t| t.is_file()) {
                continue;
            }
            if let Some(first) = files.get(&name) {
                let same = std::fs::read(first).ok() == std::fs::read(e.path()).ok();
                if !same {
                    return Err(CliError::input(anyhow!(
                        "{} and {} differ: the shards did not bake the same inputs",
                        first.display(),
                        e.path().display()
                    )));
                }
                continue;
            }
            files.insert(name, e.path());
        }
    }
    // the report: each stage from the shard that ran it
    let mut stages = Vec::new();
    let mut failed_gates = Vec::new();
    let all: Vec<Vec<Value>> = shards.iter().map(stages_of).collect();
    for i in 0..all[0].len() {
        let ran: Vec<(usize, &Value)> = all
            .iter()
            .enumerate()
            .map(|(j, v)| (j, &v[i]))
            .filter(|(_, v)| v["status"] != "skipped-by-shard")
            .collect();
        let stage = match ran.as_slice() {
            [one] => one.1,
            [] => {
                return Err(CliError::input(anyhow!("stage {} ran in no shard", all[0][i]["name"])));
            }
            // skipped by --only everywhere: any shard's entry
            [first, ..]
                if ran.iter().all(|(_, v)| v["status"] == first.1["status"]) && first.1.get("output").is_none() =>
            {
                first.1
            }
            _ => {
                return Err(CliError::input(anyhow!("stage {} ran in more than one shard", all[0][i]["name"])));
            }
        };
        let mut stage = stage.clone();
        if let Some(out) = stage["output"].as_str() {
            let file = Path::new(out).file_name().map(|f| a.output.join(f));
            if let Some(f) = file {
                stage["output"] = json!(f.display().to_string());
            }
        }
        if stage["gate"]["passed"] == false {
            for f in stage["gate"]["failures"].as_array().into_iter().flatten() {
                failed_gates.push(json!({"stage": stage["name"], "gate": f["gate"], "metric": f["metric"],
                                         "value": f["value"], "max": f["max"]}));
            }
        }
        stages.push(stage);
    }
    // only now, every check passed: nothing is written for a refused merge
    std::fs::create_dir_all(&a.output).with_context(|| format!("cannot create {}", a.output.display()))?;
    for (name, src) in &files {
        let bytes = std::fs::read(src).with_context(|| format!("cannot read {}", src.display()))?;
        penumbra_asset::write_file_atomic(a.output.join(name), &bytes)
            .with_context(|| format!("cannot write {}", a.output.join(name).display()))?;
    }
    let seconds = shards.iter().filter_map(|s| s.report["seconds"].as_f64()).fold(0.0f64, f64::max);
    let report = json!({
        "config": shards[0].report["config"],
        "output_dir": a.output.display().to_string(),
        "shard": Value::Null,
        "stages": stages,
        "gates_passed": failed_gates.is_empty(),
        "failed_gates": failed_gates,
        "seconds": seconds,
        "merged_from": a.dirs.iter().map(|d| d.display().to_string()).collect::<Vec<_>>(),
    });
    let path = a.output.join("report.json");
    write_atomic_text(&path, &(serde_json::to_string_pretty(&report).map_err(CliError::internal)? + "\n"))?;
    if a.json {
        print_json(&report);
    } else {
        eprintln!("merged {n} shards ({} files) into {}; report: {}", files.len(), a.output.display(), path.display());
    }
    Ok(if failed_gates.is_empty() { ExitCode::Ok } else { ExitCode::QualityGate })
}
