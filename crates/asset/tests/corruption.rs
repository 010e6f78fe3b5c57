//! The loader refuses every damaged or non-canonical file with the precise error.

mod common;

use common::{
    META, entry_at, exercise, patched, sample_builder, sample_bytes, set_name, set_u16, set_u32, set_u64, with_version,
};
use penumbra_asset::format::{entry, first_section_offset, header};
use penumbra_asset::{Asset, AssetBuilder, DType, Kind, LoadError, NameError, SectionFault, ViewError};

/// What occupies each byte of a valid file.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Region {
    Magic,
    Major,
    Header,
    Table,
    Padding,
    Data(usize),
}

fn regions(bytes: &[u8]) -> Vec<Region> {
    let a = Asset::parse(bytes).unwrap();
    let table_end = 64 + 96 * a.sections().len();
    let mut r = vec![Region::Padding; bytes.len()];
    r[..8].fill(Region::Magic);
    r[8..10].fill(Region::Major);
    r[10..64].fill(Region::Header);
    r[64..table_end].fill(Region::Table);
    for (i, s) in a.sections().iter().enumerate() {
        let (o, l) = (s.offset() as usize, s.byte_len() as usize);
        r[o..o + l].fill(Region::Data(i));
    }
    r
}

#[test]
fn every_truncated_prefix_is_rejected() {
    let bytes = sample_bytes();
    for len in 0..bytes.len() {
        match Asset::parse(&bytes[..len]) {
            Err(LoadError::TooShort { len: l }) => assert!(len < 64 && l == len),
            Err(LoadError::Truncated { expected, actual }) => {
                assert!(len >= 64);
                assert_eq!((expected, actual), (bytes.len() as u64, len as u64));
            }
            other => panic!("prefix of {len} bytes: expected a truncation error, got {other:?}"),
        }
        assert!(Asset::parse_unverified(&bytes[..len]).is_err());
    }
    assert!(Asset::parse(&bytes).is_ok());
    let e = Asset::parse(&bytes[..100]).unwrap_err();
    assert!(e.to_string().contains("truncated"), "{e}");
}

#[test]
fn every_single_byte_flip_is_rejected_with_the_right_error() {
    let bytes = sample_bytes();
    let regions = regions(&bytes);
    let names: Vec<String> = Asset::parse(&bytes).unwrap().sections().iter().map(|s| s.name().to_string()).collect();
    let mut seen_padding = 0;
    for (pos, &region) in regions.iter().enumerate() {
        for mask in [0x01u8, 0x80] {
            let mut b = bytes.clone();
            b[pos] ^= mask;
            let err = Asset::parse(&b).expect_err("a flipped byte must be rejected");
            let ok = match region {
                Region::Magic => matches!(err, LoadError::BadMagic { .. }),
                Region::Major => matches!(err, LoadError::UnsupportedVersion { .. }),
                Region::Header => matches!(err, LoadError::HeaderChecksum { .. }),
                Region::Table => matches!(err, LoadError::TableChecksum { .. }),
                Region::Padding => err == LoadError::NonZeroPadding { offset: pos as u64 },
                Region::Data(i) => {
                    matches!(&err, LoadError::SectionChecksum { name, .. } if *name == names[i].as_str())
                }
            };
            assert!(ok, "byte {pos} ({region:?}) ^ {mask:#04x}: unexpected {err:?}");
            if let Region::Data(i) = region {
                // parse_unverified accepts it and flags exactly that section.
                let a = Asset::parse_unverified(&b).unwrap();
                let bad: Vec<&str> = a.sections().iter().filter(|s| !s.checksum_ok()).map(|s| s.name()).collect();
                assert_eq!(bad, [names[i].as_str()]);
                assert!(!a.all_checksums_ok() && !a.is_verified());
                exercise(&a);
            }
        }
        seen_padding += usize::from(region == Region::Padding);
    }
    assert!(seen_padding > 100, "the sample must contain padding");
}

