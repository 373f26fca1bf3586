//! One lane of a lockstep run: a sample's own state and work, set up from its model and settings;
//! its clearance joints' contact terms, the Woodbury correction on the shared factor or a
//! refactorization for them, the iterated contact terms, the contact episodes, and the divergence
//! checks.

use super::*;

impl<'m> Lane<'m> {
    pub(super) fn new(model: &'m Model, settings: &Settings, sys: System) -> Self {
        let n = sys.n();
        let nj = sys.joints.len();
        let m = 2 * nj;
        let needs_refactor = nj > 0 && !matches!(settings.coupling, Coupling::Force);
        let limit = settings
            .divergence_limit
            .unwrap_or_else(|| 10.0 * model.links.iter().map(|l| l.section.length).fold(0.0, f64::max));
        let gap_k = sys
            .joints
            .iter()
            .map(|j| match settings.coupling {
                Coupling::Gap { stiffness, .. } => stiffness.unwrap_or(1000.0 * j.element_stiffness),
                _ => 0.0,
            })
            .collect();
        let mut terms_desc = vec!["M (consistent mass)".to_string(), "K1 (linear stiffness)".to_string()];
        if sys.damping.iter().any(|&c| c != 0.0) {
            terms_desc.push(match sys.proportional_damping {
                Some(c) => format!("D1 = (eta/E) K1, eta/E = {c:.4e} s (one matrix-vector product)"),
                None => "D1 (material damping, per-link eta/E)".to_string(),
            });
        }
        for (l, plan) in model.links.iter().zip(&sys.links) {
            if plan.inertia_load.is_some() {
                terms_desc.push(format!("M_R a_R (nominal translation inertia) on link {:?}", l.name));
            }
        }
        if nj > 0 {
            terms_desc.push(format!(
                "clearance contact, {} coupling, on {nj} joint(s)",
                settings.coupling.name()
            ));
        }
        let node_dof = |l: usize, node: usize| sys.links[l].offset + 3 * node;
        let clearances: Vec<f64> = sys.joints.iter().map(|j| j.clearance).collect();
        let mut rec = Recorder::new(&settings.record, &clearances, node_dof, settings.steps());
        if settings.adaptive.is_some() {
            rec.weigh_by_time();
        }
        let reads_u = settings.record.histories && !settings.record.nodes.is_empty();
        Lane {
            model,
            settings: settings.clone(),
            frames: sys.frames(),
            chol_c: None,
            ac_values: if needs_refactor {
                vec![0.0; sys.pattern.nnz()]
            } else {
                Vec::new()
            },
            rb: vec![0.0; n],
            sol: vec![0.0; n],
            col: vec![0.0; n],
            terms: vec![ContactTerms::default(); nj],
            g: vec![[[0.0; 2]; 2]; nj],
            g_factored: vec![[[f64::NAN; 2]; 2]; nj],
            h: vec![0.0; m],
            yb: vec![0.0; m],
            s: vec![0.0; m],
            pa: vec![0.0; m],
            pa_old: vec![0.0; m],
            cap: vec![0.0; m * m],
            q: vec![[0.0; 2]; nj],
            qd: vec![[0.0; 2]; nj],
            qt: vec![[0.0; 2]; nj],
            qdt: vec![[0.0; 2]; nj],
            pen: vec![0.0; nj],
            force: vec![[0.0; 2]; nj],
            gap_closed: vec![false; nj],
            gap_normal: vec![[1.0, 0.0]; nj],
            gap_k,
            needs_v0: model.joints.iter().map(|j| j.law.needs_approach_speed()).collect(),
            any_v0: model.joints.iter().any(|j| j.law.needs_approach_speed()),
            episode: vec![None; nj],
            frozen: Vec::new(),
            switches: vec![0; nj],
            prev_change: f64::INFINITY,
            limit,
            stats: RunStats {
                terms: terms_desc,
                stepper: "constant",
                unknowns: n,
                ..Default::default()
            },
            rec,
            refactored: false,
            reads_u,
            outcome: None,
            pending: None,
            sys,
        }
    }

