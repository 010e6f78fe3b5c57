//! Union polish: coordinate descent on the union's outside volume `V(∪Sᵢ − T)` (issue 16).
//!
//! The Lloyd fit minimises SHEXP §6.2's E = Σ V(Sᵢ − T), and [`crate::refine`] only shrinks
//! spheres to what the others do not bound. Neither moves a sphere to where its outside volume
//! *overlaps* the outside volume of its neighbours, which is what the union (what leaks
//! light) rewards. This pass does that directly:
//!
//! - **Measure.** The outside region is sampled by a jittered lattice of spacing `h/subdiv`
//!   (`h` the signed-distance grid's cell; one hash-jittered point per lattice cell), each
//!   point classified *exactly* by the winding-number oracle, kept when it lies outside T and
//!   inside the region any sphere may reach. The union's outside volume is the number of kept
//!   points inside some sphere times the lattice cell volume: no grid blur (the volume model's
//!   soft indicator is one cell wide, and its ball quadrature has no sample in the outer 2 % of
//!   the radius, where a tight sphere's outside volume lies).
//! - **Constraint.** Every element (a whole sub-triangle or an interior point, see
//!   [`crate::samples`]) stays inside at least one sphere, whole. A sphere must keep the
//!   elements no other sphere contains whole (its *must* set); its radius is the bounding
//!   radius of their points about its centre, as in the Lloyd update.
//! - **Step.** Spheres are visited in order of decreasing exclusive outside volume (index order
//!   on ties); Powell (SHEXP's optimiser) moves the centre to minimise the outside points only
//!   this sphere covers, each point weighted by a ramp one lattice spacing wide across the
//!   sphere's surface (continuous in the centre). A move is kept only when it lowers that
//!   count, so the union's outside volume never increases. A sphere whose must set is empty
//!   is dropped. A sphere never leaves the ball `B(c₀, slack·r₀)` of its start, which bounds
//!   the region the lattice has to cover.
//!
//! Sequential in a fixed order with hash-based jitter: the same bytes for any thread count.

use penumbra_geometry::InsideOracle;

use crate::powell::{PowellSettings, minimize};
use crate::samples::Samples;
use crate::sphere::{Sphere, bounding_radius, dist, dist2};

/// Settings of the polish.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolishSettings {
    /// Sweeps over all spheres (at most; it stops when a sweep gains less than `min_gain`).
    pub sweeps: usize,
    /// Lattice points per grid cell along each axis.
    pub subdiv: usize,
    /// A sphere stays inside `B(c₀, slack·r₀)`.
    pub slack: f64,
    /// Stop when a sweep lowers the union's outside volume by less than this fraction.
    pub min_gain: f64,
    /// Seed of the jitter.
    pub seed: u64,
    /// Also move the boundary between overlapping pairs of spheres.
    pub pairs: bool,
    /// Nearest overlapping neighbours tried per sphere by the pair move.
    pub pair_neighbours: usize,
}

impl Default for PolishSettings {
    fn default() -> Self {
        Self { sweeps: 6, subdiv: 2, slack: 1.25, min_gain: 0.005, seed: 1, pairs: true, pair_neighbours: 4 }
    }
}

/// What the polish did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PolishStats {
    /// Sweeps run.
    pub sweeps: usize,
    /// Spheres dropped (nothing left that only they bounded).
    pub dropped: usize,
    /// Outside lattice points (the measure's resolution).
    pub lattice_points: usize,
    /// Union outside volume before and after, by the lattice (canonical units).
    pub union_before: f64,
    /// See `union_before`.
    pub union_after: f64,
}

/// Largest lattice (cells) the polish allocates; beyond it the spacing grows.
const MAX_LATTICE_CELLS: f64 = 8.0e6;

/// Lattice cells in the mean reachable ball, at most (see the spacing).
const BALL_POINTS: f64 = 30_000.0;

