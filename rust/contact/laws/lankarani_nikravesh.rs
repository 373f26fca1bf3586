//! The Lankarani-Nikravesh law (1990), the default of most clearance-joint papers.

use super::power::hysteresis_law;
use super::{DEFAULT_EXPONENT, DEFAULT_MIN_APPROACH_SPEED};

/// Lankarani & Nikravesh (1990), "A contact force model with hysteresis damping for impact
/// analysis of multibody systems", J. Mech. Des. 112:369-376: `chi = 3 (1 - e^2) / 4`, from an
/// energy balance valid for `e` near 1 (0.9 and above). Nominal `e` in [0, 1]; effective
/// restitution 0.913 at nominal 0.9, 0.725 at 0.5.
///
/// `F = K d^n (1 + chi dd / v0)` for `d > 0` with `v0 = max(approach speed of the episode,
/// min_approach_speed)`; with `clip_tension` the force is `max(F, 0)` (see the module
/// documentation of [`laws`](super) for both choices).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LankaraniNikravesh {
    /// Stiffness coefficient `K`, N/m^n.
    pub stiffness: f64,
    /// Exponent `n`, default 1.5.
    pub exponent: f64,
    /// Nominal coefficient of restitution `e` (dimensionless).
    pub restitution: f64,
    /// Floor of the approach speed, m/s (default 1e-3).
    pub min_approach_speed: f64,
    /// Clip a tensile force to zero (default true).
    pub clip_tension: bool,
}

impl LankaraniNikravesh {
    /// Stiffness `K` (N/m^1.5) and nominal restitution `e`, other parameters at their
    /// defaults (n = 1.5, floor 1e-3 m/s, tension clipped).
    pub fn new(stiffness: f64, restitution: f64) -> Self {
        LankaraniNikravesh {
            stiffness,
            exponent: DEFAULT_EXPONENT,
            restitution,
            min_approach_speed: DEFAULT_MIN_APPROACH_SPEED,
            clip_tension: true,
        }
    }

    /// Hysteresis factor `chi = 3 (1 - e^2) / 4` (dimensionless).
    #[inline]
    pub fn chi(&self) -> f64 {
        let e = self.restitution;
        0.75 * (1.0 - e * e)
    }
}

hysteresis_law!(LankaraniNikravesh, "LankaraniNikravesh", 0.0, false);
