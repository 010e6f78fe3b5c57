//! The MRT dictionary bake (`penumbra mrt dict`): for every shape of a dictionary, the
//! prior, `F`, the reduced operators with enrichment, vector irradiance and volume probes,
//! and the quality measurements (MRT thesis ch. 3–4, App. A–B).

use crate::TransportError;
use crate::balance::{BalanceStats, balance_transport};
use crate::gather::{DirectionSet, Gather, probe_sh, texel_sh, transport_matrix};
use crate::interface::{
    InterfaceBake, InterfaceMetrics, InterfaceParams, ShapeInput, VectorResponseParams, bake_interfaces, side_openings,
};
use crate::operators::{Prior, Reduced, enrich, fallback_basis, prior_from_samples, reduce};
use crate::prior::{DirectLight, LightLayout, SphereLight, prior_lights, test_lights};
use crate::reference::{ff_parallel_rectangles, ff_perpendicular_rectangles, one_bounce, point_polygon_form_factor};
use crate::shape::{CLOSED, DictionaryKind, FACE_COUNT, Shape, Texels, face_axis, face_point};
use crate::svd::{energy_count, frobenius, mul, singular_values_gram};
use faer::{Mat, MatRef};
use penumbra_math::ohlsh::quadratic_to_ohlsh;
use penumbra_math::progress::Progress;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};

/// Kind version of the `MRTD` sections this bake writes (2: optional interface sections;
/// 3: `<shape>.l_imp` for DRT; version 1 and 2 assets still load, version 1 as a dictionary
/// without interfaces). A dictionary with the interfaces' vector and volume response
/// (`iface.u_rvec`, `iface.u_rvol`) is [`MRTD_KIND_VERSION_VECTORS`].
pub const MRTD_KIND_VERSION: u32 = 3;

/// Kind version of an `MRTD` with `iface.u_rvec` and `iface.u_rvol` (optional sections:
/// readers of version 3 skip them).
pub const MRTD_KIND_VERSION_VECTORS: u32 = 4;

/// Energy fractions of Table 3.2.
pub const TABLE_3_2_FRACTIONS: [f64; 3] = [0.80, 0.90, 0.95];

/// Bake parameters (defaults: the thesis settings, §3.6.1).
#[derive(Debug, Clone, PartialEq)]
pub struct DictParams {
    /// Which shapes.
    pub dictionary: DictionaryKind,
    /// Texels per face edge (thesis: 16).
    pub face_res: usize,
    /// Prior vectors `k_d` (thesis: 64).
    pub k_d: usize,
    /// Indirect modes `k_b` (thesis: 32).
    pub k_b: usize,
    /// Gather rays per texel for `F` (thesis: 16K).
    pub rays: usize,
    /// Diffuse albedo in `F`.
    pub albedo: f64,
    /// Enrichment iterations (App. A).
    pub enrich: usize,
    /// Face-restricted prior vectors per face in the enrichment fallback basis (0 = face
    /// constants only, as in the thesis).
    pub fallback_modes: usize,
    /// How gathers read the texels they hit.
    pub gather: Gather,
    /// Balance `F`'s row and column sums to the exact wall fractions ([`crate::balance`]),
    /// which makes `‖F l‖₁ ≤ ρ‖l‖₁` hold for every `l ≥ 0`.
    pub balance: bool,
    /// Runtime rule: a face's indirect light excludes the reduced operator's transfer from
    /// that face to itself ([`predict_excluding_same_face`]); recorded in the asset.
    pub exclude_same_face: bool,
    /// Prior light positions.
    pub layout: LightLayout,
    /// Radius of the prior and test sphere lights (cube edge = 1).
    pub light_radius: f64,
    /// Rays per texel of the vector-irradiance gather.
    pub vector_rays: usize,
    /// Volume probes per axis (`U_bvol` grid).
    pub volume_res: usize,
    /// Rays per volume probe.
    pub probe_rays: usize,
    /// Lights for the error measurements (per shape).
    pub test_lights: usize,
    /// Rays per texel of the path-traced reference.
    pub reference_rays: usize,
    /// Seed of every hashed random draw.
    pub seed: u64,
    /// Bake the interface operators (when the dictionary has missing side faces).
    pub interfaces: bool,
    /// Interface parameters.
    pub interface: InterfaceParams,
    /// Bake the interfaces' vector and volume response (`U_r⃗`, `U_rvol`, MRT thesis
    /// §3.5.4–3.5.5 driven by `r`) with `vector_rays`, `volume_res`, `probe_rays`; MRTD kind
    /// version 4. Off: the kind-version-3 bytes.
    pub interface_vectors: bool,
    /// Bake only these shapes (by name, in the dictionary's order; `None`: all of them). The
    /// closed cube is always baked (Table 3.2 and App. A are measured on it). Each shape keeps
    /// its index in the whole dictionary as its hash stream, so a shape's operators are the
    /// bytes the whole dictionary would hold; the interfaces' shared basis is fitted to the
    /// openings of the shapes baked.
    pub only: Option<Vec<String>>,
}

impl DictParams {
    /// Defaults for `dictionary`.
    pub fn new(dictionary: DictionaryKind) -> Self {
        Self {
            dictionary,
            face_res: 16,
            k_d: 64,
            k_b: 32,
            rays: 16384,
            albedo: 1.0,
            enrich: 1,
            fallback_modes: 16,
            gather: Gather::Bilinear,
            balance: true,
            exclude_same_face: true,
            layout: LightLayout::Lattice,
            light_radius: 0.05,
            vector_rays: 1024,
            volume_res: 4,
            probe_rays: 4096,
            test_lights: 8,
            reference_rays: 1024,
            seed: 0,
            interfaces: true,
            interface: InterfaceParams::default(),
            interface_vectors: true,
            only: None,
        }
    }

