//! The variational sphere-set fit of SHEXP §6.2 (after Wang et al. 2006): flood-fill point
//! clustering, Powell updates of the sphere centres, and cluster teleportation, iterated until
//! the outside volume E (eq. 35) stops decreasing.
//!
//! Choices where the paper is silent or where we deviate, and why:
//! - **Initial centres** (SHEXP §6.2 picks them at random): by default farthest-point sampling
//!   over an approximate medial axis (ridge nodes of the distance to the surface), so that
//!   every seed starts where one sphere bounds a whole cross-section of a tube or plate; or
//!   k-means++ (D² sampling, seeded) over the element positions, which spreads the seeds but
//!   mostly over the surface. Measured in docs/spheres.md ("Thin features").
//! - **Flood fill order**: a FIFO queue over grid cells, seeded with each cluster's nearest
//!   element, instead of the paper's stack. A stack visits elements depth-first, so a cluster's
//!   radius jumps to the far end of a chain before nearby elements are seen; breadth-first
//!   grows all clusters at the same pace from their centres. Each visited element still joins
//!   the cluster whose sphere gains the least outside volume (zero when already inside; ties
//!   broken by distance).
//! - **Monotone E**: an iteration (clustering + Powell update) is kept only when it lowers E;
//!   otherwise, as when the decrease falls below 0.5 %, teleportation is tried. A teleport
//!   candidate (split the worst cluster along its farthest pair, delete the most-overlapped
//!   one, recluster, update) is kept only if E drops, as in the paper; up to five candidates
//!   (the worst, second-worst, ... fifth-worst clusters) are tried before the fit stops. So the
//!   accepted E never increases.
//! - **Settling**: a teleport candidate may take up to two further Lloyd steps (while they
//!   lower its E) before it is compared with the kept state. A split needs a step or two to
//!   find its shape; judging it after one step rejected moves that pay off (measured on the
//!   bunny, armadillo and spot at 64 spheres: E 9 %, 9 % and 21 % lower with settling).

use rayon::prelude::*;
use serde::Serialize;

use penumbra_math::progress::Progress;
use penumbra_math::rng::{ItemRng, stage};

use crate::powell::{PowellSettings, minimize};
use crate::samples::Samples;
use crate::sphere::{Sphere, bounding_radius, dist, dist2};
use crate::volume::VolumeModel;

/// Knobs of the Lloyd fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LloydSettings {
    /// Number of spheres.
    pub count: usize,
    /// Maximum number of clustering + update iterations (teleport trials included).
    pub iterations: usize,
    /// Seed of the initial centres.
    pub seed: u64,
    /// Teleport candidates tried before the fit stops.
    pub teleport_attempts: usize,
    /// Relative decrease of E below which an iteration counts as stalled.
    pub stall_ratio: f64,
    /// Extra Lloyd steps a teleport candidate may take to settle before it is judged.
    pub settle_steps: usize,
    /// How the initial centres are chosen.
    pub seeding: Seeding,
}

/// Initial centres of the Lloyd fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Seeding {
    /// k-means++ (D² sampling) over all element positions.
    KMeansPlusPlus,
    /// Farthest-point sampling over an approximate medial axis: the interior grid nodes whose
    /// distance to the surface is a local maximum (issue 16).
    Medial,
}

impl LloydSettings {
    /// Defaults for `count` spheres.
    pub fn new(count: usize) -> Self {
        Self {
            count,
            iterations: 100,
            seed: 1,
            teleport_attempts: 5,
            stall_ratio: 0.005,
            settle_steps: 2,
            seeding: Seeding::KMeansPlusPlus,
        }
    }
}

/// What one iteration did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StepKind {
    /// Clustering from the current centres, then Powell updates.
    Lloyd,
    /// A teleport candidate, then clustering and Powell updates.
    Teleport,
}

/// One line of the iteration log.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IterationLog {
    /// 1-based iteration number.
    pub iteration: usize,
    /// Lloyd step or teleport trial.
    pub kind: StepKind,
    /// E of the candidate (objective model, relative to the model's volume of T).
    pub candidate_e: f64,
    /// E of the state kept after this iteration.
    pub e: f64,
    /// Whether the candidate was kept.
    pub accepted: bool,
}

