//! penumbra-math: the numerical ground floor shared by every baker.
//!
//! - [`sh`]: the real orthonormal SH basis and the index convention (write-once: every
//!   crate and the asset spec refer to it).
//! - [`quadrature`]: Gauss–Legendre and exact product rules on the sphere.
//! - [`rng`]: hash-based, counter-style randomness (same bytes for any thread count).
//! - [`linalg`]: small dense symmetric eigensolver, linear solve, least squares.
//! - [`warp`]: sampling warps (uniform sphere, cosine hemisphere, cones).
//! - [`ohlsh`]: quadratic SH → optimal hemispherical linear SH (MRT thesis App. B), shared by
//!   the SH tables bake and the MRT dictionary bake.

pub mod linalg;
pub mod ohlsh;
pub mod progress;
pub mod quadrature;
pub mod rng;
pub mod sh;
pub mod warp;
