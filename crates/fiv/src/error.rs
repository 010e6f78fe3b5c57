//! Errors of the FIV bake, its asset and its merge.

/// Why a FIV bake, asset read or merge failed. Messages name the value and the allowed range.
#[derive(Debug, thiserror::Error)]
pub enum FivError {
    /// Sample counts or radii out of range.
    #[error("--samples/--r-min/--r-max: {0}")]
    Layout(String),
    /// Bad `--shard`.
    #[error("--shard: {0}")]
    Shard(String),
    /// Another parameter out of range.
    #[error("{0}")]
    Parameter(String),
    /// The occluder mesh cannot be used.
    #[error("occluder mesh: {0}")]
    Mesh(String),
    /// A value does not fit the f16 range of `--half`.
    #[error("--half: FIV value {value} does not fit in f16 (largest finite 65504); bake without --half")]
    HalfOverflow {
        /// The offending value.
        value: f64,
    },
    /// The asset is not a FIVT asset this crate can read.
    #[error("{0}")]
    Asset(String),
    /// Shards that cannot be merged.
    #[error("merge: {0}")]
    Merge(String),
}
