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

    // the yoke with gravity: its frames translate at a fixed angle, no geometric term, so its
    // Jacobian is constant: the constant-rate stepper runs it
    let mut m = yoke();
    m.gravity = [0.0, -9.81];
    assert_eq!(kind(&m, &s).0, StepperKind::ConstantRate);
    let out = simulate_any(&m, &s, &mut |_| true).unwrap();
    assert_eq!(out.stats.stepper, "constant-rate");
    // and the Newton stepper runs what neither constant stepper can (geometric terms)
    let mut m = yoke();
    m.gravity = [0.0, -9.81];
    m.links[0].terms.geometric = Some(true);
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

fn rate_kind(m: &Mechanism, s: &Settings) -> (StepperKind, String) {
    let p = Plan::compile(m, s).unwrap();
    (p.kind, p.rate_reason)
}

fn spinning(rate: f64) -> Arc<RotatingFrame> {
    Arc::new(RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: Rotation::Constant { angle0: 0.0, rate },
    })
}

/// The yoke's link on a frame spinning at 50 rad/s about its origin, geometric terms off: its
/// journal (node 0) and the bearing body now turn at one rate.
fn spinning_yoke() -> Mechanism {
    let mut m = yoke();
    m.links[0].frame = spinning(50.0);
    m.links[0].terms.geometric = Some(false);
    if let Endpoint::Body { frame, .. } = &mut m.joints[0].bearing {
        *frame = spinning(50.0);
    }
    m
}

#[test]
fn the_constant_rate_stepper_runs_a_constant_jacobian_each_rule() {
    let s = Settings::new(0.01, 1e-5);
    // the rules of the constant stepper first: the yoke stays there
    assert_eq!(kind(&yoke(), &s).0, StepperKind::Constant);
    // a frame spinning at a constant rate, no geometric term: constant-rate
    let m = spinning_yoke();
    assert_eq!(rate_kind(&m, &s), (StepperKind::ConstantRate, String::new()));
    assert!(kind(&m, &s).1.contains("rotates"));
    // energies recorded: not the constant stepper, but constant-rate records them
    let mut e = s.clone();
    e.record.links.energy = true;
    assert_eq!(
        kind(&yoke(), &e),
        (StepperKind::ConstantRate, "the run records link energies".into())
    );

    // rule 1: a frame whose rate varies
    let mut m = spinning_yoke();
    m.links[0].frame = Arc::new(RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: Rotation::SpinUp {
            angle0: 0.0,
            final_rate: 50.0,
            ramp_time: 1.0,
        },
    });
    let (k, why) = rate_kind(&m, &s);
    assert_eq!(k, StepperKind::Newton);
    assert!(why.contains("varying rate"), "{why}");

    // rule 2: geometric terms (on by default in a rotating link)
    let mut m = spinning_yoke();
    m.links[0].terms.geometric = None;
    let (k, why) = rate_kind(&m, &s);
    assert_eq!(k, StepperKind::Newton);
    assert!(why.contains("geometric"), "{why}");

    // rule 3: a node pinned (global unknowns, turned by the link's angle) in a rotating link:
    // a second link on the same frame pinned to the first at their nodes 0
    let pinned = |mut m: Mechanism| {
        let mut arm = m.links[0].clone();
        arm.name = "arm".into();
        m.links.push(arm);
        m.pins.push(Pin {
            name: "p".into(),
            a: Endpoint::Node { link: 0, node: 0 },
            b: Endpoint::Node { link: 1, node: 0 },
        });
        m
    };
    let (k, why) = rate_kind(&pinned(spinning_yoke()), &s);
    assert_eq!(k, StepperKind::Newton);
    assert!(why.contains("pinned or on a slider"), "{why}");
    // ... which links at a fixed angle may have
    assert_eq!(
        rate_kind(&pinned(yoke()), &s),
        (StepperKind::ConstantRate, String::new())
    );

    // rule 4 (contact terms in the Jacobian): the two sides of a joint turning at different
    // rates: the spinning link's journal in a bearing on a second link at rest
    let mut m = spinning_yoke();
    let mut other = m.links[0].clone();
    other.name = "still".into();
    other.frame = Arc::new(RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: Rotation::Fixed { angle: 0.0 },
    });
    m.links.push(other);
    m.joints[0].bearing = Endpoint::Node { link: 1, node: 0 };
    let (k, why) = rate_kind(&m, &s);
    assert_eq!(k, StepperKind::Newton);
    assert!(why.contains("different rates"), "{why}");
    // with the force method the contact is not in the Jacobian: allowed
    let mut f = s.clone();
    f.coupling = flexclear::contact::Coupling::Force;
    assert_eq!(rate_kind(&m, &f), (StepperKind::ConstantRate, String::new()));

    // forced: constant-rate runs the yoke; refused where the Jacobian changes, saying why;
    // the constant stepper refused for the spinning yoke
    let mut c = s.clone();
    c.stepper = Some(StepperKind::ConstantRate);
    let out = simulate_any(&yoke(), &c, &mut |_| true).unwrap();
    assert_eq!(out.stats.stepper, "constant-rate");
    let mut m = spinning_yoke();
    m.links[0].terms.geometric = Some(true);
    let err = simulate_any(&m, &c, &mut |_| true).unwrap_err().error.to_string();
    assert!(err.contains("stepper") && err.contains("geometric"), "{err}");
    c.stepper = Some(StepperKind::Constant);
    let err = simulate_any(&spinning_yoke(), &c, &mut |_| true)
        .unwrap_err()
        .error
        .to_string();
    assert!(err.contains("stepper") && err.contains("rotates"), "{err}");
    c.stepper = Some(StepperKind::Newton);
    let out = simulate_any(&spinning_yoke(), &c, &mut |_| true).unwrap();
    assert_eq!(out.stats.stepper, "newton");
}

