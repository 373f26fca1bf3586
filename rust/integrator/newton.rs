//! Newmark integration of a kineto-elastodynamic [`Mechanism`]: links in moving frames with the
//! full element equation of docs/method.md section 2,
//!
//! `M Qdd + (D1 + D2 + M_COR) Qd + (K1 + K2 + K3 + M_IC) Q = f - M_R a_R`,
//!
//! ideal pins by elimination (a pinned node's translation is a shared unknown in global axes and
//! enters each link through its frame rotation, the `T_ij` of paper eq. 4b; a node on a slider
//! has one unknown along the guide), and clearance joints by the force or modified method.
//!
//! Each step solves for the accelerations `a` at `t + dt` (`y = y~ + beta dt^2 a`,
//! `yd = v~ + gamma dt a`; the generalized-alpha family of [`crate::integrator::Newmark`] with its
//! `beta'`, `gamma'` and predictors, the residual still at `t + dt`) by Newton iterations on the
//! residual with the tangent Jacobian of the
//! step start (including the axial-force dependence of K2, K3, D2: a modified Newton whose rate
//! is set by how much the axial force moves within the step). The Jacobian is refactorized only when
//! a quantity it depends on changed (step, frame rate and acceleration, frame angle for links
//! with transformed nodes, axial forces): a non-rotating link or one spinning at
//! constant speed with no geometric terms factors it once per run (after the one factorization of
//! the mass matrix for the initial accelerations). The clearance joints' terms go on that
//! contact-free factor by Woodbury (below) where both sides of every joint turn at one rate and
//! the solver is [`SolverMode::Woodbury`] (the default); otherwise a change of the contact terms
//! refactorizes too (the reference, [`SolverMode::Refactor`]). A step with nothing nonlinear
//! takes exactly one solve.
//!
//! Clearance joints: the force method applies the contact force of the step start; the modified
//! method adds the secant `kappa K_B` and `C_B` of the step start to the Jacobian (lagged kappa).
//! Both are explicit in the contact and add energy at every impact (of order dt over the contact
//! time: measured on free links in an undamped bearing, and as MN forces in a slider-crank with a
//! restitution of 0.9). With `iterate` the contact is implicit: the spring force, its tangent and
//! the damping are evaluated at every iterate (the Jacobian refactorized when they change; the
//! dashpot left out for the rest of a step whose status keeps switching at the contact edge).
//! That conserves energy up to the cost of the contact edge within a step and converges under dt
//! refinement; use it with clearance joints. The terms per coupling, the iterated algorithm and
//! the recorded force (the force applied in the step) are those of the constant stepper: one
//! evaluation, [`crate::contact::evaluation`].
//!
//! The contact on the contact-free factor: the constant-rate stepper
//! ([`NewtonRun::use_constant_rate`], `stats.stepper == "constant-rate"`) is this stepper for
//! models whose Jacobian without the contact terms is the same at every step ([`NewtonRun::constant_rate_obstacle`]: frames at rest or turning at a
//! constant rate, no geometric terms, no transformed node in a rotating link, both sides of each
//! clearance joint turning at one rate). It factorizes that Jacobian once, at the run's step, and
//! solves each iteration with the contact terms as a low-rank update `P^T G P` on it
//! (Sherman-Morrison-Woodbury, [`crate::linalg::Woodbury`], one 2 x 2 block per joint): `P`, the
//! derivative of the joint's relative displacement, is constant in axes turning with the joint's
//! frame, and `G = beta h^2 k + gamma h c + beta h^2 rate c S` (the damping's frame-rotation
//! term) is turned into those axes. The same linear system as the refactorizing path's, so the
//! same iterates up to rounding; steps of another length (halved, cut at an event) and a
//! capacitance too ill-conditioned to trust take the refactorizing path. The Newton stepper uses
//! the same update on the contact-free factor of its step, refactorized when that changes
//! (every step for geometric terms, whose axial forces are those of the step's first iterate);
//! its later iterations then keep the step start's geometric tangent where the refactorizing
//! path refreshes it whenever the contact changes, so the two differ within the iteration
//! tolerance.
//!
//! Adaptive steps ([`Settings::adaptive`](crate::run::Settings::adaptive), the `tol=` runs of
//! Python): steps of `h_max / 2^m` (`Adaptive::h_max`), independent of the output grid `dt`,
//! chosen by the Zienkiewicz-Xie local error estimate, with every contact entry and exit located
//! by a cut and no contact stepped over between open ends (`NewtonRun::adaptive_advance`); an
//! output instant inside a step takes the interpolated state (`NewtonRun::interpolate_output`). The cut aims just short of the circle,
//! so the substep to it carries no force of the new status (a substep ending inside would spread
//! the dashpot's entry jump over its length at first order), and the step after it starts from
//! the restarted accelerations and is sized by the estimate, which sees the jump.
//!
//! Friction in a clearance joint ([`crate::model::mechanism::Clearance::friction`],
//! docs/contact.md section 4.1): the slip speed `(v_J - v_B) . t + R_J w_J - R_B w_B` (total
//! spins: frame rate plus elastic rotation rate), the force `F_t(v, F_N)` on both sides'
//! translations and the moments `F_t R_J`, `-F_t R_B` on their rotation unknowns, evaluated at
//! every iterate in the residual with the normal force of the contact terms acting in the step.
//! Its tangent goes into the Jacobian (refactorized when it changes): the slip-speed part
//! `-dF/dv` (a symmetric damper along the slip; for Coulomb, the larger secant `-F_t / v` after
//! [`FRICTION_SECANT_AFTER`] iterations of a step, where Newton cycles across the kinks of a
//! steep regularization) and the normal-force part `dF_t/dF_N` (unsymmetric). Neither is a
//! symmetric block on the joint's relative displacement, so a model with friction never uses the
//! contact-free factor (no Woodbury, not the constant-rate stepper; the plan never gives it to
//! the constant stepper). Left on the right-hand side instead, a stuck joint with a steep
//! regularization did not converge (the measurements are in docs/contact.md). LuGre's bristle
//! state is advanced exactly over the step from the last accepted state and committed when the
//! step converges (step halving and event cuts restart from it).
//!
//! Nothing allocates inside the time loop.

use super::adaptive;
use super::events::{earliest_crossing, penetration_rate, CutSearch, EVENT_MAX_CUTS};
use super::run_loop::{self, Stepper};
use super::{norm2, same_instant};
use crate::contact::friction::FrictionEval;
use crate::contact::{evaluation, ContactLaw, ContactTerms, Coupling, Mat2, SpringDamper};
use crate::element::{BeamElement, Mat6, Vec6};
use crate::error::{Error, Result};
use crate::kinematics::FrameState;
use crate::linalg::{BandLu, LowRankBlocks, Woodbury, WoodburyScratch};
use crate::model::mechanism::{Endpoint, Mechanism};
use crate::record::{reserve_now, JointHistory, LinkHistory, LinkPeaks, RecordSpec, Recorder, SliderHistory};
use crate::run::JACOBIAN_REUSE_ITERATIONS;
use crate::run::{RunFailure, RunOutput, RunStats, Settings, SolverMode};

use crate::plan::dofs::{self, DofMap, LinkTerms, NodeMap, Trans, NONE};

mod continuous;
mod element_lanes;
mod state_update;

use state_update::{correct, max_abs_difference, max_of_lanes, predict};
#[cfg(target_arch = "x86_64")]
use state_update::{correct_avx2, max_abs_difference_avx2, predict_avx2};

/// Largest relative correction (of the displacement scale) that a step may stall at and still be
/// accepted as converged at round-off: when a Newton correction below this level is no smaller
/// than one of the two before it, and the residual has fallen by [`ROUNDOFF_RESIDUAL`], the
/// iterates are at the floor of the system's floating-point
/// arithmetic (about eps times its conditioning: 1e-13 to 2e-12 on a 200-element rod), so a
/// tolerance finer than that floor does not fail the run; such steps are counted in
/// [`RunStats::roundoff_steps`](crate::run::RunStats::roundoff_steps). A stall above it is a
/// real failure to converge and ends the run (or halves the step).
pub const ROUNDOFF_FLOOR: f64 = 1e-6;

/// From its third iteration on, a Newton iteration also stops when its contraction, the ratio
/// `rho` of its last correction to the one before, is below this and the error left in its
/// iterate, `rho / (1 - rho)` times the last correction (the geometric bound of the corrections
/// still to come), is within the tolerance: the correction that would only confirm it is not
/// computed. Not at the second: the first correction takes out the predictor's error and says
/// nothing of the rate (on a kept factor, stopping there let the contact force drift by 7.5e-6
/// of its peak from the refactorizing solver's over 1000 steps, `tests/constant_rate.rs`).
pub const CONTRACTION_STOP: f64 = 0.5;

/// The contraction rate of the Newton iterations is carried from step to step, as SUNDIALS'
/// CVODE does: at every second or later iteration it becomes the larger of the measured rate
/// (the last correction over the one before) and this fraction of the carried one, so it falls
/// by at most this factor a measurement. A step stops at any iteration whose correction times
/// the carried rate (the error it leaves) is within the Newton tolerance, when that rate is
/// below [`CONTRACTION_STOP`] and [`NewtonRun::carried_rate_margin`] allows it: every joint's
/// contact status at the corrected iterate is the one its terms were evaluated at, and in a
/// fixed-step run with a joint in contact the error left must be within
/// [`CONTACT_RATE_MARGIN`] of the tolerance. Not for friction or continuous contact. Without
/// it a step at the error bound of a `tol=` run always took a second iteration (the first
/// correction, the predictor's error, is about 3 times the local error
/// `(beta - 1/6) h^2 (a1 - a0)` the step's error test bounds), and a fixed step of the ideal
/// slider-crank a third (its rate is 1e-4, its second correction 1e-7). Measured: the
/// crank-pin slider-crank at `tol` 3e-2 (one crank turn) 9776 -> 6075 iterations (Jacobian
/// age 20); the ideal slider-crank at dt 1e-5 2.87 -> 1.81 iterations a
/// step; with clearance, whose steps are mostly in contact, 1.84 -> 1.35 with the margin in
/// contact (without it, 1.15 a step, the rattling contact force of `tests/constant_rate.rs`
/// drifted by 2.1e-3 of its scale from the refactorizing solver's, 5.7e-7 before).
pub const RATE_CARRY_DOWN: f64 = 0.3;

/// In a fixed-step run, a step with a joint in contact stops on the carried contraction rate
/// ([`RATE_CARRY_DOWN`]) only when the correction times the rate is within this fraction of the
/// Newton tolerance, and only where it iterates on the Woodbury solver with a contact-free factor
/// kept from an earlier step (a modified Newton, whose linear contraction a carried rate
/// follows; where the factor is this step's, the refactorizing solver's or the constant-rate
/// stepper's exact one, the iterations are a full Newton's and converge quadratically: a rate
/// measured at a small error understates the next step's).
/// Measured on Simeon's slider-crank with a clearance at the crank pin, dt 1e-5 s, 0.1 s, force
/// history against iterations to 1e-12 (relative to its peak), the stop on every step in
/// contact: margin 1: 1.75e-4 (1.15 iterations a step); 0.1: 2.8e-6 (1.24); 0.01: 1.27e-6
/// (1.29); as kept (0.01, kept factors only): 1.268e-6 (1.35), what it is without the stop in
/// contact (1.270e-6, 1.84 iterations a step). Full Newton iterations stopped so drifted:
/// with the margin 0.01, 7.8e-5 over 0.01 s on the refactorizing solver and on a factor made
/// every step, 1.1e-2 of the spinning beam's rattling contact force on the constant-rate
/// stepper (`tests/constant_rate.rs`), hence not there.
pub const CONTACT_RATE_MARGIN: f64 = 0.01;

/// The other half of the round-off test: the step's residual has fallen to this fraction of its
/// first iteration's, so what is left is the arithmetic's, not a stalled iteration's (a Newton
/// iteration that cycles, e.g. on a contact edge, keeps a residual of the order of the forces).
pub const ROUNDOFF_RESIDUAL: f64 = 1e-9;

/// Whether the first iterate of a Newmark step is the accelerations extrapolated along the last
/// step, `a_n + (h / h_(n-1)) (a_n - a_(n-1))`, instead of `a_n`: where the motion is smooth the
/// first correction is then of order `h^2 a''` rather than `h a'`, which on a reused factor
/// saves an iteration (the iterations converge to the same solution within `iter_tol`). Only
/// where the last converged step ended at this step's start with the accelerations it computed
/// (not after a restart at a cut, a restore or a projection: those change them), this step is at
/// most [`EXTRAPOLATION_MAX_RATIO`] times as long, and the extrapolation predicted the last step
/// better than `a_n` by [`EXTRAPOLATION_MARGIN`]. Plain Newmark only (the alpha schemes keep
/// their predictors).
pub const ACCELERATION_EXTRAPOLATION: bool = true;

/// The longest step, in lengths of the last, whose first iterate is extrapolated
/// ([`ACCELERATION_EXTRAPOLATION`]): adaptive steps grow by at most a factor 2 at a time; a step
/// after a short cut substep starts from `a_n`.
pub const EXTRAPOLATION_MAX_RATIO: f64 = 2.0;

/// How much better than `a_n` the extrapolation must have predicted the last step's end (largest
/// difference over the unknowns) to be the next step's first iterate
/// ([`ACCELERATION_EXTRAPOLATION`]). Over 0.1 s at dt 1e-5 s: 0.5 kept the slider-crank's gain
/// (crank-pin clearance 21874 -> 18431 iterations) where 1 (no margin) cost the four-bar 2.8 %
/// more (22890 -> 23521; 0.5: 23118, 0.25: 22911 but 1.3 % less of the slider-crank's gain).
pub const EXTRAPOLATION_MARGIN: f64 = 0.5;

/// The last converged Newmark step, for the extrapolated first iterate of the next
/// ([`ACCELERATION_EXTRAPOLATION`]).
#[derive(Debug, Clone)]
struct Extrapolation {
    /// Accelerations at the last step's start and end.
    a0: Vec<f64>,
    a1: Vec<f64>,
    /// The last step's end (s) and length (s; 0: none yet).
    t1: f64,
    h: f64,
    /// Whether the extrapolation predicted the last step's end better than its start did, by
    /// [`EXTRAPOLATION_MARGIN`] (largest difference over the unknowns): where the accelerations
    /// change irregularly from step to step it predicts worse, and the next step starts from
    /// `a_n`.
    better: bool,
    /// The weight of the step begun ([`Self::start`]) where the extrapolation applied to it.
    pending: Option<f64>,
}

impl Extrapolation {
    /// No step recorded yet, for `n` unknowns.
    fn new(n: usize) -> Self {
        Extrapolation {
            a0: vec![0.0; n],
            a1: vec![0.0; n],
            t1: f64::NAN,
            h: 0.0,
            better: true,
            pending: None,
        }
    }

    /// The weight of `a_n - a_(n-1)` in an extrapolated first iterate of a step of `h` (s)
    /// from `t` (s) where the accelerations are `a`, `h / h_(n-1)`, when the last converged
    /// step ended at `t` (the same instant up to rounding, [`super::same_instant`]) with exactly these accelerations and the step is at most
    /// [`EXTRAPOLATION_MAX_RATIO`] times as long; else `None`.
    fn applicable(&self, t: f64, h: f64, a: &[f64]) -> Option<f64> {
        if self.h <= 0.0 || (t - self.t1).abs() > same_instant(h) {
            return None;
        }
        let w = h / self.h;
        (w <= EXTRAPOLATION_MAX_RATIO && self.a1.iter().zip(a).all(|(x, y)| x.to_bits() == y.to_bits())).then_some(w)
    }

    /// At the start of a step of `h` (s) from `t` (s) where the accelerations are `a`: the
    /// weight `w` of `a_n - a_(n-1)` in its first iterate, as [`Self::applicable`] where the
    /// extrapolation predicted the last step clearly better than `a_n` did, else 0 (the first
    /// iterate is `a_n`). Keeps whether it applies for [`Self::converged`].
    fn start(&mut self, t: f64, h: f64, a: &[f64]) -> f64 {
        self.pending = if ACCELERATION_EXTRAPOLATION {
            self.applicable(t, h, a)
        } else {
            None
        };
        match self.pending {
            Some(w) if self.better => w,
            _ => 0.0,
        }
    }

    /// Records the converged step from `t` of `h` (s) with start and end accelerations `a0`,
    /// `a1` (those of the step [`Self::start`] began), and whether the extrapolation would have
    /// predicted `a1` better than `a0` (kept from before where it could not have applied).
    #[inline(always)]
    fn converged(&mut self, t: f64, h: f64, a0: &[f64], a1: &[f64]) {
        if let Some(w) = self.pending.take() {
            let n = a1.len();
            let (a0, xp) = (&a0[..n], &self.a0[..n]);
            // four running maxima each (no chain through every unknown; maxima are exact, so
            // the result is that of one running maximum), `if d > m` as in max_abs_difference
            let (mut ms, mut me) = ([0.0f64; 4], [0.0f64; 4]);
            let chunks = a1.chunks_exact(4).zip(a0.chunks_exact(4)).zip(xp.chunks_exact(4));
            for ((c1, c0), cp) in chunks {
                for k in 0..4 {
                    let d = (c1[k] - c0[k]).abs();
                    let e = (c1[k] - (c0[k] + w * (c0[k] - cp[k]))).abs();
                    ms[k] = if d > ms[k] { d } else { ms[k] };
                    me[k] = if e > me[k] { e } else { me[k] };
                }
            }
            for i in n / 4 * 4..n {
                let d = (a1[i] - a0[i]).abs();
                let e = (a1[i] - (a0[i] + w * (a0[i] - xp[i]))).abs();
                ms[i % 4] = if d > ms[i % 4] { d } else { ms[i % 4] };
                me[i % 4] = if e > me[i % 4] { e } else { me[i % 4] };
            }
            self.better = max_of_lanes(me) < EXTRAPOLATION_MARGIN * max_of_lanes(ms);
            // `a0` is the last step's end, bitwise (`applicable`)
            std::mem::swap(&mut self.a0, &mut self.a1);
        } else if ACCELERATION_EXTRAPOLATION {
            self.a0.copy_from_slice(a0);
        }
        self.a1.copy_from_slice(a1);
        self.t1 = t + h;
        self.h = h;
    }
}

/// The constant-rate stepper gives up the Woodbury update for an iteration whose capacitance pivot
/// ratio is below this (the value of the constant stepper), and solves with the whole Jacobian,
/// refactorized (counted in [`RunStats::woodbury_fallbacks`]).
const WOODBURY_RCOND: f64 = 1e-12;

/// The gap element is not offered in moving frames; every other setting of [`Settings`] applies
/// (the Newton iterations from [`Settings::newton`]).
fn validate_settings(settings: &Settings) -> Result<()> {
    settings.validate_run()?;
    if settings.coupling == Coupling::Continuous {
        continuous::validate(settings)?;
    }
    if let Coupling::Gap { .. } = settings.coupling {
        return Err(Error::param(
            "method",
            "gap",
            "\"force\" or \"modified\" for a mechanism (the gap element is offered for Model only)",
        ));
    }
    Ok(())
}

/// The joint part of the record spec for the shared recorder: extremes (contact time, RMS,
/// velocities, time of the largest penetration) and impact logs. Its histories stay off: the
/// run keeps its own on its grid.
fn joint_spec(record: &RecordSpec) -> RecordSpec {
    RecordSpec {
        nodes: Vec::new(),
        every: 1,
        histories: false,
        joint_position: false,
        sliders: false,
        slider_reference: None,
        ..record.clone()
    }
}

/// The largest `|v|` of `r`, infinite when some entry is not finite (four running maxima: no
/// dependency chain through every entry; maxima are exact, so the result is that of a plain
/// fold).
#[inline]
fn max_abs_or_inf(r: &[f64]) -> f64 {
    let mut m = [0.0f64; 4];
    let mut finite = true;
    // `if a > m` rather than f64::max (whose NaN rule keeps the loop from vectorizing); a NaN
    // makes `finite` false either way
    for c in r.chunks_exact(4) {
        for k in 0..4 {
            finite &= c[k].is_finite();
            let a = c[k].abs();
            m[k] = if a > m[k] { a } else { m[k] };
        }
    }
    for (i, v) in r.iter().enumerate().skip(r.len() / 4 * 4) {
        finite &= v.is_finite();
        let a = v.abs();
        m[i % 4] = if a > m[i % 4] { a } else { m[i % 4] };
    }
    if finite {
        max_of_lanes(m)
    } else {
        f64::INFINITY
    }
}

/// The running extremes of one clearance joint that the stepper tracks itself (every step from
/// [`RecordSpec::start`] on, the law at the reached state), and whether its histories are kept.
#[derive(Debug, Clone, Copy, PartialEq)]
struct JointTrack {
    recorded: bool,
    max_penetration: f64,
    max_force: f64,
}

struct LinkData {
    nodes: Vec<NodeMap>,
    m: Mat6,
    k1: Mat6,
    d1: Mat6,
    g: Mat6,
    mt: Mat6,
    k2u: Mat6,
    k3u: Mat6,
    eta_e: f64,
    /// `k2u + k3u` and `k2u eta_e` (the geometric terms per unit axial force, N/m and N s/m per N).
    k23: Mat6,
    d2: Mat6,
    ea_l: f64,
    /// The patterns of `m`, `k23` and `d2` (the residual's products, [`mul6`]).
    m_sparsity: Sparsity,
    k23_sparsity: Sparsity,
    d2_sparsity: Sparsity,
    /// `m`, `k23` and `d2` in the layout of [`mul6`]'s split product.
    m_split: SplitMat,
    k23_split: SplitMat,
    d2_split: SplitMat,
    /// Inertia load vectors per element: bx, by, bxx, byx.
    loads: Vec<[Vec6; 4]>,
    /// `loads` by entry for the residual's lanes of four and of eight
    /// ([`element_lanes::loads_by_entry`]; empty for a rigid link).
    loads_t: Vec<f64>,
    loads_t8: Vec<f64>,
    active: LinkTerms,
    /// Point mass per node (kg), summed.
    point_mass: Vec<f64>,
    /// Constant nodal loads per node `[Fu, Fv, M]`.
    nodal_load: Vec<[f64; 3]>,
    /// The nodes with a point mass or a nodal load (the residual's loop over them skips the
    /// others without testing each node at every call).
    loaded_nodes: Vec<usize>,
    /// A rigid link: its first moment `m c` (kg m), the rotation's stiffness per unit of the
    /// frame origin's nominal acceleration along the link, `K_thth = -m c a_x`
    /// ([`crate::model::mechanism::RigidBody::matrices`]); `None` for a beam.
    rigid_moment: Option<f64>,
}