/// Result of the Lloyd fit (canonical frame).
#[derive(Debug, Clone)]
pub struct LloydOutcome {
    /// The spheres, bounding their clusters' points.
    pub spheres: Vec<Sphere>,
    /// Cluster of every element.
    pub assign: Vec<u32>,
    /// The iteration log.
    pub log: Vec<IterationLog>,
    /// Iterations run.
    pub iterations: usize,
    /// Teleport candidates kept / discarded.
    pub teleports_accepted: usize,
    /// Teleport candidates discarded.
    pub teleports_rejected: usize,
}

#[derive(Debug, Clone)]
struct State {
    spheres: Vec<Sphere>,
    outside: Vec<f64>,
    assign: Vec<u32>,
    /// Sorted distinct point ids of every cluster.
    members: Vec<Vec<u32>>,
    energy: f64,
}

/// Runs the fit. `volume_t` is the model's volume of T (for the relative E in the log).
pub fn fit(
    samples: &Samples,
    model: &VolumeModel,
    volume_t: f64,
    s: &LloydSettings,
    progress: &dyn Progress,
) -> LloydOutcome {
    let n = s.count.clamp(1, samples.elements.len().max(1));
    let centers = match s.seeding {
        Seeding::KMeansPlusPlus => init_centers(samples, n, s.seed),
        Seeding::Medial => medial_centers(samples, n).unwrap_or_else(|| init_centers(samples, n, s.seed)),
    };
    fit_from(samples, model, volume_t, s, &centers, progress)
}

/// [`fit`] from given initial centres (their number is the sphere count; `s.count` and
/// `s.seeding` are not used).
pub fn fit_from(
    samples: &Samples,
    model: &VolumeModel,
    volume_t: f64,
    s: &LloydSettings,
    centers: &[[f64; 3]],
    progress: &dyn Progress,
) -> LloydOutcome {
    let n = centers.len();
    let rel = |e: f64| if volume_t > 0.0 { e / volume_t } else { e };
    let mut log = Vec::new();
    let mut iterations = 1;
    let mut best = step(samples, model, centers, None);
    log.push(IterationLog {
        iteration: 1,
        kind: StepKind::Lloyd,
        candidate_e: rel(best.energy),
        e: rel(best.energy),
        accepted: true,
    });
    let (mut tp_ok, mut tp_bad) = (0, 0);
    progress.update("fit", 1, s.iterations as u64);
    'outer: while iterations < s.iterations {
        let centers: Vec<[f64; 3]> = best.spheres.iter().map(|x| x.center).collect();
        let cand = step(samples, model, &centers, Some(&best));
        iterations += 1;
        let accepted = cand.energy < best.energy;
        let improvement = if accepted { (best.energy - cand.energy) / best.energy.max(f64::MIN_POSITIVE) } else { 0.0 };
        if accepted {
            best = cand.clone();
        }
        log.push(IterationLog {
            iteration: iterations,
            kind: StepKind::Lloyd,
            candidate_e: rel(cand.energy),
            e: rel(best.energy),
            accepted,
        });
        progress.update("fit", iterations as u64, s.iterations as u64);
        if improvement > s.stall_ratio {
            continue;
        }
        if n < 2 {
            break;
        }
        // stalled: teleportation
        for attempt in 0..s.teleport_attempts {
            if iterations >= s.iterations {
                break 'outer;
            }
            let Some(centers) = teleport_centers(samples, model, &best, attempt) else { break };
            let mut cand = step(samples, model, &centers, Some(&best));
            iterations += 1;
            // let the split settle: a few more Lloyd steps from the candidate while they help
            for _ in 0..s.settle_steps {
                if cand.energy < best.energy || iterations >= s.iterations {
                    break;
                }
                let c2: Vec<[f64; 3]> = cand.spheres.iter().map(|x| x.center).collect();
                let next = step(samples, model, &c2, Some(&cand));
                iterations += 1;
                if next.energy >= cand.energy {
                    break;
                }
                cand = next;
            }
            let accepted = cand.energy < best.energy;
            if accepted {
                best = cand.clone();
                tp_ok += 1;
            } else {
                tp_bad += 1;
            }
            log.push(IterationLog {
                iteration: iterations,
                kind: StepKind::Teleport,
                candidate_e: rel(cand.energy),
                e: rel(best.energy),
                accepted,
            });
            progress.update("fit", iterations as u64, s.iterations as u64);
            if accepted {
                continue 'outer;
            }
        }
        break;
    }
    LloydOutcome {
        spheres: best.spheres,
        assign: best.assign,
        log,
        iterations,
        teleports_accepted: tp_ok,
        teleports_rejected: tp_bad,
    }
}

