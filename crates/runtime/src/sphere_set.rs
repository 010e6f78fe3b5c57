//! [`SphereSet`]: a validated, zero-copy view of an `SPHR` asset (sphere proxies of one
//! object, SHEXP §6.2–6.3), and the hierarchy cut with ratio vectors (SHEXP §6.3, eq. 36–38).
//!
//! Layout (see `schemas/asset-format.md`, SPHR): leaf spheres `[N, 4]`; optionally internal
//! nodes level by level from the root with `(first, count)` child ranges into the next level
//! (or the leaves), per-leaf skin influences and (kind_version 2) per-leaf albedo.

use crate::error::RuntimeError;
use crate::shadows::Sphere;
use penumbra_asset::{Asset, DType};

/// The sphere proxies of one object.
#[derive(Debug, Clone, Copy)]
pub struct SphereSet<'a> {
    leaves: &'a [f32],
    levels: &'a [u32],
    nodes: &'a [f32],
    children: &'a [u32],
    skin_nodes: Option<&'a [u32]>,
    skin_weights: Option<&'a [f32]>,
    albedo: Option<&'a [f32]>,
}

/// A node of the sphere tree as seen by a cut: a leaf or an internal node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeRef {
    /// Leaf `i` (index into the leaf spheres).
    Leaf(u32),
    /// Internal node `i` (index into all internal nodes, root = 0).
    Node(u32),
}

fn section<'a, T: penumbra_asset::Element>(
    asset: &Asset<'a>,
    name: &'static str,
    dtype: DType,
    cols: usize,
) -> Result<Option<(&'a [T], usize)>, RuntimeError> {
    let Some(s) = asset.section(name) else { return Ok(None) };
    let dims = s.dims();
    if s.dtype() != dtype || dims.len() != 2 || dims[1] != cols {
        return Err(RuntimeError::BadSection {
            name,
            reason: format!("expected {} [n, {cols}], found {} {dims:?}", dtype.name(), s.dtype().name()),
        });
    }
    let v = s.view::<T>().map_err(|e| RuntimeError::BadSection { name, reason: e.to_string() })?;
    Ok(Some((v, dims[0])))
}

impl<'a> SphereSet<'a> {
    /// Validates kind, shapes and every index of the hierarchy (never panics later).
    pub fn from_asset(asset: &Asset<'a>) -> Result<Self, RuntimeError> {
        if asset.kind().as_str() != "SPHR" {
            return Err(RuntimeError::WrongKind { expected: "SPHR", found: asset.kind().as_str().to_string() });
        }
        let (leaves, n) =
            section::<f32>(asset, "spheres", DType::F32, 4)?.ok_or(RuntimeError::MissingSection("spheres"))?;
        let bad = |name: &'static str, reason: &str| RuntimeError::BadSection { name, reason: reason.to_string() };
        if leaves.iter().any(|v| !v.is_finite()) || leaves.chunks_exact(4).any(|s| s[3] < 0.0) {
            return Err(bad("spheres", "non-finite value or negative radius"));
        }
        let lv = section::<u32>(asset, "hierarchy_levels", DType::U32, 2)?;
        let nd = section::<f32>(asset, "hierarchy_nodes", DType::F32, 4)?;
        let ch = section::<u32>(asset, "hierarchy_children", DType::U32, 2)?;
        let (levels, nodes, children) = match (lv, nd, ch) {
            (Some((l, nl)), Some((nodes, m)), Some((c, mc))) => {
                if mc != m {
                    return Err(bad("hierarchy_children", "row count differs from hierarchy_nodes"));
                }
                // levels tile the nodes in order; children index the next level (or the leaves)
                let mut next = 0u64;
                for k in 0..nl {
                    let (first, count) = (l[2 * k] as u64, l[2 * k + 1] as u64);
                    if first != next || count == 0 {
                        return Err(bad("hierarchy_levels", "levels must tile hierarchy_nodes in order"));
                    }
                    next = first + count;
                }
                if next != m as u64 || (nl > 0 && l[1] != 1) {
                    return Err(bad("hierarchy_levels", "levels must cover every node; level 0 is the root"));
                }
                for k in 0..nl {
                    let below = if k + 1 < nl { l[2 * k + 3] as u64 } else { n as u64 };
                    for node in l[2 * k]..l[2 * k] + l[2 * k + 1] {
                        let (f, cnt) = (c[2 * node as usize] as u64, c[2 * node as usize + 1] as u64);
                        if cnt == 0 || f + cnt > below {
                            return Err(bad("hierarchy_children", "child range out of the level below"));
                        }
                    }
                }
                if nodes.iter().any(|v| !v.is_finite()) {
                    return Err(bad("hierarchy_nodes", "non-finite value"));
                }
                (l, nodes, c)
            }
            (None, None, None) => (&[][..], &[][..], &[][..]),
            _ => return Err(bad("hierarchy_levels", "hierarchy sections must come together")),
        };
        let skin = match (
            section::<u32>(asset, "skin_nodes", DType::U32, 4)?,
            section::<f32>(asset, "skin_weights", DType::F32, 4)?,
        ) {
            (Some((sn, a)), Some((sw, b))) if a == n && b == n => (Some(sn), Some(sw)),
            (None, None) => (None, None),
            _ => return Err(bad("skin_nodes", "skin sections must come together, one row per sphere")),
        };
        let albedo = match section::<f32>(asset, "albedo", DType::F32, 3)? {
            None => None,
            Some((_, rows)) if rows != n => return Err(bad("albedo", "one row per sphere expected")),
            Some((v, _)) if v.iter().any(|x| !(0.0..=1.0).contains(x)) => {
                return Err(bad("albedo", "a value outside [0, 1] (or NaN)"));
            }
            Some((v, _)) => Some(v),
        };
        Ok(Self { leaves, levels, nodes, children, skin_nodes: skin.0, skin_weights: skin.1, albedo })
    }

