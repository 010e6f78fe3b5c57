use crate::{listing, penumbra, run, shared_data};
use penumbra_asset::AssetFile;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn character() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("bake-configs/assets/character.obj")
}

/// A small, quick fit of the demo character.
fn fit(out: &Path, extra: &[&str]) -> (i32, String, String) {
    let mut c = penumbra();
    c.arg("spheres").arg(character()).args(["--grid", "20", "--iterations", "8"]).args(extra).arg("-o").arg(out);
    run(&mut c)
}

#[test]
fn committed_demo_character_is_what_the_generator_writes() {
    let committed = std::fs::read_to_string(character()).unwrap();
    assert!(
        committed == penumbra_geometry::procedural::demo_character_obj(),
        "bake-configs/assets/character.obj is stale: run `cargo run -p penumbra-geometry --example demo_character > bake-configs/assets/character.obj`"
    );
}

#[test]
fn spheres_json_has_the_issue_keys_with_honest_values() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.sphr");
    let (code, stdout, stderr) = fit(&out, &["--count", "12", "--hierarchy", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    for k in [
        "count",
        "outside_volume_ratio",
        "union_outside_ratio",
        "uncovered_ratio",
        "max_uncovered_distance",
        "iterations",
        "hierarchy_levels",
        "skin_coverage_min",
        "seconds",
        "output",
    ] {
        assert!(v.get(k).is_some(), "missing key {k}: {stdout}");
    }
    assert_eq!(v["count"], 12);
    let e = v["outside_volume_ratio"].as_f64().unwrap();
    let u = v["union_outside_ratio"].as_f64().unwrap();
    // overlaps are counted once in the union, every time in E
    assert!(u > 0.0 && u <= e + 4.0 * v["outside_volume_ratio_stderr"].as_f64().unwrap(), "{u} vs {e}");
    assert_eq!(v["max_uncovered_distance"].as_f64().unwrap(), 0.0);
    assert!(v["uncovered_ratio"].as_f64().unwrap() < 1e-3);
    assert_eq!(v["hierarchy_levels"], 2, "12 leaves → 3 → 1: two internal levels");
    assert_eq!(v["hierarchy_levels_with_leaves"], 3);
    assert!(v["requested_count"] == 12 && v["settled_count"].is_null(), "{stdout}");
    assert!(v["skin_coverage_min"].is_null());
    assert_eq!(v["output"].as_str().unwrap(), out.display().to_string());
    // the asset holds what the JSON says
    let file = AssetFile::open(&out).unwrap();
    let a = file.asset();
    let s = a.section("spheres").unwrap();
    assert_eq!(s.dims(), &[12, 4]);
    // the JSON key counts what the SPHR section holds
    let levels = a.section("hierarchy_levels").unwrap().dims()[0];
    assert_eq!(a.section("hierarchy_levels").unwrap().dims(), &[2, 2]);
    assert_eq!(v["hierarchy_levels"], levels);
    let meta: Value = serde_json::from_str(a.meta_json()).unwrap();
    assert_eq!(meta["kind"], "SPHR");
    assert!(
        meta["metrics"].get("seconds").is_none() && meta["metrics"].get("fit_seconds").is_none(),
        "no durations in meta"
    );
    assert_eq!(meta["metrics"]["outside_volume_ratio"], v["outside_volume_ratio"]);
}

#[test]
fn spheres_bytes_do_not_depend_on_threads_or_runs() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = Vec::new();
    for (i, threads) in ["1", "2", "2"].iter().enumerate() {
        let out = dir.path().join(format!("c{i}.sphr"));
        let mut c = penumbra();
        c.args(["--threads", threads, "spheres"])
            .arg(character())
            .args(["--count", "10", "--grid", "20", "--iterations", "6", "--hierarchy", "-o"])
            .arg(&out);
        let (code, _, stderr) = run(&mut c);
        assert_eq!(code, 0, "{stderr}");
        bytes.push(std::fs::read(&out).unwrap());
    }
    assert!(
        bytes[0] == bytes[1] && bytes[1] == bytes[2],
        "SPHR bytes differ between --threads 1 and 2 or between runs"
    );
}

