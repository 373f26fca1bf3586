//! A run's output as Python objects: one [`PyRunOutput`] (`flexclear._core.RunOutput`) for every
//! stepper, whose parts are objects too (`JointExtremes`, `JointHistory`, `ImpactLog`,
//! `NodeHistory`, `LinkHistory`, `SliderHistory`), with numpy arrays for the series;
//! `flexclear.Result` reads their attributes. The per-sample rows of a study batch are dicts (the
//! rows of the study's table) holding the same `JointExtremes` objects ([`extremes_objects`]) and
//! the joint histories as dicts ([`joint_histories`]).

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::record::{Impact, JointExtremes, JointHistory};
use crate::run::{RunOutput, RunStats};

/// The running extremes of one clearance joint (`flexclear.JointResult` takes its values from
/// these): SI units as in [`JointExtremes`]; the contact-mode fractions and the dissipated energy
/// are NaN unless the run tracked them (`Record(contact_modes=True)`).
#[pyclass(module = "flexclear._core", name = "JointExtremes", frozen, get_all)]
pub struct PyJointExtremes {
    max_penetration: f64,
    time_of_max_penetration: f64,
    max_force: f64,
    impacts: u64,
    contact_episodes: u64,
    contact_time: f64,
    max_velocity: f64,
    max_impact_velocity: f64,
    contact_period: f64,
    rms_penetration: f64,
    rms_force: f64,
    free_flight_fraction: f64,
    impact_fraction: f64,
    continuous_fraction: f64,
    dissipated_energy: f64,
    friction_energy: f64,
}

impl From<&JointExtremes> for PyJointExtremes {
    fn from(e: &JointExtremes) -> Self {
        PyJointExtremes {
            max_penetration: e.max_penetration,
            time_of_max_penetration: e.time_of_max_penetration,
            max_force: e.max_force,
            impacts: e.impacts,
            contact_episodes: e.contact_episodes,
            contact_time: e.contact_time,
            max_velocity: e.max_velocity,
            max_impact_velocity: e.max_impact_velocity,
            contact_period: e.contact_period(),
            rms_penetration: e.rms_penetration(),
            rms_force: e.rms_force(),
            free_flight_fraction: e.free_flight_fraction(),
            impact_fraction: e.impact_fraction(),
            continuous_fraction: e.continuous_fraction(),
            dissipated_energy: e.dissipated_energy(),
            friction_energy: e.friction_energy(),
        }
    }
}

/// The histories of one recorded clearance joint: `joint` (its index), `penetration` (m),
/// `force` (N), `qx`, `qy` (journal centre relative to the bearing centre, m; empty unless
/// recorded), `friction` (friction force along the tangent, N) and `slip` (slip speed, m/s;
/// empty for a joint without friction).
#[pyclass(module = "flexclear._core", name = "JointHistory", frozen, get_all)]
pub struct PyJointHistory {
    joint: usize,
    penetration: Py<PyArray1<f64>>,
    force: Py<PyArray1<f64>>,
    qx: Py<PyArray1<f64>>,
    qy: Py<PyArray1<f64>>,
    friction: Py<PyArray1<f64>>,
    slip: Py<PyArray1<f64>>,
}

/// The impact log of one joint: per impact its `time` (s), approach `speed` (m/s), `peak_force`
/// (N), `peak_penetration` (m) and `duration` (s).
#[pyclass(module = "flexclear._core", name = "ImpactLog", frozen, get_all)]
pub struct PyImpactLog {
    joint: usize,
    time: Py<PyArray1<f64>>,
    speed: Py<PyArray1<f64>>,
    peak_force: Py<PyArray1<f64>>,
    peak_penetration: Py<PyArray1<f64>>,
    duration: Py<PyArray1<f64>>,
}

