//! The sphere-set bake from a loaded scene to bounding f32 spheres, hierarchy, skin weights
//! and measured quality.

use std::time::Instant;

use serde::Serialize;

use penumbra_geometry::{GridSpec, InsideOracle, MeshBvh, Scene, SignedDistanceGrid, TriMesh, WindingNumber};
use penumbra_math::progress::Progress;

use crate::albedo;
use crate::error::SpheresError;
use crate::frame::Frame;
use crate::hierarchy::{self, Hierarchy};
use crate::lloyd::{self, IterationLog, LloydSettings};
use crate::metrics::{self, MetricSettings, Metrics};
use crate::octree;
use crate::samples::Samples;
use crate::skin::{self, SkinCoverage, SphereSkin};
use crate::sphere::{Sphere, from_f32, round_to_f32};
use crate::volume::VolumeModel;

/// Fitting method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// SHEXP §6.2: Lloyd clustering + Powell + teleportation.
    Lloyd,
    /// Hubbard's octree baseline.
    Octree,
}

/// What to fit to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// Exactly this many spheres (octree: about this many).
    Count(usize),
    /// The smallest count (up to [`FitParams::max_count`]) whose measured E = Σ V(Sᵢ − T)/V(T)
    /// is at most this.
    Error(f64),
    /// The smallest count (up to [`FitParams::max_count`]) whose measured union outside ratio
    /// V(∪Sᵢ − T)/V(T) is at most this (what leaks light: overlaps count once).
    Union(f64),
}

impl Target {
    /// The metric a target search bisects on, with its name; `None` for a fixed count.
    fn searched(&self) -> Option<(&'static str, f64)> {
        match *self {
            Target::Count(_) => None,
            Target::Error(e) => Some(("outside_volume_ratio", e)),
            Target::Union(u) => Some(("union_outside_ratio", u)),
        }
    }
}

/// Largest sphere count.
pub const MAX_COUNT: usize = 4096;
/// Default cap of a target search (`--max-count`): the doubling stops at this count.
pub const DEFAULT_MAX_COUNT: usize = 256;
/// Allowed `grid` range.
pub const GRID_RANGE: std::ops::RangeInclusive<usize> = 8..=256;

/// Parameters of the bake.
#[derive(Debug, Clone, PartialEq)]
pub struct FitParams {
    /// Count or target error.
    pub target: Target,
    /// Largest count a target search tries (`--max-count`; default [`DEFAULT_MAX_COUNT`]).
    pub max_count: usize,
    /// Method.
    pub method: Method,
    /// Grid resolution: about `grid³` cells in the mesh's bounding box (interior points and
    /// the signed-distance grid of the volume model).
    pub grid: usize,
    /// Maximum Lloyd iterations (teleport trials included).
    pub iterations: usize,
    /// Seed.
    pub seed: u64,
    /// Initial centres of the Lloyd fit.
    pub seeding: lloyd::Seeding,
    /// Union-aware refinement after the Lloyd fit ([`crate::refine`]; on by default).
    pub refine: bool,
    /// Also build the evenly spaced candidate ([`crate::cvt`]: a centroidal Voronoi
    /// tessellation of the medial ridge), refine it like the SHEXP fit and keep whichever set
    /// has the smaller union outside volume (on by default; only with `refine`).
    pub cvt: bool,
    /// Refine the chosen set once more on surface elements `FINE_DIVISOR` times finer than the
    /// grid spacing (on by default; only with `refine`).
    pub fine_refine: bool,
    /// Union polish after the refinement ([`crate::polish`]; off by default: it lowers the
    /// union ratio on every shape measured, but costs about as much CPU again as the fit).
    pub polish: bool,
    /// Build the hierarchy.
    pub hierarchy: bool,
    /// Compute skin weights (needs a skinned scene).
    pub skin: bool,
    /// With `skin`: pad each sphere's radius so the set stays bounding in every sampled
    /// animation pose ([`skin::pose_padding`]).
    pub skin_padding: bool,
    /// Per-proxy albedo ([`crate::albedo`]): `Some(rgb)` stores an albedo per sphere, from
    /// the glTF materials where the mesh has them and `rgb` elsewhere; `None` stores albedo
    /// only when the mesh has glTF materials (triangles without one: the glTF default
    /// material's `baseColorFactor`, 1).
    pub albedo: Option<[f64; 3]>,
    /// Measurement sample counts.
    pub metrics: MetricSettings,
}

