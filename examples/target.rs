use flexclear::scenes::SliderYoke;
use flexclear::{simulate, Settings};
use std::time::Instant;
fn main() {
    let model = SliderYoke {
        clearance: 1e-5,
        ..Default::default()
    }
    .build()
    .unwrap();
    let mut s = Settings::new(1.0, 1e-6);
    s.record.histories = false;
    let t = Instant::now();
    let out = simulate(&model, &s, &mut |_| true).unwrap();
    println!(
        "{:.4}s per 1e5 steps; maxpen {:e}",
        t.elapsed().as_secs_f64() / 10.0,
        out.record.extremes[0].max_penetration
    );
}
