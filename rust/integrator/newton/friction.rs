//! Friction in clearance joints (docs/contact.md section 4.1): the slip speed from both sides'
//! translations and spins, the law's force and moments on the unknowns, and its tangent in the
//! refactorized Jacobian.

use super::*;

impl<'a> NewtonRun<'a> {
    /// The total angular velocity of an endpoint (rad/s: frame rate plus elastic rotation rate)
    /// and its rotation unknown (`NONE` for a rigid-body point, a slider, or a node whose
    /// rotation is held).
    fn endpoint_spin(&self, e: &Endpoint) -> (f64, usize) {
        match e {
            Endpoint::Node { link, node } => {
                let rot = self.links[*link].nodes[*node].rot;
                let w = if rot == NONE { 0.0 } else { self.yd[rot] };
                (self.frames[*link].rate + w, rot)
            }
            Endpoint::Body { frame, .. } => (frame.frame(self.t_frames).rate, NONE),
            Endpoint::Slider(_) => (0.0, NONE),
        }
    }

    /// The friction of joint `j` at the current iterate, over a step of `h` (s) from the last
    /// accepted bristle state (docs/contact.md, "Friction in the joint"): the normal force is
    /// that of the contact terms acting in the step (`self.contact`, as the residual applies
    /// it), the slip speed `v = (v_J - v_B) . t + R_J w_J - R_B w_B` with `t = S n`. An open
    /// joint (no compressive normal force) carries no friction and its bristle state is reset.
    /// `None` for a joint without friction.
    #[inline(always)]
    pub(super) fn joint_friction(&self, j: usize, h: f64) -> Option<JointFrictionState> {
        // `friction`: whether any joint has friction. A mechanism without it asks nothing of its
        // joints, in the caller (the recording and the joint tracking ask for every joint at
        // every step: the call itself cost about 70 instructions a step)
        if !self.friction {
            return None;
        }
        self.friction_of_joint(j, h)
    }

    /// [`Self::joint_friction`] where some joint of the mechanism has friction.
    fn friction_of_joint(&self, j: usize, h: f64) -> Option<JointFrictionState> {
        let jt = &self.mech.joints[j];
        let fr = jt.friction.as_ref()?;
        let (q, qd) = self.joint_state(j, &self.y, &self.yd);
        let f = self.contact[j].force(q, qd);
        let (wj, _) = self.endpoint_spin(&jt.journal);
        let (wb, _) = self.endpoint_spin(&jt.bearing);
        let Some(sl) = evaluation::slip(q, qd, f, wj, wb, fr.journal_radius, jt.clearance) else {
            return Some(JointFrictionState::default());
        };
        let (n, t, slip, f_n) = (sl.n, sl.t, sl.speed, sl.normal_force);
        if f_n <= 0.0 {
            return Some(JointFrictionState {
                slip,
                t,
                ..Default::default()
            });
        }
        let eval = fr.law.evaluate(self.fric_z[j], slip, f_n, h);
        Some(JointFrictionState {
            eval,
            slip,
            t,
            // the secant only for Coulomb, whose regularization has the kinks (LuGre's force at a
            // vanishing slip is the bristles' and finite: its secant would be unbounded)
            kf: if self.fric_secant && slip != 0.0 && !fr.law.has_state() {
                (-eval.dforce_dv).max(-eval.force / slip).max(0.0)
            } else {
                (-eval.dforce_dv).max(0.0)
            },
            kn: eval.dforce_dn,
            n,
        })
    }

    /// Evaluates every joint's friction at the current iterate (step `h`, s) into `self.fric`.
    pub(super) fn evaluate_friction(&mut self, h: f64) {
        for j in 0..self.mech.joints.len() {
            if let Some(s) = self.joint_friction(j, h) {
                self.fric[j] = s;
            }
        }
    }

    /// Adds the friction of every joint at the current iterate to the residual `r` (moved to
    /// the left: minus): the force `F_t t` on the journal and `-F_t t` on the bearing, the
    /// moment `F_t R_J` on the journal's rotation and `-F_t R_B` on the bearing's.
    pub(super) fn apply_friction(&mut self, h: f64, r: &mut [f64]) {
        self.evaluate_friction(h);
        for j in 0..self.mech.joints.len() {
            let jt = &self.mech.joints[j];
            let Some(fr) = jt.friction.as_ref() else {
                continue;
            };
            let s = self.fric[j];
            let ft = s.eval.force;
            if ft == 0.0 {
                continue;
            }
            self.apply_joint_force(j, [-ft * s.t[0], -ft * s.t[1]], r);
            let rj = fr.journal_radius;
            let (_, ij) = self.endpoint_spin(&jt.journal);
            let (_, ib) = self.endpoint_spin(&jt.bearing);
            if ij != NONE {
                r[ij] -= ft * rj;
            }
            if ib != NONE {
                r[ib] += ft * (rj + jt.clearance);
            }
        }
    }