/// k-means++ seeding over element positions (D² sampling with the seeded hash RNG).
pub(crate) fn init_centers(samples: &Samples, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let reps: Vec<[f64; 3]> = samples.elements.iter().map(|e| e.rep).collect();
    let mut rng = ItemRng::new(seed, stage::SPHERES, 0x696e_6974);
    let first = rng.below(reps.len() as u64) as usize;
    let mut centers = vec![reps[first]];
    let mut d2: Vec<f64> = reps.iter().map(|p| dist2(*p, reps[first])).collect();
    while centers.len() < n {
        let total: f64 = d2.iter().sum();
        let pick = if total > 0.0 {
            let mut target = rng.next_f64() * total;
            let mut idx = d2.len() - 1;
            for (i, &w) in d2.iter().enumerate() {
                if target < w {
                    idx = i;
                    break;
                }
                target -= w;
            }
            idx
        } else {
            rng.below(reps.len() as u64) as usize
        };
        let c = reps[pick];
        centers.push(c);
        for (i, p) in reps.iter().enumerate() {
            d2[i] = d2[i].min(dist2(*p, c));
        }
    }
    centers
}

/// Medial seeding: farthest-point sampling, from the deepest interior node, over the interior
/// nodes whose distance to the surface is within 0.3 grid cells of the largest among their 26
/// neighbours (a ridge of the distance field: the centre line of a tube, the mid-surface of a
/// plate). Spheres centred there bound a whole cross-section with the least bulge, which is
/// what thin parts need and what surface-dominated k-means++ seeds miss. `None` when there
/// are fewer ridge nodes than spheres.
pub(crate) fn ridge_nodes(samples: &Samples) -> Option<Vec<usize>> {
    let first = samples.surface_elements;
    let depth = &samples.interior_depth;
    if depth.len() != samples.elements.len() - first || depth.is_empty() {
        return None;
    }
    let [nx, ny, nz] = samples.grid_nodes;
    let mut at = vec![u32::MAX; nx * ny * nz];
    for (k, &node) in samples.interior_nodes.iter().enumerate() {
        at[node as usize] = k as u32;
    }
    let h = samples.grid_spacing;
    let mut ridge: Vec<usize> = Vec::new();
    for (k, &node) in samples.interior_nodes.iter().enumerate() {
        let node = node as usize;
        let (i, j, l) = (node % nx, (node / nx) % ny, node / (nx * ny));
        let mut best = 0.0f64;
        for dl in -1i64..=1 {
            for dj in -1i64..=1 {
                for di in -1i64..=1 {
                    let (ii, jj, ll) = (i as i64 + di, j as i64 + dj, l as i64 + dl);
                    if (di, dj, dl) == (0, 0, 0)
                        || ii < 0
                        || jj < 0
                        || ll < 0
                        || ii >= nx as i64
                        || jj >= ny as i64
                        || ll >= nz as i64
                    {
                        continue;
                    }
                    let m = at[ii as usize + nx * (jj as usize + ny * ll as usize)];
                    if m != u32::MAX {
                        best = best.max(depth[m as usize]);
                    }
                }
            }
        }
        if depth[k] + 0.3 * h >= best {
            ridge.push(k);
        }
    }
    Some(ridge)
}

pub(crate) fn medial_centers(samples: &Samples, n: usize) -> Option<Vec<[f64; 3]>> {
    let ridge = ridge_nodes(samples)?;
    if ridge.len() < n {
        return None;
    }
    let first = samples.surface_elements;
    let depth = &samples.interior_depth;
    let start = *ridge.iter().max_by(|&&a, &&b| depth[a].total_cmp(&depth[b]).then(b.cmp(&a)))?;
    Some(farthest_points(samples, &ridge, vec![samples.elements[first + start].rep], n))
}

/// `existing` centres followed by ridge nodes farthest-point sampled from them, `n` in all
/// (used to spend spheres the refinement dropped); `None` without enough ridge nodes.
pub fn more_medial_centers(samples: &Samples, existing: &[[f64; 3]], n: usize) -> Option<Vec<[f64; 3]>> {
    let ridge = ridge_nodes(samples)?;
    if existing.is_empty() || ridge.len() < n.saturating_sub(existing.len()) {
        return None;
    }
    Some(farthest_points(samples, &ridge, existing.to_vec(), n))
}

