//! The screen-space estimators of MRT thesis §6.3.1–6.3.4 over a depth buffer, and their
//! ground truths (the reference evaluator of `penumbra verify vo`).
//!
//! Coordinates: an orthographic view; a pixel's surface point is `(x, y, z)` with `z` the
//! depth along the view direction (larger is farther). Every estimator maps the sphere of
//! radius `R` around the pixel's point to the unit sphere (§6.3.2: "all quantities are mapped
//! to a unit sphere centered at the origin before the integral is computed").

use crate::quality::{line_free, reflect};

/// A depth buffer with per-pixel view-space normals (facing the camera, `n_z < 0`).
///
/// Orthographic: pixel `(i, j)` is the view-space line `(x, y) = origin + (i, j)·pixel`.
/// Perspective (camera at the view origin): the pixel is the ray of slopes
/// `(X/Z, Y/Z) = origin + (i, j)·pixel`; depths are view-space `Z`. The estimators project each
/// line sample at the depth of the pixel being shaded (as a screen-space shader does).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthBuffer {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Pixel edge: world units (orthographic) or slope units (perspective).
    pub pixel: f64,
    /// Image-plane coordinates of pixel (0, 0)'s centre.
    pub origin: [f64; 2],
    /// Perspective projection (see above).
    pub perspective: bool,
    /// Depth per pixel, row-major; `f64::INFINITY` where nothing was hit.
    pub depth: Vec<f64>,
    /// Unit normal per pixel in view coordinates (zero where nothing was hit).
    pub normal: Vec<[f64; 3]>,
}

impl DepthBuffer {
    /// A buffer from a height-field function `f(x, y) → (depth, normal)` (tests, synthetic
    /// scenes).
    pub fn from_fn(
        width: usize,
        height: usize,
        pixel: f64,
        origin: [f64; 2],
        f: impl Fn(f64, f64) -> Option<(f64, [f64; 3])>,
    ) -> DepthBuffer {
        let mut depth = vec![f64::INFINITY; width * height];
        let mut normal = vec![[0.0; 3]; width * height];
        for j in 0..height {
            for i in 0..width {
                let (x, y) = (origin[0] + i as f64 * pixel, origin[1] + j as f64 * pixel);
                if let Some((d, n)) = f(x, y) {
                    depth[j * width + i] = d;
                    normal[j * width + i] = n;
                }
            }
        }
        DepthBuffer { width, height, pixel, origin, depth, normal, perspective: false }
    }

    /// View-space `(x, y)` of a pixel's surface point (perspective: at its depth).
    pub fn position(&self, i: usize, j: usize) -> [f64; 2] {
        let a = [self.origin[0] + i as f64 * self.pixel, self.origin[1] + j as f64 * self.pixel];
        if self.perspective {
            let z = self.depth[j * self.width + i];
            [a[0] * z, a[1] * z]
        } else {
            a
        }
    }

    /// Image-plane coordinates of view-space `(x, y)` projected at depth `z`.
    #[inline]
    fn project(&self, x: f64, y: f64, z: f64) -> (f64, f64) {
        if self.perspective { (x / z, y / z) } else { (x, y) }
    }

    /// Depth of the pixel that view-space `(x, y, z)` projects to: the nearest pixel's (point
    /// sampling of the z-buffer, as a GPU's unfiltered fetch); infinity outside the buffer.
    #[inline]
    pub fn depth_at(&self, x: f64, y: f64, z: f64) -> f64 {
        let (x, y) = self.project(x, y, z);
        let fi = ((x - self.origin[0]) / self.pixel).round();
        let fj = ((y - self.origin[1]) / self.pixel).round();
        if fi < 0.0 || fj < 0.0 || fi >= self.width as f64 || fj >= self.height as f64 {
            return f64::INFINITY;
        }
        self.depth[fj as usize * self.width + fi as usize]
    }

