//! The MRT runtime (MRT thesis §3.6.3, ch. 4): indirect light of a level from direct light
//! at its block texels, with an `MRTD` dictionary (kind version 2) and an `MRTL` level.
//!
//! Per evaluation ([`MrtRuntime::indirect`]):
//! 1. `b = T_d→b l_d` per block (§4.4), split per face when the dictionary's same-face rule
//!    is on (`iface.flags` bit 0: the texels of face `g` get `U_b (b − b_g)`);
//! 2. `U_b b` into the block's texels (§4.4.3);
//! 3. `r = T_b→r b` per record: receiving block, entering face, source block (§4.5.1);
//! 4. `U_r r` into the receiving block's texels, through the row index of its entering face
//!    (§4.5.2);
//! 5. ([`MrtRuntime::pad_atlas`]) the padded light-map atlas (§4.6).
//!
//! [`MrtRuntime::multi_bounce`] feeds albedo × indirect back as direct light (§3.6.3).
//! Everything is f32, single-threaded, and allocation-free after construction.

use crate::RuntimeError;
use penumbra_asset::{Asset, DType};

fn bad(m: impl Into<String>) -> RuntimeError {
    RuntimeError::Invalid(m.into())
}

fn f32_section<'a>(a: &Asset<'a>, name: &str, dims: &[usize]) -> Result<&'a [f32], RuntimeError> {
    let s = a.section(name).ok_or_else(|| bad(format!("section {name:?} is missing")))?;
    if s.dtype() != DType::F32 || s.dims() != dims {
        return Err(bad(format!("section {name:?}: expected f32 {dims:?}, found {:?} {:?}", s.dtype(), s.dims())));
    }
    s.as_f32().map_err(|e| bad(format!("section {name:?}: {e}")))
}

fn u32_section<'a>(a: &Asset<'a>, name: &str) -> Result<(&'a [u32], Vec<usize>), RuntimeError> {
    let s = a.section(name).ok_or_else(|| bad(format!("section {name:?} is missing")))?;
    if s.dtype() != DType::U32 {
        return Err(bad(format!("section {name:?}: expected u32")));
    }
    Ok((s.as_u32().map_err(|e| bad(format!("section {name:?}: {e}")))?, s.dims().to_vec()))
}

/// Face tokens of interface section names.
const FACE_TOKENS: [&str; 6] = ["nx", "px", "ny", "py", "nz", "pz"];

/// One dictionary shape's runtime operators.
#[derive(Debug, Clone)]
pub struct MrtShape<'a> {
    /// Name.
    pub name: String,
    /// Texels.
    pub n: usize,
    /// Indirect modes.
    pub k_b: usize,
    /// Present faces in texel-slot order.
    pub faces: &'a [u8],
    /// `U_b` (n × k_b, row-major).
    pub u_b: &'a [f32],
    /// `T_d→b` (k_b × n, row-major).
    pub t_d2b: &'a [f32],
    /// Per face: the `U_r` row of each texel for light entering through that face.
    pub u_r_idx: [Option<&'a [u32]>; 6],
    /// `U_b⃗` (n × k_b × 4, OHLSH in the texel frame), when the dictionary has it.
    pub u_bvec: Option<&'a [f32]>,
    /// `U_bvol` (G × k_b × 9, order-3 SH in the shape frame) and the probe centres (G × 3).
    pub u_bvol: Option<(&'a [f32], &'a [f32])>,
    /// Texel centres in the shape frame (n × 3), when the dictionary has them.
    pub positions: Option<&'a [f32]>,
}

/// A dictionary's runtime view (`MRTD`, kind version 2 with interfaces).
#[derive(Debug, Clone)]
pub struct MrtDictionary<'a> {
    /// Shapes in dictionary order.
    pub shapes: Vec<MrtShape<'a>>,
    /// `U_r` (rows × k_r, row-major).
    pub u_r: &'a [f32],
    /// `k_r`.
    pub k_r: usize,
    /// Texels per face (`R²`).
    pub face_texels: usize,
    /// The same-face exclusion rule.
    pub exclude_same_face: bool,
    /// The interfaces' vector and volume response (MRTD kind_version 4), when present.
    pub vectors: Option<MrtInterfaceVectors<'a>>,
    /// `face_frames` (6 × (origin, u, v, n)), when present.
    pub face_frames: Option<&'a [f32]>,
}

