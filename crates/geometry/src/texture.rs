//! glTF base-colour textures: the encoded images a scene refers to, decoded on demand into
//! linear RGB, and a box-filtered mip chain for area-averaged lookups.
//!
//! Conventions (glTF 2.0 §3.8, §5.22): `baseColorTexture` holds sRGB-encoded colour, decoded
//! here with the sRGB EOTF (IEC 61966-2-1) and multiplied by the linear `baseColorFactor` by
//! the caller; alpha is ignored. UV `(0, 0)` is the upper-left corner of the image (its first
//! row), texel `(x, y)` covers `[x, x + 1] × [y, y + 1]` in `(u·w, v·h)`. Wrap modes are the
//! sampler's (`REPEAT` when there is no sampler).
//!
//! Images are read at import (bytes only) but decoded only when asked for, so a scene whose
//! textures are missing or broken still imports: geometry never depends on them, and the
//! error reaches whoever needs the colour (the sphere-albedo bake), naming the image.

/// One image of the glTF `images` array: where it came from and its encoded bytes, or why
/// they could not be read.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneImage {
    /// `image I ("name" or "uri")`, for messages.
    pub label: String,
    /// The encoded bytes (PNG or JPEG), or the reason they are unavailable.
    pub bytes: Result<Vec<u8>, String>,
}

/// Texture coordinate wrap mode (glTF sampler `wrapS` / `wrapT`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// `REPEAT` (10497): the fractional part.
    Repeat,
    /// `CLAMP_TO_EDGE` (33071).
    Clamp,
    /// `MIRRORED_REPEAT` (33648).
    Mirror,
}

/// The base-colour texture of a primitive's material.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BaseColorTexture {
    /// Index into [`crate::Scene::images`].
    pub image: u32,
    /// Sampler wrap mode along u.
    pub wrap_s: Wrap,
    /// Sampler wrap mode along v.
    pub wrap_t: Wrap,
}

/// Why an image could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{label}: {reason}")]
pub struct TextureError {
    /// The image's label ([`SceneImage::label`]).
    pub label: String,
    /// What went wrong.
    pub reason: String,
}

/// Largest accepted image side, in texels (guards decompression bombs).
pub const MAX_SIDE: u32 = 16_384;

/// The sRGB EOTF: encoded value in [0, 1] → linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// A decoded image in linear RGB with its mip chain (level 0 first). Level `l + 1` is level
/// `l` halved (sides `max(1, ⌊s/2⌋)`), each texel the mean of the 2×2 (or 2×1, 1×2) texels
/// it covers; an odd last row or column of level `l` is folded into the last texel of level
/// `l + 1` (mean of 3), so every level keeps the mean of level 0 exactly for even sides and to
/// within one row/column's weight for odd ones.
#[derive(Debug, Clone, PartialEq)]
pub struct MipChain {
    levels: Vec<(u32, u32, Vec<[f32; 3]>)>,
}