impl FitParams {
    /// Defaults for a target.
    pub fn new(target: Target) -> Self {
        Self {
            target,
            max_count: DEFAULT_MAX_COUNT,
            method: Method::Lloyd,
            grid: 48,
            iterations: 100,
            seed: 1,
            refine: true,
            cvt: true,
            fine_refine: true,
            polish: false,
            seeding: lloyd::Seeding::Medial,
            hierarchy: false,
            skin: false,
            skin_padding: false,
            albedo: None,
            metrics: MetricSettings::default(),
        }
    }

    /// Checks every range.
    pub fn validate(&self) -> Result<(), SpheresError> {
        match self.target {
            Target::Count(n) if !(1..=MAX_COUNT).contains(&n) => {
                return Err(SpheresError::OutOfRange {
                    name: "count",
                    value: n.to_string(),
                    allowed: format!("1..={MAX_COUNT}"),
                });
            }
            Target::Error(e) if !(e > 0.0 && e.is_finite()) => {
                return Err(SpheresError::OutOfRange {
                    name: "target-error",
                    value: e.to_string(),
                    allowed: "a positive number (E = Σ V(Sᵢ − T) / V(T))".into(),
                });
            }
            Target::Union(e) if !(e > 0.0 && e.is_finite()) => {
                return Err(SpheresError::OutOfRange {
                    name: "target-union",
                    value: e.to_string(),
                    allowed: "a positive number (V(∪Sᵢ − T) / V(T))".into(),
                });
            }
            _ => {}
        }
        if !(1..=MAX_COUNT).contains(&self.max_count) {
            return Err(SpheresError::OutOfRange {
                name: "max-count",
                value: self.max_count.to_string(),
                allowed: format!("1..={MAX_COUNT}"),
            });
        }
        if !GRID_RANGE.contains(&self.grid) {
            return Err(SpheresError::OutOfRange {
                name: "grid",
                value: self.grid.to_string(),
                allowed: format!("{}..={}", GRID_RANGE.start(), GRID_RANGE.end()),
            });
        }
        if !(1..=10_000).contains(&self.iterations) {
            return Err(SpheresError::OutOfRange {
                name: "iterations",
                value: self.iterations.to_string(),
                allowed: "1..=10000".into(),
            });
        }
        Ok(())
    }
}

/// The hierarchy as stored: f32 node spheres per level (root first) and child ranges.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredHierarchy {
    /// Node spheres `[x, y, z, r]` per level, root level first.
    pub levels: Vec<Vec<[f32; 4]>>,
    /// `(first, count)` of each node's children in the next level (the leaves for the last).
    pub children: Vec<Vec<(u32, u32)>>,
}

/// Everything the bake reports besides the spheres.
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// Method used.
    pub method: Method,
    /// Spheres produced.
    pub count: usize,
    /// Requested count (or the count the error search settled on).
    pub requested_count: usize,
    /// Iterations of the final fit (octree: 0).
    pub iterations: usize,
    /// Teleport candidates kept.
    pub teleports_accepted: usize,
    /// Teleport candidates discarded.
    pub teleports_rejected: usize,
    /// The Lloyd iteration log (E by the volume model).
    pub log: Vec<IterationLog>,
    /// Requested counts tried by a target search, with the measured value of the searched
    /// metric (the set of a request can have fewer spheres after the refinement, or another
    /// count for the octree).
    pub search: Vec<(usize, f64)>,
    /// The outcome of a target search (`None` for a fixed count).
    pub target: Option<TargetOutcome>,
    /// Octree level used and the cell counts of every level.
    pub octree_level: Option<u32>,
    /// Octree cell counts per level.
    pub octree_level_counts: Vec<usize>,
    /// Grid nodes along x, y, z and the spacing in input units.
    pub grid_nodes: [usize; 3],
    /// Grid spacing, input units.
    pub grid_spacing: f64,
    /// Surface elements (sub-triangles) and interior points clustered.
    pub surface_elements: usize,
    /// Interior points.
    pub interior_points: usize,
    /// Whether the mesh is watertight.
    pub watertight: bool,
    /// Whether the triangles were inside-out (negative volume) and were flipped.
    pub flipped_orientation: bool,
    /// E by the volume model for the final set (compare with the measured E).
    pub model_outside_volume_ratio: f64,
    /// Seconds: grid and samples.
    pub setup_seconds: f64,
    /// Seconds: the fit.
    pub fit_seconds: f64,
    /// Seconds: hierarchy, skin and measurements.
    pub finish_seconds: f64,
}

