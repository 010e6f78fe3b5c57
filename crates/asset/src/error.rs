//! Error types of the writer ([`BuildError`]), the loader ([`LoadError`], [`SectionFault`]) and
//! the typed views ([`ViewError`]). File errors (`WriteError`, `OpenError`) live in `file.rs`.
//!
//! All of them implement `core::error::Error` and have messages meant for people: they say
//! what is wrong and, where useful, what was expected.

use crate::format::{FORMAT_MAJOR, FORMAT_MINOR, MAX_RANK, MAX_SECTIONS};
use crate::types::{DType, NameError, SectionName};
use alloc::string::String;
use core::fmt;

/// Why [`AssetBuilder`](crate::AssetBuilder) refused a section or could not encode the asset.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BuildError {
    /// The section name is not 1–32 bytes of `[A-Za-z0-9_.-]`.
    InvalidName {
        /// The name as given.
        name: String,
        /// What is wrong with it.
        reason: NameError,
    },
    /// A section of this name was already added.
    DuplicateName {
        /// The repeated name.
        name: SectionName,
    },
    /// The rank (number of dims) is 0 or above 6.
    BadRank {
        /// The section.
        name: SectionName,
        /// The number of dims given.
        rank: usize,
    },
    /// A dimension does not fit the file's u32 field.
    DimTooLarge {
        /// The section.
        name: SectionName,
        /// Axis index (0 = outermost).
        axis: usize,
        /// The dimension given.
        dim: usize,
    },
    /// The product of the dims overflows `usize`.
    ShapeOverflow {
        /// The section.
        name: SectionName,
    },
    /// The data does not hold product(dims) elements.
    ShapeMismatch {
        /// The section.
        name: SectionName,
        /// product(dims).
        expected_elements: usize,
        /// Number of elements given.
        found_elements: usize,
    },
    /// Raw bytes given to [`add_raw`](crate::AssetBuilder::add_raw) are not product(dims) × element size long.
    RawLengthMismatch {
        /// The section.
        name: SectionName,
        /// product(dims) × element size.
        expected_bytes: usize,
        /// Bytes given.
        found_bytes: usize,
    },
    /// A JSON section given as raw bytes is not UTF-8.
    JsonNotUtf8 {
        /// The section.
        name: SectionName,
    },
    /// A JSON section must have rank 1.
    JsonRank {
        /// The section.
        name: SectionName,
        /// The rank given.
        rank: usize,
    },
    /// The `meta` section must be JSON.
    MetaNotJson {
        /// The element type offered for `meta`.
        found: DType,
    },
    /// More than 4096 sections.
    TooManySections,
    /// [`to_bytes`](crate::AssetBuilder::to_bytes) was called without a `meta` section.
    MissingMeta,
    /// [`set_critical`](crate::AssetBuilder::set_critical) named a section that was not added.
    UnknownSection {
        /// The name given.
        name: String,
    },
    /// The encoded asset would not fit in memory (`usize`) or in the u64 size fields.
    TooLarge,
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::InvalidName { name, reason } => {
                write!(f, "invalid section name {name:?}: {reason}")
            }
            BuildError::DuplicateName { name } => write!(f, "section {name:?} was added twice"),
            BuildError::BadRank { name, rank } => {
                write!(f, "section {name:?} has rank {rank} (must be 1..={MAX_RANK})")
            }
            BuildError::DimTooLarge { name, axis, dim } => {
                write!(f, "section {name:?}: dimension {axis} is {dim}, above the format's limit {}", u32::MAX)
            }
            BuildError::ShapeOverflow { name } => {
                write!(f, "section {name:?}: the product of its dims overflows")
            }
            BuildError::ShapeMismatch { name, expected_elements, found_elements } => {
                write!(f, "section {name:?}: dims hold {expected_elements} elements but {found_elements} were given")
            }
            BuildError::RawLengthMismatch { name, expected_bytes, found_bytes } => write!(
                f,
                "section {name:?}: dims and element type need {expected_bytes} bytes but {found_bytes} were given"
            ),
            BuildError::JsonNotUtf8 { name } => {
                write!(f, "JSON section {name:?} is not valid UTF-8")
            }
            BuildError::JsonRank { name, rank } => {
                write!(f, "JSON section {name:?} has rank {rank} (JSON sections have rank 1)")
            }
            BuildError::MetaNotJson { found } => {
                write!(f, "section \"meta\" must be JSON, not {found}")
            }
            BuildError::TooManySections => {
                write!(f, "an asset holds at most {MAX_SECTIONS} sections")
            }
            BuildError::MissingMeta => f.write_str("every asset needs a JSON section named \"meta\""),
            BuildError::UnknownSection { name } => write!(f, "no section named {name:?} was added"),
            BuildError::TooLarge => f.write_str("the asset is too large to encode"),
        }
    }
}

