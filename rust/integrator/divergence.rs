//! The one divergence rule of every stepper.
//!
//! Every [`CHECK_STRIDE`] steps (of an adaptive run: accepted steps, `AcceptedSteps`) and at
//! the last step, the state is checked: every unknown's displacement and velocity must be
//! finite, and every translational unknown (a displacement in metres: nodal `u, v` in a link
//! frame, global `x, y` of a pinned node, a slider's travel) must stay within the divergence
//! limit (by default 10 x the longest link), and every elastic rotation within
//! [`ROTATION_LIMIT`] (half a turn: far outside what a small-rotation beam element describes; a
//! limit in metres says nothing about an angle).
//! Both steppers also compare each clearance joint's penetration with the limit at every step (one
//! comparison per joint, which is also its finite check; an open gap of any width passes): a joint
//! whose sides follow prescribed motions can run away while every unknown stays bounded.

/// Steps between two checks of the whole state.
pub const CHECK_STRIDE: u64 = 16;

/// Largest elastic rotation before a run counts as diverged, rad.
pub const ROTATION_LIMIT: f64 = std::f64::consts::PI;

/// The first unknown `i < n` whose displacement `x(i)` or velocity `v(i)` is not finite, or whose
/// displacement exceeds `limit` (m) in magnitude if it is translational, [`ROTATION_LIMIT`] if
/// it is a rotation.
#[inline]
pub(crate) fn first_bad(
    n: usize,
    translational: impl Fn(usize) -> bool,
    x: impl Fn(usize) -> f64,
    v: impl Fn(usize) -> f64,
    limit: f64,
) -> Option<usize> {
    (0..n).position(|i| {
        let (xi, vi) = (x(i), v(i));
        !(xi.is_finite() && vi.is_finite()) || xi.abs() > if translational(i) { limit } else { ROTATION_LIMIT }
    })
}

/// The accepted steps of an adaptive run since its last check of the whole state: adaptive
/// steps check at every [`CHECK_STRIDE`]-th accepted step and at the run's last, as fixed steps
/// do, so that a state that diverged between two output instants stops within
/// [`CHECK_STRIDE`] steps rather than being carried on with ever shorter ones.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct AcceptedSteps(u64);

impl AcceptedSteps {
    /// Counts one accepted step; whether the state is to be checked after it (every
    /// [`CHECK_STRIDE`]-th, or `last`, the run's last step).
    #[inline]
    pub(crate) fn check_due(&mut self, last: bool) -> bool {
        self.0 += 1;
        if self.0 >= CHECK_STRIDE || last {
            self.0 = 0;
            true
        } else {
            false
        }
    }
}

/// [`first_bad`] on contiguous displacements `x`, velocities `v` and unknown kinds
/// `translational` (one length): first one pass over all of them without early exit or bounds
/// checks, which the compiler vectorizes, for the common case where nothing is wrong; the search
/// for the culprit only when that pass fails.
#[inline]
pub(crate) fn first_bad_in(x: &[f64], v: &[f64], translational: &[bool], limit: f64) -> Option<usize> {
    if all_within(x, v, translational, limit) {
        return None;
    }
    first_bad(translational.len(), |i| translational[i], |i| x[i], |i| v[i], limit)
}

/// Whether no unknown fails [`first_bad`]'s test (displacements `x`, velocities `v`, whether
/// each is `translational`, `limit` in m), in one pass ([`first_bad_in`]'s fast path).
#[inline]
fn all_within(x: &[f64], v: &[f64], translational: &[bool], limit: f64) -> bool {
    debug_assert!(x.len() == translational.len() && v.len() == translational.len());
    x.iter().zip(v).zip(translational).fold(true, |ok, ((&xi, &vi), &tr)| {
        let lim = if tr { limit } else { ROTATION_LIMIT };
        ok & xi.is_finite() & vi.is_finite() & (xi.abs() <= lim)
    })
}

