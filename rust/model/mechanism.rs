//! A kineto-elastodynamic (KED) mechanism: flexible links whose frames move with large prescribed
//! planar motion (translation and rotation), ideal pins between links, supports, sliders on
//! straight guides, point masses, nodal loads and clearance joints (docs/method.md sections 2-4).
//!
//! Plain data plus validation; [`crate::plan::simulate`] runs it on the stepper the plan picks
//! (the constant one on its translating form, else [`crate::integrator::newton`]). The nominal
//! (rigid-body) motion of every frame comes from a [`FrameKinematics`] (a spinning hub, a
//! slider-crank, a four-bar, tables); elastic displacements are measured in each link's frame.

use std::sync::Arc;

use super::section::{self, BeamSection};
use crate::contact::friction::JointFriction;
use crate::contact::ContactLaw;
use crate::element::BeamElement;
use crate::error::{check_finite, check_non_negative, check_positive, Error, Result};
use crate::kinematics::FrameKinematics;

/// Which terms of the element equation (docs/method.md section 2) a link carries. `None` = chosen
/// automatically from the link's motion: Coriolis and inertia coupling only for a rotating frame,
/// geometric stiffness (K2, K3, D2) only for a rotating frame or an axially loaded link, the
/// nominal-motion inertia load only for a frame that moves or under gravity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Terms {
    /// Coriolis `M_COR = 2 phidot rho A int N^T S N`.
    pub coriolis: Option<bool>,
    /// Rigid/elastic inertia coupling `M_IC = rho A int N^T (phiddot S - phidot^2 I) N`.
    pub inertia_coupling: Option<bool>,
    /// Geometric (axial-force) terms K2, K3 and D2, updated with the axial force by iteration.
    pub geometric: Option<bool>,
    /// Inertia load of the nominal motion `M_R a_R`.
    pub inertia_load: Option<bool>,
}

/// A straight flexible link of equal beam elements in a moving frame: node 0 at the frame origin,
/// the link along the frame's x axis.
#[derive(Debug, Clone)]
pub struct Link {
    /// Name, unique among links.
    pub name: String,
    /// Length, element count and section (SI units).
    pub section: BeamSection,
    /// Prescribed motion of the link frame.
    pub frame: Arc<dyn FrameKinematics>,
    /// Term selection (automatic by default).
    pub terms: Terms,
    /// Include rotary inertia in the mass matrix (the constant stepper only: the Newton stepper
    /// refuses it).
    pub rotary_inertia: bool,
    /// Initial elastic displacement, `3 (N + 1)` values `[u, v, th]` per node, link frame.
    pub initial_displacement: Option<Vec<f64>>,
    /// Initial elastic velocity relative to the frame, `3 (N + 1)` values (m/s, rad/s).
    pub initial_velocity: Option<Vec<f64>>,
    /// `Some`: the link is a rigid body ([`RigidBody`]), not a beam: it carries only its
    /// rigid-body deviation from the nominal motion (node 0's translation and one rotation), has
    /// one element (2 nodes) and of its section only the length counts.
    pub rigid: Option<RigidBody>,
}

/// The inertia of a rigid link: a rigid body along the frame's x axis, node 0 at the frame
/// origin, node 1 at `x = L`. Its unknowns are node 0's deviation `(u0, v0)` (shared with pins as
/// for any node) and one rotation `theta`; node 1 follows linearly, `[u0, v0 + L theta, theta]`,
/// as the beam elements' small deviations do. No stiffness, damping or geometric terms: only the
/// inertia of the body (mass, Coriolis, inertia coupling, nominal-motion load, gravity), exact
/// for the rigid body to first order in the deviation (docs in [`RigidBody::matrices`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidBody {
    /// Mass m, kg (> 0).
    pub mass: f64,
    /// Moment of inertia about the centroid, kg m^2 (>= 0).
    pub inertia: f64,
    /// Centroid position along the link from node 0, m (finite; L/2 for a uniform bar).
    pub centroid: f64,
}

