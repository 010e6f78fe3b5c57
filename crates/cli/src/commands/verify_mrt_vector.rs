//! `penumbra verify mrt` on the vector and volume response (MRT thesis §3.5.4–3.5.5, §3.6.3
//! steps 8–9): the receivers where it is measured and the runtime's values there, against the
//! same path tracer as the scalar keys (`level_reference::reference_at`, one bounce).
//!
//! - **Tilted normals on the walls** (normal maps): every texel of the level, its normal tilted
//!   by 40° toward +u, +v, −u, −v of its face (cycling by texel); light from below the wall
//!   does not count. Runtime: the OHLSH coefficients of [`MrtRuntime::vector_coefficients`]
//!   (`U_b⃗ (b − b_g) + U_r⃗ r`), through [`ohlsh_irradiance`]; next to it the `b` part alone
//!   and the scalar indirect light of the texel used for the tilted normal (what a renderer
//!   without vector irradiance shows).
//! - **Volume points**: 32 hashed points per block (block-local `[0.05, 0.95]³`), each with the
//!   six axis normals: the probes of [`MrtRuntime::probe_sh`] (`U_bvol b + U_rvol r`, rotated
//!   into the world), trilinear in block-local coordinates; next to it the `b` part alone.

use penumbra_math::rng::{hash4, unit_f64};
use penumbra_runtime::mrt::MrtRuntime;
use penumbra_runtime::mrt_vec::ohlsh_irradiance;
use penumbra_transport::drt_reference::Receiver;
use penumbra_transport::level_reference::{LevelGeometry, LevelTexels};
use serde_json::{Value, json};

/// Tilt of the normal-mapped normals, degrees.
pub const TILT_DEG: f64 = 40.0;
/// Volume points per block.
pub const POINTS: usize = 32;

/// Runtime values at one receiver.
#[derive(Debug, Clone, Copy)]
struct Values {
    /// `b` and `r` (what the runtime gives).
    full: f64,
    /// `b` only.
    b_only: f64,
    /// The scalar indirect light of the texel (walls only).
    scalar: f64,
}

/// The receivers of the vector and volume checks and the runtime's values there.
#[derive(Debug)]
pub struct VectorChecks {
    /// Wall receivers (one per texel), then volume receivers.
    pub receivers: Vec<Receiver>,
    walls: usize,
    values: Vec<Values>,
    /// Whether the dictionary drives them by `r` too (MRTD kind_version 4).
    interface_vectors: bool,
}

/// The `k`-th tilted normal of a texel with frame `fr` (`TILT_DEG` toward +u, +v, −u, −v,
/// cycling): `(local, world)`. Shared with `verify drt`'s vector check.
pub(crate) fn tilt(fr: [[f64; 3]; 3], k: usize) -> ([f64; 3], [f64; 3]) {
    let (s, c) = TILT_DEG.to_radians().sin_cos();
    let (su, sv) = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][k % 4];
    let local = [su * s, sv * s, c];
    (local, core::array::from_fn(|m| local[0] * fr[0][m] + local[1] * fr[1][m] + local[2] * fr[2][m]))
}

