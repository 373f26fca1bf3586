//! The translating-frame [`Model`] written as a moving-frame [`Mechanism`]: a link whose frame
//! keeps a fixed angle and translates is a [`RotatingFrame`] with a fixed rotation; a rigid body
//! with prescribed translation is a body endpoint on such a frame; every clearance joint keeps its
//! law, clearance and sides.
//!
//! The Python `Model` builds on the translating model as long as it can and moves to the
//! mechanism when it meets a feature only the moving-frame engine has (a rotating frame, a pin,
//! a slider, a support, a mass, a load, gravity). The differential test of the two engines runs
//! the slider-yoke both ways through this conversion.

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
    /// Fails with [`Error::InvalidModel`] when a link asks for rotary inertia, which the
    /// moving-frame engine does not have.
    pub fn from_translating(model: &Model) -> Result<Mechanism> {
        let mut mech = Mechanism::default();
        for l in &model.links {
            if l.rotary_inertia {
                return Err(Error::InvalidModel {
                    message: format!(
                        "link {:?} has rotary_inertia=True, which only models whose links all translate \
                         (no rotating frame, pin, slider, support, mass, load or gravity) support",
                        l.name
                    ),
                });
            }
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
