//! The constant-rate stepper (`stats.stepper == "constant-rate"`): moving-frame equations whose
//! contact-free Jacobian is the same at every step, factorized once, the contact terms put on it
//! by Woodbury. Its results are the Newton stepper's on the same model up to rounding (the two
//! solve the same linear system each iteration, one by a low-rank update of the contact-free
//! factor, the other by refactorizing with the contact terms, `solver="refactor"`), with one
//! factorization of the effective matrix for the whole run however often the contact changes.

use flexclear::contact::Coupling;
use flexclear::integrator::newton::simulate_mechanism;
use flexclear::model::mechanism::Mechanism;
use flexclear::plan::{simulate as simulate_any, Plan, StepperKind};
use flexclear::run::SolverMode;
use flexclear::{RunOutput, Settings};

use flexclear::scenes::spinning_beam_in_a_bearing;

/// The Newton stepper refactorizing the whole Jacobian whenever it changes (`solver="refactor"`:
/// the reference; with the default Woodbury solver the Newton stepper also puts the contact on
/// its contact-free factor).
fn refactorizing(mech: &Mechanism, s: &Settings) -> RunOutput {
    let mut s = s.clone();
    s.solver = SolverMode::Refactor;
    simulate_mechanism(mech, &s, &mut |_| true).unwrap()
}

fn settings(coupling: Coupling) -> Settings {
    let mut s = Settings::new(0.02, 1e-5);
    s.coupling = coupling;
    s.record.links.displacements = true;
    // the solvers compared here agree within the iteration tolerance: iterate to it alone, not
    // to a fraction of each step's truncation error (up to 1e-6, which the rattling contact
    // carries over: 4.8e-6 and 2.1e-5 apart over 1000 steps with the default)
    s.newton.truncation_fraction = 0.0;
    s
}

/// Largest difference of the tip's recorded displacements and of the joint's force history,
/// relative to their largest magnitudes.
fn difference(a: &RunOutput, b: &RunOutput) -> (f64, f64) {
    let rel = |x: &[f64], y: &[f64]| {
        assert_eq!(x.len(), y.len());
        let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        x.iter().zip(y).fold(0.0f64, |m, (p, q)| m.max((p - q).abs())) / scale
    };
    (
        rel(&a.record.links[0].displacements, &b.record.links[0].displacements),
        rel(&a.record.joints[0].force, &b.record.joints[0].force),
    )
}

#[test]
fn a_spinning_beam_in_a_bearing_plans_as_constant_rate_and_factors_once() {
    let mech = spinning_beam_in_a_bearing();
    let s = settings(Coupling::default());
    let plan = Plan::compile(&mech, &s).unwrap();
    assert_eq!(plan.kind, StepperKind::ConstantRate, "{}", plan.rate_reason);
    // why not the constant stepper: the clamp (a support) comes first among its rules
    assert_eq!(plan.reason, "the mechanism has a support");
    let out = simulate_any(&mech, &s, &mut |_| true).unwrap();
    assert_eq!(out.stats.stepper, "constant-rate");
    // the mass matrix for the initial accelerations, then the contact-free effective matrix once
    assert_eq!(out.stats.factorizations, 2);
    let e = &out.record.extremes[0];
    assert!(e.impacts >= 10, "{} impacts", e.impacts);
    // contact closed in many steps, each solved by Woodbury on the one factor
    assert!(out.stats.woodbury_steps >= 100, "{}", out.stats.woodbury_steps);
    assert_eq!(out.stats.woodbury_fallbacks, 0);
}

/// Lagged kappa (one solve per step): the two steppers solve the same linear system at every
/// step; over 2000 steps and 15 impacts the histories agree to 1e-11 of their scale (measured:
/// 8.2e-14 for the displacements, 2.7e-13 for the force), while Newton refactorizes at every
/// change of the contact terms (207 factorizations against 2).
#[test]
fn constant_rate_equals_newton_with_lagged_contact() {
    let mech = spinning_beam_in_a_bearing();
    let s = settings(Coupling::default());
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let b = refactorizing(&mech, &s);
    assert_eq!((a.stats.stepper, b.stats.stepper), ("constant-rate", "newton"));
    assert_eq!(a.record.extremes[0].impacts, b.record.extremes[0].impacts);
    let (du, df) = difference(&a, &b);
    assert!(du < 1e-11 && df < 1e-11, "displacements {du:e}, force {df:e}");
    assert!(b.stats.factorizations > 100, "{}", b.stats.factorizations);
    assert_eq!(a.stats.factorizations, 2);
}

/// Implicit contact (Newton on the contact at every iterate): the constant-rate stepper updates
/// the Woodbury blocks with the tangent at each iterate instead of refactorizing; same
/// iterations to the same tolerance (4000 in both), histories within 1e-11 of their scale
/// (measured: 5.1e-14 displacements, 2.5e-13 force; Newton: 524 factorizations against 2).
#[test]
fn constant_rate_equals_newton_with_implicit_contact() {
    let mech = spinning_beam_in_a_bearing();
    let s = settings(Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    });
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let b = refactorizing(&mech, &s);
    assert_eq!(a.stats.stepper, "constant-rate");
    assert_eq!(a.record.extremes[0].impacts, b.record.extremes[0].impacts);
    let (du, df) = difference(&a, &b);
    assert!(du < 1e-11 && df < 1e-11, "displacements {du:e}, force {df:e}");
    assert_eq!(a.stats.factorizations, 2);
    assert!(b.stats.factorizations > a.stats.factorizations);
}

