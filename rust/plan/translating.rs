//! The constant stepper's compiled input: the translating-frame form of a [`Mechanism`] whose
//! every link and bearing body translates at a fixed angle (no pin, slider, support, point mass,
//! load or gravity; only clearance joints). [`crate::plan::Plan::compile`] derives it
//! ([`Mechanism::to_translating`]) when it picks the constant stepper; the assembly
//! ([`crate::plan::assembly::System`]), the constant stepper ([`crate::integrator::constant`]),
//! the lockstep lanes of [`crate::batch`] and the natural frequencies ([`crate::modes`]) take it.
//! It is not a user model: models are [`Mechanism`]s (`flexclear.Model` in Python), and Rust
//! code that tests or benches the constant stepper's internals derives this form the same way.
//!
//! Plain data plus validation; nothing here knows about matrices or time stepping.

use std::sync::Arc;

use crate::contact::ContactLaw;
use crate::element::BeamElement;
use crate::error::{check_finite, check_non_negative, Error, Result};
use crate::model::mechanism::{Endpoint, Mechanism};
use crate::model::section::{self, BeamSection};
use crate::model::Motion;

/// A straight flexible link meshed into equal beam elements. Its frame has a fixed orientation
/// `angle` and an origin that follows the prescribed translation `motion`; elastic displacements
/// are measured in that frame (floating frame of reference).
#[derive(Debug, Clone)]
pub struct FlexibleLink {
    /// Name, unique among links.
    pub name: String,
    /// Length, element count (node 0 at the frame origin), material and section: those of the
    /// mechanism's link it is derived from.
    pub section: BeamSection,
    /// Include rotary inertia in the mass matrix.
    pub rotary_inertia: bool,
    /// Orientation of the link axis in the global frame, rad (fixed).
    pub angle: f64,
    /// Prescribed translation of the frame origin.
    pub motion: Motion,
    /// Initial elastic displacement, `3 (N + 1)` values `[u, v, th]` per node, link frame.
    pub initial_displacement: Option<Vec<f64>>,
    /// Initial elastic velocity, `3 (N + 1)` values, link frame (m/s, rad/s).
    pub initial_velocity: Option<Vec<f64>>,
}

impl FlexibleLink {
    /// Length, element count and section.
    pub fn section(&self) -> BeamSection {
        self.section
    }

    /// Element length l = L / N, m.
    pub fn element_length(&self) -> f64 {
        self.section().element_length()
    }

    /// Number of DOFs, `3 (N + 1)`.
    pub fn dofs(&self) -> usize {
        self.section().dofs()
    }

    /// The element all of whose copies make up the link.
    pub fn element(&self) -> BeamElement {
        self.section().element(self.rotary_inertia)
    }

    /// Rotation matrix of the link frame, columns are the frame axes in global coordinates.
    pub fn rotation(&self) -> [[f64; 2]; 2] {
        let (s, c) = self.angle.sin_cos();
        [[c, -s], [s, c]]
    }

    fn validate(&self, i: usize) -> Result<()> {
        let prefix = format!("links[{i}].");
        let section = self.section();
        section.validate(&prefix)?;
        check_finite(&format!("{prefix}angle"), self.angle, "rad")?;
        self.motion.validate(&format!("{prefix}motion"))?;
        section.validate_initial_state(
            &prefix,
            self.initial_displacement.as_deref(),
            self.initial_velocity.as_deref(),
        )
    }
}

/// A rigid body with prescribed translation (yoke, ground).
#[derive(Debug, Clone)]
pub struct RigidBody {
    /// Name, unique among bodies.
    pub name: String,
    /// Prescribed motion of its reference point.
    pub motion: Motion,
}

/// What the journal node of a clearance joint is joined to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointTarget {
    /// The bearing centre is a point of a rigid body, at `point` (m) from its reference point.
    Body {
        /// Index into [`Model::bodies`].
        body: usize,
        /// Offset of the bearing centre from the body's reference point, m (global axes).
        point: [f64; 2],
    },
    /// The bearing centre is a node of another flexible link.
    Node {
        /// Index into [`Model::links`].
        link: usize,
        /// Node index on that link.
        node: usize,
    },
}

