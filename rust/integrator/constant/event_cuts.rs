//! Steps cut at contact events (`events=True`): the state kept at a step's start, a step redone as
//! two substeps cut where a clearance joint opens or closes, and the accelerations restarted at the
//! cut.

use super::*;

impl<'m, const L: usize> Lockstep<'m, L> {
    /// One step of the (single) lane to `t1` with event location: the step is taken; when it
    /// changes a joint's contact status (sign of the penetration), the earliest crossing (linear
    /// interpolation of the penetration, then regula falsi on the first substep's end) places a
    /// cut, the step is redone from its start as two substeps, each with the contact-free
    /// factorization of its own size, and the acceleration is restarted at the cut
    /// ([`Self::restart_at_event`]). A step without a status change, or whose cut would leave a
    /// substep shorter than `EVENT_MIN_FRACTION dt`, is kept as taken: bitwise the fixed-step
    /// result.
    pub(super) fn advance_with_events(&mut self, t1: f64, ev: &mut Events) {
        debug_assert!(L == 1);
        let t0 = self.t;
        let snap = &mut ev.snap;
        self.snapshot(snap);
        self.advance(t1);
        if !self.active[0] {
            return;
        }
        let Some((mut theta, jstar)) = earliest_crossing(&snap.pen, &self.lanes[0].pen) else {
            return;
        };
        ev.pen1.clone_from(&self.lanes[0].pen);
        let dt = self.sh.dt;
        let settings = &self.lanes[0].settings;
        let nm = settings.newmark;
        let analysis = Arc::clone(self.sh.chol0.analysis());
        let consts =
            |sys: &System, h: f64| StepConsts::new(sys, h, &nm, Cholesky::with_analysis(Arc::clone(&analysis)));
        self.lanes[0].stats.event_steps += 1;
        let nan = [[f64::NAN; 2]; 2];
        // the crossing of joint `jstar` by regula falsi (Illinois) on the first substep's end
        // penetration, bracketed by the step's ends; the trial step's end (contact forces acting
        // over the whole step) gives only a first estimate
        // aim just short of the circle (on the old side, within `tol`): a first substep that ended
        // across it would carry the new status (for an entry, the dashpot force) over its length
        let mut search = CutSearch::new(snap.pen[jstar], ev.pen1[jstar], false);
        let mut factorizations = 0;
        let mut h1 = theta * dt;
        // the first substep keeps every joint's start-of-step status: it follows the old-status
        // trajectory to the crossing (with the status iterated, an end state near the circle has
        // no consistent status when the dashpot force jumps there, and the iteration would switch
        // between the two until its cap)
        let lane = &mut self.lanes[0];
        lane.frozen.clear();
        lane.frozen.extend(snap.pen.iter().map(|&p| p > 0.0));
        for it in 0..EVENT_MAX_CUTS {
            h1 = theta * dt;
            let Ok(mut s1) = consts(&self.sh.sys, h1) else {
                self.lanes[0].frozen.clear();
                return; // cannot happen for h > 0 (M is positive definite)
            };
            factorizations += 1;
            self.restore(snap);
            self.lanes[0].g_factored.fill(nan);
            self.sh.swap_step(&mut s1);
            self.advance(t0 + h1);
            self.sh.swap_step(&mut s1);
            if !self.active[0] {
                self.lanes[0].frozen.clear();
                self.sh.chol0.factorizations += factorizations;
                return;
            }
            match search.next(theta, self.lanes[0].pen[jstar], it + 1 == EVENT_MAX_CUTS) {
                Some(next) => theta = next,
                None => break,
            }
        }
        self.lanes[0].frozen.clear();
        self.restart_at_event(t0 + h1, &snap.pen, &ev.pen1, true);
        let Ok(mut s2) = consts(&self.sh.sys, dt - h1) else {
            return;
        };
        factorizations += 1;
        self.lanes[0].g_factored.fill(nan);
        self.sh.swap_step(&mut s2);
        self.advance(t1);
        self.sh.swap_step(&mut s2);
        self.lanes[0].g_factored.fill(nan);
        self.sh.chol0.factorizations += factorizations;
    }

    /// Keeps the single lane's state in `snap` (the start of a step that may be redone).
    pub(super) fn snapshot(&self, snap: &mut Snapshot) {
        let lane = &self.lanes[0];
        snap.u.resize(self.sh.n, 0.0);
        snap.v.resize(self.sh.n, 0.0);
        snap.a.resize(self.sh.n, 0.0);
        get_lane(&self.u, 0, &mut snap.u);
        get_lane(&self.v, 0, &mut snap.v);
        get_lane(&self.a, 0, &mut snap.a);
        if self.sh.alpha.is_some() {
            snap.aa.resize(self.sh.n, 0.0);
            get_lane(&self.aa, 0, &mut snap.aa);
        }
        snap.q.clone_from(&lane.q);
        snap.qd.clone_from(&lane.qd);
        snap.pen.clone_from(&lane.pen);
        snap.force.clone_from(&lane.force);
        snap.gap_closed.clone_from(&lane.gap_closed);
        snap.gap_normal.clone_from(&lane.gap_normal);
        snap.episode.clone_from(&lane.episode);
        snap.pa_old.clone_from(&lane.pa_old);
    }

