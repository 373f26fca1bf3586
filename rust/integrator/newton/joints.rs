//! The clearance joints seen from the unknowns: each endpoint's position and velocity, the joint's
//! relative displacement `q` and velocity, their derivatives, the contact law's terms at an iterate
//! (one evaluation, `contact::evaluation`), the joint force on the unknowns, and the margin the
//! carried-rate stop allows.

use super::*;

impl<'a> NewtonRun<'a> {
    /// Global elastic displacement and velocity of an endpoint, and the columns of `d q/d y`
    /// (unknown, column) and of the velocity's extra position dependence.
    #[inline(always)]
    fn endpoint_state(&self, e: &Endpoint, y: &[f64], yd: &[f64]) -> ([f64; 2], [f64; 2]) {
        match e {
            Endpoint::Node { link, node } => {
                let nt = self.nt(*link, *node);
                let z = &self.ydd; // unused by the first two rows
                let w = Self::local(nt, y, yd, z);
                let f = &self.frames[*link];
                let r = self.rots[*link];
                let (wl, wd) = (
                    [w[0][0], w[0][1]],
                    [w[1][0] - f.rate * w[0][1], w[1][1] + f.rate * w[0][0]],
                );
                (
                    [r[0][0] * wl[0] + r[0][1] * wl[1], r[1][0] * wl[0] + r[1][1] * wl[1]],
                    [r[0][0] * wd[0] + r[0][1] * wd[1], r[1][0] * wd[0] + r[1][1] * wd[1]],
                )
            }
            Endpoint::Body { .. } => ([0.0; 2], [0.0; 2]),
            Endpoint::Slider(s) => {
                let i = self.slider_dof[*s];
                let e = self.slider_dir[*s];
                let (sv, sd) = if i == NONE { (0.0, 0.0) } else { (y[i], yd[i]) };
                ([e[0] * sv, e[1] * sv], [e[0] * sd, e[1] * sd])
            }
        }
    }

    #[inline(always)]
    pub(super) fn joint_state(&self, j: usize, y: &[f64], yd: &[f64]) -> ([f64; 2], [f64; 2]) {
        let jt = &self.mech.joints[j];
        let (a, ad) = self.endpoint_state(&jt.journal, y, yd);
        let (b, bd) = self.endpoint_state(&jt.bearing, y, yd);
        let (q, qd) = ([a[0] - b[0], a[1] - b[1]], [ad[0] - bd[0], ad[1] - bd[1]]);
        if !self.nominal_offset[j] {
            return (q, qd);
        }
        // sides that move apart: the nominal relative position and velocity too
        let (pa, va) = self.mech.nominal_kinematics(&jt.journal, self.t_frames);
        let (pb, vb) = self.mech.nominal_kinematics(&jt.bearing, self.t_frames);
        (
            [q[0] + pa[0] - pb[0], q[1] + pa[1] - pb[1]],
            [qd[0] + va[0] - vb[0], qd[1] + va[1] - vb[1]],
        )
    }

    /// Derivative of an endpoint's global displacement with respect to its unknowns, as up to 2
    /// (unknown, column) pairs, and the extra velocity term `d qd/d y` (frame rotation).
    pub(super) fn endpoint_jac(&self, e: &Endpoint) -> EndpointJac {
        let mut out = [(NONE, [0.0; 2], [0.0; 2]); 3];
        match e {
            Endpoint::Node { link, node } => {
                let m = self.links[*link].nodes[*node];
                let f = &self.frames[*link];
                if m.lever != 0.0 && m.rot != NONE {
                    // node 1 of a rigid link: R [0, L] theta; velocity extra rate R S [0, L]
                    let r = self.rots[*link];
                    let col = [r[0][1] * m.lever, r[1][1] * m.lever];
                    out[2] = (m.rot, col, [-f.rate * col[1], f.rate * col[0]]);
                }
                match m.trans {
                    Trans::Local(ix) => {
                        let r = self.rots[*link];
                        for k in 0..2 {
                            // column k of R; velocity extra: rate R S e_k
                            let col = [r[0][k], r[1][k]];
                            let sk = if k == 0 { [0.0, 1.0] } else { [-1.0, 0.0] };
                            let rs = [r[0][0] * sk[0] + r[0][1] * sk[1], r[1][0] * sk[0] + r[1][1] * sk[1]];
                            out[k] = (ix[k], col, [f.rate * rs[0], f.rate * rs[1]]);
                        }
                    }
                    Trans::Global(ix) => {
                        out[0] = (ix[0], [1.0, 0.0], [0.0; 2]);
                        out[1] = (ix[1], [0.0, 1.0], [0.0; 2]);
                    }
                    Trans::Slider { s, slider } => {
                        out[0] = (s, self.slider_dir[slider], [0.0; 2]);
                    }
                    Trans::Fixed => {}
                }
            }
            Endpoint::Body { .. } => {}
            Endpoint::Slider(s) => {
                out[0] = (self.slider_dof[*s], self.slider_dir[*s], [0.0; 2]);
            }
        }
        out
    }

    /// Adds a global force `f` acting on the journal (and `-f` on the bearing) to `r`.
    pub(super) fn apply_joint_force(&self, j: usize, f: [f64; 2], r: &mut [f64]) {
        for (jac, sgn) in self.joint_jacs[j].iter().zip([1.0, -1.0]) {
            for &(i, col, _) in jac {
                if i != NONE {
                    r[i] += sgn * (col[0] * f[0] + col[1] * f[1]);
                }
            }
        }
    }

