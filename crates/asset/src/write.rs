//! The writer: [`AssetBuilder`] collects named, typed sections and encodes the canonical v1 layout.
//!
//! Output is a pure function of the sections added (in order), so the same bake gives the same
//! bytes. Sections are laid out in the order they were added.

use crate::crc::crc32c;
use crate::error::BuildError;
use crate::f16::f32_to_f16_bits;
use crate::format::{
    FORMAT_MAJOR, FORMAT_MINOR, HEADER_LEN, MAGIC, MAX_RANK, MAX_SECTIONS, META_SECTION, SECTION_ENTRY_LEN,
    SECTION_FLAG_CRITICAL, TABLE_OFFSET, align_up, entry, first_section_offset, header,
};
use crate::section::{Element, Sealed};
use crate::types::{DType, Kind, SectionName};
use alloc::string::ToString;
use alloc::vec::Vec;
use core::fmt;

/// One section waiting to be written.
#[derive(Clone)]
struct Pending {
    name: SectionName,
    dtype: DType,
    rank: u8,
    dims: [u32; MAX_RANK],
    critical: bool,
    /// Little-endian element bytes.
    data: Vec<u8>,
}

/// Builds an asset in memory: add sections, then [`to_bytes`](Self::to_bytes) or (with the `std`
/// feature) `write_atomic`.
///
/// ```
/// use penumbra_asset::{Asset, AssetBuilder, Kind};
/// let mut b = AssetBuilder::new(Kind::SPHR);
/// b.add_json("meta", r#"{"tool":"doc"}"#)?
///     .add_f32("centers", &[2, 3], &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0])?;
/// let bytes = b.to_bytes()?;
/// let asset = Asset::parse(&bytes)?;
/// assert_eq!(asset.section("centers").unwrap().dims(), &[2, 3]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone)]
pub struct AssetBuilder {
    kind: Kind,
    sections: Vec<Pending>,
}

impl fmt::Debug for Pending {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {} {:?} ({} bytes{})",
            self.name,
            self.dtype,
            self.dims.get(..usize::from(self.rank)).unwrap_or(&[]),
            self.data.len(),
            if self.critical { ", critical" } else { "" }
        )
    }
}

impl fmt::Debug for AssetBuilder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("AssetBuilder").field("kind", &self.kind).field("sections", &self.sections).finish()
    }
}

/// Checks `dims` and returns (rank, u32 dims, element count).
fn shape(name: SectionName, dims: &[usize]) -> Result<(u8, [u32; MAX_RANK], usize), BuildError> {
    if dims.is_empty() || dims.len() > MAX_RANK {
        return Err(BuildError::BadRank { name, rank: dims.len() });
    }
    let mut out = [0u32; MAX_RANK];
    let mut count: usize = 1;
    for (axis, (&d, o)) in dims.iter().zip(out.iter_mut()).enumerate() {
        *o = u32::try_from(d).map_err(|_| BuildError::DimTooLarge { name, axis, dim: d })?;
        count = count.checked_mul(d).ok_or(BuildError::ShapeOverflow { name })?;
    }
    Ok((dims.len() as u8, out, count))
}

impl AssetBuilder {
    /// An empty asset of the given kind.
    pub fn new(kind: Kind) -> AssetBuilder {
        AssetBuilder { kind, sections: Vec::new() }
    }

    /// The asset kind.
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// Number of sections added so far.
    pub fn section_count(&self) -> usize {
        self.sections.len()
    }

    /// Validates a new section's name and checks it is not taken and the asset is not full.
    fn new_name(&self, name: &str, dtype: DType) -> Result<SectionName, BuildError> {
        let n = SectionName::new(name).map_err(|reason| BuildError::InvalidName { name: name.to_string(), reason })?;
        if self.sections.iter().any(|s| s.name == n) {
            return Err(BuildError::DuplicateName { name: n });
        }
        if self.sections.len() >= MAX_SECTIONS as usize {
            return Err(BuildError::TooManySections);
        }
        if n == META_SECTION && dtype != DType::Json {
            return Err(BuildError::MetaNotJson { found: dtype });
        }
        Ok(n)
    }

    fn push(&mut self, name: SectionName, dtype: DType, rank: u8, dims: [u32; MAX_RANK], data: Vec<u8>) -> &mut Self {
        self.sections.push(Pending { name, dtype, rank, dims, critical: false, data });
        self
    }

