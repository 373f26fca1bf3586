//! Newmark (beta, gamma) at a fixed step, in acceleration form:
//!
//! ```text
//! u~ = u_n + dt v_n + dt^2 (1/2 - beta) a_n,      v~ = v_n + dt (1 - gamma) a_n
//! (M + gamma dt C + beta dt^2 K) a_{n+1} = F(t_{n+1}) - C v~ - K u~ + contact
//! u_{n+1} = u~ + beta dt^2 a_{n+1},               v_{n+1} = v~ + gamma dt a_{n+1}
//! ```
//!
//! The generalized-alpha family ([`Newmark`]: Chung-Hulbert, HHT, in the Arnold-Bruls form)
//! runs the same step with `beta`, `gamma` replaced by [`Newmark::coefficients`] and predictors
//! that carry the acceleration-like variable; plain Newmark keeps the code above, bitwise.
//!
//! The contact-free effective matrix `A0 = M + gamma dt C + beta dt^2 K` is factorized once. A
//! clearance joint adds `P^T (beta dt^2 k + gamma dt c) P` on its 2 (or 4) DOFs (modified and gap
//! couplings); that is solved with the `A0` factorization and a Sherman-Morrison-Woodbury
//! correction `a = z + Z (h - s)`, `z = A0^-1 r`, `Z = A0^-1 P^T`, `s = (I + G W)^-1 G (P z + W h)`,
//! `W = P Z`: an open contact has `G = 0` and costs nothing extra, and iterating the contact within
//! a step needs no further sparse solve. The loop does not allocate.
//!
//! **Lockstep.** Runs whose `A0` is the same (same M, C, K, dt, beta, gamma: e.g. samples of a
//! study that differ only in clearance or bearing law) share that factorization and can step
//! together: [`Lockstep`] advances `L` such runs ("lanes") at once, with the global vectors stored
//! lane-fastest (`u[dof][lane]`), so the banded substitution and the band product load each matrix
//! entry once and run `L` independent dependency chains side by side (the single substitution is
//! latency-bound). The joint work (contact law, Woodbury correction, iterations, recording,
//! divergence checks) is per lane. Every lane does exactly the floating-point operations of a
//! single run, in the same order, so its result is bitwise that of [`NewmarkRun`] (which is the
//! one-lane case of the same code). A lane that fails (divergence, a contact matrix that is not
//! positive definite) is finished with its own error and what it recorded, and the others go on.
//!
//! **Event-aware stepping** ([`Settings::events`], one-lane runs only). A step that changes a
//! joint's contact status (sign of the penetration `delta = |q| - c`) is redone from its start as
//! two substeps cut at `theta dt` (first estimate `theta = delta_0 / (delta_0 - delta_1)`, linear
//! interpolation between the step's ends, earliest joint; refined by regula falsi on the first
//! substep's end penetration so that it ends just short of the circle), the acceleration restarted
//! at the cut with the new status, each with the contact-free factorization of its own
//! size (numeric refactorization on the shared analysis; the Woodbury columns are rebuilt). The
//! next step is at the nominal size again, so output stays on the `dt` grid; of the state at the
//! cut only the contact force enters the running largest force (it is the peak of an entry with
//! contact damping). A step without a status change is bitwise the fixed-step one.
//!
//! **Adaptive steps** ([`Settings::adaptive`](crate::run::Settings::adaptive), one-lane runs
//! only; the `tol=` runs of Python on translating models): the controller of the Newton stepper
//! (`integrator/newton.rs`, "Adaptive steps"; `newton/adaptive_steps.rs`) on this stepper. Steps are `h_max / 2^m` (the
//! level `m`; `Adaptive::h_max`), independent of the output grid `dt`, chosen by the
//! Zienkiewicz-Xie estimate `|beta - 1/6| h^2 |a_(n+1) - a_n|` against `atol + rtol |u|`; a
//! rejected step goes up by the levels the `h^3` law asks, an easy one (below a tenth of the
//! tolerance) lets the next go down one level; a step that changes a joint's status is cut just
//! short of the circle (the cut substep keeping the start's statuses, as above) and the
//! accelerations restart there with the crossing joint on its new side (the right limit,
//! recorded). `A0` depends on the step only, so the step constants (`A0`'s numeric factorization
//! on the shared analysis and its Woodbury columns) of up to `FACTOR_CACHE` recent step sizes are
//! kept besides the one in use: a level that comes back swaps its constants in and costs no
//! refactorization; a miss refills the least recently used slot in place (an odd length in
//! use, a cut's, is refilled in place and evicts no level). Every factorization counts in
//! `stats.factorizations`. A step whose cubic Hermite joint path passes through a clearance
//! circle between open ends is redone shorter, so no contact is stepped over. Accepted steps'
//! ends enter the joints' extremes (largest force and penetration, impacts), and so does a
//! smooth contact peak within a step (the cubic Hermite interpolant of the joint's relative
//! displacement sampled at 7 points, as on Newton); an output instant inside a step records the
//! interpolated state (Hermite displacements and joint paths, linear accelerations), in time
//! order with the steps' ends.
//! Nothing is allocated in the time loop besides the cache's first fills.
//!
//! **Divergence checks**: the one rule of [`super::divergence`]. Every step, each joint's
//! penetration `delta` (positive = overlap; an open gap of any width passes) is compared with the
//! divergence limit (one comparison per joint, which is also the finite check); every
//! `CHECK_STRIDE` steps and at the last step the whole state is checked for finiteness and the
//! translational DOFs against the limit.
//!
//! Where the parts live (under `constant/`): `lane.rs`, one lane's own state and joint work;
//! `lane_band.rs`, the band products and lane access on lane-fastest vectors; `event_cuts.rs`,
//! steps cut at contact events; `adaptive_steps.rs`, the `tol=` runs. The scheme's coefficients
//! are [`Newmark`]'s (`integrator/newmark.rs`).

