//! `penumbra mrt level` and `penumbra verify mrt` (MRT thesis §3.5.3, §3.6.3, §4.3–4.6).

use crate::mrt::SMALL;
use crate::{penumbra, run};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A small cube2d dictionary with interfaces (SMALL settings) in `dir`.
pub fn small_dict(dir: &Path) -> PathBuf {
    let out = dir.join("d.mrtd");
    let (code, _, stderr) = run(penumbra().args(["mrt", "dict"]).args(SMALL).arg("-o").arg(&out));
    assert_eq!(code, 0, "{stderr}");
    out
}

fn level_json(args: &[&str], dict: &Path, out: &Path) -> Value {
    let (code, stdout, stderr) =
        run(penumbra().args(["mrt", "level"]).args(args).arg("--dict").arg(dict).arg("-o").arg(out).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).expect("one JSON object")
}

#[test]
fn maze_level_keys_round_trip_and_determinism() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("m.mrtl");
    let toml = dir.path().join("m.toml");
    let v = level_json(&["--maze", "12", "--seed", "3", "--write-level", toml.to_str().unwrap()], &d, &out);
    for k in ["blocks", "block_pairs", "records", "bytes", "seconds", "atlas", "pad_records", "max_depth"] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["blocks"], 12);
    // a tree maze of 12 blocks: every ordered pair within 8 interfaces of each other
    let pairs = v["block_pairs"].as_u64().unwrap();
    assert!(pairs > 11 * 2 && pairs <= 12 * 11, "{pairs}");
    assert_eq!(v["bytes"].as_u64().unwrap(), std::fs::metadata(&out).unwrap().len());
    let a = penumbra_asset::AssetFile::open(&out).unwrap();
    assert_eq!(a.asset().kind().as_str(), "MRTL");
    let recs = a.asset().section("t_b2r").unwrap().dims().to_vec();
    assert_eq!(recs, vec![v["records"].as_u64().unwrap() as usize, 8, 12]);
    // the written level file bakes to the same bytes, with any thread count
    let again = dir.path().join("again.mrtl");
    let (code, _, stderr) =
        run(penumbra().args(["--threads", "1", "mrt", "level"]).arg(&toml).arg("--dict").arg(&d).arg("-o").arg(&again));
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());
    // depth 0: no light between blocks
    let v0 = level_json(&["--maze", "12", "--seed", "3", "--max-depth", "0"], &d, &dir.path().join("z.mrtl"));
    assert_eq!(v0["block_pairs"], 0);
}

#[test]
fn bad_levels_and_old_dictionaries_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("x.mrtl");
    let cases = [
        ("[[block]]\nshape = \"torus\"\ntranslation = [0, 0, 0]\n", "block 0: shape \"torus\""),
        (
            "[[block]]\nshape = \"dead_end\"\ntranslation = [0.5, 0.5, 0.5]\n[[block]]\nshape = \"dead_end\"\n\
             rotation = 2\ntranslation = [0.5, 0.5, 1.75]\n[[connection]]\na = 0\na_face = \"+z\"\nb = 1\nb_face = \"+z\"\n",
            "do not coincide",
        ),
        (
            "[[block]]\nshape = \"dead_end\"\ntranslation = [0.5, 0.5, 0.5]\n[[connection]]\na = 0\na_face = \"+z\"\nb = 3\nb_face = \"-z\"\n",
            "block 3 does not exist",
        ),
        ("[[block]]\nshape = \"closed\"\ntranslation = [0, 0, 0]\nrotation = 7\n", "0..=3"),
        ("[[block]]\nshape = \"closed\"\ntranslaton = [0, 0, 0]\n", "translaton"),
    ];
    for (body, what) in cases {
        let f = dir.path().join("bad.toml");
        std::fs::write(&f, body).unwrap();
        let (code, _, stderr) =
            run(penumbra().args(["mrt", "level"]).arg(&f).arg("--dict").arg(&d).arg("-o").arg(&out));
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains("bad.toml") && stderr.contains(what), "{what}: {stderr}");
        assert!(!out.exists());
    }
    // the v1 corpus dictionary has no interfaces: a clear error, not a crash
    let v1 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets/v1/mrt-cube2d-r4.mrtd");
    let (code, _, stderr) =
        run(penumbra().args(["mrt", "level", "--maze", "3", "--dict"]).arg(&v1).arg("-o").arg(&out));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("kind_version 1"), "{stderr}");
    // exactly one level source
    let (code, _, stderr) =
        run(penumbra().args(["mrt", "level", "--maze", "3", "--corridor", "4", "--dict"]).arg(&d).arg("-o").arg(&out));
    assert_eq!(code, 2, "{stderr}");
}

