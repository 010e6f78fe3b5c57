//! Delta Radiance Transfer (MRT thesis ch. 5): the clutter operators of a level, built against
//! the dictionary's implicit lights `L_imp` (§5.2.2.2) with rays through the level's walls
//! and the clutter (`penumbra drt`).
//!
//! # Operators (per receiving block `X`; `Y` the block a ray lands in)
//! - **Delta occlusion** `ΔU_b^{X←Y}` (§5.3.1): from each scene texel `x` of `X`, `N`
//!   cosine-distributed rays; a ray that meets clutter before the first wall is continued to
//!   that wall (block `Y`, point `y`) and adds `−(ρ/N)·L_imp_Y(y)` (a bilinear read of `Y`'s
//!   `L_imp` rows at `y`, as the dictionary's gathers read texels). Then `(U_b + ΔU_b) b` is
//!   the one bounce with the clutter's shadows: with the same rays `ΔU_b = (F_clutter − F)
//!   L_imp` exactly (tested). **Weighting:** the thesis says "uniformly distributed shadow
//!   rays … average"; an unweighted average of uniform rays is not irradiance (it misses the
//!   cosine), so the rays are cosine-distributed, which makes the average the irradiance
//!   estimator `F` itself uses (`crate::gather`).
//! - **Delta reflection** `ΔU_c^X` (§5.3.2): the same rays; one that meets the front side of
//!   clutter chart `j` first adds `(1/N)·B_j = 1/(N√m_j)`: the irradiance at `x` per unit
//!   basis coefficient of chart `j`'s outgoing `radiance·π`. The runtime scales `c_j` by
//!   the chart's albedo, so `ΔU_c` holds geometry only and one bake serves every colour.
//! - **Clutter gather** `C_b` (§5.3.3): from each clutter texel, `N` cosine rays about its
//!   normal; a ray that reaches a wall without meeting clutter adds `(ρ/N)·L_imp_Y(y)`
//!   (clutter in the way shadows it; clutter-to-clutter light is not a DRT path). Per
//!   instance the rows of all source blocks are stacked, `C = [C_{Y₁} … C_{Yₛ}]`
//!   (`m × Σ k_b`), and stored in factored form `C ≈ A·W` of rank `k_c` ([`KcMode`]).
//!
//! `ρ` is the dictionary's baked albedo: every operator that reads `L_imp` scales with the
//! walls' albedo exactly as `U_b` does (the runtime's `albedo_scale`).
//!
//! # Neighbourhood (§5.3)
//! "The resulting transport is propagated beyond the current block to all blocks within a
//! prescribed neighborhood": the receiving blocks are those within `D` connection hops of a
//! block that a clutter instance overlaps; rays from them go wherever the level lets them.
//!
//! # Inpainting (§5.4.2)
//! A scene texel is *inside* clutter when more than half of its rays meet clutter from behind
//! (back faces: only the inside of an object, or of a five-faced pillar standing on it, is
//! seen that way) — the thesis's "all their rays intersecting a clutter object", made robust
//! to texels on an object's edge. Inside texels are filled ring by ring from valid 8-neighbours
//! on the same face: `ΔU_b^{X←X}[x] = mean(U_b + ΔU_b^{X←X})[nbrs] − U_b[x]` (average the
//! shadowed operator, subtract the texel's own unshadowed one), and the mean of the
//! neighbours' entries for the other records and `ΔU_c`. A texel no valid neighbour reaches
//! is an inpainting failure (reported, left as traced).
//!
//! Every texel's rays are a pure function of `(seed, block, texel)`, so the bytes do not
//! depend on the thread count.

use crate::TransportError;
use crate::clutter::ClutterScene;
use crate::drt_state::{Acc, DrtState, IncrementalStats, Sums, W_SCALE, clutter_origin, clutter_texel, scene_texel};
use crate::level::{Level, Links};
use crate::level_reference::LevelGeometry;
use crate::shape::{FACE_COUNT, Shape, Texels};
use crate::svd::thin_svd;
use penumbra_asset::{Asset, Kind};
use penumbra_math::progress::Progress;
use penumbra_math::rng::{hash4, unit_f64};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// Hash stage of the DRT rays (distinct from every other stage's stream).
const STAGE: u64 = 0x4452_5400;

/// Kind version of the `DRTO` sections this bake writes.
pub const DRTO_KIND_VERSION: u32 = 1;

/// How `C_b` is reduced to rank `k_c`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KcMode {
    /// The best rank-`k_c` approximation of the stacked `C` (truncated SVD): `A = U Σ`,
    /// `W = Vᵀ`.
    Svd,
    /// The thesis's reading of "5 modes": the first `k_c` columns of each source block's
    /// `C_Y` (the leading `b` modes), `W` a 0/1 selection.
    First,
    /// No reduction (`A = C`, `W = I`), for measurements.
    Full,
}

impl KcMode {
    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Svd => "svd",
            Self::First => "first",
            Self::Full => "full",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "svd" => Some(Self::Svd),
            "first" => Some(Self::First),
            "full" => Some(Self::Full),
            _ => None,
        }
    }
}

/// Bake parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct DrtParams {
    /// Rays per scene texel (thesis: 1024).
    pub rays: usize,
    /// Rays per clutter texel (`C_b`, `C_c`; thesis: the same 1024). Fewer suffice for the
    /// rank-`k_c` gather on large scenes (docs/drt.md, measured).
    pub clutter_rays: usize,
    /// Receiving blocks: within this many connection hops of a cluttered block.
    pub neighborhood: usize,
    /// Rank of `C_b` and `C_c` (thesis: 5 for `C_b`).
    pub k_c: usize,
    /// Rank of `ΔU_c` (thesis: 32 modes).
    pub k_dc: usize,
    /// Bake `C_c`, the clutter-to-clutter gather (not in the thesis; docs/drt.md).
    pub clutter_to_clutter: bool,
    /// How `C_b` is reduced.
    pub kc_mode: KcMode,
    /// Inpaint texels inside clutter.
    pub inpaint: bool,
    /// Texels per box-face edge (thesis: 16).
    pub clutter_res: usize,
    /// Charts per box-face edge (1: the thesis's one constant per face).
    pub clutter_basis_res: usize,
    /// Seed of every hashed draw.
    pub seed: u64,
    /// Store the operators and clutter normals as f16 (default: half the bytes at a relative
    /// change of the verified error below 10⁻⁵, docs/drt.md).
    pub half: bool,
    /// Also bake the vector and volume operators (§5.4.3, [`crate::drt_vector`]) with this many
    /// uniform-hemisphere rays per texel; `None`: scalar operators only.
    pub vector_rays: Option<usize>,
    /// `U_dyn` probes per block edge (`None`: the dictionary's `volume_res`, so `U_dyn`
    /// replaces `U_bvol` probe for probe).
    pub volume_res: Option<usize>,
}

impl Default for DrtParams {
    fn default() -> Self {
        Self {
            rays: 1024,
            clutter_rays: 1024,
            neighborhood: 1,
            k_c: 5,
            k_dc: 32,
            clutter_to_clutter: true,
            kc_mode: KcMode::Svd,
            inpaint: true,
            clutter_res: 16,
            clutter_basis_res: 2,
            seed: 0,
            half: true,
            vector_rays: None,
            volume_res: None,
        }
    }
}

impl DrtParams {
    /// Checks every range; the message names the parameter and the allowed range.
    pub fn validate(&self) -> Result<(), TransportError> {
        let bad =
            |w: &str, v: String, r: &str| Err(TransportError::Param(format!("{w} {v} is out of range (allowed: {r})")));
        if !(16..=1 << 20).contains(&self.rays) {
            return bad("rays", self.rays.to_string(), "16..=1048576");
        }
        if !(16..=1 << 20).contains(&self.clutter_rays) {
            return bad("clutter_rays", self.clutter_rays.to_string(), "16..=1048576");
        }
        if self.neighborhood > 16 {
            return bad("neighborhood", self.neighborhood.to_string(), "0..=16");
        }
        if !(1..=256).contains(&self.k_c) {
            return bad("kc", self.k_c.to_string(), "1..=256");
        }
        if !(1..=4096).contains(&self.k_dc) {
            return bad("kdc", self.k_dc.to_string(), "1..=4096");
        }
        if !(2..=64).contains(&self.clutter_res) {
            return bad("clutter_res", self.clutter_res.to_string(), "2..=64");
        }
        if let Some(v) = self.vector_rays {
            if !(16..=1 << 18).contains(&v) {
                return bad("vector_rays", v.to_string(), "16..=262144");
            }
        }
        if let Some(g) = self.volume_res {
            if !(1..=16).contains(&g) {
                return bad("volume_res", g.to_string(), "1..=16");
            }
        }
        Ok(())
    }

    /// The normalised parameters (the asset's `meta.params`).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::json!({
            "rays": self.rays,
            "clutter_rays": self.clutter_rays,
            "neighborhood": self.neighborhood,
            "k_c": self.k_c,
            "k_dc": self.k_dc,
            "clutter_to_clutter": self.clutter_to_clutter,
            "kc_mode": self.kc_mode.name(),
            "inpaint": self.inpaint,
            "clutter_res": self.clutter_res,
            "clutter_basis_res": self.clutter_basis_res,
            "seed": self.seed,
            "half": self.half,
            "weighting": "cosine",
        });
        // only when asked for: scalar bakes keep their bytes and cache keys
        if let Some(r) = self.vector_rays {
            v["vector_rays"] = serde_json::json!(r);
        }
        if let Some(g) = self.volume_res {
            v["volume_res"] = serde_json::json!(g);
        }
        v
    }
}

/// Version of the rays' arithmetic (directions, box and wall queries, rounding). Bake
/// caches and incremental state keys carry it: a state whose sums came from other
/// arithmetic would not re-bake to a full bake's bytes. Bump it with any such change.
pub const TRACE_VERSION: u32 = 2;

/// One dictionary shape as DRT needs it.
#[derive(Debug, Clone)]
pub struct DrtShape {
    /// Name.
    pub name: String,
    /// Texel layout.
    pub texels: Texels,
    /// Modes.
    pub k_b: usize,
    /// `L_imp`, `n × k_b` row-major.
    pub l_imp: Vec<f64>,
    /// `U_b`, `n × k_b` row-major (for inpainting).
    pub u_b: Vec<f64>,
    /// `L_imp` in fixed point (`crate::drt_state`): `round(L_imp·l_q_scale)`.
    pub l_q: Vec<i32>,
    /// The power-of-two scale of `l_q`.
    pub l_q_scale: f64,
    /// `l_q` as `f64` (exact: `|l_q| ≤ 2²²`), for the accumulation's exact `f64` path.
    pub l_qf: Vec<f64>,
}

impl DrtShape {
    /// A shape from its implicit lights and `U_b` (both `n × k_b`, row-major).
    pub fn new(name: String, texels: Texels, k_b: usize, l_imp: Vec<f64>, u_b: Vec<f64>) -> Self {
        let (l_q, l_q_scale) = crate::drt_state::quantize(&l_imp);
        let l_qf = l_q.iter().map(|&x| f64::from(x)).collect();
        Self { name, texels, k_b, l_imp, u_b, l_q, l_q_scale, l_qf }
    }
}

