//! Same inputs, same bytes, for any thread count (DESIGN §4).

use penumbra_math::progress::NoProgress;
use penumbra_transport::asset::to_asset;
use penumbra_transport::dict::{DictParams, bake};
use penumbra_transport::shape::DictionaryKind;

fn bytes_with(threads: usize, p: &DictParams) -> Vec<u8> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let b = bake(p, &NoProgress).unwrap();
        to_asset(&b, Some("k")).unwrap().to_bytes().unwrap()
    })
}

#[test]
fn cube2d_bytes_do_not_depend_on_the_thread_count() {
    let mut p = DictParams::new(DictionaryKind::Cube2d);
    p.face_res = 4;
    p.rays = 256;
    p.k_d = 16;
    p.k_b = 8;
    p.vector_rays = 64;
    p.probe_rays = 64;
    p.volume_res = 2;
    p.reference_rays = 64;
    p.test_lights = 2;
    // interfaces at a small lightfield resolution (the thesis's is exercised by make bench)
    p.interface.grid = penumbra_transport::lightfield::LfGrid { spatial: 4, dir: 6, sub: 2 };
    p.interface.k_rlf = 24;
    p.interface.k_r = 8;
    p.interface.response_rays = 64;
    let one = bytes_with(1, &p);
    let two = bytes_with(2, &p);
    let three = bytes_with(3, &p);
    assert_eq!(one, two);
    assert_eq!(one, three);
    let a = penumbra_asset::Asset::parse(&one).unwrap();
    assert!(a.section("iface.u_r").is_some() && a.section("cross.r_b2rlf.pz").is_some());
    // and the seed matters
    p.seed = 1;
    assert_ne!(one, bytes_with(2, &p));
}