/// The rigid-body terms of a [`RigidBody`] in its three unknowns `(u0, v0, theta)` (link-frame
/// components): see [`RigidBody::matrices`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMatrices {
    /// Mass about node 0, `[[m, 0, 0], [0, m, m c], [0, m c, J0]]`, `J0 = I + m c^2`.
    pub mass: [[f64; 3]; 3],
    /// Skew (Coriolis) matrix `int N^T S N dm = [[0, -m, -m c], [m, 0, 0], [m c, 0, 0]]`.
    pub skew: [[f64; 3]; 3],
    /// The mass of the inertia coupling `-rate^2 mt`: the mass with its `theta theta` entry
    /// zero (the centrifugal moment about node 0 of a rigid body turning about it vanishes).
    pub coupling: [[f64; 3]; 3],
    /// Load vectors `[bx, by, bxx, byx]`: the nominal-motion load is
    /// `bx a_x + by a_y - bxx rate^2 + byx accel` (a: the frame origin's acceleration minus
    /// gravity in link axes): `bx = [m, 0, 0]`, `by = [0, m, m c]`, `bxx = [m c, 0, 0]`,
    /// `byx = [0, m c, J0]`.
    pub loads: [[f64; 3]; 4],
    /// `m c`, kg m: the rotation's stiffness from the nominal load, `K_thth = -m c a_x`.
    pub first_moment: f64,
}

impl RigidBody {
    /// The terms of the body's equation in its unknowns `q = (u0, v0, theta)` (link frame,
    /// turning at `rate` with `accel`, origin acceleration minus gravity `a` in link axes):
    ///
    /// `M qdd + 2 rate G qd + (accel G - rate^2 mt - m c a_x e_th e_th^T) q
    ///  = F - (bx a_x + by a_y - bxx rate^2 + byx accel)`,
    ///
    /// the Newton-Euler equations of the body (translation of node 0, moment about node 0)
    /// linearized in the deviation: the moment of the nominal inertia forces about node 0 turns
    /// with `theta` (`-m c a_x theta`), the centrifugal moment of the body about node 0 does
    /// not (no `-rate^2 J0 theta`, which a linear displacement field would give).
    pub fn matrices(&self) -> RigidMatrices {
        let (m, c) = (self.mass, self.centroid);
        let j0 = self.inertia + m * c * c;
        let mass = [[m, 0.0, 0.0], [0.0, m, m * c], [0.0, m * c, j0]];
        let mut coupling = mass;
        coupling[2][2] = 0.0;
        RigidMatrices {
            mass,
            skew: [[0.0, -m, -m * c], [m, 0.0, 0.0], [m * c, 0.0, 0.0]],
            coupling,
            loads: [[m, 0.0, 0.0], [0.0, m, m * c], [m * c, 0.0, 0.0], [0.0, m * c, j0]],
            first_moment: m * c,
        }
    }
}

impl Link {
    /// A flexible link named `name` of `section` in `frame`: terms chosen automatically, no rotary
    /// inertia, starting undeformed at rest in its frame.
    pub fn new(name: impl Into<String>, section: BeamSection, frame: Arc<dyn FrameKinematics>) -> Self {
        Link {
            name: name.into(),
            section,
            frame,
            terms: Terms::default(),
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: None,
            rigid: None,
        }
    }

    /// Element length l = L / N, m.
    pub fn element_length(&self) -> f64 {
        self.section.element_length()
    }

    /// The element all of whose copies make up the link (no rotary inertia).
    pub fn element(&self) -> BeamElement {
        self.section.element(false)
    }

    /// Number of nodes N + 1.
    pub fn nodes(&self) -> usize {
        self.section.elements + 1
    }
}