/// Farthest-point sampling over the ridge nodes, continuing from `centers`, up to `n`.
fn farthest_points(samples: &Samples, ridge: &[usize], mut centers: Vec<[f64; 3]>, n: usize) -> Vec<[f64; 3]> {
    let first = samples.surface_elements;
    let pos = |k: usize| samples.elements[first + k].rep;
    let mut d2: Vec<f64> =
        ridge.iter().map(|&k| centers.iter().map(|&c| dist2(pos(k), c)).fold(f64::INFINITY, f64::min)).collect();
    while centers.len() < n {
        let (mut bi, mut bd) = (0usize, -1.0f64);
        for (i, &d) in d2.iter().enumerate() {
            if d > bd {
                (bi, bd) = (i, d);
            }
        }
        let c = pos(ridge[bi]);
        centers.push(c);
        for (i, &k) in ridge.iter().enumerate() {
            d2[i] = d2[i].min(dist2(pos(k), c));
        }
    }
    centers
}

/// Clustering from `centers`, then a Powell update of every cluster sphere. A cluster whose
/// points and starting centre equal those of the same cluster in `prev` keeps its sphere
/// (Powell would start at its own optimum).
fn step(samples: &Samples, model: &VolumeModel, centers: &[[f64; 3]], prev: Option<&State>) -> State {
    let assign = cluster(samples, model, centers);
    let n = centers.len();
    let members = members(samples, &assign, n);
    let results: Vec<(Sphere, f64)> = (0..n)
        .into_par_iter()
        .map(|i| {
            if let Some(p) = prev {
                if p.spheres.get(i).is_some_and(|s| s.center == centers[i]) && p.members.get(i) == Some(&members[i]) {
                    return (p.spheres[i], p.outside[i]);
                }
            }
            let pts: Vec<[f64; 3]> = members[i].iter().map(|&k| samples.points[k as usize]).collect();
            update_sphere(model, &pts, centers[i])
        })
        .collect();
    let spheres: Vec<Sphere> = results.iter().map(|r| r.0).collect();
    let outside: Vec<f64> = results.iter().map(|r| r.1).collect();
    let energy = outside.iter().sum();
    State { spheres, outside, assign, members, energy }
}

/// The sorted distinct point ids of each cluster's elements.
fn members(samples: &Samples, assign: &[u32], n: usize) -> Vec<Vec<u32>> {
    let mut ids: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (e, &c) in assign.iter().enumerate() {
        ids[c as usize].extend_from_slice(samples.elements[e].point_ids());
    }
    ids.into_par_iter()
        .map(|mut v| {
            v.sort_unstable();
            v.dedup();
            v
        })
        .collect()
}

/// Powell's method on the centre, the radius constrained to bound the cluster (SHEXP §6.2).
/// Returns the sphere and its outside volume.
pub(crate) fn update_sphere(model: &VolumeModel, points: &[[f64; 3]], start: [f64; 3]) -> (Sphere, f64) {
    if points.is_empty() {
        return (Sphere::new(start, 0.0), 0.0);
    }
    let r0 = bounding_radius(start, points).max(model.grid().spec().h);
    let settings = PowellSettings { step: 0.25 * r0, xtol: 1e-3 * r0, ftol: 1e-4, max_iterations: 8 };
    let f = |c: [f64; 3]| model.outside_volume(c, bounding_radius(c, points));
    let res = minimize(f, start, &settings);
    let r = bounding_radius(res.x, points);
    (Sphere::new(res.x, r), res.f)
}

/// Largest radius tabulated by the clustering profiles (canonical units; the canonical
/// bounding-box diagonal is 1).
const PROFILE_MAX_RADIUS: f64 = 0.5;

/// Slack of the per-cell candidate test (canonical volume units; the canonical mesh has unit
/// bounding-box diagonal, so real cost differences are many orders of magnitude larger).
const CANDIDATE_SLACK: f64 = 1e-15;

