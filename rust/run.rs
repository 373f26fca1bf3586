//! A run: its settings, its output, and the [`simulate`] entry point.

use crate::contact::Coupling;
use crate::error::{check_positive, Error, Result};
use crate::integrator::{Newmark, NewmarkRun};
use crate::linalg::AnalysisCache;
use crate::plan::translating::Model;
use crate::record::{RecordSpec, Recorder};

/// How the effective matrix with contact terms is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SolverMode {
    /// Contact-free factorization plus a Sherman-Morrison-Woodbury correction on the joints'
    /// DOFs; falls back to a numeric refactorization for a step whose small capacitance matrix is
    /// ill-conditioned (pivot ratio below 1e-12).
    #[default]
    Woodbury,
    /// Numeric refactorization (symbolic analysis reused) whenever the contact terms change.
    Refactor,
}

/// Settings of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// End time, s (> 0).
    pub t_end: f64,
    /// Time step, s (> 0, at most `t_end`).
    pub dt: f64,
    /// The time integration scheme: Newmark (beta, gamma) or a member of the generalized-alpha
    /// family (Chung-Hulbert, HHT: [`Newmark::generalized_alpha`], [`Newmark::hht`]).
    pub newmark: Newmark,
    /// How contact enters the step.
    pub coupling: Coupling,
    /// How the effective matrix is solved.
    pub solver: SolverMode,
    /// A translational DOF beyond this magnitude (m) means divergence; `None` = 10 x the longest
    /// link.
    pub divergence_limit: Option<f64>,
    /// What to record.
    pub record: RecordSpec,
    /// Event-aware stepping: a step that changes a joint's contact status (open/closed) is redone
    /// as two substeps cut at the located crossing, with the acceleration restarted there (see
    /// [`crate::integrator::constant`]). Output stays on the `dt` grid. Such runs do not share
    /// a lockstep factorization.
    pub events: bool,
    /// Step iterations of the moving-frame (Newton) stepper.
    pub newton: NewtonSettings,
    /// The stepper to use for a [`crate::model::mechanism::Mechanism`]; `None` = chosen from
    /// the model ([`crate::plan::Plan::compile`]).
    pub stepper: Option<crate::plan::StepperKind>,
    /// Adaptive steps with local error control (`None` = the fixed step `dt`). `dt` is then the
    /// output grid (steps may span several of its instants, whose states are interpolated:
    /// [`Adaptive::h_max`]); the constant stepper runs such a model where it can
    /// ([`crate::integrator::constant`], "Adaptive steps": one lane, factorizations of recent step
    /// sizes cached), else the Newton stepper ([`crate::integrator::newton`], "Adaptive steps").
    pub adaptive: Option<Adaptive>,
}

/// Local error control of adaptive steps: a step is accepted when the Zienkiewicz-Xie estimate
/// of its local displacement error, `|beta - 1/6| h^2 |a_(n+1) - a_n|` per unknown, is at most
/// `atol + rtol |y|` for every unknown (m for translations, rad for rotations and the same
/// number as a tolerance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Relative local error tolerance (> 0).
    pub rtol: f64,
    /// Absolute local error tolerance, m (> 0).
    pub atol: f64,
    /// Shortest step, s (> 0, at most `dt`): a step that fails the error test or does not
    /// converge at this length is accepted (counted in `RunStats::floor_steps`) or, when its
    /// iterations did not converge, fails the run.
    pub h_min: f64,
    /// Longest step, s (at least `h_min`; finite). Steps are `h_max / 2^m`; one longer than
    /// the output grid's `dt` spans output instants, whose states are interpolated (cubic
    /// Hermite displacements, linear accelerations: `integrator/adaptive.rs`,
    /// `interpolate_state`), as SciPy's `solve_ivp` does with its `max_step`.
    pub h_max: f64,
}

/// The local error tolerance of a run asked for a relative accuracy `tol` is
/// `(tol / TOL_GLOBAL)^1.5`: Newmark's global error goes as the local tolerance to the power 2/3,
/// and on the impact oscillator of `tests/test_adaptive.py` (an exact solution) the trajectory
/// error at 2 s was 4.6 times the local tolerance to the 2/3 over local tolerances 1e-8 to 1e-6;
/// 10 leaves a factor of about 2 (a calibration on that one problem; the accuracy report checks
/// other measures per scene).
pub const TOL_GLOBAL: f64 = 10.0;

