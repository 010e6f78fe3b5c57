//! Posing a skinned sphere set (SHEXP §6.2 "Animation", §6.3 "Construction and Animation"):
//! leaf centres by linear blend skinning of their stored influences, radii kept, and the
//! hierarchy refitted bottom-up with a
//! sphere-pair bound so every node still bounds its children in the pose — cuts (eq. 36)
//! and ratio vectors (eq. 37) then stay valid.
//!
//! Convention (schemas/asset-format.md, SPHR `skin_nodes`/`skin_weights`): a leaf with
//! influences `(nᵦ, Wᵦ)` is posed as `P' = Σᵦ Wᵦ · Mₙᵦ · P`, where `Mₙ = Gₙ(t)·Gₙ(rest)⁻¹`
//! is glTF node `n`'s global transform in the pose times the inverse of its rest-pose global
//! transform (for a skin joint, equivalently `S(t)·S(rest)⁻¹` with the skinning matrix
//! `S = G·IBM`). The engine supplies `M` per node as a column-major 4×4 matrix (glTF order;
//! the last row is ignored: affine).

use crate::error::RuntimeError;
use crate::shadows::Sphere;
use crate::sphere_set::{NodeRef, SphereSet, SphereTree};

/// A posed sphere set: leaves and internal nodes of a [`SphereSet`] moved to one pose, with
/// the stored topology. Reuse one value across frames: [`PosedSpheres::pose`] allocates only
/// the first time.
#[derive(Debug, Clone)]
pub struct PosedSpheres<'a> {
    set: SphereSet<'a>,
    leaves: Vec<Sphere>,
    nodes: Vec<Sphere>,
}

/// The smallest sphere containing spheres `a` and `b` (the sphere-pair bound of SHEXP §6.3).
/// Exact in real arithmetic; in f32 the radius is raised by 2 ulp-scale units of the
/// extent so rounding never leaves a child outside.
pub fn pair_bound(a: Sphere, b: Sphere) -> Sphere {
    let v = [b.center[0] - a.center[0], b.center[1] - a.center[1], b.center[2] - a.center[2]];
    let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if d + b.radius <= a.radius {
        return a;
    }
    if d + a.radius <= b.radius {
        return b;
    }
    let r = 0.5 * (d + a.radius + b.radius);
    let t = (r - a.radius) / d; // d > |ra − rb| ≥ 0 here
    let c = [a.center[0] + v[0] * t, a.center[1] + v[1] * t, a.center[2] + v[2] * t];
    let extent = c.iter().fold(r, |m, x| m.max(x.abs()));
    Sphere { center: c, radius: r + 4.0 * f32::EPSILON * extent }
}

impl<'a> PosedSpheres<'a> {
    /// The rest pose of `set` (stored leaves and nodes; no skin needed).
    pub fn rest(set: SphereSet<'a>) -> Self {
        let leaves = (0..set.len()).map(|i| set.leaf(i)).collect();
        let nodes = (0..set.node_count() as u32).map(|i| set.sphere(NodeRef::Node(i))).collect();
        Self { set, leaves, nodes }
    }

