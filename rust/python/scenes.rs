//! Bindings of the bundled scenes (`flexclear.scenes`): each builds the scene in Rust
//! (`crate::scenes`) and returns the one model class with the scene's derived values.
//!
//! The Python wrappers check the types of their keywords; the ranges are checked here, by the
//! scenes, in the order of their documentation. A numeric keyword that is not a Python `int` or
//! `float` reaches the scene as NaN (a count that is not an `int`, or is a `bool`, as 0), so the
//! scene's own check refuses it in its order; the message then shows the value as the caller gave
//! it (`str`), as Python's checks would.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt};

use super::mechanism::PyMechanism;
use super::motion::PyRotation;
use super::{err, parse_damping_law};
use crate::contact::DampingLaw;
use crate::error::{check_non_negative, Error};
use crate::model::check_elements;
use crate::scenes::{
    BearingDerived, FlexibleFourBar, FlexibleSliderCrank, FloresSliderCrank, FourBarPin, SliderCrankPin, SliderYoke,
    SliderYokeGeometry, SpinUp, SpinUpData,
};

/// The keyword arguments of one scene call.
struct Keywords<'a, 'py> {
    py: Python<'py>,
    scene: &'static str,
    kw: &'a Bound<'py, PyDict>,
    /// The keywords whose errors show the value as given.
    numbers: &'static [&'static str],
}

impl<'py> Keywords<'_, 'py> {
    fn arg(&self, name: &str) -> PyResult<Bound<'py, PyAny>> {
        self.kw
            .get_item(name)?
            .ok_or_else(|| pyo3::exceptions::PyTypeError::new_err(format!("{}: missing keyword `{name}`", self.scene)))
    }

    /// A number (`int` or `float`; anything else NaN).
    fn num(&self, name: &str) -> PyResult<f64> {
        let v = self.arg(name)?;
        let number = v.is_instance_of::<PyFloat>() || v.is_instance_of::<PyInt>();
        Ok(if number {
            v.extract().unwrap_or(f64::NAN)
        } else {
            f64::NAN
        })
    }

    /// `None` or a number.
    fn opt_num(&self, name: &str) -> PyResult<Option<f64>> {
        Ok(if self.arg(name)?.is_none() {
            None
        } else {
            Some(self.num(name)?)
        })
    }

    /// A count (an `int` that is not a `bool`; anything else, or a negative one, 0).
    fn count(&self, name: &str) -> PyResult<usize> {
        let v = self.arg(name)?;
        Ok(if v.is_instance_of::<PyInt>() && !v.is_instance_of::<PyBool>() {
            v.extract::<usize>().unwrap_or(0)
        } else {
            0
        })
    }

    /// Refuses a `bool` given for a link parameter, as `Model.add_link` does (a scene's own range
    /// checks take `True` as 1): `(keyword, name in the message, allowed)`, in order.
    fn no_bool(&self, links: &[(&str, &str, &str)]) -> PyResult<()> {
        for (key, name, allowed) in links {
            let v = self.arg(key)?;
            if v.is_instance_of::<PyBool>() {
                return Err(err(self.py, Error::param(*name, v.repr()?.to_string(), *allowed)));
            }
        }
        Ok(())
    }

    /// The error as a Python exception; for a keyword of `numbers`, the value as given.
    fn as_given(&self, e: Error) -> PyErr {
        let e = match e {
            Error::InvalidParameter { name, value, allowed } if self.numbers.contains(&name.as_str()) => {
                let value = self
                    .kw
                    .get_item(&name)
                    .ok()
                    .flatten()
                    .and_then(|v| v.str().ok().map(|s| s.to_string()))
                    .unwrap_or(value);
                Error::InvalidParameter { name, value, allowed }
            }
            e => e,
        };
        err(self.py, e)
    }
}

/// A scene's derived values as a dict: `values` in order, then, with a clearance joint, the
/// bearing's `bearing_stiffness`, `bearing_damping` and `effective_mass`.
fn derived_dict<'py>(
    py: Python<'py>,
    values: &[(&str, f64)],
    bearing: Option<BearingDerived>,
) -> PyResult<Bound<'py, PyDict>> {
    let info = PyDict::new(py);
    for (k, v) in values {
        info.set_item(*k, *v)?;
    }
    if let Some(b) = bearing {
        info.set_item("bearing_stiffness", b.bearing_stiffness)?;
        info.set_item("bearing_damping", b.bearing_damping)?;
        info.set_item("effective_mass", b.effective_mass)?;
    }
    Ok(info)
}

