//! Adaptive steps (`tol=` runs): steps sized by the Zienkiewicz-Xie local error estimate, cut at
//! every contact entry and exit, with the output instants interpolated inside a step and the peaks
//! within a step tracked.

use super::*;

impl<'a> NewtonRun<'a> {
    /// The Zienkiewicz-Xie estimate of the local displacement error of the step of length `h`
    /// (s) just taken from accelerations `a0`, `c |a_(n+1) - a_n| h^2` with `c = |beta - 1/6|`
    /// (at least 1/24), over the tolerance `atol + rtol |y|`, largest over the unknowns
    /// (infinite when not finite); with the absolute error and the largest `|y|`
    /// ([`adaptive::LocalError`]). A rotation counts as the displacement it makes (rad x
    /// [`Self::err_scale`], m).
    fn local_error(&self, h: f64, a0: &[f64], tol: &crate::run::Adaptive) -> adaptive::LocalError {
        let unknowns = (0..self.n).map(|i| {
            let s = self.err_scale[i];
            (self.ydd[i] * s, a0[i] * s, self.y[i] * s)
        });
        adaptive::local_error(self.settings.newmark.beta, h, unknowns, tol)
    }

    /// Puts back the state saved in `ad` (the start of a trial step at `t`, s).
    fn restore_adaptive(&mut self, ad: &AdaptiveScratch, t: f64) {
        self.y.copy_from_slice(&ad.y);
        self.yd.copy_from_slice(&ad.yd);
        self.ydd.copy_from_slice(&ad.ydd);
        self.aa.copy_from_slice(&ad.aa);
        self.fric_z.copy_from_slice(&ad.fric_z);
        self.update_frames(t);
    }

