//! `penumbra shaders export`: every shader as WGSL, SPIR-V, HLSL, GLSL and MSL, translated by
//! naga without a device.
//!
//! Bindings keep the WGSL numbers everywhere: SPIR-V `DescriptorSet` = group, `Binding` =
//! binding; HLSL `register(tN/uN/bN, spaceG)` with N = binding; GLSL `layout(binding = N)`
//! (desktop GLSL 4.30, one file per entry point, since a GLSL compute shader has exactly
//! one); MSL buffer indices as naga's defaults assign them (`fake_missing_bindings`: the
//! binding number, one argument buffer slot per binding).

use crate::{GpuError, Shader};

/// One translated file: name (e.g. `mrt.spv`, `mrt.project.glsl`) and bytes.
#[derive(Debug, Clone)]
pub struct Exported {
    /// File name.
    pub name: String,
    /// Contents.
    pub bytes: Vec<u8>,
}

fn err(name: &str, e: impl std::fmt::Display) -> GpuError {
    GpuError::Shader { name: name.into(), message: e.to_string() }
}

/// Parses and validates a shader (every naga check on).
pub fn validate(s: &Shader) -> Result<(naga::Module, naga::valid::ModuleInfo), GpuError> {
    let module = naga::front::wgsl::parse_str(s.source).map_err(|e| err(s.name, e.emit_to_string(s.source)))?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .map_err(|e| err(s.name, e.emit_to_string(s.source)))?;
    Ok((module, info))
}

/// The SPIR-V words of a shader (all entry points, Vulkan 1.0 SPIR-V 1.0 semantics as naga
/// writes them by default).
pub fn spirv(s: &Shader) -> Result<Vec<u32>, GpuError> {
    let (module, info) = validate(s)?;
    naga::back::spv::write_vec(&module, &info, &naga::back::spv::Options::default(), None).map_err(|e| err(s.name, e))
}

/// Every translation of `s`: `.wgsl`, `.spv`, `.hlsl` (shader model 5.1, all entry points),
/// `.msl`, and one `.<entry>.glsl` per entry point.
pub fn translate(s: &Shader) -> Result<Vec<Exported>, GpuError> {
    let (module, info) = validate(s)?;
    let mut out = vec![Exported { name: format!("{}.wgsl", s.name), bytes: s.source.as_bytes().to_vec() }];
    let words = spirv(s)?;
    out.push(Exported { name: format!("{}.spv", s.name), bytes: bytemuck::cast_slice(&words).to_vec() });

    let mut hlsl = String::new();
    let ho = naga::back::hlsl::Options::default();
    let hp = naga::back::hlsl::PipelineOptions::default();
    naga::back::hlsl::Writer::new(&mut hlsl, &ho, &hp).write(&module, &info, None).map_err(|e| err(s.name, e))?;
    out.push(Exported { name: format!("{}.hlsl", s.name), bytes: hlsl.into_bytes() });

    let mo = naga::back::msl::Options::default();
    let mp = naga::back::msl::PipelineOptions::default();
    let (msl, _) = naga::back::msl::write_string(&module, &info, &mo, &mp).map_err(|e| err(s.name, e))?;
    out.push(Exported { name: format!("{}.msl", s.name), bytes: msl.into_bytes() });

    let mut go = naga::back::glsl::Options { version: naga::back::glsl::Version::Desktop(430), ..Default::default() };
    for (_, var) in module.global_variables.iter() {
        if let Some(rb) = &var.binding {
            let b = u8::try_from(rb.binding).map_err(|_| err(s.name, "binding beyond 255"))?;
            go.binding_map.insert(*rb, b);
        }
    }
    for e in s.entry_points {
        let gp = naga::back::glsl::PipelineOptions {
            shader_stage: naga::ShaderStage::Compute,
            entry_point: (*e).to_string(),
            multiview: None,
        };
        let mut glsl = String::new();
        let mut w = naga::back::glsl::Writer::new(
            &mut glsl,
            &module,
            &info,
            &go,
            &gp,
            naga::proc::BoundsCheckPolicies::default(),
        )
        .map_err(|e| err(s.name, e))?;
        w.write().map_err(|e| err(s.name, e))?;
        out.push(Exported { name: format!("{}.{e}.glsl", s.name), bytes: glsl.into_bytes() });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SHADERS;

    #[test]
    fn every_shader_validates_and_translates_to_every_target() {
        for s in SHADERS {
            let files = translate(s).unwrap();
            let names: Vec<&str> = files.iter().map(|f| f.name.as_str()).collect();
            assert_eq!(names.len(), 4 + s.entry_points.len(), "{names:?}");
            // SPIR-V magic number, little-endian words
            assert_eq!(&files[1].bytes[..4], &0x0723_0203u32.to_le_bytes());
            for e in s.entry_points {
                let hlsl = std::str::from_utf8(&files[2].bytes).unwrap();
                assert!(hlsl.contains(&format!("void {e}(")), "{e} missing from the HLSL");
                let msl = std::str::from_utf8(&files[3].bytes).unwrap();
                assert!(msl.contains(&format!("kernel void {e}(")), "{e} missing from the MSL");
            }
            let glsl = std::str::from_utf8(&files[4].bytes).unwrap();
            assert!(glsl.starts_with("#version 430"), "{}", &glsl[..40.min(glsl.len())]);
            assert!(glsl.contains("layout(std430, binding = 1)") || glsl.contains("binding = 1"), "bindings kept");
        }
    }
}
