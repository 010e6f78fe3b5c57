use penumbra_config::{ConfigErrorKind, parse_str};
use std::path::Path;

fn err(src: &str) -> penumbra_config::ConfigError {
    parse_str(src, Path::new("scene.toml")).expect_err("config should be rejected")
}

#[test]
fn valid_config_parses() {
    let c = parse_str("output_dir = \"out\"\n[tables]\norder = 4\ntheta_samples = 128\n", Path::new("a.toml")).unwrap();
    let t = c.tables.unwrap();
    assert_eq!(t.order, 4);
    assert_eq!(t.theta_samples, Some(128));
    assert_eq!(t.output_name(), "tables.shtb");
}

#[test]
fn unknown_key_named_with_path_and_line() {
    let e = err("output_dir = \"out\"\n\n[tables]\norder = 4\nordr = 5\n");
    assert_eq!(e.kind, ConfigErrorKind::Field);
    assert_eq!(e.key, "tables.ordr");
    assert_eq!(e.line, Some(5));
    let msg = e.to_string();
    assert!(msg.starts_with("scene.toml:5:1: `tables.ordr`: unknown field `ordr`"), "{msg}");
}

#[test]
fn unknown_top_level_key() {
    let e = err("output_dir = \"out\"\nspheres_typo = 1\n[tables]\norder = 4\n");
    assert_eq!(e.key, "spheres_typo");
    assert_eq!(e.line, Some(2));
}

#[test]
fn wrong_type_names_key_and_line() {
    let e = err("output_dir = \"out\"\n[tables]\norder = \"four\"\n");
    assert_eq!(e.kind, ConfigErrorKind::Field);
    assert_eq!(e.key, "tables.order");
    assert_eq!(e.line, Some(3));
}

#[test]
fn out_of_range_value_names_key_line_and_range() {
    let e = err("output_dir = \"out\"\n[tables]\n\norder = 11\n");
    assert_eq!(e.kind, ConfigErrorKind::Invalid);
    assert_eq!(e.key, "tables.order");
    assert_eq!(e.line, Some(4));
    assert!(e.to_string().contains("allowed: 2..=8"), "{e}");
}

#[test]
fn missing_required_key() {
    let e = err("[tables]\norder = 4\n");
    assert!(e.to_string().contains("output_dir"), "{e}");
}

#[test]
fn syntax_error_has_line() {
    let e = err("output_dir = \"out\"\n[tables\norder = 4\n");
    assert_eq!(e.kind, ConfigErrorKind::Syntax);
    assert_eq!(e.line, Some(2));
}

#[test]
fn output_must_be_a_plain_name() {
    let e = err("output_dir = \"out\"\n[tables]\norder = 4\noutput = \"../x.shtb\"\n");
    assert_eq!(e.key, "tables.output");
    assert_eq!(e.line, Some(4));
}

#[test]
fn empty_config_names_missing_stage() {
    let e = err("output_dir = \"out\"\n");
    assert_eq!(e.key, "stages");
    assert!(e.message.contains("no stage"), "{}", e.message);
}

#[test]
fn schema_denies_unknown_fields() {
    let s = penumbra_config::schema_json();
    let v: serde_json::Value = serde_json::from_str(&s).unwrap();
    assert_eq!(v["additionalProperties"], serde_json::Value::Bool(false));
    assert!(s.contains("\"order\""));
}

#[test]
fn spheres_entries_are_validated_with_their_index() {
    let ok = penumbra_config::parse_str(
        "output_dir = \"out\"\n[[spheres]]\nmesh = \"a.obj\"\ncount = 8\n[[spheres]]\nmesh = \"b.glb\"\ntarget_error = 0.5\nmethod = \"octree\"\n",
        std::path::Path::new("c.toml"),
    )
    .unwrap();
    assert_eq!(ok.spheres.len(), 2);
    assert_eq!(ok.spheres[1].output_name(), "b.sphr");
    assert_eq!(ok.spheres[1].method, Some(penumbra_config::SphereMethod::Octree));
    let e = err(
        "output_dir = \"out\"\n[[spheres]]\nmesh = \"a.obj\"\ncount = 8\n[[spheres]]\nmesh = \"b.obj\"\ncount = 0\n",
    );
    assert_eq!(e.key, "spheres[1].count");
    assert_eq!(e.line, Some(7));
    let e = err("output_dir = \"out\"\n[[spheres]]\nmesh = \"a.obj\"\n");
    assert_eq!(e.key, "spheres[0]");
    assert!(e.message.contains("exactly one of"), "{}", e.message);
    let e = err(
        "output_dir = \"out\"\n[[spheres]]\nmesh = \"a.obj\"\ncount = 8\n[[spheres]]\nmesh = \"x/a.obj\"\ncount = 4\n",
    );
    assert_eq!(e.key, "spheres[1].output");
    let e = err("output_dir = \"out\"\n[[spheres]]\nmesh = \"a.obj\"\ncount = 8\nmethod = \"voxel\"\n");
    assert_eq!(e.key, "spheres[0].method");
    assert_eq!(e.line, Some(5));
}

