//! Directional and volume evaluation of MRT (MRT thesis §3.5.4–3.5.5, §3.6.3 steps 8–9,
//! App. B), from the block coefficients `b` and the interface response coefficients `r` of
//! the last [`MrtRuntime::indirect`].
//!
//! - [`MrtRuntime::vector_coefficients`]: per texel the 4 OHLSH coefficients
//!   `a = U_b⃗[t] · (b − b_g)` (the same same-face rule as the scalar `U_b`, MRTD runtime
//!   string) plus, for every interface `(block, entering face g)` with response `r`,
//!   `U_r⃗[u_r_idx.g[t]] · r` turned from the canonical texel's frame into the texel's
//!   (floor and ceiling texels turn their tangent part, [`crate::mrt::MrtInterfaceVectors`]).
//!   Texel frame: x = face u, y = face v, z = inward normal; [`ohlsh_irradiance`] gives the
//!   irradiance for a tilted unit normal `m` in that frame (App. B, eq. B.3 form:
//!   `E = π a₀ y₀₀ + (2π/3) Σ_m a₁ₘ y₁ₘ(m)`).
//! - [`MrtRuntime::probe_sh`]: per block probe SH `U_bvol · b` (full `b`, MRTD rule) plus, per
//!   interface `(block, g)`, `U_rvol · r` read at the canonical probe of each probe
//!   (`P^q`, `P(x, y, z) = (1 − z, y, x)`) and rotated by `q` quarter turns from the canonical
//!   into the shape frame (`q` = [`crate::mrt::canonical_turns`]`(g)`); then rotated into the
//!   world frame by the block's quarter turns about +Y ([`rotate_sh9_y`], exact for order 3);
//!   [`sh9_irradiance`] with `Â = (π, 2π/3, π/4)`.
//! - [`MrtRuntime::probe_irradiance`]: irradiance at a block-local point and world normal,
//!   trilinear between the 8 nearest probe centres of that block (clamped to the outermost
//!   centres: no extrapolation, no blending across blocks).
//!
//! A dictionary without the interface response (MRTD kind_version ≤ 3, or baked with
//! `--no-interface-vectors`) gives the `b` part only: light arriving across interfaces is then
//! missing from these values (it is in the scalar `indirect`). The `_parts` variants choose.

use crate::mrt::{MrtRuntime, dot};

const Y00: f32 = 0.282_094_8; // 1/(2√π)
const C1: f32 = 0.488_602_5; // √(3/4π)
const A2: f32 = 1.092_548_4; // √(15/4π)
const B20: f32 = 0.315_391_57; // √(5/16π)
const PI: f32 = core::f32::consts::PI;

/// `res` with `res³ = g`.
pub fn grid_res(g: usize) -> Option<usize> {
    let r = (g as f64).cbrt().round() as usize;
    (r > 0 && r * r * r == g).then_some(r)
}

/// Irradiance from OHLSH coefficients `[a₀₀, a₁₋₁, a₁₀, a₁₁]` for a unit normal `m` in the
/// texel frame (MRT thesis App. B; SH convention `y₁₋₁ ∝ −y, y₁₀ ∝ z, y₁₁ ∝ −x`).
#[inline]
pub fn ohlsh_irradiance(a: &[f32; 4], m: [f32; 3]) -> f32 {
    PI * a[0] * Y00 + 2.0 * PI / 3.0 * C1 * (-a[1] * m[1] + a[2] * m[2] - a[3] * m[0])
}

/// Irradiance of order-3 SH radiance `c` for a unit normal `m` (Ramamoorthi–Hanrahan
/// convolution, `Â = (π, 2π/3, π/4)`; the MRTD `u_bvol` rule).
#[inline]
pub fn sh9_irradiance(c: &[f32; 9], m: [f32; 3]) -> f32 {
    let [x, y, z] = m;
    let l0 = c[0] * Y00;
    let l1 = C1 * (-c[1] * y + c[2] * z - c[3] * x);
    let l2 = A2 * (c[4] * x * y - c[5] * y * z - c[7] * x * z + 0.5 * c[8] * (x * x - y * y))
        + B20 * c[6] * (3.0 * z * z - 1.0);
    PI * l0 + 2.0 * PI / 3.0 * l1 + PI / 4.0 * l2
}

