use crate::{penumbra, run};
use serde_json::Value;

fn small_asset(dir: &std::path::Path) -> std::path::PathBuf {
    let out = dir.join("t.shtb");
    let (code, _, stderr) = run(penumbra().args(["tables", "--order", "2", "--theta-samples", "32", "-o"]).arg(&out));
    assert_eq!(code, 0, "{stderr}");
    out
}

#[test]
fn inspect_json_lists_sections_and_meta() {
    let dir = tempfile::tempdir().unwrap();
    let a = small_asset(dir.path());
    let (code, stdout, _) = run(penumbra().arg("inspect").arg(&a).arg("--json"));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["kind"], "SHTB");
    assert_eq!(v["format_version"], serde_json::json!([1, 0]));
    assert_eq!(v["bytes"].as_u64().unwrap(), std::fs::metadata(&a).unwrap().len());
    let names: Vec<&str> = v["sections"].as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap()).collect();
    for n in
        ["meta", "gamma_index", "gamma_value", "cap_log", "ol_ab", "proxy_log_occlusion", "indirect_m", "ohlsh_map"]
    {
        assert!(names.contains(&n), "{n} missing");
    }
    assert!(v["sections"].as_array().unwrap().iter().all(|s| s["checksum_ok"] == true));
    assert_eq!(v["meta"]["params"]["order"], 2);
}

#[test]
fn section_json_is_flat_row_major_with_exact_values() {
    let dir = tempfile::tempdir().unwrap();
    let a = small_asset(dir.path());
    let (code, stdout, _) = run(penumbra().arg("inspect").arg(&a).args(["--section", "gamma_value", "--json"]));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["name"], "gamma_value");
    assert_eq!(v["dtype"], "f32");
    let vals = v["values"].as_array().unwrap();
    assert_eq!(vals.len(), 10); // order 2: 10 nonzeros
    // Γ₀₀₀ = 1/(2√π) is the first entry (sorted by i, j, k)
    assert!((vals[0].as_f64().unwrap() - 0.282_094_79).abs() < 1e-7);
    let (code, stdout, _) = run(penumbra().arg("inspect").arg(&a).args(["--section", "cap_log", "--json"]));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["dims"], serde_json::json!([32, 2]));
    assert_eq!(v["values"].as_array().unwrap().len(), 64);
    // θ = 0: no blocker, log visibility 0
    assert_eq!(v["values"][0].as_f64().unwrap(), 0.0);
    // dump shows statistics for large sections and values for small ones
    let (code, stdout, _) = run(penumbra().arg("inspect").arg(&a).args(["--dump", "--json"]));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let secs = v["sections"].as_array().unwrap();
    let eta = secs.iter().find(|s| s["name"] == "eta").unwrap();
    assert_eq!(eta["values"].as_array().unwrap().len(), 4);
    let m = secs.iter().find(|s| s["name"] == "indirect_m").unwrap();
    assert_eq!(m["summary"]["count"], 32 * 81);
}

#[test]
fn damaged_asset_names_the_section_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let a = small_asset(dir.path());
    let mut bytes = std::fs::read(&a).unwrap();
    // flip a byte in the last section's data (the end of the file)
    let n = bytes.len();
    bytes[n - 3] ^= 0x40;
    std::fs::write(&a, &bytes).unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("inspect").arg(&a));
    assert_eq!(code, 2);
    assert!(stdout.contains("NO"), "{stdout}");
    assert!(stderr.contains("ohlsh_map"), "{stderr}");
    let (code, _, stderr) = run(penumbra().arg("inspect").arg(&a).args(["--section", "ohlsh_map", "--json"]));
    assert_eq!(code, 2);
    assert!(stderr.contains("checksum"), "{stderr}");
}

#[test]
fn not_an_asset_and_missing_file_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.bin");
    std::fs::write(&junk, b"hello, this is not an asset at all........................................").unwrap();
    let (code, _, stderr) = run(penumbra().arg("inspect").arg(&junk));
    assert_eq!(code, 2);
    assert!(stderr.contains("junk.bin"), "{stderr}");
    let (code, _, stderr) = run(penumbra().arg("inspect").arg(dir.path().join("missing.shtb")));
    assert_eq!(code, 2);
    assert!(stderr.contains("missing.shtb"), "{stderr}");
    let a = small_asset(dir.path());
    let (code, _, stderr) = run(penumbra().arg("inspect").arg(&a).args(["--section", "nope"]));
    assert_eq!(code, 2);
    assert!(stderr.contains("nope") && stderr.contains("gamma_value"), "{stderr}");
}

#[test]
fn a_reader_that_closes_the_pipe_early_is_not_a_crash() {
    // `penumbra … --json | grep -q …` under `set -o pipefail`: the reader is gone before the
    // report is written; println! would panic (exit 101). The command keeps its own exit code.
    let dir = tempfile::tempdir().unwrap();
    let a = small_asset(dir.path());
    for args in [vec!["--json"], vec![], vec!["--section", "cap_log", "--json"]] {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
            .args(["--progress", "none", "inspect"])
            .arg(&a)
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // close the read end before the child writes
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}