    /// Initial state from the links' initial conditions and the initial acceleration from
    /// `M a0 = F(0) - K u0 - C v0 + contact(u0, v0)`, into `u`, `v`, `a` (this lane's vectors).
    pub(super) fn initialize(
        &mut self,
        mchol: &mut Cholesky,
        translational: &[bool],
        u: &mut [f64],
        v: &mut [f64],
        a: &mut [f64],
    ) -> Result<()> {
        for (l, plan) in self.model.links.iter().zip(&self.sys.links) {
            if let Some(u0) = &l.initial_displacement {
                u[plan.offset..plan.offset + plan.ndof].copy_from_slice(u0);
            }
            if let Some(v0) = &l.initial_velocity {
                v[plan.offset..plan.offset + plan.ndof].copy_from_slice(v0);
            }
        }
        let pat = &self.sys.pattern;
        let r = a;
        pat.mul(&self.sys.stiffness, u, r);
        pat.mul(&self.sys.damping, v, &mut self.col);
        for (r, t) in r.iter_mut().zip(&self.col) {
            *r = -*r - t;
        }
        self.sys.frames_at(0.0, &mut self.frames);
        self.sys.add_inertia_load(&self.frames, r);
        for jj in 0..self.sys.joints.len() {
            let j = &self.sys.joints[jj];
            let (qo, qdo) = self.sys.joint_offset(j, &self.frames);
            let pu = System::joint_project(j, u);
            let pv = System::joint_project(j, v);
            self.q[jj] = [qo[0] + pu[0], qo[1] + pu[1]];
            self.qd[jj] = [qdo[0] + pv[0], qdo[1] + pv[1]];
            let q = self.q[jj];
            let dr = norm2(q);
            self.pen[jj] = dr - j.clearance;
            if self.needs_v0[jj] {
                self.episode[jj] = crate::contact::next_episode(q, self.qd[jj], self.pen[jj], None);
            }
            self.gap_closed[jj] = self.pen[jj] > 0.0;
            if dr > 0.0 {
                self.gap_normal[jj] = [q[0] / dr, q[1] / dr];
            }
            let terms = self.contact_terms(jj, q, self.qd[jj]);
            let f = terms.force(q, self.qd[jj]);
            self.force[jj] = f;
            let j = &self.sys.joints[jj];
            for k in 0..j.ndof {
                r[j.dofs[k]] += j.coef[0][k] * f[0] + j.coef[1][k] * f[1];
            }
        }
        mchol.solve_in_place(r);
        self.check_state(&*u, &*v, translational, 0.0, 0)?;
        let dt = self.settings.dt;
        self.rec
            .record(0, 0.0, dt, &self.pen, &self.force, &self.q, &self.qd, u);
        Ok(())
    }

    /// Contact terms of joint `jj` at state `(q, qd)` under the lane's coupling (the gap coupling
    /// uses its status and normal instead of the law).
    #[inline]
    pub(super) fn contact_terms(&self, jj: usize, q: [f64; 2], qd: [f64; 2]) -> ContactTerms {
        let j = &self.sys.joints[jj];
        match self.settings.coupling {
            Coupling::Gap { damping, .. } => {
                let pen = norm2(q) - j.clearance;
                if !self.gap_closed[jj] {
                    return ContactTerms {
                        penetration: pen,
                        ..Default::default()
                    };
                }
                let n = self.gap_normal[jj];
                let k = self.gap_k[jj];
                let nn = [[n[0] * n[0], n[0] * n[1]], [n[1] * n[0], n[1] * n[1]]];
                ContactTerms {
                    penetration: pen,
                    k: [[k * nn[0][0], k * nn[0][1]], [k * nn[1][0], k * nn[1][1]]],
                    c: [
                        [damping * nn[0][0], damping * nn[0][1]],
                        [damping * nn[1][0], damping * nn[1][1]],
                    ],
                    f_explicit: [k * j.clearance * n[0], k * j.clearance * n[1]],
                }
            }
            _ => evaluation::law_terms(
                &*j.law,
                self.any_v0 && self.needs_v0[jj],
                q,
                qd,
                j.clearance,
                self.episode[jj],
            ),
        }
    }

