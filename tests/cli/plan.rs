//! `penumbra plan`: the bake config of a glTF level, from node extras and `--role` patterns.

use crate::{listing, penumbra, run, shared_data};
use penumbra_config::{BakeConfig, NodeSelect};
use serde_json::{Value, json};
use std::path::Path;

type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Quads (four corners each, in order) as a mesh.
fn quads(qs: &[[[f32; 3]; 4]]) -> Mesh {
    let mut m: Mesh = (Vec::new(), Vec::new());
    for q in qs {
        let b = m.0.len() as u32;
        m.0.extend_from_slice(q);
        m.1.push([b, b + 1, b + 2]);
        m.1.push([b, b + 2, b + 3]);
    }
    m
}

/// A room `[x0, x0+1] × [0, 1] × [z0, z0+1]`: floor, ceiling and the side walls named in
/// `walls` (`-x`, `+x`, `-z`, `+z`).
fn room(x0: f32, z0: f32, walls: &[&str]) -> Mesh {
    let (x1, z1) = (x0 + 1.0, z0 + 1.0);
    let mut qs = vec![
        [[x0, 0.0, z0], [x1, 0.0, z0], [x1, 0.0, z1], [x0, 0.0, z1]],
        [[x0, 1.0, z0], [x1, 1.0, z0], [x1, 1.0, z1], [x0, 1.0, z1]],
    ];
    for w in walls {
        qs.push(match *w {
            "-x" => [[x0, 0.0, z0], [x0, 1.0, z0], [x0, 1.0, z1], [x0, 0.0, z1]],
            "+x" => [[x1, 0.0, z0], [x1, 1.0, z0], [x1, 1.0, z1], [x1, 0.0, z1]],
            "-z" => [[x0, 0.0, z0], [x1, 0.0, z0], [x1, 1.0, z0], [x0, 1.0, z0]],
            _ => [[x0, 0.0, z1], [x1, 0.0, z1], [x1, 1.0, z1], [x0, 1.0, z1]],
        });
    }
    quads(&qs)
}

fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> Mesh {
    penumbra_testkit::gltf::cuboid(lo, hi)
}

/// A node of the test scene: name, mesh, extras, children (node indices).
struct N<'a> {
    name: &'a str,
    mesh: Option<Mesh>,
    extras: Option<Value>,
    children: Vec<usize>,
}

/// Writes `dir/level.gltf` + `dir/level.bin`: one mesh per node that has one.
fn write_gltf(dir: &Path, nodes: &[N<'_>]) {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut jnodes) = (vec![], vec![], vec![], vec![]);
    for n in nodes {
        let mut node = json!({"name": n.name});
        if let Some((p, t)) = &n.mesh {
            let (lo, hi) = p.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(l, h), v| {
                (std::array::from_fn(|k| l[k].min(v[k])), std::array::from_fn(|k| h[k].max(v[k])))
            });
            let off = bin.len();
            bin.extend(p.iter().flatten().flat_map(|x| x.to_le_bytes()));
            views.push(json!({"buffer": 0, "byteOffset": off, "byteLength": p.len() * 12}));
            accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126, "count": p.len(),
                                  "type": "VEC3", "min": lo, "max": hi}));
            let off = bin.len();
            bin.extend(t.iter().flatten().flat_map(|x| x.to_le_bytes()));
            views.push(json!({"buffer": 0, "byteOffset": off, "byteLength": t.len() * 12}));
            accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5125, "count": t.len() * 3,
                                  "type": "SCALAR"}));
            meshes.push(json!({"primitives": [{"attributes": {"POSITION": accessors.len() - 2},
                                                "indices": accessors.len() - 1}]}));
            node["mesh"] = json!(meshes.len() - 1);
        }
        if let Some(e) = &n.extras {
            node["extras"] = e.clone();
        }
        if !n.children.is_empty() {
            node["children"] = json!(n.children);
        }
        jnodes.push(node);
    }
    let children: Vec<usize> = nodes.iter().flat_map(|n| n.children.iter().copied()).collect();
    let roots: Vec<usize> = (0..nodes.len()).filter(|i| !children.contains(i)).collect();
    let doc = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": roots}], "nodes": jnodes,
        "meshes": meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"uri": "level.bin", "byteLength": bin.len()}],
    });
    std::fs::write(dir.join("level.bin"), &bin).unwrap();
    std::fs::write(dir.join("level.gltf"), serde_json::to_string_pretty(&doc).unwrap()).unwrap();
}

