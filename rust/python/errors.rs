//! The one place where engine errors become Python exceptions, and the one helper that releases
//! the GIL around a long call and turns Ctrl-C into a stop of the run.
//!
//! The exception classes are defined in Python (`flexclear/errors.py`) so that they can inherit
//! from both `FlexclearError` and the matching builtin (`ValueError`, `ArithmeticError`,
//! `KeyboardInterrupt`); here they are looked up and given structured attributes.

use pyo3::prelude::*;

use crate::error::Error;

fn class<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("flexclear.errors")?.getattr(name)
}

/// A `flexclear.ModelError` with `message` as it stands (no `invalid model:` prefix): for a
/// binding that words the message itself.
pub fn model_error(py: Python<'_>, message: String) -> PyErr {
    match class(py, "ModelError").and_then(|c| c.call1((message,))) {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

/// Converts an engine error into the matching `flexclear` exception. `partial` (the output
/// recorded until the failure, a `RunOutput`) is attached as `exc.partial` when given.
pub fn to_pyerr(py: Python<'_>, e: &Error, partial: Option<Bound<'_, PyAny>>) -> PyErr {
    let build = || -> PyResult<PyErr> {
        let msg = e.to_string();
        let (cls, attrs): (&str, Vec<(&str, Py<PyAny>)>) = match e {
            Error::InvalidParameter { name, value, allowed } => (
                "InvalidParameterError",
                vec![
                    ("parameter", name.clone().into_pyobject(py)?.into_any().unbind()),
                    ("value", value.clone().into_pyobject(py)?.into_any().unbind()),
                    ("allowed", allowed.clone().into_pyobject(py)?.into_any().unbind()),
                ],
            ),
            Error::InvalidModel { .. } => ("ModelError", vec![]),
            Error::Singular { what, index, dof } => (
                "SingularMatrixError",
                vec![
                    ("matrix", what.clone().into_pyobject(py)?.into_any().unbind()),
                    ("pivot", index.into_pyobject(py)?.into_any().unbind()),
                    ("dof", dof.clone().into_pyobject(py)?.into_any().unbind()),
                ],
            ),
            Error::Diverged {
                time,
                step,
                dof,
                reason,
            } => (
                "SimulationDivergedError",
                vec![
                    ("time", time.into_pyobject(py)?.into_any().unbind()),
                    ("step", step.into_pyobject(py)?.into_any().unbind()),
                    ("dof", dof.clone().into_pyobject(py)?.into_any().unbind()),
                    ("reason", reason.clone().into_pyobject(py)?.into_any().unbind()),
                ],
            ),
            Error::NotConverged {
                time,
                step,
                iterations,
                residual,
                correction,
            } => (
                "ConvergenceError",
                vec![
                    ("time", time.into_pyobject(py)?.into_any().unbind()),
                    ("step", step.into_pyobject(py)?.into_any().unbind()),
                    ("iterations", iterations.into_pyobject(py)?.into_any().unbind()),
                    ("residual", residual.into_pyobject(py)?.into_any().unbind()),
                    ("correction", correction.into_pyobject(py)?.into_any().unbind()),
                ],
            ),
            Error::Interrupted { time, step } => (
                "SimulationInterrupted",
                vec![
                    ("time", time.into_pyobject(py)?.into_any().unbind()),
                    ("step", step.into_pyobject(py)?.into_any().unbind()),
                ],
            ),
        };
        let exc = class(py, cls)?.call1((msg,))?;
        for (k, v) in attrs {
            exc.setattr(k, v)?;
        }
        exc.setattr("partial", partial.map_or_else(|| py.None(), |p| p.unbind()))?;
        Ok(PyErr::from_value(exc))
    };
    build().unwrap_or_else(|err| err)
}

/// Whether the calling thread is Python's main thread, the only one that sees signals (an
/// error in asking counts as the main thread: the run then checks as it always may).
fn on_main_thread(py: Python<'_>) -> bool {
    let ask = || -> PyResult<bool> {
        let threading = py.import("threading")?;
        let main = threading.call_method0("main_thread")?;
        Ok(main.is(&threading.call_method0("current_thread")?))
    };
    ask().unwrap_or(true)
}

/// Runs `f` with the GIL released. `f` receives a control function for the engine: it briefly
/// re-acquires the GIL to check for signals (Ctrl-C) and to call `progress(fraction)` when given,
/// and returns false to stop the run. On a thread other than the main one, which never sees a
/// signal, and without `progress`, it does not take the GIL at all: runs on worker threads (a
/// study's samples) then never wait for each other's Python code.
pub fn run_detached<T, F>(py: Python<'_>, progress: Option<Py<PyAny>>, f: F) -> (T, Option<PyErr>)
where
    T: Send,
    F: FnOnce(&mut dyn FnMut(f64) -> bool) -> T + Send,
{
    let silent = progress.is_none() && !on_main_thread(py);
    py.detach(|| {
        let mut pending: Option<PyErr> = None;
        let result = {
            let mut control = |fraction: f64| -> bool {
                if silent {
                    return true;
                }
                Python::attach(|py| {
                    if let Err(e) = py.check_signals() {
                        pending = Some(e);
                        return false;
                    }
                    if let Some(cb) = &progress {
                        if let Err(e) = cb.call1(py, (fraction,)) {
                            pending = Some(e);
                            return false;
                        }
                    }
                    true
                })
            };
            f(&mut control)
        };
        (result, pending)
    })
}
