//! What every `penumbra sweep …` shares: list arguments, the CSV table, the Pareto front of a
//! panel, and writing `sweep.csv`, `sweep.json` and `sweep.svg` atomically.

use crate::exit::CliError;
use crate::fsutil::write_atomic_text;
use crate::svgplot::{Panel, pareto_front, render};
use anyhow::{Context, anyhow};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Parses a comma-separated list (`--what` names the option in the error).
pub fn parse_list<T: std::str::FromStr>(s: &str, what: &str) -> Result<Vec<T>, CliError> {
    s.split(',')
        .map(|x| {
            x.trim().parse::<T>().map_err(|_| CliError::input(anyhow!("--{what}: {x:?} is not a valid value in {s:?}")))
        })
        .collect()
}

/// The rows as CSV with the given columns (strings unquoted, everything else as JSON).
pub fn csv_text(cols: &[&str], rows: &[Value]) -> String {
    let mut csv = cols.join(",") + "\n";
    for r in rows {
        let cells: Vec<String> = cols
            .iter()
            .map(|c| match &r[*c] {
                Value::String(s) => s.clone(),
                v => v.to_string(),
            })
            .collect();
        csv.push_str(&(cells.join(",") + "\n"));
    }
    csv
}

/// Sets `panel.front` to the Pareto front (both coordinates minimised) of all its points.
pub fn with_front(mut panel: Panel) -> Panel {
    let pts: Vec<(f64, f64)> = panel.series.iter().flat_map(|s| s.points.iter().map(|q| (q.0, q.1))).collect();
    let on = pareto_front(&pts);
    panel.front = pts.iter().zip(&on).filter(|(_, o)| **o).map(|(p, _)| *p).collect();
    panel
}

/// Writes `sweep.csv`, `sweep.svg` and `sweep.json` (pretty, newline-terminated) into `dir`.
pub fn write_outputs(dir: &Path, csv: &str, panels: &[Panel], summary: &Value) -> Result<(), CliError> {
    write_atomic_text(&dir.join("sweep.csv"), csv)?;
    write_atomic_text(&dir.join("sweep.svg"), &render(panels))?;
    write_atomic_text(
        &dir.join("sweep.json"),
        &(serde_json::to_string_pretty(summary).map_err(CliError::internal)? + "\n"),
    )?;
    Ok(())
}

/// The output directory of a sweep, cleaned up unless the sweep finishes: dropped before
/// [`OutputGuard::keep`], it removes every file registered with [`OutputGuard::file`], and the
/// directory itself when this sweep created it. A sweep that
/// fails half-way (a point whose bake rejects its parameters, a full disk) leaves no partial
/// outputs.
#[derive(Debug)]
pub struct OutputGuard {
    dir: PathBuf,
    created: bool,
    files: Vec<PathBuf>,
    kept: bool,
}

impl OutputGuard {
    /// Creates `dir` (and its parents) if needed.
    pub fn create(dir: &Path) -> Result<Self, CliError> {
        let created = !dir.exists();
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        Ok(Self { dir: dir.to_path_buf(), created, files: Vec::new(), kept: false })
    }

    /// `dir/name`, registered for removal if the sweep fails.
    pub fn file(&mut self, name: &str) -> PathBuf {
        let p = self.dir.join(name);
        self.files.push(p.clone());
        p
    }

    /// The sweep finished: keep everything.
    pub fn keep(mut self) {
        self.kept = true;
    }
}

impl Drop for OutputGuard {
    fn drop(&mut self) {
        if self.kept {
            return;
        }
        for f in &self.files {
            let _ = std::fs::remove_file(f);
        }
        if self.created {
            // only what this sweep made: the directory is removed only when now empty
            let _ = std::fs::remove_dir(&self.dir);
        }
    }
}

/// Flags each row `key` = whether it is on the Pareto front of `(row[x], row[y])`, both
/// minimised (a row missing either value is never on it).
pub fn flag_front(rows: &mut [Value], key: &str, x: &str, y: &str) {
    let pts: Vec<(f64, f64)> =
        rows.iter().map(|r| (r[x].as_f64().unwrap_or(f64::NAN), r[y].as_f64().unwrap_or(f64::NAN))).collect();
    for (r, on) in rows.iter_mut().zip(pareto_front(&pts)) {
        r[key] = Value::Bool(on);
    }
}

/// The sweep's `seconds` over its most expensive point's `bake_seconds` (null without points).
pub fn cost_ratio(rows: &[Value], seconds: f64) -> Value {
    let max = rows.iter().filter_map(|r| r["bake_seconds"].as_f64()).fold(0.0f64, f64::max);
    if max > 0.0 { Value::from(seconds / max) } else { Value::Null }
}

/// Writes `sweep.csv`, `sweep.svg` and `sweep.json` into `dir` under `guard` (removed with the
/// rest if a write fails) and keeps the sweep's outputs.
pub fn finish(
    mut guard: OutputGuard,
    dir: &Path,
    csv: &str,
    panels: &[Panel],
    summary: &Value,
) -> Result<(), CliError> {
    for f in ["sweep.csv", "sweep.svg", "sweep.json"] {
        guard.file(f);
    }
    write_outputs(dir, csv, panels, summary)?;
    guard.keep();
    Ok(())
}
