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
use crate::svd::{frobenius, mul, mul_tn, sym_eigen, thin_svd};
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
    /// The vector and volume response (`U_r⃗`, `U_rvol`); `None` skips them.
    pub vectors: Option<VectorResponseParams>,
}

impl Default for InterfaceParams {
    fn default() -> Self {
        Self { k_rlf: 128, k_r: 32, grid: LfGrid::THESIS, enrich: 3, response_rays: 1024, vectors: None }
    }
}

/// Sampling of the interface vector and volume response (MRT thesis §3.5.4–3.5.5 driven by
/// `r`; the dictionary's `vector_rays`, `volume_res`, `probe_rays`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VectorResponseParams {
    /// Uniform-hemisphere rays per canonical response texel (quadratic SH → OHLSH).
    pub vector_rays: usize,
    /// Probes per axis of the canonical block's probe grid (the shapes' `U_bvol` grid).
    pub volume_res: usize,
    /// Uniform-sphere rays per probe.
    pub probe_rays: usize,
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
    /// `‖G⃗ − U_r⃗ T_rlf→r‖ / ‖G⃗‖`: the part of the OHLSH response `G⃗ = F⃗_rlf H_rlf` that
    /// the `k_r` response coefficients `r` cannot drive (`U_r⃗ = G⃗ Ṽ_g Σ̃_g⁻¹`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vector_response_rel_error: Option<f64>,
    /// The same for the probe response `U_rvol`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume_response_rel_error: Option<f64>,
    /// Irradiance at the unperturbed normal from `G⃗` against `G` (OHLSH's band truncation and
    /// the two gathers' noise; self-consistency, not error against truth).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vector_response_consistency: Option<f64>,
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
    /// The vector and volume response, when [`InterfaceParams::vectors`] asks for it.
    pub vectors: Option<VectorResponse>,
    /// Measurements.
    pub metrics: InterfaceMetrics,
}

/// The interface's vector and volume response (MRT thesis §3.5.4–3.5.5 and §3.6.3 step 8,
/// "from the b's and r's"): for light entering the canonical block through −Z with response
/// coefficients `r`, per response texel the OHLSH coefficients `U_r⃗ r` of the incident
/// radiance in the texel frame (x = face u, y = face v, z = inward normal), and per probe of
/// the canonical block's grid the order-3 SH `U_rvol r` in the canonical block's frame. Both
/// are `G_x Ṽ_g Σ̃_g⁻¹` with `G_x` the gather of the lightfield basis `H_rlf` (the least-squares
/// map from `r = T_rlf→r c` to `G_x c`).
#[derive(Debug, Clone)]
pub struct VectorResponse {
    /// `U_r⃗`: `5R² × k_r × 4`, texel-major (rows as `U_r`).
    pub u_rvec: Vec<f64>,
    /// `U_rvol`: `g³ × k_r × 9`, probe-major; probes at the cell centres of a `g³` grid,
    /// x fastest, then y, then z (the shapes' `probes`).
    pub u_rvol: Vec<f64>,
    /// `g`.
    pub volume_res: usize,
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
    let lf = WallLightfield::new(tex, face, grid, albedo);
    let mut out = vec![0.0; grid.len() * k];
    out.par_chunks_mut(k * 64).enumerate().for_each(|(c, block)| lf.rows(c * 64, l, k, block));
    out
}

/// One opening's lightfield resampling, evaluated row by row (MRT thesis §4.2.1): the
/// interface bake evaluates it twice instead of holding the 82944 × 384 `H_lf` through the
/// enrichment.
struct WallLightfield<'a> {
    tex: &'a Texels,
    frame: IfaceFrame,
    grid: LfGrid,
    w: f64,
    dirs: Vec<[f64; 3]>,
}

impl<'a> WallLightfield<'a> {
    fn new(tex: &'a Texels, face: usize, grid: LfGrid, albedo: f64) -> Self {
        let frame = IfaceFrame::outgoing(face);
        let w = albedo / core::f64::consts::PI / (grid.sub * grid.sub) as f64;
        let dirs = grid.sub_directions().iter().map(|&d| frame.world(d)).collect();
        Self { tex, frame, grid, w, dirs }
    }

