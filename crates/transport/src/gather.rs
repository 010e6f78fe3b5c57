//! Ray gathers inside a shape: the one-bounce operator `F` (MRT thesis §3.2.1, eq. 3.1;
//! §3.6.1: 16K gather rays per texel with importance sampling), and the SH gathers of
//! implicit lights for vector irradiance (§3.5.4) and volume probes (§3.5.5).
//!
//! # `F`
//! `F` maps direct irradiance at the texel centres to one-bounce indirect irradiance there,
//! for a diffuse albedo `ρ`: `E_ind(x) = ∫_H (ρ/π) E_d(y(x, ω)) cos θ dω`. With `N`
//! cosine-distributed rays (pdf `cos θ/π`) this is `(ρ/N) Σ E_d(hit)`. How a gather reads
//! the direct light at the point it hits decides `F` ([`Gather`]):
//! - [`Gather::Bilinear`] (default, the thesis's choice as we read it): the texels of the
//!   hit face are a texture, read with bilinear filtering clamped to the face's edge. Row `x`
//!   of `F` holds `ρ/N` times the summed bilinear weights of its rays.
//! - [`Gather::Exact`]: each hit reads the texel it lands in, integrated exactly: `F_xt =
//!   ρ·FF(x → texel t)`, the point-to-polygon form factor (Lambert's formula), no rays. The
//!   nearest-texel ray gather converges to this.
//!
//! Rays escaping through a missing face carry no light (nothing is outside a block).
//!
//! # Sampling
//! One fixed set of `N` directions per purpose (a Hammersley set warped to the cosine
//! hemisphere by the concentric map, or to the uniform hemisphere / sphere for SH
//! projections), rotated about the normal by a per-texel angle from the hash of
//! `(seed, TRANSPORT, shape, texel)`. Every row is a pure function of its texel, so the
//! result does not depend on the thread count.

use crate::reference::point_polygon_form_factor;
use crate::shape::{FACE_FRAMES, Texels, exit_face, face_point, face_uv};
use faer::Mat;
use penumbra_math::rng::{hash4, stage, unit_f64};
use rayon::prelude::*;

/// How a gather reads the direct light where its ray lands (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gather {
    /// Bilinear texture read of the hit face, clamped to the face (default).
    Bilinear,
    /// Exact point-to-texel form factors (no rays).
    Exact,
}

impl Gather {
    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bilinear => "bilinear",
            Self::Exact => "exact",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "bilinear" => Some(Self::Bilinear),
            "exact" => Some(Self::Exact),
            _ => None,
        }
    }
}

/// Base-2 radical inverse (van der Corput) of `i`.
#[inline]
fn radical_inverse(i: u32) -> f64 {
    i.reverse_bits() as f64 * (1.0 / 4_294_967_296.0)
}

/// A fixed set of unit directions in a local frame (`+z` = normal for hemispheres).
#[derive(Debug, Clone)]
pub struct DirectionSet {
    /// Directions.
    pub dirs: Vec<[f64; 3]>,
}

impl DirectionSet {
    /// `n` Hammersley points warped to the cosine-weighted hemisphere (pdf `cos θ/π`).
    pub fn cosine(n: usize) -> Self {
        Self::warped(n, penumbra_math::warp::cosine_hemisphere)
    }

    /// `n` Hammersley points warped to the uniform hemisphere (pdf `1/2π`).
    pub fn uniform_hemisphere(n: usize) -> Self {
        Self::warped(n, |u, v| {
            let z = u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * core::f64::consts::PI * v;
            [r * phi.cos(), r * phi.sin(), z]
        })
    }

    /// `n` Hammersley points warped to the uniform sphere (pdf `1/4π`).
    pub fn uniform_sphere(n: usize) -> Self {
        Self::warped(n, penumbra_math::warp::uniform_sphere)
    }

    fn warped(n: usize, warp: impl Fn(f64, f64) -> [f64; 3]) -> Self {
        // (i+½)/n keeps the first coordinate off the domain's edge (no horizon-grazing ray).
        Self { dirs: (0..n).map(|i| warp((i as f64 + 0.5) / n as f64, radical_inverse(i as u32))).collect() }
    }

    /// Number of directions.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }
}

/// Per-texel azimuthal rotation `(cos φ, sin φ)` from the hash of `(seed, shape, texel)`.
#[inline]
pub fn texel_rotation(seed: u64, shape_id: u64, texel: usize) -> (f64, f64) {
    let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, stage::TRANSPORT, shape_id, texel as u64));
    let (s, c) = phi.sin_cos();
    (c, s)
}