/// The Newton tolerance of a tolerance-driven run ([`Adaptive::newton_tol`]) as a fraction of
/// its relative local tolerance `rtol`: a step's iterations stop when their displacement error
/// is a tenth of what the step's error test allows (the nonlinear-solver share of SUNDIALS'
/// integrators), instead of the fixed-step default 1e-8 of the displacement scale. Measured
/// over one crank turn of the slider-crank with a crank-pin clearance at `tol` 3e-2 and 1e-2,
/// and on the Flores slider-crank: the peak contact force and penetration moved by at most 8e-8
/// (relative) against iterations to 1e-9, while the iterations fell by 17 to 30 % (before the
/// carried contraction rate, `integrator::newton::RATE_CARRY_DOWN`, which stops most steps after
/// one correction: since, the peaks of such runs differ from those of iterations to 1e-10 by
/// what their different steps sample, up to a tenth of `tol` in the force's spike).
pub const NEWTON_TOL_OF_LOCAL: f64 = 0.1;

/// The default longest adaptive step in output steps: [`Adaptive::default_max_step`] is `dt`
/// times this or the whole run, whichever is shorter.
pub const DEFAULT_MAX_STEP_OUTPUTS: f64 = 1e12;

impl Adaptive {
    /// The adaptive settings for a relative accuracy `tol` in (0, 1) with output grid `dt` (s)
    /// on a model whose clearance joints have the radial clearances `clearances` (m):
    /// `rtol = (tol / TOL_GLOBAL)^1.5`, `atol = rtol` times the smallest positive clearance
    /// (1 mm without one), `h_min = max(dt / 2^30, 1e-14 s)`, longest step `h_max` (s). Fails
    /// with [`Error::InvalidParameter`] naming `tol` outside (0, 1) or `max_step` not finite and
    /// positive.
    pub fn for_tolerance(tol: f64, clearances: impl IntoIterator<Item = f64>, dt: f64, h_max: f64) -> Result<Adaptive> {
        if !(tol > 0.0 && tol < 1.0) {
            return Err(Error::param("tol", tol, "a relative accuracy in (0, 1), e.g. 1e-3"));
        }
        check_positive("max_step", h_max, "s")?;
        let local = (tol / TOL_GLOBAL).powf(1.5);
        let scale = clearances
            .into_iter()
            .filter(|c| *c > 0.0)
            .fold(f64::INFINITY, f64::min);
        let scale = if scale.is_finite() { scale } else { 1e-3 };
        Ok(Adaptive {
            rtol: local,
            atol: local * scale,
            h_min: (dt * 2f64.powi(-30)).max(1e-14).min(h_max),
            h_max,
        })
    }

    /// The Newton tolerance (relative correction of the displacement scale) of a run with these
    /// local tolerances when none is asked for: [`NEWTON_TOL_OF_LOCAL`] times `rtol`, and never
    /// tighter than the fixed-step `default` (so a tolerance whose local test is finer than it
    /// iterates as a fixed-step run does).
    pub fn newton_tol(&self, default: f64) -> f64 {
        default.max(NEWTON_TOL_OF_LOCAL * self.rtol)
    }

    /// The longest step of a run of `t_end` (s) with output grid `dt` (s) when none is asked for
    /// (`max_step=None`): see [`DEFAULT_MAX_STEP_OUTPUTS`].
    pub fn default_max_step(t_end: f64, dt: f64) -> f64 {
        let steps = (t_end / dt).round().max(1.0);
        dt * steps.min(DEFAULT_MAX_STEP_OUTPUTS)
    }

