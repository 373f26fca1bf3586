//! A cantilever clamped to a hub spun up in the plane (`docs/scenes.md`): the classic test of
//! geometric (centrifugal) stiffening, built as a [`Mechanism`] of one link `"beam"` on a
//! rotating frame, node 0 clamped at the hub centre.
//!
//! The hub angle follows Kane's smooth spin-up ([`Rotation::SpinUp`]): rate
//! `theta_dot(t) = (W/T) (t - (T/(2 pi)) sin(2 pi t/T))` for `t < T`, then `W`. Data sets
//! ([`SpinUpData`]): Kane, Ryan & Banerjee (1987), J. Guidance Control Dyn. 10(2) 139-151; Simo &
//! Vu-Quoc (1986), J. Appl. Mech. 53 849-863 (who give EI = 1.4e4 N m^2, rho A = 1.2 kg/m and
//! EA = 2.8e7 N only; E = 7e10 Pa is chosen here and A, I, rho follow).
//!
//! [`Mechanism`]: crate::model::mechanism::Mechanism

use std::sync::Arc;

use super::{finite, positive};
use crate::error::Result;
use crate::kinematics::{RotatingFrame, Rotation};
use crate::model::check_elements;
use crate::model::mechanism::{Link, Mechanism, Support, Terms};
use crate::model::section::BeamSection;
use crate::model::Motion;

/// The beam data of one of the two classic spin-up problems, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinUpValues {
    /// Beam length L, m.
    pub length: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
    /// Section area A, m^2.
    pub area: f64,
    /// Second moment of area I (in-plane bending), m^4.
    pub inertia: f64,
    /// Final hub rate W, rad/s.
    pub final_rate: f64,
    /// Ramp time T, s.
    pub ramp_time: f64,
}

/// Which published data set a spin-up scene starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpinUpData {
    /// Kane, Ryan & Banerjee (1987): L = 8 m, E = 6.8952e10 Pa, rho = 2766.67 kg/m^3,
    /// A = 7.2968e-5 m^2, I = 8.2189e-9 m^4, W = 4 rad/s, T = 15 s.
    Kane,
    /// Simo & Vu-Quoc (1986): L = 10 m, E = 7e10 Pa, rho = 3000 kg/m^3, A = 4e-4 m^2,
    /// I = 2e-7 m^4, W = 6 rad/s, T = 15 s.
    Simo,
}

