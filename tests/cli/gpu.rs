//! The WGSL twins of the runtime (issue #20): `penumbra shaders export` and `penumbra verify
//! gpu`. The device tests skip with a message when no adapter exists (a bare machine); CI
//! installs lavapipe, a software Vulkan device, so they run there.

use crate::mrt_level::{U_TURN, small_dict};
use crate::{penumbra, run};
use penumbra_asset::AssetFile;
use penumbra_gpu::{Gpu, GpuError, compare, mrt::GpuMrt};
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use serde_json::Value;

/// The device, or `None` with a skip message.
fn device(test: &str) -> Option<Gpu> {
    match Gpu::new() {
        Ok(g) => Some(g),
        Err(GpuError::NoAdapter(e)) => {
            eprintln!("skipping {test}: no GPU adapter ({e})");
            None
        }
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn shaders_export_writes_every_translation_and_the_spirv_validates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("shaders");
    let (code, stdout, stderr) = run(penumbra().args(["shaders", "export", "--json", "-o"]).arg(&out));
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let files: Vec<&str> = v["files"].as_array().unwrap().iter().map(|f| f["file"].as_str().unwrap()).collect();
    for s in penumbra_gpu::SHADERS {
        for ext in ["wgsl", "spv", "hlsl", "msl"] {
            let name = format!("{}.{ext}", s.name);
            assert!(files.contains(&name.as_str()), "{name} not in {files:?}");
            assert!(std::fs::metadata(out.join(&name)).unwrap().len() > 100, "{name} is empty");
        }
        for e in s.entry_points {
            assert!(out.join(format!("{}.{e}.glsl", s.name)).exists(), "{e}.glsl");
        }
        assert_eq!(std::fs::read_to_string(out.join(format!("{}.wgsl", s.name))).unwrap(), s.source);
        match std::process::Command::new("spirv-val").arg(out.join(format!("{}.spv", s.name))).output() {
            Ok(o) => assert!(o.status.success(), "spirv-val {}: {}", s.name, String::from_utf8_lossy(&o.stderr)),
            Err(_) => eprintln!("spirv-val not installed (Debian: spirv-tools): {}.spv not validated", s.name),
        }
    }
    assert!(std::fs::read_to_string(out.join("README.md")).unwrap().contains("mrt.wgsl"));
}

#[test]
fn the_mrt_shader_matches_the_cpu_runtime_on_a_u_turn_of_turned_blocks() {
    let Some(gpu) = device("the_mrt_shader_matches_the_cpu_runtime_on_a_u_turn_of_turned_blocks") else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let lt = dir.path().join("l.toml");
    std::fs::write(&lt, U_TURN).unwrap();
    let l = dir.path().join("l.mrtl");
    let (code, _, stderr) = run(penumbra().args(["mrt", "level"]).arg(&lt).arg("--dict").arg(&d).arg("-o").arg(&l));
    assert_eq!(code, 0, "{stderr}");
    let (df, lf) = (AssetFile::open(&d).unwrap(), AssetFile::open(&l).unwrap());
    let (da, la) = (df.asset(), lf.asset());
    let rd = MrtDictionary::from_asset(&da).unwrap();
    let rl = MrtLevel::from_asset(&la, &rd).unwrap();
    let mut rt = MrtRuntime::new(rd, rl);
    let n = rt.texel_count();
    // direct light: a hashed pattern, so every texel and face carries a different value
    let l_d: Vec<f32> = (0..n).map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32 / 16_777_216.0).collect();
    let (mut one, mut none, mut multi) = (vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
    rt.indirect(&l_d, &mut none, false);
    rt.multi_bounce(&l_d, &mut multi, 4, 0.7);
    rt.indirect(&l_d, &mut one, true);
    let (w, h) = rt.level().atlas;
    let mut atlas = vec![0.0f32; w * h];
    rt.pad_atlas(&one, &mut atlas);

    let mut g = GpuMrt::new(&gpu, &rt).unwrap();
    let g_none = g.indirect(&l_d, false).unwrap();
    let g_multi = g.multi_bounce(&l_d, 4, 0.7).unwrap();
    let g_one = g.indirect(&l_d, true).unwrap();
    let g_atlas = g.pad_atlas(&g_one).unwrap();
    for (what, gv, cv) in [
        ("one bounce", &g_one, &one),
        ("no interfaces", &g_none, &none),
        ("multi", &g_multi, &multi),
        ("atlas", &g_atlas, &atlas),
    ] {
        let d = compare(gv, cv);
        assert!(d.max_rel <= 1e-4, "{what}: {d:?} (gpu {} cpu {})", gv[d.at], cv[d.at]);
    }
    // the comparison has teeth: the interfaces carry light between the blocks (one bounce
    // differs from the blocks alone by far more than the tolerance), and so do the bounces
    assert!(compare(&g_one, &none).max_rel > 1e-2);
    assert!(compare(&g_multi, &one).max_rel > 1e-2);
    assert!(g_atlas.iter().filter(|&&x| x != 0.0).count() > n / 2);
    // a wrong input length is an error, not a panic
    assert!(matches!(g.indirect(&l_d[1..], true), Err(GpuError::Size { .. })));
}

#[test]
fn verify_gpu_mrt_reports_the_device_and_the_difference_from_the_cpu_runtime() {
    let dir = tempfile::tempdir().unwrap();
    let d = small_dict(dir.path());
    let (code, stdout, stderr) = run(penumbra()
        .args(["verify", "gpu", "mrt", "--corridor", "3", "--bounces", "3", "--max-diff", "1e-4", "--json", "--dict"])
        .arg(&d));
    if code == 2 && stderr.contains("no GPU adapter") {
        assert!(stderr.contains("mesa-vulkan-drivers"), "the message says how to install one: {stderr}");
        eprintln!("skipping verify_gpu_mrt: {stderr}");
        return;
    }
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["gate_passed"], true);
    assert_eq!(v["max_diff"], 1e-4);
    let mut worst = 0.0f64;
    for k in ["one_bounce", "no_interfaces", "multi_bounce", "atlas"] {
        let d = v["checks"][k]["max_rel_diff"].as_f64().unwrap();
        assert!(d <= 1e-4, "{k}: {v}");
        worst = worst.max(d);
    }
    // the top-level figure is the worst check's, not the gate's bound
    assert_eq!(v["max_rel_diff"].as_f64().unwrap(), worst);
    assert!(!v["adapter"].as_str().unwrap().is_empty());
    assert!(v["gpu_ms"].as_f64().unwrap() > 0.0 && v["cpu_ms"].as_f64().unwrap() > 0.0);
    assert_eq!(v["blocks"], 3);
}