use super::adaptive::{self, Levels};
use super::divergence;
use super::events::{earliest_crossing, penetration_rate, CutSearch, EVENT_MAX_CUTS};
use super::run_loop::{self, Stepper};
use super::{norm2, same_instant, Newmark};
use crate::contact::{evaluation, ContactTerms, Coupling, Mat2};
use crate::error::{Error, Result};
use crate::linalg::{capacitance_solve, subtract_ws, Analysis, AnalysisCache, Cholesky, LowRankBlocks};
use crate::model::NODE_DOFS;
use crate::plan::assembly::{shares_factor, Frames, Pattern, System};
use crate::plan::translating::Model;
use crate::record::Recorder;
use crate::run::{RunFailure, RunOutput, RunStats, Settings, SolverMode};
use std::sync::Arc;

mod adaptive_steps;
mod event_cuts;
mod lane;
mod lane_band;

use lane_band::{get_lane, matvec, project_lane, set_lane, LaneBand};

/// Steps between calls of the caller's control function (progress and interruption).
const CONTROL_STRIDE: u64 = 1 << 14;
/// Woodbury is abandoned for a step whose capacitance pivot ratio is below this.
const WOODBURY_RCOND: f64 = 1e-12;

/// One run's outcome: its output, or why it stopped with what it recorded until then.
pub type RunResult = std::result::Result<RunOutput, Box<RunFailure>>;

/// A run in progress: the assembled system, factorizations, state and workspace. The one-lane
/// case of [`Lockstep`].
pub struct NewmarkRun<'m> {
    inner: Lockstep<'m, 1>,
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
        let mut inner = Lockstep::<1>::with_analysis(&[(model, settings)], cache)?;
        if let Some(Err(f)) = inner.lanes[0].outcome.take() {
            return Err(f.error);
        }
        Ok(NewmarkRun { inner })
    }

    /// Runs to the end. See [`crate::run::simulate`].
    pub fn run(self, control: &mut dyn FnMut(f64) -> bool) -> RunResult {
        self.inner.run(control).pop().expect("a one-lane run has one outcome")
    }
}

fn mat2_is_zero(m: &Mat2) -> bool {
    m[0][0] == 0.0 && m[0][1] == 0.0 && m[1][0] == 0.0 && m[1][1] == 0.0
}

/// What the lanes share: the contact-free matrices, their factorization, the Woodbury columns,
/// the step constants, and (when every lane has the same frame motions) the frames.
struct Shared {
    /// Lane 0's system (pattern, M, K, C, joint DOFs and projections are every lane's).
    sys: System,
    n: usize,
    m: usize,
    dt: f64,
    c1: f64,
    c2: f64,
    bdt2: f64,
    gdt: f64,
    /// `beta dt^2`, `gamma dt` (the alpha schemes' predictors).
    bdt2r: f64,
    gdtr: f64,
    /// The alpha schemes' [`Newmark::alpha_constants`]; `None` for plain Newmark.
    alpha: Option<[f64; 3]>,
    steps: u64,
    chol0: Cholesky,
    a0_values: Vec<f64>,
    /// Positions of each joint's DOF block in the pattern, `[a][b]`.
    joint_pos: Vec<[[usize; 4]; 4]>,
    zcols: Vec<f64>,
    wmat: Vec<f64>,
    /// Banded copies of K and C for the per-step products, when the pattern is banded.
    k_band: Option<LaneBand>,
    c_band: Option<LaneBand>,
    translational: Vec<bool>,
    /// Every lane has lane 0's link and body motions and inertia loads: frames are evaluated
    /// once per step into `frames` and the inertia load is the same on every lane.
    frames_shared: bool,
    frames: Frames,
    /// The mass matrix factorization (initial and event restart accelerations).
    mchol: Cholesky,
    /// The output grid's step, s (`settings.dt`; `dt` above is the step in use).
    grid_dt: f64,
    /// The longest step of adaptive steps, s (`Adaptive::h_max`; the levels are `h_max / 2^m`),
    /// `grid_dt` without them.
    h_max: f64,
    /// Adaptive steps: the step constants of recent step sizes besides the one in use
    /// ([`FactorCache`]); empty otherwise.
    cache: FactorCache,
}

/// Adaptive steps' small cache of factorizations: the constants ([`StepConsts`]: `A0`'s numeric
/// factorization on the shared analysis and its Woodbury columns) of up to [`FACTOR_CACHE`]
/// recent step sizes besides the one in [`Shared`], so that a step size that comes back costs no
/// refactorization. A step of another size swaps its constants in (a hit), or refills the least
/// recently used slot in place (a miss; slots holding a cut's odd length go first); an odd
/// length in use is refilled in place by the next odd length.
#[derive(Default)]
struct FactorCache {
    slots: Vec<StepConsts>,
    /// When each slot's constants were last in use (a counter).
    used: Vec<u64>,
    clock: u64,
}

/// Step sizes whose factorizations adaptive steps keep besides the one in use: levels
/// `h_max / 2^m` come back as the controller moves one level at a time, and into a contact it
/// spans a factor of 100 or more in step (eight levels with the one in use: a factor of 128).
/// A cut's odd lengths are refilled in place of the one in use and evict no level.
pub(crate) const FACTOR_CACHE: usize = 7;