/// What DRT reads from an `MRTD` dictionary (kind version 3: `<shape>.l_imp`).
#[derive(Debug, Clone)]
pub struct DrtDict {
    /// Shapes in dictionary order.
    pub shapes: Vec<DrtShape>,
    /// Missing-face masks.
    pub missing: Vec<u8>,
    /// Texels per face edge.
    pub face_res: usize,
    /// The albedo `U_b` and `L_imp` were baked for.
    pub albedo: f64,
    /// CRC-32C of the dictionary file.
    pub crc32c: u32,
    /// Volume probes per block edge of the dictionary's `U_bvol` (`params.volume_res`; 4 when
    /// the meta does not say).
    pub volume_res: usize,
}

fn read_rows(a: &Asset<'_>, name: &str, n: usize, k: usize) -> Result<Vec<f64>, TransportError> {
    let s = a.section(name).ok_or_else(|| TransportError::Input(format!("section {name} is missing")))?;
    if s.dims() != [n, k] {
        return Err(TransportError::Input(format!("section {name}: dims {:?}, expected [{n}, {k}]", s.dims())));
    }
    let v = s.as_f32().map_err(|e| TransportError::Input(format!("section {name}: {e}")))?;
    Ok(v.iter().map(|&x| f64::from(x)).collect())
}

impl DrtDict {
    /// Reads the implicit lights and `U_b` of every shape; a dictionary older than kind
    /// version 3 has no `L_imp` and must be re-baked.
    pub fn from_asset(a: &Asset<'_>) -> Result<Self, TransportError> {
        if a.kind() != Kind::MRTD {
            return Err(TransportError::Input(format!("not an MRT dictionary (kind {})", a.kind().as_str())));
        }
        let meta: serde_json::Value =
            serde_json::from_str(a.meta_json()).map_err(|e| TransportError::Input(e.to_string()))?;
        let kv = meta["kind_version"].as_u64().unwrap_or(0);
        if kv < 3 {
            return Err(TransportError::Input(format!(
                "the dictionary is MRTD kind_version {kv}, which has no implicit lights (L_imp) for DRT: re-bake it \
                 with this penumbra (`penumbra mrt dict`, kind_version 3)"
            )));
        }
        let face_res = meta["params"]["face_res"].as_u64().unwrap_or(0) as usize;
        let albedo = meta["params"]["albedo"].as_f64().unwrap_or(1.0);
        let mut shapes = Vec::new();
        let mut missing = Vec::new();
        for s in meta["shapes"].as_array().ok_or_else(|| TransportError::Input("meta.shapes missing".into()))? {
            let name = s["name"].as_str().unwrap_or("").to_string();
            let mut m = 0u8;
            for f in s["missing_faces"].as_array().into_iter().flatten() {
                let f = f
                    .as_str()
                    .and_then(crate::level::parse_face)
                    .ok_or_else(|| TransportError::Input("bad missing face in meta".into()))?;
                m |= 1 << f;
            }
            let texels = Texels::new(Shape::new("dict", m), face_res);
            let n = texels.len();
            let k_b = a
                .section(&format!("{name}.u_b"))
                .and_then(|s| s.dims().get(1).copied())
                .ok_or_else(|| TransportError::Input(format!("section {name}.u_b is missing")))?;
            let l_imp = read_rows(a, &format!("{name}.l_imp"), n, k_b)?;
            let u_b = read_rows(a, &format!("{name}.u_b"), n, k_b)?;
            shapes.push(DrtShape::new(name, texels, k_b, l_imp, u_b));
            missing.push(m);
        }
        let volume_res = meta["params"]["volume_res"].as_u64().unwrap_or(4) as usize;
        Ok(Self { shapes, missing, face_res, albedo, crc32c: penumbra_asset::crc32c(a.bytes()), volume_res })
    }
}

/// `ΔU_b^{dst←src}`: `rows(dst) × k_b(src)`, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct DeltaRecord {
    /// Receiving block.
    pub dst: usize,
    /// Block whose `b` drives it.
    pub src: usize,
    /// Rows (texels of `dst`).
    pub rows: usize,
    /// Columns (`k_b` of `src`'s shape).
    pub cols: usize,
    /// Values.
    pub op: Vec<f64>,
}

/// A reflection operator over the charts its rays reach (`ΔU_c^{dst}` of a receiving block,
/// or `C_c` of a clutter instance): `rows × charts.len()`, row-major, and its factored form
/// `A·W` of rank `rank` (what the asset stores).
#[derive(Debug, Clone, PartialEq)]
pub struct ReflectRecord {
    /// Receiving block (`ΔU_c`) or instance (`C_c`).
    pub dst: usize,
    /// Global chart indices (columns), ascending.
    pub charts: Vec<usize>,
    /// Rows (texels of `dst`).
    pub rows: usize,
    /// Values (unreduced).
    pub op: Vec<f64>,
    /// `rows × rank`, row-major.
    pub a: Vec<f64>,
    /// `rank × charts.len()`, row-major.
    pub w: Vec<f64>,
    /// Rank kept.
    pub rank: usize,
    /// `‖op − A W‖_F / ‖op‖_F`.
    pub truncation_rel_error: f64,
}

impl ReflectRecord {
    /// An unfactored record.
    pub fn new(dst: usize, charts: Vec<usize>, rows: usize) -> Self {
        let op = vec![0.0; rows * charts.len()];
        Self { dst, charts, rows, op, a: Vec::new(), w: Vec::new(), rank: 0, truncation_rel_error: 0.0 }
    }

    /// Factors `op` to rank `k` (truncated SVD; exact with `W = I` when the operator has no
    /// more than `k` columns).
    pub fn factor(&mut self, k: usize) -> Result<(), TransportError> {
        let (rows, cols) = (self.rows, self.charts.len());
        if cols <= k || rows == 0 {
            self.a = self.op.clone();
            self.w = (0..cols * cols).map(|i| if i / cols == i % cols { 1.0 } else { 0.0 }).collect();
            self.rank = cols;
            self.truncation_rel_error = 0.0;
            return Ok(());
        }
        let (a, w, r, err) = truncated(&self.op, rows, cols, k)?;
        self.truncation_rel_error = err;
        (self.a, self.w, self.rank) = (a, w, r);
        Ok(())
    }
}

/// Best rank-`k` factors `A = U Σ` (`rows × r`), `W = Vᵀ` (`r × cols`) of a row-major matrix;
/// `r ≤ k` drops singular values below `10⁻¹²·σ₁`. Also returns `‖op − A W‖_F / ‖op‖_F`,
/// which for a truncated SVD is `√(Σ_{c≥r} σ_c² / Σ σ_c²)` (Eckart–Young), with no product.
fn truncated(op: &[f64], rows: usize, cols: usize, k: usize) -> Result<Factors, TransportError> {
    if rows == 0 || cols == 0 {
        return Ok((Vec::new(), Vec::new(), 0, 0.0));
    }
    let m = faer::MatRef::from_row_major_slice(op, rows, cols);
    // tall operators (every DRT operator: texels × charts or modes): the eigenvectors of the
    // cols × cols Gram matrix are V and its eigenvalues σ²; A = op·V = UΣ. m·n² + n³ instead
    // of a thin SVD's larger constant. The Gram's rounding floor is about √ε·σ₁ ≈ 1.5·10⁻⁸σ₁,
    // so modes below 10⁻⁷σ₁ are cut (10⁻¹²σ₁ on the SVD path); the verified errors did not
    // change to the printed digits (docs/drt.md)
    let (s, v) = if rows >= 2 * cols {
        let g = gram(op, rows, cols);
        let (l, v) = crate::svd::sym_eigen(g.as_ref())?;
        (l.iter().map(|&x| x.max(0.0).sqrt()).collect::<Vec<f64>>(), v)
    } else {
        let d = thin_svd(m)?;
        (d.s, d.v)
    };
    let s0 = s.first().copied().unwrap_or(0.0);
    let floor = if rows >= 2 * cols { 1e-7 } else { 1e-12 };
    let r = k.min(s.iter().filter(|&&x| x > floor * s0 && x > 0.0).count());
    let vr = v.subcols(0, r);
    let us = crate::svd::mul(m, vr);
    let mut a = vec![0.0; rows * r];
    let mut w = vec![0.0; r * cols];
    for c in 0..r {
        // canonical sign: the largest-magnitude entry of each left vector positive
        let mut best = (0.0f64, 0usize);
        for t in 0..rows {
            if us[(t, c)].abs() > best.0 {
                best = (us[(t, c)].abs(), t);
            }
        }
        let sg = if us[(best.1, c)] < 0.0 { -1.0 } else { 1.0 };
        for t in 0..rows {
            a[t * r + c] = sg * us[(t, c)];
        }
        for j in 0..cols {
            w[c * cols + j] = sg * v[(j, c)];
        }
    }
    let all: f64 = s.iter().map(|x| x * x).sum();
    let rest: f64 = s[r..].iter().map(|x| x * x).sum();
    let err = if all > 0.0 { (rest / all).sqrt() } else { 0.0 };
    Ok((a, w, r, err))
}

/// `opᵀ·op` of a row-major matrix. The DRT operators are sparse by rows (a clutter texel
/// sees a few charts and blocks of the dozens its instance's rays reach), so when the rows'
/// nonzeros are few the Gram matrix is summed from each row's outer product
/// (`Σ nnz_row²` multiply-adds instead of `rows·cols²`), else by the dense product.
fn gram(op: &[f64], rows: usize, cols: usize) -> faer::Mat<f64> {
    let mut work = 0usize;
    for row in op.chunks_exact(cols) {
        let nz = row.iter().filter(|&&x| x != 0.0).count();
        work += nz * nz;
    }
    // the dense product runs several times faster per multiply-add
    if work.saturating_mul(8) >= rows * cols * cols {
        let m = faer::MatRef::from_row_major_slice(op, rows, cols);
        return crate::svd::mul_tn(m, m);
    }
    let mut g = vec![0.0; cols * cols];
    let mut nz: Vec<(usize, f64)> = Vec::with_capacity(cols);
    for row in op.chunks_exact(cols) {
        nz.clear();
        nz.extend(row.iter().enumerate().filter(|(_, x)| **x != 0.0).map(|(j, &x)| (j, x)));
        for (a, &(i, x)) in nz.iter().enumerate() {
            let gi = &mut g[i * cols..(i + 1) * cols];
            for &(j, y) in &nz[a..] {
                gi[j] += x * y;
            }
        }
    }
    faer::Mat::from_fn(cols, cols, |i, j| if i <= j { g[i * cols + j] } else { g[j * cols + i] })
}

/// `(A, W, rank, ‖op − A W‖_F / ‖op‖_F)`.
type Factors = (Vec<f64>, Vec<f64>, usize, f64);

