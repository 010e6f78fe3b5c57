//! # penumbra-vo: volumetric-obscurance sample sets (MRT thesis ch. 6)
pub mod asset;
pub mod bake;
pub mod estimator;
pub mod quality;
pub mod reference;
pub mod sets;
pub mod voronoi;

pub use bake::{Comparison, Quality, SampleSet, VoBake, VoError, VoParams, bake};
pub use voronoi::Domain;
