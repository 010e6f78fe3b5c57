//! Procedural environment maps, generated in code (no data files): an environment lit by a
//! few coloured area lights over a dim sky, for the FIV shadow figures (FIV Figs. 13–14 use
//! "two area light sources" and "one green and one red area light").

use super::latlong::{EnvMap, texel_direction};

/// One disc-shaped area light on the sphere of directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaLight {
    /// Unit direction of the light's centre (world frame, +Y up).
    pub direction: [f64; 3],
    /// Angular radius in radians.
    pub radius: f64,
    /// Linear RGB radiance inside the disc.
    pub radiance: [f32; 3],
}

/// Unit direction at elevation `el` (above the XZ plane) and azimuth `az` (from +Z toward +X),
/// both in degrees.
pub fn direction_deg(el: f64, az: f64) -> [f64; 3] {
    let (el, az) = (el.to_radians(), az.to_radians());
    [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()]
}

/// The lights of [`area_lights`]: a warm white key light, a red and a green light.
pub fn default_area_lights() -> [AreaLight; 3] {
    [
        AreaLight { direction: direction_deg(60.0, 40.0), radius: 12f64.to_radians(), radiance: [9.0, 8.5, 8.0] },
        AreaLight { direction: direction_deg(35.0, -100.0), radius: 9f64.to_radians(), radiance: [12.0, 0.8, 0.4] },
        AreaLight { direction: direction_deg(45.0, 170.0), radius: 9f64.to_radians(), radiance: [0.4, 10.0, 0.8] },
    ]
}

/// Sky radiance of [`area_lights`] above the horizon and ground radiance below it.
pub const SKY: [f32; 3] = [0.05, 0.06, 0.08];
/// Ground radiance of [`area_lights`].
pub const GROUND: [f32; 3] = [0.02, 0.02, 0.02];

/// A `width × height` lat-long map of [`default_area_lights`] over [`SKY`] / [`GROUND`].
/// Each texel is the average of 4×4 stratified sub-samples (so the discs' edges are
/// anti-aliased); the lights overwrite the sky.
pub fn area_lights(width: usize, height: usize) -> EnvMap {
    with_lights(width, height, &default_area_lights())
}

/// Like [`area_lights`] with the given lights.
pub fn with_lights(width: usize, height: usize, lights: &[AreaLight]) -> EnvMap {
    const SS: usize = 4;
    let (w, h) = (width.max(1), height.max(1));
    let cos_r: Vec<f64> = lights.iter().map(|l| l.radius.cos()).collect();
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let mut acc = [0.0f64; 3];
            for sy in 0..SS {
                for sx in 0..SS {
                    // sub-sample of a (SS·w) × (SS·h) map inside this texel
                    let d = texel_direction(SS * w, SS * h, SS * x + sx, SS * y + sy);
                    let mut l = if d[1] >= 0.0 { SKY } else { GROUND };
                    for (light, &c) in lights.iter().zip(&cos_r) {
                        let dot = d[0] * light.direction[0] + d[1] * light.direction[1] + d[2] * light.direction[2];
                        if dot >= c {
                            l = light.radiance;
                        }
                    }
                    for c in 0..3 {
                        acc[c] += l[c] as f64;
                    }
                }
            }
            data.push(acc.map(|v| (v / (SS * SS) as f64) as f32));
        }
    }
    // finite by construction
    EnvMap::new(w, h, data).unwrap_or_else(|_| unreachable!("procedural map is finite and sized"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lights_have_their_power() {
        let env = area_lights(512, 256);
        // power of each light ≈ radiance × cap solid angle 2π(1 − cos r), plus the sky
        let lights = default_area_lights();
        let cap = |r: f64| std::f64::consts::TAU * (1.0 - r.cos());
        let mut expect = [0.0f64; 3];
        let mut covered = 0.0;
        for l in &lights {
            for c in 0..3 {
                expect[c] += l.radiance[c] as f64 * cap(l.radius);
            }
            covered += cap(l.radius);
        }
        // the lights are all above the horizon: the sky loses their area
        let half = std::f64::consts::TAU;
        for c in 0..3 {
            expect[c] += SKY[c] as f64 * (half - covered) + GROUND[c] as f64 * half;
        }
        let got = env.integral();
        for c in 0..3 {
            assert!((got[c] - expect[c]).abs() < 0.01 * expect[c], "channel {c}: {} vs {}", got[c], expect[c]);
        }
        // the brightest texel points at the red light in the red channel
        let dir = direction_deg(35.0, -100.0);
        assert!(env.texel_at(dir)[0] > 11.0);
    }
}