/// Flood-fill clustering (see the module docs). Returns the cluster of every element.
fn cluster(samples: &Samples, model: &VolumeModel, centers: &[[f64; 3]]) -> Vec<u32> {
    let n = centers.len();
    let ne = samples.elements.len();
    let spec = model.grid().spec();
    // Radial profiles up to the farthest grid corner, but at most half the (unit) canonical
    // diagonal: beyond the table a profile counts all growth as outside volume, an upper
    // bound that only matters for spheres that would already be enormous.
    let profiles: Vec<_> = centers
        .par_iter()
        .map(|&c| {
            let mut r_max: f64 = 0.0;
            for k in 0..8 {
                let corner: [f64; 3] = std::array::from_fn(|d| {
                    spec.origin[d] + if k >> d & 1 == 1 { (spec.nodes[d] - 1) as f64 * spec.h } else { 0.0 }
                });
                r_max = r_max.max(dist(c, corner));
            }
            model.profile(c, r_max.min(PROFILE_MAX_RADIUS))
        })
        .collect();
    let mut assign = vec![u32::MAX; ne];
    let mut radius = vec![0.0f64; n];
    let mut base: Vec<f64> = (0..n).map(|i| profiles[i].at(radius[i])).collect(); // profile at the current radius
    let mut lb = vec![0.0f64; n];
    let mut cands: Vec<usize> = Vec::with_capacity(n);
    let mut queued = vec![false; samples.cell_count()];
    let mut queue = std::collections::VecDeque::new();
    let elem_dist = |e: usize, c: [f64; 3]| -> f64 {
        let el = &samples.elements[e];
        el.point_ids().iter().fold(0.0f64, |m, &p| m.max(dist2(samples.points[p as usize], c))).sqrt()
    };
    // seeds: each cluster takes its nearest free element (lowest index on ties). The scans
    // over all elements run in parallel, ignoring which elements earlier clusters took; a
    // cluster whose nearest element an earlier cluster took scans again, skipping taken ones.
    // The nearest element of the whole set, when free, is the nearest free one, so the result
    // equals the sequential scan's.
    let reps = samples.reps();
    let nearest = |c: [f64; 3], free: Option<&[u32]>| -> usize {
        let mut best = (f64::INFINITY, usize::MAX);
        for (e, &r) in reps.iter().enumerate() {
            if free.is_none_or(|a| a[e] == u32::MAX) {
                let d = dist2(r, c);
                if d < best.0 {
                    best = (d, e);
                }
            }
        }
        best.1
    };
    let first_choice: Vec<usize> = centers.par_iter().map(|&c| nearest(c, None)).collect();
    for (i, &c) in centers.iter().enumerate() {
        let mut e = first_choice[i];
        if e != usize::MAX && assign[e] != u32::MAX {
            e = nearest(c, Some(&assign));
        }
        if e == usize::MAX {
            continue;
        }
        assign[e] = i as u32;
        radius[i] = elem_dist(e, c);
        base[i] = profiles[i].at(radius[i]);
        let cell = samples.element_cell(e);
        if !queued[cell] {
            queued[cell] = true;
            queue.push_back(cell);
        }
    }
    let mut next_unassigned = 0usize;
    loop {
        while let Some(cell) = queue.pop_front() {
            // Candidate clusters for the whole cell: with B the box of the cell's element
            // points, a cluster's cost for any element lies between its cost at the nearest
            // and at the farthest point of B. Clusters whose lower bound exceeds the smallest
            // upper bound can win no element of the cell (radii only grow while the cell is
            // processed, which lowers only the growing clusters' bounds), so only the others
            // are evaluated; the result equals a scan of all clusters.
            let [lo, hi] = samples.cell_box(cell);
            let mut min_ub = f64::INFINITY;
            for i in 0..n {
                let c = centers[i];
                let (mut near, mut far) = (0.0, 0.0);
                for d in 0..3 {
                    let out = (lo[d] - c[d]).max(c[d] - hi[d]).max(0.0);
                    near += out * out;
                    let f = (c[d] - lo[d]).abs().max((hi[d] - c[d]).abs());
                    far += f * f;
                }
                let (near, far) = (near.sqrt(), far.sqrt());
                lb[i] = if near <= radius[i] { 0.0 } else { (profiles[i].at(near) - base[i]).max(0.0) };
                let ub = if far <= radius[i] { 0.0 } else { (profiles[i].at(far) - base[i]).max(0.0) };
                min_ub = min_ub.min(ub);
            }
            cands.clear();
            // (a tolerance far above rounding noise, far below any real volume difference)
            cands.extend((0..n).filter(|&i| lb[i] <= min_ub + CANDIDATE_SLACK));
            for (&e, pts) in samples.cell(cell).iter().zip(samples.cell_points(cell)) {
                let e = e as usize;
                if assign[e] != u32::MAX {
                    continue;
                }
                // the element's points, stored by cell (the same maximum as `elem_dist`: an
                // interior point is repeated, and max is idempotent)
                let mut best = (f64::INFINITY, f64::INFINITY, 0usize);
                for &i in &cands {
                    let c = centers[i];
                    let d = pts.iter().fold(0.0f64, |m, &q| m.max(dist2(q, c))).sqrt();
                    let cost = if d <= radius[i] { 0.0 } else { (profiles[i].at(d) - base[i]).max(0.0) };
                    if cost < best.0 || (cost == best.0 && d < best.1) {
                        best = (cost, d, i);
                    }
                }
                let i = best.2;
                assign[e] = i as u32;
                if best.1 > radius[i] {
                    radius[i] = best.1;
                    base[i] = profiles[i].at(radius[i]);
                }
            }
            samples.for_neighbors(cell, |nb| {
                if !queued[nb] && !samples.cell(nb).is_empty() {
                    queued[nb] = true;
                    queue.push_back(nb);
                }
            });
        }
        // disconnected pieces: continue from the first unassigned element
        while next_unassigned < ne && assign[next_unassigned] != u32::MAX {
            next_unassigned += 1;
        }
        if next_unassigned >= ne {
            break;
        }
        let cell = samples.element_cell(next_unassigned);
        if queued[cell] {
            // its cell was visited, so the element was assigned; unreachable, but be safe
            assign[next_unassigned] = 0;
            continue;
        }
        queued[cell] = true;
        queue.push_back(cell);
    }
    assign
}

