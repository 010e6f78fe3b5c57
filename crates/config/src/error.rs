//! Config errors: file, key path, line and column, message.

use crate::validate::Issue;
use std::path::{Path, PathBuf};

/// What went wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ConfigErrorKind {
    /// The file could not be read.
    Io,
    /// TOML syntax error.
    Syntax,
    /// Wrong type, unknown or missing key.
    Field,
    /// A value out of range or otherwise invalid.
    Invalid,
}

/// A config error that names the file, the key path and the line.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}", self.render())]
pub struct ConfigError {
    /// Kind.
    pub kind: ConfigErrorKind,
    /// Config file.
    pub path: PathBuf,
    /// Dotted key path (empty for syntax and IO errors without one).
    pub key: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// 1-based column, when known.
    pub column: Option<usize>,
    /// Message.
    pub message: String,
}

fn line_col(source: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(source.len());
    let before = &source[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map(|s| s.chars().count()).unwrap_or(0) + 1;
    (line, col)
}

/// First line of a toml error message without its code snippet.
fn short_message(e: &toml::de::Error) -> String {
    e.message().lines().next().unwrap_or("").trim().to_string()
}

impl ConfigError {
    fn render(&self) -> String {
        let mut s = self.path.display().to_string();
        if let Some(l) = self.line {
            s.push_str(&format!(":{l}"));
            if let Some(c) = self.column {
                s.push_str(&format!(":{c}"));
            }
        }
        s.push_str(": ");
        if !self.key.is_empty() {
            s.push_str(&format!("`{}`: ", self.key));
        }
        s.push_str(&self.message);
        s
    }

    pub(crate) fn io(path: &Path, e: std::io::Error) -> Self {
        Self {
            kind: ConfigErrorKind::Io,
            path: path.to_path_buf(),
            key: String::new(),
            line: None,
            column: None,
            message: format!("cannot read the config: {e}"),
        }
    }

    pub(crate) fn syntax(path: &Path, source: &str, e: &toml::de::Error) -> Self {
        let (line, column) = e.span().map(|s| line_col(source, s.start)).unzip();
        Self {
            kind: ConfigErrorKind::Syntax,
            path: path.to_path_buf(),
            key: String::new(),
            line,
            column,
            message: format!("TOML syntax error: {}", short_message(e)),
        }
    }

    pub(crate) fn field(path: &Path, source: &str, key: String, e: &toml::de::Error) -> Self {
        let (line, column) = e.span().map(|s| line_col(source, s.start)).unzip();
        let key = if key == "." { String::new() } else { key };
        Self { kind: ConfigErrorKind::Field, path: path.to_path_buf(), key, line, column, message: short_message(e) }
    }

    pub(crate) fn invalid(path: &Path, source: &str, issue: &Issue, total: usize) -> Self {
        let span = locate(source, &issue.key);
        let (line, column) = span.map(|s| line_col(source, s)).unzip();
        let more = if total > 1 { format!(" (and {} more problem(s))", total - 1) } else { String::new() };
        Self {
            kind: ConfigErrorKind::Invalid,
            path: path.to_path_buf(),
            key: issue.key.clone(),
            line,
            column,
            message: format!("{}{more}", issue.message),
        }
    }
}

/// Byte offset of the value at a dotted key path (or of its table, or the document start).
fn locate(source: &str, key: &str) -> Option<usize> {
    let doc = toml_edit::Document::parse(source.to_string()).ok()?;
    let mut item: &toml_edit::Item = doc.as_item();
    let mut best = None;
    for part in key.split('.') {
        // `name[i]`: the i-th table of an array of tables
        let next = match part.split_once('[') {
            Some((name, rest)) => {
                let idx: Option<usize> = rest.strip_suffix(']').and_then(|i| i.parse().ok());
                item.get(name).and_then(|a| idx.and_then(|i| a.get(i)))
            }
            None => item.get(part),
        };
        match next {
            Some(next) => {
                item = next;
                if let Some(sp) = item.span() {
                    best = Some(sp.start);
                }
            }
            None => break,
        }
    }
    best.or(Some(0))
}