/// A point of the mechanism that a pin or clearance joint connects.
#[derive(Debug, Clone)]
pub enum Endpoint {
    /// Node `node` of link `link`.
    Node {
        /// Index into [`Mechanism::links`].
        link: usize,
        /// Node index, 0 ..= elements.
        node: usize,
    },
    /// A point of a rigid body with prescribed motion (a crank, ground): it has no elastic
    /// displacement. `point` is its position in the body frame, m.
    Body {
        /// The body's frame motion.
        frame: Arc<dyn FrameKinematics>,
        /// Position in the body frame, m.
        point: [f64; 2],
        /// Name for messages.
        name: String,
    },
    /// A slider: index into [`Mechanism::sliders`].
    Slider(usize),
}

/// A slider block on a straight fixed guide: one elastic DOF `s` (m) along the guide on top of
/// its nominal motion.
#[derive(Debug, Clone)]
pub struct Slider {
    /// Name, unique among sliders.
    pub name: String,
    /// Mass, kg (>= 0).
    pub mass: f64,
    /// Guide direction, global angle, rad.
    pub angle: f64,
    /// Nominal motion of the slider pin (the frame origin is used; its angle is ignored).
    pub path: Arc<dyn FrameKinematics>,
}

/// An ideal revolute joint: translations shared, rotations free.
#[derive(Debug, Clone)]
pub struct Pin {
    /// Name, unique among pins and joints.
    pub name: String,
    /// A node.
    pub a: Endpoint,
    /// A node, a rigid-body point or a slider.
    pub b: Endpoint,
}

/// Elastic DOFs of a node held at zero in its link frame (a clamp at a hub, a simple support).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// Link index.
    pub link: usize,
    /// Node index.
    pub node: usize,
    /// Which of `u`, `v`, `theta` are held.
    pub fixed: [bool; 3],
}

/// A point mass at a node, kg; it moves with the link frame like the beam's own mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    /// Link index.
    pub link: usize,
    /// Node index.
    pub node: usize,
    /// Mass, kg.
    pub mass: f64,
}

/// A constant nodal load in the link frame: `[F_u, F_v]` (N) and a moment (N m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodalLoad {
    /// Link index.
    pub link: usize,
    /// Node index.
    pub node: usize,
    /// Force, link frame, N.
    pub force: [f64; 2],
    /// Moment, N m.
    pub moment: f64,
}

/// A revolute joint with radial clearance between a journal node and a bearing (node, body point
/// or slider).
#[derive(Debug, Clone)]
pub struct Clearance {
    /// Name, unique among pins and joints.
    pub name: String,
    /// The journal: a node.
    pub journal: Endpoint,
    /// The bearing.
    pub bearing: Endpoint,
    /// Radial clearance, m.
    pub clearance: f64,
    /// Contact law.
    pub law: Arc<dyn ContactLaw>,
    /// Friction in the joint and the journal radius (`None`: frictionless). A joint with
    /// friction runs on the Newton stepper's refactorizing path ([`crate::plan`]).
    pub friction: Option<JointFriction>,
}

/// The one user model: flexible links in any frame, sliders, pins, supports, point masses, loads,
/// gravity and clearance joints. Checked by [`Mechanism::validate`]; run by
/// [`crate::plan::simulate`] on the stepper [`crate::plan::Plan::compile`] picks for it (the
/// constant stepper on its translating form, [`Mechanism::to_translating`], or Newton), alone or
/// in a batch ([`crate::batch::run_batch`]). The bundled scenes ([`crate::scenes`]) build one.
#[derive(Debug, Clone, Default)]
pub struct Mechanism {
    /// Flexible links.
    pub links: Vec<Link>,
    /// Sliders.
    pub sliders: Vec<Slider>,
    /// Ideal pins.
    pub pins: Vec<Pin>,
    /// Supports.
    pub supports: Vec<Support>,
    /// Point masses.
    pub masses: Vec<PointMass>,
    /// Nodal loads.
    pub loads: Vec<NodalLoad>,
    /// Clearance joints.
    pub joints: Vec<Clearance>,
    /// Gravity, global, m/s^2.
    pub gravity: [f64; 2],
}