impl core::error::Error for BuildError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            BuildError::InvalidName { reason, .. } => Some(reason),
            _ => None,
        }
    }
}

/// What is wrong with one section-table entry (inside [`LoadError::BadSection`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum SectionFault {
    /// The name field is invalid.
    BadName(NameError),
    /// Another entry has the same name.
    DuplicateName(SectionName),
    /// The element-type code is not one of 1..=8.
    UnknownDType(u8),
    /// The rank is 0 or above 6.
    BadRank(u8),
    /// A JSON section whose rank is not 1.
    JsonRank(u8),
    /// A dimension beyond the rank is not zero.
    DimBeyondRank {
        /// Axis index (rank..6).
        axis: u8,
        /// The non-zero value found.
        value: u32,
    },
    /// Flag bits other than bit 0 (critical) are set.
    UnknownFlags(u16),
    /// A reserved field of the entry is not zero.
    ReservedNotZero,
    /// product(dims) × element size overflows u64.
    LengthOverflow,
    /// The byte length is not product(dims) × element size.
    LengthMismatch {
        /// product(dims) × element size.
        expected: u64,
        /// The stored byte length.
        found: u64,
    },
    /// The byte offset is not the canonical one (64-aligned end of the previous section, or
    /// of the section table for the first section).
    OffsetNotCanonical {
        /// The canonical offset.
        expected: u64,
        /// The stored offset.
        found: u64,
    },
    /// The data extends past the end of the file.
    OutOfBounds {
        /// Offset + length (`None` if it overflows u64).
        end: Option<u64>,
        /// The file size.
        file_size: u64,
    },
    /// A JSON section that is not valid UTF-8.
    InvalidUtf8 {
        /// Length of the valid UTF-8 prefix.
        valid_up_to: usize,
    },
}

impl fmt::Display for SectionFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SectionFault::BadName(e) => write!(f, "{e}"),
            SectionFault::DuplicateName(n) => write!(f, "duplicate section name {n:?}"),
            SectionFault::UnknownDType(c) => {
                write!(f, "unknown element type code {c} (known: 1..=8)")
            }
            SectionFault::BadRank(r) => write!(f, "rank {r} (must be 1..={MAX_RANK})"),
            SectionFault::JsonRank(r) => write!(f, "JSON section with rank {r} (must be 1)"),
            SectionFault::DimBeyondRank { axis, value } => {
                write!(f, "dimension {axis} is {value} but lies beyond the rank (must be 0)")
            }
            SectionFault::UnknownFlags(bits) => {
                write!(f, "unknown flag bits {bits:#06x} (v1 defines only bit 0)")
            }
            SectionFault::ReservedNotZero => f.write_str("reserved bytes are not zero"),
            SectionFault::LengthOverflow => f.write_str("product of dims times element size overflows"),
            SectionFault::LengthMismatch { expected, found } => {
                write!(f, "byte length is {found}, but dims × element size = {expected}")
            }
            SectionFault::OffsetNotCanonical { expected, found } => {
                write!(f, "data offset is {found}, the canonical layout puts it at {expected}")
            }
            SectionFault::OutOfBounds { end: Some(end), file_size } => {
                write!(f, "data ends at byte {end}, past the end of the {file_size}-byte file")
            }
            SectionFault::OutOfBounds { end: None, file_size } => {
                write!(f, "data offset + length overflows (file is {file_size} bytes)")
            }
            SectionFault::InvalidUtf8 { valid_up_to } => {
                write!(f, "JSON text is not valid UTF-8 (valid up to byte {valid_up_to})")
            }
        }
    }
}

