//! `verify shadows --local-light X,Y,Z,RADIUS`: the runtime's local spherical light (SHEXP §7,
//! `L_H(θ, φ)` ZH fit) against the light ray traced at its finite distance, blocked by the
//! mesh and by the (self-shadow-replaced) spheres, and unblocked.

use super::{Receiver, effective_spheres, to32};
use crate::exit::CliError;
use anyhow::anyhow;
use penumbra_geometry::MeshBvh;
use penumbra_runtime::shadows::{LocalLight, ShadowEvaluator, Sphere as RtSphere};
use penumbra_spheres::reference;
use penumbra_spheres::sphere::Sphere;
use rayon::prelude::*;

/// The light: centre x, y, z and radius (unit radiance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light(pub [f64; 4]);

/// Parses `X,Y,Z,RADIUS`.
pub fn parse(s: &str) -> Result<Light, CliError> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| CliError::input(anyhow!("--local-light {s}: expected four numbers X,Y,Z,RADIUS")))?;
    if v.len() != 4 || v.iter().any(|x| !x.is_finite()) || v[3] <= 0.0 {
        return Err(CliError::input(anyhow!(
            "--local-light {s}: expected four finite numbers X,Y,Z,RADIUS with RADIUS > 0"
        )));
    }
    Ok(Light([v[0], v[1], v[2], v[3]]))
}

/// Runtime and references at every receiver (irradiance of a unit-radiance light, grey).
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    ev: &ShadowEvaluator<'_>,
    light: Light,
    recv: &[Receiver],
    leaves: &[RtSphere],
    spheres: &[Sphere],
    bvh: &MeshBvh,
    lift: f64,
    k: usize,
    seed: u64,
) -> Result<super::LocalOut, CliError> {
    let [x, y, z, r] = light.0;
    if let Some((p, _)) =
        recv.iter().find(|(p, _)| ((p[0] - x).powi(2) + (p[1] - y).powi(2) + (p[2] - z).powi(2)).sqrt() <= r)
    {
        return Err(CliError::input(anyhow!("--local-light: receiver {p:?} lies inside the light")));
    }
    let rt_light = LocalLight { sphere: RtSphere { center: to32([x, y, z]), radius: r as f32 }, radiance: [1.0; 3] };
    let n2 = ev.order() * ev.order();
    let mut one = vec![0.0f32; n2];
    one[0] = (4.0 * std::f32::consts::PI).sqrt();
    let rt: Vec<([f64; 3], [f64; 3])> = recv
        .iter()
        .map(|(p, n)| {
            let (p, n) = (to32(*p), to32(*n));
            let s = ev.irradiance_local_light(p, n, leaves, &rt_light).unwrap_or([f32::NAN; 3]);
            let u = ev.shade_local_light(p, n, &rt_light, &one).unwrap_or([f32::NAN; 3]);
            (s.map(f64::from), u.map(f64::from))
        })
        .collect();
    let blocked_mesh = reference::mesh_blocked_before(bvh, lift);
    let truths: Vec<(f64, f64, f64)> = recv
        .par_iter()
        .enumerate()
        .map(|(i, (p, n))| {
            let o: [f64; 3] = std::array::from_fn(|c| p[c] + lift * n[c]);
            let c = [x, y, z];
            // its own seed stage: item offset keeps these draws apart from the environment's
            let item = (1u64 << 40) + i as u64;
            let mesh = reference::sphere_light_irradiance(o, *n, c, r, k, seed, item, &blocked_mesh).0;
            let eff = effective_spheres(spheres, *p, *n);
            let sph = reference::sphere_light_irradiance(o, *n, c, r, k, seed, item, &|oo, d, t| {
                reference::spheres_hit_before(&eff, oo, d, t)
            })
            .0;
            let un = reference::sphere_light_irradiance(o, *n, c, r, k, seed, item, &|_, _, _| false).0;
            (mesh, sph, un)
        })
        .collect();
    let grey = |v: f64| [v; 3];
    Ok(super::LocalOut {
        runtime: rt.iter().map(|x| x.0).collect(),
        runtime_unshadowed: rt.iter().map(|x| x.1).collect(),
        mesh: truths.iter().map(|t| grey(t.0)).collect(),
        spheres: truths.iter().map(|t| grey(t.1)).collect(),
        unshadowed: truths.iter().map(|t| grey(t.2)).collect(),
    })
}
