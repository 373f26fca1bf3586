//! The parts of adaptive steps ([`crate::run::Adaptive`]) that the constant and the Newton
//! stepper share: the step levels `dt / 2^m` and their controller, the Zienkiewicz-Xie local
//! error, the counters of accepted steps, and the cubic Hermite path of a clearance joint within
//! a step (the smooth peaks between the step's ends). Each stepper keeps its own trial step, cut
//! and restart.

use crate::contact::{ContactTerms, Mat2};
use crate::run::{Adaptive, RunStats};

/// The level `m` of the next step `dt / 2^m` and the level of the shortest step `h_min`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Levels {
    level: u32,
    max_level: u32,
}

impl Levels {
    /// Level 0 (a whole output step `dt`, s) first; at most the level of `h_min` (s), and 30.
    pub(crate) fn new(dt: f64, h_min: f64) -> Self {
        Levels {
            level: 0,
            max_level: ((dt / h_min).log2().floor().max(0.0) as u32).min(30),
        }
    }

    /// The step of the current level, `dt / 2^m` (s).
    pub(crate) fn step(&self, dt: f64) -> f64 {
        dt / f64::from(1u32 << self.level.min(30))
    }

    /// Whether the current level is the shortest step's.
    pub(crate) fn at_floor(&self) -> bool {
        self.level >= self.max_level
    }

    /// After a rejected step of error `err` (over the tolerance; infinite when its iterations
    /// did not converge): the local error goes as `h^3`, so up by the levels that bring it to 0.9
    /// of the tolerance (at least one; two for an infinite error), at most to the floor.
    pub(crate) fn reject(&mut self, err: f64) {
        let up = if err.is_finite() {
            ((err / 0.729).log2() / 3.0).ceil().max(1.0) as u32
        } else {
            2
        };
        self.level = (self.level + up).min(self.max_level);
    }

    /// After an accepted step of length `h` (s) that was not cut, of error `err`: below a tenth
    /// of the tolerance, and taken at the level's own length, the next step is twice as long
    /// (up to `dt`).
    pub(crate) fn accept(&mut self, err: f64, h: f64, dt: f64) {
        if err <= 0.1 && self.level > 0 && h == self.step(dt) {
            self.level -= 1;
        }
    }
}

/// The Zienkiewicz-Xie estimate of a step's local displacement error (see [`local_error`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LocalError {
    /// Largest over the unknowns of the error over its tolerance `atol + rtol |y|` (the
    /// controller's measure; infinite when not finite).
    pub ratio: f64,
    /// Largest absolute error over the unknowns, m (rad for rotations).
    pub abs: f64,
    /// Largest `|y|` over the unknowns at the step's end, m (rad for rotations).
    pub y_max: f64,
}

/// The Zienkiewicz-Xie estimate of the local displacement error of a step of length `h` (s),
/// `c |a_(n+1) - a_n| h^2` with `c = |beta - 1/6|` (at least 1/24), over the tolerance
/// `atol + rtol |y|`, largest over the unknowns given as `(a_(n+1), a_n, y)` (infinite when not
/// finite); with the largest absolute error and the largest `|y|` (the bookkeeping of the
/// run's achieved-accuracy estimate, [`count_step`]).
pub(crate) fn local_error(
    beta: f64,
    h: f64,
    unknowns: impl Iterator<Item = (f64, f64, f64)>,
    tol: &Adaptive,
) -> LocalError {
    let c = (beta - 1.0 / 6.0).abs().max(1.0 / 24.0) * h * h;
    // plain comparisons (one `maxsd` each, where `f64::max`'s NaN rule costs more): the
    // largest ratio, and the sum of the ratios, NaN when any is (they are >= 0)
    let (mut e, mut sum) = (0.0f64, 0.0f64);
    let (mut abs, mut y_max) = (0.0f64, 0.0f64);
    for (a1, a0, y) in unknowns {
        let d = c * (a1 - a0).abs();
        let ya = y.abs();
        let r = d / (tol.atol + tol.rtol * ya);
        e = if r > e { r } else { e };
        sum += r;
        abs = if d > abs { d } else { abs };
        y_max = if ya > y_max { ya } else { y_max };
    }
    let ratio = if sum.is_nan() || !e.is_finite() {
        f64::INFINITY
    } else {
        e
    };
    LocalError { ratio, abs, y_max }
}

/// The factor between the sum of the accepted steps' local errors and the achieved-accuracy
/// estimates of [`count_step`] and [`ForceErrors`]: on the impact oscillator of
/// `tests/test_adaptive.py` (an exact solution) the plain sum was 0.22 to 0.30 of the largest
/// trajectory error over the run for tol 1e-2 to 1e-5 (the Zienkiewicz-Xie estimate sees the
/// displacement part of a step's error, not the velocity part that becomes a phase error, and
/// an impact amplifies an error in its timing); 10 makes the estimate an upper one by a factor
/// of 2 to 3 there (a calibration on that one problem, checked on the slider-yoke's peak force).
pub const ERROR_ESTIMATE_FACTOR: f64 = 10.0;

