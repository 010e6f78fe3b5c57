//! Optimal linear (OL) exponential coefficients `a(‖f̂‖)`, `b(‖f̂‖)` (SHEXP §4.2) and the
//! domain in which OL is accurate.

use crate::exp::{SQRT_4PI, exp_exact, norm, without_dc};
use crate::gamma::TripleProduct;
use crate::log::{EPS_REL, log_eigen_zonal};
use crate::zonal::{cap_visibility, to_sh};
use core::f64::consts::PI;
use penumbra_math::sh::{ShEval, dir_from_angles, zh_rotate};

/// Accuracy threshold defining OL's accurate domain: relative L2 error
/// `‖exp_OL(f) − exp(M_f)·1‖ / ‖exp(M_f)·1‖` at most 2 % against the exact exponential of
/// eq. 28, for every member of the test family of blockers (see [`test_family`]) whose
/// `‖f̂‖` is at most the domain's bound.
///
/// Relation to SHEXP §4.2: the paper reports that a/b curves fitted to different blocker
/// models agree for `‖f̂‖ < 4.8` at order 4 (caps below 50°). We reproduce the geometry of
/// that statement — our 50° cap has `‖f̂‖ = 4.82` at order 4, and beyond it `‖f̂‖`
/// plateaus (4.82–6.36 for 50°–90°) while the shapes keep changing, so the table stops
/// being a function of the norm ([`cap_accurate_norm`] measures the single-cap domain).
/// Agreement of the curves is not accuracy, though: OL has only two degrees of freedom
/// and for *composite* blockers (two or three caps) its error passes 2 % at much smaller
/// norms (≈0.8 at order 4). We define the domain by error, which is what HYB relies on.
pub const OL_ACCURACY_REL: f64 = 0.02;

/// Worst-case relative error HYB must meet over the whole test family (all norms) when
/// choosing its scaling target [`OlTable::hyb_target_norm`]. Repeated truncated squaring
/// itself has an error floor of ≈4 % against eq. 28 on the largest members of the family
/// (PS*-2 shows the same floor), so 5 % means "as accurate as scaling/squaring allows".
pub const HYB_ACCURACY_REL: f64 = 0.05;

/// OL coefficients tabulated on a uniform grid of `‖f̂‖`.
#[derive(Debug, Clone)]
pub struct OlTable {
    /// `‖f̂‖` grid, uniform from 0 to `norms[last]`.
    pub norms: Vec<f64>,
    /// `a(‖f̂‖)`.
    pub a: Vec<f64>,
    /// `b(‖f̂‖)`.
    pub b: Vec<f64>,
    /// Largest `‖f̂‖` at which OL meets [`OL_ACCURACY_REL`] (HYB applies OL unscaled below it).
    pub accurate_norm: f64,
    /// Above `accurate_norm`, HYB scales `f̂` by `2^-s` until `‖f̂‖/2^s ≤ hyb_target_norm`.
    pub hyb_target_norm: f64,
}

/// One cap sample of the OL fit.
#[derive(Debug, Clone, Copy)]
pub struct OlSample {
    /// Cap half-angle (radians).
    pub theta: f64,
    /// `‖f̂‖` of its log.
    pub norm_hat: f64,
    /// SHEXP eq. 24 `a`.
    pub a: f64,
    /// SHEXP eq. 24 `b`.
    pub b: f64,
}

/// SHEXP eq. 24 for one cap of half-angle `theta`: `f = log g` by eigen-inversion,
/// `ĝ = exp(−f₀/√4π)·g`, `a = ĝ₀/√4π`, `b = ĝ·f̂/(f̂·f̂)`.
pub fn cap_ol_sample(t: &TripleProduct, theta: f64) -> OlSample {
    let n = t.order();
    let g = cap_visibility(n, theta);
    let f = log_eigen_zonal(t, &g, EPS_REL);
    let scale = (-f[0] / SQRT_4PI).exp();
    let a = scale * g[0] / SQRT_4PI;
    let fh: f64 = f[1..].iter().map(|x| x * x).sum();
    let b = if fh > 0.0 { scale * g[1..].iter().zip(&f[1..]).map(|(x, y)| x * y).sum::<f64>() / fh } else { 1.0 };
    OlSample { theta, norm_hat: fh.sqrt(), a, b }
}

