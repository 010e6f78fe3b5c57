//! The C/C++ examples (`examples/c/inspect.c`, `examples/c/shade_fiv.c`,
//! `examples/cpp/mrt_level.cpp`), built with the system compiler under ASan/UBSan against this
//! crate's static library, print what the Rust runtime computes: the test parses their output
//! and recomputes every value with `penumbra-runtime` (1e-6 relative). Inputs: the compat
//! corpus (always) and the demo bake's outputs in `out/demo/` (when baked). Skips with a message
//! when there is no C or C++ compiler.
#![allow(clippy::print_stderr)]

mod common;

use penumbra_asset::{Asset, AssetFile};
use penumbra_runtime::fiv::{FivShader, FivTable, PlacedOccluder, ShadeOptions};
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use std::path::{Path, PathBuf};
use std::process::Command;

fn out_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("c-examples")
}

/// Builds example `src` (relative to examples/) into `name`; None when the compiler is absent.
fn example(src: &str, name: &str, cpp: bool, with_lib: bool) -> Option<PathBuf> {
    let cc = if cpp { common::compiler("CXX", "c++", src)? } else { common::compiler("CC", "cc", src)? };
    std::fs::create_dir_all(out_dir()).unwrap();
    let out = out_dir().join(name);
    let mut flags: Vec<String> = common::C_FLAGS.iter().map(|s| s.to_string()).collect();
    if cpp {
        flags[0] = "-std=c++17".into();
    }
    let ex = common::root().join("examples");
    flags.push(format!("-I{}", ex.join("c").display()));
    let mut sources = vec![ex.join(src)];
    let mut tail = Vec::new();
    if with_lib {
        sources.push(common::staticlib());
        tail = vec!["-lpthread".to_string(), "-ldl".to_string(), "-lm".to_string()];
    }
    flags.extend(tail.iter().cloned());
    let flags: Vec<&str> = flags.iter().map(String::as_str).collect();
    common::build(&cc, &sources, &flags, &out);
    Some(out)
}

fn run(exe: &Path, args: &[&Path]) -> String {
    let out = Command::new(exe).args(args).output().unwrap();
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "{} failed ({}):\n{}",
        exe.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-6 * a.abs().max(b.abs()) || (a - b).abs() <= 1e-30
}

fn corpus(name: &str) -> PathBuf {
    common::root().join("tests/assets/v1").join(name)
}

/// Existing demo outputs among `names` (all or nothing).
fn demo(names: &[&str]) -> Option<Vec<PathBuf>> {
    let paths: Vec<PathBuf> = names.iter().map(|n| common::root().join("out/demo").join(n)).collect();
    if paths.iter().all(|p| p.is_file()) {
        Some(paths)
    } else {
        eprintln!("demo outputs {names:?} not baked (cargo run --release -- bake bake-configs/demo.toml): corpus only");
        None
    }
}

#[test]
fn inspect_lists_what_the_rust_loader_reads() {
    let Some(exe) = example("c/inspect.c", "inspect", false, false) else { return };
    let mut files: Vec<PathBuf> = std::fs::read_dir(common::root().join("tests/assets/v1"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x != "md"))
        .collect();
    files.sort();
    let refs: Vec<&Path> = files.iter().map(PathBuf::as_path).collect();
    let text = run(&exe, &refs);
    let mut lines = text.lines();
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let a = Asset::parse(&bytes).unwrap();
        let head = lines.next().unwrap();
        let (major, minor) = a.version();
        let want = format!(
            "{}: {} format {major}.{minor}, {} sections, {} bytes",
            f.display(),
            a.kind(),
            a.sections().len(),
            bytes.len()
        );
        assert_eq!(head, want);
        for s in a.sections() {
            let dims: Vec<String> = s.dims().iter().map(usize::to_string).collect();
            let crit = if s.is_critical() { " critical" } else { "" };
            let want = format!(
                "  {:<32} {:<4} [{}] {} bytes crc32c {:08x}{crit}",
                s.name(),
                s.dtype().name(),
                dims.join(", "),
                s.byte_len(),
                s.crc()
            );
            assert_eq!(lines.next().unwrap(), want);
        }
    }
    assert!(lines.next().is_none());
    // A damaged file is refused with exit 2.
    let bad = out_dir().join("damaged.fivt");
    let mut bytes = std::fs::read(corpus("fiv-torus-8x5x4.fivt")).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&bad, &bytes).unwrap();
    let out = Command::new(&exe).arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("checksum"));
}

fn floats(words: &[&str]) -> Vec<f32> {
    words.iter().map(|w| w.parse::<f32>().unwrap()).collect()
}

