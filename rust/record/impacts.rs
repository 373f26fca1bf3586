//! How the recorder tells an impact from a rebound and takes an impact's approach speed: the
//! joints' last open states, the closings after a shallow separation, the impact log's entries.

use super::*;

/// Magnitude of a force, N.
#[inline(always)]
pub(super) fn norm(f: [f64; 2]) -> f64 {
    (f[0] * f[0] + f[1] * f[1]).sqrt()
}

/// An impact of a joint at time `t` (s): counted in its extremes `e` with its normal approach
/// speed `speed` (m/s), and started in its impact log (if kept) with penetration `pen` (m) and
/// force `force` (N).
pub(super) fn enter(e: &mut JointExtremes, log: Option<&mut Vec<Impact>>, t: f64, pen: f64, force: f64, speed: f64) {
    e.impacts += 1;
    e.contact_episodes += 1;
    e.max_impact_velocity = e.max_impact_velocity.max(speed);
    e.impact_state = [speed, pen];
    if let Some(log) = log {
        log.push(Impact {
            time: t,
            speed,
            peak_force: force,
            peak_penetration: pen,
            duration: f64::NAN,
        });
    }
}

/// A closing after a separation no deeper than the joint's rebound depth ([`REBOUND_DEPTH`]): the
/// impact going on continues (the last entry of the log, if kept, is open again and takes the
/// closing state's penetration `pen`, m, and force `force`, N, into its peaks); nothing is
/// counted.
pub(super) fn rebound(e: &mut JointExtremes, log: Option<&mut Vec<Impact>>, pen: f64, force: f64) {
    e.contact_episodes += 1;
    if let Some(last) = log.and_then(|l| l.last_mut()) {
        last.duration = f64::NAN;
        last.peak_force = last.peak_force.max(force);
        last.peak_penetration = last.peak_penetration.max(pen);
    }
}

/// A joint's state taken by the recorder: time `t` (s), penetration `pen` (m), journal position
/// `q` (m) and velocity `qd` (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct JointState {
    pub(super) t: f64,
    pub(super) pen: f64,
    pub(super) q: [f64; 2],
    pub(super) qd: [f64; 2],
}

impl JointState {
    /// The state at `t` (s): penetration `pen` (m), journal position `q` (m), velocity `qd` (m/s).
    #[inline(always)]
    pub(super) fn at(t: f64, pen: f64, q: [f64; 2], qd: [f64; 2]) -> Self {
        JointState { t, pen, q, qd }
    }

    /// No state yet (all NaN).
    pub(super) const NONE: JointState = JointState {
        t: f64::NAN,
        pen: f64::NAN,
        q: [f64::NAN; 2],
        qd: [f64::NAN; 2],
    };

    /// The instant (s) and approach speed (m/s) of an impact first seen closed at an event or
    /// substep, `closing` (penetration > 0): those of whichever of the last open state (`self`)
    /// and the closing state is nearer the circle. An event-aware fixed step cuts just past the
    /// circle, and there the closing state is the crossing; an adaptive step cuts just short of
    /// it, and there the last open state is (the closing state, a substep later, has been slowed
    /// by the contact: the four-bar's first rocker-pin impact read 0.197 m/s at tol 1e-3 against
    /// 0.2181 m/s converged on fixed steps).
    pub(super) fn nearer(&self, closing: &JointState) -> (f64, f64) {
        if -self.pen < closing.pen {
            (self.t, normal_speed(self.q, self.qd))
        } else {
            (closing.t, normal_speed(closing.q, closing.qd))
        }
    }
}

/// A joint's contact status after a state `s`: `was` (closed) follows it, and at an open state
/// the deepest separation since the opening, `retreat` (m; reset at the opening), and the last
/// open state, `last`.
#[inline(always)]
pub(super) fn next_status(was: &mut bool, retreat: &mut f64, last: &mut JointState, s: JointState) {
    let closed = s.pen > 0.0;
    if !closed {
        *retreat = if *was { -s.pen } else { retreat.max(-s.pen) };
        *last = s;
    }
    *was = closed;
}

/// The impact of a log that is still going on (the last one, with no duration yet).
pub(super) fn open_impact(log: Option<&mut Vec<Impact>>) -> Option<&mut Impact> {
    log?.last_mut().filter(|i| i.duration.is_nan())
}

/// The approach speed (m/s) of an impact whose first closed state is `(q, qd)` (m, m/s), taken at
/// a step end: the normal speed of the state taken before it (`last`, open; NaN when there was
/// none), else its own.
///
/// The contact force has acted on the closing state for part of its step, and for a stiff
/// contact that is much of the approach speed: the crank-pin slider-crank's first impact gave
/// 1.165, 1.715, 2.001 and 2.101 m/s from the closing state at dt = 1e-5, 2.5e-6, 6.25e-7 and
/// 1.5625e-7 s, and 2.132, 2.129, 2.134 and 2.135 m/s from the last open state. (The
/// contact-mode classification keeps the closing state's speed: it divides the episode's peak
/// penetration, also sampled at the step ends, by it, and the two errors cancel there.)
#[inline]
pub(super) fn entry_speed(last: JointState, q: [f64; 2], qd: [f64; 2]) -> f64 {
    if last.pen.is_nan() {
        normal_speed(q, qd)
    } else {
        normal_speed(last.q, last.qd)
    }
}

/// The normal approach speed `q' . q / |q|` (m/s) of a journal at `q` (m) moving at `qd` (m/s);
/// zero at the bearing centre.
#[inline]
pub(super) fn normal_speed(q: [f64; 2], qd: [f64; 2]) -> f64 {
    let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
    if r > 0.0 {
        (qd[0] * q[0] + qd[1] * q[1]) / r
    } else {
        0.0
    }
}
