//! penumbra-runtime: the reference runtime evaluation of penumbra assets — what an engine
//! ports. Depends on `penumbra-asset` only (checked in CI), f32, no allocation per query.
//!
//! - [`ShTables`]: a validated view of an `SHTB` tables asset (lookups, SH products, SH
//!   exponentials HYB/OL/PS*-p).
//! - [`shadows`]: soft shadows from sphere proxies at a receiver (log accumulation,
//!   self-shadow replacement rules, exponentiation, windowed diffuse shading, indirect light
//!   from proxies, hierarchy cuts with ratio vectors, receiver batches).
//! - [`SphereSet`]: a validated view of an `SPHR` sphere-proxy asset (leaves, hierarchy, skin)
//!   and its cut for a receiver cluster (SHEXP §6.3, eq. 36); [`PosedSpheres`]: the set in
//!   an animation pose from its skin influences, hierarchy refitted (SHEXP §6.2–6.3).
//! - [`fiv`]: soft shadows from FIV occlusion tables (`FIVT`): irradiance cube lookup,
//!   trilinear FIV lookup with inside flags, partial occluders, overlap correction,
//!   self-shadowing (FIV §4.3).
//! - [`mrt`]: Modular Radiance Transfer: indirect light of a level of dictionary blocks from
//!   direct light at their texels (`MRTD` + `MRTL`), one or many bounces, padded atlas.

pub mod drt;
pub mod drt_vec;
mod error;
pub mod fiv;
pub mod mrt;
pub mod mrt_vec;
mod proxy_knots;
pub mod sh;
pub mod shadows;
pub mod sphere_pose;
pub mod sphere_set;
mod tables;

pub use error::RuntimeError;
pub use sphere_pose::PosedSpheres;
pub use sphere_set::{NodeRef, SphereSet, SphereTree};
pub use tables::{CUBIC_MIN_ORDER, LOCAL_LIGHT_PHI, LOCAL_LIGHT_THETA, MAX_ORDER, NEAR_CONTACT_ALPHA, ShTables};