pub(crate) fn to32(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// Builds the checks from the runtime state of the last one-bounce evaluation with
/// interfaces (`scalar` its output at the texels, already albedo-scaled); `None` when the
/// dictionary has no `U_b⃗` or `U_bvol`.
pub fn build(
    rt: &MrtRuntime<'_>,
    scalar: &[f64],
    scale: f32,
    geo: &LevelGeometry<'_>,
    tex: &LevelTexels,
) -> Option<VectorChecks> {
    if !(rt.has_vector() && rt.has_volume()) {
        return None;
    }
    let n = rt.texel_count();
    let (mut full, mut bonly) = (vec![[0.0f32; 4]; n], vec![[0.0f32; 4]; n]);
    rt.vector_coefficients_parts(&mut full, true);
    rt.vector_coefficients_parts(&mut bonly, false);
    let s = f64::from(scale);
    let mut receivers = Vec::with_capacity(n);
    let mut values = Vec::with_capacity(n);
    for (i, &(x, f, p, nn)) in tex.texels.iter().enumerate() {
        let (ml, mw) = tilt(geo.frame(x, f), i);
        receivers.push(Receiver { block: x, point: p, normal: mw, horizon: Some(nn) });
        let ml = to32(ml);
        values.push(Values {
            full: f64::from(ohlsh_irradiance(&full[i], ml)) * s,
            b_only: f64::from(ohlsh_irradiance(&bonly[i], ml)) * s,
            scalar: scalar[i],
        });
    }
    let walls = receivers.len();
    let (mut sh, mut sh_b) = (Vec::new(), Vec::new());
    for (x, blk) in geo.level.blocks.iter().enumerate() {
        rt.probe_sh_parts(x, &mut sh, true);
        rt.probe_sh_parts(x, &mut sh_b, false);
        for k in 0..POINTS as u64 {
            let h = |a: u64| 0.05 + 0.9 * unit_f64(hash4(0x4D56_4F4C, x as u64, k, a));
            let pl = [h(0), h(1), h(2)];
            let w = blk.to_world(pl);
            for a in 0..6 {
                let mut nn = [0.0; 3];
                nn[a / 2] = if a % 2 == 0 { 1.0 } else { -1.0 };
                receivers.push(Receiver { block: x, point: w, normal: nn, horizon: None });
                let (p32, n32) = (to32(pl), to32(nn));
                values.push(Values {
                    full: f64::from(rt.probe_irradiance(x, &sh, p32, n32)) * s,
                    b_only: f64::from(rt.probe_irradiance(x, &sh_b, p32, n32)) * s,
                    scalar: f64::NAN,
                });
            }
        }
    }
    Some(VectorChecks { receivers, walls, values, interface_vectors: rt.has_interface_vectors() })
}

/// `‖a − b‖/‖b‖` over `idx`.
fn rel_over(a: impl Fn(usize) -> f64, b: &[f64], idx: impl Iterator<Item = usize> + Clone) -> f64 {
    let num: f64 = idx.clone().map(|i| (a(i) - b[i]).powi(2)).sum();
    let den: f64 = idx.map(|i| b[i] * b[i]).sum();
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

impl VectorChecks {
    /// The `--json` keys from the reference's values `one` and half differences `half` at
    /// [`VectorChecks::receivers`]; per block in `per_block` (`blocks` entries).
    pub fn report(&self, one: &[f64], half: &[f64], blocks: usize) -> (Value, Vec<Value>) {
        let walls = 0..self.walls;
        let vol = self.walls..self.receivers.len();
        let v = &self.values;
        let noise = |r: core::ops::Range<usize>| {
            let num: f64 = half[r.clone()].iter().map(|x| x * x).sum();
            let den: f64 = one[r].iter().map(|x| x * x).sum();
            if den > 0.0 { (num / den).sqrt() } else { 0.0 }
        };
        let top = json!({
            "interface_vectors": self.interface_vectors,
            "tilt_deg": TILT_DEG,
            "vector_receivers": self.walls,
            "volume_receivers": self.receivers.len() - self.walls,
            "rel_error_vector": rel_over(|i| v[i].full, one, walls.clone()),
            "rel_error_vector_b_only": rel_over(|i| v[i].b_only, one, walls.clone()),
            "rel_error_vector_scalar": rel_over(|i| v[i].scalar, one, walls.clone()),
            "reference_noise_vector": noise(walls.clone()),
            "rel_error_volume": rel_over(|i| v[i].full, one, vol.clone()),
            "rel_error_volume_b_only": rel_over(|i| v[i].b_only, one, vol.clone()),
            "reference_noise_volume": noise(vol.clone()),
        });
        let per: Vec<Value> = (0..blocks)
            .map(|x| {
                let w = walls.clone().filter(move |&i| self.receivers[i].block == x);
                let p = vol.clone().filter(move |&i| self.receivers[i].block == x);
                json!({
                    "vector": rel_over(|i| v[i].full, one, w.clone()),
                    "vector_b_only": rel_over(|i| v[i].b_only, one, w),
                    "volume": rel_over(|i| v[i].full, one, p.clone()),
                    "volume_b_only": rel_over(|i| v[i].b_only, one, p),
                })
            })
            .collect();
        (top, per)
    }
}
