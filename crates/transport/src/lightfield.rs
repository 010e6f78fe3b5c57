//! Interface lightfields (MRT thesis §3.4.1, §4.2, §3.6.1): the radiance crossing a missing
//! side face of a block, sampled on `S × S` spatial points × `D × D` directions, the
//! hemisphere mapped to a square by the concentric map ("mapping the hemisphere to a square
//! for continuous directional interpolation"), each directional cell averaged over `Q × Q`
//! supersamples (thesis: 12² × 24², 5²).
//!
//! # Interface frame
//! A lightfield is described in the frame of its **travel direction** `t̂` (the direction light
//! crosses the face in) and world up `ŷ`: `r̂ = ŷ × t̂`, so `(r̂, ŷ, t̂)` is right-handed. The frame
//! depends only on `t̂`, so the block the light leaves (its outgoing face) and the block it
//! enters (its incoming face) describe the same lightfield with the same numbers, and
//! rotating a block about `+Y` (the only rotation levels use) rotates the frame with it.
//! Position on the face: `p = c + (r − ½) r̂ + (y − ½) ŷ`, `(r, y) ∈ [0,1]²`, `c` the face centre
//! (block-local unit-cube coordinates). Direction: `ω = a r̂ + b ŷ + c t̂`, `c > 0`, with
//! `(a, b)` the concentric-map image of the square coordinates `(s₁, s₂) ∈ [0,1]²` and
//! `c = √(1 − a² − b²)` (Malley's projection: equal square areas are equal projected solid
//! angles).
//!
//! # Sample layout
//! Spatial node `(i_r, i_y)` at `((i_r+½)/S, (i_y+½)/S)`, directional node `(j₁, j₂)` at
//! `((j₁+½)/D, (j₂+½)/D)` in square coordinates; sample index
//! `((i_y·S + i_r)·D + j₂)·D + j₁`. Continuous lookups interpolate bilinearly in both the
//! spatial and the directional square (16 taps), clamped to the edge like texels.

use crate::shape::{FACE_FRAMES, bilinear_1d, face_axis};
use core::f64::consts::PI;

/// World up.
pub const UP: [f64; 3] = [0.0, 1.0, 0.0];

/// Lightfield resolution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LfGrid {
    /// Spatial samples per face edge (thesis: 12).
    pub spatial: usize,
    /// Directional samples per square edge (thesis: 24).
    pub dir: usize,
    /// Directional supersamples per cell edge (thesis: 5).
    pub sub: usize,
}

impl LfGrid {
    /// The thesis's resolution (§3.6.1).
    pub const THESIS: LfGrid = LfGrid { spatial: 12, dir: 24, sub: 5 };