#[test]
fn committed_level_schema_is_current() {
    let (code, stdout, _) = run(penumbra().args(["schema", "--level"]));
    assert_eq!(code, 0);
    let committed = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/schemas/mrt-level.schema.json"))
        .expect("schemas/mrt-level.schema.json (run `make schemas`)");
    assert_eq!(stdout, committed, "schemas/mrt-level.schema.json is stale: run `make schemas`");
}

#[test]
fn verify_corridor_interfaces_beat_none_and_report_every_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let png = dir.path().join("top.png");
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "mrt", "--corridor", "5", "--rays", "256", "--bounces", "4", "--dict"])
        .arg(&d)
        .arg("--image")
        .arg(&png)
        .arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    for k in ["rel_error_one_bounce", "rel_error_multi_bounce", "ms_runtime", "rel_error_one_bounce_no_interfaces"] {
        let x = v[k].as_f64().unwrap_or_else(|| panic!("{k}"));
        assert!(x.is_finite() && x > 0.0, "{k} = {x}");
    }
    assert_eq!(v["per_block"].as_array().unwrap().len(), 5);
    let with = v["rel_error_one_bounce"].as_f64().unwrap();
    let without = v["rel_error_one_bounce_no_interfaces"].as_f64().unwrap();
    // the light sits in block 0: without interfaces the other four blocks get nothing
    assert!(with < 0.5 * without, "{with} vs {without}");
    assert!(with < 0.2 && v["rel_error_multi_bounce"].as_f64().unwrap() < 0.3, "{v}");
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // the baked level asset verifies to the same figures as the level it came from
    let asset = dir.path().join("c5.mrtl");
    level_json(&["--corridor", "5"], &d, &asset);
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "mrt", "--rays", "256", "--bounces", "4", "--dict"])
        .arg(&d)
        .arg("--level")
        .arg(&asset)
        .arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let w: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(w["rel_error_one_bounce"], v["rel_error_one_bounce"]);
    assert_eq!(w["block_pairs"], v["block_pairs"]);
    // the quality gate: above the measured error passes, below it exits 1 (reports still out)
    let gate = |x: f64| {
        run(penumbra()
            .args(["verify", "mrt", "--rays", "256", "--bounces", "4", "--dict"])
            .arg(&d)
            .arg("--level")
            .arg(&asset)
            .arg("--max-rel-error")
            .arg(x.to_string()))
    };
    assert_eq!(gate(1.01 * with).0, 0);
    let (code, _, stderr) = gate(0.99 * with);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("quality gate failed"), "{stderr}");
    // … and only with its own dictionary
    let other = dir.path().join("other.mrtd");
    let (code, _, stderr) = run(penumbra().args(["mrt", "dict"]).args(SMALL).args(["--seed", "5", "-o"]).arg(&other));
    assert_eq!(code, 0, "{stderr}");
    let (code, _, stderr) = run(penumbra().args(["verify", "mrt", "--dict"]).arg(&other).arg("--level").arg(&asset));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("another dictionary"), "{stderr}");
    // a light outside every block is a clean error
    let lights = dir.path().join("l.toml");
    std::fs::write(&lights, "[[light]]\nposition = [9.0, 0.5, 0.5]\n").unwrap();
    let (code, _, stderr) =
        run(penumbra().args(["verify", "mrt", "--corridor", "3", "--dict"]).arg(&d).arg("--lights").arg(&lights));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("l.toml") && stderr.contains("light 0"), "{stderr}");
    // a light 0.05 block above the floor is outside the light prior (nearest prior light: 1/7)
    std::fs::write(&lights, "[[light]]\nposition = [0.5, 0.05, 0.5]\n[[light]]\nposition = [0.5, 0.5, 0.5]\n").unwrap();
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "mrt", "--corridor", "3", "--rays", "16", "--json", "--dict"])
        .arg(&d)
        .arg("--lights")
        .arg(&lights));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let o = v["lights_outside_prior"].as_array().unwrap();
    assert_eq!(o.len(), 1, "{v}");
    assert_eq!(o[0]["light"], 0);
    assert!((o[0]["distance"].as_f64().unwrap() - 0.05).abs() < 1e-9);
    assert!(stderr.contains("warning: light 0"), "{stderr}");
}