/// `‖C − A W‖_F / ‖C‖_F`.
fn factored_error(full: &[f64], a: &[f64], w: &[f64], rows: usize, cols: usize, rank: usize) -> f64 {
    let norm = full.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut err2 = 0.0;
    for t in 0..rows {
        for j in 0..cols {
            let aw: f64 = (0..rank).map(|c| a[t * rank + c] * w[c * cols + j]).sum();
            err2 += (full[t * cols + j] - aw).powi(2);
        }
    }
    if norm > 0.0 { err2.sqrt() / norm } else { 0.0 }
}

/// `C_b` of one clutter instance in factored form `A·W` (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct GatherOp {
    /// Instance.
    pub instance: usize,
    /// Source blocks, ascending; `W`'s columns are their `b` vectors stacked.
    pub srcs: Vec<usize>,
    /// Column offset of each source block in the stacked `b` (and the total).
    pub src_offsets: Vec<usize>,
    /// `m × r`, row-major.
    pub a: Vec<f64>,
    /// `r × K`, row-major.
    pub w: Vec<f64>,
    /// Rank `r`.
    pub rank: usize,
    /// `‖C − A W‖_F / ‖C‖_F`.
    pub truncation_rel_error: f64,
    /// The unreduced `C` (`m × K`, row-major), kept for measurements (not written).
    pub full: Vec<f64>,
    /// `C_c`: light from the clutter's charts onto this instance's texels (an extension of
    /// the thesis, docs/drt.md), factored to rank `k_c`; empty without `clutter_to_clutter`.
    pub c_c: ReflectRecord,
}

/// Per receiving block: where its texels start in the concatenated inpainting mask.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Receiver {
    /// Block.
    pub block: usize,
    /// Texels.
    pub texels: usize,
    /// Per texel: 0 = outside clutter, 1 = inside and inpainted, 2 = inside, inpainting failed.
    pub mask: Vec<u8>,
}

/// Measurements of a DRT bake (`--json`).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct DrtMetrics {
    /// Receiving blocks.
    pub blocks: usize,
    /// Clutter instances.
    pub clutter_instances: usize,
    /// Clutter texels.
    pub clutter_texels: usize,
    /// Clutter charts (basis functions).
    pub clutter_charts: usize,
    /// Rays per texel.
    pub rays: usize,
    /// Rays traced in all.
    pub rays_traced: u64,
    /// Scene texels inside clutter that were inpainted.
    pub inpainted_texels: usize,
    /// Inside texels no valid neighbour reached.
    pub inpaint_failures: usize,
    /// Clutter texels whose outward side lies in no block (they receive nothing).
    pub clutter_texels_outside: usize,
    /// Neighbourhood (hops).
    pub neighborhood: usize,
    /// `ΔU_b` records.
    pub delta_occlusion_records: usize,
    /// `C_b` rank kept per instance (largest).
    pub k_c: usize,
    /// `C_b` truncation error per instance (`‖C − A W‖/‖C‖`).
    pub c_b_truncation_rel_error: Vec<f64>,
    /// `ΔU_c` rank kept (largest over blocks).
    pub k_dc: usize,
    /// `ΔU_c` truncation error per receiving block.
    pub du_c_truncation_rel_error: Vec<f64>,
    /// `C_c` truncation error per instance (empty without `clutter_to_clutter`).
    pub c_c_truncation_rel_error: Vec<f64>,
}

/// A baked set of DRT operators.
#[derive(Debug, Clone)]
pub struct DrtBake {
    /// Parameters.
    pub params: DrtParams,
    /// Which shard this is ([`DrtShard::WHOLE`] for a whole bake).
    pub shard: DrtShard,
    /// Receiving blocks in ascending order.
    pub receivers: Vec<Receiver>,
    /// `ΔU_b` records sorted by `(dst, src)`.
    pub du_b: Vec<DeltaRecord>,
    /// `ΔU_c` per receiving block (ascending).
    pub du_c: Vec<ReflectRecord>,
    /// `C_b` per instance.
    pub c_b: Vec<GatherOp>,
    /// Measurements.
    pub metrics: DrtMetrics,
}

/// World axis-aligned bounds of a block.
pub fn block_bounds(level: &Level, b: usize) -> [[f64; 3]; 2] {
    let blk = &level.blocks[b];
    let (p, q) = (blk.to_world([0.0; 3]), blk.to_world([1.0; 3]));
    [core::array::from_fn(|k| p[k].min(q[k])), core::array::from_fn(|k| p[k].max(q[k]))]
}

/// Blocks that an instance's bounds overlap (with a positive-volume intersection).
pub fn cluttered_blocks(level: &Level, clutter: &ClutterScene, instance: usize) -> Vec<usize> {
    let [lo, hi] = clutter.bounds[instance];
    (0..level.blocks.len())
        .filter(|&b| {
            let [bl, bh] = block_bounds(level, b);
            (0..3).all(|k| lo[k] < bh[k] - 1e-9 && hi[k] > bl[k] + 1e-9)
        })
        .collect()
}

/// Blocks within `d` hops (through connections) of any cluttered block, ascending.
pub fn receiving_blocks(level: &Level, links: &Links, clutter: &ClutterScene, d: usize) -> Vec<usize> {
    let nb = level.blocks.len();
    let mut dist = vec![usize::MAX; nb];
    let mut queue = std::collections::VecDeque::new();
    for i in 0..clutter.len() {
        for b in cluttered_blocks(level, clutter, i) {
            if dist[b] != 0 {
                dist[b] = 0;
                queue.push_back(b);
            }
        }
    }
    while let Some(b) = queue.pop_front() {
        if dist[b] >= d {
            continue;
        }
        for l in links[b].iter().flatten() {
            if dist[l.0] == usize::MAX {
                dist[l.0] = dist[b] + 1;
                queue.push_back(l.0);
            }
        }
    }
    (0..nb).filter(|&b| dist[b] != usize::MAX).collect()
}

/// Everything the ray loops share.
pub struct Scene<'a> {
    /// Level geometry (walls, openings).
    pub geo: LevelGeometry<'a>,
    /// Clutter.
    pub clutter: &'a ClutterScene,
    /// Dictionary.
    pub dict: &'a DrtDict,
    /// Per block: the clutter instances that overlap it.
    pub block_clutter: Vec<Vec<usize>>,
    /// Per block and local face: the affine maps world point → face `(u, v)`,
    /// `[a_u (3), c_u, a_v (3), c_v]` ([`wall_uv_maps`]).
    pub(crate) wall_uv: Vec<[[f64; 8]; FACE_COUNT]>,
    /// The ray loops' level walk and clutter pre-filter.
    pub(crate) walk: crate::drt_walk::Walk,
    /// Per block: its shape's texels (the wall hits' bilinear taps).
    pub(crate) block_texels: Vec<&'a Texels>,
}

/// Per local face of `blk`, the affine maps from a world point to the face's `(u, v)`:
/// `to_local` (translate, quarter turns, divide by the scale) followed by `face_uv`, folded
/// into six multiply-adds so the ray loops' wall hits need no division.
pub(crate) fn wall_uv_maps(blk: &crate::level::Block) -> [[f64; 8]; FACE_COUNT] {
    // columns of the world → local linear part: to_local(T + e_j) − 0.5, exact for the
    // signed permutation of the quarter turns; only the scale's reciprocal rounds
    let r = (4 - blk.rotation % 4) % 4;
    let lin: [[f64; 3]; 3] = core::array::from_fn(|j| {
        let e = crate::level::rotate_y(core::array::from_fn(|k| f64::from(u8::from(k == j))), r);
        core::array::from_fn(|k| e[k] / blk.scale[k])
    });
    core::array::from_fn(|f| {
        let fr = &crate::shape::FACE_FRAMES[f];
        let mut m = [0.0; 8];
        for (h, axis) in [fr.u, fr.v].iter().enumerate() {
            let a: [f64; 3] = core::array::from_fn(|j| (0..3).map(|k| axis[k] * lin[j][k]).sum());
            let c = (0..3).map(|k| axis[k] * (0.5 - fr.origin[k])).sum::<f64>()
                - (0..3).map(|j| a[j] * blk.translation[j]).sum::<f64>();
            m[4 * h..4 * h + 3].copy_from_slice(&a);
            m[4 * h + 3] = c;
        }
        m
    })
}

impl<'a> Scene<'a> {
    /// The scene of a level with clutter.
    pub fn new(geo: LevelGeometry<'a>, clutter: &'a ClutterScene, dict: &'a DrtDict) -> Self {
        let mut block_clutter = vec![Vec::new(); geo.level.blocks.len()];
        for i in 0..clutter.len() {
            for b in cluttered_blocks(geo.level, clutter, i) {
                block_clutter[b].push(i);
            }
        }
        let wall_uv = geo.level.blocks.iter().map(wall_uv_maps).collect();
        let walk = crate::drt_walk::Walk::new(geo.level, geo.links, geo.missing, clutter, &block_clutter);
        let block_texels = geo.level.blocks.iter().map(|b| &dict.shapes[b.shape].texels).collect();
        Self { geo, clutter, dict, block_clutter, wall_uv, walk, block_texels }
    }
}

impl core::fmt::Debug for Scene<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Scene")
            .field("blocks", &self.geo.level.blocks.len())
            .field("clutter", &self.clutter.len())
            .finish()
    }
}

/// A ray's outcome.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RayHit {
    /// Left the level.
    Lost,
    /// Reached a wall (block, local face, world point) with no clutter before it.
    Wall(usize, usize, [f64; 3]),
    /// Met clutter first; the wall behind it, if any, and the clutter hit.
    Clutter(Option<(usize, usize, [f64; 3])>, crate::clutter::ClutterHit),
}

