//! Differential test of the single-header C reader `include/penumbra_asset.h` against the Rust
//! loader (`penumbra_asset::Asset::parse`): the same accept/reject decision and the same
//! section list (name, dtype, rank, flags, dims, elements, offset, byte length, CRC) for the
//! compat corpus, the demo outputs (when baked), every file of `../shared/data/bad/` (when
//! present), the fuzz seeds and corpus, and a bounded mutation loop. The driver is built with
//! `-std=c99 -Wall -Wextra -Werror -fsanitize=address,undefined`; any sanitizer report aborts it
//! and fails the test. Skips with a message when there is no C compiler.
#![allow(clippy::print_stderr)]

mod common;

use penumbra_asset::Asset;
use penumbra_asset::format::reseal_checksums;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

#[allow(dead_code)] // its main() is the example's
#[path = "../../asset/examples/fuzz_seeds.rs"]
mod fuzz_seeds;

/// What the Rust loader decides, in the driver's text form.
fn rust_view(bytes: &[u8]) -> String {
    let mut s = String::new();
    match Asset::parse(bytes) {
        Err(_) => s.push_str("R\n"),
        Ok(a) => {
            let (major, minor) = a.version();
            writeln!(s, "A {} {} {} {}", a.kind(), major, minor, a.sections().len()).unwrap();
            for info in a.sections() {
                let critical = u16::from(info.is_critical());
                write!(s, "S {} {} {} {critical}", info.name(), info.dtype().code(), info.rank()).unwrap();
                for axis in 0..6 {
                    write!(s, " {}", info.dims().get(axis).copied().unwrap_or(0)).unwrap();
                }
                let (elements, offset, length, crc) =
                    (info.element_count(), info.offset(), info.byte_len(), info.crc());
                writeln!(s, " {elements} {offset} {length} {crc}").unwrap();
            }
            s.push_str("E\n");
        }
    }
    s
}

/// Runs the driver over `inputs` in one process; returns one text block per input.
fn c_views(driver: &Path, inputs: &[Vec<u8>]) -> Vec<String> {
    let mut child = Command::new(driver)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run the C driver");
    let mut stdin = child.stdin.take().unwrap();
    let payload: Vec<u8> =
        inputs.iter().flat_map(|b| (b.len() as u64).to_le_bytes().into_iter().chain(b.iter().copied())).collect();
    let writer = std::thread::spawn(move || stdin.write_all(&payload));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "C driver failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let mut blocks = Vec::new();
    let mut cur = String::new();
    for line in text.lines() {
        cur.push_str(line);
        cur.push('\n');
        if line == "R" || line == "E" {
            blocks.push(std::mem::take(&mut cur));
        }
    }
    assert!(cur.is_empty(), "trailing driver output: {cur}");
    blocks
}