/// Teleport candidate `attempt`: split the (attempt+1)-th worst cluster along its farthest
/// pair of points and delete the most-overlapped other cluster. `None` if there is no
/// cluster to delete.
fn teleport_centers(samples: &Samples, model: &VolumeModel, st: &State, attempt: usize) -> Option<Vec<[f64; 3]>> {
    let n = st.spheres.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| st.outside[b].total_cmp(&st.outside[a]).then(a.cmp(&b)));
    let worst = *order.get(attempt)?;
    // farthest pair (two alternations from the centroid, the usual approximation)
    let pts: Vec<[f64; 3]> = st.members[worst].iter().map(|&p| samples.points[p as usize]).collect();
    if pts.len() < 2 {
        return None;
    }
    let centroid: [f64; 3] = std::array::from_fn(|d| pts.iter().map(|p| p[d]).sum::<f64>() / pts.len() as f64);
    let farthest =
        |from: [f64; 3]| *pts.iter().max_by(|a, b| dist2(**a, from).total_cmp(&dist2(**b, from))).unwrap_or(&from);
    let mut a = farthest(centroid);
    let b = farthest(a);
    a = farthest(b);
    let (mut ga, mut gb) = ([0.0; 3], [0.0; 3]);
    let (mut na, mut nb) = (0usize, 0usize);
    for p in &pts {
        if dist2(*p, a) <= dist2(*p, b) {
            (0..3).for_each(|d| ga[d] += p[d]);
            na += 1;
        } else {
            (0..3).for_each(|d| gb[d] += p[d]);
            nb += 1;
        }
    }
    if na == 0 || nb == 0 {
        return None;
    }
    let ga = ga.map(|x| x / na as f64);
    let gb = gb.map(|x| x / nb as f64);
    // most-overlapped other cluster
    let overlaps: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|j| {
            if j == worst {
                return -1.0;
            }
            let others: Vec<Sphere> = (0..n).filter(|&k| k != j).map(|k| st.spheres[k]).collect();
            model.overlap_fraction(&st.spheres[j], &others)
        })
        .collect();
    let delete = (0..n).filter(|&j| j != worst).max_by(|&x, &y| overlaps[x].total_cmp(&overlaps[y]).then(y.cmp(&x)))?;
    let mut centers: Vec<[f64; 3]> = st.spheres.iter().map(|s| s.center).collect();
    centers[worst] = ga;
    centers[delete] = gb;
    Some(centers)
}