#[inline]
fn hash3(seed: u64, i: u64, j: u64, k: u64) -> u64 {
    let mut x = seed
        ^ i.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ j.wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ k.wrapping_mul(0x1656_67B1_9E37_79F9);
    // splitmix64 finaliser
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

#[inline]
fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Polishes `spheres` (canonical frame; `assign` gives every element a sphere containing it
/// whole). Returns the kept spheres, an owner for every element (a kept sphere containing it
/// whole), and what was done.
pub fn polish(
    samples: &Samples,
    oracle: &InsideOracle<'_>,
    spheres: &[Sphere],
    assign: &[u32],
    s: &PolishSettings,
) -> (Vec<Sphere>, Vec<u32>, PolishStats) {
    let n = spheres.len();
    let ne = samples.elements.len();
    let mut stats = PolishStats::default();
    if n == 0 || ne == 0 {
        return (spheres.to_vec(), assign.to_vec(), stats);
    }
    // every sphere contains its own elements whole (bounding radius about its centre)
    let mut sph: Vec<Sphere> = spheres.to_vec();
    {
        let mut pts: Vec<Vec<[f64; 3]>> = vec![Vec::new(); n];
        for (e, &o) in assign.iter().enumerate() {
            for &p in samples.elements[e].point_ids() {
                pts[o as usize].push(samples.points[p as usize]);
            }
        }
        for (i, x) in sph.iter_mut().enumerate() {
            x.radius = x.radius.max(bounding_radius(x.center, &pts[i]));
        }
    }
    let allowed: Vec<Sphere> = sph.iter().map(|x| Sphere::new(x.center, s.slack * x.radius)).collect();

    // ---- lattice of outside points inside the reachable region
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for a in &allowed {
        for d in 0..3 {
            lo[d] = lo[d].min(a.center[d] - a.radius);
            hi[d] = hi[d].max(a.center[d] + a.radius);
        }
    }
    // the lattice spacing: h/subdiv, coarser where the reachable balls are large (a thin plate
    // under 16 spheres), so that a ball holds at most about BALL_POINTS lattice cells and one
    // Powell evaluation stays cheap
    let mean_ball = allowed.iter().map(Sphere::volume).sum::<f64>() / n as f64;
    let mut step = (samples.grid_spacing / s.subdiv.max(1) as f64).max((mean_ball / BALL_POINTS).cbrt());
    let cells_at = |st: f64| -> f64 { (0..3).map(|d| ((hi[d] - lo[d]) / st).ceil().max(1.0)).product() };
    if cells_at(step) > MAX_LATTICE_CELLS {
        step *= (cells_at(step) / MAX_LATTICE_CELLS).cbrt();
    }
    let dims: [usize; 3] = std::array::from_fn(|d| (((hi[d] - lo[d]) / step).ceil() as usize).max(1));
    let mut seen = vec![0u64; (dims[0] * dims[1] * dims[2]).div_ceil(64)];
    let mut pts: Vec<[f64; 3]> = Vec::new();
    for a in &allowed {
        let range = |d: usize| {
            let i0 = (((a.center[d] - a.radius - lo[d]) / step).floor().max(0.0)) as usize;
            let i1 = ((((a.center[d] + a.radius - lo[d]) / step).ceil()) as usize).min(dims[d] - 1);
            (i0, i1)
        };
        let (rx, ry, rz) = (range(0), range(1), range(2));
        for k in rz.0..=rz.1 {
            for j in ry.0..=ry.1 {
                for i in rx.0..=rx.1 {
                    let idx = i + dims[0] * (j + dims[1] * k);
                    if seen[idx / 64] >> (idx % 64) & 1 == 1 {
                        continue;
                    }
                    let h = hash3(s.seed, i as u64, j as u64, k as u64);
                    let p = [
                        lo[0] + (i as f64 + unit(h)) * step,
                        lo[1] + (j as f64 + unit(hash3(h, 1, 0, 0))) * step,
                        lo[2] + (k as f64 + unit(hash3(h, 0, 1, 0))) * step,
                    ];
                    if !a.contains(p) {
                        continue;
                    }
                    seen[idx / 64] |= 1 << (idx % 64);
                    if !oracle.is_inside(p) {
                        pts.push(p);
                    }
                }
            }
        }
    }
    drop(seen);
    stats.lattice_points = pts.len();
    let cell_volume = step * step * step;

    // per-sphere candidate lists (points and elements inside the reachable ball)
    let mut cand_pts: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut cand_elems: Vec<Vec<u32>> = vec![Vec::new(); n];
    // a coarse bucket grid of the allowed balls keeps this linear in the point count
    let bucket = (allowed.iter().map(|a| a.radius).fold(0.0, f64::max) * 2.0).max(step);
    let bdims: [usize; 3] = std::array::from_fn(|d| (((hi[d] - lo[d]) / bucket).ceil() as usize).max(1));
    let bidx = |p: [f64; 3]| -> Option<usize> {
        let mut c = [0usize; 3];
        for d in 0..3 {
            let u = ((p[d] - lo[d]) / bucket).floor();
            if u < 0.0 || u >= bdims[d] as f64 {
                return None;
            }
            c[d] = u as usize;
        }
        Some(c[0] + bdims[0] * (c[1] + bdims[1] * c[2]))
    };
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); bdims[0] * bdims[1] * bdims[2]];
    for (i, a) in allowed.iter().enumerate() {
        // a ball of radius ≤ bucket/2 touches the buckets of its centre's 3×3×3 neighbourhood
        let c: [isize; 3] = std::array::from_fn(|d| ((a.center[d] - lo[d]) / bucket).floor() as isize);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let q = [c[0] + dx, c[1] + dy, c[2] + dz];
                    if (0..3).all(|d| q[d] >= 0 && (q[d] as usize) < bdims[d]) {
                        let b = q[0] as usize + bdims[0] * (q[1] as usize + bdims[1] * q[2] as usize);
                        buckets[b].push(i as u32);
                    }
                }
            }
        }
    }
    for (k, p) in pts.iter().enumerate() {
        if let Some(b) = bidx(*p) {
            for &i in &buckets[b] {
                if allowed[i as usize].contains(*p) {
                    cand_pts[i as usize].push(k as u32);
                }
            }
        }
    }
    for (e, el) in samples.elements.iter().enumerate() {
        if let Some(b) = bidx(el.rep) {
            for &i in &buckets[b] {
                let a = &allowed[i as usize];
                if el.point_ids().iter().all(|&q| a.contains(samples.points[q as usize])) {
                    cand_elems[i as usize].push(e as u32);
                }
            }
        }
    }
    drop(buckets);

    let mut st = State {
        samples,
        pts: &pts,
        step,
        allowed: &allowed,
        cand_pts: &cand_pts,
        cand_elems: &cand_elems,
        sph,
        alive: vec![true; n],
        pcnt: vec![0; pts.len()],
        ecnt: vec![0; ne],
        dropped: 0,
    };
    for i in 0..n {
        let x = st.sph[i];
        st.sph[i].radius = 0.0;
        st.apply(i, x);
    }
    let union_count = |pcnt: &[u16]| pcnt.iter().filter(|&&c| c > 0).count();
    stats.union_before = union_count(&st.pcnt) as f64 * cell_volume;
    for sweep in 0..s.sweeps {
        stats.sweeps += 1;
        let start = union_count(&st.pcnt);
        let excl: Vec<usize> = (0..n).map(|i| st.exclusive_count(i, st.sph[i])).collect();
        let mut order: Vec<usize> = (0..n).filter(|&i| st.alive[i]).collect();
        order.sort_by(|&a, &b| excl[b].cmp(&excl[a]).then(a.cmp(&b)));
        for &i in &order {
            st.single_move(i);
        }
        if s.pairs && sweep + 1 < s.sweeps {
            for &i in &order {
                if !st.alive[i] {
                    continue;
                }
                let mut nb: Vec<usize> = (0..n)
                    .filter(|&j| {
                        j != i
                            && st.alive[j]
                            && dist(st.sph[i].center, st.sph[j].center) < st.sph[i].radius + st.sph[j].radius
                    })
                    .collect();
                nb.sort_by(|&a, &b| {
                    dist2(st.sph[i].center, st.sph[a].center).total_cmp(&dist2(st.sph[i].center, st.sph[b].center))
                });
                for &j in nb.iter().take(s.pair_neighbours) {
                    if st.alive[i] && st.alive[j] {
                        st.pair_move(i, j);
                    }
                }
            }
        }
        let now = union_count(&st.pcnt);
        if (start.saturating_sub(now)) as f64 <= s.min_gain * start as f64 {
            break;
        }
    }
    stats.union_after = union_count(&st.pcnt) as f64 * cell_volume;
    stats.dropped = st.dropped;
    let State { sph, alive, .. } = st;
    let contains_elem = |x: &Sphere, e: usize| -> bool {
        samples.elements[e].point_ids().iter().all(|&q| x.contains(samples.points[q as usize]))
    };

    // owners: the largest kept sphere containing each element whole
    let mut new_index = vec![u32::MAX; n];
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        if alive[i] {
            new_index[i] = out.len() as u32;
            out.push(sph[i]);
        }
    }
    let mut owner = vec![u32::MAX; ne];
    let mut owner_r = vec![f64::NEG_INFINITY; ne];
    for i in 0..n {
        if !alive[i] {
            continue;
        }
        for &e in &cand_elems[i] {
            let e = e as usize;
            if sph[i].radius > owner_r[e] && contains_elem(&sph[i], e) {
                owner[e] = new_index[i];
                owner_r[e] = sph[i].radius;
            }
        }
    }
    debug_assert!(owner.iter().all(|&o| o != u32::MAX), "an element lost every sphere");
    // (cannot happen: a sphere keeps every element no other sphere contains; kept as a guard)
    for (e, o) in owner.iter_mut().enumerate() {
        if *o == u32::MAX {
            *o = new_index[assign[e] as usize].min(out.len().saturating_sub(1) as u32);
        }
    }
    (out, owner, stats)
}

