//! `penumbra vo` (MRT thesis §6.3.5) and the `[vo]` bake stage.

use crate::{penumbra, run};
use serde_json::Value;

const SMALL: &[&str] = &["--counts", "1..4", "--starts", "2", "--noise-trials", "64"];

fn vo_json(extra: &[&str], out: &std::path::Path) -> Value {
    let (code, stdout, stderr) = run(penumbra().arg("vo").args(SMALL).args(extra).arg("-o").arg(out).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).expect("one JSON object")
}

#[test]
fn vo_bake_keys_asset_and_thread_independence() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.voss");
    let v = vo_json(&[], &a);
    for k in ["sets", "domains", "bytes", "seconds", "comparison", "electrostatic_vs_n_le_16", "output"] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["sets"], 16);
    assert_eq!(v["domains"], serde_json::json!(["disk", "ball"]));
    assert_eq!(v["bytes"].as_u64().unwrap(), std::fs::metadata(&a).unwrap().len());
    let rows = v["comparison"].as_array().unwrap();
    assert_eq!(rows.len(), 16);
    for r in rows {
        for m in ["electrostatic", "lloyd", "halton", "poisson"] {
            assert!(r[m]["cell_cv"].as_f64().unwrap() >= 0.0);
            assert!(r[m]["noise"].as_f64().unwrap() > 0.0);
        }
    }
    let f = penumbra_asset::AssetFile::open(&a).unwrap();
    let asset = f.asset();
    assert_eq!(asset.kind().as_str(), "VOSS");
    let w = asset.section("ball.c1.n4.weights").unwrap().to_f32_vec().unwrap();
    assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    assert_eq!(asset.section("disk.c0.n3.points").unwrap().dims(), &[3, 2]);
    assert_eq!(asset.section("ball.c0.n3.points").unwrap().dims(), &[3, 3]);
    // same bytes on one and two threads
    let b = dir.path().join("b.voss");
    let (code, _, stderr) = run(penumbra().args(["--threads", "1", "vo"]).args(SMALL).arg("-o").arg(&b));
    assert_eq!(code, 0, "{stderr}");
    let c = dir.path().join("c.voss");
    let (code, _, stderr) = run(penumbra().args(["--threads", "2", "vo"]).args(SMALL).arg("-o").arg(&c));
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(std::fs::read(&b).unwrap(), std::fs::read(&c).unwrap());
}

#[test]
fn vo_bad_counts_exit_2_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.voss");
    for bad in ["0..4", "1..300", "9,5", "4..2", "many"] {
        let (code, _, stderr) = run(penumbra().args(["vo", "--counts", bad]).arg("-o").arg(&out));
        assert_eq!(code, 2, "{bad}: {stderr}");
        assert!(stderr.contains("--counts"), "{stderr}");
    }
    assert!(!out.exists());
}

#[test]
fn vo_bake_stage_bakes_then_skips() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("b.toml");
    std::fs::write(&cfg, "output_dir = \"out\"\n[vo]\ncounts = [1, 2, 3]\nstarts = 2\nnoise_trials = 32\n").unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["name"], "vo");
    assert_eq!(v["stages"][0]["status"], "baked");
    assert_eq!(v["stages"][0]["metrics"]["sets"], 12);
    let (code, stdout, _) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0);
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["stages"][0]["status"], "up-to-date");
    // out of range values name the key path
    std::fs::write(&cfg, "output_dir = \"out\"\n[vo]\ncounts = [3, 2]\n").unwrap();
    let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
    assert_eq!(code, 2);
    assert!(stderr.contains("vo.counts"), "{stderr}");
}

/// A closed axis-aligned box as OBJ text.
fn box_obj(lo: [f64; 3], hi: [f64; 3]) -> String {
    let mut s = String::new();
    for k in 0..8 {
        let v: Vec<f64> = (0..3).map(|a| if (k >> a) & 1 == 1 { hi[a] } else { lo[a] }).collect();
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for q in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
        s += &format!("f {} {} {}\nf {} {} {}\n", q[0] + 1, q[1] + 1, q[2] + 1, q[0] + 1, q[2] + 1, q[3] + 1);
    }
    s
}

