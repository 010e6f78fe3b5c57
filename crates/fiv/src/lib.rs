//! # penumbra-fiv: Fullsphere Irradiance Vector occlusion bake (FIV §3–4.2)
//!
//! A rigid occluder under a fixed, all-frequency environment gets its soft shadows from a
//! table of *fullsphere irradiance vectors* (FIVs): for a receiver at a sample position
//! around the occluder, the FIV of the environment part the occluder hides,
//! `Σ_{t occluded} L_t ω_t dΩ_t` (FIV eq. 9), per colour channel. At run time the
//! occluded irradiance of a receiver with normal `N` is `N · FIV` (eq. 10), subtracted from
//! the unoccluded irradiance looked up in a diffuse irradiance cube map (eq. 11).
//!
//! This crate bakes, per occluder:
//! - the diffuse irradiance cube map of the environment (exact convolution over every
//!   texel) and the environment's FIV ([`Lighting`]);
//! - the occluded-environment FIV at `A × P × K` sample positions on concentric shells
//!   around the occluder's minimum enclosing ball, with inside flags ([`layout`], [`bake()`]);
//! - the `FIVT` asset, in whole or in azimuth slabs (`--shard`), and the merge of slabs into
//!   the bytes a single run writes ([`asset`]);
//! - the brute-force references ([`reference`]);
//! - the GPU export: a KTX2 3D texture that trilinear filtering turns into the runtime's
//!   lookup ([`ktx2`]).
//!
//! The runtime side (trilinear lookup, partial occluders, overlap correction,
//! self-shadowing; FIV §4.3) is `penumbra_runtime::fiv`.
//!
//! ## Units and conventions
//! Positions in the mesh's units and world frame; directions in the world frame; radiance
//! linear RGB as in the environment map; FIVs and irradiance in radiance × steradian.
//! Environment: a cube map (OpenGL faces +X, −X, +Y, −Y, +Z, −Z; see
//! [`penumbra_geometry::CubeFace`]) with exact texel solid angles; lat-long inputs follow
//! OpenEXR's LatLong orientation and are resampled by solid-angle-weighted area averaging
//! ([`penumbra_geometry::CubeMap::from_latlong`]). Everything is computed in f64 and stored
//! as f32 (f16 for `fiv` with `--half`).

pub mod asset;
pub mod bake;
mod error;
mod interior;
pub mod ktx2;
pub mod layout;
pub mod lighting;
pub mod reference;
pub mod silhouette;

pub use asset::{FIVT_KIND_VERSION, FIVT_SECTIONS, FivMeta, Storage, merge, to_asset};
pub use bake::{BakeStats, Culling, FivBake, FivParams, FivTracer, Occluder, bake, bake_multi, bake_with};
pub use error::FivError;
pub use layout::{Frame, Shard, ShellLayout, UpAxis};
pub use lighting::Lighting;
