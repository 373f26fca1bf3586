//! Python bindings (`flexclear._core`), behind the `python` feature: the only code that knows
//! about Python. One module per concept: the one model class (`Mechanism` and its runs) in
//! `mechanism.rs`, the bundled scenes that build it in `scenes.rs`, motions and frames in `motion.rs`, the linkage kinematics in `linkage.rs`, the batch in
//! `batch.rs`, run outputs in `output.rs`, contact laws in `contact.rs`, errors in `errors.rs`;
//! here the module and the parsers they share.

mod batch;
mod contact;
mod errors;
mod linkage;
mod mechanism;
mod motion;
mod output;
mod scenes;

use pyo3::prelude::*;

use crate::contact::{Coupling, DampingLaw};
use crate::error::Error;
use crate::run::SolverMode;

use errors::to_pyerr;

pub(crate) fn err(py: Python<'_>, e: Error) -> PyErr {
    to_pyerr(py, &e, None)
}

pub(crate) fn parse_damping_law(py: Python<'_>, s: &str) -> PyResult<DampingLaw> {
    match s {
        "viscous" => Ok(DampingLaw::Viscous),
        "radial" => Ok(DampingLaw::Radial),
        "literal" => Ok(DampingLaw::Literal),
        other => Err(err(
            py,
            Error::param(
                "damping_law",
                format!("{other:?}"),
                "one of \"viscous\", \"radial\", \"literal\"",
            ),
        )),
    }
}

/// The clearance coupling named `method` ("force", "modified", "gap", "continuous") with its iteration
/// tolerance and cap (the modified method's kappa iteration, the gap element's status
/// iteration) and the gap element's stiffness (N/m, None = derived) and damping (N s/m).
pub(super) fn parse_coupling(
    py: Python<'_>,
    method: &str,
    iterate: bool,
    tol: f64,
    max_iter: usize,
    gap_stiffness: Option<f64>,
    gap_damping: f64,
) -> PyResult<Coupling> {
    match method {
        "force" => Ok(Coupling::Force),
        "continuous" => Ok(Coupling::Continuous),
        "modified" => Ok(Coupling::Modified { iterate, tol, max_iter }),
        "gap" => Ok(Coupling::Gap {
            stiffness: gap_stiffness,
            damping: gap_damping,
            max_iter,
        }),
        other => Err(err(
            py,
            Error::param(
                "method",
                format!("{other:?}"),
                "one of \"force\", \"modified\", \"gap\", \"continuous\"",
            ),
        )),
    }
}

/// The solver named `solver` ("woodbury", "refactor").
pub(super) fn parse_solver(py: Python<'_>, solver: &str) -> PyResult<SolverMode> {
    match solver {
        "woodbury" => Ok(SolverMode::Woodbury),
        "refactor" => Ok(SolverMode::Refactor),
        other => Err(err(
            py,
            Error::param("solver", format!("{other:?}"), "one of \"woodbury\", \"refactor\""),
        )),
    }
}

/// Sets up, at import, what the numpy crate otherwise sets up on the first array a run hands
/// over: NumPy's C API table (imported from `numpy.core.multiarray`, with a check of NumPy's
/// version) and the type of the object that owns a `Vec`'s memory inside an array. Done there, it
/// made a fresh process's first `simulate` about 200 us slower: the crank-pin slider-crank over
/// one step took 460 us (`Result.wall_time`), 260 us with it done here; the import pays it once.
fn init_numpy(py: Python<'_>) {
    use numpy::IntoPyArray;
    let _ = Vec::<f64>::new().into_pyarray(py);
}

/// The compiled core of flexclear.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<motion::PyMotion>()?;
    m.add_class::<motion::PyRotation>()?;
    m.add_class::<motion::PyFrame>()?;
    m.add_class::<mechanism::PyMechanism>()?;
    m.add_class::<output::PyRunOutput>()?;
    m.add_class::<output::PyJointExtremes>()?;
    m.add_class::<output::PyJointHistory>()?;
    m.add_class::<output::PyImpactLog>()?;
    m.add_class::<output::PyNodeHistory>()?;
    m.add_class::<output::PyLinkHistory>()?;
    m.add_class::<output::PySliderHistory>()?;
    m.add_class::<output::PySliderReference>()?;
    m.add_function(wrap_pyfunction!(scenes::slider_yoke, m)?)?;
    m.add_function(wrap_pyfunction!(scenes::slider_crank, m)?)?;
    m.add_function(wrap_pyfunction!(scenes::flores_slider_crank, m)?)?;
    m.add_function(wrap_pyfunction!(scenes::four_bar, m)?)?;
    m.add_function(wrap_pyfunction!(scenes::spin_up, m)?)?;
    m.add_function(wrap_pyfunction!(scenes::spin_up_data, m)?)?;
    m.add_function(wrap_pyfunction!(batch::run_batch, m)?)?;
    m.add_function(wrap_pyfunction!(linkage::solve_linkage, m)?)?;
    contact::register(m)?;
    m.add("RETRY_MIN_STEP_RATIO", crate::batch::RETRY_MIN_STEP_RATIO)?;
    m.add("LINKAGE_TOLERANCE", crate::kinematics::linkage::TOLERANCE)?;
    m.add("LINKAGE_MAX_CONDITION", crate::kinematics::linkage::MAX_CONDITION)?;
    m.add("TRUNCATION_FRACTION", crate::run::TRUNCATION_FRACTION)?;
    m.add("MAX_ITER", crate::run::MAX_ITER)?;
    m.add("REBOUND_DEPTH", crate::record::REBOUND_DEPTH)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SIMD_PATHS", crate::linalg::simd_paths())?;
    init_numpy(m.py());
    Ok(())
}