/// The driver, built once per test process (the tests run in parallel).
fn driver() -> Option<PathBuf> {
    static DRIVER: std::sync::OnceLock<Option<PathBuf>> = std::sync::OnceLock::new();
    DRIVER
        .get_or_init(|| {
            let cc = common::compiler("CC", "cc", "the C reader differential test")?;
            let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("penumbra_asset_reader_driver");
            let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/c/reader_driver.c");
            common::build(&cc, &[src], common::C_FLAGS, &out);
            Some(out)
        })
        .clone()
}

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files_under(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// Compares C and Rust on every input; returns (accepted, refused).
fn compare(driver: &Path, names: &[String], inputs: &[Vec<u8>]) -> (usize, usize) {
    let c = c_views(driver, inputs);
    assert_eq!(c.len(), inputs.len(), "one driver answer per input");
    let mut accepted = 0;
    for ((name, bytes), c) in names.iter().zip(inputs).zip(&c) {
        let rust = rust_view(bytes);
        if rust != *c {
            let keep = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("c_reader_mismatch.bin");
            std::fs::write(&keep, bytes).unwrap();
            panic!("C and Rust disagree on {name} (bytes kept in {}):\nRust:\n{rust}C:\n{c}", keep.display());
        }
        accepted += usize::from(rust.starts_with('A'));
    }
    (accepted, inputs.len() - accepted)
}

fn corpus() -> (Vec<String>, Vec<Vec<u8>>) {
    let root = common::root();
    let mut paths = Vec::new();
    files_under(&root.join("tests/assets/v1"), &mut paths);
    files_under(&root.join("out/demo"), &mut paths);
    files_under(&root.join("fuzz/corpus"), &mut paths);
    if let Some(d) = penumbra_testkit::shared_data("the C reader on ../shared/data/bad") {
        files_under(&d.join("bad"), &mut paths);
    }
    let mut names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let mut inputs: Vec<Vec<u8>> = paths.iter().map(|p| std::fs::read(p).unwrap()).collect();
    for (name, builder) in fuzz_seeds::seeds().unwrap() {
        names.push(format!("fuzz seed {name}"));
        inputs.push(builder.to_bytes().unwrap());
    }
    (names, inputs)
}

#[test]
fn c_reader_agrees_with_rust_on_every_corpus_file() {
    let Some(driver) = driver() else { return };
    let (names, inputs) = corpus();
    let (accepted, refused) = compare(&driver, &names, &inputs);
    eprintln!("C reader = Rust loader on {} files ({accepted} accepted, {refused} refused)", inputs.len());
    // The compat corpus (6 assets with the README) and the 4 seeds are valid; README.md and the
    // bad meshes are not assets.
    assert!(accepted >= 9, "only {accepted} accepted");
    assert!(refused >= 1);
    // every asset kind has a file in the compat corpus, so the C reader is tested on each
    let mut kinds: Vec<String> = names
        .iter()
        .zip(&inputs)
        .filter(|(n, _)| n.contains("tests/assets/v1"))
        .filter_map(|(_, b)| Asset::parse(b).ok().map(|a| a.kind().as_str().to_string()))
        .collect();
    kinds.sort();
    kinds.dedup();
    for k in penumbra_asset::Kind::KNOWN {
        assert!(kinds.iter().any(|x| x == k.as_str()), "no {} file in tests/assets/v1 (have {kinds:?})", k.as_str());
    }
}

/// `tests/c/voss_reader.c`: the VOSS sets (`{disk|ball}.{c0|c1}.n{N}.{points|weights|log2area|zs}`
/// and the reflection textures) read with the C header alone, as the spec's "VOSS" section
/// describes them, on the compat corpus's VOSS file; the sets it finds (by name) must be the
/// ones the Rust loader lists, with the same sums of weights. A weight changed in the file
/// (checksums resealed) must make it fail.
#[test]
fn c_reader_reads_the_voss_sample_sets() {
    let Some(cc) = common::compiler("CC", "cc", "the C VOSS reader") else { return };
    let exe = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("penumbra_voss_reader");
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/c/voss_reader.c");
    let mut flags = common::C_FLAGS.to_vec();
    flags.push("-lm");
    common::build(&cc, &[src], &flags, &exe);
    let file = common::root().join("tests/assets/v1/vo-counts1-3.voss");
    let bytes = std::fs::read(&file).unwrap();
    // what the Rust loader sees: every `<set>.points` and the sum of `<set>.weights`
    let a = Asset::parse(&bytes).unwrap();
    let mut expected = format!("A {}\n", a.sections().len());
    for info in a.sections() {
        let Some(key) = info.name().strip_suffix(".points") else { continue };
        let w = a.section(&format!("{key}.weights")).unwrap().to_f32_vec().unwrap();
        let sum: f64 = w.iter().map(|&x| f64::from(x)).sum();
        writeln!(expected, "S {key} {} {} {sum:.6}", info.dims()[0], info.dims()[1]).unwrap();
    }
    expected.push_str("E\n");
    assert_eq!(expected.matches("\nS ").count(), 12, "4 families x N = 1..3:\n{expected}");
    let out = Command::new(&exe).arg(&file).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "{}\n{stdout}{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(stdout, expected);
    // a weight of ball.c1.n3 doubled: the file still loads, the C check must refuse the set
    let mut bad = bytes.clone();
    let at = a.section("ball.c1.n3.weights").unwrap().info().offset() as usize + 4;
    let w = f32::from_le_bytes(bad[at..at + 4].try_into().unwrap());
    bad[at..at + 4].copy_from_slice(&(2.0 * w + 0.1).to_le_bytes());
    reseal_checksums(&mut bad);
    assert!(Asset::parse(&bad).is_ok());
    let bad_file = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("voss_bad_weight.voss");
    std::fs::write(&bad_file, &bad).unwrap();
    let out = Command::new(&exe).arg(&bad_file).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("X weights do not sum to 1 in ball.c1.n3"), "{stdout}");
}

