//! Posed sphere sets (SHEXP §6.2 "Animation", §6.3): the runtime's `PosedSpheres` — leaves by
//! linear blend skinning of the stored influences with the engine's node matrices, hierarchy
//! refitted bottom-up — and hierarchy cuts on the posed tree.

use crate::shadows::{pn_cluster, pn_shadow, pn_sphere, pn_spheres};
use crate::{
    PN_ERR_ABSENT, PN_ERR_NULL, PN_ERR_RANGE, PN_ERR_SIZE, PN_OK, emit, guard, handle, handle_mut, release, slice,
    slice_mut, vec3,
};
use penumbra_runtime::{PosedSpheres, SphereTree};

/// A sphere set moved to one pose (leaves and refitted internal nodes). It borrows its
/// `pn_spheres`, which must outlive it. Scratch state: posing and querying from one thread at
/// a time (make one per character instance).
#[derive(Debug)]
pub struct pn_posed_spheres {
    posed: PosedSpheres<'static>,
}

/// Makes a posed set in the rest pose of `set` (the stored leaves and nodes).
///
/// # Safety
/// `set` is a live handle; `out` is a writable pointer slot.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_posed_spheres_new(set: *const pn_spheres, out: *mut *mut pn_posed_spheres) -> i32 {
    guard(|| {
        let Some(set): Option<&'static pn_spheres> = handle(set) else { return PN_ERR_NULL };
        if out.is_null() {
            return PN_ERR_NULL;
        }
        emit(out, pn_posed_spheres { posed: PosedSpheres::rest(set.set) });
        PN_OK
    })
}

/// Frees a posed set (NULL is a no-op).
///
/// # Safety
/// `p` is NULL or a live handle, not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_posed_spheres_free(p: *mut pn_posed_spheres) {
    release(p);
}

/// Poses every leaf from its skin influences, `P' = Σᵦ wᵦ Mₙᵦ P` (radius kept), with
/// `node_count` matrices `Mₙ = Gₙ(t)·Gₙ(rest)⁻¹` (16 floats each, column-major as glTF; the
/// last row is ignored) indexed by glTF node, then refits the hierarchy bottom-up (pair
/// bounds, schemas/asset-format.md SPHR). Errors leave the pose unchanged: `PN_ERR_ABSENT`
/// when the set has no skin, `PN_ERR_RANGE` when a leaf names a node at or beyond
/// `node_count` or a matrix holds a non-finite value. No allocation after the first call.
///
/// # Safety
/// `p` is a live handle; `matrices` points to `16 × node_count` floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_posed_spheres_pose(
    p: *mut pn_posed_spheres,
    matrices: *const f32,
    node_count: usize,
) -> i32 {
    guard(|| {
        let Some(p) = handle_mut(p) else { return PN_ERR_NULL };
        let Some(m) = node_count.checked_mul(16).and_then(|n| slice(matrices, n)) else { return PN_ERR_NULL };
        if !p.posed.topology().is_skinned() {
            return PN_ERR_ABSENT;
        }
        // SAFETY: [f32; 16] is 16 packed f32 with f32's alignment; `m` holds 16 × node_count
        // readable floats (checked by `slice`).
        let mats = unsafe { core::slice::from_raw_parts(m.as_ptr().cast::<[f32; 16]>(), node_count) };
        match p.posed.pose(mats) {
            Ok(()) => PN_OK,
            Err(_) => PN_ERR_RANGE,
        }
    })
}

/// Moves the leaves to `count` spheres the engine computed itself (one per stored leaf) and
/// refits the hierarchy. `PN_ERR_SIZE` unless `count` is the set's leaf count.
///
/// # Safety
/// `p` is a live handle; `leaves` points to `count` spheres.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_posed_spheres_set_leaves(
    p: *mut pn_posed_spheres,
    leaves: *const pn_sphere,
    count: usize,
) -> i32 {
    guard(|| {
        let (Some(p), Some(l)) = (handle_mut(p), crate::shadows::spheres(leaves, count)) else { return PN_ERR_NULL };
        match p.posed.set_leaves(l) {
            Ok(()) => PN_OK,
            Err(_) => PN_ERR_SIZE,
        }
    })
}

/// Copies the posed leaves (`count` = the set's leaf count, else `PN_ERR_SIZE`) into `out`:
/// the blockers to hand to `pn_shadow_irradiance` & co.
///
/// # Safety
/// `p` is a live handle; `out` points to `count` writable spheres.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_posed_spheres_leaves(p: *const pn_posed_spheres, out: *mut pn_sphere, count: usize) -> i32 {
    guard(|| {
        let (Some(p), Some(o)) = (handle(p), slice_mut(out, count)) else { return PN_ERR_NULL };
        let l = p.posed.leaves();
        if l.len() != count {
            return PN_ERR_SIZE;
        }
        for (d, s) in o.iter_mut().zip(l) {
            *d = pn_sphere { center: s.center, radius: s.radius };
        }
        PN_OK
    })
}

/// [`crate::pn_cluster_cut`] on the posed tree: the cut of the cluster bounded by
/// `(p_r, r_r)` with the refitted nodes, and its blockers with ratio vectors at
/// `(p_star, n_star)`.
///
/// # Safety
/// Handles live; vectors point to 3 floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_cluster_cut_posed(
    c: *mut pn_cluster,
    s: *const pn_shadow,
    posed: *const pn_posed_spheres,
    p_r: *const f32,
    r_r: f32,
    sin_theta_max: f32,
    p_star: *const f32,
    n_star: *const f32,
) -> i32 {
    guard(|| {
        let (Some(c), Some(s), Some(t), Some(p_r), Some(p_star), Some(n_star)) =
            (handle_mut(c), handle(s), handle(posed), vec3(p_r), vec3(p_star), vec3(n_star))
        else {
            return PN_ERR_NULL;
        };
        t.posed.cut(p_r, r_r, sin_theta_max, &mut c.stack, &mut c.cut);
        s.ev.cluster_blockers(&t.posed, &c.cut, p_star, n_star, &mut c.blockers);
        PN_OK
    })
}
