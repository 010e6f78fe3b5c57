//! The FIV bake (FIV §4.2): the occluded-environment FIV at every shell sample, inside
//! flags, the irradiance cube map and the environment FIV.
//!
//! # Visibility
//! For the sample at `p`, texel `t` is occluded when the ray `p + s·ω_t`, `s ≥ 0`, hits the
//! occluder (the paper's binary cube mask, Fig. 5); the sample's FIV is
//! `Σ_{t occluded} L_t ω_t dΩ_t` (FIV eq. 9 on the occluded environment), per channel.
//! Rays are only cast toward texels that can be occluded: a sample at distance `ρ > R` from
//! the ball centre sees the ball inside the cone of half-angle `α = asin(R/ρ)` around the
//! direction to the centre, so a tile of texels whose bounding cone (half-angle β) lies
//! farther than `α + β` from that axis is skipped whole, and a texel of a surviving tile is
//! traced only when its direction is within `α` of the axis (with a 1e-9 margin, so the
//! skipping is exact: a skipped ray cannot touch the ball). Samples on or inside the ball
//! trace every texel. Ray casting is exact ([`MeshBvh::any_hit`]: watertight f64 triangle
//! test, first hit ends the ray). Before a ray is cast, the per-texel silhouette bitmaps of
//! [`crate::silhouette`] skip rays whose line certainly misses the mesh and accept, without
//! a ray, rays that certainly hit it ([`crate::interior`]); both are proofs, so the mask —
//! and every bit of the result — is the one that tracing every ray gives.
//!
//! # Inside flags
//! A sample on or inside the ball (`ρ ≤ R`) is flagged inside when the generalized winding
//! number `w` of the mesh has `|w| ≥ ½` there (robust for open meshes such as the scanned
//! bunny, and for either orientation of the triangles). The
//! runtime drops flagged samples from its interpolation (FIV §4.3.2), so their FIV is not
//! computed: it is stored as 0 and no ray is cast.
//!
//! # Determinism
//! Every sample is summed sequentially in a fixed texel order (tile by tile); samples are
//! independent and written to fixed slots, so the output is the same for any thread count,
//! and a shard computes exactly the bits a whole bake computes for its samples.

use crate::error::FivError;
use crate::layout::{Frame, Shard, ShellLayout};
use crate::lighting::Lighting;
use crate::silhouette::{Class, Silhouettes};
use penumbra_geometry::{MeshBvh, TraversalStack, TriMesh, WindingNumber, min_enclosing_ball};
use penumbra_math::progress::Progress;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Allowed cube face sizes of the environment.
pub const CUBE_SIZE: core::ops::RangeInclusive<usize> = 1..=512;
/// Default cube face size (the paper's 6×32×32).
pub const DEFAULT_CUBE_SIZE: usize = 32;
/// Allowed irradiance cube face sizes.
pub const IRRADIANCE_SIZE: core::ops::RangeInclusive<usize> = 1..=256;
/// Default irradiance cube face size.
pub const DEFAULT_IRRADIANCE_SIZE: usize = 32;

/// Parameters of a FIV bake.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FivParams {
    /// Shell sampling.
    pub layout: ShellLayout,
    /// Face size of the irradiance cube map.
    pub irradiance_size: usize,
}

impl FivParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<(), FivError> {
        self.layout.validate().map_err(FivError::Layout)?;
        if !IRRADIANCE_SIZE.contains(&self.irradiance_size) {
            return Err(FivError::Parameter(format!(
                "irradiance cube size {} is out of range (allowed: {}..={})",
                self.irradiance_size,
                IRRADIANCE_SIZE.start(),
                IRRADIANCE_SIZE.end()
            )));
        }
        Ok(())
    }
}

/// An occluder ready for the bake: its mesh, BVH, winding number and frame.
#[derive(Debug)]
pub struct Occluder {
    mesh: TriMesh,
    bvh: MeshBvh,
    winding: WindingNumber,
    frame: Frame,
}

