//! Receiver-batched shadow evaluation: [`LANES`] receivers at a time in structure-of-arrays
//! form, so the compiler vectorises across receivers the way a GPU runs SHEXP §7's shader
//! once per vertex. Every lane performs the scalar path's operations in the scalar path's
//! order (replacement rules, log accumulation, HYB, shading), so a batch returns exactly
//! what [`ShadowEvaluator::irradiance`] returns per receiver, for any batch composition
//! (tested bit for bit) — batching is a speed choice, never an accuracy one.
//!
//! On x86-64 the batch loop is also compiled with AVX and picked at run time when the CPU
//! has it (eight lanes in one register instead of two SSE ones); that is this crate's one
//! `unsafe` call. No FMA: every lane still rounds each operation as the scalar path does.

use super::rules::{self, replace_parts};
use super::{CutBlocker, ShadowEvaluator, Sphere};
use crate::sh::MAX_ORDER;

/// Receivers evaluated together. Eight f32 lanes fill one AVX register or two SSE ones.
pub const LANES: usize = 8;

type V = [f32; LANES];

/// Receiver positions and normals of one batch, structure of arrays.
struct Receivers {
    p: [V; 3],
    n: [V; 3],
}

/// The self-shadow replacement rules ([`super::rules::replace_parts`], the scalar path's
/// rule itself) for one sphere on every lane: the effective centre, radius and whether the
/// lane keeps the sphere.
#[inline(always)]
fn replace_lanes(s: Sphere, rc: &Receivers) -> ([V; 3], V, [bool; LANES]) {
    let mut center = [[0.0f32; LANES]; 3];
    let mut radius = [0.0f32; LANES];
    let mut keep = [false; LANES];
    for lane in 0..LANES {
        let p = [rc.p[0][lane], rc.p[1][lane], rc.p[2][lane]];
        let n = [rc.n[0][lane], rc.n[1][lane], rc.n[2][lane]];
        let (c, r, k) = replace_parts(s.center, s.radius, p, n);
        center[0][lane] = c[0];
        center[1][lane] = c[1];
        center[2][lane] = c[2];
        radius[lane] = r;
        keep[lane] = k;
    }
    (center, radius, keep)
}

/// Whether the rules keep sphere `s` (valid) unchanged on every lane ([`rules::unchanged`]).
#[inline(always)]
fn unchanged_on_all_lanes(s: Sphere, rc: &Receivers) -> bool {
    let mut all = [false; LANES];
    for lane in 0..LANES {
        let p = [rc.p[0][lane], rc.p[1][lane], rc.p[2][lane]];
        let n = [rc.n[0][lane], rc.n[1][lane], rc.n[2][lane]];
        all[lane] = rules::unchanged(s.center, s.radius, p, n);
    }
    all.iter().all(|&u| u)
}