    /// Number of leaf spheres.
    pub fn len(&self) -> usize {
        self.leaves.len() / 4
    }

    /// Whether there are no spheres.
    pub fn is_empty(&self) -> bool {
        self.leaves.is_empty()
    }

    /// Leaf sphere `i`.
    #[inline]
    pub fn leaf(&self, i: usize) -> Sphere {
        let s = &self.leaves[4 * i..4 * i + 4];
        Sphere { center: [s[0], s[1], s[2]], radius: s[3] }
    }

    /// Copies all leaves into `out` (cleared first).
    pub fn leaves_into(&self, out: &mut Vec<Sphere>) {
        out.clear();
        out.extend((0..self.len()).map(|i| self.leaf(i)));
    }

    /// Internal levels (0 without a hierarchy): the rows of the SPHR `hierarchy_levels`
    /// section. Counting the leaves, the tree has `depth() + 1` levels.
    pub fn depth(&self) -> usize {
        self.levels.len() / 2
    }

    /// Internal nodes (all levels).
    pub fn node_count(&self) -> usize {
        self.nodes.len() / 4
    }

    /// The stored sphere of internal node `i`.
    #[inline]
    fn node(&self, i: u32) -> Sphere {
        let s = &self.nodes[4 * i as usize..4 * i as usize + 4];
        Sphere { center: [s[0], s[1], s[2]], radius: s[3] }
    }

    /// The level of internal node `i`.
    fn level_of(&self, i: u32) -> usize {
        (0..self.depth()).find(|&k| i < self.levels[2 * k] + self.levels[2 * k + 1]).unwrap_or(0)
    }

    /// `(first node, node count)` of internal level `k` (root level 0).
    pub(crate) fn level(&self, k: usize) -> (u32, u32) {
        (self.levels[2 * k], self.levels[2 * k + 1])
    }

    /// `(first, count)` of internal node `i`'s children in the level below (or the leaves).
    pub(crate) fn child_range(&self, i: u32) -> (u32, u32) {
        (self.children[2 * i as usize], self.children[2 * i as usize + 1])
    }

    /// Whether the asset holds skin influences.
    pub fn is_skinned(&self) -> bool {
        self.skin_nodes.is_some()
    }

    /// Whether the asset stores a per-sphere albedo (SPHR kind_version 2, `albedo`).
    pub fn has_albedo(&self) -> bool {
        self.albedo.is_some()
    }

    /// Linear RGB albedo of leaf `i` in [0, 1] (`None` without an `albedo` section).
    pub fn albedo(&self, i: usize) -> Option<[f32; 3]> {
        let a = self.albedo?.get(3 * i..3 * i + 3)?;
        Some([a[0], a[1], a[2]])
    }

