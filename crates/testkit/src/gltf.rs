//! Minimal glTF 2.0 binary (GLB) writer for tests: one node and one mesh whose primitives are
//! the given parts, each with its own material (`baseColorFactor`) or none.

/// One primitive: positions, triangles and the material's `baseColorFactor` (`None`: no
/// material).
#[derive(Debug, Clone, Copy)]
pub struct Part<'a> {
    /// Vertex positions.
    pub positions: &'a [[f32; 3]],
    /// Triangles (indices into `positions`).
    pub triangles: &'a [[u32; 3]],
    /// `baseColorFactor` of the part's material, or no material.
    pub base_color: Option<[f32; 4]>,
}

/// The GLB bytes of a scene with one node holding a mesh of `parts`.
pub fn glb(parts: &[Part<'_>]) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut prims, mut materials) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for p in parts {
        let off = bin.len();
        bin.extend(p.positions.iter().flatten().flat_map(|x| x.to_le_bytes()));
        let plen = bin.len() - off;
        let ioff = bin.len();
        bin.extend(p.triangles.iter().flatten().flat_map(|x| x.to_le_bytes()));
        let ilen = bin.len() - ioff;
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for v in p.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let a = accessors.len();
        views.push(format!(r#"{{"buffer":0,"byteOffset":{off},"byteLength":{plen}}}"#));
        views.push(format!(r#"{{"buffer":0,"byteOffset":{ioff},"byteLength":{ilen}}}"#));
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5126,"count":{},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            a,
            p.positions.len(),
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2]
        ));
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5125,"count":{},"type":"SCALAR"}}"#,
            a + 1,
            3 * p.triangles.len()
        ));
        let mat = match p.base_color {
            Some(c) => {
                materials.push(format!(
                    r#"{{"pbrMetallicRoughness":{{"baseColorFactor":[{},{},{},{}]}}}}"#,
                    c[0], c[1], c[2], c[3]
                ));
                format!(r#","material":{}"#, materials.len() - 1)
            }
            None => String::new(),
        };
        prims.push(format!(r#"{{"attributes":{{"POSITION":{a}}},"indices":{}{mat}}}"#, a + 1));
    }
    let mats = if materials.is_empty() { String::new() } else { format!(r#","materials":[{}]"#, materials.join(",")) };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"name":"parts"}}],"meshes":[{{"primitives":[{}]}}]{mats},"buffers":[{{"byteLength":{}}}],"bufferViews":[{}],"accessors":[{}]}}"#,
        prims.join(","),
        bin.len(),
        views.join(","),
        accessors.join(",")
    );
    container(json, bin)
}

/// A GLB container (glTF 2.0 §4.4): header, the JSON chunk padded with spaces and the BIN
/// chunk padded with zeros to 4 bytes.
fn container(json: String, mut bin: Vec<u8>) -> Vec<u8> {
    let mut j = json.into_bytes();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&j);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}

/// A closed axis-aligned box `[lo, hi]` (8 vertices, 12 outward-facing triangles).
pub fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let v: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect();
    let t = vec![
        [0, 2, 3],
        [0, 3, 1], // -z
        [4, 5, 7],
        [4, 7, 6], // +z
        [0, 1, 5],
        [0, 5, 4], // -y
        [2, 6, 7],
        [2, 7, 3], // +y
        [0, 4, 6],
        [0, 6, 2], // -x
        [1, 3, 7],
        [1, 7, 5], // +x
    ];
    (v, t)
}

/// The GLB bytes of one textured primitive: `part` (its `base_color` the material's factor,
/// white when `None`) with `TEXCOORD_0` = `uv` (one per position) and a `baseColorTexture`
/// whose image is `image` (encoded bytes, stored in a buffer view with `mime`) and whose
/// sampler wraps with `wrap` (glTF enum: 10497 repeat, 33071 clamp, 33648 mirror).
pub fn glb_textured(part: Part<'_>, uv: &[[f32; 2]], image: &[u8], mime: &str, wrap: u32) -> Vec<u8> {
    assert_eq!(uv.len(), part.positions.len());
    let mut bin: Vec<u8> = Vec::new();
    let mut push = |bytes: Vec<u8>| {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let off = bin.len();
        bin.extend(bytes);
        (off, bin.len() - off)
    };
    let (po, pl) = push(part.positions.iter().flatten().flat_map(|x| x.to_le_bytes()).collect());
    let (io, il) = push(part.triangles.iter().flatten().flat_map(|x| x.to_le_bytes()).collect());
    let (uo, ul) = push(uv.iter().flatten().flat_map(|x| x.to_le_bytes()).collect());
    let (mo, ml) = push(image.to_vec());
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for v in part.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let c = part.base_color.unwrap_or([1.0; 4]);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"name":"textured"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":2}},"indices":1,"material":0}}]}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[{},{},{},{}],"baseColorTexture":{{"index":0}}}}}}],
"textures":[{{"source":0,"sampler":0}}],"samplers":[{{"wrapS":{wrap},"wrapT":{wrap}}}],
"images":[{{"bufferView":3,"mimeType":"{mime}","name":"albedo"}}],
"buffers":[{{"byteLength":{}}}],
"bufferViews":[{{"buffer":0,"byteOffset":{po},"byteLength":{pl}}},{{"buffer":0,"byteOffset":{io},"byteLength":{il}}},
{{"buffer":0,"byteOffset":{uo},"byteLength":{ul}}},{{"buffer":0,"byteOffset":{mo},"byteLength":{ml}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}},
{{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}},
{{"bufferView":2,"componentType":5126,"count":{},"type":"VEC2"}}]}}"#,
        c[0],
        c[1],
        c[2],
        c[3],
        bin.len(),
        part.positions.len(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        3 * part.triangles.len(),
        uv.len()
    );
    container(json, bin)
}

/// Positions, triangles and per-vertex UVs.
pub type UvMesh = (Vec<[f32; 3]>, Vec<[u32; 3]>, Vec<[f32; 2]>);

/// A closed cube `[lo, hi]` with four vertices per face (24 vertices, 12 outward triangles)
/// and each face's UVs spanning `[0, 1]²`.
pub fn uv_cube(lo: [f32; 3], hi: [f32; 3]) -> UvMesh {
    let (v8, t12) = cuboid(lo, hi);
    let (mut v, mut t, mut uv) = (Vec::new(), Vec::new(), Vec::new());
    // each face is two triangles [a, b, c], [a, c, d] of cuboid()'s list
    for f in 0..6 {
        let (p, q) = (t12[2 * f], t12[2 * f + 1]);
        let quad = [p[0], p[1], p[2], q[2]];
        let base = v.len() as u32;
        for (k, &i) in quad.iter().enumerate() {
            v.push(v8[i as usize]);
            uv.push([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]][k]);
        }
        t.push([base, base + 1, base + 2]);
        t.push([base, base + 2, base + 3]);
    }
    (v, t, uv)
}
