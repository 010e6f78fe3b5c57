//! Shared helpers for tests that use the real data in `../shared/data`.
#![allow(dead_code, clippy::print_stderr)]

use std::path::PathBuf;

/// The shared data directory (`PENUMBRA_SHARED_DATA`, or `../../../shared/data` from this
/// crate), or `None` (with a printed message) when it is absent.
pub fn shared_data(test: &str) -> Option<PathBuf> {
    let dir = match std::env::var_os("PENUMBRA_SHARED_DATA") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    };
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping {test}: shared data directory {} not found (set PENUMBRA_SHARED_DATA)", dir.display());
        None
    }
}
