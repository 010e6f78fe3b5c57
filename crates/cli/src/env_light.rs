//! Environment map → SH lighting for the η analysis of `penumbra tables --env`.

use anyhow::Context;
use penumbra_math::sh::ShEval;
use std::path::Path;

/// Rec. 709 luminance weights.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Projects the luminance of a lat-long environment map onto SH of `order`, weighting
/// every texel by its exact solid angle.
pub fn env_luminance_sh(path: &Path, order: usize) -> anyhow::Result<Vec<f64>> {
    let (env, _report) = penumbra_geometry::env::load_env_map(path)
        .with_context(|| format!("cannot load environment map {}", path.display()))?;
    let eval = ShEval::new(order);
    let mut y = vec![0.0; order * order];
    let mut out = vec![0.0; order * order];
    for (dir, solid_angle, rgb) in env.iter() {
        eval.eval_into(dir, &mut y);
        let lum = LUMINANCE[0] * rgb[0] as f64 + LUMINANCE[1] * rgb[1] as f64 + LUMINANCE[2] * rgb[2] as f64;
        let w = lum * solid_angle;
        for (o, yi) in out.iter_mut().zip(&y) {
            *o += w * yi;
        }
    }
    Ok(out)
}
