//! SH tables, sphere sets and the sphere-proxy shadow runtime (SHEXP §4–7, IBPA §3–5).

use crate::{
    PN_ERR_ABSENT, PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, SetupResult, emit, guard, guard_err, handle,
    handle_mut, parse, points, points_mut, put3, release, runtime_err, slice, slice_mut, vec3,
};
use core::ffi::c_char;
use penumbra_runtime::shadows::{CutBlocker, RuntimeExp, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{NodeRef, ShTables, SphereSet, SphereTree};

/// A blocker sphere: centre and radius (the runtime's `Sphere`, same layout).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct pn_sphere {
    /// Centre.
    pub center: [f32; 3],
    /// Radius (> 0).
    pub radius: f32,
}

// The sphere arrays of the C caller are handed to the runtime in place.
const _: () = assert!(size_of::<pn_sphere>() == size_of::<Sphere>() && align_of::<pn_sphere>() == align_of::<Sphere>());

pub(crate) fn spheres<'a>(p: *const pn_sphere, n: usize) -> Option<&'a [Sphere]> {
    let s = slice(p, n)?;
    // SAFETY: pn_sphere and Sphere are both repr(C) { [f32; 3], f32 } (asserted above).
    Some(unsafe { core::slice::from_raw_parts(s.as_ptr().cast::<Sphere>(), s.len()) })
}

/// An `SHTB` tables asset (immutable; shareable between threads).
#[derive(Debug)]
pub struct pn_tables {
    tables: ShTables<'static>,
}

/// Opens an `SHTB` asset over the caller's bytes (kept alive until [`pn_tables_free`]).
///
/// # Safety
/// `data` points to `size` readable bytes; `out` is a writable pointer slot; `err` is NULL or
/// points to `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_tables_open(
    data: *const u8,
    size: usize,
    out: *mut *mut pn_tables,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let asset = parse(data, size)?;
        let tables = ShTables::from_asset(&asset).map_err(runtime_err)?;
        emit(out, pn_tables { tables });
        Ok(())
    })
}

/// Frees tables (NULL is a no-op). Free every `pn_shadow` made from them first.
///
/// # Safety
/// `t` is NULL or a live handle from [`pn_tables_open`], not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_tables_free(t: *mut pn_tables) {
    release(t);
}

/// SH order `n` of the tables (`n²` coefficients), 0 for NULL.
///
/// # Safety
/// `t` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_tables_order(t: *const pn_tables) -> u32 {
    handle(t).map_or(0, |t| t.tables.order() as u32)
}

/// Zonal table `cap_log` (starred ZH of a blocker cap's log visibility), argument θ in radians.
pub const PN_TABLE_CAP_LOG: u32 = 0;
/// Zonal table `cap_visibility`, argument θ in radians.
pub const PN_TABLE_CAP_VISIBILITY: u32 = 1;
/// Zonal table `proxy_log_occlusion` (smoothly clamped), argument α = sin θ.
pub const PN_TABLE_PROXY_LOG_OCCLUSION: u32 = 2;
/// Zonal table `proxy_visibility` (smoothly clamped), argument α = sin θ.
pub const PN_TABLE_PROXY_VISIBILITY: u32 = 3;

/// Looks up zonal table `which` (`PN_TABLE_*`) at `x` by linear interpolation (spec §15.1):
/// `order` starred ZH coefficients into `out` (`out_len ≥ order`).
///
/// # Safety
/// `t` live; `out` points to `out_len` floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_tables_zonal(
    t: *const pn_tables,
    which: u32,
    x: f32,
    out: *mut f32,
    out_len: usize,
) -> i32 {
    guard(|| {
        let (Some(t), Some(o)) = (handle(t), slice_mut(out, out_len)) else { return PN_ERR_NULL };
        let n = t.tables.order();
        if out_len < n {
            return PN_ERR_SIZE;
        }
        let o = &mut o[..n];
        match which {
            PN_TABLE_CAP_LOG => t.tables.cap_log(x, o),
            PN_TABLE_CAP_VISIBILITY => t.tables.cap_visibility(x, o),
            PN_TABLE_PROXY_LOG_OCCLUSION => t.tables.proxy_log_occlusion(x, o),
            PN_TABLE_PROXY_VISIBILITY => t.tables.proxy_visibility(x, o),
            _ => return PN_ERR_RANGE,
        }
        PN_OK
    })
}

