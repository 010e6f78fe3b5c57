use crate::{listing, penumbra, run};
use penumbra_asset::AssetFile;
use serde_json::Value;

/// Small, fast settings (the thesis settings are exercised by crates/transport's tests and
/// by `make bench`).
pub const SMALL: &[&str] = &[
    "--face-res",
    "4",
    "--rays",
    "512",
    "--kd",
    "24",
    "--kb",
    "12",
    "--vector-rays",
    "64",
    "--volume-res",
    "2",
    "--probe-rays",
    "64",
    "--test-lights",
    "3",
    "--reference-rays",
    "128",
    "--lf-spatial",
    "4",
    "--lf-dir",
    "6",
    "--lf-super",
    "2",
    "--k-rlf",
    "24",
    "--k-r",
    "8",
    "--response-rays",
    "64",
];

fn dict_json(extra: &[&str], out: &std::path::Path) -> Value {
    let (code, stdout, stderr) =
        run(penumbra().args(["mrt", "dict"]).args(SMALL).args(extra).arg("-o").arg(out).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).expect("one JSON object on stdout")
}

#[test]
fn json_keys_are_present_and_honest() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.mrtd");
    let v = dict_json(&["--dictionary", "cube2d"], &out);
    for key in [
        "table_3_2",
        "reconstruction_rel_error",
        "reference_rel_error",
        "enrichment_rel_error_before",
        "enrichment_rel_error_after",
        "enrichment_rel_error_enriched_only",
        "enrichment_rel_error_excluded_only",
        "enrichment",
        "shapes",
        "bytes",
        "seconds",
        "output",
        "interfaces",
        "k_rlf",
        "k_r",
        "interface_seconds",
    ] {
        assert!(v.get(key).is_some(), "missing key {key}");
    }
    let t = &v["table_3_2"];
    assert_eq!(t["n"], 6 * 16);
    for m in ["F", "L_d", "M"] {
        let c: Vec<u64> = t[m].as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect();
        assert_eq!(c.len(), 3);
        assert!(c[0] >= 1 && c[0] <= c[1] && c[1] <= c[2], "{m}: {c:?}");
    }
    // energy concentrates: the one-bounce operator needs more modes than the prior-space one
    assert!(t["F"][2].as_u64().unwrap() > t["M"][2].as_u64().unwrap());
    let names = ["closed", "dead_end", "straight", "corner", "tee", "cross"];
    for key in ["reconstruction_rel_error", "reference_rel_error"] {
        let m = v[key].as_object().unwrap();
        assert_eq!(m.len(), 6, "{key}");
        for n in names {
            let e = m[n].as_f64().unwrap();
            assert!(e.is_finite() && e > 0.0 && e < 1.0, "{key}.{n} = {e}");
        }
    }
    assert!(v["enrichment_rel_error_after"].as_f64().unwrap() < v["enrichment_rel_error_before"].as_f64().unwrap());
    assert_eq!(v["bytes"].as_u64().unwrap(), std::fs::metadata(&out).unwrap().len());
    assert!(v["seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(v["output"].as_str().unwrap(), out.display().to_string());
    // interfaces: the thesis's 12 openings, their operators in the asset (MRTD kind version 2)
    assert_eq!(v["interfaces"].as_array().unwrap().len(), 12);
    assert_eq!(v["k_rlf"], 24);
    assert_eq!(v["k_r"], 8);
    let is = v["interface_seconds"].as_f64().unwrap();
    assert!(is > 0.0 && is < v["seconds"].as_f64().unwrap());
    let file = AssetFile::open(&out).unwrap();
    let a = file.asset();
    let dims = |s: &str| a.section(s).unwrap().dims().to_vec();
    assert_eq!(dims("iface.r_straight"), vec![24, 24]);
    assert_eq!(dims("iface.u_r"), vec![5 * 16, 8]);
    assert_eq!(dims("iface.t_rlf2r"), vec![8, 24]);
    assert_eq!(dims("cross.r_b2rlf.pz"), vec![24, 12]);
    assert_eq!(dims("tee.u_r_idx.nx"), vec![3 * 16]); // floor, ceiling, −z
    let meta: Value = serde_json::from_str(a.meta_json()).unwrap();
    assert_eq!(meta["interfaces"][0], serde_json::json!({"shape": "dead_end", "face": "+z"}));
}

#[test]
fn asset_holds_every_section_and_its_operators_reproduce_a_known_answer() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.mrtd");
    let v = dict_json(&["--dictionary", "closed-cube", "--albedo", "0.5"], &out);
    let file = AssetFile::open(&out).unwrap();
    let a = file.asset();
    assert_eq!(a.kind().as_str(), "MRTD");
    let meta: Value = serde_json::from_str(a.meta_json()).unwrap();
    assert_eq!(meta["kind_version"], 3);
    // the closed cube has no interfaces: a version-2 asset without interface sections
    assert_eq!(meta["interfaces"], serde_json::json!([]));
    assert!(a.section("iface.u_r").is_none());
    assert_eq!(meta["shapes"][0]["name"], "closed");
    assert_eq!(meta["metrics"]["table_3_2"], v["table_3_2"]);
    let known = penumbra_transport::asset::section_names(&["closed"]);
    let known: Vec<&str> = known.iter().map(String::as_str).collect();
    a.require_known(&known).unwrap();
    for name in &known {
        assert!(a.section(name).is_some(), "{name}");
    }
    let n = 6 * 16;
    let kb = 12;
    let dims = |s: &str| a.section(s).unwrap().dims().to_vec();
    assert_eq!(dims("closed.u_b"), vec![n, kb]);
    assert_eq!(dims("closed.t_d2b"), vec![kb, n]);
    assert_eq!(dims("closed.u_bvec"), vec![n, kb, 4]);
    assert_eq!(dims("closed.u_bvol"), vec![8, kb, 9]);
    assert_eq!(dims("closed.positions"), vec![n, 3]);
    assert_eq!(dims("face_frames"), vec![6, 4, 3]);
    // A closed box under uniform direct light E = 1 reflects ρ·1 everywhere (every gather ray
    // lands on a wall): b = T_d→b·1, U_b·b ≈ ρ (the enriched prior holds the face constants).
    let u = a.section("closed.u_b").unwrap().to_f64_vec().unwrap();
    let t = a.section("closed.t_d2b").unwrap().to_f64_vec().unwrap();
    let b: Vec<f64> = (0..kb).map(|m| (0..n).map(|j| t[m * n + j]).sum()).collect();
    let e: Vec<f64> = (0..n).map(|i| (0..kb).map(|m| u[i * kb + m] * b[m]).sum()).collect();
    let worst = e.iter().map(|x| (x - 0.5).abs()).fold(0.0, f64::max) / 0.5;
    let rms = (e.iter().map(|x| (x - 0.5).powi(2)).sum::<f64>() / n as f64).sqrt() / 0.5;
    // what remains is the truncation to k_d = 24, k_b = 12 modes (2 % rms, 3.4 % worst here)
    assert!(rms < 0.03 && worst < 0.05, "rms {rms}, worst {worst}: {e:?}");
    // texel positions lie on the walls they claim: |n·p| is 0 or 1 along the normal axis
    let p = a.section("closed.positions").unwrap().to_f64_vec().unwrap();
    let nm = a.section("closed.normals").unwrap().to_f64_vec().unwrap();
    for i in 0..n {
        let d: f64 = (0..3).map(|k| p[i * 3 + k] * nm[i * 3 + k]).sum();
        assert!(d.abs() < 1e-6 || (d + 1.0).abs() < 1e-6, "texel {i}");
    }
}

