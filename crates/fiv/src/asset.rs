//! The `FIVT` asset: writing a bake (or a shard of one), and merging shards into exactly the
//! bytes a single run writes. Sections are specified in `schemas/asset-format.md` ("FIVT").

use crate::bake::{BakeStats, FivBake};
use crate::error::FivError;
use crate::layout::{Frame, Shard, ShellLayout, UpAxis};
use penumbra_asset::{Asset, AssetBuilder, DType, Kind};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Kind version of the FIVT asset written by this crate.
pub const FIVT_KIND_VERSION: u32 = 1;

/// Every section a FIVT v1 asset may hold (`shard` only in shard assets, critical there).
pub const FIVT_SECTIONS: &[&str] =
    &["fiv", "inside", "irradiance", "env_fiv", "frame", "radii", "env_cube", "ref_vertices", "ref_triangles", "shard"];

/// Storage type of the `fiv` section.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Storage {
    /// IEEE binary32 (36 bytes per sample).
    #[default]
    F32,
    /// IEEE binary16 (`--half`, 18 bytes per sample).
    F16,
}

/// The normalised bake parameters recorded in `meta.params`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetaParams {
    /// `[A, P, K]`.
    pub samples: [usize; 3],
    /// Innermost shell radius / R.
    pub r_min: f64,
    /// Outermost shell radius / R.
    pub r_max: f64,
    /// Polar axis.
    pub up: UpAxis,
    /// Environment cube face size.
    pub cube_size: usize,
    /// Irradiance cube face size.
    pub irradiance_size: usize,
    /// Storage of `fiv`.
    pub storage: Storage,
}

impl MetaParams {
    /// The shell layout.
    pub fn layout(&self) -> ShellLayout {
        ShellLayout {
            azimuth: self.samples[0],
            polar: self.samples[1],
            radial: self.samples[2],
            r_min: self.r_min,
            r_max: self.r_max,
            up: self.up,
        }
    }
}

/// `meta.metrics`: the bake's counters and derived figures. Every field is either a sum over
/// shards or a function of sections every shard shares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Rays cast.
    pub rays_traced: u64,
    /// Texels found occluded (traced hits and certified hits).
    pub rays_hit: u64,
    /// Hits certified without a ray ([`crate::interior`]).
    pub rays_certified: u64,
    /// Samples flagged inside the occluder.
    pub inside_samples: u64,
    /// Bytes of the `fiv` section of the whole bake (A·P·K·9·element size).
    pub fiv_bytes: u64,
    /// `∫ L dΩ` of the environment cube per channel.
    pub env_power: [f64; 3],
}

/// `meta.shard` of a shard asset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardMeta {
    /// K.
    pub index: usize,
    /// N.
    pub count: usize,
    /// Azimuth slab `[a0, a1)`.
    pub azimuth: [usize; 2],
}

/// The `meta` JSON of a FIVT asset. Serialised in field order; no timestamps, durations or
/// absolute paths.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FivMeta {
    /// `"FIVT"`.
    pub kind: String,
    /// [`FIVT_KIND_VERSION`].
    pub kind_version: u32,
    /// `penumbra <version>`.
    pub tool: String,
    /// The conventions in words.
    pub convention: Value,
    /// Normalised parameters.
    pub params: MetaParams,
    /// Input descriptions (names and content hashes), as given by the caller.
    pub inputs: Value,
    /// Occluder frame.
    pub frame: Frame,
    /// blake3 of the normalised parameters and input hashes (`penumbra bake` skips a stage
    /// whose key is unchanged).
    pub cache_key: Option<String>,
    /// Counters and figures.
    pub metrics: Metrics,
    /// Present only in a shard asset.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<ShardMeta>,
}

