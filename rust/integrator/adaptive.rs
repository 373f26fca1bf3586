//! The parts of adaptive steps ([`crate::run::Adaptive`]) that the constant and the Newton
//! stepper share: the step levels `h_max / 2^m` and their controller, the Zienkiewicz-Xie local
//! error, the counters of accepted steps, the cubic Hermite path of a clearance joint within a
//! step (the smooth peaks between the step's ends, a contact between open ends, the first
//! estimate of a cut) and the interpolated state of an output instant within a step (dense
//! output). Each stepper keeps its own trial step, cut
//! and restart.

use super::norm2;
use crate::contact::{ContactTerms, Mat2};
use crate::error::Error;
use crate::run::{Adaptive, RunStats};

/// Accepted steps in a row at the shortest step over the error tolerance after which an
/// adaptive run stops ([`floor_error`]): a step at the floor is accepted over the tolerance (a
/// discontinuity the error estimate cannot resolve), but a run of them means no step can meet
/// the tolerance, and the run would go on at `h_min` for up to `(t_end - t) / h_min` steps
/// (a damping of 1e20 N s/m: 2e10 steps of 1.8e-14 s, hours, in a fuzz case).
pub(crate) const FLOOR_RUN_LIMIT: u32 = 1000;

/// The error of a run stopped by [`FLOOR_RUN_LIMIT`] steps in a row at the shortest step `h`
/// (s), at time `t` (s), output step `step`.
pub(crate) fn floor_error(t: f64, step: u64, h: f64) -> Error {
    Error::Diverged {
        time: t,
        step,
        dof: "the adaptive step".to_string(),
        reason: format!(
            "{FLOOR_RUN_LIMIT} steps in a row at the shortest step, h_min = {h:.3e} s, exceed the \
             local error tolerance: no step meets it (a contact stiffness or damping far too large \
             for the masses it acts on?); a larger tol or a fixed dt runs the model"
        ),
    }
}

/// Accepted steps per block of an adaptive run's crawl test ([`Levels::count_crawl`]): a block
/// whose steps average less than [`CRAWL_RATIO`] times the output step stops the run
/// ([`crawl_error`]). Such steps are within the tolerance and above the floor, but the model asks
/// for steps no run can afford: a fuzz case's contact of 1e20 N/m took steps of 2.4e-14 to 1.5e-12
/// s against an output step of 1.1e-6 s, 3.3 million a microsecond of simulated time (minutes
/// for its 2e-5 s). Real models stay far above it: the crank-pin slider-crank at `tol=1e-8`
/// (1.08 million steps in 2 ms) averages 9e-4 of its output step; their shortest steps are
/// isolated event cuts.
pub(crate) const CRAWL_BLOCK: u32 = 1_000_000;

/// The average step of a [`CRAWL_BLOCK`], as a fraction of the output step, below which the run
/// stops: `2^-20`, about 1e-6.
pub(crate) const CRAWL_RATIO: f64 = 1.0 / 1_048_576.0;

/// The error of a run stopped by the crawl test: a block of [`CRAWL_BLOCK`] accepted steps whose
/// average `mean` (s) is below `limit` (s), ending at time `t` (s), output step `step`; `t_end`
/// (s) is the run's end.
pub(crate) fn crawl_error(t: f64, step: u64, mean: f64, limit: f64, t_end: f64) -> Error {
    Error::Diverged {
        time: t,
        step,
        dof: "the adaptive step".to_string(),
        reason: format!(
            "{CRAWL_BLOCK} accepted steps averaged {mean:.3e} s, below {limit:.3e} s (1e-6 of the \
             output step): the rest of the run would take about {:.1e} more steps (a contact \
             stiffness or damping far too large for the masses it acts on?); a larger tol or a \
             fixed dt runs the model",
            (t_end - t).max(0.0) / mean
        ),
    }
}

/// Trial steps of an adaptive run between two calls of the caller's control function (progress,
/// Ctrl-C from Python): the run loop calls it every so many output steps, and an output interval
/// may hold any number of adaptive steps (millions in a fuzz case), so the adaptive loops call it
/// too ([`ControlTicker`]).
pub(crate) const CONTROL_STRIDE: u32 = 1024;

