//! Interface operators of a dictionary (MRT thesis §3.4.1, §4.2, App. A): how light leaves a
//! block through a missing face, crosses the next block, and lights its walls.
//!
//! 1. **Raw lightfields** `H_lf` (§4.2.1): for every missing side face of every shape, the
//!    radiance leaving through the face under each implicit light (column of `L_imp`),
//!    `L = ρ·l/π` on the walls, resampled on the lightfield grid ([`crate::lightfield`]):
//!    from each spatial node, each supersampled direction looks back into the block and reads
//!    the wall it sees (bilinear texel read; an opening gives 0).
//! 2. **Normalisation** (eq. 4.1): every shape's columns are scaled by
//!    `√(Sum_total / (Sum_element · element_count))`, `Sum = Σσ_m²` of the shape's `M`, so
//!    that shapes weigh alike in the SVD (the operators use the unscaled lightfields).
//! 3. **Reduced lightfield basis** `H_rlf = Ũ_rlf Σ̃_rlf` (`k_rlf`, default 128) from the SVD of
//!    the normalised `H_lf` (via its Gram matrix: 82944 rows × 384 columns at the thesis's
//!    resolution), then **enrichment** (App. A, thesis: 3 iterations): the basis propagated
//!    through the three propagation resamplings (`L_temp`) and the basis itself, each at unit
//!    Frobenius norm, concatenated and re-decomposed, `k_rlf` kept.
//! 4. **Operators** in the coordinates `c` of `H_rlf` (a lightfield `h ≈ H_rlf c`,
//!    `c = Σ̃⁻¹Ũᵀh`): `R_b→rlf = Σ̃⁻¹Ũᵀ H_lf(shape, face)` (k_rlf × k_b) per interface;
//!    `R_↑, R_←, R_→ = Σ̃⁻¹Ũᵀ P_turn H_rlf` (k_rlf²) with `P_turn` the free-space resampling
//!    from the canonical entering face (−Z) to the face straight ahead, left or right
//!    (§4.2.2: the basis on one interface, ray traced from the others); the response
//!    `G = F_rlf H_rlf` on the five other faces of the canonical block by cosine gathers
//!    through the entering face (§4.2.3), `G = U_g Σ_g V_gᵀ`, `U_r = Ũ_g` (k_r, default 32),
//!    `T_rlf→r = Σ̃_g Ṽ_gᵀ`.
//! 5. Per shape and missing face, the map from the shape's texels to the canonical response
//!    texels for light entering through that face (a rotation about the vertical axis).
//!
//! Propagation is free space: a ray from one interface to another crosses the block without
//! touching its walls (the block is convex), so `P_turn`, `G` and the `R`s depend only on the
//! geometry of the canonical cube, not on which of its faces are walls (§4.2.3: "a single
//! interface ... can then be used for any other element").

use crate::TransportError;
use crate::gather::{DirectionSet, cast, texel_rotation, to_world};
use crate::lightfield::{
    CANONICAL_ENTRY, IfaceFrame, LfGrid, RESPONSE_FACES, Turn, dir_to_square, quarter_turns_to_canonical,
    rotate_to_canonical, square_to_dir,
};
use crate::operators::Reduced;
use crate::shape::{FACE_COUNT, Shape, Texels, exit_face, face_axis, face_uv};
use crate::sparse::Csr;
use crate::svd::{frobenius, gram_tn, mul_tall, sym_eigen, thin_svd};
use faer::{Mat, MatRef};
use penumbra_math::progress::Progress;
use rayon::prelude::*;
use serde::Serialize;

/// Interface bake parameters (defaults: the thesis, §3.6.1).
#[derive(Debug, Clone, PartialEq)]
pub struct InterfaceParams {
    /// Reduced lightfield modes (thesis: 128).
    pub k_rlf: usize,
    /// Response modes (thesis: 32).
    pub k_r: usize,
    /// Lightfield resolution (thesis: 12² × 24², 5² supersampling).
    pub grid: LfGrid,
    /// Enrichment iterations of `H_rlf` (thesis: 3).
    pub enrich: usize,
    /// Cosine gather rays per texel for the response `G`.
    pub response_rays: usize,
}

