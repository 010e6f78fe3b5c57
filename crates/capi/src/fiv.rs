//! FIV occlusion tables and the FIV shading of placed occluders (FIV §4.3).

use crate::{
    PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, emit, guard, guard_err, handle, handle_mut, parse, points,
    points_mut, put3, release, runtime_err, slice, vec3,
};
use core::ffi::c_char;
use penumbra_runtime::fiv::{FivShader, FivTable, Partial, PlacedOccluder, ShadeOptions};

/// A `FIVT` occluder table (immutable; shareable between threads).
#[derive(Debug)]
pub struct pn_fiv_table {
    table: FivTable<'static>,
}

/// Opens a `FIVT` asset over the caller's bytes (f32 or f16 storage).
///
/// # Safety
/// As `pn_tables_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_table_open(
    data: *const u8,
    size: usize,
    out: *mut *mut pn_fiv_table,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let asset = parse(data, size)?;
        let table = FivTable::from_asset(&asset).map_err(runtime_err)?;
        emit(out, pn_fiv_table { table });
        Ok(())
    })
}

/// Frees a table (NULL is a no-op). Free every `pn_fiv_scene` using it first.
///
/// # Safety
/// `t` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_table_free(t: *mut pn_fiv_table) {
    release(t);
}

/// Where the occluder was baked: the centre of its bounding ball (3 floats into `center`)
/// and its radius (into `radius`).
///
/// # Safety
/// `t` live; `center` 3 writable floats; `radius` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_table_ball(t: *const pn_fiv_table, center: *mut f32, radius: *mut f32) -> i32 {
    guard(|| {
        let Some(t) = handle(t) else { return PN_ERR_NULL };
        if let Some(r) = crate::slice_mut(radius, 1) {
            r[0] = t.table.radius();
        }
        put3(center, t.table.center())
    })
}

/// Unoccluded irradiance of the table's environment at unit normal `n` (seamless bilinear
/// lookup of the irradiance cube): RGB into `out`.
///
/// # Safety
/// `t` live; `n`, `out` 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_table_irradiance(t: *const pn_fiv_table, n: *const f32, out: *mut f32) -> i32 {
    guard(|| {
        let (Some(t), Some(n)) = (handle(t), vec3(n)) else { return PN_ERR_NULL };
        put3(out, t.table.total_irradiance(n))
    })
}

/// An occluder placed in the world: its table and the world position of its ball centre.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct pn_fiv_placed {
    /// The occluder's table (borrowed; must outlive the scene).
    pub table: *const pn_fiv_table,
    /// World position of the ball centre.
    pub center: [f32; 3],
}

/// Partial occluders used as they are (default).
pub const PN_FIV_PARTIAL_NONE: u32 = 0;
/// Partial occluders scaled by `clamp((d + R)/2R, 0, 1)`.
pub const PN_FIV_PARTIAL_SCALE: u32 = 1;

/// Placed occluders and the shading scratch. One thread at a time.
#[derive(Debug)]
pub struct pn_fiv_scene {
    occluders: Vec<PlacedOccluder<'static, 'static>>,
    shader: FivShader,
    opts: ShadeOptions,
}

/// Makes a scene of `count` placed occluders (at least 1; the first one's environment
/// lights the scene). `partial` is `PN_FIV_PARTIAL_*`; `overlap` enables the overlap
/// correction (FIV eq. 13–14). The scene borrows the tables.
///
/// # Safety
/// `placed` points to `count` entries with live tables; `out` writable; `err` as usual.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_new(
    placed: *const pn_fiv_placed,
    count: usize,
    partial: u32,
    overlap: bool,
    out: *mut *mut pn_fiv_scene,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let placed = slice(placed, count).ok_or((PN_ERR_NULL, "placed is NULL".to_string()))?;
        if placed.is_empty() {
            return Err((PN_ERR_SIZE, "a scene needs at least one occluder".into()));
        }
        let partial = match partial {
            PN_FIV_PARTIAL_NONE => Partial::None,
            PN_FIV_PARTIAL_SCALE => Partial::Scale,
            p => return Err((PN_ERR_RANGE, format!("partial {p} is not PN_FIV_PARTIAL_NONE (0) or _SCALE (1)"))),
        };
        let mut occluders = Vec::with_capacity(placed.len());
        for (i, p) in placed.iter().enumerate() {
            let t: &'static pn_fiv_table =
                handle(p.table).ok_or((PN_ERR_NULL, format!("placed[{i}].table is NULL")))?;
            occluders.push(PlacedOccluder { table: &t.table, center: p.center });
        }
        emit(out, pn_fiv_scene { occluders, shader: FivShader::new(), opts: ShadeOptions { partial, overlap } });
        Ok(())
    })
}

