//! Per-proxy albedo (IBPA §5) from glTF materials: a GLB written here with two boxes of known
//! `baseColorFactor` (and a third part without a material) gives spheres with those albedos,
//! stored in and read back from the SPHR `albedo` section.

use penumbra_geometry::import::gltf::load_gltf_bytes;
use penumbra_spheres::asset::{read, to_asset};
use penumbra_spheres::fit::{FitParams, Target, fit};
use penumbra_testkit::gltf::{Part, cuboid, glb};
use std::path::Path;

const RED: [f32; 4] = [0.9, 0.1, 0.2, 1.0];
const BLUE: [f32; 4] = [0.1, 0.3, 0.7, 0.5];

fn scene(third: bool) -> penumbra_geometry::Scene {
    let a = cuboid([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    let b = cuboid([3.0, 0.0, 0.0], [4.0, 1.0, 1.0]);
    let c = cuboid([0.0, 0.0, 3.0], [1.0, 1.0, 4.0]);
    let mut parts = vec![
        Part { positions: &a.0, triangles: &a.1, base_color: Some(RED) },
        Part { positions: &b.0, triangles: &b.1, base_color: Some(BLUE) },
    ];
    if third {
        parts.push(Part { positions: &c.0, triangles: &c.1, base_color: None });
    }
    let bytes = glb(&parts);
    load_gltf_bytes(Path::new("two.glb"), &bytes, Path::new(".")).unwrap().0
}

fn params(n: usize) -> FitParams {
    let mut p = FitParams::new(Target::Count(n));
    p.grid = 16;
    p.iterations = 10;
    p
}

fn close(a: [f32; 3], b: [f32; 4]) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() < 1e-6)
}

#[test]
fn spheres_take_the_albedo_of_the_material_they_bound() {
    let s = scene(true);
    assert_eq!(s.base_color.len(), s.mesh.positions.len());
    let mut p = params(6);
    p.albedo = Some([0.25, 0.5, 0.75]);
    let r = fit(&s, &p, &penumbra_math::progress::NoProgress).unwrap();
    let al = r.albedo.as_ref().expect("albedo stored");
    assert_eq!(al.len(), r.spheres.len());
    let mut seen = [0usize; 3];
    for (sp, a) in r.spheres.iter().zip(al) {
        // every sphere lies around one of the three boxes, far apart: its albedo is that box's
        let (x, z) = (sp[0], sp[2]);
        let want = if x > 2.0 {
            seen[1] += 1;
            BLUE
        } else if z > 2.0 {
            seen[2] += 1;
            [0.25, 0.5, 0.75, 1.0]
        } else {
            seen[0] += 1;
            RED
        };
        assert!(close(*a, want), "sphere {sp:?}: albedo {a:?}, expected {want:?}");
    }
    assert!(seen.iter().all(|&k| k > 0), "{seen:?}");
    // stored and read back
    let bytes = to_asset(&r, &serde_json::json!({"kind": "SPHR"})).unwrap().to_bytes().unwrap();
    let owned = penumbra_asset::OwnedAsset::parse(&bytes).unwrap();
    let back = read(&owned.asset()).unwrap();
    assert_eq!(back.albedo.as_ref(), Some(al));
}

#[test]
fn a_sphere_across_two_materials_gets_their_area_weighted_mean() {
    // one sphere over both boxes: equal areas, so the mean of the two factors
    let s = scene(false);
    let r = fit(&s, &params(1), &penumbra_math::progress::NoProgress).unwrap();
    let al = r.albedo.unwrap();
    let want: [f32; 3] = std::array::from_fn(|k| 0.5 * (RED[k] + BLUE[k]));
    for k in 0..3 {
        assert!((al[0][k] - want[k]).abs() < 1e-5, "{:?} vs {want:?}", al[0]);
    }
}

#[test]
fn no_material_and_no_albedo_stores_nothing_and_bad_factors_are_refused() {
    let a = cuboid([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    let bytes = glb(&[Part { positions: &a.0, triangles: &a.1, base_color: None }]);
    let s = load_gltf_bytes(Path::new("plain.glb"), &bytes, Path::new(".")).unwrap().0;
    assert!(s.base_color.is_empty());
    let r = fit(&s, &params(2), &penumbra_math::progress::NoProgress).unwrap();
    assert!(r.albedo.is_none());
    let bytes = glb(&[Part { positions: &a.0, triangles: &a.1, base_color: Some([1.5, 0.0, 0.0, 1.0]) }]);
    let s = load_gltf_bytes(Path::new("bad.glb"), &bytes, Path::new(".")).unwrap().0;
    let e = fit(&s, &params(2), &penumbra_math::progress::NoProgress).unwrap_err();
    assert!(e.to_string().contains("baseColorFactor"), "{e}");
}