/// The conventions, written into every asset's meta.
pub fn convention() -> Value {
    serde_json::json!({
        "samples": "theta_i = 2 pi i/A, phi_j = pi j/(P-1) (poles included), rho_k = R (r_min + (r_max - r_min) k/(K-1)); position = c + rho (sin phi sin theta e1 + cos phi e2 + sin phi cos theta e3), (e1, e2, e3) = frame rows 1..3",
        "fiv": "sum over environment cube texels whose ray from the sample hits the occluder of L(w) w dOmega, per rgb channel (FIV eq. 9); [A, P, K, rgb, xyz]",
        "cube": "faces +X, -X, +Y, -Y, +Z, -Z, OpenGL orientation; texel (i = column, j = row), s = (i + 0.5)/S, t = (j + 0.5)/S",
        "latlong": "OpenEXR LatLong: row 0 = +Y, centre column = +Z, quarter width = +X",
        "irradiance": "E(n) = sum over all texels of max(0, n.w) L dOmega at every irradiance cube texel centre normal",
    })
}

fn err(e: impl core::fmt::Display) -> FivError {
    FivError::Asset(e.to_string())
}

/// Everything besides the bake that goes into the asset.
#[derive(Debug, Clone)]
pub struct AssetInputs<'a> {
    /// Input descriptions for `meta.inputs` (mesh and environment names, hashes).
    pub inputs: Value,
    /// Cache key for `meta.cache_key`.
    pub cache_key: Option<String>,
    /// f16 storage of `fiv`.
    pub storage: Storage,
    /// The radiance cube texels `[6·C², rgb]` (for `env_cube`).
    pub env_cube: &'a [[f32; 3]],
    /// The occluder mesh (for `ref_vertices`, `ref_triangles`).
    pub mesh: &'a penumbra_geometry::TriMesh,
}

/// Builds the meta of a bake.
pub fn meta_of(b: &FivBake, inp: &AssetInputs<'_>) -> FivMeta {
    let l = b.params.layout;
    let elem = if inp.storage == Storage::F16 { 2 } else { 4 };
    let mut power = [0.0f64; 3];
    let c = b.cube_size;
    for (t, rgb) in inp.env_cube.iter().enumerate() {
        let (i, j) = (t % c, (t / c) % c);
        let sa = penumbra_geometry::env::cube_texel_solid_angle(c, i, j);
        for k in 0..3 {
            power[k] += rgb[k] as f64 * sa;
        }
    }
    let shard = (b.shard != Shard::WHOLE).then(|| {
        let r = b.shard.azimuth_range(l.azimuth);
        ShardMeta { index: b.shard.index, count: b.shard.count, azimuth: [r.start, r.end] }
    });
    FivMeta {
        kind: "FIVT".into(),
        kind_version: FIVT_KIND_VERSION,
        tool: concat!("penumbra ", env!("CARGO_PKG_VERSION")).into(),
        convention: convention(),
        params: MetaParams {
            samples: [l.azimuth, l.polar, l.radial],
            r_min: l.r_min,
            r_max: l.r_max,
            up: l.up,
            cube_size: b.cube_size,
            irradiance_size: b.params.irradiance_size,
            storage: inp.storage,
        },
        inputs: inp.inputs.clone(),
        frame: b.frame,
        cache_key: inp.cache_key.clone(),
        metrics: Metrics {
            rays_traced: b.stats.rays_traced,
            rays_hit: b.stats.rays_hit,
            rays_certified: b.stats.rays_certified,
            inside_samples: b.stats.inside_samples,
            fiv_bytes: (l.samples() * 9 * elem) as u64,
            env_power: power,
        },
        shard,
    }
}

