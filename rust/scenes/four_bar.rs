//! A crank-rocker four-bar with a flexible coupler (`docs/scenes.md`), built as a [`Mechanism`]:
//! a rigid crank at constant speed, a flexible coupler, a rigid or flexible rocker, no gravity;
//! optionally one of the two coupler pins a revolute clearance joint.
//!
//! Geometry: ground pivots O2 = (0, 0) (crank) and O4 = (`ground_length`, 0) (rocker). The coupler
//! is link `"coupler"` (frame origin at the crank pin A, x axis towards the rocker pin B); pin
//! `"crank_pin"` joins its node 0 to the crank body point `(crank_length, 0)`, pin `"rocker_pin"`
//! its last node to the rigid rocker's body point `(rocker_length, 0)`, or, with
//! `flexible_rocker`, to the last node of link `"rocker"` (frame origin at O4, x axis towards B),
//! whose node 0 is held at O4 (u = v = 0). The pin named by `clearance_at` becomes a clearance
//! joint of the same name.
//!
//! The numbers are illustrative, not a published test case: round inch lengths (10, 2, 11, 11 in)
//! in the proportions of laboratory flexible four-bars, a 1 in x 1/8 in aluminium strip with its
//! thin side in the plane. The geometry is Grashof with the crank shortest (a crank-rocker).
//!
//! [`Mechanism`]: crate::model::mechanism::Mechanism

use std::sync::Arc;

use super::bearing::{hertz_secant, BearingDerived};
use super::{bad, finite, positive};
use crate::contact::{ContactLaw, DampingLaw, SpringDamper};
use crate::error::{check_non_negative, g6, Error, Result};
use crate::kinematics::{FourBar, FourBarFrame, FourBarLink, FrameKinematics, Rotation};
use crate::model::check_elements;
use crate::model::mechanism::{Clearance, Endpoint, Link, Mechanism, Pin, Support, Terms};
use crate::model::section::BeamSection;

/// One of the two coupler pins of the four-bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FourBarPin {
    /// Pin A, between coupler node 0 and the crank (`"crank_pin"`).
    CrankPin,
    /// Pin B, between the last coupler node and the rocker (`"rocker_pin"`).
    RockerPin,
}

impl FourBarPin {
    /// The pin's (or clearance joint's) name: `"crank_pin"` or `"rocker_pin"`.
    pub fn name(self) -> &'static str {
        match self {
            FourBarPin::CrankPin => "crank_pin",
            FourBarPin::RockerPin => "rocker_pin",
        }
    }
}

/// Parameters of the flexible four-bar (SI units). `None` fields are derived as documented.
#[derive(Debug, Clone, PartialEq)]
pub struct FlexibleFourBar {
    /// Distance O2-O4 between the ground pivots, m. Default 0.254 (10 in).
    pub ground_length: f64,
    /// Crank length, m. Default 0.0508 (2 in).
    pub crank_length: f64,
    /// Coupler length, m. Default 0.2794 (11 in).
    pub coupler_length: f64,
    /// Rocker length, m. Default 0.2794 (11 in).
    pub rocker_length: f64,
    /// Constant crank rate, rad/s. Default 100 (955 rpm, a sixth of the coupler's first
    /// pinned-pinned bending frequency, about 593 rad/s).
    pub crank_speed: f64,
    /// Assembly: +1 open, -1 crossed (exactly). Default +1.
    pub branch: f64,
    /// Young's modulus of coupler and rocker, Pa. Default 7.1e10 (aluminium).
    pub youngs_modulus: f64,
    /// Density of coupler and rocker, kg/m^3. Default 2710 (aluminium).
    pub density: f64,
    /// Out-of-plane width of the section, m (A = width depth). Default 0.0254.
    pub width: f64,
    /// In-plane depth of the section, m (I = width depth^3 / 12). Default 0.003175.
    pub depth: f64,
    /// Coupler elements. Default 6.
    pub elements: usize,
    /// The rocker as a flexible link of the same section (else a rigid body). Default false.
    pub flexible_rocker: bool,
    /// Rocker elements; `None` = `elements`. Checked even for a rigid rocker.
    pub rocker_elements: Option<usize>,
    /// Kelvin-Voigt coefficient, Pa s (>= 0). Default 0.
    pub damping: f64,
    /// Which coupler pin, if any, is a clearance joint. Default none. The fields below are used
    /// only when this is set.
    pub clearance_at: Option<FourBarPin>,
    /// Radial clearance, m (>= 0). Default 2.5e-4.
    pub clearance: f64,
    /// Bearing stiffness K_B, N/m; `None` = the secant at `reference_penetration` of the Hertz
    /// law of a journal of `pin_radius` in a bearing of radius `pin_radius + clearance`
    /// ([`hertz_secant`] with the links' material; about 5.4e7 N/m for the defaults).
    pub bearing_stiffness: Option<f64>,
    /// Bearing damping C_B, N s/m; `None` = `2 bearing_damping_ratio sqrt(K_B m_eff)` with
    /// `m_eff` half the coupler mass, or at a rocker pin on a flexible rocker the reduced mass of
    /// half the coupler and half the rocker (about 516 N s/m for the defaults).
    pub bearing_damping: Option<f64>,
    /// Journal radius of the derived K_B, m. Default 5e-3.
    pub pin_radius: f64,
    /// Poisson's ratio of the derived K_B (0 <= nu < 0.5). Default 0.33 (aluminium).
    pub poisson_ratio: f64,
    /// Penetration at which the Hertz law is linearized for K_B, m. Default 1e-5.
    pub reference_penetration: f64,
    /// Fraction of critical of the derived C_B. Default 0.2.
    pub bearing_damping_ratio: f64,
    /// Form of the bearing damping. Default viscous `-C_B qdot`.
    pub damping_law: DampingLaw,
}