    /// Rows `r0..r0 + out.len()/k` into `out` (row-major, overwritten).
    fn rows(&self, r0: usize, l: &[f64], k: usize, out: &mut [f64]) {
        let (grid, q2) = (self.grid, self.grid.sub * self.grid.sub);
        let d2 = grid.dir * grid.dir;
        out.fill(0.0);
        // a cell's supersamples land close together: sum their tap weights per texel first
        // (a handful of distinct texels instead of 4·Q² taps), then one k-wide read each
        let mut wt = vec![0.0f64; self.tex.len()];
        let mut touched: Vec<usize> = Vec::with_capacity(4 * q2);
        for (q, dst) in out.chunks_mut(k).enumerate() {
            let row = r0 + q;
            let (sp, dk) = (row / d2, row % d2);
            let (ir, iy) = (sp % grid.spatial, sp / grid.spatial);
            let (r, y) = grid.spatial_pos(ir, iy);
            let p = self.frame.point(r, y);
            for om in &self.dirs[dk * q2..(dk + 1) * q2] {
                let Some((g, u, v)) = cast(self.tex, p, [-om[0], -om[1], -om[2]]) else { continue };
                for (t, bw) in self.tex.bilinear(g, u, v) {
                    if bw > 0.0 {
                        if wt[t] == 0.0 {
                            touched.push(t);
                        }
                        wt[t] += bw;
                    }
                }
            }
            for &t in &touched {
                let a = self.w * wt[t];
                wt[t] = 0.0;
                for (o, s) in dst.iter_mut().zip(&l[t * k..(t + 1) * k]) {
                    *o += a * s;
                }
            }
            touched.clear();
        }
    }
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

/// Row access to a row-major lightfield matrix for [`response_gather`]: `dst += w · row(s)`,
/// then `finish` (a per-column scale, for a basis stored without its `Σ̃`).
trait LfRows: Sync {
    fn add(&self, s: usize, w: f64, dst: &mut [f64]);
    fn finish(&self, _dst: &mut [f64]) {}
}

struct RowsF64<'a> {
    x: &'a [f64],
    k: usize,
}

impl LfRows for RowsF64<'_> {
    #[inline]
    fn add(&self, s: usize, w: f64, dst: &mut [f64]) {
        for (o, v) in dst.iter_mut().zip(&self.x[s * self.k..(s + 1) * self.k]) {
            *o += w * v;
        }
    }
}

/// `H_rlf = Ũ Σ̃` with `Ũ` stored in f32: `F (Ũ Σ̃) = (F Ũ) Σ̃`.
struct RowsBasis<'a> {
    u: &'a Tall32,
    sig: &'a [f64],
}

impl LfRows for RowsBasis<'_> {
    #[inline]
    fn add(&self, s: usize, w: f64, dst: &mut [f64]) {
        for (o, v) in dst.iter_mut().zip(self.u.row(s)) {
            *o += w * f64::from(*v);
        }
    }
    fn finish(&self, dst: &mut [f64]) {
        for (o, s) in dst.iter_mut().zip(self.sig) {
            *o *= s;
        }
    }
}

/// `G = F_rlf X`: irradiance at the canonical response texels from lightfields (columns of
/// `x`, row-major `m × k`) entering through −Z, by `rays` cosine gathers per texel with
/// interpolated lightfield reads: `E = (π/N) Σ L`. Returns row-major `5R² × k`.
pub fn response_gather(res: usize, grid: LfGrid, x: &[f64], k: usize, rays: usize, seed: u64) -> Vec<f64> {
    gather_rows(res, grid, &RowsF64 { x, k }, k, rays, seed)
}

fn gather_rows(res: usize, grid: LfGrid, x: &dyn LfRows, k: usize, rays: usize, seed: u64) -> Vec<f64> {
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
                x.add(s, w, dst);
            }
        }
        x.finish(dst);
        dst.iter_mut().for_each(|o| *o *= scale);
    });
    out
}

/// A point's map from a set direction to `(local, world)` directions.
type DirMap = Box<dyn Fn([f64; 3]) -> ([f64; 3], [f64; 3])>;

/// Order-3 SH (9 per column, `9 × k` per point, SH-major) of the radiance arriving at
/// `points` through the canonical entry (−Z) from lightfields (the rows of `x`), by the
/// directions `dirs` (pdf `1/solid`) turned per point by `frame(point, dir) → (local, world)`:
/// `c_j = (solid/N) Σ L(ω) y_j(local ω)`. Lightfield reads interpolate as in [`gather_rows`].
fn gather_sh(
    n_points: usize,
    grid: LfGrid,
    x: &dyn LfRows,
    k: usize,
    dirs: &DirectionSet,
    solid: f64,
    point: &(dyn Fn(usize) -> ([f64; 3], DirMap) + Sync),
) -> Vec<f64> {
    let fa = IfaceFrame::incoming(CANONICAL_ENTRY);
    let scale = solid / dirs.len() as f64;
    let mut out = vec![0.0; n_points * 9 * k];
    out.par_chunks_mut(9 * k).enumerate().for_each(|(t, acc)| {
        let (p, frame) = point(t);
        let mut val = vec![0.0; k];
        for l in &dirs.dirs {
            let (local, d) = frame(*l);
            let (g, tt) = exit_face(p, d);
            if g != CANONICAL_ENTRY {
                continue;
            }
            let q = [p[0] + tt * d[0], p[1] + tt * d[1], p[2] + tt * d[2]];
            let (ra, ya) = fa.coords(q);
            let om = fa.local([-d[0], -d[1], -d[2]]);
            let (sa, sb) = dir_to_square(om[0], om[1]);
            val.fill(0.0);
            for (s, w) in grid.taps(ra, ya, sa, sb) {
                if w != 0.0 {
                    x.add(s, w, &mut val);
                }
            }
            x.finish(&mut val);
            let y = crate::gather::sh9(local);
            for (j, yj) in y.iter().enumerate() {
                for (a, v) in acc[j * k..(j + 1) * k].iter_mut().zip(&val) {
                    *a += yj * v;
                }
            }
        }
        acc.iter_mut().for_each(|a| *a *= scale);
    });
    out
}

