//! The one user model, [`mechanism::Mechanism`]: flexible links in any frame, rigid bodies with
//! prescribed motion, pins, sliders, supports, point masses, loads, gravity and clearance joints;
//! prescribed motions ([`motion`]) and beam sections ([`section`]). Plain data plus validation;
//! nothing here knows about matrices or time stepping (the constant stepper's translating form is
//! derived by the plan, [`crate::plan::translating`]).

pub mod mechanism;
pub mod motion;
pub mod section;

pub use motion::{Kinematics, Motion, Table};
pub use section::{check_elements, BeamSection, ELEMENTS_ALLOWED, MAX_ELEMENTS};

/// Degrees of freedom per beam node: axial u (m), transverse v (m), rotation theta (rad).
pub const NODE_DOFS: usize = 3;
