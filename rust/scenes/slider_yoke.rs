//! The paper's slider-yoke mechanism (Hong & Kim 1993, Fig. 4; after Dubowsky, Deck & Costello
//! 1987), as reconstructed in `docs/scenes.md` section 1.
//!
//! The original parameters are not available; this reconstruction reproduces the paper's Table 1
//! analytic column within about 0.7 dB. A free-free steel slider (0.269 x 0.0127 x 0.0127 m,
//! first bending frequency 880 Hz) is joined at its end x = 0 by a clearance bearing to a rigid
//! yoke moving `Y(t) = Y sin(2 pi f t)` transversely. The slider's frame translates with the
//! yoke, so the bearing centre is at the frame origin and the yoke's motion enters as the
//! inertia load `-M_R a_R`.

use std::f64::consts::PI;
use std::sync::Arc;

use crate::contact::{DampingLaw, SpringDamper};
use crate::error::{check_non_negative, check_positive, Error, Result};
use crate::kinematics::{FrameKinematics, RotatingFrame, Rotation};
use crate::model::mechanism::{Clearance, Endpoint, Link, Mechanism, Terms};
use crate::model::section::BeamSection;
use crate::model::{check_elements, Motion};

/// `(beta_1 L)^2` of the first free-free bending mode.
pub const BETA1_L_SQUARED: f64 = 22.3733;

/// Where the clearance bearings sit along the slider.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SliderYokeGeometry {
    /// One bearing at the slider end x = 0 (the default; "the end of the slider touches the
    /// bearing surface").
    #[default]
    End,
    /// One bearing at each end, named `"bearing"` (x = 0) and `"bearing_2"` (x = L).
    BothEnds,
    /// One bearing at mid-span (needs an even element count).
    MidSpan,
}

/// Parameters of the slider-yoke scene (SI units). `None` fields are derived as documented.
#[derive(Debug, Clone, PartialEq)]
pub struct SliderYoke {
    /// Radial clearance delta_c, m (Table 1 rows: r * amplitude, r in {0, 0.001, 0.01, 0.1}).
    pub clearance: f64,
    /// Yoke amplitude Y, m. Default 0.010.
    pub amplitude: f64,
    /// Yoke frequency f, Hz. Default 6.
    pub frequency: f64,
    /// Slider length L, m. Default 0.269.
    pub length: f64,
    /// Side of the square section a, m. Default 0.0127 (A = a^2, I = a^4/12).
    pub side: f64,
    /// Density, kg/m^3. Default 7850.
    pub density: f64,
    /// Young's modulus, Pa; `None` = calibrated so that the first free-free bending frequency is
    /// `first_frequency` with `(beta1 L)^2 = 22.3733` (about 1.868e11 Pa).
    pub youngs_modulus: Option<f64>,
    /// Target first free-free bending frequency for the E calibration, Hz. Default 880.
    pub first_frequency: f64,
    /// Kelvin-Voigt damping as a fraction of critical at `first_frequency`. Default 0.01:
    /// `eta/E = 2 zeta / (2 pi f1)`.
    pub damping_ratio: f64,
    /// Number of elements, 1 ..= 1000000. Default 12 (converged for this scene).
    pub elements: usize,
    /// Bearing stiffness K_B, N/m; `None` = `(m/4) (stiffness_ratio 2 pi f)^2`, m = rho A L
    /// (about 1.21e6 N/m).
    pub bearing_stiffness: Option<f64>,
    /// The ratio in the K_B default. Default 100 (gives the -80.0 dB row).
    pub stiffness_ratio: f64,
    /// Bearing damping C_B, N s/m; `None` = `2 bearing_damping_ratio sqrt(K_B m/4)` (about
    /// 321 N s/m).
    pub bearing_damping: Option<f64>,
    /// Fraction of critical damping of the end mass on the bearing. Default 0.5.
    pub bearing_damping_ratio: f64,
    /// Form of the bearing damping. Default viscous `-C_B qdot`.
    pub damping_law: DampingLaw,
    /// Forbid tensile contact force. Default false.
    pub no_tension: bool,
    /// Bearing placement. Default one bearing at x = 0.
    pub geometry: SliderYokeGeometry,
    /// Include rotary inertia. Default false (Euler-Bernoulli, as the paper).
    pub rotary_inertia: bool,
}

impl Default for SliderYoke {
    fn default() -> Self {
        SliderYoke {
            clearance: 0.0,
            amplitude: 0.010,
            frequency: 6.0,
            length: 0.269,
            side: 0.0127,
            density: 7850.0,
            youngs_modulus: None,
            first_frequency: 880.0,
            damping_ratio: 0.01,
            elements: 12,
            bearing_stiffness: None,
            stiffness_ratio: 100.0,
            bearing_damping: None,
            bearing_damping_ratio: 0.5,
            damping_law: DampingLaw::Viscous,
            no_tension: false,
            geometry: SliderYokeGeometry::End,
            rotary_inertia: false,
        }
    }
}

/// Derived values of a slider-yoke parameter set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Derived {
    /// Section area, m^2.
    pub area: f64,
    /// Second moment of area, m^4.
    pub inertia: f64,
    /// Slider mass, kg.
    pub mass: f64,
    /// Young's modulus, Pa.
    pub youngs_modulus: f64,
    /// Kelvin-Voigt eta, Pa s.
    pub eta: f64,
    /// Bearing stiffness, N/m.
    pub bearing_stiffness: f64,
    /// Bearing damping, N s/m.
    pub bearing_damping: f64,
}

