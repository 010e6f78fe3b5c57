//! Shading a few receivers under sphere proxies with the runtime alone (what an engine ports):
//! load an `SHTB` tables asset and an `SPHR` sphere set, light them with a simple sky, and print
//! the shadowed irradiance on a line of ground points — with all leaves, and with the
//! hierarchy cut and ratio vectors of a receiver cluster (SHEXP §6.3).
//!
//! ```sh
//! cargo run --release -- bake bake-configs/demo.toml      # writes out/demo/{tables.shtb,character.sphr}
//! cargo run --release --example shade_with_proxies [TABLES.shtb SPHERES.sphr]
//! ```

#![allow(clippy::print_stdout)] // an example prints its results

use penumbra_asset::AssetFile;
use penumbra_runtime::shadows::{CutBlocker, ShadowEvaluator, ShadowOptions, Sphere};
use penumbra_runtime::{NodeRef, ShTables, SphereSet, SphereTree};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tables_path = args.first().map_or("out/demo/tables.shtb", String::as_str);
    let spheres_path = args.get(1).map_or("out/demo/character.sphr", String::as_str);
    let tables_file = AssetFile::open(tables_path)?;
    let sphere_file = AssetFile::open(spheres_path)?;
    let (ta, sa) = (tables_file.asset(), sphere_file.asset());
    let tables = ShTables::from_asset(&ta)?;
    let set = SphereSet::from_asset(&sa)?;
    let order = tables.order();

    // a sky as RGB SH coefficients: radiance 1 everywhere (y₀₀ coefficient √4π), brighter
    // toward the zenith +Y (y₁₋₁ ∝ −y in the SH convention, so a negative coefficient)
    let mut sky = vec![[0.0f32; 3]; order * order];
    let y00 = (4.0 * std::f32::consts::PI).sqrt();
    sky[0] = [y00, y00, y00 * 1.1];
    sky[1] = [-1.5, -1.5, -1.6];
    let ev = ShadowEvaluator::new(&tables, &sky, ShadowOptions::default());

    let leaves: Vec<Sphere> = (0..set.len()).map(|i| set.leaf(i)).collect();
    let lowest = leaves.iter().map(|s| s.center[1] - s.radius).fold(f32::INFINITY, f32::min);
    let up = [0.0f32, 1.0, 0.0];
    println!("{} spheres ({} hierarchy levels), SH order {order}", set.len(), set.depth());
    println!("{:>8} {:>12} {:>12} {:>12}", "x", "unshadowed", "all leaves", "hierarchy");

    // one receiver cluster: the line of points, bounded by a sphere around its middle
    let points: Vec<[f32; 3]> = (0..9).map(|k| [-0.8 + 0.2 * k as f32, lowest, 0.3]).collect();
    let (mut stack, mut cut, mut blockers) = (Vec::<NodeRef>::new(), Vec::<NodeRef>::new(), Vec::<CutBlocker>::new());
    let center = points[4];
    set.cut(center, 0.8, 25f32.to_radians().sin(), &mut stack, &mut cut);
    ev.cluster_blockers(&set, &cut, center, up, &mut blockers);
    for p in &points {
        let open = ev.unshadowed(up)[0];
        let direct = ev.irradiance(*p, up, &leaves)[0];
        let cut_result = ev.irradiance_blockers(*p, up, &blockers)[0];
        println!("{:>8.2} {open:>12.4} {direct:>12.4} {cut_result:>12.4}", p[0]);
    }
    println!("the cluster's cut holds {} blockers instead of {} leaves", blockers.len(), set.len());
    Ok(())
}
