//! The undamped Hertz law `F = K d^n`.

use super::{check_exponent, check_stiffness, NormalLaw, DEFAULT_EXPONENT};
use crate::error::Result;

/// Elastic Hertz contact `F = K d^n` (Hertz 1882; `n = 3/2` for point contact): no dissipation,
/// effective restitution 1. The baseline the dissipative laws add hysteresis to; the force never
/// becomes tensile, so there is nothing to clip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hertz {
    /// Stiffness coefficient `K`, N/m^n (for a pin in a hole see `flexclear.contact.pin_in_hole`).
    pub stiffness: f64,
    /// Exponent `n`, default 1.5.
    pub exponent: f64,
}

impl Hertz {
    /// Stiffness `K` (N/m^1.5) with the default exponent 1.5.
    pub fn new(stiffness: f64) -> Self {
        Hertz {
            stiffness,
            exponent: DEFAULT_EXPONENT,
        }
    }
}

impl NormalLaw for Hertz {
    fn name(&self) -> &'static str {
        "Hertz"
    }

    #[inline]
    fn force(&self, d: f64, _dd: f64, _v0: f64) -> f64 {
        if d > 0.0 {
            self.stiffness * d.powf(self.exponent)
        } else {
            0.0
        }
    }

    #[inline]
    fn tangent(&self, d: f64, _dd: f64, _v0: f64) -> (f64, f64) {
        if d < 0.0 {
            return (0.0, 0.0);
        }
        let n = self.exponent;
        let dn1 = if n == 1.0 { 1.0 } else { d.powf(n - 1.0) };
        (n * self.stiffness * dn1, 0.0)
    }

    fn velocity_dependent(&self) -> bool {
        false
    }

    fn needs_approach_speed(&self) -> bool {
        false
    }

    fn stiffness(&self) -> f64 {
        self.stiffness
    }

    fn exponent(&self) -> f64 {
        self.exponent
    }

    fn validate(&self, name: &str) -> Result<()> {
        check_stiffness(name, self.stiffness, "N/m^n")?;
        check_exponent(name, self.exponent)
    }
}