/// Counts an accepted step of length `h` (s) of local error `err` in `stats`: the steps, the
/// shortest and longest, and the achieved-accuracy estimate of the trajectory,
/// `RunStats::error_estimate` = [`ERROR_ESTIMATE_FACTOR`] times the sum of the accepted steps'
/// largest absolute local errors over the largest `|y|` so far (every local error adding up,
/// as a phase error does, none decaying).
pub(crate) fn count_step(stats: &mut RunStats, h: f64, err: &LocalError) {
    stats.adaptive_steps += 1;
    stats.min_step = if stats.min_step > 0.0 { stats.min_step.min(h) } else { h };
    stats.max_step = stats.max_step.max(h);
    stats.local_error_sum += err.abs;
    stats.largest_displacement = stats.largest_displacement.max(err.y_max);
    stats.error_estimate = if stats.largest_displacement > 0.0 {
        ERROR_ESTIMATE_FACTOR * stats.local_error_sum / stats.largest_displacement
    } else if stats.local_error_sum > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
}

/// The achieved-accuracy estimate of each clearance joint's largest contact force
/// (`RunStats::peak_force_error_estimate`): the joint's relative displacement and velocity carry
/// the sums of the accepted steps' local errors up to the instant of the peak, `E_q = sum e_q`
/// (m) and `E_v = sum e_v` (m/s); at the peak they go through the law's terms there,
/// `|dF| = |k| E_q + |c| E_v` (the secant stiffness and damping, N/m and N s/m, row-sum norms),
/// times [`ERROR_ESTIMATE_FACTOR`], over the peak force. `e_q` is the Zienkiewicz-Xie error of
/// the joint's relative displacement and `e_v` its velocity error from the second difference of
/// the joint's relative acceleration ([`Self::add_joint`]; on the Newton stepper that
/// acceleration is the joint's velocity map applied to the unknowns' accelerations).
#[derive(Debug, Clone, Default)]
pub(crate) struct ForceErrors {
    /// `E_q` per joint, m.
    eq: Vec<f64>,
    /// `E_v` per joint, m/s.
    ev: Vec<f64>,
    /// The largest force so far per joint, N.
    peak: Vec<f64>,
    /// The relative error estimate of that force per joint.
    est: Vec<f64>,
    /// Per joint, the change of its relative acceleration over the last accepted step, m/s^2,
    /// and that step's length, s (0: none to difference, at the start and after a cut).
    prev_da: Vec<[f64; 2]>,
    prev_h: Vec<f64>,
}

fn norm_inf(m: &Mat2) -> f64 {
    (m[0][0].abs() + m[0][1].abs()).max(m[1][0].abs() + m[1][1].abs())
}

impl ForceErrors {
    /// For `joints` clearance joints (allocates; before the time loop).
    pub(crate) fn new(joints: usize) -> Self {
        ForceErrors {
            eq: vec![0.0; joints],
            ev: vec![0.0; joints],
            peak: vec![0.0; joints],
            est: vec![0.0; joints],
            prev_da: vec![[0.0; 2]; joints],
            prev_h: vec![0.0; joints],
        }
    }

    /// Adds an accepted step of length `h` (s) of joint `j` whose relative acceleration
    /// changed by `da` (m/s^2), under Newmark `beta`, `gamma`. Displacement: the Zienkiewicz-Xie
    /// `c h^2 |da|`. Velocity: `|gamma - 1/2| h |da|` plus `h^3 |a''| / 12`, `a''` from the
    /// second difference of the joint's acceleration over this step and the last one (the
    /// bound `h |da| / 6` where there is no last one: at the start and after a cut, whose
    /// restart makes the acceleration jump). `cut`: this step ended at a cut.
    pub(crate) fn add_joint(&mut self, j: usize, da: [f64; 2], h: f64, (beta, gamma): (f64, f64), cut: bool) {
        let c = (beta - 1.0 / 6.0).abs().max(1.0 / 24.0);
        let n = da[0].hypot(da[1]);
        self.eq[j] += c * h * h * n;
        let (p, hp) = (self.prev_da[j], self.prev_h[j]);
        let third = if hp > 0.0 {
            let s = 2.0 / (h + hp);
            let add = [s * (da[0] / h - p[0] / hp), s * (da[1] / h - p[1] / hp)];
            h * h * h * add[0].hypot(add[1]) / 12.0
        } else {
            h * n / 6.0
        };
        self.ev[j] += (gamma - 0.5).abs() * h * n + third;
        self.prev_da[j] = da;
        self.prev_h[j] = if cut { 0.0 } else { h };
    }

    /// Whether `force` (N) is above joint `j`'s largest force so far.
    pub(crate) fn is_peak(&self, j: usize, force: f64) -> bool {
        force > self.peak[j]
    }

    /// Joint `j`'s largest force so far is `force` (N), with the law's `terms` there.
    pub(crate) fn set_peak(&mut self, j: usize, force: f64, terms: &ContactTerms) {
        self.peak[j] = force;
        let df = norm_inf(&terms.k) * self.eq[j] + norm_inf(&terms.c) * self.ev[j];
        self.est[j] = ERROR_ESTIMATE_FACTOR * df / force;
    }