/// The interfaces' vector and volume response of a dictionary (MRTD kind_version 4,
/// `iface.u_rvec`, `iface.u_rvol`; MRT thesis §3.5.4–3.5.5 driven by `r`), in the canonical
/// block (light entering through −Z). [`crate::mrt_vec`] turns it into each block's frame.
#[derive(Debug, Clone)]
pub struct MrtInterfaceVectors<'a> {
    /// `U_r⃗` (rows of `U_r` × k_r × 4, OHLSH in the canonical texel's frame).
    pub u_rvec: &'a [f32],
    /// `U_rvol` (g³ × k_r × 9, order-3 SH in the canonical block's frame).
    pub u_rvol: &'a [f32],
    /// Probes per axis `g` (the shapes' probe grid).
    pub volume_res: usize,
    /// Per quarter-turn count `q` and texel face: the 2×2 map `Mᵀ` (row-major) taking the
    /// tangent part `(a₁₁, a₁₋₁)` of a canonical texel's OHLSH into the texel's own frame,
    /// from the dictionary's `face_frames`.
    pub tangent: [[[f32; 4]; 6]; 4],
}

impl<'a> MrtDictionary<'a> {
    /// Validates and views a dictionary. Shapes are found by their `<shape>.u_b` sections in
    /// file order (the dictionary order), so no JSON is parsed.
    pub fn from_asset(a: &Asset<'a>) -> Result<Self, RuntimeError> {
        if a.kind().as_str() != "MRTD" {
            return Err(RuntimeError::WrongKind { expected: "MRTD", found: a.kind().as_str().to_string() });
        }
        let us = a.section("iface.u_r").ok_or_else(|| {
            bad("the dictionary has no interface operators (MRTD kind_version 1 or baked without interfaces)")
        })?;
        let (rows, k_r) = match us.dims() {
            &[r, k] if r % 5 == 0 && r > 0 && k > 0 => (r, k),
            d => return Err(bad(format!("iface.u_r: dims {d:?}"))),
        };
        let u_r = f32_section(a, "iface.u_r", &[rows, k_r])?;
        let (flags, _) = u32_section(a, "iface.flags")?;
        let exclude_same_face = flags.first().is_some_and(|f| f & 1 == 1);
        let face_texels = rows / 5;
        let mut shapes = Vec::new();
        for s in a.iter() {
            let Some(name) = s.name().strip_suffix(".u_b").map(str::to_string) else { continue };
            let (n, k_b) = match s.dims() {
                &[n, k] if k <= 256 => (n, k),
                d => return Err(bad(format!("{name}.u_b: dims {d:?} (k_b ≤ 256)"))),
            };
            let u_b = f32_section(a, &format!("{name}.u_b"), &[n, k_b])?;
            let t_d2b = f32_section(a, &format!("{name}.t_d2b"), &[k_b, n])?;
            let fs = a.section(&format!("{name}.faces")).ok_or_else(|| bad(format!("{name}.faces missing")))?;
            let faces = fs.as_u8().map_err(|e| bad(format!("{name}.faces: {e}")))?;
            if faces.len() * face_texels != n || faces.iter().any(|&f| f >= 6) {
                return Err(bad(format!("{name}: {} faces × {face_texels} texels ≠ {n}", faces.len())));
            }
            let mut u_r_idx = [None; 6];
            for (f, slot) in u_r_idx.iter_mut().enumerate() {
                let sec = format!("{name}.u_r_idx.{}", FACE_TOKENS[f]);
                if a.section(&sec).is_some() {
                    let (idx, dims) = u32_section(a, &sec)?;
                    if dims != [n] || idx.iter().any(|&i| i as usize >= rows) {
                        return Err(bad(format!("{sec}: dims {dims:?} or a row out of range")));
                    }
                    *slot = Some(idx);
                }
            }
            let u_bvec = match a.section(&format!("{name}.u_bvec")) {
                Some(_) => Some(f32_section(a, &format!("{name}.u_bvec"), &[n, k_b, 4])?),
                None => None,
            };
            let u_bvol = match a.section(&format!("{name}.probes")) {
                Some(p) => {
                    let g = p.dims().first().copied().unwrap_or(0);
                    let probes = f32_section(a, &format!("{name}.probes"), &[g, 3])?;
                    if crate::mrt_vec::grid_res(g).is_none() {
                        return Err(bad(format!("{name}.probes: {g} probes is not a cube number")));
                    }
                    Some((f32_section(a, &format!("{name}.u_bvol"), &[g, k_b, 9])?, probes))
                }
                None => None,
            };
            let positions = match a.section(&format!("{name}.positions")) {
                Some(_) => Some(f32_section(a, &format!("{name}.positions"), &[n, 3])?),
                None => None,
            };
            shapes.push(MrtShape { name, n, k_b, faces, u_b, t_d2b, u_r_idx, u_bvec, u_bvol, positions });
        }
        if shapes.is_empty() {
            return Err(bad("the dictionary has no shapes"));
        }
        let vectors = match (a.section("iface.u_rvec"), a.section("iface.u_rvol")) {
            (None, None) => None,
            (Some(_), Some(vol)) => {
                let g = vol.dims().first().copied().unwrap_or(0);
                let volume_res = crate::mrt_vec::grid_res(g)
                    .ok_or_else(|| bad(format!("iface.u_rvol: {g} probes is not a cube number")))?;
                if shapes.iter().any(|s| s.u_bvol.is_some_and(|(_, p)| p.len() != 3 * g)) {
                    return Err(bad("iface.u_rvol: its probe grid differs from the shapes' probes"));
                }
                let frames = f32_section(a, "face_frames", &[6, 4, 3])?;
                Some(MrtInterfaceVectors {
                    u_rvec: f32_section(a, "iface.u_rvec", &[rows, k_r, 4])?,
                    u_rvol: f32_section(a, "iface.u_rvol", &[g, k_r, 9])?,
                    volume_res,
                    tangent: tangent_maps(frames)?,
                })
            }
            _ => return Err(bad("iface.u_rvec and iface.u_rvol come together")),
        };
        let face_frames = match a.section("face_frames") {
            Some(_) => Some(f32_section(a, "face_frames", &[6, 4, 3])?),
            None => None,
        };
        Ok(Self { shapes, u_r, k_r, face_texels, exclude_same_face, vectors, face_frames })
    }
}

