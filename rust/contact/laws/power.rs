//! The form shared by the Hertz family: `F = K d^n (1 + chi dd / v0)`.

use super::{check_exponent, check_min_approach_speed, check_stiffness, pname, NormalLaw};
use crate::error::{check_non_negative, Result};

/// `F = K d^n (1 + chi dd / max(v0, min_approach_speed))` for `d > 0`, else 0; clipped at zero
/// when `clip_tension`. Each named law (Hunt-Crossley, Lankarani-Nikravesh, ...) computes its
/// `chi` from the restitution and evaluates through this type; it is public for laws fitted by
/// the user (`chi` given directly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerLaw {
    /// Stiffness coefficient `K`, N/m^n.
    pub stiffness: f64,
    /// Exponent `n`.
    pub exponent: f64,
    /// Hysteresis factor `chi` (dimensionless, >= 0; 0 = elastic).
    pub chi: f64,
    /// Floor of the approach speed, m/s.
    pub min_approach_speed: f64,
    /// Clip a tensile total force to zero.
    pub clip_tension: bool,
}

impl PowerLaw {
    /// The approach speed the law uses for the caller's `v0`: `max(v0, floor)` (NaN and
    /// negative values give the floor).
    #[inline]
    pub fn approach_speed(&self, v0: f64) -> f64 {
        // f64::max returns the other operand when one is NaN
        v0.max(self.min_approach_speed)
    }

    /// `K d^n`, N (0 when `d <= 0`).
    #[inline]
    pub fn elastic(&self, d: f64) -> f64 {
        if d > 0.0 {
            self.stiffness * d.powf(self.exponent)
        } else {
            0.0
        }
    }
}

impl NormalLaw for PowerLaw {
    fn name(&self) -> &'static str {
        "PowerLaw"
    }

    #[inline]
    fn force(&self, d: f64, dd: f64, v0: f64) -> f64 {
        if d <= 0.0 {
            return 0.0;
        }
        let f = self.elastic(d) * (1.0 + self.chi * dd / self.approach_speed(v0));
        if self.clip_tension {
            f.max(0.0)
        } else {
            f
        }
    }

    #[inline]
    fn tangent(&self, d: f64, dd: f64, v0: f64) -> (f64, f64) {
        if d < 0.0 {
            return (0.0, 0.0);
        }
        let v = self.approach_speed(v0);
        let h = 1.0 + self.chi * dd / v;
        if self.clip_tension && h < 0.0 {
            return (0.0, 0.0);
        }
        let n = self.exponent;
        // d^(n-1) at d = 0 is 1 for n = 1 (the one-sided limit), 0 above
        let dn1 = if n == 1.0 { 1.0 } else { d.max(0.0).powf(n - 1.0) };
        let dn = d.max(0.0).powf(n);
        (n * self.stiffness * dn1 * h, self.stiffness * dn * self.chi / v)
    }

    fn velocity_dependent(&self) -> bool {
        self.chi != 0.0
    }

    fn needs_approach_speed(&self) -> bool {
        self.chi != 0.0
    }

    fn stiffness(&self) -> f64 {
        self.stiffness
    }

    fn exponent(&self) -> f64 {
        self.exponent
    }

    fn validate(&self, name: &str) -> Result<()> {
        check_stiffness(name, self.stiffness, "N/m^n")?;
        check_exponent(name, self.exponent)?;
        check_non_negative(&pname(name, "chi"), self.chi, "(dimensionless)")?;
        check_min_approach_speed(name, self.min_approach_speed)
    }
}

/// Implements [`NormalLaw`] for a named law with fields `stiffness`, `exponent`, `restitution`,
/// `min_approach_speed` and `clip_tension` and a method `chi()`, by delegation to
/// [`PowerLaw`]; `$lo`/`$lo_open` give the restitution's lower bound.
macro_rules! hysteresis_law {
    (
        $(#[$doc:meta])*
        $ty:ident, $name:literal, restitution_from($lo:expr, open: $lo_open:expr),
        chi($e:ident) = $chi:expr, $chi_doc:literal
    ) => {
        $(#[$doc])*
        ///
        /// `F = K d^n (1 + chi dd / v0)` for `d > 0` with `v0 = max(approach speed of the episode,
        /// min_approach_speed)`; with `clip_tension` the force is `max(F, 0)` (see the module
        /// documentation of [`laws`](super) for both choices).
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $ty {
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

        impl $ty {
            /// Stiffness `K` (N/m^1.5) and nominal restitution `e`, other parameters at their
            /// defaults (n = 1.5, floor 1e-3 m/s, tension clipped).
            pub fn new(stiffness: f64, restitution: f64) -> Self {
                $ty {
                    stiffness,
                    exponent: super::DEFAULT_EXPONENT,
                    restitution,
                    min_approach_speed: super::DEFAULT_MIN_APPROACH_SPEED,
                    clip_tension: true,
                }
            }

            #[doc = concat!("Hysteresis factor ", $chi_doc, " (dimensionless).")]
            #[inline]
            pub fn chi(&self) -> f64 {
                let $e = self.restitution;
                $chi
            }

            /// The law as a [`PowerLaw`](super::PowerLaw) with its `chi`.
            pub fn power(&self) -> super::PowerLaw {
                super::PowerLaw {
                    stiffness: self.stiffness,
                    exponent: self.exponent,
                    chi: self.chi(),
                    min_approach_speed: self.min_approach_speed,
                    clip_tension: self.clip_tension,
                }
            }
        }

        impl super::NormalLaw for $ty {
            fn name(&self) -> &'static str {
                $name
            }
            #[inline]
            fn force(&self, d: f64, dd: f64, v0: f64) -> f64 {
                self.power().force(d, dd, v0)
            }
            #[inline]
            fn tangent(&self, d: f64, dd: f64, v0: f64) -> (f64, f64) {
                self.power().tangent(d, dd, v0)
            }
            fn velocity_dependent(&self) -> bool {
                true
            }
            fn needs_approach_speed(&self) -> bool {
                true
            }
            fn stiffness(&self) -> f64 {
                self.stiffness
            }
            fn exponent(&self) -> f64 {
                self.exponent
            }
            fn validate(&self, name: &str) -> crate::error::Result<()> {
                super::check_stiffness(name, self.stiffness, "N/m^n")?;
                super::check_exponent(name, self.exponent)?;
                super::check_restitution(name, self.restitution, $lo, $lo_open)?;
                super::check_min_approach_speed(name, self.min_approach_speed)
            }
        }
    };
}

pub(crate) use hysteresis_law;
