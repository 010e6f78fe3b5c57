//! `penumbra verify shadows` and `penumbra sweep shadows` on the committed demo character under
//! a procedural environment (no external data).

use crate::{listing, penumbra, run};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn character() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("bake-configs/assets/character.obj")
}

/// Bakes small tables and a small sphere set with a hierarchy into `dir`.
fn assets(dir: &Path) -> (PathBuf, PathBuf) {
    let t = dir.join("t3.shtb");
    let (code, _, e) = run(penumbra().args(["tables", "--order", "3", "--theta-samples", "64", "-o"]).arg(&t));
    assert_eq!(code, 0, "{e}");
    let s = dir.join("c.sphr");
    let (code, _, e) = run(penumbra()
        .arg("spheres")
        .arg(character())
        .args(["--count", "12", "--grid", "20", "--iterations", "8", "--hierarchy", "-o"])
        .arg(&s));
    assert_eq!(code, 0, "{e}");
    (t, s)
}

fn verify(dir: &Path, t: &Path, s: &Path, extra: &[&str]) -> (i32, Value, String) {
    let mut c = penumbra();
    c.args(["verify", "shadows", "--tables"]).arg(t).arg("--spheres").arg(s).arg("--mesh").arg(character());
    c.args(["--env", "builtin:area-lights", "--resolution", "16", "--rays", "12", "--json"]).args(extra);
    let _ = dir;
    let (code, out, err) = run(&mut c);
    (code, serde_json::from_str(&out).unwrap_or(Value::Null), err)
}