fn role(r: &str) -> Option<Value> {
    Some(json!({"penumbra": {"role": r}}))
}

/// The test level: two rooms (one by extras, one by `--role`), clutter in both (one by extras
/// under its room, one by `--role`), a rigid occluder, a rigid character, a node without a
/// role and one with a role the tool does not know.
fn test_level(dir: &Path) {
    write_gltf(
        dir,
        &[
            N {
                name: "Room_A",
                mesh: Some(room(0.0, 0.0, &["-x", "+x", "-z"])),
                extras: role("block"),
                children: vec![1],
            },
            N {
                name: "Crate_1",
                mesh: Some(cuboid([0.3, 0.0, 0.3], [0.5, 0.2, 0.5])),
                extras: role("clutter"),
                children: vec![],
            },
            N { name: "Room_B", mesh: Some(room(0.0, 1.0, &["-x", "+x", "+z"])), extras: None, children: vec![] },
            N {
                name: "Prop_Vase",
                mesh: Some(cuboid([0.4, 0.0, 1.4], [0.6, 0.3, 1.6])),
                extras: None,
                children: vec![],
            },
            N {
                name: "Statue",
                mesh: Some(cuboid([3.0, 0.0, 0.0], [3.5, 1.0, 0.5])),
                extras: role("occluder"),
                children: vec![],
            },
            N {
                name: "Hero",
                mesh: Some(cuboid([5.0, 0.0, 0.0], [5.4, 1.8, 0.3])),
                extras: role("character"),
                children: vec![],
            },
            N { name: "Lamp", mesh: Some(cuboid([7.0, 0.0, 0.0], [7.2, 2.0, 0.2])), extras: None, children: vec![] },
            N {
                name: "Sign",
                mesh: Some(cuboid([8.0, 0.0, 0.0], [8.5, 0.5, 0.1])),
                extras: role("decal"),
                children: vec![],
            },
        ],
    );
}

fn nodes(n: &Option<NodeSelect>) -> Vec<String> {
    n.as_ref().map(NodeSelect::patterns).unwrap_or_default()
}

