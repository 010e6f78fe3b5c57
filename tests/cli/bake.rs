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

/// A `.gltf` whose geometry lives in an external `mesh.bin` (a box `[0, s]³`, 8 vertices,
/// 12 triangles); the JSON does not change with `s`.
fn write_external_gltf(dir: &std::path::Path, s: f32) {
    let (v, t) = penumbra_testkit::gltf::cuboid([0.0; 3], [s; 3]);
    let mut bin: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let plen = bin.len();
    bin.extend(t.iter().flatten().flat_map(|x| x.to_le_bytes()));
    std::fs::write(dir.join("mesh.bin"), &bin).unwrap();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"name":"box"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"buffers":[{{"byteLength":{},"uri":"mesh.bin"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{plen}}},{{"buffer":0,"byteOffset":{plen},"byteLength":{}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[10,10,10]}},
{{"bufferView":1,"componentType":5125,"count":36,"type":"SCALAR"}}]}}"#,
        bin.len(),
        bin.len() - plen
    );
    std::fs::write(dir.join("box.gltf"), json).unwrap();
}

fn bake_json(cfg: &std::path::Path, extra: &[&str]) -> Value {
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(cfg).arg("--json").args(extra));
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).unwrap()
}

#[test]
fn an_edited_external_buffer_re_bakes_the_stages_that_read_it() {
    // the cache key once hashed only the .gltf, so a changed .bin left stale assets "up-to-date"
    let dir = tempfile::tempdir().unwrap();
    write_external_gltf(dir.path(), 1.0);
    let cfg = write_config(
        dir.path(),
        "output_dir = \"out\"\n[[spheres]]\nmesh = \"box.gltf\"\ncount = 2\ngrid = 16\n\
         [[fiv]]\nmesh = \"box.gltf\"\nenv = \"builtin:area-lights\"\nsamples = [8, 5, 3]\ncube_size = 8\nirradiance_size = 8\n",
    );
    let v = bake_json(&cfg, &[]);
    assert_eq!(v["stages"][0]["status"], "baked");
    assert_eq!(v["stages"][1]["status"], "baked");
    let first = std::fs::read(v["stages"][0]["output"].as_str().unwrap()).unwrap();
    let v = bake_json(&cfg, &[]);
    assert_eq!(v["stages"][0]["status"], "up-to-date");
    assert_eq!(v["stages"][1]["status"], "up-to-date");
    write_external_gltf(dir.path(), 2.0);
    let v = bake_json(&cfg, &[]);
    assert_eq!(v["stages"][0]["status"], "baked", "{v}");
    assert_eq!(v["stages"][1]["status"], "baked", "{v}");
    let second = std::fs::read(v["stages"][0]["output"].as_str().unwrap()).unwrap();
    assert_ne!(first, second);
}

