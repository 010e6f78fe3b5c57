//! Targets instead of knobs (`fiv --target-nrmse`, `drt --target-error`, a bake stage's
//! `target = …`): walk a ladder of settings ordered by bake cost, measure each candidate as
//! its `verify` measures it against **one** reference computed before the walk, and stop at
//! the first candidate that meets the target. Every cheaper candidate of the ladder was
//! tried and missed, so the choice is the cheapest on the ladder that meets it. A target no
//! candidate meets writes the best candidate measured (the lowest error) and exits 1 (a
//! quality gate), with the reason.
//!
//! This module holds what the searches share: the target's value parser, the record of the
//! candidates tried, the `--json` keys and the candidate files (written next to the output,
//! the chosen one renamed onto it, the others removed, all removed if the search fails).

use crate::exit::CliError;
use anyhow::{Context, anyhow};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Value parser of a target flag: a finite number > 0.
pub fn parse_target(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v.is_finite() { Ok(v) } else { Err(format!("{v} is out of range (allowed: a finite value > 0)")) }
}

/// A target given in a bake config: the same rule as [`parse_target`], with the key path.
pub fn check_target(v: f64, key: &str) -> Result<f64, CliError> {
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(CliError::input(anyhow!("{key} = {v} is out of range (allowed: a finite value > 0)")))
    }
}

/// One candidate measured.
#[derive(Debug, Clone)]
pub struct Tried {
    /// Its knob values (the `chosen` object when chosen).
    pub settings: Value,
    /// The error `verify` would report.
    pub measured: f64,
    /// What the search spent on it (bake and measurement).
    pub seconds: f64,
}

/// A search in progress: the target, the candidates tried, the clock.
#[derive(Debug)]
pub struct Search {
    /// The target (the error must be at most this).
    pub target: f64,
    /// The metric's name in the `verify` report (`nrmse`, `rel_error_mrt_drt`).
    pub metric: &'static str,
    /// Candidates in the order tried.
    pub tried: Vec<Tried>,
    start: Instant,
}

impl Search {
    /// Starts the clock.
    pub fn new(target: f64, metric: &'static str) -> Self {
        Self { target, metric, tried: Vec::new(), start: Instant::now() }
    }

    /// Records a candidate; true when it meets the target (`measured <= target`; NaN never does).
    pub fn record(&mut self, settings: Value, measured: f64, seconds: f64) -> bool {
        self.tried.push(Tried { settings, measured, seconds });
        measured <= self.target
    }

    /// The candidate to write: the first that met the target, else the lowest error (the first
    /// of equals); `None` before any candidate. Also whether the target was met.
    pub fn chosen(&self) -> Option<(usize, bool)> {
        if let Some(i) = self.tried.iter().position(|t| t.measured <= self.target) {
            return Some((i, true));
        }
        let mut best: Option<usize> = None;
        for (i, t) in self.tried.iter().enumerate() {
            if !t.measured.is_nan() && best.is_none_or(|b| t.measured < self.tried[b].measured) {
                best = Some(i);
            }
        }
        best.or(if self.tried.is_empty() { None } else { Some(0) }).map(|i| (i, false))
    }

