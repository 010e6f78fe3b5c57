//! Dictionary shapes: the unit cube with missing faces (MRT thesis §3.5.1, Fig. 4.1), its
//! texel sample points, and the analytic ray queries the bake needs.
//!
//! # Frame and faces
//! Every shape lives in the unit cube `[0,1]³` with **+Y up** (glTF's convention): the floor
//! is `y = 0`, the ceiling `y = 1`. Faces are numbered like a cube map: 0 = −X (`x = 0`),
//! 1 = +X, 2 = −Y (floor), 3 = +Y (ceiling), 4 = −Z, 5 = +Z. Normals point **into** the cube.
//! Each face has a frame `(origin, u, v, n)` with `u × v = n`; texel `(i, j)` of an `R × R`
//! face has its centre at `origin + (i+½)/R·u + (j+½)/R·v` (side faces keep `v = +Y`).
//! A shape's texels are its present faces in face order, each face row-major in `j`, then
//! `i`: texel index `slot·R² + j·R + i`.
//!
//! # Rays
//! The cube is convex, so a ray leaving a point on (or in) it never hits a wall before it
//! reaches the boundary: "ray tracing" is finding the boundary face where it exits, and the
//! ray is lost when that face is missing. No BVH is needed.

/// Number of cube faces.
pub const FACE_COUNT: usize = 6;

/// Face names in face order.
pub const FACE_NAMES: [&str; FACE_COUNT] = ["-x", "+x", "-y", "+y", "-z", "+z"];

/// The frame of one cube face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceFrame {
    /// Corner where texel coordinates start.
    pub origin: [f64; 3],
    /// Texel column direction (unit, axis-aligned).
    pub u: [f64; 3],
    /// Texel row direction (unit, axis-aligned).
    pub v: [f64; 3],
    /// Inward normal `u × v`.
    pub n: [f64; 3],
}

/// Face frames in face order (see the module docs).
pub const FACE_FRAMES: [FaceFrame; FACE_COUNT] = [
    FaceFrame { origin: [0.0, 0.0, 1.0], u: [0.0, 0.0, -1.0], v: [0.0, 1.0, 0.0], n: [1.0, 0.0, 0.0] },
    FaceFrame { origin: [1.0, 0.0, 0.0], u: [0.0, 0.0, 1.0], v: [0.0, 1.0, 0.0], n: [-1.0, 0.0, 0.0] },
    FaceFrame { origin: [0.0, 0.0, 0.0], u: [0.0, 0.0, 1.0], v: [1.0, 0.0, 0.0], n: [0.0, 1.0, 0.0] },
    FaceFrame { origin: [0.0, 1.0, 0.0], u: [1.0, 0.0, 0.0], v: [0.0, 0.0, 1.0], n: [0.0, -1.0, 0.0] },
    FaceFrame { origin: [0.0, 0.0, 0.0], u: [1.0, 0.0, 0.0], v: [0.0, 1.0, 0.0], n: [0.0, 0.0, 1.0] },
    FaceFrame { origin: [1.0, 0.0, 1.0], u: [-1.0, 0.0, 0.0], v: [0.0, 1.0, 0.0], n: [0.0, 0.0, -1.0] },
];

/// `(axis, sign)` of face `f`: the face lies on the plane `x_axis = 0` (sign −1) or `= 1`.
#[inline]
pub const fn face_axis(f: usize) -> (usize, bool) {
    (f / 2, f % 2 == 1)
}

/// A shape: the unit cube with a set of missing faces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    /// Stable name (used as a key in reports and the asset).
    pub name: &'static str,
    /// Bit `f` set when face `f` is missing (an opening / interface).
    pub missing: u8,
}

impl Shape {
    /// A shape with the given missing-face mask (bits 0..6).
    pub const fn new(name: &'static str, missing: u8) -> Self {
        Self { name, missing: missing & 0x3F }
    }

    /// Whether face `f` is present (a wall with texels).
    #[inline]
    pub const fn has(&self, f: usize) -> bool {
        self.missing & (1 << f) == 0
    }

    /// Present faces in face order.
    pub fn faces(&self) -> Vec<usize> {
        (0..FACE_COUNT).filter(|&f| self.has(f)).collect()
    }

    /// Missing faces in face order.
    pub fn missing_faces(&self) -> Vec<usize> {
        (0..FACE_COUNT).filter(|&f| !self.has(f)).collect()
    }

