//! glTF 2.0 import (`.gltf` with embedded or external buffers, `.glb`).
//!
//! Geometry: every triangle primitive (lists; strips and fans are converted) of every mesh
//! reachable from the default scene, or from all scenes when there is no default (from all
//! root nodes when there are no scenes, and every mesh once with the identity transform when
//! there are no nodes), in world space at the rest pose. Point and line primitives are
//! skipped and counted; if no triangle remains it is an error. Skins, animations and the node
//! hierarchy are returned in the [`Scene`] as plain data, with one [`VertexBinding`] per
//! vertex so callers can pose the mesh ([`Scene::pose`]).
//!
//! Validation (beyond the gltf crate's reference checks): accessor bounds, strides and types,
//! equal attribute counts, index ranges, finite positions and matrices, joint indices, skin
//! weights (renormalised when they do not sum to 1), strictly increasing key times, and an
//! acyclic single-parent node hierarchy. Remote URIs are refused.
//!
//! Materials: each vertex keeps its primitive's `baseColorFactor` and, when the material has a
//! `baseColorTexture`, the texture (image, wrap modes) and the vertex's UV in the texture's
//! `TEXCOORD_n` set. The images those textures use are read as encoded bytes (a missing or
//! unreadable image is recorded with its reason, not an import error: geometry never needs
//! it) and decoded on demand by [`crate::texture::MipChain::decode`]. `KHR_texture_transform`
//! (offset, rotation, scale, texCoord override) is applied to those UVs.

use std::path::Path;