    /// Number of samples `S²·D²`.
    pub fn len(&self) -> usize {
        self.spatial * self.spatial * self.dir * self.dir
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `(i_r, i_y, j₁, j₂)` of sample `k`.
    #[inline]
    pub fn coords(&self, k: usize) -> (usize, usize, usize, usize) {
        let d2 = self.dir * self.dir;
        let (sp, dk) = (k / d2, k % d2);
        (sp % self.spatial, sp / self.spatial, dk % self.dir, dk / self.dir)
    }

    /// Spatial position `(r, y)` of node `(i_r, i_y)`.
    #[inline]
    pub fn spatial_pos(&self, ir: usize, iy: usize) -> (f64, f64) {
        let s = self.spatial as f64;
        ((ir as f64 + 0.5) / s, (iy as f64 + 0.5) / s)
    }

    /// Square coordinates of supersample `(q₁, q₂)` of directional cell `(j₁, j₂)`.
    #[inline]
    pub fn sub_square(&self, j1: usize, j2: usize, q1: usize, q2: usize) -> (f64, f64) {
        let (d, q) = (self.dir as f64, self.sub as f64);
        ((j1 as f64 + (q1 as f64 + 0.5) / q) / d, (j2 as f64 + (q2 as f64 + 0.5) / q) / d)
    }

    /// Local directions of every supersample, indexed `(j₂·D + j₁)·Q² + q₂·Q + q₁` (the
    /// concentric map evaluated once per grid instead of once per spatial node).
    pub fn sub_directions(&self) -> Vec<[f64; 3]> {
        let mut v = Vec::with_capacity(self.dir * self.dir * self.sub * self.sub);
        for j2 in 0..self.dir {
            for j1 in 0..self.dir {
                for q2 in 0..self.sub {
                    for q1 in 0..self.sub {
                        let (s1, s2) = self.sub_square(j1, j2, q1, q2);
                        v.push(square_to_dir(s1, s2));
                    }
                }
            }
        }
        v
    }

    /// The 16 `(sample, weight)` taps of a continuous lookup at `(r, y)`, square `(s₁, s₂)`.
    #[inline]
    pub fn taps(&self, r: f64, y: f64, s1: f64, s2: f64) -> [(usize, f64); 16] {
        let (r0, r1, fr) = bilinear_1d(r, self.spatial);
        let (y0, y1, fy) = bilinear_1d(y, self.spatial);
        let (a0, a1, fa) = bilinear_1d(s1, self.dir);
        let (b0, b1, fb) = bilinear_1d(s2, self.dir);
        let (s, d) = (self.spatial, self.dir);
        let sp = [
            (y0 * s + r0, (1.0 - fr) * (1.0 - fy)),
            (y0 * s + r1, fr * (1.0 - fy)),
            (y1 * s + r0, (1.0 - fr) * fy),
            (y1 * s + r1, fr * fy),
        ];
        let dr = [
            (b0 * d + a0, (1.0 - fa) * (1.0 - fb)),
            (b0 * d + a1, fa * (1.0 - fb)),
            (b1 * d + a0, (1.0 - fa) * fb),
            (b1 * d + a1, fa * fb),
        ];
        let mut out = [(0usize, 0.0f64); 16];
        for (i, &(si, sw)) in sp.iter().enumerate() {
            for (j, &(di, dw)) in dr.iter().enumerate() {
                out[i * 4 + j] = (si * d * d + di, sw * dw);
            }
        }
        out
    }
}

/// Square `(s₁, s₂) ∈ [0,1]²` → local direction `(a, b, c)`, `c ≥ 0` (concentric map, Malley).
#[inline]
pub fn square_to_dir(s1: f64, s2: f64) -> [f64; 3] {
    penumbra_math::warp::cosine_hemisphere(s1, s2)
}

/// The inverse of [`square_to_dir`] from `(a, b)` (the disk point): square coordinates.
#[inline]
pub fn dir_to_square(a: f64, b: f64) -> (f64, f64) {
    let r = (a * a + b * b).sqrt();
    if r == 0.0 {
        return (0.5, 0.5);
    }
    let phi = b.atan2(a);
    let q = PI / 4.0;
    // which wedge of the concentric map the point came from (see warp::concentric_disk)
    let (u, v) = if (-q..=q).contains(&phi) {
        (r, r * phi / q)
    } else if phi > q && phi <= 3.0 * q {
        (r * (2.0 - phi / q), r)
    } else if phi < -q && phi >= -3.0 * q {
        let p = phi + PI;
        (-r * (2.0 - p / q), -r)
    } else {
        let p = if phi > 0.0 { phi - PI } else { phi + PI };
        (-r, -r * p / q)
    };
    (((u + 1.0) * 0.5).clamp(0.0, 1.0), ((v + 1.0) * 0.5).clamp(0.0, 1.0))
}

/// `a × b`.
#[inline]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The frame of a lightfield crossing a side face of the unit cube (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IfaceFrame {
    /// Travel direction.
    pub t: [f64; 3],
    /// `ŷ × t̂`.
    pub r: [f64; 3],
    /// Face centre.
    pub centre: [f64; 3],
}

impl IfaceFrame {
    fn with(face: usize, t: [f64; 3]) -> Self {
        let (a, pos) = face_axis(face);
        let mut centre = [0.5; 3];
        centre[a] = if pos { 1.0 } else { 0.0 };
        Self { t, r: cross(UP, t), centre }
    }