impl core::error::Error for SectionFault {}

/// Why the loader refused an asset. Checks run in the order of the variants below (see
/// `schemas/asset-format.md`, "Validation rules").
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum LoadError {
    /// Shorter than the 64-byte header.
    TooShort {
        /// Length of the buffer.
        len: usize,
    },
    /// The first 8 bytes are not `PENUMBRA`.
    BadMagic {
        /// The first 8 bytes (fewer are zero-filled).
        found: [u8; 8],
    },
    /// Another major version (the header's layout may differ: nothing else is read).
    UnsupportedVersion {
        /// Major version in the file.
        found_major: u16,
        /// Minor version in the file.
        found_minor: u16,
        /// The major version this loader reads.
        supported_major: u16,
        /// The newest minor version this loader knows (newer minors are read too).
        supported_minor: u16,
    },
    /// The header CRC (bytes 60..64) does not match bytes 0..60.
    HeaderChecksum {
        /// Stored CRC.
        stored: u32,
        /// CRC of the bytes.
        computed: u32,
    },
    /// The asset kind is not 4 bytes of `[A-Z0-9]`.
    BadKind {
        /// The 4 kind bytes.
        found: [u8; 4],
    },
    /// A header field has a value v1 does not allow.
    BadHeader {
        /// Field name as in the spec, e.g. `"section_count"`.
        field: &'static str,
        /// The value found.
        value: u64,
        /// What v1 requires.
        expected: &'static str,
    },
    /// The buffer is shorter than the file size in the header.
    Truncated {
        /// File size from the header.
        expected: u64,
        /// Length of the buffer.
        actual: u64,
    },
    /// The buffer is longer than the file size in the header.
    TrailingBytes {
        /// File size from the header.
        expected: u64,
        /// Length of the buffer.
        actual: u64,
    },
    /// The section-table CRC in the header does not match the table.
    TableChecksum {
        /// Stored CRC.
        stored: u32,
        /// CRC of the table bytes.
        computed: u32,
    },
    /// A section-table entry is malformed.
    BadSection {
        /// Index of the entry in the table.
        index: u32,
        /// What is wrong.
        reason: SectionFault,
    },
    /// A padding byte (between the table and the first section, or between sections) is not zero.
    NonZeroPadding {
        /// File offset of the first non-zero padding byte.
        offset: u64,
    },
    /// A section's data does not match its CRC.
    SectionChecksum {
        /// The damaged section.
        name: SectionName,
        /// CRC stored in the table.
        stored: u32,
        /// CRC of the data.
        computed: u32,
    },
    /// There is no section named `meta`.
    MissingMeta,
    /// The `meta` section is not JSON.
    MetaNotJson {
        /// Its element type.
        found: DType,
    },
    /// From [`Asset::require_known`](crate::Asset::require_known): a section marked critical
    /// that the caller does not know.
    UnknownCritical {
        /// The section.
        name: SectionName,
    },
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadError::TooShort { len } => {
                write!(f, "not a penumbra asset: {len} bytes is shorter than the 64-byte header")
            }
            LoadError::BadMagic { found } => {
                write!(f, "not a penumbra asset: the file starts with {} instead of \"PENUMBRA\"", Escaped(found))
            }
            LoadError::UnsupportedVersion { found_major, found_minor, supported_major, supported_minor } => write!(
                f,
                "asset format version {found_major}.{found_minor} is not supported \
                 (this loader reads {supported_major}.x, up to {supported_major}.{supported_minor})"
            ),
            LoadError::HeaderChecksum { stored, computed } => write!(
                f,
                "header checksum mismatch (stored {stored:#010x}, computed {computed:#010x}): the file is damaged"
            ),
            LoadError::BadKind { found } => {
                write!(f, "asset kind {} is not 4 characters of A-Z 0-9", Escaped(found))
            }
            LoadError::BadHeader { field, value, expected } => {
                write!(f, "invalid header: {field} is {value}, expected {expected}")
            }
            LoadError::Truncated { expected, actual } => {
                write!(f, "asset is truncated: the header says {expected} bytes but only {actual} are present")
            }
            LoadError::TrailingBytes { expected, actual } => write!(
                f,
                "asset has {} trailing bytes: the header says {expected} bytes but {actual} are present",
                actual.saturating_sub(*expected)
            ),
            LoadError::TableChecksum { stored, computed } => write!(
                f,
                "section table checksum mismatch (stored {stored:#010x}, computed {computed:#010x}): the file is damaged"
            ),
            LoadError::BadSection { index, reason } => {
                write!(f, "section table entry {index}: {reason}")
            }
            LoadError::NonZeroPadding { offset } => {
                write!(f, "padding byte at offset {offset} is not zero: the file is damaged")
            }
            LoadError::SectionChecksum { name, stored, computed } => write!(
                f,
                "checksum mismatch in section {name:?} (stored {stored:#010x}, computed {computed:#010x}): the file is damaged"
            ),
            LoadError::MissingMeta => f.write_str("asset has no \"meta\" section"),
            LoadError::MetaNotJson { found } => {
                write!(f, "section \"meta\" has type {found}, expected json")
            }
            LoadError::UnknownCritical { name } => write!(
                f,
                "asset contains critical section {name:?} that this reader does not know; \
                 it needs a newer reader"
            ),
        }
    }
}

