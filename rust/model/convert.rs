//! The translating-frame [`Model`] written as a moving-frame [`Mechanism`]: a link whose frame
//! keeps a fixed angle and translates is a [`RotatingFrame`] with a fixed rotation; a rigid body
//! with prescribed translation is a body endpoint on such a frame; every clearance joint keeps its
//! law, clearance and sides.
//!
//! The Python `Model` builds only the mechanism; [`Mechanism::to_translating`] is what
//! `plan::Plan::compile` derives for the constant stepper where every link translates, and
//! [`Mechanism::from_translating`] writes the Rust scenes built as translating models (the
//! slider-yoke) as the one user model.

use std::sync::Arc;

use super::mechanism::{Clearance, Endpoint, Link, Mechanism, Terms};
use super::{FlexibleLink, JointTarget, Model, RigidBody};
use crate::error::{Error, Result};
use crate::kinematics::{FrameKinematics, RotatingFrame, Rotation};

impl FlexibleLink {
    /// The link's frame as a moving frame: the fixed angle, the origin on the link's motion.
    pub fn frame(&self) -> RotatingFrame {
        RotatingFrame {
            origin: self.motion.clone(),
            rotation: Rotation::Fixed { angle: self.angle },
        }
    }
}

impl RigidBody {
    /// The body's frame as a moving frame: angle 0 (so an offset in global axes from the
    /// reference point is the same vector in the body frame), origin on the body's motion.
    pub fn frame(&self) -> RotatingFrame {
        RotatingFrame {
            origin: self.motion.clone(),
            rotation: Rotation::Fixed { angle: 0.0 },
        }
    }
}

impl Mechanism {
    /// The mechanism that moves exactly as `model`: one link per flexible link (frame at the
    /// link's fixed angle, origin on its motion; terms chosen automatically), one body endpoint
    /// per rigid body (frame at angle 0, so the joint's `point`, given in global axes from the
    /// body's reference point, is the same vector in the body frame), the clearance joints
    /// unchanged.
    ///
    /// Rotary inertia is kept: only the constant stepper has it ([`crate::plan`] runs such a
    /// mechanism there; the Newton stepper refuses it).
    pub fn from_translating(model: &Model) -> Result<Mechanism> {
        let mut mech = Mechanism::default();
        for l in &model.links {
            mech.links.push(Link {
                name: l.name.clone(),
                length: l.length,
                elements: l.elements,
                youngs_modulus: l.youngs_modulus,
                density: l.density,
                damping: l.damping,
                area: l.area,
                inertia: l.inertia,
                frame: Arc::new(l.frame()),
                terms: Terms::default(),
                rotary_inertia: l.rotary_inertia,
                initial_displacement: l.initial_displacement.clone(),
                initial_velocity: l.initial_velocity.clone(),
            });
        }
        let body_frames: Vec<Arc<dyn FrameKinematics>> = model
            .bodies
            .iter()
            .map(|b| Arc::new(b.frame()) as Arc<dyn FrameKinematics>)
            .collect();
        for j in &model.joints {
            let bearing = match j.target {
                JointTarget::Body { body, point } => Endpoint::Body {
                    frame: body_frames
                        .get(body)
                        .ok_or_else(|| Error::InvalidModel {
                            message: format!("joint {:?} refers to rigid body #{body}, which does not exist", j.name),
                        })?
                        .clone(),
                    point,
                    name: model.bodies[body].name.clone(),
                },
                JointTarget::Node { link, node } => Endpoint::Node { link, node },
            };
            mech.joints.push(Clearance {
                name: j.name.clone(),
                journal: Endpoint::Node {
                    link: j.link,
                    node: j.node,
                },
                bearing,
                clearance: j.clearance,
                law: j.law.clone(),
            });
        }
        Ok(mech)
    }
}

impl Mechanism {
    /// The translating-frame [`Model`] that moves exactly as this mechanism, when there is one:
    /// every link's frame a translation at a fixed angle ([`FrameKinematics::fixed_angle_translation`])
    /// whose terms resolve to the constant stepper's (no Coriolis, inertia coupling or
    /// geometric terms; the inertia load of the frame's motion on), every clearance joint from
    /// a node to a node or to a body point on such a frame, and nothing else (no pin, slider,
    /// support, point mass, load or gravity). Bodies are collected by name in the order the
    /// joints meet them; a body frame at a fixed angle `a` turns the joint's point (body frame)
    /// into global axes.
    ///
    /// The inverse of [`Mechanism::from_translating`]: `from_translating(m).to_translating()`
    /// gives back `m`'s links and joints with the same numbers (bodies that no joint uses are
    /// dropped: they carry nothing). Fails with the first reason, in words, that the constant
    /// stepper cannot take the mechanism.
    pub fn to_translating(&self) -> std::result::Result<Model, String> {
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
                length: l.length,
                elements: l.elements,
                youngs_modulus: l.youngs_modulus,
                density: l.density,
                damping: l.damping,
                area: l.area,
                inertia: l.inertia,
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
            model.joints.push(super::ClearanceJoint {
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