impl Default for InterfaceParams {
    fn default() -> Self {
        Self { k_rlf: 128, k_r: 32, grid: LfGrid::THESIS, enrich: 3, response_rays: 1024 }
    }
}

/// One shape's side of one interface.
#[derive(Debug, Clone)]
pub struct ShapeInterface {
    /// Index of the shape in the dictionary.
    pub shape: usize,
    /// The missing face (0, 1, 4 or 5).
    pub face: usize,
    /// `R_b→rlf` (k_rlf × k_b): the shape's `b` to the lightfield leaving through `face`.
    pub r_b2rlf: Mat<f64>,
    /// For light entering through `face`: each texel's row in the canonical `U_r`.
    pub u_r_index: Vec<u32>,
}

/// Quality figures of the interface bake.
#[derive(Debug, Clone, Serialize)]
pub struct InterfaceMetrics {
    /// Lightfield samples per interface (`S²·D²`).
    pub lightfield_samples: usize,
    /// Share of the normalised `H_lf`'s energy `Σσ²` in the first `k_rlf` modes (before
    /// enrichment).
    pub lightfield_energy_captured: f64,
    /// `‖H_lf − Ũ Ũᵀ H_lf‖ / ‖H_lf‖` (normalised `H_lf`) with the final basis.
    pub lightfield_rel_error: f64,
    /// The same before enrichment.
    pub lightfield_rel_error_before_enrichment: f64,
    /// Per turn: the part of the propagated basis `P_turn H_rlf` outside the final basis
    /// (`‖(I − ŨŨᵀ) P H_rlf‖ / ‖P H_rlf‖`): what enrichment is for.
    pub propagation_rel_error: [f64; 3],
    /// The same before enrichment.
    pub propagation_rel_error_before_enrichment: [f64; 3],
    /// `‖G − U_r T_rlf→r‖ / ‖G‖`.
    pub response_rel_error: f64,
    /// Stored entries of the three propagation resamplings (sparsity).
    pub propagation_nnz: [usize; 3],
}

/// The interface operators of a dictionary.
#[derive(Debug, Clone)]
pub struct InterfaceBake {
    /// Parameters.
    pub params: InterfaceParams,
    /// Every interface of every shape, in shape order then face order.
    pub interfaces: Vec<ShapeInterface>,
    /// Singular values of the final `H_rlf` (its scales `Σ̃_rlf`, k_rlf).
    pub sigma_rlf: Vec<f64>,
    /// Every singular value of the normalised raw `H_lf`.
    pub sigma_lf: Vec<f64>,
    /// `R_↑`, `R_←`, `R_→` (k_rlf × k_rlf), in [`Turn::ALL`] order.
    pub r_turn: [Mat<f64>; 3],
    /// `U_r` (5·R² × k_r), rows: the canonical block's faces [`RESPONSE_FACES`] in order,
    /// each `R × R` in its texel layout.
    pub u_r: Mat<f64>,
    /// `T_rlf→r` (k_r × k_rlf).
    pub t_rlf2r: Mat<f64>,
    /// Every singular value of `G`.
    pub sigma_g: Vec<f64>,
    /// Measurements.
    pub metrics: InterfaceMetrics,
}

/// What the interface bake reads from each shape's dictionary bake.
#[derive(Debug, Clone, Copy)]
pub struct ShapeInput<'a> {
    /// Texel layout.
    pub texels: &'a Texels,
    /// Final operators (`l_imp`).
    pub reduced: &'a Reduced,
}

/// The missing side faces of a shape (interfaces), in face order.
pub fn side_openings(shape: &Shape) -> Vec<usize> {
    shape.missing_faces().into_iter().filter(|&f| face_axis(f).0 != 1).collect()
}