/// The local direction `l` rotated by `(c, s)` about `+z`, and its world direction in the
/// frame of face `f`.
#[inline]
pub fn to_world(f: usize, l: [f64; 3], (c, s): (f64, f64)) -> ([f64; 3], [f64; 3]) {
    let a = l[0] * c - l[1] * s;
    let b = l[0] * s + l[1] * c;
    let fr = &FACE_FRAMES[f];
    let local = [a, b, l[2]];
    let world = [
        a * fr.u[0] + b * fr.v[0] + l[2] * fr.n[0],
        a * fr.u[1] + b * fr.v[1] + l[2] * fr.n[1],
        a * fr.u[2] + b * fr.v[2] + l[2] * fr.n[2],
    ];
    (local, world)
}

/// Where a ray from `p` along `d` lands on a present wall: `(face, u, v)`, or `None` when it
/// leaves through an opening.
#[inline]
pub fn cast(tex: &Texels, p: [f64; 3], d: [f64; 3]) -> Option<(usize, f64, f64)> {
    let (f, t) = exit_face(p, d);
    if f == usize::MAX || !tex.shape.has(f) {
        return None;
    }
    let q = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
    let (u, v) = face_uv(f, q);
    Some((f, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)))
}

/// Rows per progress tick.
const CHUNK: usize = 32;

