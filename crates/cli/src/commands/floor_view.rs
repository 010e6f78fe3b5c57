//! The top view of a level's floors that `verify mrt --image` and `verify drt --image`
//! write: one panel per series (one pixel per floor texel, +x right, +z down, upscaled by
//! the figure), a difference panel of the runtime against the reference with its colour
//! bar, and a caption.

use crate::figure::{ColorBar, Figure, Panel, diverging};
use penumbra_transport::level_reference::LevelTexels;

/// Texels inside clutter (`keep` false).
const MASKED: [u8; 3] = [90, 20, 20];
/// Where no floor texel is.
const EMPTY: [u8; 3] = [32, 32, 32];

/// Panels for `series` (title, per-texel irradiance; same tone scale: gamma 2.2 of value /
/// the kept texels' peak) and `series[runtime] − series[reference]` on a diverging scale of
/// ±`diff_span` × that peak.
pub fn floor_figure(
    tex: &LevelTexels,
    series: &[(&str, &[f64])],
    keep: Option<&[bool]>,
    (runtime, reference): (usize, usize),
    diff_span: f64,
    mut caption: Vec<String>,
) -> Figure {
    let floor: Vec<usize> = (0..tex.texels.len()).filter(|&i| tex.texels[i].1 == 2).collect();
    let kept = |i: usize| keep.is_none_or(|k| k[i]);
    let (mut x0, mut x1, mut z0, mut z1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &i in &floor {
        let p = tex.texels[i].2;
        (x0, x1, z0, z1) = (x0.min(p[0]), x1.max(p[0]), z0.min(p[2]), z1.max(p[2]));
    }
    // the texel pitch in world units (blocks may be scaled): the smallest gap between
    // distinct texel x coordinates
    let mut xs: Vec<f64> = floor.iter().map(|&i| tex.texels[i].2[0]).collect();
    xs.sort_by(f64::total_cmp);
    let pitch = xs.windows(2).map(|w| w[1] - w[0]).filter(|&d| d > 1e-9).fold(f64::MAX, f64::min);
    let s = if pitch < f64::MAX { 1.0 / pitch } else { 1.0 };
    let w = ((x1 - x0) * s).round().max(0.0) as usize + 1;
    let h = ((z1 - z0) * s).round().max(0.0) as usize + 1;
    let peak = floor
        .iter()
        .filter(|&&i| kept(i))
        .map(|&i| series.iter().map(|v| v.1[i]).fold(0.0f64, f64::max))
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    // pixel → floor texel
    let mut at = vec![usize::MAX; w * h];
    for &i in &floor {
        let p = tex.texels[i].2;
        let (px, pz) = (((p[0] - x0) * s).round() as usize, ((p[2] - z0) * s).round() as usize);
        if px < w && pz < h {
            at[pz * w + px] = i;
        }
    }
    let tone = |v: f64| {
        let g = ((v.max(0.0) / peak).powf(1.0 / 2.2) * 255.0).round().clamp(0.0, 255.0) as u8;
        [g, g, (f64::from(g) * 0.9) as u8]
    };
    let mut panels: Vec<Panel> = series
        .iter()
        .map(|(title, v)| {
            Panel::from_fn(*title, w, h, |x, z| match at[z * w + x] {
                usize::MAX => EMPTY,
                i if !kept(i) => MASKED,
                i => tone(v[i]),
            })
        })
        .collect();
    let span = diff_span * peak;
    let (rt, rf) = (series[runtime].1, series[reference].1);
    panels.push(Panel::from_fn("difference (scale below)", w, h, |x, z| match at[z * w + x] {
        usize::MAX => EMPTY,
        i if !kept(i) => MASKED,
        i => diverging(0.5 + 0.5 * (rt[i] - rf[i]) / span),
    }));
    caption.push(format!(
        "floors seen from above (+x right, +z down), one pixel per texel; tone: gamma 2.2 of irradiance / peak {peak:.4}{}",
        if keep.is_some() { "; dark red: inside clutter" } else { "" }
    ));
    Figure {
        panels,
        colorbar: Some(ColorBar {
            label: format!(
                "{} - {}, irradiance (clamped at {:.0}% of the peak)",
                series[runtime].0,
                series[reference].0,
                100.0 * diff_span
            ),
            lo: -span,
            hi: span,
            map: diverging,
        }),
        caption,
    }
}