/// Counts an adaptive loop's trial steps and calls the control function every
/// [`CONTROL_STRIDE`]-th.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ControlTicker(u32);

impl ControlTicker {
    /// Counts a trial step; at every [`CONTROL_STRIDE`]-th, `control(fraction)` (the fraction
    /// of the run done) decides: false when the run is to stop ([`Error::Interrupted`]).
    #[inline]
    pub(crate) fn tick(&mut self, control: &mut dyn FnMut(f64) -> bool, fraction: f64) -> bool {
        self.0 += 1;
        if self.0 < CONTROL_STRIDE {
            return true;
        }
        self.0 = 0;
        control(fraction)
    }
}

/// The level `m` of the next step `h_max / 2^m`, and the level of the shortest step `h_min`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Levels {
    h_max: f64,
    level: u32,
    max_level: u32,
    /// Accepted steps in a row at the floor over the tolerance ([`Self::count_floor`]).
    floor_run: u32,
    /// [`CRAWL_RATIO`] times the output step (s); the accepted steps of the current block of the
    /// crawl test and their total length (s) ([`Self::count_crawl`]).
    crawl_h: f64,
    crawl_steps: u32,
    crawl_time: f64,
}

/// The deepest level: `h_max / 2^60`.
const LEVELS: u32 = 60;

impl Levels {
    /// Steps `h_max / 2^m` (s), at most the level of `h_min` (s); the first at the longest level
    /// not above `h_start` (s: the output step, so that a run starts as short as its grid).
    pub(crate) fn new(h_max: f64, h_min: f64, h_start: f64) -> Self {
        let max_level = ((h_max / h_min).log2().floor().max(0.0) as u32).min(LEVELS);
        let start = (h_max / h_start.min(h_max)).log2().ceil().max(0.0) as u32;
        Levels {
            h_max,
            level: start.min(max_level),
            max_level,
            floor_run: 0,
            crawl_h: h_start * CRAWL_RATIO,
            crawl_steps: 0,
            crawl_time: 0.0,
        }
    }

    /// Counts an accepted step of length `h` (s) into the crawl test's block; at the end of a
    /// block of [`CRAWL_BLOCK`] steps, `Some((mean, limit))` when their average `mean` (s) was
    /// below `limit`, [`CRAWL_RATIO`] times the output step (the run is to stop with
    /// [`crawl_error`]), else a new block begins.
    pub(crate) fn count_crawl(&mut self, h: f64) -> Option<(f64, f64)> {
        self.crawl_steps += 1;
        self.crawl_time += h;
        if self.crawl_steps < CRAWL_BLOCK {
            return None;
        }
        let mean = self.crawl_time / f64::from(CRAWL_BLOCK);
        self.crawl_steps = 0;
        self.crawl_time = 0.0;
        (mean < self.crawl_h).then_some((mean, self.crawl_h))
    }

    /// The step of the current level, `h_max / 2^m` (s; exact: a power of two).
    pub(crate) fn step(&self) -> f64 {
        self.h_max * 0.5f64.powi(self.level as i32)
    }

    /// Counts an accepted step, `over` the tolerance (at the floor) or not; true when
    /// [`FLOOR_RUN_LIMIT`] accepted steps in a row were over it (the run is to stop with
    /// [`floor_error`]).
    pub(crate) fn count_floor(&mut self, over: bool) -> bool {
        self.floor_run = if over { self.floor_run + 1 } else { 0 };
        self.floor_run >= FLOOR_RUN_LIMIT
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
            ((err / 0.729).log2() / 3.0).ceil().clamp(1.0, f64::from(LEVELS)) as u32
        } else {
            2
        };
        self.level = (self.level + up).min(self.max_level);
    }

    /// After an accepted step of length `h` (s) that was not cut, of error `err`: below a tenth
    /// of the tolerance, and taken at the level's own length, the next step is twice as long
    /// (up to `h_max`).
    pub(crate) fn accept(&mut self, err: f64, h: f64) {
        if err <= 0.1 && self.level > 0 && h == self.step() {
            self.level -= 1;
        }
    }
}