impl ShadowEvaluator<'_> {
    /// Shadowed irradiance at every receiver `(points[k], normals[k])` from `spheres`,
    /// written to `out[k]`: the batched form of [`ShadowEvaluator::irradiance`], with the
    /// same result per receiver. Panics if the three slices differ in length.
    pub fn irradiance_batch(
        &self,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        spheres: &[Sphere],
        out: &mut [[f32; 3]],
    ) {
        let get = |i: usize| (spheres[i], None);
        self.batch_dispatch(points, normals, spheres.len(), get, out);
    }

    /// Shadowed irradiance at every receiver from a cluster's cut blockers with their ratio
    /// vectors: the batched form of [`ShadowEvaluator::irradiance_blockers`].
    pub fn irradiance_blockers_batch(
        &self,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        blockers: &[CutBlocker],
        out: &mut [[f32; 3]],
    ) {
        let get = |i: usize| (blockers[i].sphere, Some(&blockers[i].w));
        self.batch_dispatch(points, normals, blockers.len(), get, out);
    }

    fn batch_dispatch<'w>(
        &self,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>) + Copy,
        out: &mut [[f32; 3]],
    ) {
        assert!(points.len() == normals.len() && points.len() == out.len(), "receiver slices differ in length");
        match self.order {
            2 => self.batch_n::<2, 4>(points, normals, count, get, out),
            3 => self.batch_n::<3, 9>(points, normals, count, get, out),
            4 => self.batch_n::<4, 16>(points, normals, count, get, out),
            5 => self.batch_n::<5, 25>(points, normals, count, get, out),
            6 => self.batch_n::<6, 36>(points, normals, count, get, out),
            7 => self.batch_n::<7, 49>(points, normals, count, get, out),
            _ => self.batch_n::<8, 64>(points, normals, count, get, out),
        }
    }

    /// [`Self::batch_body`], compiled twice on x86-64: for the baseline target (SSE2: an
    /// eight-lane vector is two registers) and with AVX (one register), picked at run time.
    /// Both compile the same IEEE operations in the same order — AVX without FMA changes only
    /// how many lanes one instruction processes, never a lane's rounding — so the result is
    /// the same bit for bit on every machine (tested against the scalar path).
    #[allow(unsafe_code)] // the one call of an AVX-compiled function, after detecting AVX
    fn batch_n<'w, const N: usize, const N2: usize>(
        &self,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>) + Copy,
        out: &mut [[f32; 3]],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: `batch_avx` only requires the CPU to support AVX, checked just above;
            // it has no other precondition (safe Rust inside).
            unsafe { self.batch_avx::<N, N2>(points, normals, count, get, out) };
            return;
        }
        self.batch_body::<N, N2>(points, normals, count, get, out);
    }

    /// [`Self::batch_body`] compiled with AVX enabled (no FMA: see [`Self::batch_n`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn batch_avx<'w, const N: usize, const N2: usize>(
        &self,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>) + Copy,
        out: &mut [[f32; 3]],
    ) {
        self.batch_body::<N, N2>(points, normals, count, get, out);
    }

    /// The batch loop: receivers `LANES` at a time through accumulation, HYB and shading
    /// (everything inlined, so it is compiled for the caller's target features).
    #[inline(always)]
    fn batch_body<'w, const N: usize, const N2: usize>(
        &self,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>) + Copy,
        out: &mut [[f32; 3]],
    ) {
        let mut f = [[0.0f32; LANES]; N2];
        let mut g = [[0.0f32; LANES]; N2];
        for start in (0..points.len()).step_by(LANES) {
            let m = LANES.min(points.len() - start);
            // a short last batch repeats its last receiver in the spare lanes
            let mut rc = Receivers { p: [[0.0; LANES]; 3], n: [[0.0; LANES]; 3] };
            for lane in 0..LANES {
                let k = start + lane.min(m - 1);
                for a in 0..3 {
                    rc.p[a][lane] = points[k][a];
                    rc.n[a][lane] = normals[k][a];
                }
            }
            self.accumulate_lanes::<N, N2>(&rc, count, get, &mut f);
            self.exponentiate_lanes::<N2>(&f, &mut g);
            let e = self.shade_lanes::<N, N2>(&rc.n, &g);
            for lane in 0..m {
                out[start + lane] = [e[0][lane], e[1][lane], e[2][lane]];
            }
        }
    }

    /// [`ShadowEvaluator::accumulate_log`]'s loop on every lane: a sphere no lane keeps is
    /// skipped whole; in the others, a lane that drops it adds exact zeros.
    #[inline(always)]
    fn accumulate_lanes<'w, const N: usize, const N2: usize>(
        &self,
        rc: &Receivers,
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>),
        f: &mut [V; N2],
    ) {
        *f = [[0.0; LANES]; N2];
        let basis = self.tables.basis();
        let rules = self.options.self_shadow_rules;
        for i in 0..count {
            let (s0, w) = get(i);
            if !s0.is_valid() {
                continue; // as the scalar path: invalid blockers are ignored
            }
            // a blocker entirely in front of every lane's tangent plane (the common case) is
            // kept as it is by the rule: skip the rule's other cases (same result, bit for bit)
            let (center, radius, mut keep) = if rules && !unchanged_on_all_lanes(s0, rc) {
                replace_lanes(s0, rc)
            } else {
                (
                    [[s0.center[0]; LANES], [s0.center[1]; LANES], [s0.center[2]; LANES]],
                    [s0.radius; LANES],
                    [true; LANES],
                )
            };
            let mut dir = [[0.0f32; LANES]; 3];
            let mut alpha = [0.0f32; LANES];
            for lane in 0..LANES {
                let (vx, vy, vz) =
                    (center[0][lane] - rc.p[0][lane], center[1][lane] - rc.p[1][lane], center[2][lane] - rc.p[2][lane]);
                let d2 = vx * vx + vy * vy + vz * vz;
                let d = d2.sqrt();
                let a = (radius[lane] / d).min(1.0);
                // `d2 > 0` is false for NaN too
                let ok = keep[lane] && d2 > 0.0 && radius[lane] > 0.0;
                keep[lane] = ok;
                let inv = 1.0 / d;
                // a dropped lane evaluates the basis at +Z with zero weights
                dir[0][lane] = if ok { vx * inv } else { 0.0 };
                dir[1][lane] = if ok { vy * inv } else { 0.0 };
                dir[2][lane] = if ok { vz * inv } else { 1.0 };
                alpha[lane] = a;
            }
            if !keep.iter().any(|&k| k) {
                continue;
            }
            // each lane's row whole, then transposed in one pass (not written lane by lane
            // into `zh`, whose vector loads would then wait for eight narrow stores)
            let mut rows = [[0.0f32; N]; LANES];
            for lane in 0..LANES {
                if keep[lane] {
                    let mut z = self.tables.proxy_log_n::<N>(alpha[lane]);
                    if let Some(w) = w {
                        for l in 0..N {
                            z[l] *= w[l];
                        }
                    }
                    rows[lane] = z;
                }
            }
            let zh: [[f32; LANES]; N] = core::array::from_fn(|l| core::array::from_fn(|lane| rows[lane][l]));
            basis.add_zonal_lanes::<N, N2, LANES>(&dir, &zh, f);
        }
    }
}