/// The lightfield leaving `tex`'s shape through `face` for the texel values in the columns
/// of `l` (n × k, row-major): `L = (ρ/π)·l(wall seen)` averaged over each cell's supersamples
/// (bilinear texel reads; an opening gives 0). Returns `m × k`, row-major. Rows are
/// independent (parallel in fixed chunks); each row sums in a fixed order.
pub fn wall_lightfield_apply(tex: &Texels, face: usize, grid: LfGrid, albedo: f64, l: &[f64], k: usize) -> Vec<f64> {
    let frame = IfaceFrame::outgoing(face);
    let q2 = grid.sub * grid.sub;
    let w = albedo / core::f64::consts::PI / q2 as f64;
    let dirs: Vec<[f64; 3]> = grid.sub_directions().iter().map(|&d| frame.world(d)).collect();
    let d2 = grid.dir * grid.dir;
    let mut out = vec![0.0; grid.len() * k];
    out.par_chunks_mut(k * 64).enumerate().for_each(|(c, block)| {
        for (q, dst) in block.chunks_mut(k).enumerate() {
            let row = c * 64 + q;
            let (sp, dk) = (row / d2, row % d2);
            let (ir, iy) = (sp % grid.spatial, sp / grid.spatial);
            let (r, y) = grid.spatial_pos(ir, iy);
            let p = frame.point(r, y);
            for om in &dirs[dk * q2..(dk + 1) * q2] {
                let Some((g, u, v)) = cast(tex, p, [-om[0], -om[1], -om[2]]) else { continue };
                for (t, bw) in tex.bilinear(g, u, v) {
                    if bw != 0.0 {
                        let src = &l[t * k..(t + 1) * k];
                        let a = w * bw;
                        for (o, s) in dst.iter_mut().zip(src) {
                            *o += a * s;
                        }
                    }
                }
            }
        }
    });
    out
}

/// The same resampling as a sparse matrix (m × n), for tests and inspection.
pub fn wall_lightfield(tex: &Texels, face: usize, grid: LfGrid, albedo: f64) -> Csr {
    let frame = IfaceFrame::outgoing(face);
    let w = albedo / core::f64::consts::PI / (grid.sub * grid.sub) as f64;
    Csr::build(grid.len(), tex.len(), |k, out| {
        let (ir, iy, j1, j2) = grid.coords(k);
        let (r, y) = grid.spatial_pos(ir, iy);
        let p = frame.point(r, y);
        for q2 in 0..grid.sub {
            for q1 in 0..grid.sub {
                let (s1, s2) = grid.sub_square(j1, j2, q1, q2);
                let om = frame.world(square_to_dir(s1, s2));
                let Some((g, u, v)) = cast(tex, p, [-om[0], -om[1], -om[2]]) else { continue };
                for (t, bw) in tex.bilinear(g, u, v) {
                    if bw != 0.0 {
                        out.push((t as u32, w * bw));
                    }
                }
            }
        }
    })
}

/// The free-space resampling `P_turn` (m × m): the lightfield leaving the canonical block
/// through the face of `turn` from the lightfield entering through −Z (travel +Z).
pub fn propagation(grid: LfGrid, turn: Turn) -> Csr {
    let fb = IfaceFrame::outgoing(turn.canonical_exit());
    let fa = IfaceFrame::incoming(CANONICAL_ENTRY);
    let q2n = grid.sub * grid.sub;
    let w = 1.0 / q2n as f64;
    let dirs: Vec<[f64; 3]> = grid.sub_directions().iter().map(|&d| fb.world(d)).collect();
    let d2 = grid.dir * grid.dir;
    Csr::build(grid.len(), grid.len(), |k, out| {
        let (ir, iy) = ((k / d2) % grid.spatial, (k / d2) / grid.spatial);
        let (r, y) = grid.spatial_pos(ir, iy);
        let p = fb.point(r, y);
        {
            for &om in &dirs[(k % d2) * q2n..(k % d2 + 1) * q2n] {
                let back = [-om[0], -om[1], -om[2]];
                let (g, t) = exit_face(p, back);
                if g != CANONICAL_ENTRY {
                    continue;
                }
                let q = [p[0] + t * back[0], p[1] + t * back[1], p[2] + t * back[2]];
                let (ra, ya) = fa.coords(q);
                let l = fa.local(om);
                let (sa, sb) = dir_to_square(l[0], l[1]);
                for (s, tw) in grid.taps(ra, ya, sa, sb) {
                    if tw != 0.0 {
                        out.push((s as u32, w * tw));
                    }
                }
            }
        }
    })
}