    fn validate(&self, dt: f64) -> Result<()> {
        check_positive("rtol", self.rtol, "(relative)")?;
        check_positive("atol", self.atol, "m")?;
        check_positive("h_min", self.h_min, "s")?;
        if self.h_min > dt {
            return Err(Error::param("h_min", self.h_min, format!("<= dt = {dt} s")));
        }
        check_positive("max_step", self.h_max, "s")?;
        if self.h_max < self.h_min {
            return Err(Error::param(
                "max_step",
                self.h_max,
                format!(">= h_min = {} s", self.h_min),
            ));
        }
        Ok(())
    }
}

/// Iterations of a step of the moving-frame (Newton) stepper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Relative tolerance: displacement correction over the displacement scale (> 0). A step
    /// has converged when its last correction is within it, or when the error its corrections'
    /// contraction leaves is (`integrator::newton::CONTRACTION_STOP`).
    pub tol: f64,
    /// Iteration cap per step (>= 1).
    pub max_iter: usize,
    /// How many times a step that does not converge may be halved (0 ..= 20; 0 = fail at once
    /// with [`Error::NotConverged`]).
    pub step_halving: u32,
    /// The most steps the moving-frame (Newton) stepper solves with one factorization of its
    /// Jacobian without the contact terms (0 or 1: a new one every step). The Jacobian moves
    /// slowly from step to step (the frames' rates and the axial forces of the geometric terms),
    /// so an older factor still converges, to the same `tol`, in about as many iterations; it
    /// is refactorized at once when the step size changes, when a step needed more than
    /// [`JACOBIAN_REUSE_ITERATIONS`] iterations, or, within a step, at the iteration after that.
    pub jacobian_age: u32,
    /// In a fixed-step run, a step's iterations also stop once the error they leave is within
    /// this fraction of the step's own local truncation error, where that is the larger: the
    /// Zienkiewicz-Xie estimate `|beta - 1/6| h^2 max|a_(n+1) - a_n|` over the displacement
    /// scale, at the current iterate, in place of `tol` in every stopping test (0 = `tol` alone;
    /// in `[0, 1)`), and never above [`TRUNCATION_TOL_MAX`]. The Newton iteration then solves
    /// each step's equations only as far as the step itself is accurate. Not used by adaptive
    /// steps (whose `tol` is already tied to their local tolerance, [`Adaptive::newton_tol`]).
    /// Default [`TRUNCATION_FRACTION`].
    pub truncation_fraction: f64,
}

/// The default [`NewtonSettings::truncation_fraction`]: a step's iterations stop once they leave
/// 1 % of its local truncation error (or `tol`, where that is larger). Measured on Simeon's
/// slider-crank, dt 1e-5 s, 0.1 s, against iterating to `tol` = 1e-8 alone: ideal pins 1.81 ->
/// 1.04 iterations a step (`examples/profile_newton`: 178.5 -> 133.4 M instructions), clearance
/// at the crank pin 1.35 -> 1.20 (209.6 -> 203.1 M). Over 0.02 s the rod's midspan moved by
/// 0.6 % (ideal pins) and 6e-5 (crank pin) of the step's own discretization error (the strict
/// run's difference to dt/2); the crank pin's peak contact force by 7e-10 relative. At dt 1e-6 the
/// truncation error is below `tol` almost everywhere and the iterations are those of `tol`.
pub const TRUNCATION_FRACTION: f64 = 0.01;

/// Largest iteration cap a step may be given (`max_iter` of Newton and of the contact
/// iteration). The iterations converge within tens or cycle for good (a contact status that
/// keeps switching): a cap beyond this only makes such a run last hours (a fuzzed gap-element
/// run asked for 1e7 a step: 782 steps, about 55 minutes).
pub const MAX_ITER: usize = 10_000;

/// An iteration cap, Newton's or a contact coupling's: `1 ..= MAX_ITER`, else
/// [`Error::InvalidParameter`] naming `max_iter`.
pub(crate) fn check_max_iter(max_iter: usize) -> Result<()> {
    if (1..=MAX_ITER).contains(&max_iter) {
        Ok(())
    } else {
        Err(Error::param(
            "max_iter",
            max_iter,
            format!("an integer in 1 ..= {MAX_ITER}"),
        ))
    }
}

