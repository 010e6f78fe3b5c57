use crate::{penumbra, run};
use serde_json::Value;

fn write_config(dir: &std::path::Path, body: &str) -> std::path::PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, body).unwrap();
    p
}

#[test]
fn bake_skips_up_to_date_stages_and_writes_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_config(dir.path(), "output_dir = \"out\"\n[tables]\norder = 3\ntheta_samples = 32\n");
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["status"], "baked");
    assert_eq!(v["stages"][0]["metrics"]["gamma_nonzeros"], 83);
    let asset = dir.path().join("out/tables.shtb");
    let first = std::fs::read(&asset).unwrap();
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/report.json")).unwrap()).unwrap();
    assert_eq!(report["stages"][0]["name"], "tables");

    let (code, stdout, _) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["status"], "up-to-date");
    assert_eq!(v["stages"][0]["metrics"]["gamma_nonzeros"], 83);

    // Same bytes as the standalone command with the same parameters.
    let standalone = dir.path().join("standalone.shtb");
    let (code, _, _) = run(penumbra().args(["tables", "--order", "3", "--theta-samples", "32", "-o"]).arg(&standalone));
    assert_eq!(code, 0);
    assert_eq!(std::fs::read(&standalone).unwrap(), first);

    // A parameter change invalidates the stage.
    write_config(dir.path(), "output_dir = \"out\"\n[tables]\norder = 3\ntheta_samples = 48\n");
    let (_, stdout, _) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["status"], "baked");
    // --force re-bakes; --shard selects work items
    let (_, stdout, _) = run(penumbra().arg("bake").arg(&cfg).args(["--force", "--json"]));
    assert_eq!(serde_json::from_str::<Value>(&stdout).unwrap()["stages"][0]["status"], "baked");
    let (_, stdout, _) = run(penumbra().arg("bake").arg(&cfg).args(["--shard", "1/2", "--json"]));
    assert_eq!(serde_json::from_str::<Value>(&stdout).unwrap()["stages"][0]["status"], "skipped-by-shard");
}

#[test]
fn bad_configs_name_file_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("output_dir = \"out\"\n[tables]\norder = 4\nthetasamples = 9\n", "scene.toml:4", "tables.thetasamples"),
        ("output_dir = \"out\"\n[tables]\norder = 12\n", "scene.toml:3", "2..=8"),
        ("output_dir = \"out\"\n[tables\n", "scene.toml:2", "syntax"),
        ("output_dir = 3\n[tables]\norder = 4\n", "scene.toml:1", "output_dir"),
    ];
    for (body, at, what) in cases {
        let cfg = write_config(dir.path(), body);
        let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
        assert_eq!(code, 2, "{body}");
        assert!(stderr.contains(at) && stderr.contains(what), "{body}: {stderr}");
        assert!(!dir.path().join("out").exists(), "no output for a bad config");
    }
    let cfg = write_config(dir.path(), "output_dir = \"out\"\n[tables]\norder = 2\ntheta_samples = 32\n");
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg).args(["--only", "spheres"]));
    assert_eq!(code, 2);
    assert!(stderr.contains("spheres"), "{stderr}");
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg).args(["--shard", "3/3"]));
    assert_eq!(code, 2);
    assert!(stderr.contains("K/N"), "{stderr}");
    let (code, _, stderr) = run(penumbra().arg("bake").arg(dir.path().join("none.toml")));
    assert_eq!(code, 2);
    assert!(stderr.contains("none.toml"), "{stderr}");
}

#[test]
fn committed_schema_is_current() {
    let (code, stdout, _) = run(penumbra().arg("schema"));
    assert_eq!(code, 0);
    let committed = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/schemas/bake-config.schema.json"))
        .expect("schemas/bake-config.schema.json (run `make schemas`)");
    assert_eq!(stdout, committed, "schemas/bake-config.schema.json is stale: run `make schemas`");
}

#[test]
fn every_bake_config_example_parses() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/bake-configs");
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            penumbra_config::load(&p).unwrap_or_else(|err| panic!("{err}"));
        }
    }
}

/// A stage `gate` runs the stage's verify after the bake: a bound above the measured value
/// exits 0; an impossible one (1e-9) exits 1, keeps the asset and names the stage and gate.
#[test]
fn bake_stage_gates_pass_and_fail_keeping_the_asset() {
    let dir = tempfile::tempdir().unwrap();
    let fiv = "[[fiv]]\nmesh = \"builtin:torus\"\nenv = \"builtin:area-lights\"\nsamples = [12, 7, 5]\ncube_size = 8\n";
    let cfg = write_config(dir.path(), &format!("output_dir = \"out\"\n{fiv}gate = {{ max_nrmse = 10.0 }}\n"));
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let g = &v["stages"][0]["gate"];
    assert_eq!(g["passed"], true, "{g}");
    let e = g["measured"]["nrmse"].as_f64().unwrap();
    assert!(e > 0.0 && e < 10.0, "{g}");
    assert_eq!(v["gates_passed"], true);
    let cfg = write_config(dir.path(), &format!("output_dir = \"out\"\n{fiv}gate = {{ max_nrmse = 1e-9 }}\n"));
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 1, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["gates_passed"], false);
    assert_eq!(v["failed_gates"][0]["stage"], "fiv[0]");
    assert_eq!(v["failed_gates"][0]["gate"], "max_nrmse");
    // the same bake (up to date): the same measured value
    assert_eq!(v["failed_gates"][0]["value"].as_f64().unwrap(), e);
    assert!(dir.path().join("out/torus.fivt").is_file());
    assert!(stderr.contains("quality gate failed: fiv[0]: nrmse"), "{stderr}");
    // a bound of the wrong kind is an unknown key, named with its path
    let cfg = write_config(dir.path(), &format!("output_dir = \"out\"\n{fiv}gate = {{ max_rel_error = 1 }}\n"));
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
    assert_eq!(code, 2);
    assert!(stderr.contains("fiv[0].gate") || stderr.contains("max_rel_error"), "{stderr}");
}
