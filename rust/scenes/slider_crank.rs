//! Simeon's flexible slider-crank (`docs/scenes.md` scene 3), built as a KED [`Mechanism`]:
//! rigid crank at constant speed, flexible connecting rod, slider on a straight guide, no gravity;
//! optionally one of the two pins a revolute clearance joint.
//!
//! Data: Simeon, B. (1996), "Modelling a flexible slider crank mechanism by a mixed system of DAEs
//! and PDEs", Math. Modelling of Systems 2(1) 1-18; also the "slider crank" problem ("crank") of
//! the Test Set for IVP Solvers (Mazzia & Magherini): crank 0.15 m, rod 0.30 m of 8 x 8 mm steel
//! (E = 2.0e11 Pa, rho = 7870 kg/m^3), slider 0.075552 kg, crank 150 rad/s. The mechanism starts
//! from rest in the moving frames (no deformation), not from Simeon's initial values.
//!
//! Geometry: crank pivot at the origin, guide along global x at height `offset`. The rod is link
//! `"rod"` (frame origin at the crank pin A, x axis towards the slider pin B: node 0 at A, the last
//! node at B); the slider block is `"slider"`. Pin `"crank_pin"` joins rod node 0 to the crank body
//! point `(crank_length, 0)`, pin `"slider_pin"` the last rod node to the slider; the one named by
//! `clearance_at` becomes a clearance joint of the same name.
//!
//! [`Mechanism`]: crate::model::mechanism::Mechanism

use std::sync::Arc;

use super::bearing::{hertz_secant, BearingDerived};
use super::{bad, finite, positive};
use crate::contact::{ContactLaw, DampingLaw, SpringDamper};
use crate::error::{g6, Result};
use crate::kinematics::{FrameKinematics, Rotation, SliderCrank, SliderCrankFrame, SliderCrankLink};
use crate::model::check_elements;
use crate::model::mechanism::{Clearance, Endpoint, Link, Mechanism, Pin, Slider, Terms};
use crate::model::section::BeamSection;

/// One of the two pins of the slider-crank.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SliderCrankPin {
    /// Pin A, between rod node 0 and the crank (`"crank_pin"`).
    CrankPin,
    /// Pin B, between the last rod node and the slider (`"slider_pin"`).
    SliderPin,
}

impl SliderCrankPin {
    /// The pin's (or clearance joint's) name: `"crank_pin"` or `"slider_pin"`.
    pub fn name(self) -> &'static str {
        match self {
            SliderCrankPin::CrankPin => "crank_pin",
            SliderCrankPin::SliderPin => "slider_pin",
        }
    }
}