#[test]
fn out_of_range_options_are_rejected_with_the_allowed_range() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.mrtd");
    let cases: &[(&[&str], &str)] = &[
        (&["--face-res", "1"], "2..=24"),
        (&["--face-res", "25"], "2..=24"),
        (&["--albedo", "0"], "0 < A <= 1"),
        (&["--light-radius", "0.2"], "0 < r <= 0.08"),
        (&["--enrich", "9"], "0..=8"),
        (&["--kd", "8", "--kb", "9"], "1..=kd"),
        (&["--dictionary", "sphere"], "cube2d"),
        (&["--enrich", "0"], "--keep-same-face"),
    ];
    for (args, allowed) in cases {
        let (code, _, stderr) = run(penumbra().args(["mrt", "dict"]).args(*args).arg("-o").arg(&out));
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stderr.contains(allowed), "{args:?}: {stderr}");
    }
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn same_bytes_for_any_thread_count_and_across_runs() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (i, threads) in ["1", "2", "2"].iter().enumerate() {
        let out = dir.path().join(format!("d{i}.mrtd"));
        let (code, _, stderr) =
            run(penumbra().args(["--threads", threads, "mrt", "dict"]).args(SMALL).arg("-o").arg(&out));
        assert_eq!(code, 0, "{stderr}");
        files.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(files[0], files[1]);
    assert_eq!(files[1], files[2]);
}