impl LinkData {
    /// The inertia loads laid out for `w` lanes (four or eight; see
    /// [`element_lanes::loads_by_entry`]).
    fn lane_loads(&self, w: usize) -> &[f64] {
        if w == 8 {
            &self.loads_t8
        } else {
            &self.loads_t
        }
    }
}

/// Which entries of a 6 x 6 element matrix can be nonzero, for [`mul6`]: a beam element's mass,
/// stiffness and geometric matrices do not couple the axial unknowns (`u` of both nodes, 0 and
/// 3) with the bending ones (`v`, `theta`: 1, 2, 4, 5); a rigid link's are on node 0's block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sparsity {
    /// Every entry exactly zero.
    Zero,
    /// Axial and bending blocks only (20 of 36 entries).
    Split,
    /// Node 0's 3 x 3 block only.
    Node0,
    /// Any entry.
    Full,
}

impl Sparsity {
    /// The smallest pattern that holds every nonzero entry of `a`.
    fn of(a: &Mat6) -> Sparsity {
        // whether every entry outside `keep` is exactly zero
        let holds =
            |keep: &dyn Fn(usize, usize) -> bool| (0..6).all(|i| (0..6).all(|j| keep(i, j) || a[(i, j)] == 0.0));
        let axial = |i: usize| i == 0 || i == 3;
        if holds(&|_, _| false) {
            Sparsity::Zero
        } else if holds(&|i, j| axial(i) == axial(j)) {
            Sparsity::Split
        } else if holds(&|i, j| i < 3 && j < 3) {
            Sparsity::Node0
        } else {
            Sparsity::Full
        }
    }
}

/// `a v` for a matrix of pattern `s` ([`Sparsity::of`]): the sums of nalgebra's product (row
/// `i`: `a_i0 v_0`, then the sum so far `+ a_ij v_j`, column by column; a floating-point sum of
/// two terms does not depend on their order) without the terms that are exactly zero, so the
/// same result up to the sign of a zero, in 20 (split), 9 (node 0's block) or no
/// multiplications instead of 36.
#[inline(always)]
fn mul6(a: &Mat6, s: Sparsity, split: &SplitMat, v: &Vec6) -> Vec6 {
    match s {
        Sparsity::Full => a * v,
        Sparsity::Zero => Vec6::zeros(),
        Sparsity::Split => split.mul(v),
        Sparsity::Node0 => {
            let mut y = Vec6::zeros();
            for i in 0..3 {
                let mut x = a[(i, 0)] * v[0];
                x += a[(i, 1)] * v[1];
                y[i] = a[(i, 2)] * v[2] + x;
            }
            y
        }
    }
}

/// The two blocks of a [`Sparsity::Split`] matrix stored for [`mul6`]: the axial rows' entries
/// (rows 0 and 3) by column, and the bending block (rows and columns 1, 2, 4, 5) as four
/// columns of four. The product takes the bending rows four at a time (one vector register in
/// the AVX2 build) where reading them out of the 6 x 6 matrix took them one by one; the
/// operations per row are those of the row-by-row product (`a_i1 v_1 + a_i2 v_2 + a_i4 v_4`,
/// then `a_i5 v_5 +` that; the axial rows `a_i3 v_3 + a_i0 v_0`), so the same bits.
#[derive(Debug, Clone, Copy, Default)]
struct SplitMat {
    /// `[a_00, a_30]` and `[a_03, a_33]`.
    ax0: [f64; 2],
    ax3: [f64; 2],
    /// `bend[c][r] = a[(B[r], B[c])]`, `B = [1, 2, 4, 5]`.
    bend: [[f64; 4]; 4],
}

impl SplitMat {
    const BEND: [usize; 4] = [1, 2, 4, 5];

    fn of(a: &Mat6) -> SplitMat {
        SplitMat {
            ax0: [a[(0, 0)], a[(3, 0)]],
            ax3: [a[(0, 3)], a[(3, 3)]],
            bend: Self::BEND.map(|c| Self::BEND.map(|r| a[(r, c)])),
        }
    }

    #[inline(always)]
    fn mul(&self, v: &Vec6) -> Vec6 {
        let mut ya = [0.0; 2];
        for (r, y) in ya.iter_mut().enumerate() {
            *y = self.ax3[r] * v[3] + self.ax0[r] * v[0];
        }
        let b = &self.bend;
        let mut x = [0.0; 4];
        for r in 0..4 {
            x[r] = b[0][r] * v[1];
        }
        for r in 0..4 {
            x[r] += b[1][r] * v[2];
        }
        for r in 0..4 {
            x[r] += b[2][r] * v[4];
        }
        for r in 0..4 {
            // `x + a_i5 v_5`: a sum of two terms, the same bits in either order
            x[r] += b[3][r] * v[5];
        }
        Vec6::new(ya[0], x[0], x[1], ya[1], x[2], x[3])
    }
}

/// A 6 x 6 element matrix with `a` on node 0's block (a rigid link's terms, all on node 0).
fn node0_block(a: &[[f64; 3]; 3]) -> Mat6 {
    let mut m = Mat6::zeros();
    for r in 0..3 {
        for c in 0..3 {
            m[(r, c)] = a[r][c];
        }
    }
    m
}

/// A 6-vector with `a` on node 0's entries.
fn node0_vec(a: &[f64; 3]) -> Vec6 {
    Vec6::new(a[0], a[1], a[2], 0.0, 0.0, 0.0)
}

/// A stretch of a link's nodes as the record reads their displacements
/// ([`NewtonRun::displacement_runs`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum DispRun {
    /// Nodes plain on consecutive unknowns: `len` (3 per node) entries of `y` from `first`.
    Slice { first: usize, len: usize },
    /// A node read through its transform ([`NewtonRun::local_displacement`]).
    Node(usize),
}

/// Rotation-derived per-node transform for the current frame state: T (3x3 block, local from
/// slots), Td, Tdd, and the slot unknown indices.
#[derive(Clone, Copy)]
struct NodeT {
    idx: [usize; 3],
    t: [[f64; 3]; 3],
    td: [[f64; 3]; 3],
    tdd: [[f64; 3]; 3],
    plain: bool,
}

impl NodeT {
    /// The first of the node's unknowns where it is plain (T = I) on three consecutive ones
    /// `i, i + 1, i + 2`: its local state is then a slice of the global vectors.
    fn consecutive(&self) -> Option<usize> {
        let [i, j, k] = self.idx;
        (self.plain && i != NONE && j == i + 1 && k == i + 2).then_some(i)
    }
}

/// A link's element matrices `(C, K)` at zero axial force for frame `f` into `out`:
/// [`NewtonRun::element_ck`]`(li, 0.0)` entry by entry in one pass (`C = D1 + G (2 w)`, `K = K1 +
/// (G al - Mt w^2)`, the same operations as its matrix expressions, without their temporaries).
#[inline(always)]
fn frame_ck(ld: &LinkData, f: &FrameState, out: &mut (Mat6, Mat6)) {
    let (c, k) = out;
    let (two_w, al, w2) = (2.0 * f.rate, f.accel, f.rate * f.rate);
    let (coriolis, coupling) = (ld.active.coriolis, ld.active.coupling);
    let (d1, k1, g, mt) = (ld.d1.as_slice(), ld.k1.as_slice(), ld.g.as_slice(), ld.mt.as_slice());
    for (i, (ci, ki)) in c.as_mut_slice().iter_mut().zip(k.as_mut_slice()).enumerate() {
        *ci = if coriolis { d1[i] + g[i] * two_w } else { d1[i] };
        *ki = if coupling {
            k1[i] + (g[i] * al - mt[i] * w2)
        } else {
            k1[i]
        };
    }
}

/// The links' part of [`NewtonRun::constant_rate_obstacle`], from the mechanism and the terms its
/// links carry ([`dofs::link_terms`], in link order): each link's constant frame rate (rad/s), or
/// why the constant-rate stepper cannot run the model (a rigid link, a frame turning at a
/// varying rate, geometric terms, or a node pinned or on a slider in a link that turns). The
/// plan asks it before building a run ([`crate::plan::Plan::compile`]).
pub(crate) fn links_rate_obstacle(
    mech: &Mechanism,
    terms: impl IntoIterator<Item = LinkTerms>,
) -> std::result::Result<Vec<f64>, String> {
    let mut rate = Vec::with_capacity(mech.links.len());
    for (l, t) in mech.links.iter().zip(terms) {
        if l.rigid.is_some() {
            return Err(format!(
                "link {:?} is rigid (its rigid-body terms run on the Newton stepper)",
                l.name
            ));
        }
        let Some(r) = l.frame.constant_rate() else {
            return Err(format!("the frame of link {:?} rotates at a varying rate", l.name));
        };
        rate.push(r);
        if t.geometric {
            return Err(format!(
                "link {:?} carries geometric terms (K2, K3, D2), which change with its axial force",
                l.name
            ));
        }
        if t.transformed && r != 0.0 {
            return Err(format!(
                "link {:?} rotates and has a node pinned or on a slider, whose transform turns with it",
                l.name
            ));
        }
    }
    Ok(rate)
}

/// Element vector (`u, v, theta` of both nodes) of component `c` (0 displacement, 1 velocity,
/// 2 acceleration) from the local states of its two nodes (see [`NewtonRun::local`]).
#[inline]
fn element_vec(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3], c: usize) -> Vec6 {
    Vec6::new(a[c][0], a[c][1], a[c][2], b[c][0], b[c][1], b[c][2])
}

/// Midspan deflection of a beam link of `elements` elements relative to the chord through its
/// end nodes, m, from its nodes' local displacements `w(node) = [u, v, theta]` (m, m, rad):
/// the element's transverse shape at mid-length less the chord's mean of the end nodes' `v`.
#[inline]
fn midspan(e: &BeamElement, elements: usize, w: impl Fn(usize) -> [f64; 3]) -> f64 {
    let xm = 0.5 * elements as f64;
    let k = (xm.floor() as usize).min(elements - 1);
    let xi = xm - k as f64;
    let (a, b) = (w(k), w(k + 1));
    let q = Vec6::new(a[0], a[1], a[2], b[0], b[1], b[2]);
    e.transverse_at(xi, &q) - 0.5 * (w(0)[1] + w(elements)[1])
}

/// The transforms of a node (see [`NodeT`]) in a link frame `f` whose rotation is `r` (kept with
/// the frame, once per link), with the guides' unit directions `slider_dir`.
fn node_t(map: &NodeMap, f: &FrameState, r: [[f64; 2]; 2], slider_dir: &[[f64; 2]]) -> NodeT {
    let mut nt = NodeT {
        idx: [NONE, NONE, map.rot],
        t: [[0.0; 3]; 3],
        td: [[0.0; 3]; 3],
        tdd: [[0.0; 3]; 3],
        plain: true,
    };
    nt.t[2][2] = 1.0;
    // Columns of T for global unknowns: Rt = R(phi)^T; Td = -w S Rt; Tdd = (-al S - w^2) Rt.
    let glob = |cols: &[[f64; 2]], nt: &mut NodeT| {
        let (w, al) = (f.rate, f.accel);
        for (c, g) in cols.iter().enumerate() {
            // t = R^T g
            let t = [r[0][0] * g[0] + r[1][0] * g[1], r[0][1] * g[0] + r[1][1] * g[1]];
            // S t = (-t1, t0)
            let st = [-t[1], t[0]];
            nt.t[0][c] = t[0];
            nt.t[1][c] = t[1];
            nt.td[0][c] = -w * st[0];
            nt.td[1][c] = -w * st[1];
            nt.tdd[0][c] = -al * st[0] - w * w * t[0];
            nt.tdd[1][c] = -al * st[1] - w * w * t[1];
        }
        nt.plain = false;
    };
    if map.lever != 0.0 {
        // node 1 of a rigid link: v = v0 + L theta in the link frame (L fixed in the frame:
        // no Td, Tdd term)
        nt.t[1][2] = map.lever;
        nt.plain = false;
    }
    match map.trans {
        Trans::Local(ix) => {
            nt.idx[0] = ix[0];
            nt.idx[1] = ix[1];
            nt.t[0][0] = 1.0;
            nt.t[1][1] = 1.0;
        }
        Trans::Global(ix) => {
            nt.idx[0] = ix[0];
            nt.idx[1] = ix[1];
            glob(&[[1.0, 0.0], [0.0, 1.0]], &mut nt);
        }
        Trans::Slider { s, slider } => {
            nt.idx[0] = s;
            glob(&[slider_dir[slider]], &mut nt);
        }
        Trans::Fixed => {}
    }
    // the structure `NewtonRun::local` relies on: the rotation passes through unchanged, and
    // the frame's rate enters the translations only
    debug_assert!(nt.t[2] == [0.0, 0.0, 1.0] && nt.td[2] == [0.0; 3] && nt.tdd[2] == [0.0; 3]);
    debug_assert!((0..2).all(|r| nt.td[r][2] == 0.0 && nt.tdd[r][2] == 0.0));
    nt
}

/// The columns of a joint endpoint's relative displacement over its unknowns, up to three:
/// `(unknown, d q / d y, the velocity's position dependence)` ([`NewtonRun::endpoint_jac`]).
type EndpointJac = [(usize, [f64; 2], [f64; 2]); 3];

/// The rows of `P` for the constant-rate stepper's Woodbury update: per clearance joint, the
/// derivative of the relative displacement `q` (journal minus bearing, global axes turned by
/// `-angle` of the joint's reference frame) with respect to its up to four unknowns. Constant over
/// the run when the joint's unknowns all turn with the reference frame (the plan's rule).
#[derive(Debug, Clone, Default)]
struct JointRows {
    /// Per joint: (unknown, `[d q_x / d y_i, d q_y / d y_i]`), `NONE` for an unused slot.
    cols: Vec<[(usize, [f64; 2]); 6]>,
    /// Per joint: the link whose frame angle the rows are expressed in (`None`: global axes, every
    /// unknown of the joint on a frame that does not rotate).
    axes: Vec<Option<usize>>,
    /// Per joint: the rate (rad/s) of its unknowns' frames; the velocity of `q` has the position
    /// dependence `rate S dq/dy`. 0 for a joint whose sides turn at different rates (`split`).
    rate: Vec<f64>,
    /// Per joint: whether its two sides' unknowns turn at different rates (a slider pin on a
    /// turning rod, the pin between a four-bar's coupler and rocker): the velocity of `q` then
    /// depends on the positions through `vel`, not through a multiple of the rows.
    split: Vec<bool>,
    /// Per joint, per slot of `cols`: `d qd / d y` at fixed velocities, in the same axes (the
    /// frames' rotation; zeros unless `split`).
    vel: Vec<[[f64; 2]; 6]>,
}

/// The velocity rows of [`JointRows`] (`V`, the right factor of the Woodbury update's second
/// term: [`Woodbury::solve_with`]) on the same unknowns as its rows.
struct VelocityRows<'a>(&'a JointRows);

impl LowRankBlocks for VelocityRows<'_> {
    fn blocks(&self) -> usize {
        self.0.cols.len()
    }
    fn scatter(&self, b: usize, r: usize, col: &mut [f64]) {
        for (&(i, _), v) in self.0.cols[b].iter().zip(&self.0.vel[b]) {
            if i != NONE {
                col[i] += v[r];
            }
        }
    }
    #[inline]
    fn project(&self, b: usize, x: &[f64]) -> [f64; 2] {
        let mut p = [0.0; 2];
        for (&(i, _), v) in self.0.cols[b].iter().zip(&self.0.vel[b]) {
            if i != NONE {
                p[0] += v[0] * x[i];
                p[1] += v[1] * x[i];
            }
        }
        p
    }
}

impl LowRankBlocks for JointRows {
    fn blocks(&self) -> usize {
        self.cols.len()
    }
    fn scatter(&self, b: usize, r: usize, col: &mut [f64]) {
        for &(i, g) in &self.cols[b] {
            if i != NONE {
                col[i] += g[r];
            }
        }
    }
    #[inline]
    fn project(&self, b: usize, x: &[f64]) -> [f64; 2] {
        let mut p = [0.0; 2];
        for &(i, g) in &self.cols[b] {
            if i != NONE {
                p[0] += g[0] * x[i];
                p[1] += g[1] * x[i];
            }
        }
        p
    }
}

/// The contact-free factor and the Woodbury update of the contact terms on it (`J = J0 + P^T G
/// P`, one 2 x 2 block of `G` per clearance joint, linalg/woodbury.rs): the constant-rate
/// stepper's solver (the contact-free Jacobian factorized once), and the Newton stepper's with
/// the Woodbury solver (refactorized when the contact-free Jacobian changes, never for a change
/// of the contact terms).
#[derive(Debug, Clone)]
struct RateSolver {
    /// The constant-rate stepper: the step (s) `lu0` is kept for (other steps, halved or event
    /// substeps, take the refactorizing path). `None`: the Newton stepper, which refactorizes
    /// `lu0` whenever the contact-free Jacobian changes (every step with geometric terms).
    fixed_step: Option<f64>,
    lu0: BandLu,
    /// Whether `lu0`, `wb` and `rows` hold a factorized Jacobian.
    ready: bool,
    /// The frame signature `lu0` was assembled with (refactorized if it ever changes).
    signature: Vec<f64>,
    sig_new: Vec<f64>,
    rows: JointRows,
    /// The rows at the current frames, compared with `rows` (the Woodbury columns are rebuilt
    /// when they differ).
    rows_new: JointRows,
    wb: Woodbury,
    /// `G`, per joint, in its reference axes.
    g: Vec<Mat2>,
    /// `H`, per joint, in its reference axes: `beta h^2 C` of a joint whose sides turn at
    /// different rates ([`JointRows::split`]), else zero.
    hv: Vec<Mat2>,
    /// `V Z` of the velocity rows ([`Woodbury::project_z`]) when some joint is split.
    wv: Vec<f64>,
    /// With split joints ([`NewtonRun::split_joints`]), whose rows turn against their axes at
    /// every step: `A0^-1 e_i` for the unknown `i` of each slot of [`JointRows::cols`] (`n` values
    /// per slot, joint by joint, zeros for an unused slot), made with `lu0`; the Woodbury
    /// columns are their combinations ([`Woodbury::rebuild_with`]).
    basis: Vec<f64>,
    /// Whether `basis` was made with the current `lu0`.
    basis_ready: bool,
    /// Whether some block of `H` is non-zero in this iteration.
    any_split: bool,
    /// Whether some block of `G` is non-zero in this iteration.
    any: bool,
    scratch: WoodburyScratch,
    /// The right-hand side kept for a fallback solve.
    rhs: Vec<f64>,
    /// [`NewtonRun::steps_begun`] when `lu0` was factorized (its age in steps).
    made: u64,
}

impl RateSolver {
    /// The Woodbury columns for `lu0` and `rows`: solved anew ([`Woodbury::rebuild`]), or with
    /// `split_joints` ([`NewtonRun::split_joints`]: rows that turn against their axes at every
    /// step) as combinations of `basis`, made first where `lu0` is new.
    fn rebuild_columns(&mut self, split_joints: bool) {
        let RateSolver {
            lu0,
            rows,
            wb,
            basis,
            basis_ready,
            ..
        } = self;
        if !split_joints {
            wb.rebuild(lu0, rows);
            return;
        }
        let n = lu0.n();
        if !*basis_ready {
            // one solve per slot's unknown (the unknowns of a joint are fixed)
            basis.clear();
            basis.resize(rows.cols.len() * 6 * n, 0.0);
            for (slot, col) in rows.cols.iter().flatten().zip(basis.chunks_exact_mut(n)) {
                if slot.0 != NONE {
                    col[slot.0] = 1.0;
                    lu0.solve_in_place(col);
                }
            }
            *basis_ready = true;
        }
        wb.rebuild_with(n, rows, |c, z| {
            let (b, r) = (c / 2, c % 2);
            for (k, &(i, g)) in rows.cols[b].iter().enumerate() {
                if i != NONE {
                    let e = &basis[(6 * b + k) * n..(6 * b + k + 1) * n];
                    for (zi, ei) in z.iter_mut().zip(e) {
                        *zi += g[r] * ei;
                    }
                }
            }
        });
    }
}

/// Contact-free factors of other step sizes that the Newton stepper keeps besides the one in use
/// (adaptive steps and event cuts change the step; [`NewtonRun::rate_prepare`]): a step of a size
/// that comes back within the Jacobian age limit
/// ([`NewtonSettings::jacobian_age`](crate::run::NewtonSettings::jacobian_age), in steps of any
/// size) solves on its factor as a step of the same size does. Over one crank turn of the
/// slider-crank with a crank-pin clearance at `tol = 3e-2`, 835 of 1495 refactorizations of
/// the contact-free Jacobian were for a step size other than the last one's.
pub const RATE_FACTORS_KEPT: usize = 3;

