//! Exact 180° rotations of lat-long maps about the coordinate axes: each one permutes the
//! texels (no resampling). Useful to bring a probe stored in another frame into ours — e.g.
//! `grace_latlong.exr` is upside down in the OpenEXR frame (see the [module docs](super)):
//! [`Rotation::Z180`] puts the cathedral's floor at −Y.

use super::latlong::EnvMap;

/// A rotation by 180° about an axis (or none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rotation {
    /// Identity.
    #[default]
    None,
    /// `(x, y, z) → (x, −y, −z)`: rows flipped, columns mirrored about a quarter width.
    X180,
    /// `(x, y, z) → (−x, y, −z)`: columns shifted by half the width.
    Y180,
    /// `(x, y, z) → (−x, −y, z)`: rows and columns flipped.
    Z180,
}

impl Rotation {
    /// `"none"`, `"x180"`, `"y180"`, `"z180"`.
    pub fn name(self) -> &'static str {
        match self {
            Rotation::None => "none",
            Rotation::X180 => "x180",
            Rotation::Y180 => "y180",
            Rotation::Z180 => "z180",
        }
    }

    /// Parses [`Rotation::name`].
    pub fn parse(s: &str) -> Option<Self> {
        [Rotation::None, Rotation::X180, Rotation::Y180, Rotation::Z180].into_iter().find(|r| r.name() == s)
    }
}

impl EnvMap {
    /// The map rotated by `r`: the radiance arriving from `d` now arrives from `r(d)`.
    /// `None` for X180 and Y180 on an odd width (not a texel permutation then).
    pub fn rotated(&self, r: Rotation) -> Option<EnvMap> {
        let (w, h) = (self.width(), self.height());
        if matches!(r, Rotation::X180 | Rotation::Y180) && w % 2 != 0 {
            return None;
        }
        let mut out = vec![[0.0f32; 3]; w * h];
        for y in 0..h {
            for x in 0..w {
                let (x2, y2) = match r {
                    Rotation::None => (x, y),
                    Rotation::X180 => ((w / 2 + w - 1 - x) % w, h - 1 - y),
                    Rotation::Y180 => ((x + w / 2) % w, y),
                    Rotation::Z180 => (w - 1 - x, h - 1 - y),
                };
                out[y2 * w + x2] = self.texel(x, y);
            }
        }
        EnvMap::new(w, h, out).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotations_move_texels_to_the_rotated_directions() {
        let (w, h) = (16, 8);
        let env = EnvMap::from_fn(w, h, |d| [d[0] as f32, d[1] as f32, d[2] as f32]).unwrap();
        let map = |r: Rotation, d: [f64; 3]| match r {
            Rotation::None => d,
            Rotation::X180 => [d[0], -d[1], -d[2]],
            Rotation::Y180 => [-d[0], d[1], -d[2]],
            Rotation::Z180 => [-d[0], -d[1], d[2]],
        };
        for r in [Rotation::None, Rotation::X180, Rotation::Y180, Rotation::Z180] {
            let rot = env.rotated(r).unwrap();
            for y in 0..h {
                for x in 0..w {
                    // the texel at direction d' holds the radiance that came from r⁻¹(d') = r(d')
                    let d = rot.texel_direction(x, y);
                    let src = map(r, d);
                    let v = rot.texel(x, y);
                    for k in 0..3 {
                        assert!((v[k] as f64 - src[k]).abs() < 1e-6, "{r:?} ({x},{y})");
                    }
                }
            }
            assert_eq!(Rotation::parse(r.name()), Some(r));
        }
        assert!(EnvMap::constant(5, 2, [1.0; 3]).unwrap().rotated(Rotation::Y180).is_none());
    }
}
