//! Event location shared by the event-aware stepping of both integrators ([`super::constant`]
//! and [`super::newton`]): the earliest contact status change within a step, and the regula falsi
//! (Illinois) search for the length of the first substep so that it ends within a tolerance of
//! the clearance circle on the chosen side.

/// A substep shorter than this fraction of the step is not cut off: the step is kept as computed.
pub(crate) const EVENT_MIN_FRACTION: f64 = 1e-3;
/// The cut is accepted when the first substep ends within this fraction of the step's change of
/// penetration from the circle (on the chosen side).
pub(crate) const EVENT_PEN_TOL: f64 = 1e-3;
/// At most this many first substeps per event.
pub(crate) const EVENT_MAX_CUTS: usize = 6;

/// True when a cut at fraction `theta` of the step leaves both substeps at least
/// [`EVENT_MIN_FRACTION`] of it.
#[inline]
fn cuttable(theta: f64) -> bool {
    (EVENT_MIN_FRACTION..=1.0 - EVENT_MIN_FRACTION).contains(&theta)
}

/// The earliest status change (sign of the penetration, m) between the step's start `pen0` and
/// end `pen1`, by linear interpolation: `(theta, joint)` with `theta` the fraction of the step,
/// or `None` when no joint changes status or the earliest change is too close to either end to
/// cut ([`EVENT_MIN_FRACTION`]).
pub(crate) fn earliest_crossing(pen0: &[f64], pen1: &[f64]) -> Option<(f64, usize)> {
    let mut theta = f64::INFINITY;
    let mut jstar = 0;
    for (j, (&p0, &p1)) in pen0.iter().zip(pen1).enumerate() {
        if (p0 > 0.0) != (p1 > 0.0) {
            let th = p0 / (p0 - p1);
            if th < theta {
                theta = th;
                jstar = j;
            }
        }
    }
    cuttable(theta).then_some((theta, jstar))
}

/// The rate of a clearance joint's penetration `|q| - c` at relative displacement `q` (m) and
/// velocity `qd` (m/s), m/s (0 at the centre).
pub(crate) fn penetration_rate(q: [f64; 2], qd: [f64; 2]) -> f64 {
    let r = q[0].hypot(q[1]);
    if r > 0.0 {
        (q[0] * qd[0] + q[1] * qd[1]) / r
    } else {
        0.0
    }
}

/// Regula falsi (Illinois) on the first substep's end penetration of one joint, bracketed by the
/// step's ends, aiming at `target`: half the tolerance off the circle on the old side
/// (`past = false`) or on the new side (`past = true`).
pub(crate) struct CutSearch {
    p0: f64,
    tol: f64,
    target: f64,
    lo: (f64, f64),
    hi: (f64, f64),
    side: i8,
}

impl CutSearch {
    /// The search for a joint whose penetration goes from `p0` to `p1` (m) over the trial step.
    pub(crate) fn new(p0: f64, p1: f64, past: bool) -> Self {
        let tol = EVENT_PEN_TOL * (p1 - p0).abs();
        let old_side = if p0 > 0.0 { 0.5 * tol } else { -0.5 * tol };
        let target = if past { -old_side } else { old_side };
        CutSearch {
            p0,
            tol,
            target,
            lo: (0.0, p0 - target),
            hi: (1.0, p1 - target),
            side: 0,
        }
    }

    /// The penetration the search aims at, m (half its tolerance off the circle).
    pub(crate) fn target(&self) -> f64 {
        self.target
    }

    /// A first estimate `theta` (a fraction of the step) moved inside the range a cut may take
    /// (both substeps at least [`EVENT_MIN_FRACTION`] of the step).
    pub(crate) fn cuttable_estimate(theta: f64) -> f64 {
        theta.clamp(EVENT_MIN_FRACTION, 1.0 - EVENT_MIN_FRACTION)
    }

