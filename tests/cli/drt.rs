//! `penumbra drt` and `penumbra verify drt` (MRT thesis ch. 5).

use crate::mrt_level::small_dict;
use crate::{penumbra, run};
use serde_json::Value;
use std::path::Path;

const FAST: &[&str] = &["--clutter-res", "4", "--rays", "128"];

fn drt_json(args: &[&str], dict: &Path, out: &Path) -> (i32, Value, String) {
    let (code, stdout, stderr) =
        run(penumbra().arg("drt").args(args).args(FAST).arg("--dict").arg(dict).arg("-o").arg(out).arg("--json"));
    (code, serde_json::from_str(&stdout).unwrap_or(Value::Null), stderr)
}

#[test]
fn drt_bakes_deterministically_and_beats_mrt_alone_on_the_pillars() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("p.drto");
    let (code, v, stderr) = drt_json(&["--example", "pillars"], &d, &out);
    assert_eq!(code, 0, "{stderr}");
    for k in [
        "blocks",
        "clutter_instances",
        "clutter_texels",
        "rays",
        "inpainted_texels",
        "inpaint_failures",
        "neighborhood",
        "bytes",
        "seconds",
        "output",
    ] {
        assert!(v.get(k).is_some(), "missing {k}: {v}");
    }
    assert_eq!(v["blocks"], 1);
    assert_eq!(v["clutter_instances"], 4);
    // four five-faced pillars, 4×4 texels per face
    assert_eq!(v["clutter_texels"], 4 * 5 * 16);
    assert_eq!(v["bytes"].as_u64().unwrap(), std::fs::metadata(&out).unwrap().len());
    let a = penumbra_asset::AssetFile::open(&out).unwrap();
    assert_eq!(a.asset().kind().as_str(), "DRTO");
    a.asset().require_known(penumbra_transport::drt_asset::DRTO_SECTIONS).unwrap();
    // f16 operators (the default) against f32: half the bytes, the same verified error
    let full = dir.path().join("p32.drto");
    let (code, v32, stderr) = drt_json(&["--example", "pillars", "--f32"], &d, &full);
    assert_eq!(code, 0, "{stderr}");
    assert!(v["bytes"].as_u64().unwrap() < v32["bytes"].as_u64().unwrap());
    let err_of = |asset: &Path| -> f64 {
        let (code, stdout, stderr) = run(penumbra()
            .args(["verify", "drt", "--example", "pillars", "--clutter-res", "4", "--reference-rays", "64", "--json"])
            .arg("--dict")
            .arg(&d)
            .arg("--drt")
            .arg(asset));
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<Value>(&stdout).unwrap()["rel_error_mrt_drt"].as_f64().unwrap()
    };
    let (e16, e32) = (err_of(&out), err_of(&full));
    assert!((e16 - e32).abs() <= 1e-3 * e32, "f16 {e16} vs f32 {e32}");
    // same bytes with one thread
    let again = dir.path().join("again.drto");
    let (code, _, stderr) = run(penumbra()
        .args(["--threads", "1", "drt", "--example", "pillars"])
        .args(FAST)
        .arg("--dict")
        .arg(&d)
        .arg("-o")
        .arg(&again));
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());

    // verify the baked asset against the path tracer with the pillars in it
    let png = dir.path().join("p.png");
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "drt", "--example", "pillars", "--clutter-res", "4", "--reference-rays", "256", "--json"])
        .arg("--dict")
        .arg(&d)
        .arg("--drt")
        .arg(&out)
        .arg("--image")
        .arg(&png));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    for k in [
        "rel_error_mrt",
        "rel_error_mrt_drt",
        "rel_error_clutter_cb",
        "rel_error_clutter_probes",
        "rel_error_mrt_drt_occlusion_only",
        "texels_inside_clutter",
        "reference_noise",
        "ms_runtime",
        "per_block",
        "boundary_points",
        "rel_error_boundary_inpainted",
        "rel_error_boundary_without_inpainting",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    let (mrt, drt) = (v["rel_error_mrt"].as_f64().unwrap(), v["rel_error_mrt_drt"].as_f64().unwrap());
    assert!(drt < 0.6 * mrt, "DRT {drt} vs MRT alone {mrt}");
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // a gate below the measured error exits 1
    let (code, _, _) = run(penumbra()
        .args(["verify", "drt", "--example", "pillars", "--clutter-res", "4", "--reference-rays", "16"])
        .arg("--dict")
        .arg(&d)
        .arg("--drt")
        .arg(&out)
        .args(["--max-rel-error", "1e-9"]));
    assert_eq!(code, 1);
    // an asset of another scene is refused
    let (code, _, stderr) = run(penumbra()
        .args(["verify", "drt", "--example", "cornell", "--clutter-res", "4"])
        .arg("--dict")
        .arg(&d)
        .arg("--drt")
        .arg(&out));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("another dictionary, level or clutter"), "{stderr}");
}

