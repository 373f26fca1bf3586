//! # flexclear
//!
//! Elastodynamics of flexible planar mechanisms with joint clearance, after Hong & Kim (1993):
//! Euler-Bernoulli beam elements in a floating frame, Newmark time integration, and clearance
//! joints entered either as forces (force reaction method) or through the stiffness and damping
//! matrices (the paper's modified-matrix method), or as gap elements.
//!
//! Data flows one way: a [`model::Model`] (plain data, validated) is assembled into an
//! [`assembly::System`] (one sparsity pattern for the run), factorized with faer
//! ([`linsolve`]), stepped by [`integrator::NewmarkRun`], which feeds a [`recorder::Recorder`].
//! [`simulation::simulate`] is the entry point. Units are SI throughout.
//!
//! The Python bindings live in the `python` module behind the `python` feature; nothing else
//! knows about Python.

#![warn(missing_docs)]
// Index loops over small fixed-size matrices read like the formulas they implement.
#![allow(clippy::needless_range_loop)]

pub mod assembly;
pub mod contact;
pub mod element;
pub mod error;
pub mod integrator;
pub mod kinematics;
pub mod linsolve;
pub mod model;
pub mod modes;
pub mod plan;
pub mod recorder;
pub mod scenes;
pub mod simulation;
pub mod study;

#[cfg(feature = "python")]
mod python;

pub use error::{Error, Result};
pub use simulation::{simulate, RunFailure, RunOutput, Settings, SolverMode};
