//! Typed errors. Every error that concerns a file names the file and the problem in its
//! `Display` text, so the CLI can print it as is (exit code 2).

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem found in an in-memory mesh (no file involved), see [`crate::TriMesh::validate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshValidationError {
    /// The mesh has no triangles at all.
    #[error("mesh has no triangles")]
    NoTriangles,
    /// A vertex position has a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition {
        /// Vertex index.
        vertex: usize,
        /// The offending position.
        position: [f64; 3],
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The offending vertex index.
        index: u32,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// More vertices than a `u32` index can address.
    #[error("{0} vertices exceed the u32 index range")]
    TooManyVertices(usize),
}

/// What went wrong while loading a mesh; wrapped in [`MeshError`] together with the path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshErrorKind {
    /// The file could not be read.
    #[error("cannot read file: {0}")]
    Io(#[from] std::io::Error),
    /// The extension is not one of the supported mesh formats.
    #[error("unsupported mesh format {0:?} (supported: .obj, .gltf, .glb)")]
    UnsupportedFormat(String),
    /// A syntax or content problem at a known line of a text file (OBJ).
    #[error("line {line}: {message}")]
    Line {
        /// 1-based line number.
        line: usize,
        /// What is wrong on that line.
        message: String,
    },
    /// The file parsed but holds no usable triangle.
    #[error("no triangles: {0}")]
    NoTriangles(String),
    /// glTF: the container or JSON document is malformed (includes truncated GLB files).
    #[error("malformed glTF: {0}")]
    Gltf(String),
    /// glTF: an accessor, buffer view or buffer is inconsistent (out of bounds, wrong type, ...).
    #[error("{0}")]
    GltfData(String),
    /// The resulting mesh failed validation.
    #[error("{0}")]
    Invalid(#[from] MeshValidationError),
    /// Error reported by the OBJ parser (tobj) that the pre-validation did not catch.
    #[error("OBJ parser: {0}")]
    Obj(String),
}

/// A mesh file could not be loaded. `Display`: `"<path>: <problem>"`.
#[derive(Debug)]
pub struct MeshError {
    /// The file that failed.
    pub path: PathBuf,
    /// What went wrong.
    pub kind: MeshErrorKind,
}

impl MeshError {
    /// Builds an error for `path`.
    pub fn new(path: &Path, kind: impl Into<MeshErrorKind>) -> Self {
        Self { path: path.to_path_buf(), kind: kind.into() }
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.kind)
    }
}

impl std::error::Error for MeshError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            MeshErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

/// What went wrong while loading an environment map; wrapped in [`EnvError`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EnvErrorKind {
    /// The file could not be read.
    #[error("cannot read file: {0}")]
    Io(#[from] std::io::Error),
    /// The extension is not a supported environment-map format.
    #[error("unsupported environment map format {0:?} (supported: .exr, .hdr)")]
    UnsupportedFormat(String),
    /// The decoder rejected the file (damaged, truncated, unsupported compression, ...).
    #[error("cannot decode: {0}")]
    Decode(String),
    /// The image has no usable RGB (or luminance) channels.
    #[error("{0}")]
    Channels(String),
    /// A texel is NaN or infinite.
    #[error("non-finite texel value {value} in channel {channel} at pixel (x={x}, y={y})")]
    NonFinite {
        /// Column.
        x: usize,
        /// Row (0 = top).
        y: usize,
        /// Channel name.
        channel: &'static str,
        /// The value (NaN or ±inf).
        value: f32,
    },
    /// A texel is negative (radiance cannot be).
    #[error("negative texel value {value} in channel {channel} at pixel (x={x}, y={y})")]
    Negative {
        /// Column.
        x: usize,
        /// Row (0 = top).
        y: usize,
        /// Channel name.
        channel: &'static str,
        /// The value.
        value: f32,
    },
    /// Width/height unusable for a lat-long map.
    #[error("{0}")]
    Dimensions(String),
}

/// An environment map could not be loaded. `Display`: `"<path>: <problem>"`.
#[derive(Debug)]
pub struct EnvError {
    /// The file that failed.
    pub path: PathBuf,
    /// What went wrong.
    pub kind: EnvErrorKind,
}

impl EnvError {
    /// Builds an error for `path`.
    pub fn new(path: &Path, kind: impl Into<EnvErrorKind>) -> Self {
        Self { path: path.to_path_buf(), kind: kind.into() }
    }
}

impl fmt::Display for EnvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.kind)
    }
}

impl std::error::Error for EnvError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            EnvErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

/// Errors of in-memory environment-map construction (no file involved).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EnvMapError {
    /// `data.len()` does not match `width * height`.
    #[error("expected {expected} texels for {width}x{height}, got {got}")]
    SizeMismatch {
        /// Width in texels.
        width: usize,
        /// Height in texels.
        height: usize,
        /// `width * height`.
        expected: usize,
        /// Texels supplied.
        got: usize,
    },
    /// Zero width or height.
    #[error("empty map ({width}x{height})")]
    Empty {
        /// Width in texels.
        width: usize,
        /// Height in texels.
        height: usize,
    },
    /// A texel is NaN or infinite.
    #[error("texel {index} is not finite: {value:?}")]
    NonFinite {
        /// Linear texel index.
        index: usize,
        /// The offending RGB value.
        value: [f32; 3],
    },
}