impl Occluder {
    /// Validates the mesh and computes the frame: the minimum enclosing ball of the vertices
    /// that triangles reference (unreferenced vertices are ignored).
    pub fn new(mesh: TriMesh) -> Result<Self, FivError> {
        mesh.validate().map_err(|e| FivError::Mesh(e.to_string()))?;
        let mut used = vec![false; mesh.positions.len()];
        for t in &mesh.indices {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let pts: Vec<[f64; 3]> = mesh.positions.iter().zip(&used).filter(|(_, u)| **u).map(|(p, _)| *p).collect();
        let ball = min_enclosing_ball(&pts).ok_or_else(|| FivError::Mesh("no finite vertices".into()))?;
        if !(ball.radius > 0.0 && ball.radius.is_finite()) {
            return Err(FivError::Mesh(format!("degenerate: its bounding radius is {}", ball.radius)));
        }
        let bvh = MeshBvh::build(&mesh).map_err(|e| FivError::Mesh(e.to_string()))?;
        let winding = WindingNumber::new(&mesh);
        Ok(Self { mesh, bvh, winding, frame: Frame { center: ball.center, radius: ball.radius } })
    }

    /// The mesh.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// The BVH.
    pub fn bvh(&self) -> &MeshBvh {
        &self.bvh
    }

    /// The frame (minimum enclosing ball).
    pub fn frame(&self) -> Frame {
        self.frame
    }

    /// Whether `p` is inside the mesh: `|w| ≥ ½` for the generalized winding number `w`, so
    /// an inside-out mesh (consistently reversed triangles, `w ≈ −1` inside) is flagged the
    /// same as the one authored outward.
    pub fn is_inside(&self, p: [f64; 3]) -> bool {
        self.winding.winding_number(p).abs() >= 0.5
    }
}

/// Counters of a bake (deterministic; they add up over shards).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BakeStats {
    /// Rays cast.
    pub rays_traced: u64,
    /// Texels found occluded: rays cast that hit plus hits certified without a ray.
    pub rays_hit: u64,
    /// Hits certified by the interior balls without casting a ray.
    pub rays_certified: u64,
    /// Samples flagged inside.
    pub inside_samples: u64,
}

/// The result of a bake (or of one shard).
#[derive(Debug, Clone)]
pub struct FivBake {
    /// Parameters.
    pub params: FivParams,
    /// Occluder frame.
    pub frame: Frame,
    /// Cube face size of the environment.
    pub cube_size: usize,
    /// The shard baked ([`Shard::WHOLE`] for a whole bake).
    pub shard: Shard,
    /// Occluded-environment FIVs, `[a1 − a0, P, K, 3 (rgb), 3 (xyz)]` for the shard's
    /// azimuth slab `[a0, a1)`.
    pub fiv: Vec<f32>,
    /// Inside flags (1 = inside), `[a1 − a0, P, K]`.
    pub inside: Vec<u8>,
    /// Irradiance cube, `[6, S, S, 3]`.
    pub irradiance: Vec<f32>,
    /// Environment FIV `[rgb][xyz]`.
    pub env_fiv: [[f32; 3]; 3],
    /// Counters.
    pub stats: BakeStats,
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Whether building the silhouette bitmaps pays off for `rows` (azimuth, polar) rows of the
/// layout (always the whole bake's rows, so every shard decides alike and the ray counters
/// of shards add up to the single run's): the rays the bounding cones let through
/// (estimated from the cones' solid angles) against the building work (one stamp per
/// cluster and bitmap at ~2/3 of a ray, plus ~5M rays' worth for the interior balls;
/// measured on the bunnies). Only the speed depends on this choice, never the result.
fn worth_culling(occ: &Occluder, lighting: &Lighting, l: &ShellLayout, rows: usize) -> bool {
    let mut cone_rays = 0.0;
    for k in 0..l.radial {
        let r = l.rho_over_r(k);
        let frac = if r <= 1.0 { 1.0 } else { 0.5 * (1.0 - (1.0 - 1.0 / (r * r)).sqrt()) };
        cone_rays += frac * (rows * lighting.texel_count()) as f64;
    }
    let stamps = (lighting.texel_count() / 2) as f64 * (occ.mesh().indices.len() as f64 / 16.0).ceil();
    cone_rays > 0.67 * stamps + 5.0e6
}

/// (Azimuth, polar) rows traced together by [`FivTracer::block`] in a bake (speed only:
/// stanford-bunny 128×65×30, one thread, 8.7 s user with 8 rows, 7.4 s with 260, 7.2 s with
/// 1040; 256 leaves 33 blocks for the threads to share).
const BLOCK_ROWS: usize = 256;

/// Traces the occluded-environment FIV of sample positions around one occluder.
#[derive(Debug)]
pub struct FivTracer<'a> {
    occ: &'a Occluder,
    lighting: &'a Lighting,
    sil: Option<Silhouettes>,
}