/// The vector and volume response of the canonical interface ([`VectorResponse`]) from the
/// basis `x` (`k` columns) and `G`'s SVD (`k_r` kept), with its two projection errors and the
/// consistency of `G⃗` against `G` (`g_scalar`, `5R² × k` row-major).
#[allow(clippy::too_many_arguments)]
fn vector_response(
    res: usize,
    grid: LfGrid,
    x: &dyn LfRows,
    k: usize,
    svd: &crate::svd::ThinSvd,
    kr: usize,
    g_scalar: &[f64],
    vp: &VectorResponseParams,
    seed: u64,
) -> (VectorResponse, [f64; 3]) {
    let tex = response_texels(res);
    let hemi = DirectionSet::uniform_hemisphere(vp.vector_rays);
    let sh = gather_sh(tex.len(), grid, x, k, &hemi, 2.0 * core::f64::consts::PI, &|t| {
        let (f, _, _) = tex.coords(t);
        let rot = texel_rotation(seed ^ 0x5652_4543, 0x4946, t);
        (tex.position(t), Box::new(move |l| to_world(f, l, rot)))
    });
    // quadratic SH → OHLSH (App. B), per texel 4 × k
    let a = penumbra_math::ohlsh::quadratic_to_ohlsh();
    let n = tex.len();
    let mut gv = vec![0.0; n * 4 * k];
    for t in 0..n {
        for c in 0..4 {
            let dst = &mut gv[(t * 4 + c) * k..(t * 4 + c + 1) * k];
            for j in 0..9 {
                let w = a[c * 9 + j];
                if w == 0.0 {
                    continue;
                }
                for (d, v) in dst.iter_mut().zip(&sh[(t * 9 + j) * k..(t * 9 + j + 1) * k]) {
                    *d += w * v;
                }
            }
        }
    }
    let g = vp.volume_res;
    let probes: Vec<[f64; 3]> = (0..g * g * g)
        .map(|i| {
            let c = |j: usize| (j as f64 + 0.5) / g as f64;
            [c(i % g), c((i / g) % g), c(i / (g * g))]
        })
        .collect();
    let sphere = DirectionSet::uniform_sphere(vp.probe_rays);
    let gvol = gather_sh(probes.len(), grid, x, k, &sphere, 4.0 * core::f64::consts::PI, &|i| {
        let (c, s) = texel_rotation(seed ^ 0x5652_564F, 0x4946, i);
        // rotated about +Y (world up) per probe, as the shapes' probes
        (
            probes[i],
            Box::new(move |l: [f64; 3]| {
                let d = [l[0] * c + l[2] * s, l[1], -l[0] * s + l[2] * c];
                (d, d)
            }),
        )
    });
    // U_x = G_x Ṽ Σ̃⁻¹ (rows of G_x: k values each) and ‖G_x (I − ṼṼᵀ)‖/‖G_x‖
    let project = |gx: &[f64], width: usize| -> (Vec<f64>, f64) {
        let rows = gx.len() / k;
        let mut u = vec![0.0; rows * kr];
        let (mut out2, mut all2) = (0.0, 0.0);
        for r in 0..rows {
            let row = &gx[r * k..(r + 1) * k];
            let mut proj = vec![0.0; k];
            for i in 0..kr {
                let c: f64 = (0..k).map(|j| row[j] * svd.v[(j, i)]).sum();
                u[r * kr + i] = c / svd.s[i];
                for (j, p) in proj.iter_mut().enumerate() {
                    *p += c * svd.v[(j, i)];
                }
            }
            out2 += row.iter().zip(&proj).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            all2 += row.iter().map(|a| a * a).sum::<f64>();
        }
        // rows are (point, coefficient); store point-major, mode, coefficient
        let pts = rows / width;
        let mut stored = vec![0.0; rows * kr];
        for pnt in 0..pts {
            for c in 0..width {
                for i in 0..kr {
                    stored[(pnt * kr + i) * width + c] = u[(pnt * width + c) * kr + i];
                }
            }
        }
        (stored, if all2 > 0.0 { (out2 / all2).sqrt() } else { 0.0 })
    };
    let (u_rvec, e_vec) = project(&gv, 4);
    let (u_rvol, e_vol) = project(&gvol, 9);
    // consistency: irradiance at the normal, π a₀ y₀₀ + (2π/3) a₁₀ y₁₀(+z), against G
    let (c0, c1) = (0.282_094_791_773_878_14, 0.488_602_511_902_919_9);
    let pi = core::f64::consts::PI;
    let (mut d2, mut g2) = (0.0, 0.0);
    for t in 0..n {
        for j in 0..k {
            let e = pi * c0 * gv[(t * 4) * k + j] + 2.0 * pi / 3.0 * c1 * gv[(t * 4 + 2) * k + j];
            let want = g_scalar[t * k + j];
            d2 += (e - want) * (e - want);
            g2 += want * want;
        }
    }
    let consistency = if g2 > 0.0 { (d2 / g2).sqrt() } else { 0.0 };
    (VectorResponse { u_rvec, u_rvol, volume_res: g }, [e_vec, e_vol, consistency])
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

/// Rows per chunk of the streamed products over the lightfield samples: fixed (not tied to
/// the thread count), so every sum is the same bits for any `--threads`.
const ROWS: usize = 1024;

/// Chunks computed side by side before their partial results are combined in chunk order:
/// bounds what is held at once (a chunk's `Xᵀ X` is 2 MB at `4·k_rlf` = 512 columns).
const BATCH: usize = 4;

/// Column block of the symmetric Gram products (only blocks on and above the diagonal are
/// multiplied).
const GRAM_BLOCK: usize = 128;

/// A tall matrix stored row-major in f32 (the lightfields `H_lf` and the bases `Ũ`: 82944
/// rows at the thesis's resolution, MRT thesis §3.6.1). Storage only: every product reads it
/// into f64 chunks and computes in f64 (DESIGN §4).
#[derive(Debug, Clone)]
struct Tall32 {
    cols: usize,
    data: Vec<f32>,
}

impl Tall32 {
    fn zeros(rows: usize, cols: usize) -> Self {
        Self { cols, data: vec![0.0; rows * cols] }
    }

    #[inline]
    fn row(&self, i: usize) -> &[f32] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// Rows `r0..r0+len` in f64, row-major (view it with [`rm`]).
    fn chunk(&self, r0: usize, len: usize) -> Vec<f64> {
        self.data[r0 * self.cols..(r0 + len) * self.cols].iter().map(|&v| f64::from(v)).collect()
    }

    /// Stores the f64 rows `r0..r0+c.nrows()` (rounded to f32).
    fn put(&mut self, r0: usize, c: MatRef<'_, f64>) {
        for i in 0..c.nrows() {
            let row = &mut self.data[(r0 + i) * self.cols..(r0 + i + 1) * self.cols];
            for (j, d) in row.iter_mut().enumerate() {
                *d = c[(i, j)] as f32;
            }
        }
    }

    /// Negates the columns whose flag is set (exact in any precision).
    fn flip(&mut self, neg: &[bool]) {
        if !neg.iter().any(|&n| n) {
            return;
        }
        for row in self.data.chunks_exact_mut(self.cols) {
            for (d, &n) in row.iter_mut().zip(neg) {
                if n {
                    *d = -*d;
                }
            }
        }
    }
}

/// A row-major `rows × cols` slice as a matrix view.
fn rm(v: &[f64], cols: usize) -> MatRef<'_, f64> {
    MatRef::from_row_major_slice(v, v.len() / cols.max(1), cols)
}

