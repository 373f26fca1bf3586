//! Rigid links (`Link::rigid`) against the rigid-body equations derived independently of the
//! code: a bar hinged at one end under a constant transverse tip load (fixed and spinning
//! frames: `J0 theta'' = F L`, no centrifugal term about the hinge), the small oscillations of a
//! hanging pendulum (`omega^2 = m g c / J0`), flexible links of growing stiffness converging to
//! the rigid response, the energy of a free pendulum, and the plan's routing.
//!
//! Run with `cargo test --release --test integration rigid::`.

use std::sync::Arc;

use flexclear::integrator::newton::{simulate_mechanism, NewtonRun};
use flexclear::kinematics::{FrameKinematics, Rotation};
use flexclear::model::mechanism::{Endpoint, Link, Mechanism, NodalLoad, Pin, RigidBody};
use flexclear::plan::{Plan, StepperKind};
use flexclear::record::LinkChannels;
use flexclear::Settings;

use crate::common::{hub, link};

fn rigid(length: f64, body: RigidBody, frame: Arc<dyn FrameKinematics>) -> Link {
    let mut l = link("bar", length, 1, 1.0, 1.0, 1.0, 1.0, frame);
    l.rigid = Some(body);
    l
}

/// `link` hinged at node 0 to ground at the origin (an ideal pin to a body at rest).
fn hinged(link: Link) -> Mechanism {
    Mechanism {
        links: vec![link],
        pins: vec![Pin {
            name: "hinge".into(),
            a: Endpoint::Node { link: 0, node: 0 },
            b: Endpoint::Body {
                frame: hub(Rotation::Fixed { angle: 0.0 }),
                point: [0.0, 0.0],
                name: "ground".into(),
            },
        }],
        ..Default::default()
    }
}

/// History of `v` of the last node of link 0.
fn tip_v(mech: &Mechanism, t_end: f64, dt: f64) -> (Vec<f64>, Vec<f64>) {
    let settings = Settings::new(t_end, dt);
    let out = simulate_mechanism(mech, &settings, &mut |_| true).unwrap();
    let nn = mech.links[0].nodes();
    let d = &out.record.links[0].displacements;
    let v = d.chunks(3 * nn).map(|row| row[3 * (nn - 1) + 1]).collect();
    (out.record.time.clone(), v)
}

const L: f64 = 0.5;
const F: f64 = 2.0;

/// A uniform steel bar's rigid body: m = rho A L, I = m L^2 / 12, c = L / 2.
fn bar_body() -> RigidBody {
    let m = 7800.0 * 1e-4 * L;
    RigidBody {
        mass: m,
        inertia: m * L * L / 12.0,
        centroid: L / 2.0,
    }
}

fn tip_load(mut mech: Mechanism, nodes: usize) -> Mechanism {
    mech.loads.push(NodalLoad {
        link: 0,
        node: nodes - 1,
        force: [0.0, F],
        moment: 0.0,
    });
    mech
}

/// A hinged bar under a constant transverse tip load F turns as `J0 theta'' = F L`:
/// `v_tip = F L^2 t^2 / (2 J0)`, `J0 = m L^2 / 3`; the average-acceleration Newmark rule is
/// exact for a constant acceleration, so to round-off. The same in a frame spinning at 50 rad/s
/// about the hinge: about the hinge the centrifugal forces of a rigid body have no moment (the
/// Coriolis force of the deviation has none either), so the deviation is the same.
#[test]
fn a_hinged_rigid_bar_under_a_tip_load_turns_as_the_rigid_body_equation_says() {
    let b = bar_body();
    let j0 = b.inertia + b.mass * b.centroid * b.centroid;
    for rotation in [
        Rotation::Fixed { angle: 0.3 },
        Rotation::Constant {
            angle0: 0.0,
            rate: 50.0,
        },
    ] {
        let mech = tip_load(hinged(rigid(L, b, hub(rotation.clone()))), 2);
        let (t, v) = tip_v(&mech, 0.02, 1e-4);
        for (t, v) in t.iter().zip(&v).skip(1) {
            let exact = F * L * L * t * t / (2.0 * j0);
            assert!(
                (v - exact).abs() <= 1e-9 * exact,
                "{rotation:?} t = {t}: {v} vs {exact}"
            );
        }
    }
}