impl<'a> FivTracer<'a> {
    /// A tracer; `cull` builds the silhouette bitmaps ([`crate::silhouette`]) that skip rays
    /// which certainly miss (the result is the same either way, only faster).
    pub fn new(occ: &'a Occluder, lighting: &'a Lighting, cull: bool) -> Self {
        let sil = if cull { Silhouettes::build(occ, lighting) } else { None };
        Self { occ, lighting, sil }
    }

    /// Whether silhouette culling is active.
    pub fn culls(&self) -> bool {
        self.sil.is_some()
    }

    /// The occluded-environment FIV seen from `p`, with its counters (`inside_samples` 0).
    pub fn fiv(&self, p: [f64; 3]) -> ([[f64; 3]; 3], BakeStats) {
        self.fiv_with(p, &mut self.occ.bvh.traversal_stack())
    }

    /// [`FivTracer::fiv`] with a caller-held traversal stack (no allocation).
    pub fn fiv_with(&self, p: [f64; 3], stack: &mut TraversalStack) -> ([[f64; 3]; 3], BakeStats) {
        let mut acc = [[[0.0f64; 3]; 3]];
        let st = self.fiv_multi(p, stack, &[self.lighting], &mut acc);
        (acc[0], st)
    }

    /// The occluded FIVs seen from `p` under several environments at once, from one
    /// visibility pass: `out[e]` accumulates `Σ_t L^e_t ω_t dΩ_t` over the texels occluded
    /// from `p`, in the same texel order as a bake under `envs[e]` alone (so the same bits).
    /// Every environment must have the tracer's cube size (directions and solid angles are
    /// the tracer's; only the radiance differs).
    pub fn fiv_multi(
        &self,
        p: [f64; 3],
        stack: &mut TraversalStack,
        envs: &[&Lighting],
        out: &mut [[[f64; 3]; 3]],
    ) -> BakeStats {
        debug_assert_eq!(envs.len(), out.len());
        let view = self.view(p);
        let mut st = BakeStats::default();
        self.block(core::slice::from_ref(&view), stack, envs, out, &mut Vec::new(), &mut st);
        st
    }

    /// What the visibility pass needs to know of the sample at `p`, computed once.
    pub(crate) fn view(&self, p: [f64; 3]) -> SampleView {
        let f = self.occ.frame;
        let to_c = [f.center[0] - p[0], f.center[1] - p[1], f.center[2] - p[2]];
        let rho = dot(to_c, to_c).sqrt();
        // A ray heading away from the centre's side (d·(c − p) ≤ 0) stays within
        // √(R² − ρ²) of p while inside the ball (0 from on or outside it); when no mesh point
        // is that close, it cannot hit. Decided once per sample near the ball's surface (the
        // innermost shell at ρ = R, whose rounded positions fall on either side of it).
        let away_misses = rho >= f.radius * (1.0 - 1e-6) && {
            let reach = (f.radius * f.radius - rho * rho).max(0.0).sqrt();
            self.occ.bvh.closest_point_within(p, reach).is_none()
        };
        let whole = rho <= f.radius;
        let (axis, sin_a, cos_a) = if whole {
            ([0.0; 3], 1.0, -1.0)
        } else {
            let sin_a = f.radius / rho;
            (to_c.map(|v| v / rho), sin_a, (1.0 - sin_a * sin_a).max(0.0).sqrt())
        };
        SampleView { p, to_c, outside: rho >= f.radius, away_misses, whole, axis, sin_a, cos_a }
    }