#[test]
fn octree_baseline_and_export() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.sphr");
    let (code, stdout, stderr) = fit(&out, &["--count", "20", "--method", "octree", "--hierarchy", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let n = v["count"].as_u64().unwrap() as usize;
    assert!(v["octree_level"].as_u64().is_some());
    assert!(n > 5 && n < 80, "about the requested count: {n}");
    // export: one 80-triangle icosphere (42 vertices) per sphere
    let obj = dir.path().join("o.obj");
    let (code, _, stderr) =
        run(penumbra().args(["spheres", "export"]).arg(&out).arg("--obj").arg(&obj).args(["--subdivisions", "1"]));
    assert_eq!(code, 0, "{stderr}");
    let text = std::fs::read_to_string(&obj).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 42 * n);
    assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 80 * n);
    // a hierarchy level, and a level that does not exist
    let (code, _, _) =
        run(penumbra().args(["spheres", "export"]).arg(&out).arg("--obj").arg(&obj).args(["--level", "0"]));
    assert_eq!(code, 0);
    assert_eq!(std::fs::read_to_string(&obj).unwrap().lines().filter(|l| l.starts_with("o ")).count(), 1);
    let (code, _, stderr) =
        run(penumbra().args(["spheres", "export"]).arg(&out).arg("--obj").arg(&obj).args(["--level", "99"]));
    assert_eq!(code, 2);
    assert!(stderr.contains("out of range"), "{stderr}");
}

#[test]
fn bad_spheres_input_exits_2_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.sphr");
    let missing = dir.path().join("missing.obj");
    let (code, _, stderr) = run(penumbra().arg("spheres").arg(&missing).args(["--count", "4", "-o"]).arg(&out));
    assert_eq!(code, 2);
    assert!(stderr.contains("missing.obj"), "{stderr}");
    let (code, _, _) = fit(&out, &["--count", "0"]);
    assert_eq!(code, 2);
    let (code, _, _) = fit(&out, &["--count", "4", "--target-error", "0.5"]);
    assert_eq!(code, 2);
    let (code, _, stderr) = fit(&out, &["--count", "4", "--skin"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("no skin"), "{stderr}");
    let (code, _, stderr) = fit(&out, &["--count", "4", "--mesh-name", "torso"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("character.obj") && stderr.contains("torso"), "{stderr}");
    assert_eq!(listing(dir.path()), Vec::<String>::new(), "no output or temp file after a failure");
}

#[test]
fn every_bad_corpus_file_fails_cleanly_or_fits() {
    let Some(data) = shared_data() else { return };
    let root = data.join("bad");
    let mut files = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(
                p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
                Some("obj" | "gltf" | "glb" | "ply" | "stl" | "off")
            ) {
                files.push(p);
            }
        }
    }
    files.sort();
    assert!(files.len() > 20, "{} mesh files", files.len());
    let dir = tempfile::tempdir().unwrap();
    let (mut ok, mut rejected) = (0, 0);
    for f in &files {
        let out = dir.path().join("bad.sphr");
        let (code, _, stderr) = run(penumbra()
            .arg("spheres")
            .arg(f)
            .args(["--count", "4", "--grid", "12", "--iterations", "3", "-o"])
            .arg(&out));
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match code {
            0 => {
                ok += 1;
                assert!(AssetFile::open(&out).is_ok(), "{name}: exit 0 but no valid asset");
                std::fs::remove_file(&out).unwrap();
            }
            2 => {
                rejected += 1;
                assert!(stderr.contains(&name), "{name}: the message must name the file: {stderr}");
                assert!(!stderr.contains("panicked"), "{name}: {stderr}");
            }
            c => panic!("{name}: exit {c}: {stderr}"),
        }
        assert_eq!(listing(dir.path()), Vec::<String>::new(), "{name}: stray files");
    }
    eprintln!("bad corpus: {ok} fitted, {rejected} rejected with exit 2");
}

