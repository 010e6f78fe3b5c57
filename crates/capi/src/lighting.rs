//! Local spherical lights (SHEXP §7, the `L_H(θ, φ)` ZH fit) and indirect light from the
//! proxies by each IBPA §5 operator, with one albedo for all proxies or one per sphere (SPHR
//! `albedo`).

use crate::shadows::{pn_shadow, pn_sphere, pn_spheres, spheres};
use crate::{PN_ERR_ABSENT, PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, guard, handle, points, put3, slice, vec3};
use penumbra_runtime::shadows::{IndirectOperator, LocalLight, Sphere};

/// A spherical light at a finite distance: emitting sphere and RGB radiance.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct pn_local_light {
    /// Centre and radius of the emitting sphere.
    pub sphere: pn_sphere,
    /// Emitted radiance, RGB.
    pub radiance: [f32; 3],
}

fn local(l: &pn_local_light) -> LocalLight {
    LocalLight { sphere: Sphere { center: l.sphere.center, radius: l.sphere.radius }, radiance: l.radiance }
}

/// Shadowed irradiance at `(p, n)` from a local spherical light, blocked by `count` spheres
/// (SHEXP §7; schemas/asset-format.md §15.1, SHTB `local_light_zh`): RGB into `out`.
/// `PN_ERR_ABSENT` when the tables have no `local_light_zh` section or the light is not a
/// valid sphere (non-finite, radius ≤ 0, or centred on the receiver).
///
/// # Safety
/// `p`, `n`, `out` point to 3 floats; `sph` to `count` spheres; `light` is valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_irradiance_local_light(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    light: *const pn_local_light,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph), Some(l)) =
            (handle(s), vec3(p), vec3(n), spheres(sph, count), handle(light))
        else {
            return PN_ERR_NULL;
        };
        match s.ev.irradiance_local_light(p, n, sph, &local(l)) {
            Some(v) => put3(out, v),
            None => PN_ERR_ABSENT,
        }
    })
}

/// The local light's irradiance for a visibility `g` already computed (`g_len ≥ order²`
/// floats, e.g. from `pn_shadow_accumulate_log` + `pn_shadow_exponentiate`): one visibility,
/// several lights. Errors as [`pn_shadow_irradiance_local_light`].
///
/// # Safety
/// `p`, `n`, `out` point to 3 floats; `g` to `g_len` floats; `light` is valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_shade_local_light(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    light: *const pn_local_light,
    g: *const f32,
    g_len: usize,
    out: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(l), Some(g)) =
            (handle(s), vec3(p), vec3(n), handle(light), slice(g, g_len))
        else {
            return PN_ERR_NULL;
        };
        if g.len() < s.n2 {
            return PN_ERR_SIZE;
        }
        match s.ev.shade_local_light(p, n, &local(l), &g[..s.n2]) {
            Some(v) => put3(out, v),
            None => PN_ERR_ABSENT,
        }
    })
}

/// Point sampled (IBPA eq. 13).
pub const PN_INDIRECT_POINT: u32 = 0;
/// Averaged `D(θ)` (IBPA eq. 14–15), what [`crate::pn_shadow_shade_with_indirect`] uses.
pub const PN_INDIRECT_AVERAGED: u32 = 1;
/// Exact `M(θ)` (IBPA eq. 16–17; contributes nothing if the tables lack `indirect_m`).
pub const PN_INDIRECT_EXACT: u32 = 2;

/// Direct (shadowed) irradiance and indirect light from `count` proxies by operator `op`
/// (`PN_INDIRECT_*`): RGB into `direct` and `indirect`. `albedo` holds `albedo_count` RGB
/// triples: 1 (every proxy that albedo) or `count` (proxy `i` takes triple `i`, e.g. the SPHR
/// `albedo` rows from [`pn_spheres_albedo`]); other counts give `PN_ERR_SIZE`, an unknown `op`
/// `PN_ERR_RANGE`.
///
/// # Safety
/// `p`, `n`, `direct`, `indirect` point to 3 floats; `sph` to `count` spheres; `albedo` to
/// `3 × albedo_count` floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_shadow_shade_with_indirect_by(
    s: *const pn_shadow,
    p: *const f32,
    n: *const f32,
    sph: *const pn_sphere,
    count: usize,
    albedo: *const f32,
    albedo_count: usize,
    op: u32,
    direct: *mut f32,
    indirect: *mut f32,
) -> i32 {
    guard(|| {
        let (Some(s), Some(p), Some(n), Some(sph), Some(a)) =
            (handle(s), vec3(p), vec3(n), spheres(sph, count), points(albedo, albedo_count))
        else {
            return PN_ERR_NULL;
        };
        let op = match op {
            PN_INDIRECT_POINT => IndirectOperator::PointSampled,
            PN_INDIRECT_AVERAGED => IndirectOperator::Averaged,
            PN_INDIRECT_EXACT => IndirectOperator::Exact,
            _ => return PN_ERR_RANGE,
        };
        let r = if albedo_count == 1 {
            s.ev.shade_with_indirect_by(p, n, sph, a[0], op)
        } else if albedo_count == count {
            s.ev.shade_with_indirect_per_sphere(p, n, sph, a, op)
        } else {
            return PN_ERR_SIZE;
        };
        match put3(direct, r.direct) {
            PN_OK => put3(indirect, r.indirect),
            e => e,
        }
    })
}

/// Linear RGB albedo of leaf `index` (SPHR kind_version 2 `albedo`) into `out`;
/// `PN_ERR_ABSENT` when the set stores none, `PN_ERR_RANGE` for an index out of range.
///
/// # Safety
/// `set` is a live handle; `out` points to 3 writable floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_spheres_albedo(set: *const pn_spheres, index: usize, out: *mut f32) -> i32 {
    guard(|| {
        let Some(s) = handle(set) else { return PN_ERR_NULL };
        if index >= s.set.len() {
            return PN_ERR_RANGE;
        }
        match s.set.albedo(index) {
            Some(a) => put3(out, a),
            None => PN_ERR_ABSENT,
        }
    })
}