/// The numeric keywords of [`slider_crank`] that the scene checks by name. (`bearing_stiffness`
/// and `bearing_damping` are checked by the bearing law, as `joints[0].stiffness` / `.damping`.)
const SLIDER_CRANK_NUMBERS: &[&str] = &[
    "crank_length",
    "rod_length",
    "crank_speed",
    "side",
    "youngs_modulus",
    "density",
    "slider_mass",
    "elements",
    "damping",
    "offset",
    "clearance",
    "pin_radius",
    "poisson_ratio",
    "reference_penetration",
    "bearing_damping_ratio",
];

/// Builds the flexible slider-crank scene for `flexclear.scenes.slider_crank`, which passes
/// every keyword of `FlexibleSliderCrank` plus `clearance_at` (None, "crank_pin" or
/// "slider_pin") and `damping_law` (read only with a clearance joint). Returns the mechanism and
/// the derived values as a dict: `area`, `inertia`, `rod_mass` and, with a clearance joint,
/// `bearing_stiffness`, `bearing_damping`, `effective_mass`. Errors come in the order of the
/// scene's checks: `clearance_at` after the rod and slider data, `damping_law` after the bearing
/// data.
#[pyfunction]
#[pyo3(signature = (**kwargs))]
pub(super) fn slider_crank<'py>(
    py: Python<'py>,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<(PyMechanism, Bound<'py, PyDict>)> {
    let empty = PyDict::new(py);
    let k = Keywords {
        py,
        scene: "slider_crank",
        kw: kwargs.unwrap_or(&empty),
        numbers: SLIDER_CRANK_NUMBERS,
    };
    let scene = FlexibleSliderCrank {
        crank_length: k.num("crank_length")?,
        rod_length: k.num("rod_length")?,
        crank_speed: k.num("crank_speed")?,
        side: k.num("side")?,
        youngs_modulus: k.num("youngs_modulus")?,
        density: k.num("density")?,
        slider_mass: k.num("slider_mass")?,
        elements: k.count("elements")?,
        damping: k.num("damping")?,
        offset: k.num("offset")?,
        geometric: k.arg("geometric")?.extract()?,
        clearance_at: None,
        clearance: k.num("clearance")?,
        bearing_stiffness: k.opt_num("bearing_stiffness")?,
        bearing_damping: k.opt_num("bearing_damping")?,
        pin_radius: k.num("pin_radius")?,
        poisson_ratio: k.num("poisson_ratio")?,
        reference_penetration: k.num("reference_penetration")?,
        bearing_damping_ratio: k.num("bearing_damping_ratio")?,
        damping_law: DampingLaw::Viscous,
    };
    // A bad `clearance_at` or `damping_law` is reported after the checks that precede it.
    let after_checks_of =
        |s: &FlexibleSliderCrank, e: PyErr| -> PyErr { s.derived().map_or_else(|e| k.as_given(e), |_| e) };
    let at = k.arg("clearance_at")?;
    let at = if at.is_none() {
        None
    } else {
        match at.extract::<String>().as_deref() {
            Ok("crank_pin") => Some(SliderCrankPin::CrankPin),
            Ok("slider_pin") => Some(SliderCrankPin::SliderPin),
            _ => {
                let shown = at.repr().map_or_else(|_| String::from("?"), |r| r.to_string());
                let e = Error::param("clearance_at", shown, "None, \"crank_pin\" or \"slider_pin\"");
                return Err(after_checks_of(&scene, err(py, e)));
            }
        }
    };
    let mut scene = FlexibleSliderCrank {
        clearance_at: at,
        ..scene
    };
    if at.is_some() {
        let law = k.arg("damping_law")?.extract::<String>()?;
        scene.damping_law = parse_damping_law(py, &law).map_err(|e| after_checks_of(&scene, e))?;
    }
    let mech = scene.build().map_err(|e| k.as_given(e))?;
    let d = scene.derived().map_err(|e| k.as_given(e))?;
    let values = [("area", d.area), ("inertia", d.inertia), ("rod_mass", d.rod_mass)];
    Ok((PyMechanism { inner: mech }, derived_dict(py, &values, d.bearing)?))
}

/// The numeric keywords of [`four_bar`] that the scene checks by name.
const FOUR_BAR_NUMBERS: &[&str] = &[
    "ground_length",
    "crank_length",
    "coupler_length",
    "rocker_length",
    "crank_speed",
    "branch",
    "youngs_modulus",
    "density",
    "width",
    "depth",
    "elements",
    "rocker_elements",
    "damping",
    "clearance",
    "pin_radius",
    "poisson_ratio",
    "reference_penetration",
    "bearing_damping_ratio",
];

