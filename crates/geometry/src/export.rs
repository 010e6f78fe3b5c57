//! Writing meshes: Wavefront OBJ text (1-based indices, shortest round-trip decimal floats, so
//! the same mesh always gives the same bytes and reads back exactly).

use std::fmt::Write;

use crate::mesh::TriMesh;

/// The mesh as OBJ text, with `comment` lines first (each prefixed by `# `).
pub fn obj_text(mesh: &TriMesh, comment: &str) -> String {
    let mut s = String::with_capacity(40 * (mesh.positions.len() + mesh.indices.len()));
    for line in comment.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in &mesh.indices {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::obj::load_obj_bytes;

    #[test]
    fn round_trips_exactly() {
        let m = crate::procedural::torus([0.0; 3], 1.0, 0.3, 12, 7);
        let text = obj_text(&m, "torus\nfor a test");
        assert!(text.starts_with("# torus\n# for a test\nv "));
        let (back, _) = load_obj_bytes(std::path::Path::new("t.obj"), text.as_bytes()).unwrap();
        // the loader may renumber vertices; every triangle's corners come back bit-exact
        assert_eq!(back.triangle_count(), m.triangle_count());
        for t in 0..m.triangle_count() {
            assert_eq!(back.triangle(t), m.triangle(t));
        }
    }
}
