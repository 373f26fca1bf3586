//! Bindings of the prescribed motions: translations (`Motion`), angle drivers (`Rotation`) and
//! frame kinematics (rotating frames, slider-crank, four-bar: `Frame`).

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt};

use super::err;
use crate::error::Error;
use crate::kinematics::{FourBar, FourBarLink, FrameKinematics, RotatingFrame, Rotation, SliderCrank, SliderCrankLink};
use crate::model::{Motion, Table};

/// A prescribed planar translation (see `flexclear.motion`).
#[pyclass(name = "Motion", module = "flexclear._core", frozen)]
#[derive(Clone)]
pub(crate) struct PyMotion {
    pub(crate) inner: Motion,
}

#[pymethods]
impl PyMotion {
    /// At rest at `position` (m).
    #[staticmethod]
    fn fixed(position: (f64, f64)) -> Self {
        PyMotion {
            inner: Motion::Fixed {
                position: [position.0, position.1],
            },
        }
    }

    /// `offset + amplitude sin(2 pi frequency t + phase)` (m, Hz, rad).
    #[staticmethod]
    #[pyo3(signature = (amplitude, frequency, offset=(0.0, 0.0), phase=0.0))]
    fn harmonic(amplitude: (f64, f64), frequency: f64, offset: (f64, f64), phase: f64) -> Self {
        PyMotion {
            inner: Motion::Harmonic {
                offset: [offset.0, offset.1],
                amplitude: [amplitude.0, amplitude.1],
                frequency,
                phase,
            },
        }
    }

    /// Tabulated motion: times (s), positions (m, shape (n, 2)), optional velocities (m/s) and
    /// accelerations (m/s^2); missing derivatives by central differences.
    #[staticmethod]
    #[pyo3(signature = (time, position, velocity=None, acceleration=None))]
    fn tabulated(
        py: Python<'_>,
        time: Vec<f64>,
        position: Vec<(f64, f64)>,
        velocity: Option<Vec<(f64, f64)>>,
        acceleration: Option<Vec<(f64, f64)>>,
    ) -> PyResult<Self> {
        let conv = |v: Vec<(f64, f64)>| v.into_iter().map(|(a, b)| [a, b]).collect::<Vec<_>>();
        let table = Table::new(
            "motion",
            time,
            conv(position),
            velocity.map(conv),
            acceleration.map(conv),
        )
        .map_err(|e| err(py, e))?;
        Ok(PyMotion {
            inner: Motion::Tabulated(table),
        })
    }

    /// Position, velocity and acceleration at time `t` (s).
    fn at(&self, t: f64) -> ((f64, f64), (f64, f64), (f64, f64)) {
        let k = self.inner.at(t);
        ((k.pos[0], k.pos[1]), (k.vel[0], k.vel[1]), (k.acc[0], k.acc[1]))
    }

    fn __repr__(&self) -> String {
        format!("{:?}", self.inner)
    }
}

/// A real-number argument `name` (a Python int or float; bool refused), or an
/// `InvalidParameterError` naming the parameter, the value and `allowed`.
fn real(arg: &Bound<'_, PyAny>, name: &str, allowed: &str) -> PyResult<f64> {
    if arg.is_instance_of::<PyBool>() || !(arg.is_instance_of::<PyFloat>() || arg.is_instance_of::<PyInt>()) {
        return Err(bad_arg(arg, name, allowed));
    }
    arg.extract::<f64>().map_err(|_| bad_arg(arg, name, allowed))
}

/// The `InvalidParameterError` of argument `name` holding `arg`, which is not `allowed`.
fn bad_arg(arg: &Bound<'_, PyAny>, name: &str, allowed: &str) -> PyErr {
    let shown = arg.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
    err(arg.py(), Error::param(name, shown, allowed))
}

/// A sequence of real numbers `name`, each as [`real`].
fn reals(arg: &Bound<'_, PyAny>, name: &str, allowed: &str) -> PyResult<Vec<f64>> {
    if arg.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad_arg(arg, name, allowed));
    }
    let items = arg.try_iter().map_err(|_| bad_arg(arg, name, allowed))?;
    let mut out = Vec::new();
    for (i, x) in items.enumerate() {
        let x = x.map_err(|_| bad_arg(arg, name, allowed))?;
        out.push(real(&x, &format!("{name}[{i}]"), allowed)?);
    }
    Ok(out)
}

/// A `flexclear.Rotation` argument `name`.
fn rotation_arg<'py>(arg: &Bound<'py, PyAny>, name: &str) -> PyResult<Rotation> {
    arg.extract::<PyRef<'py, PyRotation>>()
        .map(|r| r.inner.clone())
        .map_err(|_| bad_arg(arg, name, "a flexclear.Rotation"))
}

/// A string argument `name`.
fn str_arg(arg: &Bound<'_, PyAny>, name: &str, allowed: &str) -> PyResult<String> {
    arg.extract::<String>().map_err(|_| bad_arg(arg, name, allowed))
}

