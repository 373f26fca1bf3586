//! Adaptive steps (`tol=` runs, one lane): steps of `h_max / 2^m` sized by the Zienkiewicz-Xie
//! local error estimate, the shared factor made again for a new step, output instants interpolated
//! inside a step, and the peaks within a step tracked.

use super::*;

impl<'m, const L: usize> Lockstep<'m, L> {
    /// Puts the constants of step `h` (s) in use for the single lane: nothing to do when they
    /// are; a hit in the [`FactorCache`] swaps them in; a miss refills the least recently used
    /// slot (a cut's odd length first) in place, or fills a new slot while there are fewer than
    /// [`FACTOR_CACHE`] (the only allocation of adaptive steps); an odd length in use (not a
    /// level `h_max / 2^m`) is refilled in place, evicting no level.
    fn use_step(&mut self, h: f64) -> Result<()> {
        let sh = &mut self.sh;
        if sh.dt.to_bits() == h.to_bits() {
            return Ok(());
        }
        let is_level = |x: f64| {
            let r = sh.h_max / x;
            r >= 1.0 && r.fract() == 0.0 && (r as u64).is_power_of_two()
        };
        let nm = self.lanes[0].settings.newmark;
        let cache = &mut sh.cache;
        cache.clock += 1;
        let hit = cache.slots.iter().position(|c| c.dt.to_bits() == h.to_bits());
        if hit.is_none() && !is_level(sh.dt) && !cache.slots.is_empty() {
            // the odd length in use (a cut's) will not come back: its constants are refilled in
            // place (through slot 0, whose constants are put back), no cached level is evicted
            let mut slots = std::mem::take(&mut sh.cache.slots);
            sh.swap_step(&mut slots[0]);
            let refilled = slots[0].refill(&sh.sys, h, &nm);
            sh.swap_step(&mut slots[0]);
            sh.cache.slots = slots;
            self.lanes[0].g_factored.fill([[f64::NAN; 2]; 2]);
            return refilled;
        }
        let slot = match hit {
            Some(k) => k,
            None if cache.slots.len() < FACTOR_CACHE => {
                let analysis = Arc::clone(sh.chol0.analysis());
                cache
                    .slots
                    .push(StepConsts::new(&sh.sys, h, &nm, Cholesky::with_analysis(analysis))?);
                cache.used.push(0);
                cache.slots.len() - 1
            }
            None => {
                // the least recently used slot, one holding an odd length first
                let k = (0..cache.slots.len())
                    .min_by_key(|&k| (is_level(cache.slots[k].dt), cache.used[k]))
                    .expect("a full cache has slots");
                cache.slots[k].refill(&sh.sys, h, &nm)?;
                k
            }
        };
        // the constants in use go to the slot, marked as just used
        let mut slots = std::mem::take(&mut sh.cache.slots);
        sh.swap_step(&mut slots[slot]);
        sh.cache.slots = slots;
        sh.cache.used[slot] = sh.cache.clock;
        // a refactorized contact matrix (Woodbury fallback) was made on the old A0
        self.lanes[0].g_factored.fill([[f64::NAN; 2]; 2]);
        Ok(())
    }

    /// The Zienkiewicz-Xie estimate of the local displacement error of the step of length `h`
    /// (s) just taken from accelerations `a0` (the single lane), over the tolerance, largest
    /// over the unknowns (infinite when not finite): as the Newton stepper's (`NewtonRun`'s
    /// `local_error`), `c |a_(n+1) - a_n| h^2 / (atol + rtol |u|)` with `c = |beta - 1/6|` (at
    /// least 1/24); with the absolute error and the largest `|u|` ([`adaptive::LocalError`]).
    /// Each unknown counts as a displacement, a rotation times its `scale` (m,
    /// [`rotation_scales`]).
    fn local_error(&self, h: f64, a0: &[f64], scale: &[f64], tol: &crate::run::Adaptive) -> adaptive::LocalError {
        let unknowns = self
            .a
            .iter()
            .zip(a0)
            .zip(&self.u)
            .zip(scale)
            .map(|(((a1, &a0), u), &s)| (a1[0] * s, a0 * s, u[0] * s));
        adaptive::local_error(self.lanes[0].settings.newmark.beta, h, unknowns, tol)
    }

