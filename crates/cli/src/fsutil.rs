//! Small file helpers: atomic text writes, content hashes.

use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// Writes `text` to `path` atomically (temp file in the same directory, fsync, rename).
pub fn write_atomic_text(path: &Path, text: &str) -> anyhow::Result<()> {
    write_atomic(path, text.as_bytes())
}

/// Writes `bytes` to `path` atomically (temp file in the same directory, fsync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp.{}", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.with_context(|| format!("cannot write {}", path.display()))
}

/// Content hash of a bake input: the BLAKE3 of the file's bytes when it reads nothing else
/// (OBJ, self-contained glTF/GLB, environment maps), otherwise the BLAKE3 of
/// `{"file": <its hash>, "external": [[uri, <hash>], …]}` over every external buffer and image
/// the glTF import reads (document order; a missing file hashes as `"missing"`, and the import
/// then fails naming it). Cache keys built from it change when an edited `.bin` or texture
/// would change the bake's bytes.
pub fn hash_input(path: &Path) -> anyhow::Result<String> {
    let file = hash_file(path)?;
    // an unparsable glTF fails its import with the real message; hash what can be read
    let external = penumbra_geometry::external_files(path).unwrap_or_default();
    if external.is_empty() {
        return Ok(file);
    }
    let ext: Vec<serde_json::Value> = external
        .iter()
        .map(|(uri, f)| {
            let h =
                std::fs::read(f).map(|b| blake3::hash(&b).to_hex().to_string()).unwrap_or_else(|_| "missing".into());
            serde_json::json!([uri, h])
        })
        .collect();
    Ok(blake3::hash(serde_json::json!({"file": file, "external": ext}).to_string().as_bytes()).to_hex().to_string())
}

/// blake3 hex digest of a file's bytes.
pub fn hash_file(path: &Path) -> anyhow::Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(blake3::hash(&bytes).to_hex().to_string())
}

/// Creates the parent directory of an output path if needed.
pub fn ensure_parent(path: &Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create directory {}", dir.display()))?;
    }
    Ok(())
}
