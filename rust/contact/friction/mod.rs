//! Friction laws of a contact: the tangential force as a function of the slip speed `v` (m/s)
//! and the normal force `F_N` (N, compressive positive). Every law returns the force on the body
//! whose slip speed is `v`, so it opposes `v`; a tensile or zero normal force carries no
//! friction (`F_N` is taken as `max(F_N, 0)`).
//!
//! In a pin joint the slip speed includes the spin of the pin relative to the bearing
//! (`docs/contact.md`); these types only see `v`. Friction makes the contact tangent unsymmetric;
//! the engine decides whether it stays on the right-hand side. Not yet used by the integrators.

mod coulomb;
mod lugre;

pub use coulomb::{Coulomb, Regularization, Stribeck};
pub use lugre::LuGre;
