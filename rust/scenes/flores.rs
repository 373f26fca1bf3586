//! The slider-crank of Flores, Ambrosio, Claro & Lankarani (2006-2008): a rigid crank at
//! constant speed, a rigid connecting rod, a slider, an ideal crank pin and a revolute clearance
//! joint at the piston pin (rod end - slider), the field's standard clearance-joint benchmark.
//!
//! Data as commonly cited (`../shared/CONTACT.md` section 4, `tests/data/flores_slider_crank.csv`),
//! NOT checked against the papers' own tables: crank 0.05 m, 0.30 kg, 1.0e-4 kg m^2; rod 0.12 m,
//! 0.21 kg, 2.5e-4 kg m^2 (centroid at mid-length); slider 0.14 kg; bearing radius 10.0 mm,
//! journal radius 9.5 mm (c = 0.5 mm); steel, E = 207 GPa, nu = 0.3; Lankarani-Nikravesh with
//! restitution 0.9 and the Hertz stiffness of the pin in its hole; crank 5000 rpm; no gravity.
//!
//! Geometry and names: crank pivot at the origin, guide along global x through it (no offset),
//! the crank's nominal angle 0 at t = 0. The rod is link `"rod"` (frame origin at the crank pin,
//! x axis toward the piston pin: node 0 at the crank pin, its last node at the piston pin); the
//! slider is `"slider"`; the ideal crank pin is pin `"crank_pin"` (rod node 0 to the crank body
//! point `(crank_length, 0)`), the piston pin the clearance joint `"piston_pin"` (journal: the
//! rod's last node; bearing: the slider), or with no clearance an ideal pin of that name (the
//! mechanism of rigid bodies then has no unknown and follows its nominal motion).

use std::sync::Arc;

use super::bearing::hertz_pin_stiffness;
use super::{bad, finite, positive};
use crate::contact::laws::{LankaraniNikravesh, NormalContact};
use crate::contact::ContactLaw;
use crate::error::Result;
use crate::kinematics::{FrameKinematics, Rotation, SliderCrank, SliderCrankFrame, SliderCrankLink};
use crate::model::check_elements;
use crate::model::mechanism::{Clearance, Endpoint, Link, Mechanism, Pin, RigidBody, Slider, Terms};
use crate::model::section::BeamSection;

/// Density of the flexible rod's steel, kg/m^3 (the section area gives the rod's 0.21 kg).
pub const ROD_DENSITY: f64 = 7800.0;

/// Parameters of the Flores slider-crank (SI units).
#[derive(Debug, Clone)]
pub struct FloresSliderCrank {
    /// Radial clearance of the piston pin, m (>= 0); `None`: an ideal pin. Default 5e-4.
    pub clearance: Option<f64>,
    /// The contact law of the piston pin; `None`: Lankarani-Nikravesh with restitution
    /// `restitution` and the Hertz stiffness [`hertz_pin_stiffness`] of a journal of
    /// `journal_radius` in a bearing of radius `journal_radius + clearance` (6.61e10 N/m^1.5 at
    /// the default 0.5 mm).
    pub law: Option<Arc<dyn ContactLaw>>,
    /// Crank speed, rad/s (counter-clockwise). Default 5000 rpm = 523.6 rad/s.
    pub crank_speed: f64,
    /// Crank length, m. Default 0.05.
    pub crank_length: f64,
    /// Rod length, m (> crank_length). Default 0.12.
    pub rod_length: f64,
    /// Rod mass, kg. Default 0.21.
    pub rod_mass: f64,
    /// Rod moment of inertia about its centroid, kg m^2. Default 2.5e-4.
    pub rod_inertia: f64,
    /// Slider mass, kg. Default 0.14.
    pub slider_mass: f64,
    /// Journal radius, m. Default 9.5e-3.
    pub journal_radius: f64,
    /// Young's modulus of pin and bearing (and of the flexible rod), Pa. Default 207e9.
    pub youngs_modulus: f64,
    /// Poisson's ratio of pin and bearing. Default 0.3.
    pub poisson_ratio: f64,
    /// Nominal restitution of the default law. Default 0.9.
    pub restitution: f64,
    /// A flexible rod instead of the rigid one: a steel beam of `ROD_DENSITY`, the rod's mass
    /// and length (square section of area `rod_mass / (ROD_DENSITY rod_length)`, 2.24e-4 m^2,
    /// side 14.98 mm, I = side^4 / 12 = 4.20e-9 m^4; its own rotary inertia m L^2 / 12 is
    /// 2.52e-4 kg m^2, the rigid rod's 2.5e-4). Default false.
    pub flexible_rod: bool,
    /// Elements of the flexible rod. Default 4.
    pub rod_elements: usize,
    /// Friction in the piston pin (on a journal of `journal_radius`); `None`: frictionless.
    pub friction: Option<crate::contact::friction::FrictionLaw>,
}

