//! Constants and byte layout of container format v1.
//!
//! Everything here mirrors `schemas/asset-format.md`; the two must change together. All
//! multi-byte integers in the file are little-endian. Offsets are in bytes.

/// The 8 magic bytes at offset 0 of every asset.
pub const MAGIC: [u8; 8] = *b"PENUMBRA";

/// Format major version written by this crate. A loader refuses any other major version:
/// a major bump means an incompatible layout.
pub const FORMAT_MAJOR: u16 = 1;

/// Format minor version written by this crate. A loader accepts any minor version of its
/// major version: a minor bump may only add new sections, which older readers skip (or refuse
/// by name, when the writer marked them critical).
pub const FORMAT_MINOR: u16 = 0;

/// Length of the fixed header, in bytes.
pub const HEADER_LEN: usize = 64;

/// Length of one section-table entry, in bytes.
pub const SECTION_ENTRY_LEN: usize = 96;

/// Offset of the section table in a v1 file (it follows the header directly).
pub const TABLE_OFFSET: u64 = 64;

/// Alignment of every section's data, in bytes, relative to the start of the file. 64 bytes
/// is a cache line and the widest SIMD register, and covers every element type's alignment,
/// so a file loaded at a 64-byte aligned address gives aligned zero-copy views.
pub const ALIGN: usize = 64;

/// Largest number of sections an asset may hold.
pub const MAX_SECTIONS: u32 = 4096;

/// Largest rank (number of dimensions) of a section.
pub const MAX_RANK: usize = 6;

/// Length of the NUL-padded name field of a section-table entry, in bytes. A name uses at
/// most this many bytes (no terminating NUL is needed when it uses all 32).
pub const NAME_LEN: usize = 32;

/// Name of the JSON section every asset must contain: tool version, asset-kind version,
/// normalised bake parameters, input content hashes and quality metrics.
pub const META_SECTION: &str = "meta";

/// Section flag bit 0: a reader that does not know this section must refuse the asset
/// (see [`Asset::require_known`](crate::Asset::require_known)). All other bits are zero in v1.
pub const SECTION_FLAG_CRITICAL: u16 = 0x0001;

/// Byte offsets of the header fields (relative to the start of the file).
pub mod header {
    /// `PENUMBRA`, 8 bytes.
    pub const MAGIC: usize = 0;
    /// Format major version, u16.
    pub const MAJOR: usize = 8;
    /// Format minor version, u16.
    pub const MINOR: usize = 10;
    /// Asset kind, 4 ASCII bytes from `[A-Z0-9]`.
    pub const KIND: usize = 12;
    /// Number of sections, u32 in `1..=4096`.
    pub const SECTION_COUNT: usize = 16;
    /// Header flags, u32, zero in v1.
    pub const FLAGS: usize = 20;
    /// Offset of the section table, u64, 64 in v1.
    pub const TABLE_OFFSET: usize = 24;
    /// Total file size in bytes, u64.
    pub const FILE_SIZE: usize = 32;
    /// CRC-32C of the section-table bytes, u32.
    pub const TABLE_CRC: usize = 40;
    /// 16 reserved bytes, zero.
    pub const RESERVED: usize = 44;
    /// Length of the reserved field.
    pub const RESERVED_LEN: usize = 16;
    /// CRC-32C of header bytes `0..60`, u32.
    pub const HEADER_CRC: usize = 60;
}

/// Byte offsets of the fields of one section-table entry (relative to the entry's start).
pub mod entry {
    /// Name, 32 bytes ASCII from `[A-Za-z0-9_.-]`, NUL-padded.
    pub const NAME: usize = 0;
    /// Element type code, u8 (see [`DType`](crate::DType)).
    pub const DTYPE: usize = 32;
    /// Rank, u8 in `1..=6`.
    pub const RANK: usize = 33;
    /// Section flags, u16 (bit 0 = critical).
    pub const FLAGS: usize = 34;
    /// Reserved u32, zero.
    pub const RESERVED0: usize = 36;
    /// Six u32 dimensions, outermost first; those beyond the rank are zero.
    pub const DIMS: usize = 40;
    /// Byte offset of the section data from the start of the file, u64.
    pub const OFFSET: usize = 64;
    /// Byte length of the section data, u64.
    pub const LENGTH: usize = 72;
    /// CRC-32C of the section data, u32.
    pub const CRC: usize = 80;
    /// 12 reserved bytes, zero.
    pub const RESERVED1: usize = 84;
    /// Length of the trailing reserved field.
    pub const RESERVED1_LEN: usize = 12;
}

