//! Writer → loader round trips, typed views, conversions and builder errors.

mod common;

use common::{META, exercise, sample_bytes};
use penumbra_asset::{
    AlignedBuf, Asset, AssetBuilder, BuildError, DType, FORMAT_MAJOR, FORMAT_MINOR, Kind, NameError, OwnedAsset,
    ViewError, f16_bits_to_f32, f32_to_f16_bits,
};

#[test]
fn every_dtype_round_trips_with_dims() {
    let u8s: Vec<u8> = (0..=255).collect();
    let u16s = [0u16, 1, 0x1234, u16::MAX, 7, 8];
    let u32s = [0u32, 1, 0xDEAD_BEEF, u32::MAX];
    let i32s = [i32::MIN, -1, 0, 1, i32::MAX, 42];
    let f32s = [0.0f32, -0.0, 1.5, -2.25, f32::MAX, f32::MIN_POSITIVE, f32::INFINITY, 1.0e-40];
    let f64s = [0.0f64, -1.0, core::f64::consts::E, f64::MAX, f64::MIN_POSITIVE, 5e-324];
    let halves = [0.0f32, 1.0, -0.5, 65504.0, 0.1, 1.0e-6, 70000.0, f32::NEG_INFINITY];
    let json = r#"{"name":"ünïcode ✓","list":[1,2,3]}"#;

    let mut b = AssetBuilder::new(Kind::MRTD);
    b.add_json("meta", META)
        .unwrap()
        .add_u8("u8", &[16, 16], &u8s)
        .unwrap()
        .add_u16("u16", &[2, 3], &u16s)
        .unwrap()
        .add_u32("u32", &[4], &u32s)
        .unwrap()
        .add_i32("i32", &[1, 2, 3], &i32s)
        .unwrap()
        .add_f32("f32", &[2, 2, 2], &f32s)
        .unwrap()
        .add_f64("f64", &[1, 1, 1, 1, 2, 3], &f64s)
        .unwrap()
        .add_f16("f16", &[8], &halves)
        .unwrap()
        .add_json("notes", json)
        .unwrap();
    let bytes = b.to_bytes().unwrap();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let a = owned.asset();

    assert_eq!(a.kind(), Kind::MRTD);
    assert_eq!(a.version(), (FORMAT_MAJOR, FORMAT_MINOR));
    assert_eq!(a.file_size(), bytes.len() as u64);
    assert!(a.is_verified() && a.all_checksums_ok());
    assert_eq!(a.meta_json(), META);
    let names: Vec<&str> = a.sections().iter().map(|s| s.name()).collect();
    assert_eq!(names, ["meta", "u8", "u16", "u32", "i32", "f32", "f64", "f16", "notes"]);
    for s in a.sections() {
        assert_eq!(s.offset() % 64, 0, "{}", s.name());
        assert!(s.checksum_ok());
        assert!(!s.is_critical());
        assert_eq!(s.byte_len(), (s.element_count() * s.dtype().size()) as u64);
    }

    let s = a.section("u8").unwrap();
    assert_eq!((s.dtype(), s.dims(), s.info().rank()), (DType::U8, &[16usize, 16][..], 2));
    assert_eq!(s.as_u8().unwrap(), &u8s[..]);
    assert_eq!(a.section("u16").unwrap().as_u16().unwrap(), &u16s);
    assert_eq!(a.section("u16").unwrap().dims(), &[2, 3]);
    assert_eq!(a.section("u32").unwrap().as_u32().unwrap(), &u32s);
    assert_eq!(a.section("i32").unwrap().as_i32().unwrap(), &i32s);
    assert_eq!(a.section("i32").unwrap().dims(), &[1, 2, 3]);
    let f = a.section("f32").unwrap().as_f32().unwrap();
    assert_eq!(f.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), f32s.map(f32::to_bits));
    let d = a.section("f64").unwrap();
    assert_eq!(d.dims(), &[1, 1, 1, 1, 2, 3]);
    assert_eq!(d.info().rank(), 6);
    assert_eq!(d.as_f64().unwrap().iter().map(|v| v.to_bits()).collect::<Vec<_>>(), f64s.map(f64::to_bits));

    let h = a.section("f16").unwrap();
    assert_eq!(h.dtype(), DType::F16);
    let bits = h.as_f16_bits().unwrap();
    assert_eq!(bits, halves.map(f32_to_f16_bits));
    let widened = h.to_f32_vec().unwrap();
    assert_eq!(widened, bits.iter().map(|&b| f16_bits_to_f32(b)).collect::<Vec<_>>());
    assert_eq!(widened[1], 1.0);
    assert_eq!(widened[6], f32::INFINITY, "70000 overflows f16");
    assert!((widened[4] - 0.1).abs() < 1e-4);

    let n = a.section("notes").unwrap();
    assert_eq!(n.as_json().unwrap(), json);
    assert_eq!(n.dims(), &[json.len()]);

    // Owned conversions agree with the views.
    assert_eq!(a.section("u16").unwrap().to_vec::<u16>().unwrap(), u16s);
    assert_eq!(a.section("i32").unwrap().to_f64_vec().unwrap(), i32s.map(f64::from));
    assert_eq!(a.section("u8").unwrap().to_f64_vec().unwrap()[255], 255.0);
    assert_eq!(a.section("u32").unwrap().to_f64_vec().unwrap()[3], f64::from(u32::MAX));
    assert_eq!(a.section("f64").unwrap().to_f32_vec().unwrap()[2], core::f64::consts::E as f32);
    assert_eq!(a.section("f32").unwrap().to_f64_vec().unwrap()[2], 1.5);
    exercise(&a);
}

