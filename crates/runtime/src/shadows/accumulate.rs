//! Log-visibility accumulation (SHEXP eq. 34 and, with ratio vectors, eq. 38): for each
//! blocker, the self-shadow rules ([`super::rules`]), `α = r/d`, the proxy table's zonal log
//! `O^log(α)` (IBPA §4.1, `ShTables::proxy_log`) and the zonal rotation rule
//! `f_lm += z*_l y_lm(ŝ)`.
//!
//! No blocker is dropped for being small (issue #14): far blockers add their small-cap log,
//! so many small ones keep their summed shadow. Invalid blockers (NaN or non-positive radius,
//! non-finite centre) are ignored. The loop is monomorphised per SH order so the zonal
//! rotation unrolls and loses its bounds checks.

use super::{CutBlocker, ShadowEvaluator, Sphere, dot, rules, sub};
use crate::sh::MAX_ORDER;

impl ShadowEvaluator<'_> {
    /// Accumulates the log visibility of `spheres` at `(p, n)` into `f` (`order²`
    /// entries, overwritten).
    pub fn accumulate_log(&self, p: [f32; 3], n: [f32; 3], spheres: &[Sphere], f: &mut [f32]) {
        let get = |i: usize| (spheres[i], None);
        self.accumulate_dispatch(p, n, spheres.len(), get, f);
    }

    /// Accumulates a receiver's log visibility from its cluster's blockers (SHEXP eq. 38:
    /// each sphere's zonal log visibility scaled per band by its ratio vector).
    pub fn accumulate_log_blockers(&self, p: [f32; 3], n: [f32; 3], blockers: &[CutBlocker], f: &mut [f32]) {
        let get = |i: usize| (blockers[i].sphere, Some(&blockers[i].w));
        self.accumulate_dispatch(p, n, blockers.len(), get, f);
    }

    /// How many of `spheres` a receiver at `(p, n)` accumulates: those the self-shadow rules
    /// keep (when enabled) with a positive distance and radius. This is what the log sum
    /// really adds up; blockers far away are counted (they are not skipped).
    pub fn accumulated_count(&self, p: [f32; 3], n: [f32; 3], spheres: impl Iterator<Item = Sphere>) -> usize {
        spheres
            .filter(|&s0| {
                self.effective(s0, p, n).is_some_and(|s| {
                    let v = sub(s.center, p);
                    let d2 = dot(v, v);
                    d2 > 0.0 && s.radius > 0.0
                })
            })
            .count()
    }

    fn accumulate_dispatch<'w>(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>),
        f: &mut [f32],
    ) {
        match self.order {
            2 => self.accumulate_n::<2, 4>(p, n, count, get, f),
            3 => self.accumulate_n::<3, 9>(p, n, count, get, f),
            4 => self.accumulate_n::<4, 16>(p, n, count, get, f),
            5 => self.accumulate_n::<5, 25>(p, n, count, get, f),
            6 => self.accumulate_n::<6, 36>(p, n, count, get, f),
            7 => self.accumulate_n::<7, 49>(p, n, count, get, f),
            _ => self.accumulate_n::<8, 64>(p, n, count, get, f),
        }
    }

    /// The accumulation loop for a compile-time order `N` (`N2 = N²`): `get(i)` is blocker `i`
    /// with its optional per-band ratio vector (SHEXP eq. 38).
    #[inline(always)]
    fn accumulate_n<'w, const N: usize, const M: usize>(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        count: usize,
        get: impl Fn(usize) -> (Sphere, Option<&'w [f32; MAX_ORDER]>),
        f: &mut [f32],
    ) {
        let mut acc = [0.0f32; M];
        let basis = self.tables.basis();
        for i in 0..count {
            let (s0, w) = get(i);
            let Some(s) = self.effective(s0, p, n) else { continue };
            let v = sub(s.center, p);
            let d2 = dot(v, v);
            if d2.is_nan() || d2 <= 0.0 || s.radius.is_nan() || s.radius <= 0.0 {
                continue;
            }
            let d = d2.sqrt();
            let alpha = (s.radius / d).min(1.0);
            let mut zh = self.tables.proxy_log_n::<N>(alpha);
            if let Some(w) = w {
                for l in 0..N {
                    zh[l] *= w[l];
                }
            }
            let inv = 1.0 / d;
            basis.add_zonal_n::<N, M>([v[0] * inv, v[1] * inv, v[2] * inv], &zh, &mut acc);
        }
        f[..M].copy_from_slice(&acc);
    }

    /// Adds one (already replaced) sphere's log visibility at `p` to `f` (`order²` entries).
    /// A receiver still inside the sphere (rules off) sees `α = 1`, the whole hemisphere.
    pub(crate) fn add_sphere_log(&self, p: [f32; 3], s: Sphere, f: &mut [f32]) {
        let v = sub(s.center, p);
        let d = dot(v, v).sqrt();
        if d.is_nan() || d <= 0.0 || s.radius.is_nan() || s.radius <= 0.0 {
            return;
        }
        let alpha = (s.radius / d).min(1.0);
        let mut zh = [0.0f32; MAX_ORDER];
        self.tables.proxy_log(alpha, &mut zh[..self.order]);
        let inv = 1.0 / d;
        self.tables.basis().add_zonal([v[0] * inv, v[1] * inv, v[2] * inv], &zh[..self.order], f);
    }

    /// The sphere a receiver at `(p, n)` accumulates for blocker `s` (the self-shadow rules of
    /// [`rules::replace`] when enabled).
    ///
    /// A blocker whose radius is not a positive finite number or whose centre is not finite
    /// (NaN through the API) is ignored, in every path (scalar, batched, product, indirect).
    #[inline]
    pub(crate) fn effective(&self, s: Sphere, p: [f32; 3], n: [f32; 3]) -> Option<Sphere> {
        if !s.is_valid() {
            return None;
        }
        if self.options.self_shadow_rules { rules::replace(s, p, n) } else { Some(s) }
    }
}