/// Runs `map` over the row chunks of an `rows`-row matrix (parallel within batches of
/// [`BATCH`]) and hands each result to `fold` in chunk order: the streamed form of a product
/// over the rows, with the same result for any thread count.
fn stream<T: Send>(rows: usize, map: impl Fn(usize, usize) -> T + Sync, mut fold: impl FnMut(usize, T)) {
    let n = rows.div_ceil(ROWS);
    let mut c0 = 0;
    while c0 < n {
        let c1 = (c0 + BATCH).min(n);
        let parts: Vec<T> = (c0..c1)
            .into_par_iter()
            .map(|c| {
                let r0 = c * ROWS;
                map(r0, ROWS.min(rows - r0))
            })
            .collect();
        for (c, p) in (c0..c1).zip(parts) {
            fold(c * ROWS, p);
        }
        c0 = c1;
    }
}

/// `XᵀX` of a row chunk, only its blocks on and above the diagonal ([`GRAM_BLOCK`]); the
/// caller mirrors the sum ([`mirror_upper`]).
fn gram_upper(x: MatRef<'_, f64>) -> Mat<f64> {
    let n = x.ncols();
    let mut g = Mat::<f64>::zeros(n, n);
    for b0 in (0..n).step_by(GRAM_BLOCK) {
        let bl = GRAM_BLOCK.min(n - b0);
        for c0 in (b0..n).step_by(GRAM_BLOCK) {
            let cl = GRAM_BLOCK.min(n - c0);
            let blk = mul_tn(x.subcols(b0, bl), x.subcols(c0, cl));
            g.as_mut().submatrix_mut(b0, c0, bl, cl).copy_from(blk.as_ref());
        }
    }
    g
}