    /// Mean and standard deviation of the depth, mapped to the unit sphere around depth `z0`
    /// with radius `r` and clamped to `[−1, 1]` (beyond the sphere a depth only matters by its
    /// side), over the pixels of the axis-aligned square of edge `side` centred at `(x, y)`:
    /// the first two moments a mip level of `z` and `z²` holds (§6.3.2), computed exactly.
    pub fn moments(&self, x: f64, y: f64, side: f64, z0: f64, r: f64) -> (f64, f64) {
        let (x, y) = self.project(x, y, z0);
        let side = if self.perspective { side / z0 } else { side };
        let half = 0.5 * side / self.pixel;
        let ci = (x - self.origin[0]) / self.pixel;
        let cj = (y - self.origin[1]) / self.pixel;
        let (i0, i1) = ((ci - half).round() as i64, (ci + half).round() as i64);
        let (j0, j1) = ((cj - half).round() as i64, (cj + half).round() as i64);
        let (mut m1, mut m2, mut n) = (0.0, 0.0, 0.0);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let d = if i < 0 || j < 0 || i >= self.width as i64 || j >= self.height as i64 {
                    f64::INFINITY
                } else {
                    self.depth[j as usize * self.width + i as usize]
                };
                let dr = ((d - z0) / r).clamp(-1.0, 1.0);
                m1 += dr;
                m2 += dr * dr;
                n += 1.0;
            }
        }
        let mu = m1 / n;
        (mu, (m2 / n - mu * mu).max(0.0).sqrt())
    }
}

/// Which estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Line sampling (§6.3.1) with a disk set.
    Lines,
    /// Area sampling (§6.3.2) with a disk set.
    Area,
    /// Point sampling with a ball set.
    Points,
}

/// A set in use: samples, weights, log₂ area fractions.
#[derive(Debug, Clone, Copy)]
pub struct SetRef<'a> {
    /// Samples.
    pub points: &'a [[f64; 3]],
    /// Weights (sum 1).
    pub weights: &'a [f64],
    /// `log₂(cell area / domain area)`.
    pub log2area: &'a [f64],
}

/// Options of the estimators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Sphere radius in world units.
    pub radius: f64,
    /// Restrict to the hemisphere above the surface (§6.3.4).
    pub normal_clamp: bool,
    /// Thickness model (§6.3.3): surfaces occupy `[d, d + t]` (unit-sphere units); `None`:
    /// everything behind the depth buffer is matter.
    pub thickness: Option<f64>,
}

/// `∫_{−∞}^{d} clamp(s + z_s, 0, 2 z_s) ds`: the antiderivative of the line's free length.
fn free_antiderivative(z_s: f64, d: f64) -> f64 {
    if d <= -z_s {
        0.0
    } else if d <= z_s {
        0.5 * (d + z_s) * (d + z_s)
    } else {
        2.0 * z_s * z_s + 2.0 * z_s * (d - z_s)
    }
}

/// Expected free length of a line of half extent `z_s` when the depth is box-distributed on
/// `[μ − σ, μ + σ]` (§6.3.2, footnote 4: a box of half-width one standard deviation): the
/// constant part `V_c(z_min, z_max)` plus the linear part `V_c(z_0, z_1, a, b)`, written as a
/// difference of the antiderivative. `σ → 0` falls back to the line integral (§6.3.1).
pub fn area_free(z_s: f64, mu: f64, sigma: f64) -> f64 {
    if sigma < 1e-9 {
        return line_free(z_s, mu);
    }
    (free_antiderivative(z_s, mu + sigma) - free_antiderivative(z_s, mu - sigma)) / (2.0 * sigma)
}

/// Free length with the thickness model (§6.3.3): the step integral plus the integral of the
/// complementary step shifted back by `t`.
fn thick_free(z_s: f64, d: f64, t: Option<f64>) -> f64 {
    match t {
        None => line_free(z_s, d),
        Some(t) => line_free(z_s, d) + (2.0 * z_s - line_free(z_s, d + t)),
    }
}