#[test]
fn bad_drt_inputs_are_clean_errors_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("x.drto");
    // a kind_version 2 dictionary has no L_imp: re-bake it
    let v2 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets/v1/mrt-cube2d-r4-interfaces.mrtd");
    let (code, _, stderr) = drt_json(&["--example", "pillars"], &v2, &out);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("kind_version 2") && stderr.contains("re-bake"), "{stderr}");
    let level = dir.path().join("room.toml");
    std::fs::write(&level, "[[block]]\nshape = \"closed\"\ntranslation = [0.5, 0.5, 0.5]\n").unwrap();
    let cases = [
        ("[[clutter]]\nbox = { size = [0.2, 0.5, 0.2] }\ntranslate = [0.5, 0, 0.5]\nrotat = 3\n", "rotat"),
        ("[[clutter]]\ntranslate = [0.5, 0, 0.5]\n", "clutter[0].mesh"),
        ("[[clutter]]\nbox = { size = [0.2, 0.5, 0.2] }\ntranslate = [5, 0, 5]\n", "outside every block"),
        ("[[clutter]]\nmesh = \"missing.obj\"\ntranslate = [0.5, 0, 0.5]\n", "missing.obj"),
    ];
    for (src, want) in cases {
        let c = dir.path().join("c.toml");
        std::fs::write(&c, src).unwrap();
        let (code, _, stderr) =
            drt_json(&["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap()], &d, &out);
        assert_eq!(code, 2, "{src}: {stderr}");
        assert!(stderr.contains(want), "{src}: {stderr}");
        assert!(!out.exists(), "no output on error");
    }
    // a mesh clutter from an OBJ the test writes
    let obj = dir.path().join("crate.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n",
    )
    .unwrap();
    let c = dir.path().join("c.toml");
    std::fs::write(&c, "[[clutter]]\nmesh = \"crate.obj\"\ntranslate = [0.4, 0.0, 0.4]\nscale = 0.2\n").unwrap();
    let (code, v, stderr) = drt_json(&["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap()], &d, &out);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(v["clutter_instances"], 1);
    // six box-projected charts of 4×4 texels (the mesh's largest extent / 4 = the face size / 4)
    assert_eq!(v["clutter_texels"], 6 * 16);
}

#[test]
fn clutter_schema_is_committed_and_fresh() {
    let (code, stdout, stderr) = run(penumbra().args(["schema", "--clutter"]));
    assert_eq!(code, 0, "{stderr}");
    let committed = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/schemas/clutter.schema.json"))
        .expect("schemas/clutter.schema.json (run `make schemas`)");
    assert_eq!(stdout, committed, "schemas/clutter.schema.json is stale: run `make schemas`");
}

/// `--shard K/N` over blocks and instances, then `drt merge` (any order): the bytes of one
/// run (on a maze, where several blocks receive and the instances spread over shards), and
/// clean refusals of incomplete or mixed shard sets; a shard is refused by the runtime.
#[test]
fn drt_shards_merge_to_the_single_run_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let scene = ["--example", "maze-boxes", "--maze", "4", "--seed", "2", "--boxes", "5"];
    let whole = dir.path().join("w.drto");
    let (code, v, stderr) = drt_json(&scene, &d, &whole);
    assert_eq!(code, 0, "{stderr}");
    assert!(v["blocks"].as_u64().unwrap() >= 2, "{v}");
    let mut parts = Vec::new();
    for k in 0..3 {
        let p = dir.path().join(format!("s{k}.drto"));
        let shard = format!("{k}/3");
        let mut args = scene.to_vec();
        args.extend(["--shard", &shard]);
        let (code, v, stderr) = drt_json(&args, &d, &p);
        assert_eq!(code, 0, "{stderr}");
        assert_eq!(v["shard"]["index"], k, "{v}");
        parts.push(p);
    }
    let merged = dir.path().join("m.drto");
    let (code, _, stderr) =
        run(penumbra().args(["drt", "merge"]).arg(&parts[2]).arg(&parts[0]).arg(&parts[1]).arg("-o").arg(&merged));
    assert_eq!(code, 0, "{stderr}");
    assert!(std::fs::read(&whole).unwrap() == std::fs::read(&merged).unwrap(), "merged bytes differ from one run");
    // a missing shard, and a whole bake given as a shard: exit 2, nothing written
    let bad = dir.path().join("bad.drto");
    let (code, _, stderr) = run(penumbra().args(["drt", "merge"]).arg(&parts[0]).arg(&parts[1]).arg("-o").arg(&bad));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("exactly once"), "{stderr}");
    let (code, _, stderr) = run(penumbra().args(["drt", "merge"]).arg(&whole).arg("-o").arg(&bad));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("not a shard"), "{stderr}");
    assert!(!bad.exists());
    // a shard does not pass as an operator set
    let f = penumbra_asset::AssetFile::open(&parts[0]).unwrap();
    assert!(f.asset().require_known(penumbra_transport::drt_asset::DRTO_SECTIONS).is_err());

    // with the vector and volume operators: each shard bakes its blocks' and instances'
    let mut vscene = scene.to_vec();
    vscene.extend(["--vector", "--vector-rays", "32", "--volume-res", "2"]);
    let whole = dir.path().join("vw.drto");
    let (code, v, stderr) = drt_json(&vscene, &d, &whole);
    assert_eq!(code, 0, "{stderr}");
    let mut parts = Vec::new();
    let mut rays = 0;
    for k in 0..2 {
        let p = dir.path().join(format!("v{k}.drto"));
        let shard = format!("{k}/2");
        let mut args = vscene.clone();
        args.extend(["--shard", &shard]);
        let (code, s, stderr) = drt_json(&args, &d, &p);
        assert_eq!(code, 0, "{stderr}");
        rays += s["vector"]["rays_traced"].as_u64().unwrap();
        parts.push(p);
    }
    // the shards split the vector rays, none twice
    assert_eq!(rays, v["vector"]["rays_traced"].as_u64().unwrap(), "{v}");
    let merged = dir.path().join("vm.drto");
    let (code, _, stderr) = run(penumbra().args(["drt", "merge"]).arg(&parts[1]).arg(&parts[0]).arg("-o").arg(&merged));
    assert_eq!(code, 0, "{stderr}");
    assert!(
        std::fs::read(&whole).unwrap() == std::fs::read(&merged).unwrap(),
        "merged vector bytes differ from one run"
    );
}

