//! Every mesh in ../shared/data/meshes and ../shared/data/gltf loads, with the counts and
//! measures stated in their SOURCES.md.

#![allow(clippy::print_stderr)] // tests may print a summary

mod common;

use std::path::{Path, PathBuf};

use penumbra_geometry::{Scene, load_mesh};

fn files_with_ext(dir: &Path, exts: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| exts.contains(&e.to_ascii_lowercase().as_str()))
            {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn every_mesh_and_gltf_file_loads() {
    let Some(data) = common::shared_data("every_mesh_and_gltf_file_loads") else {
        return;
    };
    let mut n = 0;
    for dir in ["meshes", "gltf"] {
        for f in files_with_ext(&data.join(dir), &["obj", "gltf", "glb"]) {
            let (scene, report) = load_mesh(&f).unwrap_or_else(|e| panic!("{e}"));
            assert!(!scene.mesh.indices.is_empty(), "{}", f.display());
            scene.mesh.validate().unwrap();
            assert_eq!(report.dropped_triangles(), 0, "{}: {report:?}", f.display());
            n += 1;
        }
    }
    assert_eq!(n, 12, "expected 7 OBJ and 5 glTF files");
}

/// (file, vertices, triangles, watertight, volume (0 = not checked), boundary edges)
const OBJ_FACTS: &[(&str, usize, usize, bool, f64, usize)] = &[
    ("armadillo_43k.obj", 43243, 86482, true, 0.0686187, 0),
    ("bunny_closed_3k.obj", 3485, 6966, true, 0.000753934, 0),
    ("spot.obj", 2930, 5856, true, 0.718259, 0),
    ("decimated-knight.obj", 502, 1000, true, 0.0244911, 0),
    ("rocker-arm.obj", 10044, 20088, true, 0.0425136, 0),
    // 35,947 `v` lines but only 34,834 referenced positions (tobj keeps referenced ones)
    ("stanford-bunny.obj", 34834, 69451, false, 0.0, 223),
    ("cornell_box/CornellBox-Original.obj", 64, 32, false, 0.0, 16),
];

#[test]
fn obj_counts_and_measures_match_sources() {
    let Some(data) = common::shared_data("obj_counts_and_measures_match_sources") else {
        return;
    };
    for &(f, v, t, closed, vol, boundary) in OBJ_FACTS {
        let (scene, report) = load_mesh(data.join("meshes").join(f)).unwrap();
        let m = &scene.mesh;
        assert_eq!(m.positions.len(), v, "{f}");
        assert_eq!(m.indices.len(), t, "{f}");
        assert_eq!(report.source_triangles, t, "{f}");
        assert_eq!(m.is_watertight(), closed, "{f}");
        let es = m.edge_stats();
        assert_eq!(es.boundary, boundary, "{f}");
        assert_eq!(es.non_manifold, 0, "{f}");
        assert_eq!(es.inconsistent, 0, "{f}");
        if vol > 0.0 {
            assert!(rel(m.signed_volume(), vol) < 1e-5, "{f}: volume {}", m.signed_volume());
        }
    }
    // bounding boxes from SOURCES.md
    let (arm, _) = load_mesh(data.join("meshes/armadillo_43k.obj")).unwrap();
    let b = arm.mesh.bounds().unwrap();
    assert_eq!(b.min, [-0.435275, -0.573402, -0.379481]);
    assert_eq!(b.max, [0.403342, 0.426549, 0.38333]);
    let (bunny, r) = load_mesh(data.join("meshes/stanford-bunny.obj")).unwrap();
    assert_eq!(r.vertices_in_file, 35947);
    let b = bunny.mesh.bounds().unwrap();
    assert_eq!(b.min, [-0.09469, 0.032987, -0.061874]);
    assert_eq!(b.max, [0.061009, 0.187321, 0.0588]);
}

fn gltf(data: &Path, f: &str) -> Scene {
    load_mesh(data.join("gltf").join(f)).unwrap().0
}

#[test]
fn gltf_counts_match_sources() {
    let Some(data) = common::shared_data("gltf_counts_match_sources") else {
        return;
    };
    // (file, vertices, triangles, bbox min, bbox max) — trimesh's bind-pose numbers
    type Fact = (&'static str, usize, usize, [f64; 3], [f64; 3]);
    let facts: &[Fact] = &[
        ("Fox/Fox.glb", 1728, 576, [-12.5927, -0.121745, -88.095], [12.5927, 78.9072, 66.6249]),
        ("SimpleSkin/SimpleSkin.gltf", 10, 8, [-0.5, 0.0, 0.0], [0.5, 2.0, 0.0]),
        ("CornellBox/CornellBox.glb", 74, 36, [-556.0, 0.0, -559.2], [0.0, 548.8, 0.00012207]),
        (
            "MixedLightingExample/MixedLightingExample.gltf",
            23028,
            40898,
            [-1.55355, -6.97779e-05, -1.55355],
            [1.55355, 0.686177, 1.55355],
        ),
        // trimesh reports 804 / 1084: it counts the d8 mesh once although two nodes
        // instance it (6 + 6 triangles, 16 + 16 vertices each); we import every instance.
        ("TestScene/TestScene.gltf", 836, 1096, [-5.0, -0.685001, -5.0], [5.0, 1.86791, 5.0]),
    ];
    for &(f, v, t, lo, hi) in facts {
        let s = gltf(&data, f);
        assert_eq!(s.mesh.positions.len(), v, "{f}");
        assert_eq!(s.mesh.indices.len(), t, "{f}");
        let b = s.mesh.bounds().unwrap();
        for k in 0..3 {
            let tol = 1e-5 * (1.0 + hi[k].abs().max(lo[k].abs()));
            assert!((b.min[k] - lo[k]).abs() < tol, "{f} min {:?}", b.min);
            assert!((b.max[k] - hi[k]).abs() < tol, "{f} max {:?}", b.max);
        }
        assert_eq!(s.bindings.len(), v, "{f}");
        assert_eq!(s.pose(None, 0.0).unwrap(), s.mesh.positions, "{f}: rest pose");
    }
}

#[test]
fn fox_is_skinned_with_three_animations() {
    let Some(data) = common::shared_data("fox_is_skinned_with_three_animations") else {
        return;
    };
    let fox = gltf(&data, "Fox/Fox.glb");
    assert!(fox.is_skinned());
    assert!(fox.mesh.is_watertight());
    assert_eq!(fox.skins.len(), 1);
    assert_eq!(fox.skins[0].joints.len(), 24);
    assert_eq!(fox.nodes.len(), 26);
    let names: Vec<_> = fox.animations.iter().map(|a| a.name.clone().unwrap()).collect();
    assert_eq!(names, ["Survey", "Walk", "Run"]);
    for b in &fox.bindings {
        let s = b.skin.expect("every Fox vertex is skinned");
        assert!((s.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    let rest_diag = fox.mesh.bounds().unwrap().diagonal();
    for (k, anim) in fox.animations.iter().enumerate() {
        let [t0, t1] = anim.time_range();
        assert!(t1 > t0);
        let mut moved: f64 = 0.0;
        for i in 0..8 {
            let t = t0 + (t1 - t0) * i as f64 / 7.0;
            let posed = fox.posed_mesh(Some(k), t).unwrap();
            posed.validate().unwrap();
            let d = posed.bounds().unwrap().diagonal();
            assert!(d > 0.5 * rest_diag && d < 1.5 * rest_diag, "{} at {t}: {d}", names[k]);
            for (p, q) in posed.positions.iter().zip(&fox.mesh.positions) {
                let dd: f64 = (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt();
                moved = moved.max(dd);
            }
        }
        // every clip visibly moves the fox (it is ~150 units long)
        assert!(moved > 5.0, "{}: max displacement {moved}", names[k]);
    }
    // time outside the clip clamps to the end keys
    let a = fox.pose(Some(1), -10.0).unwrap();
    let b = fox.pose(Some(1), fox.animations[1].time_range()[0]).unwrap();
    assert_eq!(a, b);
}

#[test]
fn simple_skin_bends() {
    let Some(data) = common::shared_data("simple_skin_bends") else {
        return;
    };
    let s = gltf(&data, "SimpleSkin/SimpleSkin.gltf");
    assert_eq!(s.skins[0].joints.len(), 2);
    assert_eq!(s.animations.len(), 1);
    let [t0, t1] = s.animations[0].time_range();
    // the top vertices (y = 2) swing sideways during the clip, the bottom ones stay
    let mut max_dx: f64 = 0.0;
    for i in 0..=10 {
        let p = s.pose(Some(0), t0 + (t1 - t0) * i as f64 / 10.0).unwrap();
        for (k, q) in p.iter().enumerate() {
            let r = s.mesh.positions[k];
            if r[1] == 2.0 {
                max_dx = max_dx.max((q[0] - r[0]).abs());
            }
            if r[1] == 0.0 {
                assert!((q[0] - r[0]).abs() < 1e-9 && (q[1] - r[1]).abs() < 1e-9);
            }
        }
    }
    assert!(max_dx > 0.3, "top vertices moved only {max_dx}");
}
