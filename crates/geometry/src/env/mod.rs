//! Environment maps: lat-long and cube maps of linear RGB radiance, with exact texel solid
//! angles, and loading from OpenEXR (exr crate) and Radiance `.hdr` (image crate).
//!
//! # Lat-long mapping (OpenEXR `LatLong` orientation)
//! A `W × H` map, row 0 at the top. Texel `(x, y)` covers
//! - polar angle (from +Y) `θ ∈ [πy/H, π(y+1)/H]`, centre `θ = π(y + ½)/H`;
//! - longitude `λ = π − 2πu` for `u ∈ [x/W, (x+1)/W]`, centre `u = (x + ½)/W`;
//!
//! and its direction is `(sin λ · sin θ, cos θ, cos λ · sin θ)`. So row 0 is +Y (up), the
//! centre column (`u = ½`, `λ = 0`) is +Z, a quarter of the width (`u = ¼`, `λ = π/2`) is +X,
//! three quarters is −X, and the left/right edges are −Z. Its exact solid angle is
//! `(2π/W)·(cos θ₀ − cos θ₁)`; the texels sum to 4π.
//!
//! This is OpenEXR's orientation (`ImfEnvmap.h`: "pixel (dataWindow.min) has latitude +π/2 and
//! longitude +π; latitude +π/2 is +y; latitude 0, longitude 0 is +z; longitude π/2 is +x",
//! direction `(sin λ cos φ, sin φ, cos λ cos φ)` with latitude `φ = π/2 − θ`). OpenEXR's own
//! pixel-position formula puts the *centres* of the first and last rows and columns on the
//! poles and the seam (`u = x/(W−1)`, `v = y/(H−1)`); here the *edges* of the image are the
//! poles and the seam (`u = (x+½)/W`), which makes every column the same width, the texels a
//! partition of the sphere, and matches how equirectangular HDRIs (Poly Haven, pbrt, the
//! Radiance probes) are produced. The two differ by at most half a texel (0.18° at 1024×512),
//! and the orientation test on `OrientationLatLong.exr` (axis markers) passes with both.
//!
//! ## Relation to `grace_rh2001_sh9.json`
//! The check recorded there maps pixel `(i = row, j = column)` of `grace_latlong.exr` to
//! `θ = π(i+½)/512`, `φ = 2π(j+½)/1024`, `d_RH = (−sin θ sin φ, −cos θ, −sin θ cos φ)` in
//! Ramamoorthi & Hanrahan's frame. Ours gives the same pixel `d = (sin φ sin θ, cos θ,
//! −cos φ sin θ)` (since `λ = π − φ`), so `d_RH = (−d.x, −d.y, d.z)`: a 180° rotation about Z.
//! In our (OpenEXR) frame the stored probe is upside down — the cathedral's up (R&H +y) is
//! our −Y — exactly as the JSON says. Bakes use the map in our frame; to compare with the
//! R&H table, rotate directions by 180° about Z (the tests do, and reproduce the table).
//!
//! # Cube maps
//! See [`CubeFace::direction`] for the OpenGL face orientation, [`CubeMap::texel_solid_angle`]
//! for the exact solid angles, and [`CubeMap::from_latlong`] for the resampling.

mod cube;
mod latlong;
mod load;
pub mod procedural;
mod rotate;

pub use cube::{
    CubeFace, CubeMap, DEFAULT_FACE_SIZE, DEFAULT_GAUSS_POINTS, face_rect_solid_angle,
    texel_solid_angle as cube_texel_solid_angle,
};
pub use latlong::{EnvMap, texel_direction, texel_solid_angle};
pub use load::{EnvmapAttribute, load_env_map};
pub use rotate::Rotation;

/// Facts and warnings of an environment-map load, returned as data.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnvReport {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// The OpenEXR `envmap` attribute, if the file has one.
    pub envmap: Option<EnvmapAttribute>,
    /// Negative channel values set to 0.
    pub negative_texels_clamped: usize,
    /// Other notes (e.g. not 2:1).
    pub warnings: Vec<String>,
}
