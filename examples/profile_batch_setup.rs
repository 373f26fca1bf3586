//! The per-sample cost of a batch's setup: `N` crank-pin slider-crank samples (clearances 0.1 mm
//! apart by 1 um) of `T_END` s at dt 1e-5 s (default 64 samples of 1e-4 s: 10 steps, so that
//! planning, validation and preparing the runs dominate), extremes recorded only, one thread.
//!
//!     cargo run --release --example profile_batch_setup [N] [T_END]
//!
//! Prints the wall time per sample (us); under callgrind, the instructions of each part.
use std::sync::atomic::{AtomicBool, AtomicUsize};
use std::time::Instant;

use flexclear::batch::{run_batch, BatchOptions};
use flexclear::record::{LinkChannels, RecordSpec};
use flexclear::scenes::{FlexibleSliderCrank, SliderCrankPin};
use flexclear::Settings;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(64);
    let t_end: f64 = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(1e-4);
    let mut s = Settings::new(t_end, 1e-5);
    s.record = RecordSpec {
        histories: false,
        links: LinkChannels::NONE,
        ..RecordSpec::default()
    };
    let samples: Vec<_> = (0..n)
        .map(|i| {
            let m = FlexibleSliderCrank {
                clearance_at: Some(SliderCrankPin::CrankPin),
                clearance: 1e-4 + 1e-6 * i as f64,
                ..Default::default()
            }
            .build()
            .expect("scene");
            (m, s.clone())
        })
        .collect();
    let opts = BatchOptions {
        threads: 1,
        lanes: 1,
        ..Default::default()
    };
    let t0 = Instant::now();
    let (out, _) = run_batch(&samples, &opts, &AtomicBool::new(false), &AtomicUsize::new(0)).unwrap();
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "{n} samples: {:.1} us/sample ({} ok)",
        dt / n as f64 * 1e6,
        out.iter().filter(|o| matches!(o.result, Some(Ok(_)))).count()
    );
}