#[test]
fn damaged_meta_still_inspectable_unverified() {
    let bytes = sample_bytes();
    let a = Asset::parse(&bytes).unwrap();
    let meta = a.section("meta").unwrap().info().offset() as usize;
    let mut b = bytes.clone();
    b[meta] = 0xFF; // not UTF-8 any more
    assert!(matches!(Asset::parse(&b), Err(LoadError::SectionChecksum { .. })));
    let a = Asset::parse_unverified(&b).unwrap();
    assert_eq!(a.meta_json(), "");
    assert!(matches!(a.section("meta").unwrap().as_json(), Err(ViewError::InvalidUtf8 { valid_up_to: 0, .. })));
    // A damaged meta that is still UTF-8 shows its text.
    let mut b = bytes.clone();
    b[meta + 1] = b'X';
    let a = Asset::parse_unverified(&b).unwrap();
    assert!(a.meta_json().starts_with("{X"));
}

#[test]
fn major_version_bump_is_rejected_naming_both_versions() {
    let bytes = with_version(&sample_bytes(), 2, 0);
    let err = Asset::parse(&bytes).unwrap_err();
    assert_eq!(
        err,
        LoadError::UnsupportedVersion { found_major: 2, found_minor: 0, supported_major: 1, supported_minor: 0 }
    );
    let msg = err.to_string();
    assert!(msg.contains("2.0") && msg.contains("1.0"), "{msg}");
    assert_eq!(msg, "asset format version 2.0 is not supported (this loader reads 1.x, up to 1.0)");
    assert!(Asset::parse_unverified(&bytes).is_err());
    assert!(matches!(Asset::parse(&with_version(&sample_bytes(), 0, 9)), Err(LoadError::UnsupportedVersion { .. })));
}

#[test]
fn minor_version_bump_is_accepted() {
    for minor in [1u16, 7, u16::MAX] {
        let bytes = with_version(&sample_bytes(), 1, minor);
        let a = Asset::parse(&bytes).unwrap();
        assert_eq!(a.version(), (1, minor));
        assert_eq!(a.meta_json(), META);
    }
}

#[test]
fn unknown_sections_skipped_unless_critical() {
    let mut b = sample_builder();
    b.add_f32("future_optional", &[1], &[1.0]).unwrap();
    let bytes = b.to_bytes().unwrap();
    let a = Asset::parse(&bytes).unwrap();
    let known = ["values", "index", "half", "empty", "signed", "double", "big", "tail"];
    assert_eq!(a.require_known(&known), Ok(()));
    let skipped: Vec<&str> = a.unknown_sections(&known).map(|s| s.name()).collect();
    assert_eq!(skipped, ["future_optional"]);

    b.add_u8("future_critical", &[0], &[]).unwrap();
    b.set_critical("future_critical", true).unwrap();
    let bytes = b.to_bytes().unwrap();
    let a = Asset::parse(&bytes).unwrap();
    let err = a.require_known(&known).unwrap_err();
    assert!(matches!(&err, LoadError::UnknownCritical { name } if *name == "future_critical"), "{err:?}");
    assert!(err.to_string().contains("future_critical"), "{err}");
    let mut known2 = known.to_vec();
    known2.push("future_critical");
    assert_eq!(a.require_known(&known2), Ok(()));
    // meta is always known.
    assert_eq!(a.unknown_sections(&known2).count(), 1);
}

#[test]
fn trailing_garbage_is_rejected() {
    let bytes = sample_bytes();
    for extra in [1usize, 64, 1000] {
        let mut b = bytes.clone();
        b.extend(std::iter::repeat_n(0u8, extra));
        assert_eq!(
            Asset::parse(&b).unwrap_err(),
            LoadError::TrailingBytes { expected: bytes.len() as u64, actual: (bytes.len() + extra) as u64 }
        );
        assert!(Asset::parse_unverified(&b).is_err());
    }
}

#[test]
fn short_or_foreign_buffers() {
    assert_eq!(Asset::parse(&[]).unwrap_err(), LoadError::TooShort { len: 0 });
    assert_eq!(Asset::parse(b"PENUM").unwrap_err(), LoadError::TooShort { len: 5 });
    assert!(matches!(Asset::parse(b"GIF89a"), Err(LoadError::BadMagic { .. })));
    let mut png = vec![0x89, b'P', b'N', b'G'];
    png.resize(200, 0);
    let e = Asset::parse(&png).unwrap_err();
    assert!(matches!(e, LoadError::BadMagic { .. }));
    assert!(e.to_string().contains("\\x89PNG"), "{e}");
}

