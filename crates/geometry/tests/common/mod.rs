//! Shared helpers for tests that use the real data in `../shared/data`.
#![allow(dead_code, clippy::print_stderr)]

use std::path::PathBuf;

/// The shared data directory, or `None` (with a printed message) when it is absent.
pub fn shared_data(test: &str) -> Option<PathBuf> {
    penumbra_testkit::shared_data(test)
}
