//! Direct-light prior samples (MRT thesis §3.3, §4.1.1): sphere lights placed uniformly in
//! the block's volume and, for every missing face, outside it; their direct irradiance at
//! the texel centres forms the columns of `L_d`.
//!
//! Layout (§4.1.1): 6×6×6 lights inside; 3×6×6 outside every missing face (the three
//! layers of the neighbouring block nearest the opening); 3×3×6 kitty-corner for every pair
//! of contiguous missing faces (the diagonal neighbour's corner nearest the shared edge).
//! The six positions per axis are `i/7, i = 1..6` ([`LightLayout::Lattice`], the default,
//! which reproduces the thesis's `L_d` statistics) or the cell centres `(i+½)/6`
//! ([`LightLayout::Cells`]); outside, the same spacing continues past the face.

use crate::shape::{Shape, Texels, face_axis, segment_enters_open};
use penumbra_math::rng::{ItemRng, stage};

/// Where the six prior lights per axis sit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightLayout {
    /// `i/7, i = 1..6` (thesis statistics; see docs/mrt.md).
    Lattice,
    /// Cell centres `(i+½)/6, i = 0..5`.
    Cells,
}

impl LightLayout {
    /// The six in-block coordinates and the three outside offsets past a face.
    fn grid(self) -> ([f64; 6], [f64; 3]) {
        match self {
            Self::Lattice => {
                (core::array::from_fn(|i| (i + 1) as f64 / 7.0), core::array::from_fn(|k| (k + 1) as f64 / 7.0))
            }
            Self::Cells => {
                (core::array::from_fn(|i| (i as f64 + 0.5) / 6.0), core::array::from_fn(|k| (k as f64 + 0.5) / 6.0))
            }
        }
    }

    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Lattice => "lattice",
            Self::Cells => "cells",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "lattice" => Some(Self::Lattice),
            "cells" => Some(Self::Cells),
            _ => None,
        }
    }

    /// Smallest distance from a prior light centre to a wall plane.
    pub fn min_wall_distance(self) -> f64 {
        let (g, o) = self.grid();
        g[0].min(o[0])
    }
}

/// Coordinate along axis `a` for a position "outside face `f`" at offset `off` past it.
#[inline]
fn outside(f: usize, off: f64) -> f64 {
    if face_axis(f).1 { 1.0 + off } else { -off }
}

