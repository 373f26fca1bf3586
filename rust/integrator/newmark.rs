//! Newmark (beta, gamma) at a fixed step, in acceleration form:
//!
//! ```text
//! u~ = u_n + dt v_n + dt^2 (1/2 - beta) a_n,      v~ = v_n + dt (1 - gamma) a_n
//! (M + gamma dt C + beta dt^2 K) a_{n+1} = F(t_{n+1}) - C v~ - K u~ + contact
//! u_{n+1} = u~ + beta dt^2 a_{n+1},               v_{n+1} = v~ + gamma dt a_{n+1}
//! ```
//!
//! The contact-free effective matrix `A0 = M + gamma dt C + beta dt^2 K` is factorized once. A
//! clearance joint adds `P^T (beta dt^2 k + gamma dt c) P` on its 2 (or 4) DOFs (modified and gap
//! couplings); that is solved with the `A0` factorization and a Sherman-Morrison-Woodbury
//! correction `a = z + Z (h - s)`, `z = A0^-1 r`, `Z = A0^-1 P^T`, `s = (I + G W)^-1 G (P z + W h)`,
//! `W = P Z`: an open contact has `G = 0` and costs nothing extra, and iterating the contact within
//! a step needs no further sparse solve. The loop does not allocate.

use crate::assembly::{Band, Frames, Pattern, System};
use crate::contact::{ContactTerms, Coupling, Mat2};
use crate::error::{Error, Result};
use crate::linsolve::{solve_dense_in_place, Analysis, AnalysisCache, Cholesky};
use crate::model::Model;
use crate::recorder::Recorder;
use crate::simulation::{RunFailure, RunOutput, RunStats, Settings, SolverMode};
use std::sync::Arc;

/// Newmark parameters. Default: average acceleration (beta 1/4, gamma 1/2), unconditionally
/// stable for linear systems and without numerical damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Newmark {
    /// beta, in (0, 1/2].
    pub beta: f64,
    /// gamma, in [1/2, 1].
    pub gamma: f64,
}

impl Default for Newmark {
    fn default() -> Self {
        Newmark { beta: 0.25, gamma: 0.5 }
    }
}

impl Newmark {
    /// Checks the parameters.
    pub fn validate(&self) -> Result<()> {
        if !(self.beta > 0.0 && self.beta <= 0.5) {
            return Err(Error::param("beta", self.beta, "in (0, 0.5]"));
        }
        if !(self.gamma >= 0.5 && self.gamma <= 1.0) {
            return Err(Error::param("gamma", self.gamma, "in [0.5, 1]"));
        }
        Ok(())
    }
}

/// Steps between calls of the caller's control function (progress and interruption).
const CONTROL_STRIDE: u64 = 1 << 14;
/// Steps between full finite/limit checks of the state.
const CHECK_STRIDE: u64 = 16;
/// Woodbury is abandoned for a step whose capacitance pivot ratio is below this.
const WOODBURY_RCOND: f64 = 1e-12;

/// A run in progress: the assembled system, factorizations, state and workspace.
pub struct NewmarkRun<'m> {
    model: &'m Model,
    sys: System,
    settings: Settings,
    bdt2: f64,
    gdt: f64,
    chol0: Cholesky,
    chol_c: Option<Cholesky>,
    a0_values: Vec<f64>,
    ac_values: Vec<f64>,
    /// Positions of each joint's DOF block in the pattern, `[a][b]`.
    joint_pos: Vec<[[usize; 4]; 4]>,
    m: usize,
    zcols: Vec<f64>,
    wmat: Vec<f64>,
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    r: Vec<f64>,
    rb: Vec<f64>,
    tmp: Vec<f64>,
    terms: Vec<ContactTerms>,
    g: Vec<Mat2>,
    g_factored: Vec<Mat2>,
    h: Vec<f64>,
    yb: Vec<f64>,
    s: Vec<f64>,
    pa: Vec<f64>,
    pa_old: Vec<f64>,
    cap: Vec<f64>,
    frames: Frames,
    q: Vec<[f64; 2]>,
    qd: Vec<[f64; 2]>,
    qt: Vec<[f64; 2]>,
    qdt: Vec<[f64; 2]>,
    pen: Vec<f64>,
    fmag: Vec<f64>,
    gap_closed: Vec<bool>,
    gap_normal: Vec<[f64; 2]>,
    gap_k: Vec<f64>,
    limit: f64,
    /// Banded copies of K and C for the per-step products, when the pattern is banded.
    k_band: Option<Band>,
    c_band: Option<Band>,
    xpad: Vec<f64>,
    translational: Vec<bool>,
    stats: RunStats,
    rec: Recorder,
    t: f64,
    step: u64,
}