/// The largest Newton tolerance (relative correction) that [`NewtonSettings::truncation_fraction`]
/// may relax a fixed step's to. The Zienkiewicz-Xie estimate speaks for the modes a step
/// resolves; modes far above `1 / h` (a stiff rod's) inflate it without making the step less
/// accurate where it matters, and an iteration stopped at such a level drifts: Simeon's
/// slider-crank with E = 2e15 Pa at dt 1e-5 s failed to converge at t = 2.4 ms without this
/// bound, and runs at any fixed tolerance from 1e-8 to 1e-5.
pub const TRUNCATION_TOL_MAX: f64 = 1e-6;

/// The default [`NewtonSettings::jacobian_age`], in steps (of any size): the bound of SUNDIALS'
/// CVODE between two setups of its Newton matrix. A step that takes more than
/// [`JACOBIAN_REUSE_ITERATIONS`] iterations on an old factor refactorizes at once, so the bound
/// only caps how far the frames and axial forces move from the factor's. Measured on Simeon's
/// slider-crank at dt 1e-5 s, 0.1 s (`examples/profile_newton`, iterated to 1e-10, callgrind),
/// against an age of 8: ideal pins 1251 -> 501 factorizations, 1.040 -> 1.070 iterations a step,
/// 125.3 -> 112.8 M instructions; clearance at the crank pin 1275 -> 531, 1.134 -> 1.178, 188.0 ->
/// 172.5 M.
/// Tolerance-driven runs: crank pin at `tol` 3e-2 (one crank turn) factorizations 1404 -> 1106
/// against 8, at 1e-2 2373 -> 1793, instructions -7 %.
pub const JACOBIAN_AGE: u32 = 20;

/// The iterations a step may take on a reused Jacobian factor ([`NewtonSettings::jacobian_age`])
/// before it is refactorized at the current iterate (and the next step starts on a new one).
pub const JACOBIAN_REUSE_ITERATIONS: usize = 3;

impl Default for NewtonSettings {
    /// Tolerance 1e-8 (or 1 % of a fixed step's truncation error, [`TRUNCATION_FRACTION`]), 25
    /// iterations, no halving, a Jacobian factor kept for up to [`JACOBIAN_AGE`] steps.
    fn default() -> Self {
        NewtonSettings {
            tol: 1e-8,
            max_iter: 25,
            step_halving: 0,
            jacobian_age: JACOBIAN_AGE,
            truncation_fraction: TRUNCATION_FRACTION,
        }
    }
}

impl NewtonSettings {
    /// The defaults with the iteration tolerance `tol` where one is given, met as given (no
    /// [`Self::truncation_fraction`]); without one, the default tolerance, at which a fixed step
    /// also stops at [`TRUNCATION_FRACTION`] of its truncation error. The rule of
    /// `Model.simulate`, of the batch path and of `_core.Mechanism.simulate`.
    pub fn with_tol(tol: Option<f64>) -> Self {
        match tol {
            Some(tol) => NewtonSettings {
                tol,
                truncation_fraction: 0.0,
                ..NewtonSettings::default()
            },
            None => NewtonSettings::default(),
        }
    }

    fn validate(&self) -> Result<()> {
        check_positive("tol", self.tol, "(relative)")?;
        check_max_iter(self.max_iter)?;
        let f = self.truncation_fraction;
        if !(f.is_finite() && (0.0..1.0).contains(&f)) {
            return Err(Error::param("truncation_fraction", f, "in [0, 1)"));
        }
        if self.step_halving > 20 {
            return Err(Error::param("step_halving", self.step_halving, "0 ..= 20"));
        }
        Ok(())
    }
}

impl Settings {
    /// Default settings for `t_end` and `dt` (s): average-acceleration Newmark, the modified
    /// method with lagged kappa, Woodbury solves, full recording.
    pub fn new(t_end: f64, dt: f64) -> Self {
        Settings {
            t_end,
            dt,
            newmark: Newmark::default(),
            coupling: Coupling::default(),
            solver: SolverMode::default(),
            divergence_limit: None,
            record: RecordSpec::default(),
            events: false,
            newton: NewtonSettings::default(),
            stepper: None,
            adaptive: None,
        }
    }