/// The step-size-dependent part of [`Shared`]: the Newmark constants for a step `dt`, the
/// contact-free effective matrix `A0 = M + gamma dt C + beta dt^2 K`, its factorization and the
/// Woodbury columns `Z = A0^-1 P^T`, `W = P Z`. Event-aware stepping swaps in those of a substep.
struct StepConsts {
    dt: f64,
    c1: f64,
    c2: f64,
    bdt2: f64,
    gdt: f64,
    bdt2r: f64,
    gdtr: f64,
    chol0: Cholesky,
    a0_values: Vec<f64>,
    zcols: Vec<f64>,
    wmat: Vec<f64>,
}

impl StepConsts {
    /// The constants of step `dt` (s) for `sys` under the scheme `nm` (`bdt2`, `gdt` its
    /// [`Newmark::coefficients`], `bdt2r = beta dt^2`, `gdtr = gamma dt`); factorizes `A0` with
    /// `chol` (its analysis must be that of `sys.pattern`).
    fn new(sys: &System, dt: f64, nm: &Newmark, chol: Cholesky) -> Result<Self> {
        let mut c = StepConsts {
            dt: 0.0,
            c1: 0.0,
            c2: 0.0,
            bdt2: 0.0,
            gdt: 0.0,
            bdt2r: 0.0,
            gdtr: 0.0,
            chol0: chol,
            a0_values: vec![0.0; sys.pattern.nnz()],
            zcols: Vec::new(),
            wmat: Vec::new(),
        };
        c.refill(sys, dt, nm)?;
        Ok(c)
    }

    /// Makes these the constants of step `dt` (s) in place, as [`Self::new`] builds them (the
    /// same operations): a numeric refactorization on the same analysis, the Woodbury columns
    /// rebuilt in their storage (nothing is allocated once they have their size).
    fn refill(&mut self, sys: &System, dt: f64, nm: &Newmark) -> Result<()> {
        let (bdt2, gdt) = nm.coefficients(dt);
        let (beta, gamma) = (nm.beta, nm.gamma);
        for (p, x) in self.a0_values.iter_mut().enumerate() {
            *x = sys.mass[p] + gdt * sys.damping[p] + bdt2 * sys.stiffness[p];
        }
        self.chol0
            .factorize(&self.a0_values, "the effective matrix M + gamma dt C + beta dt^2 K")?;
        // Z = A0^-1 P^T, W = P Z (as `Woodbury::new`, in this storage)
        let p = sys.joints.as_slice();
        let n = sys.n();
        let m = 2 * LowRankBlocks::blocks(p);
        self.zcols.clear();
        self.zcols.resize(n * m, 0.0);
        for b in 0..p.blocks() {
            for r in 0..2 {
                let col = &mut self.zcols[(2 * b + r) * n..(2 * b + r + 1) * n];
                p.scatter(b, r, col);
                self.chol0.solve_in_place(col);
            }
        }
        self.wmat.clear();
        self.wmat.resize(m * m, 0.0);
        for b in 0..p.blocks() {
            for c in 0..m {
                let pz = p.project(b, &self.zcols[c * n..(c + 1) * n]);
                self.wmat[(2 * b) * m + c] = pz[0];
                self.wmat[(2 * b + 1) * m + c] = pz[1];
            }
        }
        self.dt = dt;
        self.c1 = dt * dt * (0.5 - beta);
        self.c2 = dt * (1.0 - gamma);
        self.bdt2 = bdt2;
        self.gdt = gdt;
        self.bdt2r = beta * dt * dt;
        self.gdtr = gamma * dt;
        Ok(())
    }
}

impl Shared {
    /// Exchanges the step constants in use with `o`.
    fn swap_step(&mut self, o: &mut StepConsts) {
        std::mem::swap(&mut self.dt, &mut o.dt);
        std::mem::swap(&mut self.c1, &mut o.c1);
        std::mem::swap(&mut self.c2, &mut o.c2);
        std::mem::swap(&mut self.bdt2, &mut o.bdt2);
        std::mem::swap(&mut self.gdt, &mut o.gdt);
        std::mem::swap(&mut self.bdt2r, &mut o.bdt2r);
        std::mem::swap(&mut self.gdtr, &mut o.gdtr);
        std::mem::swap(&mut self.chol0, &mut o.chol0);
        std::mem::swap(&mut self.a0_values, &mut o.a0_values);
        std::mem::swap(&mut self.zcols, &mut o.zcols);
        std::mem::swap(&mut self.wmat, &mut o.wmat);
    }
}

/// The start-of-step state of a one-lane run, kept by event-aware stepping to redo the step.
#[derive(Default)]
struct Snapshot {
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    aa: Vec<f64>,
    q: Vec<[f64; 2]>,
    qd: Vec<[f64; 2]>,
    pen: Vec<f64>,
    force: Vec<[f64; 2]>,
    gap_closed: Vec<bool>,
    gap_normal: Vec<[f64; 2]>,
    pa_old: Vec<f64>,
    episode: Vec<Option<f64>>,
}