/// Order-3 SH of `g(ω) = f(R⁻¹ω)` with `R` the rotation by `angle` about +Y,
/// `(x, y, z) → (x cos θ + z sin θ, y, −x sin θ + z cos θ)` (one quarter turn: `(z, y, −x)`,
/// the level's block rotation). Exact: band 1 is the vector `v` with `f₁ = v·ω` (`v' = R v`),
/// band 2 the traceless quadratic form `Q` with `f₂ = ωᵀQω` (`Q' = R Q Rᵀ`).
pub fn rotate_sh9_y(c: &[f32; 9], angle: f32) -> [f32; 9] {
    let (s, co) = angle.sin_cos();
    // exact quarter turns (f32 sin/cos of k·π/2 is not exactly 0/±1)
    let (s, co) = snap(s, co);
    let rot = |v: [f32; 3]| [v[0] * co + v[2] * s, v[1], -v[0] * s + v[2] * co];
    // band 1: f₁ = C1 (−c₋₁ y + c₀ z − c₁ x)
    let v = rot([-c[3], -c[1], c[2]]);
    // band 2 → Q (symmetric)
    let (qxy, qyz, qxz) = (0.5 * A2 * c[4], -0.5 * A2 * c[5], -0.5 * A2 * c[7]);
    let qxx = -B20 * c[6] + 0.5 * A2 * c[8];
    let qyy = -B20 * c[6] - 0.5 * A2 * c[8];
    let qzz = 2.0 * B20 * c[6];
    let q = [[qxx, qxy, qxz], [qxy, qyy, qyz], [qxz, qyz, qzz]];
    // Q' = R Q Rᵀ: columns of Q rotated, then rows
    let mut t = [[0.0f32; 3]; 3];
    for j in 0..3 {
        let col = rot([q[0][j], q[1][j], q[2][j]]);
        for i in 0..3 {
            t[i][j] = col[i];
        }
    }
    let mut r = [[0.0f32; 3]; 3];
    for (i, row) in t.iter().enumerate() {
        r[i] = rot(*row);
    }
    [
        c[0],
        -v[1],
        v[2],
        -v[0],
        2.0 * r[0][1] / A2,
        -2.0 * r[1][2] / A2,
        r[2][2] / (2.0 * B20),
        -2.0 * r[0][2] / A2,
        (r[0][0] - r[1][1]) / A2,
    ]
}

fn snap(s: f32, c: f32) -> (f32, f32) {
    let e = 1e-6;
    let f = |v: f32| {
        if v.abs() < e {
            0.0
        } else if (v.abs() - 1.0).abs() < e {
            v.signum()
        } else {
            v
        }
    };
    (f(s), f(c))
}

