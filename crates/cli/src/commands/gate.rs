//! Quality gates of the verify commands (`--max-nrmse`, `--max-rel-error`, `--max-rmse`, …):
//! one metric of the report must be at most a bound, else exit 1 (DESIGN §2). Every verify
//! reports each gate's bound under the flag's key (`max_nrmse`, null when not given) and
//! `gate_passed` (null when no gate was given); `penumbra bake` reuses the same check for the
//! `gate = { … }` of a stage.

use crate::exit::ExitCode;
use serde_json::{Value, json};

/// One gate: the report's `metric` must be at most `max`.
#[derive(Debug, Clone, Copy)]
pub struct Gate<'a> {
    /// The flag without dashes, with underscores: `max_nrmse` (also its JSON key).
    pub key: &'a str,
    /// The report key it bounds: `nrmse_vs_mesh`.
    pub metric: &'a str,
    /// The bound, when the gate was given.
    pub max: Option<f64>,
}

/// A gate that failed: the measured value is above the bound (or not a number).
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// The gate's key (`max_nrmse`).
    pub gate: String,
    /// The metric it bounds.
    pub metric: String,
    /// The measured value (NaN when the report has none).
    pub value: f64,
    /// The bound.
    pub max: f64,
}

impl Failure {
    /// `{gate, metric, value, max}` (a NaN value as null).
    pub fn to_json(&self) -> Value {
        json!({"gate": self.gate, "metric": self.metric, "value": finite_or_null(self.value), "max": self.max})
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {:.6} > {} {}", self.metric, self.value, self.gate.replace('_', "-"), self.max)
    }
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// Checks `gates` against the report `v` (an object): inserts each gate's bound under its key
/// (null when not given) and `gate_passed` (null when no gate was given), and returns the
/// failures. A missing or NaN metric fails its gate.
pub fn apply(v: &mut Value, gates: &[Gate<'_>]) -> Vec<Failure> {
    let mut failures = Vec::new();
    for g in gates {
        if let Some(max) = g.max {
            let value = v[g.metric].as_f64().unwrap_or(f64::NAN);
            if value.is_nan() || value > max {
                failures.push(Failure { gate: g.key.into(), metric: g.metric.into(), value, max });
            }
        }
    }
    let any = gates.iter().any(|g| g.max.is_some());
    if let Some(o) = v.as_object_mut() {
        for g in gates {
            o.insert(g.key.into(), json!(g.max));
        }
        o.insert("gate_passed".into(), if any { json!(failures.is_empty()) } else { Value::Null });
    }
    failures
}

/// Prints each failure on stderr (`quality gate failed: nrmse 0.0312 > max-nrmse 0.02`) and
/// returns the exit code: [`ExitCode::QualityGate`] when any failed.
#[allow(clippy::print_stderr)]
pub fn finish(failures: &[Failure]) -> ExitCode {
    for f in failures {
        eprintln!("quality gate failed: {} {} > --{} {}", f.metric, f.value, f.gate.replace('_', "-"), f.max);
    }
    if failures.is_empty() { ExitCode::Ok } else { ExitCode::QualityGate }
}

/// Value parser of a `--max-…` flag: a finite number > 0.
pub fn parse_max(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v.is_finite() { Ok(v) } else { Err(format!("{v} is out of range (allowed: a finite value > 0)")) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gates_pass_fail_and_report() {
        let mut v = json!({"nrmse": 0.03, "nrmse_visible": 0.01});
        let f = apply(
            &mut v,
            &[
                Gate { key: "max_nrmse", metric: "nrmse", max: Some(0.02) },
                Gate { key: "max_nrmse_visible", metric: "nrmse_visible", max: Some(0.02) },
            ],
        );
        assert_eq!(f.len(), 1);
        assert_eq!(f[0].gate, "max_nrmse");
        assert_eq!(f[0].value, 0.03);
        assert_eq!(v["gate_passed"], json!(false));
        assert_eq!(v["max_nrmse"], json!(0.02));
        assert_eq!(finish(&f), ExitCode::QualityGate);
        // the bound equal to the value passes
        let mut v = json!({"nrmse": 0.02});
        assert!(apply(&mut v, &[Gate { key: "max_nrmse", metric: "nrmse", max: Some(0.02) }]).is_empty());
        assert_eq!(v["gate_passed"], json!(true));
    }

    #[test]
    fn no_gate_is_null_and_nan_fails() {
        let mut v = json!({"nrmse": 0.5});
        assert!(apply(&mut v, &[Gate { key: "max_nrmse", metric: "nrmse", max: None }]).is_empty());
        assert_eq!(v["gate_passed"], Value::Null);
        assert_eq!(v["max_nrmse"], Value::Null);
        let mut v = json!({"nrmse": null});
        let f = apply(&mut v, &[Gate { key: "max_nrmse", metric: "nrmse", max: Some(1.0) }]);
        assert_eq!(f.len(), 1);
        assert!(f[0].value.is_nan());
        assert_eq!(f[0].to_json()["value"], Value::Null);
    }

    #[test]
    fn parse_max_rejects_non_positive() {
        assert_eq!(parse_max("0.5"), Ok(0.5));
        assert!(parse_max("0").is_err());
        assert!(parse_max("-1").is_err());
        assert!(parse_max("inf").is_err());
        assert!(parse_max("x").is_err());
    }
}
