//! The validating loader: [`Asset::parse`] checks every byte of the container once, then hands
//! out [`Section`]s whose views borrow the caller's buffer.
//!
//! Every read goes through `get`/`first_chunk` and every computation on a file value is checked,
//! so no input can make the loader panic (see the proptests and the `fuzz/` target).

use crate::crc::crc32c;
use crate::error::{LoadError, SectionFault};
use crate::format::{
    FORMAT_MAJOR, HEADER_LEN, MAGIC, MAX_RANK, MAX_SECTIONS, META_SECTION, NAME_LEN, SECTION_ENTRY_LEN,
    SECTION_FLAG_CRITICAL, TABLE_OFFSET, align_up, entry, first_section_offset, header,
};
use crate::section::{Section, SectionInfo};
use crate::types::{DType, Kind, SectionName};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use core::fmt;

/// Reads a little-endian u16 at `at`; callers pass fixed-size header/entry arrays with constant
/// in-range offsets, so the fallback 0 is unreachable.
fn u16_at(b: &[u8], at: usize) -> u16 {
    b.get(at..).and_then(|s| s.first_chunk::<2>()).map_or(0, |c| u16::from_le_bytes(*c))
}

/// See [`u16_at`].
fn u32_at(b: &[u8], at: usize) -> u32 {
    b.get(at..).and_then(|s| s.first_chunk::<4>()).map_or(0, |c| u32::from_le_bytes(*c))
}

/// See [`u16_at`].
fn u64_at(b: &[u8], at: usize) -> u64 {
    b.get(at..).and_then(|s| s.first_chunk::<8>()).map_or(0, |c| u64::from_le_bytes(*c))
}

/// `bytes[start..end]` of a file whose length was already checked; empty if out of range.
fn range(bytes: &[u8], start: u64, end: u64) -> &[u8] {
    match (usize::try_from(start), usize::try_from(end)) {
        (Ok(s), Ok(e)) => bytes.get(s..e).unwrap_or(&[]),
        _ => &[],
    }
}

/// Everything the loader learned about a file, without borrowing it: an [`Asset`] pairs this
/// with the bytes; [`OwnedAsset`](crate::OwnedAsset) keeps both.
#[derive(Clone, Debug)]
pub(crate) struct Index {
    kind: Kind,
    major: u16,
    minor: u16,
    file_size: u64,
    sections: Vec<SectionInfo>,
    /// Section indices sorted by name, for binary search.
    by_name: Vec<usize>,
    /// Index of the `meta` section.
    meta: usize,
    /// Whether every section CRC was required to match (`parse`, not `parse_unverified`).
    verified: bool,
}