    /// Pairs of missing faces that share an edge ("contiguous"), in face order; each pair
    /// gets kitty-corner prior lights (MRT thesis §4.1.1).
    pub fn contiguous_missing_pairs(&self) -> Vec<(usize, usize)> {
        let m = self.missing_faces();
        let mut out = Vec::new();
        for (a, &fa) in m.iter().enumerate() {
            for &fb in &m[a + 1..] {
                if face_axis(fa).0 != face_axis(fb).0 {
                    out.push((fa, fb));
                }
            }
        }
        out
    }
}

/// The closed cube.
pub const CLOSED: Shape = Shape::new("closed", 0);

/// The 2D cube dictionary (§3.5.1, Fig. 4.1): floor and ceiling always present, 0–4 side
/// faces missing, six entries up to symmetry, 12 missing faces in total.
pub const CUBE2D: [Shape; 6] = [
    CLOSED,
    Shape::new("dead_end", 1 << 5),
    Shape::new("straight", (1 << 4) | (1 << 5)),
    Shape::new("corner", (1 << 1) | (1 << 5)),
    Shape::new("tee", (1 << 0) | (1 << 1) | (1 << 5)),
    Shape::new("cross", (1 << 0) | (1 << 1) | (1 << 4) | (1 << 5)),
];

/// Which dictionary to bake.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DictionaryKind {
    /// The six cube2d shapes.
    Cube2d,
    /// The closed cube alone (Table 3.2's setting).
    ClosedCube,
}

impl DictionaryKind {
    /// The shapes, in asset order.
    pub fn shapes(self) -> Vec<Shape> {
        match self {
            Self::Cube2d => CUBE2D.to_vec(),
            Self::ClosedCube => vec![CLOSED],
        }
    }

    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Cube2d => "cube2d",
            Self::ClosedCube => "closed-cube",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "cube2d" => Some(Self::Cube2d),
            "closed-cube" => Some(Self::ClosedCube),
            _ => None,
        }
    }
}

/// Texel layout of one shape at `res × res` texels per present face.
#[derive(Debug, Clone)]
pub struct Texels {
    /// The shape.
    pub shape: Shape,
    /// Texels per face edge.
    pub res: usize,
    /// Present faces, in face order (slot → face).
    pub faces: Vec<usize>,
    /// Face → slot, `usize::MAX` when missing.
    pub slot: [usize; FACE_COUNT],
}

impl Texels {
    /// The layout of `shape` at `res` texels per edge.
    pub fn new(shape: Shape, res: usize) -> Self {
        let faces = shape.faces();
        let mut slot = [usize::MAX; FACE_COUNT];
        for (s, &f) in faces.iter().enumerate() {
            slot[f] = s;
        }
        Self { shape, res, faces, slot }
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        self.faces.len() * self.res * self.res
    }

    /// Whether the shape has no texels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `(face, i, j)` of texel `t`.
    #[inline]
    pub fn coords(&self, t: usize) -> (usize, usize, usize) {
        let r2 = self.res * self.res;
        let f = self.faces[t / r2];
        let k = t % r2;
        (f, k % self.res, k / self.res)
    }

    /// Texel index of `(face, i, j)`; the face must be present.
    #[inline]
    pub fn index(&self, f: usize, i: usize, j: usize) -> usize {
        self.slot[f] * self.res * self.res + j * self.res + i
    }

    /// Centre of texel `t`.
    pub fn position(&self, t: usize) -> [f64; 3] {
        let (f, i, j) = self.coords(t);
        face_point(f, (i as f64 + 0.5) / self.res as f64, (j as f64 + 0.5) / self.res as f64)
    }

    /// Inward normal of texel `t`.
    pub fn normal(&self, t: usize) -> [f64; 3] {
        FACE_FRAMES[self.coords(t).0].n
    }

    /// Texels of one present face, as an index range.
    pub fn face_range(&self, f: usize) -> core::ops::Range<usize> {
        let r2 = self.res * self.res;
        let s = self.slot[f];
        s * r2..(s + 1) * r2
    }

