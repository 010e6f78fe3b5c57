//! `schemas/asset-format.md` and the code agree: the worked example is exactly what the writer
//! produces, and the field tables give the offsets the code uses.

use penumbra_asset::format::{HEADER_LEN, SECTION_ENTRY_LEN, entry, header};
use penumbra_asset::{Asset, AssetBuilder, Kind, crc32c};

const SPEC: &str = include_str!("../../../schemas/asset-format.md");

/// The bytes of the hex dump that follows the `worked-example-hex` marker.
fn example_bytes() -> Vec<u8> {
    let start = SPEC.find("<!-- worked-example-hex").expect("marker in the spec");
    let block = &SPEC[start..];
    let block = &block[block.find("```text").unwrap() + 7..];
    let block = &block[..block.find("```").unwrap()];
    let mut out = Vec::new();
    for line in block.lines().filter(|l| !l.trim().is_empty()) {
        let (addr, hex) = line.split_once(':').expect("offset: bytes");
        assert_eq!(usize::from_str_radix(addr.trim(), 16).unwrap(), out.len(), "dump offsets are contiguous");
        out.extend(hex.split_whitespace().map(|h| u8::from_str_radix(h, 16).unwrap()));
    }
    out
}

#[test]
fn worked_example_matches_the_writer() {
    let mut b = AssetBuilder::new(Kind::SPHR);
    b.add_json("meta", r#"{"v":1}"#).unwrap().add_f32("radii", &[2], &[1.0, 0.5]).unwrap();
    let written = b.to_bytes().unwrap();
    let documented = example_bytes();
    assert_eq!(documented.len(), 328);
    assert_eq!(written, documented);
    let a = Asset::parse(&documented).unwrap();
    assert_eq!(a.section("radii").unwrap().to_f32_vec().unwrap(), [1.0, 0.5]);
    // The CRCs the annotation quotes.
    assert_eq!(crc32c(&documented[..60]), 0x74CC_D46A);
    assert_eq!(crc32c(&documented[64..256]), 0x33DB_24A8);
    assert_eq!(crc32c(br#"{"v":1}"#), 0xE8A3_BAFD);
    assert_eq!(crc32c(&documented[320..328]), 0x074B_A198);
}

#[test]
fn crc_test_vectors_of_the_spec() {
    assert!(SPEC.contains("`0xE3069283`"));
    assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    assert_eq!(crc32c(&[0; 32]), 0x8A91_36AA);
    assert_eq!(crc32c(&[0xFF; 32]), 0x62A8_AB43);
    assert_eq!(crc32c(&(0u8..32).collect::<Vec<_>>()), 0x46DD_794E);
}

/// Rows `| offset | size | type | `field` | rule |` of the table under `heading`.
fn table_rows(heading: &str) -> Vec<(usize, usize, String)> {
    let start = SPEC.find(heading).expect("heading in the spec");
    let rest = &SPEC[start..];
    let end = rest[1..].find("\n## ").map_or(rest.len(), |e| e + 1);
    rest[..end]
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            let offset = cells.get(1)?.parse().ok()?;
            let size = cells.get(2)?.parse().ok()?;
            Some((offset, size, cells.get(4)?.trim_matches('`').to_string()))
        })
        .collect()
}

#[test]
fn field_tables_match_the_code() {
    let rows = table_rows("## 2. Header");
    let expected = [
        (header::MAGIC, 8, "magic"),
        (header::MAJOR, 2, "format_major"),
        (header::MINOR, 2, "format_minor"),
        (header::KIND, 4, "kind"),
        (header::SECTION_COUNT, 4, "section_count"),
        (header::FLAGS, 4, "flags"),
        (header::TABLE_OFFSET, 8, "table_offset"),
        (header::FILE_SIZE, 8, "file_size"),
        (header::TABLE_CRC, 4, "table_crc"),
        (header::RESERVED, header::RESERVED_LEN, "reserved"),
        (header::HEADER_CRC, 4, "header_crc"),
    ];
    let expected: Vec<(usize, usize, String)> = expected.iter().map(|&(o, s, n)| (o, s, n.to_string())).collect();
    assert_eq!(rows, expected);
    assert_eq!(rows.iter().map(|r| r.1).sum::<usize>(), HEADER_LEN);

    let rows = table_rows("## 3. Section table");
    let expected = [
        (entry::NAME, 32, "name"),
        (entry::DTYPE, 1, "dtype"),
        (entry::RANK, 1, "rank"),
        (entry::FLAGS, 2, "flags"),
        (entry::RESERVED0, 4, "reserved0"),
        (entry::DIMS, 24, "dims"),
        (entry::OFFSET, 8, "offset"),
        (entry::LENGTH, 8, "length"),
        (entry::CRC, 4, "crc"),
        (entry::RESERVED1, entry::RESERVED1_LEN, "reserved1"),
    ];
    let expected: Vec<(usize, usize, String)> = expected.iter().map(|&(o, s, n)| (o, s, n.to_string())).collect();
    assert_eq!(rows, expected);
    assert_eq!(rows.iter().map(|r| r.1).sum::<usize>(), SECTION_ENTRY_LEN);
}