#[test]
fn bake_config_mrt_level_stage_bakes_then_skips_and_validates() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("scene.toml");
    let mrt = "[mrt]\nface_res = 4\nrays = 512\nkd = 24\nkb = 12\nvector_rays = 64\nvolume_res = 2\nprobe_rays = 64\n\
               test_lights = 3\nreference_rays = 128\nlf_spatial = 4\nlf_dir = 6\nlf_super = 2\nk_rlf = 24\nk_r = 8\n\
               response_rays = 64\n";
    std::fs::write(&cfg, format!("output_dir = \"out\"\n{mrt}[mrt_level]\nmaze = 6\nseed = 2\n")).unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let st = v["stages"].as_array().unwrap().iter().find(|s| s["name"] == "mrt_level").unwrap().clone();
    assert_eq!(st["status"], "baked");
    assert_eq!(st["kind"], "MRTL");
    assert_eq!(st["metrics"]["blocks"], 6);
    let (_, stdout, _) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["stages"].as_array().unwrap().iter().all(|s| s["status"] == "up-to-date"), "{v}");
    for (body, what) in [
        ("[mrt_level]\nmaze = 3\n".to_string(), "needs the [mrt] stage"),
        (format!("{mrt}[mrt_level]\nmaze = 3\nlevel = \"l.toml\"\n"), "exactly one of"),
        (format!("{mrt}[mrt_level]\nmaze = 0\n"), "mrt_level.maze"),
        (format!("{mrt}interfaces = false\n[mrt_level]\nmaze = 3\n"), "mrt.interfaces"),
    ] {
        std::fs::write(&cfg, format!("output_dir = \"out2\"\n{body}")).unwrap();
        let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(what), "{what}: {stderr}");
    }
}

#[test]
fn runtime_places_texels_in_the_padded_atlas_and_adds_light_only_through_records() {
    use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("l.mrtl");
    level_json(&["--l-turn", "1", "--max-depth", "1"], &d, &out);
    let df = penumbra_asset::AssetFile::open(&d).unwrap();
    let lf = penumbra_asset::AssetFile::open(&out).unwrap();
    let (da, la) = (df.asset(), lf.asset());
    let rd = MrtDictionary::from_asset(&da).unwrap();
    let rl = MrtLevel::from_asset(&la, &rd).unwrap();
    let r2 = rd.face_texels;
    let r = (r2 as f64).sqrt() as usize;
    let tiles: Vec<u32> = rl.tiles.to_vec();
    let (w, h) = rl.atlas;
    let mut rt = MrtRuntime::new(rd, rl);
    let n = rt.texel_count();
    let offsets = rt.offsets().to_vec();
    // texel values that name their block and texel
    let vals: Vec<f32> = (0..n).map(|i| i as f32).collect();
    let mut atlas = vec![-1.0f32; w * h];
    rt.pad_atlas(&vals, &mut atlas);
    for t in tiles.chunks_exact(4) {
        let (b, f, x0, y0) = (t[0] as usize, t[1] as u8, t[2] as usize, t[3] as usize);
        let sh = &rt.dictionary().shapes[rt.level().shapes[b]];
        let slot = sh.faces.iter().position(|&x| x == f).unwrap();
        for j in 0..r {
            for i in 0..r {
                let want = (offsets[b] + slot * r2 + j * r + i) as f32;
                assert_eq!(atlas[(y0 + 1 + j) * w + x0 + 1 + i], want);
            }
        }
        // every border pixel is written
        for i in 0..r + 2 {
            for (x, y) in [(x0 + i, y0), (x0 + i, y0 + r + 1), (x0, y0 + i), (x0 + r + 1, y0 + i)] {
                assert!(atlas[y * w + x] >= 0.0, "tile {t:?} border ({x},{y})");
            }
        }
    }
    // light in block 0 only: with depth 1 the interfaces light block 1 and nothing else
    let mut l_d = vec![0.0f32; n];
    l_d[offsets[0]..offsets[1]].iter_mut().for_each(|v| *v = 1.0);
    let (mut with, mut without) = (vec![0.0f32; n], vec![0.0f32; n]);
    rt.indirect(&l_d, &mut with, true);
    rt.indirect(&l_d, &mut without, false);
    let diff = |b: usize| (offsets[b]..offsets[b + 1]).map(|i| (with[i] - without[i]).abs()).fold(0.0f32, f32::max);
    assert!(without[offsets[1]..].iter().all(|&v| v == 0.0));
    assert!(diff(1) > 0.0 && diff(0) == 0.0 && diff(2) == 0.0);
}