/// Quarter turns about the block's vertical axis that take side face `face` to the canonical
/// entry −Z (the rotation behind `u_r_idx`): −z 0, −x 1, +z 2, +x 3; other faces 0.
pub fn canonical_turns(face: usize) -> u32 {
    match face {
        0 => 1,
        5 => 2,
        1 => 3,
        _ => 0,
    }
}

/// One quarter turn from a block's frame to the canonical one, `(x, y, z) → (−z, y, x)`.
#[inline]
fn to_canonical_dir(d: [f32; 3]) -> [f32; 3] {
    [-d[2], d[1], d[0]]
}

/// [`MrtInterfaceVectors::tangent`] from `face_frames` (6 × (origin, u, v, n)): for `q` turns
/// `R` and face `g` with frame `(u, v, n)`, the canonical face `g'` has normal `Rᵍ n`, and
/// `M_ik = (R^q e_k)·e'_i` (`e = (u, v)` of `g`, `e'` of `g'`) maps the texel's tangent
/// coordinates to the canonical texel's; a tangent vector's coordinates go back by `Mᵀ`.
pub(crate) fn tangent_maps(frames: &[f32]) -> Result<[[[f32; 4]; 6]; 4], RuntimeError> {
    let fr = |g: usize, k: usize| -> [f32; 3] { core::array::from_fn(|c| frames[g * 12 + k * 3 + c]) };
    let d3 = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let mut out = [[[0.0f32; 4]; 6]; 4];
    for (q, row) in out.iter_mut().enumerate() {
        for (g, m) in row.iter_mut().enumerate() {
            let turn = |mut v: [f32; 3]| {
                for _ in 0..q {
                    v = to_canonical_dir(v);
                }
                v
            };
            let (u, v, n) = (turn(fr(g, 1)), turn(fr(g, 2)), turn(fr(g, 3)));
            let gc = (0..6)
                .find(|&h| d3(fr(h, 3), n) > 0.5)
                .ok_or_else(|| bad("face_frames: the faces' normals are not the six axis directions"))?;
            let (uc, vc) = (fr(gc, 1), fr(gc, 2));
            // M = [[u·uc, v·uc], [u·vc, v·vc]]; Mᵀ row-major
            *m = [d3(u, uc), d3(u, vc), d3(v, uc), d3(v, vc)];
        }
    }
    Ok(out)
}