impl SliderYoke {
    /// The derived quantities (E, eta, K_B, C_B, ...). Fails on invalid parameters.
    pub fn derived(&self) -> Result<Derived> {
        check_positive("amplitude", self.amplitude, "m")?;
        check_positive("frequency", self.frequency, "Hz")?;
        check_positive("length", self.length, "m")?;
        check_positive("side", self.side, "m")?;
        check_positive("density", self.density, "kg/m^3")?;
        check_positive("first_frequency", self.first_frequency, "Hz")?;
        crate::error::check_non_negative("damping_ratio", self.damping_ratio, "")?;
        check_positive("stiffness_ratio", self.stiffness_ratio, "")?;
        crate::error::check_non_negative("bearing_damping_ratio", self.bearing_damping_ratio, "")?;
        check_elements("elements", self.elements)?;
        if self.geometry == SliderYokeGeometry::MidSpan && !self.elements.is_multiple_of(2) {
            return Err(Error::param(
                "elements",
                self.elements,
                "an even integer >= 2 for a mid-span bearing",
            ));
        }
        let area = self.side * self.side;
        let inertia = self.side.powi(4) / 12.0;
        let mass = self.density * area * self.length;
        let w1 = 2.0 * PI * self.first_frequency;
        let youngs_modulus = match self.youngs_modulus {
            Some(e) => e,
            None => self.density * area * w1 * w1 * self.length.powi(4) / (BETA1_L_SQUARED * BETA1_L_SQUARED * inertia),
        };
        let eta = youngs_modulus * 2.0 * self.damping_ratio / w1;
        let end_mass = mass / 4.0;
        let wb = self.stiffness_ratio * 2.0 * PI * self.frequency;
        let bearing_stiffness = self.bearing_stiffness.unwrap_or(end_mass * wb * wb);
        let bearing_damping = self
            .bearing_damping
            .unwrap_or(2.0 * self.bearing_damping_ratio * (bearing_stiffness * end_mass).sqrt());
        Ok(Derived {
            area,
            inertia,
            mass,
            youngs_modulus,
            eta,
            bearing_stiffness,
            bearing_damping,
        })
    }

    /// Builds the mechanism. The slider is link `"slider"` on a frame translating with the yoke
    /// (angle 0), the yoke the body `"yoke"` on that frame, the joint `"bearing"` (and
    /// `"bearing_2"`) from a slider node to the yoke point at that node. Fails as
    /// [`SliderYoke::derived`], then on the section (`links[0].*`: a given `youngs_modulus`), the
    /// joints' clearance (`joints[i].clearance`, >= 0 m) and bearing law (`joints[i].law.*`).
    /// Initial state: the zero-clearance steady motion, i.e. absolute transverse
    /// velocity `Y 2 pi f (1 - 1.5 x/L)` (in the yoke-fixed frame `-1.5 x Y 2 pi f / L`) and
    /// rotation rate `-1.5 Y 2 pi f / L`, no deformation.
    pub fn build(&self) -> Result<Mechanism> {
        let d = self.derived()?;
        let motion = Motion::Harmonic {
            offset: [0.0, 0.0],
            amplitude: [0.0, self.amplitude],
            frequency: self.frequency,
            phase: 0.0,
        };
        let n = self.elements;
        let yw = self.amplitude * 2.0 * PI * self.frequency;
        let rate = -1.5 * yw / self.length;
        let mut v0 = vec![0.0; 3 * (n + 1)];
        for i in 0..=n {
            let x = self.length * i as f64 / n as f64;
            v0[3 * i + 1] = rate * x;
            v0[3 * i + 2] = rate;
        }
        // the slider's frame and the yoke's: translating with the yoke at angle 0 (so a bearing
        // point given in global axes from the yoke's reference point is the same in its frame)
        let frame: Arc<dyn FrameKinematics> = Arc::new(RotatingFrame {
            origin: motion.clone(),
            rotation: Rotation::Fixed { angle: 0.0 },
        });
        let slider = Link {
            name: "slider".into(),
            section: BeamSection {
                length: self.length,
                elements: n,
                youngs_modulus: d.youngs_modulus,
                density: self.density,
                damping: d.eta,
                area: d.area,
                inertia: d.inertia,
            },
            frame: frame.clone(),
            terms: Terms::default(),
            rotary_inertia: self.rotary_inertia,
            initial_displacement: None,
            initial_velocity: Some(v0),
            rigid: None,
        };
        slider.section.validate("links[0].")?;
        motion.validate("links[0].motion")?;
        motion.validate("bodies[0].motion")?;
        let law = Arc::new(SpringDamper {
            stiffness: d.bearing_stiffness,
            damping: d.bearing_damping,
            damping_law: self.damping_law,
            no_tension: self.no_tension,
        });
        let joint = |name: &str, node: usize| Clearance {
            friction: None,
            name: name.into(),
            journal: Endpoint::Node { link: 0, node },
            bearing: Endpoint::Body {
                frame: frame.clone(),
                point: [self.length * node as f64 / n as f64, 0.0],
                name: "yoke".into(),
            },
            clearance: self.clearance,
            law: law.clone(),
        };
        let joints = match self.geometry {
            SliderYokeGeometry::End => vec![joint("bearing", 0)],
            SliderYokeGeometry::BothEnds => vec![joint("bearing", 0), joint("bearing_2", n)],
            SliderYokeGeometry::MidSpan => vec![joint("bearing", n / 2)],
        };
        for (i, j) in joints.iter().enumerate() {
            check_non_negative(&format!("joints[{i}].clearance"), j.clearance, "m")?;
            j.law.validate(&format!("joints[{i}].law"))?;
        }
        Ok(Mechanism {
            links: vec![slider],
            joints,
            ..Default::default()
        })
    }
}
