//! The sample-set bake: every (domain, centre, N) set by the electrostatic method and by the
//! three baselines, their weights, LOD logs and quality (MRT thesis §6.3.5).

use crate::quality::{noise, unit_vector};
use crate::sets::{ElectroParams, STAGE_VO, electrostatic, halton, item_id, lloyd, poisson};
use crate::voronoi::{Cells, Domain, Grid};
use penumbra_math::progress::Progress;
use penumbra_math::rng::ItemRng;
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicU64, Ordering};

/// Largest sample count of a set.
pub const MAX_COUNT: usize = 256;

/// Knobs of the bake (all recorded in the asset's `meta`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VoParams {
    /// Sample counts N to bake (each for both domains, with and without the centre sample).
    pub counts: Vec<usize>,
    /// Seed of every random draw.
    pub seed: u64,
    /// Electrostatic starting sets (best kept).
    pub starts: usize,
    /// Boundary-charge adaptations per start.
    pub rounds: usize,
    /// Repulsion steps per adaptation.
    pub steps: usize,
    /// Lloyd iterations of the Lloyd baseline.
    pub lloyd_iterations: usize,
    /// Discrete-diagram resolution of the boundary-charge adaptation: disk, ball (per axis).
    pub adapt_res: [usize; 2],
    /// Discrete-diagram resolution of the selection among starts and of Lloyd's iterations.
    pub opt_res: [usize; 2],
    /// Discrete-diagram resolution of the stored weights and metrics (thesis: 512², 128³).
    pub res: [usize; 2],
    /// Random half-spaces per noise measurement.
    pub noise_trials: usize,
    /// Edge of the random reflection textures (size × size texels).
    pub reflect_size: usize,
}

impl Default for VoParams {
    fn default() -> Self {
        let e = ElectroParams::default();
        VoParams {
            counts: (1..=64).collect(),
            seed: 1,
            starts: e.starts,
            rounds: e.rounds,
            steps: e.steps,
            lloyd_iterations: 30,
            adapt_res: [64, 16],
            opt_res: [128, 32],
            res: [512, 128],
            noise_trials: 4096,
            reflect_size: 4,
        }
    }
}

/// Why a bake cannot run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VoError {
    /// A parameter out of its range.
    #[error("{name} = {value} is out of range (allowed: {allowed})")]
    Range {
        /// Parameter.
        name: &'static str,
        /// Given value.
        value: String,
        /// Allowed range.
        allowed: &'static str,
    },
    /// A malformed VOSS asset.
    #[error("VOSS asset: {0}")]
    Asset(String),
}

impl VoParams {
    /// Checks every range.
    pub fn validate(&self) -> Result<(), VoError> {
        let range = |name, value: String, allowed| Err(VoError::Range { name, value, allowed });
        if self.counts.is_empty() || self.counts.iter().any(|&n| n == 0 || n > MAX_COUNT) {
            return range("counts", format!("{:?}", self.counts), "a non-empty list of 1..=256");
        }
        if self.counts.windows(2).any(|w| w[0] >= w[1]) {
            return range("counts", format!("{:?}", self.counts), "strictly increasing");
        }
        if !(1..=1000).contains(&self.starts) {
            return range("starts", self.starts.to_string(), "1..=1000");
        }
        if !(1..=1000).contains(&self.rounds) {
            return range("rounds", self.rounds.to_string(), "1..=1000");
        }
        if !(1..=10000).contains(&self.steps) {
            return range("steps", self.steps.to_string(), "1..=10000");
        }
        if self.lloyd_iterations > 10000 {
            return range("lloyd_iterations", self.lloyd_iterations.to_string(), "0..=10000");
        }
        for (name, r, max) in [
            ("adapt_res[0] (disk)", self.adapt_res[0], 4096),
            ("adapt_res[1] (ball)", self.adapt_res[1], 256),
            ("opt_res[0] (disk)", self.opt_res[0], 4096),
            ("opt_res[1] (ball)", self.opt_res[1], 256),
            ("res[0] (disk)", self.res[0], 4096),
            ("res[1] (ball)", self.res[1], 256),
        ] {
            if !r.is_power_of_two() || r < 16 || r > max {
                return range(name, r.to_string(), "a power of two, 16..=4096 (disk) or 16..=256 (ball)");
            }
        }
        if !(1..=1_000_000).contains(&self.noise_trials) {
            return range("noise_trials", self.noise_trials.to_string(), "1..=1000000");
        }
        if !(1..=256).contains(&self.reflect_size) {
            return range("reflect_size", self.reflect_size.to_string(), "1..=256");
        }
        Ok(())
    }