    /// Seconds since [`Search::new`].
    pub fn seconds(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The `--json` keys of a finished search: `target`, `metric`, `chosen`, `measured`,
    /// `target_met`, `search_seconds`, `candidates_tried` (`{settings, measured, seconds}`),
    /// and `reason` when the target was not met.
    pub fn report(&self, method: &str) -> Value {
        let (i, met) = self.chosen().unwrap_or((0, false));
        let c = self.tried.get(i);
        let tried: Vec<Value> = self
            .tried
            .iter()
            .map(|t| json!({"settings": t.settings, "measured": finite(t.measured), "seconds": t.seconds}))
            .collect();
        let mut v = json!({
            "target": self.target,
            "metric": self.metric,
            "method": method,
            "chosen": c.map_or(Value::Null, |c| c.settings.clone()),
            "measured": c.map_or(Value::Null, |c| finite(c.measured)),
            "target_met": met,
            "search_seconds": self.seconds(),
            "candidates_tried": tried,
        });
        if !met {
            v["reason"] = json!(self.reason());
        }
        v
    }

    /// Why the target was not met (for the text output and `reason`).
    pub fn reason(&self) -> String {
        match self.chosen() {
            Some((i, false)) => format!(
                "no candidate of the ladder meets {} <= {}: the best of the {} tried, {}, measured {:.6}; it was written",
                self.metric,
                self.target,
                self.tried.len(),
                settings_text(&self.tried[i].settings),
                self.tried[i].measured
            ),
            Some((_, true)) => String::new(),
            None => "no candidate was tried (the ladder is empty under the budget)".into(),
        }
    }
}

fn finite(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// `key value, key value` of a settings object, for the text output.
pub fn settings_text(v: &Value) -> String {
    match v.as_object() {
        Some(o) => o
            .iter()
            .map(|(k, v)| match v {
                Value::String(s) => format!("{k} {s}"),
                v => format!("{k} {v}"),
            })
            .collect::<Vec<_>>()
            .join(", "),
        None => v.to_string(),
    }
}

/// The candidate files of a search, next to the output (same directory, so the chosen one is
/// renamed onto it): removed when dropped unless [`Candidates::finish`] moved one into place.
#[derive(Debug)]
pub struct Candidates {
    output: PathBuf,
    files: Vec<PathBuf>,
}

impl Candidates {
    /// Candidate files for `output` (its parent directory is created).
    pub fn new(output: &Path) -> Result<Self, CliError> {
        crate::fsutil::ensure_parent(output)?;
        Ok(Self { output: output.to_path_buf(), files: Vec::new() })
    }

    /// The path of candidate `i` (`.NAME.candidate-I.tmp` beside the output).
    pub fn path(&mut self, i: usize) -> PathBuf {
        let name = self.output.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let p = self.output.with_file_name(format!(".{name}.candidate-{i}.tmp"));
        if !self.files.contains(&p) {
            self.files.push(p.clone());
        }
        p
    }

    /// Removes candidate `i`'s file (a candidate that can no longer be chosen).
    pub fn discard(&mut self, i: usize) {
        let p = self.path(i);
        let _ = std::fs::remove_file(&p);
    }

    /// Moves candidate `i` onto the output and removes the others.
    pub fn finish(mut self, i: usize) -> Result<(), CliError> {
        let p = self.path(i);
        std::fs::rename(&p, &self.output)
            .with_context(|| format!("cannot move {} to {}", p.display(), self.output.display()))?;
        Ok(())
    }
}

impl Drop for Candidates {
    fn drop(&mut self) {
        for f in &self.files {
            let _ = std::fs::remove_file(f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_met_is_chosen_else_the_best() {
        let mut s = Search::new(0.1, "nrmse");
        assert!(s.chosen().is_none());
        assert!(!s.record(json!({"a": 1}), 0.3, 1.0));
        assert!(!s.record(json!({"a": 2}), 0.2, 1.0));
        assert_eq!(s.chosen(), Some((1, false)));
        assert!(s.reason().contains("0.2"));
        assert!(s.record(json!({"a": 3}), 0.1, 1.0));
        assert_eq!(s.chosen(), Some((2, true)));
        let v = s.report("ladder");
        assert_eq!(v["chosen"], json!({"a": 3}));
        assert_eq!(v["measured"], json!(0.1));
        assert_eq!(v["target_met"], json!(true));
        assert_eq!(v["candidates_tried"].as_array().unwrap().len(), 3);
        assert!(v.get("reason").is_none());
        let mut s = Search::new(0.1, "nrmse");
        assert!(!s.record(json!({}), f64::NAN, 0.0));
        assert_eq!(s.chosen(), Some((0, false)));
    }

    #[test]
    fn targets_must_be_positive_and_finite() {
        assert_eq!(parse_target("0.05"), Ok(0.05));
        for bad in ["0", "-1", "nan", "NaN", "inf", "x", ""] {
            assert!(parse_target(bad).is_err(), "{bad}");
        }
        assert!(check_target(f64::NAN, "fiv[0].target").is_err());
    }
}