#[test]
fn bake_config_spheres_stage() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(character(), dir.path().join("c.obj")).unwrap();
    let cfg = dir.path().join("scene.toml");
    std::fs::write(
        &cfg,
        "output_dir = \"out\"\n[[spheres]]\nmesh = \"c.obj\"\ncount = 6\ngrid = 16\niterations = 4\n[[spheres]]\nmesh = \"c.obj\"\ncount = 6\nmethod = \"octree\"\noutput = \"oct.sphr\"\n[[spheres]]\nmesh = \"c.obj\"\ncount = 6\ngrid = 16\niterations = 4\npolish = true\noutput = \"pol.sphr\"\n\
         [[spheres]]\nmesh = \"c.obj\"\ntarget_union = 2.5\nmax_count = 16\ngrid = 16\niterations = 4\noutput = \"tu.sphr\"\n",
    )
    .unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["name"], "spheres[0]");
    assert_eq!(v["stages"][0]["status"], "baked");
    assert_eq!(v["stages"][1]["metrics"]["method"], "octree");
    assert!(dir.path().join("out/c.sphr").is_file() && dir.path().join("out/oct.sphr").is_file());
    // shards split the two entries; a second run is up to date
    let (code, stdout, _) = run(penumbra().arg("bake").arg(&cfg).args(["--json", "--shard", "1/2"]));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["status"], "skipped-by-shard");
    assert_eq!(v["stages"][1]["status"], "up-to-date");
    // the stage's asset equals the standalone command's
    let standalone = dir.path().join("s.sphr");
    let (code, _, stderr) = run(penumbra()
        .arg("spheres")
        .arg(dir.path().join("c.obj"))
        .args(["--count", "6", "--grid", "16", "--iterations", "4", "-o"])
        .arg(&standalone));
    assert_eq!(code, 0, "{stderr}");
    let a = AssetFile::open(&standalone).unwrap();
    let b = AssetFile::open(dir.path().join("out/c.sphr")).unwrap();
    assert_eq!(a.asset().section("spheres").unwrap().bytes(), b.asset().section("spheres").unwrap().bytes());
    // `polish = true` is the command's --polish (and not the unpolished fit)
    let polished = dir.path().join("p.sphr");
    let (code, _, stderr) = run(penumbra()
        .arg("spheres")
        .arg(dir.path().join("c.obj"))
        .args(["--count", "6", "--grid", "16", "--iterations", "4", "--polish", "-o"])
        .arg(&polished));
    assert_eq!(code, 0, "{stderr}");
    let p = AssetFile::open(&polished).unwrap();
    let q = AssetFile::open(dir.path().join("out/pol.sphr")).unwrap();
    assert_eq!(p.asset().section("spheres").unwrap().bytes(), q.asset().section("spheres").unwrap().bytes());
    assert_ne!(p.asset().section("spheres").unwrap().bytes(), a.asset().section("spheres").unwrap().bytes());
    // `target_union` + `max_count` are the command's --target-union/--max-count search
    let tu = dir.path().join("tu.sphr");
    let (code, _, stderr) = run(penumbra()
        .arg("spheres")
        .arg(dir.path().join("c.obj"))
        .args(["--target-union", "2.5", "--max-count", "16", "--grid", "16", "--iterations", "4", "-o"])
        .arg(&tu));
    assert_eq!(code, 0, "{stderr}");
    let t = AssetFile::open(&tu).unwrap();
    let u = AssetFile::open(dir.path().join("out/tu.sphr")).unwrap();
    assert_eq!(t.asset().section("spheres").unwrap().bytes(), u.asset().section("spheres").unwrap().bytes());
    // a cap with a fixed count, or two targets, is a config error (exit 2) naming the key
    for (extra, want) in
        [("count = 6\nmax_count = 8\n", "max_count"), ("count = 6\ntarget_union = 0.5\n", "exactly one")]
    {
        let bad = dir.path().join("bad.toml");
        std::fs::write(&bad, format!("output_dir = \"out2\"\n[[spheres]]\nmesh = \"c.obj\"\n{extra}")).unwrap();
        let (code, _, stderr) = run(penumbra().arg("bake").arg(&bad));
        assert_eq!(code, 2, "{extra}: {stderr}");
        assert!(stderr.contains(want), "{extra}: {stderr}");
    }
}