use glam::{DMat4, DQuat, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::gltf_data::{AccessorData, BufferStore, check_finite, read_accessor, type_name};
use crate::error::{MeshError, MeshErrorKind};
use crate::import::ImportReport;
use crate::mesh::TriMesh;
use crate::scene::{
    AnimProperty, Animation, Channel, Interpolation, Node, Sampler, Scene, Skin, Trs, VertexBinding, VertexSkin,
};
use crate::texture::{BaseColorTexture, SceneImage, Wrap};

/// Extensions that change how geometry is stored or instanced; a file that *requires* one of
/// them cannot be imported correctly, so it is rejected.
const UNSUPPORTED_GEOMETRY_EXTENSIONS: &[&str] = &[
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
];

/// Loads a `.gltf` or `.glb` file (see the module docs).
pub fn load_gltf(path: &Path) -> Result<(Scene, ImportReport), MeshError> {
    let bytes = std::fs::read(path).map_err(|e| MeshError::new(path, e))?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_gltf_bytes(path, &bytes, base)
}

/// The files outside `path` that a load of it reads: every buffer and image whose URI is a
/// relative file path (percent-decoded, relative to the file's directory), in document order
/// (buffers, then images), each with its URI. `data:` URIs and the GLB's own BIN chunk are part
/// of the file and are not listed. What a content hash of the input must cover besides the file.
pub fn external_files(path: &Path) -> Result<Vec<(String, std::path::PathBuf)>, MeshError> {
    let bytes = std::fs::read(path).map_err(|e| MeshError::new(path, e))?;
    let err = |m: String| MeshError::new(path, MeshErrorKind::Gltf(m));
    let json = if bytes.starts_with(b"glTF") { split_glb(&bytes).map_err(err)?.0 } else { &bytes[..] };
    let gltf::Gltf { document: doc, .. } =
        gltf::Gltf::from_slice_without_validation(json).map_err(|e| err(e.to_string()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    // the raw JSON, not the crate's accessors: those panic on unvalidated indices
    let root = doc.as_json();
    let uris =
        root.buffers.iter().filter_map(|b| b.uri.clone()).chain(root.images.iter().filter_map(|i| i.uri.clone()));
    Ok(uris.filter_map(|u| super::gltf_data::local_file(base, &u).map(|f| (u, f))).collect())
}

/// Loads glTF/GLB bytes; external buffers are resolved relative to `base_dir`; `path` is only
/// used in error messages.
pub fn load_gltf_bytes(path: &Path, bytes: &[u8], base_dir: &Path) -> Result<(Scene, ImportReport), MeshError> {
    let err = |k: MeshErrorKind| MeshError::new(path, k);
    let data = |m: String| MeshError::new(path, MeshErrorKind::GltfData(m));
    if bytes.is_empty() {
        return Err(err(MeshErrorKind::Gltf("the file is empty".into())));
    }
    // GLB containers are split here (the gltf crate panics on some malformed headers); the
    // JSON part is then parsed without the crate's validation, which is run below with
    // guards against the crate's own panics.
    let (json, bin) = if bytes.starts_with(b"glTF") {
        let (j, b) = split_glb(bytes).map_err(|m| err(MeshErrorKind::Gltf(m)))?;
        (j, b.map(<[u8]>::to_vec))
    } else {
        (bytes, None)
    };
    let gltf::Gltf { document: doc, .. } =
        gltf::Gltf::from_slice_without_validation(json).map_err(|e| err(MeshErrorKind::Gltf(e.to_string())))?;
    let blob = bin;
    let mut report = ImportReport::default();
    for ext in doc.extensions_required() {
        if UNSUPPORTED_GEOMETRY_EXTENSIONS.contains(&ext) {
            return Err(data(format!("the file requires extension {ext}, which is not supported")));
        }
    }
    validate_document(&doc, &mut report).map_err(|m| err(MeshErrorKind::Gltf(m)))?;
    let mut store = BufferStore::new(&doc, blob, base_dir);
    let nodes = read_nodes(&doc).map_err(data)?;
    let skins = read_skins(&doc, &mut store).map_err(data)?;
    let animations = read_animations(&doc, &mut store).map_err(data)?;
    let scene_shell = Scene {
        mesh: TriMesh::default(),
        nodes,
        skins,
        animations,
        bindings: Vec::new(),
        uv1: Vec::new(),
        base_color: Vec::new(),
        base_color_texture: Vec::new(),
        images: Vec::new(),
    };
    let rest = scene_shell.global_transforms(None, 0.0).map_err(|e| data(e.to_string()))?;
    let rest: Vec<DMat4> = rest.iter().map(DMat4::from_cols_array_2d).collect();

    // Which (node, mesh) instances to import.
    let mut instances: Vec<(Option<usize>, usize)> = Vec::new();
    let roots: Vec<usize> = if let Some(s) = doc.default_scene() {
        s.nodes().map(|n| n.index()).collect()
    } else if doc.scenes().len() > 0 {
        let mut r: Vec<usize> = doc.scenes().flat_map(|s| s.nodes().map(|n| n.index())).collect();
        r.sort_unstable();
        r.dedup();
        r
    } else {
        if doc.nodes().len() > 0 {
            report.warnings.push("no scene defined: using every root node".into());
        }
        (0..scene_shell.nodes.len()).filter(|&n| scene_shell.nodes[n].parent.is_none()).collect()
    };
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    while let Some(n) = stack.pop() {
        let node = doc.nodes().nth(n).ok_or_else(|| data(format!("node {n} does not exist")))?;
        if let Some(m) = node.mesh() {
            instances.push((Some(n), m.index()));
        }
        stack.extend(scene_shell.nodes[n].children.iter().rev());
    }
    if doc.nodes().len() == 0 && doc.meshes().len() > 0 {
        report.warnings.push("the file has no nodes: every mesh is used once with the identity transform".into());
        instances.extend((0..doc.meshes().len()).map(|m| (None, m)));
    }

    let mut mesh = TriMesh::default();
    let mut bindings: Vec<VertexBinding> = Vec::new();
    // TEXCOORD_1 per vertex while every triangle primitive has it
    let mut uv1: Option<Vec<[f64; 2]>> = Some(Vec::new());
    let mut triangle_primitives = 0usize;
    // material baseColorFactor per vertex (`None`: no material); dropped if no primitive has one
    let mut base_color: Vec<Option<[f64; 4]>> = Vec::new();
    // baseColorTexture and the vertex's UV in its set, per vertex; dropped if no primitive has one
    let mut base_color_texture: Vec<Option<(BaseColorTexture, [f64; 2])>> = Vec::new();
    let mut morph_warned = false;
    for &(node_index, mesh_index) in &instances {
        let gmesh = doc.meshes().nth(mesh_index).ok_or_else(|| data(format!("mesh {mesh_index} does not exist")))?;
        let skin_index = node_index.and_then(|n| doc.nodes().nth(n)).and_then(|n| n.skin()).map(|s| s.index());
        for prim in gmesh.primitives() {
            let label = format!("mesh {mesh_index} primitive {}", prim.index());
            match prim.mode() {
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {}
                _ => {
                    report.skipped_elements += 1;
                    continue;
                }
            }
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                report.warnings.push(format!("{label} has no POSITION attribute and was skipped"));
                report.skipped_elements += 1;
                continue;
            };
            // all attributes must have the same count
            let counts: Vec<(String, usize)> = prim.attributes().map(|(s, a)| (s.to_string(), a.count())).collect();
            if let Some((s, c)) = counts.iter().find(|(_, c)| *c != pos_acc.count()) {
                return Err(data(format!(
                    "{label}: attribute {s} has {c} elements but POSITION has {}",
                    pos_acc.count()
                )));
            }
            if pos_acc.dimensions() != Dimensions::Vec3 || pos_acc.data_type() != DataType::F32 || pos_acc.normalized()
            {
                return Err(data(format!(
                    "{label}: POSITION accessor must be Vec3 F32, found {}",
                    type_name(pos_acc.data_type(), pos_acc.dimensions(), pos_acc.normalized())
                )));
            }
            let pos = read_accessor(&pos_acc, &mut store, &format!("{label} POSITION")).map_err(data)?;
            check_finite(&pos, &format!("{label} POSITION")).map_err(data)?;
            let vcount = pos.count;
            let idx: Vec<u32> = match prim.indices() {
                Some(a) => {
                    if a.dimensions() != Dimensions::Scalar
                        || a.normalized()
                        || !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
                    {
                        return Err(data(format!(
                            "{label}: indices accessor must be unsigned integer scalars, found {}",
                            type_name(a.data_type(), a.dimensions(), a.normalized())
                        )));
                    }
                    let d = read_accessor(&a, &mut store, &format!("{label} indices")).map_err(data)?;
                    let mut out = Vec::with_capacity(d.count);
                    for (k, &v) in d.values.iter().enumerate() {
                        if v as usize >= vcount {
                            return Err(MeshError::new(
                                path,
                                MeshErrorKind::GltfData(format!(
                                    "{label}: indices[{k}] = {v} is out of range for {vcount} vertices"
                                )),
                            ));
                        }
                        out.push(v as u32);
                    }
                    out
                }
                None => (0..vcount as u32).collect(),
            };
            let tris = triangulate(prim.mode(), &idx).map_err(|m| data(format!("{label}: {m}")))?;
            if prim.mode() != Mode::Triangles {
                report.converted_strips_fans += 1;
            }
            if prim.morph_targets().len() > 0 && !morph_warned {
                morph_warned = true;
                report.warnings.push("morph targets are not applied: geometry is the base shape".to_string());
            }
            // skinning
            let vskin = match (skin_index, prim.get(&gltf::Semantic::Joints(0))) {
                (Some(si), Some(_)) => Some(
                    read_vertex_skin(&prim, si, &scene_shell.skins[si], vcount, &mut store, &label, &mut report)
                        .map_err(data)?,
                ),
                (Some(_), None) => {
                    report
                        .warnings
                        .push(format!("{label}: node has a skin but the primitive has no JOINTS_0; treated as rigid"));
                    None
                }
                _ => None,
            };
            match (prim.get(&gltf::Semantic::TexCoords(1)), uv1.as_mut()) {
                (Some(a), Some(out)) => {
                    out.extend(read_uv(&a, 1, &mut store, &label).map_err(data)?);
                }
                (None, Some(_)) => {
                    if triangle_primitives > 0 {
                        report.warnings.push(format!(
                            "{label} has no TEXCOORD_1 while earlier primitives do: lightmap UVs are ignored"
                        ));
                    }
                    uv1 = None;
                }
                (_, None) => {}
            }
            let base = mesh.positions.len();
            if base + vcount > u32::MAX as usize {
                return Err(data("more than 2^32 vertices".into()));
            }
            let node_m = node_index.map_or(DMat4::IDENTITY, |n| rest[n]);
            let factor = prim.material().index().map(|_| {
                let f = prim.material().pbr_metallic_roughness().base_color_factor();
                f.map(f64::from)
            });
            base_color.extend(std::iter::repeat_n(factor, vcount));
            let texture = match prim.material().pbr_metallic_roughness().base_color_texture() {
                Some(info) if prim.material().index().is_some() => {
                    let transform = info.texture_transform();
                    let set = transform.as_ref().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord());
                    match prim.get(&gltf::Semantic::TexCoords(set)) {
                        Some(a) => {
                            let sampler = info.texture().sampler();
                            let tex = BaseColorTexture {
                                image: info.texture().source().index() as u32,
                                wrap_s: wrap(sampler.wrap_s()),
                                wrap_t: wrap(sampler.wrap_t()),
                            };
                            let mut uvs = read_uv(&a, set, &mut store, &label).map_err(data)?;
                            if let Some(t) = transform {
                                let m = uv_transform(t.offset(), t.rotation(), t.scale());
                                check_finite_uv(&m).map_err(|e| data(format!("{label}: KHR_texture_transform {e}")))?;
                                for uv in &mut uvs {
                                    *uv = apply_uv(&m, *uv);
                                }
                            }
                            Some((tex, uvs))
                        }
                        None => {
                            report.warnings.push(format!(
                                "{label}: its material's baseColorTexture reads TEXCOORD_{set}, which the primitive \
                                 does not have; the texture is ignored"
                            ));
                            None
                        }
                    }
                }
                _ => None,
            };
            match texture {
                Some((tex, uvs)) => base_color_texture.extend(uvs.into_iter().map(|uv| Some((tex, uv)))),
                None => base_color_texture.extend(std::iter::repeat_n(None, vcount)),
            }
            for v in 0..vcount {
                let e = pos.element(v);
                let local = [e[0], e[1], e[2]];
                let skin = vskin.as_ref().map(|s| s[v]);
                bindings.push(VertexBinding { local, node: node_index.map(|n| n as u32), skin });
                let world = match skin {
                    None => node_m.transform_point3(DVec3::from(local)),
                    Some(s) => {
                        let sk = &scene_shell.skins[s.skin as usize];
                        let p = DVec3::from(local);
                        let mut acc = DVec3::ZERO;
                        for k in 0..4 {
                            if s.weights[k] != 0.0 {
                                let j = s.joints[k] as usize;
                                let m = rest[sk.joints[j]] * DMat4::from_cols_array_2d(&sk.inverse_bind_matrices[j]);
                                acc += s.weights[k] * m.transform_point3(p);
                            }
                        }
                        acc
                    }
                };
                mesh.positions.push(world.to_array());
            }
            let b = base as u32;
            // glTF 2.0 §3.7.4: a node whose global transform has a negative determinant (a
            // mirror) reverses the winding, so the front face stays counter-clockwise in the
            // world. Skinned vertices ignore the node's transform (§3.7.3.3): kept as they are.
            if vskin.is_none() && node_m.determinant() < 0.0 {
                mesh.indices.extend(tris.iter().map(|t| [t[0] + b, t[2] + b, t[1] + b]));
            } else {
                mesh.indices.extend(tris.iter().map(|t| [t[0] + b, t[1] + b, t[2] + b]));
            }
            triangle_primitives += 1;
        }
    }
    report.source_triangles = mesh.indices.len();
    if triangle_primitives == 0 || mesh.indices.is_empty() {
        let why = if report.skipped_elements > 0 {
            format!(
                "no triangle primitives ({} point/line or position-less primitives skipped)",
                report.skipped_elements
            )
        } else if instances.is_empty() {
            "no triangle primitives (no mesh is reachable from the scene)".to_string()
        } else {
            "no triangle primitives (all primitives are empty)".to_string()
        };
        return Err(err(MeshErrorKind::NoTriangles(why)));
    }
    if mesh.positions.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(data("a node transform or skin produces non-finite world positions".into()));
    }
    mesh.validate().map_err(|e| err(e.into()))?;
    let (clean, cr) = mesh.clean();
    report.clean = cr;
    if clean.indices.is_empty() {
        return Err(err(MeshErrorKind::NoTriangles(format!(
            "all {} triangles are degenerate",
            report.source_triangles
        ))));
    }
    if base_color.iter().all(Option::is_none) {
        base_color.clear();
    }
    if base_color_texture.iter().all(Option::is_none) {
        base_color_texture.clear();
    }
    // the images the base-colour textures use, as encoded bytes (others stay empty)
    let mut used = vec![false; doc.images().len()];
    for (t, _) in base_color_texture.iter().flatten() {
        if let Some(u) = used.get_mut(t.image as usize) {
            *u = true;
        }
    }
    let images = doc
        .images()
        .map(|im| {
            let name = im.name().map(|n| format!(" ({n:?})")).unwrap_or_default();
            let label = format!("image {}{name}", im.index());
            let bytes = if used[im.index()] {
                store.image_bytes(&im)
            } else {
                Err("not used by any baseColorTexture, not read".to_string())
            };
            SceneImage { label, bytes }
        })
        .collect();
    let scene = Scene {
        mesh: clean,
        bindings,
        uv1: uv1.unwrap_or_default(),
        base_color,
        base_color_texture,
        images,
        ..scene_shell
    };
    Ok((scene, report))
}

