//! `penumbra verify drt` on the vector and volume response (MRT thesis §5.4.3), when the
//! DRTO carries it (`penumbra drt --vector`): the receivers where it is measured and the
//! runtime's values there, against the same path tracer as the scalar keys.
//!
//! - **Tilted normals on the walls** (normal maps): every scene texel of a receiving block
//!   outside clutter, its normal tilted by 40° toward +u, +v, −u, −v of its face (cycling by
//!   texel); light from below the wall does not count (`Receiver::horizon`). Runtime: MRT's
//!   `s·U_b⃗ (b − b_g)` plus, with a kind_version 4 dictionary, the interface part `U_r⃗ r`
//!   ([`MrtRuntime::vector_coefficients`]) alone and plus DRT's
//!   `s·ΔU_b⃗ b + ΔU_c⃗ c`, through [`ohlsh_irradiance`].
//! - **Tilted normals on the clutter**: every clutter texel in a block, tilted the same way in
//!   its `orthonormal_basis` frame: `C_b⃗`/`C_c⃗` ([`world_ohlsh_irradiance`]) against MRT's
//!   `U_bvol` probes at the texel (what DRT replaces).
//! - **Volume points**: 32 hashed points per receiving block (block-local `[0.05, 0.95]³`,
//!   outside every clutter bound), each with the six axis normals: `U_dyn` against MRT's
//!   `U_bvol` probes, both trilinear in block-local coordinates.

use crate::exit::CliError;
use anyhow::anyhow;
use penumbra_math::rng::{hash4, unit_f64};
use penumbra_runtime::drt::DrtOperators;
use penumbra_runtime::drt_vec::{DrtVector, world_ohlsh_irradiance};
use penumbra_runtime::mrt::MrtRuntime;
use penumbra_runtime::mrt_vec::ohlsh_irradiance;
use penumbra_transport::drt_reference::Receiver;
use penumbra_transport::level_reference::{LevelGeometry, LevelTexels};
use serde_json::{Value, json};

/// MRT's `U_bvol` irradiance at receivers (albedo-scaled).
pub type ProbeEval<'a> = dyn Fn(&[Receiver]) -> Result<Vec<f64>, CliError> + 'a;

// the same tilted normals as `verify mrt`'s vector check, so the two tables compare
use super::verify_mrt_vector::{TILT_DEG, tilt, to32};
/// Volume points per receiving block.
const POINTS: usize = 32;

/// The receivers of the vector checks and the runtime's values there.
#[derive(Debug)]
pub struct VectorChecks {
    /// Receivers: scene texels, then clutter texels, then volume points (see the counts).
    pub receivers: Vec<Receiver>,
    counts: [usize; 3],
    /// Runtime values per receiver: (MRT, MRT + DRT).
    values: Vec<(f64, f64)>,
    /// Scene texels inside clutter (left out).
    probes_inside: usize,
}