/// Copies the blocks above the diagonal of a [`gram_upper`] sum to below it.
fn mirror_upper(g: &mut Mat<f64>) {
    let n = g.nrows();
    for j in 0..n {
        for i in (j / GRAM_BLOCK + 1) * GRAM_BLOCK..n {
            g[(i, j)] = g[(j, i)];
        }
    }
}

/// Running canonical sign of each column (largest-magnitude entry positive, the first on
/// ties, as [`crate::svd::canonical_columns`]) over chunks seen in row order.
struct SignTracker {
    mag: Vec<f64>,
    neg: Vec<bool>,
}

impl SignTracker {
    fn new(k: usize) -> Self {
        Self { mag: vec![-1.0; k], neg: vec![false; k] }
    }

    fn see(&mut self, c: MatRef<'_, f64>) {
        for j in 0..c.ncols() {
            for i in 0..c.nrows() {
                let a = c[(i, j)].abs();
                if a > self.mag[j] {
                    self.mag[j] = a;
                    self.neg[j] = c[(i, j)] < 0.0;
                }
            }
        }
    }
}

/// The eigen-decomposition of a weighted Gram matrix `W G W` (`W = diag(w)`): all singular
/// values `σ` of `X W` and the map `B = W V_k Σ_k⁻¹` (n × k) with `X W V_k Σ_k⁻¹ = Ũ_k`,
/// `k ≤ k_max` capped at the numerical rank.
fn weighted_basis_map(g: &Mat<f64>, w: &[f64], k_max: usize) -> Result<(Mat<f64>, Vec<f64>), TransportError> {
    let n = g.nrows();
    let gw = Mat::from_fn(n, n, |i, j| g[(i, j)] * w[i] * w[j]);
    let (vals, vecs) = sym_eigen(gw.as_ref())?;
    let sigma: Vec<f64> = vals.iter().map(|&l| l.max(0.0).sqrt()).collect();
    let k = k_max.min(crate::svd::numerical_rank(&sigma, 1e-7));
    Ok((Mat::from_fn(n, k, |r, c| vecs[(r, c)] * w[r] / sigma[c]), sigma))
}

/// Row `i` of `P X` for a row-major f32 `X` (`P` sparse), accumulated in f64.
#[inline]
fn sparse_row(p: &Csr, x: &Tall32, i: usize, out: &mut [f64]) {
    out.fill(0.0);
    for e in p.ptr[i]..p.ptr[i + 1] {
        let v = p.val[e];
        for (o, s) in out.iter_mut().zip(x.row(p.idx[e] as usize)) {
            *o += v * f64::from(*s);
        }
    }
}

/// Rows `r0..r0+len` of `[Ũ Σ̃, P_↑ Ũ Σ̃, P_← Ũ Σ̃, P_→ Ũ Σ̃]` (len × 4k, row-major): App. A's
/// enrichment matrix, the basis and its three propagations (`P Ũ Σ̃ = (P Ũ) Σ̃`).
fn enrichment_chunk(u: &Tall32, sig: &[f64], props: &[Csr], r0: usize, len: usize) -> Vec<f64> {
    let k = u.cols;
    let mut x = vec![0.0; len * 4 * k];
    for (i, xr) in x.chunks_exact_mut(4 * k).enumerate() {
        let (own, turns) = xr.split_at_mut(k);
        for ((d, v), s) in own.iter_mut().zip(u.row(r0 + i)).zip(sig) {
            *d = f64::from(*v) * s;
        }
        for (p, out) in props.iter().zip(turns.chunks_exact_mut(k)) {
            sparse_row(p, u, r0 + i, out);
            for (d, s) in out.iter_mut().zip(sig) {
                *d *= s;
            }
        }
    }
    x
}

/// `‖(I − UUᵀ)X‖/‖X‖` from `UᵀX` and `‖X‖`, for orthonormal `U`.
fn outside_from(utx: MatRef<'_, f64>, norm_x: f64) -> f64 {
    if norm_x == 0.0 {
        return 0.0;
    }
    (1.0 - (frobenius(utx) / norm_x).powi(2)).max(0.0).sqrt()
}

/// Squared Frobenius norm of columns `c0..c0+n` of `x`.
fn norm2_cols(x: MatRef<'_, f64>, c0: usize, n: usize) -> f64 {
    let s = frobenius(x.subcols(c0, n));
    s * s
}

