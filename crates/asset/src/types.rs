//! Small value types of the format: element types, asset kinds and section names.

use crate::format::NAME_LEN;
use core::fmt;

/// Element type of a section (the u8 at offset 32 of a section-table entry).
///
/// Every numeric type is stored little-endian and packed (no padding between elements).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum DType {
    /// Unsigned 8-bit integer (code 1).
    U8 = 1,
    /// Unsigned 16-bit integer (code 2).
    U16 = 2,
    /// Unsigned 32-bit integer (code 3).
    U32 = 3,
    /// Signed 32-bit two's-complement integer (code 4).
    I32 = 4,
    /// IEEE 754 binary16, stored as its 16 bits (code 5); see [`f16_bits_to_f32`](crate::f16_bits_to_f32).
    F16 = 5,
    /// IEEE 754 binary32 (code 6).
    F32 = 6,
    /// IEEE 754 binary64 (code 7).
    F64 = 7,
    /// UTF-8 JSON text (code 8); rank 1, `dims[0]` = length in bytes. The loader checks the
    /// UTF-8 but does not parse the JSON.
    Json = 8,
}

impl DType {
    /// Every element type, in code order.
    pub const ALL: [DType; 8] =
        [DType::U8, DType::U16, DType::U32, DType::I32, DType::F16, DType::F32, DType::F64, DType::Json];

    /// The code stored in the file.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The element type of a code, or `None` for a code this version does not define.
    pub const fn from_code(code: u8) -> Option<DType> {
        Some(match code {
            1 => DType::U8,
            2 => DType::U16,
            3 => DType::U32,
            4 => DType::I32,
            5 => DType::F16,
            6 => DType::F32,
            7 => DType::F64,
            8 => DType::Json,
            _ => return None,
        })
    }

    /// Size of one element in bytes (1 for JSON, whose elements are bytes).
    pub const fn size(self) -> usize {
        match self {
            DType::U8 | DType::Json => 1,
            DType::U16 | DType::F16 => 2,
            DType::U32 | DType::I32 | DType::F32 => 4,
            DType::F64 => 8,
        }
    }

    /// Short lower-case name: `"u8"`, `"u16"`, `"u32"`, `"i32"`, `"f16"`, `"f32"`, `"f64"`, `"json"`.
    pub const fn name(self) -> &'static str {
        match self {
            DType::U8 => "u8",
            DType::U16 => "u16",
            DType::U32 => "u32",
            DType::I32 => "i32",
            DType::F16 => "f16",
            DType::F32 => "f32",
            DType::F64 => "f64",
            DType::Json => "json",
        }
    }

    /// Whether the elements are numbers (every type but JSON).
    pub const fn is_numeric(self) -> bool {
        !matches!(self, DType::Json)
    }
}

impl fmt::Display for DType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Asset kind: 4 ASCII bytes from `[A-Z0-9]` at header offset 12.
///
/// The loader accepts any kind that matches the character set and exposes it; what a kind's
/// sections mean is documented per kind in `schemas/asset-format.md`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Kind([u8; 4]);

impl Kind {
    /// SH tables: log/exp tables, proxy tables (`penumbra tables`).
    pub const SHTB: Kind = Kind(*b"SHTB");
    /// Sphere sets and hierarchy for a mesh (`penumbra spheres`).
    pub const SPHR: Kind = Kind(*b"SPHR");
    /// FIV occlusion textures (`penumbra fiv`).
    pub const FIVT: Kind = Kind(*b"FIVT");
    /// MRT dictionary (`penumbra mrt dict`).
    pub const MRTD: Kind = Kind(*b"MRTD");
    /// MRT level operators (`penumbra mrt level`).
    pub const MRTL: Kind = Kind(*b"MRTL");
    /// DRT clutter operators (`penumbra drt`).
    pub const DRTO: Kind = Kind(*b"DRTO");
    /// Volumetric-obscurance sample sets (`penumbra vo`).
    pub const VOSS: Kind = Kind(*b"VOSS");

