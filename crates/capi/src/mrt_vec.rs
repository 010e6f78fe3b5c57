//! The MRT runtime's geometry, vector and volume queries (MRT thesis §3.5.4–3.5.5, App. B):
//! where a level's texels are in the world (what an engine needs to compute `l_d` there), the
//! OHLSH coefficients of the indirect light per texel for normal-mapped surfaces, and the
//! world-frame SH of the volume probes for dynamic objects. Formulas: schemas/asset-format.md
//! (MRTD, MRTL) and docs/engine-integration.md.

use crate::mrt::pn_mrt;
use crate::{
    PN_ERR_ABSENT, PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, guard, handle, handle_mut, slice, slice_mut,
};
use penumbra_runtime::mrt_vec::{TexelWorld, ohlsh_irradiance, sh9_irradiance};

/// [`pn_mrt_features`]: the dictionary has `U_b⃗` for every shape of the level.
pub const PN_MRT_VECTOR: u32 = 1;
/// [`pn_mrt_features`]: the dictionary has `U_bvol` (volume probes) for every shape of the level.
pub const PN_MRT_VOLUME: u32 = 2;
/// [`pn_mrt_features`]: the dictionary has the interfaces' `U_r⃗` and `U_rvol`.
pub const PN_MRT_INTERFACE_VECTORS: u32 = 4;
/// [`pn_mrt_features`]: texel world positions and frames ([`pn_mrt_texel_world`]) are
/// available (the level has `block_xform`, the dictionary texel positions and `face_frames`).
pub const PN_MRT_TEXEL_WORLD: u32 = 8;

/// A texel in the world (level `block_xform` and quarter turns applied): its centre, its
/// inward unit normal (the side light arrives from: the OHLSH coefficients' z), and its
/// face's `u` and `v` axes (the coefficients' x and y).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct pn_texel_world {
    /// Texel centre, world units.
    pub position: [f32; 3],
    /// Inward unit normal.
    pub normal: [f32; 3],
    /// The face's u axis.
    pub u: [f32; 3],
    /// The face's v axis.
    pub v: [f32; 3],
}

/// What the level and dictionary carry: an OR of `PN_MRT_*` flags (0 for NULL).
///
/// # Safety
/// `m` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_features(m: *const pn_mrt) -> u32 {
    let Some(m) = handle(m) else { return 0 };
    let (rt, d) = (&m.rt, m.rt.dictionary());
    let world = rt.level().xform.is_some()
        && d.face_frames.is_some()
        && rt.level().shapes.iter().all(|&s| d.shapes[s].positions.is_some());
    [
        (rt.has_vector(), PN_MRT_VECTOR),
        (rt.has_volume(), PN_MRT_VOLUME),
        (rt.has_interface_vectors(), PN_MRT_INTERFACE_VECTORS),
        (world, PN_MRT_TEXEL_WORLD),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .fold(0, |f, (_, bit)| f | bit)
}

/// World position, inward normal and face axes of every texel (level texel order, `texels`
/// entries): block-local `p` lands at `translation + R_q(scale ⊙ (p − ½))`, directions turn by
/// `R_q` (MRTL `block_xform`, quarter turns about +Y). [`PN_ERR_ABSENT`] without
/// [`PN_MRT_TEXEL_WORLD`]. A load-time call: it allocates a scratch copy of the frames.
///
/// # Safety
/// `m` live; `out` holds `texels` writable entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_texel_world(m: *const pn_mrt, out: *mut pn_texel_world, texels: usize) -> i32 {
    guard(|| {
        let (Some(m), Some(o)) = (handle(m), slice_mut(out, texels)) else { return PN_ERR_NULL };
        if texels != m.rt.texel_count() {
            return PN_ERR_SIZE;
        }
        let mut w = vec![TexelWorld::default(); texels];
        if m.rt.texel_world(&mut w).is_none() {
            return PN_ERR_ABSENT;
        }
        for (o, w) in o.iter_mut().zip(&w) {
            *o = pn_texel_world { position: w.position, normal: w.normal, u: w.u, v: w.v };
        }
        PN_OK
    })
}

/// Per texel the 4 OHLSH coefficients of the indirect incident radiance from the last
/// [`crate::pn_mrt_indirect`] (`out`: `4 × texels` floats, texel-major): `U_b⃗[t]·b` with the
/// same-face rule, plus with `interfaces` the interfaces' `U_r⃗ r` turned into the texel's
/// frame. Irradiance at a unit normal `m` given in the texel frame `(u, v, normal)`:
/// [`pn_ohlsh_irradiance`]. [`PN_ERR_ABSENT`] without [`PN_MRT_VECTOR`].
///
/// # Safety
/// `m` live; `out` holds `4 × texels` writable floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_vector_coefficients(
    m: *const pn_mrt,
    out: *mut f32,
    texels: usize,
    interfaces: bool,
) -> i32 {
    guard(|| {
        let Some(m) = handle(m) else { return PN_ERR_NULL };
        let Some(o) = texels.checked_mul(4).and_then(|n| slice_mut(out, n)) else { return PN_ERR_NULL };
        if texels != m.rt.texel_count() {
            return PN_ERR_SIZE;
        }
        if !m.rt.has_vector() {
            return PN_ERR_ABSENT;
        }
        // [f32; 4] is four packed f32 with f32's alignment
        let o = o.as_mut_ptr().cast::<[f32; 4]>();
        // SAFETY: `o` points to 4 × texels writable floats (checked above), unaliased.
        let o = unsafe { core::slice::from_raw_parts_mut(o, texels) };
        m.rt.vector_coefficients_parts(o, interfaces);
        PN_OK
    })
}