#[test]
fn verify_reports_every_error_with_honest_values() {
    let dir = tempfile::tempdir().unwrap();
    let (t, s) = assets(dir.path());
    let img = dir.path().join("v.png");
    let (code, v, err) = verify(dir.path(), &t, &s, &["--image", img.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    for k in [
        "nrmse_vs_mesh",
        "nrmse_vs_mesh_full",
        "nrmse_vs_spheres",
        "nrmse_log_vs_product",
        "receivers",
        "ns_per_receiver",
        "exp_method",
        "order",
        "sphere_count",
    ] {
        assert!(v.get(k).is_some_and(|x| !x.is_null()), "missing {k}: {v}");
    }
    assert_eq!(v["receivers"], 256);
    assert_eq!(v["order"], 3);
    assert_eq!(v["sphere_count"], 12);
    assert_eq!(v["exp_method"], "hyb");
    for k in ["nrmse_vs_mesh", "nrmse_vs_mesh_full", "nrmse_vs_spheres", "nrmse_log_vs_product"] {
        let x = v[k].as_f64().unwrap();
        assert!(x > 0.0 && x < 0.5, "{k} = {x}");
    }
    // log space is close to product space; proxies are close to the mesh they bound
    assert!(v["nrmse_log_vs_product"].as_f64().unwrap() < 0.05, "{v}");
    assert!(v["nrmse_spheres_vs_mesh"].as_f64().unwrap() < 0.15, "{v}");
    let png = std::fs::read(&img).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // three panels of at least 512 px, a colour bar and a caption
    let (w, h) =
        (u32::from_be_bytes(png[16..20].try_into().unwrap()), u32::from_be_bytes(png[20..24].try_into().unwrap()));
    assert!(w >= 3 * 512 && h > 512 + 4 * 22, "{w} x {h}");
    // the hierarchy path gives nearly the same answer with fewer blockers
    let (code, h, err) = verify(dir.path(), &t, &s, &["--hierarchy", "--cluster", "4"]);
    assert_eq!(code, 0, "{err}");
    // 12 leaves: the cut must replace some of them by nodes on this plane (a cut that always
    // listed all 12 would report exactly 12)
    let bpr = h["candidate_blockers_per_receiver"].as_f64().unwrap();
    assert!(bpr > 1.0 && bpr < 12.0, "blockers per receiver {bpr}: {h}");
    assert!(h["blockers_per_receiver"].as_f64().unwrap() <= bpr, "{h}");
    assert!((h["nrmse_vs_mesh"].as_f64().unwrap() - v["nrmse_vs_mesh"].as_f64().unwrap()).abs() < 0.05, "{h}");
    // mesh receivers (self-shadowing) run too
    let (code, m, err) = verify(dir.path(), &t, &s, &["--receivers", "mesh", "--max-receivers", "200"]);
    assert_eq!(code, 0, "{err}");
    assert!(m["receivers"].as_u64().unwrap() <= 200 && m["receivers"].as_u64().unwrap() > 100);
    // on its own surface a receiver has spheres behind its tangent plane or around it, which
    // the self-shadow rules drop: fewer accumulated than handed over (all 12 leaves)
    assert_eq!(m["candidate_blockers_per_receiver"], 12.0);
    let acc = m["blockers_per_receiver"].as_f64().unwrap();
    assert!(acc > 0.5 && acc < 11.0, "accumulated blockers per receiver {acc}: {m}");
    assert_eq!(v["candidate_blockers_per_receiver"], 12.0);
    // accumulating at a higher order is closer to the sphere truth (SHEXP Fig. 7e)
    let t5 = dir.path().join("t5.shtb");
    let (code, _, e) = run(penumbra().args(["tables", "--order", "5", "--theta-samples", "64", "-o"]).arg(&t5));
    assert_eq!(code, 0, "{e}");
    let (code, a5, err) = verify(dir.path(), &t, &s, &["--accumulate-tables", t5.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(a5["accumulation_order"], 5);
    assert!(a5["nrmse_vs_spheres"].as_f64().unwrap() < v["nrmse_vs_spheres"].as_f64().unwrap(), "{a5} vs {v}");
}

#[test]
fn verify_bad_inputs_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (t, s) = assets(dir.path());
    // swapped assets: kinds are checked
    let (code, _, err) = verify(dir.path(), &s, &t, &[]);
    assert_eq!(code, 2);
    assert!(err.contains("SHTB") || err.contains("SPHR"), "{err}");
    let (code, _, err) = verify(dir.path(), &t, &dir.path().join("nope.sphr"), &[]);
    assert_eq!(code, 2);
    assert!(err.contains("nope.sphr"), "{err}");
    let (code, _, err) = verify(dir.path(), &t, &s, &["--theta-max", "95"]);
    assert_eq!(code, 2);
    assert!(err.contains("theta-max"), "{err}");
    // accumulation order below the shading order
    let t2 = dir.path().join("t2.shtb");
    let (code, _, _) = run(penumbra().args(["tables", "--order", "2", "--theta-samples", "32", "-o"]).arg(&t2));
    assert_eq!(code, 0);
    let (code, _, err) = verify(dir.path(), &t, &s, &["--accumulate-tables", t2.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("below"), "{err}");
    let (code, _, err) = verify(dir.path(), &t, &s, &["--max-nrmse=-1"]);
    assert_eq!(code, 2);
    assert!(err.contains("max-nrmse"), "{err}");
}

#[test]
fn verify_max_nrmse_gates_and_far_receivers_report_by_distance() {
    let dir = tempfile::tempdir().unwrap();
    let (t, s) = assets(dir.path());
    let mut c = penumbra();
    c.args(["verify", "shadows", "--tables"]).arg(&t).arg("--spheres").arg(&s).arg("--mesh").arg(character());
    c.args(["--env", "builtin:area-lights", "--resolution", "8", "--rays", "12", "--json", "--receivers", "far"]);
    let (code, out, err) = run(&mut c);
    let v: Value = serde_json::from_str(&out).unwrap_or(Value::Null);
    assert_eq!(code, 0, "{err}");
    let list = v["nrmse_by_distance"].as_array().unwrap();
    assert_eq!(list.len(), 7);
    assert_eq!(list[0]["diagonals"], 0.5);
    assert_eq!(list[6]["diagonals"], 20.0);
    assert_eq!(v["receivers"], 7 * 64);
    for e in list {
        for k in ["nrmse_vs_spheres", "nrmse_vs_mesh"] {
            assert!(e[k].as_f64().is_some_and(|x| x.is_finite() && x >= 0.0), "{k}: {e}");
        }
    }
    // a gate above the error passes, one below it fails with exit 1 and still reports
    let (code, p, err) = verify(dir.path(), &t, &s, &[]);
    assert_eq!(code, 0, "{err}");
    let e = p["nrmse_vs_mesh"].as_f64().unwrap();
    let (code, g, err) = verify(dir.path(), &t, &s, &["--max-nrmse", &format!("{}", 2.0 * e)]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(g["gate_passed"], true);
    let (code, g, _) = verify(dir.path(), &t, &s, &["--max-nrmse", &format!("{}", 0.5 * e)]);
    assert_eq!(code, 1);
    assert_eq!(g["gate_passed"], false);
}

#[test]
fn tables_reject_theta_samples_that_cannot_hold_the_smooth_clamp() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) =
        run(penumbra().args(["tables", "--order", "4", "--theta-samples", "16", "-o"]).arg(dir.path().join("t.shtb")));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("smooth clamp") && err.contains("theta-samples"), "{err}");
    assert!(!dir.path().join("t.shtb").exists());
}

#[test]
fn sweep_writes_table_json_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let mut c = penumbra();
    c.args(["sweep", "shadows", "--mesh"]).arg(character());
    c.args([
        "--env",
        "builtin:area-lights",
        "--counts",
        "4,8",
        "--orders",
        "3",
        "--resolution",
        "12",
        "--rays",
        "8",
        "-o",
    ])
    .arg(&out);
    let (code, _, err) = run(&mut c);
    assert_eq!(code, 0, "{err}");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with("count,order,exp_method,"));
    let j: Value = serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(j["rows"].as_array().unwrap().len(), 2);
    assert!(j["rows"][1]["bake_seconds"].as_f64().unwrap() > 0.0);
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.matches("<circle").count() == 4, "two panels × two points");
    let l = listing(&out);
    assert!(l.contains(&"spheres-4.sphr".to_string()) && l.contains(&"tables-o3.shtb".to_string()), "{l:?}");
}

