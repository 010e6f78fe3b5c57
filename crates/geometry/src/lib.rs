//! # penumbra-geometry
//!
//! Geometry for the bakes: the triangle-mesh model and its validation, OBJ and glTF 2.0
//! import (with skins and animations), ray queries and closest points over a BVH, robust
//! inside tests for open meshes, and environment maps (lat-long and cube) with exact texel
//! solid angles.
//!
//! ## Units and conventions
//! - **Frame**: right-handed; directions and positions are in the input's world frame and
//!   units (glTF: +Y up, metres; OBJ: whatever the file uses). Nothing is rescaled or
//!   re-oriented on import.
//! - **Precision**: positions and all geometric computation in f64; environment-map texels
//!   in f32 (linear radiance, as stored in the file).
//! - **Triangles**: counter-clockwise is front (`(b − a) × (c − a)` is the outward normal of
//!   a closed, consistently oriented mesh); [`TriMesh::signed_volume`] is then positive.
//! - **glTF**: node transforms `T·R·S`, quaternions `[x, y, z, w]`, matrices column-major;
//!   the imported [`TriMesh`] is the world-space rest pose; see [`scene`] for skinning.
//! - **Lat-long maps**: OpenEXR orientation — row 0 is +Y, the centre column +Z, a quarter
//!   of the width +X; texel `(x, y)` has direction `(sin λ sin θ, cos θ, cos λ sin θ)` with
//!   `θ = π(y+½)/H`, `λ = π − 2π(x+½)/W`; see [`env`](mod@env) for the exact solid angles and how this
//!   relates to OpenEXR's pixel formula and to the R&H Grace Cathedral frame.
//! - **Cube maps**: faces +X, −X, +Y, −Y, +Z, −Z with OpenGL's orientation
//!   ([`CubeFace::direction`]); default face size [`env::DEFAULT_FACE_SIZE`] = 32.
//!
//! ## Errors and warnings
//! The library never prints. Failures are typed errors ([`MeshError`], [`EnvError`]) whose
//! `Display` names the file and the problem; recoverable oddities (dropped degenerate
//! triangles, skipped line primitives, renormalised skin weights, ...) are returned as data
//! ([`ImportReport`], [`EnvReport`]).
//!
//! ## Modules
//! - [`mesh`]: [`TriMesh`], bounds, area, volume, watertightness, cleaning.
//! - [`import`]: [`load_mesh`] (dispatch by extension), OBJ and glTF loaders; [`export`]: OBJ text.
//! - [`scene`]: node hierarchy, skins, animations, linear blend skinning ([`Scene::pose`]).
//! - [`bvh`]: [`MeshBvh`] (obvhs CWBVH + exact watertight f64 tests): closest hit, any hit,
//!   closest point; brute-force references.
//! - [`inside`]: generalized winding number, exact and fast ([`WindingNumber`]).
//! - [`procedural`]: icosphere, box, torus, grid, implicit surfaces, the demo character.
//! - [`voxel`]: [`SignedDistanceGrid`] (narrow-band exact signed distances on a grid) and the
//!   fast exact [`InsideOracle`]; triangle/box overlap.
//! - [`env`](mod@env): [`EnvMap`], [`CubeMap`], [`load_env_map`], procedural area-light maps.
//! - [`ball`]: minimum enclosing ball ([`min_enclosing_ball`]).
//! - [`demo_level`]: the demo glTF level of `penumbra plan` (`bake-configs/assets/demo-level.gltf`).

mod aabb_tree;
pub mod ball;
pub mod bvh;
#[cfg(test)]
mod bvh_tests;
pub mod demo_level;
pub mod env;
pub mod error;
pub mod export;
pub mod import;
pub mod inside;
mod kernels;
pub mod mesh;
pub mod packet;
pub mod procedural;
pub mod scene;
#[cfg(test)]
mod testutil;
pub mod texture;
pub mod voxel;

pub use ball::{Ball, min_enclosing_ball};
pub use bvh::{ClosestPoint, Hit, MeshBvh, PreparedDir, Ray, TraversalStack};
pub use env::{CubeFace, CubeMap, EnvMap, EnvReport, load_env_map};
pub use error::{EnvError, EnvErrorKind, EnvMapError, MeshError, MeshErrorKind, MeshValidationError};
pub use import::{ImportReport, external_files, load_mesh};
pub use inside::WindingNumber;
pub use mesh::{Aabb, TriMesh};
pub use packet::ParallelBvh;
pub use scene::Scene;
pub use voxel::{GridSpec, InsideOracle, SignedDistanceGrid, triangle_box_overlap};