/// A prescribed angle `phi(t)` (see `flexclear.kinematics`).
#[pyclass(name = "Rotation", module = "flexclear._core", frozen)]
#[derive(Clone)]
pub(super) struct PyRotation {
    pub(super) inner: Rotation,
}

#[pymethods]
impl PyRotation {
    /// A fixed angle, rad.
    #[staticmethod]
    fn fixed(angle: &Bound<'_, PyAny>) -> PyResult<Self> {
        let angle = real(angle, "angle", "a real number, rad")?;
        Ok(PyRotation {
            inner: Rotation::Fixed { angle },
        })
    }

    /// Constant rate `rate` (rad/s) from `angle0` (rad).
    #[staticmethod]
    #[pyo3(signature = (rate, angle0=None))]
    fn constant(rate: &Bound<'_, PyAny>, angle0: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let rate = real(rate, "rate", "a real number, rad/s")?;
        let angle0 = angle0.map_or(Ok(0.0), |a| real(a, "angle0", "a real number, rad"))?;
        Ok(PyRotation {
            inner: Rotation::Constant { angle0, rate },
        })
    }

    /// Kane's smooth spin-up to `final_rate` (rad/s) over `ramp_time` (s).
    #[staticmethod]
    #[pyo3(signature = (final_rate, ramp_time, angle0=None))]
    fn spin_up(
        final_rate: &Bound<'_, PyAny>,
        ramp_time: &Bound<'_, PyAny>,
        angle0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let final_rate = real(final_rate, "final_rate", "a real number, rad/s")?;
        let ramp_time = real(ramp_time, "ramp_time", "a real number > 0, s")?;
        let angle0 = angle0.map_or(Ok(0.0), |a| real(a, "angle0", "a real number, rad"))?;
        Ok(PyRotation {
            inner: Rotation::SpinUp {
                angle0,
                final_rate,
                ramp_time,
            },
        })
    }

    /// `mean + amplitude sin(2 pi frequency t + phase)` (rad, Hz).
    #[staticmethod]
    #[pyo3(signature = (amplitude, frequency, mean=None, phase=None))]
    fn harmonic(
        amplitude: &Bound<'_, PyAny>,
        frequency: &Bound<'_, PyAny>,
        mean: Option<&Bound<'_, PyAny>>,
        phase: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let amplitude = real(amplitude, "amplitude", "a real number, rad")?;
        let frequency = real(frequency, "frequency", "a real number >= 0, Hz")?;
        let mean = mean.map_or(Ok(0.0), |a| real(a, "mean", "a real number, rad"))?;
        let phase = phase.map_or(Ok(0.0), |a| real(a, "phase", "a real number, rad"))?;
        Ok(PyRotation {
            inner: Rotation::Harmonic {
                mean,
                amplitude,
                frequency,
                phase,
            },
        })
    }

    /// Tabulated angle (rad) at increasing times (s); rate and acceleration by central
    /// differences unless given.
    #[staticmethod]
    #[pyo3(signature = (time, angle, rate=None, accel=None))]
    fn tabulated(
        py: Python<'_>,
        time: &Bound<'_, PyAny>,
        angle: &Bound<'_, PyAny>,
        rate: Option<&Bound<'_, PyAny>>,
        accel: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let time = reals(time, "time", "a sequence of real numbers, s")?;
        let angle = reals(angle, "angle", "a sequence of real numbers, rad")?;
        let rate = rate
            .map(|r| reals(r, "rate", "a sequence of real numbers, rad/s"))
            .transpose()?;
        let accel = accel
            .map(|a| reals(a, "accel", "a sequence of real numbers, rad/s^2"))
            .transpose()?;
        let inner = Rotation::tabulated(time, angle, rate, accel).map_err(|e| err(py, e))?;
        Ok(PyRotation { inner })
    }

    /// `(angle, rate, accel)` at time `t` (s).
    fn at(&self, t: f64) -> (f64, f64, f64) {
        self.inner.at(t)
    }

    fn __repr__(&self) -> String {
        format!("{:?}", self.inner)
    }
}

/// The prescribed motion of a link frame or rigid body.
#[pyclass(name = "Frame", module = "flexclear._core", frozen)]
#[derive(Clone)]
pub(super) struct PyFrame {
    pub(super) inner: Arc<dyn FrameKinematics>,
}

#[pymethods]
impl PyFrame {
    /// A frame whose origin follows `origin` (fixed at (0, 0) when None) and whose angle follows
    /// `rotation`.
    #[staticmethod]
    #[pyo3(signature = (rotation, origin=None))]
    fn rotating(py: Python<'_>, rotation: &Bound<'_, PyAny>, origin: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let rotation = rotation_arg(rotation, "rotation")?;
        let origin = match origin {
            None => Motion::Fixed { position: [0.0, 0.0] },
            Some(m) => m
                .extract::<PyRef<'_, PyMotion>>()
                .map_err(|_| bad_arg(m, "origin", "None or a flexclear.motion.Motion"))?
                .inner
                .clone(),
        };
        origin.validate("origin").map_err(|e| err(py, e))?;
        rotation.validate("rotation").map_err(|e| err(py, e))?;
        Ok(PyFrame {
            inner: Arc::new(RotatingFrame { origin, rotation }),
        })
    }