/// Builds the four-bar scene for `flexclear.scenes.four_bar`, which passes every keyword of
/// `FlexibleFourBar` (`clearance_at`: None, "crank_pin" or "rocker_pin"; `damping_law` read only
/// with a clearance joint). Returns the mechanism and the derived values as a dict: `area`,
/// `inertia`, `rocker_elements` and, with a clearance joint, `bearing_stiffness`,
/// `bearing_damping`, `effective_mass`. Errors come in the order of the scene's checks
/// (`clearance_at` after `branch`, `damping_law` after the bearing data and the joint's
/// clearance); a loop that does not close is a `ModelError` that shows the four lengths as given.
#[pyfunction]
#[pyo3(signature = (**kwargs))]
pub(super) fn four_bar<'py>(
    py: Python<'py>,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<(PyMechanism, Bound<'py, PyDict>)> {
    let empty = PyDict::new(py);
    let k = Keywords {
        py,
        scene: "four_bar",
        kw: kwargs.unwrap_or(&empty),
        numbers: FOUR_BAR_NUMBERS,
    };
    let rocker_elements = if k.arg("rocker_elements")?.is_none() {
        None
    } else {
        Some(k.count("rocker_elements")?)
    };
    let mut scene = FlexibleFourBar {
        ground_length: k.num("ground_length")?,
        crank_length: k.num("crank_length")?,
        coupler_length: k.num("coupler_length")?,
        rocker_length: k.num("rocker_length")?,
        crank_speed: k.num("crank_speed")?,
        branch: k.num("branch")?,
        youngs_modulus: k.num("youngs_modulus")?,
        density: k.num("density")?,
        width: k.num("width")?,
        depth: k.num("depth")?,
        elements: k.count("elements")?,
        flexible_rocker: k.arg("flexible_rocker")?.is_truthy()?,
        rocker_elements,
        damping: k.num("damping")?,
        clearance_at: None,
        clearance: k.num("clearance")?,
        bearing_stiffness: k.opt_num("bearing_stiffness")?,
        bearing_damping: k.opt_num("bearing_damping")?,
        pin_radius: k.num("pin_radius")?,
        poisson_ratio: k.num("poisson_ratio")?,
        reference_penetration: k.num("reference_penetration")?,
        bearing_damping_ratio: k.num("bearing_damping_ratio")?,
        damping_law: DampingLaw::Viscous,
    };
    let at = k.arg("clearance_at")?;
    if !at.is_none() {
        scene.clearance_at = match at.extract::<String>().as_deref() {
            Ok("crank_pin") => Some(FourBarPin::CrankPin),
            Ok("rocker_pin") => Some(FourBarPin::RockerPin),
            _ => {
                scene.check_leading().map_err(|e| k.as_given(e))?;
                let shown = at.str().map_or_else(|_| String::from("?"), |r| r.to_string());
                let e = Error::param("clearance_at", shown, "None, \"crank_pin\" or \"rocker_pin\"");
                return Err(err(py, e));
            }
        };
    }
    let derived = scene.derived().map_err(|e| match (e, scene.check_closure()) {
        (Error::InvalidModel { .. }, Err(closure @ Error::InvalidModel { .. })) => {
            let shown = |name: &str| {
                k.arg(name)
                    .and_then(|v| Ok(v.str()?.to_string()))
                    .unwrap_or_else(|_| "?".into())
            };
            super::errors::model_error(
                py,
                format!(
                    "four_bar(ground_length={}, crank_length={}, coupler_length={}, rocker_length={}): the loop does \
                     not close over a crank turn: {closure}",
                    shown("ground_length"),
                    shown("crank_length"),
                    shown("coupler_length"),
                    shown("rocker_length"),
                ),
            )
        }
        (e, _) => k.as_given(e),
    })?;
    if scene.clearance_at.is_some() {
        let law = k.arg("damping_law")?.extract::<String>()?;
        scene.damping_law = match parse_damping_law(py, &law) {
            Ok(l) => l,
            Err(e) => {
                check_non_negative("joints[0].clearance", scene.clearance, "m").map_err(|e| err(py, e))?;
                return Err(e);
            }
        };
    }
    let mut link_keywords = vec![
        ("coupler_length", "length", "a finite number > 0, m"),
        ("youngs_modulus", "youngs_modulus", "a finite number > 0, Pa"),
        ("density", "density", "a finite number > 0, kg/m^3"),
        ("damping", "damping", "a finite number >= 0, Pa s"),
    ];
    if scene.flexible_rocker {
        link_keywords.push(("rocker_length", "length", "a finite number > 0, m"));
    }
    k.no_bool(&link_keywords)?;
    let mech = scene.build().map_err(|e| k.as_given(e))?;
    let values = [("area", derived.area), ("inertia", derived.inertia)];
    let info = derived_dict(py, &values, derived.bearing)?;
    info.set_item("rocker_elements", derived.rocker_elements)?;
    Ok((PyMechanism { inner: mech }, info))
}