/// The yoke forced onto the constant-rate stepper gives the constant stepper's results to
/// rounding (two different factorizations of the same effective matrix: LDL^T of the
/// translating model, band LU of the moving-frame one), with one factorization of it (and one
/// of the mass matrix): displacement histories within 1e-10 of their scale.
#[test]
fn the_slider_yoke_on_the_constant_rate_stepper_matches_the_constant_one() {
    let mut s = Settings::new(0.02, 1e-5);
    s.record.links.displacements = true;
    let a = simulate_any(&yoke(), &s, &mut |_| true).unwrap();
    s.stepper = Some(StepperKind::ConstantRate);
    let b = simulate_any(&yoke(), &s, &mut |_| true).unwrap();
    assert_eq!((a.stats.stepper, b.stats.stepper), ("constant", "constant-rate"));
    assert_eq!(b.stats.factorizations, 2);
    let (x, y) = (&a.record.links[0].displacements, &b.record.links[0].displacements);
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let d = x.iter().zip(y).fold(0.0f64, |m, (p, q)| m.max((p - q).abs())) / scale;
    // measured 1.1e-11 (3 impacts in 0.02 s)
    assert!(d < 1e-10, "{d:e}");
    assert_eq!(a.record.extremes[0].impacts, b.record.extremes[0].impacts);
}