    /// The largest relative estimate over the joints that touched (0 when none did) into
    /// `stats`.
    pub(crate) fn to_stats(&self, stats: &mut RunStats) {
        stats.peak_force_error_estimate = self
            .est
            .iter()
            .fold(0.0, |a: f64, &e| if e.is_nan() { f64::INFINITY } else { a.max(e) });
    }
}

/// The 7 interior points `s = k/8` of a step of length `h` (s) on the cubic Hermite path of a
/// joint's relative displacement with values `q0`, `q1` (m) and rates `v0`, `v1` (m/s) at the
/// step's ends: `(s, q(s), qdot(s))`.
pub(crate) fn hermite_points(
    (q0, v0): ([f64; 2], [f64; 2]),
    (q1, v1): ([f64; 2], [f64; 2]),
    h: f64,
) -> impl Iterator<Item = (f64, [f64; 2], [f64; 2])> {
    (1..8).map(move |k| {
        let s = f64::from(k) / 8.0;
        let (s2, s3) = (s * s, s * s * s);
        let (h00, h10, h01, h11) = (
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        );
        let (d00, d10, d01, d11) = (
            6.0 * s2 - 6.0 * s,
            3.0 * s2 - 4.0 * s + 1.0,
            -6.0 * s2 + 6.0 * s,
            3.0 * s2 - 2.0 * s,
        );
        let mut q = [0.0; 2];
        let mut qd = [0.0; 2];
        for i in 0..2 {
            q[i] = h00 * q0[i] + h10 * h * v0[i] + h01 * q1[i] + h11 * h * v1[i];
            qd[i] = (d00 * q0[i] + d01 * q1[i]) / h + d10 * v0[i] + d11 * v1[i];
        }
        (s, q, qd)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_points_follow_a_cubic_exactly() {
        // q(t) = t^3 - t on [0.5, 0.5 + h] is its own cubic Hermite interpolant
        let (t0, h) = (0.5, 0.25);
        let q = |t: f64| [t * t * t - t, 2.0 * t];
        let v = |t: f64| [3.0 * t * t - 1.0, 2.0];
        let pts: Vec<_> = hermite_points((q(t0), v(t0)), (q(t0 + h), v(t0 + h)), h).collect();
        assert_eq!(pts.len(), 7);
        for (s, x, xd) in pts {
            let t = t0 + s * h;
            for i in 0..2 {
                assert!((x[i] - q(t)[i]).abs() < 1e-14 && (xd[i] - v(t)[i]).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn joint_velocity_errors_take_the_second_difference_of_the_acceleration() {
        // a(t) = t^2 along x: a'' = 2; over steps of 0.1 and then 0.2 s the second difference
        // gives it exactly; the first step (nothing to difference) takes the bound h |da| / 6
        let mut f = ForceErrors::new(1);
        let a = |t: f64| t * t;
        let nm = (0.25, 0.5);
        f.add_joint(0, [a(0.1) - a(0.0), 0.0], 0.1, nm, false);
        assert!((f.ev[0] - 0.1 * 0.01 / 6.0).abs() < 1e-15);
        assert!((f.eq[0] - 0.01 * 0.01 / 12.0).abs() < 1e-15);
        f.add_joint(0, [a(0.3) - a(0.1), 0.0], 0.2, nm, false);
        let third = 0.2f64.powi(3) * 2.0 / 12.0;
        assert!((f.ev[0] - 0.1 * 0.01 / 6.0 - third).abs() < 1e-15);
        // a cut leaves nothing to difference: the next step takes the bound again
        f.add_joint(0, [1.0, 0.0], 0.1, nm, true);
        let before = f.ev[0];
        f.add_joint(0, [2.0, 0.0], 0.1, nm, false);
        assert!((f.ev[0] - before - 0.1 * 2.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn levels_go_up_by_the_h3_law_and_down_one_at_a_time() {
        let mut l = Levels::new(1e-3, 1e-3 / 1024.0);
        assert_eq!((l.step(1e-3), l.at_floor()), (1e-3, false));
        l.reject(0.729 * 8.0 * 0.999); // just under 2^3 over 0.9^3: one level
        assert_eq!(l.step(1e-3), 5e-4);
        l.reject(64.0); // (64/0.729)^(1/3) = 4.4: three levels
        assert_eq!(l.step(1e-3), 6.25e-5);
        l.accept(0.05, 6.25e-5, 1e-3);
        assert_eq!(l.step(1e-3), 1.25e-4);
        l.accept(0.05, 1e-4, 1e-3); // not at the level's own length: stays
        assert_eq!(l.step(1e-3), 1.25e-4);
        for _ in 0..4 {
            l.reject(f64::INFINITY); // two levels each, up to the floor (level 10)
        }
        assert!(l.at_floor() && l.step(1e-3) == 1e-3 / 1024.0);
    }
}
