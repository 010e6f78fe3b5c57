//! GPU export of a FIVT table: one KTX2 3D texture whose hardware trilinear filtering,
//! followed by a divide by alpha, is the runtime's lookup (asset spec §15.2 steps 2–4).
//!
//! # Layout
//! `VK_FORMAT_R32G32B32A32_SFLOAT` ([`TexelFormat::Rgba32F`], the default) or
//! `VK_FORMAT_R16G16B16A16_SFLOAT` ([`TexelFormat::Rgba16F`], `--half`: half the memory; each
//! value the f32 texel rounded to the nearest f16, ties to even; a value beyond f16's range
//! (65504) is an error, never an infinity), `pixelWidth = A` (θ, wrap addressing), `pixelHeight = P`
//! (φ, clamp), `pixelDepth = 3K`: three stacked slabs of `K` texels (ρ, clamp), slab `x`
//! holding the FIVs' `x`-component (`x = 0, 1, 2` along the shell basis' *world* axes, the
//! stored `[rgb][xyz]`). Texel `(i, j, x·K + k)` is
//! `(ŝ_k²·FIV[i][j][k][r][x], ŝ_k²·FIV[…][g][x], ŝ_k²·FIV[…][b][x], α)` with
//! `ŝ_k = max(ρ_k/R, δ)` (δ = `r_min`, or the second shell's radius when `r_min = 0`) and
//! `α = 1 − inside[i][j][k]` (inside samples store FIV 0, so their
//! colour is 0 too). One mip level, no supercompression, little-endian floats.
//!
//! # Sampling (what an engine's shader does)
//! With the runtime's `(u, v, w)` of §15.2 step 2 (`v`, `w` already clamped), sample slab `x`
//! at normalised coordinates `((u + ½)/A, (v + ½)/P, (x·K + w + ½)/(3K))` with linear
//! filtering: `w ∈ [0, K−1]` keeps every tap inside its slab (at `w = K−1` the upper tap has
//! weight 0), so the stacking never blends two slabs. Then
//! `FIV_rgb,x = tex.rgb / (tex.a · ŝ²)` with `ŝ = max(ρ/R, δ)`, which is the runtime's
//! renormalised `Σ w_c (ŝ_c/ŝ)² FIV_c / Σ w_c` over the valid corners. (`tex.a = 0`: every
//! corner with weight is inside; the runtime then takes the plain mean of any valid
//! zero-weight corners, or no FIV at all — a shader treats it as no occlusion.)
//!
//! The key/value data holds `KTXwriter` and `penumbra.fiv`: a JSON object with `samples`,
//! `radius`, `r_min`, `r_max`, `center`, `basis` (rows `e₁, e₂, e₃`), `layout`.

use crate::error::FivError;
use penumbra_asset::{Asset, DType};

/// `VK_FORMAT_R32G32B32A32_SFLOAT`.
pub const VK_FORMAT_R32G32B32A32_SFLOAT: u32 = 109;
/// `VK_FORMAT_R16G16B16A16_SFLOAT`.
pub const VK_FORMAT_R16G16B16A16_SFLOAT: u32 = 97;

/// Texel format of the exported texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TexelFormat {
    /// Four 32-bit floats (16 bytes per texel).
    #[default]
    Rgba32F,
    /// Four 16-bit floats (8 bytes per texel).
    Rgba16F,
}

impl TexelFormat {
    /// The Vulkan format number.
    pub fn vk_format(self) -> u32 {
        match self {
            Self::Rgba32F => VK_FORMAT_R32G32B32A32_SFLOAT,
            Self::Rgba16F => VK_FORMAT_R16G16B16A16_SFLOAT,
        }
    }

    /// Bytes per channel.
    pub fn channel_bytes(self) -> usize {
        match self {
            Self::Rgba32F => 4,
            Self::Rgba16F => 2,
        }
    }

    /// The Vulkan name without the `VK_FORMAT_` prefix.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rgba32F => "R32G32B32A32_SFLOAT",
            Self::Rgba16F => "R16G16B16A16_SFLOAT",
        }
    }
}

/// The KTX2 file identifier `«KTX 20»\r\n\x1A\n`.
pub const KTX2_IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

