//! Hierarchy cuts with ratio vectors (SHEXP §6.3, eq. 37–38): the blockers of a receiver
//! cluster are the nodes of its cut, each with a per-band scale `w` fitted at the cluster's
//! central point so the node's bounding sphere blocks like the leaves below it.

use super::{N2, ShadowEvaluator, Sphere};
use crate::sh::MAX_ORDER;
use crate::sphere_set::{NodeRef, SphereTree};

/// A blocker of a receiver cluster (SHEXP §6.3): a node of the cluster's cut with its
/// ratio vector `w` (eq. 37, one weight per band; 1 for leaves).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutBlocker {
    /// The node's bounding sphere.
    pub sphere: Sphere,
    /// Per-band scaling of the sphere's log visibility (eq. 37).
    pub w: [f32; MAX_ORDER],
}

impl ShadowEvaluator<'_> {
    /// The blockers of a receiver cluster from its cut (see [`SphereTree::cut`]), with ratio
    /// vectors computed at the cluster's central point `(p_star, n_star)`:
    /// `w_l = Σ_m f_b f_d / Σ_m f_b²` with `f_b` the log visibility of the node's bounding
    /// sphere and `f_d` the summed log visibility of the leaves below it (SHEXP eq. 37; the
    /// self-shadow rules applied as at run time). `set` is a stored sphere set or a posed one.
    /// `out` is cleared first.
    pub fn cluster_blockers(
        &self,
        set: &impl SphereTree,
        cut: &[NodeRef],
        p_star: [f32; 3],
        n_star: [f32; 3],
        out: &mut Vec<CutBlocker>,
    ) {
        out.clear();
        let order = self.order;
        let n2 = order * order;
        for &node in cut {
            let sphere = set.sphere(node);
            let mut w = [1.0f32; MAX_ORDER];
            if let NodeRef::Node(_) = node {
                let mut fb = [0.0f32; N2];
                let mut fd = [0.0f32; N2];
                if let Some(s) = self.effective(sphere, p_star, n_star) {
                    self.add_sphere_log(p_star, s, &mut fb[..n2]);
                }
                set.for_leaves_below(node, &mut |leaf| {
                    if let Some(s) = self.effective(set.sphere(NodeRef::Leaf(leaf)), p_star, n_star) {
                        self.add_sphere_log(p_star, s, &mut fd[..n2]);
                    }
                });
                w = ratio_vector(&fb[..n2], &fd[..n2], order);
            }
            out.push(CutBlocker { sphere, w });
        }
    }
}

/// Largest ratio a band may take, relative to the DC ratio `w₀` (see [`ratio_vector`]).
pub const RATIO_BOUND: f32 = 4.0;
/// A band whose energy in `f_b` is below this fraction of the DC's is ill-conditioned.
pub const RATIO_BAND_FLOOR: f32 = 1e-3;

/// The ratio vector of a node (SHEXP eq. 37): per band `w_l = Σ_m f_b f_d / Σ_m f_b²`,
/// the least-squares scale of the node's log `f_b` onto its leaves' summed log `f_d`.
///
/// Bounded (issue #14): eq. 37 divides by the band energy of `f_b`, which nears zero for
/// large caps at high order (a band of the cap's ZH crosses zero; order 8, θ ≳ 29°), and the
/// ratio then explodes at every other receiver of the cluster. The DC ratio `w₀` is always
/// well conditioned (`f_b0 < 0`), so
/// - a band with `Σ_m f_b² < 10⁻³·f_b0²` takes `w₀`;
/// - every band is clamped to `[0, 4·max(w₀, 1)]` (a node's leaves never block more than
///   the node's bounding sphere does, per band, by more than that: overlap counts twice).
pub fn ratio_vector(fb: &[f32], fd: &[f32], order: usize) -> [f32; MAX_ORDER] {
    let mut w = [1.0f32; MAX_ORDER];
    let den0 = fb[0] * fb[0];
    if den0.is_nan() || den0 <= 0.0 {
        return w;
    }
    let w0 = (fb[0] * fd[0] / den0).max(0.0);
    let hi = RATIO_BOUND * w0.max(1.0);
    for l in 0..order {
        let (mut num, mut den) = (0.0f32, 0.0f32);
        for i in l * l..(l + 1) * (l + 1) {
            num += fb[i] * fd[i];
            den += fb[i] * fb[i];
        }
        let r = if den > RATIO_BAND_FLOOR * den0 { num / den } else { w0 };
        w[l] = if r.is_finite() { r.clamp(0.0, hi) } else { w0 };
    }
    w
}
