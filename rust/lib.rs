//! # flexclear
//!
//! Elastodynamics of flexible planar mechanisms with joint clearance, after Hong & Kim (1993):
//! Euler-Bernoulli beam elements in a floating frame, Newmark time integration, and clearance
//! joints entered either as forces (force reaction method) or through the stiffness and damping
//! matrices (the paper's modified-matrix method), or as gap elements.
//!
//! Data flows one way: a [`model::mechanism::Mechanism`] (plain data, one validation) is compiled
//! by [`plan::Plan::compile`], which picks the stepper kind, into the run of one of the
//! [`integrator`]s (constant effective matrix factorized once with faer, [`linalg`]; or Newton in
//! moving frames), which feeds the one [`record::Recorder`]; [`plan::simulate`] is the entry
//! point and [`batch`] runs samples in parallel. `docs/architecture.md` draws the flow. Units are
//! SI throughout.
//!
//! The Python bindings live in the `python` module behind the `python` feature; nothing else
//! knows about Python.

#![warn(missing_docs)]
// Index loops over small fixed-size matrices read like the formulas they implement.
#![allow(clippy::needless_range_loop)]

pub mod batch;
pub mod contact;
pub mod element;
pub mod error;
pub mod integrator;
pub mod kinematics;
pub mod linalg;
pub mod model;
pub mod modes;
pub mod plan;
pub mod record;
pub mod run;
pub mod scenes;

#[cfg(feature = "python")]
mod python;

pub use error::{Error, Result};
pub use plan::simulate;
pub use run::{RunFailure, RunOutput, Settings, SolverMode};
