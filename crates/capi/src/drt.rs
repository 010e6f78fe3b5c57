//! The DRT runtime: clutter's indirect shadows and interreflections on top of the MRT runtime
//! (MRT thesis ch. 5; schemas/asset-format.md §15.4).

use crate::{
    PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, emit, guard, guard_err, handle, handle_mut, parse, release,
};
use crate::{runtime_err, slice, slice_mut};
use core::ffi::c_char;
use penumbra_runtime::drt::{DrtOperators, DrtRuntime, Paths};
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};

/// A level (`MRTL`) with its dictionary (`MRTD`, kind_version 3) and its clutter operators
/// (`DRTO`), with the evaluation buffers. One thread at a time.
#[derive(Debug)]
pub struct pn_drt {
    mrt: MrtRuntime<'static>,
    drt: DrtRuntime<'static>,
}

/// Opens the dictionary, level and DRT operators over the caller's bytes (all kept alive
/// until [`pn_drt_free`]); refuses operators baked for another level or dictionary layout.
///
/// # Safety
/// Each data pointer points to its size in readable bytes; `out` writable; `err` as usual.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_drt_open(
    dict_data: *const u8,
    dict_size: usize,
    level_data: *const u8,
    level_size: usize,
    drt_data: *const u8,
    drt_size: usize,
    out: *mut *mut pn_drt,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let d = parse(dict_data, dict_size).map_err(|(c, m)| (c, format!("dictionary: {m}")))?;
        let l = parse(level_data, level_size).map_err(|(c, m)| (c, format!("level: {m}")))?;
        let o = parse(drt_data, drt_size).map_err(|(c, m)| (c, format!("DRT operators: {m}")))?;
        let dict = MrtDictionary::from_asset(&d).map_err(runtime_err)?;
        let level = MrtLevel::from_asset(&l, &dict).map_err(runtime_err)?;
        let ops = DrtOperators::from_asset(&o, &dict, &level).map_err(runtime_err)?;
        let mrt = MrtRuntime::new(dict, level);
        let drt = DrtRuntime::new(ops, &mrt);
        emit(out, pn_drt { mrt, drt });
        Ok(())
    })
}

/// Frees a handle (NULL is a no-op).
///
/// # Safety
/// `h` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_drt_free(h: *mut pn_drt) {
    release(h);
}

/// Scene texels (the length of `l_d` and `scene_out`, as [`crate::pn_mrt_texel_count`]).
///
/// # Safety
/// `h` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_drt_texel_count(h: *const pn_drt) -> usize {
    handle(h).map_or(0, |h| h.mrt.texel_count())
}

/// Clutter texels (the length of `l_dc` and `clutter_out`); their world positions and normals
/// are the DRTO sections `clutter.positions` and `clutter.normals`.
///
/// # Safety
/// `h` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_drt_clutter_texel_count(h: *const pn_drt) -> usize {
    handle(h).map_or(0, |h| h.drt.operators().clutter_texel_count())
}

/// One bounce with clutter: from direct irradiance `l_d` at the scene texels and `l_dc` at
/// the clutter texels, the scene's indirect irradiance (MRT + `ΔU_b b` + `ΔU_c c`) into
/// `scene_out` and the clutter's (`C_b b + C_c c`) into `clutter_out`. `channel` (0..=2)
/// selects the clutter albedo; `albedo_scale` is the walls' albedo over the dictionary's.
///
/// # Safety
/// `h` live; the arrays hold `texels` / `clutter_texels` floats and do not overlap.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_drt_one_bounce(
    h: *mut pn_drt,
    l_d: *const f32,
    scene_out: *mut f32,
    texels: usize,
    l_dc: *const f32,
    clutter_out: *mut f32,
    clutter_texels: usize,
    channel: u32,
    albedo_scale: f32,
) -> i32 {
    // SAFETY: the same contract as this function's (forwarded unchanged).
    unsafe {
        pn_drt_multi_bounce(h, l_d, scene_out, texels, l_dc, clutter_out, clutter_texels, channel, albedo_scale, 0)
    }
}

/// `bounces` bounces through scene and clutter (each fed the previous one's scene and clutter
/// indirect light as direct light), their sums into the outputs; `bounces = 0` is one bounce
/// as [`pn_drt_one_bounce`].
///
/// # Safety
/// As [`pn_drt_one_bounce`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_drt_multi_bounce(
    h: *mut pn_drt,
    l_d: *const f32,
    scene_out: *mut f32,
    texels: usize,
    l_dc: *const f32,
    clutter_out: *mut f32,
    clutter_texels: usize,
    channel: u32,
    albedo_scale: f32,
    bounces: u32,
) -> i32 {
    guard(|| {
        let Some(h) = handle_mut(h) else { return PN_ERR_NULL };
        let (Some(l), Some(s), Some(lc), Some(c)) = (
            slice(l_d, texels),
            slice_mut(scene_out, texels),
            slice(l_dc, clutter_texels),
            slice_mut(clutter_out, clutter_texels),
        ) else {
            return PN_ERR_NULL;
        };
        if texels != h.mrt.texel_count() || clutter_texels != h.drt.operators().clutter_texel_count() {
            return PN_ERR_SIZE;
        }
        if channel > 2 || bounces > 1024 {
            return PN_ERR_RANGE;
        }
        if bounces == 0 {
            h.drt.one_bounce(&mut h.mrt, l, lc, channel as usize, albedo_scale, Paths::ALL, s, c);
        } else {
            h.drt.multi_bounce(&mut h.mrt, l, lc, channel as usize, albedo_scale, bounces as usize, s, c);
        }
        PN_OK
    })
}
