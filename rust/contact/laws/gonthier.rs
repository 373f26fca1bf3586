//! The Gonthier et al. law (2004), usable at low restitution.

use super::power::hysteresis_law;
use super::{DEFAULT_EXPONENT, DEFAULT_MIN_APPROACH_SPEED};

/// Gonthier, McPhee, Lange & Piedboeuf (2004), "A regularized contact model with asymmetric
/// damping and dwell-time dependent friction", Multibody Syst. Dyn. 11:209-233:
/// `chi = (1 - e^2) / e`. Nominal `e` in (0, 1] (chi is unbounded as e -> 0).
///
/// `F = K d^n (1 + chi dd / v0)` for `d > 0` with `v0 = max(approach speed of the episode,
/// min_approach_speed)`; with `clip_tension` the force is `max(F, 0)` (see the module
/// documentation of [`laws`](super) for both choices).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gonthier {
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

impl Gonthier {
    /// Stiffness `K` (N/m^1.5) and nominal restitution `e`, other parameters at their
    /// defaults (n = 1.5, floor 1e-3 m/s, tension clipped).
    pub fn new(stiffness: f64, restitution: f64) -> Self {
        Gonthier {
            stiffness,
            exponent: DEFAULT_EXPONENT,
            restitution,
            min_approach_speed: DEFAULT_MIN_APPROACH_SPEED,
            clip_tension: true,
        }
    }

    /// Hysteresis factor `chi = (1 - e^2) / e` (dimensionless).
    #[inline]
    pub fn chi(&self) -> f64 {
        let e = self.restitution;
        (1.0 - e * e) / e
    }
}

hysteresis_law!(Gonthier, "Gonthier", 0.0, true);
