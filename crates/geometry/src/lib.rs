//! penumbra-geometry (work in progress)

mod aabb_tree;
pub mod bvh;
#[cfg(test)]
mod bvh_tests;
pub mod env;
pub mod error;
pub mod import;
pub mod inside;
mod kernels;
pub mod mesh;
pub mod scene;
#[cfg(test)]
mod testutil;

pub use bvh::{ClosestPoint, Hit, MeshBvh, Ray};
pub use env::{CubeFace, CubeMap, EnvMap, EnvReport, load_env_map};
pub use error::{EnvError, EnvErrorKind, EnvMapError, MeshError, MeshErrorKind, MeshValidationError};
pub use import::{ImportReport, load_mesh};
pub use inside::WindingNumber;
pub use mesh::{Aabb, TriMesh};
pub use scene::Scene;