impl Scene<'_> {
    /// Casts a unit ray from `x` in block `b`: the wall it reaches through the level, then
    /// block by block along the way the clutter that overlaps each block (the first block
    /// with a hit inside its segment holds the closest hit).
    pub fn cast(&self, b: usize, x: [f64; 3], d: [f64; 3]) -> RayHit {
        self.cast_with(b, x, d, &mut Vec::with_capacity(8))
    }

    /// [`Scene::cast`] with a caller-owned buffer for the blocks the ray crosses (the bake's
    /// ray loops cast millions of rays; one allocation per texel instead of per ray).
    pub fn cast_with(&self, b: usize, x: [f64; 3], d: [f64; 3], segs: &mut Vec<(usize, f64, f64)>) -> RayHit {
        self.cast_except(b, x, d, segs, usize::MAX)
    }

    /// [`Scene::cast_with`] for a ray that cannot meet clutter instance `skip` (a box's own
    /// texel looking out); `usize::MAX` skips none.
    pub fn cast_except(
        &self,
        b: usize,
        x: [f64; 3],
        d: [f64; 3],
        segs: &mut Vec<(usize, f64, f64)>,
        skip: usize,
    ) -> RayHit {
        let wall = self.geo.trace_segments(b, x, d, segs).map(|h| (h.block, h.face, h.point));
        self.resolve(wall, segs, x, d, skip)
    }

    /// The rest of [`Scene::cast_except`] once the level walk is done (`wall` and the blocks
    /// `segs` crossed do not depend on the clutter: an incremental re-bake walks a ray once
    /// for the old and the new scene).
    pub(crate) fn resolve(
        &self,
        wall: Option<(usize, usize, [f64; 3])>,
        segs: &[(usize, f64, f64)],
        x: [f64; 3],
        d: [f64; 3],
        skip: usize,
    ) -> RayHit {
        self.resolve_inv(wall, segs, x, d, d.map(|c| 1.0 / c), skip)
    }

    /// [`Scene::resolve`] with the direction's reciprocals `inv = 1/d` from the caller.
    #[inline]
    pub(crate) fn resolve_inv(
        &self,
        wall: Option<(usize, usize, [f64; 3])>,
        segs: &[(usize, f64, f64)],
        x: [f64; 3],
        d: [f64; 3],
        inv: [f64; 3],
        skip: usize,
    ) -> RayHit {
        let mut hit = None;
        for &(y, t0, t1) in segs.iter() {
            let insts = self.walk.instances(y);
            if insts.is_empty() {
                continue;
            }
            let tmin = t0.max(1e-9);
            // the pre-filter's survivors in order; the search repeats their padded test
            let found = match self.walk.prefilter(y, x, inv, (tmin, t1)) {
                Some(0) => continue,
                Some(mask) => {
                    let cand = crate::drt_walk::Bits(mask).map(|j| insts[j]);
                    self.clutter.closest_among_except_iter(cand, skip, x, d, inv, tmin, t1)
                }
                None => self.clutter.closest_among_except_inv(insts, skip, x, d, inv, tmin, t1),
            };
            if let Some(h) = found {
                hit = Some(h);
                break;
            }
        }
        match hit {
            Some(h) => RayHit::Clutter(wall, h),
            None => match wall {
                Some(w) => RayHit::Wall(w.0, w.1, w.2),
                None => RayHit::Lost,
            },
        }
    }
}

/// World `(u, v, n)` frame of local face `f` of block `b` and the rotated local direction.
pub(crate) fn frame_dir(fr: &[[f64; 3]; 3], l: [f64; 3]) -> [f64; 3] {
    core::array::from_fn(|k| l[0] * fr[0][k] + l[1] * fr[1][k] + l[2] * fr[2][k])
}

/// Per-texel rotation of the shared direction set.
pub(crate) fn rotation(seed: u64, item: u64, texel: u64) -> (f64, f64) {
    let phi = 2.0 * core::f64::consts::PI * unit_f64(hash4(seed, STAGE, item, texel));
    let (s, c) = phi.sin_cos();
    (c, s)
}

/// The frame `g` with `frame_dir(&g, l) = frame_dir(fr, rotate_z(l, (c, s)))`: the
/// per-texel rotation folded into the frame once, not applied per ray.
pub(crate) fn rotated_frame(fr: &[[f64; 3]; 3], (c, s): (f64, f64)) -> [[f64; 3]; 3] {
    [
        core::array::from_fn(|k| c * fr[0][k] + s * fr[1][k]),
        core::array::from_fn(|k| c * fr[1][k] - s * fr[0][k]),
        fr[2],
    ]
}

pub(crate) fn rotate_z(l: [f64; 3], (c, s): (f64, f64)) -> [f64; 3] {
    [l[0] * c - l[1] * s, l[0] * s + l[1] * c, l[2]]
}

/// What the rays of one scene texel found, as the assembly reads it.
#[derive(Debug, Default)]
struct TexelRays {
    /// `(src block, row)` of `ΔU_b`.
    du_b: Vec<(usize, Vec<f64>)>,
    /// `(chart, value)` of `ΔU_c`.
    du_c: Vec<(usize, f64)>,
    /// Rays meeting clutter from behind.
    back: usize,
}

/// What the rays of one clutter texel found: `(src block, row)` pairs of `C_b` and
/// `(chart, value)` pairs of `C_c`.
type ClutterRays = (Vec<(usize, Vec<f64>)>, Vec<(usize, f64)>);

/// Rows `scale·row/(W_SCALE·s_y)` of a texel's fixed-point sums (`crate::drt_state`).
fn rows_of(s: &Sums, dict: &DrtDict, level: &Level, scale: f64) -> Vec<(usize, Vec<f64>)> {
    s.rows
        .iter()
        .map(|(y, r)| {
            let y = *y as usize;
            let f = scale / (W_SCALE * dict.shapes[level.blocks[y].shape].l_q_scale);
            (y, r.iter().map(|&v| v as f64 * f).collect())
        })
        .collect()
}

/// `(chart, hits/(N·√m_j))`: the orthonormal basis value per hit (§5.3.2).
fn charts_of(s: &Sums, clutter: &ClutterScene, n: f64) -> Vec<(usize, f64)> {
    s.charts
        .iter()
        .map(|&(j, c)| (j as usize, c as f64 / (n * (clutter.charts[j as usize].count as f64).sqrt())))
        .collect()
}

/// One of `count` shards of a bake (`index < count`): receiving block `j` (in ascending
/// block order) belongs to shard `j mod count`, clutter instance `i` to shard `i mod count`.
/// Every record depends only on its own texels' rays, so the shards' records together are
/// exactly a single run's ([`crate::drt_asset::merge`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DrtShard {
    /// This shard.
    pub index: usize,
    /// Shards in all.
    pub count: usize,
}

impl DrtShard {
    /// The whole bake.
    pub const WHOLE: Self = Self { index: 0, count: 1 };

    /// Whether item `j` (a receiving block's rank, or an instance) is this shard's.
    pub fn owns(self, j: usize) -> bool {
        j % self.count == self.index
    }
}

/// Bakes the DRT operators of a level with clutter.
pub fn bake(
    level: &Level,
    links: &Links,
    dict: &DrtDict,
    clutter: &ClutterScene,
    params: &DrtParams,
    progress: &dyn Progress,
) -> Result<DrtBake, TransportError> {
    bake_shard(level, links, dict, clutter, params, DrtShard::WHOLE, progress)
}

/// [`bake`], also returning the rays' sums an incremental re-bake starts from
/// ([`crate::drt_state`]; `key` and `instances` as the caller describes its inputs).
#[allow(clippy::too_many_arguments)]
pub fn bake_with_state(
    level: &Level,
    links: &Links,
    dict: &DrtDict,
    clutter: &ClutterScene,
    params: &DrtParams,
    key: String,
    instances: Vec<crate::drt_state::StateInstance>,
    progress: &dyn Progress,
) -> Result<(DrtBake, DrtState), TransportError> {
    check_inputs(level, dict, clutter, params, DrtShard::WHOLE)?;
    let sc = Scene::new(LevelGeometry { level, links, missing: &dict.missing }, clutter, dict);
    let recv = receiving_blocks(level, links, clutter, params.neighborhood);
    let insts: Vec<usize> = (0..clutter.len()).collect();
    let (scene, csums) = trace(&sc, params, &recv, &insts, progress);
    let b = assemble(&sc, params, DrtShard::WHOLE, &recv, &scene, &insts, &csums, None)?;
    let state = DrtState {
        key,
        instances,
        blocks: recv.into_iter().zip(scene).collect(),
        clutter: csums,
        asset_crc32c: None,
        vector: None,
    };
    Ok((b, state))
}