/// Reads `TEXCOORD_{set}` (glTF 2.0 §3.7.2.1: Vec2 float, or normalized unsigned byte/short).
fn read_uv(
    a: &gltf::Accessor<'_>,
    set: u32,
    store: &mut BufferStore<'_>,
    label: &str,
) -> Result<Vec<[f64; 2]>, String> {
    let ok = a.dimensions() == Dimensions::Vec2
        && (a.data_type() == DataType::F32
            || (a.normalized() && matches!(a.data_type(), DataType::U8 | DataType::U16)));
    if !ok {
        return Err(format!(
            "{label}: TEXCOORD_{set} accessor must be Vec2 F32 or normalized U8/U16, found {}",
            type_name(a.data_type(), a.dimensions(), a.normalized())
        ));
    }
    let d = read_accessor(a, store, &format!("{label} TEXCOORD_{set}"))?;
    check_finite(&d, &format!("{label} TEXCOORD_{set}"))?;
    Ok((0..d.count)
        .map(|v| {
            let e = d.element(v);
            [e[0], e[1]]
        })
        .collect())
}

/// KHR_texture_transform's affine UV map `T·R·S` as `[[a, b, tx], [c, d, ty]]` (the
/// extension's GLSL: `rotation = mat3(cos, sin, 0, −sin, cos, 0, 0, 0, 1)` column-major, so
/// `u' = tx + cos·sx·u − sin·sy·v`, `v' = ty + sin·sx·u + cos·sy·v`).
fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [[f64; 3]; 2] {
    let (s, c) = f64::from(rotation).sin_cos();
    let (sx, sy) = (f64::from(scale[0]), f64::from(scale[1]));
    [[c * sx, -s * sy, f64::from(offset[0])], [s * sx, c * sy, f64::from(offset[1])]]
}