/// The cubic Hermite weights at the fraction `s` (0..=1) of a step: of `y0`, `h v0`, `y1`,
/// `h v1` in `y(s)`, and their derivatives in `s` (`h` times the weights of `y0`, `v0`, `y1`,
/// `v1` in `ydot(s)` for the first and third, the weights themselves for the second and fourth).
fn hermite_weights(s: f64) -> ([f64; 4], [f64; 4]) {
    let (s2, s3) = (s * s, s * s * s);
    (
        [
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        ],
        [
            6.0 * s2 - 6.0 * s,
            3.0 * s2 - 4.0 * s + 1.0,
            -6.0 * s2 + 6.0 * s,
            3.0 * s2 - 2.0 * s,
        ],
    )
}

/// The displacements at the fraction `s` (0..=1) of a step of length `h` (s) from `(y0, v0)`
/// to `(y1, v1)` on the cubic Hermite interpolant of the ends' values and rates (`O(h^4)`),
/// into `y`. The dense output of adaptive steps that span output instants where only the
/// displacements are recorded (the constant stepper's node histories).
pub(crate) fn interpolate_displacements(
    (y0, v0): (&[f64], &[f64]),
    (y1, v1): (&[f64], &[f64]),
    h: f64,
    s: f64,
    y: &mut [f64],
) {
    let (w, _) = hermite_weights(s);
    let (h00, h10, h01, h11) = (w[0], w[1] * h, w[2], w[3] * h);
    let n = y.len();
    assert!([y0, v0, y1, v1].iter().all(|x| x.len() == n));
    for i in 0..n {
        y[i] = h00 * y0[i] + h10 * v0[i] + h01 * y1[i] + h11 * v1[i];
    }
}

/// The state at the fraction `s` (0..=1) of a step of length `h` (s) from `(y0, v0, a0)` to
/// `(y1, v1, a1)`, into `(y, v, a)`: displacements as [`interpolate_displacements`],
/// velocities the interpolant's derivative, accelerations linear between the ends (Newmark's
/// own assumption within a step). The dense output of the Newton stepper's adaptive steps.
#[allow(clippy::too_many_arguments)]
pub(crate) fn interpolate_state(
    (y0, v0, a0): (&[f64], &[f64], &[f64]),
    (y1, v1, a1): (&[f64], &[f64], &[f64]),
    h: f64,
    s: f64,
    y: &mut [f64],
    v: &mut [f64],
    a: &mut [f64],
) {
    interpolate_displacements((y0, v0), (y1, v1), h, s, y);
    let (_, d) = hermite_weights(s);
    let hr = 1.0 / h;
    let (d00, d10, d01, d11) = (d[0] * hr, d[1], d[2] * hr, d[3]);
    let n = y.len();
    assert!(v.len() == n && a.len() == n && a0.len() == n && a1.len() == n);
    for i in 0..n {
        v[i] = d00 * y0[i] + d01 * y1[i] + d10 * v0[i] + d11 * v1[i];
        a[i] = (1.0 - s) * a0[i] + s * a1[i];
    }
}

