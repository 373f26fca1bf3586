//! A fixed workload for profiling the moving-frame steppers (wall time here, instruction counts
//! under `valgrind --tool=callgrind`, which are repeatable on a loaded machine):
//!
//! ```text
//! cargo run --release --example profile_newton -- crank-pin 0.1     # Simeon's slider-crank, clearance at the crank pin
//! cargo run --release --example profile_newton -- ideal 0.1         # the same with ideal pins
//! cargo run --release --example profile_newton -- slider-pin 0.1    # the clearance at the slider pin instead
//! cargo run --release --example profile_newton -- four-bar 0.05     # the four-bar, clearance at the rocker pin
//! cargo run --release --example profile_newton -- spin-newton 0.02  # spinning beam in a bearing, Newton stepper
//! cargo run --release --example profile_newton -- spin-rate 0.02    # the same on the constant-rate stepper
//! ```
//!
//! Every case steps at dt = 1e-5 s and records nothing but the joint extremes
//! (`FLEXCLEAR_RECORD=default`: the default recording of Python's `simulate`, joint histories
//! and every node's displacements at every step; `FLEXCLEAR_WARM=1`: timed on a second run, the
//! first one's memory reused). The slider-crank
//! runs with the scene's defaults of `flexclear.scenes.slider_crank(clearance_at="crank_pin")`
//! (8 elements, 26 unknowns, geometric terms on, implicit contact iterated to `iter_tol` 1e-10);
//! the four-bar with those of `flexclear.scenes.four_bar(clearance_at="rocker_pin")`.

use std::time::Instant;

use flexclear::contact::Coupling;
use flexclear::integrator::newton::{simulate_constant_rate, simulate_mechanism};
use flexclear::record::{LinkChannels, RecordSpec};
use flexclear::scenes::{spinning_beam_in_a_bearing, FlexibleFourBar, FlexibleSliderCrank, FourBarPin, SliderCrankPin};
use flexclear::Settings;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let case = args.get(1).map_or("crank-pin", |s| s.as_str());
    let t_end: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.1);
    let mut s = Settings::new(t_end, 1e-5);
    s.record = RecordSpec {
        histories: false,
        links: LinkChannels::NONE,
        ..RecordSpec::default()
    };
    if std::env::var("FLEXCLEAR_RECORD").as_deref() == Ok("default") {
        // what Python's `simulate` keeps by default: joint histories and every node
        s.record = RecordSpec::default();
    }
    s.coupling = Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    };
    if let Some(age) = std::env::var("FLEXCLEAR_JACOBIAN_AGE")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        s.newton.jacobian_age = age;
    }
    let mech = match case {
        "crank-pin" => FlexibleSliderCrank {
            clearance_at: Some(SliderCrankPin::CrankPin),
            ..Default::default()
        }
        .build()
        .expect("slider-crank scene"),
        "slider-pin" => FlexibleSliderCrank {
            clearance_at: Some(SliderCrankPin::SliderPin),
            ..Default::default()
        }
        .build()
        .expect("slider-crank scene"),
        "ideal" => FlexibleSliderCrank {
            clearance_at: None,
            ..Default::default()
        }
        .build()
        .expect("slider-crank scene"),
        "four-bar" => FlexibleFourBar {
            clearance_at: Some(FourBarPin::RockerPin),
            ..Default::default()
        }
        .build()
        .expect("four-bar scene"),
        "spin-newton" | "spin-rate" => spinning_beam_in_a_bearing(),
        other => panic!("unknown case {other:?}: crank-pin, slider-pin, ideal, four-bar, spin-newton or spin-rate"),
    };
    // FLEXCLEAR_WARM=1: a first run untimed (the process's memory then holds the histories'
    // pages: the timed run sees no first-touch page faults)
    let warm = std::env::var("FLEXCLEAR_WARM").as_deref() == Ok("1");
    let run = || {
        if case == "spin-rate" {
            simulate_constant_rate(&mech, &s, &mut |_| true)
        } else {
            simulate_mechanism(&mech, &s, &mut |_| true)
        }
        .expect("run")
    };
    if warm {
        drop(run());
    }
    let t0 = Instant::now();
    let out = run();
    let el = t0.elapsed().as_secs_f64();
    let st = &out.stats;
    let (force, impacts) = out
        .record
        .extremes
        .first()
        .map_or((0.0, 0), |x| (x.max_force, x.impacts));
    println!(
        "{case}: {} steps, {:.3} us/step, stepper {}, {} unknowns, half-bandwidth {}, factorizations {}, iterations {}, woodbury steps {}, max force {:.6e} N, impacts {}",
        st.steps,
        el / st.steps as f64 * 1e6,
        st.stepper,
        st.unknowns,
        st.bandwidth,
        st.factorizations,
        st.iterations,
        st.woodbury_steps,
        force,
        impacts
    );
}