fn check_finite_uv(m: &[[f64; 3]; 2]) -> Result<(), String> {
    if m.iter().flatten().all(|x| x.is_finite()) { Ok(()) } else { Err("has a non-finite value".into()) }
}

fn apply_uv(m: &[[f64; 3]; 2], uv: [f64; 2]) -> [f64; 2] {
    [m[0][0] * uv[0] + m[0][1] * uv[1] + m[0][2], m[1][0] * uv[0] + m[1][1] * uv[1] + m[1][2]]
}

/// The sampler's wrap mode.
fn wrap(m: gltf::texture::WrappingMode) -> Wrap {
    match m {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    }
}

/// The gltf crate's reference validation, except that required extensions it does not
/// parse (materials, textures, lights: nothing that changes geometry) become warnings.
///
/// Also tolerated, because this importer handles them itself: accessors without a buffer
/// view (all zeros, plus sparse values), primitives without POSITION (skipped and counted),
/// and POSITION accessors without `min`/`max` (bounds are computed from the data, which is
/// checked for non-finite values).
fn validate_document(doc: &gltf::Document, report: &mut ImportReport) -> Result<(), String> {
    use gltf::json::validation::{Error, Validate};
    let root = doc.as_json();
    // gltf-json's primitive hook indexes the POSITION accessor without a bounds check
    let n_acc = root.accessors.len();
    for (mi, m) in root.meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            for (sem, idx) in &p.attributes {
                if idx.value() >= n_acc {
                    let name = match sem {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "?".to_string(),
                    };
                    return Err(format!(
                        "invalid glTF: meshes[{mi}].primitives[{pi}].attributes[{name:?}]: accessor {} does not exist ({n_acc} accessors)",
                        idx.value()
                    ));
                }
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, e| {
        let p = path().to_string();
        let tolerated = (e == Error::Missing && p.starts_with("accessors[") && p.ends_with("].bufferView"))
            || (e == Error::Missing && p.ends_with(".attributes[\"POSITION\"]"))
            || (p.contains(".attributes[\"POSITION\"].m") && (p.ends_with(".min") || p.ends_with(".max")));
        if e == Error::Unsupported && p.starts_with("extensionsRequired") {
            report.warnings.push(format!("required extension ignored (does not affect geometry): {p}"));
        } else if !tolerated {
            errors.push(format!("{p}: {e}"));
        }
    });
    if errors.is_empty() { Ok(()) } else { Err(format!("invalid glTF: {}", errors.join("; "))) }
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk, checking the header
/// (magic, version 2, total length equal to the file size) and every chunk header.
fn split_glb(b: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    let u32_at = |o: usize| -> Option<u32> { b.get(o..o + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]])) };
    if b.len() < 12 {
        return Err(format!("GLB header truncated ({} of 12 bytes)", b.len()));
    }
    let version = u32_at(4).unwrap_or(0);
    if version != 2 {
        return Err(format!("unsupported GLB version {version} (expected 2)"));
    }
    let length = u32_at(8).unwrap_or(0) as usize;
    if length != b.len() {
        return Err(format!("GLB header declares {length} bytes but the file has {}", b.len()));
    }
    let mut off = 12;
    let mut json: Option<&[u8]> = None;
    let mut bin: Option<&[u8]> = None;
    let mut index = 0;
    while off < length {
        let (Some(clen), Some(ctype)) = (u32_at(off), u32_at(off + 4)) else {
            return Err(format!("GLB chunk {index} header truncated at byte {off}"));
        };
        let clen = clen as usize;
        let start = off + 8;
        let end = start.checked_add(clen).filter(|&e| e <= length).ok_or_else(|| {
            format!("GLB chunk {index} declares {clen} bytes but only {} remain", length.saturating_sub(start))
        })?;
        if clen % 4 != 0 {
            return Err(format!("GLB chunk {index} length {clen} is not a multiple of 4"));
        }
        match (index, ctype) {
            (0, JSON) => json = Some(&b[start..end]),
            (0, _) => return Err("the first GLB chunk is not JSON".into()),
            (_, JSON) => return Err("more than one JSON chunk in GLB".into()),
            (1, BIN) => bin = Some(&b[start..end]),
            (_, BIN) => return Err("BIN chunk is not the second GLB chunk or appears twice".into()),
            _ => {} // unknown chunk types must be ignored
        }
        off = end;
        index += 1;
    }
    let json = json.ok_or("GLB file has no JSON chunk")?;
    if json.is_empty() {
        return Err("GLB JSON chunk is empty".into());
    }
    Ok((json, bin))
}

