//! Environment-map files: OpenEXR through the exr crate, Radiance `.hdr` through image.

use std::path::Path;

use crate::error::{EnvError, EnvErrorKind};

use super::EnvReport;
use super::latlong::EnvMap;

/// The `envmap` attribute of an OpenEXR file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvmapAttribute {
    /// `ENVMAP_LATLONG`.
    LatLong,
    /// `ENVMAP_CUBE`.
    Cube,
}

/// Loads a lat-long environment map from `.exr` or `.hdr` (dispatch by extension).
/// EXR: the first layer, level 0 of mip/rip-mapped files, scanline or tiled, half/float/uint
/// R, G, B channels (alpha ignored; a lone Y channel is used as grey); the `envmap`
/// attribute is returned in the report (a cube-map layout is rejected).
/// Rejects NaN/Inf texels and damaged files with an error naming the file; negative texels
/// (which some HDR tools produce by ringing) are clamped to 0 and counted in the report.
pub fn load_env_map(path: impl AsRef<Path>) -> Result<(EnvMap, EnvReport), EnvError> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
    let (w, h, rgb, envmap) = match ext.as_str() {
        "exr" => read_exr(path)?,
        "hdr" | "pic" => read_hdr(path)?,
        _ => {
            return Err(EnvError::new(
                path,
                EnvErrorKind::UnsupportedFormat(if ext.is_empty() {
                    "(no extension)".into()
                } else {
                    format!(".{ext}")
                }),
            ));
        }
    };
    finish(path, w, h, rgb, envmap)
}

fn finish(
    path: &Path,
    w: usize,
    h: usize,
    mut rgb: Vec<[f32; 3]>,
    envmap: Option<EnvmapAttribute>,
) -> Result<(EnvMap, EnvReport), EnvError> {
    if envmap == Some(EnvmapAttribute::Cube) {
        return Err(EnvError::new(
            path,
            EnvErrorKind::Dimensions(
                "the file is an OpenEXR cube-map layout (envmap = cube); a lat-long map is expected".into(),
            ),
        ));
    }
    if w == 0 || h == 0 || rgb.len() != w * h {
        return Err(EnvError::new(
            path,
            EnvErrorKind::Dimensions(format!("image is {w}x{h} with {} texels", rgb.len())),
        ));
    }
    const NAMES: [&str; 3] = ["R", "G", "B"];
    let mut report = EnvReport { width: w, height: h, envmap, ..EnvReport::default() };
    for (i, t) in rgb.iter_mut().enumerate() {
        for c in 0..3 {
            let v = t[c];
            if !v.is_finite() {
                return Err(EnvError::new(
                    path,
                    EnvErrorKind::NonFinite { x: i % w, y: i / w, channel: NAMES[c], value: v },
                ));
            }
            if v < 0.0 {
                t[c] = 0.0;
                report.negative_texels_clamped += 1;
            }
        }
    }
    if w != 2 * h {
        report.warnings.push(format!("{w}x{h} is not 2:1; texels are not square in angle"));
    }
    let map = EnvMap::new(w, h, rgb).map_err(|e| EnvError::new(path, EnvErrorKind::Dimensions(e.to_string())))?;
    Ok((map, report))
}

type Decoded = (usize, usize, Vec<[f32; 3]>, Option<EnvmapAttribute>);

fn read_exr(path: &Path) -> Result<Decoded, EnvError> {
    use exr::prelude::*;
    // deep images are not environment maps (and the exr reader does not skip them)
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| EnvError::new(path, EnvErrorKind::Decode(e.to_string())))?;
    if meta.headers.iter().any(|h| h.deep) {
        return Err(EnvError::new(path, EnvErrorKind::Decode("deep-data OpenEXR files are not supported".into())));
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_file(path)
        .map_err(|e| EnvError::new(path, EnvErrorKind::Decode(e.to_string())))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let envmap = layer.attributes.environment_map.map(|e| match e {
        exr::meta::attribute::EnvironmentMap::LatitudeLongitude => EnvmapAttribute::LatLong,
        exr::meta::attribute::EnvironmentMap::Cube => EnvmapAttribute::Cube,
    });
    let channels = &layer.channel_data.list;
    let find = |name: &str| {
        channels.iter().position(|c| {
            let n = c.name.to_string();
            n == name || n.rsplit('.').next() == Some(name)
        })
    };
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    let idx: [usize; 3] = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => [r, g, b],
        (_, _, _, Some(y)) => [y, y, y],
        _ => {
            return Err(EnvError::new(
                path,
                EnvErrorKind::Channels(format!("no R, G, B (or Y) channels; found {names:?}")),
            ));
        }
    };
    let n = w.checked_mul(h).ok_or_else(|| EnvError::new(path, EnvErrorKind::Dimensions(format!("{w}x{h}"))))?;
    let mut rgb = vec![[0.0f32; 3]; n];
    for (c, &ci) in idx.iter().enumerate() {
        let ch = &channels[ci];
        if ch.sampling.x() != 1 || ch.sampling.y() != 1 {
            return Err(EnvError::new(path, EnvErrorKind::Channels(format!("channel {} is subsampled", names[ci]))));
        }
        let len = ch.sample_data.len();
        if len != n {
            return Err(EnvError::new(
                path,
                EnvErrorKind::Channels(format!("channel {} has {len} samples for {w}x{h} pixels", names[ci])),
            ));
        }
        match &ch.sample_data {
            FlatSamples::F16(v) => rgb.iter_mut().zip(v).for_each(|(t, s)| t[c] = s.to_f32()),
            FlatSamples::F32(v) => rgb.iter_mut().zip(v).for_each(|(t, s)| t[c] = *s),
            FlatSamples::U32(v) => rgb.iter_mut().zip(v).for_each(|(t, s)| t[c] = *s as f32),
        }
    }
    Ok((w, h, rgb, envmap))
}

fn read_hdr(path: &Path) -> Result<Decoded, EnvError> {
    let file = std::fs::File::open(path).map_err(|e| EnvError::new(path, e))?;
    let reader = std::io::BufReader::new(file);
    let dec = image::codecs::hdr::HdrDecoder::new(reader)
        .map_err(|e| EnvError::new(path, EnvErrorKind::Decode(e.to_string())))?;
    let img = image::DynamicImage::from_decoder(dec)
        .map_err(|e| EnvError::new(path, EnvErrorKind::Decode(e.to_string())))?
        .into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let rgb = img.pixels().map(|p| p.0).collect();
    Ok((w, h, rgb, None))
}