/// The canonical response block: every face but the entering −Z.
pub fn response_texels(res: usize) -> Texels {
    let t = Texels::new(Shape::new("canonical", 1 << CANONICAL_ENTRY), res);
    debug_assert_eq!(t.faces, RESPONSE_FACES);
    t
}

/// `G = F_rlf X`: irradiance at the canonical response texels from lightfields (columns of
/// `x`, row-major `m × k`) entering through −Z, by `rays` cosine gathers per texel with
/// interpolated lightfield reads: `E = (π/N) Σ L`. Returns row-major `5R² × k`.
pub fn response_gather(res: usize, grid: LfGrid, x: &[f64], k: usize, rays: usize, seed: u64) -> Vec<f64> {
    let tex = response_texels(res);
    let dirs = DirectionSet::cosine(rays);
    let fa = IfaceFrame::incoming(CANONICAL_ENTRY);
    let scale = core::f64::consts::PI / rays as f64;
    let mut out = vec![0.0; tex.len() * k];
    out.par_chunks_mut(k).enumerate().for_each(|(t, dst)| {
        let (f, _, _) = tex.coords(t);
        let p = tex.position(t);
        let rot = texel_rotation(seed ^ 0x4946_4143, 0x4946, t);
        for l in &dirs.dirs {
            let (_, d) = to_world(f, *l, rot);
            let (g, tt) = exit_face(p, d);
            if g != CANONICAL_ENTRY {
                continue;
            }
            let q = [p[0] + tt * d[0], p[1] + tt * d[1], p[2] + tt * d[2]];
            let (ra, ya) = fa.coords(q);
            let om = fa.local([-d[0], -d[1], -d[2]]);
            let (sa, sb) = dir_to_square(om[0], om[1]);
            for (s, w) in grid.taps(ra, ya, sa, sb) {
                if w == 0.0 {
                    continue;
                }
                let src = &x[s * k..(s + 1) * k];
                for (o, v) in dst.iter_mut().zip(src) {
                    *o += w * v;
                }
            }
        }
        dst.iter_mut().for_each(|o| *o *= scale);
    });
    out
}

/// For light entering `shape` through side face `face`: each texel's row in the canonical
/// response texels ([`response_texels`]): the block rotated about its vertical axis so that
/// `face` becomes the canonical −Z entry.
pub fn u_r_index(tex: &Texels, face: usize) -> Vec<u32> {
    let q = quarter_turns_to_canonical(face);
    let canon = response_texels(tex.res);
    let r = tex.res as f64;
    (0..tex.len())
        .map(|t| {
            let p = rotate_to_canonical(tex.position(t), q);
            let g = (0..FACE_COUNT)
                .find(|&g| {
                    let (a, pos) = face_axis(g);
                    (p[a] - if pos { 1.0 } else { 0.0 }).abs() < 1e-9
                })
                .unwrap_or(CANONICAL_ENTRY);
            debug_assert_ne!(g, CANONICAL_ENTRY, "the entering face is missing");
            let (u, v) = face_uv(g, p);
            let (i, j) = (((u * r) as usize).min(tex.res - 1), ((v * r) as usize).min(tex.res - 1));
            canon.index(g, i, j) as u32
        })
        .collect()
}