/// Triangle list from an index list in the given mode (glTF 2.0 §3.7.2.1 orderings).
fn triangulate(mode: Mode, idx: &[u32]) -> Result<Vec<[u32; 3]>, String> {
    match mode {
        Mode::Triangles => {
            if idx.len() % 3 != 0 {
                return Err(format!("{} indices/vertices is not a multiple of 3 for a triangle list", idx.len()));
            }
            Ok(idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
        Mode::TriangleStrip => Ok((0..idx.len().saturating_sub(2))
            .map(|i| if i % 2 == 0 { [idx[i], idx[i + 1], idx[i + 2]] } else { [idx[i + 1], idx[i], idx[i + 2]] })
            .collect()),
        Mode::TriangleFan => Ok((0..idx.len().saturating_sub(2)).map(|i| [idx[i + 1], idx[i + 2], idx[0]]).collect()),
        _ => Ok(Vec::new()),
    }
}

fn finite_all(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn read_nodes(doc: &gltf::Document) -> Result<Vec<Node>, String> {
    let n = doc.nodes().len();
    let mut nodes: Vec<Node> = Vec::with_capacity(n);
    for node in doc.nodes() {
        let (rest, matrix) = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                if !matrix.iter().all(|c| finite_all(c)) {
                    return Err(format!("node {} has a non-finite matrix", node.index()));
                }
                let m = DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)));
                let (s, r, t) = m.to_scale_rotation_translation();
                (
                    Trs { translation: t.to_array(), rotation: r.to_array(), scale: s.to_array() },
                    Some(m.to_cols_array_2d()),
                )
            }
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                if !finite_all(&translation) || !finite_all(&rotation) || !finite_all(&scale) {
                    return Err(format!("node {} has a non-finite transform", node.index()));
                }
                (
                    Trs {
                        translation: translation.map(f64::from),
                        rotation: rotation.map(f64::from),
                        scale: scale.map(f64::from),
                    },
                    None,
                )
            }
        };
        nodes.push(Node {
            name: node.name().map(str::to_string),
            parent: None,
            children: node.children().map(|c| c.index()).collect(),
            rest,
            matrix,
            extras: node.extras().as_ref().map(|r| r.get().to_string()),
        });
    }
    for p in 0..n {
        for ci in 0..nodes[p].children.len() {
            let c = nodes[p].children[ci];
            if c >= n {
                return Err(format!("node {p} has a child {c} that does not exist"));
            }
            if let Some(q) = nodes[c].parent {
                return Err(format!(
                    "node {c} is a child of both node {q} and node {p} (the hierarchy must be a tree)"
                ));
            }
            nodes[c].parent = Some(p);
        }
    }
    // cycle check: walking up from any node must end within n steps
    for start in 0..n {
        let mut cur = start;
        let mut steps = 0;
        while let Some(p) = nodes[cur].parent {
            cur = p;
            steps += 1;
            if steps > n {
                return Err(format!("the node hierarchy contains a cycle through node {start}"));
            }
        }
    }
    Ok(nodes)
}

fn read_skins(doc: &gltf::Document, store: &mut BufferStore<'_>) -> Result<Vec<Skin>, String> {
    let mut skins = Vec::new();
    for skin in doc.skins() {
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        let label = format!("skin {}", skin.index());
        let ibms = match skin.inverse_bind_matrices() {
            None => vec![DMat4::IDENTITY.to_cols_array_2d(); joints.len()],
            Some(acc) => {
                if acc.dimensions() != Dimensions::Mat4 || acc.data_type() != DataType::F32 {
                    return Err(format!(
                        "{label}: inverseBindMatrices must be Mat4 F32, found {}",
                        type_name(acc.data_type(), acc.dimensions(), acc.normalized())
                    ));
                }
                let d = read_accessor(&acc, store, &format!("{label} inverseBindMatrices"))?;
                check_finite(&d, &format!("{label} inverseBindMatrices"))?;
                if d.count < joints.len() {
                    return Err(format!("{label}: {} inverse bind matrices for {} joints", d.count, joints.len()));
                }
                (0..joints.len())
                    .map(|j| {
                        let e = d.element(j);
                        let mut m = [[0.0; 4]; 4];
                        for c in 0..4 {
                            for r in 0..4 {
                                m[c][r] = e[c * 4 + r];
                            }
                        }
                        m
                    })
                    .collect()
            }
        };
        skins.push(Skin {
            name: skin.name().map(str::to_string),
            joints,
            inverse_bind_matrices: ibms,
            skeleton: skin.skeleton().map(|n| n.index()),
        });
    }
    Ok(skins)
}

