#![allow(clippy::print_stderr, clippy::print_stdout)] // tests report skips on stderr
//! CLI integration tests: one test binary (DESIGN §1), on data the tests write themselves.
//! Real-data tests skip with a message when `../shared/data` is absent.

mod bake;
mod capi_mrt;
mod capi_shadows;
mod compat;
mod drt;
mod fiv;
mod gpu;
mod indirect;
mod inspect;
mod local_lights;
mod mrt;
mod mrt_level;
mod plan;
mod posed_spheres;
mod runtime;
mod shadows;
mod shadows_extremes;
mod spheres;
mod sweeps;
mod tables;
mod verify_shadows;
mod vo;

use assert_cmd::Command;
use std::path::{Path, PathBuf};

/// The `penumbra` binary with progress output off.
pub fn penumbra() -> Command {
    let mut c = Command::cargo_bin("penumbra").expect("penumbra binary");
    c.arg("--progress").arg("none");
    c
}

/// Runs and returns (exit code, stdout, stderr).
pub fn run(cmd: &mut Command) -> (i32, String, String) {
    let out = cmd.output().expect("run penumbra");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `../shared/data` (or `$PENUMBRA_SHARED_DATA`) if present.
pub fn shared_data() -> Option<PathBuf> {
    penumbra_testkit::shared_data("this test")
}

/// Files in a directory (for "no stray temp files" checks).
pub fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| r.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    v.sort();
    v
}