/// xorshift64*: a tiny deterministic generator (no dependency).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One mutation of a valid file: byte flips, interesting integers written over header or
/// table fields, truncation or extension; most are resealed so that the checksums pass and the
/// structural rules behind them are reached.
fn mutate(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut b = seed.to_vec();
    let table_end = 64 + 96 * u32::from_le_bytes(b[16..20].try_into().unwrap()) as usize;
    for _ in 0..1 + rng.below(3) {
        let table_end = table_end.min(b.len());
        if table_end < 8 {
            break;
        }
        match rng.below(6) {
            0 | 1 => {
                // a byte of the header or the table (where the rules live)
                let at = rng.below(table_end);
                b[at] ^= 1 << rng.below(8);
            }
            2 => {
                let at = rng.below(b.len());
                b[at] = rng.next() as u8;
            }
            3 => {
                const VALUES: [u64; 9] = [0, 1, 2, 63, 64, 0xFFFF_FFFF, 0x8000_0000_0000_0000, u64::MAX, 1 << 32];
                let v = VALUES[rng.below(VALUES.len())].wrapping_add(rng.below(3) as u64).wrapping_sub(1);
                let at = rng.below(table_end.saturating_sub(8)) & !3;
                let w = if rng.below(2) == 0 { 4 } else { 8 };
                b[at..at + w].copy_from_slice(&v.to_le_bytes()[..w]);
            }
            4 => {
                let n = rng.below(b.len() + 1);
                b.truncate(n);
            }
            _ => {
                let n = 1 + rng.below(130);
                b.extend((0..n).map(|_| if rng.below(2) == 0 { 0 } else { rng.next() as u8 }));
            }
        }
    }
    if rng.below(4) != 0 {
        reseal_checksums(&mut b);
    }
    b
}

#[test]
fn c_reader_agrees_with_rust_under_mutation() {
    let Some(driver) = driver() else { return };
    let (_, inputs) = corpus();
    // Small valid seeds keep the sanitized loop fast.
    let seeds: Vec<&Vec<u8>> = inputs.iter().filter(|b| b.len() <= 16384 && Asset::parse(b).is_ok()).collect();
    assert!(seeds.len() >= 5, "{} small valid seeds", seeds.len());
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut names = Vec::new();
    let mut mutants = Vec::new();
    for i in 0..4000 {
        let seed = seeds[i % seeds.len()];
        mutants.push(mutate(&mut rng, seed));
        names.push(format!("mutant {i} of seed {}", i % seeds.len()));
    }
    let (accepted, refused) = compare(&driver, &names, &mutants);
    eprintln!("C reader = Rust loader on {} mutants ({accepted} accepted, {refused} refused)", mutants.len());
    // Both outcomes must be exercised, or the loop tests nothing.
    assert!(accepted >= 20 && refused >= 2000, "{accepted} accepted, {refused} refused");
}

/// UTF-8 edge cases in a JSON section (rule 15, RFC 3629): both readers accept the valid
/// sequences and refuse overlong forms, surrogates, code points above U+10FFFF and truncation.
#[test]
fn c_reader_agrees_with_rust_on_utf8_edge_cases() {
    let Some(driver) = driver() else { return };
    let cases: &[(&[u8], bool)] = &[
        (b"\xF0\x9F\x98\x80", true),  // U+1F600
        (b"\xED\x9F\xBF", true),      // U+D7FF, just below the surrogates
        (b"\xEE\x80\x80", true),      // U+E000, just above
        (b"\xF4\x8F\xBF\xBF", true),  // U+10FFFF
        (b"\xC2\x80", true),          // U+0080
        (b"\xC0\x80", false),         // overlong NUL
        (b"\xE0\x80\x80", false),     // overlong
        (b"\xF0\x80\x80\x80", false), // overlong
        (b"\xED\xA0\x80", false),     // U+D800 surrogate
        (b"\xF4\x90\x80\x80", false), // above U+10FFFF
        (b"\xE2\x82", false),         // truncated at the end
        (b"\x80", false),             // lone continuation byte
        (b"\xFF", false),
    ];
    let mut names = Vec::new();
    let mut inputs = Vec::new();
    for (k, (seq, valid)) in cases.iter().enumerate() {
        let text = format!("\"{}\"", "x".repeat(seq.len()));
        let mut b = penumbra_asset::AssetBuilder::new(penumbra_asset::Kind::SHTB);
        b.add_json("meta", "{}").unwrap().add_json("notes", &text).unwrap();
        let mut bytes = b.to_bytes().unwrap();
        let a = Asset::parse(&bytes).unwrap();
        let at = a.section("notes").unwrap().info().offset() as usize + 1;
        bytes[at..at + seq.len()].copy_from_slice(seq);
        reseal_checksums(&mut bytes);
        assert_eq!(Asset::parse(&bytes).is_ok(), *valid, "case {k}: the Rust loader");
        names.push(format!("utf-8 case {k} {seq:02x?}"));
        inputs.push(bytes);
    }
    compare(&driver, &names, &inputs);
}
