//! Environment maps from ../shared/data/env: orientation markers, the Grace Cathedral SH9
//! table, solid angles, cube resampling.

#![allow(clippy::print_stderr)] // tests may print a summary

mod common;

use std::f64::consts::PI;

use penumbra_geometry::env::{CubeMap, DEFAULT_FACE_SIZE, EnvMap, EnvmapAttribute, load_env_map};

/// OrientationLatLong.exr draws, at each of the six axis directions, two short dark arms
/// along great circles toward the two perpendicular *positive* axes (e.g. at +Z: toward +X
/// and +Y), on a light background. Mirroring or rotating the mapping moves the arms to the
/// negative side, so checking both sides pins the orientation. Tolerance: one texel (0.35°).
#[test]
fn orientation_markers_land_at_documented_directions() {
    let Some(data) = common::shared_data("orientation_markers_land_at_documented_directions") else {
        return;
    };
    let (m, report) = load_env_map(data.join("env/OrientationLatLong.exr")).unwrap();
    assert_eq!((m.width(), m.height()), (1024, 512));
    assert_eq!(report.envmap, Some(EnvmapAttribute::LatLong));
    let dark_near = |dir: [f64; 3]| {
        let [u, v] = EnvMap::direction_to_uv(dir);
        let (x, y) = ((u * 1024.0) as i64, (v * 512.0) as i64);
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let t = m.texel((x + dx).rem_euclid(1024) as usize, (y + dy).clamp(0, 511) as usize);
                t[0].max(t[1]).max(t[2]) < 0.45
            })
        })
    };
    let axes =
        [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    let positive = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut checked = 0;
    for a in axes {
        for b in positive {
            if (0..3).map(|k| a[k] * b[k]).sum::<f64>() != 0.0 {
                continue;
            }
            for deg in [6.0f64, 10.0, 15.0] {
                let (s, c) = deg.to_radians().sin_cos();
                let toward = [0, 1, 2].map(|k| c * a[k] + s * b[k]);
                let away = [0, 1, 2].map(|k| c * a[k] - s * b[k]);
                assert!(dark_near(toward), "no marker from {a:?} toward +{b:?} at {deg}°");
                assert!(!dark_near(away), "marker from {a:?} toward −{b:?} at {deg}°");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 6 * 2 * 3);
    // the +X arm toward +Y is drawn in column 256 (our +X is the 255|256 texel boundary)
    let col = |y: usize| (250..262).filter(|&x| m.texel(x, y)[1] < 0.45).collect::<Vec<_>>();
    for y in [200, 220, 240] {
        let c = col(y);
        assert!(!c.is_empty() && c.iter().all(|&x| (x as f64 - 255.5).abs() <= 1.5), "row {y}: {c:?}");
    }
}

/// Projecting grace_latlong.exr onto SH9 reproduces the raw coefficients recorded in
/// grace_rh2001_sh9.json once our directions are rotated 180° about Z into R&H's frame.
#[test]
fn grace_reproduces_ramamoorthi_hanrahan_table() {
    let Some(data) = common::shared_data("grace_reproduces_ramamoorthi_hanrahan_table") else {
        return;
    };
    let (m, report) = load_env_map(data.join("env/grace_latlong.exr")).unwrap();
    assert_eq!(report.envmap, None);
    let json = std::fs::read_to_string(data.join("env/grace_rh2001_sh9.json")).unwrap();
    let expected = numbers_after(&json, "\"raw_coefficients_file_units\"", 27);
    let mut c = [[0.0f64; 3]; 9];
    for (d, sa, rgb) in m.iter() {
        let (x, y, z) = (-d[0], -d[1], d[2]); // our frame → R&H frame
        let basis = [
            0.282095,
            0.488603 * y,
            0.488603 * z,
            0.488603 * x,
            1.092548 * x * y,
            1.092548 * y * z,
            0.315392 * (3.0 * z * z - 1.0),
            1.092548 * x * z,
            0.546274 * (x * x - y * y),
        ];
        for (i, b) in basis.iter().enumerate() {
            for ch in 0..3 {
                c[i][ch] += b * sa * rgb[ch] as f64;
            }
        }
    }
    let mut worst: f64 = 0.0;
    for i in 0..9 {
        for ch in 0..3 {
            worst = worst.max((c[i][ch] - expected[i * 3 + ch]).abs());
        }
    }
    assert!(worst < 2e-4, "max |ours − json| = {worst}; ours {c:?}");
    // the same projection without the rotation is far off (the map is "upside down")
    let l10_unrotated: f64 = m.iter().map(|(d, sa, rgb)| 0.488603 * d[2] * sa * rgb[0] as f64).sum();
    let l1m1_unrotated: f64 = m.iter().map(|(d, sa, rgb)| 0.488603 * d[1] * sa * rgb[0] as f64).sum();
    assert!((l10_unrotated - expected[6]).abs() < 2e-4); // z is unchanged by the rotation
    assert!((l1m1_unrotated + expected[3]).abs() < 2e-4); // y flips sign
}

/// The first `n` numbers after `key` in a JSON text (keys in between are skipped).
fn numbers_after(text: &str, key: &str, n: usize) -> Vec<f64> {
    let start = text.find(key).expect("key") + key.len();
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut in_string = false;
    for ch in text[start..].chars() {
        if ch == '"' {
            in_string = !in_string;
            cur.clear();
            continue;
        }
        if in_string {
            continue;
        }
        if ch.is_ascii_digit() || ch == '.' || ch == '-' || ch == 'e' || ch == 'E' || ch == '+' {
            cur.push(ch);
        } else {
            if let Ok(v) = cur.parse::<f64>() {
                out.push(v);
                if out.len() == n {
                    break;
                }
            }
            cur.clear();
        }
    }
    out
}

#[test]
fn all_env_maps_load_and_cube_resampling_keeps_power() {
    let Some(data) = common::shared_data("all_env_maps_load_and_cube_resampling_keeps_power") else {
        return;
    };
    let files = [
        "env/grace_latlong.exr",
        "env/OrientationLatLong.exr",
        "env/spiaggia_di_mondello_1k.hdr",
        "env/probes_small/uffizi_256x128.hdr",
        "env/probes_small/pisa_256x128.hdr",
        "env/probes_small/ennis_256x128.hdr",
        "env/probes_small/grace_256x128.hdr",
    ];
    for f in files {
        let (m, r) = load_env_map(data.join(f)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.width(), 2 * m.height(), "{f}");
        assert!(r.warnings.is_empty(), "{f}: {:?}", r.warnings);
        let total: f64 = (0..m.height()).map(|y| m.texel_solid_angle(y) * m.width() as f64).sum();
        assert!((total - 4.0 * PI).abs() < 1e-12 * 4.0 * PI, "{f}");
        let ll = m.integral();
        let cube = CubeMap::from_latlong(&m, DEFAULT_FACE_SIZE);
        let cu = cube.integral();
        for ch in 0..3 {
            let rel = (cu[ch] - ll[ch]).abs() / ll[ch];
            eprintln!("{f} ch{ch}: lat-long {:.6e}, cube {:.6e}, rel {rel:.2e}", ll[ch], cu[ch]);
            assert!(rel < 1e-6, "{f} channel {ch}: relative power error {rel}");
        }
    }
}
