//! What a step hands the record: the clearance joints' extremes, impacts and contact episodes, the
//! sliders' motion along their guides, the links' midspan deflection and axial force, and the
//! histories' storage.

use super::*;

impl<'a> NewtonRun<'a> {
    /// Reserves the histories of a run of `steps` grid steps up front: the samples of the output
    /// grid (every `RecordSpec::every`-th step, the first and the last), at most
    /// [`INITIAL_SAMPLES`](crate::record::INITIAL_SAMPLES) of them (a longer run grows its
    /// histories as it goes), for the channels the record keeps. Without it each history grew by
    /// doubling, copying what it held (5 M of the 219 M instructions of the crank-pin
    /// slider-crank's 0.1 s with the default record).
    pub(super) fn reserve_histories(&mut self, steps: u64) {
        if !self.keep_grid {
            return;
        }
        let rec = &self.settings.record;
        let samples = crate::record::initial_samples(steps, rec.every);
        reserve_now(&mut self.hist_time, samples);
        let ch = rec.links;
        for (li, hist) in self.hist_links.iter_mut().enumerate() {
            let l = &self.mech.links[li];
            reserve_now(&mut hist.frame, samples);
            if ch.displacements {
                reserve_now(&mut hist.displacements, samples * 3 * l.nodes());
            }
            if ch.axial_force {
                reserve_now(&mut hist.axial_force, samples * l.section.elements);
            }
            if ch.midspan {
                reserve_now(&mut hist.midspan, samples);
            }
            if ch.energy {
                for v in [&mut hist.kinetic, &mut hist.strain, &mut hist.momentum] {
                    reserve_now(v, samples);
                }
            }
        }
        for h in &mut self.hist_joints {
            reserve_now(&mut h.penetration, samples);
            reserve_now(&mut h.force, samples);
            if rec.joint_position {
                reserve_now(&mut h.qx, samples);
                reserve_now(&mut h.qy, samples);
            }
        }
        if self.keep_sliders {
            for h in &mut self.hist_sliders {
                for v in [&mut h.position, &mut h.velocity, &mut h.acceleration] {
                    reserve_now(v, samples);
                }
            }
        }
    }