/// Bakes the interface operators of the shapes (the dictionary's, in order), for a
/// dictionary baked with albedo `albedo` and `face_res` texels per edge.
///
/// Memory (MRT thesis §3.6.1 resolution, 82944 lightfield samples): the raw lightfields
/// `H_lf` (82944 × 384) and the bases `Ũ` (82944 × 128) are stored in f32, and every product
/// streams them in row chunks of [`ROWS`] and computes in f64. `H_lf` is held only for its
/// Gram matrix and the first basis, then dropped; the final `ŨᵀH_lf` evaluates the
/// lightfields again chunk by chunk (rounded to f32 as stored, so the same values). The
/// enrichment matrix `[H_rlf, L_temp]` (82944 × 512) is never materialised: its Gram matrix
/// is accumulated chunk by chunk and its chunks recomputed (a sparse product) for
/// `Ũ = X W V Σ⁻¹`. Peak ≈ 170 MB above the shape bakes instead of ≈ 1 GB
/// (docs/benchmarks.md).
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
    // 1. raw lightfields H_lf (§4.2.1), one block of k_b columns per interface, side by side
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
    let lfs: Vec<(WallLightfield<'_>, Vec<f64>)> = list
        .iter()
        .map(|&(s, f)| {
            (WallLightfield::new(shapes[s].texels, f, grid, albedo), to_row_major(shapes[s].reduced.l_imp.as_ref()))
        })
        .collect();
    // rows r0..r0+len of H_lf (len × total, row-major), each value rounded to f32 as stored
    let h_rows = |r0: usize, len: usize| -> Vec<f64> {
        let mut h = vec![0.0; len * total];
        let mut part = Vec::new();
        for (i, (lf, l)) in lfs.iter().enumerate() {
            part.resize(len * widths[i], 0.0);
            lf.rows(r0, l, widths[i], &mut part);
            for (dst, src) in h.chunks_exact_mut(total).zip(part.chunks_exact(widths[i])) {
                for (d, v) in dst[offs[i]..offs[i] + widths[i]].iter_mut().zip(src) {
                    *d = f64::from(*v as f32);
                }
            }
        }
        h
    };
    let mut h_all = Tall32::zeros(m, total);
    for (i, (lf, l)) in lfs.iter().enumerate() {
        let mut h = vec![0.0; m * widths[i]];
        h.par_chunks_mut(widths[i] * 64).enumerate().for_each(|(c, block)| lf.rows(c * 64, l, widths[i], block));
        for (dst, src) in h_all.data.chunks_exact_mut(total).zip(h.chunks_exact(widths[i])) {
            for (d, v) in dst[offs[i]..offs[i] + widths[i]].iter_mut().zip(src) {
                *d = *v as f32;
            }
        }
        tick(progress);
    }
    // 2. eq. 4.1: per-element scale of its columns
    let sums: Vec<f64> = sigma_m.iter().map(|s| s.iter().map(|x| x * x).sum()).collect();
    let sum_total: f64 = sums.iter().sum();
    let scale: Vec<f64> =
        sums.iter().map(|&e| if e > 0.0 { (sum_total / (e * sums.len() as f64)).sqrt() } else { 0.0 }).collect();
    let col_w: Vec<f64> = list.iter().zip(&widths).flat_map(|(&(s, _), &w)| std::iter::repeat_n(scale[s], w)).collect();
    // 3. basis of the normalised H_lf (§3.4.1): Gram streamed over the rows
    let mut gh = Mat::<f64>::zeros(total, total);
    stream(m, |r0, len| gram_upper(rm(&h_all.chunk(r0, len), total)), |_, g| gh += g);
    mirror_upper(&mut gh);
    let (b0, sigma_lf) = weighted_basis_map(&gh, &col_w, p.k_rlf)?;
    let k0 = b0.ncols();
    let mut signs = SignTracker::new(k0);
    // Ũ₀ = H W V Σ⁻¹, and Ũ₀ᵀH for the share of H_lf it captures (signs applied after). Row
    // r of Ũ₀ needs row r of H only, so Ũ₀ (k0 ≤ total columns) overwrites H in place: a
    // batch's rows land in rows of H that this batch or an earlier one has read.
    let mut uth0 = Mat::<f64>::zeros(k0, total);
    let n_chunks = m.div_ceil(ROWS);
    let mut c0 = 0;
    while c0 < n_chunks {
        let c1 = (c0 + BATCH).min(n_chunks);
        let parts: Vec<(Mat<f64>, Mat<f64>)> = (c0..c1)
            .into_par_iter()
            .map(|c| {
                let r0 = c * ROWS;
                let hc = h_all.chunk(r0, ROWS.min(m - r0));
                let uc = mul(rm(&hc, total), b0.as_ref());
                let p = mul_tn(uc.as_ref(), rm(&hc, total));
                (uc, p)
            })
            .collect();
        for (c, (uc, p)) in (c0..c1).zip(parts) {
            signs.see(uc.as_ref());
            let r0 = c * ROWS;
            for i in 0..uc.nrows() {
                for j in 0..k0 {
                    h_all.data[(r0 + i) * k0 + j] = uc[(i, j)] as f32;
                }
            }
            uth0 += p;
        }
        c0 = c1;
    }
    // H_lf is evaluated again for the final coordinates (one more lightfield pass) rather
    // than held through the enrichment
    let mut u = h_all;
    u.cols = k0;
    u.data.truncate(m * k0);
    u.data.shrink_to_fit();
    u.flip(&signs.neg);
    for (i, &n) in signs.neg.iter().enumerate() {
        if n {
            uth0.row_mut(i).iter_mut().for_each(|x| *x = -*x);
        }
    }
    tick(progress);
    let h_norm2: f64 = (0..total).map(|j| gh[(j, j)] * col_w[j] * col_w[j]).sum();
    drop(gh);
    // share of the normalised H_lf outside the basis, from UᵀH
    let captured = |uth: MatRef<'_, f64>| -> f64 {
        let inside: f64 = (0..total).map(|j| uth.col(j).iter().map(|x| x * x).sum::<f64>() * col_w[j] * col_w[j]).sum();
        (1.0 - inside / h_norm2).max(0.0).sqrt()
    };
    let lf_before = captured(uth0.as_ref());
    let energy: f64 = sigma_lf.iter().map(|x| x * x).sum();
    let lightfield_energy_captured = sigma_lf[..k0].iter().map(|x| x * x).sum::<f64>() / energy.max(f64::MIN_POSITIVE);
    let mut sig: Vec<f64> = sigma_lf[..k0].to_vec();
    let props: Vec<Csr> = Turn::ALL.par_iter().map(|&t| propagation(grid, t)).collect();
    tick(progress);
    let mut prop_before = [0.0; 3];
    // 3b. enrichment (App. A): X = [H_rlf, L_temp], each part at unit Frobenius norm. X's
    // Gram matrix and norms are accumulated over row chunks; its chunks are recomputed for
    // the new basis Ũ = X W V Σ⁻¹ (cheap: a sparse product per chunk).
    for it in 0..p.enrich {
        let k = u.cols;
        let first = it == 0;
        let mut gx = Mat::<f64>::zeros(4 * k, 4 * k);
        let mut utx = Mat::<f64>::zeros(k, 4 * k);
        let mut n2 = [0.0f64; 4];
        stream(
            m,
            |r0, len| {
                let xv = enrichment_chunk(&u, &sig, &props, r0, len);
                let x = rm(&xv, 4 * k);
                let g = gram_upper(x);
                let ut = first.then(|| mul_tn(rm(&u.chunk(r0, len), k), x));
                let n: [f64; 4] = core::array::from_fn(|b| norm2_cols(x, b * k, k));
                (g, ut, n)
            },
            |_, (g, ut, n)| {
                gx += g;
                if let Some(ut) = ut {
                    utx += ut;
                }
                for (a, b) in n2.iter_mut().zip(n) {
                    *a += b;
                }
            },
        );
        mirror_upper(&mut gx);
        if first {
            for (i, e) in prop_before.iter_mut().enumerate() {
                *e = outside_from(utx.as_ref().subcols((i + 1) * k, k), n2[i + 1].sqrt());
            }
        }
        tick(progress);
        let na = n2[0].sqrt().max(f64::MIN_POSITIVE);
        let nb = (n2[1] + n2[2] + n2[3]).sqrt().max(f64::MIN_POSITIVE);
        let w: Vec<f64> = (0..4 * k).map(|j| if j < k { 1.0 / na } else { 1.0 / nb }).collect();
        let (bx, ns) = weighted_basis_map(&gx, &w, p.k_rlf)?;
        drop(gx);
        let kn = bx.ncols();
        let mut nu = Tall32::zeros(m, kn);
        let mut signs = SignTracker::new(kn);
        stream(
            m,
            |r0, len| mul(rm(&enrichment_chunk(&u, &sig, &props, r0, len), 4 * k), bx.as_ref()),
            |r0, c| {
                signs.see(c.as_ref());
                nu.put(r0, c.as_ref());
            },
        );
        nu.flip(&signs.neg);
        // keep the basis on the lightfields' physical scale
        sig = ns[..kn].iter().map(|x| x * na).collect();
        u = nu;
        tick(progress);
    }
    let k = u.cols;
    // 4. operators in the coordinates c = Σ̃⁻¹Ũᵀh: ŨᵀH_lf (H_lf evaluated again, rounded as
    // stored), and ŨᵀP_turn H_rlf with the propagated basis's norms, in one streamed pass
    let mut uth = Mat::<f64>::zeros(k, total);
    let mut utl: [Mat<f64>; 3] = core::array::from_fn(|_| Mat::<f64>::zeros(k, k));
    let mut l2 = [0.0f64; 3];
    stream(
        m,
        |r0, len| {
            let ucv = u.chunk(r0, len);
            let uc = rm(&ucv, k);
            let uh = mul_tn(uc, rm(&h_rows(r0, len), total));
            let xv = enrichment_chunk(&u, &sig, &props, r0, len);
            let x = rm(&xv, 4 * k);
            let ul: [Mat<f64>; 3] = core::array::from_fn(|t| mul_tn(uc, x.subcols((t + 1) * k, k)));
            let n: [f64; 3] = core::array::from_fn(|t| norm2_cols(x, (t + 1) * k, k));
            (uh, ul, n)
        },
        |_, (uh, ul, n)| {
            uth += uh;
            for t in 0..3 {
                utl[t] += &ul[t];
                l2[t] += n[t];
            }
        },
    );
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
    let propagation_rel_error: [f64; 3] = core::array::from_fn(|t| outside_from(utl[t].as_ref(), l2[t].sqrt()));
    if p.enrich == 0 {
        prop_before = propagation_rel_error;
    }
    let r_turn: [Mat<f64>; 3] = core::array::from_fn(|t| coords(utl[t].as_ref()));
    tick(progress);
    // response (§4.2.3): G = F_rlf H_rlf, U_r, T_rlf→r
    let gv = gather_rows(face_res, grid, &RowsBasis { u: &u, sig: &sig }, k, p.response_rays, seed);
    let g = Mat::from_fn(5 * face_res * face_res, k, |i, j| gv[i * k + j]);
    let d = thin_svd(g.as_ref())?;
    let kr = p.k_r.min(crate::svd::numerical_rank(&d.s, 1e-12)).max(1).min(d.s.len());
    let u_r = Mat::from_fn(g.nrows(), kr, |i, j| d.u[(i, j)]);
    let t_rlf2r = Mat::from_fn(kr, k, |i, j| d.s[i] * d.v[(j, i)]);
    let ge: f64 = d.s.iter().map(|x| x * x).sum();
    let response_rel_error = (d.s[kr..].iter().map(|x| x * x).sum::<f64>() / ge.max(f64::MIN_POSITIVE)).sqrt();
    // the vector and volume response driven by r (§3.5.4–3.5.5, §3.6.3 step 8)
    let (vectors, vector_errors) = match &p.vectors {
        Some(vp) => {
            let basis = RowsBasis { u: &u, sig: &sig };
            let (v, e) = vector_response(face_res, grid, &basis, k, &d, kr, &gv, vp, seed);
            (Some(v), Some(e))
        }
        None => (None, None),
    };
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
        vector_response_rel_error: vector_errors.map(|e| e[0]),
        volume_response_rel_error: vector_errors.map(|e| e[1]),
        vector_response_consistency: vector_errors.map(|e| e[2]),
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
        vectors,
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
    fn sh_gathers_of_uniform_entering_radiance_match_solid_angle_and_form_factor() {
        // radiance 1 entering through the whole −Z face: the order-3 SH of what arrives at a
        // point has y₀₀ coefficient y₀₀·Ω (Ω the face's solid angle) and, along an axis a of
        // which the face lies wholly on one side, y₁ coefficient ±C1·∫ω_a dω = ±C1·π·FF
        let (c0, c1) = (0.282_094_791_773_878_14, 0.488_602_511_902_919_9);
        let pi = core::f64::consts::PI;
        let x = vec![1.0; SMALL.len()];
        let rows = RowsF64 { x: &x, k: 1 };
        let poly = [face_point(4, 0.0, 0.0), face_point(4, 1.0, 0.0), face_point(4, 1.0, 1.0), face_point(4, 0.0, 1.0)];
        // the block centre (a probe of the 1³ grid): Ω = 4π/6, ∫ω dω = −π·FF(centre, −z)·ẑ
        let sphere = DirectionSet::uniform_sphere(16384);
        let c =
            gather_sh(1, SMALL, &rows, 1, &sphere, 4.0 * pi, &|_| ([0.5; 3], Box::new(|l: [f64; 3]| (l, l)) as DirMap));
        let e = pi * point_polygon_form_factor([0.5; 3], [0.0, 0.0, -1.0], &poly);
        assert!((c[0] - c0 * 4.0 * pi / 6.0).abs() < 2e-3, "{c:?}");
        assert!((c[2] + c1 * e).abs() < 2e-3, "{c:?} vs {}", -c1 * e);
        assert!(c[1].abs() < 2e-3 && c[3].abs() < 2e-3, "{c:?}");
        // a texel of the opposite (+Z) wall in its texel frame (z = inward normal −ẑ): the
        // y₁₀ coefficient is C1·π·FF(texel → entry), the irradiance at its normal
        let tex = response_texels(3);
        let hemi = DirectionSet::uniform_hemisphere(16384);
        for t in tex.face_range(5) {
            let c = gather_sh(1, SMALL, &rows, 1, &hemi, 2.0 * pi, &|_| {
                let rot = texel_rotation(1, 2, t);
                (tex.position(t), Box::new(move |l| to_world(5, l, rot)) as DirMap)
            });
            let e = pi * point_polygon_form_factor(tex.position(t), tex.normal(t), &poly);
            assert!((c[2] - c1 * e).abs() < 0.01 * e, "texel {t}: {} vs {}", c[2], c1 * e);
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