/// Re-bakes from `state` (a bake of the scene `old`) for the scene `new`, in which the
/// instances `moved` were placed elsewhere: only the rays that meet a moved instance at its
/// old or new place are traced again, in both scenes, and `state` becomes the new scene's.
/// The result is the bytes a full bake of `new` gives (the sums are integers,
/// [`crate::drt_state`]). With `prev`, the bake the state came from (its asset decoded,
/// [`crate::drt_asset::read_bake`]), only the records whose sums changed are assembled and
/// factored again; the others are copied (a record depends on its own sums alone, so the
/// bytes are still a full bake's). `Err(Param)` when the scenes are not comparable (the
/// caller bakes in full).
#[allow(clippy::too_many_arguments)]
pub fn bake_incremental(
    level: &Level,
    links: &Links,
    dict: &DrtDict,
    old: &ClutterScene,
    new: &ClutterScene,
    moved: &[usize],
    state: &mut DrtState,
    params: &DrtParams,
    prev: Option<&DrtBake>,
    progress: &dyn Progress,
) -> Result<(DrtBake, IncrementalStats), TransportError> {
    check_inputs(level, dict, new, params, DrtShard::WHOLE)?;
    crate::drt_state::compatible(old, new).map_err(TransportError::Param)?;
    if state.clutter.len() != new.len()
        || (0..new.len()).any(|i| state.clutter[i].len() != new.instance_texels[i][1])
        || moved.iter().any(|&i| i >= new.len())
    {
        return Err(TransportError::Param("the state's clutter texels do not match the scene".into()));
    }
    let geo = LevelGeometry { level, links, missing: &dict.missing };
    let sc_old = Scene::new(geo, old, dict);
    let sc = Scene::new(LevelGeometry { level, links, missing: &dict.missing }, new, dict);
    let boxes: Vec<[[f64; 3]; 2]> = moved.iter().flat_map(|&i| [old.padded_bounds(i), new.padded_bounds(i)]).collect();
    let dirs = crate::drt_walk::coherent_cosine(params.rays);
    let cdirs = crate::drt_walk::coherent_cosine(params.clutter_rays);
    let upper = dirs.dirs.iter().chain(&cdirs.dirs).all(|d| d[2] >= 0.0);
    let cull = crate::drt_state::Cull::new(boxes, upper);
    let keep = Some(&cull);
    let recv = receiving_blocks(level, links, new, params.neighborhood);
    let mut stats = IncrementalStats { moved: moved.to_vec(), ..Default::default() };
    let mut old_blocks: BTreeMap<usize, Vec<Sums>> = core::mem::take(&mut state.blocks).into_iter().collect();
    let mut scene = Vec::with_capacity(recv.len());
    let total = recv.len() as u64 + new.len() as u64;
    // what did not change, and so may be copied from `prev`
    let mut same_blocks = std::collections::BTreeSet::new();
    let mut same_insts = std::collections::BTreeSet::new();
    for (done, &x) in recv.iter().enumerate() {
        let n = dict.shapes[level.blocks[x].shape].texels.len();
        let items: Vec<(usize, usize)> = (0..n).map(|t| (x, t)).collect();
        let prev = old_blocks.remove(&x).filter(|v| v.len() == n);
        let full = prev.is_none();
        let mut sums = prev.unwrap_or_else(|| vec![Sums::default(); n]);
        let deltas: Vec<(Sums, u64)> = items
            .par_chunks(64)
            .flat_map_iter(|chunk| {
                let mut acc = Acc::new(new.charts.len());
                let mut segs = Vec::with_capacity(8);
                chunk
                    .iter()
                    .map(|&xt| {
                        let mut cast = 0;
                        if full {
                            cast += scene_texel(&[(&sc, 1)], &dirs, params.seed, xt, None, &mut acc, &mut segs);
                        } else {
                            let both = [(&sc_old, -1), (&sc, 1)];
                            cast += 2 * scene_texel(&both, &dirs, params.seed, xt, keep, &mut acc, &mut segs);
                        }
                        (acc.take(dict, level), cast)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut changed = full;
        for (s, (d, cast)) in sums.iter_mut().zip(deltas) {
            stats.rays_cast += cast;
            if !d.is_zero() {
                stats.texels_changed += 1;
                s.add(&d);
                changed = true;
            }
        }
        if !changed {
            same_blocks.insert(x);
        }
        stats.blocks_traced_in_full += usize::from(full);
        scene.push(sums);
        progress.update("drt rays (incremental)", done as u64 + 1, total);
    }
    let mut csums = core::mem::take(&mut state.clutter);
    for (i, inst) in csums.iter_mut().enumerate() {
        let [first, count] = new.instance_texels[i];
        let is_moved = moved.contains(&i);
        let idx: Vec<usize> = (first..first + count).collect();
        let deltas: Vec<(Option<Sums>, u64)> = idx
            .par_chunks(64)
            .flat_map_iter(|chunk| {
                let mut acc = Acc::new(new.charts.len());
                let mut segs = Vec::with_capacity(8);
                chunk
                    .iter()
                    .map(|&ti| {
                        let (o, b) = clutter_origin(&sc, ti);
                        let Some(b) = b else { return (None, 0) };
                        let mut cast = 0;
                        let it = (ti, b, o);
                        if is_moved {
                            cast += clutter_texel(&[(&sc, 1)], &cdirs, params.seed, it, None, &mut acc, &mut segs);
                        } else {
                            let both = [(&sc_old, -1), (&sc, 1)];
                            cast += 2 * clutter_texel(&both, &cdirs, params.seed, it, keep, &mut acc, &mut segs);
                        }
                        (Some(acc.take(dict, level)), cast)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut changed = is_moved;
        for (s, (d, cast)) in inst.iter_mut().zip(deltas) {
            stats.rays_cast += cast;
            if is_moved {
                if d.as_ref().is_some_and(|d| !d.is_zero()) || s.as_ref().is_some_and(|s| !s.is_zero()) {
                    stats.texels_changed += 1;
                }
                *s = d;
            } else if let (Some(s), Some(d)) = (s.as_mut(), d) {
                if !d.is_zero() {
                    stats.texels_changed += 1;
                    s.add(&d);
                    changed = true;
                }
            }
        }
        if !changed {
            same_insts.insert(i);
        }
        progress.update("drt rays (incremental)", recv.len() as u64 + i as u64 + 1, total);
    }
    let insts: Vec<usize> = (0..new.len()).collect();
    // the previous bake lends records only if it is a whole bake with these parameters
    let reuse = prev.filter(|p| p.params == *params && p.shard == DrtShard::WHOLE).map(|p| Reuse {
        prev: p,
        blocks: same_blocks.into_iter().filter(|x| p.receivers.iter().any(|r| r.block == *x)).collect(),
        insts: same_insts.into_iter().filter(|&i| p.c_b.iter().any(|g| g.instance == i)).collect(),
    });
    stats.records_reused = reuse.as_ref().map_or(0, |r| r.blocks.len() + r.insts.len());
    stats.records_assembled = recv.len() + insts.len() - stats.records_reused;
    let b = assemble(&sc, params, DrtShard::WHOLE, &recv, &scene, &insts, &csums, reuse.as_ref())?;
    stats.rays_full = b.metrics.rays_traced;
    state.blocks = recv.into_iter().zip(scene).collect();
    state.clutter = csums;
    Ok((b, stats))
}

/// The checks every bake makes before tracing.
fn check_inputs(
    level: &Level,
    dict: &DrtDict,
    clutter: &ClutterScene,
    params: &DrtParams,
    shard: DrtShard,
) -> Result<(), TransportError> {
    params.validate()?;
    if shard.count == 0 || shard.index >= shard.count {
        return Err(TransportError::Param(format!(
            "shard {}/{} is out of range (allowed: K/N with 0 <= K < N)",
            shard.index, shard.count
        )));
    }
    if dict.face_res == 0 || level.blocks.iter().any(|b| b.shape >= dict.shapes.len()) {
        return Err(TransportError::Input("the level does not match the dictionary".into()));
    }
    for i in 0..clutter.len() {
        if cluttered_blocks(level, clutter, i).is_empty() {
            let [lo, hi] = clutter.bounds[i];
            return Err(TransportError::Param(format!(
                "clutter {i} ({}) lies outside every block of the level (bounds {lo:?} – {hi:?})",
                clutter.specs[i].name
            )));
        }
    }
    Ok(())
}

/// One of [`bake`]'s shards: only its receiving blocks and instances (the metrics count those).
pub fn bake_shard(
    level: &Level,
    links: &Links,
    dict: &DrtDict,
    clutter: &ClutterScene,
    params: &DrtParams,
    shard: DrtShard,
    progress: &dyn Progress,
) -> Result<DrtBake, TransportError> {
    check_inputs(level, dict, clutter, params, shard)?;
    let sc = Scene::new(LevelGeometry { level, links, missing: &dict.missing }, clutter, dict);
    let recv: Vec<usize> = receiving_blocks(level, links, clutter, params.neighborhood)
        .into_iter()
        .enumerate()
        .filter(|&(j, _)| shard.owns(j))
        .map(|(_, x)| x)
        .collect();
    let insts: Vec<usize> = (0..clutter.len()).filter(|&i| shard.owns(i)).collect();
    let (scene, csums) = trace(&sc, params, &recv, &insts, progress);
    assemble(&sc, params, shard, &recv, &scene, &insts, &csums, None)
}

/// Every ray of the receiving blocks `recv` and the instances `insts`: per block its texels'
/// sums, per instance its texels' (`None`: outside every block).
#[allow(clippy::type_complexity)]
fn trace(
    sc: &Scene<'_>,
    params: &DrtParams,
    recv: &[usize],
    insts: &[usize],
    progress: &dyn Progress,
) -> (Vec<Vec<Sums>>, Vec<Vec<Option<Sums>>>) {
    let (dict, level, clutter) = (sc.dict, sc.geo.level, sc.clutter);
    let dirs = crate::drt_walk::coherent_cosine(params.rays);
    let cdirs = crate::drt_walk::coherent_cosine(params.clutter_rays);
    // scene texels of every receiving block, flattened; clutter texels of the instances
    let items: Vec<(usize, usize)> =
        recv.iter().flat_map(|&x| (0..dict.shapes[level.blocks[x].shape].texels.len()).map(move |t| (x, t))).collect();
    let ctex: usize = insts.iter().map(|&i| clutter.instance_texels[i][1]).sum();
    let total = (items.len() + ctex) as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    let tick = |k: u64| {
        let v = done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k;
        progress.update("drt rays", v.min(total), total);
    };
    let flat: Vec<Sums> = items
        .par_chunks(64)
        .flat_map_iter(|chunk| {
            let mut acc = Acc::new(clutter.charts.len());
            let mut segs = Vec::with_capacity(8);
            let v: Vec<Sums> = chunk
                .iter()
                .map(|&xt| {
                    scene_texel(&[(sc, 1)], &dirs, params.seed, xt, None, &mut acc, &mut segs);
                    acc.take(dict, level)
                })
                .collect();
            tick(chunk.len() as u64);
            v
        })
        .collect();
    let mut it = flat.into_iter();
    let scene: Vec<Vec<Sums>> =
        recv.iter().map(|&x| it.by_ref().take(dict.shapes[level.blocks[x].shape].texels.len()).collect()).collect();
    // chunks never straddle instances
    let chunks: Vec<Vec<usize>> = insts
        .iter()
        .flat_map(|&i| {
            let [first, count] = clutter.instance_texels[i];
            (first..first + count).collect::<Vec<_>>().chunks(64).map(<[usize]>::to_vec).collect::<Vec<_>>()
        })
        .collect();
    let flat: Vec<Option<Sums>> = chunks
        .par_iter()
        .flat_map_iter(|chunk| {
            let mut acc = Acc::new(clutter.charts.len());
            let mut segs = Vec::with_capacity(8);
            let v: Vec<Option<Sums>> = chunk
                .iter()
                .map(|&ti| {
                    let (o, b) = clutter_origin(sc, ti);
                    let b = b?;
                    clutter_texel(&[(sc, 1)], &cdirs, params.seed, (ti, b, o), None, &mut acc, &mut segs);
                    Some(acc.take(dict, level))
                })
                .collect();
            tick(chunk.len() as u64);
            v
        })
        .collect();
    let mut it = flat.into_iter();
    let csums = insts.iter().map(|&i| it.by_ref().take(clutter.instance_texels[i][1]).collect()).collect();
    (scene, csums)
}

/// The operators of the receiving blocks `recv` and instances `insts` from their sums.
#[allow(clippy::too_many_arguments)]
fn assemble(
    sc: &Scene<'_>,
    params: &DrtParams,
    shard: DrtShard,
    recv: &[usize],
    scene: &[Vec<Sums>],
    insts: &[usize],
    csums: &[Vec<Option<Sums>>],
    reuse: Option<&Reuse<'_>>,
) -> Result<DrtBake, TransportError> {
    let (dict, level, clutter) = (sc.dict, sc.geo.level, sc.clutter);
    let rho = dict.albedo;
    let (n, nc) = (params.rays as f64, params.clutter_rays as f64);
    let per_block: Vec<BlockOut> = recv
        .par_iter()
        .zip(scene.par_iter())
        .map(|(&x, sums)| {
            if let Some(o) = reuse.and_then(|r| r.block(x)) {
                return Ok(o);
            }
            let rows: Vec<TexelRays> = sums
                .iter()
                .map(|s| TexelRays {
                    du_b: rows_of(s, dict, level, -rho / n),
                    du_c: charts_of(s, clutter, n),
                    back: s.back.max(0) as usize,
                })
                .collect();
            assemble_block(x, &rows, level, dict, params)
        })
        .collect::<Result<_, _>>()?;
    let mut receivers = Vec::new();
    let mut du_b = Vec::new();
    let mut du_c = Vec::new();
    let (mut inpainted, mut failures) = (0, 0);
    for o in per_block {
        inpainted += o.inpainted;
        failures += o.failures;
        du_b.extend(o.du_b);
        du_c.push(o.du_c);
        receivers.push(o.receiver);
    }

    // C_b per instance; a texel whose outside is in no block (a box face lying on a wall, or
    // clutter poking through a wall) receives no light from the level: a zero row, counted
    let outside = csums.iter().flatten().filter(|g| g.is_none()).count();
    let c_b: Vec<GatherOp> = insts
        .par_iter()
        .zip(csums.par_iter())
        .map(|(&i, sums)| {
            if let Some(g) = reuse.and_then(|r| r.instance(i)) {
                return Ok(g);
            }
            let gathers: Vec<Result<ClutterRays, usize>> = sums
                .iter()
                .map(|s| match s {
                    Some(s) => Ok((rows_of(s, dict, level, rho / nc), charts_of(s, clutter, nc))),
                    None => Err(i),
                })
                .collect();
            assemble_instance(i, &gathers, level, dict, params)
        })
        .collect::<Result<_, _>>()?;
    let scene_texels: usize = scene.iter().map(Vec::len).sum();
    let ctex: usize = csums.iter().map(Vec::len).sum();
    let rays_traced = (scene_texels * params.rays + ctex * params.clutter_rays) as u64;
    let metrics = DrtMetrics {
        blocks: receivers.len(),
        clutter_instances: clutter.len(),
        clutter_texels: clutter.texels.len(),
        clutter_charts: clutter.charts.len(),
        rays: params.rays,
        rays_traced,
        inpainted_texels: inpainted,
        inpaint_failures: failures,
        clutter_texels_outside: outside,
        neighborhood: params.neighborhood,
        delta_occlusion_records: du_b.len(),
        k_c: c_b.iter().map(|g| g.rank).max().unwrap_or(0),
        c_b_truncation_rel_error: c_b.iter().map(|g| g.truncation_rel_error).collect(),
        k_dc: du_c.iter().map(|r| r.rank).max().unwrap_or(0),
        du_c_truncation_rel_error: du_c.iter().map(|r| r.truncation_rel_error).collect(),
        c_c_truncation_rel_error: if params.clutter_to_clutter {
            c_b.iter().map(|g| g.c_c.truncation_rel_error).collect()
        } else {
            Vec::new()
        },
    };
    Ok(DrtBake { params: params.clone(), shard, receivers, du_b, du_c, c_b, metrics })
}

/// The records of a previous bake an incremental re-bake keeps: those of the receiving
/// blocks and instances whose rays' sums did not change (a record is a function of its own
/// sums, the dictionary and the parameters alone; the shards rely on the same fact).
#[derive(Debug)]
pub(crate) struct Reuse<'a> {
    prev: &'a DrtBake,
    /// Receiving blocks whose records are kept.
    blocks: std::collections::BTreeSet<usize>,
    /// Instances whose `C_b`/`C_c` are kept.
    insts: std::collections::BTreeSet<usize>,
}

impl Reuse<'_> {
    fn block(&self, x: usize) -> Option<BlockOut> {
        if !self.blocks.contains(&x) {
            return None;
        }
        let p = self.prev;
        let receiver = p.receivers.iter().find(|r| r.block == x)?.clone();
        let du_c = p.du_c.iter().find(|r| r.dst == x)?.clone();
        let du_b = p.du_b.iter().filter(|r| r.dst == x).cloned().collect();
        let count = |v: u8| receiver.mask.iter().filter(|&&m| m == v).count();
        Some(BlockOut { inpainted: count(1), failures: count(2), receiver, du_b, du_c })
    }

    fn instance(&self, i: usize) -> Option<GatherOp> {
        if !self.insts.contains(&i) {
            return None;
        }
        self.prev.c_b.iter().find(|g| g.instance == i).cloned()
    }
}

/// One receiving block's records.
struct BlockOut {
    receiver: Receiver,
    du_b: Vec<DeltaRecord>,
    du_c: ReflectRecord,
    inpainted: usize,
    failures: usize,
}

/// The records of receiving block `x` from its texels' rays (`rows` starts at its first
/// texel): `ΔU_b` per source block, `ΔU_c` factored, inpainting.
fn assemble_block(
    x: usize,
    rows: &[TexelRays],
    level: &Level,
    dict: &DrtDict,
    params: &DrtParams,
) -> Result<BlockOut, TransportError> {
    let sh = &dict.shapes[level.blocks[x].shape];
    let n = sh.texels.len();
    let rows = &rows[..n];
    let mut srcs: Vec<usize> = rows.iter().flat_map(|r| r.du_b.iter().map(|(s, _)| *s)).collect();
    let inside: Vec<bool> = rows.iter().map(|r| 2 * r.back > params.rays).collect();
    if params.inpaint && inside.iter().any(|&b| b) {
        srcs.push(x);
    }
    srcs.sort_unstable();
    srcs.dedup();
    let mut recs: Vec<DeltaRecord> = srcs
        .iter()
        .map(|&y| {
            let cols = dict.shapes[level.blocks[y].shape].k_b;
            let mut op = vec![0.0; n * cols];
            for (t, r) in rows.iter().enumerate() {
                if let Some((_, row)) = r.du_b.iter().find(|(s, _)| *s == y) {
                    op[t * cols..(t + 1) * cols].copy_from_slice(row);
                }
            }
            DeltaRecord { dst: x, src: y, rows: n, cols, op }
        })
        .collect();
    let mut charts: Vec<usize> = rows.iter().flat_map(|r| r.du_c.iter().map(|(j, _)| *j)).collect();
    charts.sort_unstable();
    charts.dedup();
    let mut refl = ReflectRecord::new(x, charts.clone(), n);
    let col = column_map(&charts);
    for (t, r) in rows.iter().enumerate() {
        for &(j, v) in &r.du_c {
            refl.op[t * charts.len() + col[j]] = v;
        }
    }
    let mut mask = vec![0u8; n];
    let (inpainted, failures) = if params.inpaint {
        inpaint(&sh.texels, &inside, sh, x, &mut recs, &mut refl, &mut mask)
    } else {
        for (m, &i) in mask.iter_mut().zip(&inside) {
            if i {
                *m = 2;
            }
        }
        (0, inside.iter().filter(|&&b| b).count())
    };
    // records that inpainting left all zero carry nothing
    recs.retain(|r| r.op.iter().any(|&v| v != 0.0));
    refl.factor(params.k_dc)?;
    Ok(BlockOut { receiver: Receiver { block: x, texels: n, mask }, du_b: recs, du_c: refl, inpainted, failures })
}

/// Column of each chart in a sorted, deduplicated chart list.
/// (dense: indexed by chart, `usize::MAX` for charts not in the list).
fn column_map(charts: &[usize]) -> Vec<usize> {
    let mut col = vec![usize::MAX; charts.last().map_or(0, |&j| j + 1)];
    for (c, &j) in charts.iter().enumerate() {
        col[j] = c;
    }
    col
}

/// `C_b` (and `C_c`) of instance `i` from its texels' rays.
fn assemble_instance(
    i: usize,
    gathers: &[Result<ClutterRays, usize>],
    level: &Level,
    dict: &DrtDict,
    params: &DrtParams,
) -> Result<GatherOp, TransportError> {
    let empty: ClutterRays = (Vec::new(), Vec::new());
    let rows: Vec<&ClutterRays> = gathers.iter().map(|g| g.as_ref().unwrap_or(&empty)).collect();
    let b_rows: Vec<&Vec<(usize, Vec<f64>)>> = rows.iter().map(|r| &r.0).collect();
    let mut g = gather_op(i, &b_rows, level, dict, params)?;
    if params.clutter_to_clutter {
        let mut charts: Vec<usize> = rows.iter().flat_map(|r| r.1.iter().map(|(j, _)| *j)).collect();
        charts.sort_unstable();
        charts.dedup();
        let mut cc = ReflectRecord::new(i, charts.clone(), rows.len());
        let col = column_map(&charts);
        for (t, r) in rows.iter().enumerate() {
            for &(j, v) in &r.1 {
                cc.op[t * charts.len() + col[j]] = v;
            }
        }
        cc.factor(params.k_c)?;
        g.c_c = cc;
    }
    Ok(g)
}

/// Ring-by-ring inpainting of the inside texels of one receiving block (module docs).
/// Returns (inpainted, failed).
fn inpaint(
    tex: &Texels,
    inside: &[bool],
    sh: &DrtShape,
    x: usize,
    recs: &mut [DeltaRecord],
    refl: &mut ReflectRecord,
    mask: &mut [u8],
) -> (usize, usize) {
    let r = tex.res;
    let mut valid: Vec<bool> = inside.iter().map(|&b| !b).collect();
    let k = sh.k_b;
    // shadowed own-block operator Ū = U_b + ΔU_b^{x←x}, per texel
    let own = recs.iter().position(|rc| rc.src == x);
    let mut inpainted = 0;
    loop {
        let mut ring: Vec<(usize, Vec<usize>)> = Vec::new();
        for t in 0..tex.len() {
            if valid[t] {
                continue;
            }
            let (f, i, j) = tex.coords(t);
            let mut nb = Vec::new();
            for dj in -1i64..=1 {
                for di in -1i64..=1 {
                    let (ii, jj) = (i as i64 + di, j as i64 + dj);
                    if (di, dj) == (0, 0) || ii < 0 || jj < 0 || ii >= r as i64 || jj >= r as i64 {
                        continue;
                    }
                    let u = tex.index(f, ii as usize, jj as usize);
                    if valid[u] {
                        nb.push(u);
                    }
                }
            }
            if !nb.is_empty() {
                ring.push((t, nb));
            }
        }
        if ring.is_empty() {
            break;
        }
        // compute the whole ring from the previous state, then apply it
        let mut updates: Vec<(usize, Vec<Vec<f64>>, Vec<f64>)> = Vec::with_capacity(ring.len());
        for (t, nb) in &ring {
            let m = nb.len() as f64;
            let per_rec: Vec<Vec<f64>> = recs
                .iter()
                .enumerate()
                .map(|(ri, rc)| {
                    let mut row = vec![0.0; rc.cols];
                    for &u in nb {
                        for c in 0..rc.cols {
                            let ub = if Some(ri) == own { sh.u_b[u * k + c] } else { 0.0 };
                            row[c] += (rc.op[u * rc.cols + c] + ub) / m;
                        }
                    }
                    if Some(ri) == own {
                        for c in 0..rc.cols {
                            row[c] -= sh.u_b[t * k + c];
                        }
                    }
                    row
                })
                .collect();
            let nc = refl.charts.len();
            let mut rr = vec![0.0; nc];
            for &u in nb {
                for c in 0..nc {
                    rr[c] += refl.op[u * nc + c] / m;
                }
            }
            updates.push((*t, per_rec, rr));
        }
        for (t, per_rec, rr) in updates {
            for (rc, row) in recs.iter_mut().zip(per_rec) {
                rc.op[t * rc.cols..(t + 1) * rc.cols].copy_from_slice(&row);
            }
            let nc = refl.charts.len();
            refl.op[t * nc..(t + 1) * nc].copy_from_slice(&rr);
            valid[t] = true;
            mask[t] = 1;
            inpainted += 1;
        }
    }
    let failed = valid.iter().filter(|&&v| !v).count();
    for (m, v) in mask.iter_mut().zip(&valid) {
        if !v {
            *m = 2;
        }
    }
    (inpainted, failed)
}

/// The factored `C_b` of one instance from its texels' gathered rows.
fn gather_op(
    instance: usize,
    rows: &[&Vec<(usize, Vec<f64>)>],
    level: &Level,
    dict: &DrtDict,
    params: &DrtParams,
) -> Result<GatherOp, TransportError> {
    let mut srcs: Vec<usize> = rows.iter().flat_map(|r| r.iter().map(|(s, _)| *s)).collect();
    srcs.sort_unstable();
    srcs.dedup();
    let mut src_offsets = vec![0];
    for &s in &srcs {
        let k = dict.shapes[level.blocks[s].shape].k_b;
        src_offsets.push(src_offsets.last().copied().unwrap_or(0) + k);
    }
    let kk = *src_offsets.last().unwrap_or(&0);
    let m = rows.len();
    let mut full = vec![0.0; m * kk];
    for (t, r) in rows.iter().enumerate() {
        for (s, row) in r.iter() {
            let Ok(si) = srcs.binary_search(s) else { continue };
            let o = src_offsets[si];
            full[t * kk + o..t * kk + o + row.len()].copy_from_slice(row);
        }
    }
    let (a, w, rank, truncation_rel_error) = match params.kc_mode {
        KcMode::Full => {
            let mut w = vec![0.0; kk * kk];
            for i in 0..kk {
                w[i * kk + i] = 1.0;
            }
            (full.clone(), w, kk, 0.0)
        }
        KcMode::First => {
            let mut cols = Vec::new();
            for (si, &s) in srcs.iter().enumerate() {
                let k = dict.shapes[level.blocks[s].shape].k_b;
                cols.extend((0..params.k_c.min(k)).map(|c| src_offsets[si] + c));
            }
            let r = cols.len();
            let mut a = vec![0.0; m * r];
            let mut w = vec![0.0; r * kk];
            for (ci, &c) in cols.iter().enumerate() {
                for t in 0..m {
                    a[t * r + ci] = full[t * kk + c];
                }
                w[ci * kk + c] = 1.0;
            }
            let e = factored_error(&full, &a, &w, m, kk, r);
            (a, w, r, e)
        }
        KcMode::Svd => truncated(&full, m, kk, params.k_c)?,
    };
    Ok(GatherOp {
        instance,
        srcs,
        src_offsets,
        a,
        w,
        rank,
        truncation_rel_error,
        full,
        c_c: ReflectRecord::new(instance, Vec::new(), m),
    })
}

/// Faces of a block that exist (for callers that walk texels face by face).
pub fn present_faces(missing: u8) -> Vec<usize> {
    (0..FACE_COUNT).filter(|f| missing & (1 << f) == 0).collect()
}

/// Sums `ΔU_b` records into a dense map `(dst, src) → op` (for tests and the reference).
pub fn delta_map(b: &DrtBake) -> BTreeMap<(usize, usize), &DeltaRecord> {
    b.du_b.iter().map(|r| ((r.dst, r.src), r)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clutter::{BoxFaces, ClutterShape, ClutterSpec, quat_y};
    use crate::level::Block;
    use crate::reference::point_polygon_form_factor;
    use crate::shape::face_uv;
    use crate::shape::{CLOSED, exit_face};
    use penumbra_geometry::TriMesh;
    use penumbra_math::progress::NoProgress;

    const R: usize = 5;
    const KB: usize = 3;

    /// A one-shape (closed cube) dictionary with hashed `L_imp` and `U_b`; the identities
    /// tested hold for any `L_imp`.
    fn dict(albedo: f64, ones: bool) -> DrtDict {
        let texels = Texels::new(CLOSED, R);
        let n = texels.len();
        let h = |i: usize, j: u64| unit_f64(hash4(7, 99, i as u64, j));
        let l_imp =
            (0..n * KB).map(|i| if ones { if i % KB == 0 { 1.0 } else { 0.0 } } else { h(i, 0) - 0.3 }).collect();
        let u_b = (0..n * KB).map(|i| h(i, 1)).collect();
        DrtDict {
            shapes: vec![DrtShape::new("closed".into(), texels, KB, l_imp, u_b)],
            missing: vec![0],
            face_res: R,
            albedo,
            crc32c: 0,
            volume_res: 2,
        }
    }

    fn room() -> (Level, Links) {
        let level = Level {
            blocks: vec![Block { shape: 0, rotation: 0, translation: [0.5; 3], scale: [1.0; 3] }],
            connections: vec![],
        };
        (level, vec![[None; 6]])
    }

    fn pillar(x: f64, z: f64, deg: f64) -> ClutterSpec {
        ClutterSpec {
            name: "p".into(),
            shape: ClutterShape::Box { size: [0.2, 0.6, 0.15], faces: BoxFaces::NoBottom },
            translate: [x, 0.0, z],
            rotate: quat_y(deg),
            scale: 1.0,
            albedo: [0.5, 0.4, 0.3],
        }
    }

    /// A square `[x0,x1]×[z0,z1]` at height `y`, facing `dir` (±1 along y).
    fn quad(x0: f64, x1: f64, z0: f64, z1: f64, y: f64, down: bool) -> ClutterSpec {
        let positions = vec![[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]];
        let indices = if down { vec![[0, 1, 2], [0, 2, 3]] } else { vec![[0, 2, 1], [0, 3, 2]] };
        ClutterSpec {
            name: "quad".into(),
            shape: ClutterShape::Mesh(TriMesh { positions, indices }),
            translate: [0.0; 3],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 1.0,
            albedo: [0.5; 3],
        }
    }

    fn params(rays: usize) -> DrtParams {
        DrtParams {
            rays,
            clutter_rays: rays,
            neighborhood: 0,
            k_c: KB,
            k_dc: 4096,
            clutter_to_clutter: false,
            kc_mode: KcMode::Full,
            inpaint: false,
            clutter_res: 4,
            clutter_basis_res: 1,
            seed: 3,
            half: false,
            vector_rays: None,
            volume_res: None,
        }
    }

    #[test]
    fn no_clutter_means_no_delta_operators() {
        let d = dict(0.7, false);
        let (level, links) = room();
        let b = bake(&level, &links, &d, &ClutterScene::empty(), &params(64), &NoProgress).unwrap();
        assert!(b.du_b.is_empty() && b.du_c.is_empty() && b.c_b.is_empty() && b.receivers.is_empty());
        // clutter in the room but rays that miss it carry nothing: a texel's row is zero
        // exactly when none of its rays meets the clutter
        let c = ClutterScene::new(&[pillar(0.5, 0.5, 20.0)], 4).unwrap();
        let b = bake(&level, &links, &d, &c, &params(64), &NoProgress).unwrap();
        let rec = &b.du_b[0];
        let tex = &d.shapes[0].texels;
        let ceiling = tex.face_range(3);
        // the ceiling's rays go down; some meet the pillar, so at least one row is non-zero
        assert!(ceiling.clone().any(|t| rec.op[t * KB..(t + 1) * KB].iter().any(|&v| v != 0.0)));
    }

    #[test]
    fn delta_occlusion_is_the_clutter_gather_difference_times_l_imp() {
        // ΔU_b = (F_clutter − F) L_imp with the same rays: F by exit faces of the unit cube and
        // bilinear weights, F_clutter the same without the rays the clutter blocks
        let d = dict(0.7, false);
        let (level, links) = room();
        let c = ClutterScene::new(&[pillar(0.4, 0.45, 30.0), pillar(0.75, 0.7, -10.0)], 4).unwrap();
        let p = params(128);
        let b = bake(&level, &links, &d, &c, &p, &NoProgress).unwrap();
        let rec = b.du_b.iter().find(|r| r.src == 0).unwrap();
        let tex = &d.shapes[0].texels;
        let n = tex.len();
        let dirs = crate::gather::DirectionSet::cosine(p.rays);
        let mut max_err: f64 = 0.0;
        let mut max_val: f64 = 0.0;
        for t in 0..n {
            let (f, _, _) = tex.coords(t);
            let x = tex.position(t);
            let fr = crate::shape::FACE_FRAMES[f];
            let rot = rotation(p.seed, 0, t as u64);
            let mut f_row = vec![0.0; n];
            let mut fc_row = vec![0.0; n];
            for dl in &dirs.dirs {
                let l = rotate_z(*dl, rot);
                let dw: [f64; 3] = core::array::from_fn(|k| l[0] * fr.u[k] + l[1] * fr.v[k] + l[2] * fr.n[k]);
                let (g, tt) = exit_face(x, dw);
                let q: [f64; 3] = core::array::from_fn(|k| x[k] + tt * dw[k]);
                let (u, v) = face_uv(g, q);
                let blocked = c.closest(x, dw, 1e-9, tt).is_some();
                for (s, w) in tex.bilinear(g, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)) {
                    f_row[s] += d.albedo * w / p.rays as f64;
                    if !blocked {
                        fc_row[s] += d.albedo * w / p.rays as f64;
                    }
                }
            }
            for m in 0..KB {
                let want: f64 = (0..n).map(|s| (fc_row[s] - f_row[s]) * d.shapes[0].l_imp[s * KB + m]).sum();
                let got = rec.op[t * KB + m];
                max_err = max_err.max((got - want).abs());
                max_val = max_val.max(want.abs());
            }
        }
        assert!(max_val > 0.01, "the clutter must shadow something ({max_val})");
        // exact but for the fixed point of the sums (crate::drt_state): each ray's bilinear
        // weights round by ≤ 2⁻¹⁷ each (4 taps), L_imp by half its scale's step
        let sh = &d.shapes[0];
        let lmax = sh.l_imp.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
        let bound = d.albedo * (lmax * 4.0 * 0.5 / crate::drt_state::W_SCALE + 0.5 / sh.l_q_scale);
        assert!(max_err <= bound, "{max_err} > {bound}");
    }

    #[test]
    fn delta_reflection_of_a_planar_face_is_its_form_factor() {
        // a horizontal square facing down over the floor: under constant radiosity the floor
        // centre receives ρ_c·E·FF(x → square) (Lambert's point-to-polygon form factor)
        let d = dict(0.7, false);
        let (level, links) = room();
        let (x0, x1, z0, z1, y) = (0.3, 0.7, 0.25, 0.75, 0.4);
        let c = ClutterScene::new(&[quad(x0, x1, z0, z1, y, true)], 4).unwrap();
        assert_eq!(c.charts.len(), 1);
        let mut p = params(1 << 15);
        p.rays = 1 << 15;
        let b = bake(&level, &links, &d, &c, &p, &NoProgress).unwrap();
        let tex = &d.shapes[0].texels;
        let refl = &b.du_c[0];
        let m = c.charts[0].count as f64;
        for t in tex.face_range(2) {
            let x = tex.position(t);
            let poly = [[x0, y, z0], [x0, y, z1], [x1, y, z1], [x1, y, z0]];
            let ff = point_polygon_form_factor(x, [0.0, 1.0, 0.0], &poly);
            // c = ρ_c Σ_t B_t E = ρ_c √m E for constant E = 1 on the chart
            let got = refl.op[t] * 0.5 * m.sqrt();
            let want = 0.5 * ff;
            assert!((got - want).abs() < 0.01 * want + 2e-3, "texel {t}: {got} vs {want}");
        }
    }

    #[test]
    fn clutter_gather_under_uniform_walls_is_albedo_times_the_visible_wall_fraction() {
        // L_imp's first mode is 1 on every wall: C_b's first column is ρ × the fraction of
        // cosine rays from a clutter texel that reach a wall. The top of a low box under a
        // large horizontal plate sees the walls except the plate: 1 − FF(x → plate).
        let d = dict(0.8, true);
        let (level, links) = room();
        let low = ClutterSpec {
            name: "low".into(),
            shape: ClutterShape::Box { size: [0.3, 0.1, 0.3], faces: BoxFaces::All },
            translate: [0.5, 0.0, 0.5],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 1.0,
            albedo: [0.5; 3],
        };
        let (x0, x1, z0, z1, y) = (0.2, 0.8, 0.15, 0.85, 0.35);
        let c = ClutterScene::new(&[low, quad(x0, x1, z0, z1, y, true)], 4).unwrap();
        let mut p = params(1 << 14);
        p.kc_mode = KcMode::Full;
        let b = bake(&level, &links, &d, &c, &p, &NoProgress).unwrap();
        let g = &b.c_b[0];
        let kk = *g.src_offsets.last().unwrap();
        let [first, _] = c.instance_texels[0];
        let top = c.charts.iter().position(|ch| ch.instance == 0 && c.texels[ch.first].normal[1] > 0.5).unwrap();
        let ch = c.charts[top];
        for t in ch.first..ch.first + ch.count {
            let x = c.texels[t].position;
            let poly = [[x0, y, z0], [x0, y, z1], [x1, y, z1], [x1, y, z0]];
            let want = 0.8 * (1.0 - point_polygon_form_factor(x, [0.0, 1.0, 0.0], &poly));
            let got = g.full[(t - first) * kk];
            assert!((got - want).abs() < 0.01, "texel {t}: {got} vs {want}");
        }
    }

    #[test]
    fn inside_texels_are_inpainted_from_their_neighbours() {
        // a wide pillar covers floor texels; with inpainting on they are filled and flagged
        let d = dict(0.7, false);
        let (level, links) = room();
        let wide = ClutterSpec {
            name: "wide".into(),
            shape: ClutterShape::Box { size: [0.45, 0.5, 0.45], faces: BoxFaces::NoBottom },
            translate: [0.5, 0.0, 0.5],
            rotate: [0.0, 0.0, 0.0, 1.0],
            scale: 1.0,
            albedo: [0.5; 3],
        };
        let c = ClutterScene::new(&[wide], 4).unwrap();
        let mut p = params(128);
        p.inpaint = true;
        let b = bake(&level, &links, &d, &c, &p, &NoProgress).unwrap();
        let tex = &d.shapes[0].texels;
        let mask = &b.receivers[0].mask;
        // floor texel centres at (i+½)/5: 0.3, 0.5, 0.7 in x and z are under the box
        // [0.275, 0.725]² — 9 texels
        let under: Vec<usize> = tex.face_range(2).filter(|&t| mask[t] != 0).collect();
        assert_eq!(under.len(), 9, "{under:?}");
        assert!(
            under.iter().all(|&t| mask[t] == 1) && b.metrics.inpainted_texels == 9 && b.metrics.inpaint_failures == 0
        );
        // the centre texel has no outside neighbour: it is filled in the second ring, from
        // the first ring's values — so its shadowed operator equals the first ring's mean
        let own = b.du_b.iter().find(|r| r.src == 0).unwrap();
        let centre = tex.index(2, 2, 2);
        let ring: Vec<usize> = under.iter().copied().filter(|&t| t != centre).collect();
        for m in 0..KB {
            let ubar = |t: usize| own.op[t * KB + m] + d.shapes[0].u_b[t * KB + m];
            let mean = ring.iter().map(|&t| ubar(t)).sum::<f64>() / ring.len() as f64;
            assert!((ubar(centre) - mean).abs() < 1e-12);
        }
    }

    fn state_instances(c: &ClutterScene) -> Vec<crate::drt_state::StateInstance> {
        c.specs
            .iter()
            .map(|s| crate::drt_state::StateInstance {
                shape_key: "box".into(),
                translate: s.translate,
                rotate: s.rotate,
                scale: s.scale,
            })
            .collect()
    }

    fn same_bake(a: &DrtBake, b: &DrtBake) {
        assert_eq!(a.receivers, b.receivers);
        assert_eq!(a.du_b, b.du_b);
        assert_eq!(a.du_c, b.du_c);
        assert_eq!(a.c_b, b.c_b);
        assert_eq!(a.metrics.rays_traced, b.metrics.rays_traced);
    }

    #[test]
    fn moving_a_pillar_re_bakes_to_the_full_bake_of_the_new_scene() {
        let d = dict(0.7, false);
        let (level, links) = room();
        let mut p = params(64);
        p.clutter_to_clutter = true;
        p.inpaint = true;
        p.kc_mode = KcMode::Svd;
        p.k_dc = 4;
        let a = [pillar(0.3, 0.3, 10.0), pillar(0.7, 0.35, -25.0), pillar(0.5, 0.75, 0.0)];
        let old = ClutterScene::new(&a, 4).unwrap();
        let (_, mut state) =
            bake_with_state(&level, &links, &d, &old, &p, "k".into(), state_instances(&old), &NoProgress).unwrap();
        // through the file format
        state = DrtState::from_bytes(&state.to_bytes()).unwrap();
        let mut moved = a.clone();
        moved[1].translate = [0.62, 0.0, 0.55];
        moved[1].rotate = quat_y(40.0);
        let new = ClutterScene::new(&moved, 4).unwrap();
        let (inc, stats) =
            bake_incremental(&level, &links, &d, &old, &new, &[1], &mut state, &p, None, &NoProgress).unwrap();
        let (full, full_state) =
            bake_with_state(&level, &links, &d, &new, &p, "k".into(), state_instances(&new), &NoProgress).unwrap();
        same_bake(&inc, &full);
        assert_eq!(state.blocks, full_state.blocks);
        assert_eq!(state.clutter, full_state.clutter);
        // fewer rays than a full bake, and some texels did change
        assert!(stats.rays_cast < stats.rays_full, "{stats:?}");
        assert!(stats.texels_changed > 0 && stats.blocks_traced_in_full == 0, "{stats:?}");
        // and back again: the first scene's bake
        let (back, _) =
            bake_incremental(&level, &links, &d, &new, &old, &[1], &mut state, &p, None, &NoProgress).unwrap();
        let first = bake(&level, &links, &d, &old, &p, &NoProgress).unwrap();
        same_bake(&back, &first);
        // an instance count that differs is refused (the caller bakes in full)
        let fewer = ClutterScene::new(&a[..2], 4).unwrap();
        let e = bake_incremental(&level, &links, &d, &old, &fewer, &[], &mut state, &p, None, &NoProgress).unwrap_err();
        assert!(e.to_string().contains("3 clutter instances before, 2 now"), "{e}");
    }

    #[test]
    fn an_incremental_re_bake_reassembles_only_the_records_whose_sums_changed() {
        // two closed rooms side by side, a pillar in each: moving the first leaves every ray
        // of the second room unchanged, so its block's and its pillar's records are copied
        let d = dict(0.7, false);
        let room = |x: f64| Block { shape: 0, rotation: 0, translation: [x, 0.5, 0.5], scale: [1.0; 3] };
        let level = Level { blocks: vec![room(0.5), room(2.5)], connections: vec![] };
        let links = vec![[None; 6]; 2];
        let mut p = params(64);
        p.clutter_to_clutter = true;
        let a = [pillar(0.3, 0.4, 10.0), pillar(2.6, 0.5, -20.0)];
        let old = ClutterScene::new(&a, 4).unwrap();
        let (prev, mut state) =
            bake_with_state(&level, &links, &d, &old, &p, "k".into(), state_instances(&old), &NoProgress).unwrap();
        let mut moved = a.clone();
        moved[0].translate = [0.65, 0.0, 0.45];
        let new = ClutterScene::new(&moved, 4).unwrap();
        let mut st2 = state.clone();
        let (inc, stats) =
            bake_incremental(&level, &links, &d, &old, &new, &[0], &mut state, &p, Some(&prev), &NoProgress).unwrap();
        let full = bake(&level, &links, &d, &new, &p, &NoProgress).unwrap();
        same_bake(&inc, &full);
        assert_eq!(inc.metrics.c_b_truncation_rel_error, full.metrics.c_b_truncation_rel_error);
        assert_eq!(inc.metrics.du_c_truncation_rel_error, full.metrics.du_c_truncation_rel_error);
        // block 1 and instance 1 copied; block 0 and the moved instance 0 assembled
        assert_eq!((stats.records_reused, stats.records_assembled), (2, 2), "{stats:?}");
        // a previous bake with other parameters lends nothing (and the result is the same)
        let mut q = p.clone();
        q.k_dc = 3;
        let other = bake(&level, &links, &d, &old, &q, &NoProgress).unwrap();
        let (inc2, stats2) =
            bake_incremental(&level, &links, &d, &old, &new, &[0], &mut st2, &p, Some(&other), &NoProgress).unwrap();
        same_bake(&inc2, &full);
        assert_eq!((stats2.records_reused, stats2.records_assembled), (0, 4), "{stats2:?}");
    }

    #[test]
    fn state_files_round_trip_and_refuse_corruption() {
        let d = dict(0.7, false);
        let (level, links) = room();
        let c = ClutterScene::new(&[pillar(0.4, 0.45, 30.0)], 4).unwrap();
        let (_, st) =
            bake_with_state(&level, &links, &d, &c, &params(32), "key".into(), state_instances(&c), &NoProgress)
                .unwrap();
        let bytes = st.to_bytes();
        assert_eq!(DrtState::from_bytes(&bytes).unwrap(), st);
        let mut bad = bytes.clone();
        bad[bytes.len() / 2] ^= 1;
        assert!(DrtState::from_bytes(&bad).unwrap_err().to_string().contains("checksum"));
        assert!(DrtState::from_bytes(&bytes[..bytes.len() - 9]).is_err());
        assert!(DrtState::from_bytes(b"PENUMBRA").unwrap_err().to_string().contains("not a penumbra DRT state"));
    }

    #[test]
    fn sums_add_is_exact_and_canonical() {
        use crate::drt_state::Sums;
        let a = Sums { rows: vec![(1, vec![3, -2]), (4, vec![1, 1])], charts: vec![(0, 2), (5, 1)], back: 3 };
        let b = Sums {
            rows: vec![(0, vec![7, 7]), (1, vec![-3, 2]), (9, vec![0, 1])],
            charts: vec![(5, -1), (6, 4)],
            back: -3,
        };
        let mut s = a.clone();
        s.add(&b);
        assert_eq!(s.rows, vec![(0, vec![7, 7]), (4, vec![1, 1]), (9, vec![0, 1])]);
        assert_eq!(s.charts, vec![(0, 2), (6, 4)]);
        assert_eq!(s.back, 0);
        // subtracting what was added gives the start again
        let neg = Sums {
            rows: b.rows.iter().map(|(k, r)| (*k, r.iter().map(|v| -v).collect())).collect(),
            charts: b.charts.iter().map(|&(k, c)| (k, -c)).collect(),
            back: -b.back,
        };
        s.add(&neg);
        assert_eq!(s, a);
    }
}
