//! Bindings of the batch: many samples of mechanisms in parallel, each planned as
//! `Mechanism.simulate` plans it: lockstep lanes for those the constant stepper runs, one lane
//! each for the others (see `flexclear.study`).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use super::output::{extremes_objects, joint_histories};
use super::{err, mechanism, parse_coupling, parse_solver};
use crate::batch::{run_batch as run_batch_core, BatchOptions, Retry, SampleOutcome};
use crate::error::Error;
use crate::integrator::Newmark;
use crate::model::mechanism::Mechanism;
use crate::plan::{Plan, StepperKind};
use crate::record::{LinkChannels, LinkHistory, RecordSpec};
use crate::run::{NewtonSettings, Settings};

/// A count given from Python as `i64`. Only negative values are refused here; zero is reported by
/// the engine's own validation, which names the same range.
fn count_at_least_1(py: Python<'_>, name: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| err(py, Error::param(name, v, "an integer >= 1")))
}

/// The settings `run_batch` shares among its samples, as given.
struct Shared<'a> {
    method: &'a str,
    iterate: Option<bool>,
    tol: Option<f64>,
    max_iter: Option<usize>,
    step_halving: u32,
    gap_stiffness: Option<f64>,
    gap_damping: f64,
    beta: f64,
    gamma: f64,
    alpha_m: f64,
    alpha_f: f64,
    solver: &'a str,
    divergence_limit: Option<f64>,
    record: RecordSpec,
    events: bool,
    /// Relative accuracy of adaptive runs (`Study(tol=...)`), `None` for the fixed step.
    accuracy: Option<f64>,
    /// Longest adaptive step, s (`None`: `Adaptive::default_max_step`).
    max_step: Option<f64>,
}

/// The settings of one sample, resolved as `flexclear.Model.simulate` resolves them for the
/// stepper the plan picks: on the constant stepper `iterate` defaults to off and `tol`,
/// `max_iter` are the contact iteration's (1e-10, 50); otherwise `iterate` defaults to on where
/// a clearance joint sits on a rotating link or body (method "modified"), `tol`, `max_iter` are
/// Newton's (1e-8, 25) and the contact iteration keeps 1e-10, 50.
fn sample_settings(py: Python<'_>, mech: &Mechanism, t_end: f64, dt: f64, c: &Shared<'_>) -> PyResult<Settings> {
    let rotating = || {
        let rotates = |e: &crate::model::mechanism::Endpoint| match e {
            crate::model::mechanism::Endpoint::Node { link, .. } => {
                mech.links.get(*link).is_some_and(|l| l.frame.rotates())
            }
            crate::model::mechanism::Endpoint::Body { frame, .. } => frame.rotates(),
            crate::model::mechanism::Endpoint::Slider(_) => false,
        };
        mech.joints.iter().any(|j| rotates(&j.journal) || rotates(&j.bearing))
    };
    let coupling = |iterate: bool, tol: f64, max_iter: usize| {
        parse_coupling(py, c.method, iterate, tol, max_iter, c.gap_stiffness, c.gap_damping)
    };
    let mut settings = Settings {
        newmark: Newmark {
            beta: c.beta,
            gamma: c.gamma,
            alpha_m: c.alpha_m,
            alpha_f: c.alpha_f,
        },
        coupling: coupling(false, 1e-10, 50)?,
        solver: parse_solver(py, c.solver)?,
        divergence_limit: c.divergence_limit,
        record: c.record.clone(),
        events: c.events,
        newton: NewtonSettings {
            max_iter: c.max_iter.unwrap_or(25),
            step_halving: c.step_halving,
            ..NewtonSettings::with_tol(c.tol)
        },
        stepper: None,
        ..Settings::new(t_end, dt)
    };
    if let Some(tol) = c.accuracy {
        // a tolerance: adaptive steps (the plan's stepper) with implicit contact (`Model.simulate(tol=)`)
        let clearances = mech.joints.iter().map(|j| j.clearance);
        let h_max = c
            .max_step
            .unwrap_or_else(|| crate::run::Adaptive::default_max_step(t_end, dt));
        let adaptive = crate::run::Adaptive::for_tolerance(tol, clearances, dt, h_max).map_err(|e| err(py, e))?;
        if c.tol.is_none() {
            // Newton iterates to a tenth of the step's error test (`Model.simulate(tol=)` alike)
            settings.newton.tol = adaptive.newton_tol(settings.newton.tol);
        }
        settings.adaptive = Some(adaptive);
        settings.coupling = coupling(true, 1e-10, 50)?;
        return Ok(settings);
    }
    let constant = matches!(Plan::compile(mech, &settings), Ok(p) if p.kind == StepperKind::Constant);
    settings.coupling = if constant {
        coupling(
            c.iterate.unwrap_or(false),
            c.tol.unwrap_or(1e-10),
            c.max_iter.unwrap_or(50),
        )?
    } else {
        let iterate = c.iterate.unwrap_or_else(|| c.method == "modified" && rotating());
        coupling(iterate, 1e-10, 50)?
    };
    Ok(settings)
}