fn check_shade_fiv(exe: &Path, fivt: &Path) -> usize {
    let text = run(exe, &[fivt]);
    let file = AssetFile::open(fivt).unwrap();
    let asset = file.asset();
    let table = FivTable::from_asset(&asset).unwrap();
    let c = table.center();
    let moved = [c[0] + 1.2 * table.radius(), c[1], c[2]];
    let scene = [PlacedOccluder { table: &table, center: c }, PlacedOccluder { table: &table, center: moved }];
    let mut shader = FivShader::new();
    let mut receivers = 0;
    let mut shadowed = 0;
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[0] {
            "p" => {
                let v = floats(&[w[1], w[2], w[3], w[5], w[6], w[7], w[9], w[10], w[11]]);
                let e = shader.irradiance(&scene, [v[0], v[1], v[2]], [v[3], v[4], v[5]], ShadeOptions::default());
                for k in 0..3 {
                    assert!(close(v[6 + k], e[k]), "{line}: Rust {e:?}");
                }
                let tot = table.total_irradiance([0.0, 1.0, 0.0]);
                shadowed += usize::from(e[0] < 0.99 * tot[0]);
                receivers += 1;
            }
            "U" => {
                let v = floats(&w[1..4]);
                let u = table.total_irradiance([0.0, 1.0, 0.0]);
                assert!((0..3).all(|k| close(v[k], u[k])), "{line}: Rust {u:?}");
            }
            other => panic!("unexpected line {other}"),
        }
    }
    assert_eq!(receivers, 64);
    // the plane under the occluders is in shadow somewhere, so the values test the shadow path
    assert!(shadowed >= 4, "{shadowed} receivers shadowed");
    receivers
}

#[test]
fn shade_fiv_equals_the_rust_runtime() {
    let Some(exe) = example("c/shade_fiv.c", "shade_fiv", false, true) else { return };
    check_shade_fiv(&exe, &corpus("fiv-torus-8x5x4.fivt"));
    if let Some(d) = demo(&["torus.fivt"]) {
        check_shade_fiv(&exe, &d[0]);
    }
}

fn check_mrt_level(exe: &Path, dict: &Path, level: &Path) {
    let text = run(exe, &[dict, level]);
    let (df, lf) = (AssetFile::open(dict).unwrap(), AssetFile::open(level).unwrap());
    let (da, la) = (df.asset(), lf.asset());
    let d = MrtDictionary::from_asset(&da).unwrap();
    let l = MrtLevel::from_asset(&la, &d).unwrap();
    let mut rt = MrtRuntime::new(d, l);
    let n = rt.texel_count();
    let first_other = rt.offsets()[1];
    let l_d: Vec<f32> = (0..n).map(|t| if t < first_other { 1.0 + 0.25 * (t % 5) as f32 } else { 0.0 }).collect();
    let (mut one, mut local, mut multi) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    rt.indirect(&l_d, &mut one, true);
    rt.indirect(&l_d, &mut local, false);
    rt.multi_bounce(&l_d, &mut multi, 3, 0.5);
    let (w, h) = rt.level().atlas;
    let mut atlas = vec![0.0f32; w * h];
    rt.pad_atlas(&one, &mut atlas);

    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), format!("T {n} B {} A {w} {h}", rt.level().shapes.len()));
    for t in 0..n {
        let line = lines.next().unwrap();
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!((f[0], f[1]), ("t", t.to_string().as_str()));
        let v = floats(&f[2..6]);
        let want = [l_d[t], one[t], local[t], multi[t]];
        assert!((0..4).all(|k| close(v[k], want[k])), "{line}: Rust {want:?}");
    }
    let nonzero: Vec<(usize, f32)> = atlas.iter().copied().enumerate().filter(|&(_, v)| v != 0.0).collect();
    for (i, v) in &nonzero {
        let line = lines.next().unwrap();
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!((f[0], f[1]), ("a", i.to_string().as_str()));
        assert!(close(f[2].parse().unwrap(), *v), "{line}: Rust {v}");
    }
    assert!(lines.next().is_none());
    // Light crossed into other blocks through the interfaces, and the atlas is filled.
    assert!(one[first_other..].iter().any(|&v| v > 0.0) && local[first_other..].iter().all(|&v| v == 0.0));
    assert!(nonzero.len() >= n);
}

#[test]
fn mrt_level_equals_the_rust_runtime() {
    let Some(exe) = example("cpp/mrt_level.cpp", "mrt_level", true, true) else { return };
    check_mrt_level(&exe, &corpus("mrt-cube2d-r4-interfaces.mrtd"), &corpus("mrt-corridor3.mrtl"));
    if let Some(d) = demo(&["dictionary.mrtd", "level.mrtl"]) {
        check_mrt_level(&exe, &d[0], &d[1]);
    }
}