/// The obscurance estimate (free fraction of the ball, or of the hemisphere with
/// `normal_clamp`) at pixel `(i, j)`, with the set reflected by the unit normal `refl`.
/// Background pixels return `None`.
pub fn estimate(
    db: &DepthBuffer,
    i: usize,
    j: usize,
    method: Method,
    set: SetRef<'_>,
    refl: [f64; 3],
    o: &Options,
) -> Option<f64> {
    let k = j * db.width + i;
    let z0 = db.depth[k];
    if !z0.is_finite() {
        return None;
    }
    let [x0, y0] = db.position(i, j);
    let n = db.normal[k];
    let r = o.radius;
    let mut free = 0.0;
    let mut total = 0.0;
    for ((p, &w), &la) in set.points.iter().zip(set.weights).zip(set.log2area) {
        let p = reflect(*p, refl);
        match method {
            Method::Lines | Method::Area => {
                let z_s = (1.0 - p[0] * p[0] - p[1] * p[1]).max(0.0).sqrt();
                if z_s <= 0.0 {
                    continue;
                }
                let (x, y) = (x0 + r * p[0], y0 + r * p[1]);
                // §6.3.4: the plane through P with the normal clamps the line's far end
                let zp = if o.normal_clamp && n[2] < 0.0 { -(n[0] * p[0] + n[1] * p[1]) / n[2] } else { f64::INFINITY };
                let hemi = line_free(z_s, zp);
                let f = match method {
                    Method::Lines => {
                        let dr = (db.depth_at(x, y, z0) - z0) / r;
                        thick_free(z_s, dr.min(zp), o.thickness).min(hemi)
                    }
                    _ => {
                        let side = (std::f64::consts::PI * la.exp2()).sqrt() * r;
                        let (mu, sigma) = db.moments(x, y, side, z0, r);
                        if zp.is_finite() {
                            // clamp: the part of the distribution behind the plane is occupied
                            area_free(z_s, mu.min(zp), sigma).min(hemi)
                        } else {
                            area_free(z_s, mu, sigma)
                        }
                    }
                };
                let m = w / (2.0 * z_s);
                free += m * f;
                total += m * hemi;
            }
            Method::Points => {
                let mut q = p;
                if o.normal_clamp {
                    // reflect the samples below the surface into the hemisphere (§6.3.4, [29])
                    let d = q[0] * n[0] + q[1] * n[1] + q[2] * n[2];
                    if d < 0.0 {
                        q = [q[0] - 2.0 * d * n[0], q[1] - 2.0 * d * n[1], q[2] - 2.0 * d * n[2]];
                    }
                }
                let z = z0 + r * q[2];
                let d = db.depth_at(x0 + r * q[0], y0 + r * q[1], z);
                let occupied = match o.thickness {
                    None => z > d,
                    Some(t) => z > d && z < d + t * r,
                };
                free += w * f64::from(u8::from(!occupied));
                total += w;
            }
        }
    }
    Some(if total > 0.0 { free / total } else { 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::{VoParams, bake};
    use crate::quality::cap_fraction;
    use penumbra_math::progress::NoProgress;

    fn sets() -> crate::VoBake {
        let p = VoParams { counts: vec![12, 64], starts: 4, noise_trials: 16, ..VoParams::default() };
        bake(&p, &NoProgress).unwrap()
    }

    fn set(b: &crate::VoBake, ball: bool, n: usize) -> SetRef<'_> {
        let s = b
            .sets
            .iter()
            .find(|s| (s.domain == crate::Domain::Ball) == ball && !s.centre && s.points.len() == n)
            .unwrap();
        SetRef { points: &s.points, weights: &s.weights, log2area: &s.log2area }
    }

    const NO_REFL: [f64; 3] = [1.0, 0.0, 0.0];

    /// A dense μ-weighted grid of the disk (`m²` cells) or the ball (`m³`): a quadrature whose
    /// own error is far below the tolerances, so it checks the estimator's formulas.
    fn dense(ball: bool, m: usize) -> (Vec<[f64; 3]>, Vec<f64>, Vec<f64>) {
        let (mut p, mut w) = (Vec::new(), Vec::new());
        let c = |i: usize| -1.0 + (i as f64 + 0.5) * 2.0 / m as f64;
        for i in 0..m {
            for j in 0..m {
                for k in 0..if ball { m } else { 1 } {
                    let q = [c(i), c(j), if ball { c(k) } else { 0.0 }];
                    let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
                    if r2 < 1.0 {
                        p.push(q);
                        w.push(if ball { 1.0 } else { 2.0 * (1.0 - r2).sqrt() });
                    }
                }
            }
        }
        let s: f64 = w.iter().sum();
        w.iter_mut().for_each(|x| *x /= s);
        let l = vec![(1.0 / p.len() as f64).log2(); p.len()];
        (p, w, l)
    }

    /// A view-facing height field around the origin on a 257² grid of pixel 1/64.
    fn field(f: impl Fn(f64, f64) -> (f64, [f64; 3])) -> DepthBuffer {
        DepthBuffer::from_fn(257, 257, 1.0 / 64.0, [-2.0, -2.0], |x, y| Some(f(x, y)))
    }

    #[test]
    fn area_free_is_the_box_average_of_the_line_integral() {
        for (z_s, mu, s) in [(0.8, 0.1, 0.3), (0.5, -0.6, 0.2), (0.3, 0.0, 2.0), (0.9, 1.5, 0.1)] {
            let m = 20000;
            let avg: f64 =
                (0..m).map(|k| line_free(z_s, mu - s + 2.0 * s * (k as f64 + 0.5) / m as f64)).sum::<f64>() / m as f64;
            assert!((area_free(z_s, mu, s) - avg).abs() < 1e-6);
        }
        assert_eq!(area_free(0.5, 0.2, 0.0), line_free(0.5, 0.2));
    }

    #[test]
    fn plane_at_offset_h_all_methods() {
        // P at height h above a view-facing plane (depth z0 + h·R behind P): free fraction
        // 1 − (1 − h)²(2 + h)/4. The buffer holds the plane at depth h·R; P is a virtual pixel
        // at depth 0 placed by a one-pixel bump.
        let b = sets();
        let r = 1.0;
        for h in [0.0, 0.3, 0.7] {
            let db = field(|x, y| {
                if x.abs() < 1e-9 && y.abs() < 1e-9 { (0.0, [0.0, 0.0, -1.0]) } else { (h * r, [0.0, 0.0, -1.0]) }
            });
            let o = Options { radius: r, normal_clamp: false, thickness: None };
            let exact = 1.0 - cap_fraction(h);
            let c = 128;
            // the formulas, through a dense quadrature: exact to the quadrature's error
            let (dp, dw, dl) = dense(false, 200);
            let d = SetRef { points: &dp, weights: &dw, log2area: &dl };
            let l = estimate(&db, c, c, Method::Lines, d, NO_REFL, &o).unwrap();
            assert!((l - exact).abs() < 2e-3, "dense lines h={h}: {l} vs {exact}");
            let (bp, bw, bl) = dense(true, 64);
            let l =
                estimate(&db, c, c, Method::Points, SetRef { points: &bp, weights: &bw, log2area: &bl }, NO_REFL, &o)
                    .unwrap();
            // layer-aligned grid: up to half a layer of error
            assert!((l - exact).abs() < 1e-2, "dense points h={h}: {l} vs {exact}");
            // the baked sets: within their quadrature error
            let l = estimate(&db, c, c, Method::Lines, set(&b, false, 64), NO_REFL, &o).unwrap();
            let a = estimate(&db, c, c, Method::Area, set(&b, false, 64), NO_REFL, &o).unwrap();
            let p = estimate(&db, c, c, Method::Points, set(&b, true, 64), NO_REFL, &o).unwrap();
            assert!((l - exact).abs() < 0.02, "lines h={h}: {l} vs {exact}");
            // a flat buffer has σ = 0 away from P: area sampling is line sampling there
            assert!((a - exact).abs() < 0.03, "area h={h}: {a} vs {exact}");
            assert!((p - exact).abs() < 0.05, "points h={h}: {p} vs {exact}");
        }
    }

    #[test]
    fn crease_quarter_edge_three_quarters_flat_with_normal_one() {
        let b = sets();
        let o = Options { radius: 1.0, normal_clamp: false, thickness: None };
        // concave 90° crease viewed along its bisector: depth −|x|, free quadrant ¼
        let crease = field(|x, _| (-x.abs(), [-x.signum() * 0.5f64.sqrt(), 0.0, -(0.5f64.sqrt())]));
        // convex 90° edge: depth |x|, matter is the 90° wedge behind: free ¾
        let edge = field(|x, _| (x.abs(), [x.signum() * 0.5f64.sqrt(), 0.0, -(0.5f64.sqrt())]));
        let flat = field(|_, _| (0.0, [0.0, 0.0, -1.0]));
        let c = 128;
        for (db, want) in [(&crease, 0.25), (&edge, 0.75), (&flat, 0.5)] {
            let l = estimate(db, c, c, Method::Lines, set(&b, false, 64), NO_REFL, &o).unwrap();
            assert!((l - want).abs() < 0.02, "lines {l} vs {want}");
            let p = estimate(db, c, c, Method::Points, set(&b, true, 64), NO_REFL, &o).unwrap();
            assert!((p - want).abs() < 0.06, "points {p} vs {want}");
        }
        // §6.3.4: a flat surface with the normal is unoccluded (the hemisphere above is free);
        // without it, half the ball is matter
        let on = Options { normal_clamp: true, ..o };
        for m in [Method::Lines, Method::Area] {
            let v = estimate(&flat, c, c, m, set(&b, false, 12), NO_REFL, &on).unwrap();
            assert!((v - 1.0).abs() < 1e-9, "{m:?} {v}");
        }
        let v = estimate(&flat, c, c, Method::Points, set(&b, true, 12), NO_REFL, &on).unwrap();
        assert!((v - 1.0).abs() < 1e-9, "{v}");
        // a tilted plane with the normal clamp is also free, whatever the tilt
        let s = 0.6f64;
        let nz = -(1.0 / (1.0 + s * s)).sqrt();
        let tilted = field(|x, _| (s * x, [-s * nz, 0.0, nz]));
        let v = estimate(&tilted, c, c, Method::Lines, set(&b, false, 64), NO_REFL, &on).unwrap();
        assert!((v - 1.0).abs() < 0.02, "{v}");
    }

    #[test]
    fn thickness_makes_a_thin_slab_mostly_free() {
        // a view-facing slab of thickness t at offset h: matter is [h, h + t], free fraction
        // 1 − (cap(h) − cap(h + t)); the thickness model is exact per line here
        let b = sets();
        let (h, t) = (0.2, 0.3);
        let db = field(
            |x, y| if x.abs() < 1e-9 && y.abs() < 1e-9 { (0.0, [0.0, 0.0, -1.0]) } else { (h, [0.0, 0.0, -1.0]) },
        );
        let o = Options { radius: 1.0, normal_clamp: false, thickness: Some(t) };
        let exact = 1.0 - (cap_fraction(h) - cap_fraction(h + t));
        let (dp, dw, dl) = dense(false, 200);
        let l =
            estimate(&db, 128, 128, Method::Lines, SetRef { points: &dp, weights: &dw, log2area: &dl }, NO_REFL, &o)
                .unwrap();
        assert!((l - exact).abs() < 2e-3, "dense {l} vs {exact}");
        let l = estimate(&db, 128, 128, Method::Lines, set(&b, false, 64), NO_REFL, &o).unwrap();
        assert!((l - exact).abs() < 0.02, "{l} vs {exact}");
        let p = estimate(&db, 128, 128, Method::Points, set(&b, true, 64), NO_REFL, &o).unwrap();
        assert!((p - exact).abs() < 0.05, "{p} vs {exact}");
    }
}