/// The displacement histories of one node: `link`, `node` (indices), `u`, `v` (m) and `theta`
/// (rad) in the link frame.
#[pyclass(module = "flexclear._core", name = "NodeHistory", frozen, get_all)]
pub struct PyNodeHistory {
    link: usize,
    node: usize,
    u: Py<PyArray1<f64>>,
    v: Py<PyArray1<f64>>,
    theta: Py<PyArray1<f64>>,
}

/// The histories of one link: `frame` (records x 4: origin x, y in m, angle in rad, rate in
/// rad/s), `displacements` (records x 3 (N + 1): u, v, theta of every node), `axial_force`
/// (records x N, N), `midspan` (m), `kinetic` and `strain` energy (J), `momentum`; an empty array
/// for a channel not recorded. `max_midspan` (m) and `max_axial_force` (N): the running peaks
/// over every step from `start` on (`link_peaks`), NaN when not tracked or for a rigid link.
#[pyclass(module = "flexclear._core", name = "LinkHistory", frozen, get_all)]
pub struct PyLinkHistory {
    max_midspan: f64,
    max_axial_force: f64,
    frame: Py<PyArray2<f64>>,
    displacements: Py<PyArray2<f64>>,
    axial_force: Py<PyArray2<f64>>,
    midspan: Py<PyArray1<f64>>,
    kinetic: Py<PyArray1<f64>>,
    strain: Py<PyArray1<f64>>,
    momentum: Py<PyArray1<f64>>,
}

/// The histories of one slider along its guide: `name`, `position` (m), `velocity` (m/s),
/// `acceleration` (m/s^2) on the output grid (empty unless kept), `max_acceleration` (m/s^2,
/// every step), and with a reference motion (`slider_reference`) `deviation_mean` and
/// `deviation_max`: mean and peak `|x - x_ref|` over the output points from `start` on, per
/// channel (position m, velocity m/s, acceleration m/s^2), accumulated online; NaN without one.
#[pyclass(module = "flexclear._core", name = "SliderHistory", frozen, get_all)]
pub struct PySliderHistory {
    name: String,
    position: Py<PyArray1<f64>>,
    velocity: Py<PyArray1<f64>>,
    acceleration: Py<PyArray1<f64>>,
    max_acceleration: f64,
    deviation: bool,
    deviation_mean: (f64, f64, f64),
    deviation_max: (f64, f64, f64),
}

/// The sliders' motion on an output grid, shared by the runs that compare with it
/// (`simulate(slider_reference=...)`): `time` (s) and per slider `(name, position m, velocity
/// m/s, acceleration m/s^2)`, each history one value per grid point. Built once (the arrays are
/// copied into the core), then every run holds the same copy.
#[pyclass(module = "flexclear._core", name = "SliderReference", frozen)]
pub struct PySliderReference {
    pub(super) inner: std::sync::Arc<crate::record::SliderReference>,
}

/// One slider of a [`PySliderReference`]: name, position (m), velocity (m/s), acceleration (m/s^2).
type SliderColumns<'py> = (
    String,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
);

#[pymethods]
impl PySliderReference {
    #[new]
    fn new<'py>(py: Python<'py>, time: PyReadonlyArray1<'py, f64>, sliders: Vec<SliderColumns<'py>>) -> PyResult<Self> {
        let vec = |a: &PyReadonlyArray1<'py, f64>| a.as_array().to_vec();
        let sliders = (sliders.iter())
            .map(|(n, x, v, a)| (n.clone(), [vec(x), vec(v), vec(a)]))
            .collect();
        let inner = crate::record::SliderReference::new(vec(&time), sliders).map_err(|e| super::err(py, e))?;
        Ok(PySliderReference {
            inner: std::sync::Arc::new(inner),
        })
    }

    /// Number of grid points.
    fn __len__(&self) -> usize {
        self.inner.time.len()
    }
}

