//! The culled, certified visibility against plain ray casting on the real scanned bunny
//! (open: holes in its base, so the interior certificates need their caps). Skips when
//! `../shared/data` is absent.
#![allow(clippy::print_stderr)]

use penumbra_fiv::*;
use penumbra_geometry::{CubeMap, load_mesh};

#[test]
fn culling_and_certificates_change_no_bit_on_the_scanned_bunny() {
    let Some(data) = penumbra_testkit::shared_data("the scanned-bunny FIV test") else { return };
    for name in ["stanford-bunny.obj", "bunny_closed_3k.obj"] {
        let (scene, _) = load_mesh(data.join("meshes").join(name)).unwrap();
        let occ = Occluder::new(scene.mesh).unwrap();
        let light = Lighting::new(CubeMap::constant(32, [1.0; 3]));
        let fast = FivTracer::new(&occ, &light, true);
        let plain = FivTracer::new(&occ, &light, false);
        // samples from the ball's surface outward, off the grid of any default layout
        let l = ShellLayout { azimuth: 7, polar: 6, radial: 4, r_min: 1.0, r_max: 2.7, up: UpAxis::Y };
        let (mut traced, mut certified) = (0, 0);
        for i in 0..l.azimuth {
            for j in 0..l.polar {
                for k in 0..l.radial {
                    let p = l.position(&occ.frame(), i, j, k);
                    let (a, sa) = fast.fiv(p);
                    let (b, sb) = plain.fiv(p);
                    assert_eq!(a, b, "{name}: sample {i},{j},{k}");
                    assert_eq!(sa.rays_hit, sb.rays_hit);
                    traced += sa.rays_traced;
                    certified += sa.rays_certified;
                }
            }
        }
        assert!(certified > 0 && traced > 0, "{name}: {certified} certified, {traced} traced");
    }
}
