//! WGSL twins of `penumbra-runtime`'s evaluators and a wgpu harness that runs them (issue #20).
//!
//! The shaders (`shaders/*.wgsl`, f32 only, one file per evaluator) are the product: engines
//! take them as they are, or as the SPIR-V, HLSL, GLSL and MSL that [`export`] translates them
//! to with naga. The harness uploads an asset's sections as buffers, dispatches the shader and
//! reads the result back, so `penumbra verify gpu` can compare it with the CPU runtime on the
//! same inputs. A software Vulkan device (Mesa's lavapipe) is enough: timings there are
//! correctness-only (it runs the shader on the CPU).
//!
//! Layering: depends on `penumbra-asset`, `penumbra-runtime` (the buffers are built from the
//! runtime's validated views) and wgpu/naga; nothing depends on it but the CLI.

mod device;
pub mod export;
pub mod mrt;

pub use device::{Gpu, INSTALL_HINT};

/// Errors of the harness.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter (no Vulkan/Metal/DX12 driver).
    #[error("no GPU adapter ({0}); {hint}", hint = INSTALL_HINT)]
    NoAdapter(String),
    /// The device failed (request, submission, readback).
    #[error("GPU device: {0}")]
    Device(String),
    /// An input of the wrong length.
    #[error("{what}: {got} values, expected {want}")]
    Size {
        /// Which input.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The expected length.
        want: usize,
    },
    /// An asset feature the shaders do not evaluate yet.
    #[error("not supported by the GPU shaders yet: {0}")]
    Unsupported(String),
    /// A shader that naga rejects (a bug: every shipped shader is validated by the tests).
    #[error("shader {name}: {message}")]
    Shader {
        /// The shader file.
        name: String,
        /// naga's message.
        message: String,
    },
}

/// One shader file: its name (the file stem), WGSL source and compute entry points.
#[derive(Debug, Clone, Copy)]
pub struct Shader {
    /// File stem (`mrt`).
    pub name: &'static str,
    /// WGSL source.
    pub source: &'static str,
    /// Compute entry points, in dispatch order.
    pub entry_points: &'static [&'static str],
}

/// Every shader this crate ships.
pub const SHADERS: &[Shader] = &[Shader { name: "mrt", source: mrt::SOURCE, entry_points: mrt::ENTRY_POINTS }];

/// How far a GPU result is from the CPU runtime's: the largest `|g − c| / max(|c|, floor)`
/// with `floor = FLOOR_FRACTION · max |c|` (so outputs near zero are compared on the scale of
/// the largest output instead of their own), and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diff {
    /// The largest relative difference.
    pub max_rel: f64,
    /// Its index.
    pub at: usize,
    /// The floor used.
    pub floor: f64,
}

/// The near-zero floor of [`compare`], as a fraction of the largest CPU value.
pub const FLOOR_FRACTION: f64 = 1e-3;

/// [`Diff`] of `gpu` against `cpu` (equal lengths; a NaN anywhere gives an infinite difference).
pub fn compare(gpu: &[f32], cpu: &[f32]) -> Diff {
    let peak = cpu.iter().fold(0.0f64, |m, &c| m.max(f64::from(c).abs()));
    let floor = (FLOOR_FRACTION * peak).max(f64::MIN_POSITIVE);
    let mut d = Diff { max_rel: if gpu.len() == cpu.len() { 0.0 } else { f64::INFINITY }, at: 0, floor };
    for (i, (&g, &c)) in gpu.iter().zip(cpu).enumerate() {
        let e = (f64::from(g) - f64::from(c)).abs() / f64::from(c).abs().max(floor);
        let e = if e.is_nan() { f64::INFINITY } else { e };
        if e > d.max_rel {
            d = Diff { max_rel: e, at: i, floor };
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_uses_the_floor_near_zero_and_flags_nan() {
        // 1e-6 off a value of 1e-9 is far beyond 1e-4 of itself, but within 1e-3 of the peak
        let d = compare(&[1.0, 1.0e-6], &[1.0, 1.0e-9]);
        assert!((d.max_rel - (1.0e-6 - 1.0e-9) / 1.0e-3).abs() < 1e-9, "{d:?}");
        assert_eq!(d.at, 1);
        let d = compare(&[2.0, 0.5], &[1.0, 0.5]);
        assert!((d.max_rel - 1.0).abs() < 1e-12);
        assert!(compare(&[f32::NAN], &[1.0]).max_rel.is_infinite());
        assert!(compare(&[1.0], &[1.0, 2.0]).max_rel.is_infinite());
    }
}