#[test]
fn empty_arrays_round_trip() {
    let mut b = AssetBuilder::new(Kind::SPHR);
    b.add_json("meta", "").unwrap();
    b.add_f32("none", &[0], &[]).unwrap();
    b.add_f64("rows", &[0, 3], &[]).unwrap();
    b.add_u16("cols", &[5, 0, 2], &[]).unwrap();
    b.add_f16("h", &[2, 0], &[]).unwrap();
    b.add_u8("last", &[0], &[]).unwrap();
    let bytes = b.to_bytes().unwrap();
    // 6 entries: table ends at 64 + 576 = 640, and every section is empty, so the file ends there.
    assert_eq!(bytes.len(), 640);
    let a = Asset::parse(&bytes).unwrap();
    assert_eq!(a.meta_json(), "");
    assert_eq!(a.section("rows").unwrap().dims(), &[0, 3]);
    assert_eq!(a.section("cols").unwrap().dims(), &[5, 0, 2]);
    assert_eq!(a.section("cols").unwrap().as_u16().unwrap(), &[] as &[u16]);
    assert!(a.section("none").unwrap().as_f32().unwrap().is_empty());
    assert!(a.section("rows").unwrap().to_f64_vec().unwrap().is_empty());
    assert!(a.section("h").unwrap().to_f32_vec().unwrap().is_empty());
    for s in a.sections() {
        assert_eq!((s.byte_len(), s.element_count(), s.offset()), (0, 0, 640));
    }
    exercise(&a);
}

#[test]
fn output_is_deterministic() {
    assert_eq!(sample_bytes(), sample_bytes());
}