impl Default for FlexibleFourBar {
    fn default() -> Self {
        FlexibleFourBar {
            ground_length: 0.254,
            crank_length: 0.0508,
            coupler_length: 0.2794,
            rocker_length: 0.2794,
            crank_speed: 100.0,
            branch: 1.0,
            youngs_modulus: 7.1e10,
            density: 2710.0,
            width: 0.0254,
            depth: 0.003175,
            elements: 6,
            flexible_rocker: false,
            rocker_elements: None,
            damping: 0.0,
            clearance_at: None,
            clearance: 2.5e-4,
            bearing_stiffness: None,
            bearing_damping: None,
            pin_radius: 5e-3,
            poisson_ratio: 0.33,
            reference_penetration: 1e-5,
            bearing_damping_ratio: 0.2,
            damping_law: DampingLaw::Viscous,
        }
    }
}

/// Derived values of a four-bar parameter set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FourBarDerived {
    /// Section area, m^2.
    pub area: f64,
    /// Second moment of area, m^4.
    pub inertia: f64,
    /// Rocker elements (`rocker_elements`, else `elements`).
    pub rocker_elements: usize,
    /// The clearance joint's bearing, when `clearance_at` is set.
    pub bearing: Option<BearingDerived>,
}

impl FlexibleFourBar {
    /// The checks that come before `clearance_at` in the scene's order: the lengths, material and
    /// section (finite and > 0), `crank_speed` and `damping` (finite, damping >= 0), `branch`.
    pub fn check_leading(&self) -> Result<()> {
        for (name, v) in [
            ("ground_length", self.ground_length),
            ("crank_length", self.crank_length),
            ("coupler_length", self.coupler_length),
            ("rocker_length", self.rocker_length),
            ("youngs_modulus", self.youngs_modulus),
            ("density", self.density),
            ("width", self.width),
            ("depth", self.depth),
        ] {
            positive(name, v)?;
        }
        finite("crank_speed", self.crank_speed)?;
        finite("damping", self.damping)?;
        if self.damping < 0.0 {
            return Err(bad("damping", self.damping, ">= 0 Pa s"));
        }
        if self.branch != 1.0 && self.branch != -1.0 {
            return Err(bad("branch", self.branch, "+1 (open) or -1 (crossed)"));
        }
        Ok(())
    }

    fn four_bar(&self) -> Result<Arc<FourBar>> {
        let driver = Rotation::Constant {
            angle0: 0.0,
            rate: self.crank_speed,
        };
        Ok(Arc::new(FourBar::new(
            self.ground_length,
            self.crank_length,
            self.coupler_length,
            self.rocker_length,
            self.branch,
            driver,
        )?))
    }

    /// Whether the loop closes over one crank turn (`2 pi / |crank_speed|`, s; 1 s at rest): the
    /// coupler frame's [`FrameKinematics::check`] under the name `frame`, its error unchanged.
    pub fn check_closure(&self) -> Result<()> {
        let period = if self.crank_speed != 0.0 {
            2.0 * std::f64::consts::PI / self.crank_speed.abs()
        } else {
            1.0
        };
        let frame = FourBarFrame {
            mechanism: self.four_bar()?,
            link: FourBarLink::Coupler,
        };
        frame.check("frame", period)
    }