    /// Records the state at `t` (s) into the histories; with `tracked`, the joints' relative
    /// displacements, penetrations and forces are those [`Self::track_joints`] computed at this
    /// state and these frames (not computed again).
    pub(super) fn record(&mut self, t: f64, tracked: bool) {
        if !self.keep_grid {
            return;
        }
        let settings = self.settings;
        let rec = &settings.record;
        let mut buf = std::mem::take(&mut self.node_states);
        self.hist_time.push(t);
        for li in 0..self.links.len() {
            let l = &self.mech.links[li];
            let f = self.frames[li];
            // the link's node transforms; the history borrowed beside them (fields apart)
            let nts = &self.node_ts[self.node_off[li]..];
            let hist = &mut self.hist_links[li];
            hist.frame.push([f.origin[0], f.origin[1], f.angle, f.rate]);
            let nn = l.nodes();
            let ch = rec.links;
            let need_w = ch.displacements || ch.axial_force || ch.midspan || ch.energy;
            if ch.displacements && !(ch.axial_force || ch.midspan || ch.energy) {
                // the displacements alone (the default): nodes plain on consecutive unknowns
                // are a slice of `y` (their local states' displacements, T = I)
                for run in &self.disp_runs[li] {
                    match *run {
                        DispRun::Slice { first, len } => {
                            hist.displacements.extend_from_slice(&self.y[first..first + len])
                        }
                        DispRun::Node(nd) => hist
                            .displacements
                            .extend_from_slice(&Self::local_displacement(&nts[nd], &self.y)),
                    }
                }
            } else if need_w {
                buf.clear();
                for nd in 0..nn {
                    buf.push(Self::local(&nts[nd], &self.y, &self.yd, &self.ydd));
                }
                if ch.displacements {
                    for w in &buf {
                        hist.displacements.extend_from_slice(&w[0]);
                    }
                }
                let ld = &self.links[li];
                let e = l.element();
                if ch.axial_force {
                    for k in 0..l.section.elements {
                        hist.axial_force.push(ld.ea_l * (buf[k + 1][0][0] - buf[k][0][0]));
                    }
                }
                if ch.midspan {
                    hist.midspan.push(midspan(&e, l.section.elements, |k| buf[k][0]));
                }
                if ch.energy {
                    let r = self.rots[li];
                    let v0 = [
                        r[0][0] * f.origin_vel[0] + r[1][0] * f.origin_vel[1],
                        r[0][1] * f.origin_vel[0] + r[1][1] * f.origin_vel[1],
                    ];
                    let (mut te, mut ve, mut he) = (0.0, 0.0, 0.0);
                    let le = l.element_length();
                    if let Some(b) = l.rigid {
                        // the rigid body: node 0 at P (velocity V, link axes), turning at
                        // rate + theta-dot, centroid at R(theta) (c, 0) from node 0
                        let w = &buf[0];
                        let (p, th) = ([w[0][0], w[0][1]], w[0][2]);
                        let vel = [v0[0] - f.rate * p[1] + w[1][0], v0[1] + f.rate * p[0] + w[1][1]];
                        let om = f.rate + w[1][2];
                        let rc = [b.centroid * th.cos(), b.centroid * th.sin()];
                        let src = [-om * rc[1], om * rc[0]];
                        let j0 = b.inertia + b.mass * b.centroid * b.centroid;
                        let cross = |a: [f64; 2], c: [f64; 2]| a[0] * c[1] - a[1] * c[0];
                        te += 0.5 * b.mass * (vel[0] * vel[0] + vel[1] * vel[1])
                            + b.mass * (vel[0] * src[0] + vel[1] * src[1])
                            + 0.5 * j0 * om * om;
                        he += b.mass * (cross(p, vel) + cross(p, src) + cross(rc, vel)) + j0 * om;
                    }
                    for k in (0..l.section.elements).filter(|_| l.rigid.is_none()) {
                        let (q, qd) = (
                            element_vec(&buf[k], &buf[k + 1], 0),
                            element_vec(&buf[k], &buf[k + 1], 1),
                        );
                        let (tk, hk) = e.kinetic_terms(k as f64 * le, &q, &qd, v0, f.rate);
                        te += tk;
                        he += hk;
                        ve += 0.5 * q.dot(&(ld.k1 * q));
                    }
                    for (nd, w) in buf.iter().enumerate() {
                        let m = ld.point_mass[nd];
                        if m > 0.0 {
                            let px = nd as f64 * le + w[0][0];
                            let py = w[0][1];
                            let vx = v0[0] - f.rate * py + w[1][0];
                            let vy = v0[1] + f.rate * px + w[1][1];
                            te += 0.5 * m * (vx * vx + vy * vy);
                            he += m * (px * vy - py * vx);
                        }
                    }
                    hist.kinetic.push(te);
                    hist.strain.push(ve);
                    hist.momentum.push(he);
                }
            }
        }
        self.node_states = buf;
        for j in 0..self.mech.joints.len() {
            let Some(slot) = self.hist_slot[j] else {
                continue;
            };
            let (q, pen, f) = if tracked {
                (self.jq[j], self.jpen[j], self.jforce[j])
            } else {
                let (q, qd) = self.joint_state(j, &self.y, &self.yd);
                let terms = self.law_terms(j, q, qd);
                let mut pen = terms.penetration;
                let mut f = self.recorded_joint_force(j, &terms, q, qd);
                if let Some(c) = &self.cont {
                    (pen, f) = c.recorded(j, q, self.mech.joints[j].clearance);
                }
                (q, pen, f)
            };
            let h = &mut self.hist_joints[slot];
            h.penetration.push(pen);
            h.force.push((f[0] * f[0] + f[1] * f[1]).sqrt());
            if settings.record.joint_position {
                h.qx.push(q[0]);
                h.qy.push(q[1]);
            }
            if let Some(s) = self.joint_friction(j, 0.0) {
                let h = &mut self.hist_joints[slot];
                h.friction.push(s.eval.force);
                h.slip.push(s.slip);
            }
        }
    }

    /// The recorded force (N, on the journal) of joint `j` at state `(q, qd)` (m, m/s), whose law
    /// terms there are `terms`: the terms that acted in the step applied to the state
    /// ([`evaluation::recorded_force`]), or at an interpolated output instant
    /// ([`Self::output_interpolated`]) the law's own force there.
    #[inline(always)]
    fn recorded_joint_force(&self, j: usize, terms: &ContactTerms, q: [f64; 2], qd: [f64; 2]) -> [f64; 2] {
        if self.output_interpolated {
            terms.force(q, qd)
        } else {
            evaluation::recorded_force(&self.contact[j], q, qd)
        }
    }