    /// Adds the friction tangent to the Jacobian: with `g` the derivative of the slip speed with
    /// respect to the velocities (`t` on the journal's translations, `-t` on the bearing's,
    /// `R_J` and `-R_B` on the rotations) and `kf = -dF/dv >= 0`, the term
    /// `kf g (gh g + bh2 g_v)^T` (`g_v`: the frame-rotation part of the velocity), symmetric in
    /// `g`; and the normal force's part `-g dF_t/dF_N p^T`, `p` the derivative of `F_N` with
    /// respect to the accelerations through the contact tangent acting in the step
    /// (unsymmetric). The turning of `t` with the position stays out (a modified Newton on it).
    pub(super) fn assemble_friction(&self, bh2: f64, gh: f64, lu: &mut BandLu) {
        for j in 0..self.mech.joints.len() {
            let jt = &self.mech.joints[j];
            let Some(fr) = jt.friction.as_ref() else {
                continue;
            };
            let s = self.fric[j];
            if s.kf == 0.0 && s.kn == 0.0 {
                continue;
            }
            // both sides' up to 3 translation-like unknowns (a rigid link's node 1 moves with its
            // rotation too), then the two spins
            let mut g = [(NONE, 0.0, 0.0); 8];
            let dot = |a: [f64; 2]| a[0] * s.t[0] + a[1] * s.t[1];
            for (k, (i, col, v)) in self.endpoint_jac(&jt.journal).into_iter().enumerate() {
                g[k] = (i, dot(col), dot(v));
            }
            for (k, (i, col, v)) in self.endpoint_jac(&jt.bearing).into_iter().enumerate() {
                g[3 + k] = (i, -dot(col), -dot(v));
            }
            let rj = fr.journal_radius;
            g[6] = (self.endpoint_spin(&jt.journal).1, rj, 0.0);
            g[7] = (self.endpoint_spin(&jt.bearing).1, -(rj + jt.clearance), 0.0);
            // the normal force's dependence on the joint's displacement and velocity,
            // dF_N = n^T (K dq + C dqd) with the contact tangent (K, C) acting in the step: the
            // row p of dF_N / da over the translations of both sides (unsymmetric)
            let (kq, cq) = match self.settings.coupling {
                Coupling::Force => ([[0.0; 2]; 2], [[0.0; 2]; 2]),
                _ if self.implicit_contact => self.contact_tan[j],
                _ => (self.contact[j].k, self.contact[j].c),
            };
            let nk = [
                s.n[0] * kq[0][0] + s.n[1] * kq[1][0],
                s.n[0] * kq[0][1] + s.n[1] * kq[1][1],
            ];
            let nc = [
                s.n[0] * cq[0][0] + s.n[1] * cq[1][0],
                s.n[0] * cq[0][1] + s.n[1] * cq[1][1],
            ];
            let mut p = [(NONE, 0.0); 6];
            let a = self.endpoint_jac(&jt.journal);
            let b = self.endpoint_jac(&jt.bearing);
            for (k, ((i, col, v), sgn)) in a
                .into_iter()
                .map(|x| (x, 1.0))
                .chain(b.into_iter().map(|x| (x, -1.0)))
                .enumerate()
            {
                let d = |w: [f64; 2], u: [f64; 2]| w[0] * u[0] + w[1] * u[1];
                p[k] = (i, sgn * (bh2 * d(nk, col) + gh * d(nc, col) + bh2 * d(nc, v)));
            }
            for (i, gi, _) in g {
                if i == NONE || gi == 0.0 {
                    continue;
                }
                for (jj, gj, vj) in g {
                    if jj == NONE {
                        continue;
                    }
                    let v = s.kf * gi * (gh * gj + bh2 * vj);
                    if v != 0.0 {
                        lu.add(i, jj, v);
                    }
                }
                if s.kn != 0.0 {
                    for (jj, pj) in p {
                        if jj != NONE && pj != 0.0 {
                            lu.add(i, jj, -gi * s.kn * pj);
                        }
                    }
                }
            }
        }
    }
}