/// One stored block of `T_b→r`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MrtRecord {
    /// Receiving block.
    pub dst: u32,
    /// Its entering face.
    pub face: u32,
    /// Source block.
    pub src: u32,
}

/// Re-baked operators of one (shape, warp) of a level (`MRTL` kind version 2, optional
/// sections `warp.<i>.u_b`, `warp.<i>.t_d2b`, `warp.<i>.to_dict_b`; docs/mrt.md, "Warps
/// that stay accurate").
#[derive(Debug, Clone, Copy)]
pub struct MrtWarp<'a> {
    /// Dictionary shape.
    pub shape: usize,
    /// `U_b'` (n × k_b of the shape, row-major).
    pub u_b: &'a [f32],
    /// `T_d→b'` (k_b × n).
    pub t_d2b: &'a [f32],
    /// `X` (k_b × k_b): the dictionary's `b = X b'`.
    pub to_dict_b: &'a [f32],
}

/// A level's runtime view (`MRTL`).
#[derive(Debug, Clone)]
pub struct MrtLevel<'a> {
    /// Re-baked warps (empty in kind version 1).
    pub warps: Vec<MrtWarp<'a>>,
    /// Per block: its index in `warps`, or `None` (the dictionary's operators).
    pub block_warp: Vec<Option<usize>>,
    /// Per block: dictionary shape index.
    pub shapes: Vec<usize>,
    /// Per block: quarter turns about +Y.
    pub rotations: Vec<u32>,
    /// Per block: translation (centre) and scale (`block_xform`), when present.
    pub xform: Option<&'a [f32]>,
    /// Records, sorted by `(dst, face, src)`.
    pub records: Vec<MrtRecord>,
    /// `T_b→r` (records × k_r × k_b).
    pub t_b2r: &'a [f32],
    /// `k_b` of `t_b2r` (the dictionary's largest).
    pub k_b: usize,
    /// Atlas width, height.
    pub atlas: (usize, usize),
    /// Tiles: block, face, x0, y0.
    pub tiles: &'a [u32],
    /// Border records: atlas pixel, block, texel.
    pub pad: &'a [u32],
}

