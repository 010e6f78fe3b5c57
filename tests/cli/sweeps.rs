//! `penumbra sweep tables` and `penumbra sweep fiv`: one row per grid point, consistent
//! Pareto flags, errors that fall with the knob that should lower them, and bad input
//! refused with exit 2 before anything is written.

use crate::{penumbra, run};
use serde_json::Value;

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// Every row flagged on the front of (x, y) is dominated by no row, and every row not
/// flagged is dominated by some row (both minimised).
fn assert_front(rows: &[Value], x: &str, y: &str, flag: &str) {
    let pt = |r: &Value| (num(&r[x]), num(&r[y]));
    let dominated = |p: (f64, f64)| {
        rows.iter().any(|q| {
            let (a, b) = pt(q);
            a <= p.0 && b <= p.1 && (a < p.0 || b < p.1)
        })
    };
    let mut on = 0;
    for r in rows {
        let flagged = r[flag].as_bool().unwrap_or_else(|| panic!("{flag} missing in {r}"));
        assert_eq!(flagged, !dominated(pt(r)), "{flag} of {r}");
        on += flagged as usize;
    }
    assert!(on >= 1, "{flag}: empty front");
}

/// The CSV's column `col` of every data line, as text.
fn csv_column(csv: &str, col: &str) -> Vec<String> {
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let i = head.iter().position(|h| *h == col).unwrap_or_else(|| panic!("no column {col} in {head:?}"));
    lines.map(|l| l.split(',').nth(i).unwrap().to_string()).collect()
}

#[test]
fn sweep_tables_error_falls_with_theta_samples_and_the_front_is_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let (code, stdout, stderr) = run(penumbra()
        .args(["sweep", "tables", "--orders", "2,3", "--theta-samples", "32,128,512", "--json", "-o"])
        .arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 6, "2 orders × 3 θ sample counts");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    assert!(csv.starts_with("order,theta_samples,bake_seconds,bytes,cap_log_nrmse"), "{csv}");
    for o in [2, 3] {
        let e: Vec<f64> = [32, 128, 512]
            .iter()
            .map(|&k| {
                let r = rows.iter().find(|r| r["order"] == o && r["theta_samples"] == k).unwrap();
                assert!(out.join(format!("tables-o{o}-k{k}.shtb")).is_file());
                num(&r["cap_log_nrmse"])
            })
            .collect();
        // linear interpolation: 4× finer steps cut the error at least 3× (h² away from the
        // clipping kinks, h at them); the f32 floor (~1e-7) is far below
        assert!(e[0] > 3.0 * e[1] && e[1] > 3.0 * e[2], "order {o}: cap log NRMSE {e:?}");
        assert!(e[2] > 0.0 && e[0] < 0.1, "order {o}: {e:?}");
        let b: Vec<f64> = [32, 128, 512]
            .iter()
            .map(|&k| num(&rows.iter().find(|r| r["order"] == o && r["theta_samples"] == k).unwrap()["bytes"]))
            .collect();
        assert!(b[0] < b[1] && b[1] < b[2], "bytes grow with θ samples: {b:?}");
    }
    assert_front(rows, "bake_seconds", "cap_log_nrmse", "pareto_seconds");
    assert_front(rows, "bytes", "cap_log_nrmse", "pareto_bytes");
    // the CSV carries the same flags
    let flags: Vec<String> = rows.iter().map(|r| r["pareto_bytes"].to_string()).collect();
    assert_eq!(csv_column(&csv, "pareto_bytes"), flags);
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.contains("Pareto front") && svg.contains("order 3"));
    let json: Value = serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["rows"], v["rows"]);
}