    /// Puts the single lane back to the start-of-step state `snap`.
    pub(super) fn restore(&mut self, snap: &Snapshot) {
        set_lane(&mut self.u, 0, &snap.u);
        set_lane(&mut self.v, 0, &snap.v);
        set_lane(&mut self.a, 0, &snap.a);
        if self.sh.alpha.is_some() {
            set_lane(&mut self.aa, 0, &snap.aa);
        }
        let lane = &mut self.lanes[0];
        lane.q.clone_from(&snap.q);
        lane.qd.clone_from(&snap.qd);
        lane.pen.clone_from(&snap.pen);
        lane.force.clone_from(&snap.force);
        lane.gap_closed.clone_from(&snap.gap_closed);
        lane.gap_normal.clone_from(&snap.gap_normal);
        lane.episode.clone_from(&snap.episode);
        lane.pa_old.clone_from(&snap.pa_old);
    }

    /// At the cut `t` (s) of an event step (one lane): each joint whose status changed over the
    /// trial step (`pen0`, `pen1`: penetrations at its start and end, m) is put on the new side of the clearance
    /// circle (its position projected radially to `|delta| = 1e-6 |delta_0 - delta_1|`), so that
    /// the next substep starts with the new status, and the acceleration is recomputed from
    /// `M a = F(t) - K u - C v + contact(u, v)`: the right limit at a force discontinuity (the
    /// dashpot force jumps at entry), without which average acceleration integrates the jump
    /// over the next substep at first order.
    #[cold]
    pub(super) fn restart_at_event(&mut self, t: f64, pen0: &[f64], pen1: &[f64], record: bool) {
        let sh = &mut self.sh;
        let lane = &mut self.lanes[0];
        let is_gap = matches!(lane.settings.coupling, Coupling::Gap { .. });
        for jj in 0..lane.sys.joints.len() {
            // the trial step's end status is in `pen1`; the cut state `q` lies near the circle
            let (p0, p1) = (pen0[jj], pen1[jj]);
            if (p0 > 0.0) == (p1 > 0.0) {
                continue;
            }
            let entering = p1 > 0.0;
            let c = lane.sys.joints[jj].clearance;
            let q = lane.q[jj];
            let dr = norm2(q);
            let eps = 1e-6 * (p1 - p0).abs();
            let target = if entering { c + eps } else { c - eps };
            if dr > 0.0 && target > 0.0 {
                lane.q[jj] = [q[0] * target / dr, q[1] * target / dr];
                lane.pen[jj] = target - c;
                if is_gap {
                    lane.gap_closed[jj] = entering;
                    lane.gap_normal[jj] = [q[0] / dr, q[1] / dr];
                }
            }
        }
        // (the one lane's vectors; `rb` is free between steps)
        let (u, v) = (self.u.as_flattened(), self.v.as_flattened());
        let mut r = std::mem::take(&mut lane.rb);
        let pat = &lane.sys.pattern;
        pat.mul(&lane.sys.stiffness, u, &mut r);
        pat.mul(&lane.sys.damping, v, &mut lane.col);
        for (r, t) in r.iter_mut().zip(&lane.col) {
            *r = -*r - t;
        }
        lane.sys.frames_at(t, &mut lane.frames);
        lane.sys.add_inertia_load(&lane.frames, &mut r);
        for jj in 0..lane.sys.joints.len() {
            let (q, qd) = (lane.q[jj], lane.qd[jj]);
            let f = lane.contact_terms(jj, q, qd).force(q, qd);
            lane.force[jj] = f;
            let j = &lane.sys.joints[jj];
            for k in 0..j.ndof {
                r[j.dofs[k]] += j.coef[0][k] * f[0] + j.coef[1][k] * f[1];
            }
        }
        // the right-limit force at the cut (the dashpot spike at entry) lies between output steps
        // (adaptive steps record it later, in time order with the output instants)
        if record {
            lane.rec.record_event(t, &lane.pen, &lane.force, &lane.q, &lane.qd);
        }
        sh.mchol.solve_in_place(&mut r);
        set_lane(&mut self.a, 0, &r);
        if sh.alpha.is_some() {
            set_lane(&mut self.aa, 0, &r); // the alpha schemes restart with aa = a
        }
        lane.rb = r;
    }
}