/// Builds the FIVT asset of a bake or shard.
pub fn to_asset(b: &FivBake, inp: &AssetInputs<'_>) -> Result<AssetBuilder, FivError> {
    let l = b.params.layout;
    let meta = meta_of(b, inp);
    let slab = b.shard.azimuth_range(l.azimuth).len();
    let mut a = AssetBuilder::new(Kind::FIVT);
    a.add_json("meta", &serde_json::to_string(&meta).map_err(err)?).map_err(err)?;
    let dims = [slab, l.polar, l.radial, 3, 3];
    match inp.storage {
        Storage::F32 => a.add_f32("fiv", &dims, &b.fiv).map_err(err)?,
        Storage::F16 => {
            if let Some(v) = b.fiv.iter().find(|v| v.abs() > 65504.0) {
                return Err(FivError::HalfOverflow { value: *v as f64 });
            }
            a.add_f16("fiv", &dims, &b.fiv).map_err(err)?
        }
    };
    a.add_u8("inside", &[slab, l.polar, l.radial], &b.inside).map_err(err)?;
    let s = b.params.irradiance_size;
    a.add_f32("irradiance", &[6, s, s, 3], &b.irradiance).map_err(err)?;
    a.add_f32("env_fiv", &[3, 3], b.env_fiv.as_flattened()).map_err(err)?;
    let basis = l.up.basis();
    let c = b.frame.center;
    let mut frame = vec![c[0] as f32, c[1] as f32, c[2] as f32];
    frame.extend(basis.iter().flatten().map(|&v| v as f32));
    a.add_f32("frame", &[4, 3], &frame).map_err(err)?;
    a.add_f32("radii", &[3], &[b.frame.radius as f32, l.r_min as f32, l.r_max as f32]).map_err(err)?;
    let cs = b.cube_size;
    a.add_f32("env_cube", &[6, cs, cs, 3], inp.env_cube.as_flattened()).map_err(err)?;
    a.add_f64("ref_vertices", &[inp.mesh.positions.len(), 3], inp.mesh.positions.as_flattened()).map_err(err)?;
    a.add_u32("ref_triangles", &[inp.mesh.indices.len(), 3], inp.mesh.indices.as_flattened()).map_err(err)?;
    if let Some(sm) = meta.shard {
        let v = [sm.index, sm.count, sm.azimuth[0], sm.azimuth[1]].map(|x| x as u32);
        a.add_u32("shard", &[4], &v).map_err(err)?;
        // a shard is not a usable table: readers that do not know shards must refuse it
        a.set_critical("shard", true).map_err(err)?;
    }
    Ok(a)
}

/// Parses and checks the meta of a FIVT asset.
pub fn read_meta(asset: &Asset<'_>) -> Result<FivMeta, FivError> {
    if asset.kind() != Kind::FIVT {
        return Err(FivError::Asset(format!("expected a FIVT asset, found {}", asset.kind())));
    }
    let meta: FivMeta =
        serde_json::from_str(asset.meta_json()).map_err(|e| FivError::Asset(format!("meta is not FIVT meta: {e}")))?;
    if meta.kind_version != FIVT_KIND_VERSION {
        return Err(FivError::Asset(format!(
            "FIVT kind_version {} is not supported (this tool reads {FIVT_KIND_VERSION})",
            meta.kind_version
        )));
    }
    Ok(meta)
}

