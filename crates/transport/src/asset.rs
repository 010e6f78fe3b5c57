//! Writes a [`DictBake`] as an `MRTD` asset (sections documented in
//! `schemas/asset-format.md`, "MRTD").
//!
//! Per-shape sections are named `<shape>.<section>` (e.g. `closed.u_b`). Kind version 2 adds
//! the interface operators (MRT thesis §3.4.1, §4.2) as optional sections: shared `iface.*`
//! and per interface `<shape>.r_b2rlf.<face>`, `<shape>.u_r_idx.<face>`. A version-1 asset is
//! a version-2 asset without interfaces. Kind version 3 adds `<shape>.l_imp`, the implicit
//! lights `L_imp = P S Ṽ_m` (§3.3.1.1) that DRT's clutter operators are built against (ch. 5);
//! older dictionaries still load everywhere except in `penumbra drt`.

use crate::TransportError;
use crate::dict::{DictBake, MRTD_KIND_VERSION, MRTD_KIND_VERSION_VECTORS};
use crate::shape::{FACE_FRAMES, FACE_NAMES};
use penumbra_asset::{AssetBuilder, Kind};
use serde_json::json;

/// Section suffixes every shape has, in file order.
pub const SHAPE_SECTIONS: &[&str] =
    &["faces", "positions", "normals", "u_b", "t_d2b", "u_bvec", "probes", "u_bvol", "sigma_d", "prior_s", "sigma_m"];

/// Per-shape sections added in kind version 3 (after [`SHAPE_SECTIONS`] in file order).
pub const SHAPE_SECTIONS_V3: &[&str] = &["l_imp"];

/// Shared interface sections (kind version 2), in file order.
pub const INTERFACE_SECTIONS: &[&str] = &[
    "iface.r_straight",
    "iface.r_left",
    "iface.r_right",
    "iface.u_r",
    "iface.t_rlf2r",
    "iface.sigma_rlf",
    "iface.sigma_g",
    "iface.flags",
];

/// Shared interface sections of kind version 4 (the vector and volume response), after
/// every interface's own sections in file order.
pub const INTERFACE_VECTOR_SECTIONS: &[&str] = &["iface.u_rvec", "iface.u_rvol"];

/// Names of every section of an MRTD v1 asset of these shapes, for `require_known`.
pub fn section_names(shapes: &[&str]) -> Vec<String> {
    let mut v = vec!["meta".to_string(), "face_frames".to_string()];
    for s in shapes {
        v.extend(SHAPE_SECTIONS.iter().map(|x| format!("{s}.{x}")));
    }
    v
}

/// Names of every section of an MRTD v3 asset (v2 plus `<shape>.l_imp`), for `require_known`.
pub fn section_names_v3(shapes: &[&str], interfaces: &[(&str, usize)]) -> Vec<String> {
    let mut v = section_names_v2(shapes, interfaces);
    for s in shapes {
        v.extend(SHAPE_SECTIONS_V3.iter().map(|x| format!("{s}.{x}")));
    }
    v
}

/// Face tokens in section names (section names allow no `+`): `nx px ny py nz pz` for
/// `−x +x −y +y −z +z`.
pub const FACE_TOKENS: [&str; 6] = ["nx", "px", "ny", "py", "nz", "pz"];

/// Section names of one interface of a shape: `R_b→rlf` and the `U_r` row index.
pub fn interface_section_names(shape: &str, face: usize) -> [String; 2] {
    [format!("{shape}.r_b2rlf.{}", FACE_TOKENS[face]), format!("{shape}.u_r_idx.{}", FACE_TOKENS[face])]
}

/// Names of every section of an MRTD v2 asset of these shapes with these interfaces
/// (`(shape, face)`), for `require_known`.
pub fn section_names_v2(shapes: &[&str], interfaces: &[(&str, usize)]) -> Vec<String> {
    let mut v = section_names(shapes);
    if !interfaces.is_empty() {
        v.extend(INTERFACE_SECTIONS.iter().map(|s| s.to_string()));
        for (s, f) in interfaces {
            v.extend(interface_section_names(s, *f));
        }
    }
    v
}

fn err(e: impl core::fmt::Display) -> TransportError {
    TransportError::Asset(e.to_string())
}

fn f32s(v: impl IntoIterator<Item = f64>) -> Vec<f32> {
    v.into_iter().map(|x| x as f32).collect()
}