    /// The visibility pass of several samples at once, texel-major: for every texel (in the
    /// fixed tile order) every sample whose cone admits it, so each sample's sums see their
    /// texels in exactly the order [`FivTracer::fiv_multi`] gives one sample alone (the same
    /// bits), while consecutive rays share a direction and come from neighbouring samples
    /// (the same silhouette bitmap, nearby BVH nodes: far fewer cache misses).
    /// `out[s · envs.len() + e]` accumulates sample `s` under environment `e`; `live` is
    /// scratch.
    pub(crate) fn block(
        &self,
        views: &[SampleView],
        stack: &mut TraversalStack,
        envs: &[&Lighting],
        out: &mut [[[f64; 3]; 3]],
        live: &mut Vec<u32>,
        stats: &mut BakeStats,
    ) {
        debug_assert_eq!(views.len() * envs.len(), out.len());
        let (occ, lighting) = (self.occ, self.lighting);
        let n_env = envs.len();
        const MARGIN: f64 = 1e-9;
        for tile in &lighting.tiles {
            live.clear();
            for (s, v) in views.iter().enumerate() {
                // angle(axis, tile axis) ≤ α + β  ⟺  cos ≥ cos(α + β) (α + β < π here)
                if v.whole || dot(v.axis, tile.axis) >= (v.cos_a * tile.cos_b - v.sin_a * tile.sin_b) - MARGIN {
                    live.push(s as u32);
                }
            }
            if live.is_empty() {
                continue;
            }
            for &t in &lighting.tile_texels[tile.start as usize..tile.end as usize] {
                let t = t as usize;
                let d = lighting.direction(t);
                for &s in live.iter() {
                    let v = &views[s as usize];
                    if !(v.whole || dot(v.axis, d) >= v.cos_a - MARGIN) {
                        continue;
                    }
                    let towards = dot(d, v.to_c) > 0.0;
                    if v.away_misses && !towards {
                        continue;
                    }
                    // from on or outside the ball, a ray heading toward its centre side has
                    // the ball's whole chord ahead of it: only then can a hit be certified
                    let ahead = v.outside && towards;
                    let hit = match self.sil.as_ref().map_or(Class::Trace, |sil| sil.classify(t, v.p, ahead)) {
                        Class::Miss => false,
                        Class::Hit => {
                            stats.rays_certified += 1;
                            true
                        }
                        Class::Trace => {
                            stats.rays_traced += 1;
                            occ.bvh.any_hit_prepared(v.p, lighting.prepared(t), 0.0, f64::INFINITY, stack)
                        }
                    };
                    if hit {
                        stats.rays_hit += 1;
                        let base = s as usize * n_env;
                        for (acc, env) in out[base..base + n_env].iter_mut().zip(envs) {
                            let w = env.weight(t);
                            for c in 0..3 {
                                for x in 0..3 {
                                    acc[c][x] += w[c] * d[x];
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// One sample as the visibility pass sees it ([`FivTracer::view`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SampleView {
    p: [f64; 3],
    /// `c − p`.
    to_c: [f64; 3],
    /// `ρ ≥ R`.
    outside: bool,
    /// Rays heading away from the centre's side certainly miss.
    away_misses: bool,
    /// `ρ ≤ R`: every texel is a candidate (no cone).
    whole: bool,
    /// Unit direction to the centre and the cone's `sin α = R/ρ`, `cos α` (unused if `whole`).
    axis: [f64; 3],
    sin_a: f64,
    cos_a: f64,
}

/// Whether to build the silhouette bitmaps ([`crate::silhouette`]); only the speed and the
/// `rays_traced`/`rays_certified` counters depend on it, never the FIVs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Culling {
    /// When the bake is large enough to pay for them (the default).
    #[default]
    Auto,
    /// Always.
    Always,
    /// Never: the bounding cone alone (for benchmarks and comparisons).
    Never,
}

/// Bakes the samples of `shard` (all of them for [`Shard::WHOLE`]), parallel over
/// (azimuth, polar) rows; `progress` is called once per row with stage `"fiv"`.
pub fn bake(
    occ: &Occluder,
    lighting: &Lighting,
    params: &FivParams,
    shard: Shard,
    progress: &dyn Progress,
) -> Result<FivBake, FivError> {
    bake_with(occ, lighting, params, shard, progress, Culling::Auto)
}

/// [`bake`] with an explicit [`Culling`] choice.
pub fn bake_with(
    occ: &Occluder,
    lighting: &Lighting,
    params: &FivParams,
    shard: Shard,
    progress: &dyn Progress,
    culling: Culling,
) -> Result<FivBake, FivError> {
    let mut v = bake_multi(occ, &[lighting], params, shard, progress, culling)?;
    Ok(v.remove(0))
}

/// Bakes one table per environment from a single visibility pass (visibility does not
/// depend on the environment; each extra environment costs 9 multiply-adds per occluded
/// texel). Table `e` has exactly the bytes [`bake_with`] gives under `envs[e]` alone. All
/// environments must share one cube size.
pub fn bake_multi(
    occ: &Occluder,
    envs: &[&Lighting],
    params: &FivParams,
    shard: Shard,
    progress: &dyn Progress,
    culling: Culling,
) -> Result<Vec<FivBake>, FivError> {
    let Some(&lighting) = envs.first() else {
        return Err(FivError::Parameter("no environment to bake".into()));
    };
    if let Some(e) = envs.iter().find(|e| e.cube().size() != lighting.cube().size()) {
        return Err(FivError::Parameter(format!(
            "environments of one bake need one cube size ({} and {})",
            lighting.cube().size(),
            e.cube().size()
        )));
    }
    let n_env = envs.len();
    params.validate()?;
    let l = params.layout;
    shard.validate(l.azimuth).map_err(FivError::Shard)?;
    let range = shard.azimuth_range(l.azimuth);
    let rows = range.len() * l.polar;
    let k = l.radial;
    let frame = occ.frame;
    // [row][env][k][9]: one row's tables for every environment side by side
    let mut fiv = vec![0.0f32; rows * n_env * k * 9];
    let mut inside = vec![0u8; rows * k];
    let cull = match culling {
        Culling::Auto => worth_culling(occ, lighting, &l, l.azimuth * l.polar),
        Culling::Always => true,
        Culling::Never => false,
    };
    let tracer = FivTracer::new(occ, lighting, cull);
    let done = AtomicU64::new(0);
    let (rays, hits, cert, ins) = (AtomicU64::new(0), AtomicU64::new(0), AtomicU64::new(0), AtomicU64::new(0));
    progress.update("fiv", 0, rows as u64);
    // blocks of consecutive (azimuth, polar) rows, each traced texel-major
    // ([`FivTracer::block`]); the block size changes the speed only, never a bit
    let block_rows = BLOCK_ROWS.min(rows.max(1));
    fiv.par_chunks_mut(block_rows * n_env * k * 9).zip(inside.par_chunks_mut(block_rows * k)).enumerate().for_each(
        |(b, (out, flags))| {
            let row0 = b * block_rows;
            let n_rows = flags.len() / k;
            let mut n_in = 0u64;
            let mut views = Vec::with_capacity(n_rows * k);
            let mut slots = Vec::with_capacity(n_rows * k);
            // k-major, so consecutive rays of a texel start at neighbouring samples of one shell
            for kk in 0..k {
                for r in 0..n_rows {
                    let row = row0 + r;
                    let (i, j) = (range.start + row / l.polar, row % l.polar);
                    let p = l.position(&frame, i, j, kk);
                    if l.rho_over_r(kk) <= 1.0 + 1e-9 && occ.is_inside(p) {
                        flags[r * k + kk] = 1;
                        n_in += 1;
                        continue;
                    }
                    views.push(tracer.view(p));
                    slots.push((r, kk));
                }
            }
            let mut acc = vec![[[0.0f64; 3]; 3]; views.len() * n_env];
            let mut st = BakeStats::default();
            let mut stack = occ.bvh.traversal_stack();
            tracer.block(&views, &mut stack, envs, &mut acc, &mut Vec::new(), &mut st);
            for (s, &(r, kk)) in slots.iter().enumerate() {
                for e in 0..n_env {
                    let v = &acc[s * n_env + e];
                    for c in 0..3 {
                        for x in 0..3 {
                            out[((r * n_env + e) * k + kk) * 9 + c * 3 + x] = v[c][x] as f32;
                        }
                    }
                }
            }
            rays.fetch_add(st.rays_traced, Ordering::Relaxed);
            hits.fetch_add(st.rays_hit, Ordering::Relaxed);
            cert.fetch_add(st.rays_certified, Ordering::Relaxed);
            ins.fetch_add(n_in, Ordering::Relaxed);
            let d = done.fetch_add(n_rows as u64, Ordering::Relaxed) + n_rows as u64;
            progress.update("fiv", d, rows as u64);
        },
    );
    let stats = BakeStats {
        rays_traced: rays.into_inner(),
        rays_hit: hits.into_inner(),
        rays_certified: cert.into_inner(),
        inside_samples: ins.into_inner(),
    };
    Ok(envs
        .iter()
        .enumerate()
        .map(|(e, env)| {
            let irr = env.irradiance_cube(params.irradiance_size);
            let ef = env.env_fiv();
            let mut table = Vec::with_capacity(rows * k * 9);
            for row in 0..rows {
                let base = (row * n_env + e) * k * 9;
                table.extend_from_slice(&fiv[base..base + k * 9]);
            }
            FivBake {
                params: *params,
                frame,
                cube_size: env.cube().size(),
                shard,
                fiv: table,
                inside: inside.clone(),
                irradiance: irr.iter().flat_map(|v| v.map(|x| x as f32)).collect(),
                env_fiv: ef.map(|r| r.map(|x| x as f32)),
                stats,
            }
        })
        .collect())
}