/// Reads JOINTS_n / WEIGHTS_n sets, keeps the four largest influences per vertex and
/// normalises their weights to sum 1.
fn read_vertex_skin(
    prim: &gltf::Primitive<'_>,
    skin_index: usize,
    skin: &Skin,
    vcount: usize,
    store: &mut BufferStore<'_>,
    label: &str,
    report: &mut ImportReport,
) -> Result<Vec<VertexSkin>, String> {
    let mut sets: Vec<(AccessorData, AccessorData)> = Vec::new();
    for set in 0.. {
        let (Some(ja), Some(wa)) = (prim.get(&gltf::Semantic::Joints(set)), prim.get(&gltf::Semantic::Weights(set)))
        else {
            if set == 0 {
                return Err(format!("{label}: JOINTS_0 without WEIGHTS_0"));
            }
            break;
        };
        if ja.dimensions() != Dimensions::Vec4
            || ja.normalized()
            || !matches!(ja.data_type(), DataType::U8 | DataType::U16)
        {
            return Err(format!(
                "{label}: JOINTS_{set} must be Vec4 U8/U16, found {}",
                type_name(ja.data_type(), ja.dimensions(), ja.normalized())
            ));
        }
        let float_ok = wa.data_type() == DataType::F32 && !wa.normalized();
        let norm_ok = wa.normalized() && matches!(wa.data_type(), DataType::U8 | DataType::U16);
        if wa.dimensions() != Dimensions::Vec4 || !(float_ok || norm_ok) {
            return Err(format!(
                "{label}: WEIGHTS_{set} must be Vec4 F32 or normalized U8/U16, found {}",
                type_name(wa.data_type(), wa.dimensions(), wa.normalized())
            ));
        }
        let j = read_accessor(&ja, store, &format!("{label} JOINTS_{set}"))?;
        let w = read_accessor(&wa, store, &format!("{label} WEIGHTS_{set}"))?;
        check_finite(&w, &format!("{label} WEIGHTS_{set}"))?;
        if j.count != vcount || w.count != vcount {
            return Err(format!("{label}: JOINTS_{set}/WEIGHTS_{set} count mismatch"));
        }
        sets.push((j, w));
    }
    let nj = skin.joints.len();
    let mut out = Vec::with_capacity(vcount);
    let mut infl: Vec<(f64, u32)> = Vec::with_capacity(4 * sets.len());
    for v in 0..vcount {
        infl.clear();
        for (j, w) in &sets {
            for k in 0..4 {
                let wt = w.element(v)[k];
                if wt < 0.0 {
                    return Err(format!("{label}: vertex {v} has a negative skin weight {wt}"));
                }
                if wt == 0.0 {
                    continue;
                }
                let ji = j.element(v)[k] as usize;
                if ji >= nj {
                    return Err(format!(
                        "{label}: vertex {v} refers to joint {ji}, but skin {skin_index} has {nj} joints"
                    ));
                }
                match infl.iter_mut().find(|(_, jj)| *jj as usize == ji) {
                    Some(e) => e.0 += wt,
                    None => infl.push((wt, ji as u32)),
                }
            }
        }
        let sum: f64 = infl.iter().map(|e| e.0).sum();
        if sum <= 0.0 {
            return Err(format!("{label}: vertex {v} has no non-zero skin weight"));
        }
        let mut changed = (sum - 1.0).abs() > 1e-3 || infl.len() > 4;
        infl.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        infl.truncate(4);
        let kept: f64 = infl.iter().map(|e| e.0).sum();
        changed |= kept != sum;
        let mut vs = VertexSkin { skin: skin_index as u32, joints: [0; 4], weights: [0.0; 4] };
        for (k, (wt, ji)) in infl.iter().enumerate() {
            vs.joints[k] = *ji;
            vs.weights[k] = wt / kept;
        }
        if changed {
            report.renormalized_weights += 1;
        }
        out.push(vs);
    }
    Ok(out)
}