/// The one-bounce operator `F` (n×n, row = receiving texel) of a shape.
pub fn transport_matrix(
    tex: &Texels,
    dirs: &DirectionSet,
    albedo: f64,
    gather: Gather,
    seed: u64,
    shape_id: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> Mat<f64> {
    let n = tex.len();
    let mut rows = vec![0.0f64; n * n];
    if n == 0 {
        return Mat::zeros(0, 0);
    }
    let corners = texel_corners(tex);
    rows.par_chunks_mut(n * CHUNK).enumerate().for_each(|(c, block)| {
        for (k, row) in block.chunks_mut(n).enumerate() {
            let x = c * CHUNK + k;
            match gather {
                Gather::Bilinear => bilinear_row(tex, dirs, x, seed, shape_id, albedo, row),
                Gather::Exact => exact_row(tex, &corners, x, albedo, row),
            }
        }
        tick((block.len() / n) as u64);
    });
    Mat::from_fn(n, n, |i, j| rows[i * n + j])
}

/// `u = su·q[ua] + ou`, `v = sv·q[va] + ov` for a point `q` on face `g` (the frames are
/// axis-aligned), so a hit's face coordinates cost two multiply-adds.
#[derive(Clone, Copy)]
struct UvMap {
    ua: usize,
    su: f64,
    ou: f64,
    va: usize,
    sv: f64,
    ov: f64,
}

fn uv_maps() -> [UvMap; 6] {
    core::array::from_fn(|g| {
        let fr = &FACE_FRAMES[g];
        let axis = |e: [f64; 3]| (0..3).find(|&a| e[a] != 0.0).unwrap_or(0);
        let (ua, va) = (axis(fr.u), axis(fr.v));
        let (su, sv) = (fr.u[ua], fr.v[va]);
        UvMap { ua, su, ou: -su * fr.origin[ua], va, sv, ov: -sv * fr.origin[va] }
    })
}

/// One row of the bilinear-gather `F` (hot loop: ~16K rays per texel).
fn bilinear_row(tex: &Texels, dirs: &DirectionSet, x: usize, seed: u64, shape_id: u64, albedo: f64, row: &mut [f64]) {
    let (f, _, _) = tex.coords(x);
    let p = tex.position(x);
    let (c, s) = texel_rotation(seed, shape_id, x);
    let fr = &FACE_FRAMES[f];
    // rotation about the normal folded into the frame: d = l₀·ex + l₁·ey + l₂·n
    let ex: [f64; 3] = core::array::from_fn(|a| c * fr.u[a] + s * fr.v[a]);
    let ey: [f64; 3] = core::array::from_fn(|a| -s * fr.u[a] + c * fr.v[a]);
    let ez = fr.n;
    let maps = uv_maps();
    let open = tex.shape.missing;
    let r = tex.res;
    let rf = r as f64;
    let last = (r - 1) as f64;
    for l in &dirs.dirs {
        let d: [f64; 3] = core::array::from_fn(|a| l[0] * ex[a] + l[1] * ey[a] + l[2] * ez[a]);
        // exit plane per axis: the far side in the direction of travel; a zero component
        // gives +∞ (origins are texel centres, strictly inside the other two axes' range)
        let mut g = 0usize;
        let mut t = f64::INFINITY;
        for a in 0..3 {
            let pos = d[a].is_sign_positive();
            let ta = if pos { 1.0 - p[a] } else { -p[a] } / d[a];
            if ta < t {
                t = ta;
                g = 2 * a + usize::from(pos);
            }
        }
        if open & (1 << g) != 0 {
            continue;
        }
        let m = maps[g];
        let u = m.su * (p[m.ua] + t * d[m.ua]) + m.ou;
        let v = m.sv * (p[m.va] + t * d[m.va]) + m.ov;
        let su = (u * rf - 0.5).clamp(0.0, last);
        let sv = (v * rf - 0.5).clamp(0.0, last);
        let (i0, j0) = (su as usize, sv as usize);
        let (fx, fy) = (su - i0 as f64, sv - j0 as f64);
        let (i1, j1) = ((i0 + 1).min(r - 1), (j0 + 1).min(r - 1));
        let base = tex.slot[g] * r * r;
        row[base + j0 * r + i0] += (1.0 - fx) * (1.0 - fy);
        row[base + j0 * r + i1] += fx * (1.0 - fy);
        row[base + j1 * r + i0] += (1.0 - fx) * fy;
        row[base + j1 * r + i1] += fx * fy;
    }
    let scale = albedo / dirs.len() as f64;
    for r in row.iter_mut() {
        *r *= scale;
    }
}

/// The four corners of every texel, counter-clockwise seen from inside.
fn texel_corners(tex: &Texels) -> Vec<[[f64; 3]; 4]> {
    let r = tex.res as f64;
    (0..tex.len())
        .map(|t| {
            let (f, i, j) = tex.coords(t);
            let (u0, u1, v0, v1) = (i as f64 / r, (i + 1) as f64 / r, j as f64 / r, (j + 1) as f64 / r);
            [face_point(f, u0, v0), face_point(f, u1, v0), face_point(f, u1, v1), face_point(f, u0, v1)]
        })
        .collect()
}

fn exact_row(tex: &Texels, corners: &[[[f64; 3]; 4]], x: usize, albedo: f64, row: &mut [f64]) {
    let (f, _, _) = tex.coords(x);
    let p = tex.position(x);
    let n = FACE_FRAMES[f].n;
    for (t, poly) in corners.iter().enumerate() {
        if tex.coords(t).0 != f {
            row[t] = albedo * point_polygon_form_factor(p, n, poly);
        }
    }
}

/// Real SH of order 3 (9 values) of a unit direction, in the convention of
/// [`penumbra_math::sh`] (`y₁₋₁ ∝ −y, y₁₀ ∝ z, y₁₁ ∝ −x`).
#[inline]
pub fn sh9(d: [f64; 3]) -> [f64; 9] {
    let [x, y, z] = d;
    const C0: f64 = 0.282_094_791_773_878_14; // 1/(2√π)
    const C1: f64 = 0.488_602_511_902_919_9; // √(3/4π)
    const C2: f64 = 1.092_548_430_592_079_2; // √(15/4π)
    const C3: f64 = 0.315_391_565_252_520_05; // √(5/16π)
    const C4: f64 = 0.546_274_215_296_039_6; // √(15/16π)
    [C0, -C1 * y, C1 * z, -C1 * x, C2 * x * y, -C2 * y * z, C3 * (3.0 * z * z - 1.0), -C2 * x * z, C4 * (x * x - y * y)]
}

/// Quadratic SH of the radiance arriving at every texel (local frame: `+z` = normal, `+x` =
/// the face's `u`, `+y` = its `v`) when the walls carry the irradiance patterns `l` (n×k,
/// one pattern per column) and reflect it diffusely with albedo `ρ`: `L = ρ·l/π`. Returns
/// `n × k × 9`, texel-major. Uniform-hemisphere directions (`dirs`), bilinear reads.
pub fn texel_sh(
    tex: &Texels,
    l: &Mat<f64>,
    albedo: f64,
    dirs: &DirectionSet,
    seed: u64,
    shape_id: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> Vec<f64> {
    let n = tex.len();
    let k = l.ncols();
    let rows = row_major(l);
    let mut out = vec![0.0f64; n * k * 9];
    if n == 0 || k == 0 {
        return out;
    }
    let scale = albedo / core::f64::consts::PI * 2.0 * core::f64::consts::PI / dirs.len() as f64;
    out.par_chunks_mut(k * 9 * CHUNK).enumerate().for_each(|(c, block)| {
        let mut val = vec![0.0; k];
        let mut acc = vec![0.0; 9 * k];
        for (q, dst) in block.chunks_mut(k * 9).enumerate() {
            let x = c * CHUNK + q;
            let (f, _, _) = tex.coords(x);
            let p = tex.position(x);
            // a different stream from F's rotation (F and the SH gather stay independent)
            let rot = texel_rotation(seed ^ 0x5348_3947, shape_id, x);
            acc.iter_mut().for_each(|a| *a = 0.0);
            for dl in &dirs.dirs {
                let (local, d) = to_world(f, *dl, rot);
                let Some((g, u, v)) = cast(tex, p, d) else { continue };
                gather_value(tex, &rows, k, g, u, v, &mut val);
                let y = sh9(local);
                for (j, yj) in y.iter().enumerate() {
                    let a = &mut acc[j * k..(j + 1) * k];
                    for m in 0..k {
                        a[m] += yj * val[m];
                    }
                }
            }
            for m in 0..k {
                for j in 0..9 {
                    dst[m * 9 + j] = acc[j * k + m] * scale;
                }
            }
        }
        tick((block.len() / (k * 9)) as u64);
    });
    out
}

/// Order-3 SH (world frame) of the radiance arriving at each probe point (inside the cube)
/// from the walls carrying `l`, as in [`texel_sh`]; uniform-sphere directions, rotated
/// about `+Y` per probe. Returns `probes × k × 9`.
pub fn probe_sh(
    tex: &Texels,
    probes: &[[f64; 3]],
    l: &Mat<f64>,
    albedo: f64,
    dirs: &DirectionSet,
    seed: u64,
    shape_id: u64,
) -> Vec<f64> {
    let k = l.ncols();
    let rows = row_major(l);
    let scale = albedo / core::f64::consts::PI * 4.0 * core::f64::consts::PI / dirs.len() as f64;
    let per: Vec<Vec<f64>> = probes
        .par_iter()
        .enumerate()
        .map(|(pi, &p)| {
            let (c, s) = texel_rotation(seed ^ 0x564F_4C55, shape_id, pi);
            let mut val = vec![0.0; k];
            let mut acc = vec![0.0; 9 * k];
            for dl in &dirs.dirs {
                // rotate about +Y (world up): (x, z) plane
                let d = [dl[0] * c + dl[2] * s, dl[1], -dl[0] * s + dl[2] * c];
                let Some((g, u, v)) = cast(tex, p, d) else { continue };
                gather_value(tex, &rows, k, g, u, v, &mut val);
                let y = sh9(d);
                for (j, yj) in y.iter().enumerate() {
                    for m in 0..k {
                        acc[j * k + m] += yj * val[m];
                    }
                }
            }
            let mut dst = vec![0.0; k * 9];
            for m in 0..k {
                for j in 0..9 {
                    dst[m * 9 + j] = acc[j * k + m] * scale;
                }
            }
            dst
        })
        .collect();
    per.concat()
}

fn row_major(l: &Mat<f64>) -> Vec<f64> {
    let (n, k) = l.shape();
    let mut rows = vec![0.0; n * k];
    for j in 0..k {
        for i in 0..n {
            rows[i * k + j] = l[(i, j)];
        }
    }
    rows
}

#[inline]
fn gather_value(tex: &Texels, rows: &[f64], k: usize, g: usize, u: f64, v: f64, val: &mut [f64]) {
    val.iter_mut().for_each(|x| *x = 0.0);
    for (t, w) in tex.bilinear(g, u, v) {
        if w == 0.0 {
            continue;
        }
        let r = &rows[t * k..(t + 1) * k];
        for m in 0..k {
            val[m] += w * r[m];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_math::sh::ShEval;

    #[test]
    fn sh9_matches_the_math_crate() {
        let e = ShEval::new(3);
        for d in [[0.0, 0.0, 1.0], [0.48, -0.6, 0.64], [-0.36, 0.48, -0.8]] {
            let a = sh9(d);
            let b = e.eval(d);
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-14, "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn direction_sets_integrate_known_moments() {
        // cosine set: E[cos θ] = 2/3; uniform hemisphere: E[z] = 1/2; sphere: E[z²] = 1/3
        let c = DirectionSet::cosine(4096);
        let m: f64 = c.dirs.iter().map(|d| d[2]).sum::<f64>() / 4096.0;
        assert!((m - 2.0 / 3.0).abs() < 1e-3, "{m}");
        let h = DirectionSet::uniform_hemisphere(4096);
        let m: f64 = h.dirs.iter().map(|d| d[2]).sum::<f64>() / 4096.0;
        assert!((m - 0.5).abs() < 1e-6, "{m}");
        let s = DirectionSet::uniform_sphere(4096);
        let m: f64 = s.dirs.iter().map(|d| d[2] * d[2]).sum::<f64>() / 4096.0;
        assert!((m - 1.0 / 3.0).abs() < 1e-4, "{m}");
        assert!(c.dirs.iter().chain(&h.dirs).all(|d| d[2] > 0.0));
    }
}
