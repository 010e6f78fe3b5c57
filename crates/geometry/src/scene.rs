//! Imported scene: the world-space triangle mesh plus, for glTF, the node hierarchy, skins
//! and animations as plain data, and posing by linear blend skinning.
//!
//! Conventions (glTF 2.0): right-handed, +Y up, metres unless the file says otherwise;
//! quaternions are `[x, y, z, w]`; matrices are column-major `[[f64; 4]; 4]` (`m[col][row]`).
//! A node's local transform is `T · R · S`; a vertex of a skinned mesh is posed as
//! `Σᵢ wᵢ · G(jointᵢ) · IBMᵢ · p`, where `G` is the joint's global transform and `p` the
//! vertex in the mesh's own space; the transform of the node holding a skinned mesh is
//! ignored, as the glTF specification requires. Vertices of non-skinned meshes follow the
//! global transform of their node (so rigidly animated parts move too).

use glam::{DMat4, DQuat, DVec3};

use crate::mesh::TriMesh;
use crate::texture::{BaseColorTexture, SceneImage};

/// A column-major 4×4 matrix, `m[col][row]` (glTF layout).
pub type Mat4 = [[f64; 4]; 4];

/// Local transform of a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trs {
    /// Translation.
    pub translation: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// Per-axis scale.
    pub scale: [f64; 3],
}

impl Default for Trs {
    fn default() -> Self {
        Self { translation: [0.0; 3], rotation: [0.0, 0.0, 0.0, 1.0], scale: [1.0; 3] }
    }
}

impl Trs {
    /// `T · R · S` as a matrix.
    pub fn matrix(&self) -> Mat4 {
        to_dmat4_trs(self).to_cols_array_2d()
    }
}

fn to_dmat4_trs(t: &Trs) -> DMat4 {
    let q = DQuat::from_array(t.rotation);
    let q = if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY };
    DMat4::from_scale_rotation_translation(DVec3::from(t.scale), q, DVec3::from(t.translation))
}

/// A node of the glTF hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Name from the file, if any.
    pub name: Option<String>,
    /// Parent node (`None` for roots).
    pub parent: Option<usize>,
    /// Child nodes.
    pub children: Vec<usize>,
    /// Rest-pose local transform (decomposed if the file gave a matrix).
    pub rest: Trs,
    /// The file's local matrix when it gave one instead of TRS; used at rest and when no
    /// animation channel targets the node (a matrix with shear cannot be decomposed exactly).
    pub matrix: Option<Mat4>,
    /// The node's glTF `extras` as raw JSON text, when the file gives them (`penumbra plan`
    /// reads its roles from `extras.penumbra`).
    pub extras: Option<String>,
}

/// A skin: the joints (node indices) and their inverse bind matrices.
#[derive(Debug, Clone, PartialEq)]
pub struct Skin {
    /// Name from the file, if any.
    pub name: Option<String>,
    /// Joint `i` is node `joints[i]`.
    pub joints: Vec<usize>,
    /// One inverse bind matrix per joint (identity where the file has none).
    pub inverse_bind_matrices: Vec<Mat4>,
    /// The skeleton root node, if the file names one.
    pub skeleton: Option<usize>,
}

/// The node property an animation channel drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnimProperty {
    /// Translation, 3 components per key.
    Translation,
    /// Rotation quaternion `[x, y, z, w]`, 4 components per key.
    Rotation,
    /// Scale, 3 components per key.
    Scale,
    /// Morph-target weights, one component per target. Parsed and exposed; morph targets
    /// themselves are not applied to the geometry (reported as a warning on import).
    Weights,
}

/// Keyframe interpolation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// Linear (spherical linear for rotations).
    Linear,
    /// Piecewise constant.
    Step,
    /// Cubic Hermite spline with in/out tangents stored per key.
    CubicSpline,
}

/// Keyframes of one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampler {
    /// Interpolation mode.
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing.
    pub times: Vec<f64>,
    /// Key values, `components` per element; for [`Interpolation::CubicSpline`] each key holds
    /// three elements in the order in-tangent, value, out-tangent (glTF layout).
    pub values: Vec<f64>,
    /// Components per element (3 translation/scale, 4 rotation, target count for weights).
    pub components: usize,
}

