//! Atomic writes and `AssetFile`.

mod common;

use common::{META, sample_builder, sample_bytes};
use penumbra_asset::{AssetBuilder, AssetFile, Kind, LoadError, OpenError, WriteError, write_file_atomic};
use std::fs;
use std::path::Path;

/// Every entry of `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn write_atomic_writes_and_replaces_without_leftovers() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tables.shtb");
    let n = sample_builder().write_atomic(&path).unwrap();
    assert_eq!(n, fs::metadata(&path).unwrap().len());
    assert_eq!(fs::read(&path).unwrap(), sample_bytes());
    assert_eq!(listing(dir.path()), ["tables.shtb"]);

    // Replace it with a different asset.
    let mut b = AssetBuilder::new(Kind::SHTB);
    b.add_json("meta", r#"{"second":true}"#).unwrap();
    let n2 = b.write_atomic(&path).unwrap();
    assert_ne!(n, n2);
    let f = AssetFile::open(&path).unwrap();
    assert_eq!(f.asset().meta_json(), r#"{"second":true}"#);
    assert_eq!(f.path(), path);
    assert_eq!(listing(dir.path()), ["tables.shtb"]);
}

#[test]
fn write_file_atomic_writes_raw_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub");
    fs::create_dir(&path).unwrap();
    write_file_atomic(path.join("x.bin"), b"hello").unwrap();
    assert_eq!(fs::read(path.join("x.bin")).unwrap(), b"hello");
    assert_eq!(listing(&path), ["x.bin"]);
}

#[test]
fn failed_write_names_the_path_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();

    // Target directory does not exist.
    let missing = dir.path().join("no_such_dir").join("a.shtb");
    let err = sample_builder().write_atomic(&missing).unwrap_err();
    assert!(matches!(err, WriteError::Io { .. }), "{err:?}");
    assert_eq!(err.path(), missing);
    assert!(err.to_string().contains(&missing.display().to_string()), "{err}");
    assert!(std::error::Error::source(&err).is_some());
    assert!(listing(dir.path()).is_empty());

    // Target path is a (non-empty) directory: the rename fails, the directory is untouched.
    let target = dir.path().join("taken");
    fs::create_dir(&target).unwrap();
    fs::write(target.join("keep.txt"), b"keep").unwrap();
    let err = sample_builder().write_atomic(&target).unwrap_err();
    assert_eq!(err.path(), target);
    assert!(err.to_string().contains("taken"), "{err}");
    assert_eq!(listing(dir.path()), ["taken"], "no temporary file left behind");
    assert_eq!(fs::read(target.join("keep.txt")).unwrap(), b"keep");

    // An asset that cannot be encoded: nothing is created, an existing file is untouched.
    let existing = dir.path().join("existing.shtb");
    fs::write(&existing, b"old").unwrap();
    let err = AssetBuilder::new(Kind::SHTB).write_atomic(&existing).unwrap_err();
    assert!(matches!(err, WriteError::Build { .. }), "{err:?}");
    assert!(err.to_string().contains("existing.shtb") && err.to_string().contains("meta"), "{err}");
    assert_eq!(fs::read(&existing).unwrap(), b"old");
    assert_eq!(listing(dir.path()), ["existing.shtb", "taken"]);

    // A path without a file name.
    let err = write_file_atomic(dir.path().join(".."), b"x").unwrap_err();
    assert!(err.to_string().contains(".."), "{err}");
}

#[test]
fn asset_file_gives_aligned_zero_copy_views() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.shtb");
    sample_builder().write_atomic(&path).unwrap();
    let f = AssetFile::open(&path).unwrap();
    assert_eq!(f.bytes().as_ptr().addr() % 64, 0);
    let a = f.asset();
    assert_eq!(a.meta_json(), META);
    let values = a.section("values").unwrap().as_f32().unwrap();
    assert_eq!(values.as_ptr().addr() % 64, 0);
    assert_eq!(values.len(), 15);
    assert_eq!(a.section("double").unwrap().as_f64().unwrap()[0], core::f64::consts::PI);
    assert_eq!(a.section("signed").unwrap().as_i32().unwrap(), &[-1, 2, i32::MIN, i32::MAX]);
    assert_eq!(a.section("big").unwrap().as_u32().unwrap(), &[0, u32::MAX]);
    assert_eq!(a.section("index").unwrap().as_u16().unwrap()[11], u16::MAX);
    assert_eq!(a.section("half").unwrap().to_f32_vec().unwrap()[1], -1.5);
    let owned = f.clone().into_owned();
    assert_eq!(owned.bytes(), f.bytes());
}

#[test]
fn open_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.shtb");
    let err = AssetFile::open(&missing).unwrap_err();
    assert!(matches!(err, OpenError::Io { .. }));
    assert_eq!(err.path(), missing);
    assert!(err.to_string().contains("missing.shtb"), "{err}");
    assert!(err.load_error().is_none());

    let bad = dir.path().join("bad.shtb");
    let mut bytes = sample_bytes();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x40;
    fs::write(&bad, &bytes).unwrap();
    let err = AssetFile::open(&bad).unwrap_err();
    assert!(matches!(err.load_error(), Some(LoadError::SectionChecksum { name, .. }) if *name == "tail"), "{err:?}");
    assert!(err.to_string().contains("bad.shtb") && err.to_string().contains("\"tail\""), "{err}");
    // Inspecting the damaged file still works.
    let f = AssetFile::open_unverified(&bad).unwrap();
    let a = f.asset();
    assert!(!a.section("tail").unwrap().info().checksum_ok());
    assert!(a.section("values").unwrap().info().checksum_ok());

    let err = AssetFile::open(dir.path()).unwrap_err();
    assert!(matches!(err, OpenError::Io { .. }), "a directory is not an asset: {err:?}");

    let empty = dir.path().join("empty.shtb");
    fs::write(&empty, b"").unwrap();
    assert_eq!(AssetFile::open(&empty).unwrap_err().load_error(), Some(&LoadError::TooShort { len: 0 }));
}
