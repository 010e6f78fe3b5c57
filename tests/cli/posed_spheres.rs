//! Animated sphere sets (issue #14 §2, SHEXP §6.2 "Animation", §6.3): the runtime poses leaves
//! from the stored skin influences and refits the hierarchy bottom-up with sphere-pair
//! bounds; `verify shadows --animation` on Fox.glb.

use crate::{penumbra, run, shared_data};
use penumbra_asset::{AssetBuilder, Kind, OwnedAsset};
use penumbra_runtime::shadows::{CutBlocker, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::sphere_pose::pair_bound;
use penumbra_runtime::{NodeRef, PosedSpheres, ShTables, SphereSet, SphereTree};
use penumbra_sh::tables::{NoProgress, TablesParams, bake};
use penumbra_sh::tables_asset::to_asset;
use serde_json::Value;

/// Column-major translation.
fn translation(t: [f32; 3]) -> [f32; 16] {
    let mut m = [0.0f32; 16];
    m[0] = 1.0;
    m[5] = 1.0;
    m[10] = 1.0;
    m[15] = 1.0;
    m[12..15].copy_from_slice(&t);
    m
}

/// Column-major rotation by 90° about +z.
fn rot_z90() -> [f32; 16] {
    let mut m = [0.0f32; 16];
    // columns: x → y, y → −x
    m[1] = 1.0;
    m[4] = -1.0;
    m[10] = 1.0;
    m[15] = 1.0;
    m
}

/// 6 leaves on a row at height 2, two nodes of 3 leaves, one root; leaves 0–2 bound to node 0,
/// 3 and 4 to node 1, leaf 5 half to each.
fn skinned_set() -> Vec<u8> {
    let leaves: Vec<f32> = (0..6).flat_map(|k| [k as f32 * 0.5 - 1.25, 0.0, 2.0, 0.3]).collect();
    let mut b = AssetBuilder::new(Kind::SPHR);
    b.add_json("meta", "{}").unwrap();
    b.add_f32("spheres", &[6, 4], &leaves).unwrap();
    b.add_u32("hierarchy_levels", &[2, 2], &[0, 1, 1, 2]).unwrap();
    b.add_f32("hierarchy_nodes", &[3, 4], &[0.0, 0.0, 2.0, 1.6, -0.75, 0.0, 2.0, 0.81, 0.75, 0.0, 2.0, 0.81]).unwrap();
    b.add_u32("hierarchy_children", &[3, 2], &[0, 2, 0, 3, 3, 3]).unwrap();
    let u = u32::MAX;
    let nodes = [[0, u, u, u], [0, u, u, u], [0, u, u, u], [1, u, u, u], [1, u, u, u], [0, 1, u, u]];
    let weights = [[1.0f32, 0.0, 0.0, 0.0]; 5].into_iter().chain([[0.5, 0.5, 0.0, 0.0]]).collect::<Vec<_>>();
    b.add_u32("skin_nodes", &[6, 4], &nodes.concat()).unwrap();
    b.add_f32("skin_weights", &[6, 4], &weights.concat()).unwrap();
    b.to_bytes().unwrap()
}

fn contains(outer: Sphere, inner: Sphere) -> bool {
    let d = (0..3).map(|k| (outer.center[k] - inner.center[k]).powi(2)).sum::<f32>().sqrt();
    d + inner.radius <= outer.radius * (1.0 + 1e-6)
}

/// Every node contains every leaf below it.
fn assert_bounding(tree: &impl SphereTree, nodes: u32) {
    for i in 0..nodes {
        let s = tree.sphere(NodeRef::Node(i));
        tree.for_leaves_below(NodeRef::Node(i), &mut |l| {
            let leaf = tree.sphere(NodeRef::Leaf(l));
            assert!(contains(s, leaf), "node {i} {s:?} does not contain leaf {l} {leaf:?}");
        });
    }
}

#[test]
fn posing_follows_the_skin_convention_and_refits_the_hierarchy() {
    let bytes = skinned_set();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let set = SphereSet::from_asset(&owned.asset()).unwrap();
    let mut posed = PosedSpheres::rest(set);
    // node 0 rotated 90° about z, node 1 moved by +10 along x
    posed.pose(&[rot_z90(), translation([10.0, 0.0, 0.0])]).unwrap();
    let l = posed.leaves();
    // leaf 0 at (−1.25, 0, 2) → (0, −1.25, 2); leaf 3 at (0.25, 0, 2) → (10.25, 0, 2)
    assert!(
        (l[0].center[0]).abs() < 1e-6 && (l[0].center[1] + 1.25).abs() < 1e-6 && l[0].center[2] == 2.0,
        "{:?}",
        l[0]
    );
    assert!((l[3].center[0] - 10.25).abs() < 1e-5 && l[3].center[1] == 0.0, "{:?}", l[3]);
    // leaf 5 at (1.25, 0, 2): half (0, 1.25, 2), half (11.25, 0, 2)
    assert!((l[5].center[0] - 5.625).abs() < 1e-5 && (l[5].center[1] - 0.625).abs() < 1e-6, "{:?}", l[5]);
    assert!(l.iter().all(|s| s.radius == 0.3), "radii kept");
    // the stored nodes no longer bound the posed leaves; the refitted ones do
    let stored_root = set.sphere(NodeRef::Node(0));
    assert!(!contains(stored_root, l[3]), "the test pose must break the stored bounds");
    assert_bounding(&posed, 3);
    // the refit is the pair bound of the children, in order
    let n1 = posed.sphere(NodeRef::Node(1));
    let want = pair_bound(pair_bound(l[0], l[1]), l[2]);
    assert_eq!(n1, want);
    // identity matrices: the leaves come back exactly, and the nodes still bound them
    posed.pose(&[translation([0.0; 3]), translation([0.0; 3])]).unwrap();
    for i in 0..6 {
        assert_eq!(posed.sphere(NodeRef::Leaf(i)), set.sphere(NodeRef::Leaf(i)));
    }
    assert_bounding(&posed, 3);
}

#[test]
fn posing_rejects_what_it_cannot_pose() {
    let bytes = skinned_set();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let set = SphereSet::from_asset(&owned.asset()).unwrap();
    let mut posed = PosedSpheres::rest(set);
    let e = posed.pose(&[translation([0.0; 3])]).unwrap_err().to_string();
    assert!(e.contains("node 1") && e.contains("1 node matrices"), "{e}");
    let mut bad = translation([0.0; 3]);
    bad[13] = f32::NAN;
    assert!(posed.pose(&[bad, bad]).unwrap_err().to_string().contains("non-finite"));
    // a set without skin
    let mut b = AssetBuilder::new(Kind::SPHR);
    b.add_json("meta", "{}").unwrap();
    b.add_f32("spheres", &[1, 4], &[0.0, 0.0, 0.0, 1.0]).unwrap();
    let nb = b.to_bytes().unwrap();
    let no = OwnedAsset::parse(&nb).unwrap();
    let plain = SphereSet::from_asset(&no.asset()).unwrap();
    assert!(PosedSpheres::rest(plain).pose(&[]).unwrap_err().to_string().contains("no skin"));
}

#[test]
fn posed_cut_shadows_where_the_posed_leaves_are() {
    // a receiver under the moved leaves: through the refitted tree the cut sees them; the cut
    // of the stored tree (nodes at rest) would not
    let order = 4;
    let tb = to_asset(&bake(&TablesParams::new(order), &NoProgress).unwrap(), None).unwrap().to_bytes().unwrap();
    let to = OwnedAsset::parse(&tb).unwrap();
    let t = ShTables::from_asset(&to.asset()).unwrap();
    let mut light = vec![[0.0f32; 3]; order * order];
    light[0] = [(4.0 * std::f32::consts::PI).sqrt(); 3];
    let ev = ShadowEvaluator::new(&t, &light, ShadowOptions { window: false, ..Default::default() });
    let bytes = skinned_set();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let set = SphereSet::from_asset(&owned.asset()).unwrap();
    let mut posed = PosedSpheres::rest(set);
    posed.pose(&[translation([0.0; 3]), translation([10.0, 0.0, 0.0])]).unwrap();
    let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::<CutBlocker>::new());
    let n = [0.0f32, 0.0, 1.0];
    // receiver cluster far below the moved group (node 2), so the cut keeps nodes
    for p in [[10.5f32, 0.0, -2.0], [-0.75, 0.0, -2.0]] {
        posed.cut(p, 0.5, 25f32.to_radians().sin(), &mut stack, &mut cut);
        ev.cluster_blockers(&posed, &cut, p, n, &mut blockers);
        let up = [0.0f32, 0.0, 1.0];
        // shading a receiver facing up at p: irradiance from the cut vs from the posed leaves
        let e_cut = ev.irradiance_blockers(p, up, &blockers)[0];
        let e_leaves = ev.irradiance(p, up, posed.leaves())[0];
        let e_free = ev.unshadowed(up)[0];
        assert!(e_free - e_leaves > 0.01, "the posed leaves shadow {p:?}: {e_leaves} vs {e_free}");
        assert!((e_cut - e_leaves).abs() < 0.1 * (e_free - e_leaves), "{p:?}: cut {e_cut} vs leaves {e_leaves}");
    }
}