/// Validates `bytes` as a complete v1 asset. With `verify`, any section CRC mismatch is an
/// error; without, it is only recorded in [`SectionInfo::checksum_ok`].
pub(crate) fn index(bytes: &[u8], verify: bool) -> Result<Index, LoadError> {
    let len = bytes.len();
    let Some(h) = bytes.first_chunk::<HEADER_LEN>() else {
        let mut found = [0u8; 8];
        for (d, s) in found.iter_mut().zip(bytes) {
            *d = *s;
        }
        // A short buffer that does not even start like an asset is reported as not an asset.
        if !MAGIC.starts_with(bytes.get(..8.min(len)).unwrap_or(&[])) {
            return Err(LoadError::BadMagic { found });
        }
        return Err(LoadError::TooShort { len });
    };

    // 1. Identity: magic and version (bytes 0..12 are frozen across all majors).
    let magic = h.first_chunk::<8>().copied().unwrap_or([0; 8]);
    if magic != MAGIC {
        return Err(LoadError::BadMagic { found: magic });
    }
    let (major, minor) = (u16_at(h, header::MAJOR), u16_at(h, header::MINOR));
    if major != FORMAT_MAJOR {
        return Err(LoadError::unsupported(major, minor));
    }

    // 2. Header checksum, then the header fields it protects.
    let stored = u32_at(h, header::HEADER_CRC);
    let computed = crc32c(h.get(..header::HEADER_CRC).unwrap_or(&[]));
    if stored != computed {
        return Err(LoadError::HeaderChecksum { stored, computed });
    }
    let kind_bytes = h.get(header::KIND..).and_then(|s| s.first_chunk::<4>()).copied().unwrap_or([0; 4]);
    let kind = Kind::new(kind_bytes).ok_or(LoadError::BadKind { found: kind_bytes })?;
    let count = u32_at(h, header::SECTION_COUNT);
    if !(1..=MAX_SECTIONS).contains(&count) {
        return Err(LoadError::BadHeader { field: "section_count", value: count.into(), expected: "1..=4096" });
    }
    let flags = u32_at(h, header::FLAGS);
    if flags != 0 {
        return Err(LoadError::BadHeader { field: "flags", value: flags.into(), expected: "0 in format 1.x" });
    }
    let table_offset = u64_at(h, header::TABLE_OFFSET);
    if table_offset != TABLE_OFFSET {
        return Err(LoadError::BadHeader { field: "table_offset", value: table_offset, expected: "64" });
    }
    let reserved = h.get(header::RESERVED..header::RESERVED + header::RESERVED_LEN).unwrap_or(&[]);
    if let Some(&b) = reserved.iter().find(|&&b| b != 0) {
        return Err(LoadError::BadHeader { field: "reserved", value: b.into(), expected: "all 16 bytes zero" });
    }

    // 3. Size: the buffer is exactly the file.
    let file_size = u64_at(h, header::FILE_SIZE);
    let actual = len as u64;
    if actual < file_size {
        return Err(LoadError::Truncated { expected: file_size, actual });
    }
    if actual > file_size {
        return Err(LoadError::TrailingBytes { expected: file_size, actual });
    }
    let table_end = TABLE_OFFSET + SECTION_ENTRY_LEN as u64 * u64::from(count);
    let first = first_section_offset(count);
    if file_size < first {
        return Err(LoadError::BadHeader {
            field: "file_size",
            value: file_size,
            expected: "at least the 64-aligned end of the section table",
        });
    }

    // 4. Section table checksum.
    let table = range(bytes, TABLE_OFFSET, table_end);
    let stored = u32_at(h, header::TABLE_CRC);
    let computed = crc32c(table);
    if stored != computed {
        return Err(LoadError::TableChecksum { stored, computed });
    }

    // 5. Entries, in file order: fields, canonical offsets, bounds and zero padding.
    let mut sections = Vec::with_capacity(count as usize);
    let mut expected_offset = first;
    let mut prev_end = table_end;
    for (i, e) in table.chunks_exact(SECTION_ENTRY_LEN).enumerate() {
        let index = i as u32;
        let bad = |reason| LoadError::BadSection { index, reason };
        let info = entry_info(e, expected_offset, file_size).map_err(bad)?;
        let padding = range(bytes, prev_end, info.offset);
        if let Some(p) = padding.iter().position(|&b| b != 0) {
            return Err(LoadError::NonZeroPadding { offset: prev_end.saturating_add(p as u64) });
        }
        prev_end = info.offset.saturating_add(info.length); // cannot overflow: checked in entry_info
        expected_offset = align_up(prev_end).ok_or(bad(SectionFault::LengthOverflow))?;
        sections.push(info);
    }
    if file_size != prev_end {
        return Err(LoadError::BadHeader {
            field: "file_size",
            value: file_size,
            expected: "the end of the last section",
        });
    }

    // 6. Unique names (reported at the later entry of a duplicate pair) and the meta section.
    let mut by_name: Vec<usize> = (0..sections.len()).collect();
    by_name.sort_unstable_by_key(|&i| (sections.get(i).map(|s| s.name), i));
    for w in by_name.windows(2) {
        if let [a, b] = *w {
            if let (Some(sa), Some(sb)) = (sections.get(a), sections.get(b)) {
                if sa.name == sb.name {
                    return Err(LoadError::BadSection {
                        index: a.max(b) as u32,
                        reason: SectionFault::DuplicateName(sa.name),
                    });
                }
            }
        }
    }
    let meta = lookup(&sections, &by_name, META_SECTION).ok_or(LoadError::MissingMeta)?;
    let meta_dtype = sections.get(meta).map_or(DType::Json, |s| s.dtype);
    if meta_dtype != DType::Json {
        return Err(LoadError::MetaNotJson { found: meta_dtype });
    }

    // 7. Section checksums (file order), then the UTF-8 of intact JSON sections.
    for s in &mut sections {
        let data = range(bytes, s.offset, s.offset.saturating_add(s.length));
        let computed = crc32c(data);
        s.checksum_ok = computed == s.crc;
        if verify && !s.checksum_ok {
            return Err(LoadError::SectionChecksum { name: s.name, stored: s.crc, computed });
        }
    }
    for (i, s) in sections.iter().enumerate() {
        if s.dtype == DType::Json && s.checksum_ok {
            let data = range(bytes, s.offset, s.offset.saturating_add(s.length));
            if let Err(e) = core::str::from_utf8(data) {
                return Err(LoadError::BadSection {
                    index: i as u32,
                    reason: SectionFault::InvalidUtf8 { valid_up_to: e.valid_up_to() },
                });
            }
        }
    }

    Ok(Index { kind, major, minor, file_size, sections, by_name, meta, verified: verify })
}

