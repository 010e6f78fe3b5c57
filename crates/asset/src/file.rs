//! File IO (feature `std`): [`AssetFile`] reads and validates an asset into aligned memory;
//! [`write_file_atomic`] and [`AssetBuilder::write_atomic`] replace a file atomically.

use crate::error::{BuildError, LoadError};
use crate::load::Asset;
use crate::owned::{AlignedBuf, OwnedAsset};
use crate::write::AssetBuilder;
use std::ffi::OsString;
use std::fmt;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Why an asset could not be written. Always names the target path.
#[derive(Debug)]
#[non_exhaustive]
pub enum WriteError {
    /// The asset could not be encoded.
    Build {
        /// Target path.
        path: PathBuf,
        /// What is wrong with the asset.
        source: BuildError,
    },
    /// A file-system operation failed; the target is untouched and no temporary file is left.
    Io {
        /// Target path.
        path: PathBuf,
        /// The step that failed, e.g. `"create a temporary file"`.
        op: &'static str,
        /// The OS error.
        source: io::Error,
    },
}

impl WriteError {
    /// The target path.
    pub fn path(&self) -> &Path {
        match self {
            WriteError::Build { path, .. } | WriteError::Io { path, .. } => path,
        }
    }
}

impl fmt::Display for WriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WriteError::Build { path, source } => {
                write!(f, "cannot write asset {}: {source}", path.display())
            }
            WriteError::Io { path, op, source } => {
                write!(f, "cannot write {}: {op} failed: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for WriteError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            WriteError::Build { source, .. } => Some(source),
            WriteError::Io { source, .. } => Some(source),
        }
    }
}

/// Why an asset file could not be opened. Always names the path.
#[derive(Debug)]
#[non_exhaustive]
pub enum OpenError {
    /// The file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: io::Error,
    },
    /// The file was read but is not a valid asset.
    Invalid {
        /// The file.
        path: PathBuf,
        /// What the loader found wrong.
        source: LoadError,
    },
}

impl OpenError {
    /// The file.
    pub fn path(&self) -> &Path {
        match self {
            OpenError::Io { path, .. } | OpenError::Invalid { path, .. } => path,
        }
    }

    /// The loader's error, if the file was read but is invalid.
    pub fn load_error(&self) -> Option<&LoadError> {
        match self {
            OpenError::Invalid { source, .. } => Some(source),
            OpenError::Io { .. } => None,
        }
    }
}

impl fmt::Display for OpenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpenError::Io { path, source } => {
                write!(f, "cannot read asset {}: {source}", path.display())
            }
            OpenError::Invalid { path, source } => {
                write!(f, "invalid asset {}: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for OpenError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            OpenError::Io { source, .. } => Some(source),
            OpenError::Invalid { source, .. } => Some(source),
        }
    }
}

/// An asset file read into 64-byte aligned memory and validated: typed zero-copy views of its
/// sections always work (on little-endian targets).
#[derive(Debug, Clone)]
pub struct AssetFile {
    path: PathBuf,
    inner: OwnedAsset,
}

/// Reads the whole file into aligned memory.
fn read_aligned(path: &Path) -> io::Result<AlignedBuf> {
    let mut file = File::open(path)?;
    let len = file.metadata()?.len();
    let len = usize::try_from(len).map_err(|_| io::Error::new(io::ErrorKind::OutOfMemory, "file too large"))?;
    let mut buf = AlignedBuf::try_zeroed(len)
        .ok_or_else(|| io::Error::new(io::ErrorKind::OutOfMemory, format!("cannot allocate {len} bytes")))?;
    file.read_exact(buf.as_mut_slice())?;
    let mut probe = [0u8; 1];
    if file.read(&mut probe)? != 0 {
        return Err(io::Error::other("the file grew while it was being read"));
    }
    Ok(buf)
}

