//! The linear spring-dashpot `F = k d + c dd` as a normal law (the normal component of today's
//! [`SpringDamper`](crate::contact::SpringDamper)).

use super::{check_stiffness, pname, NormalLaw};
use crate::contact::DampingLaw;
use crate::error::{check_non_negative, Result};

/// Kelvin-Voigt contact along the normal: `F = k d + c dd` for `d > 0` (`Viscous` and `Radial`
/// damping have the same normal component), `F = k d + c |dd|` for the `Literal` form (the
/// dashpot always pushes outward). The force jumps by `c dd` at entry. With `no_tension` a
/// tensile force is clipped to zero, as in [`SpringDamper`](crate::contact::SpringDamper).
///
/// A single impact of mass `m` without clipping has the closed-form restitution
/// `exp(-zeta pi / sqrt(1 - zeta^2))`, `zeta = c / (2 sqrt(k m))`, and contact time `pi / omega_d`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KelvinVoigt {
    /// Stiffness `k`, N/m.
    pub stiffness: f64,
    /// Damping `c`, N s/m.
    pub damping: f64,
    /// Form of the damping force (only `Literal` differs along the normal).
    pub damping_law: DampingLaw,
    /// Clip a tensile force to zero (default false, as `SpringDamper`).
    pub no_tension: bool,
}

impl KelvinVoigt {
    /// Stiffness `k` (N/m) and damping `c` (N s/m), viscous, tension allowed.
    pub fn new(stiffness: f64, damping: f64) -> Self {
        KelvinVoigt {
            stiffness,
            damping,
            damping_law: DampingLaw::Viscous,
            no_tension: false,
        }
    }

    #[inline]
    fn unclipped(&self, d: f64, dd: f64) -> f64 {
        let v = if self.damping_law == DampingLaw::Literal {
            dd.abs()
        } else {
            dd
        };
        self.stiffness * d + self.damping * v
    }
}

impl NormalLaw for KelvinVoigt {
    fn name(&self) -> &'static str {
        "KelvinVoigt"
    }

    #[inline]
    fn force(&self, d: f64, dd: f64, _v0: f64) -> f64 {
        if d <= 0.0 {
            return 0.0;
        }
        let f = self.unclipped(d, dd);
        if self.no_tension {
            f.max(0.0)
        } else {
            f
        }
    }

    #[inline]
    fn tangent(&self, d: f64, dd: f64, _v0: f64) -> (f64, f64) {
        if d < 0.0 || (self.no_tension && self.unclipped(d, dd) < 0.0) {
            return (0.0, 0.0);
        }
        let c = match self.damping_law {
            DampingLaw::Literal => self.damping * dd.signum(),
            _ => self.damping,
        };
        (self.stiffness, c)
    }

    fn velocity_dependent(&self) -> bool {
        self.damping != 0.0
    }

    fn needs_approach_speed(&self) -> bool {
        false
    }

    fn stiffness(&self) -> f64 {
        self.stiffness
    }

    fn exponent(&self) -> f64 {
        1.0
    }

    fn validate(&self, name: &str) -> Result<()> {
        check_stiffness(name, self.stiffness, "N/m")?;
        check_non_negative(&pname(name, "damping"), self.damping, "N s/m")
    }
}
