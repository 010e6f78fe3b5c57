//! Re-baked operators for warped blocks (MRT thesis §3.5.2, §3.7.1, Fig. 3.4).
//!
//! A level block is its dictionary shape scaled per axis (`Block::scale`). The dictionary's
//! operators are baked on the unit cube; a block stretched ×2 that reuses them transports
//! light as if it were a cube (docs/mrt.md, "What a warp costs"). The thesis's remedy: "ray
//! tracing the `U` vectors again with an appropriately stretched prior … taking only seconds
//! to re-precompute" (§3.7.1).
//!
//! What a re-bake recomputes, for the box `scale` (block-local axes):
//! - `F` by cosine gathers inside the stretched box (the same texel layout, the same
//!   Hammersley directions and per-texel rotations as the dictionary; a ray is traced in
//!   the unit cube along `d ⊘ scale`, which lands where the stretched ray does), balanced to
//!   the stretched box's wall fractions;
//! - [`WarpMode::RetraceU`]: `U_b' = F' L_imp` with the dictionary's implicit lights, so `b`
//!   keeps its meaning (`T_d→b`, `R_b→rlf`, `U_b⃗`, `U_bvol` are reused);
//! - [`WarpMode::StretchedPrior`] (the thesis's fourth image): the prior lights stretched with
//!   the box, `P`, `S` by SVD of their direct light on the stretched walls, enrichment, then
//!   `M = F' P S` → `U_b'`, `T_d→b'`, `L_imp'`; `b'` is a new basis, and the map
//!   `X = L_imp⁺ L_imp'` (least squares, `L_imp X ≈ L_imp'`) takes it back to the
//!   dictionary's `b` wherever the dictionary's operators are kept (`R_b→rlf X`).
//!
//! Kept from the dictionary in both modes: the interface operators (`R_b→rlf`, `R_↑/←/→`,
//! `U_r`, `T_rlf→r`: the lightfield basis is shared by every shape and every interface is a
//! unit square, §4.2.3).
//!
//! Uniform scale needs no re-bake (form factors are scale-free and the direct light scales
//! by a constant), so a warp is its scale divided by its smallest axis, and its stretch is
//! `max(scale)/min(scale)` ([`stretch`]).

use crate::TransportError;
use crate::balance::{balance, wall_fractions_scaled};
use crate::dict::DictParams;
use crate::gather::{DirectionSet, Gather, texel_rotation};
use crate::operators::{Prior, Reduced, enrich, fallback_basis, prior_from_samples, reduce};
use crate::prior::{DirectLight, SphereLight, prior_lights, slab_visibility};
use crate::shape::{FACE_FRAMES, Shape, Texels, face_uv};
use crate::svd::mul;
use faer::Mat;
use faer::linalg::solvers::Solve;
use rayon::prelude::*;

/// How much of a warped block's operators a re-bake recomputes (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarpMode {
    /// `U_b' = F' L_imp` (the thesis's third image: "ray tracing `U` again").
    RetraceU,
    /// Stretched prior, `F'`, enrichment and reduction (the thesis's fourth image).
    StretchedPrior,
}

impl WarpMode {
    /// Name as on the command line and in the asset's `meta`.
    pub fn name(self) -> &'static str {
        match self {
            Self::RetraceU => "retrace-u",
            Self::StretchedPrior => "stretched-prior",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "retrace-u" => Some(Self::RetraceU),
            "stretched-prior" => Some(Self::StretchedPrior),
            _ => None,
        }
    }
}

/// `max(scale)/min(scale)`: 1 for a cube of any size; a block is re-baked when this exceeds
/// the threshold `S` of `--rebake-warps-above S` (e.g. `S = 1.25`: some axis is more than
/// 1.25 × another).
pub fn stretch(scale: [f64; 3]) -> f64 {
    let mx = scale.iter().copied().fold(f64::MIN, f64::max);
    let mn = scale.iter().copied().fold(f64::MAX, f64::min);
    if mn > 0.0 { mx / mn } else { f64::INFINITY }
}

/// The warp of a block scale: `scale / min(scale)` rounded to f32 (the level asset's
/// precision), so blocks of one shape and one warp share a re-bake.
pub fn canonical_warp(scale: [f64; 3]) -> [f32; 3] {
    let mn = scale.iter().copied().fold(f64::MAX, f64::min);
    scale.map(|s| (s / mn) as f32)
}

