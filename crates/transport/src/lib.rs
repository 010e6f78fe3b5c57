//! penumbra-transport: Modular Radiance Transfer (Loos 2015, "MRT thesis").
//!
//! The dictionary bake (`penumbra mrt dict`, ch. 3–4, App. A–B), one concept per module:
//! - [`shape`]: the cube dictionary (§3.5.1), texel layout, analytic ray queries.
//! - [`prior`]: the direct-light prior samples (§4.1.1) with wall shadowing.
//! - [`gather`]: the one-bounce operator `F` by ray gathers, SH gathers of implicit lights.
//! - [`balance`]: exact energy balance of `F` (row and column sums = ρ × wall fraction).
//! - [`svd`]: faer SVDs (canonical, deterministic) and products.
//! - [`operators`]: `P`, `S`, `M`, `U_b`, `T_d→b`, `L_imp` (§3.3) and enrichment (App. A).
//! - [`reference`]: the brute-force ground truth (path tracer, exact form factors).
//! - [`dict`]: the bake driver and its measurements; [`asset`]: the `MRTD` writer.
//!
//! Interfaces (§3.4.1, §4.2, `penumbra mrt dict`):
//! - [`lightfield`]: interface frames, the lightfield grid and its continuous lookups.
//! - [`sparse`]: row-compressed resampling operators.
//! - [`interface`]: `H_lf`, `H_rlf` with enrichment, `R_b→rlf`, `R_↑/←/→`, `U_r`, `T_rlf→r`.
//!
//! Delta Radiance Transfer (ch. 5, `penumbra drt`):
//! - [`clutter`]: clutter instances (boxes, meshes), their texels, charts and ray queries.
//! - [`drt`]: `ΔU_b`, `ΔU_c`, `C_b` against the dictionary's `L_imp`, inpainting, neighbourhood.
//! - [`drt_asset`]: the `DRTO` writer; [`drt_reference`]: the path tracer with clutter;
//!   [`drt_examples`]: the built-in scenes (pillars, Cornell box, maze with boxes).
//!
//! All bake math is f64; linear algebra runs `Par::Seq` inside a decomposition and rayon
//! across independent work, so the output bytes do not depend on the thread count.

pub mod asset;
pub mod balance;
pub mod clutter;
pub mod dict;
pub mod drt;
pub mod drt_asset;
pub mod drt_examples;
pub mod drt_reference;
pub mod drt_state;
pub mod drt_vector;
pub(crate) mod drt_walk;
pub mod gather;
pub mod interface;
pub mod level;
pub mod level_ops;
pub mod level_reference;
pub mod lightfield;
pub mod operators;
pub mod prior;
pub mod reference;
pub mod shape;
pub mod sparse;
pub mod svd;
pub mod warp;

/// Errors of the transport bakes.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// A parameter is out of range (the message names it and the allowed range).
    #[error("{0}")]
    Param(String),
    /// A decomposition failed to converge.
    #[error("SVD did not converge ({0})")]
    Svd(String),
    /// The asset could not be built.
    #[error("cannot build the MRTD asset: {0}")]
    Asset(String),
    /// An input asset (a dictionary read back by the level bake) is unusable.
    #[error("{0}")]
    Input(String),
    /// Shard assets that do not merge (different bakes, missing or repeated shards).
    #[error("cannot merge: {0}")]
    Merge(String),
}