    /// The shapes this bake bakes, each with its index in the whole dictionary (its hash
    /// stream): all of them, or those `only` names plus the closed cube.
    pub fn shapes(&self) -> Vec<(u64, Shape)> {
        let all = self.dictionary.shapes();
        all.iter()
            .enumerate()
            .filter(|(_, s)| self.only.as_ref().is_none_or(|o| s.missing == 0 || o.iter().any(|n| n == s.name)))
            .map(|(i, s)| (i as u64, *s))
            .collect()
    }

    /// The normalised parameters as JSON (the asset's `meta.params`; hashed for cache keys).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::json!({
            "dictionary": self.dictionary.name(),
            "face_res": self.face_res,
            "k_d": self.k_d,
            "k_b": self.k_b,
            "rays": self.rays,
            "albedo": self.albedo,
            "enrich": self.enrich,
            "fallback_modes": self.fallback_modes,
            "gather": self.gather.name(),
            "balance": self.balance,
            "exclude_same_face": self.exclude_same_face,
            "light_layout": self.layout.name(),
            "light_radius": self.light_radius,
            "vector_rays": self.vector_rays,
            "volume_res": self.volume_res,
            "probe_rays": self.probe_rays,
            "test_lights": self.test_lights,
            "reference_rays": self.reference_rays,
            "seed": self.seed,
            "interfaces": self.interfaces,
            "k_rlf": self.interface.k_rlf,
            "k_r": self.interface.k_r,
            "lf_spatial": self.interface.grid.spatial,
            "lf_dir": self.interface.grid.dir,
            "lf_super": self.interface.grid.sub,
            "interface_enrich": self.interface.enrich,
            "response_rays": self.interface.response_rays,
        });
        // only when on: a dictionary baked without it keeps its kind-version-3 bytes and key
        if self.interface_vectors {
            v["interface_vectors"] = serde_json::Value::Bool(true);
        }
        // only when given: a whole dictionary keeps its bytes and key
        if self.only.is_some() {
            let names: Vec<&str> = self.shapes().iter().map(|(_, s)| s.name).collect();
            v["shapes"] = serde_json::json!(names);
        }
        v
    }

    /// Checks every range; the message names the parameter and the allowed range.
    pub fn validate(&self) -> Result<(), TransportError> {
        let bad = |what: &str, v: String, range: &str| {
            Err(TransportError::Param(format!("{what} {v} is out of range (allowed: {range})")))
        };
        if !(2..=24).contains(&self.face_res) {
            return bad("face_res", self.face_res.to_string(), "2..=24");
        }
        if !(1..=256).contains(&self.k_d) {
            return bad("kd", self.k_d.to_string(), "1..=256");
        }
        if !(1..=self.k_d).contains(&self.k_b) {
            return bad("kb", self.k_b.to_string(), &format!("1..=kd = 1..={}", self.k_d));
        }
        if !(16..=1 << 20).contains(&self.rays) {
            return bad("rays", self.rays.to_string(), "16..=1048576");
        }
        if !(self.albedo > 0.0 && self.albedo <= 1.0) {
            return bad("albedo", self.albedo.to_string(), "0 < A <= 1");
        }
        if self.enrich > 8 {
            return bad("enrich", self.enrich.to_string(), "0..=8");
        }
        if self.exclude_same_face && self.enrich == 0 {
            return Err(TransportError::Param(
                "exclude_same_face needs enrichment (enrich >= 1): without the face-local prior vectors \
                 it multiplies the error (docs/mrt.md, \"Enrichment\"); keep the same-face transfer \
                 (--keep-same-face / exclude_same_face = false) with enrich 0"
                    .into(),
            ));
        }
        if self.fallback_modes > self.k_d {
            return bad("fallback_modes", self.fallback_modes.to_string(), &format!("0..=kd = 0..={}", self.k_d));
        }
        let max_r = self.layout.min_wall_distance().min(0.08);
        if !(self.light_radius > 0.0 && self.light_radius <= max_r) {
            return bad("light_radius", self.light_radius.to_string(), "0 < r <= 0.08");
        }
        if !(16..=65536).contains(&self.vector_rays) {
            return bad("vector_rays", self.vector_rays.to_string(), "16..=65536");
        }
        if !(1..=16).contains(&self.volume_res) {
            return bad("volume_res", self.volume_res.to_string(), "1..=16");
        }
        if !(16..=65536).contains(&self.probe_rays) {
            return bad("probe_rays", self.probe_rays.to_string(), "16..=65536");
        }
        if !(1..=64).contains(&self.test_lights) {
            return bad("test_lights", self.test_lights.to_string(), "1..=64");
        }
        if !(2..=65536).contains(&self.reference_rays) {
            return bad("reference_rays", self.reference_rays.to_string(), "2..=65536");
        }
        let ip = &self.interface;
        if !(1..=512).contains(&ip.k_rlf) {
            return bad("k_rlf", ip.k_rlf.to_string(), "1..=512");
        }
        if !(1..=ip.k_rlf).contains(&ip.k_r) {
            return bad("k_r", ip.k_r.to_string(), &format!("1..=k_rlf = 1..={}", ip.k_rlf));
        }
        if !(2..=32).contains(&ip.grid.spatial) {
            return bad("lf_spatial", ip.grid.spatial.to_string(), "2..=32");
        }
        if !(2..=64).contains(&ip.grid.dir) {
            return bad("lf_dir", ip.grid.dir.to_string(), "2..=64");
        }
        if !(1..=8).contains(&ip.grid.sub) {
            return bad("lf_super", ip.grid.sub.to_string(), "1..=8");
        }
        if ip.enrich > 8 {
            return bad("interface_enrich", ip.enrich.to_string(), "0..=8");
        }
        if !(16..=65536).contains(&ip.response_rays) {
            return bad("response_rays", ip.response_rays.to_string(), "16..=65536");
        }
        if let Some(only) = &self.only {
            let all = self.dictionary.shapes();
            if let Some(n) = only.iter().find(|n| !all.iter().any(|s| s.name == n.as_str())) {
                let known: Vec<&str> = all.iter().map(|s| s.name).collect();
                return Err(TransportError::Param(format!(
                    "shape {n:?} is not in the {} dictionary (known: {})",
                    self.dictionary.name(),
                    known.join(", ")
                )));
            }
        }
        Ok(())
    }
}