/// Rounds `x` up to the next multiple of [`ALIGN`]; `None` on overflow.
pub const fn align_up(x: u64) -> Option<u64> {
    match x.checked_add(ALIGN as u64 - 1) {
        Some(v) => Some(v & !(ALIGN as u64 - 1)),
        None => None,
    }
}

/// Offset of the first section's data in a file with `count` sections:
/// `align_up(64 + 96 * count)`.
pub const fn first_section_offset(count: u32) -> u64 {
    // 64 + 96 * u32::MAX fits comfortably in u64, and so does its rounding.
    let end = TABLE_OFFSET + SECTION_ENTRY_LEN as u64 * count as u64;
    (end + ALIGN as u64 - 1) & !(ALIGN as u64 - 1)
}

/// Recomputes every checksum of a v1 file in place: each section CRC whose entry and data lie
/// inside `bytes`, then the table CRC, then the header CRC. Best-effort on malformed input and
/// never panics.
///
/// A tool for tests, fuzzing and corpus crafting: it turns a deliberately damaged file into one
/// whose damage only the structural checks can catch. Writers never need it.
pub fn reseal_checksums(bytes: &mut [u8]) {
    let read = |b: &[u8], at: usize| -> u64 {
        b.get(at..).and_then(|s| s.first_chunk::<8>()).map_or(0, |c| u64::from_le_bytes(*c))
    };
    let write = |b: &mut [u8], at: usize, v: u32| {
        if let Some(d) = b.get_mut(at..at.saturating_add(4)) {
            d.copy_from_slice(&v.to_le_bytes());
        }
    };
    if bytes.len() < HEADER_LEN {
        return;
    }
    let count =
        bytes.get(header::SECTION_COUNT..).and_then(|s| s.first_chunk::<4>()).map_or(0, |c| u32::from_le_bytes(*c))
            as usize;
    let table_start = TABLE_OFFSET as usize;
    let entries = count.min(bytes.len().saturating_sub(table_start) / SECTION_ENTRY_LEN);
    for i in 0..entries {
        let e = table_start + i * SECTION_ENTRY_LEN;
        let (off, len) = (read(bytes, e + entry::OFFSET), read(bytes, e + entry::LENGTH));
        let data = usize::try_from(off)
            .ok()
            .zip(usize::try_from(off.saturating_add(len)).ok())
            .and_then(|(a, b)| bytes.get(a..b));
        if let Some(data) = data {
            let crc = crate::crc32c(data);
            write(bytes, e + entry::CRC, crc);
        }
    }
    let table_end = table_start.saturating_add(count.saturating_mul(SECTION_ENTRY_LEN)).min(bytes.len());
    let table_crc = crate::crc32c(bytes.get(table_start..table_end).unwrap_or(&[]));
    write(bytes, header::TABLE_CRC, table_crc);
    let header_crc = crate::crc32c(bytes.get(..header::HEADER_CRC).unwrap_or(&[]));
    write(bytes, header::HEADER_CRC, header_crc);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_helpers() {
        assert_eq!(align_up(0), Some(0));
        assert_eq!(align_up(1), Some(64));
        assert_eq!(align_up(64), Some(64));
        assert_eq!(align_up(65), Some(128));
        assert_eq!(align_up(u64::MAX), None);
        assert_eq!(align_up(u64::MAX - 63), Some(u64::MAX - 63));
        assert_eq!(first_section_offset(1), 192);
        assert_eq!(first_section_offset(2), 256);
        assert_eq!(first_section_offset(3), 384);
    }

    #[test]
    fn field_offsets_tile_the_header_and_entry() {
        assert_eq!(header::RESERVED + header::RESERVED_LEN, header::HEADER_CRC);
        assert_eq!(header::HEADER_CRC + 4, HEADER_LEN);
        assert_eq!(entry::DIMS + 4 * MAX_RANK, entry::OFFSET);
        assert_eq!(entry::RESERVED1 + entry::RESERVED1_LEN, SECTION_ENTRY_LEN);
    }
}
