//! Helpers shared by the integration tests.
#![allow(dead_code)]

use penumbra_asset::format::{SECTION_ENTRY_LEN, TABLE_OFFSET, entry, header, reseal_checksums};
use penumbra_asset::{Asset, AssetBuilder, Kind, Section};

pub const META: &str = r#"{"tool":"penumbra-asset tests","kind_version":1,"params":{"order":3}}"#;

/// A multi-section asset using every element type, an empty array and uneven lengths (so
/// there is padding between sections).
pub fn sample_builder() -> AssetBuilder {
    let mut b = AssetBuilder::new(Kind::SHTB);
    b.add_json("meta", META).unwrap();
    let values: Vec<f32> = (0..15).map(|i| i as f32 * 0.5 - 3.0).collect();
    b.add_f32("values", &[3, 5], &values).unwrap();
    b.add_u16("index", &[4, 3], &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, u16::MAX]).unwrap();
    b.add_f16("half", &[7], &[0.0, -1.5, 65504.0, 1.0e-7, 3.0, f32::INFINITY, 0.1]).unwrap();
    b.add_u8("empty", &[0, 4], &[]).unwrap();
    b.add_i32("signed", &[2, 2], &[-1, 2, i32::MIN, i32::MAX]).unwrap();
    b.add_f64("double", &[3], &[core::f64::consts::PI, -0.0, 1.0e300]).unwrap();
    b.add_u32("big", &[2, 1, 1], &[0, u32::MAX]).unwrap();
    b.add_u8("tail", &[5], &[1, 2, 3, 4, 5]).unwrap();
    b
}

pub fn sample_bytes() -> Vec<u8> {
    sample_builder().to_bytes().unwrap()
}

/// Byte offset of section-table entry `i`.
pub fn entry_at(i: usize) -> usize {
    TABLE_OFFSET as usize + i * SECTION_ENTRY_LEN
}

pub fn set_u16(b: &mut [u8], at: usize, v: u16) {
    b[at..at + 2].copy_from_slice(&v.to_le_bytes());
}

pub fn set_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

pub fn set_u64(b: &mut [u8], at: usize, v: u64) {
    b[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

pub fn set_name(b: &mut [u8], i: usize, name: &[u8]) {
    let e = entry_at(i) + entry::NAME;
    b[e..e + 32].fill(0);
    b[e..e + name.len()].copy_from_slice(name);
}

/// Applies `f` to a copy of `bytes`, then recomputes all checksums so that only the structural
/// checks can catch the change.
pub fn patched(bytes: &[u8], f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = bytes.to_vec();
    f(&mut b);
    reseal_checksums(&mut b);
    b
}

/// Bumps the header's version fields and fixes the header CRC only.
pub fn with_version(bytes: &[u8], major: u16, minor: u16) -> Vec<u8> {
    patched(bytes, |b| {
        set_u16(b, header::MAJOR, major);
        set_u16(b, header::MINOR, minor);
    })
}

/// Calls every accessor and conversion of an asset (and formats everything), to check that
/// none of them panics whatever the asset holds.
pub fn exercise(asset: &Asset<'_>) {
    let _ = (asset.kind(), asset.kind().as_str(), asset.version(), asset.file_size(), asset.bytes().len());
    let _ = (asset.is_verified(), asset.all_checksums_ok(), asset.meta_json().len());
    let _ = format!("{asset:?}");
    let _ = asset.require_known(&[]);
    let _ = asset.require_known(&["meta", "values"]);
    let _ = asset.unknown_sections(&["values"]).count();
    for (i, info) in asset.sections().iter().enumerate() {
        let _ = (info.name(), info.dtype(), info.rank(), info.dims(), info.element_count());
        let _ = (info.offset(), info.byte_len(), info.crc(), info.is_critical(), info.checksum_ok());
        let by_name = asset.section(info.name()).expect("every listed section can be found");
        assert_eq!(by_name.info(), info);
        exercise_section(&asset.section_at(i).expect("section_at"));
    }
    assert!(asset.section_at(asset.sections().len()).is_none());
    assert!(asset.section("no such section").is_none());
    assert_eq!(asset.iter().count(), asset.sections().len());
}

pub fn exercise_section(s: &Section<'_>) {
    let _ = format!("{s:?}");
    let _ = (s.name(), s.dtype(), s.dims(), s.bytes().len());
    let _ = s.as_u8().map_err(|e| e.to_string());
    let _ = s.as_u16().map_err(|e| e.to_string());
    let _ = s.as_u32().map_err(|e| e.to_string());
    let _ = s.as_i32().map_err(|e| e.to_string());
    let _ = s.as_f32().map_err(|e| e.to_string());
    let _ = s.as_f64().map_err(|e| e.to_string());
    let _ = s.as_f16_bits().map_err(|e| e.to_string());
    let _ = s.as_json().map_err(|e| e.to_string());
    let _ = s.to_f32_vec().map_err(|e| e.to_string());
    let _ = s.to_f64_vec().map_err(|e| e.to_string());
    let _ = s.to_vec::<u16>().map_err(|e| e.to_string());
    let _ = s.to_vec::<f64>().map_err(|e| e.to_string());
}