impl MrtRuntime<'_> {
    /// Whether the dictionary has `U_b⃗` for every shape of the level.
    pub fn has_vector(&self) -> bool {
        self.level().shapes.iter().all(|&s| self.dictionary().shapes[s].u_bvec.is_some())
    }

    /// Whether the dictionary has `U_bvol` for every shape of the level.
    pub fn has_volume(&self) -> bool {
        self.level().shapes.iter().all(|&s| self.dictionary().shapes[s].u_bvol.is_some())
    }

    /// Whether the dictionary has the interfaces' vector and volume response (`U_r⃗`,
    /// `U_rvol`; MRTD kind_version 4).
    pub fn has_interface_vectors(&self) -> bool {
        self.dictionary().vectors.is_some()
    }

    /// Per texel (level texel order) the OHLSH coefficients of the indirect incident radiance,
    /// `U_b⃗[t] · (b − b_g)` plus the interfaces' `U_r⃗ r` when the dictionary has them (module
    /// docs), from the last [`MrtRuntime::indirect`]. Shapes without `U_b⃗` get zeros from `b`.
    pub fn vector_coefficients(&self, out: &mut [[f32; 4]]) {
        self.vector_coefficients_parts(out, true);
    }

    /// [`MrtRuntime::vector_coefficients`] with (`interfaces`) or without the `U_r⃗ r` part.
    pub fn vector_coefficients_parts(&self, out: &mut [[f32; 4]], interfaces: bool) {
        assert!(out.len() == self.texel_count(), "out must have texel_count() entries");
        let kb = self.level().k_b;
        let r2 = self.dictionary().face_texels;
        let excl = self.dictionary().exclude_same_face;
        let (b_all, bf_all) = (self.coefficients(), self.face_coefficients());
        let offsets = self.offsets();
        for (x, &s) in self.level().shapes.iter().enumerate() {
            let sh = &self.dictionary().shapes[s];
            let o = &mut out[offsets[x]..offsets[x] + sh.n];
            let Some(uv) = sh.u_bvec else {
                o.iter_mut().for_each(|v| *v = [0.0; 4]);
                continue;
            };
            let b = &b_all[x * kb..x * kb + sh.k_b];
            let mut eff = [0.0f32; 256];
            let eff = &mut eff[..sh.k_b];
            for slot in 0..sh.faces.len() {
                let bf = &bf_all[(x * 6 + slot) * kb..(x * 6 + slot) * kb + sh.k_b];
                for (i, e) in eff.iter_mut().enumerate() {
                    *e = if excl { b[i] - bf[i] } else { b[i] };
                }
                for t in slot * r2..(slot + 1) * r2 {
                    let rows = &uv[t * sh.k_b * 4..(t + 1) * sh.k_b * 4];
                    let mut a = [0.0f32; 4];
                    for (i, e) in eff.iter().enumerate() {
                        for c in 0..4 {
                            a[c] += rows[i * 4 + c] * e;
                        }
                    }
                    o[t] = a;
                }
            }
        }
        let Some(iv) = self.dictionary().vectors.as_ref().filter(|_| interfaces) else { return };
        let k_r = self.dictionary().k_r;
        for (gi, &(dst, face)) in self.response_groups().iter().enumerate() {
            let r = &self.response_coefficients()[gi * k_r..(gi + 1) * k_r];
            let x = dst as usize;
            let sh = &self.dictionary().shapes[self.level().shapes[x]];
            let Some(idx) = sh.u_r_idx[face as usize] else { continue };
            let q = crate::mrt::canonical_turns(face as usize) as usize;
            let o = &mut out[offsets[x]..offsets[x] + sh.n];
            for (t, &row) in idx.iter().enumerate() {
                let rows = &iv.u_rvec[row as usize * k_r * 4..(row as usize + 1) * k_r * 4];
                let mut a = [0.0f32; 4];
                for (i, ri) in r.iter().enumerate() {
                    for c in 0..4 {
                        a[c] += rows[i * 4 + c] * ri;
                    }
                }
                // tangent part (a₁₁, a₁₋₁) into the texel's own frame
                let m = &iv.tangent[q][usize::from(sh.faces[t / r2])];
                let (a11, a1m) = (m[0] * a[3] + m[1] * a[1], m[2] * a[3] + m[3] * a[1]);
                o[t][0] += a[0];
                o[t][1] += a1m;
                o[t][2] += a[2];
                o[t][3] += a11;
            }
        }
    }

    /// Probe SH of block `x` in the world frame: `U_bvol · b` plus the interfaces'
    /// `U_rvol · r` when the dictionary has them (module docs), rotated by the block's quarter
    /// turns. `out` gets `G × 9` values; returns `G` (0 without `U_bvol`).
    pub fn probe_sh(&self, x: usize, out: &mut Vec<f32>) -> usize {
        self.probe_sh_parts(x, out, true)
    }

    /// [`MrtRuntime::probe_sh`] with (`interfaces`) or without the `U_rvol r` part. Allocates
    /// only when `out` holds fewer than `G × 9` values' capacity (the C ABI reserves them at
    /// setup).
    pub fn probe_sh_parts(&self, x: usize, out: &mut Vec<f32>, interfaces: bool) -> usize {
        out.clear();
        let sh = &self.dictionary().shapes[self.level().shapes[x]];
        let Some((vol, probes)) = sh.u_bvol else { return 0 };
        let g = probes.len() / 3;
        let kb = self.level().k_b;
        let b = &self.coefficients()[x * kb..x * kb + sh.k_b];
        // shape frame first (b and every interface), then one rotation into the world
        out.resize(g * 9, 0.0);
        let mut col = [0.0f32; 256];
        let col = &mut col[..sh.k_b];
        for (p, c) in out.chunks_exact_mut(9).enumerate() {
            for (j, cj) in c.iter_mut().enumerate() {
                for (i, v) in col.iter_mut().enumerate() {
                    *v = vol[(p * sh.k_b + i) * 9 + j];
                }
                *cj = dot(col, b);
            }
        }
        if let Some(iv) = self.dictionary().vectors.as_ref().filter(|_| interfaces) {
            let k_r = self.dictionary().k_r;
            let res = iv.volume_res;
            for (gi, &(dst, face)) in self.response_groups().iter().enumerate() {
                if dst as usize != x {
                    continue;
                }
                let r = &self.response_coefficients()[gi * k_r..(gi + 1) * k_r];
                let q = crate::mrt::canonical_turns(face as usize);
                for (p, c) in out.chunks_exact_mut(9).enumerate() {
                    let pc = canonical_probe(p, res, q);
                    let mut cc = [0.0f32; 9];
                    for (j, v) in cc.iter_mut().enumerate() {
                        *v = (0..k_r).map(|i| iv.u_rvol[(pc * k_r + i) * 9 + j] * r[i]).sum();
                    }
                    let rot = rotate_sh9_y(&cc, q as f32 * core::f32::consts::FRAC_PI_2);
                    for (a, v) in c.iter_mut().zip(rot) {
                        *a += v;
                    }
                }
            }
        }
        let angle = self.level().rotations[x] as f32 * core::f32::consts::FRAC_PI_2;
        for c in out.chunks_exact_mut(9) {
            let shape_frame: [f32; 9] = core::array::from_fn(|j| c[j]);
            c.copy_from_slice(&rotate_sh9_y(&shape_frame, angle));
        }
        g
    }

    /// Probe irradiance in block `x` at block-local `p ∈ [0,1]³` for a world unit normal `n`:
    /// trilinear interpolation of the world-frame probe SH between the 8 surrounding probe
    /// centres (clamped to the outermost centres), then [`sh9_irradiance`]. `sh` is the
    /// output of [`MrtRuntime::probe_sh`] for that block.
    pub fn probe_irradiance(&self, x: usize, sh: &[f32], p: [f32; 3], n: [f32; 3]) -> f32 {
        let shape = &self.dictionary().shapes[self.level().shapes[x]];
        let Some((_, probes)) = shape.u_bvol else { return 0.0 };
        let Some(res) = grid_res(probes.len() / 3) else { return 0.0 };
        let c = trilinear(sh, res, p);
        sh9_irradiance(&c, n)
    }

    /// The block containing world point `w` (by `block_xform` and the quarter turns) and its
    /// block-local coordinates; `None` without `block_xform` or outside every block.
    pub fn locate(&self, w: [f32; 3]) -> Option<(usize, [f32; 3])> {
        let xf = self.level().xform?;
        for (x, &q) in self.level().rotations.iter().enumerate() {
            let t = &xf[x * 6..x * 6 + 6];
            let d = [w[0] - t[0], w[1] - t[1], w[2] - t[2]];
            let l = rotate_vec_y(d, (4 - q % 4) % 4);
            let p = [l[0] / t[3] + 0.5, l[1] / t[4] + 0.5, l[2] / t[5] + 0.5];
            if p.iter().all(|&v| (0.0..=1.0).contains(&v)) {
                return Some((x, p));
            }
        }
        None
    }
}

