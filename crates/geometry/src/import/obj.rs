//! Wavefront OBJ import through tobj.
//!
//! tobj neither reports line numbers nor rejects everything it should (it accepts `nan`
//! coordinates, and fails on an empty `f` line that other loaders skip), so a pre-pass here
//! parses every `v` and `f` line first and reports problems with their line number:
//! unparsable or non-finite coordinates, index `0`, indices (absolute or relative) outside
//! the vertices. It then hands tobj a sanitised copy of the geometry: `v` lines, `f` lines
//! with absolute position indices only, and `o`/`g` lines. Faces with fewer than three
//! vertices, `l` and `p` elements are skipped and counted; texture coordinates, normals and
//! materials are not needed by any bake and are dropped. tobj triangulates polygons (as a
//! fan) and splits the file into models; all models and groups are merged into one mesh.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{MeshError, MeshErrorKind};
use crate::import::ImportReport;
use crate::mesh::TriMesh;

/// Loads an OBJ file from disk (see the module docs).
pub fn load_obj(path: &Path) -> Result<(TriMesh, ImportReport), MeshError> {
    let bytes = std::fs::read(path).map_err(|e| MeshError::new(path, e))?;
    load_obj_bytes(path, &bytes)
}

/// Loads OBJ text already in memory; `path` is only used in error messages.
pub fn load_obj_bytes(path: &Path, bytes: &[u8]) -> Result<(TriMesh, ImportReport), MeshError> {
    let text = String::from_utf8_lossy(bytes);
    let (sanitised, mut report) = prepass(&text).map_err(|kind| MeshError::new(path, kind))?;
    let opts = tobj::LoadOptions { single_index: false, triangulate: true, ignore_points: true, ignore_lines: true };
    let mut reader = std::io::BufReader::new(sanitised.as_bytes());
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &opts, |_| Ok((Vec::new(), Default::default())))
        .map_err(|e| MeshError::new(path, MeshErrorKind::Obj(e.to_string())))?;
    let mut mesh = TriMesh::default();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        if m.positions.len() % 3 != 0 || m.indices.len() % 3 != 0 {
            return Err(MeshError::new(
                path,
                MeshErrorKind::Obj(format!("model {:?}: position or index count not a multiple of 3", model.name)),
            ));
        }
        mesh.positions.extend(m.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        for t in m.indices.chunks_exact(3) {
            mesh.indices.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    report.source_triangles = mesh.indices.len();
    if mesh.indices.is_empty() {
        let what = if report.vertices_in_file == 0 {
            "the file has no vertices and no faces".to_string()
        } else {
            format!(
                "{} vertices but no face with three or more vertices ({} skipped)",
                report.vertices_in_file, report.skipped_elements
            )
        };
        return Err(MeshError::new(path, MeshErrorKind::NoTriangles(what)));
    }
    mesh.validate().map_err(|e| MeshError::new(path, e))?;
    let (clean, cr) = mesh.clean();
    report.clean = cr;
    if clean.indices.is_empty() {
        return Err(MeshError::new(
            path,
            MeshErrorKind::NoTriangles(format!("all {} triangles are degenerate", report.source_triangles)),
        ));
    }
    Ok((clean, report))
}

/// A logical line: backslash continuations joined; `line` is the first physical line (1-based).
fn logical_lines(text: &str) -> impl Iterator<Item = (usize, String)> + '_ {
    let mut phys = text.lines().enumerate();
    std::iter::from_fn(move || {
        let (i, first) = phys.next()?;
        let mut s = first.trim_end().to_string();
        while s.ends_with('\\') {
            s.pop();
            match phys.next() {
                Some((_, next)) => {
                    s.push(' ');
                    s.push_str(next.trim_end());
                }
                None => break,
            }
        }
        Some((i + 1, s))
    })
}

/// Drops a `#` comment; `#` only starts a comment at the start of a token, so MSVC spellings
/// such as `1.#IND` reach the number parser (and are rejected there with a clear message).
fn strip_comment(l: &str) -> &str {
    let b = l.as_bytes();
    for (i, &c) in b.iter().enumerate() {
        if c == b'#' && (i == 0 || b[i - 1].is_ascii_whitespace()) {
            return &l[..i];
        }
    }
    l
}

fn line_err(line: usize, message: String) -> MeshErrorKind {
    MeshErrorKind::Line { line, message }
}