/// Frees a scene (NULL is a no-op).
///
/// # Safety
/// `s` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_free(s: *mut pn_fiv_scene) {
    release(s);
}

/// Moves occluder `index` so that its ball centre is at `center` (no allocation).
///
/// # Safety
/// `s` live; `center` 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_move(s: *mut pn_fiv_scene, index: usize, center: *const f32) -> i32 {
    guard(|| {
        let (Some(s), Some(c)) = (handle_mut(s), vec3(center)) else { return PN_ERR_NULL };
        match s.occluders.get_mut(index) {
            Some(o) => {
                o.center = c;
                PN_OK
            }
            None => PN_ERR_RANGE,
        }
    })
}

/// Irradiance at a receiver `(p, n)` shadowed by every occluder of the scene (FIV eq. 11):
/// RGB into `out`.
///
/// # Safety
/// `s` live; `p`, `n`, `out` 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_irradiance(
    s: *mut pn_fiv_scene,
    p: *const f32,
    n: *const f32,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n)) = (handle_mut(s), vec3(p), vec3(n)) else { return PN_ERR_NULL };
        put3(out, s.shader.irradiance(&s.occluders, p, n, s.opts))
    })
}

/// [`pn_fiv_scene_irradiance`] for `receivers` receivers (`3 × receivers` floats each).
///
/// # Safety
/// Pointers valid for the lengths given; `out` does not alias the inputs.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_irradiance_batch(
    s: *mut pn_fiv_scene,
    points_xyz: *const f32,
    normals_xyz: *const f32,
    receivers: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(o)) =
            (handle_mut(s), points(points_xyz, receivers), points(normals_xyz, receivers), points_mut(out, receivers))
        else {
            return PN_ERR_NULL;
        };
        for ((p, n), o) in p.iter().zip(n).zip(o) {
            *o = s.shader.irradiance(&s.occluders, *p, *n, s.opts);
        }
        PN_OK
    })
}

/// Combined occluded irradiance of the scene's occluders at `(p, n)` (what the shadow
/// removes): RGB into `out`.
///
/// # Safety
/// `s` live; `p`, `n`, `out` 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_occluded(
    s: *mut pn_fiv_scene,
    p: *const f32,
    n: *const f32,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n)) = (handle_mut(s), vec3(p), vec3(n)) else { return PN_ERR_NULL };
        put3(out, s.shader.occluded_irradiance(&s.occluders, p, n, s.opts))
    })
}

/// Irradiance at a point `(p, n)` on the surface of occluder `own`, self-shadowed
/// (FIV §4.3.2) and shadowed by the scene's other occluders: RGB into `out`.
///
/// # Safety
/// `s` live; `p`, `n`, `out` 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_scene_self_shadowed(
    s: *mut pn_fiv_scene,
    own: usize,
    p: *const f32,
    n: *const f32,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n)) = (handle_mut(s), vec3(p), vec3(n)) else { return PN_ERR_NULL };
        if own >= s.occluders.len() {
            return PN_ERR_RANGE;
        }
        // Bring `own` to the front, keeping the others in scene order, and back afterwards:
        // the runtime takes the others as one slice, and this needs no allocation.
        s.occluders[..=own].rotate_right(1);
        let (first, others) = s.occluders.split_at(1);
        let v = s.shader.self_shadowed(&first[0], others, p, n, s.opts);
        s.occluders[..=own].rotate_left(1);
        put3(out, v)
    })
}

/// The two tables to blend for an environment turned by `yaw` radians about the shells'
/// polar axis, given tables baked at `steps` turns (`penumbra fiv --yaw-steps`; asset spec
/// §15.2 step 9): indices into `m0`, `m1` and the weight of `m1` into `f` (shade with both,
/// `(1 − f)·I(m0) + f·I(m1)`). `PN_ERR_RANGE` when `steps` is 0 or `yaw` is not finite.
///
/// # Safety
/// `m0`, `m1` writable `size_t`; `f` a writable float.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_fiv_yaw_blend(steps: usize, yaw: f32, m0: *mut usize, m1: *mut usize, f: *mut f32) -> i32 {
    guard(|| {
        let (Some(a), Some(b), Some(w)) = (crate::slice_mut(m0, 1), crate::slice_mut(m1, 1), crate::slice_mut(f, 1))
        else {
            return PN_ERR_NULL;
        };
        if steps == 0 || !yaw.is_finite() {
            return PN_ERR_RANGE;
        }
        let (i, j, t) = penumbra_runtime::fiv::yaw_blend(steps, yaw);
        (a[0], b[0], w[0]) = (i, j, t);
        PN_OK
    })
}