/// The Newton stepper's run: DOF map, element data, Jacobian and state.
pub struct NewtonRun<'a> {
    /// The CPU has AVX2 and FMA: the residual and the step run in their AVX2 builds
    /// ([`Self::residual`], [`Self::step`]); always false (and unread) off x86-64.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    avx2: bool,
    /// The CPU has AVX-512F too: the residual takes a beam link's elements eight at a time
    /// ([`element_lanes`]); always false off x86-64.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    avx512: bool,
    mech: &'a Mechanism,
    settings: &'a Settings,
    links: Vec<LinkData>,
    slider_dof: Vec<usize>,
    n: usize,
    lu: BandLu,
    /// Values the factorized Jacobian was built with (refactorize when they change).
    signature: Vec<f64>,
    sig_new: Vec<f64>,
    frames: Vec<FrameState>,
    /// Per link, `R(angle)` of its frame at [`Self::t_frames`] (one `sin_cos` per link and step,
    /// not per use).
    rots: Vec<[[f64; 2]; 2]>,
    /// Per node of every link (link `li`'s from `node_off[li]`), its transform at the current
    /// frames ([`node_t`]), refreshed by [`Self::update_frames`].
    node_ts: Vec<NodeT>,
    node_off: Vec<usize>,
    /// Per link, its element matrices `(C, K)` at zero axial force for the current frames
    /// ([`Self::element_ck`]), refreshed with the transforms.
    link_ck: Vec<(Mat6, Mat6)>,
    /// Per link, per element on its own unknowns (both nodes plain, else `None`): the band
    /// positions of its 36 entries (column-major, `NONE` for a held slot), fixed for the run.
    elem_pos: Vec<Vec<Option<Box<[usize; 36]>>>>,
    /// Per link, per element whose six unknowns are consecutive (both nodes plain, none held):
    /// the first, else `NONE`; the residual reads and adds its element vectors as slices. In a
    /// link numbered from its last node ([`Self::elem_swapped`]) the slice holds the element's
    /// second node first.
    elem_first: Vec<Vec<usize>>,
    /// Per link: whether [`Self::elem_first`]'s slices hold node `e + 1` before node `e`.
    elem_swapped: Vec<bool>,
    /// Per link, its nodes' displacements as the record reads them, node after node: runs of
    /// nodes plain on consecutive unknowns (a slice of `y` each) and the other nodes one by one.
    disp_runs: Vec<Vec<DispRun>>,
    /// Per slider, its guide's frame at [`Self::t_frames`] and `(cos, sin)` of the guide angle.
    slider_frames: Vec<FrameState>,
    slider_dir: Vec<[f64; 2]>,
    y: Vec<f64>,
    yd: Vec<f64>,
    ydd: Vec<f64>,
    y_pred: Vec<f64>,
    v_pred: Vec<f64>,
    y0: Vec<f64>,
    yd0: Vec<f64>,
    ydd0: Vec<f64>,
    /// The alpha schemes' acceleration-like variable and its start-of-step value
    /// ([`crate::integrator::Newmark`]; unused by plain Newmark).
    aa: Vec<f64>,
    aa0: Vec<f64>,
    /// The first iterate's extrapolation ([`ACCELERATION_EXTRAPOLATION`]).
    extrapolation: Extrapolation,
    a: Vec<f64>,
    r: Vec<f64>,
    /// The element vectors of a group of lanes (`y`, `yd`, `ydd`), kept between residuals so the
    /// residual does not zero them each time (lanes past a group's width keep what an earlier
    /// group left: their forces are not read). Taken out by [`Self::residual_body`] and put back.
    lane_vectors: Option<Box<[element_lanes::Lanes; 3]>>,
    contact: Vec<ContactTerms>,
    /// Tangent of the contact force of each joint at the current iterate, `(-dF/dq, -dF/dqd)`
    /// (implicit contact only: modified coupling with `iterate`).
    contact_tan: Vec<(Mat2, Mat2)>,
    /// The contact force is implicit in the step: evaluated at the current iterate, with its
    /// tangent in the Jacobian (Newton on the contact terms).
    implicit_contact: bool,
    /// [`Self::woodbury_fits`], fixed for the run.
    woodbury_fits: bool,
    /// Whether some clearance joint has its two sides' unknowns on different frames (a link's
    /// and another link's or fixed axes): only such a joint can be [`JointRows::split`].
    split_joints: bool,
    /// Contact status switches of each joint within the current step's iteration (implicit
    /// contact: [`evaluation::iterated_terms`]).
    switches: Vec<u8>,
    /// Per joint, a radius (m) at which [`Self::evaluate_contacts`] evaluates the law from the
    /// step start instead of the joint's own (its state projected radially): the new side of the
    /// circle at an adaptive step's cut, `NaN` otherwise.
    status_hint: Vec<f64>,
    /// Whether the state is an adaptive run's output instant interpolated inside an accepted
    /// step ([`Self::interpolate_output`]; the integrated state waits in the adaptive scratch
    /// until [`Self::restore_integrated`]): the recorded force is then the law's at that state,
    /// not the step end's terms applied to it (which, in the step before a cut, are the closed
    /// ones of the cut's right limit: an open state read the entry's dashpot force).
    output_interpolated: bool,
    /// Per joint, its law where it is the built-in spring-dashpot
    /// ([`ContactLaw::as_spring_damper`]): evaluated in the step, not through the trait object.
    spring_dampers: Vec<Option<SpringDamper>>,
    /// Approach speed of each joint's current contact episode, m/s (`None` while open; only
    /// for laws that need it).
    episode: Vec<Option<f64>>,
    /// Per clearance joint: its sides move apart under the nominal motion, so its relative
    /// position includes the nominal one ([`Mechanism::joint_moves_apart`]).
    nominal_offset: Vec<bool>,
    /// Time of the current frames, s.
    t_frames: f64,
    /// The joint recorder shared with the translating engine, and its per-step inputs.
    rec: Recorder,
    jpen: Vec<f64>,
    jforce: Vec<[f64; 2]>,
    jq: Vec<[f64; 2]>,
    jqd: Vec<[f64; 2]>,
    /// Whether `jq` and `jqd` are each joint's `(q, qd)` at the current state and frames: set by
    /// a fixed step's tracking ([`Self::track_joints`]), cleared by [`Self::update_frames`] and
    /// taken by the next step's start ([`Self::evaluate_contacts`]), which would compute the
    /// same values again.
    tracked_state: bool,
    /// Each joint's `(q, qd)` and law terms at the iterate [`Self::carried_rate_margin`] last
    /// judged, and whether the step stopped there (set at that stop, cleared at each step's
    /// start): the tracking that follows a fixed step ([`Self::track_joints`]) takes them
    /// instead of evaluating the same state again.
    margin_terms: Vec<([f64; 2], [f64; 2], ContactTerms)>,
    margin_state: bool,
    /// Each joint's [`Self::endpoint_jac`] of its journal and its bearing for the current
    /// frames (they depend on the frames alone): made by [`Self::refresh_transforms`], read by
    /// the residual's joint forces and the Woodbury rows of each step.
    joint_jacs: Vec<[EndpointJac; 2]>,
    /// Each joint's `(q, qd)` at the current iterate, as [`Self::evaluate_contacts`] found them,
    /// and whether they still hold (the residual that follows in the iteration takes them
    /// instead of evaluating them again; cleared when the residual has used them).
    jstate: Vec<([f64; 2], [f64; 2])>,
    jstate_fresh: bool,
    /// Scratch for recording: local states of a link's nodes (reused, no allocation per record).
    node_states: Vec<[[f64; 3]; 3]>,
    nonlinear_geometric: bool,
    stats: RunStats,
    /// Per unknown: whether it is a displacement in metres (nodal translations, slider travel),
    /// checked against the divergence limit; rotations are checked for finiteness only.
    translational: Vec<bool>,
    /// Per unknown, the length (m) its error is measured in: 1 for a displacement,
    /// [`adaptive::rotation_lever`] of its element length for a beam node's rotation (its error
    /// as the largest displacement it makes within an element), the link's length for a rigid
    /// link's rotation, for the adaptive steps' error norm.
    err_scale: Vec<f64>,
    /// Per joint: its running extremes and whether its histories are kept.
    track: Vec<JointTrack>,
    /// Histories on the output grid (kept apart from `rec`, which an event step clones): sample
    /// times, per link, per recorded joint (in joint order), and each joint's slot there.
    hist_time: Vec<f64>,
    hist_links: Vec<LinkHistory>,
    /// Slider histories and peak accelerations (outside `rec`: an event step clones `rec`).
    hist_sliders: Vec<SliderHistory>,
    /// Whether the output grid (times, link frames and channels, joint histories) is kept: with
    /// `RecordSpec::histories`, or when link channels or slider histories are asked for. Without
    /// it a run keeps nothing per output point (O(outputs) memory).
    keep_grid: bool,
    /// Whether the slider histories are kept (`RecordSpec::histories` or `RecordSpec::sliders`).
    keep_sliders: bool,
    /// Output points passed so far: the index into `RecordSpec::slider_reference`'s grid.
    slider_point: usize,
    hist_joints: Vec<JointHistory>,
    hist_slot: Vec<Option<usize>>,
    limit: f64,
    /// The contact-free factor and the Woodbury update of the contact on it (the constant-rate
    /// stepper's, and the Newton stepper's with the Woodbury solver and clearance joints).
    rate: Option<Box<RateSolver>>,
    /// The Newton stepper's contact-free factors of other step sizes ([`RATE_FACTORS_KEPT`]).
    rate_kept: Vec<RateSolver>,
    /// Steps begun so far (tries included), the clock of the factors' ages.
    steps_begun: u64,
    /// The step being taken refactorizes the whole Jacobian (a Newton step redone after it did
    /// not converge on the contact-free factor).
    direct: bool,
    /// [`Self::steps_begun`] when the current Jacobian factor (the contact-free one of the
    /// Woodbury solver, else the whole Jacobian) was made: its age is the steps since.
    factor_made: u64,
    /// The step being taken solves with a factor from an earlier step
    /// ([`NewtonSettings::jacobian_age`](crate::run::NewtonSettings::jacobian_age)).
    reusing: bool,
    /// The last step converged within [`JACOBIAN_REUSE_ITERATIONS`] iterations: the next may
    /// reuse its factor.
    reuse_ok: bool,
    /// The grid instant (s) the fixed-step run loop's next step ends at ([`Self::step_body`]).
    step_end: Option<f64>,
    /// The contraction rate of the Newton iterations, carried across steps
    /// ([`RATE_CARRY_DOWN`]): 1 until measured at a step's second iteration.
    iter_rate: f64,
    /// The truncation fraction of the last accepted step's local error, relative to the
    /// displacement scale (0 before the first: [`crate::run::NewtonSettings::truncation_fraction`]).
    truncation_last: f64,
    /// The length of the frame part of the Jacobian's signature ([`Self::frame_signature`]).
    frame_sig_len: usize,
    /// Some clearance joint has friction (evaluated at every iterate, its tangent in the
    /// refactorized Jacobian: see [`JointFrictionState`]).
    friction: bool,
    /// Per joint: the friction at the current iterate (default for a joint without friction).
    fric: Vec<JointFrictionState>,
    /// Per joint: LuGre's bristle state at the last accepted state, m (0 for Coulomb).
    fric_z: Vec<f64>,
    /// Per joint: the friction work balance from [`RecordSpec::start`] on.
    fric_track: Vec<FrictionTrack>,
    /// The current step's iteration has gone on past [`FRICTION_SECANT_AFTER`] iterations:
    /// friction's slip tangent is replaced by its secant for the rest of the step.
    fric_secant: bool,
    /// The continuous-contact model's state (`method="continuous"`, [`continuous`]).
    cont: Option<Box<continuous::Contact>>,
}

/// After this many Newton iterations in one step, Coulomb friction's slip-speed tangent in the
/// Jacobian is replaced by the larger of it and the secant `-F_t / v` for the rest of the step:
/// Newton on a regularized sign function cycles across the kinks of the regularization (in
/// stick, the slip jumps between the steep ramp, slope `mu F_N / v_reg`, and full friction,
/// slope 0), while the secant iteration contracts (the friction being monotone in `v`).
pub const FRICTION_SECANT_AFTER: usize = 6;

/// The friction of one clearance joint at the current iterate ([`NewtonRun::joint_friction`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct JointFrictionState {
    /// The law's force (N, on the journal along `t`), `dF/dv` and end-of-step state.
    eval: FrictionEval,
    /// Slip speed `v = (v_J - v_B) . t + R_J w_J - R_B w_B`, m/s.
    slip: f64,
    /// Tangent `t = S n` (n from the bearing centre to the journal centre).
    t: [f64; 2],
    /// The damping `-dF/dv` (N s/m, floored at 0) that enters the Jacobian.
    kf: f64,
    /// `dF_t/dF_N` (N/N) and the normal `n`: the normal force's part of the Jacobian.
    kn: f64,
    n: [f64; 2],
}

/// The energy friction dissipated in one joint (J) and the last tracked `(t, F_t, v)`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct FrictionTrack {
    work: f64,
    last: Option<(f64, f64, f64)>,
}

/// Scratch of event-aware stepping: the start-of-step state and penetrations.
#[derive(Default)]
struct EventScratch {
    y: Vec<f64>,
    yd: Vec<f64>,
    ydd: Vec<f64>,
    aa: Vec<f64>,
    /// Penetrations at the step's start, end, and the end of the current first substep, m.
    p0: Vec<f64>,
    p1: Vec<f64>,
    pc: Vec<f64>,
    /// Joint tracking before the cut (restored when the cut step falls back to the whole step).
    extremes: Vec<(f64, f64)>,
    rec: Option<Recorder>,
    /// LuGre states and friction work at the step's start.
    fric_z: Vec<f64>,
    fric_track: Vec<FrictionTrack>,
}

impl<'a> NewtonRun<'a> {
    /// Validates and prepares a run. Errors: invalid parameters or model
    /// ([`Mechanism::validate`]), an over-constrained node ([`dofs::number`]).
    pub fn new(mech: &'a Mechanism, settings: &'a Settings) -> Result<Self> {
        Self::prepare(mech, settings, None, None)
    }

    /// [`NewtonRun::new`] with the unknowns numbered already: `dofs` is [`dofs::number`] of
    /// `mech` (as [`crate::plan::Plan::compile`] keeps it).
    pub fn with_dofs(mech: &'a Mechanism, settings: &'a Settings, dofs: DofMap) -> Result<Self> {
        Self::prepare(mech, settings, Some(dofs), None)
    }

    /// [`NewtonRun::with_dofs`] with what a [`crate::plan::Plan`] compiled for these `mech` and
    /// `settings` keeps: the plan numbered the unknowns only once [`Mechanism::validate_apart`]
    /// passed for `settings.t_end`, which also gave `apart` (per clearance joint,
    /// [`Mechanism::joint_moves_apart`]), so the run checks the mechanism's closure no more (it
    /// solves the kinematics at 201 instants per pin and joint: most of a short run's setup).
    pub(crate) fn with_plan_dofs(
        mech: &'a Mechanism,
        settings: &'a Settings,
        dofs: DofMap,
        apart: Vec<bool>,
    ) -> Result<Self> {
        Self::prepare(mech, settings, Some(dofs), Some(apart))
    }

    /// Prepares a run; `validated`: `mech` passed [`Mechanism::validate_apart`] for
    /// `settings.t_end`, with this result.
    fn prepare(
        mech: &'a Mechanism,
        settings: &'a Settings,
        numbered: Option<DofMap>,
        validated: Option<Vec<bool>>,
    ) -> Result<Self> {
        validate_settings(settings)?;
        if let Some(l) = mech.links.iter().find(|l| l.rotary_inertia) {
            return Err(Error::InvalidModel {
                message: format!(
                    "link {:?} has rotary inertia, which only the constant stepper has (every link and \
                     bearing body translating at a fixed angle, only clearance joints, no gravity, no energy \
                     recorded); leave it out to run this model",
                    l.name
                ),
            });
        }
        let link_nodes: Vec<usize> = mech.links.iter().map(|l| l.nodes()).collect();
        settings.record.validate(mech.joints.len(), &link_nodes)?;
        if let Some(r) = &settings.record.slider_reference {
            let names: Vec<&str> = mech.sliders.iter().map(|s| s.name.as_str()).collect();
            r.check_grid(&names, settings.t_end, settings.dt, settings.record.every)?;
        }
        let apart = match validated {
            Some(apart) => apart,
            None => mech.validate_apart(settings.t_end)?,
        };
        let DofMap {
            nodes: node_maps,
            slider_dof,
            n,
            translational,
        } = match numbered {
            Some(d) => d,
            None => dofs::number(mech)?,
        };
        let terms = dofs::link_terms(mech, &node_maps);
        let b = dofs::bandwidth(mech, &node_maps, &slider_dof);
        let mut links = Vec::with_capacity(mech.links.len());
        for (((li, l), nodes), active) in mech.links.iter().enumerate().zip(node_maps).zip(terms) {
            let e = l.element();
            let le = l.element_length();
            let mut point_mass = vec![0.0; l.nodes()];
            for pm in mech.masses.iter().filter(|m| m.link == li) {
                point_mass[pm.node] += pm.mass;
            }
            let mut nodal_load = vec![[0.0; 3]; l.nodes()];
            for f in mech.loads.iter().filter(|f| f.link == li) {
                let x = &mut nodal_load[f.node];
                x[0] += f.force[0];
                x[1] += f.force[1];
                x[2] += f.moment;
            }
            let loaded_nodes: Vec<usize> = (0..l.nodes())
                .filter(|&nd| !(point_mass[nd] == 0.0 && nodal_load[nd] == [0.0; 3]))
                .collect();
            if let Some(body) = l.rigid {
                let rm = body.matrices();
                let zero = Mat6::zeros();
                let m = node0_block(&rm.mass);
                links.push(LinkData {
                    nodes,
                    m_sparsity: Sparsity::of(&m),
                    m_split: SplitMat::of(&m),
                    k23_split: SplitMat::default(),
                    d2_split: SplitMat::default(),
                    m,
                    k1: zero,
                    d1: zero,
                    g: node0_block(&rm.skew),
                    mt: node0_block(&rm.coupling),
                    k2u: zero,
                    k3u: zero,
                    eta_e: 0.0,
                    k23: zero,
                    d2: zero,
                    ea_l: 0.0,
                    k23_sparsity: Sparsity::Zero,
                    d2_sparsity: Sparsity::Zero,
                    loads: if active.load {
                        vec![rm.loads.each_ref().map(node0_vec)]
                    } else {
                        Vec::new()
                    },
                    loads_t: Vec::new(),
                    loads_t8: Vec::new(),
                    active,
                    point_mass,
                    nodal_load,
                    loaded_nodes,
                    rigid_moment: Some(rm.first_moment),
                });
                continue;
            }
            let (m, k2u, k3u) = (e.mass(), e.geometric_stiffness(1.0), e.axial_force_stiffness(1.0));
            let eta_e = e.damping / e.youngs_modulus;
            let (k23, d2) = (k2u + k3u, k2u * eta_e);
            let loads: Vec<[Vec6; 4]> = if active.load {
                (0..l.section.elements)
                    .map(|k| e.inertia_load_vectors(k as f64 * le))
                    .collect()
            } else {
                Vec::new()
            };
            let loads_t = element_lanes::loads_by_entry(&loads, 4);
            let loads_t8 = element_lanes::loads_by_entry(&loads, 8);
            links.push(LinkData {
                nodes,
                m_sparsity: Sparsity::of(&m),
                k23_sparsity: Sparsity::of(&k23),
                d2_sparsity: Sparsity::of(&d2),
                m_split: SplitMat::of(&m),
                k23_split: SplitMat::of(&k23),
                d2_split: SplitMat::of(&d2),
                m,
                k1: e.stiffness(),
                d1: e.damping_matrix(),
                g: e.skew_mass(),
                mt: e.translational_mass(),
                k2u,
                k3u,
                eta_e,
                k23,
                d2,
                ea_l: e.youngs_modulus * e.area / le,
                loads,
                loads_t,
                loads_t8,
                active,
                point_mass,
                nodal_load,
                loaded_nodes,
                rigid_moment: None,
            });
        }
        let nonlinear_geometric = links.iter().any(|l| l.active.geometric);
        let limit = settings
            .divergence_limit
            .unwrap_or(10.0 * mech.links.iter().fold(0.0f64, |s, l| s.max(l.section.length)));
        let mut stats = RunStats {
            stepper: "newton",
            unknowns: n,
            bandwidth: b,
            ..Default::default()
        };
        for (l, ld) in mech.links.iter().zip(&links) {
            let a = ld.active;
            // a rigid link carries its inertia terms only
            let mut t = if ld.rigid_moment.is_some() {
                vec!["rigid: M"]
            } else {
                let mut t = vec!["M", "K1"];
                if l.section.damping > 0.0 {
                    t.push("D1");
                }
                if a.geometric {
                    t.extend(["K2", "K3"]);
                    if l.section.damping > 0.0 {
                        t.push("D2");
                    }
                }
                t
            };
            if a.coriolis {
                t.push("M_COR");
            }
            if a.coupling {
                t.push("M_IC");
            }
            if a.load {
                t.push("M_R a_R");
            }
            stats.terms.push(format!("{}: {}", l.name, t.join(", ")));
        }
        let nj = mech.joints.len();
        let rec = &settings.record;
        let track: Vec<JointTrack> = (0..nj)
            .map(|j| JointTrack {
                recorded: rec.histories && rec.joints.as_ref().is_none_or(|js| js.contains(&j)),
                max_penetration: 0.0,
                max_force: 0.0,
            })
            .collect();
        let mut hist_slot = vec![None; nj];
        let mut hist_joints = Vec::new();
        for (j, t) in track.iter().enumerate() {
            if t.recorded {
                hist_slot[j] = Some(hist_joints.len());
                hist_joints.push(JointHistory {
                    joint: j,
                    ..Default::default()
                });
            }
        }
        let mut run = NewtonRun {
            avx2: crate::linalg::avx2_fma_available(),
            avx512: crate::linalg::avx512_available(),
            mech,
            settings,
            links,
            slider_dof,
            n,
            lu: BandLu::new(n, b),
            signature: Vec::new(),
            sig_new: Vec::new(),
            frames: vec![FrameState::default(); mech.links.len()],
            rots: vec![FrameState::default().rotation(); mech.links.len()],
            node_ts: Vec::new(),
            node_off: Vec::new(),
            link_ck: Vec::new(),
            elem_pos: Vec::new(),
            elem_first: Vec::new(),
            elem_swapped: Vec::new(),
            disp_runs: Vec::new(),
            slider_frames: vec![FrameState::default(); mech.sliders.len()],
            slider_dir: mech.sliders.iter().map(|s| [s.angle.cos(), s.angle.sin()]).collect(),
            y: vec![0.0; n],
            yd: vec![0.0; n],
            ydd: vec![0.0; n],
            y_pred: vec![0.0; n],
            v_pred: vec![0.0; n],
            y0: vec![0.0; n],
            yd0: vec![0.0; n],
            ydd0: vec![0.0; n],
            aa: vec![0.0; n],
            aa0: vec![0.0; n],
            extrapolation: Extrapolation::new(n),
            a: vec![0.0; n],
            r: vec![0.0; n],
            lane_vectors: Some(Box::new([[[0.0; element_lanes::MAX_LANES]; 6]; 3])),
            contact: vec![ContactTerms::default(); mech.joints.len()],
            contact_tan: vec![([[0.0; 2]; 2], [[0.0; 2]; 2]); mech.joints.len()],
            implicit_contact: matches!(
                settings.coupling,
                Coupling::Modified { iterate: true, .. } | Coupling::Continuous
            ) && !mech.joints.is_empty(),
            woodbury_fits: false,
            split_joints: false,
            status_hint: vec![f64::NAN; mech.joints.len()],
            output_interpolated: false,
            spring_dampers: mech.joints.iter().map(|j| j.law.as_spring_damper().copied()).collect(),
            episode: vec![None; mech.joints.len()],
            nominal_offset: apart,
            t_frames: 0.0,
            rec: Recorder::new(
                &joint_spec(&settings.record),
                &mech.joints.iter().map(|j| j.clearance).collect::<Vec<_>>(),
                |_, _| 0,
                0,
            ),
            jpen: vec![0.0; nj],
            jforce: vec![[0.0; 2]; nj],
            jq: vec![[0.0; 2]; nj],
            jqd: vec![[0.0; 2]; nj],
            tracked_state: false,
            margin_terms: vec![([0.0; 2], [0.0; 2], ContactTerms::default()); nj],
            margin_state: false,
            joint_jacs: Vec::new(),
            jstate: vec![([0.0; 2], [0.0; 2]); nj],
            jstate_fresh: false,
            node_states: Vec::with_capacity(mech.links.iter().map(|l| l.nodes()).max().unwrap_or(0)),
            switches: vec![0; mech.joints.len()],
            nonlinear_geometric,
            stats,
            translational,
            err_scale: vec![1.0; n],
            track,
            hist_time: Vec::new(),
            hist_links: vec![LinkHistory::default(); mech.links.len()],
            hist_sliders: Vec::new(),
            keep_grid: {
                let (r, ch) = (&settings.record, settings.record.links);
                r.histories || r.sliders || ch.displacements || ch.axial_force || ch.midspan || ch.energy
            },
            keep_sliders: settings.record.histories || settings.record.sliders,
            slider_point: 0,
            hist_joints,
            hist_slot,
            limit,
            rate: None,
            rate_kept: Vec::new(),
            steps_begun: 0,
            direct: false,
            factor_made: 0,
            reusing: false,
            reuse_ok: false,
            step_end: None,
            iter_rate: 1.0,
            truncation_last: 0.0,
            frame_sig_len: 0,
            friction: mech.joints.iter().any(|j| j.friction.is_some()),
            fric: vec![JointFrictionState::default(); nj],
            fric_z: vec![0.0; nj],
            fric_track: vec![FrictionTrack::default(); nj],
            fric_secant: false,
            cont: None,
        };
        if settings.adaptive.is_some() {
            run.rec.weigh_by_time();
        }
        for (li, ld) in run.links.iter().enumerate() {
            let link = &run.mech.links[li];
            // a beam node's rotation by the largest displacement it makes within an element, a
            // rigid link's by the link's length
            let lever = if link.rigid.is_some() {
                link.element_length()
            } else {
                adaptive::rotation_lever(link.element_length())
            };
            for m in &ld.nodes {
                if m.rot != NONE {
                    run.err_scale[m.rot] = lever;
                }
            }
        }
        run.refresh_transforms();
        run.elem_pos = (0..run.links.len())
            .map(|li| {
                (0..run.mech.links[li].section.elements)
                    .map(|e| {
                        let (p, q) = (run.nt(li, e), run.nt(li, e + 1));
                        if !(p.plain && q.plain) {
                            return None;
                        }
                        let idx = [p.idx[0], p.idx[1], p.idx[2], q.idx[0], q.idx[1], q.idx[2]];
                        let mut pos = [NONE; 36];
                        for c in 0..6 {
                            for r in 0..6 {
                                if idx[r] != NONE && idx[c] != NONE {
                                    pos[r + 6 * c] = run.lu.position(idx[r], idx[c]);
                                }
                            }
                        }
                        Some(Box::new(pos))
                    })
                    .collect()
            })
            .collect();
        // a link numbered from its last node (dofs::number) has its elements' nodes swapped
        run.elem_swapped = (0..run.links.len())
            .map(|li| {
                (0..run.mech.links[li].section.elements).any(|e| {
                    matches!((run.nt(li, e).consecutive(), run.nt(li, e + 1).consecutive()),
                        (Some(a), Some(b)) if a == b + 3)
                })
            })
            .collect();
        run.elem_first = (0..run.links.len())
            .map(|li| {
                (0..run.mech.links[li].section.elements)
                    .map(
                        |e| match (run.nt(li, e).consecutive(), run.nt(li, e + 1).consecutive()) {
                            (Some(a), Some(b)) if b == a + 3 && !run.elem_swapped[li] => a,
                            (Some(a), Some(b)) if a == b + 3 && run.elem_swapped[li] => b,
                            _ => NONE,
                        },
                    )
                    .collect()
            })
            .collect();
        run.disp_runs = (0..run.links.len()).map(|li| run.displacement_runs(li)).collect();
        if run.settings.coupling == Coupling::Continuous && nj > 0 {
            run.cont = Some(Box::new(continuous::Contact::new(nj, n)));
            for j in &mech.joints {
                continuous::check_joint(j)?;
            }
        }
        if run.settings.solver == SolverMode::Woodbury
            && !run.friction
            && !run.mech.joints.is_empty()
            && !matches!(run.settings.coupling, Coupling::Force | Coupling::Continuous)
        {
            run.rate = Some(run.contact_free_solver(None));
            run.rate_kept = (0..RATE_FACTORS_KEPT).map(|_| *run.contact_free_solver(None)).collect();
        }
        run.woodbury_fits = run.woodbury_fits();
        run.split_joints =
            run.mech.joints.iter().any(
                |j| match (run.endpoint_turn(&j.journal), run.endpoint_turn(&j.bearing)) {
                    (Some((_, a)), Some((_, b))) => a != b,
                    _ => false,
                },
            );
        Ok(run)
    }