/// One sample's outcome as a dict: `status` ("ok", "diverged", "unconverged", "invalid",
/// "singular", "interrupted", "not_run"), `message`, `dt`, `retries`, `wall_time`, `steps`, `t`,
/// `extremes` (per joint), `joints` (histories, when recorded) and `links` (per link, its running
/// peaks `(max_midspan m, max_axial_force N)`, NaN unless `link_peaks`, and for a rigid link).
fn outcome_dict(py: Python<'_>, o: SampleOutcome) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("dt", o.dt)?;
    d.set_item("retries", o.retries)?;
    d.set_item("wall_time", o.wall_time)?;
    let (status, message, out) = match o.result {
        None => (
            "not_run",
            String::from("the batch was stopped before this sample started"),
            None,
        ),
        Some(Ok(out)) => ("ok", String::new(), Some(out)),
        Some(Err(f)) => {
            let status = match f.error {
                Error::InvalidParameter { .. } | Error::InvalidModel { .. } => "invalid",
                Error::Diverged { .. } => "diverged",
                Error::NotConverged { .. } => "unconverged",
                Error::Singular { .. } => "singular",
                Error::Interrupted { .. } => "interrupted",
            };
            (status, f.error.to_string(), Some(f.output))
        }
    };
    d.set_item("status", status)?;
    d.set_item("message", message)?;
    let out = out.unwrap_or_default();
    d.set_item("steps", out.stats.steps)?;
    d.set_item("t", out.time)?;
    d.set_item("extremes", extremes_objects(py, &out.record.extremes)?)?;
    let rec = out.record;
    d.set_item("time", PyArray1::from_vec(py, rec.time))?;
    d.set_item("joints", joint_histories(py, rec.joints)?)?;
    let peaks: Vec<[f64; 2]> = rec.links.iter().map(LinkHistory::peak_values).collect();
    d.set_item("links", peaks)?;
    Ok(d)
}

/// The mechanism of batch sample `i`; any other object is refused naming `models[i]`.
fn batch_model(py: Python<'_>, i: usize, m: &Bound<'_, PyAny>) -> PyResult<Mechanism> {
    match m.extract::<PyRef<'_, mechanism::PyMechanism>>() {
        Ok(mech) => Ok(mech.inner.clone()),
        Err(_) => {
            let shown = m.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
            Err(err(py, Error::param(format!("models[{i}]"), shown, "a Mechanism")))
        }
    }
}

/// Runs many samples in parallel (see `flexclear.study`). `models[i]` runs to `t_end[i]` with
/// step `dt[i]` on the stepper its plan picks (the outcome of a sample that needs Newton is that
/// of its single run; see `crate::batch`); the other settings are shared, `iterate`, `tol` and
/// `max_iter` resolved per sample as `Model.simulate` resolves them (None = that stepper's
/// default). A sample that fails, before or during its run, is an outcome (`status`), not an
/// exception. Returns `(outcomes, stats, pending)`: one dict
/// per sample in input order, the batch counters, and the exception that stopped the batch
/// (KeyboardInterrupt or one raised by `progress`), else None. The GIL is released throughout;
/// `progress(done)` is called from the calling thread as samples finish. `joint_position` also
/// keeps the journal positions (`qx`, `qy`, m) in the joint histories (the orbit of a study);
/// `contact_modes` tracks the contact-mode fractions and the dissipated energy; `link_peaks` each
/// flexible link's peak midspan deflection and axial force (such a sample runs on the Newton
/// stepper).
#[pyfunction]
#[pyo3(signature = (models, t_end, dt, *, threads=0, lanes=0, retries=0, retry_factor=0.5, method="modified", iterate=None,
                    tol=None, max_iter=None, step_halving=0, gap_stiffness=None, gap_damping=0.0, beta=0.25, gamma=0.5,
                    alpha_m=0.0, alpha_f=0.0,
                    solver="woodbury", divergence_limit=None, joints=None, every=1, histories=false, start=0.0,
                    progress=None, events=false, joint_position=false,
                    contact_modes=false, accuracy=None, max_step=None, link_peaks=false))]