/// The numeric keywords of [`spin_up`] that the scene checks by name.
const SPIN_UP_NUMBERS: &[&str] = &[
    "length",
    "youngs_modulus",
    "density",
    "area",
    "inertia",
    "final_rate",
    "ramp_time",
    "elements",
    "damping",
];

/// The data sets of the spin-up scene: `{name: {length, youngs_modulus, density, area, inertia,
/// final_rate, ramp_time}}` (SI units; see `crate::scenes::SpinUpData`).
#[pyfunction]
pub(super) fn spin_up_data(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let all = PyDict::new(py);
    for (name, data) in SpinUpData::ALL {
        let v = data.values();
        let d = PyDict::new(py);
        d.set_item("length", v.length)?;
        d.set_item("youngs_modulus", v.youngs_modulus)?;
        d.set_item("density", v.density)?;
        d.set_item("area", v.area)?;
        d.set_item("inertia", v.inertia)?;
        d.set_item("final_rate", v.final_rate)?;
        d.set_item("ramp_time", v.ramp_time)?;
        all.set_item(name, d)?;
    }
    Ok(all)
}

/// Builds the spin-up scene for `flexclear.scenes.spin_up`, which passes `data` ("kane" or
/// "simo", checked there), the overrides (None = the data set's value), `elements`, `geometric`,
/// `damping` and `rotation` (None or a `flexclear.Rotation`, checked after `elements`). Returns the
/// mechanism.
#[pyfunction]
#[pyo3(signature = (**kwargs))]
pub(super) fn spin_up<'py>(py: Python<'py>, kwargs: Option<&Bound<'py, PyDict>>) -> PyResult<PyMechanism> {
    let empty = PyDict::new(py);
    let k = Keywords {
        py,
        scene: "spin_up",
        kw: kwargs.unwrap_or(&empty),
        numbers: SPIN_UP_NUMBERS,
    };
    let data = k.arg("data")?.extract::<String>()?;
    let Some(&(_, data)) = SpinUpData::ALL.iter().find(|(n, _)| *n == data) else {
        return Err(err(
            py,
            Error::param("data", format!("{data:?}"), "one of \"kane\", \"simo\""),
        ));
    };
    let mut scene = SpinUp {
        data,
        length: k.opt_num("length")?,
        youngs_modulus: k.opt_num("youngs_modulus")?,
        density: k.opt_num("density")?,
        area: k.opt_num("area")?,
        inertia: k.opt_num("inertia")?,
        final_rate: k.opt_num("final_rate")?,
        ramp_time: k.opt_num("ramp_time")?,
        elements: k.count("elements")?,
        geometric: k.arg("geometric")?.is_truthy()?,
        damping: k.num("damping")?,
        rotation: None,
    };
    scene.values().map_err(|e| k.as_given(e))?;
    let rotation = k.arg("rotation")?;
    if !rotation.is_none() {
        let Ok(r) = rotation.extract::<PyRef<'_, PyRotation>>() else {
            let shown = rotation.repr().map_or_else(|_| String::from("?"), |r| r.to_string());
            return Err(err(py, Error::param("rotation", shown, "a flexclear.Rotation")));
        };
        scene.rotation = Some(r.inner.clone());
    }
    k.no_bool(&[
        ("length", "length", "a finite number > 0, m"),
        ("youngs_modulus", "youngs_modulus", "a finite number > 0, Pa"),
        ("density", "density", "a finite number > 0, kg/m^3"),
        ("area", "area", "a finite number > 0, m^2"),
        ("inertia", "inertia", "a finite number > 0, m^4"),
        ("damping", "damping", "a finite number >= 0, Pa s"),
    ])?;
    let mech = scene.build().map_err(|e| k.as_given(e))?;
    Ok(PyMechanism { inner: mech })
}
/// Builds the slider-yoke scene (see `flexclear.scenes.slider_yoke`). Returns the model and the
/// derived parameters as a dict.
#[pyfunction]
#[pyo3(signature = (clearance=0.0, amplitude=0.010, frequency=6.0, length=0.269, side=0.0127, density=7850.0,
                    youngs_modulus=None, first_frequency=880.0, damping_ratio=0.01, elements=12,
                    bearing_stiffness=None, stiffness_ratio=100.0, bearing_damping=None, bearing_damping_ratio=0.5,
                    damping_law="viscous", no_tension=false, geometry="end", rotary_inertia=false))]