    /// Adaptive steps until the integrated state (at `ad.t`, s) reaches the output instant `t1`
    /// (s), step `k` of the output grid: trial steps of `h_max / 2^m`; a step whose error
    /// estimate ([`Self::local_error`]) exceeds the tolerance, or whose iterations do not
    /// converge, is redone shorter (`m` raised by what the estimate asks, the local error being
    /// of order `h^3`); a step that changes a clearance joint's status is cut at the located
    /// crossing (just short of the circle, see the module documentation; accelerations
    /// restarted there), so no contact entry or exit is stepped across unlocated, and a step
    /// whose interpolated joint path passes through a clearance circle between open ends is
    /// redone shorter ([`adaptive::enters_within`]); after a step whose error is below a tenth
    /// of the tolerance the next is twice as long, up to `h_max`. Step lengths are powers of
    /// two below `h_max` (besides the cuts and the last step to `t_end`), so the Jacobian's
    /// factorization is reused where only the step changed it and it comes back. Steps do not
    /// stop at output instants: the last one may end past `t1`, whose state
    /// [`Self::interpolate_output`] then gives. The joints are tracked at every accepted step's
    /// end, in time order with the output instants (an end past `t1` after `t1`'s output).
    pub(super) fn adaptive_advance(
        &mut self,
        t1: f64,
        k: u64,
        ad: &mut AdaptiveScratch,
        control: &mut dyn FnMut(f64) -> bool,
    ) -> Result<()> {
        let tol = self.settings.adaptive.expect("adaptive settings");
        let eps = same_instant(self.settings.dt);
        self.restore_integrated(ad);
        while t1 - ad.t > eps {
            if !ad.control.tick(control, ad.t / ad.t_end) {
                // at the last accepted step (the integrated state); its end is tracked below
                return Err(Error::Interrupted {
                    time: ad.t,
                    step: k - 1,
                });
            }
            if ad.pending {
                // the end of the last step, past the output instants recorded since
                let check = ad.accepted.check_due(ad.t >= ad.t_end);
                self.track_step_end(ad.t, k, check)?;
                ad.pending = false;
            }
            let t = ad.t;
            let rest = ad.t_end - t;
            let mut h = ad.levels.step();
            if h >= rest || rest - h < 1e-3 * h {
                h = rest;
            }
            ad.y.copy_from_slice(&self.y);
            ad.yd.copy_from_slice(&self.yd);
            ad.ydd.copy_from_slice(&self.ydd);
            ad.aa.copy_from_slice(&self.aa);
            ad.fric_z.copy_from_slice(&self.fric_z);
            // the joints' states at the start, and their penetrations from them
            ad.q0.clear();
            ad.p0.clear();
            for (j, jt) in self.mech.joints.iter().enumerate() {
                let (q, qd) = self.joint_state(j, &self.y, &self.yd);
                ad.p0.push(norm2(q) - jt.clearance);
                ad.q0.push((q, qd));
            }
            let at_floor = ad.levels.at_floor();
            let mut err = match self.step(t, h, k, 0) {
                Ok(()) => self.local_error(h, &ad.ydd, &tol),
                Err(e @ Error::NotConverged { .. }) => {
                    if at_floor {
                        return Err(e);
                    }
                    adaptive::LocalError::NOT_CONVERGED
                }
                Err(e) => return Err(e),
            };
            // a step that changes a joint's status is cut at the crossing first: the error of
            // the substep to it is the one to judge (the whole step carries the jump of the
            // contact force, which the step after the cut resolves)
            let mut taken = h;
            let mut cut = false;
            if err.ratio.is_finite() {
                self.penetrations(&mut ad.p1);
                if let Some((theta, j)) = earliest_crossing(&ad.p0, &ad.p1) {
                    match self.adaptive_cut(t, h, k, ad, theta, j) {
                        Ok(h1) => {
                            taken = h1;
                            err = self.local_error(taken, &ad.ydd, &tol);
                            cut = true;
                        }
                        // a cut try whose iterations do not converge (a trial step far too long
                        // converged to a state whose crossing no shorter step reproduces: the
                        // first step of a run whose output step is its whole length): the step
                        // is rejected below, as one that does not converge itself
                        Err(Error::NotConverged { .. }) if !at_floor => err = adaptive::LocalError::NOT_CONVERGED,
                        Err(e) => return Err(e),
                    }
                } else if !at_floor && self.passes_through_a_circle(h, ad) {
                    // a contact within the step, open at both ends: shorter steps locate it
                    self.restore_adaptive(ad, t);
                    self.stats.rejected_steps += 1;
                    ad.levels.reject(8.0);
                    continue;
                }
            }
            // each joint's change of relative acceleration over the step (before a restart at
            // a cut changes the accelerations): the velocity map at each end applied to the
            // accelerations there, the same frames (their terms cancel in the difference)
            for j in 0..self.mech.joints.len() {
                let a1 = self.joint_state(j, &self.y, &self.ydd).1;
                let a0 = self.joint_state(j, &ad.y, &ad.ydd).1;
                ad.da[j] = [a1[0] - a0[0], a1[1] - a0[1]];
            }
            if err.ratio > 1.0 && !at_floor {
                self.restore_adaptive(ad, t);
                self.stats.rejected_steps += 1;
                ad.levels.reject(err.ratio);
                continue;
            }
            if err.ratio > 1.0 {
                self.stats.floor_steps += 1;
            }
            if ad.levels.count_floor(err.ratio > 1.0) {
                return Err(adaptive::floor_error(t, k, h));
            }
            if let Some((mean, limit)) = ad.levels.count_crawl(taken) {
                return Err(adaptive::crawl_error(t, k, mean, limit, ad.t_end));
            }
            // the accepted step's start and end, for the output instants within it (before a
            // restart at a cut changes the accelerations: the step's own left limit)
            ad.t_start = t;
            ad.end_ydd.copy_from_slice(&self.ydd);
            if cut {
                // the accelerations and the recorded force at the cut are the right limit: each
                // joint at its crossing there is taken on the new side of its circle (the
                // dashpot's entry force acts from the cut on, as on the constant stepper)
                for (jj, jt) in self.mech.joints.iter().enumerate() {
                    let (p0, p1, pc) = (ad.p0[jj], ad.p1[jj], ad.pc[jj]);
                    let band = 1e-3 * (p1 - p0).abs();
                    if (p0 > 0.0) != (p1 > 0.0) && pc.abs() <= band {
                        let eps = 1e-6 * (p1 - p0).abs();
                        self.status_hint[jj] = jt.clearance + if p1 > 0.0 { eps } else { -eps };
                    }
                }
                // (the joints are tracked at the step's end with these terms: the right-limit
                // force at the cut enters the extremes)
                let restarted = self.restart_accelerations(t + taken);
                self.status_hint.fill(f64::NAN);
                restarted?;
                self.stats.event_steps += 1;
            } else {
                self.peaks_within_step(h, ad);
                ad.levels.accept(err.ratio, h);
            }
            ad.t = if taken == rest { ad.t_end } else { t + taken };
            ad.pending = true;
            adaptive::count_step(&mut self.stats, taken, &err);
            self.track_peak_errors(taken, cut, &ad.da, &mut ad.forces);
        }
        if (ad.t - t1).abs() <= eps {
            // the step ended at the output instant: its end is the output's state
            ad.pending = false;
        } else {
            self.interpolate_output(t1, ad);
        }
        Ok(())
    }

