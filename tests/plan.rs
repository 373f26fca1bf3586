//! The stepper is chosen from the model: the rules of `flexclear::plan` one by one, and the
//! slider-yoke written as a moving-frame mechanism runs on the constant stepper with the same
//! numbers, bit for bit, as its translating-frame model.

use std::sync::Arc;

use flexclear::kinematics::{RotatingFrame, Rotation};
use flexclear::model::mechanism::{Endpoint, Mechanism, NodalLoad, Pin, Terms};
use flexclear::model::Motion;
use flexclear::plan::{simulate as simulate_any, Plan, StepperKind};
use flexclear::run::simulate as simulate_translating;
use flexclear::scenes::SliderYoke;
use flexclear::Settings;

fn yoke() -> Mechanism {
    SliderYoke {
        clearance: 1e-4,
        ..Default::default()
    }
    .build()
    .unwrap()
}

fn kind(m: &Mechanism, s: &Settings) -> (StepperKind, String) {
    let p = Plan::compile(m, s).unwrap();
    (p.kind, p.reason)
}

#[test]
fn the_slider_yoke_as_a_mechanism_runs_on_the_constant_stepper_bitwise() {
    let mech = yoke();
    // the constant stepper's input the plan derives: the slider at angle 0 on the yoke's motion,
    // the bearing on the yoke body at the slider's node 0
    let model = mech.to_translating().unwrap();
    assert_eq!((model.links.len(), model.bodies.len(), model.joints.len()), (1, 1, 1));
    assert_eq!(model.links[0].angle, 0.0);
    assert_eq!(model.links[0].motion, model.bodies[0].motion);

    let mut s = Settings::new(0.05, 1e-5);
    s.record.links.displacements = true;
    s.record.links.axial_force = true;
    s.record.links.midspan = true;
    assert_eq!(kind(&mech, &s).0, StepperKind::Constant);
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let b = simulate_translating(&model, &Settings::new(0.05, 1e-5), &mut |_| true).unwrap();
    assert_eq!(a.stats.stepper, "constant");
    assert_eq!(a.record.extremes, b.record.extremes);
    assert_eq!(a.record.joints, b.record.joints);
    assert_eq!(a.record.time, b.record.time);
    assert_eq!(a.state, b.state);
    // link channels in the Newton stepper's layout, from the node histories
    let l = &a.record.links[0];
    let (rows, nn) = (a.record.time.len(), model.links[0].section.elements + 1);
    assert_eq!(
        (l.frame.len(), l.displacements.len(), l.midspan.len()),
        (rows, rows * 3 * nn, rows)
    );
    assert_eq!(l.axial_force.len(), rows * (nn - 1));
    // the last row's displacements are the final state (link 0's DOFs come first)
    assert_eq!(&l.displacements[(rows - 1) * 3 * nn..], &a.state[0][..3 * nn]);
}

#[test]
fn the_newton_stepper_runs_what_the_constant_one_cannot_each_rule() {
    let s = Settings::new(0.01, 1e-5);
    assert_eq!(kind(&yoke(), &s), (StepperKind::Constant, String::new()));

    let mut m = yoke();
    m.gravity = [0.0, -9.81];
    assert_eq!(kind(&m, &s).1, "the mechanism has gravity");

    let mut m = yoke();
    m.loads.push(NodalLoad {
        link: 0,
        node: 1,
        force: [0.0, 1.0],
        moment: 0.0,
    });
    assert_eq!(kind(&m, &s).1, "the mechanism has a nodal load");

    let mut m = yoke();
    let body = match &m.joints[0].bearing {
        Endpoint::Body { frame, .. } => frame.clone(),
        _ => unreachable!("the yoke's bearing is a body"),
    };
    m.pins.push(Pin {
        name: "p".into(),
        a: Endpoint::Node { link: 0, node: 12 },
        b: Endpoint::Body {
            frame: body,
            point: [0.269, 0.0],
            name: "yoke".into(),
        },
    });
    assert_eq!(kind(&m, &s).1, "the mechanism has a pin");

    let mut m = yoke();
    m.links[0].frame = Arc::new(RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: Rotation::Constant { angle0: 0.0, rate: 1.0 },
    });
    assert!(kind(&m, &s).1.contains("rotates"));

    let mut m = yoke();
    m.links[0].terms = Terms {
        geometric: Some(true),
        ..Terms::default()
    };
    assert!(kind(&m, &s).1.contains("geometric"));

    let mut m = yoke();
    m.links[0].terms.inertia_load = Some(false);
    assert!(kind(&m, &s).1.contains("inertia load"));

    let mut e = s.clone();
    e.record.links.energy = true;
    assert_eq!(kind(&yoke(), &e).1, "the run records link energies");

    // and the Newton stepper then runs it
    let mut m = yoke();
    m.gravity = [0.0, -9.81];
    let out = simulate_any(&m, &s, &mut |_| true).unwrap();
    assert_eq!(out.stats.stepper, "newton");

    // asked for: Newton on the yoke; the constant stepper refused where it cannot run, saying why
    let mut n = s.clone();
    n.stepper = Some(StepperKind::Newton);
    assert_eq!(
        simulate_any(&yoke(), &n, &mut |_| true).unwrap().stats.stepper,
        "newton"
    );
    n.stepper = Some(StepperKind::Constant);
    let err = simulate_any(&m, &n, &mut |_| true).unwrap_err().error.to_string();
    assert!(err.contains("stepper") && err.contains("gravity"), "{err}");
}
