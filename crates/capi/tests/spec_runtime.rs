//! `schemas/asset-format.md` §15 is complete: a C++ program written from its text alone
//! (`tests/cpp/spec_runtime.cpp`: the FIV lookup with the `(ρ̂_k/ρ̂)²` weighting and far-field fall-off, clamps,
//! inside-corner renormalisation and overlap sum; the unoccluded irradiance lookup; the MRT
//! one-bounce step with the same-face rule and interfaces) reproduces the runtime behind the C
//! ABI to 1e-5 relative (relative to `max(|runtime|, 1e-3·max|runtime|)`), on 4000 random
//! receivers from inside the ball to beyond `r_max` and every texel of a level. Skips with a
//! message when there is no C++ compiler.
#![allow(clippy::print_stderr)]

mod common;

use std::path::PathBuf;
use std::process::Command;

fn check(exe: &std::path::Path, fivt: PathBuf, dict: PathBuf, level: PathBuf) {
    let out = Command::new(exe).arg(&fivt).arg(&dict).arg(&level).output().unwrap();
    assert!(out.status.success() && out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let mut seen = Vec::new();
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let (err, n, nonzero): (f64, usize, usize) =
            (w[1].parse().unwrap(), w[2].parse().unwrap(), w[3].parse().unwrap());
        assert!(err <= 1e-5, "{}: {line}", fivt.display());
        // enough values, and enough of them non-zero, for the comparison to mean something
        assert!(n >= 200 && nonzero * 4 >= n, "{line}");
        seen.push(w[0].to_string());
    }
    assert_eq!(seen, ["fiv_occluded", "fiv_overlap", "fiv_irradiance", "mrt_one_bounce"]);
    eprintln!("spec vs runtime ({}):\n{text}", fivt.display());
}

#[test]
fn a_cpp_reading_of_the_spec_matches_the_runtime() {
    let Some(cxx) = common::compiler("CXX", "c++", "the spec-vs-runtime C++ test") else { return };
    let exe = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("spec_runtime");
    let mut flags: Vec<&str> = common::C_FLAGS.to_vec();
    flags[0] = "-std=c++17";
    let lib = common::staticlib();
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/cpp/spec_runtime.cpp");
    flags.extend(["-lpthread", "-ldl", "-lm"]);
    common::build(&cxx, &[src, lib], &flags, &exe);
    let v1 = common::root().join("tests/assets/v1");
    check(
        &exe,
        v1.join("fiv-torus-8x5x4.fivt"),
        v1.join("mrt-cube2d-r4-interfaces.mrtd"),
        v1.join("mrt-corridor3.mrtl"),
    );
    let demo = common::root().join("out/demo");
    if demo.join("torus.fivt").is_file() && demo.join("level.mrtl").is_file() {
        check(&exe, demo.join("torus.fivt"), demo.join("dictionary.mrtd"), demo.join("level.mrtl"));
    } else {
        eprintln!("demo outputs not baked: corpus only");
    }
}
