//! The Flores et al. law (2011), for any restitution.

use super::power::hysteresis_law;
use super::{DEFAULT_EXPONENT, DEFAULT_MIN_APPROACH_SPEED};

/// Flores, Machado, Silva & Martins (2011), "On the continuous contact force models for soft
/// materials in multibody dynamics", Multibody Syst. Dyn. 25:357-375: `chi = 8 (1 - e) / (5 e)`
/// (Chrono's SMC "Flores" model). Nominal `e` in (0, 1].
///
/// `F = K d^n (1 + chi dd / v0)` for `d > 0` with `v0 = max(approach speed of the episode,
/// min_approach_speed)`; with `clip_tension` the force is `max(F, 0)` (see the module
/// documentation of [`laws`](super) for both choices).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flores {
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

impl Flores {
    /// Stiffness `K` (N/m^1.5) and nominal restitution `e`, other parameters at their
    /// defaults (n = 1.5, floor 1e-3 m/s, tension clipped).
    pub fn new(stiffness: f64, restitution: f64) -> Self {
        Flores {
            stiffness,
            exponent: DEFAULT_EXPONENT,
            restitution,
            min_approach_speed: DEFAULT_MIN_APPROACH_SPEED,
            clip_tension: true,
        }
    }

    /// Hysteresis factor `chi = 8 (1 - e) / (5 e)` (dimensionless).
    #[inline]
    pub fn chi(&self) -> f64 {
        let e = self.restitution;
        1.6 * (1.0 - e) / e
    }
}

hysteresis_law!(Flores, "Flores", 0.0, true);