    /// Adds a section of any numeric element type: `data` holds product(`dims`) elements in
    /// row-major order (last index fastest).
    ///
    /// # Errors
    /// Bad or duplicate name, rank 0 or above 6, a dim above `u32::MAX`, product(dims) ≠
    /// `data.len()`, or more than 4096 sections.
    pub fn add<T: Element>(&mut self, name: &str, dims: &[usize], data: &[T]) -> Result<&mut Self, BuildError> {
        let dtype = <T as Element>::DTYPE;
        let n = self.new_name(name, dtype)?;
        let (rank, d, count) = shape(n, dims)?;
        if count != data.len() {
            return Err(BuildError::ShapeMismatch { name: n, expected_elements: count, found_elements: data.len() });
        }
        let mut bytes = Vec::with_capacity(core::mem::size_of_val(data));
        T::extend_le(data, &mut bytes);
        Ok(self.push(n, dtype, rank, d, bytes))
    }

    /// Adds a `u8` section (see [`add`](Self::add)).
    pub fn add_u8(&mut self, name: &str, dims: &[usize], data: &[u8]) -> Result<&mut Self, BuildError> {
        self.add(name, dims, data)
    }

    /// Adds a `u16` section (see [`add`](Self::add)).
    pub fn add_u16(&mut self, name: &str, dims: &[usize], data: &[u16]) -> Result<&mut Self, BuildError> {
        self.add(name, dims, data)
    }

    /// Adds a `u32` section (see [`add`](Self::add)).
    pub fn add_u32(&mut self, name: &str, dims: &[usize], data: &[u32]) -> Result<&mut Self, BuildError> {
        self.add(name, dims, data)
    }

    /// Adds an `i32` section (see [`add`](Self::add)).
    pub fn add_i32(&mut self, name: &str, dims: &[usize], data: &[i32]) -> Result<&mut Self, BuildError> {
        self.add(name, dims, data)
    }

    /// Adds an `f32` section (see [`add`](Self::add)).
    pub fn add_f32(&mut self, name: &str, dims: &[usize], data: &[f32]) -> Result<&mut Self, BuildError> {
        self.add(name, dims, data)
    }

    /// Adds an `f64` section (see [`add`](Self::add)).
    pub fn add_f64(&mut self, name: &str, dims: &[usize], data: &[f64]) -> Result<&mut Self, BuildError> {
        self.add(name, dims, data)
    }

    /// Adds an `f16` section, converting `data` with [`f32_to_f16_bits`] (round to nearest even;
    /// values beyond ±65504 become ±infinity).
    pub fn add_f16(&mut self, name: &str, dims: &[usize], data: &[f32]) -> Result<&mut Self, BuildError> {
        let bits: Vec<u16> = data.iter().map(|&v| f32_to_f16_bits(v)).collect();
        self.add_f16_bits(name, dims, &bits)
    }

    /// Adds an `f16` section from binary16 bit patterns already converted.
    pub fn add_f16_bits(&mut self, name: &str, dims: &[usize], bits: &[u16]) -> Result<&mut Self, BuildError> {
        let n = self.new_name(name, DType::F16)?;
        let (rank, d, count) = shape(n, dims)?;
        if count != bits.len() {
            return Err(BuildError::ShapeMismatch { name: n, expected_elements: count, found_elements: bits.len() });
        }
        let mut bytes = Vec::with_capacity(2 * bits.len());
        u16::extend_le(bits, &mut bytes);
        Ok(self.push(n, DType::F16, rank, d, bytes))
    }

    /// Adds a JSON section (rank 1, dims = [byte length]). The text is stored as given; the
    /// format does not parse it, so callers produce it with a JSON serializer.
    pub fn add_json(&mut self, name: &str, text: &str) -> Result<&mut Self, BuildError> {
        let n = self.new_name(name, DType::Json)?;
        let (rank, d, _) = shape(n, &[text.len()])?;
        Ok(self.push(n, DType::Json, rank, d, text.as_bytes().to_vec()))
    }

    /// Adds a section from raw little-endian element bytes of any type, e.g. to copy a section
    /// from another asset ([`Section::bytes`](crate::Section::bytes)).
    ///
    /// # Errors
    /// As [`add`](Self::add); the byte length must be product(dims) × element size; JSON must
    /// have rank 1 and be UTF-8.
    pub fn add_raw(
        &mut self,
        name: &str,
        dtype: DType,
        dims: &[usize],
        le_bytes: &[u8],
    ) -> Result<&mut Self, BuildError> {
        let n = self.new_name(name, dtype)?;
        let (rank, d, count) = shape(n, dims)?;
        if dtype == DType::Json {
            if rank != 1 {
                return Err(BuildError::JsonRank { name: n, rank: dims.len() });
            }
            if core::str::from_utf8(le_bytes).is_err() {
                return Err(BuildError::JsonNotUtf8 { name: n });
            }
        }
        let expected = count.checked_mul(dtype.size()).ok_or(BuildError::ShapeOverflow { name: n })?;
        if expected != le_bytes.len() {
            return Err(BuildError::RawLengthMismatch {
                name: n,
                expected_bytes: expected,
                found_bytes: le_bytes.len(),
            });
        }
        Ok(self.push(n, dtype, rank, d, le_bytes.to_vec()))
    }

