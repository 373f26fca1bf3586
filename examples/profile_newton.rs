//! A fixed workload for profiling the moving-frame steppers (wall time here, instruction counts
//! under `valgrind --tool=callgrind`, which are repeatable on a loaded machine):
//!
//! ```text
//! cargo run --release --example profile_newton -- crank-pin 0.1     # Simeon's slider-crank, clearance at the crank pin
//! cargo run --release --example profile_newton -- spin-newton 0.02  # spinning beam in a bearing, Newton stepper
//! cargo run --release --example profile_newton -- spin-rate 0.02    # the same on the constant-rate stepper
//! ```
//!
//! Every case steps at dt = 1e-5 s and records nothing but the joint extremes. The slider-crank
//! runs with the scene's defaults of `flexclear.scenes.slider_crank(clearance_at="crank_pin")`
//! (8 elements, 26 unknowns, geometric terms on, implicit contact iterated to `iter_tol` 1e-10).

use std::sync::Arc;
use std::time::Instant;

use flexclear::contact::{Coupling, DampingLaw, SpringDamper};
use flexclear::integrator::newton::{simulate_constant_rate, simulate_mechanism};
use flexclear::kinematics::{FrameKinematics, RotatingFrame, Rotation};
use flexclear::model::mechanism::{Clearance, Endpoint, Link, Mechanism, Support, Terms};
use flexclear::model::section::BeamSection;
use flexclear::model::Motion;
use flexclear::record::{LinkChannels, RecordSpec};
use flexclear::scenes::{FlexibleSliderCrank, SliderCrankPin};
use flexclear::Settings;

fn spinning_beam() -> Mechanism {
    let spin = Rotation::Constant {
        angle0: 0.3,
        rate: 30.0,
    };
    let hub = |r: Rotation| -> Arc<dyn FrameKinematics> {
        Arc::new(RotatingFrame::new(Motion::Fixed { position: [0.0, 0.0] }, r).unwrap())
    };
    let (a, n) = (0.008f64, 6);
    let v0 = (0..3 * (n + 1))
        .map(|k| {
            if k % 3 == 1 {
                0.2 * (k / 3) as f64 / n as f64
            } else {
                0.0
            }
        })
        .collect();
    Mechanism {
        links: vec![Link {
            name: "beam".into(),
            section: BeamSection {
                length: 0.3,
                elements: n,
                youngs_modulus: 2e11,
                density: 7870.0,
                damping: 2e6,
                area: a * a,
                inertia: a.powi(4) / 12.0,
            },
            frame: hub(spin.clone()),
            terms: Terms {
                geometric: Some(false),
                ..Terms::default()
            },
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: Some(v0),
        }],
        supports: vec![Support {
            link: 0,
            node: 0,
            fixed: [true; 3],
        }],
        joints: vec![Clearance {
            name: "tip".into(),
            journal: Endpoint::Node { link: 0, node: n },
            bearing: Endpoint::Body {
                frame: hub(spin),
                point: [0.3, 0.0],
                name: "hub".into(),
            },
            clearance: 1e-4,
            law: Arc::new(SpringDamper {
                stiffness: 1e7,
                damping: 20.0,
                damping_law: DampingLaw::Viscous,
                no_tension: false,
            }),
        }],
        ..Default::default()
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let case = args.get(1).map_or("crank-pin", |s| s.as_str());
    let t_end: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.1);
    let mut s = Settings::new(t_end, 1e-5);
    s.record = RecordSpec {
        histories: false,
        links: LinkChannels {
            displacements: false,
            axial_force: false,
            midspan: false,
            energy: false,
        },
        ..RecordSpec::default()
    };
    s.coupling = Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    };
    let mech = match case {
        "crank-pin" => FlexibleSliderCrank {
            clearance_at: Some(SliderCrankPin::CrankPin),
            ..Default::default()
        }
        .build()
        .expect("slider-crank scene"),
        "spin-newton" | "spin-rate" => spinning_beam(),
        other => panic!("unknown case {other:?}: crank-pin, spin-newton or spin-rate"),
    };
    let t0 = Instant::now();
    let out = if case == "spin-rate" {
        simulate_constant_rate(&mech, &s, &mut |_| true)
    } else {
        simulate_mechanism(&mech, &s, &mut |_| true)
    }
    .expect("run");
    let el = t0.elapsed().as_secs_f64();
    let st = &out.stats;
    println!(
        "{case}: {} steps, {:.3} us/step, stepper {}, factorizations {}, iterations {}, woodbury steps {}, max force {:.6e} N, impacts {}",
        st.steps,
        el / st.steps as f64 * 1e6,
        st.stepper,
        st.factorizations,
        st.iterations,
        st.woodbury_steps,
        out.record.extremes[0].max_force,
        out.record.extremes[0].impacts
    );
}