/// The force method puts no contact term in the Jacobian: both steppers solve with the same
/// factor of the same matrix, so the runs are bitwise equal.
#[test]
fn constant_rate_is_newton_bitwise_with_the_force_method() {
    let mech = spinning_beam_in_a_bearing();
    let s = settings(Coupling::Force);
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let b = refactorizing(&mech, &s);
    assert_eq!(a.stats.stepper, "constant-rate");
    assert_eq!(a.state, b.state);
    assert_eq!(a.record.links, b.record.links);
    assert_eq!(a.record.joints, b.record.joints);
    assert_eq!((a.stats.factorizations, b.stats.factorizations), (2, 2));
}

/// Event location cuts steps into substeps of other lengths: those take the Newton path
/// (refactorizing), the whole steps keep the one factor; results as Newton's with events, within
/// 1e-11 of their scale (measured: 1.6e-13, 4.6e-13; 140 factorizations against Newton's 364).
#[test]
fn constant_rate_with_events_matches_newton() {
    let mech = spinning_beam_in_a_bearing();
    let mut s = settings(Coupling::default());
    s.events = true;
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let b = refactorizing(&mech, &s);
    assert_eq!(a.stats.stepper, "constant-rate");
    assert!(a.stats.event_steps > 0);
    assert_eq!(a.stats.event_steps, b.stats.event_steps);
    let (du, df) = difference(&a, &b);
    assert!(du < 1e-11 && df < 1e-11, "displacements {du:e}, force {df:e}");
    assert!(a.stats.factorizations < b.stats.factorizations);
}

/// The Newton stepper with the Woodbury solver (the default) puts the contact terms on the
/// contact-free factor of the step too, and refactorizes only when the contact-free Jacobian
/// changes (here every step: the rod's frame rate and its axial forces move). Simeon's
/// slider-crank with a clearance at the crank pin, implicit contact, 1000 steps of 1e-5 s: one
/// factorization per step (plus the mass matrix) against 1.9 per step refactorizing for the
/// contact (2.4 before the iterations stopped on their contraction); the geometric part of the Jacobian is the step start's in both (a modified Newton),
/// but the refactorizing path also refreshes it when a contact change forces a refactorization,
/// so the iterates differ within the iteration tolerance (1e-10), not only by rounding, and the
/// differences carry over from step to step through the rattling: the displacement histories
/// agree to 1e-7 of their scale, the contact force's (stiff: a fraction of a um of penetration
/// is its whole range) to 2e-6 (measured: 1.4e-8 and 5.6e-7 with the iterations stopped on
/// their contraction; 5.1e-12 and 2.0e-8 when each took one more, confirming, iteration; with
/// the kept factor's steps in contact also stopping on the carried rate, `CONTACT_RATE_MARGIN`,
/// 1.2e-8 and 1.16e-6 for the age of 8, while the refactorizing run's force is within 8.3e-7
/// of iterations to 1e-13 and the age-8 run's within 1.27e-6), same impacts.
#[test]
fn newton_puts_contact_changes_on_the_step_factor() {
    let mech = flexclear::scenes::FlexibleSliderCrank {
        clearance_at: Some(flexclear::scenes::SliderCrankPin::CrankPin),
        ..Default::default()
    }
    .build()
    .unwrap();
    let mut s = settings(Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    });
    s.t_end = 0.01;
    // a new contact-free factor every step (the Jacobian kept for one step only)
    s.newton.jacobian_age = 1;
    let a = simulate_any(&mech, &s, &mut |_| true).unwrap();
    let b = refactorizing(&mech, &s);
    assert_eq!((a.stats.stepper, b.stats.stepper), ("newton", "newton"));
    assert_eq!(a.stats.factorizations, a.stats.steps + 1);
    assert!(a.stats.woodbury_steps > 500, "{}", a.stats.woodbury_steps);
    assert!(
        b.stats.factorizations > 3 * b.stats.steps / 2,
        "{}",
        b.stats.factorizations
    );
    assert_eq!(a.record.extremes[0].impacts, b.record.extremes[0].impacts);
    let (du, df) = difference(&a, &b);
    assert!(du < 1e-7 && df < 2e-6, "displacements {du:e}, force {df:e}");
    // the default keeps a factor for up to JACOBIAN_AGE (20) steps: fewer factorizations, a few
    // more iterations, the same answer within the iteration tolerance
    s.newton.jacobian_age = flexclear::run::JACOBIAN_AGE;
    let c = simulate_any(&mech, &s, &mut |_| true).unwrap();
    assert!(3 * c.stats.factorizations < c.stats.steps, "{}", c.stats.factorizations);
    assert!(
        c.stats.iterations < a.stats.iterations * 5 / 4,
        "{} vs {}",
        c.stats.iterations,
        a.stats.iterations
    );
    assert_eq!(c.record.extremes[0].impacts, b.record.extremes[0].impacts);
    let (du, df) = difference(&c, &b);
    assert!(
        du < 1e-7 && df < 2e-6,
        "reused factors: displacements {du:e}, force {df:e}"
    );
    eprintln!(
        "age 1: {} factorizations, {} iterations; age 20: {} factorizations, {} iterations, differences {du:e} {df:e}",
        a.stats.factorizations, a.stats.iterations, c.stats.factorizations, c.stats.iterations
    );
}