/// Inpainting measured where it matters: bilinear reads at texel corners next to texels
/// inside the Cornell boxes are closer to the path tracer with inpainting than without.
#[test]
fn verify_drt_measures_inpainting_at_bilinear_reads_next_to_clutter() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "drt", "--example", "cornell", "--clutter-res", "4", "--rays", "128"])
        .args(["--reference-rays", "256", "--ref-seed", "1", "--json", "--dict"])
        .arg(&d));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["boundary_points"].as_u64().unwrap() >= 1, "{v}");
    let (with, without) = (
        v["rel_error_boundary_inpainted"].as_f64().unwrap(),
        v["rel_error_boundary_without_inpainting"].as_f64().unwrap(),
    );
    assert!(with < without, "inpainted {with} vs without {without}");
}

/// A unit cube as glTF with split vertices per face and `TEXCOORD_1` laying each face on an
/// inset cell of a 3 × 2 grid (gap `g` of a cell), POSITION and TEXCOORD_1 in one buffer.
fn write_lightmapped_cube(dir: &Path, name: &str, g: f32) {
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([1.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ];
    let (mut pos, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for (f, (o, eu, ev)) in faces.iter().enumerate() {
        let (c, r) = ((f % 3) as f32, (f / 3) as f32);
        let b = (pos.len() / 3) as u16;
        for (a, bb) in [(0.0f32, 0.0f32), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            pos.extend((0..3).map(|k| o[k] + a * eu[k] + bb * ev[k]));
            uv.push((c + g + a * (1.0 - 2.0 * g)) / 3.0);
            uv.push((r + g + bb * (1.0 - 2.0 * g)) / 2.0);
        }
        idx.extend([b, b + 1, b + 2, b, b + 2, b + 3]);
    }
    let mut bin: Vec<u8> = Vec::new();
    bin.extend(pos.iter().flat_map(|x| x.to_le_bytes()));
    bin.extend(uv.iter().flat_map(|x| x.to_le_bytes()));
    bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let (pl, ul, il) = (pos.len() * 4, uv.len() * 4, idx.len() * 2);
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "cube"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_1": 1}, "indices": 2}]}],
        "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pl},
            {"buffer": 0, "byteOffset": pl, "byteLength": ul},
            {"buffer": 0, "byteOffset": pl + ul, "byteLength": il}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 24, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": 24, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 36, "type": "SCALAR"}
        ]
    });
    std::fs::write(dir.join(format!("{name}.gltf")), json.to_string()).unwrap();
}

