//! The MRT runtime: indirect light of a level of dictionary blocks (MRT thesis ch. 3–4).

use crate::{
    PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, emit, guard, guard_err, handle, handle_mut, parse, release,
};
use crate::{runtime_err, slice, slice_mut};
use core::ffi::c_char;
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};

/// An MRT level (`MRTL`) with its dictionary (`MRTD`) and the evaluation buffers. One thread
/// at a time.
#[derive(Debug)]
pub struct pn_mrt {
    pub(crate) rt: MrtRuntime<'static>,
    /// `G × 9` floats of the largest probe grid of the level, reserved at setup so that
    /// [`crate::pn_mrt_probe_sh`] does not allocate.
    pub(crate) probes: Vec<f32>,
}

/// Opens a level and its dictionary over the caller's bytes (both kept alive until
/// [`pn_mrt_free`]); refuses a level baked for another dictionary.
///
/// # Safety
/// Each data pointer points to its size in readable bytes; `out` writable; `err` as usual.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_open(
    dict_data: *const u8,
    dict_size: usize,
    level_data: *const u8,
    level_size: usize,
    out: *mut *mut pn_mrt,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let d = parse(dict_data, dict_size).map_err(|(c, m)| (c, format!("dictionary: {m}")))?;
        let l = parse(level_data, level_size).map_err(|(c, m)| (c, format!("level: {m}")))?;
        let dict = MrtDictionary::from_asset(&d).map_err(runtime_err)?;
        let level = MrtLevel::from_asset(&l, &dict).map_err(runtime_err)?;
        let rt = MrtRuntime::new(dict, level);
        let g = rt.level().shapes.iter().filter_map(|&s| rt.dictionary().shapes[s].u_bvol).map(|(_, p)| p.len() / 3);
        let probes = Vec::with_capacity(9 * g.max().unwrap_or(0));
        emit(out, pn_mrt { rt, probes });
        Ok(())
    })
}

/// Frees a level (NULL is a no-op).
///
/// # Safety
/// `m` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_free(m: *mut pn_mrt) {
    release(m);
}

/// Texels of the level: the length of `l_d` and of the output of the evaluation calls
/// (blocks in level order, each in its shape's texel layout, schemas/asset-format.md MRTD).
///
/// # Safety
/// `m` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_texel_count(m: *const pn_mrt) -> usize {
    handle(m).map_or(0, |m| m.rt.texel_count())
}

/// Number of blocks of the level.
///
/// # Safety
/// `m` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_block_count(m: *const pn_mrt) -> usize {
    handle(m).map_or(0, |m| m.rt.level().shapes.len())
}

/// First texel of block `block` (`block = block_count` gives the texel count), or
/// `SIZE_MAX` when out of range.
///
/// # Safety
/// `m` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_block_offset(m: *const pn_mrt, block: usize) -> usize {
    handle(m).and_then(|m| m.rt.offsets().get(block).copied()).unwrap_or(usize::MAX)
}

/// Size of the padded light-map atlas in pixels.
///
/// # Safety
/// `m` live; `width`, `height` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_atlas_size(m: *const pn_mrt, width: *mut usize, height: *mut usize) -> i32 {
    guard(|| {
        let (Some(m), Some(w), Some(h)) = (handle(m), slice_mut(width, 1), slice_mut(height, 1)) else {
            return PN_ERR_NULL;
        };
        (w[0], h[0]) = m.rt.level().atlas;
        PN_OK
    })
}

/// One-bounce indirect irradiance at every texel from direct irradiance `l_d` (`texels`
/// floats each): `b = T_d→b l_d` per block, `U_b b` with the same-face rule, and with
/// `interfaces` the light carried between blocks (`U_r T_b→r b`).
///
/// # Safety
/// `m` live; `l_d` and `out` hold `texels` floats and do not overlap.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_indirect(
    m: *mut pn_mrt,
    l_d: *const f32,
    out: *mut f32,
    texels: usize,
    interfaces: bool,
) -> i32 {
    guard(|| {
        let (Some(m), Some(l), Some(o)) = (handle_mut(m), slice(l_d, texels), slice_mut(out, texels)) else {
            return PN_ERR_NULL;
        };
        if texels != m.rt.texel_count() {
            return PN_ERR_SIZE;
        }
        m.rt.indirect(l, o, interfaces);
        PN_OK
    })
}

