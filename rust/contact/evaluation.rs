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
//! **Friction** ([`slip`]): the slip speed of the contact points and the normal force the
//! friction law of a joint sees (docs/contact.md section 4.1); the Newton stepper applies it.
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

/// The contact geometry friction needs at one state of a clearance joint (docs/contact.md
/// section 4.1): the normal `n = q / |q|` (bearing centre to journal centre), the tangent
/// `t = S n` (`n` turned by +90 degrees), the slip speed of the journal's contact point against
/// the bearing's, `v = qd . t + R_J w_J - R_B w_B` (m/s; `R_B = R_J + clearance`), and the
/// normal force `F_N = -f . n` (N, compressive positive) of the contact force `f` on the journal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slip {
    /// Unit normal.
    pub n: [f64; 2],
    /// Unit tangent `S n`.
    pub t: [f64; 2],
    /// Slip speed, m/s.
    pub speed: f64,
    /// Normal force, N.
    pub normal_force: f64,
}

/// [`Slip`] at relative position `q` (m) and velocity `qd` (m/s) of the journal centre, contact
/// force `f` (N, on the journal), total angular velocities `w_j`, `w_b` (rad/s: frame rate plus
/// elastic rotation rate) of journal and bearing, journal radius `r_j` and radial clearance
/// `clearance` (m). `None` at `q = 0` (no normal: the journal centred, no contact).
#[inline]
pub fn slip(q: [f64; 2], qd: [f64; 2], f: [f64; 2], w_j: f64, w_b: f64, r_j: f64, clearance: f64) -> Option<Slip> {
    let r = q[0].hypot(q[1]);
    if r == 0.0 {
        return None;
    }
    let n = [q[0] / r, q[1] / r];
    let t = [-n[1], n[0]];
    Some(Slip {
        n,
        t,
        speed: qd[0] * t[0] + qd[1] * t[1] + r_j * w_j - (r_j + clearance) * w_b,
        normal_force: -(f[0] * n[0] + f[1] * n[1]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{DampingLaw, SpringDamper};

    #[test]
    fn the_slip_speed_takes_both_spins() {
        // journal at the bottom of the bearing (n = -y, t = +x), pressed down by 100 N
        let (q, f) = ([0.0, -1e-4], [0.0, 100.0]);
        let s = slip(q, [0.0; 2], f, 2.0, 0.0, 0.01, 1e-4).unwrap();
        assert_eq!((s.n, s.t, s.normal_force), ([0.0, -1.0], [1.0, 0.0], 100.0));
        // a journal spinning counter-clockwise at 2 rad/s: its bottom point moves at +R_J w
        assert_eq!(s.speed, 0.02);
        // the bearing spinning along with it at the same surface speed: no slip
        let s = slip(q, [0.0; 2], f, 2.0, 2.0 * 0.01 / 0.0101, 0.01, 1e-4).unwrap();
        assert!(s.speed.abs() < 1e-17);
        // the journal centre sliding along +x at 0.3 m/s, no spin
        assert_eq!(slip(q, [0.3, 0.0], f, 0.0, 0.0, 0.01, 1e-4).unwrap().speed, 0.3);
        assert_eq!(slip([0.0; 2], [1.0, 0.0], f, 1.0, 0.0, 0.01, 1e-4), None);
    }

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