/// SH product `out = f * g` truncated to the tables' order (`len ≥ order²` each).
///
/// # Safety
/// `f`, `g`, `out` point to `len` floats; `out` overlaps neither input.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_tables_product(
    t: *const pn_tables,
    f: *const f32,
    g: *const f32,
    out: *mut f32,
    len: usize,
) -> i32 {
    guard(|| {
        let (Some(t), Some(f), Some(g), Some(o)) = (handle(t), slice(f, len), slice(g, len), slice_mut(out, len))
        else {
            return PN_ERR_NULL;
        };
        let n2 = t.tables.order() * t.tables.order();
        if len < n2 {
            return PN_ERR_SIZE;
        }
        t.tables.product(&f[..n2], &g[..n2], &mut o[..n2]);
        PN_OK
    })
}

/// The expansion factors `η_shadow` (used by the clamp) and `η_indirect` into `out[0..2]`.
///
/// # Safety
/// `t` live; `out` points to 2 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_tables_eta(t: *const pn_tables, out: *mut f32) -> i32 {
    guard(|| {
        let (Some(t), Some(o)) = (handle(t), slice_mut(out, 2)) else { return PN_ERR_NULL };
        o[0] = t.tables.eta_shadow();
        o[1] = t.tables.eta_indirect();
        PN_OK
    })
}

/// SH exponential: HYB (default), OL, PS*-p.
pub const PN_EXP_HYB: u32 = 0;
/// Optimal linear, no products.
pub const PN_EXP_OL: u32 = 1;
/// DC isolation + scaling/squaring + product series of degree `ps_degree`.
pub const PN_EXP_PS_STAR: u32 = 2;

/// Options of a shadow evaluator; [`pn_shadow_new`] with NULL options uses
/// `{PN_EXP_HYB, 0, true, true}`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct pn_shadow_options {
    /// `PN_EXP_HYB`, `PN_EXP_OL` or `PN_EXP_PS_STAR`.
    pub exp: u32,
    /// Degree p of PS*-p (1..=16; ignored otherwise).
    pub ps_degree: u32,
    /// Apply the self-shadow replacement rules (SHEXP §6.2).
    pub self_shadow_rules: bool,
    /// Window lighting and visibility with the cosine window (SHEXP §7).
    pub window: bool,
}

/// A shadow evaluator for one lighting environment (immutable; shareable between threads).
#[derive(Debug)]
pub struct pn_shadow {
    pub(crate) ev: ShadowEvaluator<'static>,
    pub(crate) n2: usize,
}

/// Makes an evaluator: `light` holds the environment radiance's RGB SH coefficients at the
/// tables' order, `order² × 3` floats (coefficient-major: r, g, b of coefficient 0, then 1…).
/// The evaluator borrows `tables`, which must outlive it.
///
/// # Safety
/// `tables` is a live handle; `light` points to `light_len` floats; `options` is NULL or valid;
/// `out` is writable; `err` is NULL or points to `err_len` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_new(
    tables: *const pn_tables,
    light: *const f32,
    light_len: usize,
    options: *const pn_shadow_options,
    out: *mut *mut pn_shadow,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        let t: &'static pn_tables = handle(tables).ok_or((PN_ERR_NULL, "tables is NULL".to_string()))?;
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let n2 = t.tables.order() * t.tables.order();
        if light_len != 3 * n2 {
            return Err((PN_ERR_SIZE, format!("light must hold order² × 3 = {} floats, got {light_len}", 3 * n2)));
        }
        let light = points(light, n2).ok_or((PN_ERR_NULL, "light is NULL or not 4-byte aligned".to_string()))?;
        let options = options_from(handle(options))?;
        emit(out, pn_shadow { ev: ShadowEvaluator::new(&t.tables, light, options), n2 });
        Ok(())
    })
}

fn options_from(o: Option<&pn_shadow_options>) -> SetupResult<ShadowOptions> {
    let Some(o) = o else { return Ok(ShadowOptions::default()) };
    let exp = match o.exp {
        PN_EXP_HYB => RuntimeExp::Hyb,
        PN_EXP_OL => RuntimeExp::Ol,
        PN_EXP_PS_STAR if (1..=16).contains(&o.ps_degree) => RuntimeExp::PsStar(o.ps_degree),
        PN_EXP_PS_STAR => return Err((PN_ERR_RANGE, format!("ps_degree {} not in 1..=16", o.ps_degree))),
        e => return Err((PN_ERR_RANGE, format!("exp {e} is not PN_EXP_HYB (0), PN_EXP_OL (1) or PN_EXP_PS_STAR (2)"))),
    };
    Ok(ShadowOptions { exp, self_shadow_rules: o.self_shadow_rules, window: o.window })
}