/// One animation channel: a sampler driving a property of a node.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Target node index.
    pub node: usize,
    /// Target property.
    pub property: AnimProperty,
    /// Keyframes.
    pub sampler: Sampler,
}

/// An animation clip.
#[derive(Debug, Clone, PartialEq)]
pub struct Animation {
    /// Name from the file, if any.
    pub name: Option<String>,
    /// Channels.
    pub channels: Vec<Channel>,
}

impl Animation {
    /// Time span `[start, end]` covered by the keys of all channels (`[0, 0]` if none).
    pub fn time_range(&self) -> [f64; 2] {
        let mut r = [f64::INFINITY, f64::NEG_INFINITY];
        for c in &self.channels {
            if let (Some(a), Some(b)) = (c.sampler.times.first(), c.sampler.times.last()) {
                r[0] = r[0].min(*a);
                r[1] = r[1].max(*b);
            }
        }
        if r[0] > r[1] { [0.0, 0.0] } else { r }
    }
}

/// Skinning data of one vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexSkin {
    /// Index into [`Scene::skins`].
    pub skin: u32,
    /// Up to four joints, as indices into that skin's `joints`.
    pub joints: [u32; 4],
    /// Their weights, non-negative, summing to 1 (unused slots have weight 0).
    pub weights: [f64; 4],
}

/// How a vertex of [`Scene::mesh`] is attached to the hierarchy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexBinding {
    /// Position in the mesh's own space (before any node transform or skinning).
    pub local: [f64; 3],
    /// The node that instantiates the mesh (`None`: the file has no nodes and the mesh is
    /// used with the identity transform).
    pub node: Option<u32>,
    /// Skinning, for vertices of a skinned mesh.
    pub skin: Option<VertexSkin>,
}

/// A loaded scene. For OBJ only `mesh` is filled.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    /// All triangles in world space at the rest pose.
    pub mesh: TriMesh,
    /// glTF nodes (empty for OBJ).
    pub nodes: Vec<Node>,
    /// glTF skins.
    pub skins: Vec<Skin>,
    /// glTF animations.
    pub animations: Vec<Animation>,
    /// One binding per vertex of `mesh` (empty for OBJ).
    pub bindings: Vec<VertexBinding>,
    /// glTF `TEXCOORD_1` (lightmap UVs) per vertex of `mesh`; empty unless every triangle
    /// primitive has it (and for OBJ).
    pub uv1: Vec<[f64; 2]>,
    /// glTF material `baseColorFactor` (linear RGBA, as stored) of each vertex's primitive, per
    /// vertex of `mesh`; `None` for a primitive without a material. Empty for OBJ and for
    /// glTF files in which no primitive has a material. The texture, if any, is in
    /// `base_color_texture`.
    pub base_color: Vec<Option<[f64; 4]>>,
    /// Per vertex of `mesh`: the `baseColorTexture` of its primitive's material and the
    /// vertex's UV in that texture's `TEXCOORD_n` set (`None`: no texture). Empty when no
    /// primitive has one (and for OBJ).
    pub base_color_texture: Vec<Option<(BaseColorTexture, [f64; 2])>>,
    /// The glTF `images` array, encoded ([`crate::texture::MipChain::decode`] decodes one).
    /// Empty for OBJ.
    pub images: Vec<SceneImage>,
}

/// Errors of [`Scene::pose`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// The animation index does not exist.
    #[error("animation {index} does not exist ({count} animations)")]
    NoSuchAnimation {
        /// Requested index.
        index: usize,
        /// Number of animations.
        count: usize,
    },
    /// The time is NaN or infinite.
    #[error("animation time {0} is not finite")]
    BadTime(f64),
    /// The scene has no hierarchy (OBJ).
    #[error("the scene has no node hierarchy to pose")]
    NoHierarchy,
}

impl Scene {
    /// Whether any vertex is skinned.
    pub fn is_skinned(&self) -> bool {
        self.bindings.iter().any(|b| b.skin.is_some())
    }

