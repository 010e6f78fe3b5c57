//! Property tests: random assets round-trip; random and mutated bytes never make the loader
//! (or any accessor) panic, and unresealed damage is always detected.

mod common;

use common::exercise;
use penumbra_asset::format::{MAGIC, reseal_checksums};
use penumbra_asset::{Asset, AssetBuilder, DType, Kind, OwnedAsset};
use proptest::prelude::*;
use proptest::sample::Index;

/// One section to write: (element type, dims, raw little-endian bytes or JSON text, critical).
#[derive(Debug, Clone)]
struct Spec {
    dtype: DType,
    dims: Vec<usize>,
    data: Vec<u8>,
    critical: bool,
}

fn spec() -> impl Strategy<Value = Spec> {
    let numeric =
        (prop::sample::select(DType::ALL[..7].to_vec()), prop::collection::vec(0usize..5, 1..=6), any::<bool>())
            .prop_flat_map(|(dtype, dims, critical)| {
                let n: usize = dims.iter().product::<usize>() * dtype.size();
                prop::collection::vec(any::<u8>(), n).prop_map(move |data| Spec {
                    dtype,
                    dims: dims.clone(),
                    data,
                    critical,
                })
            });
    let json = ("\\PC{0,40}", any::<bool>()).prop_map(|(text, critical)| Spec {
        dtype: DType::Json,
        dims: vec![text.len()],
        data: text.into_bytes(),
        critical,
    });
    prop_oneof![4 => numeric, 1 => json]
}

fn build(meta: &str, specs: &[Spec], suffixes: &[String]) -> AssetBuilder {
    let mut b = AssetBuilder::new(Kind::FIVT);
    b.add_json("meta", meta).unwrap();
    for (i, (s, suffix)) in specs.iter().zip(suffixes.iter().cycle()).enumerate() {
        let name = format!("s{i}{suffix}");
        b.add_raw(&name, s.dtype, &s.dims, &s.data).unwrap();
        b.set_critical(&name, s.critical).unwrap();
    }
    b
}

fn asset_bytes() -> impl Strategy<Value = Vec<u8>> {
    ("\\PC{0,60}", prop::collection::vec(spec(), 0..6), prop::collection::vec("[A-Za-z0-9_.-]{0,20}", 1..4))
        .prop_map(|(meta, specs, suffixes)| build(&meta, &specs, &suffixes).to_bytes().unwrap())
}

#[derive(Debug, Clone)]
enum Mutation {
    Set(Index, u8),
    Xor(Index, u8),
    Truncate(Index),
    Insert(Index, Vec<u8>),
    Remove(Index, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<Index>(), any::<u8>()).prop_map(|(i, v)| Mutation::Set(i, v)),
        4 => (any::<Index>(), 1u8..).prop_map(|(i, v)| Mutation::Xor(i, v)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
        1 => (any::<Index>(), prop::collection::vec(any::<u8>(), 1..70)).prop_map(|(i, v)| Mutation::Insert(i, v)),
        1 => (any::<Index>(), 1usize..70).prop_map(|(i, n)| Mutation::Remove(i, n)),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        return;
    }
    match m {
        Mutation::Set(i, v) => {
            let i = i.index(bytes.len());
            bytes[i] = *v;
        }
        Mutation::Xor(i, v) => {
            let i = i.index(bytes.len());
            bytes[i] ^= *v;
        }
        Mutation::Truncate(i) => bytes.truncate(i.index(bytes.len())),
        Mutation::Insert(i, v) => {
            let i = i.index(bytes.len() + 1);
            bytes.splice(i..i, v.iter().copied());
        }
        Mutation::Remove(i, n) => {
            let i = i.index(bytes.len());
            let end = (i + n).min(bytes.len());
            bytes.drain(i..end);
        }
    }
}

