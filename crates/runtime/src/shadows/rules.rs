//! The self-shadow replacement rules (SHEXP §6.2), written once: generic over the float type,
//! branch-free, so the scalar runtime (f32), its receiver batches (f32, lane by lane) and the
//! ray-traced references (f64, `penumbra verify shadows`) evaluate the same rule with the
//! same operations in the same order.
//!
//! For a blocker `S = (c, r)` seen from a receiver at `p` with unit outward normal `N`
//! (tangent plane `T_p`), let `h = (c − p)·N` (height of the centre above `T_p`), `q₁` the
//! projection of `c` onto `T_p` and `d_c = √(r² − h²)` the radius of the sphere's
//! cross-section with `T_p`.
//!
//! - `p` inside `S`: eliminated when `h ≤ 0`, else replaced by the sphere of radius `h`
//!   about `c` (tangent to `T_p` at `q₁`).
//! - `p` outside `S`: eliminated when entirely behind `T_p` (`h ≤ −r`), unchanged when
//!   entirely in front (`h ≥ r`); otherwise replaced by `S'`, the sphere tangent to `T_p`
//!   at `q₁` whose diameter is `q₀q₁`, `q₀ = c + rN`, i.e. radius `(h + r)/2`.
//!
//! Continuity. Both replacements are spheres tangent to `T_p` at `q₁`; only their radius
//! `ρ` differs (`max(h, 0)` inside, `(h + r)/2` outside), so the rule as stated jumps when
//! `p` leaves `S`. SHEXP fixes this by "gradually scaling up the radius of S' as a function
//! of p's distance to S along the tangent plane" with `α = max(1, (‖p − q₁‖ − d)/d)`,
//! `d = d_c`. As printed, `α ≥ 1` everywhere and equals 1 on the boundary, which cannot
//! make `ρ` continuous there (the text extraction may have lost a `min`). We implement the
//! stated intent: with `t = clamp((‖p − q₁‖ − d_c)/d_c, 0, 1)` — the same quantity, zero
//! on the boundary of `S` and 1 once `p` is `d_c` beyond it — the radius grows linearly
//! from the inside-rule radius to that of `S'`: `ρ = (1 − t)·max(h, 0) + t·(h + r)/2`.
//! The result is continuous in `p` (tested).

use super::Sphere;
use core::ops::{Add, Mul, Neg, Sub};

/// The float operations the rule needs (f32 at run time, f64 in the references).
pub trait Real:
    Copy + PartialOrd + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// 0.5.
    const HALF: Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// `self / rhs`.
    fn div(self, rhs: Self) -> Self;
    /// IEEE max (as `f32::max`).
    fn max(self, rhs: Self) -> Self;
    /// Clamp to `[lo, hi]` (as `f32::clamp`).
    fn clamp(self, lo: Self, hi: Self) -> Self;
}

macro_rules! real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn div(self, rhs: Self) -> Self {
                self / rhs
            }
            #[inline(always)]
            fn max(self, rhs: Self) -> Self {
                <$t>::max(self, rhs)
            }
            #[inline(always)]
            fn clamp(self, lo: Self, hi: Self) -> Self {
                <$t>::clamp(self, lo, hi)
            }
        }
    };
}
real!(f32);
real!(f64);

/// `h = (c − p)·N` and `‖c − p‖²`, as the rule computes them.
#[inline(always)]
fn height_and_distance2<T: Real>(c: [T; 3], p: [T; 3], n: [T; 3]) -> (T, T) {
    let (cpx, cpy, cpz) = (c[0] - p[0], c[1] - p[1], c[2] - p[2]);
    (cpx * n[0] + cpy * n[1] + cpz * n[2], cpx * cpx + cpy * cpy + cpz * cpz)
}

/// The "entirely in front, receiver outside" case (the blocker is kept as it is).
#[inline(always)]
fn unchanged_by<T: Real>(h: T, d2: T, r: T) -> bool {
    let inside = d2 < r * r;
    !inside && h >= r
}

/// Whether the rule keeps blocker `(c, r)` unchanged at `(p, n)` (entirely in front of `T_p`,
/// `p` outside it): then [`replace_parts`] returns `(c, r, true)` exactly for a valid blocker
/// (`r > 0`), and a caller may skip it. Same operations as the rule, so the same decision.
#[inline(always)]
pub fn unchanged<T: Real>(c: [T; 3], r: T, p: [T; 3], n: [T; 3]) -> bool {
    let (h, d2) = height_and_distance2(c, p, n);
    unchanged_by(h, d2, r)
}