impl SpinUpData {
    /// Both data sets, with their names (`"kane"`, `"simo"`).
    pub const ALL: [(&'static str, SpinUpData); 2] = [("kane", SpinUpData::Kane), ("simo", SpinUpData::Simo)];

    /// The data set's values.
    pub fn values(self) -> SpinUpValues {
        match self {
            SpinUpData::Kane => SpinUpValues {
                length: 8.0,
                youngs_modulus: 6.8952e10,
                density: 2766.67,
                area: 7.2968e-5,
                inertia: 8.2189e-9,
                final_rate: 4.0,
                ramp_time: 15.0,
            },
            // Simo & Vu-Quoc give EI, rho A and EA only; E = 7e10 Pa is our choice.
            SpinUpData::Simo => SpinUpValues {
                length: 10.0,
                youngs_modulus: 7.0e10,
                density: 3000.0,
                area: 4.0e-4,
                inertia: 2.0e-7,
                final_rate: 6.0,
                ramp_time: 15.0,
            },
        }
    }
}

/// Parameters of the spin-up scene: a data set and overrides of any of its values.
#[derive(Debug, Clone, PartialEq)]
pub struct SpinUp {
    /// The data set the `None` fields below come from. Default Kane's.
    pub data: SpinUpData,
    /// L, m (> 0).
    pub length: Option<f64>,
    /// E, Pa (> 0).
    pub youngs_modulus: Option<f64>,
    /// rho, kg/m^3 (> 0).
    pub density: Option<f64>,
    /// A, m^2 (> 0).
    pub area: Option<f64>,
    /// I, m^4 (> 0).
    pub inertia: Option<f64>,
    /// W, rad/s (finite).
    pub final_rate: Option<f64>,
    /// T, s (> 0).
    pub ramp_time: Option<f64>,
    /// Beam elements. Default 10 (the first two in-plane frequencies within 0.01 % of their
    /// converged values for the Kane data at rest).
    pub elements: usize,
    /// Geometric stiffness (K2, K3) on. Default true; false is the unstiffened linear model that
    /// diverges once the rate exceeds the first bending frequency.
    pub geometric: bool,
    /// Kelvin-Voigt coefficient eta, Pa s (>= 0). Default 0 (none in the references).
    pub damping: f64,
    /// Another hub angle driver (e.g. a constant rate for frequencies at speed); `None` = the
    /// spin-up to `final_rate` over `ramp_time` (which are then unused but still checked).
    pub rotation: Option<Rotation>,
}

impl Default for SpinUp {
    fn default() -> Self {
        SpinUp {
            data: SpinUpData::Kane,
            length: None,
            youngs_modulus: None,
            density: None,
            area: None,
            inertia: None,
            final_rate: None,
            ramp_time: None,
            elements: 10,
            geometric: true,
            damping: 0.0,
            rotation: None,
        }
    }
}

impl SpinUp {
    /// The values used: the data set with the given fields over it. Fails with
    /// [`crate::Error::InvalidParameter`] naming the first of `length`, `youngs_modulus`,
    /// `density`, `area`, `inertia`, `ramp_time` that is not finite and > 0, then `final_rate`,
    /// `damping` (finite), then `elements`.
    pub fn values(&self) -> Result<SpinUpValues> {
        let d = self.data.values();
        let v = SpinUpValues {
            length: self.length.unwrap_or(d.length),
            youngs_modulus: self.youngs_modulus.unwrap_or(d.youngs_modulus),
            density: self.density.unwrap_or(d.density),
            area: self.area.unwrap_or(d.area),
            inertia: self.inertia.unwrap_or(d.inertia),
            final_rate: self.final_rate.unwrap_or(d.final_rate),
            ramp_time: self.ramp_time.unwrap_or(d.ramp_time),
        };
        for (name, x) in [
            ("length", v.length),
            ("youngs_modulus", v.youngs_modulus),
            ("density", v.density),
            ("area", v.area),
            ("inertia", v.inertia),
            ("ramp_time", v.ramp_time),
        ] {
            positive(name, x)?;
        }
        finite("final_rate", v.final_rate)?;
        finite("damping", self.damping)?;
        check_elements("elements", self.elements)?;
        Ok(v)
    }

    /// Builds the mechanism: link `"beam"` on the hub frame (origin fixed at the hub centre,
    /// angle from `rotation` or the spin-up), geometric terms as `geometric` says (the others
    /// chosen from the motion), node 0 clamped (u = v = theta = 0). Fails as
    /// [`SpinUp::values`], then on the rotation (`rotation.*`, [`Rotation::validate`]) and the
    /// section (`links[0].*`: a negative `damping`).
    pub fn build(&self) -> Result<Mechanism> {
        let v = self.values()?;
        let rotation = self.rotation.clone().unwrap_or(Rotation::SpinUp {
            angle0: 0.0,
            final_rate: v.final_rate,
            ramp_time: v.ramp_time,
        });
        let frame = RotatingFrame::new(Motion::Fixed { position: [0.0, 0.0] }, rotation)?;
        let link = Link {
            name: "beam".into(),
            section: BeamSection {
                length: v.length,
                elements: self.elements,
                youngs_modulus: v.youngs_modulus,
                density: v.density,
                damping: self.damping,
                area: v.area,
                inertia: v.inertia,
            },
            frame: Arc::new(frame),
            terms: Terms {
                geometric: Some(self.geometric),
                ..Terms::default()
            },
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: None,
            rigid: None,
        };
        link.section.validate("links[0].")?;
        Ok(Mechanism {
            links: vec![link],
            supports: vec![Support {
                link: 0,
                node: 0,
                fixed: [true, true, true],
            }],
            ..Default::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Error;

    #[test]
    fn the_kane_beam_clamped_on_its_hub() {
        let m = SpinUp::default().build().unwrap();
        assert_eq!((m.links.len(), m.supports.len()), (1, 1));
        assert_eq!(m.links[0].section.length, 8.0);
        assert_eq!(m.links[0].terms.geometric, Some(true));
        assert!(m.validate(20.0).is_ok());
        let bad = SpinUp {
            data: SpinUpData::Simo,
            ramp_time: Some(0.0),
            ..Default::default()
        };
        assert!(matches!(bad.build(), Err(Error::InvalidParameter { name, .. }) if name == "ramp_time"));
        let negative = SpinUp {
            damping: -1.0,
            ..Default::default()
        };
        assert!(matches!(negative.build(), Err(Error::InvalidParameter { name, .. }) if name == "links[0].damping"));
    }
}