/// A revolute joint with radial clearance: the journal is a beam node, the bearing a body point
/// or another node. The contact law gives the force once the journal meets the bearing surface.
#[derive(Debug, Clone)]
pub struct ClearanceJoint {
    /// Name, unique among joints.
    pub name: String,
    /// Link of the journal node.
    pub link: usize,
    /// Journal node index on that link (0 ..= elements).
    pub node: usize,
    /// The bearing side.
    pub target: JointTarget,
    /// Radial clearance delta_c, m.
    pub clearance: f64,
    /// The contact law (spring-dashpot by default).
    pub law: Arc<dyn ContactLaw>,
}

/// The constant stepper's compiled input: links, bodies and joints, every frame a translation at
/// a fixed angle.
#[derive(Debug, Clone, Default)]
pub struct Model {
    /// Flexible links.
    pub links: Vec<FlexibleLink>,
    /// Rigid bodies with prescribed motion.
    pub bodies: Vec<RigidBody>,
    /// Clearance joints.
    pub joints: Vec<ClearanceJoint>,
}

fn check_unique<'a>(kind: &str, names: impl Iterator<Item = &'a str>) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for n in names {
        if !seen.insert(n) {
            return Err(Error::InvalidModel {
                message: format!("two {kind} are named {n:?}"),
            });
        }
    }
    Ok(())
}

impl Model {
    /// Checks every parameter and reference. Fails with [`Error::InvalidParameter`] naming the
    /// parameter and its allowed range, or [`Error::InvalidModel`] for dangling references.
    pub fn validate(&self) -> Result<()> {
        if self.links.is_empty() {
            return Err(Error::InvalidModel {
                message: "the model has no flexible link".into(),
            });
        }
        check_unique("links", self.links.iter().map(|l| l.name.as_str()))?;
        check_unique("bodies", self.bodies.iter().map(|b| b.name.as_str()))?;
        check_unique("joints", self.joints.iter().map(|j| j.name.as_str()))?;
        for i in 0..self.links.len() {
            self.links[i].validate(i)?;
        }
        for i in 0..self.bodies.len() {
            self.validate_body(i)?;
        }
        for i in 0..self.joints.len() {
            self.validate_joint(i)?;
        }
        Ok(())
    }

    /// Checks rigid body #`i` alone (its motion, its name among the earlier bodies).
    fn validate_body(&self, i: usize) -> Result<()> {
        let b = &self.bodies[i];
        if self.bodies[..i].iter().any(|o| o.name == b.name) {
            return Err(Error::InvalidModel {
                message: format!("two bodies are named {:?}", b.name),
            });
        }
        b.motion.validate(&format!("bodies[{i}].motion"))
    }

    /// Checks clearance joint #`i` alone: its name among the earlier joints, the nodes and body
    /// it refers to, its clearance and law.
    fn validate_joint(&self, i: usize) -> Result<()> {
        let j = &self.joints[i];
        if self.joints[..i].iter().any(|o| o.name == j.name) {
            return Err(Error::InvalidModel {
                message: format!("two joints are named {:?}", j.name),
            });
        }
        let p = |f: &str| format!("joints[{i}].{f}");
        self.check_node(&p("node"), j.link, j.node)?;
        match j.target {
            JointTarget::Body { body, point } => {
                if body >= self.bodies.len() {
                    return Err(Error::InvalidModel {
                        message: format!(
                            "joint {:?} refers to rigid body #{body}, but the model has {}",
                            j.name,
                            self.bodies.len()
                        ),
                    });
                }
                check_finite(&p("point[0]"), point[0], "m")?;
                check_finite(&p("point[1]"), point[1], "m")?;
            }
            JointTarget::Node { link, node } => {
                self.check_node(&p("target_node"), link, node)?;
                if link == j.link && node == j.node {
                    return Err(Error::InvalidModel {
                        message: format!("joint {:?} joins a node to itself", j.name),
                    });
                }
            }
        }
        check_non_negative(&p("clearance"), j.clearance, "m")?;
        j.law.validate(&p("law"))
    }

    fn check_node(&self, name: &str, link: usize, node: usize) -> Result<()> {
        let links = self.links.iter().map(|l| (l.name.as_str(), l.section.elements));
        section::check_node(name, "model", links, link, node)
    }
}