/// Validates the geometry lines and writes the sanitised text for tobj.
fn prepass(text: &str) -> Result<(String, ImportReport), MeshErrorKind> {
    let mut report = ImportReport::default();
    // first pass: number of vertices (positive indices may refer forward)
    let total_vertices = logical_lines(text).filter(|(_, l)| l.split_whitespace().next() == Some("v")).count();
    report.vertices_in_file = total_vertices;
    let mut out = String::with_capacity(text.len());
    let mut seen_vertices = 0usize;
    let mut face = Vec::<usize>::new();
    for (line, l) in logical_lines(text) {
        let content = strip_comment(&l);
        let mut tok = content.split_whitespace();
        let Some(keyword) = tok.next() else { continue };
        match keyword {
            "v" => {
                let mut xyz = [0.0f64; 3];
                for (k, c) in xyz.iter_mut().enumerate() {
                    let t =
                        tok.next().ok_or_else(|| line_err(line, format!("vertex has {k} coordinates, expected 3")))?;
                    let v: f64 = t.parse().map_err(|_| line_err(line, format!("invalid vertex coordinate {t:?}")))?;
                    if !v.is_finite() {
                        return Err(line_err(
                            line,
                            format!("non-finite vertex coordinate {t:?} (NaN/Inf positions are not allowed)"),
                        ));
                    }
                    *c = v;
                }
                seen_vertices += 1;
                // write the parsed values back (round-trip exact), not the original text
                let _ = writeln!(out, "v {:?} {:?} {:?}", xyz[0], xyz[1], xyz[2]);
            }
            "f" => {
                face.clear();
                for t in tok {
                    let first = t.split('/').next().unwrap_or("");
                    let idx: i64 = first.parse().map_err(|_| line_err(line, format!("invalid face vertex {t:?}")))?;
                    let abs = if idx > 0 {
                        let a = (idx - 1) as u64;
                        if a >= total_vertices as u64 {
                            return Err(line_err(
                                line,
                                format!("face index {idx} out of range (the file has {total_vertices} vertices)"),
                            ));
                        }
                        a as usize
                    } else if idx < 0 {
                        let back = idx.unsigned_abs();
                        if back > seen_vertices as u64 {
                            return Err(line_err(
                                line,
                                format!(
                                    "relative face index {idx} points before the first vertex ({seen_vertices} vertices defined so far)"
                                ),
                            ));
                        }
                        seen_vertices - back as usize
                    } else {
                        return Err(line_err(line, "face index 0 is invalid (OBJ indices start at 1)".to_string()));
                    };
                    face.push(abs);
                }
                if face.len() < 3 {
                    report.skipped_elements += 1;
                    continue;
                }
                out.push('f');
                for &i in &face {
                    let _ = write!(out, " {}", i + 1);
                }
                out.push('\n');
            }
            "l" | "p" => report.skipped_elements += 1,
            "o" | "g" => {
                out.push_str(content.trim());
                out.push('\n');
            }
            _ => {}
        }
    }
    Ok((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<(TriMesh, ImportReport), MeshError> {
        load_obj_bytes(Path::new("mem.obj"), text.as_bytes())
    }

    #[test]
    fn quad_and_relative_indices() {
        let (m, r) = load("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n").unwrap();
        assert_eq!(m.indices.len(), 2);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(r.source_triangles, 2);
        assert!((m.area() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn groups_are_merged_and_extras_ignored() {
        let text = "mtllib nothing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\n\
                    g a\nusemtl x\nf 1/1/1 2/1/1 3/1/1\ng b\nf 1//1 2//1 4//1\nl 1 2\nf 1 2\n";
        let (m, r) = load(text).unwrap();
        assert_eq!(m.indices.len(), 2);
        assert_eq!(r.skipped_elements, 2);
    }

    #[test]
    fn errors_name_the_line() {
        let e = load("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
        assert!(e.to_string().contains("non-finite"), "{e}");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert!(e.to_string().contains("line 4: face index 4 out of range"), "{e}");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err();
        assert!(e.to_string().contains("index 0 is invalid"), "{e}");
        let e = load("f -4 -3 -2\n").unwrap_err();
        assert!(e.to_string().contains("relative face index -4"), "{e}");
        let e = load("v 1.#IND 0 0\n").unwrap_err();
        assert!(e.to_string().contains("invalid vertex coordinate"), "{e}");
        let e = load("# nothing\n").unwrap_err();
        assert!(e.to_string().contains("no triangles"), "{e}");
        assert!(e.to_string().starts_with("mem.obj: "), "{e}");
    }

    #[test]
    fn degenerate_triangles_are_counted() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 2\n";
        let (m, r) = load(text).unwrap();
        assert_eq!(m.indices.len(), 1);
        assert_eq!(r.clean.dropped_zero_area, 1);
        assert_eq!(r.clean.dropped_repeated_index, 1);
    }

    #[test]
    fn continuation_lines() {
        let (m, _) = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n 2 3\n").unwrap();
        assert_eq!(m.indices.len(), 1);
    }
}