    /// Rest-pose local transforms of all nodes, as matrices.
    fn rest_locals(&self) -> Vec<DMat4> {
        self.nodes
            .iter()
            .map(|n| match n.matrix {
                Some(m) => DMat4::from_cols_array_2d(&m),
                None => to_dmat4_trs(&n.rest),
            })
            .collect()
    }

    /// Local transforms of all nodes with `animation` applied at `time` (seconds; clamped to
    /// each channel's key range, as glTF players do).
    pub fn local_transforms(&self, animation: Option<usize>, time: f64) -> Result<Vec<Mat4>, PoseError> {
        Ok(self.local_dmat4(animation, time)?.iter().map(|m| m.to_cols_array_2d()).collect())
    }

    fn local_dmat4(&self, animation: Option<usize>, time: f64) -> Result<Vec<DMat4>, PoseError> {
        let Some(a) = animation else {
            return Ok(self.rest_locals());
        };
        let anim =
            self.animations.get(a).ok_or(PoseError::NoSuchAnimation { index: a, count: self.animations.len() })?;
        if !time.is_finite() {
            return Err(PoseError::BadTime(time));
        }
        let mut trs: Vec<Trs> = self.nodes.iter().map(|n| n.rest).collect();
        let mut touched = vec![false; self.nodes.len()];
        for c in &anim.channels {
            let Some(t) = trs.get_mut(c.node) else { continue };
            let mut v = [0.0f64; 4];
            let n = c.sampler.components.min(4);
            match c.property {
                AnimProperty::Translation => {
                    sample(&c.sampler, time, false, &mut v[..n]);
                    t.translation = [v[0], v[1], v[2]];
                }
                AnimProperty::Scale => {
                    sample(&c.sampler, time, false, &mut v[..n]);
                    t.scale = [v[0], v[1], v[2]];
                }
                AnimProperty::Rotation => {
                    sample(&c.sampler, time, true, &mut v[..n]);
                    t.rotation = v;
                }
                AnimProperty::Weights => continue,
            }
            touched[c.node] = true;
        }
        Ok(self
            .nodes
            .iter()
            .zip(trs.iter().zip(&touched))
            .map(|(node, (t, &touched))| match (node.matrix, touched) {
                (Some(m), false) => DMat4::from_cols_array_2d(&m),
                _ => to_dmat4_trs(t),
            })
            .collect())
    }

    /// Global (world) transforms of all nodes at rest (`animation = None`) or posed.
    pub fn global_transforms(&self, animation: Option<usize>, time: f64) -> Result<Vec<Mat4>, PoseError> {
        Ok(self.global_dmat4(animation, time)?.iter().map(|m| m.to_cols_array_2d()).collect())
    }

    fn global_dmat4(&self, animation: Option<usize>, time: f64) -> Result<Vec<DMat4>, PoseError> {
        let local = self.local_dmat4(animation, time)?;
        // the importer guarantees an acyclic hierarchy; resolve parents first
        let mut global: Vec<Option<DMat4>> = vec![None; self.nodes.len()];
        let mut chain = Vec::new();
        for start in 0..self.nodes.len() {
            let mut n = start;
            chain.clear();
            while global[n].is_none() {
                chain.push(n);
                match self.nodes[n].parent {
                    Some(p) if chain.len() <= self.nodes.len() => n = p,
                    _ => break,
                }
            }
            for &c in chain.iter().rev() {
                let parent = self.nodes[c].parent.and_then(|p| global[p]).unwrap_or(DMat4::IDENTITY);
                global[c] = Some(parent * local[c]);
            }
        }
        Ok(global.into_iter().map(|g| g.unwrap_or(DMat4::IDENTITY)).collect())
    }