    /// Texels that a bilinear read at face coordinates `(u, v) ∈ [0,1]²` of face `f` touches,
    /// with weights (clamp-to-edge inside the face; the 4 weights sum to 1).
    #[inline]
    pub fn bilinear(&self, f: usize, u: f64, v: f64) -> [(usize, f64); 4] {
        let r = self.res;
        let (i0, i1, fx) = bilinear_1d(u, r);
        let (j0, j1, fy) = bilinear_1d(v, r);
        let base = self.slot[f] * r * r;
        [
            (base + j0 * r + i0, (1.0 - fx) * (1.0 - fy)),
            (base + j0 * r + i1, fx * (1.0 - fy)),
            (base + j1 * r + i0, (1.0 - fx) * fy),
            (base + j1 * r + i1, fx * fy),
        ]
    }

    /// Bilinear read of the per-texel values `l` at `(u, v)` of face `f`.
    #[inline]
    pub fn sample(&self, l: &[f64], f: usize, u: f64, v: f64) -> f64 {
        self.bilinear(f, u, v).iter().map(|&(t, w)| w * l[t]).sum()
    }
}

/// Texel pair and weight of a clamp-to-edge linear read at `u ∈ [0,1]` over `r` texels
/// centred at `(i+½)/r`.
#[inline]
pub(crate) fn bilinear_1d(u: f64, r: usize) -> (usize, usize, f64) {
    let s = u * r as f64 - 0.5;
    if s <= 0.0 {
        return (0, 0, 0.0);
    }
    let last = (r - 1) as f64;
    if s >= last {
        return (r - 1, r - 1, 0.0);
    }
    // s > 0 here: truncation is floor, and avoids a libm call on baseline x86-64
    let i0 = s as usize;
    (i0, i0 + 1, s - i0 as f64)
}

/// The point at face coordinates `(u, v)` of face `f`.
#[inline]
pub fn face_point(f: usize, u: f64, v: f64) -> [f64; 3] {
    let fr = &FACE_FRAMES[f];
    [
        fr.origin[0] + u * fr.u[0] + v * fr.v[0],
        fr.origin[1] + u * fr.u[1] + v * fr.v[1],
        fr.origin[2] + u * fr.u[2] + v * fr.v[2],
    ]
}

/// Face coordinates `(u, v)` of a point `q` on face `f`.
#[inline]
pub fn face_uv(f: usize, q: [f64; 3]) -> (f64, f64) {
    let fr = &FACE_FRAMES[f];
    let d = [q[0] - fr.origin[0], q[1] - fr.origin[1], q[2] - fr.origin[2]];
    (dot(d, fr.u), dot(d, fr.v))
}

/// Where a ray from `p` (inside the closed unit cube or on its boundary) along `d` leaves
/// the cube: `(face, t)` with the exit point `p + t·d`. Ties (edges, corners) go to the
/// lowest face index, so the result is deterministic.
#[inline]
pub fn exit_face(p: [f64; 3], d: [f64; 3]) -> (usize, f64) {
    let mut best = (usize::MAX, f64::INFINITY);
    for a in 0..3 {
        let (t, f) = if d[a] > 0.0 {
            ((1.0 - p[a]) / d[a], 2 * a + 1)
        } else if d[a] < 0.0 {
            (-p[a] / d[a], 2 * a)
        } else {
            continue;
        };
        if t < best.1 || (t == best.1 && f < best.0) {
            best = (f, t);
        }
    }
    best
}

/// Whether the segment from `c` to `x` (a point on the cube's boundary) reaches `x` without
/// crossing a present wall: true when `c` is inside the cube (the cube is convex) or when the
/// segment enters the cube through a missing face. A light outside the cube thus lights the
/// inside only through the openings ("shadowing by the shape's walls", §4.1.1).
pub fn segment_enters_open(shape: &Shape, c: [f64; 3], x: [f64; 3]) -> bool {
    let d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
    // Liang–Barsky: the largest entering parameter is where the segment enters the slab box.
    let mut s_in = f64::NEG_INFINITY;
    let mut face = usize::MAX;
    for a in 0..3 {
        if d[a] == 0.0 {
            if c[a] < 0.0 || c[a] > 1.0 {
                return false;
            }
            continue;
        }
        let (s, f) = if d[a] > 0.0 { (-c[a] / d[a], 2 * a) } else { ((1.0 - c[a]) / d[a], 2 * a + 1) };
        if s > s_in {
            s_in = s;
            face = f;
        }
    }
    if s_in <= 0.0 {
        return true;
    }
    face != usize::MAX && !shape.has(face)
}