/// `y = A x` through the band when there is one (faster for chains), else the sparse pattern.
#[inline]
fn matvec(pattern: &Pattern, band: Option<&Band>, a: &[f64], x: &[f64], xpad: &mut [f64], y: &mut [f64]) {
    match band {
        Some(b) => {
            let w = b.half_bandwidth();
            xpad[w..w + x.len()].copy_from_slice(x);
            b.mul(xpad, y);
        }
        None => pattern.mul(a, x, y),
    }
}

/// Euclidean length of a 2-vector. Plain `sqrt(x^2 + y^2)`: `f64::hypot` is a slow library call,
/// and the overflow it guards against (|v| > 1e154 m) only happens in a divergence, which the
/// finite checks report.
#[inline]
fn norm2(v: [f64; 2]) -> f64 {
    (v[0] * v[0] + v[1] * v[1]).sqrt()
}

fn mat2_is_zero(m: &Mat2) -> bool {
    m[0][0] == 0.0 && m[0][1] == 0.0 && m[1][0] == 0.0 && m[1][1] == 0.0
}

impl<'m> NewmarkRun<'m> {
    /// Assembles and factorizes; computes the initial acceleration. `model` and `settings` must
    /// be validated. Fails with [`Error::Singular`] if the mass or effective matrix is not
    /// positive definite.
    pub fn new(model: &'m Model, settings: &Settings) -> Result<Self> {
        Self::with_analysis(model, settings, None)
    }