#[test]
fn gltf_lightmap_uvs_are_the_clutter_charts() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("x.drto");
    let level = dir.path().join("room.toml");
    std::fs::write(&level, "[[block]]\nshape = \"closed\"\ntranslation = [0.5, 0.5, 0.5]\n").unwrap();
    // a gap of 0.04 keeps every cell centre off the rectangles' f32 edges
    write_lightmapped_cube(dir.path(), "cube", 0.04);
    let bake = |extra: &str| {
        let c = dir.path().join("c.toml");
        let src = format!("[[clutter]]\nmesh = \"cube.gltf\"\ntranslate = [0.4, 0.0, 0.4]\nscale = 0.2\n{extra}");
        std::fs::write(&c, src).unwrap();
        drt_json(&["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap()], &d, &out)
    };
    // cell centres of a 30² atlas inside each face's inset rectangle, counted here
    let n = 30;
    let mut want = 0;
    for f in 0..6 {
        let (c, r) = ((f % 3) as f64, (f / 3) as f64);
        let inside = |x: f64, lo: f64, k: f64| x >= (lo + 0.04) / k && x <= (lo + 0.96) / k;
        for j in 0..n {
            for i in 0..n {
                let (x, y) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                want += usize::from(inside(x, c, 3.0) && inside(y, r, 2.0));
            }
        }
    }
    let (code, v, stderr) = bake("lightmap_res = 30\n");
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(v["clutter_texels"].as_u64().unwrap() as usize, want);
    let a = penumbra_asset::AssetFile::open(&out).unwrap();
    let meta: Value = serde_json::from_str(a.asset().meta_json()).unwrap();
    let inst = &meta["inputs"]["clutter"][0];
    assert_eq!((inst["charts"].as_str(), inst["lightmap_res"].as_u64()), (Some("lightmap"), Some(30)), "{inst}");
    // the box projection of the same mesh: six charts of 4 × 4 (FAST's --clutter-res 4)
    let (code, v, stderr) = bake("charts = \"box-projection\"\n");
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(v["clutter_texels"], 6 * 16);
    // lightmap charts on a mesh without TEXCOORD_1, and a bad atlas size: exit 2, no output
    let obj = dir.path().join("plain.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n").unwrap();
    let c = dir.path().join("c.toml");
    std::fs::write(
        &c,
        "[[clutter]]\nmesh = \"plain.obj\"\ntranslate = [0.4, 0.0, 0.4]\nscale = 0.2\ncharts = \"lightmap\"\n",
    )
    .unwrap();
    std::fs::remove_file(&out).unwrap();
    let (code, _, stderr) = drt_json(&["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap()], &d, &out);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("TEXCOORD_1") && stderr.contains("plain.obj"), "{stderr}");
    let (code, _, stderr) = bake("lightmap_res = 1\n");
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("lightmap_res"), "{stderr}");
    assert!(!out.exists(), "no output on error");
}

#[test]
fn an_incremental_re_bake_copies_unchanged_records_from_the_previous_asset() {
    // two closed rooms, a pillar in each; the asset at -o is the one the state was baked with
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let level = dir.path().join("rooms.toml");
    std::fs::write(
        &level,
        "[[block]]\nshape = \"closed\"\ntranslation = [0.5, 0.5, 0.5]\n\
         [[block]]\nshape = \"closed\"\ntranslation = [2.5, 0.5, 0.5]\n",
    )
    .unwrap();
    let pillars = |x0: f64| {
        format!(
            "[[clutter]]\nbox = {{ size = [0.12, 0.75, 0.12], faces = \"no-bottom\" }}\ntranslate = [{x0}, 0.0, 0.4]\n\
             [[clutter]]\nbox = {{ size = [0.12, 0.75, 0.12], faces = \"no-bottom\" }}\ntranslate = [2.6, 0.0, 0.5]\n"
        )
    };
    let c = dir.path().join("c.toml");
    let state = dir.path().join("s.state");
    let out = dir.path().join("out.drto");
    let bake = |x0: f64, out: &std::path::Path, with_state: bool| {
        std::fs::write(&c, pillars(x0)).unwrap();
        let mut args = vec!["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap()];
        if with_state {
            args.extend(["--state", state.to_str().unwrap()]);
        }
        let (code, v, stderr) = drt_json(&args, &d, out);
        assert_eq!(code, 0, "{stderr}");
        (v, std::fs::read(out).unwrap())
    };
    bake(0.3, &out, true);
    let (v, inc) = bake(0.6, &out, true);
    let i = &v["incremental"];
    assert_eq!(i["used"], true, "{v}");
    // room 1's block and pillar are copied; room 0's block and the moved pillar assembled
    assert_eq!((i["records_reused"].as_u64(), i["records_assembled"].as_u64()), (Some(2), Some(2)), "{v}");
    assert!(i.get("records_reason").is_none(), "{v}");
    let (_, full) = bake(0.6, &dir.path().join("full.drto"), false);
    assert!(inc == full, "copied records give a full bake's bytes");
    // the asset at -o changed since: every record is assembled, and the reason is given
    std::fs::write(&out, b"not the asset").unwrap();
    let (v, inc) = bake(0.3, &out, true);
    let i = &v["incremental"];
    assert_eq!(i["records_reused"].as_u64(), Some(0), "{v}");
    assert!(i["records_reason"].as_str().unwrap().contains("not the asset the state was baked with"), "{v}");
    let (_, full) = bake(0.3, &dir.path().join("full0.drto"), false);
    assert!(inc == full);
}

#[test]
fn moving_one_pillar_re_bakes_incrementally_to_the_full_bake_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let level = dir.path().join("room.toml");
    std::fs::write(&level, "[[block]]\nshape = \"closed\"\ntranslation = [0.5, 0.5, 0.5]\n").unwrap();
    let pillars = |x1: f64, albedo: f64| {
        let mut s = String::new();
        for (x, z) in [(0.25, 0.25), (x1, 0.25), (0.25, 0.75), (0.75, 0.75)] {
            s += &format!(
                "[[clutter]]\nbox = {{ size = [0.12, 0.75, 0.12], faces = \"no-bottom\" }}\n\
                 translate = [{x}, 0.0, {z}]\nalbedo = {albedo}\n"
            );
        }
        s
    };
    let c = dir.path().join("c.toml");
    let state = dir.path().join("s.state");
    let bake = |src: &str, out: &str, with_state: bool, extra: &[&str]| {
        std::fs::write(&c, src).unwrap();
        let mut args = vec!["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap()];
        if with_state {
            args.extend(["--state", state.to_str().unwrap()]);
        }
        args.extend(extra);
        let out = dir.path().join(out);
        let (code, v, stderr) = drt_json(&args, &d, &out);
        assert_eq!(code, 0, "{stderr}");
        (v, std::fs::read(&out).unwrap())
    };
    let (v, _) = bake(&pillars(0.75, 0.6), "a.drto", true, &[]);
    assert_eq!(v["incremental"]["used"], false);
    assert_eq!(v["incremental"]["reason"], "no state file yet");
    // move pillar 1: only its rays and the rays that meet it are traced, to the same bytes
    let (v, inc) = bake(&pillars(0.6, 0.6), "b.drto", true, &[]);
    let i = &v["incremental"];
    assert_eq!(i["used"], true, "{v}");
    assert_eq!(i["moved"].as_array().unwrap().len(), 1, "{v}");
    assert!(i["moved"][0].as_str().unwrap().contains("clutter[1]"), "{v}");
    assert!(i["rays_cast"].as_u64().unwrap() < i["rays_full"].as_u64().unwrap() / 2, "{v}");
    let (_, full) = bake(&pillars(0.6, 0.6), "b_full.drto", false, &[]);
    assert!(inc == full, "the incremental bake's bytes are a full bake's");
    // a new albedo moves nothing: no ray is cast, the asset carries the new albedo
    let (v, inc) = bake(&pillars(0.6, 0.3), "c.drto", true, &[]);
    assert_eq!(v["incremental"]["used"], true, "{v}");
    assert_eq!(v["incremental"]["rays_cast"], 0, "{v}");
    let (_, full) = bake(&pillars(0.6, 0.3), "c_full.drto", false, &[]);
    assert!(inc == full);
    // other parameters: a full bake, and the reason
    let (v, _) = bake(&pillars(0.6, 0.3), "d.drto", true, &["--kc", "4"]);
    assert_eq!(v["incremental"]["used"], false);
    assert_eq!(v["incremental"]["reason"], "the dictionary, level or parameters changed");
    // a corrupt state is named and replaced by a full bake
    let mut b = std::fs::read(&state).unwrap();
    let n = b.len();
    b[n / 2] ^= 0x10;
    std::fs::write(&state, b).unwrap();
    let (v, _) = bake(&pillars(0.6, 0.3), "e.drto", true, &["--kc", "4"]);
    assert!(v["incremental"]["reason"].as_str().unwrap().contains("checksum mismatch"), "{v}");
    // --state and --shard do not go together
    let out = dir.path().join("f.drto");
    let (code, _, stderr) =
        drt_json(&["--example", "pillars", "--state", state.to_str().unwrap(), "--shard", "0/2"], &d, &out);
    assert_eq!(code, 2, "{stderr}");
    assert!(!out.exists());
    // a --state path that holds something else (here: an asset) is refused, not overwritten
    let asset = dir.path().join("a.drto");
    let before = std::fs::read(&asset).unwrap();
    let out = dir.path().join("g.drto");
    let (code, _, stderr) = drt_json(&["--example", "pillars", "--state", asset.to_str().unwrap()], &d, &out);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("a.drto") && stderr.contains("not a DRT state file"), "{stderr}");
    assert!(!out.exists());
    assert!(std::fs::read(&asset).unwrap() == before);
}

#[test]
fn moving_one_pillar_re_bakes_the_vector_operators_incrementally_to_the_full_bake_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let level = dir.path().join("room.toml");
    std::fs::write(&level, "[[block]]\nshape = \"closed\"\ntranslation = [0.5, 0.5, 0.5]\n").unwrap();
    let c = dir.path().join("c.toml");
    let state = dir.path().join("s.state");
    let bake = |x1: f64, out: &str, with_state: bool| {
        let mut s = String::new();
        for (x, z) in [(0.25, 0.25), (x1, 0.25), (0.25, 0.75), (0.75, 0.75)] {
            s += &format!(
                "[[clutter]]\nbox = {{ size = [0.12, 0.75, 0.12], faces = \"no-bottom\" }}\ntranslate = [{x}, 0.0, {z}]\n"
            );
        }
        std::fs::write(&c, s).unwrap();
        let mut args = vec!["--level", level.to_str().unwrap(), "--clutter", c.to_str().unwrap(), "--vector"];
        args.extend(["--vector-rays", "64"]);
        if with_state {
            args.extend(["--state", state.to_str().unwrap()]);
        }
        let out = dir.path().join(out);
        let (code, v, stderr) = drt_json(&args, &d, &out);
        assert_eq!(code, 0, "{stderr}");
        (v, std::fs::read(&out).unwrap())
    };
    let (v, _) = bake(0.75, "a.drto", true);
    assert_eq!(v["incremental"]["vector"]["used"], false, "{v}");
    let (v, inc) = bake(0.6, "b.drto", true);
    let vi = &v["incremental"]["vector"];
    assert_eq!(vi["used"], true, "{v}");
    let (traced, reused) = (vi["items_traced"].as_u64().unwrap(), vi["items_reused"].as_u64().unwrap());
    assert!(reused > 0 && traced > 0, "{v}");
    assert!(vi["rays_cast"].as_u64().unwrap() < v["vector"]["rays_traced"].as_u64().unwrap(), "{v}");
    let (_, full) = bake(0.6, "b_full.drto", false);
    assert!(inc == full, "the incremental vector bake's bytes are a full bake's");
}

#[test]
fn vector_operators_and_dyn_probes_beat_mrt_against_the_path_tracer() {
    // MRT thesis §5.4.3: ΔU_b⃗, ΔU_c⃗, C_b⃗ (normal maps) and U_dyn (volume probes), baked with
    // --vector and measured by verify drt at tilted normals and interior points
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let out = dir.path().join("v.drto");
    // for the measurements below, a dictionary whose U_bvol has 3³ probes (none inside a
    // pillar), so that U_dyn and MRT's probes share one grid
    let d3 = dir.path().join("d3.mrtd");
    let small3: Vec<&str> = crate::mrt::SMALL
        .iter()
        .enumerate()
        .map(|(i, a)| if i > 0 && crate::mrt::SMALL[i - 1] == "--volume-res" { "3" } else { *a })
        .collect();
    let (code, _, stderr) = run(penumbra().args(["mrt", "dict"]).args(&small3).arg("-o").arg(&d3));
    assert_eq!(code, 0, "{stderr}");
    let (code, v, stderr) = drt_json(&["--example", "pillars", "--vector", "--vector-rays", "256"], &d3, &out);
    assert_eq!(code, 0, "{stderr}");
    let vm = &v["vector"];
    assert_eq!(vm["vector_rays"], 256);
    assert_eq!(vm["probe_rays"], 1024);
    assert_eq!((vm["volume_res"].as_u64(), vm["probes"].as_u64()), (Some(3), Some(27)));
    assert_eq!(vm["probes_inside_clutter"], 0);
    let a = penumbra_asset::AssetFile::open(&out).unwrap();
    let mut known = penumbra_transport::drt_asset::DRTO_SECTIONS.to_vec();
    known.extend_from_slice(penumbra_transport::drt_asset::DRTO_VECTOR_SECTIONS);
    a.asset().require_known(&known).unwrap();
    assert_eq!(a.asset().section("dyn.probes").unwrap().dims(), [27, 3]);
    let meta: Value = serde_json::from_str(a.asset().meta_json()).unwrap();
    assert_eq!(meta["kind_version"], 2);
    // the dictionary's own grid (the small one's 2³): the lower four probes sit at the centres
    // of the four pillars (¾ tall, at x, z ∈ {¼, ¾}) and are filled from the upper four
    let g2 = dir.path().join("g2.drto");
    let (code, v2, stderr) = drt_json(&["--example", "pillars", "--vector", "--vector-rays", "64"], &d, &g2);
    assert_eq!(code, 0, "{stderr}");
    let vm2 = &v2["vector"];
    assert_eq!((vm2["volume_res"].as_u64(), vm2["probes"].as_u64()), (Some(2), Some(8)));
    assert_eq!((vm2["probes_inside_clutter"].as_u64(), vm2["probes_inpainted"].as_u64()), (Some(4), Some(4)));
    let a2 = penumbra_asset::AssetFile::open(&g2).unwrap();
    assert_eq!(a2.asset().section("dyn.inside").unwrap().as_u8().unwrap(), [1, 1, 0, 0, 1, 1, 0, 0]); // x fastest, then y
    // the same bytes with one thread
    let g2t = dir.path().join("g2t.drto");
    let (code, _, stderr) = run(penumbra()
        .args(["--threads", "1", "drt", "--example", "pillars", "--vector", "--vector-rays", "64"])
        .args(FAST)
        .arg("--dict")
        .arg(&d)
        .arg("-o")
        .arg(&g2t));
    assert_eq!(code, 0, "{stderr}");
    assert!(std::fs::read(&g2).unwrap() == std::fs::read(&g2t).unwrap(), "bytes depend on the thread count");
    // without --vector: kind version 1 and none of the vector sections
    let plain = dir.path().join("p.drto");
    let (code, pv, stderr) = drt_json(&["--example", "pillars"], &d, &plain);
    assert_eq!(code, 0, "{stderr}");
    assert!(pv.get("vector").is_none(), "{pv}");
    let pa = penumbra_asset::AssetFile::open(&plain).unwrap();
    assert!(pa.asset().section("vec.scene.values").is_none());

    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "drt", "--example", "pillars", "--clutter-res", "4", "--reference-rays", "256", "--json"])
        .arg("--dict")
        .arg(&d3)
        .arg("--drt")
        .arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let r: Value = serde_json::from_str(&stdout).unwrap();
    let x = &r["vector"];
    let f = |k: &str| x[k].as_f64().unwrap_or_else(|| panic!("{k}: {x}"));
    assert!(x["wall_receivers"].as_u64().unwrap() > 0 && x["volume_receivers"].as_u64().unwrap() > 0, "{x}");
    // the pillars' indirect shadows and bounced light at tilted normals, on the clutter and
    // in the volume: DRT's vector and volume response is closer to the path tracer than MRT's
    assert!(f("rel_error_vector_mrt_drt") < 0.6 * f("rel_error_vector_mrt"), "{x}");
    assert!(f("rel_error_clutter_vector_cb") < f("rel_error_clutter_vector_probes"), "{x}");
    assert!(f("rel_error_volume_dyn") < f("rel_error_volume_mrt_probes"), "{x}");
    // an asset without the vector sections reports none
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "drt", "--example", "pillars", "--clutter-res", "4", "--reference-rays", "16", "--json"])
        .arg("--dict")
        .arg(&d)
        .arg("--drt")
        .arg(&plain));
    assert_eq!(code, 0, "{stderr}");
    assert!(serde_json::from_str::<Value>(&stdout).unwrap()["vector"].is_null());
}