/// Merges shard assets (any order) into the asset a single run writes. Checks that they
/// come from the same bake (same meta apart from `shard` and the counters, same shared
/// sections) and cover every shard exactly once.
pub fn merge(shards: &[Asset<'_>]) -> Result<AssetBuilder, FivError> {
    let merr = |m: String| FivError::Merge(m);
    if shards.is_empty() {
        return Err(merr("no shards given".into()));
    }
    let mut metas = Vec::with_capacity(shards.len());
    for (i, s) in shards.iter().enumerate() {
        let m = read_meta(s).map_err(|e| merr(format!("input {}: {e}", i + 1)))?;
        let sm = m.shard.ok_or_else(|| merr(format!("input {} is a whole bake, not a shard", i + 1)))?;
        metas.push((sm, m));
    }
    let n = metas[0].0.count;
    let mut order: Vec<usize> = (0..shards.len()).collect();
    order.sort_by_key(|&i| metas[i].0.index);
    if shards.len() != n || order.iter().enumerate().any(|(k, &i)| metas[i].0.index != k || metas[i].0.count != n) {
        let have: Vec<String> = metas.iter().map(|(s, _)| format!("{}/{}", s.index, s.count)).collect();
        return Err(merr(format!("need shards 0..{n} of {n} exactly once, got {}", have.join(", "))));
    }
    let first = &metas[order[0]].1;
    let same = |m: &FivMeta| {
        m.kind == first.kind
            && m.tool == first.tool
            && m.convention == first.convention
            && m.params == first.params
            && m.inputs == first.inputs
            && m.frame == first.frame
            && m.cache_key == first.cache_key
            && m.metrics.fiv_bytes == first.metrics.fiv_bytes
            && m.metrics.env_power == first.metrics.env_power
    };
    if let Some(&i) = order.iter().find(|&&i| !same(&metas[i].1)) {
        return Err(merr(format!(
            "shard {}/{n} comes from a different bake (parameters, inputs or tool differ from shard 0/{n})",
            metas[i].0.index
        )));
    }
    let mut stats = BakeStats::default();
    for (_, m) in &metas {
        stats.rays_traced += m.metrics.rays_traced;
        stats.rays_hit += m.metrics.rays_hit;
        stats.rays_certified += m.metrics.rays_certified;
        stats.inside_samples += m.metrics.inside_samples;
    }
    let mut meta = first.clone();
    meta.shard = None;
    meta.metrics.rays_traced = stats.rays_traced;
    meta.metrics.rays_hit = stats.rays_hit;
    meta.metrics.rays_certified = stats.rays_certified;
    meta.metrics.inside_samples = stats.inside_samples;

    let a_total = first.params.samples[0];
    let mut out = AssetBuilder::new(Kind::FIVT);
    out.add_json("meta", &serde_json::to_string(&meta).map_err(err)?).map_err(err)?;
    let base = &shards[order[0]];
    for info in base.sections() {
        let name = info.name();
        if name == "meta" || name == "shard" {
            continue;
        }
        let sec = base.section(name).ok_or_else(|| err(format!("section {name} vanished")))?;
        if name == "fiv" || name == "inside" {
            let mut bytes = Vec::new();
            let mut next = 0;
            for &i in &order {
                let s = shards[i]
                    .section(name)
                    .ok_or_else(|| merr(format!("shard {}/{n} has no {name:?} section", metas[i].0.index)))?;
                let [a0, a1] = metas[i].0.azimuth;
                if a0 != next || s.dims().first() != Some(&(a1 - a0)) || s.dims()[1..] != sec.dims()[1..] {
                    return Err(merr(format!(
                        "shard {}/{n}: section {name:?} does not hold azimuths {a0}..{a1}",
                        metas[i].0.index
                    )));
                }
                if s.dtype() != sec.dtype() {
                    return Err(merr(format!("shard {}/{n}: section {name:?} has another type", metas[i].0.index)));
                }
                next = a1;
                bytes.extend_from_slice(s.bytes());
            }
            if next != a_total {
                return Err(merr(format!("the shards cover azimuths 0..{next}, not 0..{a_total}")));
            }
            let mut dims = sec.dims().to_vec();
            dims[0] = a_total;
            out.add_raw(name, sec.dtype(), &dims, &bytes).map_err(err)?;
        } else {
            for &i in &order {
                let s = shards[i]
                    .section(name)
                    .ok_or_else(|| merr(format!("shard {}/{n} has no {name:?} section", metas[i].0.index)))?;
                if s.dtype() != sec.dtype() || s.dims() != sec.dims() || s.bytes() != sec.bytes() {
                    return Err(merr(format!(
                        "shard {}/{n}: section {name:?} differs from shard 0/{n} (different bake)",
                        metas[i].0.index
                    )));
                }
            }
            if sec.dtype() == DType::Json {
                return Err(merr(format!("unexpected JSON section {name:?}")));
            }
            out.add_raw(name, sec.dtype(), sec.dims(), sec.bytes()).map_err(err)?;
        }
    }
    Ok(out)
}