    /// After a first substep of fraction `theta` ended at penetration `pen` (m): `None` to keep
    /// that cut (within tolerance, the last try, or the next estimate too close to an end), else
    /// the next fraction to try.
    pub(crate) fn next(&mut self, theta: f64, pen: f64, last_try: bool) -> Option<f64> {
        let pc = pen - self.target;
        if pc.abs() <= 0.5 * self.tol || last_try {
            return None;
        }
        if (pc > 0.0) == (self.p0 - self.target > 0.0) {
            self.lo = (theta, pc);
            if self.side == -1 {
                self.hi.1 *= 0.5;
            }
            self.side = -1;
        } else {
            self.hi = (theta, pc);
            if self.side == 1 {
                self.lo.1 *= 0.5;
            }
            self.side = 1;
        }
        let (lo, hi) = (self.lo, self.hi);
        let next = lo.0 - lo.1 * (hi.0 - lo.0) / (hi.1 - lo.1);
        cuttable(next).then_some(next)
    }

    /// As [`Self::next`], given also the rate of the end penetration with the fraction,
    /// `d pen / d theta` (m: the step's length times the penetration's rate at the substep's
    /// end, the end moving along the trajectory as the cut moves): a Newton step from `theta`
    /// where it stays inside the bracket, else the regula falsi of [`Self::next`]. Converges
    /// quadratically where the regula falsi, on a curved penetration, keeps one end of the
    /// bracket and crawls (adaptive steps' cuts, each try a step and, on the constant stepper,
    /// a factorization).
    pub(crate) fn next_with_rate(&mut self, theta: f64, pen: f64, rate: f64, last_try: bool) -> Option<f64> {
        let falsi = self.next(theta, pen, last_try)?;
        let newton = theta - (pen - self.target) / rate;
        let (a, b) = (self.lo.0.min(self.hi.0), self.lo.0.max(self.hi.0));
        if newton.is_finite() && newton > a && newton < b && cuttable(newton) {
            Some(newton)
        } else {
            Some(falsi)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn earliest_crossing_picks_the_first_cuttable_change() {
        assert_eq!(earliest_crossing(&[-1.0, -1.0], &[-0.5, 1.0]), Some((0.5, 1)));
        assert_eq!(earliest_crossing(&[-1.0, 1.0], &[3.0, -3.0]), Some((0.25, 0)));
        assert_eq!(earliest_crossing(&[-1.0], &[-0.5]), None);
        // too close to the step's start to cut
        assert_eq!(earliest_crossing(&[-1e-6], &[1.0]), None);
    }

    #[test]
    fn search_with_the_rate_converges_in_fewer_tries() {
        // pen(theta) = theta^3 + theta - 0.5 from -0.5 to 1.5 (curved: regula falsi keeps an
        // end); its rate 3 theta^2 + 1 gives Newton's steps inside the bracket
        let pen = |t: f64| t * t * t + t - 0.5;
        let rate = |t: f64| 3.0 * t * t + 1.0;
        let count = |with_rate: bool| {
            let mut s = CutSearch::new(-0.5, 1.5, false);
            let mut theta = 0.25;
            let mut tries = 1;
            loop {
                let next = if with_rate {
                    s.next_with_rate(theta, pen(theta), rate(theta), tries == EVENT_MAX_CUTS)
                } else {
                    s.next(theta, pen(theta), tries == EVENT_MAX_CUTS)
                };
                match next {
                    Some(t) => (theta, tries) = (t, tries + 1),
                    None => break,
                }
            }
            let p = pen(theta);
            assert!(p <= 0.0 && p.abs() <= 2e-3, "{with_rate}: {theta} {p} after {tries}");
            tries
        };
        assert!(count(true) < count(false));
    }

    #[test]
    fn search_finds_the_root_of_a_nonlinear_penetration() {
        // pen(theta) = theta^2 - 0.3 (the step goes from -0.3 to 0.7); root at sqrt(0.3)
        for past in [false, true] {
            let mut s = CutSearch::new(-0.3, 0.7, past);
            let mut theta = 0.3 / 1.0;
            let mut tries = 1;
            while let Some(t) = s.next(theta, theta * theta - 0.3, tries == EVENT_MAX_CUTS) {
                theta = t;
                tries += 1;
            }
            let pen = theta * theta - 0.3;
            // within the tolerance (1e-3 of the change, 1.0) of the circle, on the chosen side
            assert!(
                pen.abs() <= 1e-3 && (pen > 0.0) == past,
                "{past}: {theta} {pen} after {tries}"
            );
        }
    }
}