/// Expects `BadSection { index, reason }` after `f` patched the file and the checksums were
/// recomputed.
fn expect_section_fault(f: impl FnOnce(&mut Vec<u8>), index: u32, reason: SectionFault) {
    let b = patched(&sample_bytes(), f);
    let err = Asset::parse(&b).unwrap_err();
    assert_eq!(err, LoadError::BadSection { index, reason }, "{err}");
    assert_eq!(Asset::parse_unverified(&b).unwrap_err(), err);
    assert!(err.to_string().starts_with(&format!("section table entry {index}: ")));
}

#[test]
fn malformed_entries_are_rejected_precisely() {
    let e1 = entry_at(1); // "values", f32 [3, 5]
    expect_section_fault(|b| b[e1 + entry::DTYPE] = 0, 1, SectionFault::UnknownDType(0));
    expect_section_fault(|b| b[e1 + entry::DTYPE] = 9, 1, SectionFault::UnknownDType(9));
    expect_section_fault(|b| b[e1 + entry::RANK] = 0, 1, SectionFault::BadRank(0));
    expect_section_fault(|b| b[e1 + entry::RANK] = 7, 1, SectionFault::BadRank(7));
    expect_section_fault(|b| b[entry_at(0) + entry::RANK] = 2, 0, SectionFault::JsonRank(2));
    expect_section_fault(|b| set_u32(b, e1 + entry::DIMS + 8, 1), 1, SectionFault::DimBeyondRank { axis: 2, value: 1 });
    expect_section_fault(|b| set_u16(b, e1 + entry::FLAGS, 0x0002), 1, SectionFault::UnknownFlags(2));
    expect_section_fault(|b| set_u16(b, e1 + entry::FLAGS, 0x8001), 1, SectionFault::UnknownFlags(0x8000));
    expect_section_fault(|b| b[e1 + entry::RESERVED0 + 3] = 1, 1, SectionFault::ReservedNotZero);
    expect_section_fault(|b| b[e1 + entry::RESERVED1 + 11] = 1, 1, SectionFault::ReservedNotZero);
    expect_section_fault(
        |b| set_u64(b, e1 + entry::LENGTH, 64),
        1,
        SectionFault::LengthMismatch { expected: 60, found: 64 },
    );
    expect_section_fault(
        |b| set_u32(b, e1 + entry::DIMS, 4),
        1,
        SectionFault::LengthMismatch { expected: 80, found: 60 },
    );
    expect_section_fault(
        |b| {
            for axis in 0..6 {
                set_u32(b, e1 + entry::DIMS + 4 * axis, u32::MAX);
            }
            b[e1 + entry::RANK] = 6;
        },
        1,
        SectionFault::LengthOverflow,
    );
    let first = first_section_offset(9);
    expect_section_fault(
        |b| set_u64(b, entry_at(0) + entry::OFFSET, first + 64),
        0,
        SectionFault::OffsetNotCanonical { expected: first, found: first + 64 },
    );
    expect_section_fault(
        |b| set_u64(b, entry_at(0) + entry::OFFSET, first - 64),
        0,
        SectionFault::OffsetNotCanonical { expected: first, found: first - 64 },
    );
    expect_section_fault(|b| set_name(b, 1, b""), 1, SectionFault::BadName(NameError::Empty));
    expect_section_fault(
        |b| set_name(b, 1, b"val ues"),
        1,
        SectionFault::BadName(NameError::BadByte { byte: b' ', position: 3 }),
    );
    expect_section_fault(
        |b| b[e1 + entry::NAME + 20] = b'x',
        1,
        SectionFault::BadName(NameError::JunkAfterNul { position: 20 }),
    );
    let dup = penumbra_asset::SectionName::new("index").unwrap();
    expect_section_fault(|b| set_name(b, 1, b"index"), 2, SectionFault::DuplicateName(dup));
}

#[test]
fn section_past_the_end_is_rejected() {
    // Grow the last section's dims so its data would run past the file.
    let bytes = sample_bytes();
    let last = Asset::parse(&bytes).unwrap().sections().len() - 1;
    let b = patched(&bytes, |b| {
        set_u32(b, entry_at(last) + entry::DIMS, 500);
        set_u64(b, entry_at(last) + entry::LENGTH, 500);
    });
    let err = Asset::parse(&b).unwrap_err();
    assert!(
        matches!(err, LoadError::BadSection { reason: SectionFault::OutOfBounds { end: Some(_), .. }, .. }),
        "{err:?}"
    );
}