/// `b` of every block from the last [`pn_mrt_indirect`] (MRT thesis §4.4: `b = T_d→b l_d`
/// per block): block `x` at `x·k_b_stride`, its shape's `k_b` entries (the rest 0), with
/// `k_b_stride` the level's largest `k_b`. `len` must be `block_count × k_b_stride`; the
/// stride is written to `k_b_stride` when it is not NULL.
///
/// # Safety
/// `m` live; `b` holds `len` floats; `k_b_stride` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_coefficients(m: *const pn_mrt, b: *mut f32, len: usize, k_b_stride: *mut usize) -> i32 {
    guard(|| {
        let Some(m) = handle(m) else { return PN_ERR_NULL };
        let c = m.rt.coefficients();
        if !k_b_stride.is_null() {
            let Some(s) = slice_mut(k_b_stride, 1) else { return PN_ERR_NULL };
            s[0] = m.rt.level().k_b;
        }
        if b.is_null() && len == 0 {
            return PN_OK;
        }
        let Some(o) = slice_mut(b, len) else { return PN_ERR_NULL };
        if len != c.len() {
            return PN_ERR_SIZE;
        }
        o.copy_from_slice(c);
        PN_OK
    })
}

/// Multi-bounce indirect light: `bounces` one-bounce evaluations, each fed the previous one's
/// result times `albedo_scale` (walls' albedo relative to the dictionary's); their sum into `out`.
///
/// # Safety
/// As [`pn_mrt_indirect`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_multi_bounce(
    m: *mut pn_mrt,
    l_d: *const f32,
    out: *mut f32,
    texels: usize,
    bounces: u32,
    albedo_scale: f32,
) -> i32 {
    guard(|| {
        let (Some(m), Some(l), Some(o)) = (handle_mut(m), slice(l_d, texels), slice_mut(out, texels)) else {
            return PN_ERR_NULL;
        };
        if texels != m.rt.texel_count() {
            return PN_ERR_SIZE;
        }
        if bounces > 1024 {
            return PN_ERR_RANGE;
        }
        m.rt.multi_bounce(l, o, bounces as usize, albedo_scale);
        PN_OK
    })
}

/// Writes per-texel values into the padded atlas (`atlas_len = width × height` floats,
/// row-major): tile interiors, then the border pixels. Pixels of no tile are left as they are.
///
/// # Safety
/// `m` live; `texel_values` holds `texels` floats, `atlas` `atlas_len`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_pad_atlas(
    m: *const pn_mrt,
    texel_values: *const f32,
    texels: usize,
    atlas: *mut f32,
    atlas_len: usize,
) -> i32 {
    guard(|| {
        let (Some(m), Some(t), Some(a)) = (handle(m), slice(texel_values, texels), slice_mut(atlas, atlas_len)) else {
            return PN_ERR_NULL;
        };
        let (w, h) = m.rt.level().atlas;
        if texels != m.rt.texel_count() || Some(atlas_len) != w.checked_mul(h) {
            return PN_ERR_SIZE;
        }
        m.rt.pad_atlas(t, a);
        PN_OK
    })
}

/// The matrices of dictionary shape `shape` for engines that evaluate on the GPU: `n` texels,
/// `k_b` modes, `u_b` (`n × k_b`, row-major) and `t_d2b` (`k_b × n`). The pointers point into
/// the dictionary bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct pn_mrt_shape {
    /// Texels of the shape.
    pub n: usize,
    /// Modes.
    pub k_b: usize,
    /// `U_b`, `n × k_b`.
    pub u_b: *const f32,
    /// `T_d→b`, `k_b × n`.
    pub t_d2b: *const f32,
}

/// Dictionary shape index of block `block`, or `SIZE_MAX` when out of range.
///
/// # Safety
/// `m` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_block_shape(m: *const pn_mrt, block: usize) -> usize {
    handle(m).and_then(|m| m.rt.level().shapes.get(block).copied()).unwrap_or(usize::MAX)
}

/// Describes dictionary shape `shape` (see [`pn_mrt_shape`]).
///
/// # Safety
/// `m` live; `out` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_mrt_shape_info(m: *const pn_mrt, shape: usize, out: *mut pn_mrt_shape) -> i32 {
    guard(|| {
        let (Some(m), Some(o)) = (handle(m), slice_mut(out, 1)) else { return PN_ERR_NULL };
        let Some(s) = m.rt.dictionary().shapes.get(shape) else { return PN_ERR_RANGE };
        o[0] = pn_mrt_shape { n: s.n, k_b: s.k_b, u_b: s.u_b.as_ptr(), t_d2b: s.t_d2b.as_ptr() };
        PN_OK
    })
}