    /// As [`Self::new`], taking the symbolic factorization of the model's pattern from `cache`
    /// (shared among the samples of a study) when given; otherwise the analysis is done here.
    /// One analysis serves all of the run's factorizations.
    pub fn with_analysis(model: &'m Model, settings: &Settings, cache: Option<&AnalysisCache>) -> Result<Self> {
        let sys = System::assemble(model);
        let n = sys.n();
        let nj = sys.joints.len();
        let m = 2 * nj;
        let dt = settings.dt;
        let bdt2 = settings.newmark.beta * dt * dt;
        let gdt = settings.newmark.gamma * dt;
        let nnz = sys.pattern.nnz();
        let a0_values: Vec<f64> = (0..nnz)
            .map(|p| sys.mass[p] + gdt * sys.damping[p] + bdt2 * sys.stiffness[p])
            .collect();
        let analysis = match cache {
            Some(c) => c.get(&sys.pattern)?,
            None => Analysis::new(&sys.pattern)?,
        };
        let mut chol0 = Cholesky::with_analysis(Arc::clone(&analysis));
        chol0.factorize(&a0_values, "the effective matrix M + gamma dt C + beta dt^2 K")?;
        let needs_refactor = nj > 0 && !matches!(settings.coupling, Coupling::Force);
        let chol_c = if needs_refactor {
            Some(Cholesky::with_analysis(Arc::clone(&analysis)))
        } else {
            None
        };
        let joint_pos = sys
            .joints
            .iter()
            .map(|j| {
                let mut p = [[0usize; 4]; 4];
                for (a, row) in p.iter_mut().enumerate().take(j.ndof) {
                    for (b, cell) in row.iter_mut().enumerate().take(j.ndof) {
                        *cell = sys.pattern.position(j.dofs[a], j.dofs[b]);
                    }
                }
                p
            })
            .collect();
        // Z = A0^-1 P^T, W = P Z.
        let mut zcols = vec![0.0; n * m];
        for (jj, j) in sys.joints.iter().enumerate() {
            for r in 0..2 {
                let col = &mut zcols[(2 * jj + r) * n..(2 * jj + r + 1) * n];
                for k in 0..j.ndof {
                    col[j.dofs[k]] += j.coef[r][k];
                }
                chol0.solve_in_place(col);
            }
        }
        let mut wmat = vec![0.0; m * m];
        for (jr, j) in sys.joints.iter().enumerate() {
            for c in 0..m {
                let p = System::joint_project(j, &zcols[c * n..(c + 1) * n]);
                wmat[(2 * jr) * m + c] = p[0];
                wmat[(2 * jr + 1) * m + c] = p[1];
            }
        }
        let limit = settings
            .divergence_limit
            .unwrap_or_else(|| 10.0 * model.links.iter().map(|l| l.length).fold(0.0, f64::max));
        let mut translational = vec![true; n];
        for (i, t) in translational.iter_mut().enumerate() {
            // every link has 3 DOFs per node and starts at a multiple of 3
            *t = i % 3 != 2;
        }
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
        let rec = Recorder::new(&settings.record, nj, node_dof, settings.steps());
        let k_band = Band::from_csc(&sys.pattern, &sys.stiffness);
        let mut run = NewmarkRun {
            model,
            settings: settings.clone(),
            bdt2,
            gdt,
            chol0,
            chol_c,
            ac_values: a0_values.clone(),
            a0_values,
            joint_pos,
            m,
            zcols,
            wmat,
            u: vec![0.0; n],
            v: vec![0.0; n],
            a: vec![0.0; n],
            r: vec![0.0; n],
            rb: vec![0.0; n],
            tmp: vec![0.0; n],
            terms: vec![ContactTerms::default(); nj],
            g: vec![[[0.0; 2]; 2]; nj],
            g_factored: vec![[[f64::NAN; 2]; 2]; nj],
            h: vec![0.0; m],
            yb: vec![0.0; m],
            s: vec![0.0; m],
            pa: vec![0.0; m],
            pa_old: vec![0.0; m],
            cap: vec![0.0; m * m],
            frames: sys.frames(),
            q: vec![[0.0; 2]; nj],
            qd: vec![[0.0; 2]; nj],
            qt: vec![[0.0; 2]; nj],
            qdt: vec![[0.0; 2]; nj],
            pen: vec![0.0; nj],
            fmag: vec![0.0; nj],
            gap_closed: vec![false; nj],
            gap_normal: vec![[1.0, 0.0]; nj],
            gap_k,
            limit,
            xpad: vec![0.0; k_band.as_ref().map_or(0, Band::padded_len)],
            c_band: if sys.proportional_damping.is_some() {
                None
            } else {
                Band::from_csc(&sys.pattern, &sys.damping)
            },
            k_band,
            translational,
            stats: RunStats {
                terms: terms_desc,
                ..Default::default()
            },
            rec,
            t: 0.0,
            step: 0,
            sys,
        };
        run.initialize()?;
        Ok(run)
    }

    /// Initial state from the links' initial conditions and the initial acceleration from
    /// `M a0 = F(0) - K u0 - C v0 + contact(u0, v0)`.
    fn initialize(&mut self) -> Result<()> {
        for (l, plan) in self.model.links.iter().zip(&self.sys.links) {
            if let Some(u0) = &l.initial_displacement {
                self.u[plan.offset..plan.offset + plan.ndof].copy_from_slice(u0);
            }
            if let Some(v0) = &l.initial_velocity {
                self.v[plan.offset..plan.offset + plan.ndof].copy_from_slice(v0);
            }
        }
        let pat = &self.sys.pattern;
        pat.mul(&self.sys.stiffness, &self.u, &mut self.r);
        pat.mul(&self.sys.damping, &self.v, &mut self.tmp);
        for (r, t) in self.r.iter_mut().zip(&self.tmp) {
            *r = -*r - t;
        }
        self.sys.frames_at(0.0, &mut self.frames);
        self.sys.add_inertia_load(&self.frames, &mut self.r);
        for jj in 0..self.sys.joints.len() {
            let j = &self.sys.joints[jj];
            let (qo, qdo) = self.sys.joint_offset(j, &self.frames);
            let pu = System::joint_project(j, &self.u);
            let pv = System::joint_project(j, &self.v);
            self.q[jj] = [qo[0] + pu[0], qo[1] + pu[1]];
            self.qd[jj] = [qdo[0] + pv[0], qdo[1] + pv[1]];
            let q = self.q[jj];
            let dr = norm2(q);
            self.pen[jj] = dr - j.clearance;
            self.gap_closed[jj] = self.pen[jj] > 0.0;
            if dr > 0.0 {
                self.gap_normal[jj] = [q[0] / dr, q[1] / dr];
            }
            let terms = self.contact_terms(jj, q, self.qd[jj]);
            let f = terms.force(q, self.qd[jj]);
            self.fmag[jj] = norm2(f);
            for k in 0..j.ndof {
                self.r[j.dofs[k]] += j.coef[0][k] * f[0] + j.coef[1][k] * f[1];
            }
        }
        let mut mchol = Cholesky::with_analysis(Arc::clone(self.chol0.analysis()));
        mchol.factorize(&self.sys.mass, "the mass matrix")?;
        self.a.copy_from_slice(&self.r);
        mchol.solve_in_place(&mut self.a);
        self.check_state()?;
        self.record(0, 0.0);
        Ok(())
    }