/// State of adaptive steps (one-lane runs): the start of the trial step, the penetrations at
/// its start and end, the tolerance, the level `m` of the next step `h_max / 2^m`, and the
/// dense output's bookkeeping and scratch.
struct AdaptiveSteps {
    /// The time of the integrated state (s: the end of the last accepted step, at or past the
    /// last output instant), the start of that step (s), and the run's end (s).
    t: f64,
    t_start: f64,
    t_end: f64,
    /// The end of the last accepted step when no output instant took it yet: `Some(true)` at
    /// a cut (its right limit, an event for the recorder), `Some(false)` otherwise.
    pending: Option<bool>,
    /// Whether the output instant being recorded lies inside the last accepted step (its state
    /// interpolated).
    interpolated: bool,
    /// Scratch of an interpolated output: displacements, and per joint the relative
    /// displacement and velocity, penetration and force.
    out_u: Vec<f64>,
    out_q: Vec<[f64; 2]>,
    out_qd: Vec<[f64; 2]>,
    out_pen: Vec<f64>,
    out_force: Vec<[f64; 2]>,
    /// The start of the trial step (after acceptance: of the last accepted step).
    snap: Snapshot,
    p0: Vec<f64>,
    p1: Vec<f64>,
    tol: crate::run::Adaptive,
    levels: Levels,
    /// Calls of the caller's control function between output instants.
    control: adaptive::ControlTicker,
    /// The achieved-accuracy estimate of the joints' largest forces.
    forces: adaptive::ForceErrors,
    /// Accepted steps since the last divergence check.
    accepted: divergence::AcceptedSteps,
    /// Per unknown, the length (m) its error is measured in: 1 for a displacement,
    /// [`adaptive::rotation_lever`] of its link's element length for a rotation (as the Newton
    /// stepper's error norm).
    err_scale: Vec<f64>,
}

/// Per unknown of `sys` (`n` of them), the length (m) by which the adaptive steps' error norm
/// weighs it: 1 for a displacement, [`adaptive::rotation_lever`] of the link's element length for
/// a node's rotation (every third unknown of a link: `u`, `v`, `theta` per node).
fn rotation_scales(model: &Model, sys: &System, n: usize) -> Vec<f64> {
    let mut scale = vec![1.0; n];
    for (link, plan) in model.links.iter().zip(&sys.links) {
        let lever = adaptive::rotation_lever(link.element_length());
        for k in (NODE_DOFS - 1..plan.ndof).step_by(NODE_DOFS) {
            scale[plan.offset + k] = lever;
        }
    }
    scale
}

/// Scratch of event-aware stepping (one-lane runs): the start-of-step snapshot.
#[derive(Default)]
struct Events {
    snap: Snapshot,
    /// Penetrations at the end of the trial step, m.
    pen1: Vec<f64>,
}

/// What each lane has of its own: its model and settings (clearances, contact laws, coupling,
/// recording), its contact state, the small Woodbury system, counters and recorder.
struct Lane<'m> {
    model: &'m Model,
    settings: Settings,
    sys: System,
    frames: Frames,
    chol_c: Option<Cholesky>,
    ac_values: Vec<f64>,
    /// Full right-hand side, for refactorized steps.
    rb: Vec<f64>,
    /// This lane's solution of a refactorized step; also scratch for lane extraction.
    sol: Vec<f64>,
    col: Vec<f64>,
    terms: Vec<ContactTerms>,
    g: Vec<Mat2>,
    g_factored: Vec<Mat2>,
    h: Vec<f64>,
    yb: Vec<f64>,
    s: Vec<f64>,
    pa: Vec<f64>,
    pa_old: Vec<f64>,
    cap: Vec<f64>,
    q: Vec<[f64; 2]>,
    qd: Vec<[f64; 2]>,
    qt: Vec<[f64; 2]>,
    qdt: Vec<[f64; 2]>,
    pen: Vec<f64>,
    force: Vec<[f64; 2]>,
    gap_closed: Vec<bool>,
    gap_normal: Vec<[f64; 2]>,
    gap_k: Vec<f64>,
    /// Joints whose law depends on the approach speed of the contact episode.
    needs_v0: Vec<bool>,
    /// Some joint's law does (one test per step for the laws that do not).
    any_v0: bool,
    /// Approach speed of each joint's current episode, m/s (`None` while open).
    episode: Vec<Option<f64>>,
    /// Event-aware stepping's first substep: each joint's contact status held at its
    /// start-of-step value (`Some(closed)`), so that the substep follows the old-status
    /// trajectory up to the crossing; empty otherwise.
    frozen: Vec<bool>,
    /// Contact status switches of each joint within the current step's iteration.
    switches: Vec<u8>,
    /// The previous iteration's change of the joint accelerations (stagnation test).
    prev_change: f64,
    limit: f64,
    stats: RunStats,
    rec: Recorder,
    /// The last step of this lane was solved by refactorization (solution in `sol`).
    refactored: bool,
    /// The recorder reads node displacements (needs this lane's `u`).
    reads_u: bool,
    /// Set when the lane has finished (failed, or at the end of the run).
    outcome: Option<RunResult>,
    /// The error of a lane failing in the current step, until it is retired.
    pending: Option<Error>,
}

/// `L` runs stepped together on one shared contact-free factorization (see the module
/// documentation). Build it with [`Lockstep::with_analysis`] from 1 to `L` runs for which
/// [`shares_factor`] holds; missing lanes are idle.
pub struct Lockstep<'m, const L: usize> {
    sh: Shared,
    lanes: Vec<Lane<'m>>,
    active: [bool; L],
    u: Vec<[f64; L]>,
    v: Vec<[f64; L]>,
    a: Vec<[f64; L]>,
    /// The alpha schemes' acceleration-like variable (empty for plain Newmark).
    aa: Vec<[f64; L]>,
    r: Vec<[f64; L]>,
    tmp: Vec<[f64; L]>,
    xpad: Vec<[f64; L]>,
    col_y: Vec<f64>,
    t: f64,
    step: u64,
}

/// Read access to one lane's entries of a global vector.
trait DofAt: Copy {
    fn at(&self, i: usize) -> f64;
    /// The entries as one contiguous slice, where they are.
    fn slice(&self) -> Option<&[f64]> {
        None
    }
}

impl DofAt for &[f64] {
    #[inline]
    fn at(&self, i: usize) -> f64 {
        self[i]
    }
    #[inline]
    fn slice(&self) -> Option<&[f64]> {
        Some(self)
    }
}

