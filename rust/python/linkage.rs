//! Binding of the linkage kinematics (`flexclear.Linkage` builds the constraints in Python and
//! solves them here: `crate::kinematics::linkage`).

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;

use super::err;
use super::motion::PyRotation;
use crate::kinematics::linkage::{Constraint, Crank, LinkageSystem};

type Array3<'py> = Bound<'py, PyAny>;

/// A guide as Python passes it: pin index, a point of the line (m), its unit direction.
type LineArg = (usize, (f64, f64), (f64, f64));

/// A crank as Python passes it: name, pivot (m), tip index, length (m), driver.
type CrankArg<'py> = (String, (f64, f64), usize, f64, PyRef<'py, PyRotation>);

/// Positions (m), velocities (m/s) and accelerations (m/s^2) of every point of a linkage at the
/// increasing `times` (s), each an array of shape `(len(times), points, 2)`. Points
/// `0..moving` move (`near`: their guesses at the first instant, m, flat); `distances` are
/// `(p, q, length)`, `lines` `(p, through, unit direction)`, `slots` `(p, a, b, |b - a|)`,
/// `ground` `(index, position)`, `cranks` `(name, pivot, tip index, length, driver)`; `scale`
/// (m) the linkage's size. Raises `ModelError` where the linkage does not assemble or is at a
/// dead point (naming the instant), `InvalidParameterError` for bad times. Runs without the
/// GIL.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (times, near, moving, points, distances, lines, slots, ground, cranks, scale))]
pub(super) fn solve_linkage<'py>(
    py: Python<'py>,
    times: PyReadonlyArray1<'py, f64>,
    near: Vec<f64>,
    moving: usize,
    points: usize,
    distances: Vec<(usize, usize, f64)>,
    lines: Vec<LineArg>,
    slots: Vec<(usize, usize, usize, f64)>,
    ground: Vec<(usize, (f64, f64))>,
    cranks: Vec<CrankArg<'py>>,
    scale: f64,
) -> PyResult<(Array3<'py>, Array3<'py>, Array3<'py>)> {
    let mut constraints: Vec<Constraint> = distances
        .into_iter()
        .map(|(p, q, length)| Constraint::Distance { p, q, length })
        .collect();
    constraints.extend(lines.into_iter().map(|(p, t, d)| Constraint::Line {
        p,
        through: [t.0, t.1],
        dir: [d.0, d.1],
    }));
    constraints.extend(
        slots
            .into_iter()
            .map(|(p, a, b, length)| Constraint::Slot { p, a, b, length }),
    );
    let system = LinkageSystem {
        moving,
        points,
        constraints,
        ground: ground.into_iter().map(|(i, xy)| (i, [xy.0, xy.1])).collect(),
        cranks: cranks
            .into_iter()
            .map(|(name, pivot, tip, length, driver)| Crank {
                name,
                pivot: [pivot.0, pivot.1],
                tip,
                length,
                driver: driver.inner.clone(),
            })
            .collect(),
    };
    let count = times.len();
    let times = times.as_slice()?;
    let motion = py
        .detach(|| system.solve(times, &near, scale))
        .map_err(|e| err(py, e))?;
    let shape = [count, points, 2];
    let array = |v: Vec<f64>| PyArray1::from_vec(py, v).reshape(shape).map(|a| a.into_any());
    Ok((
        array(motion.position)?,
        array(motion.velocity)?,
        array(motion.acceleration)?,
    ))
}