fn bad(msg: impl Into<String>) -> FivError {
    FivError::Parameter(msg.into())
}

fn f32_section<'a>(asset: &Asset<'a>, name: &str) -> Result<(Vec<f32>, Vec<usize>), FivError> {
    let s = asset.section(name).ok_or_else(|| bad(format!("no {name} section")))?;
    let v = s.to_f32_vec().map_err(|e| bad(format!("section {name}: {e}")))?;
    Ok((v, s.dims().to_vec()))
}

/// The Khronos basic data format descriptor of RGBA32F or RGBA16F (linear, BT.709
/// primaries), with its `dfdTotalSize` word first. `sampleLower`/`sampleUpper` of a float
/// channel are −1.0 and 1.0 as 32-bit floats for either width (as Khronos' dfdutils write
/// them).
fn dfd(format: TexelFormat) -> Vec<u8> {
    let bits = 8 * format.channel_bytes() as u32;
    let mut w: Vec<u32> = vec![
        4 + 24 + 4 * 16,           // dfdTotalSize
        0,                         // vendorId 0 (Khronos), descriptorType 0 (basic)
        2 | ((24 + 4 * 16) << 16), // versionNumber 2, descriptorBlockSize
        // colorModel 1 (RGBSDA), colorPrimaries 1 (BT709), transferFunction 1 (linear), flags 0
        1 | (1 << 8) | (1 << 16),
        0,        // texelBlockDimension 1×1×1×1 (stored minus one)
        bits / 2, // bytesPlane0 = 4 channels × bits / 8
        0,        // bytesPlane4..7
    ];
    for (n, channel) in [0u32, 1, 2, 15].into_iter().enumerate() {
        // bitOffset, bitLength − 1, channelType | FLOAT (0x80) | SIGNED (0x40)
        w.push((bits * n as u32) | ((bits - 1) << 16) | ((channel | 0xC0) << 24));
        w.push(0); // samplePosition
        w.push(0xBF80_0000); // sampleLower = −1.0f
        w.push(0x3F80_0000); // sampleUpper = 1.0f
    }
    w.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn kv_entry(key: &str, value: &[u8]) -> Vec<u8> {
    let len = key.len() + 1 + value.len();
    let mut out = (len as u32).to_le_bytes().to_vec();
    out.extend_from_slice(key.as_bytes());
    out.push(0);
    out.extend_from_slice(value);
    while out.len() % 4 != 0 {
        out.push(0);
    }
    out
}

/// The KTX2 bytes (RGBA32F) of a (whole, not shard) FIVT asset; `writer` goes to `KTXwriter`.
pub fn to_ktx2(asset: &Asset<'_>, writer: &str) -> Result<Vec<u8>, FivError> {
    to_ktx2_as(asset, writer, TexelFormat::Rgba32F)
}

/// [`to_ktx2`] in the given texel format.
pub fn to_ktx2_as(asset: &Asset<'_>, writer: &str, format: TexelFormat) -> Result<Vec<u8>, FivError> {
    if asset.kind().as_str() != "FIVT" {
        return Err(bad(format!("expected a FIVT asset, found {}", asset.kind().as_str())));
    }
    if asset.section("shard").is_some() {
        return Err(bad("a shard holds part of a table: merge the shards first (penumbra fiv merge)"));
    }
    let (fiv, d) = f32_section(asset, "fiv")?;
    if d.len() != 5 || d[3] != 3 || d[4] != 3 || d[0] < 2 || d[1] < 2 || d[2] < 2 {
        return Err(bad(format!("fiv: expected [A, P, K, 3, 3], found {d:?}")));
    }
    let (a, p, k) = (d[0], d[1], d[2]);
    let ins = asset.section("inside").ok_or_else(|| bad("no inside section"))?;
    if ins.dtype() != DType::U8 || ins.dims() != [a, p, k] {
        return Err(bad(format!("inside: expected u8 [{a}, {p}, {k}], found {:?}", ins.dims())));
    }
    let inside = ins.as_u8().map_err(|e| bad(format!("section inside: {e}")))?;
    let (radii, rd) = f32_section(asset, "radii")?;
    let (frame, fd) = f32_section(asset, "frame")?;
    if rd != [3] || fd != [4, 3] {
        return Err(bad("radii must be [3] and frame [4, 3]"));
    }
    let (r_min, r_max) = (radii[1], radii[2]);
    if !(radii[0] > 0.0 && r_min >= 0.0 && r_max > r_min && r_max.is_finite()) {
        return Err(bad(format!("radii {radii:?}: need R > 0 and 0 <= r_min < r_max")));
    }
    let depth = 3 * k;
    if depth > u32::MAX as usize || a * p * depth * 16 > isize::MAX as usize / 2 {
        return Err(bad("table too large for one texture"));
    }
    // δ: the runtime's scale floor (the smallest positive shell radius)
    let floor = if r_min > 0.0 { r_min } else { r_min + (r_max - r_min) * 1.0 / (k - 1) as f32 };
    // texel data, x fastest, then y (φ), then z (slab·K + ρ)
    let texel_bytes = 4 * format.channel_bytes();
    let mut data = Vec::with_capacity(a * p * depth * texel_bytes);
    let mut push = |v: f32, at: (usize, usize, usize, usize)| -> Result<(), FivError> {
        match format {
            TexelFormat::Rgba32F => data.extend_from_slice(&v.to_le_bytes()),
            TexelFormat::Rgba16F => {
                let h = penumbra_asset::f32_to_f16_bits(v);
                if h & 0x7C00 == 0x7C00 {
                    let (i, j, kk, x) = at;
                    return Err(bad(format!(
                        "texel ({i}, {j}, {kk}) of slab {x} is {v}, beyond f16's range (65504): export without --half"
                    )));
                }
                data.extend_from_slice(&h.to_le_bytes());
            }
        }
        Ok(())
    };
    for x in 0..3 {
        for kk in 0..k {
            // ŝ_k in the runtime's f32 operations
            let shell = r_min + (r_max - r_min) * kk as f32 / (k - 1) as f32;
            let sc = shell.max(floor).powi(2);
            for j in 0..p {
                for i in 0..a {
                    let s = (i * p + j) * k + kk;
                    let valid = if inside[s] == 0 { 1.0f32 } else { 0.0 };
                    for c in 0..3 {
                        push(fiv[s * 9 + c * 3 + x] * sc * valid, (i, j, kk, x))?;
                    }
                    push(valid, (i, j, kk, x))?;
                }
            }
        }
    }
    let meta = serde_json::json!({
        "samples": [a, p, k],
        "radius": radii[0],
        "r_min": r_min,
        "r_max": r_max,
        "center": &frame[0..3],
        "basis": [&frame[3..6], &frame[6..9], &frame[9..12]],
        "scale_floor": floor,
        "format": format.name(),
        "layout": "RGBA float 3D texture A x P x 3K: slab x (FIV x, y, z component) holds max(rho_k/R, scale_floor)^2 FIV_rgb and alpha = 1 - inside; FIV = tex.rgb / (tex.a max(rho/R, scale_floor)^2)",
    });
    let mut kvd = kv_entry("KTXwriter", format!("{writer}\0").as_bytes());
    kvd.extend(kv_entry("penumbra.fiv", format!("{meta}\0").as_bytes()));
    let dfd = dfd(format);
    let header_len = 80 + 24; // header + index, one level
    let dfd_off = header_len;
    let kvd_off = dfd_off + dfd.len();
    let mut level_off = kvd_off + kvd.len();
    level_off = level_off.div_ceil(texel_bytes) * texel_bytes; // lcm(texel block size 16 or 8, 4)
    let mut out = Vec::with_capacity(level_off + data.len());
    out.extend_from_slice(&KTX2_IDENTIFIER);
    for v in [format.vk_format(), format.channel_bytes() as u32, a as u32, p as u32, depth as u32, 0, 1, 1, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [dfd_off as u32, dfd.len() as u32, kvd_off as u32, kvd.len() as u32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength
    for v in [level_off as u64, data.len() as u64, data.len() as u64] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    out.resize(level_off, 0);
    out.extend_from_slice(&data);
    Ok(out)
}
