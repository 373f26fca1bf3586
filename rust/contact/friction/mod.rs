//! Friction laws of a contact: the tangential force as a function of the slip speed `v` (m/s)
//! and the normal force `F_N` (N, compressive positive). Every law returns the force on the body
//! whose slip speed is `v`, so it opposes `v`; a tensile or zero normal force carries no
//! friction (`F_N` is taken as `max(F_N, 0)`).
//!
//! In a pin joint ([`JointFriction`]) the slip speed includes the spin of the pin relative to the
//! bearing, `v = (v_J - v_B) . t + R_J w_J - R_B w_B` (docs/contact.md, "Friction"); these laws
//! only see `v`. Friction makes the contact tangent unsymmetric: the plan runs joints with
//! friction on the Newton stepper's refactorizing path (band LU), never on the constant stepper
//! (LDL^T) or the Woodbury update of the contact-free factor.

mod coulomb;
mod lugre;

pub use coulomb::{Coulomb, Regularization, Stribeck};
pub use lugre::LuGre;

use super::laws::pname;
use crate::error::{check_positive, Result};

/// The friction law of a clearance joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrictionLaw {
    /// Regularized Coulomb friction (no state).
    Coulomb(Coulomb),
    /// LuGre friction: one bristle state `z` (m) per joint, part of the run's state.
    LuGre(LuGre),
}

/// What a friction law gives at one state: the force `F_t` (N, on the journal along the
/// tangent `t`, opposing the slip speed), its derivatives `dF_t/dv` (N s/m, including the
/// dependence of the end-of-step state `z` on `v` for LuGre) and `dF_t/dF_N`, and the bristle
/// state at the end of the step (m; 0 for Coulomb).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrictionEval {
    /// Tangential force, N.
    pub force: f64,
    /// `dF_t / dv`, N s/m.
    pub dforce_dv: f64,
    /// `dF_t / dF_N`, N/N.
    pub dforce_dn: f64,
    /// Bristle state at the end of the step, m.
    pub z: f64,
}

impl FrictionLaw {
    /// Checks the parameters; `name` prefixes parameter names in errors.
    pub fn validate(&self, name: &str) -> Result<()> {
        match self {
            FrictionLaw::Coulomb(c) => c.validate(name),
            FrictionLaw::LuGre(l) => l.validate(name),
        }
    }

    /// Whether the law has an internal state (LuGre).
    pub fn has_state(&self) -> bool {
        matches!(self, FrictionLaw::LuGre(_))
    }

    /// The law over a step of `h` (s) that starts with bristle state `z0` (m) and ends at slip
    /// speed `v` (m/s) under normal force `f_n` (N). Coulomb: the force at `(v, f_n)`. LuGre: the
    /// state advanced exactly over the step at constant `v` ([`LuGre::advance`], stable for any
    /// step: the backward-Euler-like choice for the stiff bristle) and the force at the end
    /// state; `h = 0` keeps `z0`.
    #[inline]
    pub fn evaluate(&self, z0: f64, v: f64, f_n: f64, h: f64) -> FrictionEval {
        match self {
            FrictionLaw::Coulomb(c) => {
                let (dv, dn) = c.tangent(v, f_n);
                FrictionEval {
                    force: c.force(v, f_n),
                    dforce_dv: dv,
                    dforce_dn: dn,
                    z: 0.0,
                }
            }
            FrictionLaw::LuGre(l) => {
                let z = l.advance(z0, v, h);
                let (dz, dv, dn) = l.tangent(z, v, f_n);
                // dz(h)/dv by a central difference of the exact update (two exponentials)
                let dzdv = if h > 0.0 {
                    let e = 1e-6 * v.abs().max(l.stribeck_speed);
                    (l.advance(z0, v + e, h) - l.advance(z0, v - e, h)) / (2.0 * e)
                } else {
                    0.0
                };
                FrictionEval {
                    force: l.force(z, v, f_n),
                    dforce_dv: dv + dz * dzdv,
                    dforce_dn: dn,
                    z,
                }
            }
        }
    }
}

/// Friction in a revolute clearance joint: the law and the journal radius `R_J` (m); the bearing
/// radius is `R_J + clearance`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointFriction {
    /// The friction law.
    pub law: FrictionLaw,
    /// Journal (pin) radius `R_J`, m (> 0).
    pub journal_radius: f64,
}

impl JointFriction {
    /// Checks the law and the radius; `name` prefixes parameter names in errors (the radius is
    /// `<name>.journal_radius`).
    pub fn validate(&self, name: &str) -> Result<()> {
        self.law.validate(name)?;
        check_positive(&pname(name, "journal_radius"), self.journal_radius, "m")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_step_tangent_includes_the_state_update() {
        // LuGre over a step: dF/dv of the end state (z advanced over h at v) by central
        // differences of `evaluate` itself
        let law = FrictionLaw::LuGre(LuGre {
            sigma1: 200.0,
            sigma2: 0.3,
            ..LuGre::new(0.1, 0.15, 1e-3)
        });
        for (z0, v, h) in [(0.0, 0.01, 1e-5), (4e-7, -3e-3, 1e-4), (-1e-6, 0.2, 1e-6)] {
            let e = law.evaluate(z0, v, 800.0, h);
            let dv = 1e-6 * f64::abs(v);
            let fd = (law.evaluate(z0, v + dv, 800.0, h).force - law.evaluate(z0, v - dv, 800.0, h).force) / (2.0 * dv);
            // relative step 1e-6: truncation ~1e-12, round-off ~1e-10 of the force scale
            assert!(
                (e.dforce_dv - fd).abs() <= 1e-5 * fd.abs().max(1.0),
                "{v}: {} {fd}",
                e.dforce_dv
            );
        }
        // Coulomb has no state; at h = 0 LuGre keeps its state
        let c = FrictionLaw::Coulomb(Coulomb::new(0.2));
        assert_eq!(c.evaluate(1.0, 0.5, 100.0, 1e-3).z, 0.0);
        assert_eq!(law.evaluate(3e-7, 0.5, 100.0, 0.0).z, 3e-7);
    }

    #[test]
    fn a_joint_without_a_positive_radius_is_refused() {
        let f = JointFriction {
            law: FrictionLaw::Coulomb(Coulomb::new(0.1)),
            journal_radius: 0.0,
        };
        match f.validate("joints[0].friction") {
            Err(crate::error::Error::InvalidParameter { name, .. }) => {
                assert_eq!(name, "joints[0].friction.journal_radius")
            }
            other => panic!("{other:?}"),
        }
    }
}