/// A U-turn of four blocks (dead end → corner → corner → dead end, the last beside the
/// first): a light in block 0 cannot see block 3, whose light all arrives across interfaces.
pub const U_TURN: &str = "[[block]]\nshape = \"dead_end\"\nrotation = 1\ntranslation = [0.5, 0.5, 0.5]\n\
[[block]]\nshape = \"corner\"\nrotation = 3\ntranslation = [1.5, 0.5, 0.5]\n\
[[block]]\nshape = \"corner\"\nrotation = 2\ntranslation = [1.5, 0.5, 1.5]\n\
[[block]]\nshape = \"dead_end\"\nrotation = 1\ntranslation = [0.5, 0.5, 1.5]\n\
[[connection]]\na = 0\na_face = \"+z\"\nb = 1\nb_face = \"+z\"\n\
[[connection]]\na = 1\na_face = \"+x\"\nb = 2\nb_face = \"+z\"\n\
[[connection]]\na = 2\na_face = \"+x\"\nb = 3\nb_face = \"+z\"\n";

#[test]
fn vector_and_volume_response_across_interfaces_match_the_path_tracer() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    // kind version 4: the interfaces' vector and volume response, canonical rows × k_r
    let file = penumbra_asset::AssetFile::open(&d).unwrap();
    let a = file.asset();
    let meta: Value = serde_json::from_str(a.meta_json()).unwrap();
    assert_eq!(meta["kind_version"], 4);
    assert_eq!(a.section("iface.u_rvec").unwrap().dims(), &[5 * 16, 8, 4]);
    assert_eq!(a.section("iface.u_rvol").unwrap().dims(), &[8, 8, 9]);
    let level = dir.path().join("u.toml");
    std::fs::write(&level, U_TURN).unwrap();
    let verify = |dict: &Path| -> Value {
        let (code, stdout, stderr) = run(penumbra()
            .args(["verify", "mrt", "--rays", "1024", "--bounces", "1", "--json", "--dict"])
            .arg(dict)
            .arg("--level")
            .arg(&level));
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str(&stdout).unwrap()
    };
    let v = verify(&d);
    let f = |x: &Value, k: &str| x[k].as_f64().unwrap_or_else(|| panic!("{k}: {x}"));
    assert_eq!(v["interface_vectors"], true);
    assert_eq!(f(&v, "tilt_deg"), 40.0);
    // block 3 has no direct light: b alone gives nothing there (error exactly 1); b and r
    // bring the light that crossed three interfaces (SMALL dictionary: k_r = 8, 4² texels)
    let b3 = &v["per_block"][3];
    assert_eq!(f(b3, "one_bounce_no_interfaces"), 1.0);
    assert_eq!(f(b3, "vector_b_only"), 1.0);
    assert_eq!(f(b3, "volume_b_only"), 1.0);
    assert!(f(b3, "vector") < 0.35, "{b3}");
    assert!(f(b3, "volume") < 0.4, "{b3}");
    // over the level: r matters, and the tilted normals need the vector response (the
    // untilted scalar light is worse than b + r)
    assert!(f(&v, "rel_error_vector") < 0.5 * f(&v, "rel_error_vector_b_only"), "{v}");
    assert!(f(&v, "rel_error_vector") < 0.5 * f(&v, "rel_error_vector_scalar"), "{v}");
    assert!(f(&v, "rel_error_volume") < 0.7 * f(&v, "rel_error_volume_b_only"), "{v}");
    assert!(f(&v, "rel_error_vector") < 0.12 && f(&v, "rel_error_volume") < 0.3, "{v}");
    for k in ["reference_noise_vector", "reference_noise_volume"] {
        assert!(f(&v, k) > 0.0 && f(&v, k) < 0.03, "{k}: {v}");
    }
    assert_eq!(v["vector_receivers"], (5 + 4 + 4 + 5) * 16); // every texel
    assert_eq!(v["volume_receivers"], 4 * 32 * 6);
    // without the interface response: kind version 3, and the runtime falls back to b only
    let d3 = dir.path().join("d3.mrtd");
    let (code, _, stderr) =
        run(penumbra().args(["mrt", "dict"]).args(SMALL).arg("--no-interface-vectors").arg("-o").arg(&d3));
    assert_eq!(code, 0, "{stderr}");
    let file = penumbra_asset::AssetFile::open(&d3).unwrap();
    let meta: Value = serde_json::from_str(file.asset().meta_json()).unwrap();
    assert_eq!(meta["kind_version"], 3);
    assert!(file.asset().section("iface.u_rvec").is_none() && meta["params"].get("interface_vectors").is_none());
    let v3 = verify(&d3);
    assert_eq!(v3["interface_vectors"], false);
    assert_eq!(f(&v3, "rel_error_vector"), f(&v3, "rel_error_vector_b_only"));
    assert_eq!(f(&v3, "rel_error_vector_b_only"), f(&v, "rel_error_vector_b_only"));
    // quality gates on both: the b-only figures fail a bound that b + r passes
    let gate = |dict: &Path, x: &str| -> i32 {
        run(penumbra()
            .args(["verify", "mrt", "--rays", "256", "--bounces", "1", "--dict"])
            .arg(dict)
            .arg("--level")
            .arg(&level)
            .args(["--max-rel-error-vector", x, "--max-rel-error-volume", "0.5"]))
        .0
    };
    assert_eq!(gate(&d, "0.2"), 0);
    assert_eq!(gate(&d3, "0.2"), 1);
}