#[test]
fn verify_shadows_poses_fox() {
    let Some(data) = shared_data() else { return };
    let fox = data.join("gltf/Fox/Fox.glb");
    if !fox.exists() {
        eprintln!("skipping: {} is absent", fox.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("t3.shtb");
    let (code, _, e) = run(penumbra().args(["tables", "--order", "3", "--theta-samples", "64", "-o"]).arg(&t));
    assert_eq!(code, 0, "{e}");
    let s = dir.path().join("fox.sphr");
    let (code, _, e) = run(penumbra()
        .arg("spheres")
        .arg(&fox)
        .args(["--count", "12", "--grid", "20", "--iterations", "6", "--hierarchy", "--skin", "-o"])
        .arg(&s));
    assert_eq!(code, 0, "{e}");
    let verify = |extra: &[&str]| {
        let mut c = penumbra();
        c.args(["verify", "shadows", "--tables"]).arg(&t).arg("--spheres").arg(&s).arg("--mesh").arg(&fox);
        c.args(["--env", "builtin:area-lights", "--resolution", "12", "--rays", "8", "--json"]).args(extra);
        let (code, out, err) = run(&mut c);
        (code, serde_json::from_str::<Value>(&out).unwrap_or(Value::Null), err)
    };
    let (code, v, err) = verify(&["--animation", "Walk", "--frames", "3", "--hierarchy"]);
    assert_eq!(code, 0, "{err}");
    let poses = v["poses"].as_array().unwrap();
    assert_eq!(poses.len(), 3);
    assert_eq!(v["receivers"], 3 * 144);
    let times: Vec<f64> = poses.iter().map(|p| p["time"].as_f64().unwrap()).collect();
    assert!(times[0] < times[1] && times[1] < times[2], "{times:?}");
    for p in poses {
        let c = p["posed_coverage"].as_f64().unwrap();
        assert!(c > 0.5 && c <= 1.0, "{p}");
        assert!(p["nrmse_vs_mesh"].as_f64().unwrap().is_finite(), "{p}");
    }
    let min = poses.iter().map(|p| p["posed_coverage"].as_f64().unwrap()).fold(1.0, f64::min);
    assert_eq!(v["posed_coverage"].as_f64().unwrap(), min);
    // the poses differ (the walk cycle's ends are the same pose; its middle is not): the
    // spheres moved with the mesh, and their shadow stays close to the posed mesh's
    assert_ne!(poses[0]["nrmse_vs_mesh"], poses[1]["nrmse_vs_mesh"]);
    for p in poses {
        assert!(p["nrmse_spheres_vs_mesh"].as_f64().unwrap() < 0.15, "{p}");
    }
    // --skin-padding: radii grown from the animations' worst case keep every posed vertex
    // inside (vertex check of the bake, 8 times per animation, other times than the 32 the
    // padding sampled) and raise the posed surface coverage of verify
    let sp = dir.path().join("fox-pad.sphr");
    let bake = |out: &std::path::Path, extra: &[&str]| {
        let (code, stdout, e) = run(penumbra()
            .arg("spheres")
            .arg(&fox)
            .args(["--count", "12", "--grid", "20", "--iterations", "6", "--hierarchy", "--skin", "--json", "-o"])
            .arg(out)
            .args(extra));
        assert_eq!(code, 0, "{e}");
        serde_json::from_str::<Value>(&stdout).unwrap()
    };
    let plain = bake(&s, &[]);
    let padded = bake(&sp, &["--skin-padding"]);
    let (c0, c1) = (plain["skin_coverage_min"].as_f64().unwrap(), padded["skin_coverage_min"].as_f64().unwrap());
    assert!(c0 < 0.95 && c1 >= 0.99, "skin coverage {c0} -> {c1}");
    assert!(padded["skin_padding_max"].as_f64().unwrap() > 0.0 && plain.get("skin_padding_max").is_none());
    let mut c = penumbra();
    c.args(["verify", "shadows", "--tables"]).arg(&t).arg("--spheres").arg(&sp).arg("--mesh").arg(&fox);
    c.args(["--env", "builtin:area-lights", "--resolution", "12", "--rays", "8", "--json"]);
    c.args(["--animation", "Walk", "--frames", "3", "--hierarchy"]);
    let (code, out, err) = run(&mut c);
    assert_eq!(code, 0, "{err}");
    let vp: Value = serde_json::from_str(&out).unwrap();
    assert!(vp["posed_coverage"].as_f64().unwrap() > min, "{} vs {min}", vp["posed_coverage"]);
    // --skin-padding needs --skin
    let (code, _, err) =
        run(penumbra().arg("spheres").arg(&fox).args(["--count", "4", "--skin-padding", "-o"]).arg(&sp));
    assert_eq!(code, 2, "{err}");
    // bad animation name: exit 2, the names listed
    let (code, _, err) = verify(&["--animation", "Fly"]);
    assert_eq!(code, 2);
    assert!(err.contains("Walk") && err.contains("Fly"), "{err}");
    let (code, _, err) = verify(&["--frames", "2"]);
    assert_eq!(code, 2);
    assert!(err.contains("--animation"), "{err}");
}