#[test]
fn adaptive_runs_of_a_translating_model_take_the_constant_stepper_with_cached_factors() {
    use flexclear::contact::Coupling;
    use flexclear::integrator::constant::Lockstep;
    use flexclear::run::Adaptive;
    let mech = yoke();
    let mut s = Settings::new(0.03, 3e-5);
    s.coupling = Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    };
    s.adaptive = Some(Adaptive::for_tolerance(0.01, mech.joints.iter().map(|j| j.clearance), s.dt, s.dt).unwrap());
    assert_eq!(kind(&mech, &s).0, StepperKind::Constant);
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let st = &a.stats;
    assert_eq!(st.stepper, "constant");
    assert!(st.adaptive_steps > st.steps && st.event_steps >= 1);
    // a step size that comes back costs no refactorization: far fewer factorizations than
    // steps, the cache's fills (7 slots and the one in use) plus the cuts' odd lengths (at most 6 regula-falsi substeps and
    // the rest of the interval per located or rejected step)
    assert!(st.factorizations * 10 < st.adaptive_steps, "{st:?}");
    assert!(
        st.factorizations <= 8 + 8 * (st.event_steps + st.rejected_steps),
        "{st:?}"
    );
    // the output stays on the grid
    assert_eq!(a.record.time.len() as u64, st.steps + 1);
    // the Newton stepper, asked for, runs the same controller: the contact peaks agree
    let mut sn = s.clone();
    sn.stepper = Some(StepperKind::Newton);
    let b = simulate_any(&mech, &sn, &mut |_| true).unwrap();
    assert_eq!(b.stats.stepper, "newton");
    let (ea, eb) = (&a.record.extremes[0], &b.record.extremes[0]);
    assert!((ea.max_force / eb.max_force - 1.0).abs() < 0.01);
    assert!((ea.max_penetration / eb.max_penetration - 1.0).abs() < 0.01);
    // the refactorizing solver (the contact terms in the matrix of each cached step size) solves
    // the same systems
    let mut sf = s.clone();
    sf.solver = flexclear::run::SolverMode::Refactor;
    let f = simulate_any(&mech, &sf, &mut |_| true).unwrap();
    let ef = &f.record.extremes[0];
    assert_eq!(f.stats.adaptive_steps, st.adaptive_steps);
    assert!((ef.max_force / ea.max_force - 1.0).abs() < 1e-9);
    assert!((ef.max_penetration / ea.max_penetration - 1.0).abs() < 1e-9);
    // the constant-rate stepper does not take adaptive steps; lockstep lanes do not either
    let mut sr = s.clone();
    sr.stepper = Some(StepperKind::ConstantRate);
    assert!(Plan::compile(&mech, &sr).unwrap_err().to_string().contains("stepper"));
    let model = mech.to_translating().unwrap();
    assert!(Lockstep::<2>::with_analysis(&[(&model, &s), (&model, &s)], None).is_err());
}

#[test]
fn a_joint_with_friction_runs_on_the_newton_stepper_refactorizing() {
    use flexclear::contact::friction::{Coulomb, FrictionLaw, JointFriction};
    let s = Settings::new(0.01, 1e-5);
    let mut m = yoke();
    m.joints[0].friction = Some(JointFriction {
        law: FrictionLaw::Coulomb(Coulomb::new(0.1)),
        journal_radius: 5e-3,
    });
    // neither the constant stepper (LDL^T) nor the contact-free factor (Woodbury) takes the
    // friction's tangent, which couples the rotations and is unsymmetric
    let p = Plan::compile(&m, &s).unwrap();
    assert_eq!(p.kind, StepperKind::Newton);
    assert!(p.reason.contains("friction"), "{}", p.reason);
    assert!(p.rate_reason.contains("friction"), "{}", p.rate_reason);
    for asked in [StepperKind::Constant, StepperKind::ConstantRate] {
        let mut a = s.clone();
        a.stepper = Some(asked);
        let err = simulate_any(&m, &a, &mut |_| true).unwrap_err().error.to_string();
        assert!(err.contains("stepper") && err.contains("friction"), "{err}");
    }
    // a run through impacts (the yoke's first closes the gap after 0.01 s)
    let mut r = Settings::new(0.05, 1e-5);
    r.record.contact_modes = true;
    let out = simulate_any(&m, &r, &mut |_| true).unwrap();
    assert_eq!((out.stats.stepper, out.stats.woodbury_steps), ("newton", 0));
    let e = &out.record.extremes[0];
    assert!(e.impacts > 0 && e.friction_energy() > 0.0, "{e:?}");
    // frictionless, the same model is the constant stepper's
    assert_eq!(kind(&yoke(), &s).0, StepperKind::Constant);
    // a bad radius is named
    m.joints[0].friction.as_mut().unwrap().journal_radius = -1.0;
    let err = Plan::compile(&m, &s).err().map(|e| e.to_string()).unwrap_or_default();
    let run_err = simulate_any(&m, &s, &mut |_| true).unwrap_err().error.to_string();
    assert!(
        run_err.contains("joints[0].friction.journal_radius"),
        "{err} / {run_err}"
    );
}