#[test]
fn bake_config_drt_stage_takes_the_vector_operators() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("scene.toml");
    let mrt = "[mrt]\nface_res = 4\nrays = 512\nkd = 24\nkb = 12\nvector_rays = 64\nvolume_res = 2\nprobe_rays = 64\n\
               test_lights = 3\nreference_rays = 128\nlf_spatial = 4\nlf_dir = 6\nlf_super = 2\nk_rlf = 24\nk_r = 8\n\
               response_rays = 64\n";
    let drt = "[drt]\nexample = \"pillars\"\nclutter_res = 4\nrays = 64\nvector_rays = 32\nvolume_res = 3\n";
    std::fs::write(&cfg, format!("output_dir = \"out\"\n{mrt}{drt}")).unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["stages"].as_array().unwrap().iter().any(|s| s["name"] == "drt" && s["status"] == "baked"), "{v}");
    // the stage writes what `penumbra drt --vector` writes with the same settings
    let out = dir.path().join("out");
    let staged = std::fs::read(out.join("clutter.drto")).unwrap();
    let again = dir.path().join("again.drto");
    let (code, _, stderr) = run(penumbra()
        .args(["drt", "--example", "pillars", "--clutter-res", "4", "--rays", "64", "--vector", "--vector-rays", "32"])
        .args(["--volume-res", "3", "--dict"])
        .arg(out.join("dictionary.mrtd"))
        .arg("-o")
        .arg(&again));
    assert_eq!(code, 0, "{stderr}");
    assert!(staged == std::fs::read(&again).unwrap(), "stage and command differ");
    let a = penumbra_asset::AssetFile::open(&again).unwrap();
    assert_eq!(a.asset().section("dyn.probes").unwrap().dims(), [27, 3]);
    // volume_res without vector_rays, and out of range: exit 2 naming the key
    for (body, key) in [
        ("[drt]\nexample = \"pillars\"\nvolume_res = 3\n", "drt.volume_res"),
        ("[drt]\nexample = \"pillars\"\nvector_rays = 8\n", "drt.vector_rays"),
    ] {
        std::fs::write(&cfg, format!("output_dir = \"out2\"\n{mrt}{body}")).unwrap();
        let (code, _, stderr) = run(penumbra().arg("bake").arg(&cfg));
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(key), "{key}: {stderr}");
    }
}