    /// The frame the unknowns of endpoint `e` turn with: `Some((rate, Some(link)))` for a node
    /// with local unknowns (the link frame's current rate, rad/s), `Some((0.0, None))` for global
    /// or slider unknowns (fixed axes), `None` when it has no unknown.
    fn endpoint_turn(&self, e: &Endpoint) -> Option<(f64, Option<usize>)> {
        match e {
            Endpoint::Node { link, node } => match self.links[*link].nodes[*node].trans {
                Trans::Local(ix) if ix.iter().any(|&i| i != NONE) => Some((self.frames[*link].rate, Some(*link))),
                // node 1 of a rigid link held at node 0: its rotation turns it with the link
                Trans::Fixed
                    if self.links[*link].nodes[*node].lever != 0.0 && self.links[*link].nodes[*node].rot != NONE =>
                {
                    Some((self.frames[*link].rate, Some(*link)))
                }
                Trans::Global(_) | Trans::Slider { .. } => Some((0.0, None)),
                _ => None,
            },
            Endpoint::Body { .. } => None,
            Endpoint::Slider(s) => (self.slider_dof[*s] != NONE).then_some((0.0, None)),
        }
    }

    /// Whether the contact terms can go on the contact-free factor by Woodbury: with the force
    /// method there is nothing to put; else no side of a clearance joint is node 1 of a rigid
    /// link whose node 0 has fixed axes (part of its unknowns turns with the link, part not).
    /// Each side's unknowns then turn at one rate: where both sides turn at the same rate the
    /// velocity's position dependence is `rate S P` and the contact block is `P^T G P`; where
    /// they turn at different rates ([`JointRows::split`]) it is `P^T (G P + H V)`
    /// ([`Woodbury::solve_with`]).
    fn woodbury_fits(&self) -> bool {
        let mixed = |e: &Endpoint| match e {
            Endpoint::Node { link, node } => {
                let m = self.links[*link].nodes[*node];
                m.lever != 0.0 && m.rot != NONE && matches!(m.trans, Trans::Global(_) | Trans::Slider { .. })
            }
            _ => false,
        };
        matches!(self.settings.coupling, Coupling::Force)
            || !self.mech.joints.iter().any(|j| mixed(&j.journal) || mixed(&j.bearing))
    }

    /// Why the constant-rate stepper cannot run this model with these settings (`None`: it can).
    /// Its Jacobian without the contact terms must be the same at every step: every link frame at
    /// rest or turning at a constant rate ([`crate::kinematics::FrameKinematics::constant_rate`]),
    /// no geometric terms (their axial forces move), no node pinned or on a slider in a link that
    /// rotates (its transform turns with the link), and, with contact terms in the Jacobian
    /// (`method="modified"`), the unknowns of both sides of each clearance joint turning at one
    /// rate (so that the contact block is `P^T G P` with a constant `P` in the joint's axes), and
    /// the Woodbury solver (`solver="refactor"` asks for refactorization).
    pub fn constant_rate_obstacle(&self) -> Option<String> {
        let rate = match links_rate_obstacle(self.mech, self.links.iter().map(|ld| ld.active)) {
            Ok(rate) => rate,
            Err(why) => return Some(why),
        };
        if matches!(self.settings.coupling, Coupling::Force) || self.mech.joints.is_empty() {
            return None;
        }
        if self.settings.coupling == Coupling::Continuous {
            return Some("the continuous-contact model (method=\"continuous\") runs on the Newton stepper".into());
        }
        if self.settings.solver == SolverMode::Refactor {
            return Some("the run asks for solver=\"refactor\"".into());
        }
        if let Some(j) = self.mech.joints.iter().find(|j| j.friction.is_some()) {
            return Some(format!(
                "clearance joint {:?} has friction, whose tangent couples the rotations and is unsymmetric",
                j.name
            ));
        }
        let turn = |e: &Endpoint| self.endpoint_turn(e).map(|(_, l)| l.map_or(0.0, |l| rate[l]));
        for j in &self.mech.joints {
            if let (Some(a), Some(b)) = (turn(&j.journal), turn(&j.bearing)) {
                if a != b {
                    return Some(format!(
                        "the two sides of clearance joint {:?} turn at different rates ({a} and {b} rad/s)",
                        j.name
                    ));
                }
            }
        }
        None
    }

    /// A contact-free solver for `n` unknowns and the joints of this run; `fixed_step` as
    /// [`RateSolver::fixed_step`].
    fn contact_free_solver(&self, fixed_step: Option<f64>) -> Box<RateSolver> {
        let nj = if matches!(self.settings.coupling, Coupling::Force) {
            0
        } else {
            self.mech.joints.len()
        };
        let rows = JointRows {
            cols: vec![[(NONE, [0.0; 2]); 6]; nj],
            axes: vec![None; nj],
            rate: vec![0.0; nj],
            split: vec![false; nj],
            vel: vec![[[0.0; 2]; 6]; nj],
        };
        Box::new(RateSolver {
            fixed_step,
            lu0: {
                let mut lu = BandLu::new(self.n, self.lu.bandwidth());
                lu.set_avx2(self.avx2);
                lu
            },
            ready: false,
            signature: Vec::new(),
            sig_new: Vec::new(),
            rows_new: rows.clone(),
            rows,
            wb: Woodbury::default(),
            g: vec![[[0.0; 2]; 2]; nj],
            hv: vec![[[0.0; 2]; 2]; nj],
            wv: Vec::new(),
            basis: Vec::new(),
            basis_ready: false,
            any_split: false,
            any: false,
            scratch: WoodburyScratch::for_rank(2 * nj),
            rhs: vec![0.0; self.n],
            made: 0,
        })
    }

    /// Makes this run the constant-rate stepper: the contact-free Jacobian at the step
    /// [`Settings::dt`] factorized once, the contact terms by Woodbury on it (steps of another
    /// length, halved or cut at an event, take the Newton path). Fails with
    /// [`Error::InvalidParameter`] naming `stepper` when [`Self::constant_rate_obstacle`] finds
    /// the model unfit (the message says why).
    pub fn use_constant_rate(&mut self) -> Result<()> {
        if let Some(why) = self.constant_rate_obstacle() {
            return Err(Error::param(
                "stepper",
                "\"constant-rate\"",
                format!("\"newton\" or None for this model ({why})"),
            ));
        }
        self.stats.stepper = "constant-rate";
        self.rate = Some(self.contact_free_solver(Some(self.settings.dt)));
        Ok(())
    }

    /// The rows of `P` in each joint's reference axes at the current frames (see
    /// [`JointRows`]), into `rows` (sized for the joints; nothing allocated). A node with local
    /// unknowns on the reference link gets the exact unit columns, so the rows of a joint that
    /// turns with its link are bitwise the same at every step. With `SPLIT` (the run has
    /// [`Self::split_joints`]), also which joints are split and their velocity rows.
    fn fill_joint_rows<const SPLIT: bool>(&self, rows: &mut JointRows) {
        for j in 0..rows.cols.len() {
            let jt = &self.mech.joints[j];
            let turns = (self.endpoint_turn(&jt.journal), self.endpoint_turn(&jt.bearing));
            let (rate, axes) = match turns {
                (Some((r, Some(l))), _) if r != 0.0 => (r, Some(l)),
                (_, Some((r, Some(l)))) if r != 0.0 => (r, Some(l)),
                _ => (0.0, None),
            };
            let split = SPLIT && matches!(turns, (Some((a, _)), Some((b, _))) if a != b);
            let rt = axes.map(|l| self.rots[l]);
            let mut cols = [(NONE, [0.0; 2]); 6];
            let mut vel = [[0.0; 2]; 6];
            for (side, (slot, e, sgn)) in [(0, &jt.journal, 1.0), (3, &jt.bearing, -1.0)].into_iter().enumerate() {
                let on_axes = match e {
                    Endpoint::Node { link, node } => {
                        Some(*link) == axes && matches!(self.links[*link].nodes[*node].trans, Trans::Local(_))
                    }
                    _ => false,
                };
                for (k, &(i, g, v)) in self.joint_jacs[j][side].iter().enumerate() {
                    if split {
                        // the frame rotation's velocity term, in the same axes
                        let v = rt.map_or(v, |r| {
                            [r[0][0] * v[0] + r[1][0] * v[1], r[0][1] * v[0] + r[1][1] * v[1]]
                        });
                        vel[slot + k] = [sgn * v[0], sgn * v[1]];
                    }
                    let g = if on_axes && k < 2 {
                        // R^T R e_k = e_k exactly
                        if k == 0 {
                            [1.0, 0.0]
                        } else {
                            [0.0, 1.0]
                        }
                    } else if let Some(r) = rt {
                        // R^T g
                        [r[0][0] * g[0] + r[1][0] * g[1], r[0][1] * g[0] + r[1][1] * g[1]]
                    } else {
                        g
                    };
                    cols[slot + k] = (i, [sgn * g[0], sgn * g[1]]);
                }
            }
            rows.cols[j] = cols;
            rows.axes[j] = axes;
            if SPLIT {
                rows.rate[j] = if split { 0.0 } else { rate };
                rows.split[j] = split;
                rows.vel[j] = vel;
            } else {
                rows.rate[j] = rate;
            }
        }
    }

    /// Before the first iteration of a step of length `h` (s) solved on the contact-free factor:
    /// factorizes the contact-free Jacobian when it changed (the frames' signature, or the axial
    /// forces of geometric terms, which are taken at the step's start as in the Newton path) and
    /// rebuilds the Woodbury columns when the factor or the rows of `P` changed. For the
    /// constant-rate stepper that is once per run. Fails as [`Self::factorize`].
    fn rate_prepare(&mut self, h: f64, force: bool) -> Result<()> {
        let mut rs = self.rate.take().expect("contact-free solver");
        if rs.fixed_step.is_none() && rs.ready && rs.signature.first() != Some(&h) && !self.rate_kept.is_empty() {
            // another step size: its kept factor if there is one, else the oldest kept slot
            // (refactorized below) while the factor in use is kept
            let k = self
                .rate_kept
                .iter()
                .position(|c| c.ready && c.signature.first() == Some(&h))
                .unwrap_or_else(|| {
                    (0..self.rate_kept.len())
                        .min_by_key(|&k| (self.rate_kept[k].ready, self.rate_kept[k].made))
                        .unwrap_or(0)
                });
            std::mem::swap(&mut *rs, &mut self.rate_kept[k]);
            if rs.ready {
                self.factor_made = rs.made;
            }
        }
        let mut sig = std::mem::take(&mut rs.sig_new);
        // with geometric terms the axial forces move the Jacobian at every step: the signature
        // is made only to be kept with a new factor (below)
        let moved = self.nonlinear_geometric || {
            self.frame_signature(h, &mut sig);
            sig != rs.signature
        };
        let newton = rs.fixed_step.is_none();
        let same_step = rs.signature.first() == Some(&h);
        let reuse = rs.ready && !force && moved && newton && self.may_reuse(same_step);
        self.reusing = reuse;
        let refactor = !rs.ready || force || (moved && !reuse);
        if refactor {
            self.factor_made = self.steps_begun;
            rs.made = self.steps_begun;
        }
        let mut res = Ok(());
        if refactor {
            if self.nonlinear_geometric {
                self.frame_signature(h, &mut sig);
            }
            std::mem::swap(&mut rs.signature, &mut sig);
            let (bh2, gh) = self.settings.newmark.coefficients(h);
            self.assemble(bh2, gh, &mut rs.lu0, true, false);
            self.stats.factorizations += 1;
            rs.ready = false;
            res = rs
                .lu0
                .factorize("effective matrix of the mechanism")
                .map_err(|e| self.name_pivot(e));
        }
        if res.is_ok() {
            if self.split_joints {
                self.fill_joint_rows::<true>(&mut rs.rows_new);
            } else {
                self.fill_joint_rows::<false>(&mut rs.rows_new);
            }
            if refactor {
                rs.basis_ready = false;
            }
            let rebuild = refactor || rs.rows_new.cols != rs.rows.cols;
            // the new rows replace the old by a swap, not a copy: `fill_joint_rows` wrote every
            // entry of `rows_new` (without split joints all but `split` and `vel`, which then
            // keep the values of the clone both started from); the old rows are overwritten at
            // the next step
            std::mem::swap(&mut rs.rows, &mut rs.rows_new);
            if rebuild {
                rs.rebuild_columns(self.split_joints);
            }
            if self.split_joints && rs.rows.split.contains(&true) {
                // the velocity rows move with the rates: V Z at every step
                let RateSolver { rows, wb, wv, .. } = &mut *rs;
                wb.project_z(&VelocityRows(rows), wv);
            }
            rs.ready = true;
        }
        rs.sig_new = sig;
        self.rate = Some(rs);
        res
    }

    /// The blocks of `G` for the current contact terms (the step's `bh2 = beta h^2`,
    /// `gh = gamma h`): the contact part of the Jacobian of [`Self::assemble`] is
    /// `P^T (bh2 k + gh c + bh2 rate c S) P`, turned into each joint's reference axes.
    #[inline(always)]
    fn rate_blocks(&mut self, bh2: f64, gh: f64) {
        let Some(rs) = self.rate.as_deref_mut() else {
            return;
        };
        rs.any = false;
        rs.any_split = false;
        if matches!(self.settings.coupling, Coupling::Force) {
            return;
        }
        // R^T A R for the joint's reference axes (the identity without)
        let turn = |a: Mat2, axes: Option<usize>| {
            let Some(l) = axes else {
                return a;
            };
            let r = self.rots[l];
            let mut ar = [[0.0; 2]; 2];
            for p in 0..2 {
                for q in 0..2 {
                    ar[p][q] = a[p][0] * r[0][q] + a[p][1] * r[1][q];
                }
            }
            let mut out = [[0.0; 2]; 2];
            for p in 0..2 {
                for q in 0..2 {
                    out[p][q] = r[0][p] * ar[0][q] + r[1][p] * ar[1][q];
                }
            }
            out
        };
        for j in 0..self.mech.joints.len() {
            let (k, c) = if self.implicit_contact {
                self.contact_tan[j]
            } else if self.contact[j].active() {
                (self.contact[j].k, self.contact[j].c)
            } else {
                ([[0.0; 2]; 2], [[0.0; 2]; 2])
            };
            if k == [[0.0; 2]; 2] && c == [[0.0; 2]; 2] {
                rs.g[j] = [[0.0; 2]; 2];
                rs.hv[j] = [[0.0; 2]; 2];
                continue;
            }
            rs.any = true;
            let axes = rs.rows.axes[j];
            if self.split_joints && rs.rows.split[j] {
                // G = bh2 k + gh c on the rows, H = bh2 c on the velocity rows
                let mut g = [[0.0; 2]; 2];
                let mut hv = [[0.0; 2]; 2];
                for p in 0..2 {
                    for q in 0..2 {
                        g[p][q] = bh2 * k[p][q] + gh * c[p][q];
                        hv[p][q] = bh2 * c[p][q];
                    }
                }
                rs.g[j] = turn(g, axes);
                rs.hv[j] = turn(hv, axes);
                rs.any_split = true;
                continue;
            }
            let w = rs.rows.rate[j] * bh2;
            // c S, S = [[0, -1], [1, 0]]
            let mut g = [[0.0; 2]; 2];
            for p in 0..2 {
                let cs = [c[p][1], -c[p][0]];
                for q in 0..2 {
                    g[p][q] = bh2 * k[p][q] + gh * c[p][q] + w * cs[q];
                }
            }
            rs.g[j] = turn(g, axes);
            rs.hv[j] = [[0.0; 2]; 2];
        }
    }