/// Measurements of one shape.
#[derive(Debug, Clone, Serialize)]
pub struct ShapeMetrics {
    /// Texel count n.
    pub texels: usize,
    /// Prior lights (columns of `L_d`).
    pub prior_lights: usize,
    /// Prior vectors kept (≤ k_d; the numerical rank of `L_d` caps it).
    pub k_d: usize,
    /// Indirect modes kept.
    pub k_b: usize,
    /// `‖U_b T_d→b l_d − F l_d‖ / ‖F l_d‖` over the test lights (not prior samples).
    pub reconstruction_rel_error: f64,
    /// The same under the plain rule `U_b T_d→b l_d` (no same-face exclusion), for comparison.
    pub reconstruction_rel_error_plain: f64,
    /// `‖U_b T_d→b l_d − E_ref‖ / ‖E_ref‖` against the path-traced one-bounce reference.
    pub reference_rel_error: f64,
    /// `‖F l_d − E_ref‖ / ‖E_ref‖`: the part of the error that `F`'s discretisation makes.
    pub transport_reference_rel_error: f64,
    /// The reference's own Monte-Carlo error estimate (half the difference of two halves).
    pub reference_noise_rel: f64,
    /// Irradiance at the unperturbed normal from `U_b⃗` against `U_b`.
    pub vector_irradiance_rel_error: f64,
    /// Largest column sum of the stored `F` divided by the albedo (`≤ 1` means
    /// `‖F l‖₁ ≤ ρ‖l‖₁`). With the balance on (the default) this holds by construction of the
    /// Sinkhorn balance: it checks the balance, not the gather (see `raw_gather`).
    pub f_max_column_sum: f64,
    /// What energy balancing changed (`null` when `balance` is off).
    pub f_balance: Option<BalanceStats>,
    /// The raw gather (before the balance) against exact form factors: the physical check
    /// the balance cannot make true by construction.
    pub raw_gather: RawGather,
}

/// The raw (unbalanced) one-bounce gather `F` against exact form factors (MRT thesis §3.3:
/// `F` gathers `ρ/π·L` over each texel's cosine-weighted hemisphere). A face-constant input
/// is read exactly by the bilinear and the exact gathers alike, so `Σ_{j∈h} F_ij / ρ` is the
/// form factor from texel `i`'s centre to face `h`, up to the gather's ray sampling.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RawGather {
    /// Largest `|Σ_j F_ij/ρ − Σ_walls FF(x_i → wall)|` over the texels `i` (Lambert's exact
    /// point-to-polygon form factors; the sum is 1 in the closed cube).
    pub row_max_abs_error: f64,
    /// Largest `|Σ_{j∈h} F_ij/ρ − FF(x_i → h)|` over texels `i` and walls `h`.
    pub point_face_max_abs_error: f64,
    /// Mean over the ordered pairs of opposite walls `(g, h)` of the face-to-face form factor
    /// measured from `F`: `(1/n_g) Σ_{i∈g} Σ_{j∈h} F_ij / ρ` (texel centres as a midpoint
    /// rule over `g`); `null` without such a pair.
    pub face_ff_opposite: Option<f64>,
    /// The same over the ordered pairs of adjacent walls.
    pub face_ff_adjacent: Option<f64>,
    /// The exact values (unit cube): opposite 0.19982, adjacent 0.20004 (Howell C-11, C-14).
    pub face_ff_opposite_exact: f64,
    /// Adjacent, exact.
    pub face_ff_adjacent_exact: f64,
    /// Largest `|measured − exact|` over every ordered pair of walls.
    pub face_ff_max_abs_error: f64,
}