/// Validates one 96-byte table entry whose data must start at `expected_offset` and end within
/// `file_size`. Returns the info with `checksum_ok = false` (filled in later).
fn entry_info(e: &[u8], expected_offset: u64, file_size: u64) -> Result<SectionInfo, SectionFault> {
    let field = e.first_chunk::<NAME_LEN>().copied().unwrap_or([0; NAME_LEN]);
    let name = SectionName::from_field(&field).map_err(SectionFault::BadName)?;
    let code = e.get(entry::DTYPE).copied().unwrap_or(0);
    let dtype = DType::from_code(code).ok_or(SectionFault::UnknownDType(code))?;
    let rank = e.get(entry::RANK).copied().unwrap_or(0);
    if rank == 0 || usize::from(rank) > MAX_RANK {
        return Err(SectionFault::BadRank(rank));
    }
    if dtype == DType::Json && rank != 1 {
        return Err(SectionFault::JsonRank(rank));
    }
    let flags = u16_at(e, entry::FLAGS);
    if flags & !SECTION_FLAG_CRITICAL != 0 {
        return Err(SectionFault::UnknownFlags(flags & !SECTION_FLAG_CRITICAL));
    }
    let reserved1 = e.get(entry::RESERVED1..entry::RESERVED1 + entry::RESERVED1_LEN).unwrap_or(&[]);
    if u32_at(e, entry::RESERVED0) != 0 || reserved1.iter().any(|&b| b != 0) {
        return Err(SectionFault::ReservedNotZero);
    }

    let mut dims = [0usize; MAX_RANK];
    let mut elements: u64 = 1;
    for (axis, d) in dims.iter_mut().enumerate() {
        let value = u32_at(e, entry::DIMS + 4 * axis);
        if axis >= usize::from(rank) {
            if value != 0 {
                return Err(SectionFault::DimBeyondRank { axis: axis as u8, value });
            }
        } else {
            *d = usize::try_from(value).map_err(|_| SectionFault::LengthOverflow)?;
            elements = elements.checked_mul(u64::from(value)).ok_or(SectionFault::LengthOverflow)?;
        }
    }
    let expected_len = elements.checked_mul(dtype.size() as u64).ok_or(SectionFault::LengthOverflow)?;
    let length = u64_at(e, entry::LENGTH);
    if length != expected_len {
        return Err(SectionFault::LengthMismatch { expected: expected_len, found: length });
    }
    let offset = u64_at(e, entry::OFFSET);
    if offset != expected_offset {
        return Err(SectionFault::OffsetNotCanonical { expected: expected_offset, found: offset });
    }
    let end = offset.checked_add(length);
    match end {
        Some(end) if end <= file_size => {}
        _ => return Err(SectionFault::OutOfBounds { end, file_size }),
    }
    // elements ≤ length ≤ file_size = buffer length, so it fits usize.
    let elements = usize::try_from(elements).map_err(|_| SectionFault::LengthOverflow)?;

    Ok(SectionInfo {
        name,
        dtype,
        rank,
        dims,
        elements,
        offset,
        length,
        crc: u32_at(e, entry::CRC),
        critical: flags & SECTION_FLAG_CRITICAL != 0,
        checksum_ok: false,
    })
}

fn lookup(sections: &[SectionInfo], by_name: &[usize], name: &str) -> Option<usize> {
    let key = name.as_bytes();
    let pos =
        by_name.binary_search_by(|&i| sections.get(i).map_or(&[][..], |s| s.name.as_str().as_bytes()).cmp(key)).ok()?;
    by_name.get(pos).copied()
}

/// A validated asset borrowing its bytes.
///
/// Obtained from [`Asset::parse`] (everything checked, including every section's CRC),
/// [`Asset::parse_unverified`] (everything but the section CRCs, which are recorded per
/// section), [`OwnedAsset::asset`](crate::OwnedAsset::asset) or `AssetFile::asset`.
/// Cheap to clone when it comes from an `OwnedAsset`/`AssetFile` (the index is borrowed).
#[derive(Clone)]
pub struct Asset<'a> {
    bytes: &'a [u8],
    index: Cow<'a, Index>,
}

impl fmt::Debug for Asset<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Asset")
            .field("kind", &self.kind())
            .field("version", &self.version())
            .field("file_size", &self.file_size())
            .field("sections", &self.sections())
            .finish()
    }
}

