//! Bindings of the contact laws (`flexclear.contact`): normal-force laws, friction laws and the
//! single-impact calibration. The Python classes of `flexclear/contact.py` hold one of these and
//! do the broadcasting; here every array argument is one-dimensional and of one length.

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

use super::err;
use super::parse_damping_law;
use crate::contact::friction::{Coulomb, FrictionLaw, JointFriction, LuGre, Regularization, Stribeck};
use crate::contact::laws::NormalContact;
use crate::contact::laws::{
    CarvalhoMartins, Flores, Gonthier, Hertz, HuntCrossley, KelvinVoigt, LankaraniNikravesh, NormalLaw,
};
use crate::contact::restitution::effective_restitution;
use crate::contact::{ContactLaw, SpringDamper};
use crate::error::Error;
use std::sync::Arc;

/// A float64 array handed to Python.
type Array<'py> = Bound<'py, PyArray1<f64>>;

/// `f` applied elementwise to `arrays` (which must all have one length), into `K` new arrays;
/// `names` names the arguments in the error.
fn map_arrays<'py, const N: usize, const K: usize>(
    py: Python<'py>,
    names: &str,
    arrays: [&PyReadonlyArray1<'_, f64>; N],
    f: impl Fn([f64; N]) -> [f64; K],
) -> PyResult<[Array<'py>; K]> {
    let s = arrays.iter().map(|a| a.as_slice()).collect::<Result<Vec<_>, _>>()?;
    let n = s[0].len();
    if s.iter().any(|x| x.len() != n) {
        let lens: Vec<String> = s.iter().map(|x| x.len().to_string()).collect();
        return Err(err(
            py,
            Error::param(names, format!("lengths {}", lens.join(", ")), "arrays of one length"),
        ));
    }
    let mut out: [Vec<f64>; K] = std::array::from_fn(|_| Vec::with_capacity(n));
    for i in 0..n {
        let r = f(std::array::from_fn(|j| s[j][i]));
        for (o, v) in out.iter_mut().zip(r) {
            o.push(v);
        }
    }
    Ok(out.map(|v| PyArray1::from_vec(py, v)))
}

/// A normal-force law (kind = the Python class name).
#[pyclass(name = "NormalLaw", module = "flexclear._core", frozen)]
pub(super) struct PyNormalLaw {
    inner: Arc<dyn NormalLaw>,
    /// The same law as the engine's spring-dashpot, for a Kelvin-Voigt law.
    spring_damper: Option<SpringDamper>,
}

/// The contact law of a clearance joint: `law` (a `flexclear.contact` law, the pin-in-hole form
/// of [`NormalContact`]; a Kelvin-Voigt law is the engine's own spring-dashpot) or, without one,
/// the paper's spring-dashpot from `stiffness`, `damping`, `damping_law` and `no_tension`.
/// `name` prefixes parameter names in errors.
#[allow(clippy::too_many_arguments)]
pub(super) fn joint_law(
    py: Python<'_>,
    name: &str,
    law: Option<PyRef<'_, PyNormalLaw>>,
    stiffness: f64,
    damping: f64,
    damping_law: &str,
    no_tension: bool,
) -> PyResult<Arc<dyn ContactLaw>> {
    let law: Arc<dyn ContactLaw> = match law {
        Some(l) => match l.spring_damper {
            Some(sd) => Arc::new(sd),
            None => Arc::new(NormalContact::new(Arc::clone(&l.inner))),
        },
        None => Arc::new(SpringDamper {
            stiffness,
            damping,
            damping_law: parse_damping_law(py, damping_law)?,
            no_tension,
        }),
    };
    law.validate(name).map_err(|e| err(py, e))?;
    Ok(law)
}