/// The `meta` JSON: tool, kind version, conventions, normalised parameters, the shape table,
/// metrics. No timestamps, durations or paths.
pub fn meta_json(b: &DictBake, cache_key: Option<&str>) -> serde_json::Value {
    let p = &b.params;
    let shapes: Vec<_> = b
        .shapes
        .iter()
        .map(|s| {
            let sh = &s.texels.shape;
            json!({
                "name": sh.name,
                "faces": s.texels.faces.iter().map(|&f| FACE_NAMES[f]).collect::<Vec<_>>(),
                "missing_faces": sh.missing_faces().iter().map(|&f| FACE_NAMES[f]).collect::<Vec<_>>(),
                "texels": s.texels.len(),
                "prior_lights": s.metrics.prior_lights,
                "k_d": s.metrics.k_d,
                "k_b": s.metrics.k_b,
                "probes": s.probes.len(),
            })
        })
        .collect();
    let mut meta = json!({
        "kind": "MRTD",
        "kind_version": kind_version(b),
        "tool": concat!("penumbra ", env!("CARGO_PKG_VERSION")),
        "convention": {
            "frame": "each shape is the unit cube [0,1]^3, +Y up; faces -x,+x,-y(floor),+y(ceiling),-z,+z = 0..5; normals point inward",
            "texels": "face_frames[f] = (origin, u, v, n); texel (i,j) of a present face is centred at origin + (i+0.5)/R u + (j+0.5)/R v; a shape's texels are its present faces in face order, each row-major (j, then i): index slot*R^2 + j*R + i",
            "light": "l_d = direct irradiance at texel centres (any unit); U_b b = one-bounce indirect irradiance in the same unit for uniform albedo `params.albedo`; for coloured surfaces feed reflectance-weighted direct light per channel",
            "runtime": "b = t_d2b . l_d (k_b); indirect = u_b . b (MRT thesis eq. 3.3); when params.exclude_same_face is true, the indirect light of the texels of face g is u_b[g] . (b - b_g) with b_g = t_d2b[:, g] . l_d[g] (a face's own direct light never reaches it; the same b - b_g for u_bvec)",
            "sh": "real orthonormal; index i = l(l+1)+m; Condon-Shortley as in graphics: y(1,-1) = -sqrt(3/4pi) y, y(1,0) = sqrt(3/4pi) z, y(1,1) = -sqrt(3/4pi) x",
            "u_bvec": "OHLSH (MRT thesis App. B) of incident radiance in the texel frame (x = face u, y = face v, z = inward normal); irradiance for unit normal m (texel frame) = pi*a0*y0 + (2pi/3)*sum_m a1m*y1m(m)",
            "interfaces": "lightfield frame of travel direction t (horizontal), r = y x t; R_b2rlf maps a shape's b to reduced lightfield coefficients c of the light leaving through the face; iface.r_{straight,left,right} map c entering a block (travel t) to c leaving it straight / turned +90 deg about +Y (left) / -90 deg (right); iface.t_rlf2r maps c entering to response coefficients r; irradiance of a texel t of a block lit through its face g = u_r[u_r_idx.g[t]] . r (MRT thesis 3.4.1, 4.2)",
            "l_imp": "implicit lights L_imp = P S V_m (n x k_b, MRT thesis 3.3.1.1): U_b = F L_imp; l_imp . b is the direct-light pattern in the prior whose one bounce U_b . b is; DRT (ch. 5) gathers it",
            "u_bvol": "order-3 SH (9) of incident radiance at probe centres, world (shape) frame; irradiance for normal m = sum_l Ahat_l sum_m c_lm y_lm(m), Ahat = (pi, 2pi/3, pi/4)",
        },
        "params": p.to_json(),
        "shapes": shapes,
        "interfaces": b.interfaces.as_ref().map_or_else(Vec::new, |ib| ib
            .interfaces
            .iter()
            .map(|i| json!({"shape": b.shapes[i.shape].texels.shape.name, "face": FACE_NAMES[i.face]}))
            .collect::<Vec<_>>()),
        "cache_key": cache_key,
        "metrics": b.metrics,
    });
    if kind_version(b) == MRTD_KIND_VERSION_VECTORS {
        meta["convention"]["u_rvec"] = json!(
            "kind_version 4. Light entering a block through side face g with response r (as for u_r): q = quarter turns taking g to the canonical entry -z (-z 0, -x 1, +z 2, +x 3); texel t gets OHLSH a = u_rvec[u_r_idx.g[t]] . r in the frame of its canonical texel; a floor or ceiling texel turns its tangent part into its own frame (schemas/asset-format.md, MRTD); side texels use it as is. Probe p of the block reads canonical probe P^q(p), P(x,y,z) = (1-z, y, x) on cell centres, u_rvol[.] . r rotated by q quarter turns about +Y ((x,y,z) -> (z,y,-x) per turn) into the shape frame"
        );
    }
    meta
}

/// The kind version of the asset `b` writes: 4 with the interfaces' vector and volume
/// response, else 3.
pub fn kind_version(b: &DictBake) -> u32 {
    if b.interfaces.as_ref().is_some_and(|i| i.vectors.is_some()) {
        MRTD_KIND_VERSION_VECTORS
    } else {
        MRTD_KIND_VERSION
    }
}

