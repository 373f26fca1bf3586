//! Contact laws of clearance joints (one trait) and the ways a contact force enters the Newmark
//! step ([`Coupling`]).
//!
//! Notation (docs/method.md section 4): `q` is the journal centre relative to the bearing centre
//! (global axes, m), `delta_r = |q|`, penetration `delta = delta_r - delta_c` (contact when > 0).
//! A law returns its force on the journal in the split form
//! `f = -k q - c qdot + f_explicit` with 2 x 2 matrices `k` (N/m) and `c` (N s/m): the force
//! reaction method uses `f` evaluated at the last state; the modified-matrix method moves `k` and
//! `c` into the effective matrix and keeps `f_explicit` on the right-hand side.

mod coupling;
pub mod evaluation;
pub mod friction;
pub mod laws;
pub mod restitution;
mod spring_damper;

pub use coupling::Coupling;
pub use spring_damper::{DampingLaw, SpringDamper};

use crate::error::Result;

/// 2 x 2 matrix, row-major.
pub type Mat2 = [[f64; 2]; 2];

/// A contact law evaluated at one state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactTerms {
    /// Penetration `delta_r - delta_c`, m (negative when open).
    pub penetration: f64,
    /// Secant stiffness matrix `k`, N/m.
    pub k: Mat2,
    /// Damping matrix `c`, N s/m.
    pub c: Mat2,
    /// Force part that stays explicit, N.
    pub f_explicit: [f64; 2],
}

impl ContactTerms {
    /// The force on the journal at `(q, qd)` with these terms, N.
    #[inline]
    pub fn force(&self, q: [f64; 2], qd: [f64; 2]) -> [f64; 2] {
        let (k, c) = (&self.k, &self.c);
        [
            self.f_explicit[0] - k[0][0] * q[0] - k[0][1] * q[1] - c[0][0] * qd[0] - c[0][1] * qd[1],
            self.f_explicit[1] - k[1][0] * q[0] - k[1][1] * q[1] - c[1][0] * qd[0] - c[1][1] * qd[1],
        ]
    }

    /// True when the law exerts any force (contact closed).
    #[inline]
    pub fn active(&self) -> bool {
        self.penetration > 0.0
    }
}

/// A contact law between journal and bearing. Implement it to add Hertz, Lankarani-Nikravesh or
/// other laws; the integrator only sees [`ContactTerms`].
pub trait ContactLaw: std::fmt::Debug + Send + Sync {
    /// Evaluates the law at relative position `q` (m) and velocity `qd` (m/s) for clearance
    /// `clearance` (m). Must return finite terms for every finite input, including `q = 0`.
    fn evaluate(&self, q: [f64; 2], qd: [f64; 2], clearance: f64) -> ContactTerms;

    /// Whether the law's force depends on the approach speed of the contact episode (the
    /// hysteresis laws of [`laws`]); the steppers then track it per joint and call
    /// [`ContactLaw::evaluate_episode`].
    fn needs_approach_speed(&self) -> bool {
        false
    }

    /// [`ContactLaw::evaluate`] within a contact episode whose approach speed is
    /// `approach_speed` (m/s, the penetration rate at the episode's first state: see
    /// [`approach_speed`]). Default: the approach speed is not used.
    fn evaluate_episode(&self, q: [f64; 2], qd: [f64; 2], clearance: f64, approach_speed: f64) -> ContactTerms {
        let _ = approach_speed;
        self.evaluate(q, qd, clearance)
    }

    /// Checks the law's parameters; `name` prefixes parameter names in errors.
    fn validate(&self, name: &str) -> Result<()>;

    /// The law as the built-in [`SpringDamper`] where it is one: the Newton stepper then calls
    /// it directly, compiled into its step, instead of through the trait object (the same
    /// code, so the same values). Default: `None`.
    fn as_spring_damper(&self) -> Option<&SpringDamper> {
        None
    }

    /// Contact stiffness scale, N/m: used for the gap coupling's defaults and diagnostics.
    fn stiffness(&self) -> f64;

    /// Tangent `-d f_spring / d q` (N/m) of the law's elastic part (without damping and explicit
    /// terms) at `q` (m): the Newton matrix of an iterated contact. Default: central differences
    /// of [`ContactLaw::evaluate`] (four evaluations); laws with a closed form override it.
    fn spring_tangent(&self, q: [f64; 2], clearance: f64) -> Mat2 {
        let force = |q: [f64; 2]| {
            let t = self.evaluate(q, [0.0; 2], clearance);
            [
                -t.k[0][0] * q[0] - t.k[0][1] * q[1],
                -t.k[1][0] * q[0] - t.k[1][1] * q[1],
            ]
        };
        let hq = 1e-7 * (q[0].hypot(q[1])).max(clearance).max(1e-5);
        let mut k = [[0.0; 2]; 2];
        for col in 0..2 {
            let (mut qp, mut qm) = (q, q);
            qp[col] += hq;
            qm[col] -= hq;
            let (fp, fm) = (force(qp), force(qm));
            for row in 0..2 {
                k[row][col] = -(fp[row] - fm[row]) / (2.0 * hq);
            }
        }
        k
    }
}

/// The approach speed (m/s) with which a law that needs one ([`ContactLaw::needs_approach_speed`])
/// is evaluated at a journal state `(q, qd)` of joint with clearance `clearance`: the stored speed
/// of the current episode (`episode`, set from the first accepted state in contact), or, at a
/// state in contact before the episode has an accepted state (the trial states of the step that
/// closes the gap), the state's own penetration rate `n . qd` — each episode's first state is its
/// own approach. Never negative (a grazing entry gives 0, which the laws floor).
#[inline]
pub fn approach_speed(q: [f64; 2], qd: [f64; 2], episode: Option<f64>) -> f64 {
    if let Some(v0) = episode {
        return v0;
    }
    let r = q[0].hypot(q[1]);
    if r == 0.0 {
        return 0.0;
    }
    ((q[0] * qd[0] + q[1] * qd[1]) / r).max(0.0)
}

/// The episode's approach speed after an accepted state: `None` while the joint is open (the
/// next episode takes its own), kept while in contact, and set from the state when an episode
/// starts ([`approach_speed`] with no episode).
#[inline]
pub fn next_episode(q: [f64; 2], qd: [f64; 2], penetration: f64, episode: Option<f64>) -> Option<f64> {
    if penetration > 0.0 {
        Some(approach_speed(q, qd, episode))
    } else {
        None
    }
}
