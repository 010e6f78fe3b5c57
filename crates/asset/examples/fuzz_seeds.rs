//! Writes a few small valid assets into a directory, as the seed corpus of the loader fuzzer
//! (`fuzz/run.sh` runs it when the corpus is empty): mutations of valid files reach far deeper
//! into the loader than random bytes, which almost never get past the magic and the checksums.
//!
//! Usage: `cargo run -p penumbra-asset --example fuzz_seeds -- DIR`

use penumbra_asset::{AssetBuilder, BuildError, Kind, write_file_atomic};
use std::error::Error;
use std::path::PathBuf;

pub fn seeds() -> Result<Vec<(&'static str, AssetBuilder)>, BuildError> {
    let mut minimal = AssetBuilder::new(Kind::SPHR);
    minimal.add_json("meta", "{}")?;

    let mut every_type = AssetBuilder::new(Kind::SHTB);
    every_type
        .add_json("meta", r#"{"tool":"fuzz seeds","kind_version":1}"#)?
        .add_u8("u8", &[3], &[1, 2, 3])?
        .add_u16("u16", &[2, 2], &[1, 2, 3, u16::MAX])?
        .add_u32("u32", &[1], &[u32::MAX])?
        .add_i32("i32", &[2], &[-5, 5])?
        .add_f16("f16", &[3], &[0.5, -2.0, 1.0e-6])?
        .add_f32("f32", &[2, 3], &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0])?
        .add_f64("f64", &[1, 1, 2], &[core::f64::consts::PI, -1.0])?
        .add_json("notes", r#"{"a":[1,2]}"#)?;

    let mut empty_and_critical = AssetBuilder::new(Kind::MRTL);
    empty_and_critical
        .add_json("meta", "{}")?
        .add_f32("none", &[0, 4], &[])?
        .add_u8("flagged", &[2], &[7, 8])?
        .set_critical("flagged", true)?;

    let mut many = AssetBuilder::new(Kind::DRTO);
    many.add_json("meta", "{}")?;
    for i in 0..40u16 {
        let data: Vec<u16> = (0..i).collect();
        many.add_u16(&format!("s{i}"), &[usize::from(i)], &data)?;
    }
    Ok(vec![
        ("minimal", minimal),
        ("every_type", every_type),
        ("empty_and_critical", empty_and_critical),
        ("many", many),
    ])
}

fn main() -> Result<(), Box<dyn Error>> {
    let dir = PathBuf::from(std::env::args_os().nth(1).ok_or("usage: fuzz_seeds DIR")?);
    std::fs::create_dir_all(&dir)?;
    for (name, builder) in seeds()? {
        write_file_atomic(dir.join(format!("seed_{name}.asset")), &builder.to_bytes()?)?;
    }
    Ok(())
}