/// The output of any run: `time` (s, the output grid), `joints` (the recorded joints'
/// histories), `nodes`, `links` (one per link), `sliders`, `extremes` (one per clearance joint,
/// in model order), `impact_log`, `stats` (the run's counters by name), `state` (`(u, v, a)` at the
/// end) and `t` (the time reached, s).
#[pyclass(module = "flexclear._core", name = "RunOutput", frozen, get_all)]
pub struct PyRunOutput {
    time: Py<PyArray1<f64>>,
    joints: Vec<Py<PyJointHistory>>,
    nodes: Vec<Py<PyNodeHistory>>,
    links: Vec<Py<PyLinkHistory>>,
    sliders: Vec<Py<PySliderHistory>>,
    extremes: Vec<Py<PyJointExtremes>>,
    impact_log: Vec<Py<PyImpactLog>>,
    stats: Py<PyDict>,
    state: State,
    t: f64,
}

/// `(u, v, a)` at the end of a run.
type State = (Py<PyArray1<f64>>, Py<PyArray1<f64>>, Py<PyArray1<f64>>);

fn arr(py: Python<'_>, v: Vec<f64>) -> Py<PyArray1<f64>> {
    PyArray1::from_vec(py, v).unbind()
}

/// The running extremes of every joint as [`PyJointExtremes`] objects, in joint order (a run's
/// output, and the per-sample extremes of a study batch).
pub(super) fn extremes_objects(py: Python<'_>, extremes: &[JointExtremes]) -> PyResult<Vec<Py<PyJointExtremes>>> {
    extremes.iter().map(|e| Py::new(py, PyJointExtremes::from(e))).collect()
}

/// Joint histories as a list of dicts (`joint`, `penetration` m, `force` N, `qx`, `qy` m; the
/// journal position empty unless recorded): the per-sample histories of a study batch.
pub(super) fn joint_histories(py: Python<'_>, joints: Vec<JointHistory>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for h in joints {
        let j = PyDict::new(py);
        j.set_item("joint", h.joint)?;
        j.set_item("penetration", PyArray1::from_vec(py, h.penetration))?;
        j.set_item("force", PyArray1::from_vec(py, h.force))?;
        j.set_item("qx", PyArray1::from_vec(py, h.qx))?;
        j.set_item("qy", PyArray1::from_vec(py, h.qy))?;
        list.append(j)?;
    }
    Ok(list)
}

/// A row-major matrix as a numpy array that takes over `v`'s buffer (no copy: a run's link
/// histories are megabytes).
pub(super) fn mat<'py>(py: Python<'py>, v: Vec<f64>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let a = Array2::from_shape_vec((rows, cols), v)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("internal shape error: {e}")))?;
    Ok(a.into_pyarray(py))
}