#[test]
fn runtime_texel_world_frames_match_the_level_geometry() {
    use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
    use penumbra_runtime::mrt_vec::TexelWorld;
    use penumbra_transport::level::{Block, rotate_y};
    use penumbra_transport::shape::{CUBE2D, FACE_FRAMES, Texels};
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    // a warped, turned closed block and a turned dead end (its opening unconnected)
    let blocks = [
        Block { shape: 0, rotation: 1, translation: [0.5, 0.5, 0.5], scale: [2.0, 1.0, 0.5] },
        Block { shape: 1, rotation: 3, translation: [5.0, 1.0, -2.0], scale: [1.0, 2.0, 1.0] },
    ];
    let mut toml = String::new();
    for b in &blocks {
        toml += &format!(
            "[[block]]\nshape = \"{}\"\nrotation = {}\ntranslation = {:?}\nscale = {:?}\n",
            CUBE2D[b.shape].name, b.rotation, b.translation, b.scale
        );
    }
    let (lt, out) = (dir.path().join("w.toml"), dir.path().join("w.mrtl"));
    std::fs::write(&lt, toml).unwrap();
    let (code, _, stderr) = run(penumbra().args(["mrt", "level"]).arg(&lt).arg("--dict").arg(&d).arg("-o").arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let df = penumbra_asset::AssetFile::open(&d).unwrap();
    let lf = penumbra_asset::AssetFile::open(&out).unwrap();
    let (da, la) = (df.asset(), lf.asset());
    let rd = MrtDictionary::from_asset(&da).unwrap();
    let rl = MrtLevel::from_asset(&la, &rd).unwrap();
    let rt = MrtRuntime::new(rd, rl);
    let mut w = vec![TexelWorld::default(); rt.texel_count()];
    rt.texel_world(&mut w).unwrap();
    let mut i = 0;
    for b in &blocks {
        let tex = Texels::new(CUBE2D[b.shape], 4);
        for t in 0..tex.len() {
            let (f, _, _) = tex.coords(t);
            let want = [
                b.to_world(tex.position(t)),
                b.normal(f),
                rotate_y(FACE_FRAMES[f].u, b.rotation),
                rotate_y(FACE_FRAMES[f].v, b.rotation),
            ];
            let got = [w[i].position, w[i].normal, w[i].u, w[i].v];
            for (g, e) in got.iter().zip(&want) {
                assert!((0..3).all(|k| (f64::from(g[k]) - e[k]).abs() < 1e-5), "texel {i}: {got:?} vs {want:?}");
            }
            i += 1;
        }
    }
    assert_eq!(i, w.len());
}

#[test]
fn warped_blocks_are_rebaked_beyond_the_threshold_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let p = |n: &str| dir.path().join(n);
    // an unwarped corridor: the flag changes nothing, byte for byte (kind version 1)
    let toml = p("c3.toml");
    level_json(&["--corridor", "3", "--write-level", toml.to_str().unwrap()], &d, &p("a.mrtl"));
    let v = level_json(&["--corridor", "3", "--rebake-warps-above", "1.25"], &d, &p("b.mrtl"));
    assert_eq!(std::fs::read(p("a.mrtl")).unwrap(), std::fs::read(p("b.mrtl")).unwrap());
    assert_eq!(v["warps"]["distinct"], 0);
    // the middle block stretched ×2
    let text = std::fs::read_to_string(&toml)
        .unwrap()
        .replace("translation = [0.5, 0.5, 1.5]", "translation = [0.5, 0.5, 2.0]\nscale = [1.0, 1.0, 2.0]")
        .replace("translation = [0.5, 0.5, 2.5]", "translation = [0.5, 0.5, 3.5]");
    assert!(text.contains("scale"), "{text}");
    let warped = p("w.toml");
    std::fs::write(&warped, text).unwrap();
    let w = warped.to_str().unwrap();
    let v = level_json(&[w, "--rebake-warps-above", "1.25", "--warp-rays", "256"], &d, &p("w.mrtl"));
    assert_eq!(v["warps"]["distinct"], 1, "{v}");
    assert_eq!(v["warps"]["blocks_rebaked"], 1, "{v}");
    assert!(v["warps"]["seconds_per_warp"].as_f64().unwrap() > 0.0);
    // beyond the threshold only: S = 2 keeps the ×2 block on the dictionary's operators
    let v = level_json(&[w, "--rebake-warps-above", "2"], &d, &p("w2.mrtl"));
    assert_eq!(v["warps"]["distinct"], 0, "{v}");
    let v = level_json(&[w], &d, &p("w1.mrtl"));
    assert_eq!(std::fs::read(p("w1.mrtl")).unwrap(), std::fs::read(p("w2.mrtl")).unwrap(), "{v}");
    // inspect shows the kind version and the warp sections
    let (code, stdout, stderr) = run(penumbra().args(["inspect", "--json"]).arg(p("w.mrtl")));
    assert_eq!(code, 0, "{stderr}");
    for s in ["block_warp", "warp_shapes", "warp.0.u_b", "warp.0.t_d2b", "warp.0.to_dict_b", "stretched-prior"] {
        assert!(stdout.contains(s), "{s} missing from inspect");
    }
    let meta: Value = serde_json::from_str(&stdout).unwrap();
    assert!(stdout.contains("\"kind_version\":2") || meta.to_string().contains("\"kind_version\":2"));
    // verify mrt: both errors on the warped level; the re-baked asset and the old (kind
    // version 1) one verify as they are
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "mrt", "--rays", "64", "--bounces", "2", "--json", "--warp-rays", "256"])
        .args(["--rebake-warps-above", "1.25", "--level", w, "--dict"])
        .arg(&d));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    for k in ["rel_error_warped_unit_ops", "rel_error_warped_rebaked", "rel_error_warped_rebaked_multi_bounce"] {
        assert!(v[k].as_f64().is_some_and(|x| x.is_finite() && x > 0.0), "{k}: {v}");
    }
    assert_eq!(v["max_stretch"], 2.0);
    assert!(v["per_block"][1]["one_bounce_rebaked"].is_number());
    for lv in ["w.mrtl", "a.mrtl"] {
        let (code, _, stderr) = run(penumbra()
            .args(["verify", "mrt", "--rays", "16", "--bounces", "1", "--level"])
            .arg(p(lv))
            .arg("--dict")
            .arg(&d));
        assert_eq!(code, 0, "{lv}: {stderr}");
    }
}