/// Probes per block edge cubed (`G`) of block `block`'s volume probes: 0 without `U_bvol`,
/// `SIZE_MAX` when `block` is out of range (or `m` is NULL).
///
/// # Safety
/// `m` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_probe_count(m: *const pn_mrt, block: usize) -> usize {
    let Some(m) = handle(m) else { return usize::MAX };
    let Some(&s) = m.rt.level().shapes.get(block) else { return usize::MAX };
    m.rt.dictionary().shapes[s].u_bvol.map_or(0, |(_, p)| p.len() / 3)
}

/// The world-frame order-3 SH (9 floats per probe, probe-major; probes x fastest, then y,
/// then z, at the block-local cell centres of a `g³` grid) of block `block`'s volume probes
/// from the last [`crate::pn_mrt_indirect`]: `U_bvol·b`, plus with `interfaces` the
/// interfaces' `U_rvol r`, turned by the block's quarter turns. `len` must be
/// `9 × pn_mrt_probe_count`. [`PN_ERR_RANGE`] for a bad block, [`PN_ERR_ABSENT`] without
/// `U_bvol`. Does not allocate (the buffer is reserved at setup).
///
/// # Safety
/// `m` live; `out` holds `len` writable floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_probe_sh(
    m: *mut pn_mrt,
    block: usize,
    out: *mut f32,
    len: usize,
    interfaces: bool,
) -> i32 {
    guard(|| {
        let (Some(m), Some(o)) = (handle_mut(m), slice_mut(out, len)) else { return PN_ERR_NULL };
        let Some(&s) = m.rt.level().shapes.get(block) else { return PN_ERR_RANGE };
        let Some((_, probes)) = m.rt.dictionary().shapes[s].u_bvol else { return PN_ERR_ABSENT };
        if len != probes.len() / 3 * 9 {
            return PN_ERR_SIZE;
        }
        let mut buf = core::mem::take(&mut m.probes);
        m.rt.probe_sh_parts(block, &mut buf, interfaces);
        o.copy_from_slice(&buf);
        m.probes = buf;
        PN_OK
    })
}

/// Irradiance of block `block`'s probes at block-local `p ∈ [0, 1]³` for a world unit normal
/// `n`: trilinear interpolation of `sh` (the output of [`pn_mrt_probe_sh`] for that block,
/// `len` floats) between the 8 surrounding probe centres (clamped to the outermost centres),
/// then [`pn_sh9_irradiance`]. Written to `out`.
///
/// # Safety
/// `m` live; `sh` holds `len` floats; `p`, `n` 3 floats; `out` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_probe_irradiance(
    m: *const pn_mrt,
    block: usize,
    sh: *const f32,
    len: usize,
    p: *const f32,
    n: *const f32,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(m), Some(sh), Some(p), Some(n), Some(o)) =
            (handle(m), slice(sh, len), crate::vec3(p), crate::vec3(n), slice_mut(out, 1))
        else {
            return PN_ERR_NULL;
        };
        let Some(&s) = m.rt.level().shapes.get(block) else { return PN_ERR_RANGE };
        let Some((_, probes)) = m.rt.dictionary().shapes[s].u_bvol else { return PN_ERR_ABSENT };
        if len != probes.len() / 3 * 9 {
            return PN_ERR_SIZE;
        }
        o[0] = m.rt.probe_irradiance(block, sh, p, n);
        PN_OK
    })
}

/// The block containing world point `w` and its block-local coordinates in `[0, 1]³` (the
/// first block in level order whose box holds it). [`PN_ERR_RANGE`] when no block holds it,
/// [`PN_ERR_ABSENT`] without `block_xform`.
///
/// # Safety
/// `m` live; `w` 3 readable floats; `block` writable; `local` 3 writable floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_locate(m: *const pn_mrt, w: *const f32, block: *mut usize, local: *mut f32) -> i32 {
    guard(|| {
        let (Some(m), Some(w), Some(b), Some(l)) =
            (handle(m), crate::vec3(w), slice_mut(block, 1), slice_mut(local, 3))
        else {
            return PN_ERR_NULL;
        };
        if m.rt.level().xform.is_none() {
            return PN_ERR_ABSENT;
        }
        let Some((x, p)) = m.rt.locate(w) else { return PN_ERR_RANGE };
        b[0] = x;
        l.copy_from_slice(&p);
        PN_OK
    })
}

/// Irradiance `E(m)` at unit normal `m` of incident radiance given by 4 OHLSH coefficients
/// `a` in the same frame (MRT thesis App. B), as [`pn_mrt_vector_coefficients`] gives them:
/// `E(m) = π·y₀₀·a₀ + (2π/3)·√(3/4π)·(a₃·(−m_x) + a₁·(−m_y) + a₂·m_z)` (the OHLSH linear band,
/// docs/mrt.md). NaN when a pointer is NULL.
///
/// # Safety
/// `a` 4 readable floats, `m` 3.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_ohlsh_irradiance(a: *const f32, m: *const f32) -> f32 {
    let (Some(a), Some(m)) = (slice(a, 4), crate::vec3(m)) else { return f32::NAN };
    ohlsh_irradiance(&[a[0], a[1], a[2], a[3]], m)
}

/// Irradiance at unit normal `n` of radiance given by order-3 real SH `c` (9 floats, the
/// project's SH convention, schemas/asset-format.md), convolved with the clamped cosine
/// (Ramamoorthi–Hanrahan). NaN when a pointer is NULL.
///
/// # Safety
/// `c` 9 readable floats, `n` 3.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_sh9_irradiance(c: *const f32, n: *const f32) -> f32 {
    let (Some(c), Some(n)) = (slice(c, 9), crate::vec3(n)) else { return f32::NAN };
    sh9_irradiance(&core::array::from_fn(|i| c[i]), n)
}