/// How a target search (`--target-error`, `--target-union`) ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetOutcome {
    /// The searched metric: `outside_volume_ratio` or `union_outside_ratio`.
    pub metric: &'static str,
    /// The target value.
    pub value: f64,
    /// Whether the returned set meets it.
    pub met: bool,
    /// The largest count the search could try (`max_count`, or fewer when the mesh
    /// discretises into fewer elements).
    pub max_count: usize,
    /// Why the target was not met (`None` when it was).
    pub reason: Option<String>,
}

/// The result of a bake.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// Leaf spheres as stored (`[x, y, z, r]`, input units), in hierarchy order when there is one.
    pub spheres: Vec<[f32; 4]>,
    /// The hierarchy.
    pub hierarchy: Option<StoredHierarchy>,
    /// Per-sphere linear RGB albedo in [0, 1] (same order as `spheres`), if stored
    /// ([`FitParams::albedo`]).
    pub albedo: Option<Vec<[f32; 3]>>,
    /// Per-sphere skin influences (same order as `spheres`).
    pub skin: Option<Vec<SphereSkin>>,
    /// Posed coverage of the skinned set.
    pub skin_coverage: Option<SkinCoverage>,
    /// Per-sphere radius padding added for the animations (`skin_padding`), input units.
    pub skin_padding: Option<Vec<f64>>,
    /// Measured quality.
    pub metrics: Metrics,
    /// Report.
    pub report: FitReport,
}

/// Everything derived from the mesh once per bake.
struct Context {
    frame: Frame,
    canonical: TriMesh,
    /// The input mesh (orientation fixed like `canonical`).
    input: TriMesh,
    grid: SignedDistanceGrid,
    winding: WindingNumber,
    samples: Samples,
    volume_exact: Option<f64>,
    watertight: bool,
    flipped: bool,
}

impl Context {
    fn new(mesh: &TriMesh, grid_res: usize) -> Result<Self, SpheresError> {
        if mesh.indices.is_empty() {
            return Err(SpheresError::EmptyMesh);
        }
        let frame = Frame::of(mesh).ok_or(SpheresError::DegenerateBounds)?;
        let mut canonical = frame.canonical_mesh(mesh);
        let mut input = mesh.clone();
        let watertight = mesh.is_watertight();
        let mut flipped = false;
        if watertight && canonical.signed_volume() < 0.0 {
            for t in canonical.indices.iter_mut().chain(input.indices.iter_mut()) {
                t.swap(1, 2);
            }
            flipped = true;
        }
        let bvh = MeshBvh::build(&canonical).map_err(|e| SpheresError::Asset(e.to_string()))?;
        let winding = WindingNumber::new(&canonical);
        let bounds = canonical.bounds().ok_or(SpheresError::EmptyMesh)?;
        let spec = GridSpec::fit(&bounds, grid_res, 2);
        let grid = SignedDistanceGrid::build(&canonical, &bvh, &winding, spec, watertight);
        let mut samples = Samples::build(&canonical, &input, &frame, &grid);
        samples.set_depths(&bvh);
        let volume_exact = watertight.then(|| canonical.signed_volume());
        Ok(Self { frame, canonical, input, grid, winding, samples, volume_exact, watertight, flipped })
    }

    fn oracle(&self) -> InsideOracle<'_> {
        InsideOracle { grid: &self.grid, winding: &self.winding }
    }
}

/// One fitted set in the canonical frame, with its cluster assignment when it has one.
struct RawFit {
    spheres: Vec<Sphere>,
    assign: Option<Vec<u32>>,
    /// Finer samples that `assign` refers to (instead of the context's), when the final
    /// refinement ran on them.
    fine: Option<Samples>,
    log: Vec<IterationLog>,
    iterations: usize,
    teleports: (usize, usize),
    octree: Option<(u32, Vec<usize>)>,
}

