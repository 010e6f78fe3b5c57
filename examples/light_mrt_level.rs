//! Lighting an MRT level with the runtime alone (what an engine ports, MRT thesis §3.6.3):
//! load an `MRTD` dictionary and an `MRTL` level, place every texel in the world
//! ([`MrtRuntime::texel_world`]), compute direct light from a point light there, and evaluate
//! multi-bounce indirect light, vector irradiance for a normal-mapped (tilted) normal and the
//! volume probes at the block centres.
//!
//! ```sh
//! cargo run --release -- bake bake-configs/demo.toml    # writes out/demo/{dictionary.mrtd,level.mrtl}
//! cargo run --release --example light_mrt_level [DICT.mrtd LEVEL.mrtl]
//! ```
//!
//! The direct light here is the point light's unshadowed irradiance on the walls of the block
//! that holds it (exact there: a block is a convex box) and zero elsewhere; an engine computes
//! `l_d` with its own shadowed lights at the same texel positions and normals.

#![allow(clippy::print_stdout)] // an example prints its results

use penumbra_asset::AssetFile;
use penumbra_runtime::mrt::{MrtDictionary, MrtLevel, MrtRuntime};
use penumbra_runtime::mrt_vec::{TexelWorld, ohlsh_irradiance};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dict_path = args.first().map_or("out/demo/dictionary.mrtd", String::as_str);
    let level_path = args.get(1).map_or("out/demo/level.mrtl", String::as_str);
    let (df, lf) = (AssetFile::open(dict_path)?, AssetFile::open(level_path)?);
    let (da, la) = (df.asset(), lf.asset());
    let dict = MrtDictionary::from_asset(&da)?;
    let level = MrtLevel::from_asset(&la, &dict)?;
    let mut rt = MrtRuntime::new(dict, level);
    let n = rt.texel_count();
    let mut world = vec![TexelWorld::default(); n];
    rt.texel_world(&mut world).ok_or("the level has no block_xform or the dictionary no texel positions")?;

    // a point light of intensity 1 at the centre of block 0
    let light = rt.level().xform.map_or([0.5; 3], |x| [x[0], x[1], x[2]]);
    let offsets = rt.offsets().to_vec();
    let mut l_d = vec![0.0f32; n];
    for (t, w) in world.iter().enumerate().take(offsets[1]) {
        let d: [f32; 3] = core::array::from_fn(|k| light[k] - w.position[k]);
        let d2 = d.iter().map(|x| x * x).sum::<f32>();
        let cos = (d[0] * w.normal[0] + d[1] * w.normal[1] + d[2] * w.normal[2]) / d2.sqrt();
        l_d[t] = cos.max(0.0) / d2;
    }

    // indirect light: 4 bounces off walls of albedo 0.5 (relative to the dictionary's baked albedo)
    let albedo_scale = 0.5 / baked_albedo(&da);
    let mut indirect = vec![0.0f32; n];
    rt.multi_bounce(&l_d, &mut indirect, 4, albedo_scale);
    println!("{} blocks, {n} texels; light at {light:?}", rt.level().shapes.len());
    println!("{:>6} {:>14} {:>14}", "block", "mean direct", "mean indirect");
    for b in 0..offsets.len() - 1 {
        let r = offsets[b]..offsets[b + 1];
        let m = |v: &[f32]| v[r.clone()].iter().sum::<f32>() / r.len() as f32;
        println!("{b:>6} {:>14.5} {:>14.5}", m(&l_d), m(&indirect));
    }

    // one bounce again for the vector and probe values (they follow the last evaluation)
    let mut one = vec![0.0f32; n];
    rt.indirect(&l_d, &mut one, true);
    let mut vec4 = vec![[0.0f32; 4]; n];
    rt.vector_coefficients(&mut vec4);
    // a normal-mapped floor texel of block 1 (or 0): the normal tilted 40° toward the face's u
    let b = 1.min(offsets.len() - 2);
    let t = (offsets[b]..offsets[b + 1]).find(|&t| world[t].normal[1] > 0.5).unwrap_or(offsets[b]);
    let (s, c) = 40f32.to_radians().sin_cos();
    let w = &world[t];
    let tilted_world: [f32; 3] = core::array::from_fn(|k| s * w.u[k] + c * w.normal[k]);
    println!(
        "texel {t} at {:?}: one-bounce irradiance {:.5} (scalar), {:.5} at the normal and {:.5} tilted 40° toward u {:?} (vector)",
        w.position,
        one[t] * albedo_scale,
        ohlsh_irradiance(&vec4[t], [0.0, 0.0, 1.0]) * albedo_scale,
        ohlsh_irradiance(&vec4[t], [s, 0.0, c]) * albedo_scale,
        tilted_world,
    );

    // probes: irradiance at each block's centre facing up and down (a dynamic object's shading)
    let mut sh = Vec::new();
    for x in 0..offsets.len() - 1 {
        if rt.probe_sh(x, &mut sh) == 0 {
            continue;
        }
        let up = rt.probe_irradiance(x, &sh, [0.5; 3], [0.0, 1.0, 0.0]) * albedo_scale;
        let down = rt.probe_irradiance(x, &sh, [0.5; 3], [0.0, -1.0, 0.0]) * albedo_scale;
        println!("block {x} centre: probe irradiance up {up:.5}, down {down:.5}");
    }
    Ok(())
}

/// `params.albedo` of the dictionary's `meta` (1 when absent).
fn baked_albedo(a: &penumbra_asset::Asset<'_>) -> f32 {
    let meta: serde_json::Value = serde_json::from_str(a.meta_json()).unwrap_or_default();
    meta["params"]["albedo"].as_f64().unwrap_or(1.0) as f32
}
