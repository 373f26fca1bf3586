//! Time integrators. Today: Newmark at a fixed step ([`newmark`]).

pub mod newmark;

pub use newmark::{Newmark, NewmarkRun};
