//! Dev-only helpers shared by the workspace's tests and benchmarks.
//!
//! - [`shared_data_dir`] / [`shared_data`]: where the real meshes, scenes and environment maps
//!   live (`../shared/data` next to the checkout, or `$PENUMBRA_SHARED_DATA`). Tests that need
//!   them skip with a message when the directory is absent, so a bare checkout still passes.
#![allow(clippy::print_stderr)]

pub mod gltf;

use std::path::PathBuf;

/// The shared data directory: `$PENUMBRA_SHARED_DATA` if set, else `shared/data` beside the
/// workspace root (the checkout's `../shared/data`). It may not exist.
pub fn shared_data_dir() -> PathBuf {
    match std::env::var_os("PENUMBRA_SHARED_DATA") {
        Some(d) => PathBuf::from(d),
        // this crate sits at <root>/crates/testkit
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    }
}

/// [`shared_data_dir`] when it exists; otherwise prints why `what` is skipped and returns
/// `None`.
pub fn shared_data(what: &str) -> Option<PathBuf> {
    let dir = shared_data_dir();
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping {what}: shared data directory {} not found (set PENUMBRA_SHARED_DATA)", dir.display());
        None
    }
}
