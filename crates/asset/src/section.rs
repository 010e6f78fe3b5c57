//! Section metadata ([`SectionInfo`]), borrowed section data ([`Section`]) with typed zero-copy
//! views and owned conversions, and the [`Element`] trait of the numeric element types.

use crate::error::ViewError;
use crate::f16::f16_bits_to_f32;
use crate::format::MAX_RANK;
use crate::types::{DType, SectionName};
use alloc::vec::Vec;
use core::fmt;

mod sealed {
    use alloc::vec::Vec;

    /// Encoding hooks; private so that only the crate's types implement [`Element`](super::Element).
    pub trait Sealed: Sized + Copy {
        /// Decodes one element from exactly `size_of::<Self>()` little-endian bytes.
        fn decode_le(bytes: &[u8]) -> Self;
        /// Appends the little-endian encoding of `items`.
        fn extend_le(items: &[Self], out: &mut Vec<u8>);
    }
}

/// A numeric element type with a zero-copy view: `u8`, `u16`, `u32`, `i32`, `f32`, `f64`.
///
/// (`f16` data is viewed as its `u16` bits with [`Section::as_f16_bits`]; this trait maps
/// `u16` to [`DType::U16`].) Sealed: implemented only by this crate.
pub trait Element: sealed::Sealed + bytemuck::Pod {
    /// The element type of sections holding `Self`.
    const DTYPE: DType;
}

macro_rules! element {
    ($t:ty, $d:expr) => {
        impl sealed::Sealed for $t {
            fn decode_le(bytes: &[u8]) -> Self {
                <[u8; core::mem::size_of::<$t>()]>::try_from(bytes).map(<$t>::from_le_bytes).unwrap_or(0 as $t)
            }
            fn extend_le(items: &[Self], out: &mut Vec<u8>) {
                if cfg!(target_endian = "little") {
                    out.extend_from_slice(bytemuck::cast_slice(items));
                } else {
                    for x in items {
                        out.extend_from_slice(&x.to_le_bytes());
                    }
                }
            }
        }
        impl Element for $t {
            const DTYPE: DType = $d;
        }
    };
}

element!(u8, DType::U8);
element!(u16, DType::U16);
element!(u32, DType::U32);
element!(i32, DType::I32);
element!(f32, DType::F32);
element!(f64, DType::F64);

pub(crate) use sealed::Sealed;

/// One validated section-table entry, plus whether the section's data matches its CRC.
///
/// Owns its data (no borrow of the file), so it can be kept after the asset is dropped.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct SectionInfo {
    pub(crate) name: SectionName,
    pub(crate) dtype: DType,
    pub(crate) rank: u8,
    pub(crate) dims: [usize; MAX_RANK],
    pub(crate) elements: usize,
    pub(crate) offset: u64,
    pub(crate) length: u64,
    pub(crate) crc: u32,
    pub(crate) critical: bool,
    pub(crate) checksum_ok: bool,
}

impl SectionInfo {
    /// The section's name.
    pub fn name(&self) -> &str {
        self.name.as_str()
    }

    /// The section's name as the inline [`SectionName`] type.
    pub fn section_name(&self) -> SectionName {
        self.name
    }

    /// Element type.
    pub fn dtype(&self) -> DType {
        self.dtype
    }

    /// Number of dimensions, 1..=6.
    pub fn rank(&self) -> usize {
        usize::from(self.rank)
    }

    /// The dimensions, outermost first (row-major: the last index varies fastest); `rank()` long.
    /// A dimension may be 0 (empty array). For JSON sections, `[byte length]`.
    pub fn dims(&self) -> &[usize] {
        self.dims.get(..self.rank()).unwrap_or(&[])
    }

    /// Number of elements, the product of the dims.
    pub fn element_count(&self) -> usize {
        self.elements
    }

    /// Byte offset of the data from the start of the file (a multiple of 64).
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// Length of the data in bytes (element count × element size).
    pub fn byte_len(&self) -> u64 {
        self.length
    }

    /// CRC-32C of the data as stored in the section table.
    pub fn crc(&self) -> u32 {
        self.crc
    }

    /// Whether the writer marked the section critical: a reader that does not know it must
    /// refuse the asset.
    pub fn is_critical(&self) -> bool {
        self.critical
    }

    /// Whether the data matches the stored CRC. Always true for an asset from
    /// [`Asset::parse`](crate::Asset::parse), which refuses any mismatch; may be false after
    /// [`Asset::parse_unverified`](crate::Asset::parse_unverified).
    pub fn checksum_ok(&self) -> bool {
        self.checksum_ok
    }
}

impl fmt::Debug for SectionInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SectionInfo")
            .field("name", &self.name)
            .field("dtype", &self.dtype)
            .field("dims", &self.dims())
            .field("offset", &self.offset)
            .field("length", &self.length)
            .field("crc", &format_args!("{:#010x}", self.crc))
            .field("critical", &self.critical)
            .field("checksum_ok", &self.checksum_ok)
            .finish()
    }
}

/// A section of a loaded asset: its table entry and its bytes, borrowed from the asset's buffer
/// for `'a` (so views outlive the [`Asset`](crate::Asset) value they came from).
#[derive(Clone, Copy)]
pub struct Section<'a> {
    pub(crate) info: SectionInfo,
    pub(crate) data: &'a [u8],
}

impl fmt::Debug for Section<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Section").field("info", &self.info).finish_non_exhaustive()
    }
}

impl<'a> Section<'a> {
    /// The table entry.
    pub fn info(&self) -> &SectionInfo {
        &self.info
    }