#[test]
fn verify_local_light_and_indirect_report_their_keys() {
    let dir = tempfile::tempdir().unwrap();
    let (t, s) = assets(dir.path());
    // a light beside and above the character (bounds about ±1 around the origin, y up)
    let (code, v, err) = verify(dir.path(), &t, &s, &["--local-light", "1.5,3.0,0.5,0.4", "--indirect"]);
    assert_eq!(code, 0, "{err}");
    for k in ["nrmse_local_light", "nrmse_local_light_vs_spheres", "nrmse_local_light_unshadowed"] {
        let x = v[k].as_f64().unwrap_or(f64::NAN);
        assert!(x > 0.0 && x < 0.5, "{k} = {x}: {v}");
    }
    for op in ["point", "d", "m"] {
        let x = v["nrmse_indirect"][op].as_f64().unwrap_or(f64::NAN);
        assert!(x > 0.0 && x < 1.0, "nrmse_indirect.{op} = {x}: {v}");
        assert!(v["indirect_ns_per_receiver"][op].as_f64().unwrap() > 0.0);
    }
    assert!(v["indirect_reference_mean"].as_f64().unwrap() > 0.0, "the proxies reflect light: {v}");
    // bad values: exit 2 naming the flag
    let (code, _, err) = verify(dir.path(), &t, &s, &["--local-light", "1,2,3"]);
    assert_eq!(code, 2);
    assert!(err.contains("--local-light"), "{err}");
    let (code, _, err) = verify(dir.path(), &t, &s, &["--local-light", "0,0,0,5"]);
    assert_eq!(code, 2, "a light containing receivers");
    assert!(err.contains("inside the light"), "{err}");
    let (code, _, err) = verify(dir.path(), &t, &s, &["--indirect", "--albedo", "1.2,0,0"]);
    assert_eq!(code, 2);
    assert!(err.contains("--albedo"), "{err}");
}