/// A texel of a level in the world (MRTL `block_xform` and quarter turns applied): what an
/// engine needs to compute the direct light `l_d` there and to shade normal-mapped surfaces
/// with [`MrtRuntime::vector_coefficients`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TexelWorld {
    /// Texel centre.
    pub position: [f32; 3],
    /// Inward unit normal (the side light arrives from; the vector coefficients' z).
    pub normal: [f32; 3],
    /// The face's u axis (the vector coefficients' x).
    pub u: [f32; 3],
    /// The face's v axis (the vector coefficients' y).
    pub v: [f32; 3],
}

impl MrtRuntime<'_> {
    /// World position, normal and tangent frame of every texel (level texel order): block-local
    /// `p` lands at `translation + R_q(scale ⊙ (p − ½))`, directions turn by `R_q`
    /// ([`rotate_vec_y`]). `None` when the level has no `block_xform` or the dictionary no
    /// texel positions or `face_frames`.
    pub fn texel_world(&self, out: &mut [TexelWorld]) -> Option<()> {
        assert!(out.len() == self.texel_count(), "out must have texel_count() entries");
        let xf = self.level().xform?;
        let frames = self.dictionary().face_frames?;
        let r2 = self.dictionary().face_texels;
        let fr = |g: usize, k: usize| -> [f32; 3] { core::array::from_fn(|c| frames[g * 12 + k * 3 + c]) };
        for (x, &s) in self.level().shapes.iter().enumerate() {
            let sh = &self.dictionary().shapes[s];
            let pos = sh.positions?;
            let q = self.level().rotations[x];
            let t6 = &xf[x * 6..x * 6 + 6];
            for t in 0..sh.n {
                let g = usize::from(sh.faces[t / r2]);
                let l = [pos[t * 3] - 0.5, pos[t * 3 + 1] - 0.5, pos[t * 3 + 2] - 0.5];
                let w = rotate_vec_y([l[0] * t6[3], l[1] * t6[4], l[2] * t6[5]], q);
                out[self.offsets()[x] + t] = TexelWorld {
                    position: [t6[0] + w[0], t6[1] + w[1], t6[2] + w[2]],
                    normal: rotate_vec_y(fr(g, 3), q),
                    u: rotate_vec_y(fr(g, 1), q),
                    v: rotate_vec_y(fr(g, 2), q),
                };
            }
        }
        Some(())
    }
}