#[test]
fn bake_config_mrt_stage_bakes_then_skips_and_validates_keys() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("scene.toml");
    let body = "output_dir = \"out\"\n[mrt]\ndictionary = \"closed-cube\"\nface_res = 4\nrays = 512\nkd = 24\nkb = 12\n\
                vector_rays = 64\nvolume_res = 2\nprobe_rays = 64\ntest_lights = 3\nreference_rays = 128\n\
                lf_spatial = 4\nlf_dir = 6\nlf_super = 2\nk_rlf = 24\nk_r = 8\nresponse_rays = 64\n";
    std::fs::write(&cfg, body).unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let stage = v["stages"].as_array().unwrap().iter().find(|s| s["name"] == "mrt").unwrap().clone();
    assert_eq!(stage["status"], "baked");
    assert_eq!(stage["kind"], "MRTD");
    assert_eq!(stage["metrics"]["table_3_2"]["n"], 96);
    let baked = std::fs::read(dir.path().join("out/dictionary.mrtd")).unwrap();
    let (_, stdout, _) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["status"], "up-to-date");
    // same bytes as the standalone command with the same parameters
    let standalone = dir.path().join("s.mrtd");
    let (code, _, stderr) =
        run(penumbra().args(["mrt", "dict", "--dictionary", "closed-cube"]).args(SMALL).arg("-o").arg(&standalone));
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(std::fs::read(&standalone).unwrap(), baked);
    // bad keys name the key path
    for (bad, what) in [
        ("kd = 16\nkb = 30\n", "mrt.kb"),
        ("gather = \"nearest\"\n", "mrt.gather"),
        ("face_rez = 3\n", "face_rez"),
        ("enrich = 0\n", "mrt.exclude_same_face"),
    ] {
        std::fs::write(&cfg, format!("output_dir = \"out\"\n[mrt]\n{bad}")).unwrap();
        let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(what), "{stderr}");
    }
}

#[test]
fn raw_gather_is_checked_against_exact_form_factors() {
    // `f_max_column_sum` ≤ 1 holds by construction of the Sinkhorn balance; `raw_gather` is
    // the physical check of the gather before the balance (docs/mrt.md, "Energy"): in the
    // closed cube every row sums to 1 (every ray lands) and the face-to-face block sums of F/ρ
    // are the unit cube's form factors, opposite 0.19982 and adjacent 0.20004 (measured at
    // these small settings, 4² texels per face and 512 rays: 0.20239 and 0.19940, the
    // 4 × 4 midpoint rule's error; 0.19997 / 0.20001 at the thesis settings).
    let dir = tempfile::tempdir().unwrap();
    let closed = ["--dictionary", "closed-cube", "--no-interfaces"];
    let balanced = dict_json(&closed, &dir.path().join("b.mrtd"));
    let raw = dict_json(&[&closed[..], &["--no-balance"]].concat(), &dir.path().join("r.mrtd"));
    let (b, r) = (&balanced["shapes"]["closed"], &raw["shapes"]["closed"]);
    let g = &b["raw_gather"];
    let f = |k: &str| g[k].as_f64().unwrap_or_else(|| panic!("raw_gather.{k}: {g}"));
    assert!(
        (f("face_ff_opposite_exact") - 0.19982).abs() < 5e-6 && (f("face_ff_adjacent_exact") - 0.20004).abs() < 5e-6
    );
    assert!((f("face_ff_opposite") - 0.19982).abs() < 0.005, "{g}");
    assert!((f("face_ff_adjacent") - 0.20004).abs() < 0.002, "{g}");
    assert!(f("face_ff_max_abs_error") < 0.006, "{g}");
    assert!(f("row_max_abs_error") < 1e-12, "{g}");
    assert!(f("point_face_max_abs_error") < 0.02, "{g}");
    // measured before the balance: the same with and without it
    assert_eq!(g, &r["raw_gather"]);
    // what the balance does: the column bound holds with it, not without (corners)
    assert!(b["f_max_column_sum"].as_f64().unwrap() <= 1.0 + 1e-12, "{b}");
    assert!(r["f_max_column_sum"].as_f64().unwrap() > 1.02, "{r}");
}