/// [`RawGather`] of a gathered (not yet balanced) `F` with albedo `albedo`.
pub fn raw_gather_check(tex: &Texels, f: MatRef<'_, f64>, albedo: f64) -> RawGather {
    let walls = tex.faces.clone();
    let poly =
        |h: usize| [face_point(h, 0.0, 0.0), face_point(h, 1.0, 0.0), face_point(h, 1.0, 1.0), face_point(h, 0.0, 1.0)];
    let opp_exact = ff_parallel_rectangles(1.0, 1.0, 1.0);
    let adj_exact = ff_perpendicular_rectangles(1.0, 1.0, 1.0);
    // per texel and wall: F's block row sum / ρ
    let n = tex.len();
    let mut block = vec![[0.0f64; FACE_COUNT]; n];
    for (i, b) in block.iter_mut().enumerate() {
        for &h in &walls {
            b[h] = tex.face_range(h).map(|j| f[(i, j)]).sum::<f64>() / albedo;
        }
    }
    let (mut row_err, mut point_err) = (0.0f64, 0.0f64);
    let mut face = [[0.0f64; FACE_COUNT]; FACE_COUNT];
    for (i, b) in block.iter().enumerate() {
        let (g, _, _) = tex.coords(i);
        let (x, nn) = (tex.position(i), tex.normal(i));
        let mut want = 0.0;
        for &h in walls.iter().filter(|&&h| h != g) {
            let ff = point_polygon_form_factor(x, nn, &poly(h));
            point_err = point_err.max((b[h] - ff).abs());
            want += ff;
            face[g][h] += b[h];
        }
        row_err = row_err.max((b.iter().sum::<f64>() - want).abs());
    }
    let (mut opp, mut adj, mut worst) = (Vec::new(), Vec::new(), 0.0f64);
    for &g in &walls {
        for &h in walls.iter().filter(|&&h| h != g) {
            let v = face[g][h] / tex.face_range(g).len() as f64;
            let opposite = face_axis(g).0 == face_axis(h).0;
            worst = worst.max((v - if opposite { opp_exact } else { adj_exact }).abs());
            if opposite { opp.push(v) } else { adj.push(v) }
        }
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    RawGather {
        row_max_abs_error: row_err,
        point_face_max_abs_error: point_err,
        face_ff_opposite: mean(&opp),
        face_ff_adjacent: mean(&adj),
        face_ff_opposite_exact: opp_exact,
        face_ff_adjacent_exact: adj_exact,
        face_ff_max_abs_error: worst,
    }
}

/// Table 3.2 of the thesis: singular values holding 80/90/95 % of `Σσ²`.
#[derive(Debug, Clone, Serialize)]
pub struct Table32 {
    /// `F`.
    #[serde(rename = "F")]
    pub f: [usize; 3],
    /// `L_d`.
    #[serde(rename = "L_d")]
    pub l_d: [usize; 3],
    /// `M` (before enrichment, as in the thesis).
    #[serde(rename = "M")]
    pub m: [usize; 3],
    /// Samples n of the closed cube (6 × face_res²).
    pub n: usize,
}

/// The five-red-faces case of App. A (Fig. A.1), measured on the closed cube.
#[derive(Debug, Clone, Serialize)]
pub struct RedBox {
    /// RGB relative error of indirect light on the white face, without enrichment (and
    /// without the same-face exclusion: the thesis's unenriched runtime).
    pub rel_error_before: f64,
    /// The same with the final operators under the dictionary's runtime rule
    /// (`exclude_same_face`).
    pub rel_error_after: f64,
    /// Non-red indirect light arriving on the white face relative to the red (the reference
    /// has none: a plane cannot light itself), without enrichment.
    pub non_red_on_white_before: f64,
    /// The same with the enriched operators.
    pub non_red_on_white_after: f64,
    /// Relative error of the red channel alone on the white face (red light is an ordinary
    /// light: this is the dictionary's general error for these lights there), without
    /// enrichment.
    pub red_on_white_before: f64,
    /// The same with the enriched operators.
    pub red_on_white_after: f64,
    /// The enriched operators evaluated without the same-face exclusion (the thesis's
    /// runtime rule), for comparison: what enrichment alone does.
    pub enriched_without_exclusion: RedBoxError,
    /// The unenriched operators evaluated with the same-face exclusion: what the exclusion
    /// alone does (a measurement only; a dictionary cannot be baked this way, see
    /// [`DictParams::validate`]).
    pub excluded_without_enrichment: RedBoxError,
    /// The case that can fail under the exclusion (App. A's test cannot: with one white face
    /// both the reference and the excluded prediction of its non-red light are zero): floor
    /// and ceiling white, four red walls; the green light one white face sends to the other is
    /// real and must be predicted.
    pub two_white: TwoWhite,
}

/// Errors of the two-white-faces case (floor and ceiling white, four walls red), per runtime.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TwoWhite {
    /// Green on the white faces against `F·green`, relative, without enrichment (plain rule).
    pub green_rel_error_before: f64,
    /// The same, enriched operators, plain rule (what enrichment alone does).
    pub green_rel_error_enriched: f64,
    /// The same, unenriched operators with the same-face exclusion (what the exclusion alone
    /// does; a measurement only).
    pub green_rel_error_excluded: f64,
    /// The same, enriched operators with the same-face exclusion (enrichment and exclusion).
    pub green_rel_error_enriched_excluded: f64,
    /// RGB error on the white faces, runtimes in the order neither, enrichment only,
    /// enrichment + exclusion (`green_rel_error_before`, `_enriched`, `_enriched_excluded`).
    pub rgb_rel_error: [f64; 3],
    /// RGB error on the white faces, exclusion only.
    pub rgb_rel_error_excluded: f64,
}

