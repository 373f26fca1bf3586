//! A run's output as Python objects: one layout for every stepper (the dict that
//! `flexclear.Result` reads), the joints' extremes and impact logs.

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, ToPyArray};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::record::{JointExtremes, JointHistory, LinkHistory};
use crate::run::RunOutput;

/// The impact logs of a recorder as a list of dicts of arrays (`joint`, `time`, `speed`,
/// `peak_force`, `peak_penetration`, `duration`).
fn impact_logs(py: Python<'_>, impacts: Vec<(usize, Vec<crate::record::Impact>)>) -> PyResult<Bound<'_, PyList>> {
    let logs = PyList::empty(py);
    for (joint, log) in impacts {
        let x = PyDict::new(py);
        x.set_item("joint", joint)?;
        let col = |f: fn(&crate::record::Impact) -> f64| PyArray1::from_vec(py, log.iter().map(f).collect());
        x.set_item("time", col(|i| i.time))?;
        x.set_item("speed", col(|i| i.speed))?;
        x.set_item("peak_force", col(|i| i.peak_force))?;
        x.set_item("peak_penetration", col(|i| i.peak_penetration))?;
        x.set_item("duration", col(|i| i.duration))?;
        logs.append(x)?;
    }
    Ok(logs)
}

/// The running extremes of every joint as a list of dicts (the keys of `flexclear.JointResult`);
/// also the per-sample extremes of a study batch.
pub(super) fn extremes_list<'py>(py: Python<'py>, extremes: &[JointExtremes]) -> PyResult<Bound<'py, PyList>> {
    let ext = PyList::empty(py);
    for e in extremes {
        let x = PyDict::new(py);
        x.set_item("max_penetration", e.max_penetration)?;
        x.set_item("time_of_max_penetration", e.time_of_max_penetration)?;
        x.set_item("max_force", e.max_force)?;
        x.set_item("impacts", e.impacts)?;
        x.set_item("contact_time", e.contact_time)?;
        x.set_item("max_velocity", e.max_velocity)?;
        x.set_item("max_impact_velocity", e.max_impact_velocity)?;
        x.set_item("rms_penetration", e.rms_penetration())?;
        x.set_item("rms_force", e.rms_force())?;
        x.set_item("free_flight_fraction", e.free_flight_fraction())?;
        x.set_item("impact_fraction", e.impact_fraction())?;
        x.set_item("continuous_fraction", e.continuous_fraction())?;
        x.set_item("dissipated_energy", e.dissipated_energy())?;
        ext.append(x)?;
    }
    Ok(ext)
}

/// Joint histories as a list of dicts (`joint`, `penetration` m, `force` N, `qx`, `qy` m; the
/// journal position empty unless recorded); also the per-sample histories of a study batch.
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

/// Link histories of a moving-frame run: per link a dict of the frame state (records x 4), the
/// nodal displacements (records x 3 (N + 1)), the axial forces (records x N) and the midspan,
/// energy and momentum series; `link_elements` gives N per link.
fn links_list<'py>(py: Python<'py>, links: Vec<LinkHistory>, link_elements: &[usize]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for (h, &ne) in links.into_iter().zip(link_elements) {
        let ld = PyDict::new(py);
        let fr_rows = h.frame.len();
        let fr: Vec<f64> = h.frame.into_iter().flatten().collect();
        ld.set_item("frame", mat(py, fr, fr_rows, 4)?)?;
        let nn = ne + 1;
        let drows = h.displacements.len() / (3 * nn);
        ld.set_item("displacements", mat(py, h.displacements, drows, 3 * nn)?)?;
        let arows = h.axial_force.len() / ne;
        ld.set_item("axial_force", mat(py, h.axial_force, arows, ne)?)?;
        ld.set_item("midspan", PyArray1::from_vec(py, h.midspan))?;
        ld.set_item("kinetic", PyArray1::from_vec(py, h.kinetic))?;
        ld.set_item("strain", PyArray1::from_vec(py, h.strain))?;
        ld.set_item("momentum", PyArray1::from_vec(py, h.momentum))?;
        list.append(ld)?;
    }
    Ok(list)
}

/// A row-major matrix as a numpy array.
pub(super) fn mat<'py>(py: Python<'py>, v: Vec<f64>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let a = Array2::from_shape_vec((rows, cols), v)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("internal shape error: {e}")))?;
    Ok(a.to_pyarray(py))
}

/// The output of any run (its extremes, histories, slider histories, counters and final state)
/// as the dict that `flexclear.Result` reads; `link_elements` (elements per link) shapes the link histories of a
/// moving-frame run.
pub(super) fn output_dict<'py>(
    py: Python<'py>,
    out: RunOutput,
    link_elements: &[usize],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let rec = out.record;
    d.set_item("time", PyArray1::from_vec(py, rec.time))?;
    d.set_item("joints", joint_histories(py, rec.joints)?)?;
    let nodes = PyList::empty(py);
    for h in rec.nodes {
        let n = PyDict::new(py);
        n.set_item("link", h.link)?;
        n.set_item("node", h.node)?;
        n.set_item("u", PyArray1::from_vec(py, h.u))?;
        n.set_item("v", PyArray1::from_vec(py, h.v))?;
        n.set_item("theta", PyArray1::from_vec(py, h.theta))?;
        nodes.append(n)?;
    }
    d.set_item("nodes", nodes)?;
    if !rec.links.is_empty() {
        d.set_item("links", links_list(py, rec.links, link_elements)?)?;
    }
    let sliders = PyList::empty(py);
    for h in rec.sliders {
        let x = PyDict::new(py);
        x.set_item("name", h.name)?;
        x.set_item("position", PyArray1::from_vec(py, h.position))?;
        x.set_item("velocity", PyArray1::from_vec(py, h.velocity))?;
        x.set_item("acceleration", PyArray1::from_vec(py, h.acceleration))?;
        x.set_item("max_acceleration", h.max_acceleration)?;
        sliders.append(x)?;
    }
    d.set_item("sliders", sliders)?;
    d.set_item("extremes", extremes_list(py, &rec.extremes)?)?;
    d.set_item("impact_log", impact_logs(py, rec.impacts)?)?;
    let s = out.stats;
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
    d.set_item("stats", st)?;
    let [u, v, a] = out.state;
    d.set_item(
        "state",
        (
            PyArray1::from_vec(py, u),
            PyArray1::from_vec(py, v),
            PyArray1::from_vec(py, a),
        ),
    )?;
    d.set_item("t", out.time)?;
    Ok(d)
}