/// The prior light centres of `shape` (§4.1.1), in a fixed order: inside (x fastest), then
/// per missing face, then per contiguous missing pair.
pub fn prior_lights(shape: &Shape, layout: LightLayout) -> Vec<[f64; 3]> {
    let (g, o) = layout.grid();
    let mut out = Vec::new();
    for &z in &g {
        for &y in &g {
            for &x in &g {
                out.push([x, y, z]);
            }
        }
    }
    for f in shape.missing_faces() {
        let a = face_axis(f).0;
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for &off in &o {
            for &s in &g {
                for &r in &g {
                    let mut p = [0.0; 3];
                    p[a] = outside(f, off);
                    p[b] = r;
                    p[c] = s;
                    out.push(p);
                }
            }
        }
    }
    for (fa, fb) in shape.contiguous_missing_pairs() {
        let (a, b) = (face_axis(fa).0, face_axis(fb).0);
        let c = 3 - a - b;
        for &oa in &o {
            for &ob in &o {
                for &s in &g {
                    let mut p = [0.0; 3];
                    p[a] = outside(fa, oa);
                    p[b] = outside(fb, ob);
                    p[c] = s;
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Fixed points on the unit disc (Vogel spiral) for the partial visibility of a sphere light.
pub const DISC_SAMPLES: usize = 16;

fn disc_points() -> [[f64; 2]; DISC_SAMPLES] {
    let golden = core::f64::consts::PI * (3.0 - 5.0f64.sqrt());
    core::array::from_fn(|k| {
        let r = ((k as f64 + 0.5) / DISC_SAMPLES as f64).sqrt();
        let phi = k as f64 * golden;
        [r * phi.cos(), r * phi.sin()]
    })
}

/// A spherical light of unit intensity (`π r² L = 1`): its irradiance at a point `x` with
/// normal `n` on the near side is `V · max(n·ω, 0) / d²`, exact for a sphere entirely above
/// the point's horizon (every prior and test light is, see [`LightLayout::min_wall_distance`]).
/// `V` is the fraction of the light's disc, seen from `x`, whose segment to `x` does not
/// cross a wall ([`segment_enters_open`]), estimated with [`DISC_SAMPLES`] fixed points.
#[derive(Debug, Clone)]
pub struct SphereLight {
    /// Centre.
    pub centre: [f64; 3],
    /// Radius.
    pub radius: f64,
}

/// Visibility of a whole sphere light from every boundary point, when it needs no sampling:
/// a light inside the cube sees every wall (the cube is convex): 1. A light whose bounding
/// box lies beyond exactly one face plane and within the cube's range on the other two axes
/// reaches the inside only across that plane, and by convexity every segment to a boundary
/// point crosses it inside the face: 1 if the face is missing, 0 if it is a wall. `None`
/// otherwise (kitty-corner lights, lights straddling a plane).
pub fn slab_visibility(shape: &Shape, light: &SphereLight) -> Option<f64> {
    let (c, r) = (light.centre, light.radius);
    let mut beyond = None;
    for a in 0..3 {
        if c[a] - r >= 0.0 && c[a] + r <= 1.0 {
            continue;
        }
        let f = if c[a] + r < 0.0 {
            2 * a
        } else if c[a] - r > 1.0 {
            2 * a + 1
        } else {
            return None;
        };
        if beyond.is_some() {
            return None;
        }
        beyond = Some(f);
    }
    Some(match beyond {
        None => 1.0,
        Some(f) if shape.has(f) => 0.0,
        Some(_) => 1.0,
    })
}

/// Evaluates direct irradiance from sphere lights with wall shadowing.
#[derive(Debug, Clone)]
pub struct DirectLight {
    disc: [[f64; 2]; DISC_SAMPLES],
}

impl Default for DirectLight {
    fn default() -> Self {
        Self::new()
    }
}

impl DirectLight {
    /// An evaluator.
    pub fn new() -> Self {
        Self { disc: disc_points() }
    }

    /// Irradiance at `x` (on the boundary of `shape`, inward normal `n`) from `light`.
    pub fn irradiance(&self, shape: &Shape, light: &SphereLight, x: [f64; 3], n: [f64; 3]) -> f64 {
        self.irradiance_with(shape, light, slab_visibility(shape, light), x, n)
    }

    /// [`Self::irradiance`] with the light's [`slab_visibility`] computed by the caller.
    #[inline]
    pub fn irradiance_with(
        &self,
        shape: &Shape,
        light: &SphereLight,
        slab: Option<f64>,
        x: [f64; 3],
        n: [f64; 3],
    ) -> f64 {
        if slab == Some(0.0) {
            return 0.0;
        }
        let c = light.centre;
        let w = [c[0] - x[0], c[1] - x[1], c[2] - x[2]];
        let d2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        let d = d2.sqrt();
        let cos = (n[0] * w[0] + n[1] * w[1] + n[2] * w[2]) / d;
        if cos <= 0.0 {
            return 0.0;
        }
        let vis = match slab {
            Some(v) => v,
            None => self.sampled_visibility(shape, light, x),
        };
        vis * cos / d2
    }

    /// The fraction of `light`'s disc (facing `x`) whose segments to `x` avoid the walls.
    pub fn sampled_visibility(&self, shape: &Shape, light: &SphereLight, x: [f64; 3]) -> f64 {
        let c = light.centre;
        let w = [c[0] - x[0], c[1] - x[1], c[2] - x[2]];
        let d = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let (t, b) = penumbra_math::warp::orthonormal_basis([w[0] / d, w[1] / d, w[2] / d]);
        let mut hit = 0usize;
        for p in &self.disc {
            let q = [
                c[0] + light.radius * (p[0] * t[0] + p[1] * b[0]),
                c[1] + light.radius * (p[0] * t[1] + p[1] * b[1]),
                c[2] + light.radius * (p[0] * t[2] + p[1] * b[2]),
            ];
            hit += usize::from(segment_enters_open(shape, q, x));
        }
        hit as f64 / DISC_SAMPLES as f64
    }

    /// The direct-light vector of `light` at every texel centre.
    pub fn texel_vector(&self, texels: &Texels, light: &SphereLight) -> Vec<f64> {
        (0..texels.len()).map(|t| self.irradiance(&texels.shape, light, texels.position(t), texels.normal(t))).collect()
    }
}

/// Lights for measuring errors: random positions (hash of `seed`, `shape_id`) that are not
/// prior samples but lie in the hull of the prior's lattice (inside: between the first and
/// last lattice coordinate on every axis; outside an opening: between the first and third
/// layer), drawn per region in proportion to the prior's own light counts. Lights closer to a
/// wall than any prior light are outside the prior by construction (thesis Fig. 3.14).
pub fn test_lights(
    shape: &Shape,
    layout: LightLayout,
    count: usize,
    radius: f64,
    seed: u64,
    shape_id: u64,
) -> Vec<SphereLight> {
    let (g, o) = layout.grid();
    let (lo, hi) = (g[0], g[5]);
    let (olo, ohi) = (o[0], o[2]);
    let missing = shape.missing_faces();
    let pairs = shape.contiguous_missing_pairs();
    // Regions: 0 = inside, 1..=m = outside face, then kitty-corner pairs; weighted like the prior
    // (216 / 108 / 54 lights).
    let mut weights = vec![216u64];
    weights.extend(missing.iter().map(|_| 108));
    weights.extend(pairs.iter().map(|_| 54));
    let total: u64 = weights.iter().sum();
    let mut rng = ItemRng::new(seed, stage::REFERENCE, 0x4C49_4748_5400 ^ shape_id);
    (0..count)
        .map(|_| {
            let mut pick = rng.below(total);
            let mut region = 0;
            while pick >= weights[region] {
                pick -= weights[region];
                region += 1;
            }
            let mut p = [0.0; 3];
            for a in &mut p {
                *a = lo + (hi - lo) * rng.next_f64();
            }
            let mut place = |f: usize, p: &mut [f64; 3]| {
                p[face_axis(f).0] = outside(f, olo + (ohi - olo) * rng.next_f64());
            };
            if region >= 1 && region <= missing.len() {
                place(missing[region - 1], &mut p);
            } else if region > missing.len() {
                let (fa, fb) = pairs[region - 1 - missing.len()];
                place(fa, &mut p);
                place(fb, &mut p);
            }
            SphereLight { centre: p, radius }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::{CLOSED, CUBE2D, Texels};

    #[test]
    fn layout_counts_follow_section_4_1_1() {
        let counts: Vec<usize> = CUBE2D.iter().map(|s| prior_lights(s, LightLayout::Lattice).len()).collect();
        // 216 inside + 108 per missing face + 54 per contiguous missing pair
        assert_eq!(counts, vec![216, 324, 432, 486, 648, 864]);
        for s in CUBE2D {
            for p in prior_lights(&s, LightLayout::Cells) {
                // every light centre is at least min_wall_distance in front of every present wall
                for f in s.faces() {
                    let (a, pos) = face_axis(f);
                    let dist = if pos { 1.0 - p[a] } else { p[a] };
                    assert!(dist >= LightLayout::Cells.min_wall_distance() - 1e-12, "{} {p:?}", s.name);
                }
            }
        }
    }

    #[test]
    fn inverse_square_cosine_law_and_wall_shadowing() {
        let dl = DirectLight::new();
        let light = SphereLight { centre: [0.5, 0.5, 0.5], radius: 0.05 };
        // floor centre: distance 0.5, normal incidence
        let e = dl.irradiance(&CLOSED, &light, [0.5, 0.0, 0.5], [0.0, 1.0, 0.0]);
        assert!((e - 4.0).abs() < 1e-12);
        // a light outside the closed cube lights nothing; through the dead end's opening it does
        let out = SphereLight { centre: [0.5, 0.5, 1.2], radius: 0.05 };
        assert_eq!(dl.irradiance(&CLOSED, &out, [0.5, 0.0, 0.5], [0.0, 1.0, 0.0]), 0.0);
        let e = dl.irradiance(&CUBE2D[1], &out, [0.5, 0.0, 0.5], [0.0, 1.0, 0.0]);
        let d2: f64 = 0.25 + 0.49;
        assert!((e - 0.5 / d2.sqrt() / d2).abs() < 1e-12);
        // a light whose disc straddles the line through the opening's edge (x = 1, z = 1) as
        // seen from the -x wall: partially shadowed by the +x wall
        let x = [0.0, 0.5, 0.5];
        let straddle = SphereLight { centre: [1.2, 0.5, 1.1], radius: 0.05 };
        let e = dl.irradiance(&CUBE2D[1], &straddle, x, [1.0, 0.0, 0.0]);
        let w = [1.2, 0.0, 0.6];
        let d2: f64 = w.iter().map(|v| v * v).sum();
        let unshadowed = (1.2 / d2.sqrt()) / d2;
        assert!(e > 0.2 * unshadowed && e < 0.8 * unshadowed, "{e} vs {unshadowed}");
    }

    #[test]
    fn slab_shortcut_agrees_with_disc_sampling() {
        let dl = DirectLight::new();
        for (id, s) in CUBE2D.iter().enumerate() {
            let tex = Texels::new(*s, 4);
            let mut lights = test_lights(s, LightLayout::Lattice, 32, 0.05, 3, id as u64);
            lights.extend(
                prior_lights(s, LightLayout::Cells).into_iter().map(|c| SphereLight { centre: c, radius: 0.08 }),
            );
            let mut shortcut = 0;
            for l in &lights {
                let Some(v) = slab_visibility(s, l) else { continue };
                shortcut += 1;
                for t in 0..tex.len() {
                    assert_eq!(v, dl.sampled_visibility(s, l, tex.position(t)), "{} {:?}", s.name, l.centre);
                }
            }
            assert!(shortcut > 0);
        }
    }

    #[test]
    fn test_lights_avoid_prior_positions_and_stay_in_regions() {
        for (id, s) in CUBE2D.iter().enumerate() {
            let prior = prior_lights(s, LightLayout::Lattice);
            let lights = test_lights(s, LightLayout::Lattice, 64, 0.05, 7, id as u64);
            for l in &lights {
                assert!(prior.iter().all(|p| (0..3).any(|a| (p[a] - l.centre[a]).abs() > 1e-9)));
                for f in s.faces() {
                    let (a, pos) = face_axis(f);
                    let dist = if pos { 1.0 - l.centre[a] } else { l.centre[a] };
                    assert!(dist >= 1.0 / 7.0 - 1e-12, "{} {:?}", s.name, l.centre);
                }
            }
        }
    }
}