#[test]
fn malformed_header_fields_are_rejected() {
    let bytes = sample_bytes();
    let field = |f: fn(&mut Vec<u8>)| Asset::parse(&patched(&bytes, f)).unwrap_err();
    assert_eq!(field(|b| b[header::KIND] = b's'), LoadError::BadKind { found: *b"sHTB" });
    assert!(matches!(
        field(|b| set_u32(b, header::SECTION_COUNT, 0)),
        LoadError::BadHeader { field: "section_count", value: 0, .. }
    ));
    assert!(matches!(
        field(|b| set_u32(b, header::SECTION_COUNT, 4097)),
        LoadError::BadHeader { field: "section_count", value: 4097, .. }
    ));
    assert!(matches!(field(|b| set_u32(b, header::FLAGS, 1)), LoadError::BadHeader { field: "flags", .. }));
    assert!(matches!(
        field(|b| set_u64(b, header::TABLE_OFFSET, 128)),
        LoadError::BadHeader { field: "table_offset", value: 128, .. }
    ));
    assert!(matches!(
        field(|b| b[header::RESERVED + 15] = 7),
        LoadError::BadHeader { field: "reserved", value: 7, .. }
    ));
    // One more section declared than the table holds: the canonical data offsets move, so the
    // first entry is no longer canonical.
    assert_eq!(
        field(|b| set_u32(b, header::SECTION_COUNT, 10)),
        LoadError::BadSection {
            index: 0,
            reason: SectionFault::OffsetNotCanonical {
                expected: first_section_offset(10),
                found: first_section_offset(9)
            }
        }
    );
    // The declared size grows with matching trailing zeros: the file no longer ends at the last section.
    let err = field(|b| {
        let n = b.len() as u64;
        set_u64(b, header::FILE_SIZE, n + 64);
        b.extend([0u8; 64]);
    });
    assert!(matches!(err, LoadError::BadHeader { field: "file_size", .. }), "{err:?}");
    // A size smaller than the table.
    let err = field(|b| {
        set_u64(b, header::FILE_SIZE, 100);
        b.truncate(100);
    });
    assert!(matches!(err, LoadError::BadHeader { field: "file_size", value: 100, .. }), "{err:?}");
}

#[test]
fn meta_rules() {
    // No section called meta.
    let b = patched(&sample_bytes(), |b| set_name(b, 0, b"mexa"));
    assert_eq!(Asset::parse(&b).unwrap_err(), LoadError::MissingMeta);

    // meta exists but is not JSON: swap the names of a JSON section and a u8 section.
    let mut builder = AssetBuilder::new(Kind::SHTB);
    builder.add_json("meta", "{}").unwrap().add_u8("mets", &[2], &[1, 2]).unwrap();
    let b = patched(&builder.to_bytes().unwrap(), |b| {
        set_name(b, 0, b"metz");
        set_name(b, 1, b"meta");
    });
    assert_eq!(Asset::parse(&b).unwrap_err(), LoadError::MetaNotJson { found: DType::U8 });

    // A JSON section whose (checksum-valid) bytes are not UTF-8.
    let mut builder = AssetBuilder::new(Kind::SHTB);
    builder.add_json("meta", "{}").unwrap().add_json("notes", "abcd").unwrap();
    let good = builder.to_bytes().unwrap();
    let notes = Asset::parse(&good).unwrap().section("notes").unwrap().info().offset() as usize;
    let b = patched(&good, |b| b[notes + 2] = 0xC3);
    let err = Asset::parse(&b).unwrap_err();
    assert_eq!(err, LoadError::BadSection { index: 1, reason: SectionFault::InvalidUtf8 { valid_up_to: 2 } });
    assert_eq!(Asset::parse_unverified(&b).unwrap_err(), err);
}

#[test]
fn every_error_has_a_message() {
    let bytes = sample_bytes();
    let mut b = bytes.clone();
    let last = b.len() - 1;
    b[last] ^= 1;
    for e in [
        Asset::parse(&b).unwrap_err(),
        Asset::parse(&bytes[..70]).unwrap_err(),
        Asset::parse(&with_version(&bytes, 3, 1)).unwrap_err(),
        LoadError::MissingMeta,
    ] {
        let msg = e.to_string();
        assert!(!msg.is_empty() && !msg.contains("{"), "{msg}");
        let _: &dyn std::error::Error = &e;
    }
}