#[test]
fn zero_copy_views_on_aligned_memory_and_misalignment_reported() {
    let bytes = sample_bytes();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    assert_eq!(owned.bytes().as_ptr().addr() % 64, 0);
    let v = owned.asset().section("values").unwrap().as_f32().unwrap();
    assert_eq!(v.len(), 15);
    assert_eq!(v[3], 3.0 * 0.5 - 3.0);
    // The view points into the owned buffer: zero copy.
    let base = owned.bytes().as_ptr().addr();
    let info = *owned.asset().section("values").unwrap().info();
    assert_eq!(v.as_ptr().addr(), base + info.offset() as usize);
    // Views outlive the Asset value they came from (they borrow the buffer).
    let d = { owned.asset().section("double").unwrap().as_f64().unwrap() };
    assert_eq!(d[0], core::f64::consts::PI);

    // Deliberately misaligned: the same bytes one byte past an aligned address.
    let mut buf = AlignedBuf::try_zeroed(bytes.len() + 1).unwrap();
    buf.as_mut_slice()[1..].copy_from_slice(&bytes);
    let shifted = &buf.as_slice()[1..];
    let a = Asset::parse(shifted).expect("parsing works at any address");
    let s = a.section("values").unwrap();
    match s.as_f32() {
        Err(ViewError::Misaligned { name, align, address }) => {
            assert_eq!(name, "values");
            assert_eq!(align, 4);
            assert_eq!(address % 4, 1);
        }
        other => panic!("expected a misalignment error, got {other:?}"),
    }
    let msg = s.as_f32().unwrap_err().to_string();
    assert!(msg.contains("values") && msg.contains("aligned"), "{msg}");
    assert!(matches!(a.section("double").unwrap().as_f64(), Err(ViewError::Misaligned { align: 8, .. })));
    // Byte views and owned conversions still work.
    assert_eq!(a.section("tail").unwrap().as_u8().unwrap(), &[1, 2, 3, 4, 5]);
    assert_eq!(s.to_f32_vec().unwrap(), v);
    assert_eq!(s.to_vec::<f32>().unwrap(), v);
    // Empty sections view fine at any address.
    assert!(a.section("empty").unwrap().as_u8().unwrap().is_empty());
}

#[test]
fn wrong_type_views_are_errors() {
    let bytes = sample_bytes();
    let owned = OwnedAsset::parse(&bytes).unwrap();
    let a = owned.asset();
    let s = a.section("values").unwrap();
    let e = s.as_u32().unwrap_err();
    assert!(matches!(e, ViewError::WrongType { found: DType::F32, wanted: "u32", .. }), "{e:?}");
    assert!(e.to_string().contains("\"values\" has element type f32, expected u32"), "{e}");
    assert!(s.as_json().is_err());
    assert!(s.as_f16_bits().is_err());
    assert!(a.section("index").unwrap().as_f16_bits().is_err(), "u16 is not f16");
    assert!(a.section("half").unwrap().as_u16().is_err(), "f16 is not u16");
    assert!(a.section("index").unwrap().to_f32_vec().is_err(), "to_f32_vec only for floats");
    assert!(a.section("meta").unwrap().to_f64_vec().is_err());
    assert!(a.section("meta").unwrap().to_vec::<u8>().is_err());
}

#[test]
fn critical_flag_round_trips() {
    let mut b = AssetBuilder::new(Kind::DRTO);
    b.add_json("meta", "{}").unwrap().add_u8("x", &[1], &[9]).unwrap();
    b.set_critical("x", true).unwrap();
    let bytes = b.to_bytes().unwrap();
    let a = Asset::parse(&bytes).unwrap();
    assert!(a.section("x").unwrap().info().is_critical());
    assert!(!a.section("meta").unwrap().info().is_critical());
    b.set_critical("x", false).unwrap();
    assert!(!Asset::parse(&b.to_bytes().unwrap()).unwrap().section("x").unwrap().info().is_critical());
    assert!(matches!(b.set_critical("y", true), Err(BuildError::UnknownSection { .. })));
}

#[test]
fn add_raw_copies_sections_between_assets() {
    let bytes = sample_bytes();
    let a = Asset::parse(&bytes).unwrap();
    let mut b = AssetBuilder::new(a.kind());
    for s in a.iter() {
        b.add_raw(s.name(), s.dtype(), s.dims(), s.bytes()).unwrap();
    }
    assert_eq!(b.to_bytes().unwrap(), bytes);

    let mut b = AssetBuilder::new(Kind::SHTB);
    assert!(matches!(
        b.add_raw("x", DType::F32, &[2], &[0; 7]),
        Err(BuildError::RawLengthMismatch { expected_bytes: 8, found_bytes: 7, .. })
    ));
    assert!(matches!(b.add_raw("j", DType::Json, &[2], &[0xFF, 0xFE]), Err(BuildError::JsonNotUtf8 { .. })));
    assert!(matches!(b.add_raw("j", DType::Json, &[1, 2], b"{}"), Err(BuildError::JsonRank { rank: 2, .. })));
    assert!(b.add_raw("j", DType::Json, &[2], b"{}").is_ok());
}

