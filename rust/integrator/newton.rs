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
//!
//! Where the parts live (one file each under `newton/`):
//! - `rate.rs`: the contact-free factor and the clearance joints' terms on it by Woodbury;
//! - `step.rs`: one Newmark step, its Newton iterations, stopping rules and fallbacks;
//! - `residual.rs`: the residual at an iterate (element, inertia, joint and friction forces);
//! - `jacobian.rs`: when the Jacobian changed, its assembly into the band, its factorization;
//! - `joints.rs`: the clearance joints' kinematics from the unknowns and their contact terms;
//! - `friction.rs`: friction in clearance joints;
//! - `tracking.rs`: what each step hands the record (joints, sliders, links);
//! - `event_cuts.rs` and `adaptive_steps.rs`: steps cut at contact events, and `tol=` runs;
//! - `continuous.rs`: the continuous-contact joints (bordered constraints);
//! - `element_lanes.rs`: the element forces of a run of plain elements in SIMD lanes;
//! - `state_update.rs`: the predictor and the correction over the unknowns (scalar and AVX2).

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

mod adaptive_steps;
mod continuous;
mod element_lanes;
mod event_cuts;
mod friction;
mod jacobian;
mod joints;
mod rate;
mod residual;
mod state_update;
mod step;
mod tracking;

use rate::RateSolver;

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
/// below [`CONTRACTION_STOP`] and `NewtonRun::carried_rate_margin` allows it: every joint's
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

/// Contact-free factors of other step sizes that the Newton stepper keeps besides the one in use
/// (adaptive steps and event cuts change the step; `NewtonRun::rate_prepare`): a step of a size
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
    /// and another link's or fixed axes): only such a joint can be [`JointRows::split`](rate::JointRows::split).
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
    /// they turn at different rates ([`JointRows::split`](rate::JointRows::split)) it is `P^T (G P + H V)`
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
