//! The continuous-contact (massless-link) model of a clearance joint on the Newton stepper
//! (`method="continuous"`, [`Coupling::Continuous`](crate::contact::Coupling::Continuous)): Earles & Wu (1977), "A determination of
//! contact-loss at a bearing of a linkage mechanism", ASME J. Eng. Ind. 99(2):375, and Haines
//! (1980). The journal is kept on the bearing circle, the contact direction is an unknown and the
//! normal force is a result; the model holds while that force is compressive.
//!
//! Per joint the state is *attached* or *free*:
//!
//! - **attached**: the constraint `g = |q| - c = 0` on the step's end state (`q` the journal's
//!   position relative to the bearing centre, m) with the normal force `lambda` (N, positive
//!   when compressive; the force on the journal is `-lambda n`, `n = q/|q|`) an unknown of the
//!   step. Each Newton iteration solves the bordered system
//!   `[J  B; beta h^2 B^T  0] [da; dlambda] = [-R; -g]` (`B` the columns `P^T n` of the joints, `P` the derivative of `q` with respect to
//!   the unknowns) by block elimination on the band LU of `J`: one extra solve per attached
//!   joint and a small dense system of the attached joints. The turning of `n` with `q` enters `J`
//!   as the stiffness `lambda/|q| (I - n n^T)` (the contact tangent slot of the implicit
//!   contact), so the iteration is Newton's on both unknowns.
//! - **loss of contact**: a step whose mean normal force `(lambda_n + lambda_(n+1))/2` is
//!   tensile is redone with the joint free; the loss instant is interpolated linearly in
//!   `lambda` between the step's ends and closes the joint's contact episode in the impact log
//!   (exact to the interpolation, as an event-aware step would record it). The mean, not the
//!   end value: with the trapezoidal rule (`gamma = 1/2`, not L-stable) the modes a step does not
//!   resolve keep their amplitude and flip sign every step, and so does their share of `lambda`
//!   (on the slider-yoke at dt 1e-5 s the end values turned tensile two steps after every
//!   attachment); the mean is the impulse the rule applies over the step, divided by its length.
//!   It is also the recorded force.
//! - **free**: no force, until a step ends with `|q| > c`; that step is redone attached (the
//!   journal ends it on the circle) and the state is then made consistent with the constraint:
//!   the normal relative velocity is removed by the mass-weighted impulse (a perfectly plastic
//!   impact, `e = 0`) and the accelerations and `lambda` are those of the constrained equations
//!   at that state (the acceleration-level constraint `d^2|q|/dt^2 = 0`). The same restart makes
//!   a journal that starts on the wall (`|q| >= c (1 - 1e-9)`) attached and consistent at `t =
//!   0`; a journal that starts inside flies free to the wall.
//!
//! A joint changes its status at most once per step (a loss then a re-attachment within one step
//! waits for the next step). The recorded penetration is the smallest positive double while
//! attached (so the recorder counts the joint closed; no law, no penetration) and `|q| - c`
//! while free; the recorded force is `-lambda n` with the step's mean `lambda`. With the
//! trapezoidal rule a hard constraint keeps any inconsistency of the accelerations as an undamped
//! alternation; the consistent restarts at every attachment keep it at the level of the step's
//! error.
//!
//! Not offered: adaptive steps, event-aware stepping (the loss instant is interpolated instead),
//! the constant and constant-rate steppers, a zero clearance (an ideal pin).

use super::NewtonRun;
use crate::contact::ContactTerms;
use crate::error::{Error, Result};
use crate::linalg::solve_dense_in_place;
use crate::model::mechanism::{Clearance, Endpoint};
use crate::plan::dofs::NONE;
use crate::run::Settings;

/// The recorded penetration of an attached joint, m: the smallest positive double.
const ATTACHED_PEN: f64 = f64::from_bits(1);

/// A journal within this relative distance of the wall at the start is attached there.
const START_ON_WALL: f64 = 1e-9;