    /// The kinds this version of the toolchain writes.
    pub const KNOWN: [Kind; 7] = [Kind::SHTB, Kind::SPHR, Kind::FIVT, Kind::MRTD, Kind::MRTL, Kind::DRTO, Kind::VOSS];

    /// A kind from its 4 bytes, or `None` unless every byte is in `[A-Z0-9]`.
    pub const fn new(bytes: [u8; 4]) -> Option<Kind> {
        let mut i = 0;
        while i < 4 {
            let b = bytes[i];
            if !(b.is_ascii_uppercase() || b.is_ascii_digit()) {
                return None;
            }
            i += 1;
        }
        Some(Kind(bytes))
    }

    /// A kind from a 4-character string such as `"SHTB"`.
    pub fn from_str_exact(s: &str) -> Option<Kind> {
        <[u8; 4]>::try_from(s.as_bytes()).ok().and_then(Kind::new)
    }

    /// The 4 bytes as stored in the file.
    pub const fn bytes(self) -> [u8; 4] {
        self.0
    }

    /// The kind as text, e.g. `"SHTB"`.
    pub fn as_str(&self) -> &str {
        // Always ASCII by construction.
        core::str::from_utf8(&self.0).unwrap_or("????")
    }

    /// Whether this is one of [`Kind::KNOWN`].
    pub fn is_known(self) -> bool {
        Kind::KNOWN.contains(&self)
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Debug for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Kind({})", self.as_str())
    }
}

/// Why a section name is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum NameError {
    /// The name is empty (in a file: the name field starts with NUL).
    Empty,
    /// The name is longer than 32 bytes.
    TooLong {
        /// Length of the offered name in bytes.
        len: usize,
    },
    /// A byte outside `[A-Za-z0-9_.-]`.
    BadByte {
        /// The offending byte.
        byte: u8,
        /// Its position in the name field.
        position: usize,
    },
    /// A non-NUL byte after the first NUL of a name field (the padding must be all NUL).
    JunkAfterNul {
        /// Position of the non-NUL byte.
        position: usize,
    },
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            NameError::Empty => f.write_str("section name is empty"),
            NameError::TooLong { len } => {
                write!(f, "section name is {len} bytes long (at most {NAME_LEN} allowed)")
            }
            NameError::BadByte { byte, position } => {
                write!(f, "section name has byte {byte:#04x} at position {position} (allowed: A-Z a-z 0-9 _ . -)")
            }
            NameError::JunkAfterNul { position } => {
                write!(f, "section name field has a non-NUL byte at position {position} after its terminating NUL")
            }
        }
    }
}

impl core::error::Error for NameError {}

/// Whether `b` may appear in a section name: `[A-Za-z0-9_.-]`.
pub const fn is_name_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_' || b == b'.' || b == b'-'
}

/// A validated section name: 1 to 32 bytes from `[A-Za-z0-9_.-]`.
///
/// Stored inline (no allocation), so errors can carry it in `no_std` builds. Ordered by bytes.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SectionName {
    /// NUL-padded, exactly as in the file.
    bytes: [u8; NAME_LEN],
}

impl SectionName {
    /// Validates a name.
    pub fn new(name: &str) -> Result<SectionName, NameError> {
        let b = name.as_bytes();
        if b.is_empty() {
            return Err(NameError::Empty);
        }
        if b.len() > NAME_LEN {
            return Err(NameError::TooLong { len: b.len() });
        }
        let mut bytes = [0u8; NAME_LEN];
        for (position, (dst, &byte)) in bytes.iter_mut().zip(b).enumerate() {
            if !is_name_byte(byte) {
                return Err(NameError::BadByte { byte, position });
            }
            *dst = byte;
        }
        Ok(SectionName { bytes })
    }