impl OlTable {
    /// Builds the table from `fit_samples` caps with half-angles uniform in `(0, 90°]`,
    /// resampled to `grid` uniform `‖f̂‖` values up to the 90° cap's norm (monotone in θ,
    /// checked), then measures the accurate domain.
    pub fn build(t: &TripleProduct, fit_samples: usize, grid: usize) -> Self {
        let samples: Vec<OlSample> =
            (1..=fit_samples).map(|k| cap_ol_sample(t, 0.5 * PI * k as f64 / fit_samples as f64)).collect();
        let mut table = Self::from_samples(&samples, grid);
        let family = test_family(t);
        table.accurate_norm = accurate_norm(&family, &table);
        table.hyb_target_norm = hyb_target_norm(t, &family, &table);
        table
    }

    /// Resamples cap samples onto a uniform `‖f̂‖` grid (limit `a = b = 1` at 0).
    pub fn from_samples(samples: &[OlSample], grid: usize) -> Self {
        // Keep the monotone prefix in ‖f̂‖ so the tabulation is single-valued.
        let mut pts = vec![(0.0, 1.0, 1.0)];
        for s in samples {
            if s.norm_hat > pts.last().map(|p| p.0).unwrap_or(0.0) {
                pts.push((s.norm_hat, s.a, s.b));
            }
        }
        let max = pts.last().map(|p| p.0).unwrap_or(1.0);
        let mut norms = Vec::with_capacity(grid);
        let mut a = Vec::with_capacity(grid);
        let mut b = Vec::with_capacity(grid);
        let mut seg = 0;
        for k in 0..grid {
            let x = max * k as f64 / (grid - 1) as f64;
            while seg + 2 < pts.len() && pts[seg + 1].0 < x {
                seg += 1;
            }
            let (x0, a0, b0) = pts[seg];
            let (x1, a1, b1) = pts[(seg + 1).min(pts.len() - 1)];
            let w = if x1 > x0 { ((x - x0) / (x1 - x0)).clamp(0.0, 1.0) } else { 0.0 };
            norms.push(x);
            a.push(a0 + w * (a1 - a0));
            b.push(b0 + w * (b1 - b0));
        }
        Self { norms, a, b, accurate_norm: max, hyb_target_norm: max }
    }

    /// `(a, b)` at `‖f̂‖` by linear interpolation; clamped to the last entry beyond the
    /// table (the "baseline" continuation; HYB never goes there).
    pub fn lookup(&self, norm_hat: f64) -> (f64, f64) {
        let n = self.norms.len();
        let max = self.norms[n - 1];
        if norm_hat.is_nan() || norm_hat <= 0.0 {
            return (self.a[0], self.b[0]);
        }
        if norm_hat >= max {
            return (self.a[n - 1], self.b[n - 1]);
        }
        let x = norm_hat / max * (n - 1) as f64;
        let i = (x.floor() as usize).min(n - 2);
        let w = x - i as f64;
        (self.a[i] + w * (self.a[i + 1] - self.a[i]), self.b[i] + w * (self.b[i + 1] - self.b[i]))
    }
}

/// One member of the OL test family: a log vector and its exact exponential.
#[derive(Debug, Clone)]
pub struct FamilyMember {
    /// Accumulated log visibility.
    pub f: Vec<f64>,
    /// `exp(M_f)·1`.
    pub exact: Vec<f64>,
    /// `‖f̂‖`.
    pub norm_hat: f64,
}