/// Runs every entry point on `bytes`; returns whether `parse` accepted them.
fn load_everything(bytes: &[u8]) -> bool {
    let verified = Asset::parse(bytes);
    if let Ok(a) = &verified {
        exercise(a);
    } else if let Err(e) = &verified {
        let _ = e.to_string();
    }
    match Asset::parse_unverified(bytes) {
        Ok(a) => {
            exercise(&a);
            if verified.is_err() {
                // Only checksum damage separates the two.
                assert!(!a.all_checksums_ok());
            }
        }
        Err(e) => assert!(verified.is_err(), "parse_unverified refused what parse accepted: {e}"),
    }
    if let Ok(o) = OwnedAsset::parse(bytes) {
        exercise(&o.asset());
    }
    verified.is_ok()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_assets_round_trip(
        meta in "\\PC{0,60}",
        specs in prop::collection::vec(spec(), 0..8),
        suffixes in prop::collection::vec("[A-Za-z0-9_.-]{0,20}", 1..4),
    ) {
        let bytes = build(&meta, &specs, &suffixes).to_bytes().unwrap();
        let owned = OwnedAsset::parse(&bytes).unwrap();
        let a = owned.asset();
        prop_assert_eq!(a.meta_json(), meta.as_str());
        prop_assert_eq!(a.sections().len(), specs.len() + 1);
        for (s, info) in specs.iter().zip(&a.sections()[1..]) {
            let sec = a.section(info.name()).unwrap();
            prop_assert_eq!(info.dtype(), s.dtype);
            prop_assert_eq!(info.dims(), &s.dims[..]);
            prop_assert_eq!(info.is_critical(), s.critical);
            prop_assert_eq!(sec.bytes(), &s.data[..]);
            prop_assert_eq!(info.offset() % 64, 0);
            if s.dtype.is_numeric() {
                prop_assert_eq!(sec.to_f64_vec().unwrap().len(), info.element_count());
            } else {
                prop_assert_eq!(sec.as_json().unwrap().as_bytes(), &s.data[..]);
            }
            // Aligned memory: the view of the declared type always works.
            let view_ok = match s.dtype {
                DType::U8 => sec.as_u8().is_ok(),
                DType::U16 => sec.as_u16().is_ok(),
                DType::U32 => sec.as_u32().is_ok(),
                DType::I32 => sec.as_i32().is_ok(),
                DType::F16 => sec.as_f16_bits().is_ok(),
                DType::F32 => sec.as_f32().is_ok(),
                DType::F64 => sec.as_f64().is_ok(),
                DType::Json => sec.as_json().is_ok(),
            };
            prop_assert!(view_ok);
        }
        exercise(&a);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
        prop_assert!(!load_everything(&bytes), "random bytes are not an asset");
    }

    /// Random bytes behind a plausible header, with every checksum recomputed, so the
    /// structural checks (not the CRCs) are what reject them.
    #[test]
    fn arbitrary_bytes_behind_a_valid_header_never_panic(
        mut bytes in prop::collection::vec(any::<u8>(), 64..3000),
        count in 0u32..12,
    ) {
        bytes[..8].copy_from_slice(&MAGIC);
        bytes[8..12].copy_from_slice(&[1, 0, 0, 0]);
        bytes[12..16].copy_from_slice(b"SHTB");
        bytes[16..20].copy_from_slice(&count.to_le_bytes());
        bytes[20..24].fill(0);
        bytes[24..32].copy_from_slice(&64u64.to_le_bytes());
        let len = bytes.len() as u64;
        bytes[32..40].copy_from_slice(&len.to_le_bytes());
        bytes[44..60].fill(0);
        reseal_checksums(&mut bytes);
        load_everything(&bytes);
    }

}

proptest! {
    // Cheap cases (tens of µs each): run many of the one that explores the most.
    #![proptest_config(ProptestConfig::with_cases(4096))]

    #[test]
    fn mutated_assets_never_panic_and_damage_is_detected(
        original in asset_bytes(),
        mutations in prop::collection::vec(mutation(), 1..5),
        reseal in any::<bool>(),
    ) {
        let mut bytes = original.clone();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        if reseal {
            reseal_checksums(&mut bytes);
        }
        let accepted = load_everything(&bytes);
        if !reseal && bytes != original {
            // Every byte is covered by a CRC, the magic/version checks, the zero-padding rule or
            // the size check (a CRC-32C collision has probability 2^-32).
            prop_assert!(!accepted, "damaged asset accepted after {:?}", mutations);
        }
        if bytes == original {
            prop_assert!(accepted);
        }
    }
}