    /// Checks what does not depend on the model: the time grid (at most 1e12 steps), the
    /// Newmark parameters, the coupling, the divergence limit and the Newton settings.
    pub fn validate_run(&self) -> Result<()> {
        check_positive("t_end", self.t_end, "s")?;
        check_positive("dt", self.dt, "s")?;
        if self.dt > self.t_end {
            return Err(Error::param("dt", self.dt, format!("<= t_end = {} s", self.t_end)));
        }
        let steps = (self.t_end / self.dt).round();
        if steps > 1e12 {
            return Err(Error::param(
                "dt",
                self.dt,
                format!("at least t_end/1e12 = {:e} s (at most 1e12 steps)", self.t_end / 1e12),
            ));
        }
        self.newmark.validate()?;
        self.coupling.validate()?;
        if let Some(l) = self.divergence_limit {
            check_positive("divergence_limit", l, "m")?;
        }
        if let Some(a) = &self.adaptive {
            a.validate(self.dt)?;
        }
        self.newton.validate()
    }

    /// Checks the settings against a model of the constant stepper.
    pub fn validate(&self, model: &Model) -> Result<()> {
        self.validate_run()?;
        if self.coupling == Coupling::Continuous && !model.joints.is_empty() {
            return Err(Error::param(
                "stepper",
                "\"constant\"",
                "\"newton\" or None with method=\"continuous\" (the continuous-contact model runs on the Newton stepper)",
            ));
        }
        let nodes: Vec<usize> = model.links.iter().map(|l| l.section.elements + 1).collect();
        self.record.validate(model.joints.len(), &nodes)?;
        for (i, l) in model.links.iter().enumerate() {
            if let crate::model::Motion::Tabulated(t) = &l.motion {
                check_table(&format!("links[{i}].motion"), t, self.t_end)?;
            }
        }
        for (i, b) in model.bodies.iter().enumerate() {
            if let crate::model::Motion::Tabulated(t) = &b.motion {
                check_table(&format!("bodies[{i}].motion"), t, self.t_end)?;
            }
        }
        Ok(())
    }

    /// Number of steps, `round(t_end / dt)`.
    pub fn steps(&self) -> u64 {
        (self.t_end / self.dt).round().max(1.0) as u64
    }
}

fn check_table(name: &str, t: &crate::model::Table, t_end: f64) -> Result<()> {
    if t.start_time() > 0.0 || t.end_time() < t_end {
        return Err(Error::param(
            format!("{name}.time"),
            format!("[{}, {}] s", t.start_time(), t.end_time()),
            format!("a table covering [0, t_end = {t_end}] s"),
        ));
    }
    Ok(())
}