/// The canonical probe of probe `p` of a `res³` grid (x fastest, then y, then z) in a block
/// lit through a face `q` quarter turns from the canonical entry: the cell centre moved by
/// `q` turns of `(x, y, z) → (1 − z, y, x)`.
pub fn canonical_probe(p: usize, res: usize, q: u32) -> usize {
    let (mut i, j, mut l) = (p % res, (p / res) % res, p / (res * res));
    for _ in 0..q % 4 {
        (i, l) = (res - 1 - l, i);
    }
    i + res * (j + res * l)
}

/// `q` quarter turns about +Y, `(x, y, z) → (z, y, −x)` per turn (the level's rotation).
pub fn rotate_vec_y(v: [f32; 3], q: u32) -> [f32; 3] {
    match q % 4 {
        0 => v,
        1 => [v[2], v[1], -v[0]],
        2 => [-v[0], v[1], -v[2]],
        _ => [-v[2], v[1], v[0]],
    }
}

/// Trilinear blend of `res³` cell-centre values (9 each, x fastest) at `p ∈ [0,1]³`.
pub(crate) fn trilinear(sh: &[f32], res: usize, p: [f32; 3]) -> [f32; 9] {
    let mut i0 = [0usize; 3];
    let mut f = [0.0f32; 3];
    for a in 0..3 {
        let u = (p[a] * res as f32 - 0.5).clamp(0.0, (res - 1) as f32);
        let i = (u.floor() as usize).min(res.saturating_sub(2));
        i0[a] = i;
        f[a] = if res > 1 { u - i as f32 } else { 0.0 };
    }
    let mut c = [0.0f32; 9];
    for corner in 0..8 {
        let mut w = 1.0;
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let hi = (corner >> a) & 1 == 1;
            idx[a] = (i0[a] + usize::from(hi)).min(res - 1);
            w *= if hi { f[a] } else { 1.0 - f[a] };
        }
        if w == 0.0 {
            continue;
        }
        let g = idx[0] + res * (idx[1] + res * idx[2]);
        for (j, cj) in c.iter_mut().enumerate() {
            *cj += w * sh[g * 9 + j];
        }
    }
    c
}

#[cfg(test)]
mod tests;