/// Green light on the white faces `faces` of the closed cube (the other faces red: zero green
/// reflectance) against `F·green`, and the RGB error there: `(green, rgb)`.
pub fn two_white_error(
    tex: &Texels,
    f: MatRef<'_, f64>,
    e: MatRef<'_, f64>,
    r: &Reduced,
    faces: &[usize],
    exclude_same_face: bool,
) -> (f64, f64) {
    let white: Vec<usize> = faces.iter().flat_map(|&g| tex.face_range(g)).collect();
    let is_white = |i: usize| white.binary_search(&i).is_ok();
    let green = Mat::from_fn(e.nrows(), e.ncols(), |i, j| if is_white(i) { e[(i, j)] } else { 0.0 });
    let on_white = |a: &Mat<f64>| Mat::from_fn(white.len(), a.ncols(), |i, j| a[(white[i], j)]);
    let (rr, rg) = (on_white(&mul(f, e)), on_white(&mul(f, green.as_ref())));
    let (mr, mg) = (
        on_white(&predict_with(tex, r, e, exclude_same_face)),
        on_white(&predict_with(tex, r, green.as_ref(), exclude_same_face)),
    );
    let er2 = frobenius((&mr - &rr).as_ref()).powi(2);
    let eg2 = frobenius((&mg - &rg).as_ref()).powi(2);
    let ref2 = frobenius(rr.as_ref()).powi(2) + 2.0 * frobenius(rg.as_ref()).powi(2);
    let g = frobenius(rg.as_ref());
    (if g > 0.0 { eg2.sqrt() / g } else { 0.0 }, if ref2 > 0.0 { ((er2 + 2.0 * eg2) / ref2).sqrt() } else { 0.0 })
}

/// The operators and samples of one shape.
#[derive(Debug, Clone)]
pub struct ShapeBake {
    /// Layout.
    pub texels: Texels,
    /// Every singular value of `L_d`.
    pub sigma_d_all: Vec<f64>,
    /// The final prior scales `S` (after enrichment).
    pub s: Vec<f64>,
    /// Final operators.
    pub reduced: Reduced,
    /// `U_b⃗`: OHLSH of the radiance at each texel per mode, `n × k_b × 4`.
    pub u_bvec: Vec<f64>,
    /// Probe centres.
    pub probes: Vec<[f64; 3]>,
    /// `U_bvol`: order-3 SH per probe per mode, `probes × k_b × 9`.
    pub u_bvol: Vec<f64>,
    /// Measurements.
    pub metrics: ShapeMetrics,
}

/// A baked dictionary.
#[derive(Debug, Clone)]
pub struct DictBake {
    /// Parameters.
    pub params: DictParams,
    /// Shapes in dictionary order.
    pub shapes: Vec<ShapeBake>,
    /// Dictionary-level measurements.
    pub metrics: DictMetrics,
    /// Interface operators (`None` without missing side faces or with `interfaces` off).
    pub interfaces: Option<InterfaceBake>,
    /// Wall time of the interface bake (reported, never stored in the asset).
    pub interface_seconds: f64,
}

/// The `--json` metrics of a dictionary bake (without `bytes`, `seconds`).
#[derive(Debug, Clone, Serialize)]
pub struct DictMetrics {
    /// Table 3.2 for the closed cube.
    pub table_3_2: Table32,
    /// Per shape: reconstruction error against `F`.
    pub reconstruction_rel_error: BTreeMap<String, f64>,
    /// Per shape: error against the path-traced reference.
    pub reference_rel_error: BTreeMap<String, f64>,
    /// The five-red-faces error without enrichment.
    pub enrichment_rel_error_before: f64,
    /// The same after enrichment *and* the same-face exclusion (the dictionary's runtime).
    pub enrichment_rel_error_after: f64,
    /// The five-red-faces error with enrichment alone (plain rule): what enrichment does.
    pub enrichment_rel_error_enriched_only: f64,
    /// The five-red-faces error with the same-face exclusion alone (unenriched operators):
    /// what the exclusion does.
    pub enrichment_rel_error_excluded_only: f64,
    /// The five-red-faces case in full.
    pub enrichment: RedBox,
    /// Everything per shape.
    pub shapes: BTreeMap<String, ShapeMetrics>,
    /// The interfaces, `"<shape>.<face>"` (e.g. `"dead_end.+z"`), in asset order.
    pub interfaces: Vec<String>,
    /// Reduced lightfield modes kept (0 without interfaces).
    pub k_rlf: usize,
    /// Response modes kept (0 without interfaces).
    pub k_r: usize,
    /// Interface quality figures.
    pub interface_metrics: Option<InterfaceMetrics>,
}

/// Counts progress of one stage across all shapes.
struct Stage<'a> {
    name: &'static str,
    done: AtomicU64,
    total: u64,
    progress: &'a dyn Progress,
}

impl Stage<'_> {
    fn tick(&self, k: u64) {
        let d = self.done.fetch_add(k, Ordering::Relaxed) + k;
        self.progress.update(self.name, d.min(self.total), self.total);
    }
}

/// Per-shape intermediate kept for the dictionary-level metrics.
struct ShapeWork {
    bake: ShapeBake,
    table: Option<Table32>,
    red: Option<RedBox>,
}

/// Bakes a dictionary.
pub fn bake(params: &DictParams, progress: &dyn Progress) -> Result<DictBake, TransportError> {
    params.validate()?;
    bake_shapes(params, &params.shapes(), progress)
}

