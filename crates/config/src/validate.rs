//! Semantic validation beyond types: ranges and names, each issue with its key path.

use crate::types::BakeConfig;

/// One validation problem.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Issue {
    /// Dotted key path, e.g. `tables.order`.
    pub key: String,
    /// What is wrong and what is allowed.
    pub message: String,
}

fn issue(key: &str, message: impl Into<String>) -> Issue {
    Issue { key: key.to_string(), message: message.into() }
}

/// A file name without directories or traversal.
fn plain_file_name(s: &str) -> bool {
    !s.is_empty() && !s.contains(['/', '\\']) && s != "." && s != ".."
}

/// Checks every value range of the config; returns all issues in document order.
pub fn validate(c: &BakeConfig) -> Vec<Issue> {
    let mut out = Vec::new();
    if c.output_dir.trim().is_empty() {
        out.push(issue("output_dir", "must not be empty"));
    }
    if let Some(t) = &c.tables {
        if !(2..=8).contains(&t.order) {
            out.push(issue("tables.order", format!("{} is out of range (allowed: 2..=8)", t.order)));
        }
        if let Some(k) = t.theta_samples {
            if !(16..=16384).contains(&k) {
                out.push(issue("tables.theta_samples", format!("{k} is out of range (allowed: 16..=16384)")));
            }
        }
        if let Some(tol) = t.shading_tolerance {
            if !(tol > 0.0 && tol < 1.0) {
                out.push(issue("tables.shading_tolerance", format!("{tol} is out of range (allowed: 0 < T < 1)")));
            }
        }
        if let Some(env) = &t.env {
            if env.trim().is_empty() {
                out.push(issue("tables.env", "must not be empty"));
            }
        }
        if let Some(o) = &t.output {
            if !plain_file_name(o) {
                out.push(issue("tables.output", format!("{o:?} must be a plain file name (no directories)")));
            }
        }
    }
    if !c.has_stage() {
        out.push(issue("stages", "the config names no stage to bake (add a stage table such as [tables])"));
    }
    out
}