#[pymethods]
impl PyNormalLaw {
    /// Builds and validates the law `kind` ("Hertz", "HuntCrossley", "LankaraniNikravesh",
    /// "Flores", "Gonthier", "CarvalhoMartins", "KelvinVoigt"). `restitution` is ignored by
    /// Hertz and KelvinVoigt, `exponent`, `min_approach_speed` by KelvinVoigt, `damping` and
    /// `damping_law` by all but KelvinVoigt; for KelvinVoigt `clip_tension` is `no_tension`.
    #[new]
    #[pyo3(signature = (kind, stiffness, exponent=1.5, restitution=1.0, min_approach_speed=1e-3, clip_tension=true,
                        damping=0.0, damping_law="viscous"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        kind: &str,
        stiffness: f64,
        exponent: f64,
        restitution: f64,
        min_approach_speed: f64,
        clip_tension: bool,
        damping: f64,
        damping_law: &str,
    ) -> PyResult<Self> {
        macro_rules! hysteresis {
            ($ty:ident) => {
                Arc::new($ty {
                    stiffness,
                    exponent,
                    restitution,
                    min_approach_speed,
                    clip_tension,
                }) as Arc<dyn NormalLaw>
            };
        }
        let mut spring_damper = None;
        let inner: Arc<dyn NormalLaw> = match kind {
            "Hertz" => Arc::new(Hertz { stiffness, exponent }),
            "HuntCrossley" => hysteresis!(HuntCrossley),
            "LankaraniNikravesh" => hysteresis!(LankaraniNikravesh),
            "Flores" => hysteresis!(Flores),
            "Gonthier" => hysteresis!(Gonthier),
            "CarvalhoMartins" => hysteresis!(CarvalhoMartins),
            "KelvinVoigt" => {
                let law = KelvinVoigt {
                    stiffness,
                    damping,
                    damping_law: parse_damping_law(py, damping_law)?,
                    no_tension: clip_tension,
                };
                // on a joint it is the engine's own spring-dashpot (the paper's law)
                spring_damper = Some(SpringDamper {
                    stiffness,
                    damping,
                    damping_law: law.damping_law,
                    no_tension: clip_tension,
                });
                Arc::new(law)
            }
            other => {
                return Err(err(
                    py,
                    Error::param(
                        "kind",
                        format!("{other:?}"),
                        "one of \"Hertz\", \"HuntCrossley\", \"LankaraniNikravesh\", \"Flores\", \"Gonthier\", \
                         \"CarvalhoMartins\", \"KelvinVoigt\"",
                    ),
                ))
            }
        };
        inner.validate("").map_err(|e| err(py, e))?;
        Ok(PyNormalLaw { inner, spring_damper })
    }

    /// The law's name.
    #[getter]
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    /// Whether the force depends on the penetration rate.
    #[getter]
    fn velocity_dependent(&self) -> bool {
        self.inner.velocity_dependent()
    }

    /// Whether the force depends on the approach speed of the episode.
    #[getter]
    fn needs_approach_speed(&self) -> bool {
        self.inner.needs_approach_speed()
    }

    /// Normal force (N) at penetration (m), rate (m/s) and approach speed (m/s).
    fn force<'py>(
        &self,
        py: Python<'py>,
        penetration: PyReadonlyArray1<'_, f64>,
        rate: PyReadonlyArray1<'_, f64>,
        approach_speed: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Array<'py>> {
        let [f] = map_arrays(
            py,
            "penetration, rate, approach_speed",
            [&penetration, &rate, &approach_speed],
            |[x0, x1, x2]| [self.inner.force(x0, x1, x2)],
        )?;
        Ok(f)
    }

    /// Tangents `(dF/dd` in N/m, `dF/d(dd)` in N s/m) at the same arguments as `force`.
    fn tangent<'py>(
        &self,
        py: Python<'py>,
        penetration: PyReadonlyArray1<'_, f64>,
        rate: PyReadonlyArray1<'_, f64>,
        approach_speed: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<(Array<'py>, Array<'py>)> {
        let [a, b] = map_arrays(
            py,
            "penetration, rate, approach_speed",
            [&penetration, &rate, &approach_speed],
            |[x0, x1, x2]| {
                let (a, b) = self.inner.tangent(x0, x1, x2);
                [a, b]
            },
        )?;
        Ok((a, b))
    }

    /// One impact of `mass` (kg) at `approach_speed` (m/s): `(restitution, contact_time` in s,
    /// `max_penetration` in m).
    fn effective_restitution(&self, py: Python<'_>, mass: f64, approach_speed: f64) -> PyResult<(f64, f64, f64)> {
        let law = self.inner.as_ref();
        let r = py.detach(|| effective_restitution(law, mass, approach_speed));
        let imp = r.map_err(|e| err(py, e))?;
        Ok((imp.restitution, imp.contact_time, imp.max_penetration))
    }
}