impl Default for FloresSliderCrank {
    fn default() -> Self {
        FloresSliderCrank {
            clearance: Some(5e-4),
            law: None,
            crank_speed: 5000.0 * std::f64::consts::TAU / 60.0,
            crank_length: 0.05,
            rod_length: 0.12,
            rod_mass: 0.21,
            rod_inertia: 2.5e-4,
            slider_mass: 0.14,
            journal_radius: 9.5e-3,
            youngs_modulus: 207e9,
            poisson_ratio: 0.3,
            restitution: 0.9,
            flexible_rod: false,
            rod_elements: 4,
            friction: None,
        }
    }
}

impl FloresSliderCrank {
    /// The Hertz stiffness of the default law at the scene's clearance (N/m^1.5), `None` without
    /// a clearance.
    pub fn pin_stiffness(&self) -> Option<f64> {
        self.clearance.map(|c| {
            hertz_pin_stiffness(
                self.journal_radius + c,
                self.journal_radius,
                self.youngs_modulus,
                self.poisson_ratio,
            )
        })
    }

    /// Builds the mechanism (names in the module doc). Fails with
    /// [`Error::InvalidParameter`](crate::Error::InvalidParameter) naming the first invalid field.
    pub fn build(&self) -> Result<Mechanism> {
        finite("crank_speed", self.crank_speed)?;
        positive("crank_length", self.crank_length)?;
        positive("rod_length", self.rod_length)?;
        positive("rod_mass", self.rod_mass)?;
        positive("rod_inertia", self.rod_inertia)?;
        positive("slider_mass", self.slider_mass)?;
        positive("journal_radius", self.journal_radius)?;
        positive("youngs_modulus", self.youngs_modulus)?;
        if !(0.0..0.5).contains(&self.poisson_ratio) {
            return Err(bad("poisson_ratio", self.poisson_ratio, "0 <= nu < 0.5"));
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(bad("restitution", self.restitution, "0 <= e <= 1"));
        }
        if let Some(c) = self.clearance {
            if !(c.is_finite() && c > 0.0) {
                return Err(bad("clearance", c, "a finite number > 0 m, or None for an ideal pin"));
            }
        }
        let elements = if self.flexible_rod {
            check_elements("rod_elements", self.rod_elements)?
        } else {
            1
        };
        let sc = Arc::new(SliderCrank::new(
            self.crank_length,
            self.rod_length,
            0.0,
            Rotation::Constant {
                angle0: 0.0,
                rate: self.crank_speed,
            },
        )?);
        let frame = |link| -> Arc<dyn FrameKinematics> {
            Arc::new(SliderCrankFrame {
                mechanism: sc.clone(),
                link,
            })
        };
        let area = self.rod_mass / (ROD_DENSITY * self.rod_length);
        let rod = Link {
            name: "rod".into(),
            section: BeamSection {
                length: self.rod_length,
                elements,
                youngs_modulus: self.youngs_modulus,
                density: ROD_DENSITY,
                damping: 0.0,
                area,
                inertia: area * area / 12.0,
            },
            frame: frame(SliderCrankLink::Rod),
            terms: Terms::default(),
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: None,
            rigid: (!self.flexible_rod).then_some(RigidBody {
                mass: self.rod_mass,
                inertia: self.rod_inertia,
                centroid: self.rod_length / 2.0,
            }),
        };
        let mut m = Mechanism {
            links: vec![rod],
            sliders: vec![Slider {
                name: "slider".into(),
                mass: self.slider_mass,
                angle: 0.0,
                path: frame(SliderCrankLink::Slider),
            }],
            pins: vec![Pin {
                name: "crank_pin".into(),
                a: Endpoint::Node { link: 0, node: 0 },
                b: Endpoint::Body {
                    frame: frame(SliderCrankLink::Crank),
                    point: [self.crank_length, 0.0],
                    name: "crank".into(),
                },
            }],
            ..Default::default()
        };
        let journal = Endpoint::Node {
            link: 0,
            node: elements,
        };
        match self.clearance {
            None => m.pins.push(Pin {
                name: "piston_pin".into(),
                a: journal,
                b: Endpoint::Slider(0),
            }),
            Some(c) => {
                let law: Arc<dyn ContactLaw> = match &self.law {
                    Some(l) => l.clone(),
                    None => Arc::new(NormalContact::new(LankaraniNikravesh::new(
                        self.pin_stiffness().unwrap_or_default(),
                        self.restitution,
                    ))),
                };
                law.validate("law")?;
                m.joints.push(Clearance {
                    name: "piston_pin".into(),
                    journal,
                    bearing: Endpoint::Slider(0),
                    clearance: c,
                    law,
                    friction: self.friction.map(|law| crate::contact::friction::JointFriction {
                        law,
                        journal_radius: self.journal_radius,
                    }),
                });
            }
        }
        Ok(m)
    }
}