/// Half-width of the central difference of the nominal relative velocity of joints whose sides
/// move apart (their nominal relative acceleration), s.
const NOMINAL_FD: f64 = 1e-6;

/// The settings the model runs with: fixed steps without events.
pub(super) fn validate(settings: &Settings) -> Result<()> {
    if settings.adaptive.is_some() {
        return Err(Error::param(
            "tol",
            "a tolerance",
            "None with method=\"continuous\" (the continuous-contact model runs on fixed steps)",
        ));
    }
    if settings.events {
        return Err(Error::param(
            "events",
            true,
            "False with method=\"continuous\" (the loss instant is interpolated within the step)",
        ));
    }
    Ok(())
}

/// A joint the model can hold: a clearance > 0 (with none the joint is an ideal pin).
pub(super) fn check_joint(j: &Clearance) -> Result<()> {
    if !(j.clearance > 0.0 && j.clearance.is_finite()) {
        return Err(Error::param(
            format!("joints[{:?}].clearance", j.name),
            j.clearance,
            "> 0 m with method=\"continuous\" (a zero clearance is an ideal pin: model it as a pin)",
        ));
    }
    if j.friction.is_some() {
        // the friction law reads the normal force of the penalty contact terms, which this
        // model replaces by its multiplier
        return Err(Error::param(
            format!("joints[{:?}].friction", j.name),
            "a friction law",
            "None with method=\"continuous\" (friction takes the penalty laws' normal force)",
        ));
    }
    Ok(())
}

/// The state of the continuous-contact joints and the scratch of their bordered solves (sized
/// once: nothing allocates in the time loop).
pub(super) struct Contact {
    /// Per joint: on the wall (the constraint holds).
    attached: Vec<bool>,
    /// Per joint: the normal force, N (compressive > 0), at the current iterate or state.
    lambda: Vec<f64>,
    /// Per joint: the normal force the last step applied, N: the mean of its ends' (the
    /// trapezoidal impulse over the step divided by its length), or the consistent force after
    /// an attachment.
    mean: Vec<f64>,
    saved_attached: Vec<bool>,
    saved_lambda: Vec<f64>,
    /// The state at the step's start (for a step redone with a changed status).
    saved: [Vec<f64>; 4],
    /// Per joint: the status changed in this step.
    flipped: Vec<bool>,
    /// Per joint: attached in this step, left out of a restart at the step's start.
    pending: Vec<bool>,
    /// Loss instants of this step: (joint, time, s).
    losses: Vec<(usize, f64)>,
    /// Attached joints of the current solve, and per slot the column `P^T n`, its solve, the
    /// joint's normal and constraint value.
    active: Vec<usize>,
    b: Vec<Vec<f64>>,
    y: Vec<Vec<f64>>,
    n: Vec<[f64; 2]>,
    s: Vec<f64>,
    s2: Vec<f64>,
    rhs: Vec<f64>,
    pen: Vec<f64>,
    force: Vec<[f64; 2]>,
}

