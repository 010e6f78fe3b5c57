//! glTF buffer loading and accessor decoding with full bounds checking.
//!
//! The gltf crate's readers silently yield zero elements when an accessor is longer than its
//! buffer view; here every accessor is checked (offsets, stride, count, view and buffer
//! bounds, sparse indices) with checked arithmetic, and every problem is an error message.

use std::path::{Path, PathBuf};

use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Source;

/// Largest number of scalar values an accessor may decode to (guards allocation bombs in
/// accessors without a buffer view, which are all zeros plus sparse substitutions).
const MAX_SCALARS: usize = 1 << 30;

/// Buffer data loaded on demand: the GLB `BIN` chunk, base64 `data:` URIs, or files relative
/// to the glTF file. Remote URIs are refused (no network access).
pub(crate) struct BufferStore<'a> {
    doc: &'a gltf::Document,
    blob: Option<Vec<u8>>,
    base_dir: PathBuf,
    cache: Vec<Option<Vec<u8>>>,
}

impl<'a> BufferStore<'a> {
    pub(crate) fn new(doc: &'a gltf::Document, blob: Option<Vec<u8>>, base_dir: &Path) -> Self {
        Self { doc, blob, base_dir: base_dir.to_path_buf(), cache: vec![None; doc.buffers().len()] }
    }

    /// The bytes of buffer `index`, truncated to its declared `byteLength`.
    pub(crate) fn get(&mut self, index: usize) -> Result<&[u8], String> {
        if index >= self.cache.len() {
            return Err(format!("buffer {index} does not exist"));
        }
        if self.cache[index].is_none() {
            let data = self.load(index)?;
            self.cache[index] = Some(data);
        }
        Ok(self.cache[index].as_deref().unwrap_or(&[]))
    }

    fn load(&mut self, index: usize) -> Result<Vec<u8>, String> {
        let buffer = self.doc.buffers().nth(index).ok_or_else(|| format!("buffer {index} does not exist"))?;
        let declared = buffer.length();
        let mut data = match buffer.source() {
            Source::Bin => self
                .blob
                .take()
                .ok_or_else(|| format!("buffer {index} refers to the GLB binary chunk, but the file has none"))?,
            Source::Uri(uri) => self.load_uri(index, uri)?,
        };
        if data.len() < declared {
            return Err(format!(
                "buffer {index}: byteLength is {declared} but only {} bytes are present (truncated?)",
                data.len()
            ));
        }
        data.truncate(declared);
        Ok(data)
    }

    fn load_uri(&self, index: usize, uri: &str) -> Result<Vec<u8>, String> {
        self.read_uri(&format!("buffer {index}"), uri)
    }

    /// The bytes of a base64 `data:` URI or of a file relative to the glTF file; `what`
    /// prefixes the messages.
    fn read_uri(&self, what: &str, uri: &str) -> Result<Vec<u8>, String> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (header, payload) =
                rest.split_once(',').ok_or_else(|| format!("{what}: malformed data URI (no ',')"))?;
            if !header.ends_with(";base64") {
                return Err(format!("{what}: only base64 data URIs are supported"));
            }
            return decode_base64(payload).map_err(|e| format!("{what}: data URI: {e}"));
        }
        let Some(file) = local_file(&self.base_dir, uri) else {
            return Err(format!(
                "{what}: URI {uri:?} is not a relative file path or data URI (remote resources are not fetched)"
            ));
        };
        std::fs::read(&file).map_err(|e| format!("{what}: cannot read {}: {e}", file.display()))
    }

    /// The encoded bytes of a glTF image: its buffer view's range, or its URI's content.
    pub(crate) fn image_bytes(&mut self, image: &gltf::Image<'_>) -> Result<Vec<u8>, String> {
        let what = format!("image {}", image.index());
        match image.source() {
            gltf::image::Source::View { view, .. } => {
                let (start, len) = (view.offset(), view.length());
                let buf = self.get(view.buffer().index()).map_err(|e| format!("{what}: {e}"))?;
                let end = start.checked_add(len).filter(|&e| e <= buf.len()).ok_or_else(|| {
                    format!(
                        "{what}: buffer view {} (bytes {start}..{start}+{len}) exceeds its buffer ({} bytes)",
                        view.index(),
                        buf.len()
                    )
                })?;
                Ok(buf[start..end].to_vec())
            }
            gltf::image::Source::Uri { uri, .. } => self.read_uri(&what, uri),
        }
    }
}