fn fit_count(
    ctx: &Context,
    model: &VolumeModel,
    volume_model: f64,
    p: &FitParams,
    n: usize,
    progress: &dyn Progress,
) -> Result<RawFit, SpheresError> {
    match p.method {
        Method::Octree => {
            let o = octree::fit(&ctx.canonical, &ctx.oracle(), n);
            Ok(RawFit {
                spheres: o.spheres,
                assign: None,
                fine: None,
                log: Vec::new(),
                iterations: 0,
                teleports: (0, 0),
                octree: Some((o.level, o.level_counts)),
            })
        }
        Method::Lloyd => {
            let ne = ctx.samples.elements.len();
            if n > ne {
                return Err(SpheresError::TooManySpheres { count: n, elements: ne, grid: p.grid });
            }
            if n == 1 {
                // One sphere: V(S − T) = V(S) − V(T), so minimising E is minimising the radius,
                // whose minimum is the minimal enclosing ball (Welzl, exact).
                let pts = &ctx.samples.points;
                let b = penumbra_geometry::min_enclosing_ball(pts).ok_or(SpheresError::EmptyMesh)?;
                let s = Sphere::new(b.center, crate::sphere::bounding_radius(b.center, pts));
                return Ok(RawFit {
                    spheres: vec![s],
                    assign: Some(vec![0; ne]),
                    fine: None,
                    log: Vec::new(),
                    iterations: 0,
                    teleports: (0, 0),
                    octree: None,
                });
            }
            let mut ls = LloydSettings::new(n);
            ls.iterations = p.iterations;
            ls.seed = p.seed;
            ls.seeding = p.seeding;
            // Three independent computations run side by side: the SHEXP fit with its
            // refinement (whose clustering and refinement are sequential, leaving a core idle),
            // the evenly spaced candidate, and the finer elements of the last refinement. Each
            // computes the same values whichever thread runs it.
            let shexp = || {
                let o = lloyd::fit(&ctx.samples, model, volume_model, &ls, progress);
                let refined = p.refine.then(|| {
                    let (mut s, mut a, _) =
                        crate::refine::refine_to_count(&ctx.samples, model, &o.spheres, &o.assign, n);
                    if s.len() < n {
                        // The refinement could not spend every sphere again: refit from its
                        // spheres plus new medial seeds where the set is sparsest, refine that,
                        // and keep whichever set has less outside volume in its union (by the
                        // model).
                        let kept: Vec<[f64; 3]> = s.iter().map(|x| x.center).collect();
                        if let Some(c) = lloyd::more_medial_centers(&ctx.samples, &kept, n) {
                            let o2 = lloyd::fit_from(&ctx.samples, model, volume_model, &ls, &c, progress);
                            let (s2, a2, _) =
                                crate::refine::refine_to_count(&ctx.samples, model, &o2.spheres, &o2.assign, n);
                            if crate::refine::union_outside(model, &s2) < crate::refine::union_outside(model, &s) {
                                (s, a) = (s2, a2);
                            }
                        }
                    }
                    (s, a)
                });
                (o, refined)
            };
            // The evenly spaced candidate (see `cvt`): SHEXP's E leaves the slabs of a tube
            // uneven, a centroidal tessellation of the medial ridge does not. Its union outside
            // volume (by the model) before refinement decides below whether it is refined.
            let candidate = || {
                (p.refine && p.cvt).then(|| {
                    let seeds = lloyd::medial_centers(&ctx.samples, n)
                        .unwrap_or_else(|| lloyd::init_centers(&ctx.samples, n, p.seed));
                    let (cs, ca) = crate::cvt::fit_from(&ctx.samples, model, &seeds);
                    let u = crate::refine::union_outside(model, &cs);
                    (cs, ca, u)
                })
            };
            let finer = || (p.refine && p.fine_refine).then(|| fine_samples(ctx));
            let ((o, refined), (candidate, finer)) = rayon::join(shexp, || rayon::join(candidate, finer));
            let (spheres, assign) = match refined {
                Some((mut s, mut a)) => {
                    if let Some((cs, ca, u_cs)) = candidate {
                        // Refining the candidate costs a refinement of the whole set (up to 1
                        // CPU-s on the bunny at 64). It is skipped when the unrefined
                        // candidate's union exceeds `CVT_SKIP_RATIO` times the refined SHEXP
                        // set's: on every row measured the candidates that won started at most
                        // 1.26× above it (the refinement lowered a candidate's union by at most
                        // 22 %), so a skipped one would need a drop of 29 % to win
                        // (docs/spheres.md, "Fourth pass").
                        let u_shexp = crate::refine::union_outside(model, &s);
                        if u_cs <= CVT_SKIP_RATIO * u_shexp {
                            let (s2, a2, _) = crate::refine::refine_to_count(&ctx.samples, model, &cs, &ca, n);
                            if crate::refine::union_outside(model, &s2) < u_shexp {
                                (s, a) = (s2, a2);
                            }
                        }
                    }
                    (s, a)
                }
                None => (o.spheres.clone(), o.assign.clone()),
            };
            // the final refinement on finer surface elements (see `fine_refine`)
            let (spheres, assign, fine) =
                match finer.flatten().and_then(|f| fine_refine(&ctx.samples, model, f, &spheres, &assign, n)) {
                    Some((s, a, f)) => (s, a, Some(f)),
                    None => (spheres, assign, None),
                };
            let samples = fine.as_ref().unwrap_or(&ctx.samples);
            let (spheres, assign) = if p.polish {
                let ps = crate::polish::PolishSettings { seed: p.seed, ..Default::default() };
                let (s, a, _) = crate::polish::polish(samples, &ctx.oracle(), &spheres, &assign, &ps);
                (s, a)
            } else {
                (spheres, assign)
            };
            Ok(RawFit {
                spheres,
                assign: Some(assign),
                fine,
                log: o.log,
                iterations: o.iterations,
                teleports: (o.teleports_accepted, o.teleports_rejected),
                octree: None,
            })
        }
    }
}