    /// A link of a slider-crank (crank pivot at the origin, guide along x at height `offset`):
    /// `link` is "crank", "rod" or "slider".
    #[staticmethod]
    #[pyo3(signature = (crank, rod, driver, link, offset=None))]
    fn slider_crank(
        py: Python<'_>,
        crank: &Bound<'_, PyAny>,
        rod: &Bound<'_, PyAny>,
        driver: &Bound<'_, PyAny>,
        link: &Bound<'_, PyAny>,
        offset: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let crank = real(crank, "crank", "a length > 0, m")?;
        let rod = real(rod, "rod", "a length > 0, m")?;
        let driver = rotation_arg(driver, "driver")?;
        let link = str_arg(link, "link", "one of \"crank\", \"rod\", \"slider\"")?;
        let offset = offset.map_or(Ok(0.0), |o| real(o, "offset", "a real number, m"))?;
        let sc = Arc::new(SliderCrank::new(crank, rod, offset, driver).map_err(|e| err(py, e))?);
        let which = match link.as_str() {
            "crank" => SliderCrankLink::Crank,
            "rod" => SliderCrankLink::Rod,
            "slider" => SliderCrankLink::Slider,
            other => {
                return Err(err(
                    py,
                    Error::param("link", format!("{other:?}"), "one of \"crank\", \"rod\", \"slider\""),
                ));
            }
        };
        Ok(PyFrame {
            inner: Arc::new(crate::kinematics::SliderCrankFrame {
                mechanism: sc,
                link: which,
            }),
        })
    }

    /// A link of a four-bar (pivots at (0, 0) and (ground, 0)): `link` is "crank", "coupler" or
    /// "rocker"; `branch` +1 or -1 picks the assembly.
    #[staticmethod]
    #[pyo3(signature = (ground, crank, coupler, rocker, driver, link, branch=None))]
    #[allow(clippy::too_many_arguments)]
    fn four_bar(
        py: Python<'_>,
        ground: &Bound<'_, PyAny>,
        crank: &Bound<'_, PyAny>,
        coupler: &Bound<'_, PyAny>,
        rocker: &Bound<'_, PyAny>,
        driver: &Bound<'_, PyAny>,
        link: &Bound<'_, PyAny>,
        branch: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let ground = real(ground, "ground", "a length > 0, m")?;
        let crank = real(crank, "crank", "a length > 0, m")?;
        let coupler = real(coupler, "coupler", "a length > 0, m")?;
        let rocker = real(rocker, "rocker", "a length > 0, m")?;
        let driver = rotation_arg(driver, "driver")?;
        let link = str_arg(link, "link", "one of \"crank\", \"coupler\", \"rocker\"")?;
        let branch = branch.map_or(Ok(1.0), |b| real(b, "branch", "+1 or -1"))?;
        let fb = Arc::new(FourBar::new(ground, crank, coupler, rocker, branch, driver).map_err(|e| err(py, e))?);
        let which = match link.as_str() {
            "crank" => FourBarLink::Crank,
            "coupler" => FourBarLink::Coupler,
            "rocker" => FourBarLink::Rocker,
            other => {
                return Err(err(
                    py,
                    Error::param(
                        "link",
                        format!("{other:?}"),
                        "one of \"crank\", \"coupler\", \"rocker\"",
                    ),
                ));
            }
        };
        Ok(PyFrame {
            inner: Arc::new(crate::kinematics::FourBarFrame {
                mechanism: fb,
                link: which,
            }),
        })
    }

    /// `(origin, origin_velocity, origin_acceleration, angle, rate, accel)` at `t` (SI).
    #[allow(clippy::type_complexity)]
    fn at(&self, t: f64) -> ((f64, f64), (f64, f64), (f64, f64), f64, f64, f64) {
        let f = self.inner.frame(t);
        (
            (f.origin[0], f.origin[1]),
            (f.origin_vel[0], f.origin_vel[1]),
            (f.origin_acc[0], f.origin_acc[1]),
            f.angle,
            f.rate,
            f.accel,
        )
    }

    /// Whether the frame's angle changes with time (a rotating frame carries Coriolis and
    /// inertia-coupling terms, and a clearance joint on it is treated implicitly by default).
    #[getter]
    fn rotates(&self) -> bool {
        self.inner.rotates()
    }

    /// Checks the motion over `[0, t_end]` (a four-bar that does not close, a short table).
    fn check(&self, py: Python<'_>, t_end: f64) -> PyResult<()> {
        self.inner.check("frame", t_end).map_err(|e| err(py, e))
    }

    fn __repr__(&self) -> String {
        format!("{:?}", self.inner)
    }
}
