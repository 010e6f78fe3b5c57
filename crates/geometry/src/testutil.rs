//! Procedural meshes for the unit tests (see [`crate::procedural`]).

pub use crate::procedural::{grid, icosphere};