/// The planned config of the test level has exactly the expected stages and node lists, the
/// level and clutter files beside it, the unassigned nodes listed; `penumbra bake` accepts it
/// (with its knobs shrunk to test size) and bakes every stage.
#[test]
fn plan_of_a_written_level_has_the_expected_stages_and_bakes() {
    let dir = tempfile::tempdir().unwrap();
    test_level(dir.path());
    let cfg = dir.path().join("plans/bake.toml");
    let (code, stdout, stderr) = run(penumbra()
        .arg("plan")
        .arg(dir.path().join("level.gltf"))
        .arg("-o")
        .arg(&cfg)
        .args(["--role", "block=Room_B", "--role", "clutter=Prop_*", "--json"]));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    // unassigned: listed in the JSON and on stderr, never guessed
    let un: Vec<(&str, &str)> = v["unassigned"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| (u["node"].as_str().unwrap(), u["reason"].as_str().unwrap()))
        .collect();
    assert_eq!(un.len(), 2, "{un:?}");
    assert_eq!(un[0], ("Lamp", "no role"));
    assert!(un[1].0 == "Sign" && un[1].1.contains("unknown role decal"), "{un:?}");
    assert!(stderr.contains("unassigned: node \"Lamp\"") && stderr.contains("unassigned: node \"Sign\""), "{stderr}");
    assert!(v["notes"].to_string().contains("\\\"Hero\\\" is not skinned"), "{}", v["notes"]);
    // the config: exactly these stages and nodes
    let text = std::fs::read_to_string(&cfg).unwrap();
    let c: BakeConfig = penumbra_config::parse_str(&text, &cfg).unwrap();
    assert!(c.tables.is_some() && c.mrt.is_some() && c.vo.is_none());
    assert_eq!(c.spheres.len(), 1);
    assert_eq!(nodes(&c.spheres[0].node), ["Hero"]);
    assert_eq!(c.spheres[0].skin, None, "a rigid character gets a plain set");
    assert_eq!(c.spheres[0].mesh, "../level.gltf");
    assert_eq!(c.fiv.len(), 1);
    assert_eq!(nodes(&c.fiv[0].node), ["Statue"]);
    assert_eq!(c.fiv[0].env, "builtin:area-lights");
    let l = c.mrt_level.as_ref().unwrap();
    assert_eq!(l.level.as_deref(), Some("bake.level.toml"));
    let d = c.drt.as_ref().unwrap();
    assert_eq!(d.clutter.as_deref(), Some("bake.clutter.toml"));
    // the level: two dead ends facing each other, connected
    let level = penumbra_config::load_level(&dir.path().join("plans/bake.level.toml")).unwrap();
    let shapes: Vec<(&str, u32, [f64; 3])> =
        level.blocks.iter().map(|b| (b.shape.as_str(), b.rotation, b.translation)).collect();
    assert_eq!(shapes, [("dead_end", 0, [0.5, 0.5, 0.5]), ("dead_end", 2, [0.5, 0.5, 1.5])]);
    assert_eq!(level.connections.len(), 1);
    let cn = &level.connections[0];
    assert_eq!((cn.a, cn.a_face.as_str(), cn.b, cn.b_face.as_str()), (0, "+z", 1, "+z"));
    // the clutter: the crate (extras, under its room) and the vase (--role), in place
    let cl = penumbra_config::clutter::load_clutter(&dir.path().join("plans/bake.clutter.toml")).unwrap();
    let names: Vec<(String, Vec<String>)> =
        cl.clutter.iter().map(|e| (e.name.clone().unwrap(), nodes(&e.node))).collect();
    assert_eq!(
        names,
        [("Crate_1".into(), vec!["Crate_1".to_string()]), ("Prop_Vase".into(), vec!["Prop_Vase".into()])]
    );
    assert!(cl.clutter.iter().all(|e| e.translate == [0.0; 3] && e.mesh.as_deref() == Some("../level.gltf")));
    let roles: Vec<(&str, &str, &str)> = v["entries"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (e["node"].as_str().unwrap(), e["role"].as_str().unwrap(), e["source"].as_str().unwrap()))
        .collect();
    assert_eq!(
        roles,
        [
            ("Room_A", "block", "extras"),
            ("Crate_1", "clutter", "extras"),
            ("Room_B", "block", "--role"),
            ("Prop_Vase", "clutter", "--role"),
            ("Statue", "occluder", "extras"),
            ("Hero", "character", "extras"),
        ]
    );

    // `penumbra bake` on it, knobs shrunk to test size (stages and nodes as planned)
    let mut small = c.clone();
    small.tables.as_mut().unwrap().theta_samples = Some(64);
    small.spheres[0].count = Some(4);
    small.spheres[0].grid = Some(16);
    small.fiv[0].samples = Some([8, 5, 3]);
    small.fiv[0].cube_size = Some(8);
    small.fiv[0].irradiance_size = Some(8);
    let m = small.mrt.as_mut().unwrap();
    (m.face_res, m.rays, m.kd, m.kb, m.vector_rays, m.volume_res, m.probe_rays) =
        (Some(4), Some(512), Some(24), Some(12), Some(64), Some(2), Some(64));
    (m.test_lights, m.reference_rays, m.lf_spatial, m.lf_dir, m.lf_super, m.k_rlf, m.k_r, m.response_rays) =
        (Some(3), Some(128), Some(4), Some(6), Some(2), Some(24), Some(8), Some(64));
    let d = small.drt.as_mut().unwrap();
    (d.clutter_res, d.rays) = (Some(4), Some(64));
    std::fs::write(&cfg, toml::to_string(&small).unwrap()).unwrap();
    let (code, stdout, stderr) = run(penumbra().arg("bake").arg(&cfg).arg("--json"));
    assert_eq!(code, 0, "{stderr}");
    let r: Value = serde_json::from_str(&stdout).unwrap();
    let stages: Vec<(&str, &str)> = r["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["name"].as_str().unwrap(), s["status"].as_str().unwrap()))
        .collect();
    assert_eq!(
        stages,
        [
            ("tables", "baked"),
            ("spheres[0]", "baked"),
            ("fiv[0]", "baked"),
            ("mrt", "baked"),
            ("mrt_level", "baked"),
            ("drt", "baked"),
        ]
    );
    assert_eq!(r["stages"][5]["metrics"]["clutter_instances"], 2, "{}", r["stages"][5]["metrics"]);
}

/// Bad input: a missing scene, a file that is not glTF, bad `--role` syntax or an unknown
/// role, and a scene without any role: exit 2 with a message naming the file or option, and
/// nothing written.
#[test]
fn plan_refuses_bad_input_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    test_level(dir.path());
    let out = dir.path().join("out");
    let cfg = out.join("bake.toml");
    std::fs::write(dir.path().join("mesh.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let gltf = dir.path().join("level.gltf");
    let cases: Vec<(Vec<std::ffi::OsString>, &str)> = vec![
        (vec![dir.path().join("nope.glb").into()], "nope.glb"),
        (vec![dir.path().join("mesh.obj").into()], "not a glTF file"),
        (vec![gltf.clone().into(), "--role".into(), "occluder".into()], "--role"),
        (vec![gltf.clone().into(), "--role".into(), "lamp=Lamp".into()], "unknown role \"lamp\""),
        (vec![gltf.clone().into(), "--role".into(), "clutter=".into()], "empty name pattern"),
    ];
    for (args, what) in cases {
        let (code, _, stderr) = run(penumbra().arg("plan").args(&args).arg("-o").arg(&cfg));
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stderr.contains(what), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} wrote {:?}", listing(&out));
    }
    // a scene whose nodes have no role at all: nothing to bake
    write_gltf(
        dir.path(),
        &[N { name: "Thing", mesh: Some(cuboid([0.0; 3], [1.0; 3])), extras: None, children: vec![] }],
    );
    let (code, _, stderr) = run(penumbra().arg("plan").arg(&gltf).arg("-o").arg(&cfg));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("level.gltf") && stderr.contains("no node has a role"), "{stderr}");
    assert!(stderr.contains("unassigned: node \"Thing\""), "{stderr}");
    assert!(!out.exists());
}