    /// The derived quantities (A, I, rocker elements and, with a clearance joint, K_B, C_B and
    /// the mass C_B is critical for). Fails with [`Error::InvalidParameter`] naming the first
    /// invalid field and its allowed range, in the order of [`FlexibleFourBar::check_leading`],
    /// `elements`, `rocker_elements`, the loop closure ([`Error::InvalidModel`]:
    /// `four_bar(ground_length=..., ...): the loop does not close over a crank turn: ...`), the
    /// section (`depth`), then the bearing data (`pin_radius`, `reference_penetration`,
    /// `clearance`, `bearing_damping_ratio`, `poisson_ratio`, `density`).
    pub fn derived(&self) -> Result<FourBarDerived> {
        self.check_leading()?;
        check_elements("elements", self.elements)?;
        let rocker_elements = check_elements("rocker_elements", self.rocker_elements.unwrap_or(self.elements))?;
        match self.check_closure() {
            Err(Error::InvalidModel { message }) => {
                return Err(Error::InvalidModel {
                    message: format!(
                        "four_bar(ground_length={:?}, crank_length={:?}, coupler_length={:?}, rocker_length={:?}): \
                         the loop does not close over a crank turn: {message}",
                        self.ground_length, self.crank_length, self.coupler_length, self.rocker_length
                    ),
                })
            }
            r => r?,
        }
        let (width, depth) = (self.width, self.depth);
        let area = width * depth;
        let inertia = width * depth * depth * depth / 12.0;
        if !(area.is_finite() && inertia.is_finite() && area > 0.0 && inertia > 0.0) {
            return Err(bad(
                "depth",
                depth,
                format!(
                    "a section whose area width depth and inertia width depth^3 / 12 are finite and > 0 (here \
                     width = {} m: {} m^2, {} m^4)",
                    g6(width),
                    g6(area),
                    g6(inertia)
                ),
            ));
        }
        let bearing = match self.clearance_at {
            None => None,
            Some(at) => {
                positive("pin_radius", self.pin_radius)?;
                positive("reference_penetration", self.reference_penetration)?;
                finite("clearance", self.clearance)?;
                finite("bearing_damping_ratio", self.bearing_damping_ratio)?;
                if !(0.0..0.5).contains(&self.poisson_ratio) {
                    return Err(bad("poisson_ratio", self.poisson_ratio, "0 <= nu < 0.5"));
                }
                let coupler_mass = self.density * area * self.coupler_length;
                if !(coupler_mass.is_finite() && coupler_mass > 0.0) {
                    return Err(bad(
                        "density",
                        self.density,
                        format!(
                            "a density whose coupler mass rho A L is finite and > 0 (here {} kg with A = {} m^2, \
                             L = {} m)",
                            g6(coupler_mass),
                            g6(area),
                            g6(self.coupler_length)
                        ),
                    ));
                }
                let mut effective_mass = 0.5 * coupler_mass;
                if at == FourBarPin::RockerPin && self.flexible_rocker {
                    let m_rocker = 0.5 * self.density * area * self.rocker_length;
                    effective_mass = effective_mass * m_rocker / (effective_mass + m_rocker);
                }
                let bearing_stiffness = self.bearing_stiffness.unwrap_or_else(|| {
                    hertz_secant(
                        self.youngs_modulus,
                        self.poisson_ratio,
                        self.pin_radius,
                        self.clearance.max(1e-12),
                        self.reference_penetration,
                    )
                });
                let bearing_damping = self.bearing_damping.unwrap_or_else(|| {
                    2.0 * self.bearing_damping_ratio * (bearing_stiffness.max(0.0) * effective_mass).sqrt()
                });
                Some(BearingDerived {
                    bearing_stiffness,
                    bearing_damping,
                    effective_mass,
                })
            }
        };
        Ok(FourBarDerived {
            area,
            inertia,
            rocker_elements,
            bearing,
        })
    }