/// Lane `.1` of lane-fastest vector `.0`.
#[derive(Clone, Copy)]
struct LaneOf<'a, const L: usize>(&'a [[f64; L]], usize);

impl<const L: usize> DofAt for LaneOf<'_, L> {
    #[inline]
    fn at(&self, i: usize) -> f64 {
        self.0[i][self.1]
    }
}

impl<'m, const L: usize> Lockstep<'m, L> {
    /// Assembles and factorizes once for all `runs` (1 to `L` pairs of a validated model and
    /// validated settings, every pair sharing the factor of the first: [`shares_factor`]; an
    /// event-aware run only with `L = 1`), and
    /// initializes every lane. Fails (for every lane) when the runs do not share the factor or
    /// when the mass or the contact-free effective matrix is not positive definite; a lane whose
    /// initial state fails its check is finished at once with that error and an empty output.
    pub fn with_analysis(runs: &[(&'m Model, &Settings)], cache: Option<&AnalysisCache>) -> Result<Self> {
        if runs.is_empty() || runs.len() > L {
            return Err(Error::InvalidModel {
                message: format!("a lockstep run takes 1 to {L} runs, not {}", runs.len()),
            });
        }
        if L > 1 && runs.iter().any(|(_, s)| s.events || s.adaptive.is_some()) {
            return Err(Error::InvalidModel {
                message: "an event-aware or adaptive run (events = true, adaptive steps) steps alone, not as a \
                          lockstep lane"
                    .into(),
            });
        }
        let systems: Vec<System> = runs.iter().map(|(m, _)| System::assemble(m)).collect();
        for (k, (sys, (_, s))) in systems.iter().zip(runs).enumerate().skip(1) {
            if !shares_factor((&systems[0], runs[0].1), (sys, s)) {
                return Err(Error::InvalidModel {
                    message: format!("lockstep lane {k} does not share lane 0's effective matrix and step"),
                });
            }
        }
        let sys = systems[0].clone();
        let settings = runs[0].1;
        let n = sys.n();
        let nj = sys.joints.len();
        let m = 2 * nj;
        let dt = settings.dt;
        let nm = settings.newmark;
        let analysis = match cache {
            Some(c) => c.get(&sys.pattern)?,
            None => Analysis::new(&sys.pattern)?,
        };
        let StepConsts {
            dt,
            c1,
            c2,
            bdt2,
            gdt,
            bdt2r,
            gdtr,
            chol0,
            a0_values,
            zcols,
            wmat,
        } = StepConsts::new(&sys, dt, &nm, Cholesky::with_analysis(Arc::clone(&analysis)))
            .map_err(|e| sys.name_pivot(runs[0].0, e))?;
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
        let mut translational = vec![true; n];
        for (i, t) in translational.iter_mut().enumerate() {
            // every link has 3 DOFs per node and starts at a multiple of 3
            *t = i % 3 != 2;
        }
        let k_band = LaneBand::from_csc(&sys.pattern, &sys.stiffness);
        let c_band = if sys.proportional_damping.is_some() {
            None
        } else {
            LaneBand::from_csc(&sys.pattern, &sys.damping)
        };
        let frames_shared = systems.iter().skip(1).all(|s| {
            s.bodies == sys.bodies
                && s.body_as_link == sys.body_as_link
                && s.links
                    .iter()
                    .zip(&sys.links)
                    .all(|(x, y)| x.motion == y.motion && x.rotation == y.rotation && x.inertia_load == y.inertia_load)
        });
        let mut mchol = Cholesky::with_analysis(Arc::clone(&analysis));
        mchol
            .factorize(&sys.mass, "the mass matrix")
            .map_err(|e| sys.name_pivot(runs[0].0, e))?;
        let mut run = Lockstep {
            sh: Shared {
                frames: sys.frames(),
                n,
                m,
                dt,
                c1,
                c2,
                bdt2,
                gdt,
                bdt2r,
                gdtr,
                alpha: nm.is_alpha().then(|| nm.alpha_constants()),
                steps: settings.steps(),
                chol0,
                a0_values,
                joint_pos,
                zcols,
                wmat,
                k_band,
                c_band,
                translational,
                frames_shared,
                sys,
                mchol,
                grid_dt: settings.dt,
                h_max: settings.adaptive.map_or(settings.dt, |a| a.h_max),
                cache: FactorCache::default(),
            },
            lanes: Vec::with_capacity(L),
            active: [false; L],
            u: vec![[0.0; L]; n],
            v: vec![[0.0; L]; n],
            a: vec![[0.0; L]; n],
            aa: Vec::new(),
            r: vec![[0.0; L]; n],
            tmp: vec![[0.0; L]; n],
            xpad: Vec::new(),
            col_y: vec![0.0; n],
            t: 0.0,
            step: 0,
        };
        let pad = run.sh.k_band.as_ref().map_or(0, LaneBand::padded_len);
        run.xpad = vec![[0.0; L]; pad];
        let (mut u0, mut v0, mut a0) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (l, ((model, settings), sys)) in runs.iter().zip(systems).enumerate() {
            let mut lane = Lane::new(model, settings, sys);
            u0.fill(0.0);
            v0.fill(0.0);
            a0.fill(0.0);
            match lane.initialize(&mut run.sh.mchol, &run.sh.translational, &mut u0, &mut v0, &mut a0) {
                Ok(()) => {
                    set_lane(&mut run.u, l, &u0);
                    set_lane(&mut run.v, l, &v0);
                    set_lane(&mut run.a, l, &a0);
                    run.active[l] = true;
                }
                Err(error) => lane.outcome = Some(Err(RunFailure::before_start(error))),
            }
            run.lanes.push(lane);
        }
        if run.sh.alpha.is_some() {
            run.aa.clone_from(&run.a); // aa_0 = a_0
        }
        Ok(run)
    }

    /// Runs every lane to the end (or to its failure) and returns the lanes' outcomes in order.
    /// `control(fraction_done)` is called every few thousand steps; when it returns `false`
    /// every running lane stops with [`Error::Interrupted`].
    pub fn run(self, control: &mut dyn FnMut(f64) -> bool) -> Vec<RunResult> {
        #[cfg(target_arch = "x86_64")]
        if L > 1 && crate::linalg::avx2_fma_available() {
            // SAFETY: the CPU reports AVX2 and FMA.
            return unsafe { self.run_avx2(control) };
        }
        self.run_body(control)
    }

    /// [`Self::run`] compiled for AVX2, so that the lane loops use 256-bit vectors. Enabling the
    /// feature changes no result: Rust never fuses a multiply and an add on its own.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn run_avx2(self, control: &mut dyn FnMut(f64) -> bool) -> Vec<RunResult> {
        self.run_body(control)
    }

    #[inline(always)]
    fn run_body(mut self, control: &mut dyn FnMut(f64) -> bool) -> Vec<RunResult> {
        let settings = &self.lanes[0].settings;
        let adaptive = (L == 1).then_some(settings.adaptive).flatten().map(|tol| {
            let nj = self.sh.sys.joints.len();
            let n = self.sh.n;
            let dt = self.sh.grid_dt;
            AdaptiveSteps {
                t: 0.0,
                t_start: 0.0,
                t_end: self.sh.steps as f64 * dt,
                pending: None,
                interpolated: false,
                out_u: vec![0.0; n],
                out_q: vec![[0.0; 2]; nj],
                out_qd: vec![[0.0; 2]; nj],
                out_pen: vec![0.0; nj],
                out_force: vec![[0.0; 2]; nj],
                snap: Snapshot::default(),
                p0: Vec::with_capacity(nj),
                p1: Vec::with_capacity(nj),
                tol,
                levels: Levels::new(tol.h_max, tol.h_min, dt),
                control: Default::default(),
                forces: adaptive::ForceErrors::new(nj),
                accepted: Default::default(),
                err_scale: rotation_scales(self.lanes[0].model, &self.sh.sys, n),
            }
        });
        let events = (L == 1 && settings.events && adaptive.is_none()).then(Events::default);
        run_loop::run(
            &mut LockstepLoop {
                ls: &mut self,
                events,
                adaptive,
            },
            control,
        );
        self.lanes
            .into_iter()
            .map(|lane| lane.outcome.expect("every lane has finished"))
            .collect()
    }

    /// Finishes lane `l` at `step`, time `t` (s): with `error`, as a failure keeping what it
    /// recorded; without, as a completed run. Its vectors are zeroed (an idle lane).
    fn retire(&mut self, l: usize, error: Option<Error>, step: u64, t: f64) {
        let lane = &mut self.lanes[l];
        let n = self.sh.n;
        let (mut u, mut v, mut a) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        get_lane(&self.u, l, &mut u);
        get_lane(&self.v, l, &mut v);
        get_lane(&self.a, l, &mut a);
        for x in [&mut self.u, &mut self.v, &mut self.a, &mut self.r] {
            for xi in x.iter_mut() {
                xi[l] = 0.0;
            }
        }
        let mut stats = std::mem::take(&mut lane.stats);
        stats.steps = step;
        stats.factorizations = self.sh.chol0.factorizations
            + self.sh.cache.slots.iter().map(|c| c.chol0.factorizations).sum::<u64>()
            + lane.chol_c.as_ref().map_or(0, |c| c.factorizations);
        let output = RunOutput {
            record: std::mem::take(&mut lane.rec),
            stats,
            state: [u, v, a],
            time: t,
        };
        lane.outcome = Some(match error {
            None => Ok(output),
            Some(error) => Err(Box::new(RunFailure { error, output })),
        });
        self.active[l] = false;
    }

    /// Retires every lane with a pending error (see [`Self::retire`]).
    #[cold]
    fn retire_pending(&mut self, step: u64, t: f64) {
        for l in 0..self.lanes.len() {
            if let Some(e) = self.lanes[l].pending.take() {
                self.retire(l, Some(e), step, t);
            }
        }
    }

    /// One step of every active lane to `t1`.
    #[inline(always)]
    fn advance(&mut self, t1: f64) {
        let sh = &mut self.sh;
        let (dt, c1, c2) = (sh.dt, sh.c1, sh.c2);
        let pat = &sh.sys.pattern;
        let alpha = sh.alpha.is_some();
        if let Some([k0, k1, _]) = sh.alpha {
            // the alpha schemes' predictors (Newmark::coefficients): b = k0 a_n + k1 aa_n,
            // u~ = u + dt v + c1 aa + beta dt^2 b, v~ = v + c2 aa + gamma dt b; aa holds b until
            // `complete`
            let (bdt2r, gdtr) = (sh.bdt2r, sh.gdtr);
            for (((u, v), &a), aa) in self
                .u
                .as_flattened_mut()
                .iter_mut()
                .zip(self.v.as_flattened_mut().iter_mut())
                .zip(self.a.as_flattened())
                .zip(self.aa.as_flattened_mut().iter_mut())
            {
                let b = k0 * a + k1 * *aa;
                *u += dt * *v + c1 * *aa + bdt2r * b;
                *v += c2 * *aa + gdtr * b;
                *aa = b;
            }
        }
        match sh.sys.proportional_damping {
            Some(c) => {
                if alpha {
                    // w = -(u~ + c v~) (the alpha predictors above already applied)
                    for ((u, v), w) in self
                        .u
                        .as_flattened()
                        .iter()
                        .zip(self.v.as_flattened())
                        .zip(self.tmp.as_flattened_mut().iter_mut())
                    {
                        *w = -(*u + c * *v);
                    }
                } else {
                    // predictors (in place: u, v hold u~, v~ until `complete`) and w = -(u~ + c v~)
                    // in one pass (lane by lane the same operations; flat, the loop vectorizes
                    // across lanes)
                    for ((u, v), (&a, w)) in self
                        .u
                        .as_flattened_mut()
                        .iter_mut()
                        .zip(self.v.as_flattened_mut().iter_mut())
                        .zip(self.a.as_flattened().iter().zip(self.tmp.as_flattened_mut().iter_mut()))
                    {
                        *u += dt * *v + c1 * a;
                        *v += c2 * a;
                        *w = -(*u + c * *v); // negated here so that r = K w needs no extra pass
                    }
                }
                // r = K w
                matvec(
                    pat,
                    sh.k_band.as_ref(),
                    &sh.sys.stiffness,
                    &self.tmp,
                    &mut self.xpad,
                    &mut self.r,
                    &mut self.lanes[0].col,
                    &mut self.col_y,
                );
            }
            None => {
                if !alpha {
                    for ((u, v), &a) in self
                        .u
                        .as_flattened_mut()
                        .iter_mut()
                        .zip(self.v.as_flattened_mut().iter_mut())
                        .zip(self.a.as_flattened())
                    {
                        *u += dt * *v + c1 * a;
                        *v += c2 * a;
                    }
                }
                matvec(
                    pat,
                    sh.k_band.as_ref(),
                    &sh.sys.stiffness,
                    &self.u,
                    &mut self.xpad,
                    &mut self.r,
                    &mut self.lanes[0].col,
                    &mut self.col_y,
                );
                matvec(
                    pat,
                    sh.c_band.as_ref(),
                    &sh.sys.damping,
                    &self.v,
                    &mut self.xpad,
                    &mut self.tmp,
                    &mut self.lanes[0].col,
                    &mut self.col_y,
                );
                for (x, t) in self.r.as_flattened_mut().iter_mut().zip(self.tmp.as_flattened()) {
                    *x = -*x - t;
                }
            }
        }
        if sh.frames_shared {
            sh.sys.frames_at(t1, &mut sh.frames);
            // -M_R a_R, the same on every lane (System::add_inertia_load, lane by lane)
            for (lp, k) in sh.sys.links.iter().zip(&sh.frames.links) {
                if let Some([bx, by]) = &lp.inertia_load {
                    let acc = k.acc;
                    let rot = &lp.rotation;
                    let ax = rot[0][0] * acc[0] + rot[1][0] * acc[1];
                    let ay = rot[0][1] * acc[0] + rot[1][1] * acc[1];
                    let seg = &mut self.r[lp.offset..lp.offset + lp.ndof];
                    for ((fi, x), y) in seg.iter_mut().zip(bx).zip(by) {
                        let f = ax * x + ay * y;
                        for l in 0..L {
                            fi[l] -= f;
                        }
                    }
                }
            }
        } else {
            for (l, lane) in self.lanes.iter_mut().enumerate() {
                if !self.active[l] {
                    continue;
                }
                lane.sys.frames_at(t1, &mut lane.frames);
                get_lane(&self.r, l, &mut lane.col);
                lane.sys.add_inertia_load(&lane.frames, &mut lane.col);
                set_lane(&mut self.r, l, &lane.col);
            }
        }
        let nj = sh.sys.joints.len();
        if nj == 0 {
            sh.chol0.solve_lanes(&mut self.r);
            std::mem::swap(&mut self.a, &mut self.r);
            return self.complete(t1);
        }
        for (l, lane) in self.lanes.iter_mut().enumerate() {
            if self.active[l] {
                if sh.frames_shared {
                    lane.pre_solve(&sh.frames, &self.u, &self.v, &self.r, l, sh.bdt2, sh.gdt);
                } else {
                    let frames = std::mem::take(&mut lane.frames);
                    lane.pre_solve(&frames, &self.u, &self.v, &self.r, l, sh.bdt2, sh.gdt);
                    lane.frames = frames;
                }
            }
        }
        sh.chol0.solve_lanes(&mut self.r); // r = z = A0^-1 rhs
        let mut failed = false;
        for (l, lane) in self.lanes.iter_mut().enumerate() {
            if self.active[l] {
                if let Err(e) = lane.post_solve(sh, &self.r, l, self.t, self.step) {
                    lane.pending = Some(e);
                    failed = true;
                }
            }
        }
        if failed {
            // the failed lanes keep their predictors and the last acceleration
            self.retire_pending(self.step, self.t);
        }
        // a = z + Z (h - s) on the Woodbury lanes; z is not needed after this step
        std::mem::swap(&mut self.a, &mut self.r);
        let sh = &self.sh;
        let (n, m) = (sh.n, sh.m);
        for c in 0..m {
            let mut w = [0.0f64; L];
            let mut any = false;
            for (l, lane) in self.lanes.iter().enumerate() {
                if self.active[l] && !lane.refactored {
                    w[l] = lane.h[c] - lane.s[c];
                    any |= w[l] != 0.0;
                }
            }
            if any {
                let col = &sh.zcols[c * n..(c + 1) * n];
                for (ai, &zi) in self.a.iter_mut().zip(col) {
                    for l in 0..L {
                        ai[l] = if w[l] != 0.0 { ai[l] + w[l] * zi } else { ai[l] };
                    }
                }
            }
        }
        for (l, lane) in self.lanes.iter().enumerate() {
            if self.active[l] && lane.refactored {
                set_lane(&mut self.a, l, &lane.sol);
            }
        }
        self.complete(t1)
    }

    /// Updates the state from the new acceleration and evaluates the joints at `t1` (a lane
    /// failing there is retired).
    #[inline(always)]
    fn complete(&mut self, t1: f64) {
        let (bdt2, gdt) = (self.sh.bdt2, self.sh.gdt);
        for ((u, v), &a) in self
            .u
            .as_flattened_mut()
            .iter_mut()
            .zip(self.v.as_flattened_mut().iter_mut())
            .zip(self.a.as_flattened())
        {
            *u += bdt2 * a;
            *v += gdt * a;
        }
        if let Some([_, _, k2]) = self.sh.alpha {
            // aa_{n+1} = b + k2 a_{n+1}
            for (aa, &a) in self.aa.as_flattened_mut().iter_mut().zip(self.a.as_flattened()) {
                *aa += k2 * a;
            }
        }
        let mut failed = false;
        for (l, lane) in self.lanes.iter_mut().enumerate() {
            if self.active[l] {
                if let Err(e) = lane.complete_joints(&self.a, l, bdt2, gdt, t1, self.step) {
                    lane.pending = Some(e);
                    failed = true;
                }
            }
        }
        if failed {
            self.retire_pending(self.step, self.t);
        }
    }

    /// The divergence check of lane `l`'s state at `t` (s), step `step`.
    #[inline(always)]
    fn check_lane(&self, l: usize, t: f64, step: u64) -> Result<()> {
        let lane = &self.lanes[l];
        if L == 1 {
            lane.check_state(
                self.u.as_flattened(),
                self.v.as_flattened(),
                &self.sh.translational,
                t,
                step,
            )
        } else {
            lane.check_state(LaneOf(&self.u, l), LaneOf(&self.v, l), &self.sh.translational, t, step)
        }
    }

    /// Records every active lane after the step to `t` (s).
    #[inline(always)]
    fn record(&mut self) {
        let (step, t) = (self.step, self.t);
        for l in 0..self.lanes.len() {
            if !self.active[l] {
                continue;
            }
            let lane = &mut self.lanes[l];
            let dt = lane.settings.dt;
            if L == 1 {
                lane.rec.record(
                    step,
                    t,
                    dt,
                    &lane.pen,
                    &lane.force,
                    &lane.q,
                    &lane.qd,
                    self.u.as_flattened(),
                );
            } else if lane.reads_u {
                get_lane(&self.u, l, &mut lane.col);
                lane.rec
                    .record(step, t, dt, &lane.pen, &lane.force, &lane.q, &lane.qd, &lane.col);
            } else {
                lane.rec
                    .record(step, t, dt, &lane.pen, &lane.force, &lane.q, &lane.qd, &[]);
            }
        }
    }
}

/// The lockstep in the one run loop ([`run_loop`]), with the scratch of event-aware stepping
/// (one lane only).
struct LockstepLoop<'a, 'm, const L: usize> {
    ls: &'a mut Lockstep<'m, L>,
    events: Option<Events>,
    /// Adaptive steps (one lane only), `None` for the fixed step.
    adaptive: Option<AdaptiveSteps>,
}

impl<const L: usize> Stepper for LockstepLoop<'_, '_, L> {
    const CONTROL_STRIDE: u64 = CONTROL_STRIDE;

