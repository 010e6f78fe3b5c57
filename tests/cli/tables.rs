use crate::{listing, penumbra, run, shared_data};
use serde_json::Value;

fn bake_json(args: &[&str], out: &std::path::Path) -> Value {
    let (code, stdout, stderr) = run(penumbra().arg("tables").args(args).arg("-o").arg(out).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).expect("one JSON object on stdout")
}

#[test]
fn json_keys_are_present_and_honest() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t3.shtb");
    let v = bake_json(&["--order", "3", "--theta-samples", "64"], &out);
    for key in [
        "order",
        "gamma_nonzeros",
        "eta_shadow",
        "eta_shadow_windowed",
        "eta_indirect",
        "ol_accurate_norm",
        "roundtrip_rel_error_eigen",
        "roundtrip_rel_error_naive",
        "d_fit_rel_sq_error",
        "cap_log_samples",
        "bytes",
        "seconds",
        "output",
    ] {
        assert!(v.get(key).is_some(), "missing key {key}");
    }
    assert_eq!(v["order"], 3);
    assert_eq!(v["gamma_nonzeros"], 83);
    assert_eq!(v["bytes"].as_u64().unwrap(), std::fs::metadata(&out).unwrap().len());
    assert_eq!(v["output"].as_str().unwrap(), out.display().to_string());
    let eta = v["eta_shadow"].as_f64().unwrap();
    assert!((eta - 20.08).abs() < 0.05, "order-3 η {eta}");
    assert!(v["roundtrip_rel_error_eigen"].as_f64().unwrap() < v["roundtrip_rel_error_naive"].as_f64().unwrap());
    let d = &v["d_fit_rel_sq_error"];
    assert!(d["D1"].as_f64().unwrap() > 0.0 && d["D2"].as_f64().unwrap() > 0.0);
    let samples = v["cap_log_samples"].as_array().unwrap();
    let thetas: Vec<f64> = samples.iter().map(|s| s["theta_deg"].as_f64().unwrap()).collect();
    assert_eq!(thetas, vec![22.5, 45.0, 67.5, 90.0]);
    for s in samples {
        assert_eq!(s["f"].as_array().unwrap().len(), 3);
        // log of a visibility ≤ 1 has a negative DC
        assert!(s["f"][0].as_f64().unwrap() < 0.0);
        assert!(s["a"].is_number() && s["b"].is_number());
    }
}

#[test]
fn order_out_of_range_is_rejected_with_the_allowed_range() {
    let dir = tempfile::tempdir().unwrap();
    for bad in ["1", "9"] {
        let out = dir.path().join("x.shtb");
        let (code, _, stderr) = run(penumbra().args(["tables", "--order", bad, "-o"]).arg(&out));
        assert_eq!(code, 2);
        assert!(stderr.contains("2..=8"), "{stderr}");
        assert!(!out.exists());
    }
    let (code, _, stderr) =
        run(penumbra().args(["tables", "--order", "4", "--shading-tolerance", "1.5", "-o"]).arg(dir.path().join("y")));
    assert_eq!(code, 2);
    assert!(stderr.contains("0 < T < 1"), "{stderr}");
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn same_bytes_for_any_thread_count_and_across_runs() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (i, threads) in ["1", "2", "2"].iter().enumerate() {
        let out = dir.path().join(format!("t{i}.shtb"));
        let (code, _, stderr) = run(penumbra()
            .args(["--threads", threads, "tables", "--order", "4", "--theta-samples", "64", "-o"])
            .arg(&out));
        assert_eq!(code, 0, "{stderr}");
        files.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(files[0], files[1], "--threads 1 vs 2");
    assert_eq!(files[1], files[2], "two runs");
}

#[test]
fn unwritable_output_fails_cleanly_without_partial_files() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, b"x").unwrap();
    // parent of the output is a regular file
    let (code, _, stderr) =
        run(penumbra().args(["tables", "--order", "2", "--theta-samples", "32", "-o"]).arg(blocker.join("t.shtb")));
    assert_eq!(code, 2);
    assert!(stderr.contains("file"), "{stderr}");
    // output path is an existing directory: nothing is clobbered, no temp file is left
    let target = dir.path().join("adir");
    std::fs::create_dir(&target).unwrap();
    let (code, _, _) = run(penumbra().args(["tables", "--order", "2", "--theta-samples", "32", "-o"]).arg(&target));
    assert_eq!(code, 2);
    assert!(target.is_dir());
    assert_eq!(listing(dir.path()), vec!["adir".to_string(), "file".to_string()]);
}

#[test]
fn env_lighting_specialises_eta() {
    let Some(data) = shared_data() else { return };
    let env = data.join("env/probes_small/uffizi_256x128.hdr");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("env.shtb");
    let v = bake_json(&["--order", "4", "--theta-samples", "64", "--env", env.to_str().unwrap()], &out);
    assert_eq!(v["eta_shadow_source"], "env");
    let (e, d) = (v["eta_shadow"].as_f64().unwrap(), v["eta_shadow_delta"].as_f64().unwrap());
    // The delta light is the worst case: a real environment never needs a larger η.
    assert!(e > 1.0 && e <= d + 1e-9, "env η {e} vs delta η {d}");
    // A missing env file is a clean input error naming the file.
    let (code, _, stderr) =
        run(penumbra().args(["tables", "--order", "3", "--env", "no-such.hdr", "-o"]).arg(dir.path().join("x.shtb")));
    assert_eq!(code, 2);
    assert!(stderr.contains("no-such.hdr"), "{stderr}");
}