/// The glTF samples in `../shared/data/gltf`: the skinned Fox becomes a skinned sphere set, the
/// Cornell box's boxes FIV occluders (by `--role`), the MixedLightingExample's chair an
/// occluder while its other nodes are listed as unassigned; every config validates.
#[test]
fn plan_on_the_shared_gltf_samples() {
    let Some(data) = shared_data() else { return };
    let g = data.join("gltf");
    let dir = tempfile::tempdir().unwrap();
    let plan = |scene: &str, roles: &[&str]| -> (BakeConfig, Value) {
        let cfg = dir.path().join(format!("{}.toml", scene.replace('/', "_")));
        let mut cmd = penumbra();
        cmd.arg("plan").arg(g.join(scene)).arg("-o").arg(&cfg).arg("--json");
        for r in roles {
            cmd.arg("--role").arg(r);
        }
        let (code, stdout, stderr) = run(&mut cmd);
        assert_eq!(code, 0, "{scene}: {stderr}");
        let c = penumbra_config::load(&cfg).unwrap().config;
        (c, serde_json::from_str(&stdout).unwrap())
    };
    // Fox: one skinned mesh node; as an occluder it deforms, so spheres with skin weights
    let (c, v) = plan("Fox/Fox.glb", &["character=fox"]);
    assert_eq!(c.spheres.len(), 1, "{v}");
    assert_eq!((nodes(&c.spheres[0].node), c.spheres[0].skin), (vec!["fox".to_string()], Some(true)));
    assert!(c.fiv.is_empty() && c.tables.is_some() && c.mrt.is_none());
    let (c, v) = plan("Fox/Fox.glb", &["occluder=fox"]);
    assert!(c.fiv.is_empty() && c.spheres[0].skin == Some(true), "{v}");
    assert!(v["notes"].to_string().contains("is skinned"), "{}", v["notes"]);
    // SimpleSkin: its mesh node has no name → cannot be selected; an unnamed node is listed
    let (code, _, stderr) =
        run(penumbra().arg("plan").arg(g.join("SimpleSkin/SimpleSkin.gltf")).arg("-o").arg(dir.path().join("s.toml")));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("unassigned"), "{stderr}");
    // Cornell box: the two boxes occlude, the room and the light are unassigned
    let (c, v) = plan("CornellBox/CornellBox.glb", &["occluder=*.box"]);
    let mut fiv: Vec<Vec<String>> = c.fiv.iter().map(|f| nodes(&f.node)).collect();
    fiv.sort();
    assert_eq!(fiv, [vec!["cornell.box".to_string()], vec!["large.box".into()], vec!["small.box".into()]], "{v}");
    let (c, v) = plan("CornellBox/CornellBox.glb", &["occluder=large.box", "occluder=small.box"]);
    assert_eq!(c.fiv.len(), 2);
    let mut un: Vec<&str> = v["unassigned"].as_array().unwrap().iter().filter_map(|u| u["node"].as_str()).collect();
    un.sort_unstable();
    assert_eq!(un, ["Light", "cornell.box"]);
    // MixedLightingExample (.gltf + .bin + textures): the chair occludes
    let (c, v) = plan("MixedLightingExample/MixedLightingExample.gltf", &["occluder=SheenChair*"]);
    assert!(!c.fiv.is_empty(), "{v}");
    assert!(c.fiv.iter().all(|f| nodes(&f.node).iter().all(|n| n.starts_with("SheenChair"))));
    assert!(!v["unassigned"].as_array().unwrap().is_empty(), "{v}");
    // TestScene (.gltf + external .bin): two nodes named "Cube" are one entry (stages select
    // by name); the others are unassigned
    let (c, v) = plan("TestScene/TestScene.gltf", &["occluder=Cube"]);
    assert_eq!(c.fiv.iter().map(|f| nodes(&f.node)).collect::<Vec<_>>(), [vec!["Cube".to_string()]], "{v}");
    let mut un: Vec<&str> = v["unassigned"].as_array().unwrap().iter().filter_map(|u| u["node"].as_str()).collect();
    un.sort_unstable();
    assert_eq!(un, ["Cylinder", "Plane", "Sphere", "d8", "d8 (1)"]);
    // "*" on every node: the root takes the role, and its one entry covers the rest
    let (c, v) = plan("TestScene/TestScene.gltf", &["occluder=*"]);
    assert_eq!(c.fiv.iter().map(|f| nodes(&f.node)).collect::<Vec<_>>(), [vec!["TestExportScene".to_string()]]);
    assert!(v["unassigned"].as_array().unwrap().is_empty(), "{v}");
}

