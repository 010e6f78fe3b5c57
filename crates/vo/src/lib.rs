//! # penumbra-vo: volumetric-obscurance sample sets and their reference evaluator
//!
//! Volumetric obscurance (MRT thesis ch. 6) is the free fraction of a ball around a shaded
//! point, `V(P) = ∫_X ρ O(x) dx` with a constant ρ (§6.3), estimated in screen space by line,
//! area or point samples. This crate bakes what that needs offline and measures it:
//!
//! - [`voronoi`]: the thesis's discrete Voronoi diagrams (512² disk, 128³ ball by default),
//!   tree-accelerated but equal to the brute-force assignment;
//! - [`sets`]: the electrostatic 1/d⁴ sets with an adapted boundary charge, adaptive steps and
//!   Poisson starts (§6.3.5), and the Lloyd, Halton and Poisson baselines;
//! - [`quality`]: cell-measure CV and the estimator noise over random half-spaces (closed-form
//!   truth `(1 − h)²(2 + h)/4`);
//! - [`bake()`]: every (domain, centre, N) set, its weights, `log₂` area fractions and the
//!   comparison table; [`asset`]: the `VOSS` asset (schemas/asset-format.md);
//! - [`estimator`]: the line (§6.3.1), area (§6.3.2), thickness (§6.3.3) and normal-clamped
//!   (§6.3.4) estimators over depth buffers; [`reference`](mod@crate::reference): ray-cast depth buffers and the
//!   Monte-Carlo truths against the mesh (winding number) and against the height field.
//!
//! ## Domains and conventions
//! The disk is the unit sphere's orthographic projection under `dμ = 2√(1 − r²) dA` (each
//! point weighted by the sphere's z-extent, footnote 6); the ball has the volume measure.
//! Weights are cell measures normalised to sum 1; `log2area` is the unweighted area (volume)
//! fraction. Depth grows away from the camera; normals face the camera (`n_z < 0`). All
//! randomness is `hash4(seed, STAGE_VO, item, counter)`: bytes do not depend on threads.
//! Everything is computed in f64 and stored as f32. `docs/vo.md` has the measurements.

pub mod asset;
pub mod bake;
pub mod estimator;
pub mod quality;
pub mod reference;
pub mod sets;
pub mod voronoi;

pub use bake::{Comparison, Quality, SampleSet, VoBake, VoError, VoParams, bake};
pub use voronoi::Domain;