    /// Adaptive steps of the single lane until its integrated state (at `ad.t`, s) reaches the
    /// output instant `t1` (s), with the controller of the Newton stepper
    /// (`NewtonRun::adaptive_advance`): trial steps of `h_max / 2^m`; a step whose error
    /// estimate ([`Self::local_error`]) exceeds the tolerance is redone shorter (`m` raised by
    /// what the `h^3` law asks); a step that changes a clearance joint's status is cut at the
    /// located crossing (regula falsi from the crossing of the joint's cubic Hermite path, the
    /// substep keeping the start's statuses and ending just short of the circle, as
    /// [`Self::advance_with_events`]) and the accelerations restart there with the crossing
    /// joints on their new side ([`Self::restart_at_event`]: the right limit, recorded); a step
    /// whose interpolated joint path passes through a clearance circle between open ends is
    /// redone shorter ([`adaptive::enters_within`]); after a step whose error is below a tenth
    /// of the tolerance the next is twice as long, up to `h_max`. Each step size takes its
    /// constants from the [`FactorCache`] ([`Self::use_step`]). Steps do not stop at output
    /// instants: the last may end past `t1`, whose state the output interpolates
    /// ([`Self::record_interpolated`]). Accepted steps' ends enter the joints' extremes
    /// ([`Recorder::record_substep`]) in time order with the output instants. A lane that fails
    /// (divergence, a matrix that is not positive definite) is retired as in a fixed step.
    pub(super) fn adaptive_advance(&mut self, t1: f64, ad: &mut AdaptiveSteps, control: &mut dyn FnMut(f64) -> bool) {
        debug_assert!(L == 1);
        let eps = same_instant(self.sh.grid_dt);
        let tol = ad.tol;
        ad.interpolated = false;
        while t1 - ad.t > eps {
            self.record_pending(ad);
            if !ad.control.tick(control, ad.t / ad.t_end) {
                // at the last accepted step, recorded above
                let e = Error::Interrupted {
                    time: ad.t,
                    step: self.step,
                };
                self.retire(0, Some(e), self.step, ad.t);
                return;
            }
            let t = ad.t;
            let rest = ad.t_end - t;
            let mut h = ad.levels.step();
            // the last step of the run: to `t_end`, at the level's length where it is that up
            // to rounding (its constants are cached), else at the rest
            let last = h >= rest || rest - h < 1e-3 * h;
            if last {
                // the level's length, or a shorter level's (after the level went down), where it
                // is the rest up to rounding: its constants are cached
                let mut hk = h;
                for _ in 0..5 {
                    if (rest - hk).abs() <= eps {
                        break;
                    }
                    hk *= 0.5;
                }
                h = if (rest - hk).abs() <= eps { hk } else { rest };
            }
            self.snapshot(&mut ad.snap);
            ad.p0.clone_from(&self.lanes[0].pen);
            let at_floor = ad.levels.at_floor();
            if !self.adaptive_step(t, h) {
                return;
            }
            let mut err = self.local_error(h, &ad.snap.a, &ad.err_scale, &tol);
            let mut taken = h;
            let mut cut = false;
            if let Some((mut theta, jstar)) = earliest_crossing(&ad.p0, &self.lanes[0].pen) {
                // a step that changes a joint's status is cut at the crossing first: the error
                // of the substep to it is the one to judge
                ad.p1.clone_from(&self.lanes[0].pen);
                let mut search = CutSearch::new(ad.p0[jstar], ad.p1[jstar], false);
                let lane = &mut self.lanes[0];
                // the first try where the joint's interpolated path crosses (half the search's
                // tolerance short of the circle), the linear estimate where it shows no crossing
                let (start, end) = ((ad.snap.q[jstar], ad.snap.qd[jstar]), (lane.q[jstar], lane.qd[jstar]));
                let radius = lane.sys.joints[jstar].clearance + search.target();
                theta = CutSearch::cuttable_estimate(adaptive::hermite_crossing(start, end, h, radius, theta));
                lane.frozen.clear();
                lane.frozen.extend(ad.p0.iter().map(|&p| p > 0.0));
                for it in 0..EVENT_MAX_CUTS {
                    taken = theta * h;
                    self.restore(&ad.snap);
                    if !self.adaptive_step(t, taken) {
                        return;
                    }
                    let lane = &self.lanes[0];
                    let rate = h * penetration_rate(lane.q[jstar], lane.qd[jstar]);
                    match search.next_with_rate(theta, lane.pen[jstar], rate, it + 1 == EVENT_MAX_CUTS) {
                        Some(next) => theta = next,
                        None => break,
                    }
                }
                self.lanes[0].frozen.clear();
                err = self.local_error(taken, &ad.snap.a, &ad.err_scale, &tol);
                cut = true;
            } else if !at_floor && self.passes_through_a_circle(h, &ad.snap) {
                // a contact within the step, open at both ends: shorter steps locate it
                self.restore(&ad.snap);
                self.lanes[0].stats.rejected_steps += 1;
                ad.levels.reject(8.0);
                continue;
            }
            if err.ratio > 1.0 && !at_floor {
                self.restore(&ad.snap);
                self.lanes[0].stats.rejected_steps += 1;
                ad.levels.reject(err.ratio);
                continue;
            }
            if ad.levels.count_floor(err.ratio > 1.0) {
                let e = adaptive::floor_error(t, self.step, h);
                self.retire(0, Some(e), self.step, t);
                return;
            }
            if let Some((mean, limit)) = ad.levels.count_crawl(taken) {
                let e = adaptive::crawl_error(t, self.step, mean, limit, ad.t_end);
                self.retire(0, Some(e), self.step, t);
                return;
            }
            let stats = &mut self.lanes[0].stats;
            if err.ratio > 1.0 {
                stats.floor_steps += 1;
            }
            if cut {
                stats.event_steps += 1;
            } else {
                ad.levels.accept(err.ratio, h);
            }
            adaptive::count_step(stats, taken, &err);
            // the joints' local displacement and velocity errors (the restart at a cut changes
            // `a`)
            let nm = self.lanes[0].settings.newmark;
            for (jj, j) in self.lanes[0].sys.joints.iter().enumerate() {
                let mut d = [0.0; 2];
                for k in 0..j.ndof {
                    let da = self.a[j.dofs[k]][0] - ad.snap.a[j.dofs[k]];
                    d[0] += j.coef[0][k] * da;
                    d[1] += j.coef[1][k] * da;
                }
                ad.forces.add_joint(jj, d, taken, (nm.beta, nm.error_gamma()), cut);
            }
            let reached = if last && !cut { ad.t_end } else { t + taken };
            ad.t_start = t;
            if cut {
                // the right limit at the cut (recorded with the step's end)
                self.restart_at_event(reached, &ad.p0, &ad.p1, false);
            } else {
                self.peaks_within_step(t, taken, &ad.snap);
            }
            ad.pending = Some(cut);
            self.track_peak_errors(&mut ad.forces);
            ad.t = reached;
            // the divergence limits every few accepted steps and at the last (as Newton's
            // `track_step_end`): a run that diverged between output instants stops there
            if ad.accepted.check_due(reached >= ad.t_end) {
                if let Err(e) = self.check_lane(0, reached, self.step) {
                    self.retire(0, Some(e), self.step, reached);
                    return;
                }
            }
        }
        if (ad.t - t1).abs() <= eps {
            // the step ended at the output instant, whose record takes its end (a cut's right
            // limit is an event: recorded first)
            if ad.pending == Some(true) {
                self.record_pending(ad);
            }
            ad.pending = None;
        } else {
            ad.interpolated = true;
        }
    }