/// `drt --target-error` on the pillars at 4² texels per clutter face, 64 reference rays.
fn drt_target(dict: &Path, target: &str, extra: &[&str], out: &Path) -> (i32, Value, String) {
    let (code, stdout, stderr) = run(penumbra()
        .args(["drt", "--example", "pillars", "--clutter-res", "4", "--reference-rays", "64"])
        .args(["--target-error", target])
        .args(extra)
        .arg("--dict")
        .arg(dict)
        .arg("-o")
        .arg(out)
        .arg("--json"));
    (code, serde_json::from_str(&stdout).unwrap_or(Value::Null), stderr)
}

fn plain_drt(dict: &Path, rays: &Value, out: &Path) {
    let (code, _, stderr) = run(penumbra()
        .args(["drt", "--example", "pillars", "--clutter-res", "4", "--rays", &rays.to_string()])
        .arg("--dict")
        .arg(dict)
        .arg("-o")
        .arg(out));
    assert_eq!(code, 0, "{stderr}");
}

fn verified_rel_error(dict: &Path, asset: &Path) -> f64 {
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "drt", "--example", "pillars", "--clutter-res", "4"])
        .args(["--reference-rays", "64", "--json", "--dict"])
        .arg(dict)
        .arg("--drt")
        .arg(asset));
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str::<Value>(&stdout).unwrap()["rel_error_mrt_drt"].as_f64().unwrap()
}

