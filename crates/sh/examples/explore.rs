use penumbra_sh::tables::*;
use std::sync::Mutex;
struct P(Mutex<std::time::Instant>);
impl Progress for P {
    fn update(&self, s: &str, d: u64, _t: u64) {
        let mut g = self.0.lock().unwrap();
        println!("  [{d}] {s} (prev stage {:?})", g.elapsed());
        *g = std::time::Instant::now();
    }
}
fn main() {
    for n in [4usize, 8] {
        let b = bake(&TablesParams::new(n), &P(Mutex::new(std::time::Instant::now()))).unwrap();
        let errs: Vec<f64> = b.local_light_fit.iter().map(|f| f.2).collect();
        for i in [0usize, 8, 16, 31] {
            println!(
                "  theta_i={i}: {:?}",
                (0..64).step_by(8).map(|j| format!("{:.3}", errs[i * 64 + j])).collect::<Vec<_>>()
            );
        }
    }
}
