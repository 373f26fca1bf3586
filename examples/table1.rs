use flexclear::contact::Coupling;
use flexclear::scenes::SliderYoke;
use flexclear::{simulate, Settings};
use std::time::Instant;
fn main() {
    for (name, coupling) in [("modified", Coupling::default()), ("force", Coupling::Force)] {
        for r in [0.0, 0.001, 0.01, 0.1] {
            let sc = SliderYoke {
                clearance: r * 0.01,
                ..Default::default()
            };
            let model = sc.build().unwrap();
            let mut s = Settings::new(5.0, 1e-5);
            s.coupling = coupling;
            s.record.histories = false;
            s.record.start = 20.0 / 6.0;
            let t = Instant::now();
            let out = simulate(&model, &s, &mut |_| true).unwrap();
            let e = out.record.extremes[0];
            println!(
                "{name} r={r}: {:.2} dB  impacts {}  {:.3}s  stats {:?}",
                20.0 * (e.max_penetration / 0.01).log10(),
                e.impacts,
                t.elapsed().as_secs_f64(),
                (out.stats.woodbury_steps, out.stats.factorizations)
            );
        }
    }
    let sc = SliderYoke {
        clearance: 1e-5,
        ..Default::default()
    };
    let model = sc.build().unwrap();
    let mut s = Settings::new(0.1, 1e-6);
    s.record.histories = false;
    let t = Instant::now();
    let out = simulate(&model, &s, &mut |_| true).unwrap();
    println!(
        "target: {:.4}s maxpen {:e}",
        t.elapsed().as_secs_f64(),
        out.record.extremes[0].max_penetration
    );
    println!("freqs {:?}", flexclear::modes::natural_frequencies(&model, 3).unwrap());
}