impl Mechanism {
    /// The translating-frame [`Model`] that moves exactly as this mechanism, when there is one:
    /// every link's frame a translation at a fixed angle ([`FrameKinematics::fixed_angle_translation`](crate::kinematics::FrameKinematics::fixed_angle_translation))
    /// whose terms resolve to the constant stepper's (no Coriolis, inertia coupling or
    /// geometric terms; the inertia load of the frame's motion on), every clearance joint from
    /// a node to a node or to a body point on such a frame, and nothing else (no pin, slider,
    /// support, point mass, load or gravity). Bodies are collected by name in the order the
    /// joints meet them; a body frame at a fixed angle `a` turns the joint's point (body frame)
    /// into global axes.
    ///
    /// Bodies that no joint uses are dropped (they carry nothing). Fails with the first reason,
    /// in words, that the constant stepper cannot take the mechanism ([`crate::plan::Plan`]
    /// reports it as the reason for the Newton stepper).
    pub fn to_translating(&self) -> std::result::Result<Model, String> {
        if let Some(l) = self.links.iter().find(|l| l.rigid.is_some()) {
            return Err(format!(
                "link {:?} is rigid (the constant stepper has flexible links only)",
                l.name
            ));
        }
        let parts = [
            (self.pins.len(), "a pin"),
            (self.sliders.len(), "a slider"),
            (self.supports.len(), "a support"),
            (self.masses.len(), "a point mass"),
            (self.loads.len(), "a nodal load"),
        ];
        if let Some((_, what)) = parts.iter().find(|(n, _)| *n > 0) {
            return Err(format!("the mechanism has {what}"));
        }
        if self.gravity != [0.0, 0.0] {
            return Err("the mechanism has gravity".into());
        }
        if let Some(j) = self.joints.iter().find(|j| j.friction.is_some()) {
            // friction makes the contact tangent unsymmetric: not for the LDL^T factor
            return Err(format!("clearance joint {:?} has friction", j.name));
        }
        let mut model = Model::default();
        for l in &self.links {
            let Some((motion, angle)) = l.frame.fixed_angle_translation() else {
                return Err(format!("the frame of link {:?} rotates", l.name));
            };
            let t = l.terms;
            let moves = l.frame.translates();
            if t.coriolis == Some(true) || t.inertia_coupling == Some(true) || t.geometric == Some(true) {
                return Err(format!(
                    "link {:?} asks for Coriolis, inertia-coupling or geometric terms",
                    l.name
                ));
            }
            if t.inertia_load == Some(false) && moves {
                return Err(format!(
                    "link {:?} leaves out the inertia load of its frame's motion",
                    l.name
                ));
            }
            model.links.push(FlexibleLink {
                name: l.name.clone(),
                section: l.section,
                rotary_inertia: l.rotary_inertia,
                angle,
                motion: motion.clone(),
                initial_displacement: l.initial_displacement.clone(),
                initial_velocity: l.initial_velocity.clone(),
            });
        }
        for j in &self.joints {
            let Endpoint::Node { link, node } = j.journal else {
                return Err(format!("the journal of joint {:?} is not a link node", j.name));
            };
            let target = match &j.bearing {
                Endpoint::Node { link, node } => JointTarget::Node {
                    link: *link,
                    node: *node,
                },
                Endpoint::Body { frame, point, name } => {
                    let Some((motion, angle)) = frame.fixed_angle_translation() else {
                        return Err(format!("the bearing body {name:?} of joint {:?} rotates", j.name));
                    };
                    let body = match model.bodies.iter().position(|b| &b.name == name) {
                        Some(b) if &model.bodies[b].motion == motion => b,
                        Some(_) => return Err(format!("two bodies named {name:?} move differently")),
                        None => {
                            model.bodies.push(RigidBody {
                                name: name.clone(),
                                motion: motion.clone(),
                            });
                            model.bodies.len() - 1
                        }
                    };
                    let point = if angle == 0.0 {
                        *point
                    } else {
                        let (s, c) = angle.sin_cos();
                        [c * point[0] - s * point[1], s * point[0] + c * point[1]]
                    };
                    JointTarget::Body { body, point }
                }
                Endpoint::Slider(_) => return Err(format!("joint {:?} has a slider as bearing", j.name)),
            };
            model.joints.push(ClearanceJoint {
                name: j.name.clone(),
                link,
                node,
                target,
                clearance: j.clearance,
                law: j.law.clone(),
            });
        }
        Ok(model)
    }
}