    /// Vertex positions (same indexing as `mesh.positions`) at rest (`animation = None`) or
    /// for animation `animation` at `time` seconds, by linear blend skinning.
    pub fn pose(&self, animation: Option<usize>, time: f64) -> Result<Vec<[f64; 3]>, PoseError> {
        if self.bindings.is_empty() {
            return match animation {
                None => Ok(self.mesh.positions.clone()),
                Some(_) => Err(PoseError::NoHierarchy),
            };
        }
        let global = self.global_dmat4(animation, time)?;
        let joint_mats: Vec<Vec<DMat4>> = self
            .skins
            .iter()
            .map(|s| {
                s.joints
                    .iter()
                    .zip(&s.inverse_bind_matrices)
                    .map(|(&j, ibm)| global.get(j).copied().unwrap_or(DMat4::IDENTITY) * DMat4::from_cols_array_2d(ibm))
                    .collect()
            })
            .collect();
        Ok(self
            .bindings
            .iter()
            .map(|b| {
                let p = DVec3::from(b.local);
                match b.skin {
                    None => b
                        .node
                        .and_then(|n| global.get(n as usize))
                        .copied()
                        .unwrap_or(DMat4::IDENTITY)
                        .transform_point3(p)
                        .to_array(),
                    Some(s) => {
                        let mats = &joint_mats[s.skin as usize];
                        let mut acc = DVec3::ZERO;
                        for k in 0..4 {
                            if s.weights[k] != 0.0 {
                                acc += s.weights[k] * mats[s.joints[k] as usize].transform_point3(p);
                            }
                        }
                        acc.to_array()
                    }
                }
            })
            .collect())
    }

    /// The part of the scene instantiated by the glTF node(s) named `name` (exactly) or by
    /// their descendants; see [`Scene::subset_by_nodes`].
    pub fn subset_by_node_name(&self, name: &str) -> Option<Scene> {
        let selected: Vec<bool> = self.nodes_under(|n| n == name);
        self.subset_of_nodes(&selected)
    }

    /// The part of the scene instantiated by the glTF nodes whose name matches one of
    /// `patterns` ([`glob_match`]: `*` any run of characters, `?` one character), or by their
    /// descendants (selecting a group selects what it holds): the triangles whose three
    /// vertices belong to such a node, with their vertices and per-vertex data (nodes, skins
    /// and animations are kept whole so the subset can still be posed). `None` when no
    /// triangle matches (including scenes without nodes, such as OBJ files).
    pub fn subset_by_nodes(&self, patterns: &[String]) -> Option<Scene> {
        let selected = self.nodes_under(|n| patterns.iter().any(|p| glob_match(p, n)));
        self.subset_of_nodes(&selected)
    }

    /// Names of the scene's named nodes, in file order (for messages).
    pub fn node_names(&self) -> Vec<&str> {
        self.nodes.iter().filter_map(|n| n.name.as_deref()).collect()
    }

    /// Per node: whether its name, or an ancestor's, satisfies `pick`.
    fn nodes_under(&self, pick: impl Fn(&str) -> bool) -> Vec<bool> {
        (0..self.nodes.len())
            .map(|mut i| {
                // walk to the root (the import checked the hierarchy is acyclic; bounded anyway)
                for _ in 0..=self.nodes.len() {
                    if self.nodes[i].name.as_deref().is_some_and(&pick) {
                        return true;
                    }
                    match self.nodes[i].parent {
                        Some(p) if p < self.nodes.len() => i = p,
                        _ => return false,
                    }
                }
                false
            })
            .collect()
    }