    /// Solves the constant-rate step's Newton system `J dx = r` in place: with the contact-free
    /// factor alone while every contact is open, by Woodbury otherwise; a capacitance below
    /// [`WOODBURY_RCOND`] falls back to the whole Jacobian, refactorized by the Newton path.
    fn rate_solve(&mut self, h: f64, dx: &mut [f64]) -> Result<()> {
        let mut rs = self.rate.take().expect("contact-free solver");
        if !rs.any {
            rs.lu0.solve_in_place(dx);
            self.rate = Some(rs);
            return Ok(());
        }
        rs.rhs.copy_from_slice(dx);
        let RateSolver {
            lu0,
            rows,
            wb,
            g,
            hv,
            wv,
            any_split,
            scratch,
            ..
        } = &mut *rs;
        let rcond = if *any_split {
            wb.solve_with(lu0, rows, &VelocityRows(rows), g, hv, wv, dx, scratch)
        } else {
            wb.solve(lu0, rows, g, dx, scratch)
        };
        let fallback = rcond.is_nan() || rcond < WOODBURY_RCOND;
        if fallback {
            dx.copy_from_slice(&rs.rhs);
        }
        self.rate = Some(rs);
        if fallback {
            self.stats.woodbury_fallbacks += 1;
            if self.jacobian_changed(h, false) {
                self.factorize(h)?;
            }
            self.lu.solve_in_place(dx);
        }
        Ok(())
    }

    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.n
    }

    /// What each unknown is: `(link, node, component)` with component `u`, `v`, `theta` (link
    /// frame), `x`, `y` (global, shared by pinned nodes) or `s` (along a slider's guide; link and
    /// node of the first node on it, or `usize::MAX` for a slider reached only by a joint).
    pub fn dof_map(&self) -> Vec<(usize, usize, &'static str)> {
        let mut out = vec![(NONE, NONE, "s"); self.n];
        for (li, ld) in self.links.iter().enumerate().rev() {
            for (nd, m) in ld.nodes.iter().enumerate().rev() {
                if m.rot != NONE {
                    out[m.rot] = (li, nd, "theta");
                }
                match m.trans {
                    Trans::Local(ix) => {
                        for (k, c) in [(0, "u"), (1, "v")] {
                            if ix[k] != NONE {
                                out[ix[k]] = (li, nd, c);
                            }
                        }
                    }
                    Trans::Global(ix) => {
                        out[ix[0]] = (li, nd, "x");
                        out[ix[1]] = (li, nd, "y");
                    }
                    Trans::Slider { s, .. } => out[s] = (li, nd, "s"),
                    Trans::Fixed => {}
                }
            }
        }
        out
    }

    /// Linearization at time `t` and state `(y, yd)` (accelerations zero): dense row-major
    /// `M`, `C`, `K` (`n x n`, with the axial forces of `y` in K2, K3, D2 and the contact terms
    /// of that state) and the residual `r(y, yd, 0)`, so that near the state
    /// `M ydd + C dyd + K dy = -r`. Used for natural frequencies of a rotating or preloaded link
    /// and static equilibria (Newton on `K dy = -r`).
    pub fn linearize(&mut self, t: f64, y: &[f64], yd: &[f64]) -> Result<[Vec<f64>; 4]> {
        self.linearize_with(t, y, yd, true)
    }

    /// [`Self::linearize`] with the clearance joints' contact terms left out when `contacts` is
    /// false (every joint open: the natural frequencies of a mechanism with clearance).
    pub fn linearize_with(&mut self, t: f64, y: &[f64], yd: &[f64], contacts: bool) -> Result<[Vec<f64>; 4]> {
        if y.len() != self.n || yd.len() != self.n {
            return Err(Error::param(
                "y",
                format!("{} values", y.len()),
                format!("{} values (one per unknown)", self.n),
            ));
        }
        self.update_frames(t);
        self.y.copy_from_slice(y);
        self.yd.copy_from_slice(yd);
        self.ydd.fill(0.0);
        self.evaluate_contacts(true, true);
        if !contacts {
            self.contact.fill(ContactTerms::default());
            self.contact_tan.fill(([[0.0; 2]; 2], [[0.0; 2]; 2]));
        }
        let n = self.n;
        let mut lu = BandLu::new(n, self.lu.bandwidth());
        let dense = |bh2: f64, gh: f64, lu: &mut BandLu| -> Vec<f64> {
            self.assemble(bh2, gh, lu, false, true);
            let mut d = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    d[i * n + j] = lu.get(i, j);
                }
            }
            d
        };
        let m = dense(0.0, 0.0, &mut lu);
        let mc = dense(0.0, 1.0, &mut lu);
        let mk = dense(1.0, 0.0, &mut lu);
        let c: Vec<f64> = mc.iter().zip(&m).map(|(a, b)| a - b).collect();
        let k: Vec<f64> = mk.iter().zip(&m).map(|(a, b)| a - b).collect();
        self.residual(0.0, t);
        Ok([m, c, k, self.r.clone()])
    }

    #[inline(always)]
    fn update_frames(&mut self, t: f64) {
        self.tracked_state = false;
        self.t_frames = t;
        for ((f, r), l) in self.frames.iter_mut().zip(&mut self.rots).zip(&self.mech.links) {
            (*f, *r) = l.frame.frame_rotation(t);
        }
        self.refresh_transforms();
    }

    /// Recomputes the per-node transforms from the current frames and their rotations (`rots`,
    /// set with the frames by [`Self::update_frames`]).
    #[inline(always)]
    fn refresh_transforms(&mut self) {
        if self.node_off.len() != self.links.len() {
            // first call: every node; later calls recompute only the nodes whose transform
            // depends on the frames (a node on its own unknowns has T = I throughout)
            self.node_off.clear();
            self.node_ts.clear();
            for (li, ld) in self.links.iter().enumerate() {
                self.node_off.push(self.node_ts.len());
                for map in &ld.nodes {
                    self.node_ts
                        .push(node_t(map, &self.frames[li], self.rots[li], &self.slider_dir));
                }
            }
        }
        for (li, ld) in self.links.iter().enumerate() {
            let off = self.node_off[li];
            for (k, map) in ld.nodes.iter().enumerate() {
                if !self.node_ts[off + k].plain {
                    self.node_ts[off + k] = node_t(map, &self.frames[li], self.rots[li], &self.slider_dir);
                }
            }
        }
        let mut jacs = std::mem::take(&mut self.joint_jacs);
        jacs.clear();
        jacs.extend(
            self.mech
                .joints
                .iter()
                .map(|jt| [self.endpoint_jac(&jt.journal), self.endpoint_jac(&jt.bearing)]),
        );
        self.joint_jacs = jacs;
        self.link_ck.resize(self.links.len(), (Mat6::zeros(), Mat6::zeros()));
        for ((ck, ld), f) in self.link_ck.iter_mut().zip(&self.links).zip(&self.frames) {
            frame_ck(ld, f, ck);
        }
        for (f, sl) in self.slider_frames.iter_mut().zip(&self.mech.sliders) {
            *f = sl.path.frame(self.t_frames);
        }
    }

    /// Node transforms of link `li` for the current frames.
    #[inline]
    fn nt(&self, li: usize, node: usize) -> &NodeT {
        &self.node_ts[self.node_off[li] + node]
    }

    /// Link `li`'s nodes in order as [`DispRun`]s: consecutive nodes plain on consecutive
    /// unknowns (node `nd + 1`'s first unknown three past node `nd`'s) make one slice.
    fn displacement_runs(&self, li: usize) -> Vec<DispRun> {
        let mut runs: Vec<DispRun> = Vec::new();
        for nd in 0..self.mech.links[li].nodes() {
            match self.nt(li, nd).consecutive() {
                Some(i) => match runs.last_mut() {
                    Some(DispRun::Slice { first, len }) if *first + *len == i => *len += 3,
                    _ => runs.push(DispRun::Slice { first: i, len: 3 }),
                },
                None => runs.push(DispRun::Node(nd)),
            }
        }
        runs
    }

    /// Local displacement, velocity and acceleration (u, v, th) of a node from global unknowns.
    #[inline(always)]
    fn local(nt: &NodeT, y: &[f64], yd: &[f64], ydd: &[f64]) -> [[f64; 3]; 3] {
        let [i, j, k] = nt.idx;
        if nt.plain && i != NONE && j != NONE && k != NONE {
            // T the identity on the node's three unknowns
            return [[y[i], y[j], y[k]], [yd[i], yd[j], yd[k]], [ydd[i], ydd[j], ydd[k]]];
        }
        let g = |v: &[f64], i: usize| if i == NONE { 0.0 } else { v[i] };
        let (q, qd, qdd) = (
            [g(y, nt.idx[0]), g(y, nt.idx[1]), g(y, nt.idx[2])],
            [g(yd, nt.idx[0]), g(yd, nt.idx[1]), g(yd, nt.idx[2])],
            [g(ydd, nt.idx[0]), g(ydd, nt.idx[1]), g(ydd, nt.idx[2])],
        );
        if nt.plain {
            // T the identity on the node's own unknowns, Td = Tdd = 0
            return [q, qd, qdd];
        }
        // `T`'s structure ([`node_t`]): row 2 is `[0, 0, 1]`, and `Td`, `Tdd` have neither row 2
        // nor column 2, so only the translations' 2 x 2 blocks and `T`'s column 2 (a rigid link's
        // lever) enter. The terms left out are exact zeros (finite unknowns) added to sums that
        // start at +0: the same values as the whole 3 x 3 products.
        let mut w = [[0.0; 3]; 3];
        for r in 0..2 {
            for c in 0..2 {
                w[0][r] += nt.t[r][c] * q[c];
                w[1][r] += nt.t[r][c] * qd[c] + nt.td[r][c] * q[c];
                w[2][r] += nt.t[r][c] * qdd[c] + 2.0 * nt.td[r][c] * qd[c] + nt.tdd[r][c] * q[c];
            }
            let l = nt.t[r][2];
            w[0][r] += l * q[2];
            w[1][r] += l * qd[2];
            w[2][r] += l * qdd[2];
        }
        w[0][2] += q[2];
        w[1][2] += qd[2];
        w[2][2] += qdd[2];
        w
    }

    /// Local displacement (u, v, th) of a node from global unknowns: [`Self::local`]'s first
    /// row alone (the same operations).
    #[inline]
    fn local_displacement(nt: &NodeT, y: &[f64]) -> [f64; 3] {
        let g = |i: usize| if i == NONE { 0.0 } else { y[i] };
        let q = [g(nt.idx[0]), g(nt.idx[1]), g(nt.idx[2])];
        if nt.plain {
            return q;
        }
        // as in `local`: `T`'s row 2 is `[0, 0, 1]`
        let mut w = [0.0; 3];
        for r in 0..2 {
            for c in 0..3 {
                w[r] += nt.t[r][c] * q[c];
            }
        }
        w[2] += q[2];
        w
    }

    /// Adds `T^T f` (f: local generalized force of a node) into `r`.
    #[inline(always)]
    fn project(nt: &NodeT, f: [f64; 3], r: &mut [f64]) {
        if nt.plain {
            // T the identity on the node's own unknowns
            for c in 0..3 {
                let i = nt.idx[c];
                if i != NONE {
                    r[i] += f[c];
                }
            }
            return;
        }
        for c in 0..3 {
            let i = nt.idx[c];
            if i != NONE {
                r[i] += nt.t[0][c] * f[0] + nt.t[1][c] * f[1] + nt.t[2][c] * f[2];
            }
        }
    }

    /// Element matrices (C, K) of element `e` of link `li` at axial force `fax`.
    #[inline(always)]
    fn element_ck(&self, li: usize, fax: f64) -> (Mat6, Mat6) {
        let ld = &self.links[li];
        let f = &self.frames[li];
        let mut c = ld.d1;
        let mut k = ld.k1;
        if ld.active.geometric && fax != 0.0 {
            k += ld.k2u * fax + ld.k3u * fax;
            if ld.eta_e > 0.0 {
                c += ld.k2u * (fax * ld.eta_e);
            }
        }
        if ld.active.coriolis {
            c += ld.g * (2.0 * f.rate);
        }
        if ld.active.coupling {
            k += ld.g * f.accel - ld.mt * (f.rate * f.rate);
        }
        (c, k)
    }

    /// Nominal acceleration `a_R` of the point at `x` in link-frame components, gravity removed.
    fn a_ref(&self, li: usize, x: f64) -> [f64; 2] {
        let f = &self.frames[li];
        let r = self.rots[li];
        let g = self.mech.gravity;
        let a = [f.origin_acc[0] - g[0], f.origin_acc[1] - g[1]];
        let a0 = [r[0][0] * a[0] + r[1][0] * a[1], r[0][1] * a[0] + r[1][1] * a[1]];
        [a0[0] - f.rate * f.rate * x, a0[1] + f.accel * x]
    }

    /// Residual at the state (y, yd, ydd); contact forces by the coupling (`explicit` = force
    /// method terms frozen from the step start).
    fn residual(&mut self, h: f64, t: f64) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            unsafe { self.residual_avx2(h, t) };
            return;
        }
        self.residual_body(h, t);
    }

    /// [`Self::residual`] compiled with AVX2 enabled: a beam link's elements four at a time, one
    /// per lane ([`element_lanes`]), the rest in vector registers twice as wide as the
    /// baseline's. The same operations in the same order (Rust does not contract a multiply and
    /// an add into an FMA), so bitwise the baseline's result
    /// (`the_avx2_residual_equals_the_baseline_one_bitwise`). The ideal slider-crank's residual
    /// 3788 -> 2936 instructions a call with the lanes (`examples/profile_newton ideal 0.1`).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn residual_avx2(&mut self, h: f64, t: f64) {
        self.residual_body(h, t);
    }

    /// The forces of link `li`'s beam elements added into `r` (the residual's element part):
    /// four at a time in AVX2 lanes, element by element otherwise; `SWAPPED` for a link
    /// numbered from its last node ([`Self::elem_swapped`]), whose element slices hold node
    /// `e + 1`'s unknowns before node `e`'s.
    #[inline(always)]
    fn link_element_forces<const SWAPPED: bool>(&self, li: usize, r: &mut [f64], qs: &mut [element_lanes::Lanes; 3]) {
        let ld = &self.links[li];
        let mut prev = self.nt(li, 0);
        // the local state of `prev` where the last element computed it
        let mut wprev = None;
        // the nominal acceleration of the frame origin and the frame's rates: the same for
        // every element of the link (one rotation per link, not per element)
        let fr = self.frames[li];
        let lf = element_lanes::LinkForces {
            ld,
            ck: &self.link_ck[li],
            fs: if ld.active.load { self.a_ref(li, 0.0) } else { [0.0; 2] },
            rate: fr.rate,
            accel: fr.accel,
        };
        let first = &self.elem_first[li];
        let elements = self.mech.links[li].section.elements;
        // a beam link's elements four at a time, one per lane (AVX2), or eight (AVX-512)
        let lanes = cfg!(target_arch = "x86_64") && self.avx2 && ld.rigid_moment.is_none();
        let wide = lanes && self.avx512;
        let w = if wide { 8 } else { 4 };
        let mut e = 0;
        while e < elements {
            let width = if lanes { w.min(elements - e) } else { 1 };
            // each element's vectors and its nodes (lanes past `width` keep what an earlier
            // group left: their forces are not read)
            let mut ends = [(prev, prev); element_lanes::MAX_LANES];
            // a register's elements on consecutive unknowns, node after node: their vectors in
            // one go (their nodes are not read: each adds its force to its slice)
            let s0 = first[e];
            let run = !SWAPPED && width == w && s0 != NONE && (1..w).all(|l| first[e + l] == s0 + 3 * l);
            #[cfg(target_arch = "x86_64")]
            if run {
                let vs = [&self.y[..], &self.yd, &self.ydd];
                if wide {
                    // SAFETY: `wide` is set only where the CPU has AVX-512F, AVX2 and FMA
                    unsafe { element_lanes::avx512::gather_run(vs, s0, qs) };
                } else {
                    // SAFETY: `lanes` is set only where the CPU has AVX2 and FMA
                    unsafe { element_lanes::avx2::gather_run(vs, s0, qs) };
                }
                prev = self.nt(li, e + w);
                wprev = None;
            }
            for l in 0..if run { 0 } else { width } {
                let next = self.nt(li, e + l + 1);
                ends[l] = (prev, next);
                // an element on six consecutive unknowns reads its vectors as slices (the
                // same values as through its nodes' local states, T = I)
                let s0 = first[e + l];
                if s0 != NONE {
                    wprev = None;
                    for (qc, v) in qs.iter_mut().zip([&self.y, &self.yd, &self.ydd]) {
                        let v = &v[s0..s0 + 6];
                        if SWAPPED {
                            // node e + 1's unknowns first
                            for j in 0..3 {
                                qc[j][l] = v[j + 3];
                                qc[j + 3][l] = v[j];
                            }
                        } else {
                            for j in 0..6 {
                                qc[j][l] = v[j];
                            }
                        }
                    }
                } else {
                    let w0 = wprev.unwrap_or_else(|| Self::local(prev, &self.y, &self.yd, &self.ydd));
                    let wn = Self::local(next, &self.y, &self.yd, &self.ydd);
                    wprev = Some(wn);
                    for (c, qc) in qs.iter_mut().enumerate() {
                        let v = element_vec(&w0, &wn, c);
                        for j in 0..6 {
                            qc[j][l] = v[j];
                        }
                    }
                }
                prev = next;
            }
            let f: element_lanes::Lanes = if lanes {
                #[cfg(target_arch = "x86_64")]
                {
                    if wide {
                        // SAFETY: `avx512` is set only where the CPU has AVX-512F, AVX2 and FMA
                        // (`linalg::avx512_available`)
                        unsafe { element_lanes::avx512::forces(&lf, e, &qs[0], &qs[1], &qs[2]) }
                    } else {
                        // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                        // (`linalg::avx2_fma_available`)
                        unsafe { element_lanes::avx2::forces(&lf, e, &qs[0], &qs[1], &qs[2]) }
                    }
                }
                #[cfg(not(target_arch = "x86_64"))]
                unreachable!("lanes are an AVX2 path")
            } else {
                let v = |c: usize| Vec6::from_fn(|j, _| qs[c][j][0]);
                let (q, qd, qdd) = (v(0), v(1), v(2));
                let mut f = element_lanes::element_force(&lf, e, &q, &qd, &qdd);
                if let Some(mc) = ld.rigid_moment {
                    f[2] -= mc * self.a_ref(li, 0.0)[0] * q[2];
                }
                std::array::from_fn(|j| std::array::from_fn(|l| if l == 0 { f[j] } else { 0.0 }))
            };
            // the leading elements on consecutive unknowns (node after node): each node's
            // entries loaded and stored once, the forces of the element before it and then of
            // the one after it added in turn (the element-by-element order, entry by entry), so
            // that no load of an entry waits on the overlapping store of the element before
            let mut plain = 0;
            let s0 = first[e];
            if !SWAPPED && s0 != NONE {
                plain = 1;
                while plain < width && first[e + plain] == s0 + 3 * plain {
                    plain += 1;
                }
                let rr = &mut r[s0..s0 + 3 * plain + 3];
                for i in 0..3 {
                    rr[i] += f[i][0];
                }
                for k in 1..plain {
                    for i in 0..3 {
                        rr[3 * k + i] = rr[3 * k + i] + f[3 + i][k - 1] + f[i][k];
                    }
                }
                for i in 0..3 {
                    rr[3 * plain + i] += f[3 + i][plain - 1];
                }
            }
            // the rest added element by element, in order
            for (l, &(p, nx)) in ends.iter().enumerate().take(width).skip(plain) {
                let s0 = first[e + l];
                if s0 != NONE {
                    if SWAPPED {
                        for (j, ri) in r[s0..s0 + 6].iter_mut().enumerate() {
                            *ri += f[(j + 3) % 6][l];
                        }
                    } else {
                        for (j, ri) in r[s0..s0 + 6].iter_mut().enumerate() {
                            *ri += f[j][l];
                        }
                    }
                } else {
                    Self::project(p, [f[0][l], f[1][l], f[2][l]], r);
                    Self::project(nx, [f[3][l], f[4][l], f[5][l]], r);
                }
            }
            e += width;
        }
    }

    #[inline(always)]
    fn residual_body(&mut self, _h: f64, t: f64) {
        let mut r = std::mem::take(&mut self.r);
        r.fill(0.0);
        let mut qs = self
            .lane_vectors
            .take()
            .expect("lane vectors put back by the last residual");
        for li in 0..self.links.len() {
            // the beam elements' forces; a link numbered from its last node (dofs::number)
            // reads its elements' slices with the nodes swapped
            if self.elem_swapped[li] {
                self.link_element_forces::<true>(li, &mut r, &mut qs);
            } else {
                self.link_element_forces::<false>(li, &mut r, &mut qs);
            }
            let ld = &self.links[li];
            let le = self.mech.links[li].element_length();
            // Point masses and nodal loads.
            for &nd in &ld.loaded_nodes {
                let (m, fl) = (ld.point_mass[nd], ld.nodal_load[nd]);
                let nt = self.nt(li, nd);
                let w = Self::local(nt, &self.y, &self.yd, &self.ydd);
                let fr = &self.frames[li];
                let ar = self.a_ref(li, nd as f64 * le);
                let (om, al) = (fr.rate, fr.accel);
                // m [wdd + 2 om S wd + (al S - om^2) w + a_R]
                let fx = m * (w[2][0] - 2.0 * om * w[1][1] - al * w[0][1] - om * om * w[0][0] + ar[0]);
                let fy = m * (w[2][1] + 2.0 * om * w[1][0] + al * w[0][0] - om * om * w[0][1] + ar[1]);
                Self::project(nt, [fx - fl[0], fy - fl[1], -fl[2]], &mut r);
            }
        }
        // Sliders: m (sdd + e . a_nominal) along the guide.
        for (s, sl) in self.mech.sliders.iter().enumerate() {
            let i = self.slider_dof[s];
            if i == NONE || sl.mass == 0.0 {
                continue;
            }
            // the guide's frame of the current frames (the residual of a step is at its end)
            let fs = if t == self.t_frames {
                self.slider_frames[s]
            } else {
                sl.path.frame(t)
            };
            let e = self.slider_dir[s];
            let g = self.mech.gravity;
            r[i] += sl.mass * (self.ydd[i] + e[0] * (fs.origin_acc[0] - g[0]) + e[1] * (fs.origin_acc[1] - g[1]));
        }
        // Clearance joints: the force on the journal is external (moved to the left: minus).
        let fresh = std::mem::take(&mut self.jstate_fresh);
        for j in 0..self.mech.joints.len() {
            let (q, qd) = if fresh {
                self.jstate[j]
            } else {
                self.joint_state(j, &self.y, &self.yd)
            };
            let f = self.contact[j].force(q, qd);
            self.apply_joint_force(j, [-f[0], -f[1]], &mut r);
        }
        if self.friction {
            self.apply_friction(_h, &mut r);
        }
        self.lane_vectors = Some(qs);
        self.r = r;
    }

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
    fn joint_friction(&self, j: usize, h: f64) -> Option<JointFrictionState> {
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
    fn evaluate_friction(&mut self, h: f64) {
        for j in 0..self.mech.joints.len() {
            if let Some(s) = self.joint_friction(j, h) {
                self.fric[j] = s;
            }
        }
    }

    /// Adds the friction of every joint at the current iterate to the residual `r` (moved to
    /// the left: minus): the force `F_t t` on the journal and `-F_t t` on the bearing, the
    /// moment `F_t R_J` on the journal's rotation and `-F_t R_B` on the bearing's.
    fn apply_friction(&mut self, h: f64, r: &mut [f64]) {
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
    fn assemble_friction(&self, bh2: f64, gh: f64, lu: &mut BandLu) {
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
    fn joint_state(&self, j: usize, y: &[f64], yd: &[f64]) -> ([f64; 2], [f64; 2]) {
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
    fn endpoint_jac(&self, e: &Endpoint) -> EndpointJac {
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
    fn apply_joint_force(&self, j: usize, f: [f64; 2], r: &mut [f64]) {
        for (jac, sgn) in self.joint_jacs[j].iter().zip([1.0, -1.0]) {
            for &(i, col, _) in jac {
                if i != NONE {
                    r[i] += sgn * (col[0] * f[0] + col[1] * f[1]);
                }
            }
        }
    }

    /// Builds the signature of the Jacobian and returns true when it differs from the factorized
    /// one (or, with `geometric`, when a link carries geometric terms: their axial forces move
    /// with every step).
    fn jacobian_changed(&mut self, h: f64, geometric: bool) -> bool {
        let mut s = std::mem::take(&mut self.sig_new);
        self.frame_signature(h, &mut s);
        self.frame_sig_len = s.len();
        if self.implicit_contact {
            for (k, c) in &self.contact_tan {
                s.extend([k[0][0], k[0][1], k[1][0], k[1][1], c[0][0], c[0][1], c[1][0], c[1][1]]);
            }
        } else if !matches!(self.settings.coupling, Coupling::Force) {
            for c in &self.contact {
                s.extend([
                    c.k[0][0], c.k[0][1], c.k[1][0], c.k[1][1], c.c[0][0], c.c[0][1], c.c[1][0], c.c[1][1],
                ]);
            }
        }
        if self.friction {
            s.extend(self.fric.iter().flat_map(|f| [f.kf, f.kn]));
        }
        let fl = self.frame_sig_len;
        let changed = if self.signature.len() != s.len() {
            true
        } else if s[fl..] != self.signature[fl..] {
            // the contact or friction terms moved: the whole Jacobian again
            true
        } else {
            let frame_moved = (geometric && self.nonlinear_geometric) || s[..fl] != self.signature[..fl];
            if frame_moved && geometric && self.may_reuse(s[0] == self.signature[0]) {
                // the first iteration of a step on the factor of an earlier one
                self.reusing = true;
                false
            } else {
                // later iterations on a reused factor look at the contact part only
                frame_moved && !self.reusing
            }
        };
        self.sig_new = s;
        changed
    }

    /// Whether the step being started may solve with the factor of an earlier step
    /// ([`NewtonSettings::jacobian_age`](crate::run::NewtonSettings::jacobian_age)): the same
    /// step size (`same_step`), younger than the age limit, the last step converged within
    /// [`JACOBIAN_REUSE_ITERATIONS`] iterations, and not a step redone on the whole Jacobian.
    fn may_reuse(&self, same_step: bool) -> bool {
        same_step
            && !self.direct
            && self.reuse_ok
            && self.steps_begun - self.factor_made < u64::from(self.settings.newton.jacobian_age)
    }

    /// The part of the Jacobian's signature that does not depend on the contact (the step `h`,
    /// s, and the frame rates, accelerations and angles the element terms use), into `s`
    /// (cleared first).
    fn frame_signature(&self, h: f64, s: &mut Vec<f64>) {
        s.clear();
        s.push(h);
        for (li, (ld, f)) in self.links.iter().zip(&self.frames).enumerate() {
            if ld.active.coriolis || ld.active.coupling || ld.active.transformed {
                s.push(f.rate);
                s.push(f.accel);
            }
            if ld.active.transformed {
                s.push(f.angle);
            }
            if ld.rigid_moment.is_some() {
                s.push(self.a_ref(li, 0.0)[0]);
            }
        }
    }

    /// A singular pivot of the band LU with the unknown named (link, node and direction).
    fn name_pivot(&self, e: Error) -> Error {
        match e {
            Error::Singular { what, index, .. } => Error::Singular {
                dof: self.describe(index),
                what,
                index,
            },
            e => e,
        }
    }

    /// Assembles and factorizes the Jacobian `d r / d a` at the current iterate.
    fn factorize(&mut self, h: f64) -> Result<()> {
        std::mem::swap(&mut self.signature, &mut self.sig_new);
        self.factor_made = self.steps_begun;
        self.reusing = false;
        let (bh2, gh) = self.settings.newmark.coefficients(h);
        let mut lu = std::mem::replace(&mut self.lu, BandLu::new(0, 0));
        self.assemble(bh2, gh, &mut lu, true, true);
        let what = if h == 0.0 {
            "mass matrix of the mechanism (with the transforms)"
        } else {
            "effective matrix of the mechanism"
        };
        let res = lu.factorize(what);
        self.lu = lu;
        self.stats.factorizations += 1;
        res.map_err(|e| self.name_pivot(e))
    }

    /// The constant and axial-force parts of the Jacobian of an element of link `li` on its own
    /// unknowns (`T = I`): `base = M + gh C0 + bh2 K0` with the frame's rate and acceleration
    /// (`C0 = D1 + 2 w G`, `K0 = K1 + a G - w^2 MT`, each term as the link carries it) and `geo =
    /// bh2 (K2 + K3) + gh eta K2`, so that the element's is `base + fax geo` at axial force `fax`
    /// (N) plus the tangent of the axial force.
    #[inline(always)]
    fn link_jacobian_terms(&self, li: usize, bh2: f64, gh: f64) -> (Mat6, Mat6) {
        let ld = &self.links[li];
        let f = &self.frames[li];
        let mut base = ld.m + ld.d1 * gh + ld.k1 * bh2;
        let mut g_coef = 0.0;
        if ld.active.coriolis {
            g_coef += 2.0 * f.rate * gh;
        }
        if ld.active.coupling {
            g_coef += f.accel * bh2;
            base -= ld.mt * (f.rate * f.rate * bh2);
        }
        if g_coef != 0.0 {
            base += ld.g * g_coef;
        }
        let geo = if ld.active.geometric {
            ld.k23 * bh2 + ld.k2u * (ld.eta_e * gh)
        } else {
            Mat6::zeros()
        };
        (base, geo)
    }

    /// Assembles `A + gh B + bh2 K` into `lu`, where the Jacobian of the residual with respect
    /// to the accelerations is that with `gh = gamma dt`, `bh2 = beta dt^2`.
    ///
    /// With `tangent` (the step Jacobian), `K` is the tangent: it includes the dependence of the
    /// axial force in K2, K3, D2 on the axial displacements, `(K23 Q + D2 Qd) dF/dQ`, and, with
    /// implicit contact, the tangent of the contact force instead of its secant `kappa K_B`.
    /// Without (the linearization), `K` holds the secant terms at the state's axial forces.
    /// Without `contacts`, the clearance joints' terms are left out (the constant-rate stepper's
    /// contact-free Jacobian).
    fn assemble(&self, bh2: f64, gh: f64, lu: &mut BandLu, tangent: bool, contacts: bool) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            return unsafe { self.assemble_avx2(bh2, gh, lu, tangent, contacts) };
        }
        self.assemble_body(bh2, gh, lu, tangent, contacts)
    }

    /// [`Self::assemble`] compiled with AVX2 enabled: bitwise the baseline's.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn assemble_avx2(&self, bh2: f64, gh: f64, lu: &mut BandLu, tangent: bool, contacts: bool) {
        self.assemble_body(bh2, gh, lu, tangent, contacts)
    }

    #[inline(always)]
    fn assemble_body(&self, bh2: f64, gh: f64, lu: &mut BandLu, tangent: bool, contacts: bool) {
        lu.clear();
        for li in 0..self.links.len() {
            let ld = &self.links[li];
            // The element Jacobian of a link is an affine function of a few scalars: with the
            // link's terms combined once here, an element on its own unknowns (T = I) takes
            // `base + fax geo` and the axial-force tangent's two columns, no 6 x 6 product.
            let (base, geo) = self.link_jacobian_terms(li, bh2, gh);
            let rigid_kk = ld.rigid_moment.map(|mc| -mc * self.a_ref(li, 0.0)[0] * bh2);
            let mut prev = self.nt(li, 0);
            // the nodes' local states (the axial forces' inputs), each node's once
            let local_state = |nt: &NodeT| {
                if ld.active.geometric {
                    Self::local(nt, &self.y, &self.yd, &self.ydd)
                } else {
                    [[0.0; 3]; 3]
                }
            };
            let mut wprev = local_state(prev);
            for e in 0..self.mech.links[li].section.elements {
                let next = self.nt(li, e + 1);
                let wnext = local_state(next);
                let (w0, w1) = (wprev, wnext);
                wprev = wnext;
                if let Some(pos) = &self.elem_pos[li][e] {
                    let mut je = base;
                    if ld.active.geometric {
                        let fax = ld.ea_l * (w1[0][0] - w0[0][0]);
                        je += geo * fax;
                        if tangent {
                            // d/dQ of F(Q) (K23 Q + D2 Qd), F = EA/l (u2 - u1): bh2 g dF/dQ^T,
                            // non-zero in the columns of u1 and u2 only
                            let (q, qd) = (element_vec(&w0, &w1, 0), element_vec(&w0, &w1, 1));
                            let g = ld.k23 * q + ld.k2u * (qd * ld.eta_e);
                            let s = ld.ea_l * bh2;
                            for r in 0..6 {
                                je[(r, 0)] -= s * g[r];
                                je[(r, 3)] += s * g[r];
                            }
                        }
                    }
                    if let Some(v) = rigid_kk {
                        je[(2, 2)] += v;
                    }
                    for (&p, &v) in pos.iter().zip(je.as_slice()) {
                        if p != NONE && v != 0.0 {
                            lu.add_at(p, v);
                        }
                    }
                    prev = next;
                    continue;
                }
                let mut kg = None;
                let fax = if ld.active.geometric {
                    if tangent {
                        // d/dQ of F(Q) (K23 Q + D2 Qd), F = EA/l (u2 - u1): a rank-1 term.
                        let (q, qd) = (element_vec(&w0, &w1, 0), element_vec(&w0, &w1, 1));
                        let g = ld.k23 * q + ld.k2u * (qd * ld.eta_e);
                        let mut dfax = Vec6::zeros();
                        dfax[0] = -ld.ea_l;
                        dfax[3] = ld.ea_l;
                        kg = Some(g * dfax.transpose());
                    }
                    ld.ea_l * (w1[0][0] - w0[0][0])
                } else {
                    0.0
                };
                let (c, mut k) = self.element_ck(li, fax);
                if let Some(kg) = kg {
                    k += kg;
                }
                if let Some(mc) = ld.rigid_moment {
                    k[(2, 2)] -= mc * self.a_ref(li, 0.0)[0];
                }
                let idx = [
                    prev.idx[0],
                    prev.idx[1],
                    prev.idx[2],
                    next.idx[0],
                    next.idx[1],
                    next.idx[2],
                ];
                // T^T (M Ta + C Tv + bh2 K T) with T = diag(T0, T1) block by block: a node on
                // its own unknowns has T = I, Ta = I, Tv = gh I
                let mut x = Mat6::zeros();
                for (o, nt) in [(0, &prev), (3, &next)] {
                    if nt.plain {
                        for r in 0..6 {
                            for cc in o..o + 3 {
                                x[(r, cc)] = ld.m[(r, cc)] + gh * c[(r, cc)] + bh2 * k[(r, cc)];
                            }
                        }
                        continue;
                    }
                    for cc in 0..3 {
                        let ta = [0, 1, 2].map(|q| nt.t[q][cc] + 2.0 * gh * nt.td[q][cc] + bh2 * nt.tdd[q][cc]);
                        let tv = [0, 1, 2].map(|q| gh * nt.t[q][cc] + bh2 * nt.td[q][cc]);
                        let tk = [0, 1, 2].map(|q| bh2 * nt.t[q][cc]);
                        for r in 0..6 {
                            let mut v = 0.0;
                            for q in 0..3 {
                                v += ld.m[(r, o + q)] * ta[q] + c[(r, o + q)] * tv[q] + k[(r, o + q)] * tk[q];
                            }
                            x[(r, o + cc)] = v;
                        }
                    }
                }
                let mut je = x;
                for (o, nt) in [(0, &prev), (3, &next)] {
                    if nt.plain {
                        continue;
                    }
                    for cc in 0..6 {
                        for r in 0..3 {
                            je[(o + r, cc)] = (0..3).map(|q| nt.t[q][r] * x[(o + q, cc)]).sum();
                        }
                    }
                }
                for a in 0..6 {
                    if idx[a] == NONE {
                        continue;
                    }
                    for b in 0..6 {
                        if idx[b] != NONE && je[(a, b)] != 0.0 {
                            lu.add(idx[a], idx[b], je[(a, b)]);
                        }
                    }
                }
                prev = next;
            }
            // Point masses: m [ (T + 2 gh Td + bh2 Tdd) + 2 om S (gh T + bh2 Td) + (al S - om^2) bh2 T ].
            let f = self.frames[li];
            for nd in 0..ld.nodes.len() {
                let m = ld.point_mass[nd];
                if m == 0.0 {
                    continue;
                }
                let nt = self.nt(li, nd);
                let (om, al) = (f.rate, f.accel);
                let mut blk = [[0.0; 3]; 2];
                for c in 0..3 {
                    let ta = [0, 1].map(|r| nt.t[r][c] + 2.0 * gh * nt.td[r][c] + bh2 * nt.tdd[r][c]);
                    let tv = [0, 1].map(|r| gh * nt.t[r][c] + bh2 * nt.td[r][c]);
                    let tk = [0, 1].map(|r| bh2 * nt.t[r][c]);
                    blk[0][c] = m * (ta[0] - 2.0 * om * tv[1] - al * tk[1] - om * om * tk[0]);
                    blk[1][c] = m * (ta[1] + 2.0 * om * tv[0] + al * tk[0] - om * om * tk[1]);
                }
                for a in 0..3 {
                    if nt.idx[a] == NONE {
                        continue;
                    }
                    for c in 0..3 {
                        if nt.idx[c] == NONE {
                            continue;
                        }
                        let v = nt.t[0][a] * blk[0][c] + nt.t[1][a] * blk[1][c];
                        if v != 0.0 {
                            lu.add(nt.idx[a], nt.idx[c], v);
                        }
                    }
                }
            }
        }
        for (s, sl) in self.mech.sliders.iter().enumerate() {
            let i = self.slider_dof[s];
            if i != NONE && sl.mass > 0.0 {
                lu.add(i, i, sl.mass);
            }
        }
        if contacts && !matches!(self.settings.coupling, Coupling::Force) {
            for j in 0..self.mech.joints.len() {
                let mut ct = self.contact[j];
                if tangent && self.implicit_contact {
                    (ct.k, ct.c) = self.contact_tan[j];
                    if ct.k == [[0.0; 2]; 2] && ct.c == [[0.0; 2]; 2] {
                        continue;
                    }
                } else if !ct.active() {
                    continue;
                }
                let jt = &self.mech.joints[j];
                let a = self.endpoint_jac(&jt.journal);
                let b = self
                    .endpoint_jac(&jt.bearing)
                    .map(|(i, c, v)| (i, [-c[0], -c[1]], [-v[0], -v[1]]));
                let all = [a[0], a[1], a[2], b[0], b[1], b[2]];
                for (i, gi, _) in all {
                    if i == NONE {
                        continue;
                    }
                    for (jj, gj, vj) in all {
                        if jj == NONE {
                            continue;
                        }
                        // d(-f)/da with f = -k q - c qd: k bh2 G + c (gh G + bh2 Gv)
                        let mut v = 0.0;
                        for p in 0..2 {
                            for qq in 0..2 {
                                v += gi[p] * (ct.k[p][qq] * bh2 * gj[qq] + ct.c[p][qq] * (gh * gj[qq] + bh2 * vj[qq]));
                            }
                        }
                        if v != 0.0 {
                            lu.add(i, jj, v);
                        }
                    }
                }
            }
        }
        if contacts && tangent && self.friction {
            self.assemble_friction(bh2, gh, lu);
        }
    }

    /// The law of joint `j` at `(q, qd)`, within its contact episode when the law needs the
    /// approach speed ([`crate::contact::approach_speed`]).
    #[inline(always)]
    fn law_terms(&self, j: usize, q: [f64; 2], qd: [f64; 2]) -> ContactTerms {
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
    fn evaluate_contacts(&mut self, from_start: bool, tangent: bool) {
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
    fn carried_rate_margin(&mut self) -> Option<f64> {
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

    /// One Newmark step from `t` of size `h`. On failure the state is restored.
    fn step(&mut self, t: f64, h: f64, step: u64, depth: u32) -> Result<()> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            return unsafe { self.step_avx2(t, h, step, depth) };
        }
        self.step_body(t, h, step, depth)
    }

    /// [`Self::step`] compiled with AVX2 enabled, as [`Self::residual_avx2`]: bitwise the
    /// baseline's.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn step_avx2(&mut self, t: f64, h: f64, step: u64, depth: u32) -> Result<()> {
        self.step_body(t, h, step, depth)
    }

    /// Runs the step, the residual and the band solves in their AVX2 builds where `on` (and the
    /// CPU has AVX2 and FMA), else in the baseline's (the tests compare the two).
    #[cfg(test)]
    fn set_avx2(&mut self, on: bool) {
        self.avx2 = on && crate::linalg::avx2_fma_available();
        self.avx512 = on && crate::linalg::avx512_available();
        self.lu.set_avx2(on);
        for rs in self
            .rate
            .iter_mut()
            .map(|rs| &mut **rs)
            .chain(self.rate_kept.iter_mut())
        {
            rs.lu0.set_avx2(on);
        }
    }

    /// A fixed step `k` from `t0` of `h` (s) to the grid instant `t1` (no events, no continuous
    /// contact) and the tracking of its joints and sliders (`keep`: an output step). The step
    /// ends where it stopped: at the state its carried-rate stop evaluated, if it stopped so
    /// ([`Self::margin_state`]); the next step starts from this state and these frames.
    fn fixed_step(&mut self, t0: f64, h: f64, k: u64, t1: f64, keep: bool) -> Result<()> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            return unsafe { self.fixed_step_avx2(t0, h, k, t1, keep) };
        }
        self.fixed_step_body(t0, h, k, t1, keep)
    }

    /// [`Self::fixed_step`] compiled with AVX2 enabled, the tracking inlined (the step itself is
    /// [`Self::step_avx2`]): bitwise the baseline's.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fixed_step_avx2(&mut self, t0: f64, h: f64, k: u64, t1: f64, keep: bool) -> Result<()> {
        self.fixed_step_body(t0, h, k, t1, keep)
    }

    #[inline(always)]
    fn fixed_step_body(&mut self, t0: f64, h: f64, k: u64, t1: f64, keep: bool) -> Result<()> {
        self.step(t0, h, k, 0)?;
        self.stats.steps = k;
        let margin = std::mem::take(&mut self.margin_state);
        self.track_joints(t1, Some((k, h)), margin);
        self.tracked_state = true;
        self.track_sliders(t1, keep);
        self.track_links(t1);
        Ok(())
    }

    #[inline(always)]
    fn step_body(&mut self, t: f64, h: f64, step: u64, depth: u32) -> Result<()> {
        self.jstate_fresh = false;
        self.margin_state = false;
        let nm = self.settings.newmark;
        let (bh2, gh) = nm.coefficients(h);
        let n = self.n;
        // Contact terms from the start-of-step state (lagged kappa, force method); the implicit
        // contact's tangent is that of the first iterate (below)
        self.evaluate_contacts(true, false);
        // State at the start (kept for a retry): swapped out of the state, which the predictor
        // then overwrites (the generalized-alpha predictor reads it in place: copied)
        if nm.is_alpha() {
            self.y0.copy_from_slice(&self.y);
            self.yd0.copy_from_slice(&self.yd);
            self.ydd0.copy_from_slice(&self.ydd);
        } else {
            std::mem::swap(&mut self.y0, &mut self.y);
            std::mem::swap(&mut self.yd0, &mut self.yd);
            std::mem::swap(&mut self.ydd0, &mut self.ydd);
        }
        // the step's end: the grid instant the run loop asked for where this step ends there up
        // to rounding (its frames are then the record's and the slider tracking's), else t + h
        let t_end = match self.step_end.take() {
            Some(te) if (te - (t + h)).abs() <= same_instant(h) => te,
            _ => t + h,
        };
        self.update_frames(t_end);
        if nm.is_alpha() {
            self.alpha_predictors(h);
        } else {
            // the first iterate: `a_n`, or its extrapolation along the last step where that
            // step ended here and nothing has changed the accelerations since
            let w = self.extrapolation.start(t, h, &self.ydd0);
            // (`w = 0`: `a = a0` exactly)
            let start = [&self.y0[..n], &self.yd0[..n], &self.ydd0[..n]];
            let state = [&mut self.y[..n], &mut self.yd[..n], &mut self.ydd[..n]];
            let pred = [&mut self.y_pred[..n], &mut self.v_pred[..n], &mut self.a[..n]];
            let (a_prev, c) = (&self.extrapolation.a0[..n], [h, nm.beta, nm.gamma, bh2, gh, w]);
            #[cfg(target_arch = "x86_64")]
            if self.avx2 {
                // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                unsafe { predict_avx2(start, state, pred, a_prev, c) }
            } else {
                predict(start, state, pred, a_prev, c)
            }
            #[cfg(not(target_arch = "x86_64"))]
            predict(start, state, pred, a_prev, c);
        }
        let iterate_contact = self.implicit_contact;
        // friction is evaluated at every iterate (its force in the residual, its slip-speed
        // tangent in the refactorized Jacobian)
        let iterate_friction = self.friction;
        let linear = !self.nonlinear_geometric && !iterate_contact && !iterate_friction;
        // the iterations may stop on the contraction rate carried from earlier steps
        // (RATE_CARRY_DOWN; not with friction's secant switch or the continuous-contact model)
        let carried = !iterate_friction && self.cont.is_none();
        // the contact terms on the contact-free factor by Woodbury (the constant-rate stepper at
        // its step; the Newton stepper with the Woodbury solver when the joints allow it)
        let rate_step = !self.direct
            && self
                .rate
                .as_ref()
                .is_some_and(|r| r.fixed_step.is_none_or(|hh| hh == h))
            && self.woodbury_fits;
        let scale_floor = 1e-9 * self.limit / 10.0;
        // the iterations' tolerance may grow to a fraction of the step's own truncation error
        // (fixed steps only: NewtonSettings::truncation_fraction)
        let truncation = if self.settings.adaptive.is_none() {
            self.settings.newton.truncation_fraction * adaptive::zx_coefficient(nm.beta) * h * h
        } else {
            0.0
        };
        // the truncation fraction of the step's error at the last iterate
        let mut truncation_now = 0.0;
        let mut iters = 0usize;
        let mut last_res = f64::NAN;
        let mut last_corr;
        // the two corrections before the last, for the round-off floor's stall test
        let mut prev_corr = [f64::INFINITY; 2];
        // the residual of the first iteration, for the round-off floor's progress test
        let mut first_res = f64::NAN;
        self.fric_secant = false;
        let converged = loop {
            iters += 1;
            if iterate_friction && iters > FRICTION_SECANT_AFTER {
                self.fric_secant = true;
            }
            if iterate_contact {
                // Implicit contact: the force and its tangent at the current iterate.
                self.evaluate_contacts(false, true);
            }
            if iterate_friction {
                self.evaluate_friction(h);
            }
            // a step on an earlier step's factor that has not converged after
            // JACOBIAN_REUSE_ITERATIONS iterations continues on a new one, at the current iterate
            let refresh = self.reusing && iters == JACOBIAN_REUSE_ITERATIONS + 1;
            let prepared = if rate_step {
                let res = if iters == 1 || refresh {
                    self.rate_prepare(h, refresh)
                } else {
                    Ok(())
                };
                if iters == 1 || iterate_contact || refresh {
                    self.rate_blocks(bh2, gh);
                }
                res
            } else if refresh {
                self.jacobian_changed(h, false);
                self.factorize(h)
            } else if (iters == 1 || iterate_contact || iterate_friction) && self.jacobian_changed(h, iters == 1) {
                self.factorize(h)
            } else {
                Ok(())
            };
            let mut failure = prepared.err();
            let mut dx = Vec::new();
            if failure.is_none() {
                self.residual(h, t_end);
                last_res = max_abs_or_inf(&self.r);
                dx = std::mem::take(&mut self.r);
                if rate_step {
                    if iters == 1 && self.rate.as_ref().is_some_and(|r| r.any) {
                        self.stats.woodbury_steps += 1;
                    }
                    failure = self.rate_solve(h, &mut dx).err();
                } else {
                    self.lu.solve_in_place(&mut dx);
                    if self.cont.is_some() {
                        // the constraints of the attached continuous-contact joints, bordered
                        failure = self.constraint_correction(bh2, &mut dx).err();
                    }
                }
            }
            if let Some(e) = failure {
                // a factorization failed (the Jacobian, or the constant-rate stepper's fallback)
                if !dx.is_empty() {
                    self.r = dx;
                }
                let finite = self.y.iter().chain(&self.yd).chain(&self.a).all(|x| x.is_finite());
                if iters > 1 && !finite {
                    // the iterates ran away (a step too long for the contact or the frame
                    // motion): not converged, which step halving may mend
                    last_res = f64::INFINITY;
                    last_corr = f64::INFINITY;
                    break false;
                }
                self.restore();
                // a state that went non-finite between two divergence checks is reported as
                // the divergence it is, with the unknown that went first
                self.check_divergence(t, step)?;
                return Err(e);
            }
            // the largest correction and displacement, four running maxima each (no chain
            // through every unknown; the maxima are exact, so the order does not matter)
            let n = self.n;
            let state = [
                &mut self.a[..n],
                &mut self.ydd[..n],
                &mut self.y[..n],
                &mut self.yd[..n],
            ];
            let pred = [&self.y_pred[..n], &self.v_pred[..n], &dx[..n]];
            #[cfg(target_arch = "x86_64")]
            let (dmax, ymax) = if self.avx2 {
                // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                unsafe { correct_avx2(state, pred, bh2, gh) }
            } else {
                correct(state, pred, bh2, gh)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let (dmax, ymax) = correct(state, pred, bh2, gh);
            // f64::max skips NaN: a non-finite correction is caught here, not by dmax
            let finite = dx.iter().all(|d| d.is_finite());
            self.r = dx;
            last_corr = if finite {
                dmax / ymax.max(scale_floor)
            } else {
                f64::INFINITY
            };
            if !last_corr.is_finite() {
                break false;
            }
            if carried && iters >= 2 {
                self.iter_rate = (last_corr / prev_corr[1]).max(RATE_CARRY_DOWN * self.iter_rate);
            }
            // the tolerance of this iterate: `tol`, or the truncation fraction of the step's
            // Zienkiewicz-Xie error at this iterate where that is larger (both relative to the
            // displacement scale), not above the last accepted step's (an iterate far from the
            // solution has accelerations, and an estimate, far from the step's) nor above
            // TRUNCATION_TOL_MAX (unresolved stiff modes inflate the estimate)
            let tol = if truncation > 0.0 {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                let da = if self.avx2 {
                    unsafe { max_abs_difference_avx2(&self.ydd[..n], &self.ydd0[..n]) }
                } else {
                    max_abs_difference(&self.ydd[..n], &self.ydd0[..n])
                };
                #[cfg(not(target_arch = "x86_64"))]
                let da = max_abs_difference(&self.ydd[..n], &self.ydd0[..n]);
                truncation_now = truncation * da / ymax.max(scale_floor);
                let relaxed = truncation_now
                    .min(self.truncation_last)
                    .min(crate::run::TRUNCATION_TOL_MAX);
                self.settings.newton.tol.max(relaxed)
            } else {
                self.settings.newton.tol
            };
            if linear || last_corr <= tol {
                break true;
            }
            if carried && self.iter_rate < CONTRACTION_STOP {
                if let Some(margin) = self.carried_rate_margin() {
                    if self.iter_rate * last_corr <= margin * tol {
                        // every joint's state and terms at this (final) iterate are at hand
                        self.margin_state = true;
                        break true;
                    }
                }
            }
            if iters >= 3 {
                // the error left after this correction, bounded by the contraction of the last
                // two (`prev_corr[1]` is the one before; the first correction, which takes out
                // the predictor's error, says nothing of the iteration's rate)
                let rho = last_corr / prev_corr[1];
                if rho < CONTRACTION_STOP && rho / (1.0 - rho) * last_corr <= tol {
                    break true;
                }
            }
            if iters == 1 {
                first_res = last_res;
            }
            if last_corr <= ROUNDOFF_FLOOR
                && last_corr >= prev_corr[0].min(prev_corr[1])
                && last_res <= ROUNDOFF_RESIDUAL * first_res
            {
                // stalled: no smaller than one of the two corrections before it (round-off
                // fluctuates; a slow but converging iteration keeps decreasing and goes on), at
                // a level no result depends on: what is left is the system's round-off
                self.stats.roundoff_steps += 1;
                break true;
            }
            prev_corr = [prev_corr[1], last_corr];
            if iters >= self.settings.newton.max_iter {
                break false;
            }
        };
        self.stats.iterations += iters as u64;
        self.stats.max_iterations = self.stats.max_iterations.max(iters as u64);
        self.steps_begun += 1;
        self.reuse_ok = converged && iters <= JACOBIAN_REUSE_ITERATIONS;
        self.reusing = false;
        if converged {
            self.truncation_last = truncation_now;
            if nm.is_alpha() {
                // aa_{n+1} = b + (1 - alpha_f)/(1 - alpha_m) a_{n+1}
                let k2 = nm.alpha_constants()[2];
                for i in 0..self.n {
                    self.aa[i] += k2 * self.a[i];
                }
            } else {
                self.extrapolation.converged(t, h, &self.ydd0, &self.ydd);
            }
            if iterate_friction {
                // the bristle states of the accepted step, at its final state
                self.evaluate_friction(h);
                for (z, f) in self.fric_z.iter_mut().zip(&self.fric) {
                    *z = f.eval.z;
                }
            }
            return Ok(());
        }
        self.restore();
        self.update_frames(t);
        if rate_step && !self.direct && self.rate.as_ref().is_some_and(|r| r.fixed_step.is_none()) {
            // the Newton stepper's step on the contact-free factor did not converge: redo it
            // refactorizing the whole Jacobian when it changes (which also refreshes the
            // geometric tangent at every contact change), as the reference path does
            self.stats.woodbury_fallbacks += 1;
            self.direct = true;
            let res = self.step(t, h, step, depth);
            self.direct = false;
            return res;
        }
        if depth < self.settings.newton.step_halving {
            self.step(t, 0.5 * h, step, depth + 1)?;
            self.step(t + 0.5 * h, 0.5 * h, step, depth + 1)?;
            self.stats.halved_substeps += 2;
            return Ok(());
        }
        Err(Error::NotConverged {
            time: t,
            step,
            iterations: iters,
            residual: last_res,
            correction: last_corr,
        })
    }

    fn restore(&mut self) {
        self.jstate_fresh = false;
        self.y.copy_from_slice(&self.y0);
        self.yd.copy_from_slice(&self.yd0);
        self.ydd.copy_from_slice(&self.ydd0);
        if self.settings.newmark.is_alpha() {
            self.aa.copy_from_slice(&self.aa0);
        }
    }

    /// The alpha schemes' predictors of a step of `h` (s) from the state in `y`, `yd`, `ydd`,
    /// `aa` ([`crate::integrator::Newmark`]): `b = (alpha_f a_n - alpha_m aa_n)/(1 - alpha_m)`,
    /// `y~ = y + h v + h^2 (1/2 - beta) aa + beta h^2 b`, `v~ = v + h (1 - gamma) aa + gamma h b`;
    /// the first iterate keeps `a = a_n`. Keeps `aa_n` in `aa0` and `b` in `aa` (completed
    /// with the step's `a_{n+1}` when it converges).
    fn alpha_predictors(&mut self, h: f64) {
        let nm = self.settings.newmark;
        let (bh2, gh) = nm.coefficients(h);
        let [k0, k1, _] = nm.alpha_constants();
        let (bh2r, ghr) = (nm.beta * h * h, nm.gamma * h);
        self.aa0.copy_from_slice(&self.aa);
        for i in 0..self.n {
            let (y0, v0, a0, aa0) = (self.y[i], self.yd[i], self.ydd[i], self.aa[i]);
            let b = k0 * a0 + k1 * aa0;
            self.y_pred[i] = y0 + h * v0 + (0.5 - nm.beta) * h * h * aa0 + bh2r * b;
            self.v_pred[i] = v0 + (1.0 - nm.gamma) * h * aa0 + ghr * b;
            self.aa[i] = b;
            self.a[i] = a0;
            self.y[i] = self.y_pred[i] + bh2 * a0;
            self.yd[i] = self.v_pred[i] + gh * a0;
            self.ydd[i] = a0;
        }
    }

    /// Initial state: given elastic displacements/velocities (link frame) mapped to the unknowns
    /// (a shared unknown takes the first link's value), initial accelerations from the equations.
    fn initialize(&mut self) -> Result<()> {
        self.update_frames(0.0);
        for li in 0..self.links.len() {
            let l = &self.mech.links[li];
            // a rigid link's state is node 0's (node 1 follows it)
            let nodes = if l.rigid.is_some() { 1 } else { l.nodes() };
            for nd in 0..nodes {
                let nt = *self.nt(li, nd);
                for (src, dst) in [(&l.initial_displacement, 0), (&l.initial_velocity, 1)] {
                    let Some(v) = src else { continue };
                    let w = [v[3 * nd], v[3 * nd + 1], v[3 * nd + 2]];
                    // Least-squares inverse of the orthonormal-column T: slots = T^T w.
                    for c in 0..3 {
                        let i = nt.idx[c];
                        if i != NONE {
                            let val = nt.t[0][c] * w[0] + nt.t[1][c] * w[1] + nt.t[2][c] * w[2];
                            if dst == 0 {
                                self.y[i] = val;
                            } else {
                                self.yd[i] = val;
                            }
                        }
                    }
                }
            }
        }
        // Velocity relative to the frame given: for global unknowns subtract T-dot y.
        // (Td y is the apparent velocity of a fixed global displacement in the rotating frame.)
        self.restart_accelerations(0.0)?;
        if self.cont.is_some() {
            self.continuous_start()?;
        }
        Ok(())
    }

    /// The Jacobian at h = 0: the mass matrix (with the transforms), for the initial
    /// accelerations.
    fn factorize_mass(&mut self) -> Result<()> {
        self.sig_new.clear();
        self.sig_new.push(f64::NAN);
        self.factorize(0.0)
    }

    /// The divergence rule of [`crate::integrator::divergence`] on the unknowns.
    fn check_divergence(&self, t: f64, step: u64) -> Result<()> {
        let (y, yd) = (&self.y[..self.n], &self.yd[..self.n]);
        match super::divergence::first_bad_in(y, yd, &self.translational[..self.n], self.limit) {
            None => Ok(()),
            Some(i) => Err(Error::Diverged {
                time: t,
                step,
                dof: self.describe(i),
                reason: super::divergence::reason(y[i], yd[i], self.translational[i], self.limit),
            }),
        }
    }

    fn describe(&self, i: usize) -> String {
        for (li, ld) in self.links.iter().enumerate() {
            for (nd, m) in ld.nodes.iter().enumerate() {
                let name = &self.mech.links[li].name;
                if m.rot == i {
                    return format!("theta of node {nd} of link {name:?}");
                }
                match m.trans {
                    Trans::Local(ix) if ix.contains(&i) => {
                        let c = if ix[0] == i { "u" } else { "v" };
                        return format!("{c} of node {nd} of link {name:?}");
                    }
                    Trans::Global(ix) if ix.contains(&i) => {
                        let c = if ix[0] == i { "x" } else { "y" };
                        return format!("global {c} of node {nd} of link {name:?}");
                    }
                    Trans::Slider { s, slider } if s == i => {
                        return format!("slider {:?}", self.mech.sliders[slider].name);
                    }
                    _ => {}
                }
            }
        }
        for (s, &d) in self.slider_dof.iter().enumerate() {
            if d == i {
                return format!("slider {:?}", self.mech.sliders[s].name);
            }
        }
        format!("unknown #{i}")
    }

    /// Reserves the histories of a run of `steps` grid steps up front: the samples of the output
    /// grid (every `RecordSpec::every`-th step, the first and the last), at most
    /// [`INITIAL_SAMPLES`](crate::record::INITIAL_SAMPLES) of them (a longer run grows its
    /// histories as it goes), for the channels the record keeps. Without it each history grew by
    /// doubling, copying what it held (5 M of the 219 M instructions of the crank-pin
    /// slider-crank's 0.1 s with the default record).
    fn reserve_histories(&mut self, steps: u64) {
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
    fn record(&mut self, t: f64, tracked: bool) {
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
    fn track_joints(&mut self, t: f64, step: Option<(u64, f64)>, margin: bool) {
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
    fn track_sliders(&mut self, t: f64, keep: bool) {
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
    fn track_links(&mut self, t: f64) {
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
    fn penetrations(&self, out: &mut Vec<f64>) {
        out.clear();
        for (j, jt) in self.mech.joints.iter().enumerate() {
            let (q, _) = self.joint_state(j, &self.y, &self.yd);
            out.push(q[0].hypot(q[1]) - jt.clearance);
        }
    }

    /// Accelerations at time `t` (s) from the current displacements and velocities (the initial
    /// ones, and the restart at an event cut): `M a = F - ... + contact`, the contact terms (and
    /// the implicit coupling's damping) taken at this state, the right limit at a contact status
    /// change. Solves `J(h -> 0) a = -r(a = 0)`: with `beta h^2 -> 0` the Jacobian is the mass
    /// matrix with the transforms (velocity-coupling terms vanish too).
    /// `ydd = -M^-1 r` with the residual at `t` (s) of the current state (its accelerations part
    /// left out by the caller: `ydd` zero) and the mass matrix in [`Self::lu`]
    /// ([`Self::factorize_mass`]).
    pub(super) fn mass_accelerations(&mut self, t: f64) {
        self.residual(0.0, t);
        let mut dx = std::mem::take(&mut self.r);
        self.lu.solve_in_place(&mut dx);
        for (a, d) in self.ydd.iter_mut().zip(&dx) {
            *a = -d;
        }
        self.r = dx;
    }

    fn restart_accelerations(&mut self, t: f64) -> Result<()> {
        self.update_frames(t);
        self.evaluate_contacts(true, true);
        self.ydd.fill(0.0);
        self.factorize_mass()?;
        self.mass_accelerations(t);
        self.signature.clear();
        if self.settings.newmark.is_alpha() {
            self.aa.copy_from_slice(&self.ydd); // the alpha schemes (re)start with aa = a
        }
        Ok(())
    }

    /// Puts back the state of `ev` (the start of the step at `t`, s).
    fn restore_from(&mut self, ev: &EventScratch, t: f64) {
        self.y.copy_from_slice(&ev.y);
        self.yd.copy_from_slice(&ev.yd);
        self.ydd.copy_from_slice(&ev.ydd);
        self.update_frames(t);
    }

    /// Step `k` from `t0` of size `h` with event location: the step is taken; when it changes a
    /// clearance joint's status (sign of `|q| - c`), the earliest crossing (linear
    /// interpolation, then regula falsi on the first substep's end penetration, aiming just past
    /// the circle, within 1e-3 of the step's change of penetration) places a cut; the step is
    /// redone from its start as a substep to the cut, the accelerations are restarted there with
    /// the new status ([`Self::restart_accelerations`]: the dashpot force of an entry acts from
    /// the cut on, instead of from the next step), the joints are tracked at the cut (the entry
    /// spike enters the largest force), and a second substep ends the step on the grid.
    fn step_with_events(&mut self, t0: f64, h: f64, k: u64, ev: &mut EventScratch) -> Result<()> {
        self.penetrations(&mut ev.p0);
        ev.y.clone_from(&self.y);
        ev.yd.clone_from(&self.yd);
        ev.ydd.clone_from(&self.ydd);
        if self.settings.newmark.is_alpha() {
            ev.aa.clone_from(&self.aa);
        }
        ev.fric_z.clone_from(&self.fric_z);
        ev.fric_track.clone_from(&self.fric_track);
        self.step(t0, h, k, 0)?;
        self.penetrations(&mut ev.p1);
        let Some((theta, jstar)) = earliest_crossing(&ev.p0, &ev.p1) else {
            return Ok(());
        };
        ev.extremes.clear();
        ev.extremes
            .extend(self.track.iter().map(|j| (j.max_penetration, j.max_force)));
        ev.rec = Some(self.rec.clone());
        if self.cut_step(t0, h, k, ev, theta, jstar).is_ok() {
            self.stats.event_steps += 1;
            return Ok(());
        }
        // a substep did not converge where the whole step did: keep the whole step (and undo the
        // tracking at the cut)
        self.stats.event_fallbacks += 1;
        for (j, &(p, f)) in self.track.iter_mut().zip(&ev.extremes) {
            (j.max_penetration, j.max_force) = (p, f);
        }
        if let Some(rec) = ev.rec.take() {
            self.rec = rec;
        }
        self.fric_track.clone_from(&ev.fric_track);
        self.restore_from(ev, t0);
        self.step(t0, h, k, 0)
    }

    /// The cut of [`Self::step_with_events`] at first estimate `theta` (fraction of `h`) for
    /// joint `jstar`, from the start state in `ev`.
    fn cut_step(&mut self, t0: f64, h: f64, k: u64, ev: &mut EventScratch, mut theta: f64, jstar: usize) -> Result<()> {
        // just past the circle: the substep after the cut starts with the new status
        let mut search = CutSearch::new(ev.p0[jstar], ev.p1[jstar], true);
        let mut h1 = theta * h;
        for it in 0..EVENT_MAX_CUTS {
            h1 = theta * h;
            self.restore_from(ev, t0);
            self.step(t0, h1, k, 0)?;
            self.penetrations(&mut ev.pc);
            match search.next(theta, ev.pc[jstar], it + 1 == EVENT_MAX_CUTS) {
                Some(next) => theta = next,
                None => break,
            }
        }
        self.restart_accelerations(t0 + h1)?;
        self.track_joints(t0 + h1, None, false);
        self.step(t0 + h1, h - h1, k, 0)
    }

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
    fn adaptive_advance(
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
            return Err(super::divergence::joint_diverged(name, self.jpen[j], self.limit, t, k));
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

    /// Runs to `t_end` in the one run loop (`integrator/run_loop.rs`; `control(fraction)` every
    /// [`NEWTON_CONTROL_STRIDE`] steps; `false` stops the run with [`Error::Interrupted`]).
    /// Failures carry everything recorded until then. With [`Settings::events`] each step goes
    /// through `step_with_events`; a step without a status change is the fixed step.
    pub fn run(mut self, control: &mut dyn FnMut(f64) -> bool) -> std::result::Result<RunOutput, Box<RunFailure>> {
        if let Err(e) = self.initialize() {
            return Err(self.fail(e, 0.0));
        }
        for j in 0..self.mech.joints.len() {
            self.track[j].max_penetration = f64::NEG_INFINITY;
        }
        let h = self.settings.dt;
        if self.rate.as_ref().is_some_and(|r| r.fixed_step.is_some()) {
            // the constant-rate stepper's one factorization (and its Woodbury columns), before
            // the time loop: nothing is allocated there
            self.update_frames(h);
            let res = self.rate_prepare(h, false);
            self.update_frames(0.0);
            if let Err(e) = res {
                return Err(self.fail(e, 0.0));
            }
        }
        self.track_joints(0.0, Some((0, h)), false);
        self.hist_sliders = (self.mech.sliders.iter())
            .map(|s| SliderHistory {
                name: s.name.clone(),
                deviation: self.settings.record.slider_reference.is_some(),
                ..Default::default()
            })
            .collect();
        let steps = (self.settings.t_end / self.settings.dt).round().max(1.0) as u64;
        self.reserve_histories(steps);
        if self.settings.record.links.peaks {
            for (h, l) in self.hist_links.iter_mut().zip(&self.mech.links) {
                h.peaks = l.rigid.is_none().then_some(LinkPeaks {
                    midspan: 0.0,
                    axial_force: 0.0,
                });
            }
        }
        self.track_sliders(0.0, true);
        self.track_links(0.0);
        self.record(0.0, true);
        let adaptive = self.settings.adaptive.map(|a| AdaptiveScratch {
            t: 0.0,
            t_start: 0.0,
            t_end: steps as f64 * h,
            pending: false,
            y: vec![0.0; self.n],
            yd: vec![0.0; self.n],
            ydd: vec![0.0; self.n],
            end_y: vec![0.0; self.n],
            end_yd: vec![0.0; self.n],
            end_ydd: vec![0.0; self.n],
            end_ydd_restart: vec![0.0; self.n],
            end_frames: Default::default(),
            aa: vec![0.0; self.n],
            q0: Vec::with_capacity(self.mech.joints.len()),
            fric_z: vec![0.0; self.mech.joints.len()],
            p0: Vec::with_capacity(self.mech.joints.len()),
            p1: Vec::with_capacity(self.mech.joints.len()),
            pc: Vec::with_capacity(self.mech.joints.len()),
            levels: adaptive::Levels::new(a.h_max, a.h_min, h),
            control: Default::default(),
            forces: adaptive::ForceErrors::new(self.mech.joints.len()),
            da: vec![[0.0; 2]; self.mech.joints.len()],
            accepted: Default::default(),
        });
        let events =
            (self.settings.events && !self.mech.joints.is_empty() && adaptive.is_none()).then(EventScratch::default);
        let mut lp = NewtonLoop {
            run: &mut self,
            steps,
            events,
            adaptive,
            outcome: None,
        };
        run_loop::run(&mut lp, control);
        match lp.outcome.take().expect("the run loop ends every run") {
            Ok(t) => Ok(self.output(t)),
            Err((error, t)) => Err(self.fail(error, t)),
        }
    }

    /// What the run has produced when it ends at `t` (s): the shared recorder's joint extremes
    /// (the largest penetration and force from the stepper's own tracking, which sees the peaks
    /// within steps) and
    /// impact logs, with the histories on the output grid; the counters; the unknowns'
    /// displacement, velocity and acceleration (see [`Self::dof_map`]).
    fn output(&mut self, t: f64) -> RunOutput {
        let mut record = std::mem::take(&mut self.rec);
        record.time = std::mem::take(&mut self.hist_time);
        record.links = std::mem::take(&mut self.hist_links);
        record.joints = std::mem::take(&mut self.hist_joints);
        record.sliders = std::mem::take(&mut self.hist_sliders);
        for (e, j) in record.extremes.iter_mut().zip(&self.track) {
            (e.max_penetration, e.max_force) = (j.max_penetration, j.max_force);
        }
        for (e, f) in record.extremes.iter_mut().zip(&self.fric_track) {
            e.friction_work = f.work;
        }
        RunOutput {
            record,
            stats: self.stats.clone(),
            state: [self.y.clone(), self.yd.clone(), self.ydd.clone()],
            time: t,
        }
    }

    fn fail(mut self, error: Error, t: f64) -> Box<RunFailure> {
        let output = self.output(t);
        Box::new(RunFailure { error, output })
    }
}

/// Steps between calls of the caller's control function on the Newton stepper (its steps cost
/// about 1-100 us, the constant stepper's well under one).
pub const NEWTON_CONTROL_STRIDE: u64 = 256;

/// A Newton run in the one run loop ([`run_loop`]): one lane, whose end is `outcome` (the end
/// time, or the error and the time of the last completed step).
struct NewtonLoop<'r, 'a> {
    run: &'r mut NewtonRun<'a>,
    /// Steps of the run, `t_end / dt` rounded (at least 1).
    steps: u64,
    events: Option<EventScratch>,
    /// Adaptive steps ([`NewtonRun::adaptive_advance`]), `None` for the fixed step.
    adaptive: Option<AdaptiveScratch>,
    outcome: Option<std::result::Result<f64, (Error, f64)>>,
}

/// The frame caches of [`AdaptiveScratch::end_frames`].
type EndFrames = (
    Vec<FrameState>,
    Vec<[[f64; 2]; 2]>,
    Vec<NodeT>,
    Vec<(Mat6, Mat6)>,
    Vec<FrameState>,
);

/// The adaptive controller's state: the start of the trial step and the penetrations at its
/// start, end and cut (allocated before the time loop), the level `m` of the next step
/// `h_max / 2^m`, and the dense output's bookkeeping.
struct AdaptiveScratch {
    /// The time of the integrated state (s: the end of the last accepted step, at or past the
    /// last output instant), the start of that step (s), and the run's end (s).
    t: f64,
    t_start: f64,
    t_end: f64,
    /// Whether the end of the last accepted step is still to be tracked (it lies past the
    /// output instant recorded last). (Whether the state in the stepper is an interpolated
    /// output's, the integrated one in `end_*`, is [`NewtonRun::output_interpolated`].)
    pending: bool,
    /// The start of the trial step (after acceptance: of the last accepted step).
    y: Vec<f64>,
    yd: Vec<f64>,
    ydd: Vec<f64>,
    /// The end of the last accepted step: accelerations before a restart at a cut (the
    /// interpolant's) and after it (the integrated state's), displacements and velocities.
    end_y: Vec<f64>,
    end_yd: Vec<f64>,
    end_ydd: Vec<f64>,
    end_ydd_restart: Vec<f64>,
    /// The frames, rotations, node transforms, links' element terms and guide frames of the
    /// integrated state while an output's interpolated one is in the stepper.
    end_frames: EndFrames,
    /// The alpha schemes' acceleration-like variable at the start.
    aa: Vec<f64>,
    /// Per joint, the relative displacement (m) and its rate (m/s) at the start.
    q0: Vec<([f64; 2], [f64; 2])>,
    /// Per joint, LuGre's bristle state at the start (m).
    fric_z: Vec<f64>,
    p0: Vec<f64>,
    p1: Vec<f64>,
    pc: Vec<f64>,
    levels: adaptive::Levels,
    /// Calls of the caller's control function between output instants.
    control: adaptive::ControlTicker,
    /// The achieved-accuracy estimate of the joints' largest forces, and each joint's change of
    /// relative acceleration over the accepted step (m/s^2).
    forces: adaptive::ForceErrors,
    da: Vec<[f64; 2]>,
    /// Accepted steps since the last divergence check.
    accepted: super::divergence::AcceptedSteps,
}

impl Stepper for NewtonLoop<'_, '_> {
    const CONTROL_STRIDE: u64 = NEWTON_CONTROL_STRIDE;

    fn steps(&self) -> u64 {
        self.steps
    }

    fn dt(&self) -> f64 {
        self.run.settings.dt
    }

    fn running(&self) -> bool {
        self.outcome.is_none()
    }

    fn advance(&mut self, k: u64, t1: f64, control: &mut dyn FnMut(f64) -> bool) {
        let last = k == self.steps;
        let r = &mut *self.run;
        let h = r.settings.dt;
        let t0 = (k - 1) as f64 * h;
        // a fixed step's frames are those of the grid instant `t1` (the first step the events
        // or the continuous contact take is the whole step)
        r.step_end = self.adaptive.is_none().then_some(t1);
        let keep = k.is_multiple_of(r.settings.record.every as u64) || last;
        // `tracked`: the step tracked its joints and sliders itself
        let (res, tracked) = match (self.adaptive.as_mut(), self.events.as_mut()) {
            (Some(ad), _) => (r.adaptive_advance(t1, k, ad, control), false),
            (None, Some(ev)) => (r.step_with_events(t0, h, k, ev), false),
            (None, None) if r.cont.is_some() => (r.continuous_step(t0, h, k), false),
            // a fixed step (no events, no continuous contact)
            (None, None) => (r.fixed_step(t0, h, k, t1, keep), true),
        };
        r.step_end = None;
        if let Err(e) = res {
            self.outcome = Some(Err((e, t0)));
            return;
        }
        if !tracked {
            r.stats.steps = k;
            r.track_joints(t1, Some((k, h)), false);
            r.tracked_state = false;
            r.track_sliders(t1, keep);
            r.track_links(t1);
        }
        if let Some(j) = r.jpen.iter().position(|&p| p.is_nan() || p > r.limit) {
            let e = super::divergence::joint_diverged(&r.mech.joints[j].name, r.jpen[j], r.limit, t1, k);
            self.outcome = Some(Err((e, t1)));
        }
    }

    fn check(&mut self, k: u64, t1: f64) {
        if self.outcome.is_none() {
            if let Err(e) = self.run.check_divergence(t1, k) {
                self.outcome = Some(Err((e, t1)));
            }
        }
    }

    fn record(&mut self, k: u64, t1: f64) {
        let last = k == self.steps;
        let r = &mut *self.run;
        let every = r.settings.record.every as u64;
        if self.outcome.is_none() && (k.is_multiple_of(every) || last) {
            // a step that ended at the grid's `k dt` up to rounding: its frames (those the state
            // was computed with) are the record's, not recomputed; then a fixed step's joints
            // are as `track_joints` left them after it (`advance`), at this state and frames
            let mut tracked = self.adaptive.is_none();
            if (r.t_frames - t1).abs() > same_instant(r.settings.dt) {
                r.update_frames(t1);
                tracked = false;
            }
            r.record(t1, tracked);
        }
    }

    fn stop_all(&mut self, error: Error, _k: u64, t: f64) {
        if self.outcome.is_none() {
            self.outcome = Some(Err((error, t)));
        }
    }

    fn end(&mut self, _k: u64, t: f64) {
        if self.outcome.is_none() {
            self.outcome = Some(Ok(t));
        }
    }
}

/// Runs a mechanism. See [`NewtonRun::run`].
pub fn simulate_mechanism(
    mech: &Mechanism,
    settings: &Settings,
    control: &mut dyn FnMut(f64) -> bool,
) -> std::result::Result<RunOutput, Box<RunFailure>> {
    let run = NewtonRun::new(mech, settings).map_err(RunFailure::before_start)?;
    run.run(control)
}

/// Runs a mechanism on the constant-rate stepper ([`NewtonRun::use_constant_rate`]: the
/// contact-free Jacobian factorized once, contact by Woodbury). Fails before the first step with
/// [`Error::InvalidParameter`] naming `stepper` where the model does not allow it, else as
/// [`NewtonRun::run`].
pub fn simulate_constant_rate(
    mech: &Mechanism,
    settings: &Settings,
    control: &mut dyn FnMut(f64) -> bool,
) -> std::result::Result<RunOutput, Box<RunFailure>> {
    let mut run = NewtonRun::new(mech, settings).map_err(RunFailure::before_start)?;
    run.use_constant_rate().map_err(RunFailure::before_start)?;
    run.run(control)
}

#[cfg(test)]
mod tests {
    use super::{mul6, Extrapolation, Mat6, Sparsity, SplitMat, Vec6, EXTRAPOLATION_MAX_RATIO};

    /// The crank-pin slider-crank the AVX2 tests run, `None` where the CPU has no AVX2 build to
    /// compare.
    #[cfg(target_arch = "x86_64")]
    fn avx2_crank_pin() -> Option<crate::model::mechanism::Mechanism> {
        use crate::scenes::{FlexibleSliderCrank, SliderCrankPin};
        crate::linalg::avx2_fma_available().then(|| {
            FlexibleSliderCrank {
                clearance_at: Some(SliderCrankPin::CrankPin),
                ..Default::default()
            }
            .build()
            .expect("slider-crank scene")
        })
    }

    /// The Woodbury solve on the contact-free factor (`rate_solve`) equals the solve with the
    /// whole Jacobian assembled and factorized (`assemble` with the contact terms) to rounding,
    /// with contact stiffness and damping in every joint: a joint whose sides turn together (the
    /// crank pin, `P^T G P`) and joints whose sides turn at different rates (the slider pin: a
    /// turning rod on a fixed guide; the four-bar's rocker pin: coupler and rocker, both
    /// flexible), whose damping term goes through the velocity rows (`P^T H V`). Dropping `H V`
    /// leaves errors of 4e-4 of the solution (the slider pin; checked when this test was
    /// written).
    #[test]
    fn the_woodbury_solve_equals_the_whole_jacobians() {
        use crate::linalg::BandLu;
        use crate::scenes::{FlexibleFourBar, FlexibleSliderCrank, FourBarPin, SliderCrankPin};
        let mechs = [
            (
                FlexibleSliderCrank {
                    clearance_at: Some(SliderCrankPin::CrankPin),
                    ..Default::default()
                }
                .build(),
                false,
            ),
            (
                FlexibleSliderCrank {
                    clearance_at: Some(SliderCrankPin::SliderPin),
                    ..Default::default()
                }
                .build(),
                true,
            ),
            (
                FlexibleFourBar {
                    flexible_rocker: true,
                    clearance_at: Some(FourBarPin::RockerPin),
                    ..Default::default()
                }
                .build(),
                true,
            ),
        ];
        for (k, (mech, split)) in mechs.into_iter().enumerate() {
            let mech = mech.expect("scene");
            let settings = crate::Settings::new(0.01, 1e-5);
            let mut run = super::NewtonRun::new(&mech, &settings).expect("a Newton run");
            let h = 1e-5;
            let (bh2, gh) = settings.newmark.coefficients(h);
            run.update_frames(3.3e-3);
            // a contact stiffness and damping (N/m, N s/m) in every joint, not symmetric, as the
            // implicit contact's tangent
            run.implicit_contact = true;
            for t in run.contact_tan.iter_mut() {
                *t = ([[2.0e8, 3.0e6], [-1.0e6, 5.0e7]], [[4.0e3, 500.0], [-200.0, 1.5e3]]);
            }
            run.rate_prepare(h, true).expect("contact-free factor");
            run.rate_blocks(bh2, gh);
            let rs = run.rate.as_ref().expect("the Woodbury solver");
            assert!(rs.any, "case {k}: contact terms");
            assert_eq!(rs.rows.split.contains(&true), split, "case {k}: split joints");
            assert_eq!(rs.any_split, split, "case {k}");
            let rhs: Vec<f64> = (0..run.n).map(|i| (i as f64 * 0.71 + k as f64).sin()).collect();
            let mut x = rhs.clone();
            run.rate_solve(h, &mut x).expect("Woodbury solve");
            assert_eq!(run.stats.woodbury_fallbacks, 0, "case {k}");
            let mut lu = BandLu::new(run.n, run.lu.bandwidth());
            run.assemble(bh2, gh, &mut lu, true, true);
            lu.factorize("whole Jacobian").expect("factorizes");
            let mut x_direct = rhs.clone();
            lu.solve_in_place(&mut x_direct);
            let scale = x_direct.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            for i in 0..run.n {
                assert!(
                    (x[i] - x_direct[i]).abs() <= 1e-9 * scale,
                    "case {k}, unknown {i}: {} against {}",
                    x[i],
                    x_direct[i]
                );
            }
        }
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_avx2_residual_equals_the_baseline_one_bitwise() {
        // the AVX2 residual (beam elements four at a time in the lanes of element_lanes, and
        // eight at a time where the CPU has AVX-512) against the baseline's element by element,
        // at random states: the crank-pin slider-crank (8 rod elements: two full groups of four,
        // one of eight, transformed end nodes), with material damping (the geometric damping
        // D2) and 7 elements (a group of three, of seven), a four-bar with a flexible coupler and
        // rocker (5 and 3 elements, a clearance joint at the rocker pin), and rods of 1 to 9
        // elements with and without the geometric terms
        use crate::scenes::{FlexibleFourBar, FlexibleSliderCrank, FourBarPin, SliderCrankPin};
        if !crate::linalg::avx2_fma_available() {
            return;
        }
        let mut mechs = vec![
            FlexibleSliderCrank {
                clearance_at: Some(SliderCrankPin::CrankPin),
                ..Default::default()
            }
            .build(),
            FlexibleSliderCrank {
                damping: 1e7,
                elements: 7,
                ..Default::default()
            }
            .build(),
            FlexibleFourBar {
                elements: 5,
                flexible_rocker: true,
                rocker_elements: Some(3),
                damping: 1e6,
                clearance_at: Some(FourBarPin::RockerPin),
                ..Default::default()
            }
            .build(),
        ];
        // every remainder of a group of four, with and without the geometric terms
        for elements in 1..=9 {
            for geometric in [Some(true), Some(false)] {
                mechs.push(
                    FlexibleSliderCrank {
                        elements,
                        geometric,
                        clearance_at: Some(SliderCrankPin::SliderPin),
                        ..Default::default()
                    }
                    .build(),
                );
            }
        }
        for (k, mech) in mechs.into_iter().enumerate() {
            let mech = mech.expect("scene");
            let settings = crate::Settings::new(0.01, 1e-5);
            let mut run = super::NewtonRun::new(&mech, &settings).expect("a Newton run");
            run.update_frames(3.3e-3);
            let mut seed = 99u64 + k as u64;
            let mut next = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-3
            };
            for i in 0..run.n {
                run.y[i] = next();
                run.yd[i] = 1e2 * next();
                run.ydd[i] = 1e5 * next();
            }
            // the baseline build's path: element by element, no lanes
            run.avx2 = false;
            run.residual_body(1e-5, 3.3e-3);
            let baseline = run.r.clone();
            assert!(baseline.iter().any(|&x| x != 0.0));
            run.avx2 = true;
            for wide in [false, crate::linalg::avx512_available()] {
                run.avx512 = wide;
                // SAFETY: the CPU has AVX2 and FMA (checked above)
                unsafe { run.residual_avx2(1e-5, 3.3e-3) };
                assert_eq!(
                    baseline.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    run.r.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    "mechanism {k}, eight lanes {wide}"
                );
            }
        }
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn a_run_in_the_avx2_build_equals_the_baseline_run_bitwise() {
        // the step and the residual in their AVX2 builds (the residual's lanes eight wide where
        // the CPU has AVX-512, and four wide) against both in the baseline's, over 2 ms of the
        // crank-pin slider-crank (its first impacts)
        let Some(mech) = avx2_crank_pin() else {
            return;
        };
        let settings = crate::Settings::new(2e-3, 1e-5);
        let outputs: Vec<_> = [(true, true), (true, false), (false, false)]
            .into_iter()
            .map(|(avx2, wide)| {
                let mut run = super::NewtonRun::new(&mech, &settings).expect("a Newton run");
                run.set_avx2(avx2);
                run.avx512 &= wide;
                run.run(&mut |_| true).expect("the run")
            })
            .collect();
        let bits = |o: &crate::run::RunOutput| -> Vec<u64> { o.state.iter().flatten().map(|x| x.to_bits()).collect() };
        let force = |o: &crate::run::RunOutput| o.record.extremes[0].max_force.to_bits();
        for other in &outputs[1..] {
            assert_eq!(bits(&outputs[0]), bits(other));
            assert_eq!(outputs[0].stats.iterations, other.stats.iterations);
            assert_eq!(force(&outputs[0]), force(other));
        }
        assert!(outputs[0].record.extremes[0].max_force > 0.0);
    }

    /// Steps of `h` from 0 whose accelerations are `a(t)`: the first iterate each step
    /// starts from (`a_n + w (a_n - a_(n-1))`) and the verdicts, as `NewtonRun::step` uses them.
    fn run(a: impl Fn(f64) -> f64, h: f64, steps: usize) -> (Vec<f64>, Vec<bool>) {
        let mut ex = Extrapolation::new(1);
        let (mut firsts, mut verdicts) = (Vec::new(), Vec::new());
        for k in 0..steps {
            let t = k as f64 * h;
            let (a0, a1) = ([a(t)], [a(t + h)]);
            let w = ex.start(t, h, &a0);
            firsts.push(if w > 0.0 { a0[0] + w * (a0[0] - ex.a0[0]) } else { a0[0] });
            ex.converged(t, h, &a0, &a1);
            verdicts.push(ex.better);
        }
        (firsts, verdicts)
    }

    #[test]
    fn sparse_element_products_equal_nalgebras_bitwise() {
        // mul6 skips the exact zeros of a pattern and keeps nalgebra's order of the sums
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 10f64.powi((seed % 7) as i32 - 3)
        };
        let axial = |i: usize| i == 0 || i == 3;
        type Keep<'a> = &'a dyn Fn(usize, usize) -> bool;
        let patterns: [(Keep, Sparsity); 4] = [
            (&|_, _| false, Sparsity::Zero),
            (&|i, j| axial(i) == axial(j), Sparsity::Split),
            (&|i, j| i < 3 && j < 3, Sparsity::Node0),
            (&|_, _| true, Sparsity::Full),
        ];
        for (keep, pattern) in patterns {
            for _ in 0..200 {
                let a = Mat6::from_fn(|i, j| if keep(i, j) { next() } else { 0.0 });
                let v = Vec6::from_fn(|_, _| next());
                assert_eq!(Sparsity::of(&a), pattern);
                let (x, y) = (mul6(&a, pattern, &SplitMat::of(&a), &v), a * v);
                for i in 0..6 {
                    assert!(
                        x[i] == y[i] && (x[i] != 0.0 || y[i] == 0.0),
                        "{pattern:?} row {i}: {} {}",
                        x[i],
                        y[i]
                    );
                    if x[i] != 0.0 {
                        assert_eq!(x[i].to_bits(), y[i].to_bits());
                    }
                }
            }
        }
        // a split matrix with one coupling entry is full
        let mut a = Mat6::identity();
        a[(0, 1)] = 1e-300;
        assert_eq!(Sparsity::of(&a), Sparsity::Full);
    }

    #[test]
    fn a_smooth_acceleration_is_extrapolated() {
        // a(t) = t: from the third step on the extrapolation is exact, a_n alone is off by h
        let h = 1e-3;
        let (firsts, verdicts) = run(|t| t, h, 6);
        for (k, &f) in firsts.iter().enumerate().skip(2) {
            let exact = (k + 1) as f64 * h;
            assert!((f - exact).abs() < 1e-15, "step {k}: {f} for {exact}");
        }
        assert!(verdicts[1..].iter().all(|&b| b));
    }

    #[test]
    fn an_alternating_acceleration_starts_from_a_n() {
        // a(t) flips sign every step (a mode at the step's Nyquist frequency): extrapolating
        // would triple the error, so after the first verdict every step starts from a_n
        let h = 1e-3;
        let (firsts, verdicts) = run(|t| if ((t / h).round() as i64) % 2 == 0 { 1.0 } else { -1.0 }, h, 8);
        assert!(!verdicts[1]);
        for (k, &f) in firsts.iter().enumerate().skip(2) {
            let a_n = if k % 2 == 0 { 1.0 } else { -1.0 };
            assert_eq!(f, a_n, "step {k}");
        }
    }

    #[test]
    fn changed_accelerations_or_a_long_step_start_from_a_n() {
        let h = 1e-3;
        let mut ex = Extrapolation::new(2);
        ex.start(0.0, h, &[0.0, 0.0]);
        ex.converged(0.0, h, &[0.0, 0.0], &[1.0, 2.0]);
        // a restart at the step's end changed one acceleration: not the step that ended here
        assert_eq!(ex.start(h, h, &[1.0, 2.5]), 0.0);
        // another start time
        assert_eq!(ex.start(2.0 * h, h, &[1.0, 2.0]), 0.0);
        // more than EXTRAPOLATION_MAX_RATIO times longer
        assert_eq!(ex.start(h, 2.5 * h, &[1.0, 2.0]), 0.0);
        // the step that ended here, twice as long (an adaptive level up): w = 2
        assert_eq!(ex.start(h, EXTRAPOLATION_MAX_RATIO * h, &[1.0, 2.0]), 2.0);
        // a grid time k dt that differs from t + h by rounding still counts as the end
        assert_eq!(ex.start(h * (1.0 + 1e-14), h, &[1.0, 2.0]), 1.0);
    }
}