    /// Poses every leaf from its skin influences with the per-node matrices `node_matrices`
    /// (column-major 4×4, see the module docs) and refits the hierarchy bottom-up.
    ///
    /// Errors, leaving `self` unchanged: the set has no skin; a leaf names a node (with
    /// non-zero weight) beyond `node_matrices`; a matrix holds a non-finite value.
    pub fn pose(&mut self, node_matrices: &[[f32; 16]]) -> Result<(), RuntimeError> {
        let set = self.set;
        if !set.is_skinned() {
            return Err(RuntimeError::Invalid("the sphere set has no skin influences (bake with --skin)".into()));
        }
        if let Some(k) = node_matrices.iter().position(|m| m.iter().any(|v| !v.is_finite())) {
            return Err(RuntimeError::Invalid(format!("node matrix {k} holds a non-finite value")));
        }
        for i in 0..set.len() {
            if let Some((nodes, weights)) = set.skin(i) {
                for b in 0..4 {
                    if weights[b] != 0.0 && nodes[b] as usize >= node_matrices.len() {
                        return Err(RuntimeError::Invalid(format!(
                            "sphere {i} is bound to node {} but only {} node matrices were given",
                            nodes[b],
                            node_matrices.len()
                        )));
                    }
                }
            }
        }
        self.leaves.clear();
        for i in 0..set.len() {
            let s = set.leaf(i);
            let mut c = [0.0f32; 3];
            if let Some((nodes, weights)) = set.skin(i) {
                for b in 0..4 {
                    let w = weights[b];
                    if w == 0.0 {
                        continue;
                    }
                    let m = &node_matrices[nodes[b] as usize];
                    let p = s.center;
                    for r in 0..3 {
                        c[r] += w * (m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
                    }
                }
            }
            self.leaves.push(Sphere { center: c, radius: s.radius });
        }
        self.refit();
        Ok(())
    }

    /// Moves leaf spheres directly (any deformation the engine computes itself) and refits the
    /// hierarchy. `leaves` must hold one sphere per stored leaf.
    pub fn set_leaves(&mut self, leaves: &[Sphere]) -> Result<(), RuntimeError> {
        if leaves.len() != self.set.len() {
            return Err(RuntimeError::Invalid(format!(
                "{} leaf spheres given, the set has {}",
                leaves.len(),
                self.set.len()
            )));
        }
        self.leaves.clear();
        self.leaves.extend_from_slice(leaves);
        self.refit();
        Ok(())
    }

    /// Bottom-up refit (SHEXP §6.3): each internal node, deepest level first, becomes the
    /// sphere-pair bound of its children merged in one after another.
    fn refit(&mut self) {
        let set = self.set;
        self.nodes.resize(set.node_count(), Sphere { center: [0.0; 3], radius: 0.0 });
        for k in (0..set.depth()).rev() {
            let (first, count) = set.level(k);
            let below = (k + 1 < set.depth()).then(|| set.level(k + 1).0);
            for i in first..first + count {
                let (cf, cc) = set.child_range(i);
                let child = |c: u32| match below {
                    Some(f) => self.nodes[(f + c) as usize],
                    None => self.leaves[c as usize],
                };
                let mut b = child(cf);
                for c in cf + 1..cf + cc {
                    b = pair_bound(b, child(c));
                }
                self.nodes[i as usize] = b;
            }
        }
    }

    /// The posed leaves.
    pub fn leaves(&self) -> &[Sphere] {
        &self.leaves
    }
}

impl SphereTree for PosedSpheres<'_> {
    fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    #[inline]
    fn sphere(&self, node: NodeRef) -> Sphere {
        match node {
            NodeRef::Leaf(i) => self.leaves[i as usize],
            NodeRef::Node(i) => self.nodes[i as usize],
        }
    }

    fn topology(&self) -> &SphereSet<'_> {
        &self.set
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contains(outer: Sphere, inner: Sphere) -> bool {
        let d = (0..3).map(|k| (outer.center[k] - inner.center[k]).powi(2)).sum::<f32>().sqrt();
        d + inner.radius <= outer.radius
    }

    #[test]
    fn pair_bound_is_the_smallest_enclosing_sphere() {
        let a = Sphere { center: [0.0, 0.0, 0.0], radius: 1.0 };
        let b = Sphere { center: [3.0, 0.0, 0.0], radius: 0.5 };
        let s = pair_bound(a, b);
        // extreme points −1 and 3.5: centre 1.25, radius 2.25
        assert!((s.center[0] - 1.25).abs() < 1e-6 && (s.radius - 2.25).abs() < 1e-5, "{s:?}");
        assert!(contains(s, a) && contains(s, b));
        // nested: the outer one
        let c = Sphere { center: [0.2, 0.0, 0.0], radius: 0.3 };
        assert_eq!(pair_bound(a, c), a);
        assert_eq!(pair_bound(c, a), a);
        // many random pairs: both contained, radius within f32 slack of the exact value
        let mut x = 0x1234_5678u32;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32) * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let a = Sphere { center: [100.0 * rnd(), rnd(), rnd()], radius: 0.1 + rnd().abs() };
            let b = Sphere { center: [100.0 * rnd(), rnd(), rnd()], radius: 0.1 + rnd().abs() };
            let s = pair_bound(a, b);
            assert!(contains(s, a) && contains(s, b), "{a:?} {b:?} -> {s:?}");
        }
    }
}
