//! The one divergence rule of every stepper.
//!
//! Every [`CHECK_STRIDE`] steps and at the last step, the state is checked: every unknown's
//! displacement and velocity must be finite, and every translational unknown (a displacement in
//! metres: nodal `u, v` in a link frame, global `x, y` of a pinned node, a slider's travel) must
//! stay within the divergence limit (by default 10 x the longest link), and every elastic
//! rotation within [`ROTATION_LIMIT`] (half a turn: far outside what a small-rotation beam
//! element describes; a limit in metres says nothing about an angle). The constant stepper also
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
        assert!(reason(1.1, 0.0, true, 1.0).contains("1.100e0 m exceeds the divergence limit"));
        assert!(reason(3.2, 0.0, false, 1.0).contains("rad exceeds half a turn"));
        assert!(reason(0.0, f64::NAN, false, 1.0).starts_with("non-finite"));
    }
}