/// Re-baked operators of one (shape, warp).
#[derive(Debug, Clone)]
pub struct WarpOps {
    /// The warp (`scale / min(scale)`).
    pub warp: [f64; 3],
    /// Mode.
    pub mode: WarpMode,
    /// `U_b'` (n × k_b'), `T_d→b'` (k_b' × n) and `L_imp'`; in `RetraceU` mode `T_d→b` and
    /// `L_imp` are the dictionary's.
    pub reduced: Reduced,
    /// `X` (k_b × k_b'): `b ≈ X b'`, the dictionary's `b` of the light whose re-baked
    /// coefficients are `b'` (identity in `RetraceU` mode).
    pub to_dict_b: Mat<f64>,
}

/// Direct light of sphere lights at the texel centres of `tex` stretched to `scale`: the
/// light's centre and the texels are scaled; visibility (which is affine-invariant: a segment
/// crosses a wall or not) is evaluated in the unit shape.
fn stretched_direct(tex: &Texels, unit_lights: &[SphereLight], scale: [f64; 3]) -> Mat<f64> {
    let dl = DirectLight::new();
    let sc = |p: [f64; 3]| [p[0] * scale[0], p[1] * scale[1], p[2] * scale[2]];
    let cols: Vec<Vec<f64>> = unit_lights
        .par_iter()
        .map(|l| {
            let slab = slab_visibility(&tex.shape, l);
            let c = sc(l.centre);
            (0..tex.len())
                .map(|t| {
                    let (x, n) = (sc(tex.position(t)), tex.normal(t));
                    let w = [c[0] - x[0], c[1] - x[1], c[2] - x[2]];
                    let d2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
                    let cos = (n[0] * w[0] + n[1] * w[1] + n[2] * w[2]) / d2.sqrt();
                    if cos <= 0.0 || slab == Some(0.0) {
                        return 0.0;
                    }
                    let vis = match slab {
                        Some(v) => v,
                        None => dl.sampled_visibility(&tex.shape, l, tex.position(t)),
                    };
                    vis * cos / d2
                })
                .collect()
        })
        .collect();
    Mat::from_fn(tex.len(), unit_lights.len(), |i, j| cols[j][i])
}

/// The bilinear-gather `F` (n × n) of `tex` stretched to `scale`: the dictionary's rays
/// (texel rotations by `(seed, shape_id, texel)`) in the stretched box's world frame.
pub fn stretched_transport(
    tex: &Texels,
    dirs: &DirectionSet,
    albedo: f64,
    seed: u64,
    shape_id: u64,
    scale: [f64; 3],
) -> Mat<f64> {
    let n = tex.len();
    let open = tex.shape.missing;
    let rows: Vec<Vec<f64>> = (0..n)
        .into_par_iter()
        .map(|x| {
            let mut row = vec![0.0f64; n];
            let (f, _, _) = tex.coords(x);
            let p = tex.position(x);
            let (c, s) = texel_rotation(seed, shape_id, x);
            let fr = &FACE_FRAMES[f];
            let ex: [f64; 3] = core::array::from_fn(|a| c * fr.u[a] + s * fr.v[a]);
            let ey: [f64; 3] = core::array::from_fn(|a| -s * fr.u[a] + c * fr.v[a]);
            let ez = fr.n;
            for l in &dirs.dirs {
                // world direction in the stretched box, then the unit cube's direction
                let d: [f64; 3] = core::array::from_fn(|a| (l[0] * ex[a] + l[1] * ey[a] + l[2] * ez[a]) / scale[a]);
                let mut g = 0usize;
                let mut t = f64::INFINITY;
                for a in 0..3 {
                    let pos = d[a].is_sign_positive();
                    let ta = if pos { 1.0 - p[a] } else { -p[a] } / d[a];
                    if ta < t {
                        t = ta;
                        g = 2 * a + usize::from(pos);
                    }
                }
                if open & (1 << g) != 0 {
                    continue;
                }
                let q = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
                let (u, v) = face_uv(g, q);
                for (k, w) in tex.bilinear(g, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)) {
                    row[k] += w;
                }
            }
            let sc = albedo / dirs.len() as f64;
            row.iter_mut().for_each(|v| *v *= sc);
            row
        })
        .collect();
    Mat::from_fn(n, n, |i, j| rows[i][j])
}

