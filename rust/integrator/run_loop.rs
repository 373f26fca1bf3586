//! The one run loop of every stepper kind.
//!
//! A run is the grid `t_k = k dt`, `k = 1 ..= steps`. At each step the loop
//!
//! 1. advances every running lane to `t_k` ([`Stepper::advance`]: the fixed step, or with
//!    [`Settings::events`](crate::run::Settings::events) the event-aware step that cuts at a
//!    located contact entry or exit; either way the stepper compares each clearance joint's
//!    penetration with the divergence limit, the per-step half of the divergence rule);
//! 2. every [`CHECK_STRIDE`] steps and at the last step, checks the whole state
//!    ([`Stepper::check`]: the rule of [`crate::integrator::divergence`]); a lane that fails is
//!    stopped with [`Error::Diverged`] and keeps what it recorded before this step;
//! 3. records every running lane ([`Stepper::record`]; the recorder keeps what its
//!    [`RecordSpec`](crate::record::RecordSpec) asks for: every `every`-th step and the last);
//! 4. every [`Stepper::CONTROL_STRIDE`] steps calls the caller's `control(fraction done)`
//!    (progress, and Ctrl-C from Python); `false` stops every running lane with
//!    [`Error::Interrupted`].
//!
//! A lane that fails keeps its output up to the failure ([`crate::run::RunFailure`]); the
//! others go on. When no lane is running or the grid is done, [`Stepper::end`] completes the
//! lanes still running.
//!
//! The loop is generic over the stepper and inlined into it, so the constant stepper's lanes stay
//! monomorphic (and inside its AVX2-compiled body) with no dispatch per step.

use super::divergence::CHECK_STRIDE;
use crate::error::Error;

/// What the run loop needs of a stepper kind. Lanes are the runs a stepper advances together
/// (one for the Newton stepper; up to `L` for the constant stepper's lockstep).
pub(crate) trait Stepper {
    /// Steps between two calls of the caller's control function: about the same wall time
    /// (tens of milliseconds) whatever the cost of a step.
    const CONTROL_STRIDE: u64;
    /// Number of steps of the run.
    fn steps(&self) -> u64;
    /// The step, s.
    fn dt(&self) -> f64;
    /// Whether any lane is still running.
    fn running(&self) -> bool;
    /// Advances every running lane from `t_{k-1}` to `t1 = t_k` (s). A lane whose step fails
    /// (no convergence, a singular matrix, a joint beyond the divergence limit) stops with its
    /// error at the start of the step. Adaptive steps call `control` every
    /// [`CONTROL_STRIDE`](super::adaptive::CONTROL_STRIDE) trial steps (an output interval may
    /// hold millions); `false` stops the run with [`Error::Interrupted`] at the last accepted
    /// step.
    fn advance(&mut self, k: u64, t1: f64, control: &mut dyn FnMut(f64) -> bool);
    /// The divergence rule's check of every running lane's state after step `k`, at `t1` (s).
    fn check(&mut self, k: u64, t1: f64);
    /// Records every running lane after step `k`, at `t1` (s).
    fn record(&mut self, k: u64, t1: f64);
    /// Stops every running lane with `error` after step `k`, at `t` (s).
    fn stop_all(&mut self, error: Error, k: u64, t: f64);
    /// Completes the lanes still running after step `k`, at `t` (s).
    fn end(&mut self, k: u64, t: f64);
}

/// Runs `stepper` over its grid (see the module documentation).
#[inline(always)]
pub(crate) fn run<S: Stepper>(stepper: &mut S, control: &mut dyn FnMut(f64) -> bool) {
    let steps = stepper.steps();
    let dt = stepper.dt();
    let mut k = 0;
    while k < steps && stepper.running() {
        k += 1;
        let t1 = k as f64 * dt;
        stepper.advance(k, t1, control);
        if k.is_multiple_of(CHECK_STRIDE) || k == steps {
            stepper.check(k, t1);
        }
        stepper.record(k, t1);
        if k.is_multiple_of(S::CONTROL_STRIDE) && !control(k as f64 / steps as f64) {
            stepper.stop_all(Error::Interrupted { time: t1, step: k }, k, t1);
        }
    }
    stepper.end(k, k as f64 * dt);
}