#[test]
fn sweep_tables_bad_input_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    for (args, want) in [
        (&["--theta-samples", "8,64"][..], ["--theta-samples", "16..=16384"]),
        // in range, but too coarse for the smooth clamp: found by the first bake, which
        // leaves nothing behind
        (&["--orders", "3", "--theta-samples", "64,16"][..], ["--theta-samples", "16"]),
        (&["--orders", "3,9"][..], ["--orders", "2..=8"]),
        (&["--orders", "3,x"][..], ["--orders", "\"x\""]),
    ] {
        let out = dir.path().join("never");
        let (code, _, stderr) = run(penumbra().args(["sweep", "tables"]).args(args).arg("-o").arg(&out));
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(want.iter().all(|w| stderr.contains(w)), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
}

const FIV: &[&str] = &["--mesh", "builtin:sphere", "--env", "builtin:area-lights", "--resolution", "24"];

#[test]
fn sweep_fiv_error_falls_with_samples_against_one_reference() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let (code, stdout, stderr) = run(penumbra()
        .args(["sweep", "fiv"])
        .args(FIV)
        .args(["--samples", "8x5x3,16x9x6,32x17x15", "--cube-size", "8,16", "--json", "-o"])
        .arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 6, "3 sample grids × 2 cube sizes");
    assert_eq!(v["points"], 6);
    assert_eq!(v["reference_cube_size"], 16);
    assert_eq!(v["receivers"], 24 * 24);
    // one reference: computed before the points, not per point
    assert_eq!(stderr.matches("reference:").count(), 1, "{stderr}");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    assert!(csv.starts_with("samples,sample_count,r_min,r_max,cube_size,bake_seconds,bytes"), "{csv}");
    for c in [8, 16] {
        let e: Vec<f64> = ["8x5x3", "16x9x6", "32x17x15"]
            .iter()
            .map(|s| {
                let r = rows.iter().find(|r| r["cube_size"] == c && r["samples"] == *s).unwrap();
                assert!(out.join(r["asset"].as_str().unwrap()).is_file());
                num(&r["nrmse"])
            })
            .collect();
        assert!(e[0] > e[1] && e[1] > e[2], "cube {c}: NRMSE {e:?} should fall with the shell samples");
        assert!(e[2] > 0.0 && e[2] < 0.2, "cube {c}: {e:?}");
    }
    // the finest point at the reference's own cube size is closer to it than at cube 8
    let at = |c: i64| num(&rows.iter().find(|r| r["cube_size"] == c && r["samples"] == "32x17x15").unwrap()["nrmse"]);
    assert!(at(16) < at(8), "cube 16 {} vs cube 8 {}", at(16), at(8));
    for (x, flag) in
        [("bake_seconds", "pareto_seconds"), ("ns_per_receiver", "pareto_runtime"), ("bytes", "pareto_bytes")]
    {
        assert_front(rows, x, "nrmse", flag);
    }
    let flags: Vec<String> = rows.iter().map(|r| r["pareto_seconds"].to_string()).collect();
    assert_eq!(csv_column(&csv, "pareto_seconds"), flags);
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.contains("Pareto front") && svg.contains("cube 16") && svg.contains("runtime"));
    assert!(num(&v["cost_over_max_point"]) >= 1.0);
}

