//! The Carvalho-Martins law (2019): a Hunt-Crossley form whose effective restitution is close to
//! the nominal one over the whole range.

use super::power::hysteresis_law;
use super::{DEFAULT_EXPONENT, DEFAULT_MIN_APPROACH_SPEED};

/// Carvalho & Martins (2019), "Exact restitution and generalizations for the Hunt-Crossley
/// contact model", Mech. Mach. Theory 139:174-194: `chi = (3/2) (1 - e) (11 - e) / (1 + 9 e)`,
/// an approximation of the exact restitution of the Hunt-Crossley form (Exudyn uses it above
/// e = 1/3). Nominal `e` in (0, 1]. Its effective restitution (measured by
/// [`effective_restitution`](crate::contact::restitution::effective_restitution)) is within
/// 2e-4 of the nominal one for e >= 0.5 and 4e-3 at e = 0.3, but 0.21 at e = 0.2 and 0.067 at
/// e = 0.01: below about 1/3 use [`Gonthier`](super::Gonthier).
///
/// `F = K d^n (1 + chi dd / v0)` for `d > 0` with `v0 = max(approach speed of the episode,
/// min_approach_speed)`; with `clip_tension` the force is `max(F, 0)` (see the module
/// documentation of [`laws`](super) for both choices).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarvalhoMartins {
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

impl CarvalhoMartins {
    /// Stiffness `K` (N/m^1.5) and nominal restitution `e`, other parameters at their
    /// defaults (n = 1.5, floor 1e-3 m/s, tension clipped).
    pub fn new(stiffness: f64, restitution: f64) -> Self {
        CarvalhoMartins {
            stiffness,
            exponent: DEFAULT_EXPONENT,
            restitution,
            min_approach_speed: DEFAULT_MIN_APPROACH_SPEED,
            clip_tension: true,
        }
    }

    /// Hysteresis factor `chi = (3/2) (1 - e) (11 - e) / (1 + 9 e)` (dimensionless).
    #[inline]
    pub fn chi(&self) -> f64 {
        let e = self.restitution;
        1.5 * (1.0 - e) * (11.0 - e) / (1.0 + 9.0 * e)
    }
}

hysteresis_law!(CarvalhoMartins, "CarvalhoMartins", 0.0, true);
