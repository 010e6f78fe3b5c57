//! The demo glTF level of `penumbra plan` (`bake-configs/assets/demo-level.gltf`): three rooms
//! of a corridor (two dead ends and a straight piece, 1 m cubes along +Z), clutter inside
//! them, a statue, a character and a lamp, with roles in node extras for some nodes and
//! none for others (the README's `penumbra plan` example adds `--role clutter='Prop_*'`).
//! One self-contained `.gltf` (the buffer is a base64 data URI).

/// A node: name, quads (four corners each), extras JSON, children.
struct DemoNode {
    name: &'static str,
    quads: Vec<[[f32; 3]; 4]>,
    extras: Option<&'static str>,
    children: Vec<usize>,
}

/// Room `[0, 1] × [0, 1] × [z0, z0 + 1]`: floor, ceiling and the side walls not in `open`.
fn room(z0: f32, open: &[&str]) -> Vec<[[f32; 3]; 4]> {
    let z1 = z0 + 1.0;
    let mut q = vec![
        [[0.0, 0.0, z0], [0.0, 0.0, z1], [1.0, 0.0, z1], [1.0, 0.0, z0]],
        [[0.0, 1.0, z0], [1.0, 1.0, z0], [1.0, 1.0, z1], [0.0, 1.0, z1]],
    ];
    let walls = [
        ("-x", [[0.0, 0.0, z0], [0.0, 1.0, z0], [0.0, 1.0, z1], [0.0, 0.0, z1]]),
        ("+x", [[1.0, 0.0, z0], [1.0, 0.0, z1], [1.0, 1.0, z1], [1.0, 1.0, z0]]),
        ("-z", [[0.0, 0.0, z0], [1.0, 0.0, z0], [1.0, 1.0, z0], [0.0, 1.0, z0]]),
        ("+z", [[0.0, 0.0, z1], [0.0, 1.0, z1], [1.0, 1.0, z1], [1.0, 0.0, z1]]),
    ];
    q.extend(walls.iter().filter(|(n, _)| !open.contains(n)).map(|(_, w)| *w));
    q
}

/// The six faces of the box `[lo, hi]`.
fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> Vec<[[f32; 3]; 4]> {
    let c = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]]
        .iter()
        .map(|f| f.map(c))
        .collect()
}

fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for ch in bytes.chunks(3) {
        let b = [ch[0], ch.get(1).copied().unwrap_or(0), ch.get(2).copied().unwrap_or(0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= ch.len() {
                s.push(T[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The `.gltf` text of the demo level.
pub fn demo_level_gltf() -> String {
    let role = |r| match r {
        "block" => Some(r#"{"penumbra": {"role": "block"}}"#),
        "clutter" => Some(r#"{"penumbra": {"role": "clutter"}}"#),
        "occluder" => Some(r#"{"penumbra": {"role": "occluder"}}"#),
        _ => Some(r#"{"penumbra": {"role": "character"}}"#),
    };
    let nodes = [
        DemoNode { name: "Room_A", quads: room(0.0, &["+z"]), extras: role("block"), children: vec![1] },
        DemoNode {
            name: "Crate",
            quads: cuboid([0.25, 0.0, 0.3], [0.5, 0.25, 0.55]),
            extras: role("clutter"),
            children: vec![],
        },
        DemoNode { name: "Room_B", quads: room(1.0, &["-z", "+z"]), extras: role("block"), children: vec![] },
        DemoNode {
            name: "Prop_Pillar",
            quads: cuboid([0.6, 0.0, 1.4], [0.75, 0.8, 1.55]),
            extras: None,
            children: vec![],
        },
        DemoNode { name: "Room_C", quads: room(2.0, &["-z"]), extras: role("block"), children: vec![] },
        DemoNode { name: "Prop_Box", quads: cuboid([0.4, 0.0, 2.5], [0.7, 0.15, 2.7]), extras: None, children: vec![] },
        DemoNode {
            name: "Statue",
            quads: cuboid([2.0, 0.0, 0.0], [2.4, 1.2, 0.4]),
            extras: role("occluder"),
            children: vec![],
        },
        DemoNode {
            name: "Hero",
            quads: cuboid([3.0, 0.0, 0.0], [3.4, 1.8, 0.3]),
            extras: role("character"),
            children: vec![],
        },
        DemoNode { name: "Lamp", quads: cuboid([4.0, 0.0, 0.0], [4.1, 2.0, 0.1]), extras: None, children: vec![] },
    ];
    let (mut bin, mut views, mut accessors, mut meshes, mut jnodes) = (Vec::new(), vec![], vec![], vec![], vec![]);
    let list = |v: &[f32]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(", ");
    for (i, n) in nodes.iter().enumerate() {
        let pos: Vec<[f32; 3]> = n.quads.iter().flatten().copied().collect();
        let idx: Vec<u32> = (0..n.quads.len() as u32)
            .flat_map(|q| [4 * q, 4 * q + 1, 4 * q + 2, 4 * q, 4 * q + 2, 4 * q + 3])
            .collect();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in &pos {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let off = bin.len();
        bin.extend(pos.iter().flatten().flat_map(|x| x.to_le_bytes()));
        views.push(format!(r#"{{"buffer": 0, "byteOffset": {off}, "byteLength": {}}}"#, pos.len() * 12));
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5126, "count": {}, "type": "VEC3", "min": [{}], "max": [{}]}}"#,
            views.len() - 1,
            pos.len(),
            list(&lo),
            list(&hi)
        ));
        let off = bin.len();
        bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
        views.push(format!(r#"{{"buffer": 0, "byteOffset": {off}, "byteLength": {}}}"#, idx.len() * 4));
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5125, "count": {}, "type": "SCALAR"}}"#,
            views.len() - 1,
            idx.len()
        ));
        meshes.push(format!(
            r#"{{"name": "{}", "primitives": [{{"attributes": {{"POSITION": {}}}, "indices": {}}}]}}"#,
            n.name,
            accessors.len() - 2,
            accessors.len() - 1
        ));
        let mut node = format!(r#"{{"name": "{}", "mesh": {i}"#, n.name);
        if let Some(e) = n.extras {
            node.push_str(&format!(r#", "extras": {e}"#));
        }
        if !n.children.is_empty() {
            node.push_str(&format!(r#", "children": {:?}"#, n.children));
        }
        node.push('}');
        jnodes.push(node);
    }
    let children: Vec<usize> = nodes.iter().flat_map(|n| n.children.iter().copied()).collect();
    let roots: Vec<usize> = (0..nodes.len()).filter(|i| !children.contains(i)).collect();
    let join = |v: &[String]| v.join(",\n    ");
    format!(
        "{{\n  \"asset\": {{\"version\": \"2.0\", \"generator\": \"penumbra demo level: `cargo run -p penumbra-geometry \
         --example demo_level`; do not edit\"}},\n  \"scene\": 0,\n  \"scenes\": [{{\"nodes\": {roots:?}}}],\n  \
         \"nodes\": [\n    {}\n  ],\n  \"meshes\": [\n    {}\n  ],\n  \"accessors\": [\n    {}\n  ],\n  \
         \"bufferViews\": [\n    {}\n  ],\n  \"buffers\": [{{\"byteLength\": {}, \"uri\": \"data:application/octet-stream;base64,{}\"}}]\n}}\n",
        join(&jnodes),
        join(&meshes),
        join(&accessors),
        join(&views),
        bin.len(),
        base64(&bin)
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn base64_matches_the_rfc_examples() {
        for (i, o) in [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foobar", "Zm9vYmFy")] {
            assert_eq!(super::base64(i.as_bytes()), o);
        }
    }

    #[test]
    fn the_demo_level_loads_with_its_nodes_and_extras() {
        let text = super::demo_level_gltf();
        let (scene, _) = crate::import::gltf::load_gltf_bytes(
            std::path::Path::new("demo-level.gltf"),
            text.as_bytes(),
            std::path::Path::new("."),
        )
        .unwrap();
        assert_eq!(scene.nodes.len(), 9);
        assert_eq!(scene.nodes[1].parent, Some(0));
        assert!(scene.nodes[0].extras.as_deref().is_some_and(|e| e.contains("block")));
        assert!(scene.nodes[3].extras.is_none());
    }
}