#[test]
fn spheres_target_search_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    // reachable: the count meets the target and the count below it was probed and missed
    let out = dir.path().join("t.sphr");
    let (code, stdout, stderr) = fit(&out, &["--target-union", "0.8", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let n = v["settled_count"].as_u64().unwrap();
    assert!(v["requested_count"].is_null(), "target mode requests no count: {stdout}");
    assert!(v["count"].as_u64().unwrap() <= n);
    assert_eq!(v["target_met"], true);
    assert!(v["union_outside_ratio"].as_f64().unwrap() <= 0.8);
    let probe = |k: u64| {
        v["search"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["requested_count"] == k)
            .map(|s| s["union_outside_ratio"].as_f64().unwrap())
    };
    if n > 1 {
        assert!(probe(n - 1).is_some_and(|x| x > 0.8), "{stdout}");
    }
    // unreachable within --max-count: exit 1, the best set written, the reason given
    let out = dir.path().join("u.sphr");
    let (code, stdout, stderr) = fit(&out, &["--target-error", "0.001", "--max-count", "3", "--json"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("target not met") && stderr.contains("--max-count 3"), "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["target_met"], false);
    assert!(v["target_reason"].as_str().is_some());
    let file = AssetFile::open(&out).unwrap();
    assert_eq!(file.asset().section("spheres").unwrap().dims()[0] as u64, v["count"].as_u64().unwrap());
    // --max-count without a target search is a usage error
    let (code, _, stderr) = fit(&out, &["--count", "4", "--max-count", "8"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("--max-count"), "{stderr}");
    // a flat sheet has no volume: exit 2 naming the file, no output
    let flat = dir.path().join("flat.obj");
    std::fs::write(&flat, penumbra_geometry::export::obj_text(&penumbra_geometry::procedural::grid(4), "flat"))
        .unwrap();
    let out = dir.path().join("flat.sphr");
    let (code, _, stderr) = run(penumbra().arg("spheres").arg(&flat).args(["--target-error", "0.5", "-o"]).arg(&out));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("flat.obj") && stderr.contains("no volume"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn sweep_spheres_writes_table_plot_and_front() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let (code, stdout, stderr) = run(penumbra()
        .args(["sweep", "spheres"])
        .arg(character())
        .args(["--counts", "4,8", "--grids", "16", "--methods", "lloyd,octree", "--json", "-o"])
        .arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4, "2 methods × 1 grid × 2 counts");
    for r in rows {
        assert!(r["union_outside_ratio"].as_f64().unwrap() > 0.0);
        assert!(r["bake_seconds"].as_f64().unwrap() > 0.0);
        assert_eq!(r["uncovered_sample_points"], 0);
    }
    // the front is the undominated (seconds, union) rows: at least one, and none dominated
    let pt = |r: &Value| (r["bake_seconds"].as_f64().unwrap(), r["union_outside_ratio"].as_f64().unwrap());
    let front: Vec<&Value> = rows.iter().filter(|r| r["pareto_union"] == true).collect();
    assert!(!front.is_empty());
    for f in &front {
        let (x, y) = pt(f);
        assert!(!rows.iter().any(|r| {
            let (a, b) = pt(r);
            a <= x && b <= y && (a < x || b < y)
        }));
    }
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5);
    assert!(csv.starts_with("method,grid,requested_count,count,bake_seconds"));
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.contains("Pareto front") && svg.contains("octree") && svg.contains("lloyd"));
    assert!(out.join("lloyd-g16-8.sphr").is_file());
    let (code, _, stderr) =
        run(penumbra().args(["sweep", "spheres"]).arg(character()).args(["--grids", "4", "-o"]).arg(&out));
    assert_eq!(code, 2);
    assert!(stderr.contains("--grids") && stderr.contains("8..=256"), "{stderr}");
}

#[test]
fn bake_config_spheres_stage_takes_albedo_and_skin_padding_rules() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(character(), dir.path().join("c.obj")).unwrap();
    let cfg = dir.path().join("scene.toml");
    let head = "output_dir = \"out\"\n[[spheres]]\nmesh = \"c.obj\"\ncount = 6\ngrid = 16\niterations = 4\n";
    std::fs::write(&cfg, format!("{head}albedo = [0.2, 0.4, 0.6]\n")).unwrap();
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    // an OBJ has no materials: every sphere gets the stage's albedo, as with --albedo
    let standalone = dir.path().join("s.sphr");
    let (code, _, stderr) = run(penumbra()
        .arg("spheres")
        .arg(dir.path().join("c.obj"))
        .args(["--count", "6", "--grid", "16", "--iterations", "4", "--albedo", "0.2,0.4,0.6", "-o"])
        .arg(&standalone));
    assert_eq!(code, 0, "{stderr}");
    let a = AssetFile::open(&standalone).unwrap();
    let b = AssetFile::open(dir.path().join("out/c.sphr")).unwrap();
    let alb = b.asset().section("albedo").expect("albedo section").as_f32().unwrap().to_vec();
    assert_eq!(alb.len(), 18);
    for rgb in alb.chunks(3) {
        assert_eq!(rgb, [0.2f32, 0.4, 0.6]);
    }
    assert_eq!(a.asset().section("albedo").unwrap().bytes(), b.asset().section("albedo").unwrap().bytes());
    // out of range, and padding without a skin: exit 2 with the key
    for (extra, want) in [("albedo = 1.5\n", "spheres[0].albedo"), ("skin_padding = true\n", "spheres[0].skin_padding")]
    {
        std::fs::write(&cfg, format!("{head}{extra}")).unwrap();
        let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(want), "{stderr}");
    }
}

#[test]
fn spheres_read_the_base_colour_texture_and_name_an_undecodable_one() {
    use penumbra_testkit::gltf::{Part, glb_textured, uv_cube};
    let dir = tempfile::tempdir().unwrap();
    let (v, t, uv) = uv_cube([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    let part = Part { positions: &v, triangles: &t, base_color: Some([1.0, 1.0, 1.0, 1.0]) };
    // uniform sRGB 128: linear 0.2158 on every sphere (the factor alone would give 1)
    let png = penumbra_cli::png::encode_rgb8(2, 2, &[128u8; 12]);
    let good = dir.path().join("grey.glb");
    std::fs::write(&good, glb_textured(part, &uv, &png, "image/png", 10497)).unwrap();
    let out = dir.path().join("grey.sphr");
    let (code, stdout, stderr) =
        run(penumbra().arg("spheres").arg(&good).args(["--count", "2", "--json", "-o"]).arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["albedo_texture_images"], 1);
    let lin = ((128.0 / 255.0 + 0.055) / 1.055f64).powf(2.4);
    for c in v["albedo_mean"].as_array().unwrap() {
        assert!((c.as_f64().unwrap() - lin).abs() < 1e-5, "{c} vs {lin}");
    }
    // an image that is not a PNG/JPEG: exit 2, the file and the image named, no output
    let bad = dir.path().join("bad.glb");
    std::fs::write(&bad, glb_textured(part, &uv, b"GIF89a...", "image/png", 10497)).unwrap();
    let out = dir.path().join("bad.sphr");
    let (code, _, stderr) = run(penumbra().arg("spheres").arg(&bad).args(["--count", "2", "-o"]).arg(&out));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("bad.glb") && stderr.contains("image 0"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn node_globs_select_the_chair_and_list_the_nodes_when_nothing_matches() {
    let Some(data) = shared_data() else { return };
    let scene = data.join("gltf/MixedLightingExample/MixedLightingExample.gltf");
    let dir = tempfile::tempdir().unwrap();
    let tris = |args: &[&str]| -> (i32, u64, String) {
        let out = dir.path().join("n.sphr");
        let _ = std::fs::remove_file(&out);
        let (code, _, stderr) =
            run(penumbra().arg("spheres").arg(&scene).args(["--count", "4", "-o"]).arg(&out).args(args));
        if code != 0 {
            return (code, 0, stderr);
        }
        let (_, meta, _) = run(penumbra().arg("inspect").arg(&out).arg("--json"));
        let v: Value = serde_json::from_str(&meta).unwrap();
        (code, v["meta"]["input"]["triangles"].as_u64().unwrap(), stderr)
    };
    // the four chair nodes together = the sum of each taken alone (the ground plane excluded)
    let (code, chair, stderr) = tris(&["--node", "SheenChair*"]);
    assert_eq!(code, 0, "{stderr}");
    let mut sum = 0;
    for part in ["SheenChair_fabric", "SheenChair_label", "SheenChair_metal", "SheenChair_wood"] {
        let (code, t, stderr) = tris(&["--node", part]);
        assert_eq!(code, 0, "{part}: {stderr}");
        assert!(t > 0);
        sum += t;
    }
    assert_eq!(chair, sum);
    let (_, all, _) = tris(&[]);
    assert!(chair < all, "{chair} vs {all}");
    // repeatable: the chair's wood and the plane
    let (code, two, _) = tris(&["--node", "*_wood", "--node", "Plane"]);
    let (_, plane, _) = tris(&["--node", "Plane"]);
    let (_, wood, _) = tris(&["--node", "SheenChair_wood"]);
    assert_eq!((code, two), (0, plane + wood));
    let (code, _, stderr) = tris(&["--node", "Chair*"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("--node \"Chair*\"") && stderr.contains("SheenChair_fabric"), "{stderr}");
}