    /// Builds the mechanism: link `"coupler"` (and `"rocker"`), pins `"crank_pin"` and
    /// `"rocker_pin"` in that order (the one named by `clearance_at` instead the clearance joint
    /// of that name, `joints[0]`), with a flexible rocker the support of its node 0 between them.
    /// Fails on invalid parameters (see [`FlexibleFourBar::derived`]), then as the links and the
    /// joint are added: each link's section (`links[i].*`, e.g. a modulus beyond 1e75 Pa), the
    /// joint's clearance (`joints[0].clearance`, >= 0 m) and the bearing law's K_B and C_B
    /// ([`ContactLaw::validate`] under `joints[0]`).
    pub fn build(&self) -> Result<Mechanism> {
        let d = self.derived()?;
        let fb = self.four_bar()?;
        let frame = |link| -> Arc<dyn FrameKinematics> {
            Arc::new(FourBarFrame {
                mechanism: fb.clone(),
                link,
            })
        };
        // each link checked as it is added, the joint's law where the joint is made
        let add_link = |m: &mut Mechanism, name: &str, length: f64, elements: usize, link| -> Result<()> {
            let l = Link {
                name: name.into(),
                section: BeamSection {
                    length,
                    elements,
                    youngs_modulus: self.youngs_modulus,
                    density: self.density,
                    damping: self.damping,
                    area: d.area,
                    inertia: d.inertia,
                },
                frame: frame(link),
                terms: Terms::default(),
                rotary_inertia: false,
                initial_displacement: None,
                initial_velocity: None,
                rigid: None,
            };
            l.section.validate(&format!("links[{}].", m.links.len()))?;
            m.links.push(l);
            Ok(())
        };
        let connect = |m: &mut Mechanism, pin: FourBarPin, node: usize, target: Endpoint| -> Result<()> {
            let journal = Endpoint::Node { link: 0, node };
            match d.bearing {
                Some(b) if self.clearance_at == Some(pin) => {
                    check_non_negative("joints[0].clearance", self.clearance, "m")?;
                    let law = SpringDamper {
                        stiffness: b.bearing_stiffness,
                        damping: b.bearing_damping,
                        damping_law: self.damping_law,
                        no_tension: false,
                    };
                    law.validate("joints[0]")?;
                    m.joints.push(Clearance {
                        friction: None,
                        name: pin.name().into(),
                        journal,
                        bearing: target,
                        clearance: self.clearance,
                        law: Arc::new(law),
                    })
                }
                _ => m.pins.push(Pin {
                    name: pin.name().into(),
                    a: journal,
                    b: target,
                }),
            }
            Ok(())
        };
        let mut m = Mechanism::default();
        add_link(
            &mut m,
            "coupler",
            self.coupler_length,
            self.elements,
            FourBarLink::Coupler,
        )?;
        let crank = Endpoint::Body {
            frame: frame(FourBarLink::Crank),
            point: [self.crank_length, 0.0],
            name: "crank".into(),
        };
        connect(&mut m, FourBarPin::CrankPin, 0, crank)?;
        let rocker = if self.flexible_rocker {
            let n = d.rocker_elements;
            add_link(&mut m, "rocker", self.rocker_length, n, FourBarLink::Rocker)?;
            m.supports.push(Support {
                link: 1,
                node: 0,
                fixed: [true, true, false],
            });
            Endpoint::Node { link: 1, node: n }
        } else {
            Endpoint::Body {
                frame: frame(FourBarLink::Rocker),
                point: [self.rocker_length, 0.0],
                name: "rocker".into(),
            }
        };
        connect(&mut m, FourBarPin::RockerPin, self.elements, rocker)?;
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pins_joint_and_support_in_the_order_of_the_scene() {
        let m = FlexibleFourBar::default().build().unwrap();
        assert_eq!((m.links.len(), m.pins.len(), m.joints.len()), (1, 2, 0));
        assert!(m.validate(0.1).is_ok());
        let s = FlexibleFourBar {
            flexible_rocker: true,
            clearance_at: Some(FourBarPin::RockerPin),
            ..Default::default()
        };
        let d = s.derived().unwrap();
        let b = d.bearing.unwrap();
        // half the coupler and half the rocker, each 0.5 rho A L = 0.5 * 2710 * 8.0645e-5 * 0.2794
        let half = 0.5 * 2710.0 * (0.0254 * 0.003175) * 0.2794;
        assert!((b.effective_mass - half / 2.0).abs() < 1e-15);
        assert!(
            (b.bearing_stiffness / 5.4e7 - 1.0).abs() < 0.01,
            "{}",
            b.bearing_stiffness
        );
        let m = s.build().unwrap();
        assert_eq!(
            (m.links.len(), m.pins.len(), m.joints.len(), m.supports.len()),
            (2, 1, 1, 1)
        );
        assert_eq!(m.joints[0].name, "rocker_pin");
        assert!(matches!(m.joints[0].bearing, Endpoint::Node { link: 1, node: 6 }));
        assert!(m.validate(0.1).is_ok());
    }

    #[test]
    fn a_loop_that_does_not_close_is_named_with_its_lengths() {
        let s = FlexibleFourBar {
            crank_length: 0.5,
            ..Default::default()
        };
        match s.build() {
            Err(Error::InvalidModel { message }) => {
                assert!(
                    message.starts_with("four_bar(ground_length=0.254, crank_length=0.5,"),
                    "{message}"
                )
            }
            r => panic!("{r:?}"),
        }
        match (FlexibleFourBar {
            branch: 0.5,
            ..Default::default()
        })
        .build()
        {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "branch"),
            r => panic!("{r:?}"),
        }
    }
}