    fn electro(&self) -> ElectroParams {
        ElectroParams { starts: self.starts, rounds: self.rounds, steps: self.steps }
    }
}

/// Cell CV and estimator noise of one set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Quality {
    /// Coefficient of variation of the cell measures (0: equal cells, the goal of §6.3.5).
    pub cell_cv: f64,
    /// RMS error of the estimator over random half-spaces ([`crate::quality`]).
    pub noise: f64,
}

/// One stored (electrostatic) set.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleSet {
    /// Domain.
    pub domain: Domain,
    /// Whether sample 0 is the fixed centre.
    pub centre: bool,
    /// Samples (`D` coordinates used).
    pub points: Vec<[f64; 3]>,
    /// Cell measures μ (sum 1): the estimator weights.
    pub weights: Vec<f64>,
    /// `log₂(cell area / domain area)` (unweighted area or volume; area sampling's LOD, §6.3.2).
    pub log2area: Vec<f64>,
    /// Quality of this set.
    pub quality: Quality,
}

impl SampleSet {
    /// `{disk|ball}.{c0|c1}.n{N}` (the section-name prefix).
    pub fn key(&self) -> String {
        set_key(self.domain, self.centre, self.points.len())
    }

    /// `z_s = √(1 − x² − y²)` per sample (disk sets: the half chord of each line sample).
    pub fn z_s(&self) -> Vec<f64> {
        self.points.iter().map(|p| (1.0 - p[0] * p[0] - p[1] * p[1]).max(0.0).sqrt()).collect()
    }
}

/// Section-name prefix of a set.
pub fn set_key(domain: Domain, centre: bool, n: usize) -> String {
    format!("{}.c{}.n{}", domain.name(), u8::from(centre), n)
}

/// One row of the comparison: the electrostatic set and the three baselines at equal N.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// `disk` or `ball`.
    pub domain: &'static str,
    /// With the centre sample.
    pub centre: bool,
    /// N.
    pub n: usize,
    /// Electrostatic (the stored set).
    pub electrostatic: Quality,
    /// Lloyd relaxation from the first Poisson start.
    pub lloyd: Quality,
    /// Halton (bases 2, 3, 5) warped to the measure.
    pub halton: Quality,
    /// Poisson dart throwing (the first start).
    pub poisson: Quality,
}

/// The whole bake.
#[derive(Debug, Clone, PartialEq)]
pub struct VoBake {
    /// Stored sets, in order: disk c0, disk c1, ball c0, ball c1, each by increasing N.
    pub sets: Vec<SampleSet>,
    /// Comparison rows, same order.
    pub comparison: Vec<Comparison>,
    /// 2D reflection normals (size², 2) for line samples.
    pub reflect2d: Vec<[f64; 2]>,
    /// 3D reflection normals (size², 3) for point samples.
    pub reflect3d: Vec<[f64; 3]>,
}

/// The (domain, centre) families in bake order.
pub const FAMILIES: [(Domain, bool); 4] =
    [(Domain::Disk, false), (Domain::Disk, true), (Domain::Ball, false), (Domain::Ball, true)];

fn weights_of(grid: &Grid, pts: &[[f64; 3]]) -> (Cells, Vec<f64>) {
    let c = grid.cells(pts);
    let floor = 1.0 / grid.res().pow(grid.domain().dim() as u32) as f64;
    let l = c.area.iter().map(|&a| a.max(floor).log2()).collect();
    (c, l)
}

fn quality(grid: &Grid, pts: &[[f64; 3]], p: &VoParams, item: u64) -> (Quality, Cells, Vec<f64>) {
    let (c, l) = weights_of(grid, pts);
    let q = Quality { cell_cv: c.cv(), noise: noise(grid.domain(), pts, &c.mass, p.noise_trials, p.seed, item) };
    (q, c, l)
}