impl AssetFile {
    fn open_with(path: &Path, verify: bool) -> Result<AssetFile, OpenError> {
        let buf = read_aligned(path).map_err(|source| OpenError::Io { path: path.to_path_buf(), source })?;
        let inner = if verify { OwnedAsset::from_buf(buf) } else { OwnedAsset::from_buf_unverified(buf) };
        let inner = inner.map_err(|source| OpenError::Invalid { path: path.to_path_buf(), source })?;
        Ok(AssetFile { path: path.to_path_buf(), inner })
    }

    /// Reads `path` and validates it completely ([`Asset::parse`]).
    pub fn open(path: impl AsRef<Path>) -> Result<AssetFile, OpenError> {
        AssetFile::open_with(path.as_ref(), true)
    }

    /// Reads `path` and validates all but the section checksums ([`Asset::parse_unverified`]),
    /// e.g. to inspect a damaged file.
    pub fn open_unverified(path: impl AsRef<Path>) -> Result<AssetFile, OpenError> {
        AssetFile::open_with(path.as_ref(), false)
    }

    /// The path it was opened from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The validated asset (cheap: no re-validation).
    pub fn asset(&self) -> Asset<'_> {
        self.inner.asset()
    }

    /// The file bytes (64-byte aligned).
    pub fn bytes(&self) -> &[u8] {
        self.inner.bytes()
    }

    /// The asset without the path.
    pub fn into_owned(self) -> OwnedAsset {
        self.inner
    }
}

/// Distinguishes temporary files of one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Removes the temporary file unless disarmed (also on panic).
struct TempGuard(Option<PathBuf>);

impl Drop for TempGuard {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = fs::remove_file(p);
        }
    }
}

/// Writes `bytes` to `path` atomically: a temporary file `.{name}.tmp.{pid}.{n}` in the
/// target's directory is written, fsynced, renamed over the target, and the directory fsynced
/// (best-effort: some platforms cannot open or sync a directory). On any error the temporary
/// file is removed and an existing target is left untouched; readers never see a partial file.
/// The new file gets default permissions (those of an existing target are not kept).
pub fn write_file_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), WriteError> {
    let path = path.as_ref();
    let io_err = |op: &'static str| move |source| WriteError::Io { path: path.to_path_buf(), op, source };
    let file_name = path.file_name().ok_or_else(|| {
        io_err("take the file name")(io::Error::new(io::ErrorKind::InvalidInput, "the path has no file name"))
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };

    // Create the temporary file; retry on the (unlikely) name collision with a stale file.
    let (tmp, mut file) = {
        let mut attempt = 0;
        loop {
            let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
            let mut name = OsString::from(".");
            name.push(file_name);
            name.push(format!(".tmp.{}.{n}", std::process::id()));
            let tmp = dir.join(name);
            match OpenOptions::new().write(true).create_new(true).open(&tmp) {
                Ok(f) => break (tmp, f),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempt < 16 => attempt += 1,
                Err(e) => return Err(io_err("create a temporary file in the target directory")(e)),
            }
        }
    };
    let mut guard = TempGuard(Some(tmp.clone()));
    file.write_all(bytes).map_err(io_err("write the temporary file"))?;
    file.sync_all().map_err(io_err("sync the temporary file"))?;
    drop(file);
    fs::rename(&tmp, path).map_err(io_err("rename the temporary file over the target"))?;
    guard.0 = None;
    // Persist the rename. Best-effort: not every platform can open a directory for syncing.
    if let Ok(d) = File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

impl AssetBuilder {
    /// Encodes the asset and writes it to `path` with [`write_file_atomic`]. Returns the number
    /// of bytes written.
    pub fn write_atomic(&self, path: impl AsRef<Path>) -> Result<u64, WriteError> {
        let path = path.as_ref();
        let bytes = self.to_bytes().map_err(|source| WriteError::Build { path: path.to_path_buf(), source })?;
        write_file_atomic(path, &bytes)?;
        Ok(bytes.len() as u64)
    }
}