#[test]
fn every_knob_and_input_changes_the_cache_key() {
    let dir = tempfile::tempdir().unwrap();
    write_external_gltf(dir.path(), 1.0);
    std::fs::copy(dir.path().join("mesh.bin"), dir.path().join("mesh1.bin")).unwrap();
    let spheres = "[[spheres]]\nmesh = \"box.gltf\"\ngrid = 16\n";
    let fiv = "[[fiv]]\nmesh = \"box.gltf\"\nenv = \"builtin:area-lights\"\ncube_size = 8\nirradiance_size = 8\n";
    // (stage index in the report, config body): each differs from the first in one thing
    let variants: &[(usize, String)] = &[
        (0, format!("{spheres}count = 2\n")),
        (0, format!("{spheres}count = 3\n")),
        (0, format!("{spheres}count = 2\nseed = 7\n")),
        (0, format!("{spheres}count = 2\niterations = 3\n")),
        (0, format!("{spheres}count = 2\nmethod = \"octree\"\n")),
        (0, format!("{spheres}count = 2\nhierarchy = true\n")),
        (0, format!("{spheres}count = 2\npolish = true\n")),
        (0, format!("{spheres}count = 2\nalbedo = [0.5, 0.5, 0.5]\n")),
        (0, format!("{spheres}count = 2\nnode = \"box\"\n")),
        (0, format!("{spheres}target_error = 0.5\n")),
        (0, "[[spheres]]\nmesh = \"box.gltf\"\ngrid = 20\ncount = 2\n".into()),
        (0, format!("{fiv}samples = [8, 5, 3]\n")),
        (0, format!("{fiv}samples = [8, 5, 4]\n")),
        (0, format!("{fiv}samples = [8, 5, 3]\nr_min = 1.5\n")),
        (0, format!("{fiv}samples = [8, 5, 3]\nr_max = 6.0\n")),
        (0, format!("{fiv}samples = [8, 5, 3]\nup = \"z\"\n")),
        (0, format!("{fiv}samples = [8, 5, 3]\nhalf = true\n")),
        (0, format!("{fiv}samples = [8, 5, 3]\nenv_rotate = \"y180\"\n")),
        (0, format!("{fiv}samples = [8, 5, 3]\nnode = \"b*\"\n")),
        (0, "[[fiv]]\nmesh = \"box.gltf\"\nenv = \"builtin:area-lights\"\ncube_size = 16\nirradiance_size = 8\nsamples = [8, 5, 3]\n".into()),
        (0, "[[fiv]]\nmesh = \"builtin:sphere\"\nenv = \"builtin:area-lights\"\ncube_size = 8\nirradiance_size = 8\nsamples = [8, 5, 3]\n".into()),
        (0, "[tables]\norder = 3\ntheta_samples = 32\n".into()),
        (0, "[tables]\norder = 4\ntheta_samples = 64\n".into()),
        (0, "[tables]\norder = 3\ntheta_samples = 48\n".into()),
    ];
    let mut keys = std::collections::HashSet::new();
    for (i, (stage, body)) in variants.iter().enumerate() {
        let cfg = write_config(dir.path(), &format!("output_dir = \"out{i}\"\n{body}"));
        let v = bake_json(&cfg, &[]);
        let s = &v["stages"][*stage];
        assert_eq!(s["status"], "baked", "{body}: {v}");
        assert!(keys.insert(s["cache_key"].as_str().unwrap().to_string()), "{body}: key not new");
        // the same config is up to date (the key is a function of the config and inputs)
        assert_eq!(bake_json(&cfg, &[])["stages"][*stage]["status"], "up-to-date", "{body}");
    }
    // the external buffer's bytes: same JSON, other .bin → other key
    let cfg = write_config(dir.path(), &format!("output_dir = \"out0\"\n{}", variants[0].1));
    write_external_gltf(dir.path(), 1.5);
    let v = bake_json(&cfg, &[]);
    assert_eq!(v["stages"][0]["status"], "baked");
    assert!(keys.insert(v["stages"][0]["cache_key"].as_str().unwrap().to_string()));
}

#[test]
fn a_shared_cache_dir_serves_equal_keys_and_read_only_never_writes() {
    let dir = tempfile::tempdir().unwrap();
    let body = "[tables]\norder = 3\ntheta_samples = 32\n";
    let a = write_config(dir.path(), &format!("output_dir = \"a\"\n{body}"));
    let cache = dir.path().join("cache");
    let cache_s = cache.to_str().unwrap();
    let v = bake_json(&a, &["--cache-dir", cache_s]);
    assert_eq!(v["stages"][0]["status"], "baked");
    assert_eq!(v["stages"][0]["cache"]["stored"], true);
    let key = v["stages"][0]["cache_key"].as_str().unwrap().to_string();
    let entry = cache.join(format!("{key}.shtb"));
    let baked = std::fs::read(dir.path().join("a/tables.shtb")).unwrap();
    assert_eq!(std::fs::read(&entry).unwrap(), baked);

    // another output directory (another machine) gets the same bytes without baking
    let b = dir.path().join("b.toml");
    std::fs::write(&b, format!("output_dir = \"b\"\n{body}")).unwrap();
    let v = bake_json(&b, &["--cache-dir", cache_s, "--cache-read-only"]);
    assert_eq!(v["stages"][0]["status"], "from-cache", "{v}");
    assert_eq!(v["stages"][0]["metrics"]["gamma_nonzeros"], 83);
    assert_eq!(std::fs::read(dir.path().join("b/tables.shtb")).unwrap(), baked);

    // a damaged entry is a miss, never a corrupt output
    let mut bad = baked.clone();
    let n = bad.len();
    bad[n - 5] ^= 0xff;
    std::fs::write(&entry, &bad).unwrap();
    std::fs::remove_dir_all(dir.path().join("b")).unwrap();
    let v = bake_json(&b, &["--cache-dir", cache_s, "--cache-read-only"]);
    assert_eq!(v["stages"][0]["status"], "baked");
    assert!(v["stages"][0]["cache"]["why"].as_str().unwrap().starts_with("entry ignored"), "{v}");
    assert_eq!(v["stages"][0]["cache"]["stored"], false);
    assert_eq!(std::fs::read(&entry).unwrap(), bad, "read-only wrote the cache");
    assert_eq!(std::fs::read(dir.path().join("b/tables.shtb")).unwrap(), baked);

    // read-only against an empty cache bakes and leaves the directory alone
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let v = bake_json(&a, &["--force", "--cache-dir", empty.to_str().unwrap(), "--cache-read-only"]);
    assert_eq!(v["stages"][0]["status"], "baked");
    assert_eq!(std::fs::read_dir(&empty).unwrap().count(), 0);
    // --cache-read-only needs --cache-dir
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&a).arg("--cache-read-only"));
    assert_eq!(code, 2, "{stderr}");
}

