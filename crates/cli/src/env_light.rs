//! Environment map → SH lighting for the η analysis of `penumbra tables --env`.

use anyhow::Context;
use penumbra_math::sh::ShEval;
use std::path::Path;

/// Rec. 709 luminance weights.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Projects an environment map onto RGB SH of `order` (`order²` coefficients, each
/// `[r, g, b]`), every texel weighted by its exact solid angle: the one environment → SH
/// projection of the CLI (shadow verification, sweeps, the η analysis).
pub fn env_rgb_sh(env: &penumbra_geometry::EnvMap, order: usize) -> Vec<[f64; 3]> {
    let eval = ShEval::new(order);
    let mut y = vec![0.0; order * order];
    let mut out = vec![[0.0f64; 3]; order * order];
    for (dir, sa, rgb) in env.iter() {
        eval.eval_into(dir, &mut y);
        for (o, yi) in out.iter_mut().zip(&y) {
            for c in 0..3 {
                o[c] += rgb[c] as f64 * sa * yi;
            }
        }
    }
    out
}

/// Projects the luminance of a lat-long environment map onto SH of `order` (the Rec. 709
/// luminance of [`env_rgb_sh`]; SH projection is linear).
pub fn env_luminance_sh(path: &Path, order: usize) -> anyhow::Result<Vec<f64>> {
    let (env, _report) = penumbra_geometry::env::load_env_map(path)
        .with_context(|| format!("cannot load environment map {}", path.display()))?;
    Ok(env_rgb_sh(&env, order)
        .iter()
        .map(|c| LUMINANCE[0] * c[0] + LUMINANCE[1] * c[1] + LUMINANCE[2] * c[2])
        .collect())
}