/// The friction of joint `name` (e.g. `joints[0]`) from the `friction` argument of
/// `add_clearance` (a `CoulombFriction` or `LuGreFriction`) and the journal radius (m, required
/// with friction, > 0). `None` without friction (a journal radius alone is accepted and unused).
pub(super) fn joint_friction(
    py: Python<'_>,
    name: &str,
    friction: Option<&Bound<'_, PyAny>>,
    journal_radius: Option<f64>,
) -> PyResult<Option<JointFriction>> {
    let Some(f) = friction else {
        return Ok(None);
    };
    let law = if let Ok(c) = f.cast::<PyCoulomb>() {
        FrictionLaw::Coulomb(c.get().inner)
    } else if let Ok(l) = f.cast::<PyLuGre>() {
        FrictionLaw::LuGre(l.get().inner)
    } else {
        return Err(err(
            py,
            Error::param(
                "friction",
                f.repr().map(|r| r.to_string()).unwrap_or_default(),
                "a friction law of flexclear.contact (Coulomb or LuGre)",
            ),
        ));
    };
    let Some(r) = journal_radius else {
        return Err(err(
            py,
            Error::param(
                "journal_radius",
                "None",
                "finite and > 0 m (required with friction: the friction torque is F_t R_J)",
            ),
        ));
    };
    crate::error::check_positive("journal_radius", r, "m").map_err(|e| err(py, e))?;
    let jf = JointFriction { law, journal_radius: r };
    jf.validate(&format!("{name}.friction")).map_err(|e| err(py, e))?;
    Ok(Some(jf))
}

/// Regularized Coulomb friction.
#[pyclass(name = "CoulombFriction", module = "flexclear._core", frozen)]
pub(super) struct PyCoulomb {
    inner: Coulomb,
}

#[pymethods]
impl PyCoulomb {
    /// `regularization` is "ambrosio" (`v0`, `v1`, m/s) or "linear" (`v_reg`, m/s); a Stribeck
    /// curve when `mu_static` is given (`stribeck_speed` m/s, `stribeck_exponent`).
    #[new]
    #[pyo3(signature = (mu, regularization="ambrosio", v0=1e-4, v1=1e-2, v_reg=1e-3, mu_static=None,
                        stribeck_speed=1e-3, stribeck_exponent=2.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        mu: f64,
        regularization: &str,
        v0: f64,
        v1: f64,
        v_reg: f64,
        mu_static: Option<f64>,
        stribeck_speed: f64,
        stribeck_exponent: f64,
    ) -> PyResult<Self> {
        let regularization = match regularization {
            "ambrosio" => Regularization::Ambrosio { v0, v1 },
            "linear" => Regularization::Linear { v_reg },
            other => {
                return Err(err(
                    py,
                    Error::param(
                        "regularization",
                        format!("{other:?}"),
                        "one of \"ambrosio\", \"linear\"",
                    ),
                ))
            }
        };
        let inner = Coulomb {
            mu,
            regularization,
            stribeck: mu_static.map(|mu_static| Stribeck {
                mu_static,
                speed: stribeck_speed,
                exponent: stribeck_exponent,
            }),
        };
        inner.validate("").map_err(|e| err(py, e))?;
        Ok(PyCoulomb { inner })
    }

    /// Friction force (N) at slip speed (m/s) and normal force (N).
    fn force<'py>(
        &self,
        py: Python<'py>,
        slip_speed: PyReadonlyArray1<'_, f64>,
        normal_force: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Array<'py>> {
        let [f] = map_arrays(
            py,
            "slip_speed, normal_force",
            [&slip_speed, &normal_force],
            |[x0, x1]| [self.inner.force(x0, x1)],
        )?;
        Ok(f)
    }

    /// Tangents `(dF/dv` in N s/m, `dF/dF_N)`.
    fn tangent<'py>(
        &self,
        py: Python<'py>,
        slip_speed: PyReadonlyArray1<'_, f64>,
        normal_force: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<(Array<'py>, Array<'py>)> {
        let [a, b] = map_arrays(
            py,
            "slip_speed, normal_force",
            [&slip_speed, &normal_force],
            |[x0, x1]| {
                let (a, b) = self.inner.tangent(x0, x1);
                [a, b]
            },
        )?;
        Ok((a, b))
    }
}