impl<'a> MrtLevel<'a> {
    /// Validates and views a level against its dictionary.
    pub fn from_asset(a: &Asset<'a>, d: &MrtDictionary<'_>) -> Result<Self, RuntimeError> {
        if a.kind().as_str() != "MRTL" {
            return Err(RuntimeError::WrongKind { expected: "MRTL", found: a.kind().as_str().to_string() });
        }
        let (blocks, bd) = u32_section(a, "blocks")?;
        let nb = match bd.as_slice() {
            &[nb, 2] => nb,
            d => return Err(bad(format!("blocks: dims {d:?}"))),
        };
        let shapes: Vec<usize> = blocks.chunks_exact(2).map(|c| c[0] as usize).collect();
        let rotations: Vec<u32> = blocks.chunks_exact(2).map(|c| c[1] % 4).collect();
        let xform = match a.section("block_xform") {
            Some(_) => Some(f32_section(a, "block_xform", &[nb, 6])?),
            None => None,
        };
        if shapes.iter().any(|&s| s >= d.shapes.len()) {
            return Err(bad("blocks: shape index out of range for this dictionary"));
        }
        let (rec, rd) = u32_section(a, "records")?;
        let np = match rd.as_slice() {
            &[np, 3] => np,
            d => return Err(bad(format!("records: dims {d:?}"))),
        };
        let records: Vec<MrtRecord> =
            rec.chunks_exact(3).map(|c| MrtRecord { dst: c[0], face: c[1], src: c[2] }).collect();
        for r in &records {
            if r.dst as usize >= nb || r.src as usize >= nb || r.face >= 6 {
                return Err(bad(format!("record {r:?} out of range")));
            }
            if d.shapes[shapes[r.dst as usize]].u_r_idx[r.face as usize].is_none() {
                return Err(bad(format!("record {r:?}: the dictionary has no interface for that face")));
            }
        }
        if records.windows(2).any(|w| (w[0].dst, w[0].face, w[0].src) > (w[1].dst, w[1].face, w[1].src)) {
            return Err(bad("records are not sorted by (dst, face, src)"));
        }
        let k_b = d.shapes.iter().map(|s| s.k_b).max().unwrap_or(0);
        let t_b2r = f32_section(a, "t_b2r", &[np, d.k_r, k_b])?;
        let (size, _) = u32_section(a, "atlas_size")?;
        let atlas = match size {
            &[w, h] => (w as usize, h as usize),
            _ => return Err(bad("atlas_size: expected 2 values")),
        };
        let (tiles, td) = u32_section(a, "atlas_tiles")?;
        let (pad, pd) = u32_section(a, "atlas_pad")?;
        if td.len() != 2 || td[1] != 4 || pd.len() != 2 || pd[1] != 3 {
            return Err(bad("atlas_tiles / atlas_pad: bad dims"));
        }
        let r = (d.face_texels as f64).sqrt() as usize;
        for t in tiles.chunks_exact(4) {
            let ok = (t[0] as usize) < nb
                && t[1] < 6
                && t[2] as usize + r + 2 <= atlas.0
                && t[3] as usize + r + 2 <= atlas.1
                && d.shapes[shapes[t[0] as usize]].faces.contains(&(t[1] as u8));
            if !ok {
                return Err(bad(format!("atlas tile {t:?} out of range")));
            }
        }
        for p in pad.chunks_exact(3) {
            let ok = (p[0] as usize) < atlas.0 * atlas.1
                && (p[1] as usize) < nb
                && (p[2] as usize) < d.shapes[shapes[p[1] as usize]].n;
            if !ok {
                return Err(bad(format!("atlas pad record {p:?} out of range")));
            }
        }
        let (warps, block_warp) = warps_of(a, d, &shapes)?;
        Ok(Self { warps, block_warp, shapes, rotations, xform, records, t_b2r, k_b, atlas, tiles, pad })
    }
}

/// The optional warp sections: `warp_shapes` (u32 [w]), `block_warp` (u32 [blocks],
/// `0xFFFF_FFFF` = none) and per warp `warp.<i>.u_b` [n, k_b], `warp.<i>.t_d2b` [k_b, n],
/// `warp.<i>.to_dict_b` [k_b, k_b] with the shape's `n` and `k_b`.
#[allow(clippy::type_complexity)]
fn warps_of<'a>(
    a: &Asset<'a>,
    d: &MrtDictionary<'_>,
    shapes: &[usize],
) -> Result<(Vec<MrtWarp<'a>>, Vec<Option<usize>>), RuntimeError> {
    let nb = shapes.len();
    let Some(_) = a.section("block_warp") else { return Ok((Vec::new(), vec![None; nb])) };
    let (bw, bd) = u32_section(a, "block_warp")?;
    let (ws, wd) = u32_section(a, "warp_shapes")?;
    if bd != [nb] || wd.len() != 1 {
        return Err(bad("block_warp / warp_shapes: bad dims"));
    }
    let mut warps = Vec::with_capacity(ws.len());
    for (i, &s) in ws.iter().enumerate() {
        let sh = d.shapes.get(s as usize).ok_or_else(|| bad(format!("warp {i}: shape {s} out of range")))?;
        let (n, kb) = (sh.n, sh.k_b);
        warps.push(MrtWarp {
            shape: s as usize,
            u_b: f32_section(a, &format!("warp.{i}.u_b"), &[n, kb])?,
            t_d2b: f32_section(a, &format!("warp.{i}.t_d2b"), &[kb, n])?,
            to_dict_b: f32_section(a, &format!("warp.{i}.to_dict_b"), &[kb, kb])?,
        });
    }
    let mut block_warp = Vec::with_capacity(nb);
    for (x, &w) in bw.iter().enumerate() {
        if w == u32::MAX {
            block_warp.push(None);
        } else if warps.get(w as usize).is_some_and(|wp| wp.shape == shapes[x]) {
            block_warp.push(Some(w as usize));
        } else {
            return Err(bad(format!("block_warp[{x}] = {w}: no warp of the block's shape")));
        }
    }
    Ok((warps, block_warp))
}

