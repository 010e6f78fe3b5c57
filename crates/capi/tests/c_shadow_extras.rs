//! Posing, local lights and indirect light from proxies (issue #14 §2) from C: a C99 program
//! written against `include/penumbra.h` alone (`tests/c/shadow_extras.c`), built with the
//! system compiler under ASan/UBSan against this crate's static library, poses a skinned
//! sphere set, cuts the posed hierarchy, shades a local spherical light blocked by the posed
//! leaves and the indirect light of the posed proxies (stored albedos, every operator), and
//! checks the error codes. This test recomputes every printed value with `penumbra-runtime`
//! (equal bit for bit: `%.9g` round-trips an f32), checks the posed leaves against the
//! analytic pose, and that the blockers really shadow the light. Skips with a message when
//! there is no C compiler.
#![allow(clippy::print_stderr)]

mod common;

use penumbra_asset::{AssetBuilder, AssetFile, Kind, OwnedAsset};
use penumbra_runtime::shadows::{IndirectOperator, LocalLight, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{PosedSpheres, ShTables, SphereSet, SphereTree};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;

/// The first nine coefficients of the C program's light (the rest zero at order 4).
const LIGHT3: [[f32; 3]; 9] = [
    [3.0, 3.2, 3.5],
    [0.1, 0.0, 0.0],
    [1.0, 1.1, 1.3],
    [0.3, 0.2, 0.1],
    [0.05, 0.02, 0.0],
    [0.0, 0.01, 0.03],
    [-0.2, -0.1, 0.0],
    [0.0, 0.0, 0.04],
    [0.02, 0.02, 0.02],
];

/// Three skinned leaves under one root, per-sphere albedo (SPHR kind_version 2): leaf 0 on node
/// 0, leaf 1 half on each node, leaf 2 on node 1.
fn skinned_set() -> OwnedAsset {
    let mut a = AssetBuilder::new(Kind::SPHR);
    a.add_json("meta", r#"{"kind":"SPHR","kind_version":2}"#).unwrap();
    let leaves = [0.0f32, 1.0, 0.0, 0.3, 0.5, 1.5, 0.2, 0.25, -0.4, 1.2, 0.1, 0.2];
    a.add_f32("spheres", &[3, 4], &leaves).unwrap();
    a.add_u32("hierarchy_levels", &[1, 2], &[0, 1]).unwrap();
    a.add_f32("hierarchy_nodes", &[1, 4], &[0.0, 1.2, 0.0, 1.0]).unwrap();
    a.add_u32("hierarchy_children", &[1, 2], &[0, 3]).unwrap();
    let u = u32::MAX;
    a.add_u32("skin_nodes", &[3, 4], &[0, u, u, u, 0, 1, u, u, 1, u, u, u]).unwrap();
    a.add_f32("skin_weights", &[3, 4], &[1.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]).unwrap();
    a.add_f32("albedo", &[3, 3], &[0.9, 0.1, 0.1, 0.2, 0.8, 0.3, 0.5, 0.5, 0.5]).unwrap();
    OwnedAsset::parse(&a.to_bytes().unwrap()).unwrap()
}

fn floats(w: &[&str]) -> Vec<f32> {
    w.iter().map(|s| s.parse::<f32>().unwrap()).collect()
}

#[test]
fn posing_local_lights_and_indirect_from_c_equal_the_runtime() {
    let Some(cc) = common::compiler("CC", "cc", "the posing/local-light/indirect C test") else { return };
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("shadow-extras");
    std::fs::create_dir_all(&dir).unwrap();
    let exe = dir.join("shadow_extras");
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/c/shadow_extras.c");
    let mut flags: Vec<&str> = common::C_FLAGS.to_vec();
    flags.extend(["-lpthread", "-ldl", "-lm"]);
    common::build(&cc, &[src, common::staticlib()], &flags, &exe);

    let sowned = skinned_set();
    let sphr = dir.join("skinned.sphr");
    std::fs::write(&sphr, sowned.bytes()).unwrap();
    let tables_path = common::root().join("tests/assets/v1/tables-order4-k64-knots-v2.shtb");
    let out = Command::new(&exe).arg(&tables_path).arg(&sphr).output().unwrap();
    assert!(out.status.success() && out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    eprintln!("{text}");
    let mut lines: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let key = match w[0] {
            "leaf" | "direct" | "indirect" | "err" => format!("{} {}", w[0], w[1]),
            k => k.to_string(),
        };
        let skip = if key.contains(' ') { 2 } else { 1 };
        assert!(lines.insert(key, w[skip..].iter().map(|s| s.to_string()).collect()).is_none(), "{line}");
    }
    let get = |k: &str| -> Vec<f32> {
        let w = lines.get(k).unwrap_or_else(|| panic!("no line `{k}` in\n{text}"));
        floats(&w.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let code = |k: &str| -> i32 { lines[&format!("err {k}")][0].parse().unwrap() };

    let tf = AssetFile::open(&tables_path).unwrap();
    let ta = tf.asset();
    let tables = ShTables::from_asset(&ta).unwrap();
    assert_eq!(tables.order(), 4);
    let mut light = [[0.0f32; 3]; 16];
    light[..9].copy_from_slice(&LIGHT3);
    let rust = ShadowEvaluator::new(&tables, &light, ShadowOptions::default());
    let sa = sowned.asset();
    let set = SphereSet::from_asset(&sa).unwrap();

    // posing: the C leaves are the runtime's posed leaves, which are the analytic pose
    let mats = [
        [1.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    ];
    let mut posed = PosedSpheres::rest(set);
    posed.pose(&mats).unwrap();
    let want = [[1.0f32, 1.0, 0.0], [0.0, 1.0, 0.2], [-1.2, -0.4, 0.1]];
    let leaves: Vec<Sphere> = posed.leaves().to_vec();
    for (i, l) in leaves.iter().enumerate() {
        let c = get(&format!("leaf {i}"));
        assert_eq!(c, [l.center[0], l.center[1], l.center[2], l.radius], "leaf {i}");
        assert!((0..3).all(|k| (c[k] - want[i][k]).abs() < 1e-6), "leaf {i}: {c:?} vs {:?}", want[i]);
        assert_eq!(c[3], set.leaf(i).radius, "posing keeps the radius");
    }
    // the cut of the refitted tree and the cluster's irradiance below the set
    let (p_r, n_up) = ([0.0f32, -3.0, 0.0], [0.0f32, 1.0, 0.0]);
    let sin_max = 0.422_618_26f32;
    let (mut stack, mut cut, mut blockers) = (Vec::new(), Vec::new(), Vec::new());
    posed.cut(p_r, 0.5, sin_max, &mut stack, &mut cut);
    rust.cluster_blockers(&posed, &cut, p_r, n_up, &mut blockers);
    assert_eq!(get("cut"), [blockers.len() as f32]);
    let cluster = rust.irradiance_blockers(p_r, n_up, &blockers);
    assert_eq!(get("cluster"), cluster);
    assert!(cluster[0] < 0.99 * rust.unshadowed(n_up)[0], "the posed set shadows the cluster: {cluster:?}");

    // a local light above, blocked by the posed leaves
    let p = [0.3f32, -0.5, 0.1];
    let ll = LocalLight { sphere: Sphere { center: [0.0, 4.0, 0.0], radius: 1.0 }, radiance: [1.0, 2.0, 0.5] };
    let local = rust.irradiance_local_light(p, n_up, &leaves, &ll).unwrap();
    let free = rust.irradiance_local_light(p, n_up, &[], &ll).unwrap();
    assert_eq!(get("local"), local);
    assert_eq!(get("local_unblocked"), free);
    assert!(local[0] > 0.0 && local[0] < 0.95 * free[0], "blocked {local:?} vs free {free:?}");

    // indirect light of the posed proxies with their stored albedos, every operator
    let mut albedo = Vec::new();
    assert!(set.albedo_into(&mut albedo));
    for (name, op) in [
        ("point", IndirectOperator::PointSampled),
        ("averaged", IndirectOperator::Averaged),
        ("exact", IndirectOperator::Exact),
    ] {
        let r = rust.shade_with_indirect_per_sphere(p, n_up, &leaves, &albedo, op);
        assert_eq!(get(&format!("direct {name}")), r.direct, "{name}");
        assert_eq!(get(&format!("indirect {name}")), r.indirect, "{name}");
        assert!(r.indirect.iter().all(|&v| v > 0.0), "{name}: the proxies reflect light: {:?}", r.indirect);
    }

    // errors, and a failed pose leaves the pose as it was
    assert_eq!(code("pose_nan"), 6, "PN_ERR_RANGE");
    assert_eq!(code("pose_few_matrices"), 6, "PN_ERR_RANGE");
    assert_eq!(code("leaves_count"), 5, "PN_ERR_SIZE");
    assert_eq!(get("leaf0_after_errors"), leaves[0].center);
    assert_eq!(code("local_bad_light"), 7, "PN_ERR_ABSENT");
    assert_eq!(code("indirect_albedo_count"), 5, "PN_ERR_SIZE");
    assert_eq!(code("indirect_op"), 6, "PN_ERR_RANGE");
    assert_eq!(code("albedo_index"), 6, "PN_ERR_RANGE");
}