#[allow(clippy::too_many_arguments)]
pub(super) fn slider_yoke<'py>(
    py: Python<'py>,
    clearance: f64,
    amplitude: f64,
    frequency: f64,
    length: f64,
    side: f64,
    density: f64,
    youngs_modulus: Option<f64>,
    first_frequency: f64,
    damping_ratio: f64,
    elements: i64,
    bearing_stiffness: Option<f64>,
    stiffness_ratio: f64,
    bearing_damping: Option<f64>,
    bearing_damping_ratio: f64,
    damping_law: &str,
    no_tension: bool,
    geometry: &str,
    rotary_inertia: bool,
) -> PyResult<(PyMechanism, Bound<'py, PyDict>)> {
    let elements = check_elements("elements", elements).map_err(|e| err(py, e))?;
    let geometry = match geometry {
        "end" => SliderYokeGeometry::End,
        "both_ends" => SliderYokeGeometry::BothEnds,
        "mid_span" => SliderYokeGeometry::MidSpan,
        other => {
            return Err(err(
                py,
                Error::param(
                    "geometry",
                    format!("{other:?}"),
                    "one of \"end\", \"both_ends\", \"mid_span\"",
                ),
            ))
        }
    };
    let scene = SliderYoke {
        clearance,
        amplitude,
        frequency,
        length,
        side,
        density,
        youngs_modulus,
        first_frequency,
        damping_ratio,
        elements,
        bearing_stiffness,
        stiffness_ratio,
        bearing_damping,
        bearing_damping_ratio,
        damping_law: parse_damping_law(py, damping_law)?,
        no_tension,
        geometry,
        rotary_inertia,
    };
    let inner = scene.build().map_err(|e| err(py, e))?;
    let d = scene.derived().map_err(|e| err(py, e))?;
    let info = PyDict::new(py);
    info.set_item("area", d.area)?;
    info.set_item("inertia", d.inertia)?;
    info.set_item("mass", d.mass)?;
    info.set_item("youngs_modulus", d.youngs_modulus)?;
    info.set_item("eta", d.eta)?;
    info.set_item("bearing_stiffness", d.bearing_stiffness)?;
    info.set_item("bearing_damping", d.bearing_damping)?;
    Ok((PyMechanism { inner }, info))
}

/// Builds the Flores slider-crank for `flexclear.scenes.flores_slider_crank`: `clearance` (m, or
/// None for an ideal piston pin), `law` (a `flexclear.contact` law's core, or None for the
/// default Lankarani-Nikravesh), `crank_speed` (rad/s), `flexible_rod`, `rod_elements`. Returns
/// the mechanism and the derived values as a dict: `pin_stiffness` (N/m^1.5, with a clearance),
/// `rod_area` (m^2), `rod_inertia_of_area` (m^4), `rod_density` (kg/m^3).
#[pyfunction]
#[pyo3(signature = (clearance, law, crank_speed, flexible_rod, rod_elements, friction=None))]
pub(super) fn flores_slider_crank<'py>(
    py: Python<'py>,
    clearance: Option<f64>,
    law: Option<PyRef<'_, super::contact::PyNormalLaw>>,
    crank_speed: f64,
    flexible_rod: bool,
    rod_elements: i64,
    friction: Option<Bound<'_, PyAny>>,
) -> PyResult<(PyMechanism, Bound<'py, PyDict>)> {
    // the journal radius is the scene's own (9.5 mm)
    let radius = FloresSliderCrank::default().journal_radius;
    let friction = super::contact::joint_friction(py, "friction", friction.as_ref(), Some(radius))?.map(|f| f.law);
    let rod_elements = check_elements("rod_elements", rod_elements).map_err(|e| err(py, e))?;
    let law = match law {
        None => None,
        Some(l) => Some(super::contact::joint_law(
            py,
            "law",
            Some(l),
            0.0,
            0.0,
            "viscous",
            false,
        )?),
    };
    let scene = FloresSliderCrank {
        clearance,
        law,
        crank_speed,
        flexible_rod,
        rod_elements,
        friction,
        ..Default::default()
    };
    let inner = scene.build().map_err(|e| err(py, e))?;
    let area = inner.links[0].section.area;
    let mut values = vec![
        ("rod_area", area),
        ("rod_inertia_of_area", inner.links[0].section.inertia),
        ("rod_density", crate::scenes::flores::ROD_DENSITY),
    ];
    if let Some(k) = scene.pin_stiffness() {
        values.push(("pin_stiffness", k));
    }
    Ok((PyMechanism { inner }, derived_dict(py, &values, None)?))
}