    /// Tracks the joints at the end of an accepted adaptive step at `t` (s), output step `k`,
    /// that no output instant took: the extremes and the shared recorder (as an event), and the
    /// divergence limit on each joint's penetration.
    fn track_step_end(&mut self, t: f64, k: u64, check: bool) -> Result<()> {
        self.track_joints(t, None, false);
        if let Some(j) = self.jpen.iter().position(|&p| p.is_nan() || p > self.limit) {
            let name = &self.mech.joints[j].name;
            return Err(crate::integrator::divergence::joint_diverged(
                name,
                self.jpen[j],
                self.limit,
                t,
                k,
            ));
        }
        // the unknowns too, every few accepted steps (`check`, [`divergence::AcceptedSteps`]):
        // a run that diverged between two output instants stops there, not after as many ever
        // shorter steps as a stiff contact of the diverged state asks for up to the next
        // output instant
        if check {
            self.check_divergence(t, k)?;
        }
        Ok(())
    }

    /// Whether a joint open at both ends of the trial step of length `h` (s) just taken passes
    /// through its clearance circle in between, on the cubic Hermite path of its relative
    /// displacement ([`adaptive::enters_within`]).
    fn passes_through_a_circle(&self, h: f64, ad: &AdaptiveScratch) -> bool {
        self.mech.joints.iter().enumerate().any(|(j, jt)| {
            let end = self.joint_state(j, &self.y, &self.yd);
            adaptive::enters_within(ad.q0[j], end, h, jt.clearance)
        })
    }

    /// Puts the state at the output instant `t1` (s) inside the last accepted step (from
    /// `ad.t_start` to `ad.t`) in place of the integrated one, which `ad` keeps until
    /// [`Self::restore_integrated`]: displacements and velocities on the cubic Hermite
    /// interpolant, accelerations linear, the frames at `t1`.
    fn interpolate_output(&mut self, t1: f64, ad: &mut AdaptiveScratch) {
        ad.end_y.copy_from_slice(&self.y);
        ad.end_yd.copy_from_slice(&self.yd);
        ad.end_ydd_restart.copy_from_slice(&self.ydd);
        // the frames of the integrated state, put back as they are (not recomputed)
        let f = &mut ad.end_frames;
        f.0.clone_from(&self.frames);
        f.1.clone_from(&self.rots);
        f.2.clone_from(&self.node_ts);
        f.3.clone_from(&self.link_ck);
        f.4.clone_from(&self.slider_frames);
        let h = ad.t - ad.t_start;
        let s = ((t1 - ad.t_start) / h).clamp(0.0, 1.0);
        adaptive::interpolate_state(
            (&ad.y, &ad.yd, &ad.ydd),
            (&ad.end_y, &ad.end_yd, &ad.end_ydd),
            h,
            s,
            &mut self.y,
            &mut self.yd,
            &mut self.ydd,
        );
        self.update_frames(t1);
        self.output_interpolated = true;
    }

    /// Puts back the integrated state after an interpolated output ([`Self::interpolate_output`]).
    fn restore_integrated(&mut self, ad: &mut AdaptiveScratch) {
        if std::mem::take(&mut self.output_interpolated) {
            self.y.copy_from_slice(&ad.end_y);
            self.yd.copy_from_slice(&ad.end_yd);
            self.ydd.copy_from_slice(&ad.end_ydd_restart);
            let f = &ad.end_frames;
            self.frames.clone_from(&f.0);
            self.rots.clone_from(&f.1);
            self.node_ts.clone_from(&f.2);
            self.link_ck.clone_from(&f.3);
            self.slider_frames.clone_from(&f.4);
            self.t_frames = ad.t;
        }
    }

