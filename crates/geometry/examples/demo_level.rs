//! Writes the demo glTF level of `penumbra plan` (`bake-configs/assets/demo-level.gltf`):
//! three rooms of a corridor, clutter, a statue, a character and a lamp
//! (`penumbra_geometry::demo_level`).
//!
//! ```sh
//! cargo run -p penumbra-geometry --example demo_level > bake-configs/assets/demo-level.gltf
//! ```
//! A CLI test checks that the committed file equals this output.

use std::io::Write;

fn main() -> std::io::Result<()> {
    std::io::stdout().write_all(penumbra_geometry::demo_level::demo_level_gltf().as_bytes())
}