/// Why an unknown with displacement `x` and velocity `v` failed [`first_bad`], in words.
#[cold]
pub(crate) fn reason(x: f64, v: f64, translational: bool, limit: f64) -> String {
    if !(x.is_finite() && v.is_finite()) {
        "non-finite displacement or velocity".to_string()
    } else if translational {
        format!(
            "|displacement| = {:.3e} m exceeds the divergence limit {:.3e} m",
            x.abs(),
            limit
        )
    } else {
        format!("|rotation| = {:.3e} rad exceeds half a turn (pi rad)", x.abs())
    }
}

/// The divergence error of clearance joint `name` whose penetration `pen` (m) is not finite or
/// beyond `limit` (m), at `time` (s), step `step`.
#[cold]
pub(crate) fn joint_diverged(name: &str, pen: f64, limit: f64, time: f64, step: u64) -> crate::error::Error {
    let reason = if pen.is_finite() {
        format!("penetration = {pen:.3e} m exceeds the divergence limit {limit:.3e} m")
    } else {
        "non-finite joint position".to_string()
    };
    crate::error::Error::Diverged {
        time,
        step,
        dof: format!("joint {name:?} position"),
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn translations_against_the_limit_rotations_against_half_a_turn() {
        // unknowns 0, 2 translational (m), 1 a rotation (rad); limit 1 m
        let tr = |i: usize| i != 1;
        let check = |x: [f64; 3], v: [f64; 3]| first_bad(3, tr, |i| x[i], |i| v[i], 1.0);
        assert_eq!(check([0.9, 3.0, -0.9], [1e9; 3]), None);
        assert_eq!(check([0.9, 3.2, 0.0], [0.0; 3]), Some(1));
        assert_eq!(check([0.0, 0.0, -1.1], [0.0; 3]), Some(2));
        assert_eq!(check([0.0, 0.0, 0.0], [0.0, f64::NAN, 0.0]), Some(1));
        assert_eq!(check([f64::INFINITY, 0.0, 0.0], [0.0; 3]), Some(0));
        // the one-pass test agrees
        let trs = [true, false, true];
        let all = |x: [f64; 3], v: [f64; 3], limit: f64| all_within(&x, &v, &trs, limit);
        assert!(all([0.9, 3.0, -0.9], [1e9; 3], 1.0));
        assert!(!all([0.9, 3.2, 0.0], [0.0; 3], 1.0));
        assert!(!all([0.0, 0.0, -1.1], [0.0; 3], 1.0));
        assert!(!all([0.0; 3], [0.0, f64::NAN, 0.0], 1.0));
        assert!(!all([0.0; 3], [0.0, 0.0, f64::NEG_INFINITY], 1.0));
        // an infinite limit still catches an infinite displacement
        assert!(all([1e300, 0.0, 0.0], [0.0; 3], f64::INFINITY));
        assert!(!all([0.0, 0.0, f64::NEG_INFINITY], [0.0; 3], f64::INFINITY));
        assert_eq!(
            first_bad(3, tr, |i| [0.0, 0.0, f64::INFINITY][i], |_| 0.0, f64::INFINITY),
            Some(2)
        );
        // and the slice form finds the same culprit
        assert_eq!(first_bad_in(&[0.9, 3.2, 0.0], &[0.0; 3], &trs, 1.0), Some(1));
        assert_eq!(first_bad_in(&[0.0; 3], &[0.0, 0.0, f64::NAN], &trs, 1.0), Some(2));
        assert_eq!(first_bad_in(&[0.9, 3.0, -0.9], &[1e9; 3], &trs, 1.0), None);
        assert!(reason(1.1, 0.0, true, 1.0).contains("1.100e0 m exceeds the divergence limit"));
        assert!(reason(3.2, 0.0, false, 1.0).contains("rad exceeds half a turn"));
        assert!(reason(0.0, f64::NAN, false, 1.0).starts_with("non-finite"));
    }

    #[test]
    fn adaptive_runs_check_every_stride_th_accepted_step_and_the_last() {
        let mut count = AcceptedSteps::default();
        let due: Vec<u64> = (1..=40).filter(|&k| count.check_due(k == 37)).collect();
        assert_eq!(due, vec![CHECK_STRIDE, 2 * CHECK_STRIDE, 37]);
    }
}
