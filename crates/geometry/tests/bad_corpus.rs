//! Every file under ../shared/data/bad either loads (valid but unusual) or returns an error;
//! none panics. Mesh formats go to `load_mesh`, images to `load_env_map`; companion files
//! (.bin, .mtl, validator reports, SOURCES.md) are only read through the files that use them.

#![allow(clippy::print_stderr)] // tests may print a summary

mod common;

use std::collections::BTreeMap;
use std::path::PathBuf;

use penumbra_geometry::{load_env_map, load_mesh};

#[derive(Debug)]
enum Outcome {
    Loaded(String),
    Error(String),
}

#[test]
fn bad_corpus_never_panics() {
    let Some(data) = common::shared_data("bad_corpus_never_panics") else {
        return;
    };
    let root = data.join("bad");
    let mut files: Vec<PathBuf> = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                files.push(p);
            }
        }
    }
    files.sort();
    let mut outcomes: BTreeMap<String, Outcome> = BTreeMap::new();
    let mut panics = Vec::new();
    for f in &files {
        let name = f.strip_prefix(&root).unwrap().display().to_string();
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let result = match ext.as_str() {
            "bin" | "mtl" | "json" | "md" => continue,
            "exr" | "hdr" => std::panic::catch_unwind(|| {
                load_env_map(f)
                    .map(|(m, r)| format!("{}x{} env map, {} warnings", m.width(), m.height(), r.warnings.len()))
                    .map_err(|e| e.to_string())
            }),
            _ => std::panic::catch_unwind(|| {
                load_mesh(f)
                    .map(|(s, r)| {
                        format!(
                            "{} triangles; dropped {} zero-area, {} repeated-index, {} duplicate; {} skipped elements",
                            s.mesh.indices.len(),
                            r.clean.dropped_zero_area,
                            r.clean.dropped_repeated_index,
                            r.clean.dropped_duplicate,
                            r.skipped_elements
                        )
                    })
                    .map_err(|e| e.to_string())
            }),
        };
        match result {
            Err(_) => panics.push(name),
            Ok(Ok(s)) => {
                outcomes.insert(name, Outcome::Loaded(s));
            }
            Ok(Err(e)) => {
                // errors name the file
                assert!(e.contains(&*f.file_name().unwrap().to_string_lossy()), "{e}");
                outcomes.insert(name, Outcome::Error(e));
            }
        }
    }
    let loaded = outcomes.values().filter(|o| matches!(o, Outcome::Loaded(_))).count();
    eprintln!(
        "bad corpus: {} files, {loaded} loaded, {} errors, {} panics",
        outcomes.len() + panics.len(),
        outcomes.len() - loaded,
        panics.len()
    );
    for (name, o) in &outcomes {
        match o {
            Outcome::Loaded(s) => eprintln!("  LOAD  {name}: {s}"),
            Outcome::Error(e) => {
                let prefix = format!("{}/", root.display());
                eprintln!("  ERROR {}", e.replace(&prefix, ""));
            }
        }
    }
    assert!(panics.is_empty(), "panicked on {panics:?}");
    assert_eq!(outcomes.len(), 60, "number of inputs walked");

    let err = |n: &str| match &outcomes[n] {
        Outcome::Error(e) => e.clone(),
        Outcome::Loaded(s) => panic!("{n} loaded ({s}) but should fail"),
    };
    let ok = |n: &str| match &outcomes[n] {
        Outcome::Loaded(s) => s.clone(),
        Outcome::Error(e) => panic!("{n} failed: {e}"),
    };
    // specific expectations
    assert!(err("exr/BrightRingsNanInf.exr").contains("non-finite texel"));
    for d in ["exr/damaged_7f11ece681f1.exr", "exr/damaged_7f6a78657cbf.exr", "exr/damaged_7fca10855564.exr"] {
        assert!(err(d).contains("cannot decode"), "{d}");
    }
    for u in ["ply/empty_0bytes.ply", "stl/soup.stl", "off/OutOfMemory.off", "stl/shared_edge.STL"] {
        assert!(err(u).contains("unsupported mesh format"), "{u}");
    }
    assert!(err("obj/test-nan.obj").contains("non-finite vertex coordinate"));
    assert!(err("obj/malformed.obj").contains("out of range"));
    assert!(err("obj/issue-140-zero-face-idx.obj").contains("index 0 is invalid"));
    assert!(err("obj/invalid-relative-vertex-index.obj").contains("relative face index -4"));
    assert!(err("obj/empty_0bytes.obj").contains("no triangles"));
    assert!(err("obj/obj_points.obj").contains("no triangles"));
    assert!(ok("obj/wallhole.obj").contains("dropped 11 zero-area"));
    assert!(ok("obj/notenoughindices.obj").starts_with("1 triangles"));
    assert!(ok("obj/malformed2.obj").contains("1 skipped elements"));
    assert!(ok("gltf/Fox_legacy_validation_errors.glb").starts_with("576 triangles"));
    assert!(ok("gltf/assimp/BoxBadNormals.glb").starts_with("12 triangles"));
    assert!(err("gltf/assimp/BoxWithInfinites.glb").contains("non-finite"));
    assert!(err("gltf/assimp/IndexOutOfRange.gltf").contains("out of range"));
    assert!(err("gltf/assimp/AllIndicesOutOfRange.gltf").contains("out of range"));
    assert!(err("gltf/assimp/RecursiveNodes.gltf").contains("cycle"));
    assert!(err("gltf/validator_glb/empty_file.glb").contains("empty"));
    assert!(err("gltf/validator_glb/length_mismatch.glb").contains("declares 49 bytes"));
    assert!(err("gltf/validator_glb/truncated_chunk_header.glb").contains("truncated"));
    assert!(err("gltf/validator_glb/invalid_version.glb").contains("version"));
    assert!(err("gltf/validator_mesh/accessor_unequal_count.gltf").contains("COLOR_0 has 4 elements"));
    assert!(err("gltf/validator_mesh/indices_invalid_format.gltf").contains("indices accessor"));
    assert!(err("gltf/validator_mesh/unresolved_positions.gltf").contains("does not exist"));
}
