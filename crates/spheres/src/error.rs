//! Errors of the sphere-set bake.

use crate::skin::SkinError;

/// Why a fit could not be made. `Display` says what is wrong and what is allowed; the CLI
/// adds the file name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpheresError {
    /// The mesh has no triangles left after cleaning.
    #[error("the mesh has no (non-degenerate) triangles")]
    EmptyMesh,
    /// All vertices coincide.
    #[error("the mesh's bounding box is a single point; there is nothing to bound")]
    DegenerateBounds,
    /// A parameter is out of range.
    #[error("{name} = {value} is out of range (allowed: {allowed})")]
    OutOfRange {
        /// Parameter name.
        name: &'static str,
        /// Given value.
        value: String,
        /// Allowed range.
        allowed: String,
    },
    /// More spheres requested than there are elements to cluster.
    #[error(
        "{count} spheres requested but the mesh discretises into only {elements} elements at --grid {grid}; ask for fewer spheres or a finer grid"
    )]
    TooManySpheres {
        /// Requested count.
        count: usize,
        /// Elements available.
        elements: usize,
        /// Grid resolution.
        grid: usize,
    },
    /// A target search on a mesh without volume (a flat or open sheet): E and the union
    /// ratio are ratios to V(T), which is zero.
    #[error(
        "the mesh encloses no volume (flat or open sheet), so {metric} (a ratio to the mesh volume) is undefined; fit a fixed --count instead"
    )]
    NoVolume {
        /// The metric the search would bisect on.
        metric: &'static str,
    },
    /// A base-colour texture could not be decoded.
    #[error("base-colour texture: {0}")]
    Texture(#[from] penumbra_geometry::texture::TextureError),
    /// Skinning failed.
    #[error("skinning: {0}")]
    Skin(#[from] SkinError),
    /// The asset could not be built or read.
    #[error("asset: {0}")]
    Asset(String),
}
