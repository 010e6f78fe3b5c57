//! penumbra-sh: SH products, the triple-product tensor, SH exponential and logarithm, and
//! the SH tables bake (`penumbra tables`).
//!
//! SH convention: see [`penumbra_math::sh`]. All bake math is f64.

pub mod eta;
pub mod exp;
pub mod gamma;
pub mod indirect;
pub mod local_light;
pub mod log;
/// The quadratic-SH → OHLSH map lives in `penumbra-math` (shared with the MRT bake).
pub use penumbra_math::ohlsh;
pub mod ol;
pub mod proxy_knots;
pub mod reference;
pub mod tables;
pub mod tables_asset;
pub mod zonal;