#[test]
fn builder_rejects_bad_sections() {
    let mut b = AssetBuilder::new(Kind::FIVT);
    let name_err = |r: Result<&mut AssetBuilder, BuildError>| match r {
        Err(BuildError::InvalidName { reason, .. }) => reason,
        other => panic!("expected InvalidName, got {:?}", other.map(|_| ())),
    };
    assert_eq!(name_err(b.add_u8("", &[0], &[])), NameError::Empty);
    assert_eq!(name_err(b.add_u8(&"n".repeat(33), &[0], &[])), NameError::TooLong { len: 33 });
    assert_eq!(name_err(b.add_u8("a/b", &[0], &[])), NameError::BadByte { byte: b'/', position: 1 });
    assert_eq!(name_err(b.add_u8("nul\0", &[0], &[])), NameError::BadByte { byte: 0, position: 3 });
    assert!(b.add_u8(&"n".repeat(32), &[0], &[]).is_ok(), "32 bytes is the limit");

    b.add_f32("x", &[2], &[1.0, 2.0]).unwrap();
    assert!(matches!(b.add_f32("x", &[2], &[1.0, 2.0]), Err(BuildError::DuplicateName { .. })));
    assert!(matches!(b.add_json("x", "{}"), Err(BuildError::DuplicateName { .. })));
    assert!(matches!(b.add_f32("r0", &[], &[]), Err(BuildError::BadRank { rank: 0, .. })));
    assert!(matches!(b.add_f32("r7", &[1; 7], &[1.0]), Err(BuildError::BadRank { rank: 7, .. })));
    let e = b.add_f32("shape", &[2, 3], &[1.0; 5]).unwrap_err();
    assert!(matches!(e, BuildError::ShapeMismatch { expected_elements: 6, found_elements: 5, .. }));
    assert!(e.to_string().contains("6 elements but 5"), "{e}");
    assert!(matches!(b.add_f16("shape", &[4], &[1.0; 5]), Err(BuildError::ShapeMismatch { .. })));
    #[cfg(target_pointer_width = "64")]
    {
        let big = u32::MAX as usize + 1;
        assert!(matches!(b.add_u8("big", &[1, big], &[]), Err(BuildError::DimTooLarge { axis: 1, .. })));
        let m = u32::MAX as usize;
        assert!(matches!(b.add_u8("ovf", &[m, m, m], &[]), Err(BuildError::ShapeOverflow { .. })));
    }
    assert!(matches!(b.add_f32("meta", &[1], &[0.0]), Err(BuildError::MetaNotJson { found: DType::F32 })));
    // None of the failed calls added anything.
    assert_eq!(b.section_count(), 2);
    assert_eq!(b.to_bytes(), Err(BuildError::MissingMeta));
    b.add_json("meta", "{}").unwrap();
    assert!(b.to_bytes().is_ok());
    assert_eq!(b.encoded_len().unwrap(), b.to_bytes().unwrap().len() as u64);
}

#[test]
fn at_most_4096_sections() {
    let mut b = AssetBuilder::new(Kind::MRTL);
    b.add_json("meta", "{}").unwrap();
    for i in 1..4096 {
        b.add_u8(&format!("s{i}"), &[0], &[]).unwrap();
    }
    assert_eq!(b.add_u8("one_too_many", &[0], &[]).unwrap_err(), BuildError::TooManySections);
    let bytes = b.to_bytes().unwrap();
    let a = Asset::parse(&bytes).unwrap();
    assert_eq!(a.sections().len(), 4096);
    assert_eq!(a.section("s4095").unwrap().info().offset(), bytes.len() as u64);
}

#[test]
fn unknown_kinds_are_exposed() {
    let kind = Kind::new(*b"ZZ99").unwrap();
    let mut b = AssetBuilder::new(kind);
    b.add_json("meta", "{}").unwrap();
    let bytes = b.to_bytes().unwrap();
    let a = Asset::parse(&bytes).unwrap();
    assert_eq!(a.kind(), kind);
    assert_eq!(a.kind().as_str(), "ZZ99");
    assert!(!a.kind().is_known());
}