/// The evenly spaced candidate is refined only when its unrefined union outside volume (by the
/// model) is at most this many times the refined SHEXP set's (see `fit_count`).
pub const CVT_SKIP_RATIO: f64 = 1.4;

/// Surface elements this many times finer than the grid spacing for the final refinement.
const FINE_DIVISOR: usize = 2;

/// The surface elements of the final refinement (`FINE_DIVISOR` times finer than the grid
/// spacing) with the context's interior elements; `None` when they do not nest in the coarse
/// elements (not expected).
fn fine_samples(ctx: &Context) -> Option<Samples> {
    let coarse = &ctx.samples;
    let mut fine = Samples::build_finer(&ctx.canonical, &ctx.input, &ctx.frame, &ctx.grid, FINE_DIVISOR);
    fine.interior_depth = coarse.interior_depth.clone();
    let (fs, cs) = (fine.surface_elements, coarse.surface_elements);
    if fine.elements.len() - fs != coarse.elements.len() - cs {
        return None;
    }
    if fine.coarse_parent.len() != fs || fine.coarse_parent.iter().any(|&c| c as usize >= cs) {
        return None;
    }
    Some(fine)
}

/// Refines a set again on surface elements `FINE_DIVISOR` times finer. An element must lie
/// inside one sphere whole; with elements as long as a grid cell, one straddling the boundary
/// between two spheres makes one of them reach up to an element further (on the torus
/// at 64 spheres, cells of 0.05 against a sphere spacing of 0.098). The finer elements nest in
/// the coarser ones, so each starts inside a sphere that contains it whole. `None` when an
/// element has no such sphere (not expected) or the set does not improve (by the model).
fn fine_refine(
    coarse: &Samples,
    model: &VolumeModel,
    fine: Samples,
    spheres: &[Sphere],
    assign: &[u32],
    n: usize,
) -> Option<(Vec<Sphere>, Vec<u32>, Samples)> {
    let (fs, cs) = (fine.surface_elements, coarse.surface_elements);
    // a finer element lies inside its coarse element, so inside that element's sphere
    let owner: Vec<u32> = (0..fine.elements.len())
        .map(|e| if e >= fs { assign[e - fs + cs] } else { assign[fine.coarse_parent[e] as usize] })
        .collect();
    let (s, a, _) = crate::refine::refine_to_count(&fine, model, spheres, &owner, n);
    (crate::refine::union_outside(model, &s) < crate::refine::union_outside(model, spheres)).then_some((s, a, fine))
}