/// The evaluator: buffers sized once for a level.
#[derive(Debug, Clone)]
pub struct MrtRuntime<'a> {
    dict: MrtDictionary<'a>,
    level: MrtLevel<'a>,
    /// First texel of each block in the concatenated texel arrays.
    offsets: Vec<usize>,
    /// `b` per block (k_b each, zero beyond the shape's k_b).
    b: Vec<f32>,
    /// `b_g` per block and face slot (6 × k_b per block).
    b_face: Vec<f32>,
    /// `(dst, face)` of each group of records (equal `(dst, face)`), in record order.
    groups: Vec<(u32, u32)>,
    /// `r` per group (k_r each) from the last [`MrtRuntime::indirect`] (zero without
    /// interfaces).
    r: Vec<f32>,
    scratch: Vec<f32>,
    bounce: Vec<f32>,
}

impl<'a> MrtRuntime<'a> {
    /// A runtime for a level and its dictionary.
    pub fn new(dict: MrtDictionary<'a>, level: MrtLevel<'a>) -> Self {
        let mut offsets = Vec::with_capacity(level.shapes.len() + 1);
        let mut o = 0;
        for &s in &level.shapes {
            offsets.push(o);
            o += dict.shapes[s].n;
        }
        offsets.push(o);
        let kb = level.k_b;
        let nb = level.shapes.len();
        let k_r = dict.k_r;
        let mut groups: Vec<(u32, u32)> = level.records.iter().map(|r| (r.dst, r.face)).collect();
        groups.dedup();
        Self {
            dict,
            level,
            offsets,
            b: vec![0.0; nb * kb],
            b_face: vec![0.0; nb * 6 * kb],
            r: vec![0.0; groups.len() * k_r],
            groups,
            scratch: vec![0.0; o],
            bounce: vec![0.0; o],
        }
    }

    /// Texels of the level (the length of `l_d` and of the output).
    pub fn texel_count(&self) -> usize {
        self.offsets.last().copied().unwrap_or(0)
    }