    /// Before the shared solve: predicted joint states, contact terms from the last state
    /// (lagged), the loads `h` and `G`, and the full right-hand side when refactorizing.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn pre_solve<const L: usize>(
        &mut self,
        frames: &Frames,
        u: &[[f64; L]],
        v: &[[f64; L]],
        r: &[[f64; L]],
        l: usize,
        bdt2: f64,
        gdt: f64,
    ) {
        let nj = self.sys.joints.len();
        for jj in 0..nj {
            let j = &self.sys.joints[jj];
            let (qo, qdo) = self.sys.joint_offset(j, frames);
            let pu = project_lane(j, u, l);
            let pv = project_lane(j, v, l);
            self.qt[jj] = [qo[0] + pu[0], qo[1] + pu[1]];
            self.qdt[jj] = [qdo[0] + pv[0], qdo[1] + pv[1]];
        }
        for jj in 0..nj {
            self.terms[jj] = self.contact_terms(jj, self.q[jj], self.qd[jj]);
        }
        if matches!(self.settings.coupling, Coupling::Force) {
            for jj in 0..nj {
                let f = self.terms[jj].force(self.q[jj], self.qd[jj]);
                self.h[2 * jj] = f[0];
                self.h[2 * jj + 1] = f[1];
                self.g[jj] = [[0.0; 2]; 2];
            }
        } else {
            self.load_implicit_terms(bdt2, gdt);
        }
        // the right-hand side is kept only where a full solve needs it; a Woodbury fallback
        // rebuilds it from z (rb = A0 z) instead of copying it every step
        if self.settings.solver == SolverMode::Refactor {
            get_lane(r, l, &mut self.rb);
        }
    }

    /// After the shared solve (`z` = lane `l` of `r`): the joints' accelerations, iterating the
    /// contact terms when asked; leaves `h - s` for the Woodbury correction or, when the step
    /// was refactorized, the solution in `sol`.
    #[inline]
    pub(super) fn post_solve<const L: usize>(
        &mut self,
        sh: &Shared,
        z: &[[f64; L]],
        l: usize,
        t: f64,
        step: u64,
    ) -> Result<()> {
        let m = sh.m;
        for jj in 0..self.sys.joints.len() {
            let p = project_lane(&self.sys.joints[jj], z, l);
            self.yb[2 * jj] = p[0];
            self.yb[2 * jj + 1] = p[1];
        }
        let (iterate, tol, max_iter) = match self.settings.coupling {
            Coupling::Force => (false, 0.0, 1),
            Coupling::Modified { iterate, tol, max_iter } => (iterate, tol, max_iter),
            Coupling::Gap { max_iter, .. } => (true, 1e-12, max_iter),
            // rejected by `Settings::validate` (the Newton stepper's coupling)
            Coupling::Continuous => (false, 0.0, 1),
        };
        let mut rb_valid = self.settings.solver == SolverMode::Refactor;
        let mut refactored;
        let mut iters = 0u64;
        if iterate {
            // state of `update_iterated_terms` within this step
            self.switches.fill(0);
            self.prev_change = f64::INFINITY;
        }
        loop {
            iters += 1;
            let closed = self.g.iter().any(|g| !mat2_is_zero(g));
            refactored =
                closed && (self.settings.solver == SolverMode::Refactor || !self.woodbury_joint_solve(&sh.wmat, m));
            if refactored {
                if !rb_valid {
                    get_lane(z, l, &mut self.col);
                    self.sys.pattern.mul(&sh.a0_values, &self.col, &mut self.rb);
                    rb_valid = true;
                }
                self.refactor_joint_solve(sh, t, step)?;
            } else if !closed {
                // pa = yb + W h
                for r in 0..m {
                    let mut s = self.yb[r];
                    for c in 0..m {
                        s += sh.wmat[r * m + c] * self.h[c];
                    }
                    self.pa[r] = s;
                    self.s[r] = 0.0;
                }
            }
            if !iterate || iters as usize >= max_iter {
                if iterate && iters as usize >= max_iter && max_iter > 1 {
                    self.stats.unconverged_steps += 1;
                }
                break;
            }
            if self.update_iterated_terms(tol, sh.bdt2, sh.gdt, m) {
                break;
            }
        }
        self.stats.iterations += iters;
        self.stats.max_iterations = self.stats.max_iterations.max(iters);
        self.refactored = refactored;
        if !refactored && self.g.iter().any(|g| !mat2_is_zero(g)) {
            self.stats.woodbury_steps += 1;
        }
        Ok(())
    }

    /// Builds `G_j = beta dt^2 k + gamma dt c` and `h_j = -k q~ - c qd~ + f_explicit` from the
    /// current terms.
    #[inline]
    fn load_implicit_terms(&mut self, bdt2: f64, gdt: f64) {
        for jj in 0..self.sys.joints.len() {
            let t = &self.terms[jj];
            let mut g = [[0.0; 2]; 2];
            for r in 0..2 {
                for c in 0..2 {
                    g[r][c] = bdt2 * t.k[r][c] + gdt * t.c[r][c];
                }
            }
            self.g[jj] = g;
            let f = t.force(self.qt[jj], self.qdt[jj]);
            self.h[2 * jj] = f[0];
            self.h[2 * jj + 1] = f[1];
        }
    }

    /// Woodbury solve for the joints' accelerations `pa` and the correction `s`. Returns false
    /// when the capacitance is too ill-conditioned to trust.
    #[inline]
    fn woodbury_joint_solve(&mut self, wmat: &[f64], m: usize) -> bool {
        // y = yb + W h (kept in pa), cap = I + G W, s = G y
        let rcond = capacitance_solve(
            wmat,
            m,
            &self.g,
            &self.yb,
            &self.h,
            &mut self.pa,
            &mut self.cap,
            &mut self.s,
        );
        if rcond.is_nan() || rcond < WOODBURY_RCOND {
            self.stats.woodbury_fallbacks += 1;
            return false;
        }
        // pa = y - W s
        subtract_ws(wmat, m, &self.s, &mut self.pa);
        true
    }

    /// Full solve with the contact terms in the matrix (numeric refactorization when they
    /// changed); the solution goes to `sol`, the joints' accelerations to `pa`.
    fn refactor_joint_solve(&mut self, sh: &Shared, t: f64, step: u64) -> Result<()> {
        let chol = self
            .chol_c
            .get_or_insert_with(|| Cholesky::with_analysis(Arc::clone(sh.chol0.analysis())));
        if self.g != self.g_factored {
            self.ac_values.copy_from_slice(&sh.a0_values);
            for (jj, j) in self.sys.joints.iter().enumerate() {
                let g = &self.g[jj];
                for a in 0..j.ndof {
                    for b in 0..j.ndof {
                        let mut x = 0.0;
                        for r in 0..2 {
                            for c in 0..2 {
                                x += j.coef[r][a] * g[r][c] * j.coef[c][b];
                            }
                        }
                        self.ac_values[sh.joint_pos[jj][a][b]] += x;
                    }
                }
            }
            chol.factorize(&self.ac_values, "the effective matrix with contact terms")
                .map_err(|e| match e {
                    Error::Singular { what, index, .. } => Error::Diverged {
                        time: t + self.settings.dt,
                        step: step + 1,
                        dof: format!("{} (pivot {index})", self.sys.describe_dof(self.model, index)),
                        reason: format!("{what} is not positive definite"),
                    },
                    e => e,
                })?;
            self.g_factored.clone_from(&self.g);
        }
        self.sol.copy_from_slice(&self.rb);
        for (jj, j) in self.sys.joints.iter().enumerate() {
            for k in 0..j.ndof {
                self.sol[j.dofs[k]] += j.coef[0][k] * self.h[2 * jj] + j.coef[1][k] * self.h[2 * jj + 1];
            }
        }
        chol.solve_in_place(&mut self.sol);
        for (jj, j) in self.sys.joints.iter().enumerate() {
            let p = System::joint_project(j, &self.sol);
            self.pa[2 * jj] = p[0];
            self.pa[2 * jj + 1] = p[1];
        }
        Ok(())
    }

    /// Re-evaluates the contact terms at the end-of-step state implied by `pa`; returns true
    /// when converged (kappa: relative change of `pa` below `tol`; gap: status unchanged and the
    /// normal settled).
    fn update_iterated_terms(&mut self, tol: f64, bdt2: f64, gdt: f64, m: usize) -> bool {
        let nj = self.sys.joints.len();
        let mut converged = true;
        let is_gap = matches!(self.settings.coupling, Coupling::Gap { .. });
        let mut scale = 0.0f64;
        let mut change = 0.0f64;
        for r in 0..m {
            scale = scale.max(self.pa[r].abs());
            change = change.max((self.pa[r] - self.pa_old[r]).abs());
        }
        for jj in 0..nj {
            let q1 = [
                self.qt[jj][0] + bdt2 * self.pa[2 * jj],
                self.qt[jj][1] + bdt2 * self.pa[2 * jj + 1],
            ];
            let qd1 = [
                self.qdt[jj][0] + gdt * self.pa[2 * jj],
                self.qdt[jj][1] + gdt * self.pa[2 * jj + 1],
            ];
            let frozen = self.frozen.get(jj).copied();
            if is_gap {
                let dr = norm2(q1);
                let closed = frozen.unwrap_or(dr - self.sys.joints[jj].clearance > 0.0);
                if closed != self.gap_closed[jj] {
                    converged = false;
                    self.gap_closed[jj] = closed;
                }
                if closed && dr > 0.0 {
                    let n = [q1[0] / dr, q1[1] / dr];
                    let old = self.gap_normal[jj];
                    if (n[0] - old[0]).abs().max((n[1] - old[1]).abs()) > tol {
                        converged = false;
                    }
                    self.gap_normal[jj] = n;
                }
            } else {
                let mut t = self.contact_terms(jj, q1, qd1);
                if t.active() {
                    let j = &self.sys.joints[jj];
                    evaluation::linearize_spring(&mut t, j.law.spring_tangent(q1, j.clearance), q1);
                }
                match frozen {
                    // held open: no force whatever the end state
                    Some(false) => self.terms[jj] = ContactTerms::default(),
                    // held closed: the law's terms while the end state is inside the circle; past
                    // it (a trial cut beyond the crossing) the last terms from inside are kept
                    Some(true) => {
                        if t.active() {
                            self.terms[jj] = t;
                        }
                    }
                    None => {
                        let (t, changed) =
                            evaluation::iterated_terms(t, self.terms[jj].active(), &mut self.switches[jj]);
                        converged &= !changed;
                        self.terms[jj] = t;
                    }
                }
            }
        }
        if !is_gap {
            // Converged when the change is below `tol` relative, or when it has stopped falling
            // while below sqrt(tol): the round-off floor. A stiff bearing's force is a difference
            // of terms ~K_B |q| (1e6 N at 1e10 N/m and 0.1 mm) that cancel to a few N, so the
            // joint accelerations are only known to ~1e-16 K_B |q| / m, which can exceed `tol`
            // times their size.
            let stagnated = change <= tol.sqrt() * scale && change >= 0.5 * self.prev_change;
            converged &= change <= tol * scale || stagnated;
            self.prev_change = change;
        }
        self.pa_old.copy_from_slice(&self.pa);
        if !converged {
            if is_gap {
                for jj in 0..nj {
                    self.terms[jj] = self.contact_terms(jj, self.qt[jj], self.qdt[jj]);
                }
            }
            self.load_implicit_terms(bdt2, gdt);
        }
        converged
    }

    /// After the state update: the joints' positions, forces and penetrations from the new
    /// acceleration (lane `l` of `a`). Fails when a joint's penetration is not finite or exceeds
    /// the divergence limit (an open gap of any width passes; checked every step: one
    /// comparison per joint).
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x <= limit)` is deliberately true for NaN
    pub(super) fn complete_joints<const L: usize>(
        &mut self,
        a: &[[f64; L]],
        l: usize,
        bdt2: f64,
        gdt: f64,
        t1: f64,
        step: u64,
    ) -> Result<()> {
        let explicit = matches!(self.settings.coupling, Coupling::Force);
        for jj in 0..self.sys.joints.len() {
            let j = &self.sys.joints[jj];
            let pu = project_lane(j, a, l);
            let q = [self.qt[jj][0] + bdt2 * pu[0], self.qt[jj][1] + bdt2 * pu[1]];
            let qd = [self.qdt[jj][0] + gdt * pu[0], self.qdt[jj][1] + gdt * pu[1]];
            let f = if explicit {
                [self.h[2 * jj], self.h[2 * jj + 1]]
            } else {
                evaluation::recorded_force(&self.terms[jj], q, qd)
            };
            self.q[jj] = q;
            self.qd[jj] = qd;
            self.pen[jj] = norm2(q) - j.clearance;
            self.force[jj] = f;
            // one comparison per joint and step: false for NaN, so it is also the finite check
            // the penetration itself: an open gap wider than the limit is no divergence
            if !(self.pen[jj] <= self.limit) {
                return Err(self.joint_diverged(jj, t1, step + 1));
            }
            if let Coupling::Gap { .. } = self.settings.coupling {
                // the status for the next step follows the state just reached
                let dr = norm2(q);
                self.gap_closed[jj] = self.pen[jj] > 0.0;
                if dr > 0.0 {
                    self.gap_normal[jj] = [q[0] / dr, q[1] / dr];
                }
            }
        }
        if self.any_v0 {
            self.track_episodes();
        }
        Ok(())
    }

    /// The contact episodes after an accepted state, for the laws that need the approach speed.
    #[cold]
    fn track_episodes(&mut self) {
        for jj in 0..self.sys.joints.len() {
            if self.needs_v0[jj] {
                self.episode[jj] =
                    crate::contact::next_episode(self.q[jj], self.qd[jj], self.pen[jj], self.episode[jj]);
            }
        }
    }

    /// The divergence error of joint `jj` whose penetration is not finite or beyond the limit.
    #[cold]
    fn joint_diverged(&self, jj: usize, time: f64, step: u64) -> Error {
        divergence::joint_diverged(&self.model.joints[jj].name, self.pen[jj], self.limit, time, step)
    }

    /// Finite and within-limit check of this lane's state (`u`, `v` give the lane's entries).
    pub(super) fn check_state(
        &self,
        u: impl DofAt,
        v: impl DofAt,
        translational: &[bool],
        t: f64,
        step: u64,
    ) -> Result<()> {
        let bad = match (u.slice(), v.slice()) {
            // contiguous (one lane): the vectorized pass first
            (Some(us), Some(vs)) => divergence::first_bad_in(us, vs, translational, self.limit),
            _ => divergence::first_bad(
                translational.len(),
                |i| translational[i],
                |i| u.at(i),
                |i| v.at(i),
                self.limit,
            ),
        };
        if let Some(d) = bad {
            let reason = divergence::reason(u.at(d), v.at(d), translational[d], self.limit);
            return Err(Error::Diverged {
                time: t,
                step,
                dof: self.sys.describe_dof(self.model, d),
                reason,
            });
        }
        Ok(())
    }
}