/// Tolerance of the closure check of pins: nominal positions must agree to this fraction of the
/// largest link length.
const CLOSURE_TOL: f64 = 1e-7;

impl Mechanism {
    /// Global nominal position of an endpoint at `t`, m.
    pub fn nominal_position(&self, e: &Endpoint, t: f64) -> [f64; 2] {
        match e {
            Endpoint::Node { link, node } => {
                let l = &self.links[*link];
                l.frame.frame(t).point(*node as f64 * l.element_length()).pos
            }
            Endpoint::Body { frame, point, .. } => {
                let f = frame.frame(t);
                let r = f.rotation();
                [
                    f.origin[0] + r[0][0] * point[0] + r[0][1] * point[1],
                    f.origin[1] + r[1][0] * point[0] + r[1][1] * point[1],
                ]
            }
            Endpoint::Slider(s) => self.sliders[*s].path.frame(t).origin,
        }
    }

    /// Global nominal position (m) and velocity (m/s) of an endpoint at `t`.
    pub fn nominal_kinematics(&self, e: &Endpoint, t: f64) -> ([f64; 2], [f64; 2]) {
        let k = match e {
            Endpoint::Node { link, node } => {
                let l = &self.links[*link];
                l.frame.frame(t).point(*node as f64 * l.element_length())
            }
            Endpoint::Body { frame, point, .. } => frame.frame(t).local_point(*point),
            Endpoint::Slider(s) => {
                let f = self.sliders[*s].path.frame(t);
                return (f.origin, f.origin_vel);
            }
        };
        (k.pos, k.vel)
    }