    /// Light leaving the cube through side face `face` (`t̂` = outward normal).
    pub fn outgoing(face: usize) -> Self {
        let n = FACE_FRAMES[face].n;
        Self::with(face, [-n[0], -n[1], -n[2]])
    }

    /// Light entering the cube through side face `face` (`t̂` = inward normal).
    pub fn incoming(face: usize) -> Self {
        Self::with(face, FACE_FRAMES[face].n)
    }

    /// The point at `(r, y)`.
    #[inline]
    pub fn point(&self, r: f64, y: f64) -> [f64; 3] {
        core::array::from_fn(|k| self.centre[k] + (r - 0.5) * self.r[k] + (y - 0.5) * UP[k])
    }

    /// `(r, y)` of a point on the face.
    #[inline]
    pub fn coords(&self, p: [f64; 3]) -> (f64, f64) {
        let d = [p[0] - self.centre[0], p[1] - self.centre[1], p[2] - self.centre[2]];
        (dot(d, self.r) + 0.5, dot(d, UP) + 0.5)
    }

    /// World direction of local `(a, b, c)`.
    #[inline]
    pub fn world(&self, l: [f64; 3]) -> [f64; 3] {
        core::array::from_fn(|k| l[0] * self.r[k] + l[1] * UP[k] + l[2] * self.t[k])
    }

    /// Local `(a, b, c)` of a world direction.
    #[inline]
    pub fn local(&self, w: [f64; 3]) -> [f64; 3] {
        [dot(w, self.r), dot(w, UP), dot(w, self.t)]
    }
}

/// Turning directions of the propagation operators (§3.4.1, Fig. 3.3): light entering a block
/// with travel `t̂` leaves straight ahead (`t̂`), to the left (`t̂` turned +90° about `+Y`) or to
/// the right (−90°).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Turn {
    /// `R_↑`.
    Straight,
    /// `R_←`.
    Left,
    /// `R_→`.
    Right,
}

impl Turn {
    /// All three, in asset order.
    pub const ALL: [Turn; 3] = [Turn::Straight, Turn::Left, Turn::Right];

    /// Name in section names and reports.
    pub fn name(self) -> &'static str {
        match self {
            Turn::Straight => "straight",
            Turn::Left => "left",
            Turn::Right => "right",
        }
    }

    /// The turn from travel direction `t_in` to `t_out` (horizontal axis directions), `None`
    /// for a U-turn.
    pub fn between(t_in: [f64; 3], t_out: [f64; 3]) -> Option<Turn> {
        let d = dot(t_in, t_out);
        if d > 0.5 {
            return Some(Turn::Straight);
        }
        if d < -0.5 {
            return None;
        }
        // left = R_y(+90°) t_in = (t_z, 0, −t_x)
        let left = [t_in[2], 0.0, -t_in[0]];
        Some(if dot(left, t_out) > 0.5 { Turn::Left } else { Turn::Right })
    }

    /// The side face of the canonical block (light entering through −Z, travel +Z) that
    /// light leaves through for this turn: straight +Z (5), left +X (1), right −X (0).
    pub fn canonical_exit(self) -> usize {
        match self {
            Turn::Straight => 5,
            Turn::Left => 1,
            Turn::Right => 0,
        }
    }
}

/// The canonical entering face: −Z (face 4), travel +Z.
pub const CANONICAL_ENTRY: usize = 4;

/// Faces of the canonical response block (every face but the entering one), in order.
pub const RESPONSE_FACES: [usize; 5] = [0, 1, 2, 3, 5];

/// Quarter turns about `+Y` that take side face `face`'s inward travel direction to `+Z`
/// (the canonical entry): rotating a block point by them maps it into the canonical block.
pub fn quarter_turns_to_canonical(face: usize) -> u32 {
    // one turn of rotate_dir_to_canonical: +X → +Z, −Z → +X, −X → −Z
    match face {
        4 => 0, // inward +Z already
        0 => 1, // inward +X
        5 => 2, // inward −Z
        1 => 3, // inward −X
        _ => 0,
    }
}