#[test]
fn a_dictionary_for_a_level_bakes_only_its_shapes_to_the_whole_dictionarys_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let level = dir.path().join("two.toml");
    std::fs::write(
        &level,
        "[[block]]\nshape = \"dead_end\"\ntranslation = [0.5, 0.5, 0.5]\n[[block]]\nshape = \"dead_end\"\n\
         rotation = 2\ntranslation = [0.5, 0.5, 1.5]\n[[connection]]\na = 0\na_face = \"+z\"\nb = 1\nb_face = \"+z\"\n",
    )
    .unwrap();
    let (sub, full) = (dir.path().join("sub.mrtd"), dir.path().join("full.mrtd"));
    let vs = dict_json(&["--for-level", level.to_str().unwrap()], &sub);
    let vf = dict_json(&[], &full);
    // the level's shape and the closed cube (its Table 3.2 and App. A checks), one opening
    assert_eq!(vs["shapes_baked"], serde_json::json!(["closed", "dead_end"]));
    assert_eq!(vf["shapes_baked"].as_array().unwrap().len(), 6);
    assert_eq!(vs["interfaces"], serde_json::json!(["dead_end.+z"]));
    assert!(vs["bytes"].as_u64().unwrap() < vf["bytes"].as_u64().unwrap() / 2, "{vs}");
    // each baked shape's operators are the whole dictionary's, bit for bit
    let (fs, ff) = (penumbra_asset::AssetFile::open(&sub).unwrap(), penumbra_asset::AssetFile::open(&full).unwrap());
    let (a, b) = (fs.asset(), ff.asset());
    for s in ["closed", "dead_end"] {
        for sec in ["u_b", "t_d2b", "l_imp", "u_bvec", "u_bvol"] {
            let name = format!("{s}.{sec}");
            let (x, y) = (a.section(&name).unwrap().as_f32().unwrap(), b.section(&name).unwrap().as_f32().unwrap());
            assert!(x == y, "{name} differs");
        }
    }
    assert!(a.section("straight.u_b").is_none());
    assert_eq!(vs["table_3_2"], vf["table_3_2"]);
    // the level bakes and verifies against it
    let l = dir.path().join("two.mrtl");
    let (code, _, stderr) =
        run(penumbra().args(["mrt", "level"]).arg(&level).arg("--dict").arg(&sub).arg("-o").arg(&l));
    assert_eq!(code, 0, "{stderr}");
    // a level naming a shape the dictionary lacks: exit 2, the file and the known shapes named
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[[block]]\nshape = \"donut\"\ntranslation = [0.5, 0.5, 0.5]\n").unwrap();
    let out = dir.path().join("bad.mrtd");
    let (code, _, stderr) =
        run(penumbra().args(["mrt", "dict"]).args(SMALL).arg("--for-level").arg(&bad).arg("-o").arg(&out));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("bad.toml") && stderr.contains("donut") && stderr.contains("cross"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn a_bake_config_with_a_level_bakes_the_dictionary_for_that_level() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("scene.toml");
    let mrt = "[mrt]\nface_res = 4\nrays = 512\nkd = 24\nkb = 12\nvector_rays = 64\nvolume_res = 2\nprobe_rays = 64\n\
               test_lights = 3\nreference_rays = 128\nlf_spatial = 4\nlf_dir = 6\nlf_super = 2\nk_rlf = 24\nk_r = 8\n\
               response_rays = 64\n";
    let bake = |extra: &str| -> Value {
        std::fs::write(&cfg, format!("output_dir = \"out\"\n{mrt}{extra}[mrt_level]\nmaze = 3\nseed = 1\n")).unwrap();
        let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
        assert_eq!(code, 0, "{stderr}");
        let v: Value = serde_json::from_str(&stdout).unwrap();
        v["stages"].as_array().unwrap().iter().find(|s| s["name"] == "mrt").unwrap()["metrics"].clone()
    };
    let m = bake("");
    let baked: std::collections::BTreeSet<String> =
        m["shapes_baked"].as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string()).collect();
    // exactly the maze's shapes (as `mrt level` resolves it against this dictionary) and the closed cube
    let lt = dir.path().join("maze.toml");
    let (code, _, stderr) = run(penumbra()
        .args(["mrt", "level", "--maze", "3", "--seed", "1", "--dict"])
        .arg(dir.path().join("out/dictionary.mrtd"))
        .arg("--write-level")
        .arg(&lt)
        .arg("-o")
        .arg(dir.path().join("x.mrtl")));
    assert_eq!(code, 0, "{stderr}");
    let text = std::fs::read_to_string(&lt).unwrap();
    let mut want: std::collections::BTreeSet<String> =
        text.lines().filter_map(|l| l.strip_prefix("shape = ")).map(|s| s.trim_matches('"').to_string()).collect();
    want.insert("closed".into());
    assert_eq!(baked, want, "{text}");
    assert!(baked.len() < 6);
    // opting out bakes the whole dictionary
    let m = bake("level_shapes_only = false\n");
    assert_eq!(m["shapes_baked"].as_array().unwrap().len(), 6);
}
