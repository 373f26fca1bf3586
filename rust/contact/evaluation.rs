//! One contact evaluation per clearance joint, shared by every stepper (the constant stepper of
//! `integrator/constant.rs` and the Newton stepper of `integrator/newton.rs`).
//!
//! What a step does with a joint's contact law, by coupling ([`super::Coupling`]):
//!
//! - **force**: the law at the state of the step's start, frozen as an explicit force
//!   ([`explicit_terms`]) for the whole step;
//! - **modified, lagged kappa**: the law's terms (`kappa K_B`, `C_B`) at the step's start, in the
//!   matrix: the force acting in the step is `-k q - c qd + f_explicit` with those terms at the
//!   state the step reaches;
//! - **modified, iterated kappa**: the terms re-evaluated at every iterate of the end-of-step
//!   state, spring *and* damping ([`iterated_terms`]), so the converged step is the implicit one:
//!   the law's force at the state the step reaches. The spring enters the iteration matrix by its
//!   tangent (Newton on the spring, [`linearize_spring`]): the fixed point is the same as the
//!   secant (kappa) iteration's, reached quadratically where the secant iteration stops
//!   contracting (stiff bearings). At the contact edge the dashpot force jumps from 0 to
//!   `C_B |qdot|` and a step may have no solution with either status; after [`EDGE_SWITCHES`]
//!   status changes within one step the dashpot is left out for the rest of the step (the spring
//!   force is continuous there, so the iteration has a fixed point; at the circle the dashpot's
//!   force is undetermined in `[0, C_B |qdot|]`: this takes 0);
//! - **gap element**: the status iterated (constant stepper only).
//!
//! The **recorded force** of a joint ([`recorded_force`]) is the force the integrator applied in
//! the step: the terms that acted in the step, at the state reached. That is what the dynamics
//! felt (the impulse the recorded forces integrate to is the one that changed the momentum); for
//! the lagged couplings it is zero in the step that closes the gap (the terms of its start are
//! those of an open joint) and, with the force method, the force of the step's start. The law at
//! the reached state would describe a force no step applied.

use super::{approach_speed, ContactLaw, ContactTerms, Mat2};

/// After this many contact status switches of a joint within one step's iteration, its dashpot
/// is left out for the rest of that step (see [`iterated_terms`]).
pub const EDGE_SWITCHES: u8 = 4;

/// The law of a joint with clearance `clearance` (m) at relative position `q` (m) and velocity
/// `qd` (m/s), within its contact episode (`episode`: approach speed, m/s, see
/// [`super::next_episode`]) when the law needs the approach speed (`needs_v0`, cached by the
/// caller from [`ContactLaw::needs_approach_speed`]).
#[inline]
pub fn law_terms(
    law: &dyn ContactLaw,
    needs_v0: bool,
    q: [f64; 2],
    qd: [f64; 2],
    clearance: f64,
    episode: Option<f64>,
) -> ContactTerms {
    if needs_v0 {
        law.evaluate_episode(q, qd, clearance, approach_speed(q, qd, episode))
    } else {
        law.evaluate(q, qd, clearance)
    }
}

/// The force coupling's terms: the whole force of `terms` at `(q, qd)` (N), explicit.
#[inline]
pub fn explicit_terms(terms: &ContactTerms, q: [f64; 2], qd: [f64; 2]) -> ContactTerms {
    ContactTerms {
        penetration: terms.penetration,
        f_explicit: terms.force(q, qd),
        ..Default::default()
    }
}

/// The iterated modified coupling at one iterate: `t` is the law at the iterate's end-of-step
/// state, `was_active` the status of the previous iterate's terms, `switches` the joint's count
/// of status changes within this step (reset to 0 at the step's start). Returns the terms to use
/// (the dashpot left out once the status has switched [`EDGE_SWITCHES`] times) and whether the
/// status changed (the step is then not converged).
#[inline]
pub fn iterated_terms(mut t: ContactTerms, was_active: bool, switches: &mut u8) -> (ContactTerms, bool) {
    let changed = t.active() != was_active;
    if changed {
        *switches = switches.saturating_add(1);
    }
    if t.active() && *switches >= EDGE_SWITCHES {
        t.c = [[0.0; 2]; 2];
    }
    (t, changed)
}

/// Newton on the spring: `t` (active, evaluated at the iterate `q1`) rewritten with the spring's
/// tangent `kt` (N/m, [`ContactLaw::spring_tangent`] at `q1`) as its matrix, so that
/// `-kt q + (kt - k_s) q1 = f_s(q1) - kt (q - q1)`: the same force at `q1`, the tangent in the
/// iteration matrix.
#[inline]
pub fn linearize_spring(t: &mut ContactTerms, kt: Mat2, q1: [f64; 2]) {
    for r in 0..2 {
        for c in 0..2 {
            t.f_explicit[r] += (kt[r][c] - t.k[r][c]) * q1[c];
        }
    }
    t.k = kt;
}

/// The recorded force of a joint (N, on the journal): the terms that acted in the step (`terms`:
/// explicit for the force coupling, lagged or iterated for the modified one) at the state reached
/// `(q, qd)`. See the module documentation.
#[inline]
pub fn recorded_force(terms: &ContactTerms, q: [f64; 2], qd: [f64; 2]) -> [f64; 2] {
    terms.force(q, qd)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{DampingLaw, SpringDamper};

    #[test]
    fn the_dashpot_goes_after_edge_switches_and_the_spring_stays() {
        let law = SpringDamper {
            stiffness: 1e8,
            damping: 50.0,
            damping_law: DampingLaw::Viscous,
            no_tension: false,
        };
        let (inside, outside) = ([1.1e-4, 0.0], [0.9e-4, 0.0]);
        let mut switches = 0u8;
        let mut active = false;
        for i in 0..EDGE_SWITCHES {
            let q = if i % 2 == 0 { inside } else { outside };
            let (t, changed) = iterated_terms(law.evaluate(q, [1.0, 0.0], 1e-4), active, &mut switches);
            assert!(changed);
            active = t.active();
            if i + 1 < EDGE_SWITCHES && active {
                assert_eq!(t.c[0][0], 50.0);
            }
        }
        assert_eq!(switches, EDGE_SWITCHES);
        let (t, _) = iterated_terms(law.evaluate(inside, [1.0, 0.0], 1e-4), active, &mut switches);
        assert_eq!(t.c, [[0.0; 2]; 2]);
        assert!(t.k[0][0] > 0.0);
    }

    #[test]
    fn newton_on_the_spring_keeps_the_force_at_the_iterate() {
        let law = SpringDamper {
            stiffness: 3e9,
            damping: 0.0,
            damping_law: DampingLaw::Viscous,
            no_tension: false,
        };
        let q1 = [1.2e-4, 0.3e-4];
        let mut t = law.evaluate(q1, [0.0; 2], 1e-4);
        let f = t.force(q1, [0.0; 2]);
        linearize_spring(&mut t, law.spring_tangent(q1, 1e-4), q1);
        let g = t.force(q1, [0.0; 2]);
        for r in 0..2 {
            assert!((f[r] - g[r]).abs() <= 1e-12 * f[0].hypot(f[1]), "{f:?} {g:?}");
        }
    }
}