    /// The section's name.
    pub fn name(&self) -> &str {
        self.info.name()
    }

    /// Element type.
    pub fn dtype(&self) -> DType {
        self.info.dtype
    }

    /// Dimensions, outermost first.
    pub fn dims(&self) -> &[usize] {
        self.info.dims()
    }

    /// The raw little-endian bytes of the data.
    pub fn bytes(&self) -> &'a [u8] {
        self.data
    }

    fn wrong_type(&self, wanted: &'static str) -> ViewError {
        ViewError::WrongType { name: self.info.name, found: self.info.dtype, wanted }
    }

    fn cast<T: bytemuck::Pod>(&self, dtype: DType) -> Result<&'a [T], ViewError> {
        if self.info.dtype != dtype {
            return Err(self.wrong_type(dtype.name()));
        }
        if self.data.is_empty() {
            return Ok(&[]);
        }
        if !(cfg!(target_endian = "little") || core::mem::size_of::<T>() == 1) {
            return Err(ViewError::BigEndianTarget { name: self.info.name });
        }
        bytemuck::try_cast_slice(self.data).map_err(|_| ViewError::Misaligned {
            name: self.info.name,
            address: self.data.as_ptr().addr(),
            align: core::mem::align_of::<T>(),
        })
    }

    /// Zero-copy view of a section of element type `T::DTYPE`.
    ///
    /// Fails if the element type differs, if the data is not aligned for `T` in memory (an
    /// asset parsed from an arbitrary `&[u8]`; [`OwnedAsset`](crate::OwnedAsset) and
    /// `AssetFile` are always 64-byte aligned), or on big-endian targets for multi-byte `T`.
    pub fn view<T: Element>(&self) -> Result<&'a [T], ViewError> {
        self.cast::<T>(<T as Element>::DTYPE)
    }

    /// Zero-copy view of a `u8` section.
    pub fn as_u8(&self) -> Result<&'a [u8], ViewError> {
        self.view()
    }

    /// Zero-copy view of a `u16` section.
    pub fn as_u16(&self) -> Result<&'a [u16], ViewError> {
        self.view()
    }

    /// Zero-copy view of a `u32` section.
    pub fn as_u32(&self) -> Result<&'a [u32], ViewError> {
        self.view()
    }

    /// Zero-copy view of an `i32` section.
    pub fn as_i32(&self) -> Result<&'a [i32], ViewError> {
        self.view()
    }

    /// Zero-copy view of an `f32` section.
    pub fn as_f32(&self) -> Result<&'a [f32], ViewError> {
        self.view()
    }

    /// Zero-copy view of an `f64` section.
    pub fn as_f64(&self) -> Result<&'a [f64], ViewError> {
        self.view()
    }

    /// Zero-copy view of an `f16` section as raw binary16 bits (e.g. to upload to a GPU);
    /// convert with [`f16_bits_to_f32`] or use [`to_f32_vec`](Self::to_f32_vec).
    pub fn as_f16_bits(&self) -> Result<&'a [u16], ViewError> {
        self.cast::<u16>(DType::F16)
    }

    /// The text of a JSON section.
    pub fn as_json(&self) -> Result<&'a str, ViewError> {
        if self.info.dtype != DType::Json {
            return Err(self.wrong_type("json"));
        }
        core::str::from_utf8(self.data)
            .map_err(|e| ViewError::InvalidUtf8 { name: self.info.name, valid_up_to: e.valid_up_to() })
    }

    fn decode<T: Sealed>(&self) -> Vec<T> {
        self.data.chunks_exact(core::mem::size_of::<T>()).map(T::decode_le).collect()
    }

    /// Owned copy of a section of element type `T::DTYPE`, decoded from little-endian bytes:
    /// works for any alignment and on any target.
    pub fn to_vec<T: Element>(&self) -> Result<Vec<T>, ViewError> {
        if self.info.dtype != <T as Element>::DTYPE {
            return Err(self.wrong_type(<T as Element>::DTYPE.name()));
        }
        Ok(self.decode::<T>())
    }

    /// Owned `f32` values of an `f16`, `f32` or `f64` section (f16 widened exactly, f64
    /// rounded to nearest). Works for any alignment and on any target.
    pub fn to_f32_vec(&self) -> Result<Vec<f32>, ViewError> {
        match self.info.dtype {
            DType::F16 => Ok(self.decode::<u16>().into_iter().map(f16_bits_to_f32).collect()),
            DType::F32 => Ok(self.decode::<f32>()),
            DType::F64 => Ok(self.decode::<f64>().into_iter().map(|v| v as f32).collect()),
            _ => Err(self.wrong_type("f16, f32 or f64")),
        }
    }

    /// Owned `f64` values of any numeric section (every conversion is exact).
    pub fn to_f64_vec(&self) -> Result<Vec<f64>, ViewError> {
        Ok(match self.info.dtype {
            DType::U8 => self.data.iter().map(|&v| f64::from(v)).collect(),
            DType::U16 => self.decode::<u16>().into_iter().map(f64::from).collect(),
            DType::U32 => self.decode::<u32>().into_iter().map(f64::from).collect(),
            DType::I32 => self.decode::<i32>().into_iter().map(f64::from).collect(),
            DType::F16 => self.decode::<u16>().into_iter().map(|h| f64::from(f16_bits_to_f32(h))).collect(),
            DType::F32 => self.decode::<f32>().into_iter().map(f64::from).collect(),
            DType::F64 => self.decode::<f64>(),
            DType::Json => return Err(self.wrong_type("a numeric type")),
        })
    }
}