/// Bakes the given shapes, each with its hash stream (its index in the whole dictionary; the
/// closed cube must be among them for Table 3.2 and the App. A case; [`bake`] always
/// includes it).
pub fn bake_shapes(
    params: &DictParams,
    shapes: &[(u64, Shape)],
    progress: &dyn Progress,
) -> Result<DictBake, TransportError> {
    let res = params.face_res;
    let total_texels: u64 = shapes.iter().map(|(_, s)| Texels::new(*s, res).len() as u64).sum();
    let stages = ShapeStages {
        transport: Stage { name: "transport", done: AtomicU64::new(0), total: total_texels, progress },
        vector: Stage { name: "vector irradiance", done: AtomicU64::new(0), total: total_texels, progress },
        reference: Stage { name: "reference", done: AtomicU64::new(0), total: total_texels, progress },
    };
    let dirs = Dirs {
        cosine: DirectionSet::cosine(params.rays),
        hemi: DirectionSet::uniform_hemisphere(params.vector_rays),
        sphere: DirectionSet::uniform_sphere(params.probe_rays),
    };
    let work: Vec<ShapeWork> =
        shapes.par_iter().map(|(id, s)| bake_shape(params, *s, *id, &dirs, &stages)).collect::<Result<_, _>>()?;
    let table = work.iter().find_map(|w| w.table.clone());
    let red = work.iter().find_map(|w| w.red.clone());
    let (Some(table_3_2), Some(enrichment)) = (table, red) else {
        return Err(TransportError::Param("the dictionary must contain the closed cube".into()));
    };
    let mut metrics = DictMetrics {
        table_3_2,
        reconstruction_rel_error: BTreeMap::new(),
        reference_rel_error: BTreeMap::new(),
        enrichment_rel_error_before: enrichment.rel_error_before,
        enrichment_rel_error_after: enrichment.rel_error_after,
        enrichment_rel_error_enriched_only: enrichment.enriched_without_exclusion.rgb,
        enrichment_rel_error_excluded_only: enrichment.excluded_without_enrichment.rgb,
        enrichment,
        shapes: BTreeMap::new(),
        interfaces: Vec::new(),
        k_rlf: 0,
        k_r: 0,
        interface_metrics: None,
    };
    for w in &work {
        let name = w.bake.texels.shape.name.to_string();
        metrics.reconstruction_rel_error.insert(name.clone(), w.bake.metrics.reconstruction_rel_error);
        metrics.reference_rel_error.insert(name.clone(), w.bake.metrics.reference_rel_error);
        metrics.shapes.insert(name, w.bake.metrics.clone());
    }
    let shapes: Vec<ShapeBake> = work.into_iter().map(|w| w.bake).collect();
    let start = std::time::Instant::now();
    let has_side_openings = shapes.iter().any(|s| !side_openings(&s.texels.shape).is_empty());
    let interfaces = if params.interfaces && has_side_openings {
        let inputs: Vec<ShapeInput<'_>> =
            shapes.iter().map(|s| ShapeInput { texels: &s.texels, reduced: &s.reduced }).collect();
        let sigma_m: Vec<Vec<f64>> = shapes.iter().map(|s| s.reduced.sigma_m.clone()).collect();
        let mut ip = params.interface.clone();
        ip.vectors = params.interface_vectors.then_some(VectorResponseParams {
            vector_rays: params.vector_rays,
            volume_res: params.volume_res,
            probe_rays: params.probe_rays,
        });
        let ib = bake_interfaces(&inputs, &sigma_m, params.albedo, params.face_res, &ip, params.seed, progress)?;
        metrics.interfaces = ib
            .interfaces
            .iter()
            .map(|i| format!("{}.{}", shapes[i.shape].texels.shape.name, crate::shape::FACE_NAMES[i.face]))
            .collect();
        metrics.k_rlf = ib.sigma_rlf.len();
        metrics.k_r = ib.u_r.ncols();
        metrics.interface_metrics = Some(ib.metrics.clone());
        Some(ib)
    } else {
        None
    };
    let interface_seconds = if interfaces.is_some() { start.elapsed().as_secs_f64() } else { 0.0 };
    Ok(DictBake { params: params.clone(), shapes, metrics, interfaces, interface_seconds })
}

struct ShapeStages<'a> {
    transport: Stage<'a>,
    vector: Stage<'a>,
    reference: Stage<'a>,
}

struct Dirs {
    cosine: DirectionSet,
    hemi: DirectionSet,
    sphere: DirectionSet,
}

/// The direct-light matrix `L_d` (n × lights) of `lights` at the texel centres.
pub fn direct_matrix(tex: &Texels, lights: &[SphereLight]) -> Mat<f64> {
    let dl = DirectLight::new();
    let cols: Vec<Vec<f64>> = lights.par_iter().map(|l| dl.texel_vector(tex, l)).collect();
    Mat::from_fn(tex.len(), lights.len(), |i, j| cols[j][i])
}

/// Relative Frobenius error `‖a − b‖ / ‖b‖` (0 when both vanish).
pub fn rel_error(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let num = frobenius((a - b).as_ref());
    let den = frobenius(b);
    if den > 0.0 { num / den } else { num }
}

/// `U_b (T_d→b L)`: the MRT one-bounce prediction for the direct-light columns `L` (eq. 3.3).
pub fn predict(r: &Reduced, l: MatRef<'_, f64>) -> Mat<f64> {
    mul(r.u_b.as_ref(), mul(r.t_d2b.as_ref(), l).as_ref())
}

/// The runtime prediction under the dictionary's rule: [`predict`], or with
/// `exclude_same_face` the same-face exclusion ([`predict_excluding_same_face`]).
pub fn predict_with(tex: &Texels, r: &Reduced, l: MatRef<'_, f64>, exclude_same_face: bool) -> Mat<f64> {
    if exclude_same_face { predict_excluding_same_face(tex, r, l) } else { predict(r, l) }
}

