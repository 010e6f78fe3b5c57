//! Fuzz target `loader`: the bytes of a would-be asset go through every entry point of the
//! loader and every accessor; nothing may panic, and the loader's invariants must hold.
//!
//! Each input runs twice: as given, and with all its checksums recomputed
//! (`reseal_checksums`), so that mutations reach the structural checks behind the CRCs.
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra_asset::format::reseal_checksums;
use penumbra_asset::{Asset, AssetBuilder, DType, OwnedAsset, Section};

fuzz_target!(|data: &[u8]| {
    check(data);
    if data.len() >= 64 {
        let mut resealed = data.to_vec();
        reseal_checksums(&mut resealed);
        check(&resealed);
    }
});

fn check(bytes: &[u8]) {
    let verified = Asset::parse(bytes);
    match &verified {
        Ok(a) => {
            exercise(a);
            assert!(a.is_verified() && a.all_checksums_ok());
            assert_eq!(a.file_size(), bytes.len() as u64);
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
    match Asset::parse_unverified(bytes) {
        Ok(a) => {
            exercise(&a);
            // Only section checksums separate the two entry points.
            assert_eq!(verified.is_ok(), a.all_checksums_ok());
        }
        Err(e) => assert!(
            verified.is_err(),
            "parse_unverified refused a valid asset: {e}"
        ),
    }
    if let Ok(owned) = OwnedAsset::parse(bytes) {
        let a = owned.asset();
        exercise(&a);
        // In aligned memory the view of the declared type always works (little-endian).
        for s in a.iter() {
            let ok = match s.dtype() {
                DType::U8 => s.as_u8().is_ok(),
                DType::U16 => s.as_u16().is_ok(),
                DType::U32 => s.as_u32().is_ok(),
                DType::I32 => s.as_i32().is_ok(),
                DType::F16 => s.as_f16_bits().is_ok(),
                DType::F32 => s.as_f32().is_ok(),
                DType::F64 => s.as_f64().is_ok(),
                DType::Json => s.as_json().is_ok(),
            };
            assert!(
                ok || cfg!(target_endian = "big"),
                "view of {} failed",
                s.name()
            );
        }
        // The layout is canonical: re-encoding the sections reproduces the file exactly.
        if a.version() == (1, 0) {
            let mut b = AssetBuilder::new(a.kind());
            for s in a.iter() {
                b.add_raw(s.name(), s.dtype(), s.dims(), s.bytes())
                    .expect("valid section re-adds");
                b.set_critical(s.name(), s.info().is_critical())
                    .expect("just added");
            }
            assert_eq!(
                b.to_bytes().expect("valid asset re-encodes"),
                bytes,
                "layout not canonical"
            );
        }
    }
}

fn exercise(a: &Asset<'_>) {
    let _ = (
        a.kind().as_str().len(),
        a.version(),
        a.file_size(),
        a.bytes().len(),
        a.meta_json().len(),
    );
    let _ = format!("{a:?}");
    let _ = a.require_known(&[]).map_err(|e| e.to_string());
    let _ = a.require_known(&["meta", "s1", "f32"]);
    let _ = a.unknown_sections(&["f32"]).count();
    for (i, info) in a.sections().iter().enumerate() {
        let _ = (
            info.name(),
            info.dtype(),
            info.rank(),
            info.dims(),
            info.element_count(),
        );
        let _ = (
            info.offset(),
            info.byte_len(),
            info.crc(),
            info.is_critical(),
            info.checksum_ok(),
        );
        assert_eq!(a.section(info.name()).map(|s| *s.info()), Some(*info));
        if let Some(s) = a.section_at(i) {
            exercise_section(&s);
        }
    }
    assert!(a.section_at(a.sections().len()).is_none());
    let _ = a.section("");
}

fn exercise_section(s: &Section<'_>) {
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
    let _ = s.to_vec::<i32>().map_err(|e| e.to_string());
}