/// Frees an evaluator (NULL is a no-op).
///
/// # Safety
/// `s` is NULL or a live handle from [`pn_shadow_new`], not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_free(s: *mut pn_shadow) {
    release(s);
}

/// Step 1: the log visibility `f` (`order²` floats into `f`, `f_len ≥ order²`) of `count`
/// blocker spheres at receiver `p` (3 floats) with unit normal `n`, after the replacement rules.
///
/// # Safety
/// Pointers are valid for the lengths given; `f` does not alias the inputs.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_accumulate_log(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    f: *mut f32,
    f_len: usize,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph), Some(f)) =
            (handle(s), vec3(p), vec3(n), spheres(sph, count), slice_mut(f, f_len))
        else {
            return PN_ERR_NULL;
        };
        if f_len < s.n2 {
            return PN_ERR_SIZE;
        }
        s.ev.accumulate_log(p, n, sph, &mut f[..s.n2]);
        PN_OK
    })
}

/// Step 2: visibility `g = exp(f)` with the evaluator's exponential (`len ≥ order²`).
///
/// # Safety
/// `f` and `g` hold `len` floats and do not overlap.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_exponentiate(s: *const pn_shadow, f: *const f32, g: *mut f32, len: usize) -> i32 {
    guard(|| {
        let (Some(s), Some(f), Some(g)) = (handle(s), slice(f, len), slice_mut(g, len)) else {
            return PN_ERR_NULL;
        };
        if len < s.n2 {
            return PN_ERR_SIZE;
        }
        s.ev.exponentiate(&f[..s.n2], &mut g[..s.n2]);
        PN_OK
    })
}

/// Step 3: irradiance (RGB into `out`) of a diffuse receiver with unit normal `n` under
/// visibility `g` (`len ≥ order²`).
///
/// # Safety
/// Pointers valid: `n` 3 floats, `g` `len` floats, `out` 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_shade(
    s: *const pn_shadow,
    n: *const f32,
    g: *const f32,
    len: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(n), Some(g)) = (handle(s), vec3(n), slice(g, len)) else { return PN_ERR_NULL };
        if len < s.n2 {
            return PN_ERR_SIZE;
        }
        put3(out, s.ev.shade(n, &g[..s.n2]))
    })
}

/// Unshadowed irradiance at unit normal `n` (RGB into `out`).
///
/// # Safety
/// `n` and `out` point to 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_unshadowed(s: *const pn_shadow, n: *const f32, out: *mut f32) -> i32 {
    guard(|| {
        let (Some(s), Some(n)) = (handle(s), vec3(n)) else { return PN_ERR_NULL };
        put3(out, s.ev.unshadowed(n))
    })
}

/// Shadowed irradiance at one receiver (steps 1–3): RGB into `out`.
///
/// # Safety
/// `p`, `n`, `out` point to 3 floats; `sph` to `count` spheres.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_irradiance(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph)) = (handle(s), vec3(p), vec3(n), spheres(sph, count)) else {
            return PN_ERR_NULL;
        };
        put3(out, s.ev.irradiance(p, n, sph))
    })
}

/// Shadowed irradiance at `receivers` receivers (`points`, `normals` and `out` hold
/// `3 × receivers` floats, xyz / rgb per receiver), eight at a time: the same result per
/// receiver as [`pn_shadow_irradiance`], bit for bit, and faster.
///
/// # Safety
/// Pointers valid for the lengths given; `out` does not alias the inputs.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_irradiance_batch(
    s: *const pn_shadow,
    points_xyz: *const f32,
    normals_xyz: *const f32,
    receivers: usize,
    sph: *const pn_sphere,
    count: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph), Some(o)) = (
            handle(s),
            points(points_xyz, receivers),
            points(normals_xyz, receivers),
            spheres(sph, count),
            points_mut(out, receivers),
        ) else {
            return PN_ERR_NULL;
        };
        s.ev.irradiance_batch(p, n, sph, o);
        PN_OK
    })
}