/// Builds the asset.
pub fn to_asset(b: &DictBake, cache_key: Option<&str>) -> Result<AssetBuilder, TransportError> {
    let mut a = AssetBuilder::new(Kind::MRTD);
    let meta = serde_json::to_string(&meta_json(b, cache_key)).map_err(err)?;
    a.add_json("meta", &meta).map_err(err)?;
    let frames: Vec<f32> =
        FACE_FRAMES.iter().flat_map(|f| [f.origin, f.u, f.v, f.n]).flatten().map(|x| x as f32).collect();
    a.add_f32("face_frames", &[6, 4, 3], &frames).map_err(err)?;
    for s in &b.shapes {
        let tex = &s.texels;
        let name = tex.shape.name;
        let n = tex.len();
        let r = &s.reduced;
        let kb = r.u_b.ncols();
        let sec = |x: &str| format!("{name}.{x}");
        let faces: Vec<u8> = tex.faces.iter().map(|&f| f as u8).collect();
        a.add_u8(&sec("faces"), &[faces.len()], &faces).map_err(err)?;
        a.add_f32(&sec("positions"), &[n, 3], &f32s((0..n).flat_map(|t| tex.position(t)))).map_err(err)?;
        a.add_f32(&sec("normals"), &[n, 3], &f32s((0..n).flat_map(|t| tex.normal(t)))).map_err(err)?;
        a.add_f32(&sec("u_b"), &[n, kb], &f32s((0..n).flat_map(|i| (0..kb).map(move |j| r.u_b[(i, j)]))))
            .map_err(err)?;
        a.add_f32(&sec("t_d2b"), &[kb, n], &f32s((0..kb).flat_map(|i| (0..n).map(move |j| r.t_d2b[(i, j)]))))
            .map_err(err)?;
        a.add_f32(&sec("u_bvec"), &[n, kb, 4], &f32s(s.u_bvec.iter().copied())).map_err(err)?;
        let g = s.probes.len();
        a.add_f32(&sec("probes"), &[g, 3], &f32s(s.probes.iter().flatten().copied())).map_err(err)?;
        a.add_f32(&sec("u_bvol"), &[g, kb, 9], &f32s(s.u_bvol.iter().copied())).map_err(err)?;
        a.add_f32(&sec("sigma_d"), &[s.sigma_d_all.len()], &f32s(s.sigma_d_all.iter().copied())).map_err(err)?;
        a.add_f32(&sec("prior_s"), &[s.s.len()], &f32s(s.s.iter().copied())).map_err(err)?;
        a.add_f32(&sec("sigma_m"), &[r.sigma_m.len()], &f32s(r.sigma_m.iter().copied())).map_err(err)?;
        a.add_f32(&sec("l_imp"), &[n, kb], &f32s((0..n).flat_map(|i| (0..kb).map(move |j| r.l_imp[(i, j)]))))
            .map_err(err)?;
    }
    if let Some(ib) = &b.interfaces {
        let mat = |m: &faer::Mat<f64>| f32s((0..m.nrows()).flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)])));
        for (name, m) in ["iface.r_straight", "iface.r_left", "iface.r_right"].iter().zip(&ib.r_turn) {
            a.add_f32(name, &[m.nrows(), m.ncols()], &mat(m)).map_err(err)?;
        }
        a.add_f32("iface.u_r", &[ib.u_r.nrows(), ib.u_r.ncols()], &mat(&ib.u_r)).map_err(err)?;
        a.add_f32("iface.t_rlf2r", &[ib.t_rlf2r.nrows(), ib.t_rlf2r.ncols()], &mat(&ib.t_rlf2r)).map_err(err)?;
        a.add_f32("iface.sigma_rlf", &[ib.sigma_rlf.len()], &f32s(ib.sigma_rlf.iter().copied())).map_err(err)?;
        a.add_f32("iface.sigma_g", &[ib.sigma_g.len()], &f32s(ib.sigma_g.iter().copied())).map_err(err)?;
        // bit 0: the same-face exclusion runtime rule (params.exclude_same_face)
        a.add_u32("iface.flags", &[1], &[u32::from(b.params.exclude_same_face)]).map_err(err)?;
        for i in &ib.interfaces {
            let name = b.shapes[i.shape].texels.shape.name;
            let [rn, xn] = interface_section_names(name, i.face);
            a.add_f32(&rn, &[i.r_b2rlf.nrows(), i.r_b2rlf.ncols()], &mat(&i.r_b2rlf)).map_err(err)?;
            a.add_u32(&xn, &[i.u_r_index.len()], &i.u_r_index).map_err(err)?;
        }
        // kind version 4: the vector and volume response driven by r, after every older section
        if let Some(v) = &ib.vectors {
            let (rows, kr) = (ib.u_r.nrows(), ib.u_r.ncols());
            a.add_f32("iface.u_rvec", &[rows, kr, 4], &f32s(v.u_rvec.iter().copied())).map_err(err)?;
            let g = v.volume_res.pow(3);
            a.add_f32("iface.u_rvol", &[g, kr, 9], &f32s(v.u_rvol.iter().copied())).map_err(err)?;
        }
    }
    Ok(a)
}