/// Builds the checks from the runtime state of the last one-bounce evaluation (`mrt`'s `b`
/// and faces, `c` the DRT runtime's coefficients); `mrt_probe` evaluates MRT's `U_bvol` at
/// receivers (already albedo-scaled).
#[allow(clippy::too_many_arguments)]
pub fn build(
    dv: &mut DrtVector<'_>,
    ops: &DrtOperators<'_>,
    mrt: &MrtRuntime<'_>,
    c: &[f32],
    scale: f32,
    geo: &LevelGeometry<'_>,
    tex: &LevelTexels,
    keep: &[bool],
    clutter: &penumbra_transport::clutter::ClutterScene,
    mrt_probe: &ProbeEval<'_>,
) -> Result<VectorChecks, CliError> {
    let kb = mrt.level().k_b;
    let b = mrt.coefficients();
    // walls
    let mut mrt_vec = vec![[0.0f32; 4]; mrt.texel_count()];
    mrt.vector_coefficients(&mut mrt_vec);
    mrt_vec.iter_mut().flatten().for_each(|x| *x *= scale);
    let mut both = mrt_vec.clone();
    dv.add_scene(b, kb, scale, c, &mut both);
    let mut receivers = Vec::new();
    let mut values = Vec::new();
    for rc in ops.receivers.chunks_exact(3) {
        let (x, cnt) = (rc[0] as usize, rc[2] as usize);
        for t in 0..cnt {
            let i = tex.offsets[x] + t;
            if !keep[i] {
                continue;
            }
            let (_, f, p, nn) = tex.texels[i];
            let (ml, mw) = tilt(geo.frame(x, f), i);
            receivers.push(Receiver { block: x, point: p, normal: mw, horizon: Some(nn) });
            let ml = to32(ml);
            values.push((f64::from(ohlsh_irradiance(&mrt_vec[i], ml)), f64::from(ohlsh_irradiance(&both[i], ml))));
        }
    }
    let n_scene = receivers.len();
    // clutter
    let mut cv = vec![[0.0f32; 4]; clutter.texels.len()];
    dv.clutter(b, kb, scale, c, &mut cv);
    let mut crecv = Vec::new();
    let mut cvals = Vec::new();
    for (i, t) in clutter.texels.iter().enumerate() {
        let o: [f64; 3] = core::array::from_fn(|k| t.position[k] + 1e-7 * t.normal[k]);
        let Some(x) = geo.block_of(o) else { continue };
        let (u, v) = penumbra_math::warp::orthonormal_basis(t.normal);
        let (_, mw) = tilt([u, v, t.normal], i);
        crecv.push(Receiver { block: x, point: t.position, normal: mw, horizon: Some(t.normal) });
        cvals.push(f64::from(world_ohlsh_irradiance(&cv[i], to32(mw))));
    }
    let cmrt = mrt_probe(&crecv)?;
    values.extend(cmrt.into_iter().zip(cvals));
    receivers.extend(crecv);
    let n_clutter = receivers.len() - n_scene;
    // volume points
    let mut sh = vec![[0.0f32; 9]; dv.blocks.len() * dv.res.pow(3)];
    dv.probe_sh(b, kb, scale, c, &mut sh);
    let mut mrt_sh = Vec::new();
    let blocks = dv.blocks.clone();
    for &x in &blocks {
        let x = x as usize;
        mrt.probe_sh(x, &mut mrt_sh);
        let blk = &geo.level.blocks[x];
        let mut found = 0;
        for k in 0..4096u64 {
            if found == POINTS {
                break;
            }
            let h = |a: u64| 0.05 + 0.9 * unit_f64(hash4(0x0056_4F4C, x as u64, k, a));
            let pl = [h(0), h(1), h(2)];
            let w = blk.to_world(pl);
            let inside = clutter.bounds.iter().any(|[lo, hi]| (0..3).all(|a| w[a] >= lo[a] && w[a] <= hi[a]));
            if inside {
                continue;
            }
            found += 1;
            for a in 0..6 {
                let mut nn = [0.0; 3];
                nn[a / 2] = if a % 2 == 0 { 1.0 } else { -1.0 };
                receivers.push(Receiver { block: x, point: w, normal: nn, horizon: None });
                let (p32, n32) = (to32(pl), to32(nn));
                let e_mrt = f64::from(mrt.probe_irradiance(x, &mrt_sh, p32, n32)) * f64::from(scale);
                let e_dyn = dv.probe_irradiance(&sh, x, p32, n32).ok_or_else(|| anyhow!("block {x} has no U_dyn"))?;
                values.push((e_mrt, f64::from(e_dyn)));
            }
        }
    }
    let n_volume = receivers.len() - n_scene - n_clutter;
    let probes_inside = dv.inside.iter().filter(|&&v| v != 0).count();
    Ok(VectorChecks { receivers, counts: [n_scene, n_clutter, n_volume], values, probes_inside })
}

impl VectorChecks {
    /// The `--json` keys from the reference's one-bounce values and half differences at
    /// [`VectorChecks::receivers`].
    pub fn report(&self, one: &[f64], half: &[f64], rel: &dyn Fn(&[f64], &[f64]) -> f64) -> Value {
        let [a, b, _] = self.counts;
        let parts = [0..a, a..a + b, a + b..self.receivers.len()];
        let mrt: Vec<f64> = self.values.iter().map(|v| v.0).collect();
        let drt: Vec<f64> = self.values.iter().map(|v| v.1).collect();
        let e = |k: usize| {
            let r = parts[k].clone();
            (rel(&mrt[r.clone()], &one[r.clone()]), rel(&drt[r.clone()], &one[r]))
        };
        // ‖half difference‖ / ‖reference‖
        let noise = |k: usize| {
            let r = parts[k].clone();
            let num: f64 = half[r.clone()].iter().map(|x| x * x).sum();
            let den: f64 = one[r].iter().map(|x| x * x).sum();
            if den > 0.0 { (num / den).sqrt() } else { 0.0 }
        };
        let (w0, w1) = e(0);
        let (c0, c1) = e(1);
        let (v0, v1) = e(2);
        json!({
            "tilt_deg": TILT_DEG,
            "wall_receivers": a,
            "clutter_receivers": b,
            "volume_receivers": self.counts[2],
            "probes_inside_clutter": self.probes_inside,
            "rel_error_vector_mrt": w0,
            "rel_error_vector_mrt_drt": w1,
            "reference_noise_vector": noise(0),
            "rel_error_clutter_vector_probes": c0,
            "rel_error_clutter_vector_cb": c1,
            "reference_noise_clutter_vector": noise(1),
            "rel_error_volume_mrt_probes": v0,
            "rel_error_volume_dyn": v1,
            "reference_noise_volume": noise(2),
        })
    }
}
