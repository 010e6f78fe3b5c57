//! The `VOSS` asset: one group of sections per sample set plus the random reflection
//! textures (schemas/asset-format.md, "VOSS").

use crate::bake::{FAMILIES, SampleSet, VoBake, VoError, set_key};
use crate::voronoi::Domain;
use penumbra_asset::{Asset, AssetBuilder, Kind};
use serde_json::json;

/// Kind version of the `VOSS` sections.
pub const VOSS_KIND_VERSION: u32 = 1;

fn werr(e: impl std::fmt::Display) -> VoError {
    VoError::Asset(e.to_string())
}

fn f32s(v: impl IntoIterator<Item = f64>) -> Vec<f32> {
    v.into_iter().map(|x| x as f32).collect()
}

/// Every section name of an asset holding `counts` for all four families.
pub fn section_names(counts: &[usize]) -> Vec<String> {
    let mut v = vec!["meta".to_string(), "reflect2d".into(), "reflect3d".into()];
    for &(d, c) in &FAMILIES {
        for &n in counts {
            let k = set_key(d, c, n);
            v.push(format!("{k}.points"));
            v.push(format!("{k}.weights"));
            v.push(format!("{k}.log2area"));
            if d == Domain::Disk {
                v.push(format!("{k}.zs"));
            }
        }
    }
    v
}

/// The asset of a bake. `params` (the normalised bake parameters) and `cache_key` go to
/// `meta` with the comparison table.
pub fn to_asset(b: &VoBake, params: serde_json::Value, cache_key: Option<&str>) -> Result<AssetBuilder, VoError> {
    let counts: Vec<usize> =
        b.sets.iter().filter(|s| s.domain == Domain::Disk && !s.centre).map(|s| s.points.len()).collect();
    let meta = json!({
        "kind": "VOSS",
        "kind_version": VOSS_KIND_VERSION,
        "tool": concat!("penumbra ", env!("CARGO_PKG_VERSION")),
        "convention": {
            "disk": "unit disk under dmu = 2 sqrt(1 - r^2) dA (the sphere's orthographic projection; line and area sampling, MRT thesis 6.3.1-6.3.2); points [N,2]",
            "ball": "unit ball under the volume measure (point sampling); points [N,3]",
            "c1": "sample 0 is the centre (0,0[,0])",
            "weights": "discrete Voronoi cell measure mu_i, sum 1: estimate = sum_i w_i * free_fraction_i",
            "log2area": "log2(cell area / disk area) or log2(cell volume / ball volume), unweighted (area sampling's LOD offset, 6.3.2)",
            "zs": "sqrt(1 - x^2 - y^2): the line's half extent; line free length max(min(zs, d) + zs, 0)",
            "reflect": "per pixel (x mod S, y mod S): p' = p - 2 (p.r) r with the texel's unit r (2D for lines, 3D for points, 6.3.5)",
        },
        "params": params,
        "counts": counts,
        "cache_key": cache_key,
        "metrics": { "sets": b.sets.len(), "comparison": b.comparison },
    });
    let mut a = AssetBuilder::new(Kind::VOSS);
    a.add_json("meta", &serde_json::to_string(&meta).map_err(werr)?).map_err(werr)?;
    let s = (b.reflect2d.len() as f64).sqrt() as usize;
    a.add_f32("reflect2d", &[s, s, 2], &f32s(b.reflect2d.iter().flat_map(|r| *r))).map_err(werr)?;
    a.add_f32("reflect3d", &[s, s, 3], &f32s(b.reflect3d.iter().flat_map(|r| *r))).map_err(werr)?;
    for set in &b.sets {
        let k = set.key();
        let n = set.points.len();
        let d = set.domain.dim();
        a.add_f32(&format!("{k}.points"), &[n, d], &f32s(set.points.iter().flat_map(|p| p[..d].to_vec())))
            .map_err(werr)?;
        a.add_f32(&format!("{k}.weights"), &[n], &f32s(set.weights.iter().copied())).map_err(werr)?;
        a.add_f32(&format!("{k}.log2area"), &[n], &f32s(set.log2area.iter().copied())).map_err(werr)?;
        if set.domain == Domain::Disk {
            a.add_f32(&format!("{k}.zs"), &[n], &f32s(set.z_s())).map_err(werr)?;
        }
    }
    Ok(a)
}

/// One set read back from an asset (f32 values widened).
#[derive(Debug, Clone, PartialEq)]
pub struct StoredSet {
    /// Domain.
    pub domain: Domain,
    /// With the centre sample.
    pub centre: bool,
    /// Samples (unused coordinates 0).
    pub points: Vec<[f64; 3]>,
    /// Weights (sum 1).
    pub weights: Vec<f64>,
    /// `log₂` area fractions.
    pub log2area: Vec<f64>,
}

/// Reads one set (`None`: the asset has no set of that key).
pub fn read_set(a: &Asset, domain: Domain, centre: bool, n: usize) -> Result<Option<StoredSet>, VoError> {
    let k = set_key(domain, centre, n);
    let Some(p) = a.section(&format!("{k}.points")) else { return Ok(None) };
    let d = domain.dim();
    if p.dims() != [n, d] {
        return Err(VoError::Asset(format!("{k}.points has dims {:?}, expected [{n}, {d}]", p.dims())));
    }
    let pv = p.to_f32_vec().map_err(werr)?;
    let get = |name: &str| -> Result<Vec<f64>, VoError> {
        let s = a.section(&format!("{k}.{name}")).ok_or_else(|| VoError::Asset(format!("{k}.{name} is missing")))?;
        if s.dims() != [n] {
            return Err(VoError::Asset(format!("{k}.{name} has dims {:?}, expected [{n}]", s.dims())));
        }
        Ok(s.to_f32_vec().map_err(werr)?.into_iter().map(f64::from).collect())
    };
    let points = pv
        .chunks_exact(d)
        .map(|c| {
            let mut q = [0.0; 3];
            for (k, v) in c.iter().enumerate() {
                q[k] = f64::from(*v);
            }
            q
        })
        .collect();
    Ok(Some(StoredSet { domain, centre, points, weights: get("weights")?, log2area: get("log2area")? }))
}

/// Reads the reflection normals of a domain (2D for the disk, 3D for the ball), row-major.
pub fn read_reflections(a: &Asset, domain: Domain) -> Result<Vec<[f64; 3]>, VoError> {
    let name = if domain == Domain::Disk { "reflect2d" } else { "reflect3d" };
    let s = a.section(name).ok_or_else(|| VoError::Asset(format!("{name} is missing")))?;
    let d = domain.dim();
    if s.dims().len() != 3 || s.dims()[2] != d || s.dims()[0] != s.dims()[1] {
        return Err(VoError::Asset(format!("{name} has dims {:?}, expected [S, S, {d}]", s.dims())));
    }
    Ok(s.to_f32_vec()
        .map_err(werr)?
        .chunks_exact(d)
        .map(|c| {
            let mut q = [0.0; 3];
            for (k, v) in c.iter().enumerate() {
                q[k] = f64::from(*v);
            }
            q
        })
        .collect())
}

impl SampleSet {
    /// Whether a stored set equals this one at f32 precision.
    pub fn matches(&self, s: &StoredSet) -> bool {
        self.points.len() == s.points.len()
            && self
                .points
                .iter()
                .zip(&s.points)
                .all(|(a, b)| (0..3).all(|k| (a[k] as f32) as f64 == b[k] || a[k] == 0.0 && b[k] == 0.0))
            && self.weights.iter().zip(&s.weights).all(|(a, b)| (*a as f32) as f64 == *b)
    }
}