/// Test family for the accurate domain ("models" in SHEXP §4.2): single caps of
/// 4°–90°, pairs of caps (half-angles 4°–60°, angular separations 0°–120°) and rows of
/// three caps, their logs summed as at run time. Deterministic; members in parallel.
pub fn test_family(t: &TripleProduct) -> Vec<FamilyMember> {
    let n = t.order();
    let eval = ShEval::new(n);
    let radii_deg: [f64; 9] = [4.0, 8.0, 12.0, 18.0, 25.0, 32.0, 40.0, 50.0, 60.0];
    let seps_deg: [f64; 6] = [0.0, 10.0, 25.0, 45.0, 70.0, 120.0];
    let cap_log = |theta_deg: f64, dir: [f64; 3]| {
        let g = cap_visibility(n, theta_deg.to_radians());
        let f = log_eigen_zonal(t, &g, EPS_REL);
        let mut out = vec![0.0; n * n];
        zh_rotate(&eval, &f, dir, &mut out);
        out
    };
    let mut logs: Vec<Vec<f64>> = Vec::new();
    for &r in radii_deg.iter().chain(&[70.0, 80.0, 90.0]) {
        logs.push(to_sh(&log_eigen_zonal(t, &cap_visibility(n, r.to_radians()), EPS_REL)));
    }
    for (i, &r1) in radii_deg.iter().enumerate() {
        for &r2 in &radii_deg[i..] {
            for &s in &seps_deg {
                let a = cap_log(r1, [0.0, 0.0, 1.0]);
                let b = cap_log(r2, dir_from_angles(s.to_radians(), 0.7));
                logs.push(a.iter().zip(&b).map(|(x, y)| x + y).collect());
            }
        }
    }
    for &r in &[6.0f64, 15.0, 30.0] {
        for &s in &[20.0f64, 50.0] {
            let mut acc = vec![0.0; n * n];
            for k in 0..3 {
                let c = cap_log(r, dir_from_angles((s * k as f64).to_radians(), 0.3 * k as f64));
                acc.iter_mut().zip(&c).for_each(|(x, y)| *x += y);
            }
            logs.push(acc);
        }
    }
    use rayon::prelude::*;
    logs.into_par_iter()
        .map(|f| {
            let exact = exp_exact(t, &f);
            let norm_hat = norm(&without_dc(&f));
            FamilyMember { f, exact, norm_hat }
        })
        .collect()
}

/// Relative error of OL on a family member.
pub fn ol_error(m: &FamilyMember, table: &OlTable) -> f64 {
    let g = crate::exp::exp_ol(&m.f, table);
    let d: f64 = g.iter().zip(&m.exact).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    d / norm(&m.exact).max(1e-300)
}

/// Largest `‖f̂‖` such that every family member with a smaller or equal norm meets
/// [`OL_ACCURACY_REL`].
pub fn accurate_norm(family: &[FamilyMember], table: &OlTable) -> f64 {
    let mut fam: Vec<(f64, f64)> = family.iter().map(|m| (m.norm_hat, ol_error(m, table))).collect();
    fam.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best = 0.0;
    for (nrm, err) in fam {
        if err > OL_ACCURACY_REL {
            // The domain ends just below the first failing member.
            return best;
        }
        best = nrm;
    }
    best
}

/// Relative error of HYB on a family member.
pub fn hyb_error(t: &TripleProduct, m: &FamilyMember, table: &OlTable) -> f64 {
    let g = crate::exp::exp_hyb(t, &m.f, table);
    let d: f64 = g.iter().zip(&m.exact).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    d / norm(&m.exact).max(1e-300)
}

/// The largest `accurate_norm / 2^k` (k = 0..=10) for which HYB's worst error over the
/// family is within [`HYB_ACCURACY_REL`]; if none is, the one with the smallest worst error.
pub fn hyb_target_norm(t: &TripleProduct, family: &[FamilyMember], table: &OlTable) -> f64 {
    let mut trial = table.clone();
    let mut best = (f64::MAX, table.accurate_norm);
    for k in 0..=10 {
        trial.hyb_target_norm = table.accurate_norm * 0.5f64.powi(k);
        let worst = family.iter().map(|m| hyb_error(t, m, &trial)).fold(0.0, f64::max);
        if worst <= HYB_ACCURACY_REL {
            return trial.hyb_target_norm;
        }
        if worst < best.0 {
            best = (worst, trial.hyb_target_norm);
        }
    }
    best.1
}

/// Largest `‖f̂‖` up to which OL meets [`OL_ACCURACY_REL`] for *single caps* (the
/// quantity comparable to SHEXP Fig. 3's 4.8 at order 4), scanning `samples` cap
/// half-angles in `(0, 90°]`.
pub fn cap_accurate_norm(t: &TripleProduct, table: &OlTable, samples: usize) -> f64 {
    let n = t.order();
    let mut best = 0.0;
    for k in 1..=samples {
        let theta = 0.5 * PI * k as f64 / samples as f64;
        let f = to_sh(&log_eigen_zonal(t, &cap_visibility(n, theta), EPS_REL));
        let m = FamilyMember { exact: exp_exact(t, &f), norm_hat: norm(&without_dc(&f)), f };
        if ol_error(&m, table) > OL_ACCURACY_REL {
            break;
        }
        best = m.norm_hat;
    }
    best
}