impl MipChain {
    /// Decodes `image` (PNG or JPEG, 8 or 16 bit, any channel layout; format from the bytes).
    pub fn decode(image: &SceneImage) -> Result<Self, TextureError> {
        let fail = |reason: String| TextureError { label: image.label.clone(), reason };
        let bytes = image.bytes.as_ref().map_err(|e| fail(e.clone()))?;
        let reader = image::ImageReader::new(std::io::Cursor::new(bytes.as_slice()))
            .with_guessed_format()
            .map_err(|e| fail(e.to_string()))?;
        if reader.format().is_none() {
            return Err(fail("not a PNG or JPEG image (unrecognised signature)".into()));
        }
        let (w, h) = reader.into_dimensions().map_err(|e| fail(format!("cannot read its header: {e}")))?;
        if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
            return Err(fail(format!("{w}×{h} texels (each side must be 1..={MAX_SIDE})")));
        }
        let img = image::load_from_memory(bytes).map_err(|e| fail(format!("cannot decode: {e}")))?;
        let rgb = img.into_rgb32f();
        let texels: Vec<[f32; 3]> = rgb.pixels().map(|p| p.0.map(srgb_to_linear)).collect();
        Ok(Self::from_linear(w, h, texels))
    }

    /// A chain from linear texels (row-major, `w·h` of them, `w, h ≥ 1`).
    pub fn from_linear(w: u32, h: u32, texels: Vec<[f32; 3]>) -> Self {
        debug_assert_eq!(texels.len(), (w as usize) * (h as usize));
        let mut levels = vec![(w, h, texels)];
        while let Some((pw, ph, prev)) = levels.last().filter(|(pw, ph, _)| *pw > 1 || *ph > 1) {
            let (nw, nh) = ((pw / 2).max(1), (ph / 2).max(1));
            let (pw, ph) = (*pw as usize, *ph as usize);
            let mut next = Vec::with_capacity(nw as usize * nh as usize);
            // source range of destination index i along a side of length n → m
            let span = |i: usize, n: usize, m: usize| {
                let lo = if m == n { i } else { 2 * i };
                let hi = if m == n {
                    i + 1
                } else if i + 1 == m {
                    n
                } else {
                    2 * i + 2
                };
                lo..hi
            };
            for y in 0..nh as usize {
                for x in 0..nw as usize {
                    let mut acc = [0.0f64; 3];
                    let mut count = 0.0f64;
                    for sy in span(y, ph, nh as usize) {
                        for sx in span(x, pw, nw as usize) {
                            let t = prev[sy * pw + sx];
                            for k in 0..3 {
                                acc[k] += f64::from(t[k]);
                            }
                            count += 1.0;
                        }
                    }
                    next.push(acc.map(|a| (a / count) as f32));
                }
            }
            levels.push((nw, nh, next));
        }
        Self { levels }
    }

    /// `(width, height)` of level 0.
    pub fn size(&self) -> (u32, u32) {
        (self.levels[0].0, self.levels[0].1)
    }

    /// Number of levels (1 for a 1×1 image).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Mean linear RGB over a footprint of about `side` level-0 texels centred at `uv`:
    /// trilinear filtering at level `log2(side)` (bilinear at level 0 for `side ≤ 1`, the
    /// 1×1 mean beyond the last level).
    pub fn sample(&self, uv: [f64; 2], wrap: (Wrap, Wrap), side: f64) -> [f64; 3] {
        let lod = if side > 1.0 { side.log2() } else { 0.0 };
        let last = (self.levels.len() - 1) as f64;
        let lod = lod.min(last);
        let l0 = lod.floor() as usize;
        let f = lod - l0 as f64;
        let a = self.bilinear(l0, uv, wrap);
        if f <= 0.0 || l0 + 1 >= self.levels.len() {
            return a;
        }
        let b = self.bilinear(l0 + 1, uv, wrap);
        std::array::from_fn(|k| a[k] + f * (b[k] - a[k]))
    }

    fn bilinear(&self, level: usize, uv: [f64; 2], wrap: (Wrap, Wrap)) -> [f64; 3] {
        let (w, h, texels) = &self.levels[level];
        let (w, h) = (*w as i64, *h as i64);
        let x = uv[0] * w as f64 - 0.5;
        let y = uv[1] * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut out = [0.0f64; 3];
        for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                let wgt = wx * wy;
                if wgt == 0.0 {
                    continue;
                }
                let tx = wrap_index(x0 + dx, w, wrap.0);
                let ty = wrap_index(y0 + dy, h, wrap.1);
                let t = texels[(ty * w + tx) as usize];
                for k in 0..3 {
                    out[k] += wgt * f64::from(t[k]);
                }
            }
        }
        out
    }
}

