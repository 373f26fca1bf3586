//! Bindings of the batch: many samples of constant-planned mechanisms in parallel, lockstep
//! lanes (see `flexclear.study`).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use super::output::{extremes_list, joint_histories};
use super::{err, mechanism, parse_coupling, parse_solver};
use crate::batch::{run_batch as run_batch_core, BatchOptions, Retry, SampleOutcome};
use crate::error::Error;
use crate::integrator::Newmark;
use crate::model::Model;
use crate::record::RecordSpec;
use crate::run::Settings;

/// A count given from Python as `i64`. Only negative values are refused here; zero is reported by
/// the engine's own validation, which names the same range.
fn count_at_least_1(py: Python<'_>, name: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| err(py, Error::param(name, v, "an integer >= 1")))
}

/// Settings of a batch run from the keyword arguments of `run_batch`.
#[allow(clippy::too_many_arguments)]
fn build_settings(
    py: Python<'_>,
    t_end: f64,
    dt: f64,
    method: &str,
    iterate: bool,
    tol: f64,
    max_iter: i64,
    gap_stiffness: Option<f64>,
    gap_damping: f64,
    beta: f64,
    gamma: f64,
    solver: &str,
    divergence_limit: Option<f64>,
    record: RecordSpec,
) -> PyResult<Settings> {
    let max_iter = count_at_least_1(py, "max_iter", max_iter)?;
    let coupling = parse_coupling(py, method, iterate, tol, max_iter, gap_stiffness, gap_damping)?;
    let solver = parse_solver(py, solver)?;
    let settings = Settings {
        t_end,
        dt,
        newmark: Newmark { beta, gamma },
        coupling,
        solver,
        divergence_limit,
        record,
        events: false,
        newton: Default::default(),
        stepper: None,
    };
    Ok(settings)
}

/// One sample's outcome as a dict: `status` ("ok", "diverged", "invalid", "singular",
/// "interrupted", "not_run"), `message`, `dt`, `retries`, `wall_time`, `steps`, `t`,
/// `extremes` (per joint) and `joints` (histories, when recorded).
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
                Error::Diverged { .. } | Error::NotConverged { .. } => "diverged",
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
    d.set_item("extremes", extremes_list(py, &out.record.extremes)?)?;
    let rec = out.record;
    d.set_item("time", PyArray1::from_vec(py, rec.time))?;
    d.set_item("joints", joint_histories(py, rec.joints)?)?;
    Ok(d)
}

/// The constant-stepper model of batch sample `i`: the translating model `plan::Plan::compile`
/// derives from a `Mechanism` it runs on the constant stepper (validated first); any other
/// object, or a mechanism that needs the Newton stepper, is refused naming `models[i]` and the
/// reason.
fn batch_model(py: Python<'_>, i: usize, m: &Bound<'_, PyAny>, t_end: f64) -> PyResult<Model> {
    let name = format!("models[{i}]");
    let Ok(mech) = m.extract::<PyRef<'_, mechanism::PyMechanism>>() else {
        let shown = m.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
        return Err(err(py, Error::param(name, shown, "a Mechanism")));
    };
    mech.inner.validate(t_end).map_err(|e| err(py, e))?;
    mech.inner.to_translating().map_err(|reason| {
        err(
            py,
            Error::param(
                name,
                "a mechanism",
                format!("a model the constant stepper runs (this one needs the Newton stepper: {reason})"),
            ),
        )
    })
}

/// Runs many samples in parallel (see `flexclear.study`). `models[i]` runs to `t_end[i]` with
/// step `dt[i]`; the other settings are shared. Returns `(outcomes, stats, pending)`: one dict
/// per sample in input order, the batch counters, and the exception that stopped the batch
/// (KeyboardInterrupt or one raised by `progress`), else None. The GIL is released throughout;
/// `progress(done)` is called from the calling thread as samples finish. `joint_position` also
/// keeps the journal positions (`qx`, `qy`, m) in the joint histories (the orbit of a study);
/// `contact_modes` tracks the contact-mode fractions and the dissipated energy.
#[pyfunction]
#[pyo3(signature = (models, t_end, dt, *, threads=0, lanes=0, retries=0, retry_factor=0.5, method="modified", iterate=false,
                    tol=1e-10, max_iter=50, gap_stiffness=None, gap_damping=0.0, beta=0.25, gamma=0.5,
                    solver="woodbury", divergence_limit=None, joints=None, every=1, histories=false, start=0.0,
                    progress=None, events=false, joint_position=false,
                    contact_modes=false))]
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
    iterate: bool,
    tol: f64,
    max_iter: i64,
    gap_stiffness: Option<f64>,
    gap_damping: f64,
    beta: f64,
    gamma: f64,
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
        links: Default::default(),
        contact_modes,
    };
    let mut samples = Vec::with_capacity(n);
    for (i, m) in models.iter().enumerate() {
        let model = batch_model(py, i, m, t_end[i])?;
        let mut settings = build_settings(
            py,
            t_end[i],
            dt[i],
            method,
            iterate,
            tol,
            max_iter,
            gap_stiffness,
            gap_damping,
            beta,
            gamma,
            solver,
            divergence_limit,
            record.clone(),
        )?;
        // event-aware runs step alone (never a lockstep lane: `shares_factor` is false for them)
        settings.events = events;
        samples.push((model, settings));
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