/// Maps a canonical fit to bounding f32 spheres in input coordinates.
fn to_input_f32(ctx: &Context, raw: &RawFit) -> Vec<[f32; 4]> {
    let samples = raw.fine.as_ref().unwrap_or(&ctx.samples);
    let f = &ctx.frame;
    let n = raw.spheres.len();
    let mut out: Vec<[f32; 4]> = match &raw.assign {
        Some(assign) => {
            let mut pts: Vec<Vec<u32>> = vec![Vec::new(); n];
            for (e, &c) in assign.iter().enumerate() {
                pts[c as usize].extend_from_slice(samples.elements[e].point_ids());
            }
            (0..n)
                .map(|i| {
                    let s = &raw.spheres[i];
                    let mut ids = std::mem::take(&mut pts[i]);
                    ids.sort_unstable();
                    ids.dedup();
                    let p: Vec<[f64; 3]> = ids.iter().map(|&k| samples.input_points[k as usize]).collect();
                    round_to_f32(&Sphere::new(f.to_input(s.center), s.radius * f.scale), &p, &[])
                })
                .collect()
        }
        None => raw
            .spheres
            .iter()
            .map(|s| round_to_f32(&Sphere::new(f.to_input(s.center), s.radius * f.scale), &[], &[]))
            .collect(),
    };
    // repair: any sample point outside every sphere enlarges the nearest one (only rounding of
    // the canonical frame can cause this, e.g. for the octree's cell spheres)
    let spheres: Vec<Sphere> = out.iter().map(|&v| from_f32(v)).collect();
    let mut extra: Vec<Vec<[f64; 3]>> = vec![Vec::new(); n];
    for q in &samples.input_points {
        if !spheres.iter().any(|s| s.contains(*q)) {
            let k = (0..n)
                .min_by(|&a, &b| spheres[a].signed_distance(*q).total_cmp(&spheres[b].signed_distance(*q)))
                .unwrap_or(0);
            extra[k].push(*q);
        }
    }
    for k in 0..n {
        if !extra[k].is_empty() {
            let s = from_f32(out[k]);
            out[k] = round_to_f32(&s, &extra[k], &[]);
        }
    }
    out
}

/// Rounds a hierarchy to f32 bottom-up so that every stored parent bounds its stored children.
fn store_hierarchy(h: &Hierarchy, leaves: &[[f32; 4]]) -> StoredHierarchy {
    let depth = h.depth();
    let mut levels: Vec<Vec<[f32; 4]>> = vec![Vec::new(); depth];
    let mut below: Vec<[f32; 4]> = leaves.to_vec();
    for l in (0..depth).rev() {
        let kids: Vec<Sphere> = below.iter().map(|&v| from_f32(v)).collect();
        levels[l] = h.levels[l]
            .iter()
            .zip(&h.children[l])
            .map(|(s, &(first, count))| round_to_f32(s, &[], &kids[first as usize..(first + count) as usize]))
            .collect();
        below = levels[l].clone();
    }
    StoredHierarchy { levels, children: h.children.clone() }
}