/// Bakes every set of `p` (parallel over sets; bytes independent of the thread count).
pub fn bake(p: &VoParams, progress: &dyn Progress) -> Result<VoBake, VoError> {
    p.validate()?;
    let grids = [
        (
            Grid::new(Domain::Disk, p.adapt_res[0]),
            Grid::new(Domain::Disk, p.opt_res[0]),
            Grid::new(Domain::Disk, p.res[0]),
        ),
        (
            Grid::new(Domain::Ball, p.adapt_res[1]),
            Grid::new(Domain::Ball, p.opt_res[1]),
            Grid::new(Domain::Ball, p.res[1]),
        ),
    ];
    let items: Vec<(Domain, bool, usize)> =
        FAMILIES.iter().flat_map(|&(d, c)| p.counts.iter().map(move |&n| (d, c, n))).collect();
    let total = items.len() as u64;
    let done = AtomicU64::new(0);
    let e = p.electro();
    let out: Vec<(SampleSet, Comparison)> = items
        .par_iter()
        .map(|&(domain, centre, n)| {
            let (adapt, opt, fine) = &grids[usize::from(domain == Domain::Ball)];
            let item = item_id(domain, centre, n, 0);
            let es = electrostatic(adapt, opt, n, centre, p.seed, &e);
            let mut rng = ItemRng::new(p.seed, STAGE_VO, item);
            let pois = poisson(domain, n, centre, &mut rng);
            let ll = lloyd(opt, pois.clone(), centre, p.lloyd_iterations);
            let ha = halton(domain, n, centre);
            let (qe, ce, le) = quality(fine, &es, p, item);
            let cmp = Comparison {
                domain: domain.name(),
                centre,
                n,
                electrostatic: qe,
                lloyd: quality(fine, &ll, p, item).0,
                halton: quality(fine, &ha, p, item).0,
                poisson: quality(fine, &pois, p, item).0,
            };
            let set = SampleSet { domain, centre, points: es, weights: ce.mass, log2area: le, quality: qe };
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress.update("vo sets", k, total);
            (set, cmp)
        })
        .collect();
    let (sets, comparison) = out.into_iter().unzip();
    let s = p.reflect_size * p.reflect_size;
    let mut r = ItemRng::new(p.seed, STAGE_VO, 0x7e_f1ec7);
    let reflect2d = (0..s)
        .map(|_| {
            let a = std::f64::consts::TAU * r.next_f64();
            [a.cos(), a.sin()]
        })
        .collect();
    let reflect3d = (0..s).map(|_| unit_vector(r.next_f64(), r.next_f64(), false)).collect();
    Ok(VoBake { sets, comparison, reflect2d, reflect3d })
}

/// How the electrostatic sets compare with one baseline over the rows `2 ≤ N ≤ max_n`
/// (N = 1 is one cell whatever the method).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VersusBaseline {
    /// Rows compared.
    pub rows: usize,
    /// Median of electrostatic / baseline cell CV (rows where the baseline's CV > 10⁻⁶).
    pub cell_cv_ratio_median: f64,
    /// Median of electrostatic / baseline noise.
    pub noise_ratio_median: f64,
    /// Rows where the electrostatic CV is at least 20 % lower (the DESIGN goal).
    pub cell_cv_wins_20pct: usize,
    /// Rows where the electrostatic noise is at least 20 % lower.
    pub noise_wins_20pct: usize,
    /// Rows where the electrostatic noise is lower at all.
    pub noise_wins: usize,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

