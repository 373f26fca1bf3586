//! Finite elements. One file per element type; today the planar Euler-Bernoulli beam of
//! docs/method.md section 2.

pub mod beam;

pub use beam::{BeamElement, Mat6, Vec6};