    /// Records the end of the last accepted adaptive step, past the output instants recorded
    /// since, when it is still to be recorded: a cut's right limit as an event
    /// ([`Recorder::record_event`]), another end as a substep ([`Recorder::record_substep`]).
    fn record_pending(&mut self, ad: &mut AdaptiveSteps) {
        let Some(event) = ad.pending.take() else {
            return;
        };
        let lane = &mut self.lanes[0];
        if event {
            lane.rec.record_event(ad.t, &lane.pen, &lane.force, &lane.q, &lane.qd);
        } else {
            lane.rec.record_substep(ad.t, &lane.pen, &lane.force, &lane.q, &lane.qd);
        }
    }

    /// Whether a joint open at both ends of the trial step of length `h` (s) just taken from
    /// `snap` passes through its clearance circle in between ([`adaptive::enters_within`]).
    fn passes_through_a_circle(&self, h: f64, snap: &Snapshot) -> bool {
        let lane = &self.lanes[0];
        (lane.sys.joints.iter().enumerate()).any(|(jj, j)| {
            adaptive::enters_within((snap.q[jj], snap.qd[jj]), (lane.q[jj], lane.qd[jj]), h, j.clearance)
        })
    }

    /// Records the output instant `t` (s), step `step`, inside the last accepted adaptive step
    /// (from `ad.t_start` to `ad.t`): each joint's relative displacement and velocity on the
    /// cubic Hermite path of the step's ends, the penetration and the law's force there, and
    /// the displacements likewise where the node histories read them.
    pub(super) fn record_interpolated(&mut self, step: u64, t: f64, ad: &mut AdaptiveSteps) {
        let h = ad.t - ad.t_start;
        let s = ((t - ad.t_start) / h).clamp(0.0, 1.0);
        let (u1, v1) = (self.u.as_flattened(), self.v.as_flattened());
        let uo = &mut ad.out_u;
        let snap = &ad.snap;
        let lane = &mut self.lanes[0];
        if lane.reads_u {
            adaptive::interpolate_displacements((&snap.u, &snap.v), (u1, v1), h, s, uo);
        }
        for jj in 0..lane.sys.joints.len() {
            let (qi, vi) = adaptive::hermite_at((snap.q[jj], snap.qd[jj]), (lane.q[jj], lane.qd[jj]), h, s);
            let terms = lane.contact_terms(jj, qi, vi);
            ad.out_q[jj] = qi;
            ad.out_qd[jj] = vi;
            ad.out_pen[jj] = terms.penetration;
            ad.out_force[jj] = evaluation::recorded_force(&terms, qi, vi);
        }
        let dt = lane.settings.dt;
        let u = if lane.reads_u { &uo[..] } else { &[] };
        lane.rec
            .record(step, t, dt, &ad.out_pen, &ad.out_force, &ad.out_q, &ad.out_qd, u);
    }