#[test]
fn verify_vo_on_a_box_face_is_a_half_and_with_the_normal_one() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("box.obj");
    std::fs::write(&mesh, box_obj([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])).unwrap();
    let img = dir.path().join("vo.png");
    let base = ["verify", "vo", "--res", "48", "--radius", "0.02", "--pixels", "200", "--mc", "128", "--json"];
    let (code, stdout, stderr) =
        run(penumbra().args(base).arg("--mesh").arg(&mesh).args(["--method", "lines:9"]).arg("--image").arg(&img));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    for k in ["bias", "noise", "rmse_vs_volume", "rmse_vs_heightfield", "ns_per_pixel", "heightfield_vs_volume_rmse"] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    // a small ball on a flat face away from the edges: half free in both truths and by lines
    // (every line is exactly half free: the estimate has no noise)
    assert!((v["mean_estimate"].as_f64().unwrap() - 0.5).abs() < 0.02, "{v}");
    assert!(v["noise"].as_f64().unwrap() < 0.02);
    assert!((v["mean_volume"].as_f64().unwrap() - 0.5).abs() < 0.03);
    assert!(std::fs::metadata(&img).unwrap().len() > 100);
    // the same from a perspective camera: the face is still half free
    let (code, stdout, stderr) =
        run(penumbra().args(base).arg("--mesh").arg(&mesh).args(["--method", "lines:9", "--perspective"]));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["perspective"], true);
    assert!((v["mean_volume"].as_f64().unwrap() - 0.5).abs() < 0.05, "{v}");
    assert!((v["mean_estimate"].as_f64().unwrap() - v["mean_heightfield"].as_f64().unwrap()).abs() < 0.05, "{v}");
    let (code, stdout, stderr) =
        run(penumbra().args(base).arg("--mesh").arg(&mesh).args(["--method", "points:12", "--normal"]));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["mean_estimate"].as_f64().unwrap() > 0.95, "{v}");
    // bad input: exit 2 naming the problem
    let (code, _, stderr) = run(penumbra().args(["verify", "vo", "--method", "cones:3"]).arg("--mesh").arg(&mesh));
    assert_eq!(code, 2);
    assert!(stderr.contains("--method"), "{stderr}");
    let (code, _, stderr) = run(penumbra().args(["verify", "vo", "--mesh", "/nonexistent/x.obj"]));
    assert_eq!(code, 2, "{stderr}");
}

/// `--max-rmse` gates `rmse_vs_volume`: a bound above the measured value exits 0, one below it
/// exits 1 with the report still printed; JSON reports the bound and `gate_passed`.
#[test]
fn verify_vo_max_rmse_gate() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("box.obj");
    std::fs::write(&mesh, box_obj([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])).unwrap();
    let base = ["verify", "vo", "--res", "32", "--radius", "0.2", "--pixels", "100", "--mc", "64", "--json"];
    let gate = |extra: &[&str]| {
        let (code, stdout, stderr) = run(penumbra().args(base).arg("--mesh").arg(&mesh).args(extra));
        let v: Value = serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{e}: {stdout} {stderr}"));
        (code, v, stderr)
    };
    let (code, v, _) = gate(&[]);
    assert_eq!(code, 0);
    assert_eq!(v["gate_passed"], Value::Null);
    assert_eq!(v["max_rmse"], Value::Null);
    let e = v["rmse_vs_volume"].as_f64().unwrap();
    // a radius of 0.2 reaches round the box's edges: the depth buffer misses what lies behind
    assert!(e > 1e-3, "{v}");
    let (code, v, _) = gate(&["--max-rmse", &format!("{}", 2.0 * e)]);
    assert_eq!(code, 0);
    assert_eq!(v["gate_passed"], true);
    assert_eq!(v["max_rmse"], 2.0 * e);
    let (code, v, stderr) = gate(&["--max-rmse", &format!("{}", 0.5 * e)]);
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(v["gate_passed"], false);
    assert!(stderr.contains("quality gate failed: rmse_vs_volume"), "{stderr}");
    let (code, _, stderr) = run(penumbra().args(["verify", "vo", "--max-rmse", "0"]).arg("--mesh").arg(&mesh));
    assert_eq!(code, 2);
    assert!(stderr.contains("--max-rmse"), "{stderr}");
}

#[test]
fn verify_vo_knight_lines_beat_points_at_lower_count() {
    let Some(data) = crate::shared_data() else { return };
    let mesh = data.join("meshes/decimated-knight.obj");
    let go = |m: &str| -> Value {
        let (code, stdout, stderr) = run(penumbra()
            .args(["verify", "vo", "--res", "128", "--pixels", "300", "--mc", "64", "--json", "--method", m])
            .arg("--mesh")
            .arg(&mesh));
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str(&stdout).unwrap()
    };
    let l = go("lines:5");
    let p = go("points:12");
    // per-pixel noise (over reflections): 5 lines below 12 points (Fig. 6.7's claim, measured)
    assert!(l["noise"].as_f64().unwrap() < p["noise"].as_f64().unwrap(), "{l} {p}");
}
