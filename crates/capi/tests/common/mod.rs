//! Compiling and running C/C++ code from the tests with the system compiler.
#![allow(dead_code, clippy::print_stderr)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

/// The workspace root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `$CC` (default `cc`) if it runs; otherwise prints why `what` is skipped and returns None.
pub fn compiler(var: &str, default: &str, what: &str) -> Option<String> {
    let cc = std::env::var(var).unwrap_or_else(|_| default.to_string());
    match Command::new(&cc).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status() {
        Ok(s) if s.success() => Some(cc),
        _ => {
            eprintln!("skipping {what}: no C/C++ compiler `{cc}` (set {var})");
            None
        }
    }
}

/// Compiles `sources` into `out` with `flags`; panics with the compiler's output on failure.
pub fn build(cc: &str, sources: &[PathBuf], flags: &[&str], out: &Path) {
    let output = Command::new(cc)
        .args(flags)
        .arg("-I")
        .arg(root().join("include"))
        .args(sources)
        .arg("-o")
        .arg(out)
        .output()
        .expect("run the compiler");
    assert!(
        output.status.success(),
        "compiling {sources:?} failed:\n{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}

/// The strict flags every C test build uses: warnings are errors, sanitizers abort on the first
/// report (so a report fails the run).
pub const C_FLAGS: &[&str] = &[
    "-std=c99",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-pedantic",
    "-g",
    "-O1",
    "-fsanitize=address,undefined",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
];

/// This crate's static library, built by a nested `cargo build` into the target directory
/// the tests run from (cargo does not build the staticlib for integration tests).
pub fn staticlib() -> PathBuf {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        let profile_dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf(); // target/<profile>
        let target_dir = profile_dir.parent().unwrap();
        let mut cmd = Command::new(env!("CARGO"));
        cmd.args(["build", "--quiet", "-p", "penumbra-capi", "--lib", "--target-dir"]).arg(target_dir);
        if profile_dir.file_name().is_some_and(|n| n == "release") {
            cmd.arg("--release");
        }
        let status = cmd.current_dir(root()).status().expect("run cargo build");
        assert!(status.success(), "cargo build -p penumbra-capi failed");
        profile_dir.join("libpenumbra_capi.a")
    })
    .clone()
}