/// Texel index `i` on a side of `n` texels under a wrap mode.
fn wrap_index(i: i64, n: i64, wrap: Wrap) -> i64 {
    match wrap {
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Mirror => {
            let p = i.rem_euclid(2 * n);
            if p < n { p } else { 2 * n - 1 - p }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decode_matches_the_standard() {
        // IEC 61966-2-1 reference points
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
        // continuous at the knee
        assert!((srgb_to_linear(0.040_45) - ((0.040_45f32 + 0.055) / 1.055).powf(2.4)).abs() < 1e-6);
    }

    #[test]
    fn every_level_keeps_the_mean_and_sampling_wraps() {
        // 8×4 texels of a ramp: every level's mean equals level 0's (even sides)
        let (w, h) = (8u32, 4u32);
        let t: Vec<[f32; 3]> = (0..w * h).map(|i| [(i % w) as f32, (i / w) as f32, 1.0]).collect();
        let m = MipChain::from_linear(w, h, t);
        assert_eq!(m.level_count(), 4); // 8×4, 4×2, 2×1, 1×1
        for (lw, lh, tex) in &m.levels {
            let mean: f64 = tex.iter().map(|t| f64::from(t[0])).sum::<f64>() / f64::from(lw * lh);
            assert!((mean - 3.5).abs() < 1e-6, "{lw}×{lh}: {mean}");
        }
        // a texel centre returns the texel at level 0
        let c = m.sample([2.5 / 8.0, 1.5 / 4.0], (Wrap::Clamp, Wrap::Clamp), 1.0);
        assert!((c[0] - 2.0).abs() < 1e-9 && (c[1] - 1.0).abs() < 1e-9);
        // repeat: u + 1 is u; mirror: −u is u; clamp: beyond the edge is the edge
        let r = m.sample([1.0 + 2.5 / 8.0, 1.5 / 4.0], (Wrap::Repeat, Wrap::Repeat), 1.0);
        assert!((r[0] - 2.0).abs() < 1e-9);
        let mi = m.sample([-2.5 / 8.0, 1.5 / 4.0], (Wrap::Mirror, Wrap::Mirror), 1.0);
        assert!((mi[0] - 2.0).abs() < 1e-9);
        let cl = m.sample([3.0, 1.5 / 4.0], (Wrap::Clamp, Wrap::Clamp), 1.0);
        assert!((cl[0] - 7.0).abs() < 1e-9);
        // a footprint as large as the image gives the mean
        let big = m.sample([0.3, 0.8], (Wrap::Repeat, Wrap::Repeat), 64.0);
        assert!((big[0] - 3.5).abs() < 1e-6 && (big[1] - 1.5).abs() < 1e-6);
    }

    #[test]
    fn odd_sides_fold_the_last_row_into_the_last_texel() {
        let m = MipChain::from_linear(3, 1, vec![[0.0; 3], [3.0; 3], [6.0; 3]]);
        // 3 → 1: one texel, the mean of all three
        assert_eq!(m.level_count(), 2);
        assert!((m.levels[1].2[0][0] - 3.0).abs() < 1e-6);
    }

    #[test]
    fn broken_or_missing_bytes_name_the_image() {
        let img = SceneImage { label: "image 0 (\"fur.png\")".into(), bytes: Ok(b"not an image".to_vec()) };
        let e = MipChain::decode(&img).unwrap_err();
        assert!(e.to_string().starts_with("image 0 (\"fur.png\"): "), "{e}");
        let img = SceneImage { label: "image 1".into(), bytes: Err("cannot read fur.png: no such file".into()) };
        assert!(MipChain::decode(&img).unwrap_err().to_string().contains("no such file"));
    }

    #[test]
    fn png_round_trip_is_srgb_decoded() {
        // a 2×1 PNG (sRGB 188 and 0): linear 0.5029… and 0
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(&[188, 188, 188, 0, 0, 0], 2, 1, image::ExtendedColorType::Rgb8)
            .unwrap();
        let m = MipChain::decode(&SceneImage { label: "t".into(), bytes: Ok(png) }).unwrap();
        assert_eq!(m.size(), (2, 1));
        let want = f64::from(srgb_to_linear(188.0 / 255.0));
        assert!((want - 0.5029).abs() < 1e-3);
        let a = m.sample([0.25, 0.5], (Wrap::Clamp, Wrap::Clamp), 1.0);
        assert!((a[0] - want).abs() < 1e-6, "{a:?}");
        let b = m.sample([0.75, 0.5], (Wrap::Clamp, Wrap::Clamp), 1.0);
        assert!(b[0].abs() < 1e-9);
    }

    use image::ImageEncoder;
}