fn read_animations(doc: &gltf::Document, store: &mut BufferStore<'_>) -> Result<Vec<Animation>, String> {
    let mut out = Vec::new();
    for anim in doc.animations() {
        let mut channels = Vec::new();
        for ch in anim.channels() {
            let label = format!("animation {} channel {}", anim.index(), ch.index());
            let target = ch.target();
            let property = match target.property() {
                gltf::animation::Property::Translation => AnimProperty::Translation,
                gltf::animation::Property::Rotation => AnimProperty::Rotation,
                gltf::animation::Property::Scale => AnimProperty::Scale,
                gltf::animation::Property::MorphTargetWeights => AnimProperty::Weights,
            };
            let s = ch.sampler();
            let interpolation = match s.interpolation() {
                gltf::animation::Interpolation::Linear => Interpolation::Linear,
                gltf::animation::Interpolation::Step => Interpolation::Step,
                gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
            };
            let input = s.input();
            if input.dimensions() != Dimensions::Scalar || input.data_type() != DataType::F32 {
                return Err(format!("{label}: sampler input must be Scalar F32"));
            }
            let times = read_accessor(&input, store, &format!("{label} input"))?;
            check_finite(&times, &format!("{label} input"))?;
            if times.count == 0 {
                return Err(format!("{label}: sampler has no keys"));
            }
            if let Some(k) = times.values.windows(2).position(|w| w[1] <= w[0]) {
                return Err(format!("{label}: key times are not strictly increasing at key {}", k + 1));
            }
            let output = s.output();
            let want_dims = match property {
                AnimProperty::Translation | AnimProperty::Scale => Dimensions::Vec3,
                AnimProperty::Rotation => Dimensions::Vec4,
                AnimProperty::Weights => Dimensions::Scalar,
            };
            if output.dimensions() != want_dims {
                return Err(format!(
                    "{label}: output must be {want_dims:?} for {property:?}, found {:?}",
                    output.dimensions()
                ));
            }
            let vals = read_accessor(&output, store, &format!("{label} output"))?;
            check_finite(&vals, &format!("{label} output"))?;
            let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
            let elems = times.count * per_key;
            let components = if property == AnimProperty::Weights {
                if vals.count % elems != 0 {
                    return Err(format!("{label}: {} weight outputs for {} keys", vals.count, times.count));
                }
                vals.count / elems
            } else {
                if vals.count != elems {
                    return Err(format!(
                        "{label}: {} outputs for {} keys ({interpolation:?})",
                        vals.count, times.count
                    ));
                }
                vals.components
            };
            if property == AnimProperty::Rotation
                && interpolation != Interpolation::CubicSpline
                && vals.values.chunks_exact(4).any(|q| DQuat::from_slice(q).length_squared() == 0.0)
            {
                return Err(format!("{label}: zero-length rotation quaternion"));
            }
            channels.push(Channel {
                node: target.node().index(),
                property,
                sampler: Sampler { interpolation, times: times.values, values: vals.values, components },
            });
        }
        out.push(Animation { name: anim.name().map(str::to_string), channels });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {

    #[test]
    fn texture_transform_is_translation_rotation_scale() {
        // scale (2, 1), a quarter turn, offset (0.5, 0): (1, 0) → (2, 0) → (0, 2) → (0.5, 2)
        let m = super::uv_transform([0.5, 0.0], std::f32::consts::FRAC_PI_2, [2.0, 1.0]);
        let p = super::apply_uv(&m, [1.0, 0.0]);
        assert!((p[0] - 0.5).abs() < 1e-6 && (p[1] - 2.0).abs() < 1e-6, "{p:?}");
        // (0, 1) → (0, 1) → (−1, 0) → (−0.5, 0)
        let q = super::apply_uv(&m, [0.0, 1.0]);
        assert!((q[0] + 0.5).abs() < 1e-6 && q[1].abs() < 1e-6, "{q:?}");
        // identity
        let id = super::uv_transform([0.0, 0.0], 0.0, [1.0, 1.0]);
        assert_eq!(super::apply_uv(&id, [0.3, 0.7]), [0.3, 0.7]);
    }

    use super::*;

    #[test]
    fn external_files_lists_relative_buffers_and_images_only() {
        let dir = std::env::temp_dir().join(format!("penumbra-extfiles-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("s.gltf");
        std::fs::write(
            &p,
            r#"{"asset":{"version":"2.0"},
                "buffers":[{"byteLength":4,"uri":"data:application/octet-stream;base64,AAAAAA=="},
                           {"byteLength":4,"uri":"sub/my%20mesh.bin"},{"byteLength":4,"uri":"https://x/y.bin"}],
                "images":[{"uri":"albedo.png"},{"bufferView":0,"mimeType":"image/png"},{"uri":"/abs/x.png"}]}"#,
        )
        .unwrap();
        let got = external_files(&p).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let want: Vec<(String, std::path::PathBuf)> = vec![
            ("sub/my%20mesh.bin".into(), dir.join("sub/my mesh.bin")),
            ("albedo.png".into(), dir.join("albedo.png")),
        ];
        assert_eq!(got, want);
    }

    #[test]
    fn strip_and_fan_orders() {
        let strip = triangulate(Mode::TriangleStrip, &[0, 1, 2, 3, 4]).unwrap();
        assert_eq!(strip, vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]);
        let fan = triangulate(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap();
        assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0]]);
        assert!(triangulate(Mode::Triangles, &[0, 1]).is_err());
    }

    /// A minimal embedded glTF: one triangle, node translated by +2 in x.
    fn tri_gltf(extra_accessor_count: Option<usize>) -> String {
        // 3 float3 positions = 36 bytes
        let mut bytes = Vec::new();
        for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in v {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
        let b64 = encode_base64(&bytes);
        let count = extra_accessor_count.unwrap_or(3);
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[2,0,0]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":{count},"type":"VEC3"}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}}],
            "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}]}}"#
        )
    }

    fn encode_base64(b: &[u8]) -> String {
        const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in b.chunks(3) {
            let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
            for k in 0..4 {
                if k <= c.len() {
                    s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    s.push('=');
                }
            }
        }
        s
    }

    #[test]
    fn embedded_triangle_with_node_transform() {
        let text = tri_gltf(None);
        let (scene, report) = load_gltf_bytes(Path::new("t.gltf"), text.as_bytes(), Path::new(".")).unwrap();
        assert_eq!(scene.mesh.indices, vec![[0, 1, 2]]);
        assert_eq!(scene.mesh.positions[1], [3.0, 0.0, 0.0]);
        assert_eq!(scene.bindings[1].local, [1.0, 0.0, 0.0]);
        assert_eq!(report.source_triangles, 1);
        assert_eq!(scene.pose(None, 0.0).unwrap(), scene.mesh.positions);
    }

    /// A node mirrored in x (scale −1, determinant < 0) reverses the winding: the world-space
    /// normal of the triangle stays +z as authored (glTF 2.0 §3.7.4); a rotation (positive
    /// determinant) keeps the order.
    #[test]
    fn mirrored_node_reverses_the_winding() {
        let normal = |text: &str| {
            let (scene, _) = load_gltf_bytes(Path::new("m.gltf"), text.as_bytes(), Path::new(".")).unwrap();
            let [a, b, c] = scene.mesh.indices[0].map(|i| DVec3::from(scene.mesh.positions[i as usize]));
            (b - a).cross(c - a).normalize()
        };
        let plain = tri_gltf(None);
        assert!((normal(&plain).z - 1.0).abs() < 1e-12);
        let mirrored = plain.replace(r#""translation":[2,0,0]"#, r#""scale":[-1,1,1]"#);
        assert!(mirrored.contains("scale"));
        // positions mirrored (x → −x) would flip the normal to −z without the fix
        assert!((normal(&mirrored).z - 1.0).abs() < 1e-12, "{}", normal(&mirrored));
        let rotated = plain.replace(r#""translation":[2,0,0]"#, r#""rotation":[0,0,1,0]"#);
        assert!((normal(&rotated).z - 1.0).abs() < 1e-12);
    }

    /// One triangle plus a line primitive and a point primitive: the two are skipped and
    /// counted; with only the point primitive it is a "no triangle primitives" error.
    #[test]
    fn non_triangle_primitives_are_skipped() {
        let text = tri_gltf(None).replace(
            r#""primitives":[{"attributes":{"POSITION":0}}]"#,
            r#""primitives":[{"attributes":{"POSITION":0}},{"attributes":{"POSITION":0},"mode":1},{"attributes":{"POSITION":0},"mode":0}]"#,
        );
        let (scene, report) = load_gltf_bytes(Path::new("t.gltf"), text.as_bytes(), Path::new(".")).unwrap();
        assert_eq!(report.skipped_elements, 2);
        assert_eq!(scene.mesh.indices.len(), 1);
        let only_points = tri_gltf(None).replace(
            r#""primitives":[{"attributes":{"POSITION":0}}]"#,
            r#""primitives":[{"attributes":{"POSITION":0},"mode":0}]"#,
        );
        let e = load_gltf_bytes(Path::new("p.gltf"), only_points.as_bytes(), Path::new(".")).unwrap_err().to_string();
        assert!(e.contains("no triangle primitives (1 point/line"), "{e}");
    }

    /// A skinned triangle whose weights sum to 0.5: renormalised and counted; a joint index
    /// beyond the skin is an error naming the vertex.
    #[test]
    fn skin_weights_are_validated() {
        let build = |joint: u8| {
            let mut b = Vec::new();
            for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
                for c in v {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
            for _ in 0..3 {
                b.extend_from_slice(&[0, joint, 0, 0]);
            }
            for _ in 0..3 {
                for w in [0.25f32, 0.25, 0.0, 0.0] {
                    b.extend_from_slice(&w.to_le_bytes());
                }
            }
            for _ in 0..2 {
                for x in DMat4::IDENTITY.to_cols_array().iter() {
                    b.extend_from_slice(&(*x as f32).to_le_bytes());
                }
            }
            let b64 = encode_base64(&b);
            format!(
                r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
                "nodes":[{{"mesh":0,"skin":0}},{{"children":[2]}},{{"translation":[0,1,0]}}],
                "skins":[{{"joints":[1,2],"inverseBindMatrices":3}}],
                "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"JOINTS_0":1,"WEIGHTS_0":2}}}}]}}],
                "accessors":[
                 {{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},
                 {{"bufferView":1,"componentType":5121,"count":3,"type":"VEC4"}},
                 {{"bufferView":2,"componentType":5126,"count":3,"type":"VEC4"}},
                 {{"bufferView":3,"componentType":5126,"count":2,"type":"MAT4"}}],
                "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":12}},
                 {{"buffer":0,"byteOffset":48,"byteLength":48}},{{"buffer":0,"byteOffset":96,"byteLength":128}}],
                "buffers":[{{"byteLength":224,"uri":"data:application/gltf-buffer;base64,{b64}"}}]}}"#
            )
        };
        let (scene, report) = load_gltf_bytes(Path::new("s.gltf"), build(1).as_bytes(), Path::new(".")).unwrap();
        assert_eq!(report.renormalized_weights, 3);
        let s = scene.bindings[0].skin.unwrap();
        assert_eq!(s.weights, [0.5, 0.5, 0.0, 0.0]);
        assert_eq!(s.joints[..2], [0, 1]);
        // rest pose: joint 1 (node 2) is translated by +1 in y with identity IBM, so every
        // vertex moves half of that
        assert_eq!(scene.mesh.positions[1], [1.0, 0.5, 0.0]);
        let e = load_gltf_bytes(Path::new("s.gltf"), build(7).as_bytes(), Path::new(".")).unwrap_err().to_string();
        assert!(e.contains("vertex 0 refers to joint 7, but skin 0 has 2 joints"), "{e}");
    }

    /// The gltf crate would silently return 0 vertices for an accessor longer than its view.
    #[test]
    fn accessor_longer_than_view_is_an_error() {
        let text = tri_gltf(Some(4));
        let e = load_gltf_bytes(Path::new("t.gltf"), text.as_bytes(), Path::new(".")).unwrap_err().to_string();
        assert!(e.starts_with("t.gltf: "), "{e}");
        assert!(e.contains("need 48 bytes but buffer view 0 has 36"), "{e}");
    }
}