#[test]
fn sweep_fiv_bad_input_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.obj");
    let m = missing.to_str().unwrap();
    let cases: [(Vec<&str>, Vec<&str>); 5] = [
        (
            vec!["--mesh", "builtin:sphere", "--env", "builtin:area-lights", "--samples", "16x9"],
            vec!["--samples", "AxPxK"],
        ),
        (vec!["--mesh", m, "--env", "builtin:area-lights"], vec!["missing.obj"]),
        (vec!["--mesh", "builtin:sphere", "--env", "nothere.hdr"], vec!["nothere.hdr"]),
        (
            vec!["--mesh", "builtin:sphere", "--env", "builtin:area-lights", "--r-min", "1,9"],
            vec!["--r-min 9", "r_max"],
        ),
        (
            vec!["--mesh", "builtin:sphere", "--env", "builtin:area-lights", "--cube-size", "8,0"],
            vec!["--cube-size", "1..=512"],
        ),
    ];
    for (args, want) in cases {
        let out = dir.path().join("never");
        let (code, _, stderr) = run(penumbra().args(["sweep", "fiv"]).args(&args).arg("-o").arg(&out));
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(want.iter().all(|w| stderr.contains(w)), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
}

#[test]
fn sweep_drt_reuses_the_rays_across_kc_to_a_standalone_bakes_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = crate::mrt_level::small_dict(dir.path());
    let out = dir.path().join("sw");
    let (code, stdout, stderr) = run(penumbra()
        .args(["sweep", "drt", "--example", "pillars", "--clutter-res", "4", "--rays", "32,256", "--kc", "2,5"])
        .args(["--reference-rays", "256", "--dict"])
        .arg(&d)
        .arg("-o")
        .arg(&out)
        .arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5);
    assert_front(rows, "bake_seconds", "rel_error_mrt_drt", "pareto_seconds");
    assert_front(rows, "bytes", "rel_error_mrt_drt", "pareto_bytes");
    // the second rank of each ray count assembles from the first one's sums
    let reused: Vec<bool> = rows.iter().map(|r| r["rays_reused"].as_bool().unwrap()).collect();
    assert_eq!(reused, [false, true, false, true]);
    // ... to the bytes `penumbra drt` writes for that point
    let own = dir.path().join("own.drto");
    let (code, _, stderr) = run(penumbra()
        .args(["drt", "--example", "pillars", "--clutter-res", "4", "--rays", "256", "--kc", "5", "--dict"])
        .arg(&d)
        .arg("-o")
        .arg(&own));
    assert_eq!(code, 0, "{stderr}");
    let swept = out.join(rows[3]["output"].as_str().unwrap());
    assert!(std::fs::read(&own).unwrap() == std::fs::read(swept).unwrap());
    // DRT beats MRT alone at every point, and more rays lower the scene error
    for r in rows {
        assert!(num(&r["rel_error_mrt_drt"]) < num(&r["rel_error_mrt"]), "{r}");
    }
    assert!(num(&rows[2]["rel_error_mrt_drt"]) < num(&rows[0]["rel_error_mrt_drt"]), "{v}");
    // a bad knob: exit 2, nothing written
    let bad = dir.path().join("bad");
    let (code, _, stderr) = run(penumbra()
        .args(["sweep", "drt", "--example", "pillars", "--kc", "2,0", "--dict"])
        .arg(&d)
        .arg("-o")
        .arg(&bad));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("kc"), "{stderr}");
    assert!(!bad.exists());
}

#[test]
fn sweep_mrt_error_falls_with_modes_and_each_dictionary_is_the_standalone_bake() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sw");
    let knobs = ["--face-res", "4", "--kd", "16", "--rays", "256", "--k-rlf", "16", "--k-r", "8"];
    let (code, stdout, stderr) = run(penumbra()
        .args(["sweep", "mrt", "--corridor", "3", "--kb", "4,12", "--reference-rays", "128"])
        .args(knobs)
        .arg("-o")
        .arg(&out)
        .arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(v["references"].as_array().unwrap().len(), 1, "one reference for one face-res");
    assert_eq!(std::fs::read_to_string(out.join("sweep.csv")).unwrap().lines().count(), 3);
    assert_front(rows, "bake_seconds", "rel_error_one_bounce", "pareto_seconds");
    assert_front(rows, "bytes", "rel_error_one_bounce", "pareto_bytes");
    // more modes, less error
    assert!(num(&rows[1]["rel_error_one_bounce"]) < num(&rows[0]["rel_error_one_bounce"]), "{v}");
    // each point's dictionary is what `penumbra mrt dict` writes for it
    let own = dir.path().join("own.mrtd");
    let (code, _, stderr) = run(penumbra().args(["mrt", "dict", "--kb", "12"]).args(knobs).arg("-o").arg(&own));
    assert_eq!(code, 0, "{stderr}");
    let swept = out.join(rows[1]["output"].as_str().unwrap());
    assert!(std::fs::read(&own).unwrap() == std::fs::read(swept).unwrap());
    // a point out of range (k_b above k_d): exit 2 before anything is written
    let bad = dir.path().join("bad");
    let (code, _, stderr) =
        run(penumbra().args(["sweep", "mrt", "--corridor", "3", "--kd", "16", "--kb", "8,20", "-o"]).arg(&bad));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("kb"), "{stderr}");
    assert!(!bad.exists());
}