    /// The sides' largest nominal distance over 201 instants of `[0, t_end]` (m; NaN when not
    /// finite) and the first instant where it exceeds the closure tolerance (`CLOSURE_TOL` of
    /// the longest link), if any.
    fn separation(&self, a: &Endpoint, b: &Endpoint, t_end: f64) -> Option<(f64, f64)> {
        let scale = self.links.iter().fold(0.0f64, |s, l| s.max(l.section.length));
        (0..=200).map(|k| t_end * k as f64 / 200.0).find_map(|t| {
            let (pa, pb) = (self.nominal_position(a, t), self.nominal_position(b, t));
            let d = ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2)).sqrt();
            (d.is_nan() || d > CLOSURE_TOL * scale).then_some((t, d))
        })
    }

    /// Whether the two sides of clearance joint `j` move apart under the nominal motion over
    /// `[0, t_end]` (a stop fixed in space beside a moving link): the contact then measures the
    /// full relative position, nominal plus elastic. Joints whose sides stay together (within
    /// the closure tolerance) measure the elastic part only, as pins do.
    pub fn joint_moves_apart(&self, j: usize, t_end: f64) -> bool {
        let jt = &self.joints[j];
        self.separation(&jt.journal, &jt.bearing, t_end).is_some()
    }

    fn endpoint_name(&self, e: &Endpoint) -> String {
        match e {
            Endpoint::Node { link, node } => match self.links.get(*link) {
                Some(l) => format!("node {node} of link {:?}", l.name),
                None => format!("node {node} of link #{link}"),
            },
            Endpoint::Body { name, .. } => format!("body {name:?}"),
            Endpoint::Slider(s) => match self.sliders.get(*s) {
                Some(sl) => format!("slider {:?}", sl.name),
                None => format!("slider #{s}"),
            },
        }
    }

    fn check_endpoint(&self, name: &str, e: &Endpoint) -> Result<()> {
        match e {
            Endpoint::Node { link, node } => self.check_node(name, *link, *node),
            Endpoint::Body { point, .. } => {
                check_finite(&format!("{name}.point[0]"), point[0], "m")?;
                check_finite(&format!("{name}.point[1]"), point[1], "m")
            }
            Endpoint::Slider(s) => {
                if *s >= self.sliders.len() {
                    return Err(Error::InvalidModel {
                        message: format!(
                            "{name}: slider #{s} does not exist (the mechanism has {})",
                            self.sliders.len()
                        ),
                    });
                }
                Ok(())
            }
        }
    }

    /// Checks that link #`link` exists and has node `node`; a missing node is an
    /// [`Error::InvalidParameter`] named `name`.
    pub fn check_node(&self, name: &str, link: usize, node: usize) -> Result<()> {
        let links = self.links.iter().map(|l| (l.name.as_str(), l.section.elements));
        section::check_node(name, "mechanism", links, link, node)
    }

    /// Checks parameters, references, connectivity and kinematic closure over `[0, t_end]`.
    /// Fails with [`Error::InvalidParameter`] (naming the parameter and its range) or
    /// [`Error::InvalidModel`] (a dangling reference, a link with nothing attached, a pin whose
    /// two sides do not stay together under the nominal motion, an over-constrained node).
    pub fn validate(&self, t_end: f64) -> Result<()> {
        self.validate_apart(t_end).map(|_| ())
    }

    /// [`Mechanism::validate`], returning for each clearance joint whether its sides move apart
    /// under the nominal motion ([`Mechanism::joint_moves_apart`], which the validation's
    /// closure check finds on the way).
    pub fn validate_apart(&self, t_end: f64) -> Result<Vec<bool>> {
        if self.links.is_empty() {
            return Err(Error::InvalidModel {
                message: "the mechanism has no flexible link".into(),
            });
        }
        let mut names = std::collections::HashSet::new();
        for l in &self.links {
            if !names.insert(("link", l.name.as_str())) {
                return Err(Error::InvalidModel {
                    message: format!("two links are named {:?}", l.name),
                });
            }
        }
        for n in self
            .pins
            .iter()
            .map(|p| &p.name)
            .chain(self.joints.iter().map(|j| &j.name))
        {
            if !names.insert(("joint", n.as_str())) {
                return Err(Error::InvalidModel {
                    message: format!("two pins or joints are named {n:?}"),
                });
            }
        }
        check_finite("gravity[0]", self.gravity[0], "m/s^2")?;
        check_finite("gravity[1]", self.gravity[1], "m/s^2")?;
        for (i, l) in self.links.iter().enumerate() {
            let prefix = format!("links[{i}].");
            let section = l.section;
            match l.rigid {
                None => section.validate(&prefix)?,
                Some(b) => {
                    check_positive(&format!("{prefix}length"), section.length, "m")?;
                    if section.elements != 1 {
                        return Err(Error::param(
                            format!("{prefix}elements"),
                            section.elements,
                            "1 for a rigid link (its two nodes are its ends)",
                        ));
                    }
                    check_positive(&format!("{prefix}mass"), b.mass, "kg")?;
                    check_non_negative(&format!("{prefix}inertia"), b.inertia, "kg m^2")?;
                    check_finite(&format!("{prefix}centroid"), b.centroid, "m")?;
                }
            }
            l.frame.check(&format!("{prefix}frame"), t_end)?;
            section.validate_initial_state(
                &prefix,
                l.initial_displacement.as_deref(),
                l.initial_velocity.as_deref(),
            )?;
        }
        for (i, s) in self.sliders.iter().enumerate() {
            check_non_negative(&format!("sliders[{i}].mass"), s.mass, "kg")?;
            check_finite(&format!("sliders[{i}].angle"), s.angle, "rad")?;
            s.path.check(&format!("sliders[{i}].path"), t_end)?;
        }
        for (i, s) in self.supports.iter().enumerate() {
            self.check_node(&format!("supports[{i}].node"), s.link, s.node)?;
        }
        for (i, m) in self.masses.iter().enumerate() {
            self.check_node(&format!("masses[{i}].node"), m.link, m.node)?;
            check_non_negative(&format!("masses[{i}].mass"), m.mass, "kg")?;
        }
        for (i, f) in self.loads.iter().enumerate() {
            self.check_node(&format!("loads[{i}].node"), f.link, f.node)?;
            for (k, v) in [f.force[0], f.force[1], f.moment].into_iter().enumerate() {
                check_finite(
                    &format!("loads[{i}].{}", ["force[0]", "force[1]", "moment"][k]),
                    v,
                    "N or N m",
                )?;
            }
        }
        let pairs = self
            .pins
            .iter()
            .map(|p| (format!("pins[{:?}]", p.name), &p.name, &p.a, &p.b, "pin"))
            .chain(self.joints.iter().map(|j| {
                (
                    format!("joints[{:?}]", j.name),
                    &j.name,
                    &j.journal,
                    &j.bearing,
                    "clearance joint",
                )
            }));
        let mut apart = Vec::with_capacity(self.joints.len());
        for (label, name, a, b, kind) in pairs {
            if !matches!(a, Endpoint::Node { .. }) {
                return Err(Error::InvalidModel {
                    message: format!("{kind} {name:?}: its first side must be a node of a flexible link"),
                });
            }
            self.check_endpoint(&format!("{label}.a"), a)?;
            self.check_endpoint(&format!("{label}.b"), b)?;
            // a body's prescribed frame, as a link's: a four-bar that does not close, a table
            // that does not cover the run (a frame evaluated outside them is NaN)
            for e in [a, b] {
                if let Endpoint::Body { frame, name, .. } = e {
                    frame.check(&format!("bodies[{name:?}].frame"), t_end)?;
                }
            }
            if let (Endpoint::Node { link: la, node: na }, Endpoint::Node { link: lb, node: nb }) = (a, b) {
                if la == lb {
                    return Err(Error::InvalidModel {
                        message: format!(
                            "{kind} {name:?} joins nodes {na} and {nb} of the same link {:?}: over-constrained",
                            self.links[*la].name
                        ),
                    });
                }
            }
            // a clearance joint's sides may move apart (a stop beside a moving link); a pin's not
            let separation = self.separation(a, b, t_end);
            if kind != "pin" {
                apart.push(separation.is_some());
            }
            if let Some((t, d)) = separation {
                if kind == "pin" || d.is_nan() {
                    let (pa, pb) = (self.nominal_position(a, t), self.nominal_position(b, t));
                    return Err(Error::InvalidModel {
                        message: format!(
                            "{kind} {name:?} does not close: {} is at ({:.6}, {:.6}) m and {} at ({:.6}, {:.6}) m at t = {t} s ({d:.3e} m apart); the links' nominal motions must keep the two sides together",
                            self.endpoint_name(a),
                            pa[0],
                            pa[1],
                            self.endpoint_name(b),
                            pb[0],
                            pb[1]
                        ),
                    });
                }
            }
        }
        for (i, j) in self.joints.iter().enumerate() {
            check_non_negative(&format!("joints[{i}].clearance"), j.clearance, "m")?;
            j.law.validate(&format!("joints[{i}].law"))?;
            if let Some(f) = &j.friction {
                f.validate(&format!("joints[{i}].friction"))?;
            }
        }
        // Every link must be held by something: a free link's elastic motion is unrestrained.
        for (i, l) in self.links.iter().enumerate() {
            let on = |e: &Endpoint| matches!(e, Endpoint::Node { link, .. } if *link == i);
            let held = self.supports.iter().any(|s| s.link == i)
                || self.pins.iter().any(|p| on(&p.a) || on(&p.b))
                || self.joints.iter().any(|j| on(&j.journal) || on(&j.bearing));
            if !held {
                return Err(Error::InvalidModel {
                    message: format!(
                        "link {:?} has no joint, pin or support: nothing holds it to the mechanism",
                        l.name
                    ),
                });
            }
        }
        Ok(apart)
    }

    /// Index of the link named `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }
}
