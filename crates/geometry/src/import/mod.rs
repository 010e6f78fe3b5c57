//! Mesh import: OBJ (tobj) and glTF 2.0 (`.gltf`, `.glb`), dispatched by extension.
//!
//! Every loader validates what it reads (finite positions, index ranges, accessor bounds,
//! skin weights), drops degenerate triangles and counts them in an [`ImportReport`]; it never
//! prints and never panics on malformed input.

pub mod gltf;
mod gltf_data;
pub mod obj;

use std::path::Path;

use crate::error::{MeshError, MeshErrorKind};
use crate::mesh::CleanReport;
use crate::scene::Scene;

/// Warnings and counts of an import, returned as data (libraries never print).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ImportReport {
    /// Triangles produced by triangulation, before cleaning.
    pub source_triangles: usize,
    /// What cleaning dropped (repeated indices, zero area, duplicates).
    pub clean: CleanReport,
    /// OBJ: faces with fewer than 3 vertices and `l`/`p` elements; glTF: point and line
    /// primitives.
    pub skipped_elements: usize,
    /// OBJ: `v` lines in the file.
    pub vertices_in_file: usize,
    /// glTF: triangle strip and fan primitives converted to triangle lists.
    pub converted_strips_fans: usize,
    /// glTF: vertices whose skin weights did not sum to 1 (within 1e-3) or had more than four
    /// influences, and were renormalised / reduced to the four largest.
    pub renormalized_weights: usize,
    /// Other notes (ignored morph targets, missing scenes, ...), one sentence each.
    pub warnings: Vec<String>,
}

impl ImportReport {
    /// Triangles dropped as degenerate or duplicate.
    pub fn dropped_triangles(&self) -> usize {
        self.clean.dropped()
    }
}

/// Mesh formats recognised by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ.
    Obj,
    /// glTF 2.0 JSON (`.gltf`) or binary (`.glb`).
    Gltf,
}

/// The format of `path` from its extension (case-insensitive), or the unsupported-format error.
pub fn mesh_format(path: &Path) -> Result<MeshFormat, MeshError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "obj" => Ok(MeshFormat::Obj),
        "gltf" | "glb" => Ok(MeshFormat::Gltf),
        _ => Err(MeshError::new(
            path,
            MeshErrorKind::UnsupportedFormat(if ext.is_empty() { "(no extension)".into() } else { format!(".{ext}") }),
        )),
    }
}

/// Loads a mesh file, dispatching on the extension: `.obj`, `.gltf`, `.glb`. Anything else
/// (PLY, STL, OFF, ...) is an "unsupported mesh format" error.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<(Scene, ImportReport), MeshError> {
    let path = path.as_ref();
    match mesh_format(path)? {
        MeshFormat::Obj => {
            let (mesh, report) = obj::load_obj(path)?;
            Ok((Scene { mesh, ..Scene::default() }, report))
        }
        MeshFormat::Gltf => gltf::load_gltf(path),
    }
}

/// The files besides `path` that [`load_mesh`] reads (see [`gltf::external_files`]); none for
/// OBJ, whose material libraries are never read. A content hash of a mesh input must cover
/// these too, or an edited `.bin` or texture would not change it.
pub fn external_files(path: impl AsRef<Path>) -> Result<Vec<(String, std::path::PathBuf)>, MeshError> {
    let path = path.as_ref();
    match mesh_format(path)? {
        MeshFormat::Obj => Ok(Vec::new()),
        MeshFormat::Gltf => gltf::external_files(path),
    }
}
