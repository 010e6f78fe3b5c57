//! penumbra-runtime: the reference runtime evaluation of penumbra assets — what an engine
//! ports. Depends on `penumbra-asset` only (checked in CI), f32, no allocation per query.
//!
//! Currently: [`ShTables`], a validated view of an `SHTB` tables asset with the lookups
//! and the SH exponential (HYB) the soft-shadow runtime needs.

mod error;
pub mod sh;
mod tables;

pub use error::RuntimeError;
pub use tables::{MAX_ORDER, ShTables};