    /// The largest penetration and contact force of each joint within an accepted adaptive step
    /// of length `h` (s), into the joint's extremes: the relative displacement `q(t)` is the
    /// cubic Hermite interpolant of its values and rates at the step's ends (the start's in
    /// `ad.q0`), sampled at 7 interior points where either end is in contact. A smooth peak
    /// (a Hertz-type contact's) then enters at the interpolant's accuracy, `O(h^4)`, instead of
    /// the `O(h^2)` of the largest value at the step ends, which long adaptive steps would leave.
    fn peaks_within_step(&mut self, h: f64, ad: &AdaptiveScratch) {
        if self.settings.record.start > 0.0 {
            return; // the extremes are counted from a start time: the end values only
        }
        for j in 0..self.mech.joints.len() {
            let (q0, v0) = ad.q0[j];
            let (q1, v1) = self.joint_state(j, &self.y, &self.yd);
            let c = self.mech.joints[j].clearance;
            if norm2(q0) <= c && norm2(q1) <= c {
                continue;
            }
            for (_, q, qd) in adaptive::hermite_points((q0, v0), (q1, v1), h) {
                let terms = self.law_terms(j, q, qd);
                if terms.penetration <= 0.0 {
                    continue;
                }
                let f = evaluation::recorded_force(&terms, q, qd);
                let tr = &mut self.track[j];
                tr.max_penetration = tr.max_penetration.max(terms.penetration);
                tr.max_force = tr.max_force.max(norm2(f));
            }
        }
    }

    /// After an accepted adaptive step of length `h` (s), ended at a cut or not (its joints
    /// tracked), in which each joint's relative acceleration changed by `da` (m/s^2): each
    /// joint's local errors enter its sums ([`adaptive::ForceErrors::add_joint`]), and a joint
    /// whose largest force rose (tracked, or at the step's end) takes the estimate of that
    /// force's error (the law's terms at the step's end, put on the closed side of the circle
    /// when it is open there: the right limit of an entry's cut), into the stats.
    fn track_peak_errors(&mut self, h: f64, cut: bool, da: &[[f64; 2]], forces: &mut adaptive::ForceErrors) {
        let mut changed = false;
        let nm = (self.settings.newmark.beta, self.settings.newmark.error_gamma());
        for j in 0..self.mech.joints.len() {
            forces.add_joint(j, da[j], h, nm, cut);
            let (mut q, qd) = self.joint_state(j, &self.y, &self.yd);
            let c = self.mech.joints[j].clearance;
            let terms = self.law_terms(j, q, qd);
            let end = if terms.penetration > 0.0 {
                let f = evaluation::recorded_force(&terms, q, qd);
                norm2(f)
            } else {
                0.0
            };
            let f = end.max(self.track[j].max_force);
            if forces.is_peak(j, f) {
                let r = norm2(q);
                let terms = if terms.penetration > 0.0 || !(r > 0.0 && c > 0.0) {
                    terms
                } else {
                    let s = c * (1.0 + 1e-9) / r;
                    q = [q[0] * s, q[1] * s];
                    self.law_terms(j, q, qd)
                };
                forces.set_peak(j, f, &terms);
                changed = true;
            }
        }
        if changed {
            forces.to_stats(&mut self.stats);
        }
    }

    /// The cut of an adaptive step of length `h` (s) from `t` at first estimate `theta`
    /// (fraction of `h`) for joint `jstar`: the first substep's length (s), ending just short of
    /// the circle (regula falsi as in [`Self::cut_step`]).
    fn adaptive_cut(
        &mut self,
        t: f64,
        h: f64,
        k: u64,
        ad: &mut AdaptiveScratch,
        mut theta: f64,
        jstar: usize,
    ) -> Result<f64> {
        let mut search = CutSearch::new(ad.p0[jstar], ad.p1[jstar], false);
        // the first try where the joint's interpolated path crosses (half the search's
        // tolerance short of the circle), the linear estimate where it shows no crossing
        let end = self.joint_state(jstar, &self.y, &self.yd);
        let radius = self.mech.joints[jstar].clearance + search.target();
        theta = CutSearch::cuttable_estimate(adaptive::hermite_crossing(ad.q0[jstar], end, h, radius, theta));
        let mut h1 = theta * h;
        for it in 0..EVENT_MAX_CUTS {
            h1 = theta * h;
            self.restore_adaptive(ad, t);
            self.step(t, h1, k, 0)?;
            self.penetrations(&mut ad.pc);
            let (q, qd) = self.joint_state(jstar, &self.y, &self.yd);
            let rate = h * penetration_rate(q, qd);
            match search.next_with_rate(theta, ad.pc[jstar], rate, it + 1 == EVENT_MAX_CUTS) {
                Some(next) => theta = next,
                None => break,
            }
        }
        Ok(h1)
    }
}