    fn subset_of_nodes(&self, selected: &[bool]) -> Option<Scene> {
        let matches = |v: u32| {
            self.bindings
                .get(v as usize)
                .and_then(|b| b.node)
                .is_some_and(|n| selected.get(n as usize).copied().unwrap_or(false))
        };
        let tris: Vec<[u32; 3]> = self.mesh.indices.iter().copied().filter(|t| t.iter().all(|&v| matches(v))).collect();
        if tris.is_empty() {
            return None;
        }
        let mut remap = vec![u32::MAX; self.mesh.positions.len()];
        let mut positions = Vec::new();
        let mut bindings = Vec::new();
        let mut uv1 = Vec::new();
        let mut base_color = Vec::new();
        let mut base_color_texture = Vec::new();
        let indices = tris
            .iter()
            .map(|t| {
                t.map(|v| {
                    if remap[v as usize] == u32::MAX {
                        remap[v as usize] = positions.len() as u32;
                        positions.push(self.mesh.positions[v as usize]);
                        bindings.push(self.bindings[v as usize]);
                        if let Some(&uv) = self.uv1.get(v as usize) {
                            uv1.push(uv);
                        }
                        if let Some(&c) = self.base_color.get(v as usize) {
                            base_color.push(c);
                        }
                        if let Some(&c) = self.base_color_texture.get(v as usize) {
                            base_color_texture.push(c);
                        }
                    }
                    remap[v as usize]
                })
            })
            .collect();
        Some(Scene {
            mesh: TriMesh { positions, indices },
            nodes: self.nodes.clone(),
            skins: self.skins.clone(),
            animations: self.animations.clone(),
            bindings,
            uv1,
            base_color,
            base_color_texture,
            images: self.images.clone(),
        })
    }

    /// Per node, `G(t)·G(rest)⁻¹`: the node's global transform in the pose times the inverse
    /// of its rest-pose global transform (column-major), the matrix that moves a rest-pose
    /// point bound to the node into the pose (SPHR skin convention, SHEXP §6.2).
    pub fn pose_deltas(&self, animation: Option<usize>, time: f64) -> Result<Vec<Mat4>, PoseError> {
        let rest = self.global_dmat4(None, 0.0)?;
        let now = self.global_dmat4(animation, time)?;
        Ok(now.iter().zip(&rest).map(|(n, r)| (*n * r.inverse()).to_cols_array_2d()).collect())
    }

    /// The mesh at a pose: `mesh` with positions replaced by [`Scene::pose`].
    pub fn posed_mesh(&self, animation: Option<usize>, time: f64) -> Result<TriMesh, PoseError> {
        Ok(TriMesh { positions: self.pose(animation, time)?, indices: self.mesh.indices.clone() })
    }
}

/// Samples `s` at `t` into `out` (`out.len() == s.components`).
fn sample(s: &Sampler, t: f64, is_rotation: bool, out: &mut [f64]) {
    let n = s.components;
    let times = &s.times;
    let stride = if s.interpolation == Interpolation::CubicSpline { 3 * n } else { n };
    let value = |k: usize| -> &[f64] {
        let off = if s.interpolation == Interpolation::CubicSpline { k * stride + n } else { k * stride };
        &s.values[off..off + n]
    };
    let m = out.len().min(n);
    if times.is_empty() {
        return;
    }
    let last = times.len() - 1;
    if t <= times[0] || last == 0 {
        out[..m].copy_from_slice(&value(0)[..m]);
        return;
    }
    if t >= times[last] {
        out[..m].copy_from_slice(&value(last)[..m]);
        return;
    }
    // times[k] <= t < times[k+1]
    let k = times.partition_point(|&x| x <= t) - 1;
    let (t0, t1) = (times[k], times[k + 1]);
    let dt = t1 - t0;
    let u = (t - t0) / dt;
    match s.interpolation {
        Interpolation::Step => out[..m].copy_from_slice(&value(k)[..m]),
        Interpolation::Linear => {
            let (a, b) = (value(k), value(k + 1));
            if is_rotation && n == 4 {
                let qa = DQuat::from_array([a[0], a[1], a[2], a[3]]).normalize();
                let qb = DQuat::from_array([b[0], b[1], b[2], b[3]]).normalize();
                // shortest-path slerp
                let q = qa.slerp(qb, u);
                out[..4].copy_from_slice(&q.to_array());
            } else {
                for i in 0..m {
                    out[i] = a[i] + (b[i] - a[i]) * u;
                }
            }
        }
        Interpolation::CubicSpline => {
            let base0 = k * stride;
            let base1 = (k + 1) * stride;
            let (u2, u3) = (u * u, u * u * u);
            let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
            let h10 = u3 - 2.0 * u2 + u;
            let h01 = -2.0 * u3 + 3.0 * u2;
            let h11 = u3 - u2;
            for i in 0..m {
                let v0 = s.values[base0 + n + i];
                let out_tangent0 = s.values[base0 + 2 * n + i];
                let in_tangent1 = s.values[base1 + i];
                let v1 = s.values[base1 + n + i];
                out[i] = h00 * v0 + h10 * dt * out_tangent0 + h01 * v1 + h11 * dt * in_tangent1;
            }
            if is_rotation && m == 4 {
                let q = DQuat::from_array([out[0], out[1], out[2], out[3]]);
                if q.length_squared() > 0.0 {
                    out.copy_from_slice(&q.normalize().to_array());
                }
            }
        }
    }
}