#[test]
fn fiv_stages_parse_with_defaults() {
    let c = parse_str(
        "output_dir = \"out\"\n[[fiv]]\nmesh = \"meshes/bunny.obj\"\nenv = \"builtin:area-lights\"\n\n[[fiv]]\nmesh = \"builtin:torus\"\nenv = \"sky.exr\"\nsamples = [64, 33, 30]\nup = \"z\"\nenv_rotate = \"z180\"\nhalf = true\n",
        Path::new("a.toml"),
    )
    .unwrap();
    assert!(c.has_stage());
    assert_eq!(c.fiv.len(), 2);
    assert_eq!(c.fiv[0].output_name(), "bunny.fivt");
    assert_eq!(c.fiv[1].output_name(), "torus.fivt");
    assert_eq!(c.fiv[1].samples, Some([64, 33, 30]));
    assert_eq!(c.fiv[1].up, Some(penumbra_config::UpAxis::Z));
    assert_eq!(c.fiv[1].env_rotate, Some(penumbra_config::EnvRotate::Z180));
}

#[test]
fn fiv_stage_errors_name_the_array_entry_and_line() {
    let body = "output_dir = \"out\"\n[[fiv]]\nmesh = \"builtin:torus\"\nenv = \"e.exr\"\n\n[[fiv]]\nmesh = \"builtin:sphere\"\nenv = \"e.exr\"\nsamples = [32, 1, 15]\n";
    let e = err(body);
    assert_eq!(e.kind, ConfigErrorKind::Invalid);
    assert_eq!(e.key, "fiv[1].samples");
    assert_eq!(e.line, Some(9));
    assert!(e.to_string().contains("allowed: 2..=2049"), "{e}");
    let e = err("output_dir = \"out\"\n[[fiv]]\nmesh = \"a.obj\"\nenv = \"e.exr\"\nr_min = 2.0\nr_max = 1.5\n");
    assert_eq!(e.key, "fiv[0].r_max");
    assert_eq!(e.line, Some(6));
    let e = err(
        "output_dir = \"out\"\n[[fiv]]\nmesh = \"a.obj\"\nenv = \"e.exr\"\n[[fiv]]\nmesh = \"b/a.obj\"\nenv = \"e.exr\"\n",
    );
    assert_eq!(e.key, "fiv[1].output");
    assert!(e.to_string().contains("another stage"), "{e}");
    let e = err("output_dir = \"out\"\n[[fiv]]\nmesh = \"a.obj\"\nenv = \"e.exr\"\nsampels = [1, 2, 3]\n");
    assert_eq!(e.key, "fiv[0].sampels");
    assert_eq!(e.line, Some(5));
}

#[test]
fn node_selection_takes_one_pattern_or_a_list_and_refuses_empty_ones() {
    let c = parse_str(
        "output_dir = \"out\"\n[[spheres]]\nmesh = \"s.glb\"\ncount = 8\nnode = [\"SheenChair*\", \"Plane\"]\n\
         [[fiv]]\nmesh = \"s.glb\"\nenv = \"e.exr\"\nnode = \"Crate?\"\n",
        Path::new("a.toml"),
    )
    .unwrap();
    assert_eq!(c.spheres[0].node.as_ref().unwrap().patterns(), ["SheenChair*", "Plane"]);
    assert_eq!(c.fiv[0].node.as_ref().unwrap().patterns(), ["Crate?"]);
    for (src, key) in [
        ("[[spheres]]\nmesh = \"s.glb\"\ncount = 8\nnode = []\n", "spheres[0].node"),
        ("[[spheres]]\nmesh = \"s.glb\"\ncount = 8\nnode = [\"\"]\n", "spheres[0].node"),
        ("[[fiv]]\nmesh = \"builtin:torus\"\nenv = \"e.exr\"\nnode = \"x\"\n", "fiv[0].node"),
    ] {
        let e = err(&format!("output_dir = \"out\"\n{src}"));
        assert!(e.to_string().contains(key), "{e}");
    }
}
