//! Time integrators, one file per stepper kind (the table in [`crate::plan`]): [`constant`]
//! (Newmark on a contact-free effective matrix factorized once, contact by Woodbury, lockstep
//! lanes) and [`newton`] (Newton iterations on the moving-frame equations, the band LU
//! refactorized when the Jacobian changes); `adaptive` holds the parts of adaptive steps both
//! share; [`events`] locates contact entry and exit for both, [`newmark`] holds the schemes both
//! step with, and one divergence rule serves both.

pub(crate) mod adaptive;
pub mod constant;
pub mod divergence;
pub mod events;
pub mod newmark;
pub mod newton;
pub(crate) mod run_loop;

pub use constant::NewmarkRun;
pub use newmark::Newmark;

/// Instants less than this fraction of a step apart are taken as the same instant: a grid's
/// `k dt` and the end `t + h` of the step that reached it differ by rounding (a few ulps of `t`,
/// far below it). Used wherever a stepper asks whether it stands at an output instant, a run's
/// end or the end of the last converged step.
pub(crate) const SAME_INSTANT: f64 = 1e-9;

/// The rounding tolerance ([`SAME_INSTANT`]) of a step of length `h` (s) in time, s.
#[inline]
pub(crate) fn same_instant(h: f64) -> f64 {
    SAME_INSTANT * h
}

/// Euclidean length of a 2-vector. Plain `sqrt(x^2 + y^2)`: `f64::hypot` is a slow library call,
/// and the overflow it guards against (|v| > 1e154 m) only happens in a divergence, which the
/// finite checks report.
#[inline]
pub(crate) fn norm2(v: [f64; 2]) -> f64 {
    (v[0] * v[0] + v[1] * v[1]).sqrt()
}