/// `F'` of a stretched shape with the dictionary's balance rule.
fn stretched_f(p: &DictParams, tex: &Texels, id: u64, scale: [f64; 3], rays: usize) -> Mat<f64> {
    let dirs = DirectionSet::cosine(rays);
    let mut f = stretched_transport(tex, &dirs, p.albedo, p.seed, id, scale);
    if p.balance {
        // Texels of a stretched box differ in area by face, so reciprocity is
        // `A_i F_ij = A_j F_ji`: balance `H = D_A F`, whose row sums (`A_i ρ g_i`: what texel
        // i gathers) and column sums (`A_j ρ g_j`: what texel j emits onto walls) share one
        // target, then `F = D_A⁻¹ H`. With unit areas this is the dictionary's balance.
        let area: Vec<f64> = (0..tex.len())
            .map(|t| {
                let fr = &FACE_FRAMES[tex.coords(t).0];
                let ext = |e: [f64; 3]| (0..3).map(|a| e[a].abs() * scale[a]).sum::<f64>();
                ext(fr.u) * ext(fr.v)
            })
            .collect();
        let n = tex.len();
        for j in 0..n {
            for i in 0..n {
                f[(i, j)] *= area[i];
            }
        }
        let target: Vec<f64> =
            wall_fractions_scaled(tex, scale).into_iter().zip(&area).map(|(g, a)| p.albedo * g * a).collect();
        balance(&mut f, &target, p.albedo);
        for j in 0..n {
            for i in 0..n {
                f[(i, j)] /= area[i];
            }
        }
    }
    f
}

/// Re-bakes shape `shape` (hash stream `id`, its index in the dictionary) for the box `scale`
/// with the dictionary's parameters `p` and `rays` gather rays per texel. `dict_l_imp` is the
/// dictionary's `L_imp` of the shape (n × k_b).
pub fn rebake(
    p: &DictParams,
    shape: Shape,
    id: u64,
    scale: [f64; 3],
    rays: usize,
    mode: WarpMode,
    dict_l_imp: &Mat<f64>,
    dict_t_d2b: &Mat<f64>,
) -> Result<WarpOps, TransportError> {
    if p.gather != Gather::Bilinear {
        return Err(TransportError::Param("warp re-bakes support the bilinear gather only".into()));
    }
    let mn = scale.iter().copied().fold(f64::MAX, f64::min);
    if !(mn > 0.0 && scale.iter().all(|s| s.is_finite())) {
        return Err(TransportError::Param(format!("block scale {scale:?} must be positive and finite")));
    }
    let warp = scale.map(|s| s / mn);
    let tex = Texels::new(shape, p.face_res);
    let f = stretched_f(p, &tex, id, warp, rays);
    let kb = dict_l_imp.ncols();
    match mode {
        WarpMode::RetraceU => {
            let u_b = mul(f.as_ref(), dict_l_imp.as_ref());
            let reduced = Reduced { sigma_m: Vec::new(), u_b, t_d2b: dict_t_d2b.clone(), l_imp: dict_l_imp.clone() };
            Ok(WarpOps { warp, mode, reduced, to_dict_b: Mat::identity(kb, kb) })
        }
        WarpMode::StretchedPrior => {
            let lights: Vec<SphereLight> = prior_lights(&shape, p.layout)
                .into_iter()
                .map(|c| SphereLight { centre: c, radius: p.light_radius })
                .collect();
            let l_d = stretched_direct(&tex, &lights, warp);
            let (prior0, _) = prior_from_samples(l_d.as_ref(), p.k_d)?;
            let fallback = fallback_basis(&tex, &prior0, p.fallback_modes);
            let mut prior: Prior = prior0;
            let mut reduced = reduce(f.as_ref(), &prior, p.k_b)?;
            for _ in 0..p.enrich {
                prior = enrich(&prior, fallback.as_ref(), reduced.u_b.as_ref(), p.k_d)?;
                reduced = reduce(f.as_ref(), &prior, p.k_b)?;
            }
            // X = (L_impᵀ L_imp)⁻¹ L_impᵀ L_imp'
            let g = crate::svd::mul_tn(dict_l_imp.as_ref(), dict_l_imp.as_ref());
            let rhs = crate::svd::mul_tn(dict_l_imp.as_ref(), reduced.l_imp.as_ref());
            let x = g.as_ref().partial_piv_lu().solve(rhs.as_ref());
            Ok(WarpOps { warp, mode, reduced, to_dict_b: x })
        }
    }
}

