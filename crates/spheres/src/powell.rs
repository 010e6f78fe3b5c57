//! Powell's direction-set method in three dimensions with Brent line minimisation
//! (Press et al., *Numerical Recipes*, §10.2 and §10.7), derivative-free as SHEXP §6.2 uses it
//! for sphere centres.
//!
//! The objectives here (outside volume with a bounding-radius constraint, the radius of a
//! bounding sphere) are continuous but only piecewise smooth, so the line search brackets
//! and then falls back to golden sections wherever the parabola is not trusted.

/// Settings of one minimisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowellSettings {
    /// Length of the initial search directions (the coordinate axes scaled by it).
    pub step: f64,
    /// Absolute position tolerance of the line searches.
    pub xtol: f64,
    /// Stop when an iteration lowers the value by less than `ftol · |f|` (+ a tiny absolute).
    pub ftol: f64,
    /// Maximum number of direction-set iterations.
    pub max_iterations: usize,
}

/// Result of a minimisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowellResult {
    /// The best point found.
    pub x: [f64; 3],
    /// Its value.
    pub f: f64,
    /// Objective evaluations spent.
    pub evaluations: usize,
}

const GOLD: f64 = 1.618_033_988_749_895;
const CGOLD: f64 = 0.381_966_011_250_105;

#[inline]
fn along(x: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [x[0] + t * d[0], x[1] + t * d[1], x[2] + t * d[2]]
}

/// Minimises `f` along `x + t·d` starting from `t = 0` (value `fx`); returns `(t, f)`.
fn line_min(
    f: &mut impl FnMut([f64; 3]) -> f64,
    x: [f64; 3],
    d: [f64; 3],
    fx: f64,
    xtol: f64,
    evals: &mut usize,
) -> (f64, f64) {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if len == 0.0 || !len.is_finite() {
        return (0.0, fx);
    }
    let tol = xtol / len; // in units of t
    let mut g = |t: f64| {
        *evals += 1;
        f(along(x, d, t))
    };
    // bracket: a < b < c (or reversed) with f(b) ≤ f(a), f(c)
    let (mut a, mut fa) = (0.0, fx);
    let (mut b, mut fb) = (1.0, g(1.0));
    if fb > fa {
        std::mem::swap(&mut a, &mut b);
        std::mem::swap(&mut fa, &mut fb);
    }
    let mut c = b + GOLD * (b - a);
    let mut fc = g(c);
    let mut guard = 0;
    while fc < fb && guard < 40 {
        a = b;
        fa = fb;
        b = c;
        fb = fc;
        c = b + GOLD * (b - a);
        fc = g(c);
        guard += 1;
    }
    let _ = fa;
    // Brent on [min(a,c), max(a,c)] starting from b
    let (mut lo, mut hi) = if a < c { (a, c) } else { (c, a) };
    let (mut xb, mut fxb) = (b, fb); // best
    let (mut w, mut fw) = (b, fb); // second best
    let (mut v, mut fv) = (b, fb); // previous w
    let mut e: f64 = 0.0;
    let mut step: f64 = 0.0;
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        let tol1 = tol + 1e-12 * xb.abs();
        let tol2 = 2.0 * tol1;
        if (xb - mid).abs() <= tol2 - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // parabola through (v, w, x)
            let r = (xb - w) * (fxb - fv);
            let mut q = (xb - v) * (fxb - fw);
            let mut p = (xb - v) * q - (xb - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = step;
            if !(p.abs() >= (0.5 * q * etemp).abs() || p <= q * (lo - xb) || p >= q * (hi - xb)) {
                step = p / q;
                let u = xb + step;
                if u - lo < tol2 || hi - u < tol2 {
                    step = if mid >= xb { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if xb >= mid { lo - xb } else { hi - xb };
            step = CGOLD * e;
        }
        let u = if step.abs() >= tol1 { xb + step } else { xb + if step >= 0.0 { tol1 } else { -tol1 } };
        let fu = g(u);
        if fu <= fxb {
            if u >= xb {
                lo = xb;
            } else {
                hi = xb;
            }
            v = w;
            fv = fw;
            w = xb;
            fw = fxb;
            xb = u;
            fxb = fu;
        } else {
            if u < xb {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == xb {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if fu <= fv || v == xb || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    if fxb <= fx { (xb, fxb) } else { (0.0, fx) }
}

/// Minimises `f` from `x0` by Powell's method (direction set initialised to the scaled
/// coordinate axes; the direction of largest decrease is replaced by the net displacement
/// when the NR criterion allows).
pub fn minimize(mut f: impl FnMut([f64; 3]) -> f64, x0: [f64; 3], s: &PowellSettings) -> PowellResult {
    let mut evals = 1;
    let mut x = x0;
    let mut fx = f(x);
    let mut dirs = [[s.step, 0.0, 0.0], [0.0, s.step, 0.0], [0.0, 0.0, s.step]];
    for _ in 0..s.max_iterations {
        let (x_start, f_start) = (x, fx);
        let mut biggest = 0usize;
        let mut biggest_drop = 0.0;
        for (i, d) in dirs.iter().enumerate() {
            let before = fx;
            let (t, ft) = line_min(&mut f, x, *d, fx, s.xtol, &mut evals);
            x = along(x, *d, t);
            fx = ft;
            if before - fx > biggest_drop {
                biggest_drop = before - fx;
                biggest = i;
            }
        }
        if 2.0 * (f_start - fx) <= s.ftol * (f_start.abs() + fx.abs()) + 1e-300 {
            break;
        }
        // extrapolated point and the new direction
        let dnew = [x[0] - x_start[0], x[1] - x_start[1], x[2] - x_start[2]];
        let xe = along(x, dnew, 1.0);
        let fe = f(xe);
        evals += 1;
        if fe < f_start {
            let t = 2.0 * (f_start - 2.0 * fx + fe) * (f_start - fx - biggest_drop).powi(2)
                - biggest_drop * (f_start - fe).powi(2);
            if t < 0.0 {
                let (tm, fm) = line_min(&mut f, x, dnew, fx, s.xtol, &mut evals);
                x = along(x, dnew, tm);
                fx = fm;
                dirs[biggest] = dirs[2];
                dirs[2] = dnew;
            }
        }
    }
    PowellResult { x, f: fx, evaluations: evals }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_a_rotated_quadratic() {
        let f = |p: [f64; 3]| {
            let (x, y, z) = (p[0] - 1.0, p[1] + 2.0, p[2] - 0.5);
            3.0 * x * x + 2.0 * y * y + z * z + 1.5 * x * y - 0.7 * y * z + 4.0
        };
        let s = PowellSettings { step: 0.5, xtol: 1e-8, ftol: 1e-14, max_iterations: 50 };
        let r = minimize(f, [0.0; 3], &s);
        assert!((r.f - 4.0).abs() < 1e-10, "{r:?}");
        assert!((r.x[0] - 1.0).abs() < 1e-4 && (r.x[1] + 2.0).abs() < 1e-4 && (r.x[2] - 0.5).abs() < 1e-4, "{r:?}");
    }

    #[test]
    fn never_returns_worse_than_the_start() {
        let f = |p: [f64; 3]| if p[0] > 0.0 { 1.0 } else { 2.0 };
        let s = PowellSettings { step: 1.0, xtol: 1e-6, ftol: 1e-9, max_iterations: 5 };
        let r = minimize(f, [0.5, 0.0, 0.0], &s);
        assert_eq!(r.f, 1.0);
    }
}