    /// Validates the 32-byte NUL-padded name field of a section-table entry.
    pub fn from_field(field: &[u8; NAME_LEN]) -> Result<SectionName, NameError> {
        let len = field.iter().position(|&b| b == 0).unwrap_or(NAME_LEN);
        if len == 0 {
            return Err(NameError::Empty);
        }
        for (position, &byte) in field.iter().enumerate() {
            if position < len {
                if !is_name_byte(byte) {
                    return Err(NameError::BadByte { byte, position });
                }
            } else if byte != 0 {
                return Err(NameError::JunkAfterNul { position });
            }
        }
        Ok(SectionName { bytes: *field })
    }

    /// The NUL-padded 32-byte field as written to the file.
    pub const fn field(&self) -> &[u8; NAME_LEN] {
        &self.bytes
    }

    /// The name as text.
    pub fn as_str(&self) -> &str {
        let len = self.bytes.iter().position(|&b| b == 0).unwrap_or(NAME_LEN);
        let used = self.bytes.get(..len).unwrap_or(&[]);
        // Always ASCII by construction.
        core::str::from_utf8(used).unwrap_or("")
    }
}

impl fmt::Display for SectionName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Debug for SectionName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

impl PartialEq<str> for SectionName {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl PartialEq<&str> for SectionName {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dtype_codes_round_trip() {
        for (i, d) in DType::ALL.iter().enumerate() {
            assert_eq!(usize::from(d.code()), i + 1);
            assert_eq!(DType::from_code(d.code()), Some(*d));
        }
        assert_eq!(DType::from_code(0), None);
        assert_eq!(DType::from_code(9), None);
        assert_eq!(DType::F64.size(), 8);
        assert_eq!(DType::F16.size(), 2);
        assert_eq!(DType::Json.size(), 1);
        let names: [&str; 8] = DType::ALL.map(DType::name);
        assert_eq!(names, ["u8", "u16", "u32", "i32", "f16", "f32", "f64", "json"]);
    }

    #[test]
    fn kinds() {
        assert_eq!(Kind::SHTB.as_str(), "SHTB");
        assert_eq!(Kind::new(*b"AB12"), Some(Kind(*b"AB12")));
        assert_eq!(Kind::new(*b"ab12"), None);
        assert_eq!(Kind::new(*b"AB 1"), None);
        assert_eq!(Kind::from_str_exact("DRTO"), Some(Kind::DRTO));
        assert_eq!(Kind::from_str_exact("DRT"), None);
        assert!(Kind::MRTL.is_known());
        assert!(!Kind::new(*b"ZZZZ").unwrap().is_known());
        for k in Kind::KNOWN {
            assert_eq!(Kind::new(k.bytes()), Some(k));
        }
    }

    #[test]
    fn names() {
        assert_eq!(SectionName::new("meta").unwrap().as_str(), "meta");
        let long = "a".repeat(32);
        assert_eq!(SectionName::new(&long).unwrap().as_str(), long);
        assert_eq!(SectionName::new(&"a".repeat(33)), Err(NameError::TooLong { len: 33 }));
        assert_eq!(SectionName::new(""), Err(NameError::Empty));
        assert_eq!(SectionName::new("a b"), Err(NameError::BadByte { byte: b' ', position: 1 }));
        assert_eq!(SectionName::new("é"), Err(NameError::BadByte { byte: 0xC3, position: 0 }));
        assert!(SectionName::new("Az09_.-").is_ok());

        let mut field = [0u8; 32];
        field[..4].copy_from_slice(b"meta");
        assert_eq!(SectionName::from_field(&field).unwrap(), "meta");
        field[5] = b'x';
        assert_eq!(SectionName::from_field(&field), Err(NameError::JunkAfterNul { position: 5 }));
        assert_eq!(SectionName::from_field(&[0u8; 32]), Err(NameError::Empty));
        assert_eq!(SectionName::from_field(&[b'z'; 32]).unwrap().as_str().len(), 32);
    }
}
