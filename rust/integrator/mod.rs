//! Time integrators: Newmark at a fixed step for translating-frame models ([`newmark`], the fast
//! path with a contact-free factorization and Woodbury updates) and for kineto-elastodynamic
//! mechanisms with rotating links ([`ked`]).

mod divergence;
mod events;
pub mod ked;
pub mod newmark;

pub use newmark::{Newmark, NewmarkRun};