impl<'a> Asset<'a> {
    /// Validates `bytes` as a complete asset: header, checksums of header, table and every
    /// section, canonical layout, zero padding and reserved fields, names, element types,
    /// dims and lengths, the `meta` section and the UTF-8 of JSON sections. Never panics.
    ///
    /// The bytes may live at any address; typed zero-copy views additionally need the buffer to
    /// be aligned (use [`OwnedAsset`](crate::OwnedAsset) or `AssetFile` to get 64-byte alignment).
    pub fn parse(bytes: &'a [u8]) -> Result<Asset<'a>, LoadError> {
        Ok(Asset { bytes, index: Cow::Owned(index(bytes, true)?) })
    }

    /// Like [`parse`](Self::parse) but a section whose data does not match its CRC is not an
    /// error: [`SectionInfo::checksum_ok`] says which ones match. The header and the section
    /// table must still be intact (their CRCs are checked). JSON sections are checked for UTF-8
    /// only when their checksum matches. Meant for inspecting damaged files; use `parse` to
    /// consume assets.
    pub fn parse_unverified(bytes: &'a [u8]) -> Result<Asset<'a>, LoadError> {
        Ok(Asset { bytes, index: Cow::Owned(index(bytes, false)?) })
    }

    pub(crate) fn from_index(bytes: &'a [u8], index: &'a Index) -> Asset<'a> {
        Asset { bytes, index: Cow::Borrowed(index) }
    }

    /// Asset kind from the header.
    pub fn kind(&self) -> Kind {
        self.index.kind
    }

    /// Format version `(major, minor)` from the header. The major is always
    /// [`FORMAT_MAJOR`]; the minor may be newer than [`FORMAT_MINOR`](crate::FORMAT_MINOR).
    pub fn version(&self) -> (u16, u16) {
        (self.index.major, self.index.minor)
    }

    /// Total size of the file in bytes (equal to the buffer length).
    pub fn file_size(&self) -> u64 {
        self.index.file_size
    }

    /// The whole file.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// True when every section CRC was required to match ([`parse`](Self::parse)); false after
    /// [`parse_unverified`](Self::parse_unverified), whatever the checksums say.
    pub fn is_verified(&self) -> bool {
        self.index.verified
    }

    /// Whether every section's data matches its CRC.
    pub fn all_checksums_ok(&self) -> bool {
        self.index.sections.iter().all(|s| s.checksum_ok)
    }

    /// Every section-table entry, in file order.
    pub fn sections(&self) -> &[SectionInfo] {
        &self.index.sections
    }

    /// The section at `index` in file order.
    pub fn section_at(&self, index: usize) -> Option<Section<'a>> {
        let info = *self.index.sections.get(index)?;
        Some(Section { info, data: range(self.bytes, info.offset, info.offset.saturating_add(info.length)) })
    }

    /// The section called `name` (binary search over the names).
    pub fn section(&self, name: &str) -> Option<Section<'a>> {
        self.section_at(lookup(&self.index.sections, &self.index.by_name, name)?)
    }

    /// Every section, in file order.
    pub fn iter(&self) -> impl Iterator<Item = Section<'a>> + '_ {
        (0..self.index.sections.len()).filter_map(|i| self.section_at(i))
    }

    /// Text of the `meta` JSON section. For an asset from [`parse_unverified`](Self::parse_unverified)
    /// whose damaged `meta` is not UTF-8, the empty string (its [`SectionInfo::checksum_ok`] is false).
    pub fn meta_json(&self) -> &'a str {
        self.section_at(self.index.meta).and_then(|s| s.as_json().ok()).unwrap_or("")
    }

    /// Checks that the asset holds no critical section outside `known` (`meta` is always
    /// known). Unknown sections that are not critical are fine: a reader skips them (see
    /// [`unknown_sections`](Self::unknown_sections)).
    ///
    /// # Errors
    /// [`LoadError::UnknownCritical`] naming the first (in file order) unknown critical section.
    pub fn require_known(&self, known: &[&str]) -> Result<(), LoadError> {
        match self.unknown_sections(known).find(|s| s.critical) {
            Some(s) => Err(LoadError::UnknownCritical { name: s.name }),
            None => Ok(()),
        }
    }

    /// The sections whose names are not in `known` (nor `meta`), in file order: the ones a
    /// reader that knows `known` skips (or refuses, when critical).
    pub fn unknown_sections<'k>(&self, known: &'k [&'k str]) -> impl Iterator<Item = &SectionInfo> {
        self.index.sections.iter().filter(move |s| s.name.as_str() != META_SECTION && !known.contains(&s.name.as_str()))
    }
}
