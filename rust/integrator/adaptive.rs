//! The parts of adaptive steps ([`crate::run::Adaptive`]) that the constant and the Newton
//! stepper share: the step levels `dt / 2^m` and their controller, the Zienkiewicz-Xie local
//! error, the counters of accepted steps, and the cubic Hermite path of a clearance joint within
//! a step (the smooth peaks between the step's ends). Each stepper keeps its own trial step, cut
//! and restart.

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

/// The Zienkiewicz-Xie estimate of the local displacement error of a step of length `h` (s),
/// `c |a_(n+1) - a_n| h^2` with `c = |beta - 1/6|` (at least 1/24), over the tolerance
/// `atol + rtol |y|`, largest over the unknowns given as `(a_(n+1), a_n, y)`; infinite when not
/// finite.
pub(crate) fn local_error(beta: f64, h: f64, unknowns: impl Iterator<Item = (f64, f64, f64)>, tol: &Adaptive) -> f64 {
    let c = (beta - 1.0 / 6.0).abs().max(1.0 / 24.0) * h * h;
    let mut e = 0.0f64;
    for (a1, a0, y) in unknowns {
        let r = c * (a1 - a0).abs() / (tol.atol + tol.rtol * y.abs());
        if r.is_nan() || r > e {
            e = if r.is_finite() { r } else { f64::INFINITY };
        }
    }
    e
}

/// Counts an accepted step of length `h` (s) in `stats` (the steps, the shortest and longest).
pub(crate) fn count_step(stats: &mut RunStats, h: f64) {
    stats.adaptive_steps += 1;
    stats.min_step = if stats.min_step > 0.0 { stats.min_step.min(h) } else { h };
    stats.max_step = stats.max_step.max(h);
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
