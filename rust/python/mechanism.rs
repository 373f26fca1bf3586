//! Bindings of the one user model: the `Mechanism` builder with its run and linearization (the
//! bundled scenes that build it are in `scenes.rs`).

use numpy::{PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;

use super::errors::{run_detached, to_pyerr};
use super::motion::PyFrame;
use super::output::{mat, run_output};
use super::{err, parse_coupling, parse_solver};
use crate::error::Error;
use crate::integrator::newton::NewtonRun;
use crate::integrator::Newmark;
use crate::model::check_elements;
use crate::model::mechanism::{
    Clearance, Endpoint, Link, Mechanism, NodalLoad, Pin, PointMass, Slider, Support, Terms,
};
use crate::model::section::BeamSection;
use crate::plan::StepperKind;
use crate::record::{LinkChannels, RecordSpec};
use crate::run::{NewtonSettings, Settings};

/// A kineto-elastodynamic mechanism under construction (see `flexclear.Mechanism`).
#[pyclass(name = "Mechanism", module = "flexclear._core")]
#[derive(Clone, Default)]
pub(super) struct PyMechanism {
    pub(super) inner: Mechanism,
}

fn vec_opt(a: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Option<Vec<f64>>> {
    a.map(|a| Ok(a.as_slice()?.to_vec())).transpose()
}

impl PyMechanism {
    fn link(&self, py: Python<'_>, name: &str, link: usize, node: usize) -> PyResult<()> {
        self.inner.check_node(name, link, node).map_err(|e| err(py, e))
    }

    #[allow(clippy::too_many_arguments)]
    fn endpoint(
        &self,
        py: Python<'_>,
        kind: &str,
        link: Option<usize>,
        node: Option<usize>,
        frame: Option<PyRef<'_, PyFrame>>,
        point: (f64, f64),
        slider: Option<usize>,
        body: &str,
    ) -> PyResult<Endpoint> {
        match kind {
            "node" => {
                let (Some(l), Some(n)) = (link, node) else {
                    return Err(err(
                        py,
                        Error::param("target", "node", "a (link, node) pair for a node target"),
                    ));
                };
                self.link(py, "target_node", l, n)?;
                Ok(Endpoint::Node { link: l, node: n })
            }
            "body" => {
                let Some(f) = frame else {
                    return Err(err(py, Error::param("target", "body", "a frame for a body target")));
                };
                Ok(Endpoint::Body {
                    frame: f.inner.clone(),
                    point: [point.0, point.1],
                    name: body.to_string(),
                })
            }
            "slider" => {
                let Some(s) = slider.filter(|s| *s < self.inner.sliders.len()) else {
                    return Err(err(
                        py,
                        Error::param(
                            "slider",
                            format!("{slider:?}"),
                            format!("a slider index 0 ..< {}", self.inner.sliders.len()),
                        ),
                    ));
                };
                Ok(Endpoint::Slider(s))
            }
            other => Err(err(
                py,
                Error::param("target", format!("{other:?}"), "one of \"node\", \"body\", \"slider\""),
            )),
        }
    }
}

#[pymethods]
impl PyMechanism {
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Adds a flexible link; returns its index. Term switches `None` = automatic.
    #[pyo3(signature = (name, length, elements, youngs_modulus, density, area, inertia, frame, damping=0.0,
                        coriolis=None, inertia_coupling=None, geometric=None, inertia_load=None,
                        initial_displacement=None, initial_velocity=None, rotary_inertia=false))]
    #[allow(clippy::too_many_arguments)]
    fn add_link(
        &mut self,
        py: Python<'_>,
        name: String,
        length: f64,
        elements: i64,
        youngs_modulus: f64,
        density: f64,
        area: f64,
        inertia: f64,
        frame: PyRef<'_, PyFrame>,
        damping: f64,
        coriolis: Option<bool>,
        inertia_coupling: Option<bool>,
        geometric: Option<bool>,
        inertia_load: Option<bool>,
        initial_displacement: Option<PyReadonlyArray1<'_, f64>>,
        initial_velocity: Option<PyReadonlyArray1<'_, f64>>,
        rotary_inertia: bool,
    ) -> PyResult<usize> {
        let i = self.inner.links.len();
        let elements = check_elements(&format!("links[{i}].elements"), elements).map_err(|e| err(py, e))?;
        if self.inner.links.iter().any(|l| l.name == name) {
            return Err(err(
                py,
                Error::InvalidModel {
                    message: format!("two links are named {name:?}"),
                },
            ));
        }
        let link = Link {
            name,
            section: BeamSection {
                length,
                elements,
                youngs_modulus,
                density,
                damping,
                area,
                inertia,
            },
            frame: frame.inner.clone(),
            terms: Terms {
                coriolis,
                inertia_coupling,
                geometric,
                inertia_load,
            },
            rotary_inertia,
            initial_displacement: vec_opt(initial_displacement)?,
            initial_velocity: vec_opt(initial_velocity)?,
            rigid: None,
        };
        link.section.validate(&format!("links[{i}].")).map_err(|e| err(py, e))?;
        self.inner.links.push(link);
        Ok(i)
    }

    /// Adds a rigid link (two nodes, node 0 at the frame origin, node 1 at `x = length`) of mass
    /// `mass` (kg), centroidal moment of inertia `inertia` (kg m^2) and centroid at `centroid` (m
    /// along the link); returns its index.
    #[allow(clippy::too_many_arguments)]
    fn add_rigid_link(
        &mut self,
        py: Python<'_>,
        name: String,
        length: f64,
        mass: f64,
        inertia: f64,
        centroid: f64,
        frame: PyRef<'_, PyFrame>,
    ) -> PyResult<usize> {
        let i = self.inner.links.len();
        if self.inner.links.iter().any(|l| l.name == name) {
            return Err(err(
                py,
                Error::InvalidModel {
                    message: format!("two links are named {name:?}"),
                },
            ));
        }
        let check = || -> crate::error::Result<()> {
            crate::error::check_positive(&format!("links[{i}].length"), length, "m")?;
            crate::error::check_positive(&format!("links[{i}].mass"), mass, "kg")?;
            crate::error::check_non_negative(&format!("links[{i}].inertia"), inertia, "kg m^2")?;
            crate::error::check_finite(&format!("links[{i}].centroid"), centroid, "m")
        };
        check().map_err(|e| err(py, e))?;
        self.inner.links.push(Link {
            name,
            section: BeamSection {
                length,
                elements: 1,
                youngs_modulus: 1.0,
                density: 1.0,
                damping: 0.0,
                area: 1.0,
                inertia: 1.0,
            },
            frame: frame.inner.clone(),
            terms: Terms::default(),
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: None,
            rigid: Some(crate::model::mechanism::RigidBody {
                mass,
                inertia,
                centroid,
            }),
        });
        Ok(i)
    }

    /// Adds a slider on a straight guide at global angle `angle` (rad) whose pin follows the
    /// origin of `path`; returns its index.
    fn add_slider(
        &mut self,
        py: Python<'_>,
        name: String,
        mass: f64,
        angle: f64,
        path: PyRef<'_, PyFrame>,
    ) -> PyResult<usize> {
        let i = self.inner.sliders.len();
        crate::error::check_non_negative(&format!("sliders[{i}].mass"), mass, "kg").map_err(|e| err(py, e))?;
        crate::error::check_finite(&format!("sliders[{i}].angle"), angle, "rad").map_err(|e| err(py, e))?;
        self.inner.sliders.push(Slider {
            name,
            mass,
            angle,
            path: path.inner.clone(),
        });
        Ok(i)
    }

    /// Adds an ideal pin between node `node` of `link` and a target: "node" (target_link,
    /// target_node), "body" (frame, point in the body frame, m) or "slider" (slider index).
    #[pyo3(signature = (name, link, node, target, target_link=None, target_node=None, frame=None, point=(0.0, 0.0), slider=None, body="body"))]
    #[allow(clippy::too_many_arguments)]
    fn add_pin(
        &mut self,
        py: Python<'_>,
        name: String,
        link: usize,
        node: usize,
        target: &str,
        target_link: Option<usize>,
        target_node: Option<usize>,
        frame: Option<PyRef<'_, PyFrame>>,
        point: (f64, f64),
        slider: Option<usize>,
        body: &str,
    ) -> PyResult<()> {
        self.link(py, "node", link, node)?;
        let b = self.endpoint(py, target, target_link, target_node, frame, point, slider, body)?;
        self.inner.pins.push(Pin {
            name,
            a: Endpoint::Node { link, node },
            b,
        });
        Ok(())
    }

    /// Adds a clearance joint: journal at node `node` of `link`, bearing at the target (as for
    /// `add_pin`), radial clearance (m), spring-dashpot bearing (N/m, N s/m).
    #[pyo3(signature = (name, link, node, target, clearance, stiffness, damping, target_link=None, target_node=None,
                        frame=None, point=(0.0, 0.0), slider=None, body="body", damping_law="viscous", no_tension=false,
                        law=None, friction=None, journal_radius=None))]
    #[allow(clippy::too_many_arguments)]
    fn add_clearance(
        &mut self,
        py: Python<'_>,
        name: String,
        link: usize,
        node: usize,
        target: &str,
        clearance: f64,
        stiffness: f64,
        damping: f64,
        target_link: Option<usize>,
        target_node: Option<usize>,
        frame: Option<PyRef<'_, PyFrame>>,
        point: (f64, f64),
        slider: Option<usize>,
        body: &str,
        damping_law: &str,
        no_tension: bool,
        law: Option<PyRef<'_, super::contact::PyNormalLaw>>,
        friction: Option<Bound<'_, PyAny>>,
        journal_radius: Option<f64>,
    ) -> PyResult<()> {
        self.link(py, "node", link, node)?;
        let i = self.inner.joints.len();
        let friction = super::contact::joint_friction(py, &format!("joints[{i}]"), friction.as_ref(), journal_radius)?;
        crate::error::check_non_negative(&format!("joints[{i}].clearance"), clearance, "m").map_err(|e| err(py, e))?;
        let law = super::contact::joint_law(
            py,
            &format!("joints[{i}]"),
            law,
            stiffness,
            damping,
            damping_law,
            no_tension,
        )?;
        let b = self.endpoint(py, target, target_link, target_node, frame, point, slider, body)?;
        self.inner.joints.push(Clearance {
            name,
            journal: Endpoint::Node { link, node },
            bearing: b,
            clearance,
            law,
            friction,
        });
        Ok(())
    }

    /// Holds elastic DOFs of a node at zero in its link frame.
    #[pyo3(signature = (link, node, u=true, v=true, theta=false))]
    fn add_support(&mut self, py: Python<'_>, link: usize, node: usize, u: bool, v: bool, theta: bool) -> PyResult<()> {
        self.link(py, "node", link, node)?;
        self.inner.supports.push(Support {
            link,
            node,
            fixed: [u, v, theta],
        });
        Ok(())
    }

    /// A point mass (kg) at a node.
    fn add_mass(&mut self, py: Python<'_>, link: usize, node: usize, mass: f64) -> PyResult<()> {
        self.link(py, "node", link, node)?;
        crate::error::check_non_negative("mass", mass, "kg").map_err(|e| err(py, e))?;
        self.inner.masses.push(PointMass { link, node, mass });
        Ok(())
    }

    /// A constant nodal load in the link frame (N, N, N m).
    #[pyo3(signature = (link, node, fu=0.0, fv=0.0, moment=0.0))]
    fn add_load(&mut self, py: Python<'_>, link: usize, node: usize, fu: f64, fv: f64, moment: f64) -> PyResult<()> {
        self.link(py, "node", link, node)?;
        self.inner.loads.push(NodalLoad {
            link,
            node,
            force: [fu, fv],
            moment,
        });
        Ok(())
    }

    /// Gravity, global, m/s^2.
    fn set_gravity(&mut self, gx: f64, gy: f64) {
        self.inner.gravity = [gx, gy];
    }

    /// Link names.
    #[getter]
    fn link_names(&self) -> Vec<String> {
        self.inner.links.iter().map(|l| l.name.clone()).collect()
    }

    /// Clearance joint names.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.inner.joints.iter().map(|j| j.name.clone()).collect()
    }

    /// Per clearance joint (in order): whether it has friction.
    #[getter]
    fn joint_friction(&self) -> Vec<bool> {
        self.inner.joints.iter().map(|j| j.friction.is_some()).collect()
    }

    /// The adaptive settings `(rtol, atol, h_min, h_max, newton_tol)` of a run of this model
    /// over `t_end` (s) asked for the relative accuracy `tol` with output grid `dt` (s) and
    /// longest step `max_step` (s; `None`: `crate::run::Adaptive::default_max_step`)
    /// (`crate::run::Adaptive::for_tolerance`); `newton_tol` is the Newton stepper's iteration
    /// tolerance when none is given (`crate::run::Adaptive::newton_tol`).
    #[pyo3(signature = (tol, t_end, dt, max_step=None))]
    fn tolerance_settings(
        &self,
        py: Python<'_>,
        tol: f64,
        t_end: f64,
        dt: f64,
        max_step: Option<f64>,
    ) -> PyResult<(f64, f64, f64, f64, f64)> {
        let h_max = max_step.unwrap_or_else(|| crate::run::Adaptive::default_max_step(t_end, dt));
        let clearances = self.inner.joints.iter().map(|j| j.clearance);
        let a = crate::run::Adaptive::for_tolerance(tol, clearances, dt, h_max).map_err(|e| err(py, e))?;
        let newton = a.newton_tol(crate::run::NewtonSettings::default().tol);
        Ok((a.rtol, a.atol, a.h_min, a.h_max, newton))
    }

    /// Ideal pin names, in order.
    #[getter]
    fn pin_names(&self) -> Vec<String> {
        self.inner.pins.iter().map(|p| p.name.clone()).collect()
    }

    /// Per link (in order): whether it is rigid (`add_rigid_link`: no deflection or axial force).
    #[getter]
    fn link_rigid(&self) -> Vec<bool> {
        self.inner.links.iter().map(|l| l.rigid.is_some()).collect()
    }

    /// Element counts per link.
    #[getter]
    fn link_elements(&self) -> Vec<usize> {
        self.inner.links.iter().map(|l| l.section.elements).collect()
    }

    /// Link lengths, m.
    #[getter]
    fn link_lengths(&self) -> Vec<f64> {
        self.inner.links.iter().map(|l| l.section.length).collect()
    }

    /// Slider names in order.
    /// For each clearance joint, whether one of its sides lies on a rotating frame (a link's or a
    /// rigid body's).
    #[getter]
    fn joint_rotating(&self) -> Vec<bool> {
        let rotates = |e: &Endpoint| match e {
            Endpoint::Node { link, .. } => self.inner.links[*link].frame.rotates(),
            Endpoint::Body { frame, .. } => frame.rotates(),
            Endpoint::Slider(_) => false,
        };
        self.inner
            .joints
            .iter()
            .map(|j| rotates(&j.journal) || rotates(&j.bearing))
            .collect()
    }

    /// The stepper `simulate` chooses for this mechanism when no energy is recorded:
    /// "constant", "constant-rate" or "newton" (see `flexclear.Model.simulate`, `stepper`).
    #[getter]
    fn stepper(&self) -> &'static str {
        match crate::plan::Plan::compile(&self.inner, &Settings::new(1.0, 1.0)) {
            Ok(p) => p.kind.name(),
            Err(_) => StepperKind::Newton.name(),
        }
    }

    /// Whether every link translates, so that `simulate` runs the model on the constant stepper
    /// (the `stepper` it chooses is "constant" exactly then): the model's translating form
    /// alone, without the plan `stepper` compiles (whose validation and moving-frame checks took
    /// 0.25 ms of each `simulate` call of the slider-crank).
    #[getter]
    fn translates(&self) -> bool {
        self.inner.to_translating().is_ok()
    }

    /// The named rigid bodies the clearance and pin joints bear on, each once, in the order of
    /// their first use: `(name, frame)`.
    #[getter]
    fn bodies(&self) -> Vec<(String, PyFrame)> {
        let mut out: Vec<(String, PyFrame)> = Vec::new();
        let ends = self.inner.joints.iter().flat_map(|j| [&j.journal, &j.bearing]);
        let pins = self.inner.pins.iter().flat_map(|p| [&p.a, &p.b]);
        for e in ends.chain(pins) {
            if let Endpoint::Body { frame, name, .. } = e {
                if !out.iter().any(|(n, _)| n == name) {
                    out.push((name.clone(), PyFrame { inner: frame.clone() }));
                }
            }
        }
        out
    }

    /// Axial stiffness E A of each link, N.
    #[getter]
    fn link_axial_stiffness(&self) -> Vec<f64> {
        self.inner
            .links
            .iter()
            .map(|l| l.section.youngs_modulus * l.section.area)
            .collect()
    }

    /// The link frames, in link order.
    #[getter]
    fn link_frames(&self) -> Vec<PyFrame> {
        self.inner
            .links
            .iter()
            .map(|l| PyFrame { inner: l.frame.clone() })
            .collect()
    }

    /// Lowest `count` natural frequencies, Hz, of a mechanism the constant stepper runs (its
    /// links' free vibration with every joint open, rigid-body modes left out), computed on the
    /// translating model the plan derives; a mechanism that needs Newton is refused with the
    /// reason (`flexclear.Model.natural_frequencies` linearizes it instead).
    fn natural_frequencies<'py>(&self, py: Python<'py>, count: i64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        if count < 1 {
            return Err(err(py, Error::param("count", count, "an integer >= 1")));
        }
        let model = self.inner.to_translating().map_err(|reason| {
            err(
                py,
                Error::InvalidModel {
                    message: format!("natural_frequencies of the constant stepper's model: {reason}"),
                },
            )
        })?;
        let f = py
            .detach(move || crate::modes::natural_frequencies(&model, count as usize))
            .map_err(|e| err(py, e))?;
        Ok(PyArray1::from_vec(py, f))
    }

    #[getter]
    fn slider_names(&self) -> Vec<String> {
        self.inner.sliders.iter().map(|s| s.name.clone()).collect()
    }

    /// Checks the whole mechanism over `[0, t_end]`.
    fn validate(&self, py: Python<'_>, t_end: f64) -> PyResult<()> {
        self.inner.validate(t_end).map_err(|e| err(py, e))
    }

    /// The unknowns: list of `(link, node, component)`.
    fn dof_map(&self, py: Python<'_>) -> PyResult<Vec<(i64, i64, String)>> {
        let settings = Settings::new(1.0, 1.0);
        let run = NewtonRun::new(&self.inner, &settings).map_err(|e| err(py, e))?;
        Ok(run
            .dof_map()
            .into_iter()
            .map(|(l, n, c)| {
                (
                    if l == usize::MAX { -1 } else { l as i64 },
                    if n == usize::MAX { -1 } else { n as i64 },
                    c.to_string(),
                )
            })
            .collect())
    }

    /// Linearization at time `t` (s) and state `y` (yd = zero when None): `(M, C, K, r)`;
    /// `contacts=False` leaves the clearance joints' contact terms out (every joint open).
    #[pyo3(signature = (t, y, yd=None, contacts=true))]
    #[allow(clippy::type_complexity)]
    fn linearize<'py>(
        &self,
        py: Python<'py>,
        t: f64,
        y: PyReadonlyArray1<'_, f64>,
        yd: Option<PyReadonlyArray1<'_, f64>>,
        contacts: bool,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
    )> {
        let settings = Settings::new(t.max(1e-9) * 2.0 + 1.0, 1.0);
        let mut run = NewtonRun::new(&self.inner, &settings).map_err(|e| err(py, e))?;
        let n = run.unknowns();
        let y = y.as_slice()?.to_vec();
        let yd = match yd {
            Some(v) => v.as_slice()?.to_vec(),
            None => vec![0.0; n],
        };
        let [m, c, k, r] = run.linearize_with(t, &y, &yd, contacts).map_err(|e| err(py, e))?;
        Ok((
            mat(py, m, n, n)?,
            mat(py, c, n, n)?,
            mat(py, k, n, n)?,
            PyArray1::from_vec(py, r),
        ))
    }

    /// Runs the mechanism; returns a dict of histories (see `flexclear.Mechanism.simulate`).
    #[pyo3(signature = (t_end, dt, method="modified", iterate=false, tol=None, max_iter=25, step_halving=0, beta=0.25, gamma=0.5,
                        alpha_m=0.0, alpha_f=0.0,
                        divergence_limit=None, every=1, displacements=true, axial_force=false, midspan=false, energy=false,
                        progress=None, events=false, joints=None, joint_position=false, histories=true, start=0.0,
                        impact_log=false, stepper=None, solver="woodbury", gap_stiffness=None, gap_damping=0.0,
                        nodes=Vec::new(), contact_modes=false, adaptive=None, sliders=false,
                        slider_reference=None, truncation_fraction=None, link_peaks=false))]
    #[allow(clippy::too_many_arguments)]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        t_end: f64,
        dt: f64,
        method: &str,
        iterate: bool,
        tol: Option<f64>,
        max_iter: i64,
        step_halving: i64,
        beta: f64,
        gamma: f64,
        alpha_m: f64,
        alpha_f: f64,
        divergence_limit: Option<f64>,
        every: i64,
        displacements: bool,
        axial_force: bool,
        midspan: bool,
        energy: bool,
        progress: Option<Py<PyAny>>,
        events: bool,
        joints: Option<Vec<usize>>,
        joint_position: bool,
        histories: bool,
        start: f64,
        impact_log: bool,
        stepper: Option<&str>,
        solver: &str,
        gap_stiffness: Option<f64>,
        gap_damping: f64,
        nodes: Vec<(usize, usize)>,
        contact_modes: bool,
        adaptive: Option<(f64, f64, f64, f64)>,
        sliders: bool,
        slider_reference: Option<PyRef<'py, super::output::PySliderReference>>,
        truncation_fraction: Option<f64>,
        link_peaks: bool,
    ) -> PyResult<Py<super::output::PyRunOutput>> {
        let solver = parse_solver(py, solver)?;
        let stepper = match stepper {
            None => None,
            Some("constant") => Some(StepperKind::Constant),
            Some("constant-rate") => Some(StepperKind::ConstantRate),
            Some("newton") => Some(StepperKind::Newton),
            Some(other) => {
                return Err(err(
                    py,
                    Error::param(
                        "stepper",
                        format!("{other:?}"),
                        "one of \"constant\", \"constant-rate\", \"newton\" or None",
                    ),
                ))
            }
        };
        let max_iter =
            usize::try_from(max_iter).map_err(|_| err(py, Error::param("max_iter", max_iter, "an integer >= 1")))?;
        let every = usize::try_from(every).map_err(|_| err(py, Error::param("every", every, "an integer >= 1")))?;
        let step_halving =
            u32::try_from(step_halving).map_err(|_| err(py, Error::param("step_halving", step_halving, "0 ..= 20")))?;
        // `tol` and `max_iter` are the within-step iteration of the stepper the plan picks: the
        // contact iteration of the constant stepper, Newton's otherwise (the coupling then keeps
        // the constant stepper's defaults, 1e-10 and 50); the gap element is the constant
        // stepper's: a model planned for Newton refuses it
        let coupling = parse_coupling(py, method, iterate, 1e-10, 50, gap_stiffness, gap_damping)?;
        // a tolerance given is met as given, the default also stops at the truncation fraction
        // (NewtonSettings::with_tol), unless a fraction is given
        let base = NewtonSettings::with_tol(tol);
        let newton = NewtonSettings {
            max_iter,
            step_halving,
            truncation_fraction: truncation_fraction.unwrap_or(base.truncation_fraction),
            ..base
        };
        let tol = newton.tol;
        let mut settings = Settings {
            newmark: Newmark {
                beta,
                gamma,
                alpha_m,
                alpha_f,
            },
            coupling,
            solver,
            divergence_limit,
            events,
            newton,
            record: RecordSpec {
                every,
                links: LinkChannels {
                    displacements,
                    axial_force,
                    midspan,
                    energy,
                    peaks: link_peaks,
                },
                joints,
                joint_position,
                histories,
                start,
                impacts: impact_log,
                nodes,
                contact_modes,
                sliders,
                slider_reference: slider_reference.map(|r| r.inner.clone()),
            },
            stepper,
            adaptive: adaptive.map(|(rtol, atol, h_min, h_max)| crate::run::Adaptive {
                rtol,
                atol,
                h_min,
                h_max,
            }),
            ..Settings::new(t_end, dt)
        };
        let mech = &self.inner;
        if let Some(r) = &settings.record.slider_reference {
            // whatever the stepper: a reference must line up with this run's sliders and grid
            let names: Vec<&str> = mech.sliders.iter().map(|s| s.name.as_str()).collect();
            (r.check_grid(&names, t_end, dt, every)).map_err(|e| err(py, e))?;
        }
        // one plan for the choice of coupling and for the run: the coupling's tolerance does not
        // enter the plan (the constant stepper's translating model, or the numbering and the
        // constant-rate check of the moving-frame steppers)
        let plan = crate::plan::Plan::compile(mech, &settings);
        if matches!(&plan, Ok(p) if p.kind == StepperKind::Constant) {
            settings.coupling = parse_coupling(py, method, iterate, tol, max_iter, gap_stiffness, gap_damping)?;
        }
        let link_elements: Vec<usize> = mech.links.iter().map(|l| l.section.elements).collect();
        let (res, pending) = run_detached(py, progress, |control| {
            let plan = plan.map_err(crate::run::RunFailure::before_start)?;
            crate::plan::simulate_planned(mech, &settings, &plan, control)
        });
        match res {
            Ok(out) => run_output(py, out, &link_elements),
            Err(fail) => {
                if let Some(e) = pending {
                    if !e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
                        return Err(e);
                    }
                }
                let partial = run_output(py, fail.output, &link_elements)?.into_bound(py).into_any();
                Err(to_pyerr(py, &fail.error, Some(partial)))
            }
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "Mechanism(links={:?}, sliders={}, pins={}, joints={:?})",
            self.link_names(),
            self.inner.sliders.len(),
            self.inner.pins.len(),
            self.joint_names()
        )
    }
}
