//! `penumbra inspect <asset> [--json] [--dump] [--section NAME]`.

use crate::args::InspectArgs;
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use anyhow::anyhow;
use penumbra_asset::{Asset, AssetFile, DType, Section};
use serde_json::{Value, json};

/// Sections up to this many elements are dumped whole; larger ones as statistics.
pub const DUMP_FULL_LIMIT: usize = 64;

/// Section values as JSON numbers (integers stay integers), or the parsed JSON text.
fn values_json(s: &Section<'_>) -> Result<Value, CliError> {
    let err = |e: penumbra_asset::ViewError| CliError::input(anyhow!("section {}: {e}", s.name()));
    Ok(match s.dtype() {
        DType::Json => {
            let text = s.as_json().map_err(err)?;
            serde_json::from_str(text).unwrap_or_else(|_| Value::String(text.to_string()))
        }
        DType::U8 => json!(s.to_vec::<u8>().map_err(err)?),
        DType::U16 => json!(s.to_vec::<u16>().map_err(err)?),
        DType::U32 => json!(s.to_vec::<u32>().map_err(err)?),
        DType::I32 => json!(s.to_vec::<i32>().map_err(err)?),
        DType::F16 | DType::F32 => {
            Value::Array(s.to_f32_vec().map_err(err)?.into_iter().map(|v| float_json(v as f64)).collect())
        }
        DType::F64 => Value::Array(s.to_f64_vec().map_err(err)?.into_iter().map(float_json).collect()),
    })
}

/// JSON has no NaN/Inf: they become strings so a dump never fails.
fn float_json(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { json!(v.to_string()) }
}

fn summary(s: &Section<'_>) -> Value {
    match s.to_f64_vec() {
        Ok(v) => {
            let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
            let (min, max) = finite.iter().fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            let mean = if finite.is_empty() { 0.0 } else { finite.iter().sum::<f64>() / finite.len() as f64 };
            json!({
                "count": v.len(),
                "min": if finite.is_empty() { Value::Null } else { json!(min) },
                "max": if finite.is_empty() { Value::Null } else { json!(max) },
                "mean": mean,
                "non_finite": v.len() - finite.len(),
                "first": v.iter().take(8).map(|&x| float_json(x)).collect::<Vec<_>>(),
            })
        }
        Err(_) => json!({"count": s.info().element_count()}),
    }
}

fn section_row(s: &Section<'_>) -> Value {
    let i = s.info();
    json!({
        "name": i.name(),
        "dtype": i.dtype().name(),
        "dims": i.dims(),
        "bytes": i.byte_len(),
        "offset": i.offset(),
        "crc32c": format!("{:08x}", i.crc()),
        "checksum_ok": i.checksum_ok(),
        "critical": i.is_critical(),
    })
}

fn describe(asset: &Asset<'_>, path: &str, dump: bool) -> Result<Value, CliError> {
    let (maj, min) = asset.version();
    let mut sections = Vec::new();
    for s in asset.iter() {
        let mut row = section_row(&s);
        if dump && s.name() != penumbra_asset::META_SECTION {
            let v = if s.info().element_count() <= DUMP_FULL_LIMIT {
                json!({"values": values_json(&s)?})
            } else {
                json!({"summary": summary(&s)})
            };
            if let (Some(r), Some(extra)) = (row.as_object_mut(), v.as_object()) {
                r.extend(extra.clone());
            }
        }
        sections.push(row);
    }
    let meta: Value =
        serde_json::from_str(asset.meta_json()).unwrap_or_else(|_| Value::String(asset.meta_json().into()));
    Ok(json!({
        "file": path,
        "bytes": asset.file_size(),
        "format_version": [maj, min],
        "kind": asset.kind().as_str(),
        "checksums_ok": asset.all_checksums_ok(),
        "sections": sections,
        "meta": meta,
    }))
}

/// Runs `penumbra inspect`.
#[allow(clippy::print_stderr)]
pub fn run(a: &InspectArgs) -> Result<ExitCode, CliError> {
    let file = AssetFile::open_unverified(&a.asset).map_err(CliError::input)?;
    let asset = file.asset();
    let path = a.asset.display().to_string();
    if let Some(name) = &a.section {
        let s = asset.section(name).ok_or_else(|| {
            let names: Vec<&str> = asset.sections().iter().map(|s| s.name()).collect();
            CliError::input(anyhow!("{path}: no section named {name:?} (sections: {})", names.join(", ")))
        })?;
        if !s.info().checksum_ok() {
            return Err(CliError::input(anyhow!("{path}: section {name:?} fails its checksum; the asset is damaged")));
        }
        let v = json!({"name": s.name(), "dtype": s.dtype().name(), "dims": s.dims(), "values": values_json(&s)?});
        if a.json {
            print_json(&v);
        } else {
            crate::outln!("{name}: {} {:?}", s.dtype().name(), s.dims());
            crate::outln!("{}", serde_json::to_string(&v["values"]).unwrap_or_default());
        }
    } else {
        let d = describe(&asset, &path, a.dump)?;
        if a.json {
            print_json(&d);
        } else {
            let (maj, min) = asset.version();
            crate::outln!(
                "{path}: {} bytes, penumbra asset format {maj}.{min}, kind {}",
                asset.file_size(),
                asset.kind()
            );
            crate::outln!("{:<22} {:<5} {:<18} {:>10} {:>9} ok", "section", "type", "dims", "bytes", "crc32c");
            for (s, row) in asset.iter().zip(d["sections"].as_array().into_iter().flatten()) {
                let i = s.info();
                crate::outln!(
                    "{:<22} {:<5} {:<18} {:>10} {:08x} {}{}",
                    i.name(),
                    i.dtype().name(),
                    format!("{:?}", i.dims()),
                    i.byte_len(),
                    i.crc(),
                    if i.checksum_ok() { "yes" } else { "NO" },
                    if i.is_critical() { "  (critical)" } else { "" }
                );
                if a.dump && i.name() != penumbra_asset::META_SECTION {
                    if let Some(v) = row.get("values") {
                        crate::outln!("    values: {v}");
                    } else if let Some(v) = row.get("summary") {
                        crate::outln!("    {v}");
                    }
                }
            }
            crate::outln!("meta:\n{}", serde_json::to_string_pretty(&d["meta"]).unwrap_or_default());
        }
    }
    if !asset.all_checksums_ok() {
        let bad: Vec<&str> = asset.sections().iter().filter(|s| !s.checksum_ok()).map(|s| s.name()).collect();
        eprintln!("error: {path}: damaged asset: checksum mismatch in section(s) {}", bad.join(", "));
        return Ok(ExitCode::BadInput);
    }
    Ok(ExitCode::Ok)
}
