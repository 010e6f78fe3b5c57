//! `verify shadows --indirect`: indirect light from the proxies (IBPA §5) by the runtime's
//! three operators (point sampled, averaged `D(θ)`, exact `M(θ)`) against a one-bounce path
//! trace off the diffuse proxy spheres under the (non-constant) environment.
//!
//! Reference: per receiver, `K × K` stratified cosine-weighted directions; a direction that
//! meets a proxy (the nearest one, after the runtime's self-shadow rules, so inter-proxy
//! occlusion is exact) at `q` with unit normal `n_q` brings the radiance `ρ_j/π · L̃(n_q)`
//! (`ρ_j` the albedo of the sphere hit: `--albedo`, or the SPHR's per-sphere albedo), with
//! `L̃` the order-3 irradiance SH of the environment (the proxies are lit by the unshadowed
//! environment, as IBPA §5 models them; order-3 irradiance is the model's own light).

use super::{Receiver, to32};
use crate::exit::CliError;
use penumbra_math::sh::ShEval;
use penumbra_runtime::shadows::rules::replace_parts;
use penumbra_runtime::shadows::{IndirectOperator, ShadowEvaluator, Sphere as RtSphere};
use penumbra_spheres::reference;
use penumbra_spheres::sphere::Sphere;
use rayon::prelude::*;
use serde_json::{Value, json};
use std::time::Instant;

/// Runtime indirect per operator and the path-traced reference, per receiver (RGB).
pub struct IndirectOut {
    /// `[point, averaged, exact]`.
    pub runtime: [Vec<[f64; 3]>; 3],
    /// One-bounce path trace.
    pub reference: Vec<[f64; 3]>,
    /// ns per receiver on one thread: direct only (`irradiance`), then each operator's
    /// `shade_with_indirect_by` (direct + indirect).
    pub ns: [f64; 4],
}

const OPS: [IndirectOperator; 3] =
    [IndirectOperator::PointSampled, IndirectOperator::Averaged, IndirectOperator::Exact];

/// Evaluates the runtime and the reference.
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    ev: &ShadowEvaluator<'_>,
    albedo: &[[f64; 3]],
    env_sh3: &[[f64; 3]],
    recv: &[Receiver],
    leaves: &[RtSphere],
    spheres: &[Sphere],
    k: usize,
    seed: u64,
) -> Result<IndirectOut, CliError> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(CliError::internal)?;
    let a32: Vec<[f32; 3]> = albedo.iter().map(|a| a.map(|x| x as f32)).collect();
    let (runtime, ns) = pool.install(|| {
        let mut ns = [0.0f64; 4];
        let t = Instant::now();
        let mut sink = 0.0f32;
        for (p, n) in recv {
            sink += ev.irradiance(to32(*p), to32(*n), leaves)[0];
        }
        ns[0] = t.elapsed().as_nanos() as f64 / recv.len() as f64;
        std::hint::black_box(sink);
        let runtime: [Vec<[f64; 3]>; 3] = core::array::from_fn(|o| {
            let t = Instant::now();
            let v: Vec<[f64; 3]> = recv
                .iter()
                .map(|(p, n)| {
                    ev.shade_with_indirect_per_sphere(to32(*p), to32(*n), leaves, &a32, OPS[o]).indirect.map(f64::from)
                })
                .collect();
            ns[1 + o] = t.elapsed().as_nanos() as f64 / recv.len() as f64;
            v
        });
        (runtime, ns)
    });
    // order-3 irradiance SH of the environment: Â_l L_lm (Â = π, 2π/3, π/4)
    let a_hat = [std::f64::consts::PI, 2.0 * std::f64::consts::PI / 3.0, std::f64::consts::PI / 4.0];
    let irr: Vec<[f64; 3]> =
        env_sh3.iter().take(9).enumerate().map(|(i, c)| c.map(|x| x * a_hat[penumbra_math::sh::band_of(i)])).collect();
    let eval = ShEval::new(3);
    let reference: Vec<[f64; 3]> = recv
        .par_iter()
        .enumerate()
        .map(|(i, (p, n))| {
            // the kept spheres with their index in `spheres` (for their albedo)
            let (eff, idx): (Vec<Sphere>, Vec<usize>) = spheres
                .iter()
                .enumerate()
                .filter_map(|(j, s)| {
                    let (c, r, keep) = replace_parts(s.center, s.radius, *p, *n);
                    keep.then(|| (Sphere::new(c, r), j))
                })
                .unzip();
            let y = std::cell::RefCell::new(vec![0.0; 9]);
            let light = |d: [f64; 3]| -> [f64; 3] {
                let Some((j, t)) = reference::nearest_sphere_hit(&eff, *p, d) else { return [0.0; 3] };
                let s = &eff[j];
                let rho = albedo.get(idx[j]).copied().unwrap_or([0.0; 3]);
                let q: [f64; 3] = std::array::from_fn(|c| (p[c] + t * d[c] - s.center[c]) / s.radius);
                let e = reference::sh_radiance(&eval, &irr, q, &mut y.borrow_mut());
                std::array::from_fn(|c| rho[c] / std::f64::consts::PI * e[c].max(0.0))
            };
            // its own stream: item offset keeps these draws apart from the environment's
            reference::irradiance(*p, *n, k, seed, (2u64 << 40) + i as u64, &light, &|_, _| false).0
        })
        .collect();
    Ok(IndirectOut { runtime, reference, ns })
}

/// The `--json` keys of the indirect verification.
pub fn report(outs: &[&IndirectOut], albedo: &[[f64; 3]], source: &str) -> Value {
    let cat = |f: &dyn Fn(&IndirectOut) -> &Vec<[f64; 3]>| -> Vec<[f64; 3]> {
        outs.iter().flat_map(|o| f(o).iter().copied()).collect()
    };
    let reference = cat(&|o| &o.reference);
    let e = |k: usize| super::nrmse(&cat(&|o| &o.runtime[k]), &reference);
    let ns = |k: usize| outs.iter().map(|o| o.ns[k]).sum::<f64>() / outs.len().max(1) as f64;
    let uniform = albedo.windows(2).all(|w| w[0] == w[1]);
    let mean_albedo: [f64; 3] =
        std::array::from_fn(|c| albedo.iter().map(|a| a[c]).sum::<f64>() / albedo.len().max(1) as f64);
    let fold = |init: f64, f: fn(f64, f64) -> f64| -> [f64; 3] {
        std::array::from_fn(|c| albedo.iter().map(|a| a[c]).fold(init, f))
    };
    let mean = reference.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).sum::<f64>() / reference.len().max(1) as f64;
    json!({
        "nrmse_indirect": {"point": e(0), "d": e(1), "m": e(2)},
        "indirect_ns_per_receiver": {"direct_only": ns(0), "point": ns(1), "d": ns(2), "m": ns(3)},
        "indirect_reference_mean": mean,
        // the proxies' albedo: one value when uniform, else the per-sphere mean and range
        "albedo": uniform.then(|| albedo.first().copied().unwrap_or([0.0; 3])),
        "albedo_mean": mean_albedo,
        "albedo_min": fold(f64::INFINITY, f64::min),
        "albedo_max": fold(f64::NEG_INFINITY, f64::max),
        "albedo_source": source,
    })
}
