//! The shared content-addressed cache of `penumbra bake --cache-dir DIR`.
//!
//! An entry is the asset itself, named by the stage's cache key and the output's extension
//! (`DIR/<key>.<ext>`). The key covers the tool version, every parameter and the content hash
//! of every input (`fsutil::hash_input`), so equal keys mean equal bytes, and any number of
//! machines can share one directory: entries are written atomically (temporary file, rename)
//! and two writers of one key write the same bytes. An entry is used only when it opens as a
//! valid asset (every section checksum) whose metadata carries the key; anything else is a
//! miss. `--cache-read-only` (CI consumers) reads entries and never writes.

use anyhow::Context;
use penumbra_asset::AssetFile;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Where (and whether) stage outputs are looked up and stored.
#[derive(Debug, Clone, Default)]
pub struct Cache {
    /// The shared directory, if any.
    pub dir: Option<PathBuf>,
    /// Look entries up but never write them.
    pub read_only: bool,
    /// Ignore the local output and the shared entries (re-bake); the result is still stored.
    pub force: bool,
}

impl Cache {
    /// The entry a key would have for an output named like `output`.
    fn entry(&self, key: &str, output: &Path) -> Option<PathBuf> {
        let dir = self.dir.as_ref()?;
        let ext = output.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "bin".into());
        Some(dir.join(format!("{key}.{ext}")))
    }

    /// Copies the entry of `key` to `output` (atomically) when a valid one exists; the report's
    /// `cache` object either way (`None` without a cache directory or with `force`).
    pub fn restore(&self, key: &str, output: &Path) -> (bool, Option<Value>) {
        let Some(entry) = self.entry(key, output) else { return (false, None) };
        if self.force {
            return (false, Some(json!({"dir": self.dir, "entry": entry, "hit": false, "why": "--force"})));
        }
        let miss = |why: String| (false, Some(json!({"dir": self.dir, "entry": entry, "hit": false, "why": why})));
        if !entry.is_file() {
            return miss("no entry".into());
        }
        let file = match AssetFile::open(&entry) {
            Ok(f) => f,
            Err(e) => return miss(format!("entry ignored: {e}")),
        };
        let meta: Value = serde_json::from_str(file.asset().meta_json()).unwrap_or(Value::Null);
        if meta.get("cache_key").and_then(Value::as_str) != Some(key) {
            return miss("entry ignored: its metadata carries another cache key".into());
        }
        if let Err(e) = crate::fsutil::ensure_parent(output) {
            return miss(format!("cannot restore: {e:#}"));
        }
        match penumbra_asset::write_file_atomic(output, file.bytes()) {
            Ok(()) => (true, Some(json!({"dir": self.dir, "entry": entry, "hit": true}))),
            Err(e) => miss(format!("cannot restore to {}: {e}", output.display())),
        }
    }

    /// An up-to-date local output the shared cache lacks is stored there too (unless
    /// read-only); the report's `cache` object, `None` without a cache directory.
    pub fn share_if_missing(&self, key: &str, output: &Path) -> Option<Value> {
        let entry = self.entry(key, output)?;
        // "present": the cache already held the key (this run was served locally, not a hit)
        let mut c = json!({"dir": self.dir, "entry": entry, "present": entry.is_file()});
        if !entry.is_file() {
            self.store(key, output, &mut c);
        }
        Some(c)
    }

    /// Stores the freshly baked `output` under `key` unless read-only; the outcome for the
    /// report (`stored`, or `store_error`: a failed store never fails the bake).
    pub fn store(&self, key: &str, output: &Path, report: &mut Value) {
        let Some(entry) = self.entry(key, output) else { return };
        if self.read_only {
            report["stored"] = json!(false);
            return;
        }
        let result = (|| -> anyhow::Result<()> {
            let dir = self.dir.as_deref().unwrap_or(Path::new("."));
            std::fs::create_dir_all(dir)?;
            let bytes = std::fs::read(output)?;
            penumbra_asset::write_file_atomic(&entry, &bytes)?;
            Ok(())
        })()
        .with_context(|| format!("cannot store {} in the cache {}", output.display(), entry.display()));
        match result {
            Ok(()) => report["stored"] = json!(true),
            Err(e) => {
                report["stored"] = json!(false);
                report["store_error"] = json!(format!("{e:#}"));
            }
        }
    }
}