/// `penumbra plan --preset preview|final` writes the knobs of the committed preset configs
/// `bake-configs/preview.toml` and `final.toml` (one source of the presets' values).
#[test]
fn plan_presets_match_the_committed_preset_configs() {
    let dir = tempfile::tempdir().unwrap();
    test_level(dir.path());
    for preset in ["preview", "final"] {
        let cfg = dir.path().join(format!("{preset}.toml"));
        let (code, _, stderr) = run(penumbra()
            .arg("plan")
            .arg(dir.path().join("level.gltf"))
            .arg("-o")
            .arg(&cfg)
            .args(["--role", "block=Room_B", "--role", "clutter=Prop_*", "--preset", preset]));
        assert_eq!(code, 0, "{stderr}");
        let p = penumbra_config::load(&cfg).unwrap().config;
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("bake-configs/{preset}.toml"));
        let c = penumbra_config::load(&file).unwrap().config;
        assert_eq!(p.tables, c.tables, "{preset}");
        assert_eq!(p.mrt, c.mrt, "{preset}");
        let (ps, cs) = (&p.spheres[0], &c.spheres[0]);
        assert_eq!((ps.count, ps.hierarchy, ps.polish), (cs.count, cs.hierarchy, cs.polish), "{preset}");
        assert_eq!(p.fiv[0].samples, c.fiv[0].samples, "{preset}");
        let (pd, cd) = (p.drt.as_ref().unwrap(), c.drt.as_ref().unwrap());
        assert_eq!((pd.clutter_res, pd.rays), (cd.clutter_res, cd.rays), "{preset}");
        assert_eq!(p.mrt_level.as_ref().unwrap().max_depth, c.mrt_level.as_ref().unwrap().max_depth);
    }
}

