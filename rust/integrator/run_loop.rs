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
//! 4. calls the caller's `control(fraction done)` (progress, and Ctrl-C from Python) every
//!    [`Stepper::CONTROL_STRIDE`] steps, or sooner where the steps turn out slow: every
//!    [`TIME_CHECK`] steps the loop looks at the clock, calls `control` once [`CONTROL_PERIOD`]
//!    has passed, and sets the next stride to the steps that take about that long at the rate
//!    just seen (a run that asked for thousands of contact iterations a step can take
//!    milliseconds a step; without this its first call came after the stepper's stride, or
//!    never); `false` stops every running lane with [`Error::Interrupted`]. When the control
//!    function is called never changes a result.
//!
//! A lane that fails keeps its output up to the failure ([`crate::run::RunFailure`]); the
//! others go on. When no lane is running or the grid is done, [`Stepper::end`] completes the
//! lanes still running.
//!
//! The loop is generic over the stepper and inlined into it, so the constant stepper's lanes stay
//! monomorphic (and inside its AVX2-compiled body) with no dispatch per step.

use std::time::{Duration, Instant};

use super::divergence::CHECK_STRIDE;
use crate::error::Error;

/// Aimed-at time between two calls of the caller's control function (progress, Ctrl-C).
pub(crate) const CONTROL_PERIOD: Duration = Duration::from_millis(50);

/// Steps between two looks at the clock (about 26 us on the constant stepper's fastest runs).
pub(crate) const TIME_CHECK: u64 = 64;

/// The steps to the next control call after `done` steps took `elapsed`: those that take about
/// [`CONTROL_PERIOD`] at that rate, at least one and at most `max` (the stepper's stride).
fn next_stride(done: u64, elapsed: Duration, max: u64) -> u64 {
    let per = done as f64 * CONTROL_PERIOD.as_secs_f64() / elapsed.as_secs_f64().max(1e-9);
    (per as u64).clamp(1, max)
}

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
    let mut next = S::CONTROL_STRIDE;
    let (mut last, mut last_k) = (Instant::now(), 0);
    while k < steps && stepper.running() {
        k += 1;
        let t1 = k as f64 * dt;
        stepper.advance(k, t1, control);
        if k.is_multiple_of(CHECK_STRIDE) || k == steps {
            stepper.check(k, t1);
        }
        stepper.record(k, t1);
        if k == next || (k.is_multiple_of(TIME_CHECK) && last.elapsed() >= CONTROL_PERIOD) {
            if !control(k as f64 / steps as f64) {
                stepper.stop_all(Error::Interrupted { time: t1, step: k }, k, t1);
            }
            let now = Instant::now();
            next = k + next_stride(k - last_k, now - last, S::CONTROL_STRIDE);
            (last, last_k) = (now, k);
        }
    }
    stepper.end(k, k as f64 * dt);
}

#[cfg(test)]
mod tests {
    use super::{next_stride, run, Stepper, CONTROL_PERIOD};
    use crate::error::Error;
    use std::time::Duration;

    /// A stepper whose steps take 2 ms each (a run that asked for many contact iterations).
    struct Slow {
        steps: u64,
        running: bool,
        stopped_at: Option<u64>,
    }

    impl Stepper for Slow {
        const CONTROL_STRIDE: u64 = 1 << 14;
        fn steps(&self) -> u64 {
            self.steps
        }
        fn dt(&self) -> f64 {
            1e-5
        }
        fn running(&self) -> bool {
            self.running
        }
        fn advance(&mut self, _k: u64, _t1: f64, _control: &mut dyn FnMut(f64) -> bool) {
            std::thread::sleep(Duration::from_millis(2));
        }
        fn check(&mut self, _k: u64, _t1: f64) {}
        fn record(&mut self, _k: u64, _t1: f64) {}
        fn stop_all(&mut self, error: Error, k: u64, _t: f64) {
            assert!(matches!(error, Error::Interrupted { step, .. } if step == k));
            (self.running, self.stopped_at) = (false, Some(k));
        }
        fn end(&mut self, _k: u64, _t: f64) {}
    }

    #[test]
    fn slow_steps_reach_the_control_function_within_its_period() {
        // 150 steps of 2 ms, far fewer than the stride of 16384: the control function is called
        // every 25 steps or so (50 ms), not never
        let mut slow = Slow {
            steps: 150,
            running: true,
            stopped_at: None,
        };
        let mut calls = 0;
        run(&mut slow, &mut |_| {
            calls += 1;
            true
        });
        assert!((3..=12).contains(&calls), "{calls} calls");
        // and `false` there stops the run at once
        let mut slow = Slow {
            steps: 150,
            running: true,
            stopped_at: None,
        };
        run(&mut slow, &mut |_| false);
        assert!(slow.stopped_at.is_some_and(|k| k < 150), "{:?}", slow.stopped_at);
    }

    #[test]
    fn the_control_stride_is_the_steps_of_one_period_at_the_rate_seen() {
        let max = 1 << 14;
        // fast steps: the stepper's stride
        assert_eq!(next_stride(max, Duration::from_millis(5), max), max);
        // 64 steps in 256 ms (4 ms a step): 12 steps to the next call, about 50 ms
        assert_eq!(next_stride(64, Duration::from_millis(256), max), 12);
        // a step slower than the period: every step
        assert_eq!(next_stride(1, 3 * CONTROL_PERIOD, max), 1);
    }
}