/// The file a relative glTF URI names (percent-decoded, under `base_dir`); `None` for `data:`
/// URIs and for URIs with a scheme or an absolute path, which the importer never reads.
pub(crate) fn local_file(base_dir: &Path, uri: &str) -> Option<std::path::PathBuf> {
    if uri.starts_with("data:") || has_scheme(uri) {
        return None;
    }
    Some(base_dir.join(percent_decode(uri)))
}

fn has_scheme(uri: &str) -> bool {
    match uri.find(':') {
        Some(p) if p > 1 => {
            let s = &uri[..p];
            s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '+' || c == '-' || c == '.')
        }
        _ => uri.starts_with('/') || uri.starts_with('\\'),
    }
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648 alphabet, optional `=` padding).
pub(crate) fn decode_base64(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let mut acc = 0u32;
    let mut bits = 0u32;
    let mut padding = false;
    for (pos, c) in s.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => {
                padding = true;
                continue;
            }
            _ => return Err(format!("invalid base64 character at offset {pos}")),
        };
        if padding {
            return Err("base64 data after '=' padding".into());
        }
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// Decoded accessor: `count × components` values, in element order; matrices column-major.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct AccessorData {
    pub values: Vec<f64>,
    pub components: usize,
    pub count: usize,
}

impl AccessorData {
    pub(crate) fn element(&self, i: usize) -> &[f64] {
        &self.values[i * self.components..(i + 1) * self.components]
    }
}

fn comp_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// (columns, rows) of an element.
fn shape(d: Dimensions) -> (usize, usize) {
    match d {
        Dimensions::Scalar => (1, 1),
        Dimensions::Vec2 => (1, 2),
        Dimensions::Vec3 => (1, 3),
        Dimensions::Vec4 => (1, 4),
        Dimensions::Mat2 => (2, 2),
        Dimensions::Mat3 => (3, 3),
        Dimensions::Mat4 => (4, 4),
    }
}

pub(crate) fn type_name(t: DataType, d: Dimensions, normalized: bool) -> String {
    format!("{:?} {:?}{}", d, t, if normalized { " normalized" } else { "" })
}