fn demo_level() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("bake-configs/assets/demo-level.gltf")
}

#[test]
fn committed_demo_level_is_what_the_generator_writes() {
    let committed = std::fs::read_to_string(demo_level()).unwrap();
    assert!(
        committed == penumbra_geometry::demo_level::demo_level_gltf(),
        "bake-configs/assets/demo-level.gltf is stale: run `cargo run -p penumbra-geometry --example demo_level > bake-configs/assets/demo-level.gltf`"
    );
}

/// The README's example: the demo level with `--role clutter='Prop_*'` plans a corridor of
/// three blocks (dead end, straight, dead end; two connections), three clutter pieces, the
/// statue's FIV, the hero's sphere set, and lists the lamp as unassigned.
#[test]
fn plan_of_the_demo_level() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("demo-level.toml");
    let (code, stdout, stderr) =
        run(penumbra().arg("plan").arg(demo_level()).args(["--role", "clutter=Prop_*", "--json", "-o"]).arg(&cfg));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let c = penumbra_config::load(&cfg).unwrap().config;
    assert_eq!(c.spheres.iter().map(|s| nodes(&s.node)).collect::<Vec<_>>(), [vec!["Hero".to_string()]]);
    assert_eq!(c.fiv.iter().map(|f| nodes(&f.node)).collect::<Vec<_>>(), [vec!["Statue".to_string()]]);
    let level = penumbra_config::load_level(&dir.path().join("demo-level.level.toml")).unwrap();
    let shapes: Vec<&str> = level.blocks.iter().map(|b| b.shape.as_str()).collect();
    assert_eq!(shapes, ["dead_end", "straight", "dead_end"]);
    assert_eq!(level.connections.len(), 2);
    let cl = penumbra_config::clutter::load_clutter(&dir.path().join("demo-level.clutter.toml")).unwrap();
    let names: Vec<String> = cl.clutter.iter().filter_map(|e| e.name.clone()).collect();
    assert_eq!(names, ["Crate", "Prop_Pillar", "Prop_Box"]);
    let un: Vec<&str> = v["unassigned"].as_array().unwrap().iter().filter_map(|u| u["node"].as_str()).collect();
    assert_eq!(un, ["Lamp"]);
}