/// Direct light of sphere lights (unit-shape coordinates) at the stretched texels (for tests
/// and measurements).
pub fn direct_stretched(tex: &Texels, lights: &[SphereLight], scale: [f64; 3]) -> Mat<f64> {
    stretched_direct(tex, lights, scale)
}

/// One-bounce errors of a single warped block (no interfaces) against the level path tracer
/// on the stretched box.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BlockWarpErrors {
    /// `max(scale)/min(scale)`.
    pub stretch: f64,
    /// The dictionary's (unit) operators applied to the stretched block.
    pub rel_error_unit_ops: f64,
    /// `U_b' = F' L_imp` (`RetraceU`).
    pub rel_error_retrace_u: f64,
    /// Stretched prior and `F'` (`StretchedPrior`).
    pub rel_error_stretched_prior: f64,
    /// `F' E` itself (the re-traced transport's discretisation: the floor of any reduction).
    pub rel_error_transport: f64,
    /// The reference's own noise (half difference of two halves).
    pub reference_noise: f64,
    /// Seconds of the `StretchedPrior` re-bake.
    pub seconds_stretched_prior: f64,
    /// Seconds of the `RetraceU` re-bake.
    pub seconds_retrace_u: f64,
}

/// Measures a warped block alone: shape `shape` (dictionary index `id`, unit operators
/// `dict`) stretched to `scale`, lit by the dictionary's test lights of the shape (placed in
/// the unit shape, then stretched), against the level path tracer with `ref_rays` rays per
/// texel; the re-bakes use `rays` gather rays per texel.
#[allow(clippy::too_many_arguments)]
pub fn block_errors(
    p: &DictParams,
    shape: Shape,
    id: u64,
    scale: [f64; 3],
    rays: usize,
    dict: &Reduced,
    lights: usize,
    ref_rays: usize,
) -> Result<BlockWarpErrors, TransportError> {
    use crate::dict::{predict_with, rel_error};
    use crate::level::{Block, Level};
    use crate::level_reference::{LevelGeometry, PointLight, level_texels, reference};
    let tex = Texels::new(shape, p.face_res);
    let t0 = std::time::Instant::now();
    let retrace = rebake(p, shape, id, scale, rays, WarpMode::RetraceU, &dict.l_imp, &dict.t_d2b)?;
    let t1 = std::time::Instant::now();
    let sp = rebake(p, shape, id, scale, rays, WarpMode::StretchedPrior, &dict.l_imp, &dict.t_d2b)?;
    let t2 = std::time::Instant::now();
    let warp = retrace.warp;
    let tl = crate::prior::test_lights(&shape, p.layout, lights, p.light_radius, p.seed, id);
    let inside: Vec<SphereLight> =
        tl.into_iter().filter(|l| l.centre.iter().all(|&c| (0.0..=1.0).contains(&c))).collect();
    if inside.is_empty() {
        return Err(TransportError::Param("no test light inside the shape".into()));
    }
    let e = stretched_direct(&tex, &inside, warp);
    let missing = [shape.missing];
    let level = Level {
        blocks: vec![Block { shape: 0, rotation: 0, translation: warp.map(|s| 0.5 * s), scale: warp }],
        connections: Vec::new(),
    };
    let links = vec![[None; crate::shape::FACE_COUNT]];
    let geo = LevelGeometry { level: &level, links: &links, missing: &missing };
    let lt = level_texels(&level, &missing, p.face_res);
    let (mut refm, mut half) = (Mat::<f64>::zeros(tex.len(), inside.len()), 0.0f64);
    let mut ref2 = 0.0;
    for (j, l) in inside.iter().enumerate() {
        let pl = PointLight { position: l.centre.map(|_| 0.0), intensity: 1.0 };
        let c = l.centre;
        let pl = PointLight { position: [c[0] * warp[0], c[1] * warp[1], c[2] * warp[2]], ..pl };
        let r = reference(&geo, &lt, &[pl], p.albedo, ref_rays, 1, p.seed ^ j as u64, &|_| {});
        for i in 0..tex.len() {
            refm[(i, j)] = r.one_bounce[i];
            ref2 += r.one_bounce[i] * r.one_bounce[i];
            half += r.one_half_difference[i] * r.one_half_difference[i];
        }
    }
    let x = p.exclude_same_face;
    let err = |r: &Reduced| rel_error(predict_with(&tex, r, e.as_ref(), x).as_ref(), refm.as_ref());
    let f = stretched_f(p, &tex, id, warp, rays);
    Ok(BlockWarpErrors {
        stretch: stretch(scale),
        rel_error_unit_ops: err(dict),
        rel_error_retrace_u: err(&retrace.reduced),
        rel_error_stretched_prior: err(&sp.reduced),
        rel_error_transport: rel_error(mul(f.as_ref(), e.as_ref()).as_ref(), refm.as_ref()),
        reference_noise: (half / ref2.max(f64::MIN_POSITIVE)).sqrt(),
        seconds_stretched_prior: (t2 - t1).as_secs_f64(),
        seconds_retrace_u: (t1 - t0).as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::{CLOSED, DictionaryKind};

    fn small() -> DictParams {
        let mut p = DictParams::new(DictionaryKind::Cube2d);
        p.face_res = 8;
        p.rays = 1024;
        p.k_d = 32;
        p.k_b = 16;
        p.fallback_modes = 4;
        p.reference_rays = 64;
        p.test_lights = 8;
        p.vector_rays = 16;
        p.probe_rays = 16;
        p.volume_res = 1;
        p.interfaces = false;
        p.interface_vectors = false;
        p
    }

    #[test]
    fn unit_warp_rebake_reproduces_the_dictionary_transport() {
        let p = small();
        let tex = Texels::new(CLOSED, p.face_res);
        let dirs = DirectionSet::cosine(p.rays);
        let a = crate::gather::transport_matrix(&tex, &dirs, p.albedo, Gather::Bilinear, p.seed, 0, &|_| {});
        let b = stretched_transport(&tex, &dirs, p.albedo, p.seed, 0, [1.0; 3]);
        assert!((a - b).norm_l2() < 1e-12, "the unit stretch is the dictionary's gather");
        assert_eq!(stretch([2.0, 2.0, 2.0]), 1.0);
        assert_eq!(stretch([1.0, 1.0, 2.0]), 2.0);
        assert_eq!(canonical_warp([2.0, 2.0, 4.0]), [1.0, 1.0, 2.0]);
    }

    #[test]
    fn rebaked_stretched_block_is_closer_to_the_reference_than_the_unit_operators() {
        let p = small();
        let d = crate::dict::bake_shapes(&p, &[(0, CLOSED)], &penumbra_math::progress::NoProgress).unwrap();
        let e = block_errors(&p, CLOSED, 0, [1.0, 1.0, 2.0], p.rays, &d.shapes[0].reduced, 8, 256).unwrap();
        // ×2: the unit operators are far off, the re-bake is much closer (both re-bakes)
        assert!(e.rel_error_unit_ops > 0.2, "{e:?}");
        assert!(e.rel_error_stretched_prior < 0.7 * e.rel_error_unit_ops, "{e:?}");
        assert!(e.rel_error_retrace_u < e.rel_error_unit_ops, "{e:?}");
    }

    #[test]
    fn the_cache_key_follows_the_warp_and_the_mode() {
        let d = crate::level_ops::DictOps {
            names: vec!["closed".into()],
            missing: vec![0],
            k_b: vec![4],
            face_res: 4,
            r_b2rlf: Default::default(),
            r_turn: [Mat::zeros(1, 1), Mat::zeros(1, 1), Mat::zeros(1, 1)],
            t_rlf2r: Mat::zeros(1, 1),
            crc32c: 7,
            albedo: 1.0,
            shape_ops: vec![None],
            params: serde_json::json!({"face_res": 4}),
        };
        let k = |w: [f32; 3], m| warp_key_json(&d, 0, w, m, 1024).to_string();
        let a = k([1.0, 1.0, 2.0], WarpMode::StretchedPrior);
        assert_eq!(a, k([1.0, 1.0, 2.0], WarpMode::StretchedPrior));
        assert_ne!(a, k([1.0, 1.0, 2.5], WarpMode::StretchedPrior));
        assert_ne!(a, k([1.0, 2.0, 1.0], WarpMode::StretchedPrior));
        assert_ne!(a, k([1.0, 1.0, 2.0], WarpMode::RetraceU));
        assert_ne!(a, warp_key_json(&d, 0, [1.0, 1.0, 2.0], WarpMode::StretchedPrior, 2048).to_string());
    }
}

#[cfg(test)]
mod measure {
    use super::*;
    use crate::shape::{CLOSED, CUBE2D, DictionaryKind};

    /// The docs/mrt.md table at the thesis settings (`cargo test --release -p
    /// penumbra-transport warp_table -- --ignored --nocapture`).
    #[test]
    #[ignore]
    #[allow(clippy::print_stdout)]
    fn warp_table() {
        let mut p = DictParams::new(DictionaryKind::Cube2d);
        p.interfaces = false;
        p.interface_vectors = false;
        let rays: usize = std::env::var("WARP_RAYS").ok().and_then(|s| s.parse().ok()).unwrap_or(p.rays);
        let shapes = [(0u64, CLOSED), (2u64, CUBE2D[2])];
        let d = crate::dict::bake_shapes(&p, &shapes, &penumbra_math::progress::NoProgress).unwrap();
        for (k, (id, s)) in shapes.iter().enumerate() {
            for z in [1.0, 1.5, 2.0, 3.0] {
                let e = block_errors(&p, *s, *id, [1.0, 1.0, z], rays, &d.shapes[k].reduced, 16, 1024).unwrap();
                println!(
                    "{} x{z} rays {rays}: unit {:.4} retrace {:.4} prior {:.4} transport {:.4} noise {:.4} s_prior {:.3} s_retrace {:.3}",
                    s.name,
                    e.rel_error_unit_ops,
                    e.rel_error_retrace_u,
                    e.rel_error_stretched_prior,
                    e.rel_error_transport,
                    e.reference_noise,
                    e.seconds_stretched_prior,
                    e.seconds_retrace_u
                );
            }
        }
    }
}

/// The dictionary parameters a re-bake needs, from an `MRTD`'s `meta.params`.
pub fn dict_params_from_meta(v: &serde_json::Value) -> Result<DictParams, TransportError> {
    let bad = |k: &str| TransportError::Input(format!("the dictionary's meta.params.{k} is missing or invalid"));
    let kind =
        v["dictionary"].as_str().and_then(crate::shape::DictionaryKind::parse).ok_or_else(|| bad("dictionary"))?;
    let mut p = DictParams::new(kind);
    let u = |k: &str| v[k].as_u64().map(|x| x as usize).ok_or_else(|| bad(k));
    let f = |k: &str| v[k].as_f64().ok_or_else(|| bad(k));
    let b = |k: &str| v[k].as_bool().ok_or_else(|| bad(k));
    p.face_res = u("face_res")?;
    p.k_d = u("k_d")?;
    p.k_b = u("k_b")?;
    p.rays = u("rays")?;
    p.albedo = f("albedo")?;
    p.enrich = u("enrich")?;
    p.fallback_modes = u("fallback_modes")?;
    p.gather = v["gather"].as_str().and_then(Gather::parse).ok_or_else(|| bad("gather"))?;
    p.balance = b("balance")?;
    p.exclude_same_face = b("exclude_same_face")?;
    p.layout =
        v["light_layout"].as_str().and_then(crate::prior::LightLayout::parse).ok_or_else(|| bad("light_layout"))?;
    p.light_radius = f("light_radius")?;
    p.seed = v["seed"].as_u64().ok_or_else(|| bad("seed"))?;
    Ok(p)
}

/// One re-baked (shape, warp) of a level.
#[derive(Debug, Clone)]
pub struct WarpEntry {
    /// Dictionary shape index.
    pub shape: usize,
    /// The warp (`scale / min(scale)`, f32).
    pub warp: [f32; 3],
    /// The operators.
    pub ops: WarpOps,
    /// Its cache key (shape, warp, mode, rays, the dictionary's parameters and CRC).
    pub cache_key: String,
    /// Wall seconds of the re-bake (reported, never stored).
    pub seconds: f64,
}

/// The re-baked warps of a level (`mrt level --rebake-warps-above S`).
#[derive(Debug, Clone)]
pub struct LevelWarps {
    /// `S`.
    pub threshold: f64,
    /// Mode.
    pub mode: WarpMode,
    /// Gather rays per texel of `F'`.
    pub rays: usize,
    /// Distinct (shape, warp) re-bakes, in first-use order.
    pub entries: Vec<WarpEntry>,
    /// Per block: its entry, or `None` (stretch ≤ S).
    pub block_warp: Vec<Option<usize>>,
}

impl LevelWarps {
    /// `meta.warps` of the level asset (no timings: same inputs, same bytes).
    pub fn meta(&self) -> serde_json::Value {
        serde_json::json!({
            "rebake_above": self.threshold,
            "mode": self.mode.name(),
            "rays": self.rays,
            "definition": "a block is re-baked when max(scale)/min(scale) > rebake_above; its warp is scale/min(scale)",
            "entries": self.entries.iter().map(|e| serde_json::json!({
                "shape": e.shape,
                "warp": e.warp,
                "stretch": stretch(e.warp.map(f64::from)),
                "cache_key": e.cache_key,
            })).collect::<Vec<_>>(),
        })
    }
}

/// The key material of one re-bake (hashed by the caller): everything its bytes depend on.
pub fn warp_key_json(
    d: &crate::level_ops::DictOps,
    shape: usize,
    warp: [f32; 3],
    mode: WarpMode,
    rays: usize,
) -> serde_json::Value {
    serde_json::json!({
        "stage": "mrt_warp",
        "tool": env!("CARGO_PKG_VERSION"),
        "dict_crc32c": d.crc32c,
        "dict_params": d.params,
        "shape": d.names[shape],
        "warp": warp.map(f32::to_bits),
        "mode": mode.name(),
        "rays": rays,
    })
}

/// Re-bakes every distinct (shape, warp) of `level` whose stretch exceeds `threshold`.
/// `key` turns [`warp_key_json`] into a cache key; `cached` may return a re-bake for a key
/// (a cache hit), `store` is told of every fresh one.
pub fn rebake_level(
    level: &crate::level::Level,
    d: &crate::level_ops::DictOps,
    threshold: f64,
    rays: usize,
    mode: WarpMode,
    key: &dyn Fn(&serde_json::Value) -> String,
    cached: &dyn Fn(&str) -> Option<WarpOps>,
) -> Result<LevelWarps, TransportError> {
    if !(threshold >= 1.0 && threshold.is_finite()) {
        return Err(TransportError::Param(format!(
            "rebake_warps_above {threshold} is out of range (allowed: 1 <= S < inf)"
        )));
    }
    let p = dict_params_from_meta(&d.params)?;
    let all = p.dictionary.shapes();
    let mut entries: Vec<WarpEntry> = Vec::new();
    let mut block_warp = Vec::with_capacity(level.blocks.len());
    for b in &level.blocks {
        if stretch(b.scale) <= threshold {
            block_warp.push(None);
            continue;
        }
        let w = canonical_warp(b.scale);
        if let Some(i) = entries.iter().position(|e| e.shape == b.shape && e.warp == w) {
            block_warp.push(Some(i));
            continue;
        }
        let name = &d.names[b.shape];
        let (id, shape) =
            all.iter().enumerate().find(|(_, s)| s.name == name).map(|(i, s)| (i as u64, *s)).ok_or_else(|| {
                TransportError::Input(format!("shape {name} is not in the {} dictionary", p.dictionary.name()))
            })?;
        let Some((l_imp, t_d2b)) = &d.shape_ops[b.shape] else {
            return Err(TransportError::Input(format!(
                "the dictionary has no {name}.l_imp (MRTD kind version 3 or later): re-bake it to re-bake warps"
            )));
        };
        let k = key(&warp_key_json(d, b.shape, w, mode, rays));
        let t = std::time::Instant::now();
        let ops = match cached(&k) {
            Some(o) => o,
            None => rebake(&p, shape, id, w.map(f64::from), rays, mode, l_imp, t_d2b)?,
        };
        entries.push(WarpEntry { shape: b.shape, warp: w, ops, cache_key: k, seconds: t.elapsed().as_secs_f64() });
        block_warp.push(Some(entries.len() - 1));
    }
    Ok(LevelWarps { threshold, mode, rays, entries, block_warp })
}