fn decode(t: DataType, normalized: bool, b: &[u8]) -> f64 {
    match t {
        DataType::I8 => {
            let v = b[0] as i8 as f64;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U8 => {
            let v = b[0] as f64;
            if normalized { v / 255.0 } else { v }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized { (v / 32767.0).max(-1.0) } else { v }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized { v / 65535.0 } else { v }
        }
        DataType::U32 => {
            let v = u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64;
            if normalized { v / 4294967295.0 } else { v }
        }
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// The byte range `[start, start + len)` of buffer view `view` inside its buffer data, checked.
fn view_bytes<'s>(
    store: &'s mut BufferStore<'_>,
    view: &gltf::buffer::View<'_>,
    what: &str,
) -> Result<&'s [u8], String> {
    let bi = view.buffer().index();
    let data = store.get(bi)?;
    let end = view
        .offset()
        .checked_add(view.length())
        .ok_or_else(|| format!("{what}: buffer view {} range overflows", view.index()))?;
    if end > data.len() {
        return Err(format!(
            "{what}: buffer view {} spans bytes {}..{end} but buffer {bi} has {} bytes",
            view.index(),
            view.offset(),
            data.len()
        ));
    }
    Ok(&data[view.offset()..end])
}

/// Decodes an accessor into f64 (normalised integers mapped to [0, 1] / [-1, 1]), with sparse
/// substitution. `what` names the accessor's role in error messages.
pub(crate) fn read_accessor(
    acc: &gltf::Accessor<'_>,
    store: &mut BufferStore<'_>,
    what: &str,
) -> Result<AccessorData, String> {
    let what = format!("{what} (accessor {})", acc.index());
    let t = acc.data_type();
    let (cols, rows) = shape(acc.dimensions());
    let components = cols * rows;
    let cs = comp_size(t);
    // matrix columns start on 4-byte boundaries
    let col_stride = if cols > 1 { (rows * cs).div_ceil(4) * 4 } else { rows * cs };
    let elem_size = col_stride * cols;
    let count = acc.count();
    let total = count
        .checked_mul(components)
        .filter(|&n| n <= MAX_SCALARS)
        .ok_or_else(|| format!("{what}: count {count} is too large"))?;
    let normalized = acc.normalized();
    let mut values = vec![0.0f64; total];
    if let Some(view) = acc.view() {
        let stride = match view.stride() {
            Some(s) if s < elem_size => {
                return Err(format!(
                    "{what}: byteStride {s} of buffer view {} is smaller than the element size {elem_size}",
                    view.index()
                ));
            }
            Some(s) => s,
            None => elem_size,
        };
        let bytes = view_bytes(store, &view, &what)?;
        if count > 0 {
            let needed = stride
                .checked_mul(count - 1)
                .and_then(|x| x.checked_add(elem_size))
                .and_then(|x| x.checked_add(acc.offset()))
                .ok_or_else(|| format!("{what}: byte range overflows"))?;
            if needed > bytes.len() {
                return Err(format!(
                    "{what}: {count} elements of {elem_size} bytes (stride {stride}, offset {}) need {needed} bytes but buffer view {} has {}",
                    acc.offset(),
                    view.index(),
                    bytes.len()
                ));
            }
        }
        for i in 0..count {
            let base = acc.offset() + i * stride;
            for c in 0..cols {
                for r in 0..rows {
                    let o = base + c * col_stride + r * cs;
                    values[i * components + c * rows + r] = decode(t, normalized, &bytes[o..o + cs]);
                }
            }
        }
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        if n > count {
            return Err(format!("{what}: sparse count {n} exceeds accessor count {count}"));
        }
        let idx_view = sparse.indices().view();
        let it = sparse.indices().index_type();
        let isz = match it {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let ioff = sparse.indices().offset();
        let idx_bytes = view_bytes(store, &idx_view, &what)?.to_vec();
        let need = n
            .checked_mul(isz)
            .and_then(|x| x.checked_add(ioff))
            .ok_or_else(|| format!("{what}: sparse index range overflows"))?;
        if need > idx_bytes.len() {
            return Err(format!("{what}: {n} sparse indices need {need} bytes, view has {}", idx_bytes.len()));
        }
        let val_view = sparse.values().view();
        let voff = sparse.values().offset();
        let val_bytes = view_bytes(store, &val_view, &what)?;
        let vneed = n
            .checked_mul(elem_size)
            .and_then(|x| x.checked_add(voff))
            .ok_or_else(|| format!("{what}: sparse value range overflows"))?;
        if vneed > val_bytes.len() {
            return Err(format!("{what}: {n} sparse values need {vneed} bytes, view has {}", val_bytes.len()));
        }
        let mut prev: Option<usize> = None;
        for k in 0..n {
            let o = ioff + k * isz;
            let ix = match isz {
                1 => idx_bytes[o] as usize,
                2 => u16::from_le_bytes([idx_bytes[o], idx_bytes[o + 1]]) as usize,
                _ => u32::from_le_bytes([idx_bytes[o], idx_bytes[o + 1], idx_bytes[o + 2], idx_bytes[o + 3]]) as usize,
            };
            if ix >= count || prev.is_some_and(|p| ix <= p) {
                return Err(format!("{what}: sparse index {ix} out of range or not increasing"));
            }
            prev = Some(ix);
            let base = voff + k * elem_size;
            for c in 0..cols {
                for r in 0..rows {
                    let o = base + c * col_stride + r * cs;
                    values[ix * components + c * rows + r] = decode(t, normalized, &val_bytes[o..o + cs]);
                }
            }
        }
    }
    Ok(AccessorData { values, components, count })
}

/// Checks that every value is finite.
pub(crate) fn check_finite(d: &AccessorData, what: &str) -> Result<(), String> {
    if let Some(i) = d.values.iter().position(|v| !v.is_finite()) {
        return Err(format!("{what}: element {} has a non-finite value {}", i / d.components.max(1), d.values[i]));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_roundtrip_known() {
        assert_eq!(decode_base64("TWFu").unwrap(), b"Man");
        assert_eq!(decode_base64("TWE=").unwrap(), b"Ma");
        assert_eq!(decode_base64("TQ==").unwrap(), b"M");
        assert_eq!(decode_base64("").unwrap(), b"");
        assert!(decode_base64("TW*u").is_err());
        assert!(decode_base64("TQ==TQ").is_err());
    }

    #[test]
    fn uri_helpers() {
        assert!(has_scheme("http://x/y.bin"));
        assert!(has_scheme("file:///y.bin"));
        assert!(has_scheme("/abs/y.bin"));
        assert!(!has_scheme("y.bin"));
        assert!(!has_scheme("sub/dir/y.bin"));
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("a%2"), "a%2");
    }
}