/// Parameters of the flexible slider-crank (SI units). `None` fields are derived as documented.
#[derive(Debug, Clone, PartialEq)]
pub struct FlexibleSliderCrank {
    /// Crank length, m. Default 0.15 (Simeon).
    pub crank_length: f64,
    /// Rod length, m; must exceed `crank_length + |offset|`. Default 0.30 (Simeon).
    pub rod_length: f64,
    /// Constant crank rate, rad/s (counter-clockwise positive). Default 150 (Simeon).
    pub crank_speed: f64,
    /// Side of the square rod section, m (A = side^2, I = side^4/12). Default 0.008 (Simeon).
    pub side: f64,
    /// Young's modulus of the rod, Pa. Default 2.0e11 (Simeon).
    pub youngs_modulus: f64,
    /// Density of the rod, kg/m^3. Default 7870 (Simeon).
    pub density: f64,
    /// Slider mass, kg (>= 0). Default 0.075552 (Simeon).
    pub slider_mass: f64,
    /// Rod elements. Default 8.
    pub elements: usize,
    /// Kelvin-Voigt coefficient of the rod, Pa s (>= 0). Default 0 (Simeon's rod is undamped).
    pub damping: f64,
    /// Height of the guide line, m. Default 0.
    pub offset: f64,
    /// Geometric (axial-force) terms K2, K3, D2 of the rod; `None` = automatic (on: the rod
    /// rotates).
    pub geometric: Option<bool>,
    /// Which pin, if any, is a clearance joint. Default none (both pins ideal). The fields below
    /// are used only when this is set.
    pub clearance_at: Option<SliderCrankPin>,
    /// Radial clearance, m (>= 0). Default 5e-4 (Flores et al.'s slider-crank studies).
    pub clearance: f64,
    /// Bearing stiffness K_B, N/m; `None` = the secant at `reference_penetration` of the Hertz
    /// law of a steel journal of `pin_radius` in a bearing of radius `pin_radius + clearance`
    /// (see [`hertz_secant`]; about 1.09e8 N/m for the defaults).
    pub bearing_stiffness: Option<f64>,
    /// Bearing damping C_B, N s/m; `None` = `2 bearing_damping_ratio sqrt(K_B m_eff)` with
    /// `m_eff` half the rod mass (crank pin) or the reduced mass of half the rod and the slider
    /// (slider pin).
    pub bearing_damping: Option<f64>,
    /// Journal radius of the derived K_B, m. Default 5e-3.
    pub pin_radius: f64,
    /// Poisson's ratio of the derived K_B (0 <= nu < 0.5). Default 0.3.
    pub poisson_ratio: f64,
    /// Penetration at which the Hertz law is linearized for K_B, m. Default 1e-5.
    pub reference_penetration: f64,
    /// Fraction of critical of the derived C_B (>= 0). Default 0.2 (a restitution of about 0.53
    /// for a linear spring-dashpot; 0.03 gives about 0.9).
    pub bearing_damping_ratio: f64,
    /// Form of the bearing damping. Default viscous `-C_B qdot`.
    pub damping_law: DampingLaw,
}

impl Default for FlexibleSliderCrank {
    fn default() -> Self {
        FlexibleSliderCrank {
            crank_length: 0.15,
            rod_length: 0.30,
            crank_speed: 150.0,
            side: 0.008,
            youngs_modulus: 2.0e11,
            density: 7870.0,
            slider_mass: 0.075552,
            elements: 8,
            damping: 0.0,
            offset: 0.0,
            geometric: None,
            clearance_at: None,
            clearance: 5e-4,
            bearing_stiffness: None,
            bearing_damping: None,
            pin_radius: 5e-3,
            poisson_ratio: 0.3,
            reference_penetration: 1e-5,
            bearing_damping_ratio: 0.2,
            damping_law: DampingLaw::Viscous,
        }
    }
}

/// Derived values of a slider-crank parameter set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliderCrankDerived {
    /// Rod section area, m^2.
    pub area: f64,
    /// Rod second moment of area, m^4.
    pub inertia: f64,
    /// Rod mass, kg.
    pub rod_mass: f64,
    /// The clearance joint's bearing, when `clearance_at` is set.
    pub bearing: Option<BearingDerived>,
}