/// Flexible bars of the same mass and length (10 elements) under the same tip load converge to
/// the rigid bar as E grows: the largest difference of the tip deflection over 20 ms falls by
/// about the factor of E (the elastic part is F L^3 / (3 E I) and its vibration).
#[test]
fn flexible_bars_of_growing_stiffness_converge_to_the_rigid_bar() {
    let rigid_mech = tip_load(hinged(rigid(L, bar_body(), hub(Rotation::Fixed { angle: 0.0 }))), 2);
    let (t, vr) = tip_v(&rigid_mech, 0.02, 1e-5);
    let mut errs = Vec::new();
    for e in [2e11, 2e12, 2e13] {
        let flex = tip_load(
            hinged(link(
                "bar",
                L,
                10,
                e,
                7800.0,
                1e-4,
                1e-9,
                hub(Rotation::Fixed { angle: 0.0 }),
            )),
            11,
        );
        let (tf, vf) = tip_v(&flex, 0.02, 1e-5);
        assert_eq!(t.len(), tf.len());
        let err = vr.iter().zip(&vf).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        errs.push(err);
    }
    let scale = vr.last().unwrap().abs();
    // the elastic tip deflection F L^3 / (3 E I) at E = 2e11: 1.7e-3 m of a 2.5e-1 m motion
    assert!(errs[0] < 0.05 * scale, "{errs:?} vs {scale}");
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(ratio > 5.0, "errors {errs:?}: ratio {ratio} (10 expected)");
    }
}

/// A rigid bar hanging from a hinge in gravity: the linearization's frequency is
/// `sqrt(m g c / J0)` (the moment of the nominal inertia load about node 0 turning with theta),
/// and a run from a small initial rate oscillates with that period (within the Newmark period
/// error (w dt)^2 / 12 and the sampling) while its energy (kinetic plus gravity potential) stays
/// constant.
#[test]
fn a_hanging_rigid_pendulum_swings_at_the_pendulum_frequency() {
    let b = RigidBody {
        mass: 0.7,
        inertia: 2e-3,
        centroid: 0.2,
    };
    let g = 9.81;
    let j0 = b.inertia + b.mass * b.centroid * b.centroid;
    let w = (b.mass * g * b.centroid / j0).sqrt();
    let mut link = rigid(
        0.3,
        b,
        hub(Rotation::Fixed {
            angle: -std::f64::consts::FRAC_PI_2,
        }),
    );
    let th0d = 0.01;
    link.initial_velocity = Some(vec![0.0, 0.0, th0d, 0.0, 0.0, 0.0]);
    let mut mech = hinged(link);
    mech.gravity = [0.0, -g];
    let settings = Settings::new(1.0, 1e-3);
    let mut run = NewtonRun::new(&mech, &settings).unwrap();
    assert_eq!(run.unknowns(), 1);
    let [m, _, k, _] = run.linearize(0.0, &[0.0], &[0.0]).unwrap();
    assert!((m[0] - j0).abs() < 1e-14 * j0, "{m:?}");
    assert!((k[0] - b.mass * g * b.centroid).abs() < 1e-12, "{k:?}");
    let period = std::f64::consts::TAU / w;
    let mut settings = Settings::new(3.0 * period, 1e-4);
    settings.record.links = LinkChannels {
        displacements: true,
        energy: true,
        ..Default::default()
    };
    let out = simulate_mechanism(&mech, &settings, &mut |_| true).unwrap();
    let th: Vec<f64> = out.record.links[0].displacements.chunks(6).map(|r| r[2]).collect();
    // upward zero crossings of theta-dot's integral: theta crosses zero downward at T/2, 3T/2, ...
    let t = &out.record.time;
    let crossings: Vec<f64> = (1..th.len())
        .filter(|&i| th[i - 1] > 0.0 && th[i] <= 0.0)
        .map(|i| t[i - 1] + (t[i] - t[i - 1]) * th[i - 1] / (th[i - 1] - th[i]))
        .collect();
    assert!(crossings.len() >= 2, "{crossings:?}");
    let measured = crossings[1] - crossings[0];
    assert!((measured - period).abs() < 1e-5 * period, "{measured} vs {period}");
    // amplitude th0d / w
    let amp = th.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    assert!((amp - th0d / w).abs() < 1e-3 * amp, "{amp} vs {}", th0d / w);
    // energy: kinetic + m g (height of the centroid), height = -c cos(theta)
    let ke = &out.record.links[0].kinetic;
    let e: Vec<f64> = ke
        .iter()
        .zip(&th)
        .map(|(k, th)| k - b.mass * g * b.centroid * th.cos())
        .collect();
    let e0 = 0.5 * j0 * th0d * th0d;
    let spread = e.iter().fold(0.0f64, |a, x| a.max((x - e[0]).abs()));
    assert!(spread < 1e-3 * e0, "energy spread {spread} of {e0}");
}