/// Rotates a block-local point about the cube's vertical axis (`x = z = ½`) by `q` quarter
/// turns of `R_y(−90°)`: `(x, z) → (1 − z, x)` per turn, which takes the inward travel `+X` of
/// face 0 to `+Z` ([`quarter_turns_to_canonical`]).
#[inline]
pub fn rotate_to_canonical(p: [f64; 3], q: u32) -> [f64; 3] {
    let mut p = p;
    for _ in 0..q % 4 {
        p = [1.0 - p[2], p[1], p[0]];
    }
    p
}

/// The same rotation for a direction.
#[inline]
pub fn rotate_dir_to_canonical(d: [f64; 3], q: u32) -> [f64; 3] {
    let mut d = d;
    for _ in 0..q % 4 {
        d = [-d[2], d[1], d[0]];
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concentric_square_round_trips() {
        for i in 0..40 {
            for j in 0..40 {
                let (s1, s2) = ((i as f64 + 0.5) / 40.0, (j as f64 + 0.5) / 40.0);
                let d = square_to_dir(s1, s2);
                let (t1, t2) = dir_to_square(d[0], d[1]);
                assert!((t1 - s1).abs() < 1e-12 && (t2 - s2).abs() < 1e-12, "{s1} {s2} -> {t1} {t2}");
            }
        }
    }

    #[test]
    fn frames_agree_across_a_shared_face_and_are_right_handed() {
        for f in [0usize, 1, 4, 5] {
            let o = IfaceFrame::outgoing(f);
            // the neighbour across face f enters through the opposite face with the same t̂
            let g = f ^ 1;
            let i = IfaceFrame::incoming(g);
            assert_eq!(o.t, i.t);
            assert_eq!(o.r, i.r);
            assert_eq!(cross(o.r, UP), o.t);
            for (r, y) in [(0.2, 0.7), (0.9, 0.1)] {
                let p = o.point(r, y);
                let mut q = i.point(r, y);
                // the neighbour's cube is shifted by t̂
                for k in 0..3 {
                    q[k] += o.t[k];
                }
                assert!((0..3).all(|k| (p[k] - q[k]).abs() < 1e-15), "{p:?} {q:?}");
                let (rr, yy) = o.coords(p);
                assert!((rr - r).abs() < 1e-15 && (yy - y).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn turns_and_canonical_rotation() {
        let z = [0.0, 0.0, 1.0];
        assert_eq!(Turn::between(z, z), Some(Turn::Straight));
        assert_eq!(Turn::between(z, [1.0, 0.0, 0.0]), Some(Turn::Left));
        assert_eq!(Turn::between(z, [-1.0, 0.0, 0.0]), Some(Turn::Right));
        assert_eq!(Turn::between(z, [0.0, 0.0, -1.0]), None);
        for t in Turn::ALL {
            let out = IfaceFrame::outgoing(t.canonical_exit()).t;
            assert_eq!(Turn::between(z, out), Some(t));
        }
        for f in [0usize, 1, 4, 5] {
            let q = quarter_turns_to_canonical(f);
            let t = rotate_dir_to_canonical(IfaceFrame::incoming(f).t, q);
            assert!((t[2] - 1.0).abs() < 1e-15, "face {f}: {t:?}");
            let c = rotate_to_canonical(IfaceFrame::incoming(f).centre, q);
            assert_eq!(c, [0.5, 0.5, 0.0], "face {f}");
        }
    }

    #[test]
    fn taps_interpolate_linearly_and_sum_to_one() {
        let g = LfGrid { spatial: 4, dir: 6, sub: 1 };
        let taps = g.taps(0.41, 0.77, 0.33, 0.5);
        assert!((taps.iter().map(|t| t.1).sum::<f64>() - 1.0).abs() < 1e-15);
        // a field linear in r and s₁ is reproduced between nodes
        let f = |k: usize| {
            let (ir, _, j1, _) = g.coords(k);
            2.0 * (ir as f64 + 0.5) / 4.0 - 3.0 * (j1 as f64 + 0.5) / 6.0
        };
        let v: f64 = taps.iter().map(|&(k, w)| w * f(k)).sum();
        assert!((v - (2.0 * 0.41 - 3.0 * 0.33)).abs() < 1e-12);
    }
}
