//! # penumbra-spheres: bounding sphere sets for sphere-proxy soft shadows
//!
//! `penumbra spheres` fits a set of spheres that *bounds* a mesh while wasting as little volume
//! outside it as possible — SHEXP §6.2's variational sphere sets — and optionally builds the
//! sphere hierarchy of §6.3 and the per-sphere bone weights that let the set follow a skinned
//! character.
//!
//! - [`fit::fit`]: the whole bake (import is the CLI's job): canonical frame, signed-distance
//!   grid, samples, the Lloyd fit ([`lloyd`], from medial-axis seeds) and its union-aware
//!   refinement ([`refine`]), the evenly spaced candidate ([`cvt`], kept when its union is
//!   smaller), optionally the union polish ([`polish`]), or the octree
//!   baseline ([`octree`]), f32 rounding that keeps the
//!   set bounding, [`hierarchy`], [`skin`], and the [`metrics`]. Target searches
//!   (`Target::Error`, `Target::Union`) bisect to the smallest requested count that meets them.
//! - [`albedo`]: per-sphere albedo from the glTF materials of the surface each sphere
//!   stands for (IBPA §5's diffuse proxies).
//! - [`asset`]: the `SPHR` asset (sections in `schemas/asset-format.md`).
//! - [`reference`]: ray-traced shadow references (mesh truth, sphere truth) for
//!   `penumbra verify shadows`.
//!
//! Units and frame: spheres are in the input's units and frame (glTF: metres, +Y up). The fit
//! itself runs in a canonical frame ([`frame`]) so that it is scale-invariant.

pub mod albedo;
pub mod asset;
pub mod cvt;
pub mod error;
pub mod fit;
pub mod frame;
pub mod hierarchy;
pub mod lloyd;
pub mod metrics;
pub mod octree;
pub mod polish;
pub mod powell;
pub mod reference;
pub mod refine;
pub mod samples;
pub mod skin;
pub mod sphere;
pub mod volume;

pub use error::SpheresError;
pub use fit::{FitParams, FitResult, Method, Target, fit};
pub use sphere::Sphere;