/// Counters of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunStats {
    /// Steps completed.
    pub steps: u64,
    /// Numeric factorizations of an effective matrix (the contact-free one included).
    pub factorizations: u64,
    /// Steps solved with the Woodbury correction while some contact was closed.
    pub woodbury_steps: u64,
    /// Steps where the Woodbury capacitance was ill-conditioned and a refactorization was used,
    /// and Newton steps redone refactorizing after they did not converge on the contact-free
    /// factor.
    pub woodbury_fallbacks: u64,
    /// Coupling iterations in all (1 per step without iteration).
    pub iterations: u64,
    /// Largest number of iterations in one step.
    pub max_iterations: u64,
    /// Steps that hit the iteration cap without converging.
    pub unconverged_steps: u64,
    /// Event-aware stepping: steps redone as two substeps cut at a contact status change.
    pub event_steps: u64,
    /// Terms active in the equations, in words.
    pub terms: Vec<String>,
    /// Which stepper ran: `"constant"` (one factorization of a constant effective matrix,
    /// contact by Woodbury) or `"newton"` (moving frames: Newton iterations, the Jacobian
    /// refactorized when it changes).
    pub stepper: &'static str,
    /// Newton stepper: substeps taken by step halving.
    pub halved_substeps: u64,
    /// Newton stepper: steps accepted at the round-off floor, where the correction stalled
    /// below [`crate::integrator::newton::ROUNDOFF_FLOOR`] but above the asked tolerance (a
    /// tolerance finer than the arithmetic of that system can deliver).
    pub roundoff_steps: u64,
    /// Newton stepper: event steps kept whole because a substep did not converge where the
    /// whole step did.
    pub event_fallbacks: u64,
    /// Number of unknowns (0 where the stepper does not report it).
    pub unknowns: usize,
    /// Half-bandwidth of the Newton Jacobian (0 for the constant stepper).
    pub bandwidth: usize,
    /// Adaptive steps: steps accepted (substeps of the output grid, event cuts included).
    pub adaptive_steps: u64,
    /// Adaptive steps: steps rejected by the error test or redone shorter after their
    /// iterations did not converge.
    pub rejected_steps: u64,
    /// Adaptive steps: steps accepted at the shortest step `h_min` although their error
    /// estimate exceeded the tolerance.
    pub floor_steps: u64,
    /// Adaptive steps: the shortest and longest accepted step, s (0 without adaptive steps).
    pub min_step: f64,
    /// See `min_step`.
    pub max_step: f64,
    /// Adaptive steps: the achieved-accuracy estimate of the trajectory, relative to the
    /// largest displacement (`local_error_sum / largest_displacement`; 0 without adaptive
    /// steps). See `integrator/adaptive.rs`, `count_step`.
    pub error_estimate: f64,
    /// Adaptive steps: the achieved-accuracy estimate of the largest contact force, relative,
    /// the largest over the clearance joints (0 without contact or adaptive steps). See
    /// `integrator/adaptive.rs`, `ForceErrors`.
    pub peak_force_error_estimate: f64,
    /// Adaptive steps: the sum over the accepted steps of the largest Zienkiewicz-Xie local
    /// displacement error over the unknowns, m (rad for rotations).
    pub local_error_sum: f64,
    /// Adaptive steps: the largest `|y|` of any unknown at the end of an accepted step, m (rad
    /// for rotations).
    pub largest_displacement: f64,
}

/// What a run produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunOutput {
    /// Recorded histories and extremes.
    pub record: Recorder,
    /// Counters.
    pub stats: RunStats,
    /// Final displacement, velocity and acceleration (global DOFs). After a failure inside a
    /// step (a contact matrix that is not positive definite), displacement and velocity are that
    /// step's Newmark predictors.
    pub state: [Vec<f64>; 3],
    /// Time reached, s.
    pub time: f64,
}

/// A run that stopped early: why, and what it had recorded until then.
#[derive(Debug, Clone, PartialEq)]
pub struct RunFailure {
    /// Why the run stopped.
    pub error: Error,
    /// Everything recorded until then.
    pub output: RunOutput,
}

impl RunFailure {
    /// A run that failed before its first step (invalid input, a singular mass matrix): nothing
    /// recorded.
    pub fn before_start(error: Error) -> Box<RunFailure> {
        Box::new(RunFailure {
            error,
            output: RunOutput::default(),
        })
    }
}

/// Runs the translating `model` (the constant stepper's compiled input,
/// [`crate::plan::translating`]; models are run through [`crate::plan::simulate`], which derives
/// it) with `settings`. `control(fraction_done)` is called every few thousand steps and
/// stops the run (as [`Error::Interrupted`]) when it returns `false`.
///
/// Errors before the first step (invalid input, a mass matrix that is not positive definite) come
/// with an empty output.
pub fn simulate(
    model: &Model,
    settings: &Settings,
    control: &mut dyn FnMut(f64) -> bool,
) -> std::result::Result<RunOutput, Box<RunFailure>> {
    simulate_shared(model, settings, None, control)
}

/// As [`simulate`], taking the symbolic factorization from `cache` (shared among runs of models
/// with the same sparsity pattern, as in [`crate::batch::run_batch`]).
pub fn simulate_shared(
    model: &Model,
    settings: &Settings,
    cache: Option<&AnalysisCache>,
    control: &mut dyn FnMut(f64) -> bool,
) -> std::result::Result<RunOutput, Box<RunFailure>> {
    let fail = RunFailure::before_start;
    model.validate().map_err(fail)?;
    settings.validate(model).map_err(fail)?;
    let run = NewmarkRun::with_analysis(model, settings, cache).map_err(fail)?;
    run.run(control)
}