impl core::error::Error for LoadError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            LoadError::BadSection { reason, .. } => Some(reason),
            _ => None,
        }
    }
}

impl LoadError {
    /// The version error for a file of version `major.minor`.
    pub(crate) fn unsupported(major: u16, minor: u16) -> Self {
        LoadError::UnsupportedVersion {
            found_major: major,
            found_minor: minor,
            supported_major: FORMAT_MAJOR,
            supported_minor: FORMAT_MINOR,
        }
    }
}

/// Why a typed view or conversion of a [`Section`](crate::Section) is not possible.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ViewError {
    /// The section's element type is not the one asked for.
    WrongType {
        /// The section.
        name: SectionName,
        /// Its element type.
        found: DType,
        /// What the call accepts, e.g. `"f32"` or `"f16, f32 or f64"`.
        wanted: &'static str,
    },
    /// The section's data is not aligned for the element type in memory. Load the asset into
    /// aligned memory ([`OwnedAsset`](crate::OwnedAsset), `AssetFile`), or use an owned
    /// conversion such as [`Section::to_vec`](crate::Section::to_vec).
    Misaligned {
        /// The section.
        name: SectionName,
        /// Address of the data.
        address: usize,
        /// Required alignment in bytes.
        align: usize,
    },
    /// Zero-copy views of multi-byte elements exist only on little-endian targets; use the
    /// owned conversions.
    BigEndianTarget {
        /// The section.
        name: SectionName,
    },
    /// A JSON section whose bytes are not UTF-8 (only possible for damaged sections of an
    /// asset loaded with [`Asset::parse_unverified`](crate::Asset::parse_unverified)).
    InvalidUtf8 {
        /// The section.
        name: SectionName,
        /// Length of the valid UTF-8 prefix.
        valid_up_to: usize,
    },
}

impl fmt::Display for ViewError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ViewError::WrongType { name, found, wanted } => {
                write!(f, "section {name:?} has element type {found}, expected {wanted}")
            }
            ViewError::Misaligned { name, address, align } => write!(
                f,
                "section {name:?} data at address {address:#x} is not {align}-byte aligned for a zero-copy view"
            ),
            ViewError::BigEndianTarget { name } => {
                write!(f, "section {name:?}: zero-copy views need a little-endian target")
            }
            ViewError::InvalidUtf8 { name, valid_up_to } => {
                write!(f, "JSON section {name:?} is not valid UTF-8 (valid up to byte {valid_up_to})")
            }
        }
    }
}

impl core::error::Error for ViewError {}

/// Shows bytes as text when printable ASCII, with `\xNN` escapes otherwise.
struct Escaped<'a>(&'a [u8]);

impl fmt::Display for Escaped<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("\"")?;
        for &b in self.0 {
            if b.is_ascii_graphic() || b == b' ' {
                write!(f, "{}", char::from(b))?;
            } else {
                write!(f, "\\x{b:02x}")?;
            }
        }
        f.write_str("\"")
    }
}
