//! penumbra-runtime: the reference runtime evaluation of penumbra assets — what an engine
//! ports. Depends on `penumbra-asset` only (checked in CI), f32, no allocation per query.
//!
//! - [`ShTables`]: a validated view of an `SHTB` tables asset (lookups, SH products, SH
//!   exponentials HYB/OL/PS*-p).
//! - [`shadows`]: soft shadows from sphere proxies at a receiver (log accumulation,
//!   self-shadow replacement rules, exponentiation, windowed diffuse shading).
//! - [`mrt`]: Modular Radiance Transfer: indirect light of a level of dictionary blocks from
//!   direct light at their texels (`MRTD` + `MRTL`), one or many bounces, padded atlas.

mod error;
pub mod mrt;
pub mod sh;
pub mod shadows;
mod tables;

pub use error::RuntimeError;
pub use tables::{MAX_ORDER, ShTables};