    /// The law of joint `j` at `(q, qd)`, within its contact episode when the law needs the
    /// approach speed ([`crate::contact::approach_speed`]).
    #[inline(always)]
    pub(super) fn law_terms(&self, j: usize, q: [f64; 2], qd: [f64; 2]) -> ContactTerms {
        let jt = &self.mech.joints[j];
        if let Some(sd) = &self.spring_dampers[j] {
            return sd.evaluate(q, qd, jt.clearance);
        }
        evaluation::law_terms(
            &*jt.law,
            jt.law.needs_approach_speed(),
            q,
            qd,
            jt.clearance,
            self.episode[j],
        )
    }

    /// The contact terms of every joint for the step ([`crate::contact::evaluation`]): with
    /// `from_start`, at the state of the step's start (`y`, `yd` hold it when called, before
    /// the predictors: lagged kappa, the force method, and the status the implicit contact
    /// starts from), else at the current iterate (implicit contact: spring and damping at the
    /// iterate, the spring by its tangent in the Jacobian, the dashpot left out after repeated
    /// status switches). With `tangent`, the implicit contact's spring tangent too (a step's
    /// start leaves it out: its first iteration evaluates the contact again, tangent included,
    /// before anything reads it).
    #[inline(always)]
    pub(super) fn evaluate_contacts(&mut self, from_start: bool, tangent: bool) {
        if self.cont.is_some() {
            self.continuous_terms(from_start);
            return;
        }
        let tracked = std::mem::take(&mut self.tracked_state);
        for j in 0..self.mech.joints.len() {
            let (mut q, qd) = if from_start {
                // the status switches of the step begun start at none (set here, joint by
                // joint: a `fill` is a `memset` call per step)
                self.switches[j] = 0;
                if tracked {
                    (self.jq[j], self.jqd[j])
                } else {
                    self.joint_state(j, &self.y, &self.yd)
                }
            } else {
                let st = self.joint_state(j, &self.y, &self.yd);
                self.jstate[j] = st;
                st
            };
            let hint = self.status_hint[j];
            if from_start && hint.is_finite() {
                let r = q[0].hypot(q[1]);
                if r > 0.0 {
                    q = [q[0] * hint / r, q[1] * hint / r];
                }
            }
            let jt = &self.mech.joints[j];
            let mut terms = self.law_terms(j, q, qd);
            if self.implicit_contact {
                if !from_start {
                    let was = self.contact[j].active();
                    (terms, _) = evaluation::iterated_terms(terms, was, &mut self.switches[j]);
                }
                if tangent {
                    let k = match &self.spring_dampers[j] {
                        Some(sd) => sd.spring_tangent(q, jt.clearance),
                        None => jt.law.spring_tangent(q, jt.clearance),
                    };
                    self.contact_tan[j] = (k, terms.c);
                }
            }
            if let Coupling::Force = self.settings.coupling {
                // Explicit: the whole force, frozen for the step.
                terms = evaluation::explicit_terms(&terms, q, qd);
            }
            self.contact[j] = terms;
        }
        self.jstate_fresh = !from_start;
    }

    /// The margin on the Newton tolerance with which a step may stop on the carried contraction
    /// rate ([`RATE_CARRY_DOWN`]) at the current iterate, `None` where it may not: every joint's
    /// contact status (closed or open) there must be the one its contact terms were evaluated at
    /// ([`Self::evaluate_contacts`]); with every joint open, or in a tolerance-driven run (whose
    /// error test judges the step), the margin is 1; in contact in a fixed-step run it is
    /// [`CONTACT_RATE_MARGIN`] where the step iterates on the Woodbury solver of a run that keeps
    /// its factors (a modified Newton, whose contraction is linear: the carried rate is a kept
    /// factor's, and a step on a factor made in it converges faster still), and there is no
    /// stop where every step's iterations are a full Newton's (a factor made every step, the
    /// refactorizing solver or the constant-rate stepper's exact factor, the contact's tangent
    /// at every iterate: quadratic, a carried rate understates the next step's error). Letting
    /// the steps on a new factor stop too (they did not before): crank-pin slider-crank at dt
    /// 1e-5 s, 0.1 s, 12028 -> 11337 iterations; slider-pin clearance, 0.02 s, 2.12 -> 1.50
    /// iterations a step and 3655 -> 2350 factorizations; the midspan against iterations to
    /// 1e-12 within 1.1e-6 and 7.4e-7 of its scale (1.1e-6 and 1.0e-4 before), the discretization
    /// error (against dt/8) 1.8e-2 and 0.12.
    #[inline(always)]
    pub(super) fn carried_rate_margin(&mut self) -> Option<f64> {
        let adaptive = self.settings.adaptive.is_some();
        let mut margin = 1.0;
        for j in 0..self.mech.joints.len() {
            let was = self.contact[j].active();
            if was && !adaptive {
                // a run that keeps its factors (jacobian_age > 1) carries a kept factor's rate,
                // which a step on a factor made in it (converging faster) only beats
                let kept = self.settings.solver == SolverMode::Woodbury
                    && (self.factor_made < self.steps_begun || self.settings.newton.jacobian_age > 1)
                    && self.rate.as_ref().is_some_and(|r| r.fixed_step.is_none());
                if !kept {
                    return None;
                }
                margin = CONTACT_RATE_MARGIN;
            }
            let (q, qd) = self.joint_state(j, &self.y, &self.yd);
            let terms = self.law_terms(j, q, qd);
            self.margin_terms[j] = (q, qd, terms);
            if terms.active() != was {
                return None;
            }
        }
        Some(margin)
    }
}