/// Product-space accumulation (SHEXP eq. 6, the reference `penumbra verify` compares the log
/// path against): the blockers' cap visibilities multiplied one by one, then shaded. RGB into `out`.
///
/// # Safety
/// `p`, `n`, `out` point to 3 floats; `sph` to `count` spheres.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_irradiance_product(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph)) = (handle(s), vec3(p), vec3(n), spheres(sph, count)) else {
            return PN_ERR_NULL;
        };
        put3(out, s.ev.irradiance_product(p, n, sph))
    })
}

/// Accumulates and exponentiates with evaluator `accum` (e.g. higher-order tables), then
/// shades with `s` at its order (SHEXP Fig. 7e): RGB into `out`.
///
/// # Safety
/// Both evaluators live; `p`, `n`, `out` 3 floats; `sph` `count` spheres.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_irradiance_accumulated_by(
    s: *const pn_shadow,
    accum: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(a), Some(p), Some(n), Some(sph)) =
            (handle(s), handle(accum), vec3(p), vec3(n), spheres(sph, count))
        else {
            return PN_ERR_NULL;
        };
        put3(out, s.ev.irradiance_accumulated_by(&a.ev, p, n, sph))
    })
}

/// Direct (shadowed) irradiance and indirect light from the proxies (IBPA §5), every proxy a
/// diffuse reflector of RGB `albedo`, averaged operator: RGB into `direct` and `indirect`
/// (per-sphere albedo and the other operators: [`pn_shadow_shade_with_indirect_by`]).
///
/// # Safety
/// `p`, `n`, `albedo`, `direct`, `indirect` point to 3 floats; `sph` to `count` spheres.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_shade_with_indirect(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    albedo: *const f32,
    direct: *mut f32,
    indirect: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph), Some(a)) =
            (handle(s), vec3(p), vec3(n), spheres(sph, count), vec3(albedo))
        else {
            return PN_ERR_NULL;
        };
        let r = s.ev.shade_with_indirect(p, n, sph, a);
        match put3(direct, r.direct) {
            PN_OK => put3(indirect, r.indirect),
            e => e,
        }
    })
}

/// An `SPHR` sphere set (immutable; shareable between threads).
#[derive(Debug)]
pub struct pn_spheres {
    pub(crate) set: SphereSet<'static>,
}

/// Opens an `SPHR` asset over the caller's bytes.
///
/// # Safety
/// As [`pn_tables_open`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_open(
    data: *const u8,
    size: usize,
    out: *mut *mut pn_spheres,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    guard_err(err, err_len, || {
        if out.is_null() {
            return Err((PN_ERR_NULL, "out is NULL".into()));
        }
        let asset = parse(data, size)?;
        let set = SphereSet::from_asset(&asset).map_err(runtime_err)?;
        emit(out, pn_spheres { set });
        Ok(())
    })
}

/// Frees a sphere set (NULL is a no-op).
///
/// # Safety
/// `s` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_free(s: *mut pn_spheres) {
    release(s);
}

/// Number of leaf spheres (0 for NULL).
///
/// # Safety
/// `s` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_count(s: *const pn_spheres) -> usize {
    handle(s).map_or(0, |s| s.set.len())
}

/// Hierarchy depth (internal levels; 0 without a hierarchy).
///
/// # Safety
/// `s` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_depth(s: *const pn_spheres) -> usize {
    handle(s).map_or(0, |s| s.set.depth())
}

/// Copies leaf sphere `index` into `*out`.
///
/// # Safety
/// `s` is a live handle; `out` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_leaf(s: *const pn_spheres, index: usize, out: *mut pn_sphere) -> i32 {
    guard(|| {
        let (Some(s), Some(o)) = (handle(s), slice_mut(out, 1)) else { return PN_ERR_NULL };
        if index >= s.set.len() {
            return PN_ERR_RANGE;
        }
        let l = s.set.leaf(index);
        o[0] = pn_sphere { center: l.center, radius: l.radius };
        PN_OK
    })
}