    /// Marks (or unmarks) the section `name` as critical: readers that do not know a critical
    /// section refuse the asset instead of skipping it. Use it for sections that change how
    /// other sections must be interpreted.
    pub fn set_critical(&mut self, name: &str, critical: bool) -> Result<&mut Self, BuildError> {
        let s = self
            .sections
            .iter_mut()
            .find(|s| s.name == name)
            .ok_or_else(|| BuildError::UnknownSection { name: name.to_string() })?;
        s.critical = critical;
        Ok(self)
    }

    /// Data offsets of every section and the file size.
    fn layout(&self) -> Result<(Vec<u64>, u64), BuildError> {
        let count = u32::try_from(self.sections.len()).map_err(|_| BuildError::TooManySections)?;
        let mut offsets = Vec::with_capacity(self.sections.len());
        let mut next = first_section_offset(count);
        let mut end = next;
        for s in &self.sections {
            offsets.push(next);
            end = next.checked_add(s.data.len() as u64).ok_or(BuildError::TooLarge)?;
            next = align_up(end).ok_or(BuildError::TooLarge)?;
        }
        Ok((offsets, end))
    }

    /// Size in bytes of the encoded asset.
    pub fn encoded_len(&self) -> Result<u64, BuildError> {
        Ok(self.layout()?.1)
    }

    /// Encodes the asset in the canonical v1 layout.
    ///
    /// # Errors
    /// [`BuildError::MissingMeta`] without a `meta` section; [`BuildError::TooLarge`] if the
    /// file would not fit in memory.
    pub fn to_bytes(&self) -> Result<Vec<u8>, BuildError> {
        if !self.sections.iter().any(|s| s.name == META_SECTION) {
            return Err(BuildError::MissingMeta);
        }
        let (offsets, file_size) = self.layout()?;
        let total = usize::try_from(file_size).map_err(|_| BuildError::TooLarge)?;
        let mut out = Vec::new();
        out.try_reserve_exact(total).map_err(|_| BuildError::TooLarge)?;
        out.resize(total, 0u8);

        let table_start = TABLE_OFFSET as usize;
        for (i, (s, &off)) in self.sections.iter().zip(&offsets).enumerate() {
            let mut e = [0u8; SECTION_ENTRY_LEN];
            put(&mut e, entry::NAME, s.name.field());
            put(&mut e, entry::DTYPE, &[s.dtype.code(), s.rank]);
            let flags = if s.critical { SECTION_FLAG_CRITICAL } else { 0 };
            put(&mut e, entry::FLAGS, &flags.to_le_bytes());
            for (axis, d) in s.dims.iter().enumerate() {
                put(&mut e, entry::DIMS + 4 * axis, &d.to_le_bytes());
            }
            put(&mut e, entry::OFFSET, &off.to_le_bytes());
            put(&mut e, entry::LENGTH, &(s.data.len() as u64).to_le_bytes());
            put(&mut e, entry::CRC, &crc32c(&s.data).to_le_bytes());
            put(&mut out, table_start + i * SECTION_ENTRY_LEN, &e);
            put(&mut out, off as usize, &s.data);
        }
        let table_end = table_start + self.sections.len() * SECTION_ENTRY_LEN;
        let table_crc = crc32c(out.get(table_start..table_end).unwrap_or(&[]));

        let mut h = [0u8; HEADER_LEN];
        put(&mut h, header::MAGIC, &MAGIC);
        put(&mut h, header::MAJOR, &FORMAT_MAJOR.to_le_bytes());
        put(&mut h, header::MINOR, &FORMAT_MINOR.to_le_bytes());
        put(&mut h, header::KIND, &self.kind.bytes());
        put(&mut h, header::SECTION_COUNT, &(self.sections.len() as u32).to_le_bytes());
        put(&mut h, header::TABLE_OFFSET, &TABLE_OFFSET.to_le_bytes());
        put(&mut h, header::FILE_SIZE, &file_size.to_le_bytes());
        put(&mut h, header::TABLE_CRC, &table_crc.to_le_bytes());
        let header_crc = crc32c(h.get(..header::HEADER_CRC).unwrap_or(&[]));
        put(&mut h, header::HEADER_CRC, &header_crc.to_le_bytes());
        put(&mut out, 0, &h);
        Ok(out)
    }
}

/// Copies `src` to `dst[at..]`. Offsets come from [`AssetBuilder::layout`], which sized `dst`,
/// so the range always fits (a misfit would be a bug caught by the round-trip tests).
fn put(dst: &mut [u8], at: usize, src: &[u8]) {
    if let Some(d) = dst.get_mut(at..at.saturating_add(src.len())) {
        d.copy_from_slice(src);
    } else {
        debug_assert!(false, "section layout out of range");
    }
}
