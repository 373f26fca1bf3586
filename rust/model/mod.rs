//! The mechanism: flexible links, rigid bodies with prescribed motion, and clearance joints.
//! Plain data plus validation; nothing here knows about matrices or time stepping.

pub mod convert;
pub mod mechanism;
pub mod motion;
pub mod section;

use std::sync::Arc;

pub use motion::{Kinematics, Motion, Table};
pub use section::{check_elements, BeamSection, ELEMENTS_ALLOWED, MAX_ELEMENTS};

use crate::contact::ContactLaw;
use crate::element::BeamElement;
use crate::error::{check_finite, check_non_negative, Error, Result};

/// Degrees of freedom per beam node: axial u (m), transverse v (m), rotation theta (rad).
pub const NODE_DOFS: usize = 3;

/// A straight flexible link meshed into equal beam elements. Its frame has a fixed orientation
/// `angle` and an origin that follows the prescribed translation `motion`; elastic displacements
/// are measured in that frame (floating frame of reference).
#[derive(Debug, Clone)]
pub struct FlexibleLink {
    /// Name, unique among links.
    pub name: String,
    /// Length L, m.
    pub length: f64,
    /// Number of elements N, 1 ..= [`MAX_ELEMENTS`] (N + 1 nodes, node 0 at the frame origin).
    pub elements: usize,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
    /// Kelvin-Voigt damping eta, Pa s (D1 = (eta/E) K1).
    pub damping: f64,
    /// Section area A, m^2.
    pub area: f64,
    /// Second moment of area I, m^4.
    pub inertia: f64,
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
        BeamSection {
            length: self.length,
            elements: self.elements,
            youngs_modulus: self.youngs_modulus,
            density: self.density,
            damping: self.damping,
            area: self.area,
            inertia: self.inertia,
        }
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

/// A mechanism: links, bodies and joints.
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

    /// Checks link #`i` alone (its parameters and initial state) and that no earlier link has its
    /// name: what adding it to a valid model needs, in time independent of the model's size
    /// apart from the name scan.
    pub fn validate_link(&self, i: usize) -> Result<()> {
        let l = &self.links[i];
        if self.links[..i].iter().any(|o| o.name == l.name) {
            return Err(Error::InvalidModel {
                message: format!("two links are named {:?}", l.name),
            });
        }
        l.validate(i)
    }

    /// Checks rigid body #`i` alone (its motion, its name among the earlier bodies).
    pub fn validate_body(&self, i: usize) -> Result<()> {
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
    pub fn validate_joint(&self, i: usize) -> Result<()> {
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
        let links = self.links.iter().map(|l| (l.name.as_str(), l.elements));
        section::check_node(name, "model", links, link, node)
    }

    /// Index of the link named `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// Index of the joint named `name`.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }
}