fn to_row_major(m: MatRef<'_, f64>) -> Vec<f64> {
    let (r, c) = m.shape();
    let mut v = vec![0.0; r * c];
    for j in 0..c {
        for i in 0..r {
            v[i * c + j] = m[(i, j)];
        }
    }
    v
}

fn from_row_major(v: &[f64], r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |i, j| v[i * c + j])
}

/// Copies a row-major `m × c` block into columns `c0..c0+c` of `x`.
fn put_columns(x: &mut Mat<f64>, c0: usize, v: &[f64], c: usize) {
    for i in 0..x.nrows() {
        for j in 0..c {
            x[(i, c0 + j)] = v[i * c + j];
        }
    }
}

/// Leading `k` left singular vectors of `X W` (`W = diag(w)`, one weight per column) and all
/// its singular values, from the eigen-decomposition of `W XᵀX W` (one chunked Gram of the
/// whole tall matrix, `u_i = X W v_i / σ_i`).
fn basis_weighted(x: MatRef<'_, f64>, w: &[f64], k: usize) -> Result<(Mat<f64>, Vec<f64>), TransportError> {
    let n = x.ncols();
    let mut g = gram_tn(x, x);
    for j in 0..n {
        for i in 0..n {
            g[(i, j)] *= w[i] * w[j];
        }
    }
    let (vals, vecs) = sym_eigen(g.as_ref())?;
    let sigma: Vec<f64> = vals.iter().map(|&l| l.max(0.0).sqrt()).collect();
    let k = k.min(crate::svd::numerical_rank(&sigma, 1e-7));
    let v = Mat::from_fn(n, k, |r, c| vecs[(r, c)] * w[r] / sigma[c]);
    let mut u = mul_tall(x, v.as_ref());
    crate::svd::canonical_columns(&mut u);
    Ok((u, sigma))
}

/// `‖(I − UUᵀ)X‖/‖X‖` from `UᵀX` and `‖X‖`, for orthonormal `U`.
fn outside_from(utx: MatRef<'_, f64>, norm_x: f64) -> f64 {
    if norm_x == 0.0 {
        return 0.0;
    }
    (1.0 - (frobenius(utx) / norm_x).powi(2)).max(0.0).sqrt()
}