/// Skinning influences of leaf `index` (glTF node indices, `0xFFFFFFFF` unused, and weights;
/// 4 each). `PN_ERR_ABSENT` when the set has no skin. Posing (`P' = Σ w G(t) G(rest)⁻¹ P`,
/// schemas/asset-format.md, SPHR) from the engine's node matrices: [`pn_posed_spheres_pose`].
///
/// # Safety
/// `s` is a live handle; `nodes` and `weights` point to 4 values each.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_skin(
    s: *const pn_spheres,
    index: usize,
    nodes: *mut u32,
    weights: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(nd), Some(w)) = (handle(s), slice_mut(nodes, 4), slice_mut(weights, 4)) else {
            return PN_ERR_NULL;
        };
        if index >= s.set.len() {
            return PN_ERR_RANGE;
        }
        match s.set.skin(index) {
            Some((n, wt)) => {
                nd.copy_from_slice(&n);
                w.copy_from_slice(&wt);
                PN_OK
            }
            None => PN_ERR_ABSENT,
        }
    })
}

/// A receiver cluster's hierarchy cut and its blockers with ratio vectors (SHEXP §6.3).
/// Scratch state: one thread at a time.
#[derive(Debug, Default)]
pub struct pn_cluster {
    pub(crate) stack: Vec<NodeRef>,
    pub(crate) cut: Vec<NodeRef>,
    pub(crate) blockers: Vec<CutBlocker>,
}

/// Makes an empty cluster.
///
/// # Safety
/// `out` is a writable pointer slot.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_new(out: *mut *mut pn_cluster) -> i32 {
    guard(|| {
        if out.is_null() {
            return PN_ERR_NULL;
        }
        emit(out, pn_cluster::default());
        PN_OK
    })
}

/// Frees a cluster (NULL is a no-op).
///
/// # Safety
/// `c` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_free(c: *mut pn_cluster) {
    release(c);
}

/// Cuts `set`'s hierarchy for a receiver cluster (bounding sphere `p_r`, `r_r`; a node enters
/// when it subtends less than `θ_max` over the cluster, `sin_theta_max`) and computes the
/// cut's blockers with ratio vectors at the cluster's representative receiver
/// (`p_star`, `n_star`). Buffers grow only when a cut is larger than any before.
///
/// # Safety
/// Handles live; vectors point to 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_cut(
    c: *mut pn_cluster,
    s: *const pn_shadow,
    set: *const pn_spheres,
    p_r: *const f32,
    r_r: f32,
    sin_theta_max: f32,
    p_star: *const f32,
    n_star: *const f32,
) -> i32 {
    guard(|| {
        let (Some(c), Some(s), Some(set), Some(p_r), Some(p_star), Some(n_star)) =
            (handle_mut(c), handle(s), handle(set), vec3(p_r), vec3(p_star), vec3(n_star))
        else {
            return PN_ERR_NULL;
        };
        set.set.cut(p_r, r_r, sin_theta_max, &mut c.stack, &mut c.cut);
        s.ev.cluster_blockers(&set.set, &c.cut, p_star, n_star, &mut c.blockers);
        PN_OK
    })
}

/// Number of blockers in the cluster's last cut.
///
/// # Safety
/// `c` is NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_size(c: *const pn_cluster) -> usize {
    handle(c).map_or(0, |c| c.blockers.len())
}

/// Shadowed irradiance at a receiver of the cluster from its cut blockers (RGB into `out`).
/// Use the evaluator the cut was made with.
///
/// # Safety
/// Handles live; `p`, `n`, `out` point to 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_irradiance(
    c: *const pn_cluster,
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(c), Some(s), Some(p), Some(n)) = (handle(c), handle(s), vec3(p), vec3(n)) else {
            return PN_ERR_NULL;
        };
        put3(out, s.ev.irradiance_blockers(p, n, &c.blockers))
    })
}

/// The batched form of [`pn_cluster_irradiance`] (layout as [`pn_shadow_irradiance_batch`]).
///
/// # Safety
/// Pointers valid for the lengths given; `out` does not alias the inputs.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_irradiance_batch(
    c: *const pn_cluster,
    s: *const pn_shadow,
    points_xyz: *const f32,
    normals_xyz: *const f32,
    receivers: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(c), Some(s), Some(p), Some(n), Some(o)) = (
            handle(c),
            handle(s),
            points(points_xyz, receivers),
            points(normals_xyz, receivers),
            points_mut(out, receivers),
        ) else {
            return PN_ERR_NULL;
        };
        s.ev.irradiance_blockers_batch(p, n, &c.blockers, o);
        PN_OK
    })
}