    /// Tracks the joints at the current state, time `t` (s): the running extremes, and the
    /// shared recorder, as step `step` of length `dt` (s) or, with `step = None`, at the cut of
    /// an event step. Nothing before [`RecordSpec::start`] counts. With `margin`, each joint's
    /// state and terms are those the step's carried-rate stop evaluated at this state
    /// ([`Self::margin_terms`]).
    #[inline(always)]
    pub(super) fn track_joints(&mut self, t: f64, step: Option<(u64, f64)>, margin: bool) {
        let counts = t >= self.settings.record.start;
        for j in 0..self.mech.joints.len() {
            let (q, qd, mut terms) = if margin {
                self.margin_terms[j]
            } else {
                let (q, qd) = self.joint_state(j, &self.y, &self.yd);
                (q, qd, self.law_terms(j, q, qd))
            };
            let mut f = self.recorded_joint_force(j, &terms, q, qd);
            if let Some(c) = &self.cont {
                // the continuous-contact model: its status and its normal force (no law)
                (terms.penetration, f) = c.recorded(j, q, self.mech.joints[j].clearance);
            }
            let fmag = (f[0] * f[0] + f[1] * f[1]).sqrt();
            let h = &mut self.track[j];
            if counts {
                h.max_penetration = h.max_penetration.max(terms.penetration);
                h.max_force = h.max_force.max(fmag);
            }
            if self.mech.joints[j].law.needs_approach_speed() {
                self.episode[j] = crate::contact::next_episode(q, qd, terms.penetration, self.episode[j]);
            }
            (self.jpen[j], self.jforce[j], self.jq[j], self.jqd[j]) = (terms.penetration, f, q, qd);
            if let Some(s) = self.joint_friction(j, 0.0) {
                // the work of the step on the trapezoidal rule of Newmark's average
                // acceleration: -(F0 + F1) / 2 (v0 + v1) / 2 dt
                let (ft, v) = (s.eval.force, s.slip);
                let tr = &mut self.fric_track[j];
                if counts {
                    if let Some((t0, f0, v0)) = tr.last {
                        tr.work -= 0.25 * (f0 + ft) * (v0 + v) * (t - t0);
                    }
                }
                tr.last = Some((t, ft, v));
            }
        }
        match step {
            Some((k, dt)) => self
                .rec
                .record(k, t, dt, &self.jpen, &self.jforce, &self.jq, &self.jqd, &[]),
            None => self.rec.record_event(t, &self.jpen, &self.jforce, &self.jq, &self.jqd),
        }
    }

    /// The sliders' motion along their guides at `t` (s), nominal path plus elastic unknown, into
    /// the recorder: the peak acceleration (from [`RecordSpec::start`] on), and at an output step
    /// (`keep`) the histories (when kept) and the deviation from
    /// [`RecordSpec::slider_reference`] (from `start` on; the reference's grid was checked against
    /// the run's in [`Self::new`], so the run's output point `k` is the reference's point `k`).
    #[inline(always)]
    pub(super) fn track_sliders(&mut self, t: f64, keep: bool) {
        let settings = self.settings;
        let counted = t >= settings.record.start;
        let reference = settings.record.slider_reference.as_deref().filter(|_| keep);
        let point = self.slider_point;
        for (s, sl) in self.mech.sliders.iter().enumerate() {
            // the guide's frame of the current frames where they are of `t` (bitwise), else
            // solved at `t`; its unit direction as computed once
            let fs = if t == self.t_frames {
                self.slider_frames[s]
            } else {
                sl.path.frame(t)
            };
            let e = self.slider_dir[s];
            let along = |v: [f64; 2]| e[0] * v[0] + e[1] * v[1];
            let i = self.slider_dof[s];
            let own = if i == NONE {
                [0.0; 3]
            } else {
                [self.y[i], self.yd[i], self.ydd[i]]
            };
            let state = [
                along(fs.origin) + own[0],
                along(fs.origin_vel) + own[1],
                along(fs.origin_acc) + own[2],
            ];
            let h = &mut self.hist_sliders[s];
            h.take(state, counted, keep && self.keep_sliders);
            if let Some(r) = reference.filter(|_| counted) {
                // the grids line up (checked), so `point` is in range; NaN (never a misaligned
                // point) should they not
                let at = |c: usize| {
                    r.sliders
                        .get(s)
                        .and_then(|h| h.1[c].get(point))
                        .copied()
                        .unwrap_or(f64::NAN)
                };
                h.deviate(state, [at(0), at(1), at(2)]);
            }
        }
        if keep {
            self.slider_point += 1;
        }
    }

    /// The running peaks of every flexible link ([`LinkHistory::peaks`], with
    /// `RecordSpec::links.peaks`) at the current state and node transforms at `t` (s), from
    /// [`RecordSpec::start`] on: the largest magnitude of the midspan deflection and of each
    /// element's axial force, the channels [`Self::record`] keeps.
    #[inline(always)]
    pub(super) fn track_links(&mut self, t: f64) {
        if !self.settings.record.links.peaks || t < self.settings.record.start {
            return;
        }
        for (li, l) in self.mech.links.iter().enumerate() {
            let Some(p) = self.hist_links[li].peaks.as_mut() else {
                continue;
            };
            let nts = &self.node_ts[self.node_off[li]..];
            let w = |nd: usize| Self::local_displacement(&nts[nd], &self.y);
            let ea_l = self.links[li].ea_l;
            let mut u0 = w(0)[0];
            for k in 1..l.nodes() {
                let u1 = w(k)[0];
                p.axial_force = p.axial_force.max((ea_l * (u1 - u0)).abs());
                u0 = u1;
            }
            p.midspan = p.midspan.max(midspan(&l.element(), l.section.elements, w).abs());
        }
    }

    /// Penetrations `|q| - c` (m) of the clearance joints at the current state and frames.
    pub(super) fn penetrations(&self, out: &mut Vec<f64>) {
        out.clear();
        for (j, jt) in self.mech.joints.iter().enumerate() {
            let (q, _) = self.joint_state(j, &self.y, &self.yd);
            out.push(q[0].hypot(q[1]) - jt.clearance);
        }
    }
}