/// The polish's state: spheres and the cover counts of outside points and elements.
struct State<'a> {
    samples: &'a Samples,
    pts: &'a [[f64; 3]],
    step: f64,
    allowed: &'a [Sphere],
    cand_pts: &'a [Vec<u32>],
    cand_elems: &'a [Vec<u32>],
    sph: Vec<Sphere>,
    alive: Vec<bool>,
    pcnt: Vec<u16>,
    ecnt: Vec<u16>,
    dropped: usize,
}

impl State<'_> {
    fn contains_elem(&self, x: &Sphere, e: usize) -> bool {
        self.samples.elements[e].point_ids().iter().all(|&q| x.contains(self.samples.points[q as usize]))
    }

    fn elem_points(&self, es: &[u32]) -> Vec<[f64; 3]> {
        es.iter()
            .flat_map(|&e| {
                self.samples.elements[e as usize].point_ids().iter().map(|&q| self.samples.points[q as usize])
            })
            .collect()
    }

    /// Replaces sphere `i` by `new`, updating the cover counts.
    fn apply(&mut self, i: usize, new: Sphere) {
        let cur = self.sph[i];
        for &k in &self.cand_pts[i] {
            let p = self.pts[k as usize];
            match (cur.radius > 0.0 && cur.contains(p), new.radius > 0.0 && new.contains(p)) {
                (true, false) => self.pcnt[k as usize] -= 1,
                (false, true) => self.pcnt[k as usize] += 1,
                _ => {}
            }
        }
        for &e in &self.cand_elems[i] {
            let e = e as usize;
            match (cur.radius > 0.0 && self.contains_elem(&cur, e), new.radius > 0.0 && self.contains_elem(&new, e)) {
                (true, false) => self.ecnt[e] -= 1,
                (false, true) => self.ecnt[e] += 1,
                _ => {}
            }
        }
        self.sph[i] = new;
    }

    /// Outside points `x` (standing in for sphere `i`) covers that no other sphere covers.
    fn exclusive_count(&self, i: usize, x: Sphere) -> usize {
        if x.radius <= 0.0 {
            return 0;
        }
        let cur = self.sph[i];
        self.cand_pts[i]
            .iter()
            .map(|&k| k as usize)
            .filter(|&k| {
                let p = self.pts[k];
                self.pcnt[k] - u16::from(cur.radius > 0.0 && cur.contains(p)) == 0 && x.contains(p)
            })
            .count()
    }

    /// Powell on the centre of sphere `i` with its radius bounding `must` (points), minimising
    /// the ramp-weighted count of `free` points inside; stays in the allowed ball.
    fn optimise(&self, i: usize, start: [f64; 3], must: &[[f64; 3]], free: &[[f64; 3]]) -> Option<Sphere> {
        let a = self.allowed[i];
        let r_cur = bounding_radius(start, must);
        let dmax = (a.radius - r_cur).max(0.0);
        let keep2 = (r_cur - 2.0 * dmax).max(0.0).powi(2);
        let mp: Vec<[f64; 3]> = must.iter().copied().filter(|p| dist2(*p, start) >= keep2).collect();
        let inv = 1.0 / self.step;
        let penalty = (free.len() as f64 + 1.0) * 1e3 * inv;
        let f = |c: [f64; 3]| -> f64 {
            let r = bounding_radius(c, &mp);
            let mut acc = 0.0;
            for p in free {
                let t = (r - dist(*p, c)) * inv + 0.5;
                acc += t.clamp(0.0, 1.0);
            }
            let excess = dist(c, a.center) + r - a.radius;
            if excess > 0.0 { acc + penalty * (1.0 + excess) } else { acc }
        };
        let settings =
            PowellSettings { step: 0.1 * r_cur.max(self.step), xtol: 0.05 * self.step, ftol: 1e-3, max_iterations: 4 };
        let res = minimize(f, start, &settings);
        let new = Sphere::new(res.x, bounding_radius(res.x, must));
        (dist(new.center, a.center) + new.radius <= a.radius).then_some(new)
    }

    /// Moves sphere `i` alone (or drops it when it bounds nothing no other sphere does).
    fn single_move(&mut self, i: usize) {
        if !self.alive[i] {
            return;
        }
        let cur = self.sph[i];
        let must: Vec<u32> = self.cand_elems[i]
            .iter()
            .copied()
            .filter(|&e| self.ecnt[e as usize] == 1 && self.contains_elem(&cur, e as usize))
            .collect();
        if must.is_empty() {
            self.apply(i, Sphere::new(cur.center, 0.0));
            self.alive[i] = false;
            self.dropped += 1;
            return;
        }
        let mp = self.elem_points(&must);
        let free: Vec<[f64; 3]> = self.cand_pts[i]
            .iter()
            .map(|&k| k as usize)
            .filter(|&k| self.pcnt[k] - u16::from(cur.contains(self.pts[k])) == 0)
            .map(|k| self.pts[k])
            .collect();
        let Some(new) = self.optimise(i, cur.center, &mp, &free) else { return };
        if self.exclusive_count(i, new) < self.exclusive_count(i, cur) {
            self.apply(i, new);
        }
    }

    /// Moves the boundary between overlapping spheres `i` and `j`: the elements only they bound
    /// are split by a plane across the line of their centres (the split with the fewest outside
    /// points in the pair's union, centres fixed), then both centres are re-optimised; kept only
    /// when the pair's exclusive outside count drops.
    fn pair_move(&mut self, i: usize, j: usize) {
        let (si, sj) = (self.sph[i], self.sph[j]);
        // elements bounded by i or j and by no other sphere
        let mut m: Vec<u32> = Vec::new();
        for &e in self.cand_elems[i].iter().chain(self.cand_elems[j].iter()) {
            let eu = e as usize;
            let (a, b) = (self.contains_elem(&si, eu), self.contains_elem(&sj, eu));
            if (a || b) && self.ecnt[eu] == u16::from(a) + u16::from(b) {
                m.push(e);
            }
        }
        m.sort_unstable();
        m.dedup();
        if m.len() < 2 {
            return;
        }
        let axis = [sj.center[0] - si.center[0], sj.center[1] - si.center[1], sj.center[2] - si.center[2]];
        let proj = |e: u32| -> f64 {
            let r = self.samples.elements[e as usize].rep;
            (0..3).map(|d| (r[d] - si.center[d]) * axis[d]).sum::<f64>()
        };
        let mut keyed: Vec<(f64, u32)> = m.iter().map(|&e| (proj(e), e)).collect();
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let order: Vec<u32> = keyed.iter().map(|x| x.1).collect();
        let len = order.len();
        // prefix/suffix bounding radii about the fixed centres
        let far = |c: [f64; 3], e: u32| -> f64 {
            self.samples.elements[e as usize]
                .point_ids()
                .iter()
                .map(|&q| dist2(c, self.samples.points[q as usize]))
                .fold(0.0, f64::max)
        };
        let mut pre = vec![0.0f64; len + 1];
        for k in 0..len {
            pre[k + 1] = pre[k].max(far(si.center, order[k]));
        }
        let mut suf = vec![0.0f64; len + 1];
        for k in (0..len).rev() {
            suf[k] = suf[k + 1].max(far(sj.center, order[k]));
        }
        // the pair's free points: outside points no third sphere covers
        let in_i = |p: [f64; 3]| self.allowed[i].contains(p);
        let mut free: Vec<[f64; 3]> = Vec::new();
        for (l, &k) in self.cand_pts[i].iter().chain(self.cand_pts[j].iter()).enumerate() {
            let p = self.pts[k as usize];
            if l >= self.cand_pts[i].len() && in_i(p) {
                continue;
            }
            let own = u16::from(si.contains(p)) + u16::from(sj.contains(p));
            if self.pcnt[k as usize] == own {
                free.push(p);
            }
        }
        let count = |a: &Sphere, b: &Sphere| free.iter().filter(|p| a.contains(**p) || b.contains(**p)).count();
        let before = count(&si, &sj);
        const SPLITS: usize = 24;
        let mut best: Option<(usize, usize)> = None;
        for q in 1..SPLITS {
            let k = q * len / SPLITS;
            if k == 0 || k >= len {
                continue;
            }
            let (ra, rb) = (pre[k].sqrt(), suf[k].sqrt());
            let (a, b) = (Sphere::new(si.center, ra), Sphere::new(sj.center, rb));
            let c = count(&a, &b);
            if best.is_none_or(|x| c < x.1) {
                best = Some((k, c));
            }
        }
        let Some((k, _)) = best else { return };
        let (ea, eb) = order.split_at(k);
        let (pa, pb) = (self.elem_points(ea), self.elem_points(eb));
        let a0 = Sphere::new(si.center, bounding_radius(si.center, &pa));
        let b0 = Sphere::new(sj.center, bounding_radius(sj.center, &pb));
        if dist(a0.center, self.allowed[i].center) + a0.radius > self.allowed[i].radius
            || dist(b0.center, self.allowed[j].center) + b0.radius > self.allowed[j].radius
        {
            return;
        }
        let (a1, b1) = {
            let ai = self.allowed[i];
            let free_a: Vec<[f64; 3]> = free.iter().copied().filter(|p| ai.contains(*p) && !b0.contains(*p)).collect();
            let a1 = self.optimise(i, a0.center, &pa, &free_a).unwrap_or(a0);
            let inside = |x: &Sphere, f: &[[f64; 3]]| f.iter().filter(|p| x.contains(**p)).count();
            let a1 = if inside(&a1, &free_a) <= inside(&a0, &free_a) { a1 } else { a0 };
            let aj = self.allowed[j];
            let free_b: Vec<[f64; 3]> = free.iter().copied().filter(|p| aj.contains(*p) && !a1.contains(*p)).collect();
            let b1 = self.optimise(j, b0.center, &pb, &free_b).unwrap_or(b0);
            let b1 = if inside(&b1, &free_b) <= inside(&b0, &free_b) { b1 } else { b0 };
            (a1, b1)
        };
        if count(&a1, &b1) < before {
            self.apply(i, a1);
            self.apply(j, b1);
        }
    }
}