/// Rigid links go to the Newton stepper, with the reason in the plan; a rigid link's node 1
/// pinned while node 0 is free is refused with a message naming the link; a wrong element
/// count and a non-positive mass are refused naming the parameter.
#[test]
fn rigid_links_are_planned_on_newton_and_checked() {
    let mech = tip_load(hinged(rigid(L, bar_body(), hub(Rotation::Fixed { angle: 0.0 }))), 2);
    let plan = Plan::compile(&mech, &Settings::new(0.01, 1e-4)).unwrap();
    assert_eq!(plan.kind, StepperKind::Newton);
    assert!(plan.reason.contains("is rigid"), "{}", plan.reason);
    assert!(plan.rate_reason.contains("is rigid"), "{}", plan.rate_reason);
    let mut free = mech.clone();
    free.pins[0].a = Endpoint::Node { link: 0, node: 1 };
    if let Endpoint::Body { point, .. } = &mut free.pins[0].b {
        *point = [L, 0.0];
    }
    let err = NewtonRun::new(&free, &Settings::new(0.01, 1e-4))
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("node 1 of rigid link \"bar\""), "{err}");
    let mut bad = mech.clone();
    bad.links[0].section.elements = 2;
    let err = bad.validate(0.01).unwrap_err().to_string();
    assert!(err.contains("links[0].elements"), "{err}");
    let mut bad = mech;
    bad.links[0].rigid.as_mut().unwrap().mass = 0.0;
    let err = bad.validate(0.01).unwrap_err().to_string();
    assert!(err.contains("links[0].mass"), "{err}");
}

/// The Flores slider-crank with ideal joints has no unknown (rigid bodies in a closed loop) and
/// reproduces the rigid slider-crank's slider acceleration, extremes -19 419 and +9 696 m/s^2
/// (CONTACT.md section 4, to the unit: within 1 m/s^2 on a 1e-6 s grid); with the 0.5 mm
/// clearance the rod has one unknown (its rotation) and the slider one.
#[test]
fn the_flores_slider_crank_with_ideal_joints_follows_the_rigid_kinematics() {
    use flexclear::scenes::FloresSliderCrank;
    let ideal = FloresSliderCrank {
        clearance: None,
        ..Default::default()
    }
    .build()
    .unwrap();
    let period = std::f64::consts::TAU / FloresSliderCrank::default().crank_speed;
    let settings = Settings::new(period, period / 20000.0);
    let run = NewtonRun::new(&ideal, &settings).unwrap();
    assert_eq!(run.unknowns(), 0);
    let out = simulate_mechanism(&ideal, &settings, &mut |_| true).unwrap();
    let a = &out.record.sliders[0].acceleration;
    let (lo, hi) = a.iter().fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
    assert!((lo + 19419.0).abs() < 1.0 && (hi - 9696.0).abs() < 1.0, "{lo} {hi}");
    let with = FloresSliderCrank::default();
    assert!((with.pin_stiffness().unwrap() - 6.61e10).abs() < 0.005e10);
    let mech = with.build().unwrap();
    let run = NewtonRun::new(&mech, &settings).unwrap();
    assert_eq!(run.unknowns(), 2);
}
