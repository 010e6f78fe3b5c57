//! # penumbra-asset: the penumbra asset container, format v1
//!
//! One container for every baked asset (SH tables, sphere sets, FIV textures, MRT dictionaries
//! and level operators, DRT clutter operators). The format is documented byte for byte in
//! `schemas/asset-format.md`, so an engine can read it without Rust; this crate is the
//! reference reader and the only writer.
//!
//! ## Format in one screen (all integers little-endian)
//!
//! ```text
//! offset 0    header, 64 bytes: "PENUMBRA", major u16 = 1, minor u16 = 0, kind [A-Z0-9]{4},
//!             section count u32 (1..=4096), flags u32 = 0, table offset u64 = 64,
//!             file size u64, table CRC u32, 16 reserved zero bytes, header CRC u32 (of 0..60)
//! offset 64   section table: count × 96-byte entries: name [32] (NUL-padded [A-Za-z0-9_.-]),
//!             dtype u8, rank u8 (1..=6), flags u16 (bit 0 = critical), reserved u32,
//!             dims 6 × u32, data offset u64, data length u64, data CRC u32, 12 reserved bytes
//! then        section data, each at the next 64-byte aligned offset, zero padding between;
//!             the file ends exactly at the end of the last section
//! ```
//!
//! Checksums are CRC-32C ([`crc32c`]). Element types are [`DType`]; every asset has a JSON
//! section named `meta`. The layout is canonical: given the sections, there is exactly one
//! valid file, and the loader checks that.
//!
//! ## Reading
//!
//! [`Asset::parse`] validates everything once (checked arithmetic, bounds, canonical layout,
//! padding, reserved fields, names, types, dims × size = length, all checksums) and never
//! panics, whatever the bytes. Sections then give zero-copy typed views
//! ([`Section::as_f32`], …) when the buffer is aligned — [`OwnedAsset`] and `AssetFile` (feature
//! `std`) keep the file in 64-byte aligned memory — and owned conversions that always work
//! ([`Section::to_f32_vec`], [`Section::to_f64_vec`]).
//!
//! Versioning: a major version other than [`FORMAT_MAJOR`] is refused with an error naming both
//! versions; a newer minor is read (minor versions only add sections). Readers skip sections
//! they do not know unless the writer marked them critical ([`Asset::require_known`]).
//!
//! ## Writing
//!
//! [`AssetBuilder`] collects sections and encodes them ([`AssetBuilder::to_bytes`]); with `std`,
//! `AssetBuilder::write_atomic` writes through a temporary file, fsync and rename so a failed
//! bake never leaves a partial or clobbered asset.
//!
//! ## Features
//!
//! - `std` (default): file IO (`AssetFile`, `write_atomic`). Without it the crate is `no_std` +
//!   `alloc`; its only dependency is `bytemuck`. No unsafe code.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

extern crate alloc;

mod crc;
mod error;
mod f16;
pub mod format;
mod load;
mod owned;
mod section;
mod types;
mod write;

#[cfg(feature = "std")]
mod file;

pub use crc::{Crc32c, crc32c};
pub use error::{BuildError, LoadError, SectionFault, ViewError};
pub use f16::{f16_bits_to_f32, f32_to_f16_bits};
pub use format::{FORMAT_MAJOR, FORMAT_MINOR, META_SECTION};
pub use load::Asset;
pub use owned::{AlignedBuf, OwnedAsset};
pub use section::{Element, Section, SectionInfo};
pub use types::{DType, Kind, NameError, SectionName};
pub use write::AssetBuilder;

#[cfg(feature = "std")]
pub use file::{AssetFile, OpenError, WriteError, write_file_atomic};