/// The run's counters by name (`steps`, `factorizations`, ..., `stepper`), as `Result.stats`
/// shows them.
fn stats_dict(py: Python<'_>, s: RunStats) -> PyResult<Bound<'_, PyDict>> {
    let st = PyDict::new(py);
    st.set_item("steps", s.steps)?;
    st.set_item("factorizations", s.factorizations)?;
    st.set_item("woodbury_steps", s.woodbury_steps)?;
    st.set_item("woodbury_fallbacks", s.woodbury_fallbacks)?;
    st.set_item("event_steps", s.event_steps)?;
    st.set_item("iterations", s.iterations)?;
    st.set_item("max_iterations", s.max_iterations)?;
    st.set_item("unconverged_steps", s.unconverged_steps)?;
    st.set_item("terms", s.terms)?;
    st.set_item("stepper", s.stepper)?;
    st.set_item("halved_substeps", s.halved_substeps)?;
    st.set_item("roundoff_steps", s.roundoff_steps)?;
    st.set_item("event_fallbacks", s.event_fallbacks)?;
    st.set_item("unknowns", s.unknowns)?;
    st.set_item("bandwidth", s.bandwidth)?;
    st.set_item("adaptive_steps", s.adaptive_steps)?;
    st.set_item("rejected_steps", s.rejected_steps)?;
    st.set_item("floor_steps", s.floor_steps)?;
    st.set_item("min_step", s.min_step)?;
    st.set_item("max_step", s.max_step)?;
    // the achieved-accuracy estimate exists for adaptive runs only
    let adaptive = s.adaptive_steps > 0;
    st.set_item("error_estimate", adaptive.then_some(s.error_estimate))?;
    st.set_item(
        "peak_force_error_estimate",
        adaptive.then_some(s.peak_force_error_estimate),
    )?;
    Ok(st)
}

/// The output of any run as a [`PyRunOutput`]; `link_elements` (elements per link) shapes the
/// link histories.
pub(super) fn run_output(py: Python<'_>, out: RunOutput, link_elements: &[usize]) -> PyResult<Py<PyRunOutput>> {
    let rec = out.record;
    let joints = (rec.joints.into_iter())
        .map(|h| {
            let j = PyJointHistory {
                joint: h.joint,
                penetration: arr(py, h.penetration),
                force: arr(py, h.force),
                qx: arr(py, h.qx),
                qy: arr(py, h.qy),
                friction: arr(py, h.friction),
                slip: arr(py, h.slip),
            };
            Py::new(py, j)
        })
        .collect::<PyResult<_>>()?;
    let nodes = (rec.nodes.into_iter())
        .map(|h| {
            let n = PyNodeHistory {
                link: h.link,
                node: h.node,
                u: arr(py, h.u),
                v: arr(py, h.v),
                theta: arr(py, h.theta),
            };
            Py::new(py, n)
        })
        .collect::<PyResult<_>>()?;
    let mut links = Vec::with_capacity(rec.links.len());
    for (h, &ne) in rec.links.into_iter().zip(link_elements) {
        let nn = ne + 1;
        let fr_rows = h.frame.len();
        let peaks = h.peak_values();
        let fr: Vec<f64> = h.frame.into_flattened();
        let drows = h.displacements.len() / (3 * nn);
        let arows = h.axial_force.len() / ne;
        let l = PyLinkHistory {
            max_midspan: peaks[0],
            max_axial_force: peaks[1],
            frame: mat(py, fr, fr_rows, 4)?.unbind(),
            displacements: mat(py, h.displacements, drows, 3 * nn)?.unbind(),
            axial_force: mat(py, h.axial_force, arows, ne)?.unbind(),
            midspan: arr(py, h.midspan),
            kinetic: arr(py, h.kinetic),
            strain: arr(py, h.strain),
            momentum: arr(py, h.momentum),
        };
        links.push(Py::new(py, l)?);
    }
    let sliders = (rec.sliders.into_iter())
        .map(|h| {
            let (deviation_mean, deviation_max) = (h.deviation_mean().into(), h.deviation_peak().into());
            let s = PySliderHistory {
                name: h.name,
                position: arr(py, h.position),
                velocity: arr(py, h.velocity),
                acceleration: arr(py, h.acceleration),
                max_acceleration: h.max_acceleration,
                deviation: h.deviation,
                deviation_mean,
                deviation_max,
            };
            Py::new(py, s)
        })
        .collect::<PyResult<_>>()?;
    let extremes = extremes_objects(py, &rec.extremes)?;
    let impact_log = (rec.impacts.into_iter())
        .map(|(joint, log)| {
            let col = |f: fn(&Impact) -> f64| arr(py, log.iter().map(f).collect());
            let l = PyImpactLog {
                joint,
                time: col(|i| i.time),
                speed: col(|i| i.speed),
                peak_force: col(|i| i.peak_force),
                peak_penetration: col(|i| i.peak_penetration),
                duration: col(|i| i.duration),
            };
            Py::new(py, l)
        })
        .collect::<PyResult<_>>()?;
    let [u, v, a] = out.state;
    let o = PyRunOutput {
        time: arr(py, rec.time),
        joints,
        nodes,
        links,
        sliders,
        extremes,
        impact_log,
        stats: stats_dict(py, out.stats)?.unbind(),
        state: (arr(py, u), arr(py, v), arr(py, a)),
        t: out.time,
    };
    Py::new(py, o)
}