/// Same-face exclusion: face `g`'s indirect light is `U_b[g] (b − b_g)` with `b = T_d→b l`
/// and `b_g = T_d→b[:, g] l[g]` the part of `b` that face `g`'s own direct light makes. A
/// planar face cannot light itself (`F`'s same-face blocks are exactly zero), so the reduced
/// operator's same-face blocks `U_b[g] T_d→b[:, g]` are pure error; dropping them removes,
/// e.g., App. A's colour leak exactly (docs/mrt.md, "Enrichment"). The per-face partial
/// sums `b_g` are what a runtime's per-face reduction of `T_d→b l` computes anyway.
pub fn predict_excluding_same_face(tex: &Texels, r: &Reduced, l: MatRef<'_, f64>) -> Mat<f64> {
    let b = mul(r.t_d2b.as_ref(), l);
    let kb = r.u_b.ncols();
    let mut out = Mat::<f64>::zeros(l.nrows(), l.ncols());
    for &g in &tex.faces {
        let rg = tex.face_range(g);
        let bg = mul(r.t_d2b.subcols(rg.start, rg.len()), l.subrows(rg.start, rg.len()));
        let d = &b - &bg;
        let og = mul(r.u_b.as_ref().subrows(rg.start, rg.len()), d.as_ref());
        out.as_mut().subrows_mut(rg.start, rg.len()).copy_from(og.as_ref());
        debug_assert_eq!(d.nrows(), kb);
    }
    out
}

fn bake_shape(
    params: &DictParams,
    shape: Shape,
    id: u64,
    dirs: &Dirs,
    st: &ShapeStages<'_>,
) -> Result<ShapeWork, TransportError> {
    let tex = Texels::new(shape, params.face_res);
    let n = tex.len();
    let lights: Vec<SphereLight> = prior_lights(&shape, params.layout)
        .into_iter()
        .map(|c| SphereLight { centre: c, radius: params.light_radius })
        .collect();
    let l_d = direct_matrix(&tex, &lights);
    let (prior0, sigma_d_all) = prior_from_samples(l_d.as_ref(), params.k_d)?;
    drop(l_d);
    let mut f =
        transport_matrix(&tex, &dirs.cosine, params.albedo, params.gather, params.seed, id, &|k| st.transport.tick(k));
    let raw_gather = raw_gather_check(&tex, f.as_ref(), params.albedo);
    let f_balance = params.balance.then(|| balance_transport(&tex, &mut f, params.albedo));
    let before = reduce(f.as_ref(), &prior0, params.k_b)?;
    let fallback = fallback_basis(&tex, &prior0, params.fallback_modes);
    let mut prior: Prior = prior0.clone();
    let mut reduced = before.clone();
    for _ in 0..params.enrich {
        prior = enrich(&prior, fallback.as_ref(), reduced.u_b.as_ref(), params.k_d)?;
        reduced = reduce(f.as_ref(), &prior, params.k_b)?;
    }
    let kb = reduced.u_b.ncols();

    // U_b⃗ (§3.5.4, App. B): quadratic SH of the radiance under the implicit lights → OHLSH.
    let sh = texel_sh(&tex, &reduced.l_imp, params.albedo, &dirs.hemi, params.seed, id, &|k| st.vector.tick(k));
    let a = quadratic_to_ohlsh();
    let mut u_bvec = vec![0.0; n * kb * 4];
    for (src, dst) in sh.chunks_exact(9).zip(u_bvec.chunks_exact_mut(4)) {
        for i in 0..4 {
            dst[i] = (0..9).map(|j| a[i * 9 + j] * src[j]).sum();
        }
    }
    // U_bvol (§3.5.5): order-3 SH at the centres of a uniform grid of cells.
    let g = params.volume_res;
    let probes: Vec<[f64; 3]> = (0..g * g * g)
        .map(|k| {
            let c = |i: usize| (i as f64 + 0.5) / g as f64;
            [c(k % g), c((k / g) % g), c(k / (g * g))]
        })
        .collect();
    let u_bvol = probe_sh(&tex, &probes, &reduced.l_imp, params.albedo, &dirs.sphere, params.seed, id);

    // Measurements against lights that are not prior samples.
    let tl = test_lights(&shape, params.layout, params.test_lights, params.light_radius, params.seed, id);
    let e_test = direct_matrix(&tex, &tl);
    let f_e = mul(f.as_ref(), e_test.as_ref());
    let mrt = predict_with(&tex, &reduced, e_test.as_ref(), params.exclude_same_face);
    let reconstruction_rel_error = rel_error(mrt.as_ref(), f_e.as_ref());
    let reconstruction_rel_error_plain = rel_error(predict(&reduced, e_test.as_ref()).as_ref(), f_e.as_ref());
    let reference =
        one_bounce(&tex, &tl, params.albedo, params.reference_rays, params.seed, id, &|k| st.reference.tick(k));
    let reference_rel_error = rel_error(mrt.as_ref(), reference.indirect.as_ref());
    let transport_reference_rel_error = rel_error(f_e.as_ref(), reference.indirect.as_ref());
    let noise = frobenius(reference.half_difference.as_ref());
    let reference_noise_rel = noise / frobenius(reference.indirect.as_ref()).max(f64::MIN_POSITIVE);
    let vector_irradiance_rel_error = vector_consistency(&u_bvec, &reduced.u_b);
    let f_max_column_sum =
        (0..n).map(|j| (0..n).map(|i| f[(i, j)]).sum::<f64>()).fold(0.0f64, f64::max) / params.albedo;

    let (table, red) = if shape == CLOSED {
        // Gram eigenvalues: the same counts as a bidiagonal SVD at ~60 % of its cost (svd.rs)
        let sf = singular_values_gram(f.as_ref())?;
        let counts = |s: &[f64]| TABLE_3_2_FRACTIONS.map(|p| energy_count(s, p));
        let table = Table32 { f: counts(&sf), l_d: counts(&sigma_d_all), m: counts(&before.sigma_m), n };
        (Some(table), Some(red_box(&tex, f.as_ref(), &e_test, &before, &reduced, params.exclude_same_face)))
    } else {
        (None, None)
    };
    let metrics = ShapeMetrics {
        texels: n,
        prior_lights: lights.len(),
        k_d: prior.k(),
        k_b: kb,
        reconstruction_rel_error,
        reconstruction_rel_error_plain,
        reference_rel_error,
        transport_reference_rel_error,
        reference_noise_rel,
        vector_irradiance_rel_error,
        f_max_column_sum,
        f_balance,
        raw_gather,
    };
    let bake = ShapeBake { texels: tex, sigma_d_all, s: prior.s.clone(), reduced, u_bvec, probes, u_bvol, metrics };
    Ok(ShapeWork { bake, table, red })
}