/// LuGre friction normalized by the normal force.
#[pyclass(name = "LuGreFriction", module = "flexclear._core", frozen)]
pub(super) struct PyLuGre {
    inner: LuGre,
}

#[pymethods]
impl PyLuGre {
    /// Coefficients `mu`, `mu_static`, Stribeck speed (m/s), `sigma0` (1/m), `sigma1` (s/m),
    /// `sigma2` (N s/m).
    #[new]
    #[pyo3(signature = (mu, mu_static, stribeck_speed, sigma0=1e5, sigma1=0.0, sigma2=0.0))]
    fn new(
        py: Python<'_>,
        mu: f64,
        mu_static: f64,
        stribeck_speed: f64,
        sigma0: f64,
        sigma1: f64,
        sigma2: f64,
    ) -> PyResult<Self> {
        let inner = LuGre {
            mu,
            mu_static,
            stribeck_speed,
            sigma0,
            sigma1,
            sigma2,
        };
        inner.validate("").map_err(|e| err(py, e))?;
        Ok(PyLuGre { inner })
    }

    /// `dz/dt` (m/s) at state (m) and slip speed (m/s).
    fn derivative<'py>(
        &self,
        py: Python<'py>,
        state: PyReadonlyArray1<'_, f64>,
        slip_speed: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Array<'py>> {
        let [f] = map_arrays(py, "state, slip_speed", [&state, &slip_speed], |[x0, x1]| {
            [self.inner.derivative(x0, x1)]
        })?;
        Ok(f)
    }

    /// The state (m) after `dt` (s) at constant slip speed, exactly.
    fn advance<'py>(
        &self,
        py: Python<'py>,
        state: PyReadonlyArray1<'_, f64>,
        slip_speed: PyReadonlyArray1<'_, f64>,
        dt: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Array<'py>> {
        let [f] = map_arrays(
            py,
            "state, slip_speed, dt",
            [&state, &slip_speed, &dt],
            |[x0, x1, x2]| [self.inner.advance(x0, x1, x2)],
        )?;
        Ok(f)
    }

    /// Steady state (m) at slip speed (m/s).
    fn steady_state<'py>(&self, py: Python<'py>, slip_speed: PyReadonlyArray1<'_, f64>) -> PyResult<Array<'py>> {
        let v = slip_speed.as_slice()?;
        Ok(PyArray1::from_vec(
            py,
            v.iter().map(|&v| self.inner.steady_state(v)).collect(),
        ))
    }

    /// Friction force (N) at state (m), slip speed (m/s) and normal force (N).
    fn force<'py>(
        &self,
        py: Python<'py>,
        state: PyReadonlyArray1<'_, f64>,
        slip_speed: PyReadonlyArray1<'_, f64>,
        normal_force: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Array<'py>> {
        let [f] = map_arrays(
            py,
            "state, slip_speed, normal_force",
            [&state, &slip_speed, &normal_force],
            |[x0, x1, x2]| [self.inner.force(x0, x1, x2)],
        )?;
        Ok(f)
    }

    /// Tangents `(dF/dz` in N/m, `dF/dv` in N s/m, `dF/dF_N)`.
    fn tangent<'py>(
        &self,
        py: Python<'py>,
        state: PyReadonlyArray1<'_, f64>,
        slip_speed: PyReadonlyArray1<'_, f64>,
        normal_force: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<(Array<'py>, Array<'py>, Array<'py>)> {
        let [a, b, c] = map_arrays(
            py,
            "state, slip_speed, normal_force",
            [&state, &slip_speed, &normal_force],
            |[x0, x1, x2]| {
                let (a, b, c) = self.inner.tangent(x0, x1, x2);
                [a, b, c]
            },
        )?;
        Ok((a, b, c))
    }
}

/// Registers the classes of this file on `_core`.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyNormalLaw>()?;
    m.add_class::<PyCoulomb>()?;
    m.add_class::<PyLuGre>()?;
    Ok(())
}