    /// After an accepted adaptive step (its peaks within and its end recorded): each joint whose
    /// largest force rose takes the estimate of that force's error ([`adaptive::ForceErrors`],
    /// the law's terms at the step's end), into the stats.
    fn track_peak_errors(&mut self, forces: &mut adaptive::ForceErrors) {
        let lane = &mut self.lanes[0];
        let mut changed = false;
        for jj in 0..lane.sys.joints.len() {
            let f = norm2(lane.force[jj]).max(lane.rec.extremes[jj].max_force);
            if forces.is_peak(jj, f) {
                let terms = lane.contact_terms(jj, lane.q[jj], lane.qd[jj]);
                forces.set_peak(jj, f, &terms);
                changed = true;
            }
        }
        if changed {
            forces.to_stats(&mut lane.stats);
        }
    }

    /// The largest penetration and contact force of each joint within the accepted adaptive step
    /// from `t` of length `h` (s), into the joint's extremes, as the Newton stepper's
    /// (`NewtonRun`'s `peaks_within_step`): the joint's relative displacement is the cubic
    /// Hermite interpolant of its values and rates at the step's ends (the start's in `snap`),
    /// sampled at 7 interior points where either end is in contact, so that a smooth peak enters
    /// at `O(h^4)` rather than the `O(h^2)` of the ends. Not for the gap coupling (its status is
    /// the iteration's), nor with a recording start time (the end values only, as on Newton).
    fn peaks_within_step(&mut self, t: f64, h: f64, snap: &Snapshot) {
        let lane = &mut self.lanes[0];
        if lane.settings.record.start > 0.0 || matches!(lane.settings.coupling, Coupling::Gap { .. }) {
            return;
        }
        for jj in 0..lane.sys.joints.len() {
            let (q0, v0) = (snap.q[jj], snap.qd[jj]);
            let (q1, v1) = (lane.q[jj], lane.qd[jj]);
            let c = lane.sys.joints[jj].clearance;
            if norm2(q0) <= c && norm2(q1) <= c {
                continue;
            }
            for (s, q, qd) in adaptive::hermite_points((q0, v0), (q1, v1), h) {
                let terms = lane.contact_terms(jj, q, qd);
                if terms.penetration <= 0.0 {
                    continue;
                }
                let f = evaluation::recorded_force(&terms, q, qd);
                lane.rec.record_peak_within(jj, t + s * h, terms.penetration, norm2(f));
            }
        }
    }

    /// One trial step of the single lane from `t` of length `h` (s) with the constants of `h`;
    /// false when the lane failed (it is then retired with its error).
    fn adaptive_step(&mut self, t: f64, h: f64) -> bool {
        if let Err(e) = self.use_step(h) {
            self.retire(0, Some(e), self.step, t);
            return false;
        }
        self.t = t;
        self.advance(t + h);
        self.active[0]
    }
}