/// Runs the bake on a loaded scene (the rest-pose mesh is `scene.mesh`).
pub fn fit(scene: &Scene, p: &FitParams, progress: &dyn Progress) -> Result<FitResult, SpheresError> {
    p.validate()?;
    if p.skin && !scene.is_skinned() {
        return Err(skin::SkinError::NotSkinned.into());
    }
    if p.skin_padding && !p.skin {
        return Err(SpheresError::OutOfRange {
            name: "skin_padding",
            value: "true".into(),
            allowed: "only with skin (--skin)".into(),
        });
    }
    let t0 = Instant::now();
    progress.update("grid", 0, 1);
    let ctx = Context::new(&scene.mesh, p.grid)?;
    let model = VolumeModel::new(&ctx.grid, p.seed);
    let volume_model = ctx.grid.soft_volume();
    let oracle = ctx.oracle();
    let (volume_t, volume_exact) = metrics::volume_of_t(&ctx.grid, &oracle, ctx.volume_exact, p.metrics.seed);
    progress.update("grid", 1, 1);
    let setup_seconds = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let measure = |stored: &[[f32; 4]]| -> Metrics {
        let input: Vec<Sphere> = stored.iter().map(|&v| from_f32(v)).collect();
        let canon: Vec<Sphere> =
            input.iter().map(|s| Sphere::new(ctx.frame.to_canonical(s.center), s.radius / ctx.frame.scale)).collect();
        let to_input = |q: [f64; 3]| ctx.frame.to_input(q);
        metrics::measure(
            &canon,
            &oracle,
            ctx.watertight,
            volume_t,
            volume_exact,
            &ctx.samples.input_points,
            &input,
            &to_input,
            ctx.frame.scale,
            &p.metrics,
        )
    };
    let mut search = Vec::new();
    let mut target_outcome = None;
    let (raw, mut stored, n_req) = match p.target {
        Target::Count(n) => {
            let raw = fit_count(&ctx, &model, volume_model, p, n, progress)?;
            let stored = to_input_f32(&ctx, &raw);
            (raw, stored, n)
        }
        Target::Error(_) | Target::Union(_) => {
            let (metric, target) = p.target.searched().unwrap_or(("outside_volume_ratio", f64::NAN));
            // E and the union ratio are ratios to V(T): a mesh without volume has none to
            // search on (the same threshold as `metrics`)
            if volume_t.is_nan() || volume_t <= 1e-12 {
                return Err(SpheresError::NoVolume { metric });
            }
            let value = |m: &Metrics| match p.target {
                Target::Union(_) => m.union_outside_ratio,
                _ => m.outside_volume_ratio,
            };
            let max_n = p.max_count.min(if p.method == Method::Lloyd { ctx.samples.elements.len() } else { MAX_COUNT });
            let probe =
                |n: usize, search: &mut Vec<(usize, f64)>| -> Result<(RawFit, Vec<[f32; 4]>, f64), SpheresError> {
                    let raw = fit_count(&ctx, &model, volume_model, p, n, progress)?;
                    let stored = to_input_f32(&ctx, &raw);
                    let v = value(&measure(&stored));
                    // the requested count: the bisection runs over it (the refinement or the octree's
                    // levels can give fewer or more spheres)
                    search.push((n, v));
                    Ok((raw, stored, v))
                };
            // Doubling until a count meets the target, then bisection between the largest
            // count known to miss (`lo`) and the smallest known to meet (`hi`) down to
            // `hi − lo = 1`: the count returned meets the target and the count below it was
            // probed and missed. (A fit's quality is not exactly monotone in the count, so
            // this is the boundary the search brackets, not a proof that no smaller count
            // meets the target.)
            let mut lo = 0usize;
            let mut n = 1usize;
            let mut best_miss: Option<(RawFit, Vec<[f32; 4]>, f64, usize)> = None;
            let mut found = None;
            loop {
                let (raw, stored, v) = probe(n, &mut search)?;
                if v <= target {
                    found = Some((raw, stored, n));
                    break;
                }
                lo = n;
                if best_miss.as_ref().is_none_or(|b| v < b.2) {
                    best_miss = Some((raw, stored, v, n));
                }
                if n >= max_n {
                    break;
                }
                n = (2 * n).min(max_n);
            }
            match found {
                Some((mut raw, mut stored, mut hi)) => {
                    while hi - lo > 1 {
                        let mid = lo + (hi - lo) / 2;
                        let (r, s, v) = probe(mid, &mut search)?;
                        if v <= target {
                            (raw, stored, hi) = (r, s, mid);
                        } else {
                            lo = mid;
                        }
                    }
                    target_outcome =
                        Some(TargetOutcome { metric, value: target, met: true, max_count: max_n, reason: None });
                    (raw, stored, hi)
                }
                None => {
                    let (raw, stored, v, n) = best_miss.ok_or(SpheresError::EmptyMesh)?;
                    let why = if max_n < p.max_count {
                        format!(
                            "the mesh discretises into only {max_n} elements at grid {} (a finer --grid allows more spheres)",
                            p.grid
                        )
                    } else {
                        format!("the search is capped at --max-count {max_n}")
                    };
                    let reason = format!(
                        "no count up to {max_n} reaches {metric} ≤ {target}: the best, {v:.4} (requested count {n}), was kept; {why}"
                    );
                    target_outcome = Some(TargetOutcome {
                        metric,
                        value: target,
                        met: false,
                        max_count: max_n,
                        reason: Some(reason),
                    });
                    (raw, stored, n)
                }
            }
        }
    };
    let fit_seconds = t1.elapsed().as_secs_f64();

    let t2 = Instant::now();
    progress.update("finish", 0, 3);
    let model_e = raw.spheres.iter().map(|s| model.outside_volume(s.center, s.radius)).sum::<f64>()
        / volume_model.max(f64::MIN_POSITIVE);
    let mut built = None;
    if p.hierarchy && stored.len() > 1 {
        let leaves: Vec<Sphere> = stored.iter().map(|&v| from_f32(v)).collect();
        let h = hierarchy::build(&leaves, p.seed);
        stored = h.leaf_order.iter().map(|&i| stored[i as usize]).collect();
        built = Some(h);
    }
    progress.update("finish", 1, 3);
    let mut padding = None;
    let (skin_w, skin_cov) = if p.skin {
        let centers: Vec<[f64; 3]> = stored.iter().map(|&v| from_f32(v).center).collect();
        let w = skin::sphere_skins(scene, &centers)?;
        let tol = 1e-6 * ctx.frame.scale;
        if p.skin_padding {
            let leaves: Vec<Sphere> = stored.iter().map(|&v| from_f32(v)).collect();
            let pad = skin::pose_padding(scene, &leaves, &w, tol)?;
            for (s, &d) in stored.iter_mut().zip(&pad) {
                if d > 0.0 {
                    // smallest f32 radius not below r + pad (+ the coverage tolerance)
                    let need = f64::from(s[3]) + d + tol;
                    let mut r = need as f32;
                    while f64::from(r) < need {
                        r = r.next_up();
                    }
                    s[3] = r;
                }
            }
            padding = Some(pad);
        }
        let leaves: Vec<Sphere> = stored.iter().map(|&v| from_f32(v)).collect();
        let cov = skin::coverage(scene, &leaves, &w, tol)?;
        (Some(w), Some(cov))
    } else {
        (None, None)
    };
    // nodes bound the (possibly padded) leaves: `round_to_f32` grows them as needed
    let hierarchy = built.map(|h| store_hierarchy(&h, &stored));
    let albedo = if p.albedo.is_some() || albedo::has_materials(scene) {
        let surface = albedo::SurfaceAlbedo::new(scene, p.albedo.unwrap_or([1.0; 3]))?;
        Some(albedo::sphere_albedo(scene, &surface, &stored))
    } else {
        None
    };
    progress.update("finish", 2, 3);
    let metrics = measure(&stored);
    progress.update("finish", 3, 3);
    let spec = ctx.grid.spec();
    let report = FitReport {
        method: p.method,
        count: stored.len(),
        requested_count: n_req,
        iterations: raw.iterations,
        teleports_accepted: raw.teleports.0,
        teleports_rejected: raw.teleports.1,
        log: raw.log,
        search,
        target: target_outcome,
        octree_level: raw.octree.as_ref().map(|o| o.0),
        octree_level_counts: raw.octree.map(|o| o.1).unwrap_or_default(),
        grid_nodes: spec.nodes,
        grid_spacing: spec.h * ctx.frame.scale,
        surface_elements: ctx.samples.surface_elements,
        interior_points: ctx.samples.elements.len() - ctx.samples.surface_elements,
        watertight: ctx.watertight,
        flipped_orientation: ctx.flipped,
        model_outside_volume_ratio: model_e,
        setup_seconds,
        fit_seconds,
        finish_seconds: t2.elapsed().as_secs_f64(),
    };
    Ok(FitResult {
        spheres: stored,
        hierarchy,
        albedo,
        skin: skin_w,
        skin_coverage: skin_cov,
        skin_padding: padding,
        metrics,
        report,
    })
}