#[allow(clippy::too_many_arguments)]
pub(super) fn run_batch<'py>(
    py: Python<'py>,
    models: Vec<Bound<'py, PyAny>>,
    t_end: Vec<f64>,
    dt: Vec<f64>,
    threads: i64,
    lanes: i64,
    retries: i64,
    retry_factor: f64,
    method: &str,
    iterate: Option<bool>,
    tol: Option<f64>,
    max_iter: Option<i64>,
    step_halving: i64,
    gap_stiffness: Option<f64>,
    gap_damping: f64,
    beta: f64,
    gamma: f64,
    alpha_m: f64,
    alpha_f: f64,
    solver: &str,
    divergence_limit: Option<f64>,
    joints: Option<Vec<usize>>,
    every: i64,
    histories: bool,
    start: f64,
    progress: Option<Py<PyAny>>,
    events: bool,
    joint_position: bool,
    contact_modes: bool,
    accuracy: Option<f64>,
    max_step: Option<f64>,
    link_peaks: bool,
) -> PyResult<(Bound<'py, PyList>, Bound<'py, PyDict>, Option<PyErr>)> {
    let n = models.len();
    if t_end.len() != n || dt.len() != n {
        return Err(err(
            py,
            Error::param(
                "t_end, dt",
                format!("lengths {} and {}", t_end.len(), dt.len()),
                format!("one value per model ({n})"),
            ),
        ));
    }
    let threads = usize::try_from(threads).map_err(|_| {
        err(
            py,
            Error::param("threads", threads, "an integer >= 0 (0 = one per core)"),
        )
    })?;
    let lanes = usize::try_from(lanes).map_err(|_| {
        err(
            py,
            Error::param("lanes", lanes, "an integer in 0 ..= 8 (0 = default, 1 = no lockstep)"),
        )
    })?;
    let attempts = u32::try_from(retries).map_err(|_| err(py, Error::param("retries", retries, "an integer >= 0")))?;
    let record = RecordSpec {
        joints,
        joint_position,
        nodes: Vec::new(),
        every: count_at_least_1(py, "every", every)?,
        histories,
        start,
        impacts: false,
        // joint channels only (a sample on the Newton stepper keeps no link history), and the
        // links' running peaks when asked for
        links: LinkChannels {
            peaks: link_peaks,
            ..LinkChannels::NONE
        },
        contact_modes,
        sliders: false,
        slider_reference: None,
    };
    let max_iter = max_iter.map(|m| count_at_least_1(py, "max_iter", m)).transpose()?;
    let step_halving = u32::try_from(step_halving)
        .map_err(|_| err(py, Error::param("step_halving", step_halving, "an integer in 0 ..= 20")))?;
    let shared = Shared {
        method,
        iterate,
        tol,
        max_iter,
        step_halving,
        gap_stiffness,
        gap_damping,
        beta,
        gamma,
        alpha_m,
        alpha_f,
        solver,
        divergence_limit,
        record,
        // event-aware runs step alone (never a lockstep lane: `shares_factor` is false for them)
        events,
        accuracy,
        max_step,
    };
    let mut samples = Vec::with_capacity(n);
    for (i, m) in models.iter().enumerate() {
        let mech = batch_model(py, i, m)?;
        let settings = sample_settings(py, &mech, t_end[i], dt[i], &shared)?;
        samples.push((mech, settings));
    }
    drop(models);
    let options = BatchOptions {
        threads,
        retry: Retry {
            attempts,
            factor: retry_factor,
        },
        lanes,
    };
    let stop = AtomicBool::new(false);
    let done = AtomicUsize::new(0);
    let (result, pending) = py.detach(|| {
        let caller = std::thread::current();
        std::thread::scope(|scope| {
            let worker = scope.spawn(|| {
                let r = run_batch_core(&samples, &options, &stop, &done);
                caller.unpark();
                r
            });
            let mut pending: Option<PyErr> = None;
            let mut reported = usize::MAX;
            while !worker.is_finished() {
                std::thread::park_timeout(Duration::from_millis(50));
                if pending.is_some() {
                    continue;
                }
                Python::attach(|py| {
                    if let Err(e) = py.check_signals() {
                        stop.store(true, Ordering::Relaxed);
                        pending = Some(e);
                        return;
                    }
                    let d = done.load(Ordering::Relaxed);
                    if let (Some(cb), true) = (&progress, d != reported) {
                        reported = d;
                        if let Err(e) = cb.call1(py, (d,)) {
                            stop.store(true, Ordering::Relaxed);
                            pending = Some(e);
                        }
                    }
                });
            }
            let result = worker.join().expect("the batch thread does not panic");
            (result, pending)
        })
    });
    let (outcomes, stats) = result.map_err(|e| err(py, e))?;
    let list = PyList::empty(py);
    for o in outcomes {
        list.append(outcome_dict(py, o)?)?;
    }
    let st = PyDict::new(py);
    st.set_item("analyses", stats.analyses)?;
    st.set_item("lockstep_groups", stats.lockstep_groups)?;
    st.set_item("lockstep_samples", stats.lockstep_samples)?;
    st.set_item("threads", stats.threads)?;
    Ok((list, st, pending))
}