#[test]
fn target_error_writes_the_fewest_rays_that_meet_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    // unreachable under the budget: exit 1, the best asset written
    let best = dir.path().join("best.drto");
    let (code, v, stderr) = drt_target(&d, "0.000001", &["--max-rays", "128"], &best);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("quality gate failed"), "{stderr}");
    for k in ["target", "chosen", "measured", "search_seconds", "candidates_tried", "target_met", "reason"] {
        assert!(v.get(k).is_some(), "missing {k}: {v}");
    }
    let tried = v["candidates_tried"].as_array().unwrap().clone();
    let rays: Vec<u64> = tried.iter().map(|t| t["settings"]["rays"].as_u64().unwrap()).collect();
    assert_eq!(rays, [32, 64, 128]);
    let m: Vec<f64> = tried.iter().map(|t| t["measured"].as_f64().unwrap()).collect();
    assert_eq!(v["measured"].as_f64().unwrap(), m.iter().copied().fold(f64::INFINITY, f64::min));
    let plain = dir.path().join("plain-best.drto");
    plain_drt(&d, &v["chosen"]["rays"], &plain);
    assert!(std::fs::read(&plain).unwrap() == std::fs::read(&best).unwrap(), "best asset != its plain bake");

    // a target the first rung misses and a later one meets
    let j =
        (1..m.len()).find(|&j| m[j] < m[..j].iter().copied().fold(f64::INFINITY, f64::min)).expect("more rays help");
    let target = 0.5 * (m[j] + m[..j].iter().copied().fold(f64::INFINITY, f64::min));
    let out = dir.path().join("t.drto");
    let (code, v, stderr) = drt_target(&d, &target.to_string(), &[], &out);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(v["target_met"], true);
    assert_eq!(v["chosen"], tried[j]["settings"]);
    assert_eq!(v["measured"].as_f64().unwrap(), m[j]);
    let now = v["candidates_tried"].as_array().unwrap();
    assert_eq!(now.len(), j + 1);
    for t in &now[..j] {
        assert!(t["measured"].as_f64().unwrap() > target, "{t}");
    }
    assert!(v["rel_error_clutter_cb"].as_f64().is_some() && v["rel_error_mrt"].as_f64().is_some());
    let plain = dir.path().join("plain.drto");
    plain_drt(&d, &v["chosen"]["rays"], &plain);
    assert!(std::fs::read(&plain).unwrap() == std::fs::read(&out).unwrap(), "chosen asset != its plain bake");
    // an independent verify: the chosen meets the target, the next cheaper rung does not
    let e = verified_rel_error(&d, &out);
    assert!((e - m[j]).abs() <= 1e-9 * m[j], "verify {e} vs search {}", m[j]);
    let cheaper = dir.path().join("cheaper.drto");
    plain_drt(&d, &tried[j - 1]["settings"]["rays"], &cheaper);
    assert!(verified_rel_error(&d, &cheaper) > target);

    // a target with a knob it chooses, or a bad value: exit 2, nothing written
    let x = dir.path().join("x.drto");
    for (t, extra) in [
        ("0.1", &["--rays", "64"][..]),
        ("0.1", &["--clutter-rays", "64"]),
        ("0.1", &["--state", "s.state"]),
        ("0", &[]),
        ("nan", &[]),
        ("0.1", &["--max-rays", "16"]),
    ] {
        let (code, _, stderr) = drt_target(&d, t, extra, &x);
        assert_eq!(code, 2, "{t} {extra:?}: {stderr}");
        assert!(!x.exists());
    }
}