/// Irradiance at the unperturbed normal from the OHLSH coefficients
/// (`E = π a₀ y₀ + (2π/3) a₁₀ y₁₀(+z)`) against `U_b`, relative Frobenius error.
fn vector_consistency(u_bvec: &[f64], u_b: &Mat<f64>) -> f64 {
    let kb = u_b.ncols();
    let c0 = 0.282_094_791_773_878_14;
    let c1 = 0.488_602_511_902_919_9;
    let e = Mat::from_fn(u_b.nrows(), kb, |i, m| {
        let a = &u_bvec[(i * kb + m) * 4..(i * kb + m) * 4 + 4];
        core::f64::consts::PI * c0 * a[0] + 2.0 * core::f64::consts::PI / 3.0 * c1 * a[2]
    });
    rel_error(e.as_ref(), u_b.as_ref())
}

/// The errors of one set of operators on the five-red-faces case.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RedBoxError {
    /// RGB relative error of indirect light on the white face (green and blue counted).
    pub rgb: f64,
    /// Non-red (green) indirect light on the white face relative to the red reference there.
    pub non_red: f64,
    /// The red channel alone on the white face (an ordinary light: the dictionary's general
    /// reconstruction error for these lights on this face).
    pub red: f64,
}

/// App. A, Fig. A.1: the closed cube with five red faces (reflectance `(ρ, 0, 0)`) and a white
/// floor (`(ρ, ρ, ρ)`), lit by the direct-light columns `e`. The runtime input per channel is
/// the reflectance-weighted direct light (red: `e`; green and blue: `e` on the floor only);
/// the reference is `F` applied to it. Only the white face is measured: the red faces'
/// green and blue reflectance is 0, so whatever reaches them there is never seen.
pub fn red_box_error(
    tex: &Texels,
    f: MatRef<'_, f64>,
    e: MatRef<'_, f64>,
    r: &Reduced,
    exclude_same_face: bool,
) -> RedBoxError {
    const WHITE: usize = 2;
    let white = tex.face_range(WHITE);
    let green = Mat::from_fn(e.nrows(), e.ncols(), |i, j| if white.contains(&i) { e[(i, j)] } else { 0.0 });
    let on_white = |a: &Mat<f64>| Mat::from_fn(white.len(), a.ncols(), |i, j| a[(white.start + i, j)]);
    let (rr, rg) = (on_white(&mul(f, e)), on_white(&mul(f, green.as_ref())));
    let (mr, mg) = (
        on_white(&predict_with(tex, r, e, exclude_same_face)),
        on_white(&predict_with(tex, r, green.as_ref(), exclude_same_face)),
    );
    let er2 = frobenius((&mr - &rr).as_ref()).powi(2);
    let eg2 = frobenius((&mg - &rg).as_ref()).powi(2);
    let ref2 = frobenius(rr.as_ref()).powi(2) + 2.0 * frobenius(rg.as_ref()).powi(2);
    let red_norm = frobenius(rr.as_ref());
    RedBoxError {
        rgb: ((er2 + 2.0 * eg2) / ref2).sqrt(),
        non_red: frobenius(mg.as_ref()) / red_norm,
        red: er2.sqrt() / red_norm,
    }
}

fn red_box(tex: &Texels, f: MatRef<'_, f64>, e: &Mat<f64>, before: &Reduced, after: &Reduced, exclude: bool) -> RedBox {
    // before: the thesis's runtime without enrichment (the plain rule: the exclusion needs
    // face-local prior vectors, which only enrichment brings)
    let b = red_box_error(tex, f, e.as_ref(), before, false);
    let p = red_box_error(tex, f, e.as_ref(), after, false);
    let a = red_box_error(tex, f, e.as_ref(), after, exclude);
    // what the exclusion does on its own: the unenriched operators, excluded
    let x = red_box_error(tex, f, e.as_ref(), before, true);
    // floor (−y, face 2) and ceiling (+y, face 3) white
    let tw = [(before, false), (after, false), (after, exclude), (before, true)]
        .map(|(r, x)| two_white_error(tex, f, e.as_ref(), r, &[2, 3], x));
    let two_white = TwoWhite {
        green_rel_error_before: tw[0].0,
        green_rel_error_enriched: tw[1].0,
        green_rel_error_excluded: tw[3].0,
        green_rel_error_enriched_excluded: tw[2].0,
        rgb_rel_error: [tw[0].1, tw[1].1, tw[2].1],
        rgb_rel_error_excluded: tw[3].1,
    };
    RedBox {
        two_white,
        rel_error_before: b.rgb,
        rel_error_after: a.rgb,
        non_red_on_white_before: b.non_red,
        non_red_on_white_after: a.non_red,
        red_on_white_before: b.red,
        red_on_white_after: a.red,
        enriched_without_exclusion: p,
        excluded_without_enrichment: x,
    }
}