/// [`VersusBaseline`] for Lloyd, Halton and Poisson (in that order) over `2 ≤ N ≤ max_n`.
pub fn versus(rows: &[Comparison], max_n: usize) -> [(&'static str, VersusBaseline); 3] {
    type Pick = fn(&Comparison) -> Quality;
    let pick: [(&'static str, Pick); 3] =
        [("lloyd", |c| c.lloyd), ("halton", |c| c.halton), ("poisson", |c| c.poisson)];
    pick.map(|(name, f)| {
        let rs: Vec<&Comparison> = rows.iter().filter(|c| c.n >= 2 && c.n <= max_n).collect();
        let cv: Vec<f64> =
            rs.iter().filter(|c| f(c).cell_cv > 1e-6).map(|c| c.electrostatic.cell_cv / f(c).cell_cv).collect();
        let no: Vec<f64> = rs.iter().map(|c| c.electrostatic.noise / f(c).noise).collect();
        (
            name,
            VersusBaseline {
                rows: rs.len(),
                cell_cv_ratio_median: median(cv),
                noise_ratio_median: median(no.clone()),
                cell_cv_wins_20pct: rs.iter().filter(|c| c.electrostatic.cell_cv <= 0.8 * f(c).cell_cv).count(),
                noise_wins_20pct: no.iter().filter(|&&r| r <= 0.8).count(),
                noise_wins: no.iter().filter(|&&r| r < 1.0).count(),
            },
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_math::progress::NoProgress;

    fn small() -> VoParams {
        VoParams {
            counts: vec![1, 4, 6],
            starts: 4,
            rounds: 4,
            steps: 10,
            lloyd_iterations: 5,
            adapt_res: [32, 16],
            opt_res: [64, 16],
            res: [128, 32],
            noise_trials: 256,
            ..VoParams::default()
        }
    }

    #[test]
    fn bake_is_deterministic_and_thread_independent() {
        let p = small();
        let a = bake(&p, &NoProgress).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let b = pool.install(|| bake(&p, &NoProgress).unwrap());
        assert_eq!(a, b);
        assert_eq!(a.sets.len(), 12);
        for s in &a.sets {
            assert!((s.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(s.points.iter().all(|q| q[0] * q[0] + q[1] * q[1] + q[2] * q[2] < 1.0));
            if s.centre {
                assert_eq!(s.points[0], [0.0; 3]);
            }
            if s.domain == Domain::Disk {
                assert!(s.points.iter().all(|q| q[2] == 0.0));
            }
            // log2area = log2 of the unweighted area fractions, which sum to 1
            let a: f64 = s.log2area.iter().map(|l| l.exp2()).sum();
            assert!((a - 1.0).abs() < 1e-9);
        }
        // one sample: the whole domain, log2area 0
        assert_eq!(a.sets[0].weights, vec![1.0]);
        assert_eq!(a.sets[0].log2area, vec![0.0]);
        // four samples in the ball: the electrostatic set is (close to) a regular tetrahedron,
        // four equal cells
        let t = a.sets.iter().find(|s| s.domain == Domain::Ball && !s.centre && s.points.len() == 4).unwrap();
        assert!(t.quality.cell_cv < 0.02, "{}", t.quality.cell_cv);
        assert_eq!(a.reflect2d.len(), 16);
        assert!(a.reflect3d.iter().all(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] - 1.0).abs() < 1e-12));
    }

    #[test]
    fn bad_parameters_name_the_range() {
        let mut p = small();
        p.counts = vec![0, 3];
        assert!(p.validate().unwrap_err().to_string().contains("counts"));
        let mut p = small();
        p.res = [100, 32];
        assert!(p.validate().unwrap_err().to_string().contains("power of two"));
        let mut p = small();
        p.counts = vec![3, 3];
        assert!(p.validate().is_err());
    }

    #[test]
    fn asset_round_trip() {
        let b = bake(&small(), &NoProgress).unwrap();
        let bytes = crate::asset::to_asset(&b, serde_json::json!({}), Some("k")).unwrap().to_bytes().unwrap();
        let a = penumbra_asset::Asset::parse(&bytes).unwrap();
        assert_eq!(a.kind(), penumbra_asset::Kind::VOSS);
        let names = crate::asset::section_names(&[1, 4, 6]);
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        a.require_known(&names).unwrap();
        assert_eq!(a.sections().len(), names.len());
        for s in &b.sets {
            let r = crate::asset::read_set(&a, s.domain, s.centre, s.points.len()).unwrap().unwrap();
            assert!(s.matches(&r));
        }
        assert!(crate::asset::read_set(&a, Domain::Ball, true, 5).unwrap().is_none());
        assert_eq!(crate::asset::read_reflections(&a, Domain::Ball).unwrap().len(), 16);
    }
}