impl FlexibleSliderCrank {
    /// The derived quantities (A, I, rod mass and, with a clearance joint, K_B, C_B). Fails with
    /// [`Error::InvalidParameter`](crate::Error::InvalidParameter) naming the first invalid field and its allowed range.
    pub fn derived(&self) -> Result<SliderCrankDerived> {
        positive("crank_length", self.crank_length)?;
        positive("rod_length", self.rod_length)?;
        positive("side", self.side)?;
        positive("youngs_modulus", self.youngs_modulus)?;
        positive("density", self.density)?;
        finite("crank_speed", self.crank_speed)?;
        finite("offset", self.offset)?;
        finite("slider_mass", self.slider_mass)?;
        finite("damping", self.damping)?;
        if self.slider_mass < 0.0 {
            return Err(bad("slider_mass", self.slider_mass, ">= 0 kg"));
        }
        if self.damping < 0.0 {
            return Err(bad("damping", self.damping, ">= 0 Pa s"));
        }
        check_elements("elements", self.elements)?;
        let reach = self.crank_length + self.offset.abs();
        if self.rod_length <= reach {
            return Err(bad(
                "rod_length",
                self.rod_length,
                format!(
                    "> crank_length + |offset| = {} m (the rod cannot reach the guide at every crank angle)",
                    g6(reach)
                ),
            ));
        }
        let area = self.side * self.side;
        let inertia = self.side.powf(4.0) / 12.0;
        let rod_mass = self.density * area * self.rod_length;
        let bearing = match self.clearance_at {
            None => None,
            Some(at) => {
                finite("clearance", self.clearance)?;
                if self.clearance < 0.0 {
                    return Err(bad("clearance", self.clearance, ">= 0 m"));
                }
                positive("pin_radius", self.pin_radius)?;
                positive("reference_penetration", self.reference_penetration)?;
                finite("poisson_ratio", self.poisson_ratio)?;
                finite("bearing_damping_ratio", self.bearing_damping_ratio)?;
                if !(0.0..0.5).contains(&self.poisson_ratio) {
                    return Err(bad("poisson_ratio", self.poisson_ratio, "0 <= nu < 0.5"));
                }
                if self.bearing_damping_ratio < 0.0 {
                    return Err(bad("bearing_damping_ratio", self.bearing_damping_ratio, ">= 0"));
                }
                let bearing_stiffness = self.bearing_stiffness.unwrap_or_else(|| {
                    // A zero clearance: the contact of a (nearly) fitted pin.
                    let c_ref = self.clearance.max(1e-9);
                    hertz_secant(
                        self.youngs_modulus,
                        self.poisson_ratio,
                        self.pin_radius,
                        c_ref,
                        self.reference_penetration,
                    )
                });
                let half = rod_mass / 2.0;
                let effective_mass = match at {
                    SliderCrankPin::CrankPin => half,
                    SliderCrankPin::SliderPin => half * self.slider_mass / (half + self.slider_mass),
                };
                let bearing_damping = self
                    .bearing_damping
                    .unwrap_or_else(|| 2.0 * self.bearing_damping_ratio * (bearing_stiffness * effective_mass).sqrt());
                Some(BearingDerived {
                    bearing_stiffness,
                    bearing_damping,
                    effective_mass,
                })
            }
        };
        Ok(SliderCrankDerived {
            area,
            inertia,
            rod_mass,
            bearing,
        })
    }

