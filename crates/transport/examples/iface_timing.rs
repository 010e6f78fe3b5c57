//! Stage timings of the interface bake at the thesis settings (profiling aid):
//! `cargo run --release -p penumbra-transport --example iface_timing`.
#![allow(clippy::print_stderr)]
use penumbra_math::progress::{NoProgress, Progress};
use penumbra_transport::dict::{DictParams, bake};
use penumbra_transport::interface::{ShapeInput, bake_interfaces};
use penumbra_transport::shape::DictionaryKind;
use std::sync::Mutex;
use std::time::Instant;

struct Ticks(Mutex<(Instant, Vec<(u64, f64)>)>);
impl Progress for Ticks {
    fn update(&self, _stage: &str, done: u64, _total: u64) {
        let mut g = self.0.lock().unwrap();
        let t = g.0.elapsed().as_secs_f64();
        g.1.push((done, t));
    }
}

fn main() {
    let mut p = DictParams::new(DictionaryKind::Cube2d);
    p.interfaces = false;
    let d = bake(&p, &NoProgress).unwrap();
    let inputs: Vec<ShapeInput<'_>> =
        d.shapes.iter().map(|s| ShapeInput { texels: &s.texels, reduced: &s.reduced }).collect();
    let sm: Vec<Vec<f64>> = d.shapes.iter().map(|s| s.reduced.sigma_m.clone()).collect();
    let ticks = Ticks(Mutex::new((Instant::now(), Vec::new())));
    let s = Instant::now();
    let ib = bake_interfaces(&inputs, &sm, p.albedo, p.face_res, &p.interface, p.seed, &ticks).unwrap();
    eprintln!("total {:.2} s\n{:?}", s.elapsed().as_secs_f64(), ib.metrics);
    let mut last = 0.0;
    for (k, t) in &ticks.0.lock().unwrap().1 {
        eprintln!("step {k:>2}: +{:.2} s", t - last);
        last = *t;
    }
}