/// Two boxes of known material albedo as GLB (issue #14 §2, IBPA §5 per-proxy albedo).
fn two_material_glb(dir: &Path, a: [f32; 4], b: [f32; 4]) -> PathBuf {
    use penumbra_testkit::gltf::{Part, cuboid, glb};
    let x = cuboid([-1.2, 0.0, -0.5], [-0.2, 1.0, 0.5]);
    let y = cuboid([0.2, 0.0, -0.5], [1.2, 1.0, 0.5]);
    let bytes = glb(&[
        Part { positions: &x.0, triangles: &x.1, base_color: Some(a) },
        Part { positions: &y.0, triangles: &y.1, base_color: Some(b) },
    ]);
    let p = dir.join(format!("boxes-{}-{}.glb", a[0], b[0]));
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn spheres_store_material_albedo_and_verify_indirect_uses_it() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("t3.shtb");
    let (code, _, e) = run(penumbra().args(["tables", "--order", "3", "--theta-samples", "64", "-o"]).arg(&t));
    assert_eq!(code, 0, "{e}");
    let bake = |mesh: &Path, name: &str, extra: &[&str]| -> (PathBuf, Value) {
        let s = dir.path().join(name);
        let (code, out, e) = run(penumbra()
            .arg("spheres")
            .arg(mesh)
            .args(["--count", "4", "--grid", "16", "--iterations", "6", "--json", "-o"])
            .arg(&s)
            .args(extra));
        assert_eq!(code, 0, "{e}");
        (s, serde_json::from_str(&out).unwrap())
    };
    let ver = |s: &Path, mesh: &Path, extra: &[&str]| -> Value {
        let mut c = penumbra();
        c.args(["verify", "shadows", "--tables"]).arg(&t).arg("--spheres").arg(s).arg("--mesh").arg(mesh);
        c.args(["--env", "builtin:area-lights", "--resolution", "12", "--rays", "8", "--json", "--indirect"]);
        let (code, out, err) = run(c.args(extra));
        assert_eq!(code, 0, "{err}");
        serde_json::from_str(&out).unwrap()
    };
    // two materials: the stored albedos are the two factors (one box per sphere pair)
    let red = [0.9f32, 0.2, 0.1, 1.0];
    let grey = [0.4f32, 0.4, 0.4, 1.0];
    let two = two_material_glb(dir.path(), red, grey);
    let (s2, j) = bake(&two, "two.sphr", &[]);
    assert_eq!(j["albedo_from_materials"], true, "{j}");
    let f = penumbra_asset::AssetFile::open(&s2).unwrap();
    let set = penumbra_spheres::asset::read(&f.asset()).unwrap();
    assert!(f.asset().meta_json().contains("\"kind_version\":2"));
    for (sp, al) in set.spheres.iter().zip(set.albedo.as_ref().unwrap()) {
        let want = if sp[0] < 0.0 { red } else { grey };
        assert!((0..3).all(|k| (al[k] - want[k]).abs() < 1e-6), "{sp:?}: {al:?}");
    }
    let v = ver(&s2, &two, &[]);
    assert_eq!(v["albedo_source"], "sphr", "{v}");
    assert!((v["albedo_max"][0].as_f64().unwrap() - 0.9).abs() < 1e-6, "{v}");
    assert!((v["albedo_min"][2].as_f64().unwrap() - 0.1).abs() < 1e-6, "{v}");
    // one grey material of 0.4 against the same set with --albedo 0.8: the reference and every
    // operator's result halve (same seeds), so the NRMSEs agree
    let (s1, _) = bake(&two_material_glb(dir.path(), grey, grey), "grey.sphr", &[]);
    let g = two_material_glb(dir.path(), grey, grey);
    let stored = ver(&s1, &g, &[]);
    let flag = ver(&s1, &g, &["--albedo", "0.8"]);
    assert_eq!(flag["albedo_source"], "flag");
    let (ms, mf) =
        (stored["indirect_reference_mean"].as_f64().unwrap(), flag["indirect_reference_mean"].as_f64().unwrap());
    assert!(ms > 0.0 && (ms / mf - 0.5).abs() < 1e-7, "stored {ms} vs --albedo 0.8 {mf}");
    for op in ["point", "d", "m"] {
        let (a, b) = (stored["nrmse_indirect"][op].as_f64().unwrap(), flag["nrmse_indirect"][op].as_f64().unwrap());
        assert!((a - b).abs() < 1e-6 * b.max(1e-9), "{op}: {a} vs {b}");
    }
    // an OBJ without --albedo stores none (and verify falls back to 0.8); with it, every sphere
    let (s3, j3) = bake(&character(), "c.sphr", &[]);
    assert!(j3["albedo_mean"].is_null(), "{j3}");
    assert_eq!(ver(&s3, &character(), &[])["albedo_source"], "default");
    let (s4, j4) = bake(&character(), "c2.sphr", &["--albedo", "0.3,0.5,0.7"]);
    assert_eq!(j4["albedo_mean"], serde_json::json!([0.30000001192092896, 0.5, 0.699999988079071]), "{j4}");
    let f = penumbra_asset::AssetFile::open(&s4).unwrap();
    assert_eq!(penumbra_spheres::asset::read(&f.asset()).unwrap().albedo.unwrap().len(), 4);
    // bad --albedo: exit 2 naming the flag, nothing written
    let bad = dir.path().join("bad.sphr");
    let (code, _, e) =
        run(penumbra().arg("spheres").arg(character()).args(["--count", "2", "--albedo", "2", "-o"]).arg(&bad));
    assert_eq!(code, 2);
    assert!(e.contains("--albedo") && !bad.exists(), "{e}");
}