    /// Builds the mechanism: link `"rod"`, slider `"slider"`, pins `"crank_pin"` and
    /// `"slider_pin"` (in that order; the one named by `clearance_at` is instead the clearance
    /// joint of that name). Fails on invalid parameters (see [`FlexibleSliderCrank::derived`];
    /// the bearing law's K_B and C_B by [`ContactLaw::validate`] under `joints[0]`).
    pub fn build(&self) -> Result<Mechanism> {
        let d = self.derived()?;
        let law = match d.bearing {
            None => None,
            Some(b) => {
                let law = SpringDamper {
                    stiffness: b.bearing_stiffness,
                    damping: b.bearing_damping,
                    damping_law: self.damping_law,
                    no_tension: false,
                };
                law.validate("joints[0]")?;
                Some(Arc::new(law))
            }
        };
        let sc = Arc::new(SliderCrank::new(
            self.crank_length,
            self.rod_length,
            self.offset,
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
        let mut m = Mechanism {
            links: vec![Link {
                name: "rod".into(),
                section: BeamSection {
                    length: self.rod_length,
                    elements: self.elements,
                    youngs_modulus: self.youngs_modulus,
                    density: self.density,
                    damping: self.damping,
                    area: d.area,
                    inertia: d.inertia,
                },
                frame: frame(SliderCrankLink::Rod),
                terms: Terms {
                    geometric: self.geometric,
                    ..Terms::default()
                },
                rotary_inertia: false,
                initial_displacement: None,
                initial_velocity: None,
                rigid: None,
            }],
            sliders: vec![Slider {
                name: "slider".into(),
                mass: self.slider_mass,
                angle: 0.0,
                path: frame(SliderCrankLink::Slider),
            }],
            ..Default::default()
        };
        let ends = [
            (
                SliderCrankPin::CrankPin,
                0,
                Endpoint::Body {
                    frame: frame(SliderCrankLink::Crank),
                    point: [self.crank_length, 0.0],
                    name: "crank".into(),
                },
            ),
            (SliderCrankPin::SliderPin, self.elements, Endpoint::Slider(0)),
        ];
        for (pin, node, target) in ends {
            let journal = Endpoint::Node { link: 0, node };
            match &law {
                Some(law) if self.clearance_at == Some(pin) => m.joints.push(Clearance {
                    friction: None,
                    name: pin.name().into(),
                    journal,
                    bearing: target,
                    clearance: self.clearance,
                    law: law.clone(),
                }),
                _ => m.pins.push(Pin {
                    name: pin.name().into(),
                    a: journal,
                    b: target,
                }),
            }
        }
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Error;

    #[test]
    fn pins_become_the_named_clearance_joint_with_the_hertz_secant_bearing() {
        let ideal = FlexibleSliderCrank::default().build().unwrap();
        let names: Vec<&str> = ideal.pins.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["crank_pin", "slider_pin"]);
        assert!(ideal.joints.is_empty());
        assert!(matches!(ideal.pins[1].a, Endpoint::Node { link: 0, node: 8 }));
        assert!(ideal.validate(0.05).is_ok());
        // K_B closed form for the defaults: E* = 2e11 / (2 (1 - 0.09)), R* = 5e-3 * 5.5e-3 / 5e-4 m,
        // K_B = 4/3 E* sqrt(R*) sqrt(1e-5 m) = 1.0866e8 N/m (the value docs/scenes.md and tests/newton.rs use).
        let s = FlexibleSliderCrank {
            clearance_at: Some(SliderCrankPin::SliderPin),
            ..Default::default()
        };
        let d = s.derived().unwrap();
        let b = d.bearing.unwrap();
        assert!(
            (b.bearing_stiffness / 1.0866e8 - 1.0).abs() < 1e-4,
            "{}",
            b.bearing_stiffness
        );
        // Reduced mass of half the rod (0.075552 kg) and the slider (0.075552 kg).
        assert!((d.rod_mass - 0.151104).abs() < 1e-12 && (b.effective_mass - 0.037776).abs() < 1e-12);
        let m = s.build().unwrap();
        assert_eq!((m.pins.len(), m.joints.len()), (1, 1));
        assert_eq!(
            (m.pins[0].name.as_str(), m.joints[0].name.as_str()),
            ("crank_pin", "slider_pin")
        );
        assert!(matches!(m.joints[0].bearing, Endpoint::Slider(0)));
        assert!(m.validate(0.05).is_ok());
    }

    #[test]
    fn bad_parameters_are_named_with_their_range() {
        let name = |s: FlexibleSliderCrank| match s.build() {
            Err(Error::InvalidParameter { name, allowed, .. }) => (name, allowed),
            r => panic!("{r:?}"),
        };
        let d = FlexibleSliderCrank::default();
        let (n, a) = name(FlexibleSliderCrank {
            crank_length: 0.2,
            offset: 0.15,
            ..d.clone()
        });
        assert_eq!(n, "rod_length");
        assert!(a.starts_with("> crank_length + |offset| = 0.35 m"), "{a}");
        assert_eq!(
            name(FlexibleSliderCrank {
                elements: 0,
                ..d.clone()
            })
            .0,
            "elements"
        );
        assert_eq!(
            name(FlexibleSliderCrank {
                side: -1.0,
                ..d.clone()
            })
            .0,
            "side"
        );
        // Bearing data are checked only with a clearance joint.
        let bad_pin = FlexibleSliderCrank {
            poisson_ratio: 0.5,
            bearing_stiffness: Some(-1.0),
            ..d.clone()
        };
        assert!(bad_pin.build().is_ok());
        let with_joint = FlexibleSliderCrank {
            clearance_at: Some(SliderCrankPin::CrankPin),
            ..bad_pin
        };
        assert_eq!(name(with_joint.clone()).0, "poisson_ratio");
        let stiffness = FlexibleSliderCrank {
            poisson_ratio: 0.3,
            ..with_joint
        };
        assert_eq!(name(stiffness).0, "joints[0].stiffness");
    }
}