    /// Every leaf's albedo in leaf order into `out` (cleared first); `false` (and `out` empty)
    /// without an `albedo` section.
    pub fn albedo_into(&self, out: &mut Vec<[f32; 3]>) -> bool {
        out.clear();
        let Some(a) = self.albedo else { return false };
        out.extend(a.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        true
    }

    /// Skin influences of leaf `i`: glTF node indices and weights (`None` without skin data).
    pub fn skin(&self, i: usize) -> Option<([u32; 4], [f32; 4])> {
        let (n, w) = (self.skin_nodes?, self.skin_weights?);
        let a = &n[4 * i..4 * i + 4];
        let b = &w[4 * i..4 * i + 4];
        Some(([a[0], a[1], a[2], a[3]], [b[0], b[1], b[2], b[3]]))
    }
}

/// A sphere tree a cut can descend: the stored set ([`SphereSet`]) or a posed one
/// ([`PosedSpheres`](crate::sphere_pose::PosedSpheres)), which shares the stored topology.
pub trait SphereTree {
    /// Number of leaf spheres.
    fn leaf_count(&self) -> usize;

    /// The sphere of a node.
    fn sphere(&self, node: NodeRef) -> Sphere;

    /// The topology (levels and child ranges).
    fn topology(&self) -> &SphereSet<'_>;

    /// The root (or, without a hierarchy, nothing: cuts then use the leaves).
    fn root(&self) -> Option<NodeRef> {
        (self.topology().depth() > 0).then_some(NodeRef::Node(0))
    }

    /// Calls `f` on every child of internal node `i`.
    fn for_children(&self, i: u32, mut f: impl FnMut(NodeRef)) {
        let t = self.topology();
        let k = t.level_of(i);
        let (first, count) = (t.children[2 * i as usize], t.children[2 * i as usize + 1]);
        for c in first..first + count {
            if k + 1 < t.depth() {
                f(NodeRef::Node(t.levels[2 * (k + 1)] + c));
            } else {
                f(NodeRef::Leaf(c));
            }
        }
    }

    /// Calls `f` on every leaf below `node` (the node itself if it is a leaf).
    fn for_leaves_below(&self, node: NodeRef, f: &mut impl FnMut(u32)) {
        match node {
            NodeRef::Leaf(i) => f(i),
            NodeRef::Node(i) => self.for_children(i, |c| self.for_leaves_below(c, f)),
        }
    }

    /// The blocker list of a receiver cluster bounded by the sphere `(p_r, r_r)` (SHEXP §6.3,
    /// eq. 36): descending from the root, a node enters the list when it subtends less than
    /// `θ_max` over the whole cluster, `r < sin θ_max (‖P − p_R‖ − r_R)`; otherwise its
    /// children are tested; leaves always enter. Without a hierarchy the list is all leaves.
    /// `out` is cleared first; `stack` is scratch (reused across clusters).
    fn cut(&self, p_r: [f32; 3], r_r: f32, sin_theta_max: f32, stack: &mut Vec<NodeRef>, out: &mut Vec<NodeRef>) {
        out.clear();
        stack.clear();
        match self.root() {
            None => out.extend((0..self.leaf_count() as u32).map(NodeRef::Leaf)),
            Some(r) => stack.push(r),
        }
        while let Some(node) = stack.pop() {
            let s = self.sphere(node);
            let d = ((s.center[0] - p_r[0]).powi(2) + (s.center[1] - p_r[1]).powi(2) + (s.center[2] - p_r[2]).powi(2))
                .sqrt();
            match node {
                NodeRef::Leaf(_) => out.push(node),
                NodeRef::Node(i) => {
                    if s.radius < sin_theta_max * (d - r_r) {
                        out.push(node);
                    } else {
                        self.for_children(i, |c| stack.push(c));
                    }
                }
            }
        }
    }
}

impl SphereTree for SphereSet<'_> {
    fn leaf_count(&self) -> usize {
        self.len()
    }

    #[inline]
    fn sphere(&self, node: NodeRef) -> Sphere {
        match node {
            NodeRef::Leaf(i) => self.leaf(i as usize),
            NodeRef::Node(i) => self.node(i),
        }
    }

    fn topology(&self) -> &SphereSet<'_> {
        self
    }
}
