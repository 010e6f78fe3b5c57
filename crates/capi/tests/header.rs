//! `include/penumbra.h` is what cbindgen generates from this crate (the staleness check CI
//! runs as part of `cargo test`). `PENUMBRA_BLESS=1` rewrites the committed header.

use std::path::PathBuf;

#[test]
fn committed_header_is_what_cbindgen_generates() {
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(&crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header")
        .write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = crate_dir.join("../../include/penumbra.h");
    if std::env::var_os("PENUMBRA_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/penumbra.h is stale: run `PENUMBRA_BLESS=1 cargo test -p penumbra-capi --test header`"
    );
    // The handles and entry points C code relies on are in it.
    for name in ["pn_abi_version", "pn_shadow_irradiance_batch", "pn_fiv_scene_irradiance", "pn_mrt_indirect"] {
        assert!(generated.contains(name), "{name} missing from the header");
    }
}