/// The rule for blocker `(c, r)` at receiver `(p, n)`, every case evaluated and selected
/// (no early return, so a loop over receiver lanes vectorises): the effective centre and
/// radius, and whether the blocker is kept. A NaN anywhere gives `keep = false`.
#[inline(always)]
pub fn replace_parts<T: Real>(c: [T; 3], r: T, p: [T; 3], n: [T; 3]) -> ([T; 3], T, bool) {
    let (h, d2) = height_and_distance2(c, p, n);
    let q1 = [c[0] + n[0] * -h, c[1] + n[1] * -h, c[2] + n[2] * -h];
    // outside and straddling: the radius grows from the inside rule's to S''s
    let dc = (r * r - h * h).max(T::ZERO).sqrt();
    let (vx, vy, vz) = (p[0] - q1[0], p[1] - q1[1], p[2] - q1[2]);
    let in_plane = (vx * vx + vy * vy + vz * vz).sqrt();
    let t = if dc > T::ZERO { (in_plane - dc).div(dc).clamp(T::ZERO, T::ONE) } else { T::ONE };
    let straddle = (T::ONE - t) * h.max(T::ZERO) + t * T::HALF * (h + r);
    let inside = d2 < r * r;
    let unchanged = unchanged_by(h, d2, r);
    let removed = if inside { h <= T::ZERO } else { h <= -r };
    let rho = if inside { h } else { straddle };
    let center = [
        if unchanged { c[0] } else { q1[0] + n[0] * rho },
        if unchanged { c[1] } else { q1[1] + n[1] * rho },
        if unchanged { c[2] } else { q1[2] + n[2] * rho },
    ];
    let radius = if unchanged { r } else { rho };
    (center, radius, !removed && (unchanged || rho > T::ZERO))
}

/// The rule for one blocker `s` at receiver `(p, n)`: the sphere to accumulate, or `None` if
/// it is eliminated (see the module docs).
#[inline]
pub fn replace(s: Sphere, p: [f32; 3], n: [f32; 3]) -> Option<Sphere> {
    let (center, radius, keep) = replace_parts(s.center, s.radius, p, n);
    keep.then_some(Sphere { center, radius })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replacement_rules_cases() {
        let n = [0.0, 0.0, 1.0];
        let p = [0.0, 0.0, 0.0];
        // entirely in front: unchanged
        let s = Sphere { center: [0.0, 0.0, 3.0], radius: 1.0 };
        assert_eq!(replace(s, p, n), Some(s));
        // entirely behind: removed
        assert_eq!(replace(Sphere { center: [2.0, 0.0, -1.5], radius: 1.0 }, p, n), None);
        // contains p, centre behind: removed
        assert_eq!(replace(Sphere { center: [0.1, 0.0, -0.2], radius: 1.0 }, p, n), None);
        // contains p, centre in front: radius = height, tangent to the plane
        let r = replace(Sphere { center: [0.1, 0.0, 0.3], radius: 1.0 }, p, n).unwrap();
        assert!((r.radius - 0.3).abs() < 1e-6 && (r.center[2] - 0.3).abs() < 1e-6);
        // straddling, far along the plane: S' with diameter q0 q1 (radius (h+r)/2)
        let r = replace(Sphere { center: [10.0, 0.0, 0.5], radius: 1.0 }, p, n).unwrap();
        assert!((r.radius - 0.75).abs() < 1e-6 && (r.center[2] - 0.75).abs() < 1e-6 && r.center[0] == 10.0);
        // NaN radius or centre: dropped
        assert_eq!(replace(Sphere { center: [0.0, 0.0, 3.0], radius: f32::NAN }, p, n), None);
        assert_eq!(replace(Sphere { center: [f32::NAN, 0.0, 3.0], radius: 1.0 }, p, n), None);
    }

    #[test]
    fn f64_rule_agrees_with_f32_rule() {
        // the references' f64 instance of the rule gives the runtime's spheres to f32 precision
        let n = [0.0f64, 0.6, 0.8];
        for k in 0..200 {
            let x = -2.0 + 4.0 * (k as f64) / 199.0;
            let c = [x, 0.3 * x, 0.2 - 0.1 * x];
            let (c64, r64, k64) = replace_parts(c, 0.9, [0.1, 0.0, 0.0], n);
            let (c32, r32, k32) = replace_parts(c.map(|v| v as f32), 0.9f32, [0.1f32, 0.0, 0.0], n.map(|v| v as f32));
            assert_eq!(k64, k32, "x={x}");
            if k64 {
                assert!((r64 - r32 as f64).abs() < 1e-5 && (0..3).all(|i| (c64[i] - c32[i] as f64).abs() < 1e-5));
            }
        }
    }

    #[test]
    fn replacement_is_continuous_leaving_the_sphere() {
        // Receiver moves along the plane out of a sphere straddling it, for centres above
        // and below the plane: the replacement radius never jumps.
        let n = [0.0, 0.0, 1.0];
        for h in [-0.6f32, -0.1, 0.0, 0.2, 0.7] {
            let s = Sphere { center: [0.0, 0.0, h], radius: 1.0 };
            let mut prev: Option<f32> = None;
            for k in 0..=4000 {
                let x = 3.0 * k as f32 / 4000.0;
                let rho = replace(s, [x, 0.0, 0.0], n).map_or(0.0, |r| r.radius);
                if let Some(pr) = prev {
                    assert!((rho - pr).abs() < 2e-3, "h={h} x={x}: {pr} -> {rho}");
                }
                prev = Some(rho);
            }
        }
    }
}