/// Bakes the interface operators of the shapes (the dictionary's, in order), for a
/// dictionary baked with albedo `albedo` and `face_res` texels per edge.
pub fn bake_interfaces(
    shapes: &[ShapeInput<'_>],
    sigma_m: &[Vec<f64>],
    albedo: f64,
    face_res: usize,
    p: &InterfaceParams,
    seed: u64,
    progress: &dyn Progress,
) -> Result<InterfaceBake, TransportError> {
    let grid = p.grid;
    let m = grid.len();
    let list: Vec<(usize, usize)> = shapes
        .iter()
        .enumerate()
        .flat_map(|(s, x)| side_openings(&x.texels.shape).into_iter().map(move |f| (s, f)))
        .collect();
    if list.is_empty() {
        return Err(TransportError::Param(
            "the dictionary has no interfaces (no shape has a missing side face)".into(),
        ));
    }
    let steps = (list.len() + 5 + 2 * p.enrich) as u64;
    let mut done = 0u64;
    let mut tick = |progress: &dyn Progress| {
        done += 1;
        progress.update("interfaces", done, steps);
    };
    // 1. raw lightfields H_lf, one block of k_b columns per interface, side by side
    let widths: Vec<usize> = list.iter().map(|&(s, _)| shapes[s].reduced.l_imp.ncols()).collect();
    let offs: Vec<usize> = widths
        .iter()
        .scan(0, |a, &w| {
            let o = *a;
            *a += w;
            Some(o)
        })
        .collect();
    let total: usize = widths.iter().sum();
    let mut h_all = Mat::<f64>::zeros(m, total);
    for (i, &(s, f)) in list.iter().enumerate() {
        let l = to_row_major(shapes[s].reduced.l_imp.as_ref());
        let h = wall_lightfield_apply(shapes[s].texels, f, grid, albedo, &l, widths[i]);
        put_columns(&mut h_all, offs[i], &h, widths[i]);
        tick(progress);
    }
    // 2. eq. 4.1: per-element scale of its columns
    let sums: Vec<f64> = sigma_m.iter().map(|s| s.iter().map(|x| x * x).sum()).collect();
    let sum_total: f64 = sums.iter().sum();
    let scale: Vec<f64> =
        sums.iter().map(|&e| if e > 0.0 { (sum_total / (e * sums.len() as f64)).sqrt() } else { 0.0 }).collect();
    let col_w: Vec<f64> = list.iter().zip(&widths).flat_map(|(&(s, _), &w)| std::iter::repeat_n(scale[s], w)).collect();
    // 3. basis of the normalised H_lf
    let (mut u, sigma_lf) = basis_weighted(h_all.as_ref(), &col_w, p.k_rlf)?;
    tick(progress);
    let col_norm2: Vec<f64> = (0..total).map(|j| h_all.col(j).iter().map(|x| x * x).sum::<f64>()).collect();
    let h_norm2: f64 = col_norm2.iter().zip(&col_w).map(|(n, w)| n * w * w).sum();
    // share of the normalised H_lf outside the basis, from UᵀH
    let captured = |uth: MatRef<'_, f64>| -> f64 {
        let inside: f64 = (0..total).map(|j| uth.col(j).iter().map(|x| x * x).sum::<f64>() * col_w[j] * col_w[j]).sum();
        (1.0 - inside / h_norm2).max(0.0).sqrt()
    };
    let lf_before = captured(gram_tn(u.as_ref(), h_all.as_ref()).as_ref());
    let k0 = u.ncols();
    let energy: f64 = sigma_lf.iter().map(|x| x * x).sum();
    let lightfield_energy_captured = sigma_lf[..k0].iter().map(|x| x * x).sum::<f64>() / energy.max(f64::MIN_POSITIVE);
    let mut sig: Vec<f64> = sigma_lf[..k0].to_vec();
    let props: Vec<Csr> = Turn::ALL.par_iter().map(|&t| propagation(grid, t)).collect();
    tick(progress);
    let scaled = |u: &Mat<f64>, s: &[f64]| Mat::from_fn(u.nrows(), u.ncols(), |i, j| u[(i, j)] * s[j]);
    let propagate = |h: &Mat<f64>| -> Vec<Vec<f64>> {
        let x = to_row_major(h.as_ref());
        props.iter().map(|pr| pr.apply(&x, h.ncols())).collect()
    };
    let norm_rm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut prop_before = [0.0; 3];
    // 3b. enrichment (App. A): [H_rlf, L_temp] at unit Frobenius norm each
    for it in 0..p.enrich {
        let k = u.ncols();
        let a = scaled(&u, &sig);
        let lt = propagate(&a);
        let mut x = Mat::<f64>::zeros(m, 4 * k);
        x.as_mut().subcols_mut(0, k).copy_from(a.as_ref());
        for (i, l) in lt.iter().enumerate() {
            put_columns(&mut x, (i + 1) * k, l, k);
        }
        if it == 0 {
            let utx = gram_tn(u.as_ref(), x.as_ref());
            for (i, e) in prop_before.iter_mut().enumerate() {
                *e = outside_from(utx.as_ref().subcols((i + 1) * k, k), norm_rm(&lt[i]));
            }
        }
        tick(progress);
        let na = frobenius(a.as_ref());
        let nb = lt.iter().map(|l| norm_rm(l).powi(2)).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
        let w: Vec<f64> = (0..4 * k).map(|j| if j < k { 1.0 / na } else { 1.0 / nb }).collect();
        let (nu, ns) = basis_weighted(x.as_ref(), &w, p.k_rlf)?;
        // keep the basis on the lightfields' physical scale
        sig = ns[..nu.ncols()].iter().map(|x| x * na).collect();
        u = nu;
        tick(progress);
    }
    let k = u.ncols();
    let h_rlf = scaled(&u, &sig);
    // 4. operators in the coordinates c = Σ̃⁻¹Ũᵀh
    let uth = gram_tn(u.as_ref(), h_all.as_ref());
    let lightfield_rel_error = captured(uth.as_ref());
    let coords = |utx: MatRef<'_, f64>| Mat::from_fn(k, utx.ncols(), |i, j| utx[(i, j)] / sig[i]);
    let mut interfaces = Vec::with_capacity(list.len());
    for (i, &(s, f)) in list.iter().enumerate() {
        interfaces.push(ShapeInterface {
            shape: s,
            face: f,
            r_b2rlf: coords(uth.as_ref().subcols(offs[i], widths[i])),
            u_r_index: u_r_index(shapes[s].texels, f),
        });
    }
    drop(h_all);
    let lt = propagate(&h_rlf);
    let mut propagation_rel_error = [0.0; 3];
    let mut r_turn: Vec<Mat<f64>> = Vec::with_capacity(3);
    for (i, l) in lt.iter().enumerate() {
        let utl = gram_tn(u.as_ref(), from_row_major(l, m, k).as_ref());
        propagation_rel_error[i] = outside_from(utl.as_ref(), norm_rm(l));
        r_turn.push(coords(utl.as_ref()));
    }
    if p.enrich == 0 {
        prop_before = propagation_rel_error;
    }
    let r_turn: [Mat<f64>; 3] = [r_turn[0].clone(), r_turn[1].clone(), r_turn[2].clone()];
    tick(progress);
    // response: G = F_rlf H_rlf, U_r, T_rlf→r
    let x = to_row_major(h_rlf.as_ref());
    let g = from_row_major(&response_gather(face_res, grid, &x, k, p.response_rays, seed), 5 * face_res * face_res, k);
    let d = thin_svd(g.as_ref())?;
    let kr = p.k_r.min(crate::svd::numerical_rank(&d.s, 1e-12)).max(1).min(d.s.len());
    let u_r = Mat::from_fn(g.nrows(), kr, |i, j| d.u[(i, j)]);
    let t_rlf2r = Mat::from_fn(kr, k, |i, j| d.s[i] * d.v[(j, i)]);
    let ge: f64 = d.s.iter().map(|x| x * x).sum();
    let response_rel_error = (d.s[kr..].iter().map(|x| x * x).sum::<f64>() / ge.max(f64::MIN_POSITIVE)).sqrt();
    tick(progress);
    let metrics = InterfaceMetrics {
        lightfield_samples: m,
        lightfield_energy_captured,
        lightfield_rel_error,
        lightfield_rel_error_before_enrichment: lf_before,
        propagation_rel_error,
        propagation_rel_error_before_enrichment: prop_before,
        response_rel_error,
        propagation_nnz: [props[0].nnz(), props[1].nnz(), props[2].nnz()],
    };
    Ok(InterfaceBake {
        params: p.clone(),
        interfaces,
        sigma_rlf: sig,
        sigma_lf,
        r_turn,
        u_r,
        t_rlf2r,
        sigma_g: d.s,
        metrics,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::point_polygon_form_factor;
    use crate::shape::{CUBE2D, face_point};

    const SMALL: LfGrid = LfGrid { spatial: 4, dir: 8, sub: 2 };

    #[test]
    fn uniform_walls_send_uniform_radiance_through_an_opening() {
        // dead end: every ray from the +Z opening back into the cube lands on a wall, so a
        // uniform wall irradiance 1 leaves with radiance ρ/π at every sample
        let tex = Texels::new(CUBE2D[1], 4);
        let a = wall_lightfield(&tex, 5, SMALL, 0.7);
        let h = a.apply(&vec![1.0; tex.len()], 1);
        for v in h {
            assert!((v - 0.7 / core::f64::consts::PI).abs() < 1e-12, "{v}");
        }
        // straight: rays from +Z that leave through −Z carry nothing, so some samples are dark
        let tex = Texels::new(CUBE2D[2], 4);
        let h = wall_lightfield(&tex, 5, SMALL, 1.0).apply(&vec![1.0; tex.len()], 1);
        assert!(h.iter().all(|&v| (-1e-12..=1.0 / core::f64::consts::PI + 1e-12).contains(&v)));
        assert!(h.iter().any(|&v| v < 0.5 / core::f64::consts::PI));
    }

    #[test]
    fn direct_lightfield_application_equals_the_sparse_operator() {
        let tex = Texels::new(CUBE2D[4], 4);
        let k = 3;
        let l: Vec<f64> = (0..tex.len() * k).map(|i| ((i * 37) % 11) as f64 * 0.1).collect();
        for f in side_openings(&CUBE2D[4]) {
            let a = wall_lightfield(&tex, f, SMALL, 0.6).apply(&l, k);
            let b = wall_lightfield_apply(&tex, f, SMALL, 0.6, &l, k);
            assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12), "face {f}");
        }
    }

    #[test]
    fn response_to_a_uniform_lightfield_is_the_form_factor_of_the_opening() {
        // constant radiance 1 entering through the whole −Z face: E(x) = π·FF(x → face)
        let res = 3;
        let tex = response_texels(res);
        let x = vec![1.0; SMALL.len()];
        let e = response_gather(res, SMALL, &x, 1, 4096, 7);
        let poly = [face_point(4, 0.0, 0.0), face_point(4, 1.0, 0.0), face_point(4, 1.0, 1.0), face_point(4, 0.0, 1.0)];
        for t in 0..tex.len() {
            let want = core::f64::consts::PI * point_polygon_form_factor(tex.position(t), tex.normal(t), &poly);
            assert!((e[t] - want).abs() < 0.01, "texel {t}: {} vs {want}", e[t]);
        }
    }

    #[test]
    fn propagation_of_uniform_radiance_is_the_visible_fraction() {
        for turn in Turn::ALL {
            let p = propagation(SMALL, turn);
            let out = p.apply(&vec![1.0; SMALL.len()], 1);
            assert!(out.iter().all(|&v| (-1e-12..=1.0 + 1e-12).contains(&v)), "{turn:?}");
            // a straight sample aimed along +Z from the middle of the face sees the entry
            if turn == Turn::Straight {
                let k = ((SMALL.spatial + 1) * SMALL.spatial / 2) * SMALL.dir * SMALL.dir
                    + (SMALL.dir / 2) * SMALL.dir
                    + SMALL.dir / 2;
                assert!((out[k] - 1.0).abs() < 1e-12, "{}", out[k]);
            }
        }
        // left and right are mirror images: the same total
        let tot = |t| propagation(SMALL, t).apply(&vec![1.0; SMALL.len()], 1).iter().sum::<f64>();
        assert!((tot(Turn::Left) - tot(Turn::Right)).abs() < 1e-9 * tot(Turn::Left));
    }

    #[test]
    fn response_rows_land_on_the_rotated_texel() {
        let canon = response_texels(4);
        for s in CUBE2D {
            let tex = Texels::new(s, 4);
            for f in side_openings(&s) {
                let idx = u_r_index(&tex, f);
                let q = quarter_turns_to_canonical(f);
                for (t, &c) in idx.iter().enumerate() {
                    let p = rotate_to_canonical(tex.position(t), q);
                    let pc = canon.position(c as usize);
                    assert!((0..3).all(|k| (p[k] - pc[k]).abs() < 1e-12), "{} face {f} texel {t}", s.name);
                }
            }
        }
    }
}
