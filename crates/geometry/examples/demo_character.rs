//! Writes the demo character (`bake-configs/assets/character.obj`), a union of capsules and
//! rounded boxes meshed by marching tetrahedra (`penumbra_geometry::procedural::character`).
//!
//! ```sh
//! cargo run -p penumbra-geometry --example demo_character > bake-configs/assets/character.obj
//! ```
//! A CLI test checks that the committed file equals this output.

use std::io::Write;

fn main() -> std::io::Result<()> {
    std::io::stdout().write_all(penumbra_geometry::procedural::demo_character_obj().as_bytes())
}
