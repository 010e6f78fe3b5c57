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

// ---- base-colour textures ----

use penumbra_geometry::texture::srgb_to_linear;
use penumbra_spheres::albedo::SurfaceAlbedo;
use penumbra_testkit::gltf::{glb_textured, uv_cube};

fn png(w: u32, h: u32, rgb: &[u8]) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out).write_image(rgb, w, h, image::ExtendedColorType::Rgb8).unwrap();
    out
}

fn textured(factor: [f32; 4], image: &[u8], wrap: u32) -> penumbra_geometry::Scene {
    let (v, t, uv) = uv_cube([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    let bytes =
        glb_textured(Part { positions: &v, triangles: &t, base_color: Some(factor) }, &uv, image, "image/png", wrap);
    load_gltf_bytes(Path::new("textured.glb"), &bytes, Path::new(".")).unwrap().0
}

#[test]
fn a_uniform_texture_multiplies_the_factor_after_srgb_decoding() {
    // 4×4 texels of sRGB (188, 100, 30): every sphere's albedo is factor × the decoded colour,
    // not the factor alone (texture ignored) nor factor × 188/255 (no sRGB decode)
    let c = [188u8, 100, 30];
    let img = png(4, 4, &c.repeat(16));
    let factor = [1.0, 0.5, 0.8, 1.0];
    let s = textured(factor, &img, 10497);
    assert_eq!(s.base_color_texture.len(), s.mesh.positions.len());
    let r = fit(&s, &params(4), &penumbra_math::progress::NoProgress).unwrap();
    let want: [f32; 3] = std::array::from_fn(|k| factor[k] * srgb_to_linear(f32::from(c[k]) / 255.0));
    assert!((want[0] - 0.5029).abs() < 1e-3);
    for a in r.albedo.as_ref().unwrap() {
        for k in 0..3 {
            assert!((a[k] - want[k]).abs() < 1e-5, "{a:?} vs {want:?}");
        }
    }
}

#[test]
fn texture_albedo_is_an_area_average_that_follows_the_uvs() {
    // 2×1 texels, white | black, clamped: each face's mean is ½ (the bilinear ramp between the
    // texel centres is symmetric), and the footprint of a small piece reads its own half
    let img = png(2, 1, &[255, 255, 255, 0, 0, 0]);
    let s = textured([1.0; 4], &img, 33071);
    let r = fit(&s, &params(1), &penumbra_math::progress::NoProgress).unwrap();
    let a = r.albedo.unwrap()[0];
    assert!(a.iter().all(|&x| (x - 0.5).abs() < 0.01), "{a:?}");
    let surface = SurfaceAlbedo::new(&s, [1.0; 3]).unwrap();
    assert!(surface.is_textured());
    // triangle 0 has UVs (0,0), (1,0), (1,1): barycentric (u, v) is UV (u + v, v)
    let left = surface.at(0, 0.05, 0.05, 1e-6);
    let right = surface.at(0, 0.8, 0.1, 1e-6);
    assert!(left.iter().all(|&x| (x - 1.0).abs() < 1e-6), "{left:?}");
    assert!(right.iter().all(|&x| x.abs() < 1e-6), "{right:?}");
    // the whole image as footprint (fraction 1 of a triangle covering half the UV square):
    // between the point value and the mean, never outside [0, 1]
    let whole = surface.at(0, 2.0 / 3.0, 1.0 / 3.0, 1.0)[0];
    assert!((0.0..=1.0).contains(&whole));
}

#[test]
fn an_undecodable_texture_is_an_error_naming_the_image() {
    let s = textured([1.0; 4], b"definitely not a png", 10497);
    let e = fit(&s, &params(2), &penumbra_math::progress::NoProgress).unwrap_err().to_string();
    assert!(e.contains("image 0 (\"albedo\")") && e.contains("not a PNG or JPEG"), "{e}");
}