    /// Hands the current joint and node state of step `step` (time `t`, s) to the recorder.
    #[inline]
    fn record(&mut self, step: u64, t: f64) {
        self.rec.record(
            step,
            t,
            self.settings.dt,
            &self.pen,
            &self.fmag,
            &self.q,
            &self.qd,
            &self.u,
        );
    }

    /// Contact terms of joint `jj` at state `(q, qd)` under the run's coupling (the gap coupling
    /// uses its status and normal instead of the law).
    #[inline]
    fn contact_terms(&self, jj: usize, q: [f64; 2], qd: [f64; 2]) -> ContactTerms {
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
            _ => j.law.evaluate(q, qd, j.clearance),
        }
    }

    /// Runs to the end. See [`crate::simulation::simulate`].
    pub fn run(mut self, control: &mut dyn FnMut(f64) -> bool) -> std::result::Result<RunOutput, Box<RunFailure>> {
        let steps = self.settings.steps();
        let dt = self.settings.dt;
        while self.step < steps {
            let t1 = (self.step + 1) as f64 * dt;
            if let Err(e) = self.advance(t1) {
                return Err(self.fail(e));
            }
            if self.step.is_multiple_of(CONTROL_STRIDE) && !control(self.step as f64 / steps as f64) {
                let e = Error::Interrupted {
                    time: self.t,
                    step: self.step,
                };
                return Err(self.fail(e));
            }
        }
        Ok(self.finish())
    }

    fn fail(self, error: Error) -> Box<RunFailure> {
        Box::new(RunFailure {
            error,
            output: self.finish(),
        })
    }

    fn finish(mut self) -> RunOutput {
        self.stats.steps = self.step;
        self.stats.factorizations = self.chol0.factorizations + self.chol_c.as_ref().map_or(0, |c| c.factorizations);
        RunOutput {
            record: self.rec,
            stats: self.stats,
            state: [self.u, self.v, self.a],
            time: self.t,
        }
    }

    /// One step to `t1`.
    fn advance(&mut self, t1: f64) -> Result<()> {
        let dt = self.settings.dt;
        let beta = self.settings.newmark.beta;
        let gamma = self.settings.newmark.gamma;
        let c1 = dt * dt * (0.5 - beta);
        let c2 = dt * (1.0 - gamma);
        let pat = &self.sys.pattern;
        match self.sys.proportional_damping {
            Some(c) => {
                // predictors (in place: u, v hold u~, v~ until `complete`) and w = -(u~ + c v~)
                // in one pass, then r = K w
                for ((u, v), (&a, w)) in self
                    .u
                    .iter_mut()
                    .zip(self.v.iter_mut())
                    .zip(self.a.iter().zip(self.tmp.iter_mut()))
                {
                    *u += dt * *v + c1 * a;
                    *v += c2 * a;
                    *w = -(*u + c * *v); // negated here so that r = K w needs no extra pass
                }
                matvec(
                    pat,
                    self.k_band.as_ref(),
                    &self.sys.stiffness,
                    &self.tmp,
                    &mut self.xpad,
                    &mut self.r,
                );
            }
            None => {
                for ((u, v), &a) in self.u.iter_mut().zip(self.v.iter_mut()).zip(&self.a) {
                    *u += dt * *v + c1 * a;
                    *v += c2 * a;
                }
                matvec(
                    pat,
                    self.k_band.as_ref(),
                    &self.sys.stiffness,
                    &self.u,
                    &mut self.xpad,
                    &mut self.r,
                );
                matvec(
                    pat,
                    self.c_band.as_ref(),
                    &self.sys.damping,
                    &self.v,
                    &mut self.xpad,
                    &mut self.tmp,
                );
                for (x, t) in self.r.iter_mut().zip(&self.tmp) {
                    *x = -*x - t;
                }
            }
        }
        self.sys.frames_at(t1, &mut self.frames);
        self.sys.add_inertia_load(&self.frames, &mut self.r);
        let nj = self.sys.joints.len();
        if nj == 0 {
            self.chol0.solve_in_place(&mut self.r);
            std::mem::swap(&mut self.a, &mut self.r);
            return self.complete(t1);
        }
        for jj in 0..nj {
            let j = &self.sys.joints[jj];
            let (qo, qdo) = self.sys.joint_offset(j, &self.frames);
            let pu = System::joint_project(j, &self.u);
            let pv = System::joint_project(j, &self.v);
            self.qt[jj] = [qo[0] + pu[0], qo[1] + pu[1]];
            self.qdt[jj] = [qdo[0] + pv[0], qdo[1] + pv[1]];
        }
        // Contact terms from the last state (lagged); iterations refine them below.
        for jj in 0..nj {
            self.terms[jj] = self.contact_terms(jj, self.q[jj], self.qd[jj]);
        }
        let explicit = matches!(self.settings.coupling, Coupling::Force);
        if explicit {
            for jj in 0..nj {
                let f = self.terms[jj].force(self.q[jj], self.qd[jj]);
                self.h[2 * jj] = f[0];
                self.h[2 * jj + 1] = f[1];
                self.g[jj] = [[0.0; 2]; 2];
            }
        } else {
            self.load_implicit_terms();
        }
        // the right-hand side is kept only where a full solve needs it; a Woodbury fallback
        // rebuilds it from z (rb = A0 z) instead of copying it every step
        let mut rb_valid = self.settings.solver == SolverMode::Refactor;
        if rb_valid {
            self.rb.copy_from_slice(&self.r);
        }
        self.chol0.solve_in_place(&mut self.r); // r = z = A0^-1 rhs
        let m = self.m;
        let n = self.u.len();
        for jj in 0..nj {
            let p = System::joint_project(&self.sys.joints[jj], &self.r);
            self.yb[2 * jj] = p[0];
            self.yb[2 * jj + 1] = p[1];
        }
        let (iterate, tol, max_iter) = match self.settings.coupling {
            Coupling::Force => (false, 0.0, 1),
            Coupling::Modified { iterate, tol, max_iter } => (iterate, tol, max_iter),
            Coupling::Gap { max_iter, .. } => (true, 1e-12, max_iter),
        };
        let mut refactored;
        let mut iters = 0u64;
        loop {
            iters += 1;
            let closed = self.g.iter().any(|g| !mat2_is_zero(g));
            refactored = closed && (self.settings.solver == SolverMode::Refactor || !self.woodbury_joint_solve());
            if refactored {
                if !rb_valid {
                    self.sys.pattern.mul(&self.a0_values, &self.r, &mut self.rb);
                    rb_valid = true;
                }
                self.refactor_joint_solve()?;
            } else if !closed {
                // pa = yb + W h
                for r in 0..m {
                    let mut s = self.yb[r];
                    for c in 0..m {
                        s += self.wmat[r * m + c] * self.h[c];
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
            if self.update_iterated_terms(tol) {
                break;
            }
        }
        self.stats.iterations += iters;
        self.stats.max_iterations = self.stats.max_iterations.max(iters);
        if refactored {
            std::mem::swap(&mut self.a, &mut self.tmp);
        } else {
            if self.g.iter().any(|g| !mat2_is_zero(g)) {
                self.stats.woodbury_steps += 1;
            }
            // a = z + Z (h - s); z is not needed after this step
            std::mem::swap(&mut self.a, &mut self.r);
            for c in 0..m {
                let w = self.h[c] - self.s[c];
                if w != 0.0 {
                    let col = &self.zcols[c * n..(c + 1) * n];
                    for (ai, zi) in self.a.iter_mut().zip(col) {
                        *ai += w * zi;
                    }
                }
            }
        }
        self.complete(t1)
    }

    /// Builds `G_j = beta dt^2 k + gamma dt c` and `h_j = -k q~ - c qd~ + f_explicit` from the
    /// current terms.
    #[inline]
    fn load_implicit_terms(&mut self) {
        for jj in 0..self.sys.joints.len() {
            let t = &self.terms[jj];
            let mut g = [[0.0; 2]; 2];
            for r in 0..2 {
                for c in 0..2 {
                    g[r][c] = self.bdt2 * t.k[r][c] + self.gdt * t.c[r][c];
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
    fn woodbury_joint_solve(&mut self) -> bool {
        let m = self.m;
        // y = yb + W h (kept in pa), cap = I + G W, s = G y
        for r in 0..m {
            let mut s = self.yb[r];
            for c in 0..m {
                s += self.wmat[r * m + c] * self.h[c];
            }
            self.pa[r] = s;
        }
        for jj in 0..self.sys.joints.len() {
            let g = &self.g[jj];
            for rr in 0..2 {
                let row = 2 * jj + rr;
                for c in 0..m {
                    let gw = g[rr][0] * self.wmat[(2 * jj) * m + c] + g[rr][1] * self.wmat[(2 * jj + 1) * m + c];
                    self.cap[row * m + c] = if row == c { 1.0 + gw } else { gw };
                }
                self.s[row] = g[rr][0] * self.pa[2 * jj] + g[rr][1] * self.pa[2 * jj + 1];
            }
        }
        let rcond = solve_dense_in_place(&mut self.cap, &mut self.s, m);
        if rcond.is_nan() || rcond < WOODBURY_RCOND {
            self.stats.woodbury_fallbacks += 1;
            return false;
        }
        // pa = y - W s
        for r in 0..m {
            let mut x = self.pa[r];
            for c in 0..m {
                x -= self.wmat[r * m + c] * self.s[c];
            }
            self.pa[r] = x;
        }
        true
    }

    /// Full solve with the contact terms in the matrix (numeric refactorization when they
    /// changed); the solution goes to `tmp`, the joints' accelerations to `pa`.
    fn refactor_joint_solve(&mut self) -> Result<()> {
        let chol = self
            .chol_c
            .as_mut()
            .expect("contact factorization exists for implicit couplings");
        if self.g != self.g_factored {
            self.ac_values.copy_from_slice(&self.a0_values);
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
                        self.ac_values[self.joint_pos[jj][a][b]] += x;
                    }
                }
            }
            chol.factorize(&self.ac_values, "the effective matrix with contact terms")
                .map_err(|e| match e {
                    Error::Singular { what, index } => Error::Diverged {
                        time: self.t + self.settings.dt,
                        step: self.step + 1,
                        dof: format!("pivot {index}"),
                        reason: format!("{what} is not positive definite"),
                    },
                    e => e,
                })?;
            self.g_factored.clone_from(&self.g);
        }
        self.tmp.copy_from_slice(&self.rb);
        for (jj, j) in self.sys.joints.iter().enumerate() {
            for k in 0..j.ndof {
                self.tmp[j.dofs[k]] += j.coef[0][k] * self.h[2 * jj] + j.coef[1][k] * self.h[2 * jj + 1];
            }
        }
        chol.solve_in_place(&mut self.tmp);
        for (jj, j) in self.sys.joints.iter().enumerate() {
            let p = System::joint_project(j, &self.tmp);
            self.pa[2 * jj] = p[0];
            self.pa[2 * jj + 1] = p[1];
        }
        Ok(())
    }

    /// Re-evaluates the contact terms at the end-of-step state implied by `pa`; returns true
    /// when converged (kappa: relative change of `pa` below `tol`; gap: status unchanged and the
    /// normal settled).
    fn update_iterated_terms(&mut self, tol: f64) -> bool {
        let nj = self.sys.joints.len();
        let mut converged = true;
        let is_gap = matches!(self.settings.coupling, Coupling::Gap { .. });
        let mut scale = 0.0f64;
        let mut change = 0.0f64;
        for r in 0..self.m {
            scale = scale.max(self.pa[r].abs());
            change = change.max((self.pa[r] - self.pa_old[r]).abs());
        }
        for jj in 0..nj {
            let q1 = [
                self.qt[jj][0] + self.bdt2 * self.pa[2 * jj],
                self.qt[jj][1] + self.bdt2 * self.pa[2 * jj + 1],
            ];
            let qd1 = [
                self.qdt[jj][0] + self.gdt * self.pa[2 * jj],
                self.qdt[jj][1] + self.gdt * self.pa[2 * jj + 1],
            ];
            if is_gap {
                let dr = norm2(q1);
                let closed = dr - self.sys.joints[jj].clearance > 0.0;
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
                let t = self.contact_terms(jj, q1, qd1);
                if t.active() != self.terms[jj].active() {
                    converged = false;
                }
                self.terms[jj] = t;
            }
        }
        if !is_gap {
            converged &= change <= tol * scale;
        }
        self.pa_old.copy_from_slice(&self.pa);
        if !converged {
            if is_gap {
                for jj in 0..nj {
                    self.terms[jj] = self.contact_terms(jj, self.qt[jj], self.qdt[jj]);
                }
            }
            self.load_implicit_terms();
        }
        converged
    }

    /// Updates the state from the new acceleration, evaluates joints, records and checks.
    #[inline]
    fn complete(&mut self, t1: f64) -> Result<()> {
        let (bdt2, gdt) = (self.bdt2, self.gdt);
        for ((u, v), &a) in self.u.iter_mut().zip(self.v.iter_mut()).zip(&self.a) {
            *u += bdt2 * a;
            *v += gdt * a;
        }
        let explicit = matches!(self.settings.coupling, Coupling::Force);
        for jj in 0..self.sys.joints.len() {
            let j = &self.sys.joints[jj];
            let pu = System::joint_project(j, &self.a);
            let q = [self.qt[jj][0] + self.bdt2 * pu[0], self.qt[jj][1] + self.bdt2 * pu[1]];
            let qd = [self.qdt[jj][0] + self.gdt * pu[0], self.qdt[jj][1] + self.gdt * pu[1]];
            let f = if explicit {
                [self.h[2 * jj], self.h[2 * jj + 1]]
            } else {
                self.terms[jj].force(q, qd)
            };
            self.q[jj] = q;
            self.qd[jj] = qd;
            self.pen[jj] = norm2(q) - j.clearance;
            self.fmag[jj] = norm2(f);
            if !self.pen[jj].is_finite() {
                let jname = self.model.joints[jj].name.clone();
                return Err(self.diverged(
                    t1,
                    format!("joint {jname:?} position"),
                    "non-finite joint position".into(),
                ));
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
        self.step += 1;
        self.t = t1;
        if self.step.is_multiple_of(CHECK_STRIDE) {
            self.check_state()?;
        }
        self.record(self.step, t1);
        Ok(())
    }

    fn diverged(&self, t: f64, dof: String, reason: String) -> Error {
        Error::Diverged {
            time: t,
            step: self.step + 1,
            dof,
            reason,
        }
    }

    /// Finite and within-limit check of the whole state.
    fn check_state(&self) -> Result<()> {
        let bad = self
            .u
            .iter()
            .zip(&self.v)
            .zip(&self.translational)
            .position(|((&u, &v), &tr)| !(u.is_finite() && v.is_finite()) || (tr && u.abs() > self.limit));
        if let Some(d) = bad {
            let x = self.u[d];
            let reason = if x.is_finite() && self.v[d].is_finite() {
                format!(
                    "|displacement| = {:.3e} m exceeds the divergence limit {:.3e} m",
                    x.abs(),
                    self.limit
                )
            } else {
                "non-finite displacement or velocity".to_string()
            };
            return Err(Error::Diverged {
                time: self.t,
                step: self.step,
                dof: self.sys.describe_dof(self.model, d),
                reason,
            });
        }
        Ok(())
    }
}