/// Glob match of a node name: `*` matches any run of characters (also none), `?` exactly one,
/// every other character itself (case-sensitive, no escapes, no character classes).
pub fn glob_match(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    // iterative matcher with one backtrack point (the last `*`): O(|p|·|n|) worst case
    let (mut i, mut j) = (0usize, 0usize);
    let mut star: Option<(usize, usize)> = None;
    while j < n.len() {
        if i < p.len() && (p[i] == '?' || (p[i] != '*' && p[i] == n[j])) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(interp: Interpolation, times: Vec<f64>, values: Vec<f64>, n: usize) -> Sampler {
        Sampler { interpolation: interp, times, values, components: n }
    }

    #[test]
    fn sampling_modes() {
        let s =
            sampler(Interpolation::Linear, vec![0.0, 1.0, 3.0], vec![0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 3.0, 2.0, 1.0], 3);
        let mut o = [0.0; 3];
        sample(&s, 0.5, false, &mut o);
        assert_eq!(o, [0.5, 1.0, 1.5]);
        sample(&s, 2.0, false, &mut o);
        assert_eq!(o, [2.0, 2.0, 2.0]);
        sample(&s, -1.0, false, &mut o);
        assert_eq!(o, [0.0, 0.0, 0.0]);
        sample(&s, 9.0, false, &mut o);
        assert_eq!(o, [3.0, 2.0, 1.0]);
        let st = Sampler { interpolation: Interpolation::Step, ..s.clone() };
        sample(&st, 0.99, false, &mut o);
        assert_eq!(o, [0.0, 0.0, 0.0]);
        sample(&st, 1.0, false, &mut o);
        assert_eq!(o, [1.0, 2.0, 3.0]);
        // cubic spline with zero tangents: smoothstep between values
        let cs = sampler(Interpolation::CubicSpline, vec![0.0, 2.0], vec![0.0, 0.0, 0.0, /**/ 0.0, 4.0, 0.0], 1);
        let mut o1 = [0.0];
        sample(&cs, 1.0, false, &mut o1);
        assert!((o1[0] - 2.0).abs() < 1e-15);
        sample(&cs, 0.5, false, &mut o1);
        assert!((o1[0] - 4.0 * (3.0 * 0.0625 - 2.0 * 0.015625)).abs() < 1e-15);
        // cubic spline with tangent 1 (units per second) reproduces a line
        let line = sampler(Interpolation::CubicSpline, vec![0.0, 2.0], vec![1.0, 0.0, 1.0, /**/ 1.0, 2.0, 1.0], 1);
        sample(&line, 0.7, false, &mut o1);
        assert!((o1[0] - 0.7).abs() < 1e-15);
    }

    #[test]
    fn rotation_slerp() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        // 0 to 90 degrees about Y
        let s = sampler(Interpolation::Linear, vec![0.0, 1.0], vec![0.0, 0.0, 0.0, 1.0, 0.0, h, 0.0, h], 4);
        let mut o = [0.0; 4];
        sample(&s, 0.5, true, &mut o);
        let q = DQuat::from_array(o);
        let expect = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        assert!(q.abs_diff_eq(expect, 1e-12), "{q:?}");
    }

    /// Two-bone chain: joint 1 rotates 90° about Z at its tip; a vertex fully bound to
    /// joint 1 swings around it, a vertex bound half/half moves halfway.
    #[test]
    fn linear_blend_skinning() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let nodes = vec![
            Node { name: None, parent: None, children: vec![1], rest: Trs::default(), matrix: None, extras: None },
            Node {
                name: None,
                parent: Some(0),
                children: vec![],
                rest: Trs { translation: [0.0, 1.0, 0.0], ..Trs::default() },
                matrix: None,
                extras: None,
            },
            Node {
                name: Some("mesh".into()),
                parent: None,
                children: vec![],
                rest: Trs {
                    translation: [100.0, 0.0, 0.0], // ignored for skinned meshes
                    ..Trs::default()
                },
                matrix: None,
                extras: None,
            },
        ];
        let ibm1 = DMat4::from_translation(DVec3::new(0.0, -1.0, 0.0)).to_cols_array_2d();
        let skins = vec![Skin {
            name: None,
            joints: vec![0, 1],
            inverse_bind_matrices: vec![DMat4::IDENTITY.to_cols_array_2d(), ibm1],
            skeleton: None,
        }];
        let anim = Animation {
            name: Some("bend".into()),
            channels: vec![Channel {
                node: 1,
                property: AnimProperty::Rotation,
                sampler: sampler(Interpolation::Linear, vec![0.0, 1.0], vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, h, h], 4),
            }],
        };
        let bind = |local: [f64; 3], w: [f64; 4]| VertexBinding {
            local,
            node: Some(2),
            skin: Some(VertexSkin { skin: 0, joints: [0, 1, 0, 0], weights: w }),
        };
        let scene = Scene {
            mesh: TriMesh {
                positions: vec![[0.0, 2.0, 0.0], [0.0, 2.0, 0.0], [1.0, 0.0, 0.0]],
                indices: vec![[0, 1, 2]],
            },
            nodes,
            skins,
            animations: vec![anim],
            uv1: Vec::new(),
            base_color: Vec::new(),
            base_color_texture: Vec::new(),
            images: Vec::new(),
            bindings: vec![
                bind([0.0, 2.0, 0.0], [0.0, 1.0, 0.0, 0.0]),
                bind([0.0, 2.0, 0.0], [0.5, 0.5, 0.0, 0.0]),
                VertexBinding { local: [1.0, 0.0, 0.0], node: Some(1), skin: None },
            ],
        };
        let rest = scene.pose(None, 0.0).unwrap();
        assert_eq!(rest[0], [0.0, 2.0, 0.0]);
        assert_eq!(rest[1], [0.0, 2.0, 0.0]);
        assert_eq!(rest[2], [1.0, 1.0, 0.0]); // rigid: node 1 global translation
        let posed = scene.pose(Some(0), 1.0).unwrap();
        let close = |a: [f64; 3], b: [f64; 3]| (DVec3::from(a) - DVec3::from(b)).length() < 1e-12;
        assert!(close(posed[0], [-1.0, 1.0, 0.0]), "{:?}", posed[0]);
        assert!(close(posed[1], [-0.5, 1.5, 0.0]), "{:?}", posed[1]);
        assert!(close(posed[2], [0.0, 2.0, 0.0]), "{:?}", posed[2]);
        assert!(matches!(scene.pose(Some(3), 0.0), Err(PoseError::NoSuchAnimation { .. })));
        assert!(scene.pose(Some(0), f64::NAN).is_err());
        assert_eq!(scene.animations[0].time_range(), [0.0, 1.0]);
    }

    #[test]
    fn glob_matches_stars_and_question_marks() {
        use super::glob_match;
        for (p, n, want) in [
            ("SheenChair*", "SheenChair_fabric", true),
            ("SheenChair*", "SheenChair", true),
            ("SheenChair*", "Plane", false),
            ("*_wood", "SheenChair_wood", true),
            ("*_wood", "SheenChair_wood2", false),
            ("Crate?", "Crate1", true),
            ("Crate?", "Crate12", false),
            ("*a*b*", "xxaYYbzz", true),
            ("*a*b*", "xxbYYazz", false),
            ("", "", true),
            ("*", "", true),
            ("exact", "exact", true),
            ("exact", "Exact", false),
        ] {
            assert_eq!(glob_match(p, n), want, "{p:?} vs {n:?}");
        }
    }
}