impl Contact {
    /// The state for `nj` joints on `n` unknowns (every joint free until the start places it).
    pub(super) fn new(nj: usize, n: usize) -> Self {
        Contact {
            attached: vec![false; nj],
            lambda: vec![0.0; nj],
            mean: vec![0.0; nj],
            saved_attached: vec![false; nj],
            saved_lambda: vec![0.0; nj],
            saved: [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            flipped: vec![false; nj],
            pending: vec![false; nj],
            losses: Vec::with_capacity(nj),
            active: Vec::with_capacity(nj),
            b: vec![vec![0.0; n]; nj],
            y: vec![vec![0.0; n]; nj],
            n: vec![[0.0; 2]; nj],
            s: vec![0.0; nj * nj],
            s2: vec![0.0; nj * nj],
            rhs: vec![0.0; nj],
            pen: vec![0.0; nj],
            force: vec![[0.0; 2]; nj],
        }
    }

    /// The recorded penetration (m) and force on the journal (N) of joint `j` at `q` (m), with
    /// clearance `c` (m): see the module documentation.
    pub(super) fn recorded(&self, j: usize, q: [f64; 2], c: f64) -> (f64, [f64; 2]) {
        let r = q[0].hypot(q[1]);
        if self.attached[j] && r > 0.0 {
            let l = self.mean[j];
            (ATTACHED_PEN, [-l * q[0] / r, -l * q[1] / r])
        } else {
            (r - c, [0.0; 2])
        }
    }
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl NewtonRun<'_> {
    /// The contact terms of the joints at the current state: an attached joint's force `-lambda
    /// n` at `q` (the explicit part) with the turning of `n` as its stiffness, `lambda/|q| (I - n
    /// n^T)` (also the Jacobian's tangent); a free joint has none.
    pub(super) fn continuous_terms(&mut self, _from_start: bool) {
        let c = self.cont.as_ref().expect("continuous-contact run");
        for j in 0..self.mech.joints.len() {
            let (q, _) = self.joint_state(j, &self.y, &self.yd);
            let r = q[0].hypot(q[1]);
            let mut t = ContactTerms {
                penetration: r - self.mech.joints[j].clearance,
                ..Default::default()
            };
            let mut kt = [[0.0; 2]; 2];
            if c.attached[j] && r > 0.0 {
                let (l, n) = (c.lambda[j], [q[0] / r, q[1] / r]);
                for a in 0..2 {
                    for b in 0..2 {
                        let id = if a == b { 1.0 } else { 0.0 };
                        kt[a][b] = l / r * (id - n[a] * n[b]);
                    }
                }
                t.k = kt;
                for a in 0..2 {
                    t.f_explicit[a] = -l * n[a] + kt[a][0] * q[0] + kt[a][1] * q[1];
                }
            }
            self.contact[j] = t;
            self.contact_tan[j] = (kt, [[0.0; 2]; 2]);
        }
    }

    /// The columns `P^T n` of the attached joints at the current state into `c.b`, their
    /// solves with the factorized matrix into `c.y`, and `S = B^T Y` into `c.s` (and `c.s2`).
    /// Returns the number of attached joints.
    fn constraint_columns(&self, c: &mut Contact) -> usize {
        c.active.clear();
        for j in 0..self.mech.joints.len() {
            if c.attached[j] {
                c.active.push(j);
            }
        }
        let m = c.active.len();
        for a in 0..m {
            let j = c.active[a];
            let (q, _) = self.joint_state(j, &self.y, &self.yd);
            let r = q[0].hypot(q[1]);
            // a journal at the bearing centre has no normal: NaN fails the step (not converged)
            let n = if r > 0.0 { [q[0] / r, q[1] / r] } else { [f64::NAN; 2] };
            c.n[a] = n;
            c.b[a].fill(0.0);
            self.apply_joint_force(j, n, &mut c.b[a]);
            c.y[a].copy_from_slice(&c.b[a]);
            self.lu.solve_in_place(&mut c.y[a]);
        }
        for a in 0..m {
            for b in 0..m {
                c.s[a * m + b] = dot(&c.b[a], &c.y[b]);
            }
        }
        c.s2[..m * m].copy_from_slice(&c.s[..m * m]);
        m
    }

    /// The bordered Newton correction of one iteration: `dx` holds `J^{-1} R` (the step applies
    /// `da = -dx`); adds the attached joints' `Y dlambda` with `S dlambda = g / (beta h^2) - B^T
    /// dx` (the linearized constraints at the new iterate) and updates `lambda`. A singular `S`
    /// (a joint whose journal cannot move normally) gives a non-finite correction: the step is
    /// not converged.
    pub(super) fn constraint_correction(&mut self, bh2: f64, dx: &mut [f64]) -> Result<()> {
        let mut c = self.cont.take().expect("continuous-contact run");
        let m = self.constraint_columns(&mut c);
        for a in 0..m {
            let j = c.active[a];
            let (q, _) = self.joint_state(j, &self.y, &self.yd);
            let g = q[0].hypot(q[1]) - self.mech.joints[j].clearance;
            c.rhs[a] = g / bh2 - dot(&c.b[a], dx);
        }
        if m > 0 {
            let ratio = solve_dense_in_place(&mut c.s[..m * m], &mut c.rhs[..m], m);
            if ratio.is_nan() || ratio <= 0.0 {
                c.rhs[..m].fill(f64::NAN);
            }
        }
        for a in 0..m {
            let dl = c.rhs[a];
            c.lambda[c.active[a]] += dl;
            for (d, y) in dx.iter_mut().zip(&c.y[a]) {
                *d += y * dl;
            }
        }
        self.cont = Some(c);
        Ok(())
    }

    /// The global acceleration of endpoint `e` (m/s^2) with the unknowns' accelerations `ydd`
    /// (and the current `y`, `yd`, frames): `R (w'' + 2 om S w' + al S w - om^2 w)` for a node,
    /// along the guide for a slider.
    fn endpoint_accel(&self, e: &Endpoint, ydd: &[f64]) -> [f64; 2] {
        match e {
            Endpoint::Node { link, node } => {
                let nt = self.nt(*link, *node);
                let w = Self::local(nt, &self.y, &self.yd, ydd);
                let f = &self.frames[*link];
                let (om, al) = (f.rate, f.accel);
                let l = [
                    w[2][0] - 2.0 * om * w[1][1] - al * w[0][1] - om * om * w[0][0],
                    w[2][1] + 2.0 * om * w[1][0] + al * w[0][0] - om * om * w[0][1],
                ];
                let (co, si) = (f.angle.cos(), f.angle.sin());
                [co * l[0] - si * l[1], si * l[0] + co * l[1]]
            }
            Endpoint::Body { .. } => [0.0; 2],
            Endpoint::Slider(s) => {
                let i = self.slider_dof[*s];
                let e = self.slider_dir[*s];
                let sdd = if i == NONE { 0.0 } else { ydd[i] };
                [e[0] * sdd, e[1] * sdd]
            }
        }
    }

    /// `d^2|q|/dt^2` of joint `j` (m/s^2) at the current state with accelerations `ydd`.
    fn radial_accel(&self, j: usize, ydd: &[f64]) -> f64 {
        let jt = &self.mech.joints[j];
        let (q, qd) = self.joint_state(j, &self.y, &self.yd);
        let (aj, ab) = (
            self.endpoint_accel(&jt.journal, ydd),
            self.endpoint_accel(&jt.bearing, ydd),
        );
        let mut qdd = [aj[0] - ab[0], aj[1] - ab[1]];
        if self.nominal_offset[j] {
            let t = self.t_frames;
            let v = |t: f64| {
                let (_, va) = self.mech.nominal_kinematics(&jt.journal, t);
                let (_, vb) = self.mech.nominal_kinematics(&jt.bearing, t);
                [va[0] - vb[0], va[1] - vb[1]]
            };
            let (vp, vm) = (v(t + NOMINAL_FD), v((t - NOMINAL_FD).max(0.0)));
            let span = t + NOMINAL_FD - (t - NOMINAL_FD).max(0.0);
            qdd[0] += (vp[0] - vm[0]) / span;
            qdd[1] += (vp[1] - vm[1]) / span;
        }
        let r = q[0].hypot(q[1]);
        let n = [q[0] / r, q[1] / r];
        let vn = n[0] * qd[0] + n[1] * qd[1];
        n[0] * qdd[0] + n[1] * qdd[1] + (qd[0] * qd[0] + qd[1] * qd[1] - vn * vn) / r
    }

    /// Makes the state at `t` (s) consistent with the attached joints' constraints: the normal
    /// relative velocities removed by mass-weighted impulses (plastic impact), then the
    /// accelerations and normal forces of the constrained equations (`M a + r0 + B lambda = 0`
    /// with `d^2|q|/dt^2 = 0`), on the mass matrix's factor.
    fn continuous_restart(&mut self, t: f64) -> Result<()> {
        self.update_frames(t);
        for j in 0..self.mech.joints.len() {
            self.contact[j] = ContactTerms::default();
            self.contact_tan[j] = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
        }
        self.ydd.fill(0.0);
        self.factorize_mass()?;
        let mut c = self.cont.take().expect("continuous-contact run");
        let m = self.constraint_columns(&mut c);
        if m > 0 {
            // velocity: S mu = B^T v-part, v -= Y mu
            for a in 0..m {
                let (_, qd) = self.joint_state(c.active[a], &self.y, &self.yd);
                c.rhs[a] = c.n[a][0] * qd[0] + c.n[a][1] * qd[1];
            }
            solve_dense_in_place(&mut c.s[..m * m], &mut c.rhs[..m], m);
            for a in 0..m {
                for (v, y) in self.yd.iter_mut().zip(&c.y[a]) {
                    *v -= y * c.rhs[a];
                }
            }
        }
        // the unconstrained accelerations a0 = -M^{-1} r0
        self.mass_accelerations(t);
        if m > 0 {
            for a in 0..m {
                c.rhs[a] = self.radial_accel(c.active[a], &self.ydd);
            }
            solve_dense_in_place(&mut c.s2[..m * m], &mut c.rhs[..m], m);
            for a in 0..m {
                c.lambda[c.active[a]] = c.rhs[a];
                for (x, y) in self.ydd.iter_mut().zip(&c.y[a]) {
                    *x -= y * c.rhs[a];
                }
            }
        }
        self.cont = Some(c);
        self.signature.clear();
        if self.settings.newmark.is_alpha() {
            self.aa.copy_from_slice(&self.ydd);
        }
        self.continuous_terms(true);
        Ok(())
    }

    /// The joints on the wall at the start are attached, with the state made consistent.
    pub(super) fn continuous_start(&mut self) -> Result<()> {
        let mut any = false;
        for j in 0..self.mech.joints.len() {
            let (q, _) = self.joint_state(j, &self.y, &self.yd);
            let c = self.mech.joints[j].clearance;
            let on = q[0].hypot(q[1]) >= c * (1.0 - START_ON_WALL);
            self.cont.as_mut().expect("continuous-contact run").attached[j] = on;
            any |= on;
        }
        if any {
            self.continuous_restart(0.0)?;
        }
        let c = self.cont.as_mut().expect("continuous-contact run");
        c.mean.copy_from_slice(&c.lambda);
        self.continuous_terms(true);
        Ok(())
    }

    /// The start of a step at `t0` (s), redone because a joint lost contact in it, made
    /// consistent with the joints still attached: the step's start accelerations held the lost
    /// joint's force (with the trapezoidal rule's step-to-step alternation of unresolved modes,
    /// which a free step would otherwise carry into the journal's flight as a kick). Joints that
    /// reach the wall in this step are left out (they are inside at `t0`).
    fn restart_after_loss(&mut self, t0: f64) -> Result<()> {
        let c = self.cont.as_mut().expect("continuous-contact run");
        for j in 0..c.attached.len() {
            if c.flipped[j] && c.attached[j] {
                c.attached[j] = false;
                c.pending[j] = true;
            }
        }
        self.continuous_restart(t0)?;
        let mut c = self.cont.take().expect("continuous-contact run");
        for j in 0..c.attached.len() {
            if c.pending[j] {
                (c.attached[j], c.pending[j], c.lambda[j]) = (true, false, 0.0);
            } else if !c.flipped[j] {
                c.saved_lambda[j] = c.lambda[j];
            }
        }
        for (dst, src) in c.saved.iter_mut().zip([&self.y, &self.yd, &self.ydd, &self.aa]) {
            dst.copy_from_slice(src);
        }
        self.cont = Some(c);
        self.continuous_terms(true);
        Ok(())
    }

    /// One step from `t0` of `h` (s) with the status logic of the module documentation: the
    /// step is redone when a joint loses contact (tensile `lambda`) or reaches the wall, at most
    /// one status change per joint; after an attachment the state is made consistent; the loss
    /// instants close the joints' episodes in the recorder.
    pub(super) fn continuous_step(&mut self, t0: f64, h: f64, k: u64) -> Result<()> {
        {
            let c = self.cont.as_mut().expect("continuous-contact run");
            for (dst, src) in c.saved.iter_mut().zip([&self.y, &self.yd, &self.ydd, &self.aa]) {
                dst.copy_from_slice(src);
            }
            c.saved_attached.copy_from_slice(&c.attached);
            c.saved_lambda.copy_from_slice(&c.lambda);
            c.flipped.fill(false);
            c.losses.clear();
        }
        let mut attached_now = false;
        let mut losses_before = 0;
        loop {
            self.step(t0, h, k, 0)?;
            let mut c = self.cont.take().expect("continuous-contact run");
            let mut changed = false;
            for j in 0..self.mech.joints.len() {
                if c.flipped[j] {
                    continue;
                }
                if c.attached[j] {
                    // the step's mean normal force, whose sign the unresolved modes of a coarse
                    // step do not flip from step to step (the trapezoidal rule leaves them
                    // undamped, alternating)
                    let (l0, l1) = (c.saved_lambda[j], c.lambda[j]);
                    if l0 + l1 < 0.0 {
                        let l0 = l0.max(0.0);
                        let theta = if l0 - l1 > 0.0 { (l0 / (l0 - l1)).min(1.0) } else { 0.0 };
                        c.losses.push((j, t0 + theta * h));
                        c.attached[j] = false;
                        (c.flipped[j], changed) = (true, true);
                    }
                } else {
                    let (q, _) = self.joint_state(j, &self.y, &self.yd);
                    if q[0].hypot(q[1]) > self.mech.joints[j].clearance {
                        c.attached[j] = true;
                        (c.flipped[j], changed, attached_now) = (true, true, true);
                    }
                }
            }
            if changed {
                // redo the step from its start with the new status
                for j in 0..c.lambda.len() {
                    c.lambda[j] = if c.flipped[j] { 0.0 } else { c.saved_lambda[j] };
                }
                let [y, yd, ydd, aa] = &c.saved;
                self.y.copy_from_slice(y);
                self.yd.copy_from_slice(yd);
                self.ydd.copy_from_slice(ydd);
                self.aa.copy_from_slice(aa);
                self.update_frames(t0);
            }
            let lost = changed && c.losses.len() > losses_before;
            losses_before = c.losses.len();
            self.cont = Some(c);
            if lost {
                self.restart_after_loss(t0)?;
            }
            if !changed {
                break;
            }
        }
        if attached_now {
            self.continuous_restart(t0 + h)?;
        }
        let mut c = self.cont.take().expect("continuous-contact run");
        for j in 0..c.mean.len() {
            c.mean[j] = if c.flipped[j] {
                c.lambda[j]
            } else {
                0.5 * (c.saved_lambda[j] + c.lambda[j])
            };
        }
        for i in 0..c.losses.len() {
            let (j, tl) = c.losses[i];
            c.pen.copy_from_slice(&self.jpen);
            c.force.copy_from_slice(&self.jforce);
            (c.pen[j], c.force[j]) = (-0.0, [0.0; 2]);
            self.rec.record_event(tl, &c.pen, &c.force, &self.jq, &self.jqd);
            // the joint is open from here in the recorder's view
            self.jpen[j] = -0.0;
        }
        self.cont = Some(c);
        Ok(())
    }
}
