//! 64-byte aligned memory ([`AlignedBuf`]) and a validated asset that owns it ([`OwnedAsset`]).
//!
//! Alignment without unsafe code: the buffer over-allocates 63 bytes and starts at the first
//! 64-byte aligned address inside the allocation. A `Vec`'s heap block never moves unless it
//! grows, and this one never grows, so the alignment holds for the buffer's whole life.

use crate::error::LoadError;
use crate::format::ALIGN;
use crate::load::{Asset, Index, index};
use alloc::vec::Vec;
use core::fmt;

/// A zero-initialised byte buffer whose first byte sits at a 64-byte aligned address, so that
/// every section of an asset stored in it (sections are 64-aligned within the file) can be
/// viewed as `&[f32]`, `&[f64]`, … without copying.
pub struct AlignedBuf {
    storage: Vec<u8>,
    start: usize,
    len: usize,
}

impl AlignedBuf {
    /// Alignment of the first byte.
    pub const ALIGN: usize = ALIGN;

    /// A zeroed buffer of `len` bytes, or `None` if the allocation fails (so callers can turn a
    /// huge length from an untrusted source into an error instead of an abort).
    pub fn try_zeroed(len: usize) -> Option<AlignedBuf> {
        let total = len.checked_add(ALIGN - 1)?;
        let mut storage = Vec::new();
        storage.try_reserve_exact(total).ok()?;
        storage.resize(total, 0);
        let addr = storage.as_ptr().addr();
        let start = (ALIGN - addr % ALIGN) % ALIGN;
        Some(AlignedBuf { storage, start, len })
    }

    /// A copy of `bytes` in aligned memory. Aborts like `Vec` if memory runs out.
    pub fn from_slice(bytes: &[u8]) -> AlignedBuf {
        let mut buf = AlignedBuf::try_zeroed(bytes.len()).unwrap_or_else(|| alloc_failure(bytes.len()));
        buf.as_mut_slice().copy_from_slice(bytes);
        buf
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        self.storage.get(self.start..self.start.saturating_add(self.len)).unwrap_or(&[])
    }

    /// The bytes, mutably (e.g. to read a file into).
    pub fn as_mut_slice(&mut self) -> &mut [u8] {
        self.storage.get_mut(self.start..self.start.saturating_add(self.len)).unwrap_or(&mut [])
    }

    /// Length in bytes.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the buffer is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Reports an allocation failure the way `Vec` does (abort via the global handler).
fn alloc_failure(len: usize) -> ! {
    let layout =
        core::alloc::Layout::from_size_align(len.max(1), ALIGN).unwrap_or(core::alloc::Layout::new::<[u8; ALIGN]>());
    alloc::alloc::handle_alloc_error(layout)
}

impl Clone for AlignedBuf {
    fn clone(&self) -> Self {
        // Re-align: the copy lives at a different address.
        AlignedBuf::from_slice(self.as_slice())
    }
}

impl fmt::Debug for AlignedBuf {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("AlignedBuf").field("len", &self.len).finish_non_exhaustive()
    }
}

impl PartialEq for AlignedBuf {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl Eq for AlignedBuf {}

/// A validated asset in 64-byte aligned memory that it owns: typed zero-copy views of its
/// sections always succeed (on little-endian targets). `no_std`-friendly counterpart of
/// `AssetFile`, e.g. for bytes an engine read through its own file system.
#[derive(Clone)]
pub struct OwnedAsset {
    buf: AlignedBuf,
    index: Index,
}

impl fmt::Debug for OwnedAsset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("OwnedAsset").field(&self.asset()).finish()
    }
}

impl OwnedAsset {
    /// Validates `bytes` like [`Asset::parse`], then copies them into aligned memory.
    pub fn parse(bytes: &[u8]) -> Result<OwnedAsset, LoadError> {
        let index = index(bytes, true)?;
        Ok(OwnedAsset { buf: AlignedBuf::from_slice(bytes), index })
    }

    /// Validates like [`Asset::parse_unverified`], then copies into aligned memory.
    pub fn parse_unverified(bytes: &[u8]) -> Result<OwnedAsset, LoadError> {
        let index = index(bytes, false)?;
        Ok(OwnedAsset { buf: AlignedBuf::from_slice(bytes), index })
    }

    /// Validates an aligned buffer in place (no copy), like [`Asset::parse`].
    pub fn from_buf(buf: AlignedBuf) -> Result<OwnedAsset, LoadError> {
        let index = index(buf.as_slice(), true)?;
        Ok(OwnedAsset { buf, index })
    }

    /// Validates an aligned buffer in place, like [`Asset::parse_unverified`].
    pub fn from_buf_unverified(buf: AlignedBuf) -> Result<OwnedAsset, LoadError> {
        let index = index(buf.as_slice(), false)?;
        Ok(OwnedAsset { buf, index })
    }

    /// The asset (no re-validation; cheap).
    pub fn asset(&self) -> Asset<'_> {
        Asset::from_index(self.buf.as_slice(), &self.index)
    }

    /// The file bytes.
    pub fn bytes(&self) -> &[u8] {
        self.buf.as_slice()
    }

    /// Gives the buffer back.
    pub fn into_buf(self) -> AlignedBuf {
        self.buf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligned_buf_is_aligned_and_zeroed() {
        for len in [0usize, 1, 63, 64, 65, 1000] {
            let b = AlignedBuf::try_zeroed(len).unwrap();
            assert_eq!(b.len(), len);
            assert_eq!(b.is_empty(), len == 0);
            assert_eq!(b.as_slice().as_ptr().addr() % 64, 0);
            assert!(b.as_slice().iter().all(|&x| x == 0));
            let data: Vec<u8> = (0..len).map(|i| i as u8).collect();
            let c = AlignedBuf::from_slice(&data);
            assert_eq!(c.as_slice(), &data[..]);
            let moved = c.clone();
            assert_eq!(moved.as_slice().as_ptr().addr() % 64, 0);
            assert_eq!(moved, c);
        }
        assert!(AlignedBuf::try_zeroed(usize::MAX).is_none());
        assert!(AlignedBuf::try_zeroed(usize::MAX - 100).is_none());
    }
}