/// Whether the cubic Hermite path of a clearance joint's relative displacement over a step of
/// length `h` (s), open at both ends (`q0`, `q1`, m, with rates `v0`, `v1`, m/s), passes
/// through the clearance circle of radius `c` (m) at one of [`hermite_points`]: a contact the
/// step would step across without locating it (a grazing impact shorter than the step). The
/// adaptive steppers reject such a step and halve it.
pub(crate) fn enters_within(q0v0: ([f64; 2], [f64; 2]), q1v1: ([f64; 2], [f64; 2]), h: f64, c: f64) -> bool {
    let (q0, q1) = (q0v0.0, q1v1.0);
    if !(norm2(q0) <= c && norm2(q1) <= c) {
        return false;
    }
    hermite_points(q0v0, q1v1, h).any(|(_, q, _)| norm2(q) > c)
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

impl LocalError {
    /// The error of a trial step whose iterations did not converge: infinite, so the step is
    /// rejected (and shortened by two levels) unless it is at the floor.
    pub(crate) const NOT_CONVERGED: LocalError = LocalError {
        ratio: f64::INFINITY,
        abs: f64::INFINITY,
        y_max: 0.0,
    };
}

/// The length (m) by which the local error of adaptive steps weighs a beam node's rotation
/// unknown (rad), for an element of length `le` (m): the largest transverse displacement a unit
/// nodal rotation makes within the element, `(4/27) le` (the cubic Hermite shape function
/// `le xi (1 - xi)^2` at `xi = 1/3`). A rotation then counts as the displacement it makes; a
/// rigid link's rotation counts by its length instead (it moves the far end by that much).
pub(crate) fn rotation_lever(le: f64) -> f64 {
    le * (4.0 / 27.0)
}

/// The coefficient `c` of the Zienkiewicz-Xie estimate `c h^2 |a_(n+1) - a_n|` of a Newmark
/// step's local displacement error: `|beta - 1/6|`, at least 1/24 (where `beta = 1/6` leaves
/// the next order).
pub(crate) fn zx_coefficient(beta: f64) -> f64 {
    (beta - 1.0 / 6.0).abs().max(1.0 / 24.0)
}

/// The Zienkiewicz-Xie estimate of the local displacement error of a step of length `h` (s),
/// `c |a_(n+1) - a_n| h^2` with `c = |beta - 1/6|` (at least 1/24, [`zx_coefficient`]), over the tolerance
/// `atol + rtol |y|`, largest over the unknowns given as `(a_(n+1), a_n, y)` (infinite when not
/// finite); with the largest absolute error and the largest `|y|` (the bookkeeping of the
/// run's achieved-accuracy estimate, [`count_step`]).
pub(crate) fn local_error(
    beta: f64,
    h: f64,
    unknowns: impl Iterator<Item = (f64, f64, f64)>,
    tol: &Adaptive,
) -> LocalError {
    let c = zx_coefficient(beta) * h * h;
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

/// The factor between a joint's summed local errors through the law's terms at the peak and the
/// peak-force estimate of [`ForceErrors`]: on the slider-yoke Table 1 scene that sum was 0.036
/// to 0.042 of the actual peak-force error against the converged reference for tol 0.3 to 1e-3
/// on both steppers (adaptive steps long in free flight build an error of the approach speed
/// that the joint's own local errors see only in part); 40 makes the estimate an upper one by
/// 1.4 to 1.7 there (`tests/test_adaptive.py`; a calibration on that one scene).
pub const FORCE_ERROR_FACTOR: f64 = 40.0;

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
/// times [`FORCE_ERROR_FACTOR`], over the peak force. `e_q` is the Zienkiewicz-Xie error of
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
    /// Per joint, the third-order velocity error the last step took for want of a second
    /// difference (0 when it had one), m/s, and the last second difference found, m/s^4 (NaN
    /// before any).
    standin: Vec<f64>,
    last_a2: Vec<f64>,
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
            standin: vec![0.0; joints],
            last_a2: vec![f64::NAN; joints],
        }
    }

    /// Adds an accepted step of length `h` (s) of joint `j` whose relative acceleration
    /// changed by `da` (m/s^2), under Newmark `beta`, `gamma`. Displacement: the Zienkiewicz-Xie
    /// `c h^2 |da|`. Velocity: `|gamma - 1/2| h |da|` plus `h^3 |a''| / 12`, `a''` from the
    /// second difference of the joint's acceleration over this step and the last one. Where
    /// there is no last one (after a cut, whose restart makes the acceleration jump) the last
    /// second difference found stands in for it, and at the start, before any, the bound
    /// `h |da| / 6`; the next step's second difference then replaces that stand-in with its own
    /// estimate for the step. `cut`: this step ended at a cut.
    pub(crate) fn add_joint(&mut self, j: usize, da: [f64; 2], h: f64, (beta, gamma): (f64, f64), cut: bool) {
        let (eq, third, a2) = self.local(j, da, h, beta);
        self.eq[j] += eq;
        self.ev[j] += (gamma - 0.5).abs() * h * norm2(da) + third;
        if let Some(a2) = a2 {
            // the last step took a stand-in: its own third-order term from this difference
            let hp = self.prev_h[j];
            if self.standin[j] > 0.0 {
                self.ev[j] += hp * hp * hp * a2 / 12.0 - self.standin[j];
            }
            self.standin[j] = 0.0;
            self.last_a2[j] = a2;
        } else {
            self.standin[j] = third;
        }
        self.prev_da[j] = da;
        self.prev_h[j] = if cut { 0.0 } else { h };
    }

    /// Joint `j`'s local displacement error (m), the third-order part of its velocity error
    /// (m/s) over a step of length `h` (s) whose relative acceleration changed by `da` (m/s^2),
    /// and `|a''|` (m/s^4) where the second difference with the last step gives it (see
    /// [`Self::add_joint`]).
    fn local(&self, j: usize, da: [f64; 2], h: f64, beta: f64) -> (f64, f64, Option<f64>) {
        let c = zx_coefficient(beta);
        let n = norm2(da);
        let (p, hp) = (self.prev_da[j], self.prev_h[j]);
        let h3 = h * h * h;
        if hp > 0.0 {
            let s = 2.0 / (h + hp);
            let add = [s * (da[0] / h - p[0] / hp), s * (da[1] / h - p[1] / hp)];
            let a2 = norm2(add);
            (c * h * h * n, h3 * a2 / 12.0, Some(a2))
        } else if self.last_a2[j].is_finite() {
            (c * h * h * n, h3 * self.last_a2[j] / 12.0, None)
        } else {
            (c * h * h * n, h * n / 6.0, None)
        }
    }

    /// Whether `force` (N) is above joint `j`'s largest force so far.
    pub(crate) fn is_peak(&self, j: usize, force: f64) -> bool {
        force > self.peak[j]
    }

    /// Joint `j`'s largest force so far is `force` (N), with the law's `terms` there.
    pub(crate) fn set_peak(&mut self, j: usize, force: f64, terms: &ContactTerms) {
        self.peak[j] = force;
        let df = norm_inf(&terms.k) * self.eq[j] + norm_inf(&terms.c) * self.ev[j];
        self.est[j] = FORCE_ERROR_FACTOR * df / force;
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

/// The point at the fraction `s` (0..=1) of a step of length `h` (s) on the cubic Hermite path
/// of a joint's relative displacement with values `q0`, `q1` (m) and rates `v0`, `v1` (m/s) at
/// the step's ends: `(q(s), qdot(s))`.
pub(crate) fn hermite_at(
    (q0, v0): ([f64; 2], [f64; 2]),
    (q1, v1): ([f64; 2], [f64; 2]),
    h: f64,
    s: f64,
) -> ([f64; 2], [f64; 2]) {
    let ([h00, h10, h01, h11], [d00, d10, d01, d11]) = hermite_weights(s);
    let mut q = [0.0; 2];
    let mut qd = [0.0; 2];
    for i in 0..2 {
        q[i] = h00 * q0[i] + h10 * h * v0[i] + h01 * q1[i] + h11 * h * v1[i];
        qd[i] = (d00 * q0[i] + d01 * q1[i]) / h + d10 * v0[i] + d11 * v1[i];
    }
    (q, qd)
}

/// The 7 interior points `s = k/8` of a step of length `h` (s) on the cubic Hermite path of a
/// joint's relative displacement ([`hermite_at`]): `(s, q(s), qdot(s))`.
pub(crate) fn hermite_points(
    start: ([f64; 2], [f64; 2]),
    end: ([f64; 2], [f64; 2]),
    h: f64,
) -> impl Iterator<Item = (f64, [f64; 2], [f64; 2])> {
    (1..8).map(move |k| {
        let s = f64::from(k) / 8.0;
        let (q, qd) = hermite_at(start, end, h, s);
        (s, q, qd)
    })
}

/// The first crossing of joint's clearance circle of radius `c` (m) on the cubic Hermite path
/// of its relative displacement over a step (ends `start`, `end` as in [`hermite_at`], length
/// `h`, s), as a fraction of the step: the first of 16 equal parts where the status changes
/// from the start's, bisected to 1e-9; `fallback` where the path shows no change (its ends
/// disagree with the integrated ones' statuses). The first estimate of an adaptive step's cut,
/// `O(h^4)` off the integrated path's crossing where the linear one, from the end penetrations
/// alone, is `O(h^2)`: the cut's regula falsi, each of whose tries costs a factorization and a
/// step, then often ends at its first try.
pub(crate) fn hermite_crossing(
    start: ([f64; 2], [f64; 2]),
    end: ([f64; 2], [f64; 2]),
    h: f64,
    c: f64,
    fallback: f64,
) -> f64 {
    let closed = |s: f64| {
        let (q, _) = hermite_at(start, end, h, s);
        norm2(q) > c
    };
    let was = closed(0.0);
    let Some(k) = (1..=16).find(|&k| closed(f64::from(k) / 16.0) != was) else {
        return fallback;
    };
    let (mut lo, mut hi) = (f64::from(k - 1) / 16.0, f64::from(k) / 16.0);
    while hi - lo > 1e-9 {
        let mid = 0.5 * (lo + hi);
        if closed(mid) == was {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_of_floor_steps_stops_at_the_limit_and_one_within_the_tolerance_resets_it() {
        let mut l = Levels::new(1.0, 1e-3, 1.0);
        for _ in 0..FLOOR_RUN_LIMIT - 1 {
            assert!(!l.count_floor(true));
        }
        assert!(
            !l.count_floor(false),
            "a step within the tolerance ends the run of floor steps"
        );
        for _ in 0..FLOOR_RUN_LIMIT - 1 {
            assert!(!l.count_floor(true));
        }
        assert!(l.count_floor(true));
        let e = floor_error(0.5, 3, 1e-14);
        assert!(
            e.to_string().contains("1000 steps in a row at the shortest step"),
            "{e}"
        );
    }

    #[test]
    fn the_rotation_lever_is_the_largest_displacement_a_unit_nodal_rotation_makes_in_a_beam_element() {
        // the beam element's own shape functions: a unit rotation at either node, every other
        // nodal value zero, sampled finely over the element
        let le = 0.0375;
        let section = crate::model::BeamSection {
            length: 8.0 * le,
            elements: 8,
            youngs_modulus: 2e11,
            density: 7800.0,
            damping: 0.0,
            area: 1e-4,
            inertia: 1e-9,
        };
        let element = section.element(false);
        for node in [2, 5] {
            let mut q = crate::element::Vec6::zeros();
            q[node] = 1.0;
            let largest = (0..=3000)
                .map(|k| element.transverse_at(k as f64 / 3000.0, &q).abs())
                .fold(0.0, f64::max);
            assert!(
                (largest - rotation_lever(le)).abs() <= 1e-9 * le,
                "{largest} against {}",
                rotation_lever(le)
            );
        }
    }

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
        // until the second step's difference gives its own h^3 a'' / 12
        let mut f = ForceErrors::new(1);
        let a = |t: f64| t * t;
        let nm = (0.25, 0.5);
        f.add_joint(0, [a(0.1) - a(0.0), 0.0], 0.1, nm, false);
        assert!((f.ev[0] - 0.1 * 0.01 / 6.0).abs() < 1e-15);
        assert!((f.eq[0] - 0.01 * 0.01 / 12.0).abs() < 1e-15);
        f.add_joint(0, [a(0.3) - a(0.1), 0.0], 0.2, nm, false);
        let third = |h: f64| h * h * h * 2.0 / 12.0;
        assert!((f.ev[0] - third(0.1) - third(0.2)).abs() < 1e-15);
        // a cut leaves nothing to difference: the next step takes the last second difference
        // (the cut step's: 2 / 0.3 (1 / 0.1 - 0.08 / 0.2) = 64) as a stand-in, and the one
        // after it replaces that with its own
        f.add_joint(0, [1.0, 0.0], 0.1, nm, true);
        let before = f.ev[0];
        f.add_joint(0, [2.0, 0.0], 0.1, nm, false);
        assert!((f.ev[0] - before - 0.1f64.powi(3) * 64.0 / 12.0).abs() < 1e-12);
        f.add_joint(0, [2.2, 0.0], 0.1, nm, false);
        // a'' = (2.2 / 0.1 - 2 / 0.1) / 0.1 = 20 for both steps
        assert!((f.ev[0] - before - 2.0 * 0.1f64.powi(3) * 20.0 / 12.0).abs() < 1e-12);
    }

    #[test]
    fn levels_go_up_by_the_h3_law_and_down_one_at_a_time() {
        let mut l = Levels::new(1e-3, 1e-3 / 1024.0, 1e-3);
        assert_eq!((l.step(), l.at_floor()), (1e-3, false));
        l.reject(0.729 * 8.0 * 0.999); // just under 2^3 over 0.9^3: one level
        assert_eq!(l.step(), 5e-4);
        l.reject(64.0); // (64/0.729)^(1/3) = 4.4: three levels
        assert_eq!(l.step(), 6.25e-5);
        l.accept(0.05, 6.25e-5);
        assert_eq!(l.step(), 1.25e-4);
        l.accept(0.05, 1e-4); // not at the level's own length: stays
        assert_eq!(l.step(), 1.25e-4);
        for _ in 0..4 {
            l.reject(f64::INFINITY); // two levels each, up to the floor (level 10)
        }
        assert!(l.at_floor() && l.step() == 1e-3 / 1024.0);
    }

    #[test]
    fn levels_start_at_the_output_step_and_grow_to_the_longest_step() {
        // h_max = 0.1 s over an output step of 1e-3 s: the first step is 0.1 / 128 (the longest
        // level not above 1e-3), and easy steps double it up to h_max, no further
        let mut l = Levels::new(0.1, 1e-9, 1e-3);
        assert_eq!(l.step(), 0.1 / 128.0);
        for _ in 0..10 {
            let h = l.step();
            l.accept(0.0, h);
        }
        assert_eq!(l.step(), 0.1);
    }

    #[test]
    fn the_interpolated_state_follows_a_cubic_and_a_linear_acceleration() {
        // y(t) = t^3 - t, v = 3 t^2 - 1, a = 6 t: the Hermite cubic is exact, and so is the
        // linear acceleration
        let (t0, h) = (0.5, 0.25);
        let f = |t: f64| ([t * t * t - t], [3.0 * t * t - 1.0], [6.0 * t]);
        let (y0, v0, a0) = f(t0);
        let (y1, v1, a1) = f(t0 + h);
        for s in [0.0, 0.3, 0.5, 1.0] {
            let (mut y, mut v, mut a) = ([0.0], [0.0], [0.0]);
            interpolate_state((&y0, &v0, &a0), (&y1, &v1, &a1), h, s, &mut y, &mut v, &mut a);
            let (ye, ve, ae) = f(t0 + s * h);
            assert!((y[0] - ye[0]).abs() < 1e-14 && (v[0] - ve[0]).abs() < 1e-13 && (a[0] - ae[0]).abs() < 1e-13);
        }
    }

    #[test]
    fn a_path_through_the_circle_between_open_ends_is_an_entry() {
        // from (-0.6, 0.7) to (0.6, 0.7), both inside the unit circle (|q| = 0.92), over
        // h = 0.25 s with rates (4.8, +-8): the cubic is x = -0.6 + 1.2 s, y = 0.7 + 2 s (1 - s),
        // which reaches y = 1.2 at s = 1/2, outside the circle
        let c = 1.0;
        let q0 = ([-0.6, 0.7], [4.8, 8.0]);
        let q1 = ([0.6, 0.7], [4.8, -8.0]);
        assert!(enters_within(q0, q1, 0.25, c));
        let flat = ([-0.6, 0.5], [4.8, 0.0]);
        let flat1 = ([0.6, 0.5], [4.8, 0.0]);
        assert!(!enters_within(flat, flat1, 0.25, c));
        // a closed end is a status change at the ends, not this test's case
        assert!(!enters_within(([1.2, 0.0], [0.0; 2]), flat1, 0.25, c));
    }
}