    #[inline(always)]
    fn steps(&self) -> u64 {
        self.ls.sh.steps
    }

    #[inline(always)]
    #[allow(clippy::misnamed_getters)] // the output grid's step, not the step in use
    fn dt(&self) -> f64 {
        self.ls.sh.grid_dt
    }

    #[inline(always)]
    fn running(&self) -> bool {
        self.ls.active.iter().any(|&a| a)
    }

    #[inline(always)]
    fn advance(&mut self, k: u64, t1: f64, control: &mut dyn FnMut(f64) -> bool) {
        debug_assert_eq!(k, self.ls.step + 1);
        match (self.adaptive.as_mut(), self.events.as_mut()) {
            (Some(ad), _) => self.ls.adaptive_advance(t1, ad, control),
            (None, None) => self.ls.advance(t1),
            (None, Some(ev)) => self.ls.advance_with_events(t1, ev),
        }
        self.ls.step = k;
        self.ls.t = t1;
    }

    #[inline(always)]
    fn check(&mut self, k: u64, t1: f64) {
        let ls = &mut *self.ls;
        for l in 0..ls.lanes.len() {
            if ls.active[l] {
                if let Err(e) = ls.check_lane(l, t1, k) {
                    ls.retire(l, Some(e), k, t1);
                }
            }
        }
    }

    #[inline(always)]
    fn record(&mut self, k: u64, t1: f64) {
        match self.adaptive.as_mut() {
            Some(ad) if ad.interpolated => {
                if self.ls.active[0] {
                    self.ls.record_interpolated(k, t1, ad);
                }
            }
            _ => self.ls.record(),
        }
    }

    #[cold]
    fn stop_all(&mut self, error: Error, k: u64, t: f64) {
        for l in 0..self.ls.lanes.len() {
            if self.ls.active[l] {
                self.ls.retire(l, Some(error.clone()), k, t);
            }
        }
    }

    fn end(&mut self, k: u64, t: f64) {
        for l in 0..self.ls.lanes.len() {
            if self.ls.active[l] {
                self.ls.retire(l, None, k, t);
            }
        }
    }
}