/// Dot product.
#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    }

    #[test]
    fn frames_are_right_handed_inward_and_on_their_planes() {
        for (f, fr) in FACE_FRAMES.iter().enumerate() {
            assert_eq!(cross(fr.u, fr.v), fr.n, "face {f}");
            let (a, pos) = face_axis(f);
            let plane = if pos { 1.0 } else { 0.0 };
            for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.3, 0.7)] {
                let p = face_point(f, u, v);
                assert_eq!(p[a], plane);
                assert!(p.iter().all(|&c| (0.0..=1.0).contains(&c)), "{p:?}");
                let (uu, vv) = face_uv(f, p);
                assert!((uu - u).abs() < 1e-15 && (vv - v).abs() < 1e-15);
            }
            // inward: the cube centre is on the positive side
            let c = [0.5 - fr.origin[0], 0.5 - fr.origin[1], 0.5 - fr.origin[2]];
            assert!(dot(c, fr.n) > 0.0);
        }
    }

    #[test]
    fn dictionary_has_six_entries_and_twelve_openings() {
        assert_eq!(CUBE2D.len(), 6);
        assert_eq!(CUBE2D.iter().map(|s| s.missing_faces().len()).sum::<usize>(), 12);
        for s in CUBE2D {
            assert!(s.has(2) && s.has(3), "{} keeps floor and ceiling", s.name);
        }
        let pairs: Vec<usize> = CUBE2D.iter().map(|s| s.contiguous_missing_pairs().len()).collect();
        assert_eq!(pairs, vec![0, 0, 0, 1, 2, 4]);
    }

    #[test]
    fn texel_indexing_round_trips() {
        let t = Texels::new(CUBE2D[3], 4);
        assert_eq!(t.len(), 4 * 16);
        for k in 0..t.len() {
            let (f, i, j) = t.coords(k);
            assert_eq!(t.index(f, i, j), k);
            let p = t.position(k);
            let (u, v) = face_uv(f, p);
            assert!((u - (i as f64 + 0.5) / 4.0).abs() < 1e-15 && (v - (j as f64 + 0.5) / 4.0).abs() < 1e-15);
        }
    }

    #[test]
    fn bilinear_reads_reproduce_texel_values_at_centres_and_linear_functions_inside() {
        let t = Texels::new(CLOSED, 5);
        let l: Vec<f64> = (0..t.len())
            .map(|k| {
                let (_, i, j) = t.coords(k);
                1.0 + 2.0 * i as f64 - 0.5 * j as f64
            })
            .collect();
        for f in 0..6 {
            for j in 0..5 {
                for i in 0..5 {
                    let (u, v) = ((i as f64 + 0.5) / 5.0, (j as f64 + 0.5) / 5.0);
                    assert!((t.sample(&l, f, u, v) - l[t.index(f, i, j)]).abs() < 1e-12);
                }
            }
            // between centres the read is exactly linear; outside them it is clamped
            let (u, v) = (0.47, 0.33);
            let (s, r) = (u * 5.0 - 0.5, v * 5.0 - 0.5);
            assert!((t.sample(&l, f, u, v) - (1.0 + 2.0 * s - 0.5 * r)).abs() < 1e-12);
            assert!((t.sample(&l, f, 0.01, 0.99) - l[t.index(f, 0, 4)]).abs() < 1e-12);
        }
    }

    #[test]
    fn exit_face_and_segment_visibility() {
        let (f, t) = exit_face([0.5, 0.0, 0.5], [0.0, 1.0, 0.0]);
        assert_eq!((f, t), (3, 1.0));
        let (f, t) = exit_face([0.0, 0.5, 0.5], [0.6, 0.0, 0.8]);
        assert_eq!(f, 5);
        assert!((t - 0.625).abs() < 1e-15);
        // a light outside +z sees the floor through the +z opening, not through a wall
        let dead_end = CUBE2D[1];
        assert!(segment_enters_open(&dead_end, [0.5, 0.5, 1.3], [0.5, 0.0, 0.5]));
        assert!(!segment_enters_open(&CLOSED, [0.5, 0.5, 1.3], [0.5, 0.0, 0.5]));
        // entering through the +x wall first: blocked even though +z is open
        assert!(!segment_enters_open(&dead_end, [1.5, 0.5, 1.1], [0.0, 0.5, 0.5]));
        // inside lights always see every wall of a convex shape
        assert!(segment_enters_open(&CLOSED, [0.2, 0.9, 0.4], [1.0, 0.1, 0.8]));
    }
}