/// A config with every independent kind of work item and the `mrt` → `mrt_level` chain.
const SHARDED: &str = "[tables]\norder = 3\ntheta_samples = 32\n\
[[spheres]]\nmesh = \"CHARACTER\"\ncount = 6\ngrid = 16\n\
[[fiv]]\nmesh = \"builtin:torus\"\nenv = \"builtin:area-lights\"\nsamples = [8, 5, 4]\ncube_size = 8\n\
[mrt]\nface_res = 4\nrays = 512\nkd = 24\nkb = 12\nvector_rays = 64\nvolume_res = 2\nprobe_rays = 64\ntest_lights = 3\n\
reference_rays = 128\nlf_spatial = 4\nlf_dir = 6\nlf_super = 2\nk_rlf = 24\nk_r = 8\nresponse_rays = 64\n\
[mrt_level]\nmaze = 3\nseed = 1\n";

#[test]
fn sharded_bakes_in_separate_directories_merge_to_the_single_runs_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let character = concat!(env!("CARGO_MANIFEST_DIR"), "/bake-configs/assets/character.obj");
    let cfg =
        write_config(dir.path(), &format!("output_dir = \"single\"\n{}", SHARDED.replace("CHARACTER", character)));
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
    assert_eq!(code, 0, "{stderr}");
    // N local processes, as a batch system's array job runs them
    let shard_dir = |k: usize| dir.path().join(format!("s{k}"));
    for k in 0..3 {
        let (code, _, stderr) = run(penumbra()
            .arg("bake")
            .arg(&cfg)
            .args(["--shard", &format!("{k}/3"), "--output-dir"])
            .arg(shard_dir(k)));
        assert_eq!(code, 0, "{stderr}");
    }
    // the level's stage runs beside its dictionary's
    let report = |k: usize| -> Value {
        serde_json::from_str(
            &std::fs::read_to_string(shard_dir(k).join(format!("report.shard-{k}-of-3.json"))).unwrap(),
        )
        .unwrap()
    };
    let ran = |k: usize, name: &str| {
        report(k)["stages"].as_array().unwrap().iter().any(|s| s["name"] == name && s["status"] == "baked")
    };
    let k_mrt = (0..3).find(|&k| ran(k, "mrt")).unwrap();
    assert!(ran(k_mrt, "mrt_level"));
    let merged = dir.path().join("merged");
    let (code, stdout, stderr) =
        run(penumbra().args(["bake", "merge"]).args((0..3).map(shard_dir)).arg("-o").arg(&merged).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let m: Value = serde_json::from_str(&stdout).unwrap();
    let single: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("single/report.json")).unwrap()).unwrap();
    let names = |v: &Value| -> Vec<(Value, Value)> {
        v["stages"].as_array().unwrap().iter().map(|s| (s["name"].clone(), s["status"].clone())).collect()
    };
    assert_eq!(names(&m), names(&single));
    assert_eq!(m["shard"], Value::Null);
    // the same files, byte for byte
    let list = |d: &std::path::Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .filter(|n| !n.starts_with("report."))
            .collect();
        v.sort();
        v
    };
    let files = list(&dir.path().join("single"));
    assert_eq!(files.len(), 5, "{files:?}");
    assert_eq!(list(&merged), files);
    for f in &files {
        assert!(
            std::fs::read(merged.join(f)).unwrap() == std::fs::read(dir.path().join("single").join(f)).unwrap(),
            "{f}"
        );
    }
    // a missing shard, a shard given twice: exit 2, named
    let (code, _, stderr) =
        run(penumbra().args(["bake", "merge"]).arg(shard_dir(0)).arg(shard_dir(1)).arg("-o").arg(dir.path().join("x")));
    assert_eq!(code, 2);
    assert!(stderr.contains("shard 2/3 is missing"), "{stderr}");
    let (code, _, stderr) = run(penumbra()
        .args(["bake", "merge"])
        .arg(shard_dir(0))
        .arg(shard_dir(0))
        .arg(shard_dir(1))
        .arg("-o")
        .arg(dir.path().join("x")));
    assert_eq!(code, 2);
    assert!(stderr.contains("given twice"), "{stderr}");
}