    /// First texel of each block (and the total at the end).
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// The dictionary.
    pub fn dictionary(&self) -> &MrtDictionary<'a> {
        &self.dict
    }

    /// The level.
    pub fn level(&self) -> &MrtLevel<'a> {
        &self.level
    }

    /// `b` of every block from the last [`MrtRuntime::indirect`] (block `x` at
    /// `x·level().k_b`, its shape's `k_b` entries; DRT reads them).
    pub fn coefficients(&self) -> &[f32] {
        &self.b
    }

    /// `b_g` per block and face slot from the last [`MrtRuntime::indirect`] (block `x`, slot
    /// `s` at `(x·6 + s)·level().k_b`): the part of `b` from face slot `s`'s direct light.
    pub fn face_coefficients(&self) -> &[f32] {
        &self.b_face
    }

    /// `(receiving block, entering face)` of each interface response, in the order of
    /// [`MrtRuntime::response_coefficients`].
    pub fn response_groups(&self) -> &[(u32, u32)] {
        &self.groups
    }

    /// `r` of every `(receiving block, entering face)` ([`MrtRuntime::response_groups`],
    /// `dictionary().k_r` each) from the last [`MrtRuntime::indirect`]; zeros after one
    /// without interfaces.
    pub fn response_coefficients(&self) -> &[f32] {
        &self.r
    }

    /// One-bounce indirect irradiance at every texel from direct irradiance `l_d` (both in
    /// block order, each block in its shape's texel layout). `interfaces = false` keeps the
    /// light inside each block (no `T_b→r`), for comparison.
    pub fn indirect(&mut self, l_d: &[f32], out: &mut [f32], interfaces: bool) {
        let n_all = self.texel_count();
        assert!(l_d.len() == n_all && out.len() == n_all, "l_d and out must have texel_count() entries");
        let kb = self.level.k_b;
        let r2 = self.dict.face_texels;
        // 1. b per block, per face
        for (x, &s) in self.level.shapes.iter().enumerate() {
            let sh = &self.dict.shapes[s];
            // a re-baked warp: its own T_d→b', U_b', then b = X b' (and b_g = X b'_g)
            let warp = self.level.block_warp[x].map(|w| self.level.warps[w]);
            let (t_d2b, u_b) = warp.map_or((sh.t_d2b, sh.u_b), |w| (w.t_d2b, w.u_b));
            let l = &l_d[self.offsets[x]..self.offsets[x] + sh.n];
            let bf = &mut self.b_face[x * 6 * kb..(x + 1) * 6 * kb];
            bf.iter_mut().for_each(|v| *v = 0.0);
            for i in 0..sh.k_b {
                let row = &t_d2b[i * sh.n..(i + 1) * sh.n];
                for slot in 0..sh.faces.len() {
                    let range = slot * r2..(slot + 1) * r2;
                    bf[slot * kb + i] = dot(&row[range.clone()], &l[range]);
                }
            }
            let b = &mut self.b[x * kb..(x + 1) * kb];
            b.iter_mut().for_each(|v| *v = 0.0);
            for slot in 0..sh.faces.len() {
                for (bi, v) in b.iter_mut().zip(&bf[slot * kb..(slot + 1) * kb]) {
                    *bi += v;
                }
            }
            // 2. U_b b (or U_b (b − b_g) at the texels of face g)
            let o = &mut out[self.offsets[x]..self.offsets[x] + sh.n];
            let mut eff = [0.0f32; 256];
            let eff = &mut eff[..sh.k_b.min(256)];
            for slot in 0..sh.faces.len() {
                for (i, e) in eff.iter_mut().enumerate() {
                    *e = if self.dict.exclude_same_face { b[i] - bf[slot * kb + i] } else { b[i] };
                }
                for t in slot * r2..(slot + 1) * r2 {
                    o[t] = dot(&u_b[t * sh.k_b..t * sh.k_b + eff.len()], eff);
                }
            }
            if let Some(w) = warp {
                let k = sh.k_b.min(256);
                let mut tmp = [0.0f32; 256];
                let xm = w.to_dict_b;
                let mut to_dict = |v: &mut [f32]| {
                    tmp[..k].copy_from_slice(&v[..k]);
                    for (i, vi) in v[..k].iter_mut().enumerate() {
                        *vi = dot(&xm[i * sh.k_b..i * sh.k_b + k], &tmp[..k]);
                    }
                };
                to_dict(b);
                for slot in 0..sh.faces.len() {
                    to_dict(&mut bf[slot * kb..slot * kb + k]);
                }
            }
        }
        self.r.iter_mut().for_each(|v| *v = 0.0);
        if !interfaces {
            return;
        }
        // 3–4. r per (dst, face), summed over sources, then U_r r
        let k_r = self.dict.k_r;
        let recs = &self.level.records;
        let mut i = 0;
        let mut gi = 0;
        while i < recs.len() {
            let (dst, face) = (recs[i].dst, recs[i].face);
            let r = &mut self.r[gi * k_r..(gi + 1) * k_r];
            gi += 1;
            while i < recs.len() && recs[i].dst == dst && recs[i].face == face {
                let src = recs[i].src as usize;
                let op = &self.level.t_b2r[i * k_r * kb..(i + 1) * k_r * kb];
                let b = &self.b[src * kb..(src + 1) * kb];
                for (j, rj) in r.iter_mut().enumerate() {
                    *rj += dot(&op[j * kb..(j + 1) * kb], b);
                }
                i += 1;
            }
            let x = dst as usize;
            let sh = &self.dict.shapes[self.level.shapes[x]];
            let Some(idx) = sh.u_r_idx[face as usize] else { continue };
            let o = &mut out[self.offsets[x]..self.offsets[x] + sh.n];
            for (t, &row) in idx.iter().enumerate() {
                let row = row as usize;
                o[t] += dot(&self.dict.u_r[row * k_r..(row + 1) * k_r], r);
            }
        }
    }

    /// Multi-bounce indirect light (§3.6.3): `bounces` evaluations, each fed the previous
    /// one's indirect light times `albedo_scale` (the walls' albedo relative to the
    /// dictionary's baked `params.albedo`); the sum of the bounces goes to `out`.
    pub fn multi_bounce(&mut self, l_d: &[f32], out: &mut [f32], bounces: usize, albedo_scale: f32) {
        let n = self.texel_count();
        assert!(l_d.len() == n && out.len() == n, "l_d and out must have texel_count() entries");
        out.iter_mut().for_each(|v| *v = 0.0);
        let mut bounce = core::mem::take(&mut self.bounce);
        let mut scratch = core::mem::take(&mut self.scratch);
        bounce.copy_from_slice(l_d);
        for _ in 0..bounces {
            self.indirect(&bounce, &mut scratch, true);
            for ((o, s), b) in out.iter_mut().zip(scratch.iter_mut()).zip(bounce.iter_mut()) {
                *s *= albedo_scale;
                *o += *s;
                *b = *s;
            }
        }
        self.bounce = bounce;
        self.scratch = scratch;
    }

    /// Writes per-texel values into the padded atlas (`width × height`, row-major): tile
    /// interiors, then the border records (§4.6).
    pub fn pad_atlas(&self, texels: &[f32], atlas: &mut [f32]) {
        let (w, h) = self.level.atlas;
        assert!(atlas.len() == w * h && texels.len() == self.texel_count(), "atlas and texel sizes");
        let r2 = self.dict.face_texels;
        let r = (r2 as f64).sqrt() as usize;
        for t in self.level.tiles.chunks_exact(4) {
            let x = t[0] as usize;
            let sh = &self.dict.shapes[self.level.shapes[x]];
            let Some(slot) = sh.faces.iter().position(|&f| u32::from(f) == t[1]) else { continue };
            let base = self.offsets[x] + slot * r2;
            for j in 0..r {
                let row = (t[3] as usize + 1 + j) * w + t[2] as usize + 1;
                atlas[row..row + r].copy_from_slice(&texels[base + j * r..base + (j + 1) * r]);
            }
        }
        for p in self.level.pad.chunks_exact(3) {
            atlas[p[0] as usize] = texels[self.offsets[p[1] as usize] + p[2] as usize];
        }
    }
}

/// `a · b` over the shorter length, with four partial sums (shared by the MRT and DRT runtimes).
#[inline]
pub(crate) fn dot(a: &[f32], b: &[f32]) -> f32 {
    // four partial sums: lets the compiler vectorise without reassociating a single chain
    let mut s = [0.0f32; 4];
    let (ca, ra) = a.split_at(a.len() & !3);
    let (cb, rb) = b.split_at(ca.len().min(b.len()));
    for (x, y) in ca.chunks_exact(4).zip(cb.chunks_exact(4)) {
        s[0] += x[0] * y[0];
        s[1] += x[1] * y[1];
        s[2] += x[2] * y[2];
        s[3] += x[3] * y[3];
    }
    let mut t = (s[0] + s[1]) + (s[2] + s[3]);
    for (x, y) in ra.iter().zip(rb) {
        t += x * y;
    }
    t
}
